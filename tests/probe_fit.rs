//! Sphere, circle and plane fits, worked on Cubas Brizuela & Yeh's (2023) table 1 and checked
//! against closed forms computed here independently of the library.

use std::collections::BTreeMap;

use fivecal::shape_fit::{
    ShapeFitError, SphereCheck, circle_through_three, fit_circle, fit_plane, fit_sphere,
    fit_sphere_algebraic,
};
use nalgebra::{Matrix3, Rotation3, Unit, Vector3};
use rand::RngExt;
use rand_distr::{Distribution, Normal};

use crate::util::rng;

/// Cubas Brizuela & Yeh's (2023) table 1, by pose, in the file's order (Xc+, Xc-, Yc+, Yc-, Zc-).
fn table1() -> BTreeMap<String, Vec<Vector3<f64>>> {
    let src = std::fs::read_to_string("tests/fixtures/probe/seed004-table1.csv").unwrap();
    let mut sets: BTreeMap<String, Vec<Vector3<f64>>> = BTreeMap::new();
    for line in src.lines().filter(|l| !l.starts_with('#')).skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let v: Vec<f64> = f[2..5].iter().map(|s| s.parse().unwrap()).collect();
        sets.entry(f[0].to_string())
            .or_default()
            .push(Vector3::new(v[0], v[1], v[2]));
    }
    sets
}

fn det3(m: &[[f64; 3]; 3]) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// The sphere through four points by Cramer's rule on the three equations
/// `2 (p_i - p_0) . c = |p_i|^2 - |p_0|^2`: an independent closed form.
fn circumsphere(p: &[Vector3<f64>; 4]) -> (Vector3<f64>, f64) {
    let mut a = [[0.0; 3]; 3];
    let mut b = [0.0; 3];
    for i in 0..3 {
        for k in 0..3 {
            a[i][k] = 2.0 * (p[i + 1][k] - p[0][k]);
        }
        b[i] = p[i + 1].norm_squared() - p[0].norm_squared();
    }
    let d = det3(&a);
    let mut c = [0.0; 3];
    for (k, ck) in c.iter_mut().enumerate() {
        let mut m = a;
        for i in 0..3 {
            m[i][k] = b[i];
        }
        *ck = det3(&m) / d;
    }
    let c = Vector3::new(c[0], c[1], c[2]);
    (c, (p[0] - c).norm())
}

/// Cubas Brizuela & Yeh's (2023) four combinations of four touches, each with the Z touch.
const COMBINATIONS: [[usize; 4]; 4] = [[0, 1, 2, 4], [0, 1, 3, 4], [0, 2, 3, 4], [1, 2, 3, 4]];

/// The ball-centre radius of the seed's reference set. The seed gives the
/// sphere (29.9996 mm) but not the stylus ball, and records ball centres,
/// so the radius to expect is 14.9998 mm plus the ball radius: 15.49 mm is
/// what its C = 0 set says, the value a controller would hold after
/// calibrating the stylus on this sphere.
const BALL_CENTRE_RADIUS: f64 = 15.49;

#[test]
fn seed004_table1_c0_set_fits_a_sphere_with_sub_micrometre_residuals() {
    let sets = table1();
    let c0 = &sets["C0"];
    let fit = fit_sphere(c0).unwrap();
    assert!(
        (fit.sphere.radius - 15.49).abs() < 0.001,
        "radius {:.5} mm",
        fit.sphere.radius
    );
    assert!(
        fit.max_abs < 0.001,
        "residuals {:?} mm should be sub-micrometre",
        fit.residuals
    );
    let checked = SphereCheck::new(BALL_CENTRE_RADIUS)
        .check("C0", c0)
        .expect("the reference set is plausible");
    assert_eq!(checked, fit);
}

#[test]
fn seed004_table1_120_and_240_sets_are_flagged_implausible_naming_the_pose() {
    let sets = table1();
    let reference = fit_sphere(&sets["C0"]).unwrap().sphere.radius;
    let check = SphereCheck::new(BALL_CENTRE_RADIUS);
    assert_eq!(check.radius_tolerance, 0.02, "HEIDENHAIN's default limit");
    for pose in ["C120", "C240"] {
        let err = check.check(pose, &sets[pose]).unwrap_err();
        let fit = err.fit.as_ref().unwrap();
        // The radius is off by more than a millimetre whichever reference
        // is taken: the expected one or the C = 0 fit.
        assert!(
            (fit.sphere.radius - BALL_CENTRE_RADIUS).abs() > 1.0
                && (fit.sphere.radius - reference).abs() > 1.0,
            "{pose}: radius {:.4}",
            fit.sphere.radius
        );
        assert!(
            (0.5..1.0).contains(&fit.max_abs),
            "{pose}: residuals {:?}",
            fit.residuals
        );
        let msg = err.to_string();
        assert!(
            msg.starts_with(&format!("pose {pose}: implausible sphere")),
            "{msg}"
        );
        assert!(
            msg.contains("off the expected 15.4900 mm (limit 0.02 mm)"),
            "{msg}"
        );
        assert!(
            msg.contains("off the fitted sphere (limit 0.02 mm)"),
            "{msg}"
        );
    }
}

#[test]
fn sphere_fits_of_four_touches_equal_the_closed_form_circumsphere() {
    for (pose, set) in table1() {
        for comb in COMBINATIONS {
            let four = comb.map(|i| set[i]);
            let (c, r) = circumsphere(&four);
            let alg = fit_sphere_algebraic(&four).unwrap();
            let geo = fit_sphere(&four).unwrap();
            for (what, got_c, got_r) in [
                ("algebraic", alg.centre, alg.radius),
                ("geometric", geo.sphere.centre, geo.sphere.radius),
            ] {
                assert!(
                    (got_c - c).norm() < 1e-8 && (got_r - r).abs() < 1e-8,
                    "{pose} {comb:?} {what}: {got_c:?} r {got_r} vs closed form {c:?} r {r}"
                );
            }
            assert!(geo.max_abs < 1e-8);
        }
    }
}

#[test]
fn least_squares_centre_agrees_with_seed004s_average_of_four_combinations() {
    let sets = table1();
    let c0 = &sets["C0"];
    let mean = COMBINATIONS
        .iter()
        .map(|comb| circumsphere(&comb.map(|i| c0[i])).0)
        .sum::<Vector3<f64>>()
        / 4.0;
    let fit = fit_sphere(c0).unwrap();
    assert!(
        (fit.sphere.centre - mean).norm() < 0.001,
        "least squares {:?} vs Cubas Brizuela & Yeh's (2023) combination average {mean:?}",
        fit.sphere.centre
    );
}

#[test]
fn geometric_sphere_fit_is_stationary_and_beats_the_algebraic_start() {
    let mut r = rng(4004);
    let noise = Normal::new(0.0, 0.002).unwrap();
    for trial in 0..50 {
        let c = Vector3::new(
            r.random_range(-300.0..300.0),
            r.random_range(-300.0..300.0),
            r.random_range(-200.0..200.0),
        );
        let radius = r.random_range(5.0..30.0);
        // Touches on the upper half only, as a probe reaches a sphere on a stem.
        let pts: Vec<Vector3<f64>> = (0..r.random_range(5..12))
            .map(|_| {
                let az: f64 = r.random_range(0.0..std::f64::consts::TAU);
                let el: f64 = r.random_range(-0.2..1.5);
                let d = Vector3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
                c + d * (radius + noise.sample(&mut r))
            })
            .collect();
        let fit = fit_sphere(&pts).unwrap();
        // First-order optimality of sum (|p - c| - r)^2: the residuals sum
        // to zero and their weighted directions cancel (to 10 pm: far below
        // any probe's resolution, and a wrong fit misses by micrometres).
        let sum_r: f64 = fit.residuals.iter().sum();
        let grad_c: Vector3<f64> = pts
            .iter()
            .zip(&fit.residuals)
            .map(|(p, e)| (p - fit.sphere.centre).normalize() * *e)
            .sum();
        assert!(
            sum_r.abs() < 1e-8 && grad_c.norm() < 1e-8,
            "trial {trial}: gradient {sum_r:e} {grad_c:?}"
        );
        let alg = fit_sphere_algebraic(&pts).unwrap();
        let cost = |c: &Vector3<f64>, rad: f64| -> f64 {
            pts.iter().map(|p| ((p - c).norm() - rad).powi(2)).sum()
        };
        assert!(
            cost(&fit.sphere.centre, fit.sphere.radius) <= cost(&alg.centre, alg.radius) + 1e-15
        );
        assert!((fit.sphere.centre - c).norm() < 0.05, "trial {trial}");
    }
}

#[test]
fn a_sphere_needs_a_touch_off_the_equator_plane() {
    let sets = table1();
    let equator: Vec<_> = sets["C0"][..4].to_vec();
    let e = fit_sphere(&equator).unwrap_err();
    assert!(matches!(e, ShapeFitError::Degenerate { .. }), "{e}");
    assert!(e.to_string().contains("lie in one plane"), "{e}");
}

/// The independent closed form of the circumcircle: the centre solves the
/// two perpendicular-bisector equations and the plane equation.
fn circumcircle(a: &Vector3<f64>, b: &Vector3<f64>, c: &Vector3<f64>) -> (Vector3<f64>, f64) {
    let n = (b - a).cross(&(c - a));
    let m = Matrix3::from_rows(&[
        (2.0 * (b - a)).transpose(),
        (2.0 * (c - a)).transpose(),
        n.transpose(),
    ]);
    let rhs = Vector3::new(
        b.norm_squared() - a.norm_squared(),
        c.norm_squared() - a.norm_squared(),
        n.dot(a),
    );
    let centre = m.try_inverse().unwrap() * rhs;
    (centre, (a - centre).norm())
}

#[test]
fn circle_through_three_and_circle_fit_agree_with_the_closed_form() {
    let mut r = rng(4005);
    for _ in 0..100 {
        let p: Vec<Vector3<f64>> = (0..3)
            .map(|_| {
                Vector3::new(
                    r.random_range(-200.0..200.0),
                    r.random_range(-200.0..200.0),
                    r.random_range(-200.0..200.0),
                )
            })
            .collect();
        let (c, rad) = circumcircle(&p[0], &p[1], &p[2]);
        let three = circle_through_three(&p[0], &p[1], &p[2]).unwrap();
        let fit = fit_circle(&p).unwrap();
        for (what, got) in [("through three", three), ("fit", fit.circle)] {
            assert!(
                (got.centre - c).norm() < 1e-7 * (1.0 + rad)
                    && (got.radius - rad).abs() < 1e-7 * (1.0 + rad),
                "{what}: {got:?} vs {c:?} r {rad}"
            );
        }
        let plane = fit_plane(&p).unwrap().plane;
        assert!(three.normal.cross(&plane.normal).norm() < 1e-9);
    }
}

/// Cubas Brizuela & Yeh 2023, section 3.2 as a worked example: the sphere's ball-centre
/// touches at 36 C positions around a C axis that is shifted and tilted;
/// fitting the sphere at each position, then a circle through the 36
/// centres, returns the axis: where it crosses Z = 0 (eq. 4.1) and its
/// angle to Z (eq. 3.4).
#[test]
fn circle_through_sphere_centres_of_a_c_sweep_finds_the_c_axis() {
    let axis_at_0 = Vector3::new(0.020, -0.012, 0.0);
    let tilt = Vector3::new(15e-6, -8e-6, 1.0).normalize();
    let to_axis = Rotation3::rotation_between(&Vector3::z(), &tilt).unwrap();
    let sphere_at_c0 = Vector3::new(87.0, 12.0, 60.0);
    let r_ball_centre = 15.49;
    let mut r = rng(4006);
    let noise = Normal::new(0.0, 0.0003).unwrap();
    let mut centres = Vec::new();
    for k in 0..36 {
        let c = (10.0 * k as f64).to_radians();
        let rot = Rotation3::from_axis_angle(&Unit::new_normalize(tilt), c);
        let centre = axis_at_0 + rot * (to_axis * sphere_at_c0);
        let touches: Vec<Vector3<f64>> = [
            -Vector3::x(),
            Vector3::x(),
            -Vector3::y(),
            Vector3::y(),
            Vector3::z(),
        ]
        .iter()
        .map(|d| centre + d * (r_ball_centre + noise.sample(&mut r)))
        .collect();
        let fit = SphereCheck::new(r_ball_centre)
            .check(&format!("C{}", 10 * k), &touches)
            .unwrap();
        centres.push(fit.sphere.centre);
    }
    let circle = fit_circle(&centres).unwrap();
    let crossing = circle.circle.axis_point_at_z(0.0).unwrap();
    assert!(
        (crossing - axis_at_0).norm() < 0.0005,
        "axis crosses Z = 0 at {crossing:?}, truth {axis_at_0:?}"
    );
    let truth_tilt = tilt.z.acos();
    assert!(
        (circle.circle.axis_tilt() - truth_tilt).abs() < 3e-6,
        "tilt {:.3e} rad vs {truth_tilt:.3e}",
        circle.circle.axis_tilt()
    );
    assert!(circle.max_abs < 0.002);
}
