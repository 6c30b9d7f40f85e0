//! Writes the contour-error example of `examples/contour/` (Jiang et al.'s (2013)
//! experiment on the CZFXYB head-table machine): a ten-sided frustum whose
//! faces lean 45 to 60 deg from the table (a different head angle for each),
//! its model (OBJ and GLB), the HEIDENHAIN finishing program that runs a
//! ball-end tool normal to the faces at four heights under TCPM (turning B
//! and C about each corner), and the 120 nominal points a CMM measures on
//! it.
//!
//! Run from the repository root: `cargo run --release --example contour_frustum`.
//! The files it writes are committed; the walk-through in
//! `examples/contour/README.md` uses them.

use std::f64::consts::PI;
use std::fmt::Write as _;
use std::path::Path;

use fivecal::formats::measured::{self, MeasuredPoint};
use fivecal::kinematics::fast::FastChain;
use fivecal::mesh::{Mesh, Triangle};
use fivecal::{Axes, Kinematics, Machine, ToolPose};
use nalgebra::Vector3;

/// Faces.
const N: usize = 10;
/// Apothem at the table, mm.
const A0: f64 = 50.0;
/// Height, mm.
const H: f64 = 15.0;
/// Pass heights, mm.
const LAYERS: [f64; 4] = [3.0, 6.0, 9.0, 12.0];

/// Angle of face k from the table, deg (the tool leans as much).
fn beta(k: usize) -> f64 {
    45.0 + 3.75 * ((k % N) % 5) as f64
}

/// Outward unit normal of face k and its plane offset (n . p = d).
fn face(k: usize) -> (Vector3<f64>, f64) {
    let k = k % N;
    let th = 2.0 * PI * k as f64 / N as f64;
    let b = beta(k).to_radians();
    let n = Vector3::new(b.sin() * th.cos(), b.sin() * th.sin(), b.cos());
    (n, A0 * b.sin())
}

fn normal(k: usize) -> Vector3<f64> {
    face(k).0
}

/// Corner between face k-1 and face k at height z: where the two planes
/// meet the horizontal plane.
fn corner(k: usize, z: f64) -> Vector3<f64> {
    let (n1, d1) = face(k + N - 1);
    let (n2, d2) = face(k);
    let (r1, r2) = (d1 - n1.z * z, d2 - n2.z * z);
    let det = n1.x * n2.y - n1.y * n2.x;
    Vector3::new(
        (r1 * n2.y - r2 * n1.y) / det,
        (n1.x * r2 - n2.x * r1) / det,
        z,
    )
}

/// The part as triangles with outward normals, one group per face.
fn mesh() -> Mesh {
    let mut triangles = Vec::new();
    let mut push = |v: [Vector3<f64>; 3], tag: u32| {
        let n = (v[1] - v[0]).cross(&(v[2] - v[0])).normalize();
        triangles.push(Triangle { v, n, tag });
    };
    let (bottom, top) = (Vector3::new(0.0, 0.0, 0.0), Vector3::new(0.0, 0.0, H));
    for k in 0..N {
        let (a0, b0) = (corner(k, 0.0), corner(k + 1, 0.0));
        let (a1, b1) = (corner(k, H), corner(k + 1, H));
        // Side face k runs from corner k to corner k+1, outward.
        push([a0, b0, b1], k as u32 + 1);
        push([a0, b1, a1], k as u32 + 1);
        push([bottom, b0, a0], 0);
        push([top, a1, b1], N as u32 + 1);
    }
    let mut groups = std::collections::BTreeMap::new();
    groups.insert(0, "bottom".to_string());
    groups.insert(N as u32 + 1, "top".to_string());
    for k in 0..N {
        groups.insert(k as u32 + 1, format!("face{}", k + 1));
    }
    Mesh { triangles, groups }
}

fn main() -> std::io::Result<()> {
    let dir = Path::new("examples/contour");
    std::fs::create_dir_all(dir)?;
    let m = Machine::builtin("head-table").unwrap();
    let kin = Kinematics::new(&m);
    let nominal = FastChain::nominal(&kin);

    let mesh = mesh();
    let title = "fivecal example: ten-sided frustum, faces 45 to 60 deg from the table, 15 mm high";
    std::fs::write(dir.join("frustum.obj"), mesh.to_obj(title))?;
    std::fs::write(dir.join("frustum.glb"), mesh.to_glb(title))?;

    // The program: tip on the face, tool along its normal.
    let mut blocks: Vec<String> = vec![
        "BEGIN PGM FRUSTUM MM".into(),
        "; FIVECAL EXAMPLE: 10-SIDED FRUSTUM, FACES 45 TO 60 DEG FROM THE TABLE".into(),
        "; FINISHED WITH A BALL-END TOOL NORMAL TO THE FACES AT 4 HEIGHTS, TCPM".into(),
        "BLK FORM 0.1 Z X-60 Y-60 Z+0".into(),
        "BLK FORM 0.2 X+60 Y+60 Z+15".into(),
        "TOOL CALL 1 Z S8000".into(),
        "L X+0 Y+0 Z+150 B+0 C+0 R0 FMAX M3".into(),
        "M128".into(),
    ];
    let f = |v: f64| format!("{v:+.4}");
    let mut hint = Axes::new(0.0, 0.0, 0.0, -beta(0), 0.0);
    let mut pose = |tip: Vector3<f64>, n: Vector3<f64>| {
        let a = nominal
            .inverse(&ToolPose { tip, axis: n }, &hint)
            .expect("reachable");
        hint = a;
        (tip, a.tilt, a.c)
    };
    let mut points = Vec::new();
    for (j, &z) in LAYERS.iter().enumerate() {
        let start = corner(0, z);
        let (tip, b, c) = pose(start, normal(0));
        let away = tip + normal(0) * 20.0;
        blocks.push(format!(
            "L X{} Y{} Z{} B{} C{} R0 FMAX",
            f(away.x),
            f(away.y),
            f(away.z),
            f(b),
            f(c)
        ));
        blocks.push(format!("L X{} Y{} Z{} F600", f(tip.x), f(tip.y), f(tip.z)));
        for k in 0..N {
            let end = corner(k + 1, z);
            let (tip, _, _) = pose(end, normal(k));
            blocks.push(format!("L X{} Y{} Z{} F800", f(tip.x), f(tip.y), f(tip.z)));
            // Turn to the next face about the corner (the tip stays).
            let (_, b, c) = pose(end, normal((k + 1) % N));
            blocks.push(format!("L B{} C{}", f(b), f(c)));
            for (i, s) in [0.25, 0.5, 0.75].iter().enumerate() {
                let p = corner(k, z) + (end - corner(k, z)) * *s;
                points.push(MeasuredPoint {
                    label: format!("L{}F{}P{}", j + 1, k + 1, i + 1),
                    p,
                    line: 0,
                    normal: None,
                });
            }
        }
        let last = corner(0, z) + normal(0) * 20.0;
        blocks.push(format!(
            "L X{} Y{} Z{} R0 FMAX",
            f(last.x),
            f(last.y),
            f(last.z)
        ));
    }
    blocks.push("M129".into());
    blocks.push("L X+0 Y+0 Z+150 B+0 C+0 R0 FMAX M30".into());
    blocks.push("END PGM FRUSTUM MM".into());
    let mut text = String::new();
    for (i, b) in blocks.iter().enumerate() {
        let _ = writeln!(text, "{i} {b}");
    }
    std::fs::write(dir.join("frustum.h"), text)?;
    std::fs::write(
        dir.join("cmm-points.csv"),
        measured::to_csv(
            &points,
            &["nominal CMM points on the frustum faces (3 per face and pass height), W frame, mm"],
        ),
    )?;
    println!(
        "wrote {} blocks, {} CMM points to {}",
        blocks.len(),
        points.len(),
        dir.display()
    );
    Ok(())
}
