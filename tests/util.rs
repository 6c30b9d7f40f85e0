//! Shared helpers: the example machines, seeded random errors, temp dirs.

use fivecal::kinematics::{Kinematics, N_SLOTS, Perturbation, SLOT_LIN};
use fivecal::{Axes, Machine};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

/// The four example machines.
pub const MACHINES: [&str; 4] = ["bc-trunnion", "ac-trunnion", "head-table", "head-head"];

pub fn machine(name: &str) -> Machine {
    Machine::builtin(name).unwrap()
}

pub fn rng(seed: u64) -> StdRng {
    StdRng::seed_from_u64(seed)
}

/// Random constant errors: every term of every link the machine has, up to
/// `lin_um` (translations) and `ang_urad` (rotations), plus a tool-length
/// error; in mm and rad.
pub fn random_perturbation(
    k: &Kinematics,
    r: &mut StdRng,
    lin_um: f64,
    ang_urad: f64,
) -> Perturbation {
    let mut p = Perturbation::zero();
    for slot in 0..SLOT_LIN {
        if k.slot_name(slot).is_none() {
            continue;
        }
        let s: f64 = r.random_range(-1.0..1.0);
        p.0[slot] = if slot % 6 < 3 {
            s * lin_um * 1e-3
        } else {
            s * ang_urad * 1e-6
        };
    }
    p.0[fivecal::kinematics::SLOT_TOOL_LENGTH] = r.random_range(-1.0..1.0) * lin_um * 1e-3;
    assert_eq!(p.0.len(), N_SLOTS);
    p
}

/// Random axis values with the gauge point inside the strokes and the
/// rotary axes inside their limits (C in [-180, 180) when continuous).
pub fn random_axes(m: &Machine, r: &mut StdRng) -> Axes {
    let mut xyz = [0.0; 3];
    for (i, v) in xyz.iter_mut().enumerate() {
        let (lo, hi) = m.strokes[i];
        *v = r.random_range(lo..hi) - m.pivot[i];
    }
    let (tlo, thi) = m.tilt.limits.unwrap();
    let (clo, chi) = m.c.limits.unwrap_or((-180.0, 180.0));
    Axes::new(
        xyz[0],
        xyz[1],
        xyz[2],
        r.random_range(tlo..thi),
        r.random_range(clo..chi),
    )
}

#[allow(dead_code)]
pub fn tempdir() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

/// A random rigid placement on a CMM: any rotation, offset up to `offset` mm.
#[allow(dead_code)]
pub fn random_placement(r: &mut StdRng, offset: f64) -> nalgebra::Isometry3<f64> {
    let axis = nalgebra::Vector3::new(
        r.random_range(-1.0..1.0),
        r.random_range(-1.0..1.0),
        r.random_range(-1.0..1.0),
    )
    .normalize();
    let angle = r.random_range(-std::f64::consts::PI..std::f64::consts::PI);
    let t = nalgebra::Vector3::new(
        r.random_range(-1.0..1.0),
        r.random_range(-1.0..1.0),
        r.random_range(-1.0..1.0),
    )
    .normalize()
        * offset;
    nalgebra::Isometry3::new(t, axis * angle)
}

/// Compares `text` with the golden file `dir/name` (relative to the
/// crate); `FIVECAL_BLESS=1` rewrites it after a deliberate change.
pub fn golden(dir: &str, name: &str, text: &str) {
    let path = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join(dir)
        .join(name);
    if std::env::var_os("FIVECAL_BLESS").is_some() {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, text).unwrap();
        return;
    }
    let want = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (run with FIVECAL_BLESS=1 to create it)",
            path.display()
        )
    });
    if want != text {
        let line = want
            .lines()
            .zip(text.lines())
            .position(|(a, b)| a != b)
            .unwrap_or(want.lines().count().min(text.lines().count()));
        panic!(
            "{name} differs from its golden file at line {}:\n  golden: {:?}\n  now:    {:?}\n(FIVECAL_BLESS=1 rewrites it after a deliberate change)",
            line + 1,
            want.lines().nth(line),
            text.lines().nth(line)
        );
    }
}
