//! The exact model: forward/inverse round trips, Jacobians against finite
//! differences, the table-table form of docs/model.md, and Ibaraki & Ota's (2014) linearization.

use fivecal::geom::{self, Axis3, d6};
use fivecal::kinematics::maps::{MapDim, MapGrid};
use fivecal::kinematics::{IkError, Kinematics, N_VARS, Perturbation, SLOT_LIN, VAR_C, VAR_TILT};
use fivecal::model::{Context, DriftBasis, Effect, Model, Squareness, Wanted};
use fivecal::{Axes, ToolPose};
use nalgebra::{Isometry3, Point3, Vector3};
use rand::RngExt;

use crate::util::{MACHINES, machine, random_axes, random_perturbation, rng};

const N_POSES: usize = 10_000;

fn assert_axes_close(got: &Axes, want: &Axes, what: &str) {
    let d = (got.xyz - want.xyz).norm();
    let dt = (got.tilt - want.tilt).abs();
    let dc = (got.c - want.c).abs();
    assert!(
        d < 1e-9 && dt < 1e-9 && dc < 1e-9,
        "{what}: got {got:?}, want {want:?} (|dxyz| {d:.2e} mm, dtilt {dt:.2e} deg, dC {dc:.2e} deg)"
    );
}

/// A hint near the true rotary position, as the previous block of a
/// program would give.
fn hint_near(a: &Axes, r: &mut rand::rngs::StdRng) -> Axes {
    Axes {
        tilt: a.tilt + r.random_range(-20.0..20.0),
        c: a.c + r.random_range(-20.0..20.0),
        ..*a
    }
}

#[test]
fn forward_then_inverse_returns_the_axes_nominal() {
    for (mi, name) in MACHINES.iter().enumerate() {
        let m = machine(name);
        let k = Kinematics::new(&m);
        let mut r = rng(100 + mi as u64);
        for i in 0..N_POSES {
            let a = random_axes(&m, &mut r);
            let pose = k.forward_nominal(&a);
            let hint = hint_near(&a, &mut r);
            let got = k
                .inverse_nominal(&pose, Some(&hint))
                .unwrap_or_else(|e| panic!("{name} pose {i} {a:?}: {e}"));
            assert_axes_close(&got, &a, &format!("{name} nominal pose {i}"));
        }
    }
}

#[test]
fn forward_then_inverse_returns_the_axes_with_constant_errors() {
    for (mi, name) in MACHINES.iter().enumerate() {
        let m = machine(name);
        let k = Kinematics::new(&m);
        let mut r = rng(200 + mi as u64);
        for i in 0..N_POSES {
            let p = random_perturbation(&k, &mut r, 50.0, 100.0);
            let a = random_axes(&m, &mut r);
            let pose = k.forward(&a, &p);
            let hint = hint_near(&a, &mut r);
            let got = k
                .inverse(&pose, Some(&hint), |_| p)
                .unwrap_or_else(|e| panic!("{name} pose {i} {a:?}: {e}"));
            assert_axes_close(&got, &a, &format!("{name} pose {i} with errors"));
        }
    }
}

/// Every location symbol, a map on every map symbol, and linear-axis
/// errors, all with random values of 50 um / 100 urad (50 um/m scale).
fn full_model(k: &Kinematics, r: &mut rand::rngs::StdRng) -> (Model, Vec<f64>) {
    let mut model = Model::new(k.clone(), vec![]);
    let n_loc = model.symbols.location.len();
    model.push(Effect::Location {
        symbols: (0..n_loc).collect(),
    });
    let m = k.machine();
    let (tlo, thi) = m.tilt.limits.unwrap();
    let tilt_nodes: Vec<f64> = (0..4).map(|i| tlo + (thi - tlo) * i as f64 / 3.0).collect();
    let c_nodes = [0.0, 60.0, 120.0, 180.0, 240.0, 300.0];
    for s in 0..model.symbols.maps.len() {
        let deps = model.symbols.maps[s].deps.clone();
        let dims = deps
            .iter()
            .map(|&d| {
                if d == 0 {
                    MapDim::new(0, &tilt_nodes, false).unwrap()
                } else {
                    MapDim::new(1, &c_nodes, true).unwrap()
                }
            })
            .collect();
        model.push(Effect::Map {
            symbol: s,
            grid: MapGrid { dims },
        });
    }
    for axis in [Axis3::X, Axis3::Y, Axis3::Z] {
        model.push(Effect::Scale { axis });
    }
    for kind in Squareness::ALL {
        model.push(Effect::Squareness { kind });
    }
    model.push(Effect::Straightness {
        moving: Axis3::X,
        direction: Axis3::Y,
        nodes: vec![-200.0, 0.0, 200.0],
    });
    model.push(Effect::Drift {
        symbol: 1,
        basis: DriftBasis::Seq,
    });
    model.push(Effect::ToolLength);
    let units = model.param_units();
    let theta = units
        .iter()
        .map(|u| {
            let s: f64 = r.random_range(-1.0..1.0);
            if u.starts_with("urad") {
                100.0 * s
            } else {
                50.0 * s
            }
        })
        .collect();
    (model, theta)
}

#[test]
fn forward_then_inverse_returns_the_axes_with_error_maps_and_linear_errors() {
    for (mi, name) in MACHINES.iter().enumerate() {
        let m = machine(name);
        let k = Kinematics::new(&m);
        let mut r = rng(300 + mi as u64);
        let (model, theta) = full_model(&k, &mut r);
        let mut ambiguous = 0;
        for i in 0..N_POSES {
            let a = random_axes(&m, &mut r);
            let ctx = Context {
                axes: a,
                seq: (i % 12) as f64,
                ..Default::default()
            };
            let pose = model.pose(&theta, &ctx);
            let hint = hint_near(&a, &mut r);
            let got = model
                .inverse(&theta, &pose, Some(&hint), &ctx)
                .unwrap_or_else(|e| panic!("{name} pose {i} {a:?}: {e}"));
            let distance = |x: &Axes| (x.tilt - hint.tilt).abs() + (x.c - hint.c).abs();
            let same = (got.xyz - a.xyz).norm() < 1e-9
                && (got.tilt - a.tilt).abs() < 1e-9
                && (got.c - a.c).abs() < 1e-9;
            if !same {
                // Within an error's width of the singular tilt, C-dependent
                // errors make several exact solutions lie close together;
                // the one returned must be exact and at least as near the
                // hint as the input.
                let back = model.pose(&theta, &Context { axes: got, ..ctx });
                assert!(
                    (back.tip - pose.tip).norm() < 1e-9 && (back.axis - pose.axis).norm() < 1e-12,
                    "{name} pose {i}: {got:?} is not a solution"
                );
                assert!(
                    distance(&got) <= distance(&a) + 1e-9,
                    "{name} pose {i}: {got:?} is farther from the hint {hint:?} than {a:?}"
                );
                assert!(
                    a.tilt.abs() < 0.05,
                    "{name} pose {i}: {a:?} is not near the singular tilt, yet {got:?} came back"
                );
                ambiguous += 1;
            }
        }
        assert!(
            ambiguous <= 3,
            "{name}: {ambiguous} of {N_POSES} poses had another solution nearer the hint"
        );
    }
}

#[test]
fn inverse_without_hint_picks_the_solution_nearest_rotary_zero() {
    let m = machine("bc-trunnion");
    let k = Kinematics::new(&m);
    // Tool axis tilted 30 deg towards +X in W: B = 30, C = 0 or B = -30, C = 180.
    let u = Vector3::new(0.5, 0.0, 3f64.sqrt() / 2.0);
    let got = k
        .inverse_nominal(
            &ToolPose {
                tip: Vector3::new(10.0, 0.0, 5.0),
                axis: u,
            },
            None,
        )
        .unwrap();
    assert!(
        (got.tilt - 30.0).abs() < 1e-12 && got.c.abs() < 1e-12,
        "{got:?}"
    );
    // With the previous position at C = 170 the other branch is nearer.
    let prev = Axes::new(0.0, 0.0, 0.0, -20.0, 170.0);
    let got = k
        .inverse_nominal(
            &ToolPose {
                tip: Vector3::new(10.0, 0.0, 5.0),
                axis: u,
            },
            Some(&prev),
        )
        .unwrap();
    assert!(
        (got.tilt + 30.0).abs() < 1e-12 && (got.c - 180.0).abs() < 1e-12,
        "{got:?}"
    );
}

#[test]
fn inverse_reports_a_tilt_outside_the_limits() {
    let m = machine("ac-trunnion");
    let k = Kinematics::new(&m);
    // A tool axis tilted 150 deg from +Z needs A = +-150, outside -120..30.
    let a = 150f64.to_radians();
    let target = ToolPose {
        tip: Vector3::zeros(),
        axis: Vector3::new(0.0, -a.sin(), a.cos()),
    };
    let e = k.inverse_nominal(&target, None).unwrap_err();
    assert!(
        matches!(e, IkError::TiltOutOfLimits { letter: 'A', .. }),
        "{e}"
    );
    let msg = e.to_string();
    assert!(
        msg.contains("outside the limits [-120, 30]") && msg.contains("150.0000"),
        "{msg}"
    );
}

/// Relative difference of an analytic and a finite-difference derivative.
/// Derivatives below `floor` are physically negligible (1e-3 mm per mm or
/// per rad, 1e-3 per rad for the unit axis) and are compared against it,
/// since there the difference quotient's round-off dominates.
fn rel_diff(an: Vector3<f64>, fd: Vector3<f64>, floor: f64) -> f64 {
    (an - fd).norm() / an.norm().max(fd.norm()).max(floor)
}

#[test]
fn analytic_jacobian_matches_central_differences() {
    // Five-point stencil: truncation of order h^4, round-off of order
    // 1e-16 * |tip| / h, both far below 1e-6 of the floor.
    let h = 1e-3;
    for (mi, name) in MACHINES.iter().enumerate() {
        let m = machine(name);
        let k = Kinematics::new(&m);
        let mut r = rng(400 + mi as u64);
        for _ in 0..200 {
            let p = random_perturbation(&k, &mut r, 50.0, 100.0);
            let a = random_axes(&m, &mut r);
            let j = k.jacobian(&a, &p);
            for v in 0..N_VARS {
                let eval = |s: f64| {
                    let mut aa = a;
                    let mut pp = p;
                    match v {
                        0..=2 => aa.xyz[v] += s,
                        VAR_TILT => aa.tilt += geom::deg(s),
                        VAR_C => aa.c += geom::deg(s),
                        _ => pp.0[v - 5] += s,
                    }
                    k.forward(&aa, &pp)
                };
                let (p1, m1, p2, m2) = (eval(h), eval(-h), eval(2.0 * h), eval(-2.0 * h));
                let fd_tip = (8.0 * (p1.tip - m1.tip) - (p2.tip - m2.tip)) / (12.0 * h);
                let fd_axis = (8.0 * (p1.axis - m1.axis) - (p2.axis - m2.axis)) / (12.0 * h);
                let an_tip = j.tip.column(v).into_owned();
                let an_axis = j.axis.column(v).into_owned();
                for (an, fd, what) in [(an_tip, fd_tip, "tip"), (an_axis, fd_axis, "axis")] {
                    let rel = rel_diff(an, fd, 1e-3);
                    assert!(
                        rel < 1e-6,
                        "{name}: d {what} / d var {v} ({:?}): relative difference {rel:.2e}",
                        k.slot_name(v.saturating_sub(5))
                    );
                }
            }
        }
    }
}

#[test]
fn parameter_jacobian_matches_central_differences() {
    // The model is linear in each parameter up to terms of (1e-6)^2
    // relative, so a step of one um or urad has no truncation error to speak of.
    let h = 1.0;
    for (mi, name) in MACHINES.iter().enumerate() {
        let m = machine(name);
        let k = Kinematics::new(&m);
        let mut r = rng(500 + mi as u64);
        let (model, theta) = full_model(&k, &mut r);
        let names = model.param_names();
        for _ in 0..20 {
            let ctx = Context {
                axes: random_axes(&m, &mut r),
                seq: 5.0,
                ..Default::default()
            };
            let (_, jt, ja) = model.pose_jacobian(&theta, &ctx);
            for i in 0..model.n_params() {
                let mut tp = theta.clone();
                tp[i] += h;
                let mut tm = theta.clone();
                tm[i] -= h;
                let (pp, pm) = (model.pose(&tp, &ctx), model.pose(&tm, &ctx));
                let fd_tip = (pp.tip - pm.tip) / (2.0 * h);
                let fd_axis = (pp.axis - pm.axis) / (2.0 * h);
                for (an, fd, what) in [
                    (
                        Vector3::new(jt[(0, i)], jt[(1, i)], jt[(2, i)]),
                        fd_tip,
                        "tip",
                    ),
                    (
                        Vector3::new(ja[(0, i)], ja[(1, i)], ja[(2, i)]),
                        fd_axis,
                        "axis",
                    ),
                ] {
                    // Floors: 1 nm of tip or 1e-9 of axis per um or urad.
                    let rel = rel_diff(an, fd, if what == "tip" { 1e-6 } else { 1e-9 });
                    assert!(
                        rel < 1e-6,
                        "{name}: d {what} / d {}: relative difference {rel:.2e}",
                        names[i]
                    );
                }
            }
        }
    }
}

#[test]
fn a_few_columns_at_parameters_found_once_are_the_whole_jacobians_columns_to_the_bit() {
    // What the machining forward model uses: the effects not at zero found
    // once per parameter vector, and only the columns a fit takes.
    for (mi, name) in MACHINES.iter().enumerate() {
        let m = machine(name);
        let k = Kinematics::new(&m);
        let mut r = rng(900 + mi as u64);
        let (model, mut theta) = full_model(&k, &mut r);
        // Every other effect at zero, as in a catalogue fitted a few at a time.
        for e in (0..model.effects.len()).step_by(2) {
            for c in model.param_range(e) {
                theta[c] = 0.0;
            }
        }
        let wanted = Wanted::new(&model, |c| c % 3 != 1);
        let at = model.params(&theta);
        for _ in 0..20 {
            let ctx = Context {
                axes: random_axes(&m, &mut r),
                seq: 5.0,
                ..Default::default()
            };
            let whole = model.perturbation(&theta, &ctx);
            assert_eq!(model.perturbation_at(&at, &ctx), whole, "{name}");
            let (pj, jt, ja) = model.pose_jacobian(&theta, &ctx);
            let (pj_at, jt_at, ja_at) = model.pose_jacobian_at(&at, &ctx, &wanted);
            let (tj_at, tt_at) = model.tip_jacobian_at(&at, &ctx, &wanted);
            let pose = model.jacobian_pose_at(&at, &ctx);
            for (what, got) in [("pose", pj_at.pose), ("tip", tj_at.pose), ("bare", pose)] {
                assert_eq!(got.tip, pj.pose.tip, "{name}: {what}'s tip");
                assert_eq!(got.axis, pj.pose.axis, "{name}: {what}'s axis");
            }
            assert_eq!(jt_at.ncols(), wanted.columns().len());
            for (c, &j) in wanted.columns().iter().enumerate() {
                assert_eq!(jt_at.column(c), jt.column(j), "{name}: tip column {j}");
                assert_eq!(tt_at.column(c), jt.column(j), "{name}: tip column {j}");
                assert_eq!(ja_at.column(c), ja.column(j), "{name}: axis column {j}");
            }
        }
    }
}

#[test]
fn the_errors_moved_along_the_linear_axes_are_the_errors_there_to_the_bit() {
    // What a probe's line uses: the errors at one position of X, Y, Z
    // carried to another by working out the linear-axis errors again.
    for (mi, name) in MACHINES.iter().enumerate() {
        let m = machine(name);
        let k = Kinematics::new(&m);
        let mut r = rng(950 + mi as u64);
        let (model, theta) = full_model(&k, &mut r);
        for _ in 0..50 {
            let from = Context {
                axes: random_axes(&m, &mut r),
                seq: 3.0,
                minutes: 7.5,
                ..Default::default()
            };
            let to = Context {
                axes: Axes {
                    xyz: random_axes(&m, &mut r).xyz,
                    ..from.axes
                },
                ..from
            };
            let there = model.perturbation(&theta, &to);
            let moved = model.perturbation_moved(&theta, &to, &model.perturbation(&theta, &from));
            assert_eq!(
                moved.0.map(f64::to_bits),
                there.0.map(f64::to_bits),
                "{name}"
            );
        }
    }
}

/// `rTw` of docs/model.md, written out independently.
fn spec_rtw(tilt_axis: Axis3, p: &Perturbation, t: f64, c: f64) -> Isometry3<f64> {
    d6(&p.link(0))
        * geom::rot(tilt_axis, -t.to_radians())
        * d6(&p.link(1))
        * geom::rot(Axis3::Z, -c.to_radians())
}

#[test]
fn table_table_transform_is_exactly_the_spec_form() {
    for (name, axis) in [("bc-trunnion", Axis3::Y), ("ac-trunnion", Axis3::X)] {
        let m = machine(name);
        let k = Kinematics::new(&m);
        let mut r = rng(600);
        for _ in 0..100 {
            let p = random_perturbation(&k, &mut r, 500.0, 5000.0);
            let a = random_axes(&m, &mut r);
            let got = k.table_transform(a.tilt, a.c, &p).to_homogeneous();
            let want = spec_rtw(axis, &p, a.tilt, a.c).to_homogeneous();
            assert!((got - want).abs().max() < 1e-13, "{name}");
            // wq = rTw^-1 * rTw* * wq*, with the tool at rTw* wq*.
            let wq_star = Vector3::new(
                r.random_range(-50.0..50.0),
                r.random_range(-50.0..50.0),
                r.random_range(0.0..80.0),
            );
            let nominal = spec_rtw(axis, &Perturbation::zero(), a.tilt, a.c);
            let commanded = nominal * Point3::from(wq_star);
            let wq = spec_rtw(axis, &p, a.tilt, a.c).inverse() * commanded;
            let mut p_no_len = p;
            p_no_len.0[fivecal::kinematics::SLOT_TOOL_LENGTH] = 0.0;
            let fk = k
                .forward(
                    &Axes {
                        xyz: commanded.coords,
                        ..a
                    },
                    &p_no_len,
                )
                .tip;
            assert!((fk - wq.coords).norm() < 1e-12, "{name}");
        }
    }
}

/// Ibaraki & Ota 2014, eq. (6): the linearized 6-DOF displacement of W for the twelve
/// terms of a B/C machine at (B, C).
fn seed001_eq6(p: &Perturbation, b: f64, c: f64) -> [f64; 6] {
    let [dx_by, dy_by, dz_by, a_by, b_by, c_by] = p.link(0);
    let [dx_cb, dy_cb, dz_cb, a_cb, b_cb, c_cb] = p.link(1);
    let (sb, cb) = b.to_radians().sin_cos();
    let (sc, cc) = c.to_radians().sin_cos();
    let u = dx_by * cb + dz_by * sb + dx_cb;
    let v = dy_by + dy_cb;
    let ua = a_by * cb + c_by * sb + a_cb;
    let va = b_by + b_cb;
    [
        -u * cc + v * sc,
        -u * sc - v * cc,
        dx_by * sb - dz_by * cb - dz_cb,
        -ua * cc + va * sc,
        -ua * sc - va * cc,
        a_by * sb - c_by * cb - c_cb,
    ]
}

fn max_linearization_gap(k: &Kinematics, p: &Perturbation) -> (f64, f64) {
    let mut gap: f64 = 0.0;
    let mut first: f64 = 0.0;
    for b in [-90.0, -45.0, 0.0, 45.0, 90.0] {
        for c in [0.0, 90.0, 180.0, 270.0, 33.0] {
            let lin = d6(&seed001_eq6(p, b, c));
            for q in [
                [0.0, 0.0, 0.0],
                [60.0, 0.0, 20.0],
                [0.0, -60.0, 40.0],
                [40.0, 40.0, 60.0],
            ] {
                let wq_star = Vector3::from(q);
                let commanded = k.nominal_table_transform(b, c) * Point3::from(wq_star);
                let exact = k
                    .forward(
                        &Axes {
                            xyz: commanded.coords,
                            tilt: b,
                            c,
                        },
                        p,
                    )
                    .tip;
                let approx = (lin * Point3::from(wq_star)).coords;
                gap = gap.max((exact - approx).norm());
                first = first.max((exact - wq_star).norm());
            }
        }
    }
    (gap, first)
}

#[test]
fn exact_model_agrees_with_seed001_eq5_eq6_to_second_order() {
    let m = machine("bc-trunnion");
    let k = Kinematics::new(&m);
    let mut r = rng(700);
    for _ in 0..20 {
        let mut p = random_perturbation(&k, &mut r, 40.0, 80.0);
        p.0[fivecal::kinematics::SLOT_TOOL_LENGTH] = 0.0;
        let mut half = p;
        for v in half.0.iter_mut().take(SLOT_LIN) {
            *v *= 0.5;
        }
        let (g1, f1) = max_linearization_gap(&k, &p);
        let (g2, _) = max_linearization_gap(&k, &half);
        let ratio = g1 / g2;
        assert!(
            (3.6..4.4).contains(&ratio),
            "halving the errors shrank the gap by {ratio:.3}, not 4"
        );
        assert!(
            g1 < 1e-3 * f1.max(1e-6) * 10.0,
            "second-order gap {g1:.3e} mm vs first-order {f1:.3e} mm"
        );
    }
}
