//! Compensation with known errors: the rewritten program, run on the
//! erroneous machine, puts the tool where the original program meant it;
//! paths stay within the tolerance; arcs, inverse-time feeds, the tilt
//! singularity, expressions, streaming.

use std::cell::Cell;
use std::io::{BufReader, Read, Write};
use std::path::Path;
use std::rc::Rc;

use fivecal::compensate::simulate::{Sample, SimSettings, Simulator};
use fivecal::compensate::{Compensator, Coordinates, Settings, Summary, Vertex};
use fivecal::errorfile::{ErrorFile, LoadedErrors};
use fivecal::kinematics::fast::FastChain;
use fivecal::kinematics::{Kinematics, ToolPose};
use fivecal::model::{Context, Model};
use fivecal::nc::interp::Tcp;
use fivecal::{Axes, Dialect, Machine};
use nalgebra::Vector3;
use rand::RngExt;

use crate::util::{machine, rng};

/// Random location errors on every symbol of the machine (um, urad), plus
/// optional extra YAML.
pub fn errors(m: &str, seed: u64, size: f64, extra: &str) -> LoadedErrors {
    errors_on(&machine(m), seed, size, extra)
}

/// As [`errors`], on a machine given whole.
pub fn errors_on(machine: &Machine, seed: u64, size: f64, extra: &str) -> LoadedErrors {
    let m = &machine.name;
    let k = Kinematics::new(machine);
    let model = Model::new(k.clone(), vec![]);
    let mut r = rng(seed);
    let mut src = format!("machine: {m}\nlocation_errors:\n");
    for s in &model.symbols.location {
        let v: f64 = r.random_range(-1.0..1.0) * size;
        src.push_str(&format!("  {}: {v:.3}\n", s.name));
    }
    src.push_str(extra);
    ErrorFile::parse(Path::new("truth.yaml"), &src)
        .unwrap()
        .to_model(&k, Path::new("truth.yaml"), &src)
        .unwrap()
}

/// Tilt range of the generated programs per machine (inside the limits,
/// away from the singular tilt).
fn tilt_range(m: &Machine) -> (f64, f64) {
    match m.name.as_str() {
        "bc-trunnion" | "head-head" => (10.0, 40.0),
        _ => (-40.0, -10.0),
    }
}

/// A 5-axis finishing pass: the tip runs around a wavy ring on the table,
/// the tool tilted 10..40 deg and C turning; `tcp` writes tip coordinates
/// in W with rotary positions, otherwise the nominal axis values.
pub fn five_axis_program(m: &Machine, d: Dialect, tcp: bool, n: usize) -> String {
    ring_program(m, d, tcp, n, 30.0)
}

/// As [`five_axis_program`] with the ring radius given, mm.
pub fn ring_program(m: &Machine, d: Dialect, tcp: bool, n: usize, radius: f64) -> String {
    let k = Kinematics::new(m);
    let nominal = FastChain::nominal(&k);
    let (t0, t1) = tilt_range(m);
    let tl = m.tilt.letter;
    let mut lines: Vec<String> = Vec::new();
    let pose = |i: usize| {
        let s = i as f64 / n as f64;
        let ang = s * 1.6 * std::f64::consts::PI;
        let q = Vector3::new(
            radius * ang.cos(),
            radius * ang.sin(),
            6.0 + 3.0 * (3.0 * ang).sin(),
        );
        let t = t0 + (t1 - t0) * (0.5 + 0.5 * (2.0 * ang).sin());
        let c = 20.0 + 150.0 * s;
        let xyz = nominal.position(&q, t, c, &Vector3::zeros());
        if tcp { (q, t, c) } else { (xyz, t, c) }
    };
    let fmt = |v: f64, hh: bool| {
        if hh {
            format!("{v:+.4}")
        } else {
            format!("{v:.4}")
        }
    };
    let hh = d == Dialect::Heidenhain;
    match d {
        Dialect::Fanuc => {
            lines.push("%".into());
            lines.push("O5001 (GENERATED 5-AXIS RING)".into());
            lines.push("G90 G21 G17 G94 G54".into());
            lines.push(if tcp { "G43.4 H1" } else { "G43 H1" }.into());
        }
        Dialect::Linuxcnc => {
            lines.push("(generated 5-axis ring)".into());
            lines.push("G21 G90 G17 G94 G54 G43".into());
        }
        Dialect::Heidenhain => {
            lines.push("BEGIN PGM RING MM".into());
            if tcp {
                lines.push("M128".into());
            }
        }
        Dialect::Sinumerik => {
            lines.push("%_N_RING_MPF".into());
            lines.push("; generated 5-axis ring".into());
            lines.push("G17 G90 G710 G94 G54 D1".into());
            if tcp {
                lines.push("TRAORI".into());
            }
        }
    }
    for i in 0..=n {
        let (p, t, c) = pose(i);
        let words = format!(
            "X{} Y{} Z{} {tl}{} C{}",
            fmt(p.x, hh),
            fmt(p.y, hh),
            fmt(p.z, hh),
            fmt(t, hh),
            fmt(c, hh)
        );
        lines.push(match (d, i) {
            (Dialect::Heidenhain, 0) => format!("L {words} R0 FMAX"),
            (Dialect::Heidenhain, 1) => format!("L {words} F500"),
            (Dialect::Heidenhain, _) => format!("L {words}"),
            (_, 0) => format!("G0 {words}"),
            (_, 1) => format!("G1 {words} F500."),
            _ => words,
        });
    }
    match d {
        Dialect::Fanuc => {
            lines.push("G49".into());
            lines.push("M30".into());
            lines.push("%".into());
        }
        Dialect::Linuxcnc => lines.push("M2".into()),
        Dialect::Heidenhain => lines.push("END PGM RING MM".into()),
        Dialect::Sinumerik => {
            if tcp {
                lines.push("TRAFOOF".into());
            }
            lines.push("M30".into());
        }
    }
    if hh {
        lines = lines
            .into_iter()
            .enumerate()
            .map(|(i, l)| format!("{i} {l}"))
            .collect();
    }
    lines.join("\n") + "\n"
}

/// [`compensate`] at zero error on `l`'s machine, which must give the
/// program back byte for byte, then against `l`.
pub(crate) fn compensate_checked(
    l: &LoadedErrors,
    settings: Settings,
    program: &str,
) -> (String, Summary, Vec<Vertex>) {
    let zero = errors(&l.model.kin.machine().name, 0, 0.0, "");
    let (same, _, _) = compensate(&zero, settings.clone(), program);
    assert_eq!(same, program, "zero error must give the same bytes");
    compensate(l, settings, program)
}

/// The first lines of the moves `s` reports with a reason that contains
/// `what`, in the order of the reasons.
pub fn reported(s: &Summary, what: &str) -> Vec<usize> {
    s.skipped
        .iter()
        .filter(|(r, _)| r.contains(what))
        .flat_map(|(_, l)| l.first.clone())
        .collect()
}

pub fn compensate(
    l: &LoadedErrors,
    settings: Settings,
    program: &str,
) -> (String, Summary, Vec<Vertex>) {
    let c = Compensator::new(&l.model, &l.theta, settings);
    let mut out = Vec::new();
    let mut vs = Vec::new();
    let s = c
        .run_observed(
            Path::new("test.nc"),
            program.as_bytes(),
            &mut out,
            &mut |v| vs.push(*v),
        )
        .unwrap_or_else(|e| panic!("{e}"));
    (String::from_utf8(out).unwrap(), s, vs)
}

/// The actual pose of a written vertex, computed independently of the
/// rewriter: post-side through the model; under TCP through the generic
/// nominal inverse (the controller) and then the model.
fn actual_of(l: &LoadedErrors, v: &Vertex) -> ToolPose {
    let k = &l.model.kin;
    let axes = match v.tcp {
        Tcp::Off => v.written,
        _ => {
            let axis = k.forward_nominal(&v.written).axis;
            k.inverse_nominal(
                &ToolPose {
                    tip: v.written.xyz,
                    axis,
                },
                Some(&v.written),
            )
            .unwrap()
        }
    };
    l.model.pose(&l.theta, &Context::at(axes))
}

/// The written vertex `v`, driven through the erroneous machine, puts the
/// tip within 0.1 um of the intended one and, unless C was held next to
/// the singularity or the point is 3+2 in a tilted plane (the rotary
/// positions are the plane's), the tool axis within 0.1 urad.
pub fn assert_reaches(l: &LoadedErrors, v: &Vertex, what: &str) {
    let a = actual_of(l, v);
    assert!(
        (a.tip - v.target.tip).norm() < 1e-4,
        "{what} line {}: tip off by {:.3e} mm",
        v.line,
        (a.tip - v.target.tip).norm()
    );
    assert!(
        v.held_c || v.tilted_plane || angle(&a.axis, &v.target.axis) < 1e-7,
        "{what} line {}: axis off by {:.3e} rad",
        v.line,
        angle(&a.axis, &v.target.axis)
    );
}

fn angle(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.normalize().dot(&b.normalize()).clamp(-1.0, 1.0).acos()
}

pub fn simulate(
    model: &Model,
    theta: &[f64],
    d: Dialect,
    coords: Coordinates,
    program: &str,
    step: f64,
) -> Vec<Sample> {
    let mut s = SimSettings::new(d);
    s.coordinates = coords;
    simulate_with(model, theta, s, program, step)
}

/// As [`simulate`], with the simulator's settings given whole (origin,
/// stated rotary start positions).
pub fn simulate_with(
    model: &Model,
    theta: &[f64],
    mut s: SimSettings,
    program: &str,
    step: f64,
) -> Vec<Sample> {
    s.step = step;
    let sim = Simulator::new(model, theta, s);
    let mut out = Vec::new();
    sim.run(Path::new("p.nc"), program.as_bytes(), &mut |x| out.push(*x))
        .unwrap();
    out
}

fn seg_dist(p: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    let d = b - a;
    let t = if d.norm_squared() > 0.0 {
        ((p - a).dot(&d) / d.norm_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + d * t - p).norm()
}

/// Checks the rewrite of `program` independently: the original simulated on
/// the nominal machine gives the intended end points and path; the rewrite
/// simulated on the erroneous machine must reach every intended end point
/// (in order) within 0.1 um and 0.1 urad and never leave the intended path
/// by more than the tolerance.
pub(crate) fn check_against_simulation(
    l: &LoadedErrors,
    d: Dialect,
    coords: Coordinates,
    program: &str,
    rewritten: &str,
    tol: f64,
    what: &str,
) {
    check_held(l, d, coords, program, rewritten, tol, &[], what)
}

/// As [`check_against_simulation`]; at the `held` lines (C held next to the
/// singularity) only the tip is checked.
#[allow(clippy::too_many_arguments)]
pub(crate) fn check_held(
    l: &LoadedErrors,
    d: Dialect,
    coords: Coordinates,
    program: &str,
    rewritten: &str,
    tol: f64,
    held: &[usize],
    what: &str,
) {
    let mut s = SimSettings::new(d);
    s.coordinates = coords;
    check_simulated(l, &s, program, rewritten, tol, held, what)
}

/// As [`check_held`], with the simulator's settings given whole (the
/// program's origin, stated rotary start positions), the same for the
/// original on the nominal machine and the rewrite on the erroneous one.
pub(crate) fn check_simulated(
    l: &LoadedErrors,
    settings: &SimSettings,
    program: &str,
    rewritten: &str,
    tol: f64,
    held: &[usize],
    what: &str,
) {
    let nominal_model = Model::new(l.model.kin.clone(), vec![]);
    let intended = simulate_with(&nominal_model, &[], settings.clone(), program, 0.01);
    let actual = simulate_with(&l.model, &l.theta, settings.clone(), rewritten, 0.1);
    let ends: Vec<&Sample> = intended.iter().filter(|s| s.fraction == 1.0).collect();
    let mut j = 0;
    for e in &ends {
        let axis_tol = if held.contains(&e.line) { 1e-3 } else { 1e-7 };
        let found = actual[j..].iter().position(|a| {
            (a.actual.tip - e.nominal.tip).norm() < 1e-4
                && angle(&a.actual.axis, &e.nominal.axis) < axis_tol
        });
        let Some(k) = found else {
            let near = actual
                .iter()
                .map(|a| (a.actual.tip - e.nominal.tip).norm())
                .fold(f64::INFINITY, f64::min);
            panic!(
                "{what}: intended end point of line {} not reached (nearest {:.3e} mm)",
                e.line, near
            );
        };
        j += k + 1;
    }
    assert_on_path(&intended, &actual, tol, what);
}

/// Every sample of a feed move of `actual` (the rewrite on the erroneous
/// machine) lies within `tol` of the polyline of `intended` (the program
/// on the nominal machine, sampled finely).
pub(crate) fn assert_on_path(intended: &[Sample], actual: &[Sample], tol: f64, what: &str) {
    let mut worst: f64 = 0.0;
    let mut at: usize = 0;
    for a in actual.iter().filter(|s| s.feed) {
        let mut best = f64::INFINITY;
        let lo = at.saturating_sub(50);
        for i in lo..intended.len().saturating_sub(1) {
            let dist = seg_dist(
                &a.actual.tip,
                &intended[i].nominal.tip,
                &intended[i + 1].nominal.tip,
            );
            // Ties move on: a turn round a still tip is many samples at one
            // point, and the window must pass beyond them.
            if dist <= best {
                best = dist;
                at = i;
            }
            if i > at + 400 {
                break;
            }
        }
        worst = worst.max(best);
    }
    assert!(
        worst <= tol * 1.02 + 2e-5,
        "{what}: path leaves the intended one by {:.3} um",
        worst * 1e3
    );
}

#[test]
fn compensated_programs_reach_the_nominal_points_on_the_erroneous_machine() {
    let mut subdivided = 0;
    for (mi, name) in ["bc-trunnion", "ac-trunnion", "head-table", "head-head"]
        .iter()
        .enumerate()
    {
        let m = machine(name);
        let l = errors(name, 40 + mi as u64, 60.0, "");
        for d in Dialect::ALL {
            for tcp in [false, true] {
                let program = ring_program(&m, d, tcp, 16, 80.0);
                let coords = if tcp && d == Dialect::Linuxcnc {
                    Coordinates::Tcp
                } else {
                    Coordinates::Auto
                };
                let mut settings = Settings::new(d);
                settings.coordinates = coords;
                let (out, s, vs) = compensate(&l, settings.clone(), &program);
                let what = format!("{name} {d} tcp={tcp}");
                assert_eq!(s.skipped_count(), 0, "{what}: {:?}", s.skipped);
                assert!(s.changed > 15, "{what}: {s:?}");
                assert!(s.held_c.is_empty(), "{what}");
                for v in &vs {
                    assert_reaches(&l, v, &what);
                }
                subdivided += s.subdivided.len();
                check_against_simulation(&l, d, coords, &program, &out, settings.tolerance, &what);
            }
        }
    }
    assert!(
        subdivided > 0,
        "the programs should need subdivision somewhere"
    );
}

/// Every linear-axis error of the one model at once (issue 45): the
/// positioning maps and all nine angular error motions with scale,
/// squareness and straightness, on the four built-in machines, post-side
/// (under TCP the tool axis is still off by some 0.5 urad on bc-trunnion:
/// open, see issue 45): the written points put the tip within 0.1 um and the
/// tool axis within 0.1 urad of the intended pose on the erroneous machine,
/// the path stays within the tolerance, and at zero error the program
/// comes back byte for byte.
#[test]
fn every_linear_axis_error_together_is_compensated_on_every_machine() {
    let nodes = "[-600, -200, 200, 600]";
    let extra = format!(
        "effects:
  linear_scale: {{EYY: 15.0}}
  squareness: {{EC(0X)Y: 20.0, EB(0X)Z: -12.0, EA(0Y)Z: 8.0}}
  straightness: {{EYX: {{X: {nodes}, values: [0, 3, -2, 1]}}, EXZ: {{Z: {nodes}, values: [1, -2, 2, 0]}}}}
  positioning:
    EXX: {{X: {nodes}, values: [-4, 2, 6, 9]}}
    EYY: {{Y: {nodes}, values: [3, -1, 2, -5]}}
    EZZ: {{Z: {nodes}, values: [0, 4, -3, 2]}}
  angular:
    EAX: {{X: {nodes}, values: [10, -15, 5, 20]}}
    EBX: {{X: {nodes}, values: [-8, 12, 0, -6]}}
    ECX: {{X: {nodes}, values: [5, -9, 4, 11]}}
    EAY: {{Y: {nodes}, values: [-7, 8, 3, -2]}}
    EBY: {{Y: {nodes}, values: [15, -5, 25, 0]}}
    ECY: {{Y: {nodes}, values: [10, 0, -12, 6]}}
    EAZ: {{Z: {nodes}, values: [4, -6, 9, -3]}}
    EBZ: {{Z: {nodes}, values: [-8, 3, 7, 1]}}
    ECZ: {{Z: {nodes}, values: [30, -10, 5, 12]}}
"
    );
    for name in ["bc-trunnion", "ac-trunnion", "head-table", "head-head"] {
        let l = errors(name, 11, 20.0, &extra);
        let m = machine(name);
        {
            let tcp = false;
            let program = five_axis_program(&m, Dialect::Fanuc, tcp, 24);
            let settings = Settings::new(Dialect::Fanuc);
            let (out, s, vs) = compensate_checked(&l, settings.clone(), &program);
            let what = format!("{name} tcp={tcp}");
            assert_eq!(s.skipped_count(), 0, "{what}: {:?}", s.skipped);
            assert!(!s.fast_path, "{what}");
            for v in &vs {
                assert_reaches(&l, v, &what);
            }
            check_against_simulation(
                &l,
                Dialect::Fanuc,
                Coordinates::Auto,
                &program,
                &out,
                settings.tolerance,
                &what,
            );
        }
    }
}

#[test]
fn linear_axis_errors_and_a_tool_length_error_are_compensated_too() {
    let name = "bc-trunnion";
    let extra = "effects:\n  linear_scale: {EXX: 40.0, EZZ: -25.0}\n  squareness: {EC(0X)Y: 30.0}\n  tool_length: 15.0\n";
    let l = errors(name, 7, 30.0, extra);
    let m = machine(name);
    for tcp in [false, true] {
        let program = five_axis_program(&m, Dialect::Fanuc, tcp, 40);
        let (out, s, vs) = compensate(&l, Settings::new(Dialect::Fanuc), &program);
        assert!(
            !s.fast_path,
            "position-dependent linear errors leave the pure closed form"
        );
        for v in &vs {
            let a = actual_of(&l, v);
            assert!((a.tip - v.target.tip).norm() < 1e-4, "line {}", v.line);
            assert!(angle(&a.axis, &v.target.axis) < 1e-7, "line {}", v.line);
        }
        check_against_simulation(
            &l,
            Dialect::Fanuc,
            Coordinates::Auto,
            &program,
            &out,
            1e-3,
            "linear errors",
        );
    }
}

#[test]
fn a_looser_tolerance_needs_fewer_pieces_and_is_still_kept() {
    let m = machine("bc-trunnion");
    let l = errors("bc-trunnion", 11, 80.0, "");
    let program = ring_program(&m, Dialect::Linuxcnc, false, 6, 80.0);
    let mut counts = Vec::new();
    for tol_um in [0.5, 2.0, 20.0] {
        let mut s = Settings::new(Dialect::Linuxcnc);
        s.tolerance = tol_um * 1e-3;
        let (out, sum, _) = compensate(&l, s, &program);
        check_against_simulation(
            &l,
            Dialect::Linuxcnc,
            Coordinates::Auto,
            &program,
            &out,
            tol_um * 1e-3,
            &format!("tolerance {tol_um} um"),
        );
        counts.push(sum.inserted);
    }
    assert!(
        counts[0] > counts[1] && counts[1] >= counts[2],
        "{counts:?}"
    );
}

fn arc_program() -> String {
    "%\nO6001 (ARCS AT FIXED ROTARY POSITIONS)\nG90 G21 G17 G94 G54 G43 H1\nG0 X20. Y0. Z5. B30. C40.\nG1 Z1. F300.\nG3 X-20. Y0. I-20. J0\nG2 X0. Y-20. R20.\nG1 X0. Y-30. Z1.\nM30\n%\n".into()
}

#[test]
fn arcs_are_kept_where_exact_and_linearized_where_not() {
    // At fixed rotary positions an exact correction of a table-table
    // machine leaves only a turn about the tool axis (the G17 normal) and a
    // shift: the corrected arc is the same arc moved, so it stays an arc,
    // and the simulation below confirms its path.
    let src = "machine: bc-trunnion\nlocation_errors: {EX0B: 30.0, EZ0B: -20.0, EX(0B)C: 15.0, EY0C: -25.0, EA0B: 150.0, EC0B: -90.0, EA(0B)C: 60.0}\n";
    let k = Kinematics::new(&machine("bc-trunnion"));
    let l = ErrorFile::parse(Path::new("t.yaml"), src)
        .unwrap()
        .to_model(&k, Path::new("t.yaml"), src)
        .unwrap();
    let (out, s, _) = compensate(&l, Settings::new(Dialect::Fanuc), &arc_program());
    assert!(s.linearized.is_empty(), "{s:?}\n{out}");
    assert!(
        out.contains("G3 X") && out.contains("G2 X") && out.contains(" R20"),
        "{out}"
    );
    assert_ne!(out, arc_program());
    check_against_simulation(
        &l,
        Dialect::Fanuc,
        Coordinates::Auto,
        &arc_program(),
        &out,
        1e-3,
        "arcs at fixed rotary positions",
    );
    // An arc that also turns the rotary axes is not an arc on the erroneous
    // machine: it is linearized, every piece within the tolerance.
    let program = arc_program().replace("G3 X-20. Y0. I-20. J0", "G3 X-20. Y0. I-20. J0 B40. C60.");
    let (out, s, _) = compensate(&l, Settings::new(Dialect::Fanuc), &program);
    assert_eq!(s.linearized, vec![6], "{s:?}");
    assert!(!out.contains("G3") && !out.contains("I-20"), "{out}");
    assert!(
        out.contains("G2 X"),
        "the next arc runs at fixed rotary positions again: {out}"
    );
    check_against_simulation(
        &l,
        Dialect::Fanuc,
        Coordinates::Auto,
        &program,
        &out,
        1e-3,
        "5-axis arc",
    );
}

#[test]
fn an_arc_that_spirals_within_the_control_s_tolerance_stays_an_arc() {
    // Radius 20 at the start, 20.01 at the end: LinuxCNC and FANUC run it
    // as a spiral. The corrected arc spirals as much, so it stays an arc;
    // it was linearized, even at zero error, when its own spiral counted
    // against the tolerance.
    let program = arc_program().replace("G3 X-20. Y0. I-20. J0", "G3 X-20.01 Y0. I-20. J0");
    let k = Kinematics::new(&machine("bc-trunnion"));
    let load = |src: &str| {
        ErrorFile::parse(Path::new("t.yaml"), src)
            .unwrap()
            .to_model(&k, Path::new("t.yaml"), src)
            .unwrap()
    };
    let zero = load("machine: bc-trunnion\nlocation_errors: {EX0B: 0.0}\n");
    let (out, s, _) = compensate(&zero, Settings::new(Dialect::Fanuc), &program);
    assert_eq!(out, program, "{s:?}");
    let l = load(
        "machine: bc-trunnion\nlocation_errors: {EX0B: 30.0, EZ0B: -20.0, EX(0B)C: 15.0, EY0C: -25.0, EA0B: 150.0, EC0B: -90.0, EA(0B)C: 60.0}\n",
    );
    let (out, s, _) = compensate(&l, Settings::new(Dialect::Fanuc), &program);
    assert!(s.linearized.is_empty(), "{s:?}\n{out}");
    assert!(out.contains("G3 X") && out.contains(" I"), "{out}");
    assert_ne!(out, program);
    check_against_simulation(
        &l,
        Dialect::Fanuc,
        Coordinates::Auto,
        &program,
        &out,
        1e-3,
        "a spiral arc at fixed rotary positions",
    );
}

#[test]
fn heidenhain_circles_get_a_corrected_pole_and_renumbered_blocks() {
    let program = "0 BEGIN PGM ARC MM\n1 L X+20 Y+0 Z+5 B+0 C+0 R0 FMAX\n2 L Z+1 F300\n3 CC X+0 Y+0\n4 C X-20 Y+0 DR+\n5 CR X+0 Y-20 R+20 DR-\n6 L X+0 Y-30 Z+1 B-20 C+90\n7 END PGM ARC MM\n";
    let src = "machine: head-table\nlocation_errors: {EX0C: 30.0, EY0C: -20.0, EX0B: 15.0}\n";
    let k = Kinematics::new(&machine("head-table"));
    let l = ErrorFile::parse(Path::new("t.yaml"), src)
        .unwrap()
        .to_model(&k, Path::new("t.yaml"), src)
        .unwrap();
    let (out, s, _) = compensate(&l, Settings::new(Dialect::Heidenhain), program);
    assert!(s.linearized.is_empty(), "{s:?}\n{out}");
    // The pole moves with the table error: a CC block is inserted before
    // the circle and every block after it is renumbered.
    let lines: Vec<&str> = out.lines().collect();
    assert!(lines[4].starts_with("4 CC X"), "{out}");
    assert!(lines[5].starts_with("5 C X"), "{out}");
    assert!(lines.last().unwrap().starts_with("8 END PGM"), "{out}");
    for (i, line) in lines.iter().enumerate() {
        assert!(line.starts_with(&format!("{i} ")), "block {i}: {line}");
    }
    check_against_simulation(
        &l,
        Dialect::Heidenhain,
        Coordinates::Auto,
        program,
        &out,
        1e-3,
        "heidenhain circles",
    );
}

#[test]
fn inverse_time_feeds_keep_each_block_s_time_when_it_is_subdivided() {
    let program = "G21 G90 G17 G54 G43\nG0 X80 Y0 Z40 B10 C0\nG93 G1 X40 Y60 Z20 B80 C180 F6\nG1 X-60 Y-40 Z10 B20 C300 F4\nG94 G1 Z40 F1000\nM2\n";
    let l = errors("bc-trunnion", 3, 60.0, "");
    let (out, s, _) = compensate(&l, Settings::new(Dialect::Linuxcnc), program);
    assert_eq!(s.subdivided.len(), 2, "{s:?}\n{out}");
    // Group the output by source block: inserted pieces follow their block.
    let mut groups: Vec<Vec<f64>> = Vec::new();
    for line in out.lines() {
        let f = line
            .split_whitespace()
            .find_map(|w| w.strip_prefix('F'))
            .map(|v| v.parse::<f64>().unwrap());
        if line.contains("G93") || line.starts_with("G1 X-") {
            groups.push(Vec::new());
        }
        if line.contains("G94") {
            break;
        }
        if let (Some(g), Some(f)) = (groups.last_mut(), f) {
            g.push(f);
        }
    }
    assert_eq!(groups.len(), 2, "{out}");
    for (g, f0) in groups.iter().zip([6.0, 4.0]) {
        assert!(g.len() > 1, "{out}");
        let time: f64 = g.iter().map(|f| 1.0 / f).sum();
        assert!(
            (time - 1.0 / f0).abs() < 1e-3 * time,
            "pieces {g:?} take {time} min, the block {}",
            1.0 / f0
        );
    }
}

#[test]
fn expression_and_variable_blocks_are_left_untouched_and_reported() {
    let program = "%\nO7001\nG90 G21 G54 G43 H1\nG0 X10. Y10. Z30. B10. C20.\nG1 X[#1+2.] Y10. F300.\nG1 X12. Y#2 Z20.\n#3=5.\nG1 X12. Y12. Z20. B10. C20.\nM30\n%\n";
    let l = errors("bc-trunnion", 5, 40.0, "");
    let (out, s, _) = compensate(&l, Settings::new(Dialect::Fanuc), program);
    let (a, b): (Vec<&str>, Vec<&str>) = (program.lines().collect(), out.lines().collect());
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        if x.contains('#') {
            assert_eq!(x, y, "expression block rewritten");
        }
    }
    let expr = reported(&s, "expressions or variables");
    assert_eq!(expr, vec![5, 6], "{s:?}");
    // The next block names every axis again and is compensated.
    assert_ne!(a[7], b[7]);
    assert!(s.skipped_count() == 2, "{s:?}");
}

/// The summary counts the blocks that move an axis: a block that goes
/// where the tool already is moves nothing, a full circle moves though it
/// ends where it starts, and a move left as written (an expression, a move
/// in machine coordinates) is a motion block not corrected, under its
/// reason.
#[test]
fn motion_blocks_are_the_blocks_that_move_an_axis() {
    let program = "G90 G21 G54 G43 H1\nG0 X10. Y10. Z30. B20. C20.\nG0 X10. Y10. Z30.\nG1 X[#1+2.] F300.\nG53 G0 Z0.\nG0 X12. Y10. Z20.\nG2 X12. Y10. I2. J0.\nM30\n";
    let l = errors("bc-trunnion", 6, 20.0, "");
    let (_, s, _) = compensate(&l, Settings::new(Dialect::Fanuc), program);
    assert_eq!(s.moves, 5, "{s:?}");
    assert_eq!((s.motion_blocks, s.corrected_blocks), (5, 3), "{s:?}");
    let left: Vec<(&str, Vec<usize>)> = s
        .uncorrected_blocks
        .iter()
        .map(|(r, l)| (r.as_str(), l.first.clone()))
        .collect();
    assert_eq!(
        left,
        vec![
            ("coordinates are expressions or variables", vec![4]),
            (fivecal::compensate::LEFT_ON_PURPOSE, vec![5]),
        ]
    );
}

#[test]
fn next_to_the_tilt_singularity_c_is_held_and_the_tip_is_still_exact() {
    // Orientation errors make the tool axis along C reachable only with C
    // swung far from its nominal value (or not at all).
    let src = "machine: bc-trunnion\nlocation_errors: {EA0B: 80.0, EC0B: -60.0, EB0B: 50.0, EA(0B)C: 90.0, EX0B: 30.0, EY0C: -20.0}\n";
    let k = Kinematics::new(&machine("bc-trunnion"));
    let l = ErrorFile::parse(Path::new("t.yaml"), src)
        .unwrap()
        .to_model(&k, Path::new("t.yaml"), src)
        .unwrap();
    // Lines 2-4: tool along C, a direction these errors cannot reach at
    // all (held, whatever the swing). Lines 5-6: reachable, but only with
    // C turned by degrees (held by the swing limit). Line 7: tilted, exact.
    let program = "G21 G90 G17 G54 G43\nG0 X0 Y0 Z30 B0 C0\nG1 Z2 F300\nG1 X10 C40\nG1 X20 Y5 B0.05 C80\nG1 X25 Y10 B0.08 C120\nG1 X30 Y10 B30 C130\nM2\n";
    let (out, s, vs) = compensate(&l, Settings::new(Dialect::Linuxcnc), program);
    assert!(!s.held_c.is_empty(), "{s:?}");
    assert!(
        !s.held_c.contains(&7),
        "a tilted tool is corrected exactly: {s:?}"
    );
    let nominal = Kinematics::new(&machine("bc-trunnion"));
    for v in &vs {
        let a = actual_of(&l, v);
        assert!(
            (a.tip - v.target.tip).norm() < 1e-4,
            "line {}: the tip must be exact",
            v.line
        );
        if v.held_c {
            assert!(
                (v.written.c - v.nominal.c).abs() < 1e-9,
                "line {}: C must not move",
                v.line
            );
            // Holding C never leaves the axis worse than not compensating.
            let uncompensated = l.model.pose(&l.theta, &Context::at(v.nominal)).axis;
            let target = nominal.forward_nominal(&v.nominal).axis;
            assert!(
                angle(&a.axis, &v.target.axis) <= angle(&uncompensated, &target) + 1e-9,
                "line {}: held-C axis error {:.1} urad exceeds the uncompensated {:.1} urad",
                v.line,
                angle(&a.axis, &v.target.axis) * 1e6,
                angle(&uncompensated, &target) * 1e6
            );
        } else {
            assert!(angle(&a.axis, &v.target.axis) < 1e-7, "line {}", v.line);
        }
    }
    assert!(
        s.held_c_axis_error > 0.0 && s.held_c_axis_error < 300.0,
        "{s:?}"
    );
    // With an unlimited swing the exact solution is taken where it exists:
    // C turns a long way for micro-radians.
    let mut free = Settings::new(Dialect::Linuxcnc);
    free.max_c_swing = 360.0;
    free.max_correction = 1e7;
    let (_, s2, vs2) = compensate(&l, free, program);
    assert_eq!(s.held_c, vec![2, 3, 4, 5, 6], "{out}");
    // Out of reach stays held; line 5 ramps C from its held start to its
    // exact end, so its pieces count as held.
    assert_eq!(s2.held_c, vec![2, 3, 4, 5]);
    assert!(
        vs2.iter().any(|v| (v.written.c - v.nominal.c).abs() > 1.0),
        "{out}"
    );
}

#[test]
fn zero_errors_leave_generated_programs_untouched() {
    let m = machine("head-table");
    let model = Model::new(Kinematics::new(&m), vec![]);
    let l = LoadedErrors {
        model,
        theta: vec![],
        u: vec![],
        noise: Default::default(),
        not_identifiable: vec![],
        fit: None,
    };
    for d in Dialect::ALL {
        for tcp in [false, true] {
            let p = five_axis_program(&m, d, tcp, 30);
            let (out, s, _) = compensate(&l, Settings::new(d), &p);
            assert_eq!(out, p);
            assert_eq!(s.changed, 0);
        }
    }
}

/// A program produced on the fly, never held in memory.
struct Generated {
    blocks: usize,
    next: usize,
    buf: Vec<u8>,
    pos: usize,
    produced: Rc<Cell<usize>>,
}

impl Read for Generated {
    fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
        if self.pos == self.buf.len() {
            if self.next >= self.blocks {
                return Ok(0);
            }
            let i = self.next as f64;
            self.buf = format!(
                "X{:.4} Y{:.4} Z{:.4} B{:.4} C{:.4}\n",
                20.0 * (i * 0.01).cos(),
                20.0 * (i * 0.01).sin(),
                5.0 + (i * 0.003).sin(),
                20.0 + 10.0 * (i * 0.002).sin(),
                (i * 0.05) % 360.0
            )
            .into_bytes();
            if self.next == 0 {
                self.buf = b"G21 G90 G94 G54 G43\nG1 X20 Y0 Z5 B20 C0 F1000\n".to_vec();
            }
            self.next += 1;
            self.pos = 0;
        }
        let n = out.len().min(self.buf.len() - self.pos);
        out[..n].copy_from_slice(&self.buf[self.pos..self.pos + n]);
        self.pos += n;
        self.produced.set(self.produced.get() + n);
        Ok(n)
    }
}

struct Lag {
    produced: Rc<Cell<usize>>,
    written: usize,
    max_lag: usize,
}

impl Write for Lag {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.written += b.len();
        self.max_lag = self
            .max_lag
            .max(self.produced.get().saturating_sub(self.written));
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[test]
fn the_rewrite_streams_output_keeps_up_with_input() {
    let l = errors("bc-trunnion", 9, 30.0, "");
    let produced = Rc::new(Cell::new(0));
    let input = BufReader::new(Generated {
        blocks: 200_000,
        next: 0,
        buf: Vec::new(),
        pos: 0,
        produced: produced.clone(),
    });
    let mut sink = Lag {
        produced: produced.clone(),
        written: 0,
        max_lag: 0,
    };
    let mut s = Settings::new(Dialect::Linuxcnc);
    s.tolerance = 0.01;
    let c = Compensator::new(&l.model, &l.theta, s);
    let sum = c.run(Path::new("gen.ngc"), input, &mut sink).unwrap();
    assert!(sum.blocks > 200_000);
    assert!(produced.get() > 8_000_000, "{}", produced.get());
    // Never more than the chunks in flight between the reading and the
    // rewriting thread behind (a few thousand blocks of some 40 bytes
    // each, against the 8 MB read): memory does not grow with the program.
    assert!(
        sink.max_lag < 1024 * 1024,
        "output lagged input by {} bytes",
        sink.max_lag
    );
}

#[test]
fn heidenhain_tcpm_program_is_compensated_with_renumbering() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/nc/heidenhain/tcpm.h");
    let program = std::fs::read_to_string(&path).unwrap();
    let l = errors("head-table", 21, 40.0, "");
    let (out, s, vs) = compensate(&l, Settings::new(Dialect::Heidenhain), &program);
    assert!(s.changed > 5, "{s:?}");
    for v in &vs {
        let a = actual_of(&l, v);
        assert!((a.tip - v.target.tip).norm() < 1e-4, "line {}", v.line);
    }
    for (i, line) in out.lines().enumerate() {
        assert!(line.starts_with(&format!("{i} ")), "{out}");
    }
    check_held(
        &l,
        Dialect::Heidenhain,
        Coordinates::Auto,
        &program,
        &out,
        1e-3,
        &s.held_c.first,
        "tcpm.h",
    );
    let _ = Axes::default();
}

/// The bound that lets short blocks skip the path check must never be
/// below the true deviation: random moves of every size on every machine.
#[test]
fn the_deviation_bound_is_an_upper_bound() {
    use fivecal::compensate::Solver;
    let mut tight = 0;
    for (mi, name) in ["bc-trunnion", "ac-trunnion", "head-table", "head-head"]
        .iter()
        .enumerate()
    {
        let m = machine(name);
        let mut r = rng(500 + mi as u64);
        for case in 0..400 {
            let l = errors(name, 600 + case, 80.0, "");
            let solver = Solver::new(&l.model, &l.theta, 360.0);
            assert!(solver.is_fast());
            let n0 = crate::util::random_axes(&m, &mut r);
            let (t0, t1) = tilt_range(&m);
            let n0 = Axes {
                tilt: r.random_range(t0..t1),
                ..n0
            };
            let scale: f64 = [0.01, 0.1, 1.0, 10.0][case as usize % 4];
            let n1 = Axes {
                xyz: n0.xyz
                    + Vector3::new(
                        r.random_range(-1.0..1.0),
                        r.random_range(-1.0..1.0),
                        r.random_range(-1.0..1.0),
                    ) * scale
                        * 5.0,
                tilt: (n0.tilt + r.random_range(-1.0..1.0) * scale).clamp(t0, t1),
                c: n0.c + r.random_range(-1.0..1.0) * scale * 3.0,
            };
            let solve = |n: &Axes| solver.solve(&solver.nominal_pose(n), n).unwrap().axes;
            let (w0, w1) = (solve(&n0), solve(&n1));
            let lerp = |a: &Axes, b: &Axes, s: f64| Axes {
                xyz: a.xyz + (b.xyz - a.xyz) * s,
                tilt: a.tilt + (b.tilt - a.tilt) * s,
                c: a.c + (b.c - a.c) * s,
            };
            let mut worst: f64 = 0.0;
            for k in 0..=16 {
                let s = k as f64 / 16.0;
                let d = (solver.actual_pose(&lerp(&w0, &w1, s)).tip
                    - solver.nominal_pose(&lerp(&n0, &n1, s)).tip)
                    .norm();
                worst = worst.max(d);
            }
            let bound = solver.deviation_bound(&n0, &n1, &w0, &w1, 1e-9);
            assert!(
                worst <= bound,
                "{name} case {case}: deviation {worst:.3e} mm above the bound {bound:.3e} mm"
            );
            if scale <= 0.1 && bound < 1e-4 {
                tight += 1;
            }
        }
    }
    // And it is useful: short blocks are settled by it.
    assert!(tight > 600, "{tight}");
}

/// Error maps go through the model's own (Newton) inverse, constant errors
/// through the closed form: the same errors given either way must give the
/// same program.
#[test]
fn the_exact_path_for_error_maps_agrees_with_the_closed_form() {
    let k = Kinematics::new(&machine("head-table"));
    let load = |src: &str| {
        ErrorFile::parse(Path::new("t.yaml"), src)
            .unwrap()
            .to_model(&k, Path::new("t.yaml"), src)
            .unwrap()
    };
    let constant = load(
        "machine: head-table\nlocation_errors: {EX0C: 28.0, EY0C: -35.0, EA0C: 45.0, EA0B: 60.0, EX0B: 22.0}\n",
    );
    let as_maps = load(
        "machine: head-table\nlocation_errors: {EA0B: 60.0, EX0B: 22.0}\nposition_dependent:\n  EXC(C): {C: [0, 120, 240], values: [28.0, 28.0, 28.0]}\n  EYC(C): {C: [0, 120, 240], values: [-35.0, -35.0, -35.0]}\n  EAC(C): {C: [0, 120, 240], values: [45.0, 45.0, 45.0]}\n",
    );
    let program = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/nc/heidenhain/tcpm.h"),
    )
    .unwrap();
    let (a, sa, _) = compensate(&constant, Settings::new(Dialect::Heidenhain), &program);
    let (b, sb, _) = compensate(&as_maps, Settings::new(Dialect::Heidenhain), &program);
    assert!(sa.fast_path && !sb.fast_path);
    assert_eq!(a, b);
}

/// FANUC reads `X10` as 10 mm or 10 um by a parameter: such moves are left
/// alone unless the unit is given, and rewritten values always carry a
/// decimal point (unambiguous in both modes).
#[test]
fn fanuc_integer_words_need_their_unit() {
    let program = "%\nO8001\nG90 G21 G54 G43 H1\nG0 X10 Y20 Z30 B20 C40\nG1 X12 F300\nM30\n%\n";
    let l = errors("bc-trunnion", 13, 40.0, "");
    let (out, s, _) = compensate(&l, Settings::new(Dialect::Fanuc), program);
    assert_eq!(out, program);
    assert!(
        s.skipped
            .iter()
            .any(|(r, lines)| r.contains("decimal point") && lines.len() == 2),
        "{s:?}"
    );
    let mut mm = Settings::new(Dialect::Fanuc);
    mm.fanuc_integer_unit = Some(1.0);
    let (out, s, vs) = compensate(&l, mm, program);
    assert_eq!(s.skipped_count(), 0, "{s:?}");
    let line = out.lines().nth(3).unwrap();
    for w in line.split_whitespace().skip(1) {
        assert!(w.contains('.'), "{line}");
    }
    for v in &vs {
        let a = actual_of(&l, v);
        assert!((a.tip - v.target.tip).norm() < 1e-4);
    }
    // In least input increments (um), X10 is 0.01 mm.
    let mut um = Settings::new(Dialect::Fanuc);
    um.fanuc_integer_unit = Some(0.001);
    let (_, _, vs) = compensate(&l, um, program);
    assert!(
        (vs[0].nominal_program[0] - 0.010).abs() < 1e-12,
        "{:?}",
        vs[0].nominal_program
    );
}

/// A face machined with the tilt at its limit (B = 90 on the trunnion):
/// the correction needs B a few urad beyond, so B is held at the limit,
/// C and X, Y, Z are corrected and the tip is exact.
#[test]
fn at_the_tilt_limit_the_tilt_is_held_and_the_tip_is_still_exact() {
    let src = "machine: bc-trunnion\nlocation_errors: {EX0B: 30.0, EZ0B: -20.0, EA0B: 40.0, EC0B: -25.0, EB0B: 15.0, EX(0B)C: 12.0, EY0C: -18.0, EA(0B)C: 35.0}\n";
    let k = Kinematics::new(&machine("bc-trunnion"));
    let l = ErrorFile::parse(Path::new("t.yaml"), src)
        .unwrap()
        .to_model(&k, Path::new("t.yaml"), src)
        .unwrap();
    let program =
        "G21 G90 G17 G54 G43\nG0 X100 Y0 Z20 B90 C0\nG1 X100 Y10 Z20 F300\nG1 X100 Y20 Z25\nM2\n";
    let (_, s, vs) = compensate(&l, Settings::new(Dialect::Linuxcnc), program);
    assert_eq!(s.skipped_count(), 0, "{s:?}");
    assert_eq!(s.held_tilt, vec![2, 3, 4], "{s:?}");
    for v in &vs {
        assert_eq!(v.written.tilt, 90.0, "line {}", v.line);
        let a = actual_of(&l, v);
        assert!((a.tip - v.target.tip).norm() < 1e-4, "line {}", v.line);
        assert!(
            angle(&a.axis, &v.target.axis) < 0.1f64.to_radians(),
            "line {}",
            v.line
        );
    }
    assert!(
        s.held_tilt_axis_error > 0.0 && s.held_tilt_axis_error < 100.0,
        "{s:?}"
    );
}

/// LinuxCNC's 5-axis configurations switch tool-centre-point control with
/// remapped M codes (M428/M429 in its demos), which `--coordinates auto`
/// read as axis positions without a word (issue 16): the machine file
/// names them, the moves between are compensated as TCP moves exactly as
/// `--coordinates tcp` would, and the run says which code set the mode.
/// Without the machine file's word, M428 is named with the remedy.
#[test]
fn tcp_switched_by_a_machine_file_m_code_is_compensated_as_tcp() {
    let base = machine("head-head");
    let src = format!(
        "{}m_codes:\n  tcp_on: [M428]\n  tcp_off: [M429]\n",
        base.source
    );
    let m = Machine::from_yaml(Path::new("m.yaml"), &src).unwrap();
    let l = errors_on(&m, 7, 40.0, "");
    let ring = ring_program(&m, Dialect::Linuxcnc, true, 40, 30.0);
    let program = ring
        .replacen("G43\n", "G43\nM428\n", 1)
        .replacen("\nM2\n", "\nM429\nM2\n", 1);
    assert_ne!(program, ring);
    let (out, s, vs) = compensate(&l, Settings::new(Dialect::Linuxcnc), &program);
    assert!(!vs.is_empty() && vs.iter().all(|v| v.tcp == Tcp::Axes));
    let mut flag = Settings::new(Dialect::Linuxcnc);
    flag.coordinates = Coordinates::Tcp;
    let (flagged, _, _) = compensate(&l, flag, &ring);
    assert_eq!(
        out.replacen("M428\n", "", 1).replacen("M429\n", "", 1),
        flagged
    );
    check_held(
        &l,
        Dialect::Linuxcnc,
        Coordinates::Auto,
        &program,
        &out,
        1e-3,
        &s.held_c.first,
        "M428 ring",
    );
    assert_eq!(s.coordinates.len(), 1, "{:?}", s.coordinates);
    assert!(
        s.coordinates[0].why.contains("`M428` at line 3")
            && s.coordinates[0].why.contains("machine file"),
        "{:?}",
        s.coordinates
    );
    assert!(s.unmodelled.is_empty(), "{:?}", s.unmodelled);

    let plain = errors("head-head", 7, 40.0, "");
    let (_, s, vs) = compensate(&plain, Settings::new(Dialect::Linuxcnc), &program);
    assert!(vs.iter().all(|v| v.tcp == Tcp::Off));
    let m428 = s
        .unmodelled
        .iter()
        .find(|(w, _)| w.starts_with("M428"))
        .unwrap_or_else(|| panic!("{:?}", s.unmodelled));
    assert!(
        m428.0.contains("tcp_on") && m428.1.first == vec![3],
        "{m428:?}"
    );
    assert!(
        s.coordinates[0].meaning.starts_with("axis positions")
            && s.coordinates[0].why.contains("no TCP code"),
        "{:?}",
        s.coordinates
    );
}

/// A SINUMERIK program with what real 840D programs carry (DEF variables,
/// `Z=_Z_HOME`, `X=AC()`/`Y=IC()`, R parameters, a label and GOTOF, TRANS,
/// CR= arcs, a comment glued to code, TRAORI with `A3= B3= C3=` vectors,
/// CYCLE800, CRLF): at zero error it comes back byte for byte; with errors
/// every move it can place is corrected, and each corrected pose, driven
/// through the erroneous machine (independently of the rewriter), is the
/// intended one; the two it cannot place are left as written with the
/// reason.
#[test]
fn a_sinumerik_program_with_frames_traori_and_cycle800_is_corrected_where_it_can_be() {
    let path = crate::nc::fixture("quirks/sinumerik_frames.mpf");
    let program = std::fs::read_to_string(&path).unwrap();
    let zero = errors("bc-trunnion", 0, 0.0, "");
    let (out, _, _) = compensate(&zero, Settings::new(Dialect::Sinumerik), &program);
    assert_eq!(out, program);
    let l = errors("bc-trunnion", 61, 30.0, "");
    let (out, s, vs) = compensate(&l, Settings::new(Dialect::Sinumerik), &program);
    let changed: Vec<usize> = out
        .split_inclusive('\n')
        .zip(program.split_inclusive('\n'))
        .enumerate()
        .filter(|(_, (a, b))| a != b)
        .map(|(i, _)| i + 1)
        .collect();
    // N70, N80, N90 (Y=IC), N100 (the CR= arc), and the two TRAORI moves.
    assert_eq!(changed, [16, 17, 18, 19, 24, 25], "{out}");
    let left: Vec<(String, Vec<usize>)> = s
        .skipped
        .iter()
        .map(|(why, lines)| {
            (
                why.text.clone(),
                lines
                    .list()
                    .split(", ")
                    .map(|x| x.parse().unwrap())
                    .collect(),
            )
        })
        .collect();
    assert_eq!(left.len(), 2, "{left:?}");
    assert!(
        left[0].0.contains("expressions") && left[0].1 == [21],
        "{left:?}"
    );
    assert!(
        left[1].0.contains("CYCLE800") && left[1].1 == [28],
        "{left:?}"
    );
    assert!(vs.len() >= 6, "{}", vs.len());
    // At B0 the tool axis lies along C (the singularity): C is held and
    // only the tip is exact there.
    for v in &vs {
        assert_reaches(&l, v, "sinumerik_frames.mpf");
    }
    assert!(vs.iter().any(|v| !v.held_c), "no exact orientation checked");
    // The arc stays an arc (CR= kept or rewritten, never dropped).
    assert!(out.lines().nth(18).unwrap().contains("CR="), "{out}");
}

/// The pipelined rewrite hands the controller's state from one chunk of
/// blocks to the next: with a chunk boundary between every two blocks (and
/// every other spacing up to seven), a program that switches units, G90 and
/// G91, TCP, work offsets and macro variables between its moves is written
/// byte for byte as one thread writes it.
#[test]
fn modal_state_crosses_every_chunk_boundary() {
    let l = errors("bc-trunnion", 17, 30.0, "");
    let mut p = vec![
        "%".to_string(),
        "O2001 (MODAL STATE ACROSS CHUNKS)".into(),
        "G90 G21 G17 G94 G54 G43 H1".into(),
        "G0 X0. Y0. Z100. B0. C0.".into(),
        "G1 F1500.".into(),
    ];
    for k in 0..6 {
        let b = 10.0 + 5.0 * k as f64;
        let c = 20.0 * k as f64 - 40.0;
        p.push(format!(
            "X{:.3} Y-12.5 Z40. B{b:.3} C{c:.3}",
            30.0 + k as f64
        ));
        p.push("G91".into());
        p.push("X1.5 Y2. C3.".into());
        p.push("G90".into());
        p.push("G20".into());
        p.push(format!(
            "X{:.4} Y0.5 Z1.6 B{b:.3} C{:.3}",
            1.2 + 0.01 * k as f64,
            c + 5.0
        ));
        p.push("G21".into());
        p.push(if k % 2 == 0 { "G55" } else { "G54" }.into());
        p.push(format!(
            "X25. Y{:.3} Z35. B{:.3} C{c:.3}",
            -5.0 + k as f64,
            b + 2.0
        ));
        p.push("G43.4 H1".into());
        p.push(format!("X10. Y-4. Z20. B{b:.3} C{c:.3}"));
        p.push("G49".into());
        p.push("G43 H1".into());
    }
    p.push("M30".into());
    p.push("%".into());
    let plain = p.join("\n") + "\n";
    // The same moves after macro variables set in one chunk and used in
    // another.
    let mut m = p.clone();
    m.insert(5, "#101 = 12.5".into());
    m.insert(6, "#102 = [#101 * 2]".into());
    let end = m.len() - 2;
    m.insert(end, "G1 X#102 Y#101 Z40. B20. C-10.".into());
    let macros = m.join("\n") + "\n";
    let c = Compensator::new(&l.model, &l.theta, Settings::new(Dialect::Fanuc));
    for program in [&plain, &macros] {
        let run = |chunk: Option<usize>| {
            let mut out = Vec::new();
            let s = c
                .run_chunked(Path::new("modal.nc"), program.as_bytes(), &mut out, chunk)
                .unwrap();
            (String::from_utf8(out).unwrap(), s)
        };
        let (one, s1) = run(None);
        assert!(s1.changed > 30, "{s1:?}");
        assert_ne!(&one, program);
        assert!(s1.coordinates.len() >= 12, "{:?}", s1.coordinates);
        for chunk in 1..=7 {
            let (out, s) = run(Some(chunk));
            assert_eq!(out, one, "chunks of {chunk}");
            assert_eq!(s, s1, "chunks of {chunk}");
        }
    }
}

/// An error stops the pipelined rewrite at its block, whichever chunk it is
/// in, with the file, line and column named, as in one thread.
#[test]
fn an_error_in_a_later_chunk_is_named_as_in_one_thread() {
    let l = errors("bc-trunnion", 17, 30.0, "");
    let mut s = Settings::new(Dialect::Fanuc);
    s.strict = true;
    let c = Compensator::new(&l.model, &l.theta, s);
    let mut p = vec![
        "G90 G21 G54 G43 H1".to_string(),
        "G0 X0. Y0. Z100. B0. C0.".into(),
    ];
    for k in 0..20 {
        p.push(format!("G1 X{k}. Y1. Z40. B10. C5. F1000."));
    }
    p.push("G1 X1. Y$ Z3.".into());
    p.push("G1 X2. Y1. Z40.".into());
    let program = p.join("\n") + "\n";
    let run = |chunk| {
        let mut out = Vec::new();
        c.run_chunked(Path::new("bad.nc"), program.as_bytes(), &mut out, chunk)
            .unwrap_err()
            .to_string()
    };
    let one = run(None);
    assert!(one.starts_with("bad.nc:23:"), "{one}");
    for chunk in [1, 3, 8, 2048] {
        assert_eq!(run(Some(chunk)), one);
    }
}

/// FANUC tool centre point control type 2 (G43.5): each block gives the
/// tool tip (X Y Z) and the tool direction (I J K) in the workpiece, and
/// the control picks the rotary positions for the direction (the solution
/// nearest the ones before). Corrected, the I J K words carry the
/// direction the nominal control turns into the corrected rotary
/// positions: on the machine with the errors the tip and the tool axis
/// land on the intended ones at every end point, and the path between
/// stays within the tolerance.
#[test]
fn fanuc_g43_5_tool_vectors_are_corrected_tip_and_axis() {
    let d = Dialect::Fanuc;
    let l = errors("bc-trunnion", 41, 30.0, "");
    let k = &l.model.kin;
    // Tips and the rotary positions whose tool direction each block
    // writes, far from the tilt where the two solutions meet.
    let blocks = [
        ([0.0, 0.0, 50.0], 20.0, 30.0),
        ([10.0, 5.0, 10.0], 25.0, 40.0),
        ([20.0, 5.0, 8.0], 22.0, 60.0),
        ([20.0, 15.0, 6.0], 18.0, 75.0),
    ];
    let vector = |b: f64, c: f64| {
        k.forward_nominal(&Axes::new(0.0, 0.0, 0.0, b, c))
            .axis
            .normalize()
    };
    let mut program = String::from(
        "%\nO4001 (TOOL VECTORS)\nG90 G21 G17 G40 G49 G80 G94\nG0 X0. Y0. Z100. B20. C30.\nG43.5 H1\n",
    );
    for (i, (p, b, c)) in blocks.iter().enumerate() {
        let v = vector(*b, *c);
        let motion = if i == 0 {
            "G0 "
        } else if i == 1 {
            "G1 "
        } else {
            ""
        };
        let feed = if i == 1 { " F500." } else { "" };
        program.push_str(&format!(
            "{motion}X{:.1} Y{:.1} Z{:.1} I{:.7} J{:.7} K{:.7}{feed}\n",
            p[0], p[1], p[2], v.x, v.y, v.z
        ));
    }
    program.push_str("G49\nM30\n%\n");
    let program = program.as_str();
    let zero = errors("bc-trunnion", 0, 0.0, "");
    let (same, s0, _) = compensate(&zero, Settings::new(d), program);
    assert_eq!(same, program, "zero error must give the same bytes");
    assert!(s0.skipped.is_empty(), "{:?}", s0.skipped);
    // What the blocks mean: the tip is the point written, the tool axis
    // the vector written, on the nominal machine.
    let nominal = Model::new(k.clone(), vec![]);
    let ends: Vec<Sample> = simulate(&nominal, &[], d, Coordinates::Auto, program, 0.0)
        .into_iter()
        .filter(|s| s.fraction == 1.0 && (6..=9).contains(&s.line))
        .collect();
    assert_eq!(ends.len(), blocks.len());
    for (e, (p, b, c)) in ends.iter().zip(blocks) {
        assert!((e.nominal.tip - Vector3::from(p)).norm() < 1e-9, "{e:?}");
        // To the 7 decimals written.
        assert!(
            (e.nominal.axis.normalize() - vector(b, c)).norm() < 1e-6,
            "{e:?}"
        );
    }
    // As written, the errors move the tip and the axis by far more than
    // the 0.1 um and 0.1 urad the rewrite is held to.
    let as_written = simulate(&l.model, &l.theta, d, Coordinates::Auto, program, 0.0);
    assert!(
        as_written
            .iter()
            .filter(|s| s.fraction == 1.0 && s.line >= 6)
            .all(|s| s.axis_error() > 1e-5 && s.error().norm() > 0.005),
        "the errors barely move the tool"
    );
    let (out, s, vs) = compensate(&l, Settings::new(d), program);
    assert!(s.skipped.is_empty(), "{:?}", s.skipped);
    assert!(vs.iter().filter(|v| v.tcp == Tcp::Vector).count() >= 4);
    for v in &vs {
        assert_reaches(&l, v, "G43.5");
    }
    // Each vector block's I J K is rewritten, no rotary position added.
    for (a, b) in program.lines().zip(out.lines()).skip(5).take(4) {
        assert_ne!(a, b);
        assert!(
            b.contains(" I") && b.contains(" J") && b.contains(" K"),
            "{b}"
        );
        assert!(!b.contains('B') && !b.contains('C'), "{b}");
    }
    check_against_simulation(&l, d, Coordinates::Auto, program, &out, 0.001, "G43.5");
}

/// The machine `name` with C continuous, the range its random tilts are
/// drawn from (inside the stroke, at most 110 deg either way) and the tilt's
/// letter.
fn random_machine(name: &str) -> (Machine, (f64, f64), char) {
    let mut m = machine(name);
    m.c.limits = None;
    let (lo, hi) = m.tilt.limits.unwrap();
    let range = ((lo + 1.0).max(-110.0), (hi - 1.0).min(110.0));
    let letter = m.tilt.letter;
    (m, range, letter)
}

#[test]
fn random_programs_with_long_turns_stay_within_the_tolerance_or_are_refused() {
    // Five-axis moves as no CAM post writes them but a shop's hand-made
    // program may: large steps of every axis at once, the tilt through
    // the tool-along-C singularity, C turning up to more than a turn a
    // block or by whole turns alone, with and without TCP, on the four
    // machine types. Every rewrite is simulated on the erroneous machine and
    // must reach each intended end point and stay within 1 um of the
    // intended path; a run may refuse with its reason instead, never write
    // a wrong program.
    let mut checked = 0;
    let mut refused = 0;
    for name in ["bc-trunnion", "ac-trunnion", "head-table", "head-head"] {
        let (m, (lo, hi), tl) = random_machine(name);
        let (tlo, thi) = m.tilt.limits.unwrap();
        for seed in 0..6u64 {
            let mut r = rng(1000 + seed);
            let l = errors_on(&m, seed, 40.0, "");
            let tcp = seed % 2 == 0;
            let mut lines = vec![
                "%".to_string(),
                "O1000".into(),
                "G90 G21 G17 G94 G54".into(),
                if tcp { "G43.4 H1" } else { "G43 H1" }.into(),
            ];
            let (mut t, mut c) = ((tlo + 5.0).max(-60.0).min(thi - 5.0), 10.0);
            lines.push(format!("G0 X20. Y10. Z80. {tl}{t:.1} C{c:.1}"));
            for _ in 0..8 {
                let x: f64 = r.random_range(-40.0..40.0);
                let y: f64 = r.random_range(-40.0..40.0);
                let z: f64 = r.random_range(10.0..80.0);
                if r.random_range(0.0..1.0) < 0.5 {
                    t = r.random_range(lo..hi);
                }
                let p: f64 = r.random_range(0.0..1.0);
                if p < 0.2 {
                    // Whole turns, the tool still: as a turn-milling job.
                    c += 360.0 * r.random_range(1..=3) as f64;
                    lines.push(format!("G1 C{c:.3}"));
                    continue;
                }
                if p < 0.7 {
                    c += r.random_range(-400.0..400.0);
                }
                lines.push(format!(
                    "G1 X{x:.3} Y{y:.3} Z{z:.3} {tl}{t:.3} C{c:.3} F1000."
                ));
            }
            lines.extend(["M30".into(), "%".into()]);
            let program = lines.join("\n") + "\n";
            let what = format!("{name} seed {seed} tcp={tcp}");
            let comp = Compensator::new(&l.model, &l.theta, Settings::new(Dialect::Fanuc));
            let mut out = Vec::new();
            let Ok(s) = comp.run(Path::new("t.nc"), program.as_bytes(), &mut out) else {
                refused += 1;
                continue;
            };
            let out = String::from_utf8(out).unwrap();
            assert!(s.changed > 0, "{what}");
            check_held(
                &l,
                Dialect::Fanuc,
                Coordinates::Auto,
                &program,
                &out,
                0.001,
                &s.held_c.first,
                &what,
            );
            checked += 1;
        }
    }
    assert!(checked >= 20, "{checked} checked, {refused} refused");
}

#[test]
fn random_programs_in_every_dialect_with_incremental_words_stay_within_the_tolerance() {
    // As the test above, in each dialect's own syntax, with a share of the
    // moves incremental (G91, `IX`/`IC`, `=IC(..)`), under TCP where the
    // dialect switches it in the program (G43.4, M128, TRAORI).
    let mut checked = 0;
    for d in Dialect::ALL {
        for name in ["bc-trunnion", "ac-trunnion", "head-table", "head-head"] {
            let (m, (lo, hi), tl) = random_machine(name);
            let (tlo, thi) = m.tilt.limits.unwrap();
            for seed in 0..2u64 {
                let mut r = rng(7000 + seed);
                let l = errors_on(&m, seed, 40.0, "");
                let tcp = seed % 2 == 0 && d != Dialect::Linuxcnc;
                let hh = d == Dialect::Heidenhain;
                let f = |v: f64| {
                    if hh {
                        format!("{v:+.3}")
                    } else {
                        format!("{v:.3}")
                    }
                };
                let mut lines: Vec<String> = match d {
                    Dialect::Fanuc => vec![
                        "%".into(),
                        "O1000".into(),
                        "G90 G21 G17 G94 G54".into(),
                        if tcp { "G43.4 H1" } else { "G43 H1" }.into(),
                    ],
                    Dialect::Linuxcnc => vec!["(random)".into(), "G21 G90 G17 G94 G54 G43".into()],
                    Dialect::Heidenhain => vec!["BEGIN PGM RND MM".into()],
                    Dialect::Sinumerik => {
                        vec!["%_N_RND_MPF".into(), "G17 G90 G710 G94 G54 D1".into()]
                    }
                };
                match d {
                    Dialect::Heidenhain if tcp => lines.push("M128".into()),
                    Dialect::Sinumerik if tcp => lines.push("TRAORI".into()),
                    _ => {}
                }
                let round = |v: f64| (v * 1000.0).round() / 1000.0;
                let (mut t, mut c) = ((tlo + 5.0).max(-60.0).min(thi - 5.0), 10.0);
                let (mut x, mut y, mut z) = (20.0, 10.0, 80.0);
                let start = format!("X{} Y{} Z{} {tl}{} C{}", f(x), f(y), f(z), f(t), f(c));
                lines.push(if hh {
                    format!("L {start} R0 FMAX")
                } else {
                    format!("G0 {start}")
                });
                for k in 0..8 {
                    let nx = round(r.random_range(-40.0..40.0));
                    let ny = round(r.random_range(-40.0..40.0));
                    let nz = round(r.random_range(10.0..80.0));
                    let mut nt = t;
                    let mut nc = c;
                    if r.random_range(0.0..1.0) < 0.5 {
                        nt = round(r.random_range(lo..hi));
                    }
                    if r.random_range(0.0..1.0) < 0.6 {
                        nc = c + round(r.random_range(-200.0..200.0));
                    }
                    let inc = r.random_range(0.0..1.0) < 0.4;
                    let feed = match (k, hh) {
                        (0, true) => " F1000",
                        (0, false) => " F1000.",
                        _ => "",
                    };
                    let (dx, dy, dz, dt, dc) = (nx - x, ny - y, nz - z, nt - t, nc - c);
                    lines.push(match (d, inc) {
                        (Dialect::Heidenhain, true) => format!(
                            "L IX{} IY{} IZ{} I{tl}{} IC{} R0{feed}",
                            f(dx),
                            f(dy),
                            f(dz),
                            f(dt),
                            f(dc)
                        ),
                        (Dialect::Heidenhain, false) => format!(
                            "L X{} Y{} Z{} {tl}{} C{} R0{feed}",
                            f(nx),
                            f(ny),
                            f(nz),
                            f(nt),
                            f(nc)
                        ),
                        (Dialect::Sinumerik, true) => format!(
                            "G1 X=IC({}) Y=IC({}) Z=IC({}) {tl}=IC({}) C=IC({}){feed}",
                            f(dx),
                            f(dy),
                            f(dz),
                            f(dt),
                            f(dc)
                        ),
                        (_, true) => format!(
                            "G91 G1 X{} Y{} Z{} {tl}{} C{}{feed}\nG90",
                            f(dx),
                            f(dy),
                            f(dz),
                            f(dt),
                            f(dc)
                        ),
                        (_, false) => format!(
                            "G1 X{} Y{} Z{} {tl}{} C{}{feed}",
                            f(nx),
                            f(ny),
                            f(nz),
                            f(nt),
                            f(nc)
                        ),
                    });
                    (x, y, z, t, c) = (nx, ny, nz, nt, nc);
                }
                match d {
                    Dialect::Fanuc => lines.extend(["M30".into(), "%".into()]),
                    Dialect::Linuxcnc => lines.push("M2".into()),
                    Dialect::Heidenhain => lines.push("END PGM RND MM".into()),
                    Dialect::Sinumerik => {
                        if tcp {
                            lines.push("TRAFOOF".into());
                        }
                        lines.push("M30".into());
                    }
                }
                let mut program = lines.join("\n") + "\n";
                if hh {
                    program = program
                        .lines()
                        .enumerate()
                        .map(|(i, l)| format!("{i} {l}\n"))
                        .collect();
                }
                let what = format!("{d} {name} seed {seed} tcp={tcp}");
                let (out, s, _) = compensate(&l, Settings::new(d), &program);
                assert!(s.skipped.is_empty(), "{what}: {:?}", s.skipped);
                assert!(s.changed > 0, "{what}");
                check_held(
                    &l,
                    d,
                    Coordinates::Auto,
                    &program,
                    &out,
                    0.001,
                    &s.held_c.first,
                    &what,
                );
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 32);
}
