//! docs/model.md: the eight location symbols are what the papers' tests can
//! identify. Computed here from the project's own Jacobians: each pose's
//! 6-DOF displacement of the table frame, relative to the reference pose,
//! as a function of the twelve constant terms.

use fivecal::Axes;
use fivecal::kinematics::{Kinematics, Perturbation};
use fivecal::model::{Context, Effect, Model};
use nalgebra::{DMatrix, DVector, Point3};

use crate::util::machine;

/// Three non-collinear points of a piece fixed in W: their displacements
/// fix the six components of a small rigid motion.
const POINTS: [[f64; 3]; 3] = [[40.0, 0.0, 30.0], [0.0, 40.0, 30.0], [-40.0, -40.0, 30.0]];

/// Rows: (pose, point, coordinate) displacement relative to the reference
/// pose (0, 0); columns: the twelve terms, mm or rad.
fn design(k: &Kinematics, poses: &[(f64, f64)]) -> DMatrix<f64> {
    let jac = |t: f64, c: f64, q: [f64; 3]| {
        let commanded = k.nominal_table_transform(t, c) * Point3::from(q);
        let a = Axes {
            xyz: commanded.coords,
            tilt: t,
            c,
        };
        k.jacobian(&a, &Perturbation::zero())
            .tip
            .columns(5, 12)
            .into_owned()
    };
    let mut rows = Vec::new();
    for &(t, c) in poses {
        for q in POINTS {
            let d = jac(t, c, q) - jac(0.0, 0.0, q);
            for r in 0..3 {
                rows.push(d.row(r).into_owned());
            }
        }
    }
    DMatrix::from_rows(&rows)
}

fn rank(m: &DMatrix<f64>) -> (usize, f64) {
    let sv = m.clone().svd(false, false).singular_values;
    let max = sv.max();
    let tol = 1e-9 * max;
    let r = sv.iter().filter(|&&s| s > tol).count();
    let min_kept = sv
        .iter()
        .copied()
        .filter(|&s| s > tol)
        .fold(f64::INFINITY, f64::min);
    (r, max / min_kept)
}

fn unit(i: usize) -> DVector<f64> {
    let mut v = DVector::zeros(12);
    v[i] = 1.0;
    v
}

fn check(name: &str, poses: &[(f64, f64)], null: &[DVector<f64>]) {
    let m = machine(name);
    let k = Kinematics::new(&m);
    let d = design(&k, poses);
    let (r, cond) = rank(&d);
    assert_eq!(
        r, 8,
        "{name}: rank of the twelve constant terms is {r}, not 8"
    );
    assert!(cond < 1e6, "{name}: condition number {cond:.3e}");
    let scale = d.norm();
    for (i, v) in null.iter().enumerate() {
        let dv = &d * v;
        assert!(
            dv.norm() < 1e-12 * scale,
            "{name}: null direction {i} is seen: |J v| = {:.3e}",
            dv.norm()
        );
    }
    // The eight symbols, through the model's own parameter Jacobian, are
    // independent: rank 8 with eight columns.
    let model = Model::new(
        k.clone(),
        vec![Effect::Location {
            symbols: (0..8).collect(),
        }],
    );
    assert_eq!(model.symbols.location.len(), 8);
    let theta = vec![0.0; 8];
    let mut rows = Vec::new();
    for &(t, c) in poses {
        for q in POINTS {
            let at = |t: f64, c: f64| {
                let commanded = k.nominal_table_transform(t, c) * Point3::from(q);
                let ctx = Context::at(Axes {
                    xyz: commanded.coords,
                    tilt: t,
                    c,
                });
                model.pose_jacobian(&theta, &ctx).1
            };
            let d = at(t, c) - at(0.0, 0.0);
            for r in 0..3 {
                rows.push(d.row(r).into_owned());
            }
        }
    }
    let sym = DMatrix::from_rows(&rows);
    let (r, cond) = rank(&sym);
    assert_eq!(r, 8, "{name}: the eight location symbols have rank {r}");
    assert!(cond < 1e6, "{name}: symbol condition number {cond:.3e}");
}

#[test]
fn stepped_square_poses_identify_the_eight_bc_symbols() {
    let mut poses = Vec::new();
    for b in [-90.0, 0.0, 90.0] {
        for c in [0.0, 90.0, 180.0, 270.0] {
            poses.push((b, c));
        }
    }
    // Slots: link 0 = B on Y (dx, dy, dz, a, b, c), link 1 = C on B.
    let null = [
        unit(6 + 2),           // dz_CB
        unit(6 + 5),           // c_CB
        unit(1) - unit(6 + 1), // dy_BY - dy_CB: only the sum EY0C is seen
        unit(4) - unit(6 + 4), // b_BY - b_CB: only the sum EB0B is seen
    ];
    check("bc-trunnion", &poses, &null);
}

#[test]
fn column_probing_poses_identify_the_eight_ac_symbols() {
    let mut poses = Vec::new();
    for a in [0.0, -30.0, -60.0, -90.0] {
        for c in (0..6).map(|i| 60.0 * i as f64) {
            poses.push((a, c));
        }
    }
    let null = [
        unit(6 + 2),           // dz_CA
        unit(6 + 5),           // c_CA
        unit(0) - unit(6),     // dx_AY - dx_CA: only EX0C
        unit(3) - unit(6 + 3), // a_AY - a_CA: only EA0A
    ];
    check("ac-trunnion", &poses, &null);
}

#[test]
fn a_single_tilt_angle_cannot_identify_all_eight() {
    // At B = 0 only, the B-axis terms cannot be told from the C-axis ones.
    let poses: Vec<(f64, f64)> = [0.0, 90.0, 180.0, 270.0]
        .iter()
        .map(|&c| (0.0, c))
        .collect();
    let k = Kinematics::new(&machine("bc-trunnion"));
    let (r, _) = rank(&design(&k, &poses));
    assert!(r < 8, "rank {r}");
}
