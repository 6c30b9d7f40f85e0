//! The five-axis finishing program that `compensate` is timed on (B/C
//! trunnion, post side): the tip runs a spiral over a dome of radius 60 mm
//! with the tool normal to it, 0.2 mm per block, every block with X Y Z B C.
//! Shared by `benches/compensate.rs` (which streams it from memory) and
//! `examples/dome_program.rs` (which writes it to a file), so that both time
//! the same program.

use fivecal::Axes;
use fivecal::kinematics::Kinematics;
use fivecal::kinematics::fast::FastChain;

/// The program's opening blocks, before the first of the spiral.
pub const HEADER: &[u8] =
    b"%\nO1000 (DOME FINISH, 5-AXIS)\nG90 G21 G17 G94 G54 G43 H1\nG0 X0. Y0. Z100. B0. C0.\nG1 F2000.\n";

/// The error file the program is compensated with: the location errors
/// and a tool-length error of `bc-trunnion`.
pub const ERRORS: &str = "machine: bc-trunnion\nlocation_errors: {EX0B: 12.0, EZ0B: -25.0, EA0B: 30.0, EC0B: -20.0, EB0B: 15.0, EX(0B)C: 8.0, EY0C: -14.0, EA(0B)C: 22.0}\neffects: {tool_length: 5.0}\n";

/// Distinct blocks of the spiral; the program replays them until it has
/// as many blocks as it should.
pub const DISTINCT: usize = 20_000;

/// The [`DISTINCT`] blocks of the spiral, each ending in a newline.
pub fn blocks(kin: &Kinematics) -> Vec<Vec<u8>> {
    let nominal = FastChain::nominal(kin);
    (0..DISTINCT)
        .map(|i| {
            let s = i as f64 / DISTINCT as f64;
            // Spiral on a sphere of radius 60 around (0, 0, -20).
            let polar = 0.15 + 0.9 * s;
            let az = s * 40.0 * std::f64::consts::TAU;
            let n =
                nalgebra::Vector3::new(polar.sin() * az.cos(), polar.sin() * az.sin(), polar.cos());
            let tip = nalgebra::Vector3::new(0.0, 0.0, -20.0) + n * 60.0;
            let tilt = polar.to_degrees();
            let c = (90.0 - az.to_degrees()).rem_euclid(360.0) - 180.0;
            // The nominal axis values that point the tool along n.
            let hint = Axes { xyz: tip, tilt, c };
            let target = fivecal::ToolPose { tip, axis: n };
            let axes = nominal.inverse(&target, &hint).unwrap();
            format!(
                "N{} G1 X{:.4} Y{:.4} Z{:.4} B{:.4} C{:.4}\n",
                i + 100,
                axes.xyz.x,
                axes.xyz.y,
                axes.xyz.z,
                axes.tilt,
                axes.c
            )
            .into_bytes()
        })
        .collect()
}
