//! The ball bar under TCP (issue 44): plans on every built-in machine and
//! dialect within the machine's limits, the seed's setups plannable on a
//! machine of its kind, LinuxCNC's rs274 running the programs, and the
//! simulated bar against the seed's first-order equations and a finite
//! difference of the exact chain.

use fivecal::formats::ball_bar::{BallBarRun, Readings};
use fivecal::kinematics::{Perturbation, pose_frame::PoseFrame};
use fivecal::machine::{Dialect, Machine};
use fivecal::procedure::ball_bar::{BallBarRequest, plan, predict::length_row};
use fivecal::simulate::ball_bar::{BallBarOptions, deviation_at};
use nalgebra::{Rotation3, Vector3};

const BUILTIN: [&str; 4] = ["bc-trunnion", "ac-trunnion", "head-table", "head-head"];

fn request(machine: &str, d: Dialect) -> BallBarRequest {
    BallBarRequest::new(
        Machine::builtin(machine).unwrap(),
        d,
        vec![100.0, 150.0, 300.0],
    )
}

/// A DMU 100 monoBLOCK-like machine, the seed's: the built-in head-table
/// (CZFXYB) with a table and strokes of its size.
fn paper_machine() -> Machine {
    let src = paper_machine_yaml("dmu100-like");
    Machine::from_yaml(std::path::Path::new("dmu100-like.yaml"), &src).unwrap()
}

/// The machine file of [`paper_machine`], named `name`.
pub(crate) fn paper_machine_yaml(name: &str) -> String {
    Machine::builtin("head-table")
        .unwrap()
        .source
        .replace("name: head-table", &format!("name: {name}"))
        .replace("X: [0, 735]", "X: [0, 1300]")
        .replace("Y: [0, 650]", "Y: [0, 1000]")
        .replace("Z: [-560, 0]", "Z: [-1100, 0]")
        .replace(
            "pivot: [367.5, 325.0, -480.0]",
            "pivot: [650.0, 500.0, -1000.0]",
        )
        .replace("radius: 300.0", "radius: 500.0")
}

#[test]
fn every_builtin_machine_and_dialect_plans_within_strokes_and_limits_with_the_dialects_tcp() {
    for name in BUILTIN {
        for d in Dialect::ALL {
            let req = request(name, d);
            let p = plan(&req).unwrap_or_else(|e| panic!("{name} {d}: {e}"));
            assert!(!p.setups.is_empty());
            let m = &req.machine;
            for (s, prog) in p.setups.iter().zip(&p.programs) {
                let lower = prog.to_lowercase();
                let kin = fivecal::Kinematics::with_gauge_length(m, s.gauge);
                for (i, a) in s.axes.iter().enumerate() {
                    kin.check_strokes(a).unwrap();
                    assert!(m.tilt.within(a.tilt, 1e-9) && m.c.within(a.c, 1e-9));
                    // The commanded axes hold the nominal ball on M.
                    let (t, c) = s.angles_at(i, m.tilt.letter);
                    let tip = PoseFrame::new(&kin, t, c).ball_w(&a.xyz);
                    assert!((tip - s.m).norm() < 1e-9, "{name} {}", s.name);
                    assert!((s.m - s.n).norm() - s.bar < 1e-9);
                }
                let (on, off) = match d {
                    Dialect::Fanuc => ("G43.4 H", "G43 H"),
                    Dialect::Heidenhain => ("FUNCTION TCPM", "FUNCTION RESET TCPM"),
                    Dialect::Sinumerik => ("TRAORI", "TRAFOOF"),
                    Dialect::Linuxcnc => ("no TCP", "no TCP"),
                };
                let i_on = prog.find(on).unwrap_or_else(|| panic!("{d}: {prog}"));
                assert!(prog[i_on..].contains(off), "{d}");
                // The first and last moves are the retract and the rotary
                // axes: before TCP and after it.
                let safe = format!("Z{}", if d == Dialect::Heidenhain { "+" } else { "" });
                let first_retract = prog.find(&safe).unwrap();
                let sweep = lower.find("sweep of").unwrap();
                assert!(first_retract < sweep);
                assert!(lower.rfind("retract before the next setup").unwrap() > sweep);
            }
        }
    }
}

#[test]
fn the_seeds_ball_positions_and_lengths_s_are_plannable_on_a_machine_of_its_kind() {
    let mut req = BallBarRequest::new(
        paper_machine(),
        Dialect::Heidenhain,
        vec![100.0, 150.0, 300.0, 400.0],
    );
    req.balls = vec![
        Vector3::new(200.0, 152.0, 57.0),
        Vector3::new(310.0, 152.0, 57.0),
        Vector3::new(310.0, 210.0, 452.0),
    ];
    req.swings = vec![415.8417, 588.1654, 472.4698];
    let p = plan(&req).unwrap();
    let names: Vec<&str> = p.setups.iter().map(|s| s.name.as_str()).collect();
    for want in [
        "C1-X", "C1-Y", "C2-X", "C2-Y", "C3-X", "C3-Y", "C3-Z", "B1-X", "B2-X", "B3-X", "B1-Z",
    ] {
        assert!(
            names.contains(&want),
            "{want} missing: {names:?}\n{:?}",
            p.notes
        );
    }
    // The seed's C sweep: 0 to 360 in 60 divisions.
    let c1 = &p.setups[0];
    assert_eq!(c1.angles.len(), 61);
    assert_eq!(c1.angles[60], 360.0);
    // S is the rotation centre to the ball: the arbor is S less the pivot.
    let b1 = p.setups.iter().find(|s| s.name == "B1-X").unwrap();
    assert!((b1.gauge - (415.8417 - 180.0)).abs() < 1e-9);
    // The table axis: all six error motions at every angle (the seed's
    // three positions separate them).
    let c = &p.prediction.axes[0];
    assert_eq!((c.axis, c.rank), ('C', 6));
    assert!(
        c.u_max
            .iter()
            .all(|u| u.is_some_and(|u| u > 0.0 && u < 50.0)),
        "{c:?}"
    );
}

#[test]
fn the_bar_on_the_exact_machine_follows_the_seeds_first_order_equations_term_by_term() {
    // head-table, C table: at C = c the C link's six terms (dx, dy, dz,
    // a, b, c) move the ball relative to the table by
    // dM = -(Rc d + (Rc e) x M): at c = 0 the seed's eq. 8 form
    // (dx + ey H - ez L, dy + ez K - ex H, dz + ex L - ey K), with the
    // sign of an error of the table rather than of the tool.
    let req = request("head-table", Dialect::Heidenhain);
    let p = plan(&req).unwrap();
    let man = p.manifest();
    let kin = fivecal::Kinematics::with_gauge_length(&req.machine, 100.0);
    let link = kin.links().iter().position(|l| l.child == 'C').unwrap();
    let opts = BallBarOptions::default();
    let mut checked = 0;
    for (s, e) in p
        .setups
        .iter()
        .zip(&man.setups)
        .filter(|(s, _)| s.axis == 'C')
    {
        for i in [0, 10, 25] {
            let c = s.angles[i].to_radians();
            let rc = Rotation3::from_axis_angle(&Vector3::z_axis(), c);
            let u = (s.m - s.n).normalize();
            for k in 0..6 {
                let v = if k < 3 { 0.010 } else { 20e-6 }; // 10 um, 20 urad
                let mut pert = Perturbation::zero();
                pert.0[6 * link + k] = v;
                let exact = deviation_at(&kin, &pert, e, i, &opts);
                let mut d = Vector3::zeros();
                let mut eps = Vector3::zeros();
                if k < 3 {
                    d[k] = v;
                } else {
                    eps[k - 3] = v;
                }
                let dm = -(rc * d + (rc * eps).cross(&s.m));
                let first = u.dot(&dm) * 1000.0;
                assert!(
                    (exact - first).abs() < 1e-3,
                    "{} at C {}: term {k}: exact {exact} um, first order {first} um",
                    s.name,
                    s.angles[i]
                );
                // And the predicted row (the chain's analytic Jacobian)
                // is the same derivative.
                let row = length_row(&req, s, i);
                let unit = if k < 3 { v * 1000.0 } else { v * 1e6 };
                assert!((row[k] * unit - exact).abs() < 1e-3, "row {k}: {row:?}");
                checked += 1;
            }
        }
    }
    assert!(checked >= 6 * 3 * 6);
}

#[test]
fn the_predicted_rows_are_finite_differences_of_the_exact_bar_on_every_machine() {
    for name in BUILTIN {
        let req = request(name, Dialect::Fanuc);
        let p = plan(&req).unwrap();
        let man = p.manifest();
        for (s, e) in p.setups.iter().zip(&man.setups).step_by(3) {
            let kin = fivecal::Kinematics::with_gauge_length(&req.machine, s.gauge);
            let link = kin.links().iter().position(|l| l.child == s.axis).unwrap();
            let i = s.angles.len() / 2;
            let row = length_row(&req, s, i);
            for (k, r) in row.iter().enumerate() {
                // Steps large enough that the bar's rounding (1e-13 mm)
                // stays far below the difference; central, so the
                // curvature cancels.
                let h = if k < 3 { 1e-3 } else { 1e-5 };
                let mut pp = Perturbation::zero();
                pp.0[6 * link + k] = h;
                let mut pm = Perturbation::zero();
                pm.0[6 * link + k] = -h;
                let o = BallBarOptions::default();
                let fd = (deviation_at(&kin, &pp, e, i, &o) - deviation_at(&kin, &pm, e, i, &o))
                    / (2.0 * h);
                let unit = if k < 3 { 1000.0 } else { 1e6 };
                assert!(
                    (r * unit - fd).abs() < 1e-4 * (10.0 + fd.abs()),
                    "{name} {} term {k}: row {} fd {fd}",
                    s.name,
                    r * unit
                );
            }
        }
    }
}

#[test]
fn the_spindle_balls_run_out_reads_as_a_sinusoid_of_its_size_over_a_turn_of_the_table() {
    // The seed's eq. 10: a ball off the spindle axis by r reads
    // r cos(C + phase) on a bar across the table.
    let req = request("head-table", Dialect::Fanuc);
    let p = plan(&req).unwrap();
    let man = p.manifest();
    let kin = fivecal::Kinematics::with_gauge_length(&req.machine, 100.0);
    let e = man.setups.iter().find(|s| s.name == "C1-X").unwrap();
    let o = BallBarOptions {
        runout_um: 8.0,
        runout_phase_deg: 30.0,
        ..Default::default()
    };
    let dev: Vec<f64> = (0..e.angles.len())
        .map(|i| deviation_at(&kin, &Perturbation::zero(), e, i, &o))
        .collect();
    let hi = dev.iter().cloned().fold(f64::MIN, f64::max);
    let lo = dev.iter().cloned().fold(f64::MAX, f64::min);
    assert!(
        (hi - 8.0).abs() < 0.05 && (lo + 8.0).abs() < 0.05,
        "{lo} {hi}"
    );
    for (i, d) in dev.iter().enumerate() {
        let u = (Vector3::from(e.spindle_ball) - Vector3::from(e.table_ball)).normalize();
        let r = fivecal::simulate::ball_bar::runout_w(&kin, 0.0, e.angles[i], 8.0, 30.0);
        assert!((d - u.dot(&r) * 1000.0).abs() < 1e-3);
        // Perpendicular to the arbor: a run-out, not a length.
        assert!(
            r.dot(&PoseFrame::new(&kin, 0.0, e.angles[i]).probe_axis_w())
                .abs()
                < 1e-12
        );
    }
}

#[test]
fn every_linuxcnc_program_runs_through_rs274() {
    let dir = crate::util::tempdir();
    for name in BUILTIN {
        let p = plan(&request(name, Dialect::Linuxcnc)).unwrap();
        for (s, prog) in p.setups.iter().zip(&p.programs).step_by(2) {
            let f = dir.path().join(format!("{name}-{}.ngc", s.name));
            std::fs::write(&f, prog).unwrap();
            let canon = dir.path().join("canon.txt");
            let run = std::process::Command::new("timeout")
                .arg("20")
                .arg("rs274")
                .env("HOME", dir.path())
                .arg("-g")
                .arg(&f)
                .arg(&canon)
                .stdin(std::process::Stdio::null())
                .output()
                .expect("LinuxCNC's rs274 (package linuxcnc-uspace) must be installed");
            let err = String::from_utf8_lossy(&run.stderr).into_owned()
                + &String::from_utf8_lossy(&run.stdout);
            assert!(
                run.status.success() && !err.contains("rror") && !err.contains("unable"),
                "{name} {}: {err}",
                s.name
            );
            let moves = std::fs::read_to_string(&canon)
                .unwrap()
                .lines()
                .filter(|l| l.contains("STRAIGHT_FEED"))
                .count();
            // The approach, every step, the lift.
            assert!(moves > s.angles.len(), "{name} {}: {moves} feeds", s.name);
        }
    }
}

#[test]
fn simulate_writes_runs_the_reader_matches_to_the_plans_angles() {
    let dir = crate::util::tempdir();
    let out = dir.path().join("plan");
    let bin = env!("CARGO_BIN_EXE_fivecal");
    let st = std::process::Command::new(bin)
        .args([
            "plan",
            "ball-bar",
            "--machine",
            "head-table",
            "--dialect",
            "sinumerik",
        ])
        .args(["--bar", "100,150,300", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let truth = dir.path().join("truth.yaml");
    std::fs::write(&truth, "machine: head-table\nlocation_errors: {}\n").unwrap();
    let runs = dir.path().join("runs");
    let st = std::process::Command::new(bin)
        .args(["simulate", "--plan"])
        .arg(out.join("ball-bar.plan.yaml"))
        .arg("--errors")
        .arg(&truth)
        .args(["--runout", "3,45", "--no-noise", "-o"])
        .arg(&runs)
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let man =
        fivecal::formats::ball_bar::BallBarManifest::read(&out.join("ball-bar.plan.yaml")).unwrap();
    for s in &man.setups {
        let run = BallBarRun::read(&runs.join(format!("{}.txt", s.name))).unwrap();
        assert_eq!(run.setup, s.name);
        let dev = run.at_angles(s).unwrap();
        assert_eq!(dev.len(), s.angles.len());
        // No machine error: only the run-out, at most its 3 um.
        assert!(dev.iter().all(|d| d.abs() <= 3.0 + 1e-3), "{dev:?}");
        assert!(matches!(run.readings, Readings::Angles(_)));
    }
}
