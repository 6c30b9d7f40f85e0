//! The laser interferometer's ten lines (issue 45): the ISO 230-2 figures
//! against a hand computation, plans on every built-in machine and dialect
//! within the strokes, the seed's setup plannable on a machine of its kind
//! with the offsets made as the seed says, LinuxCNC's rs274 running the
//! programs through the planned targets, the readers on bad input, and the
//! loop plan -> simulate -> analyze against the truth's scale errors.

use std::path::Path;

use fivecal::analyze::iso230_2::{Instrument, figures, tabulate};
use fivecal::formats::laser::{LaserManifest, LaserRun};
use fivecal::machine::{Dialect, Machine};
use fivecal::procedure::laser_lines::{LaserRequest, commanded_positions, plan};

const BUILTIN: [&str; 4] = ["bc-trunnion", "ac-trunnion", "head-table", "head-head"];

fn close(got: f64, want: f64, what: &str) {
    assert!((got - want).abs() < 1e-5, "{what}: got {got}, want {want}");
}

/// The worked example: five targets 100 mm apart, two runs each way
/// (um), a reading u of 0.2 um and 1 ppm of length. By hand:
///
/// ```text
/// target mm   + runs     mean  s        - runs      mean   s       B_i   bidir mean
///   0         0,  1      0.5   0.70711  -1, -2     -1.5    0.70711  2.0   -0.5
/// 100         2,  2      2.0   0        1,  1       1.0    0        1.0    1.5
/// 200         3,  5      4.0   1.41421  2,  2       2.0    0        2.0    3.0
/// 300         1,  2      1.5   0.70711  0,  1.5     0.75   1.06066  0.75   1.125
/// 400        -1, -1     -1.0   0       -3, -2      -2.5    0.70711  1.5   -1.75
/// ```
///
/// (s of two runs = |difference| / sqrt 2.) Then B = 2.0, mean reversal
/// 7.25 / 5 = 1.45; M = 3.0 - (-1.75) = 4.75; E+ = 4 - (-1) = 5, E- = 2 -
/// (-2.5) = 4.5, E = 4 - (-2.5) = 6.5; R+ = 4 * 1.41421 = 5.65685, R- = 4 *
/// 1.06066 = 4.24264; R_i = max(2 s+ + 2 s- + |B_i|, 4 s+, 4 s-) = 4.82843,
/// 1, 5.65685, 4.28553, 2.91421, so R = 5.65685; A+ = (4 + 2.82843) - (-1)
/// = 7.82843, A- = (0.75 + 2.12132) - (-2.5 - 1.41421) = 6.78553, A =
/// 6.82843 - (-3.91421) = 10.74264.
///
/// u: a mean of 2 readings 0.2 / sqrt 2 = 0.141421, a bidirectional mean
/// 0.2 / 2 = 0.1, s of 2 runs s / sqrt 2, 1 ppm of 200 mm = 0.2 um: u(B) =
/// 0.2 sqrt(2/2) = 0.2, u(mean reversal) = 0.2 / sqrt 5 = 0.0894427, u(E)
/// = u(E+) = u(E-) = sqrt(2 * 0.02 + 0.04) = 0.282843 (extremes at 200 and
/// 400 mm), u(M) = sqrt(0.01 + 0.01 + 0.04) = 0.244949, u(R) = u(R+) = 4 *
/// 1.41421 / sqrt 2 = 4, u(R-) = 4 * 1.06066 / sqrt 2 = 3, u(A) =
/// sqrt(0.02 + (2 * 1)^2 + 0.02 + (2 * 0.5)^2 + 0.04) = sqrt 5.08 =
/// 2.253886, u(A+) = sqrt(0.02 + 4 + 0.02 + 0 + 0.04) = sqrt 4.08 =
/// 2.019901.
#[test]
fn iso230_2_figures_match_a_hand_computation() {
    let src = "line: L1\nair_temperature_c: 20.2\ntarget_mm,run,direction,deviation_um\n\
        0,1,+,0\n100,1,+,2\n200,1,+,3\n300,1,+,1\n400,1,+,-1\n\
        400,1,-,-3\n300,1,-,0\n200,1,-,2\n100,1,-,1\n0,1,-,-1\n\
        0,2,+,1\n100,2,+,2\n200,2,+,5\n300,2,+,2\n400,2,+,-1\n\
        400,2,-,-2\n300,2,-,1.5\n200,2,-,2\n100,2,-,1\n0,2,-,-2\n";
    let run = LaserRun::parse(Path::new("L1.txt"), src).unwrap();
    let targets = [0.0, 100.0, 200.0, 300.0, 400.0];
    let table = tabulate(&run, &targets, 2).unwrap();
    let inst = Instrument {
        reading_u_um: 0.2,
        length_u_ppm: 1.0,
    };
    let f = figures("L1", &targets, &table, inst).unwrap();
    let rows = [
        ("B", f.b, 2.0, 0.2),
        ("mean reversal", f.b_mean, 1.45, 0.0894427),
        ("M", f.m, 4.75, 0.244949),
        ("E+", f.e_up, 5.0, 0.282843),
        ("E-", f.e_down, 4.5, 0.282843),
        ("E", f.e, 6.5, 0.282843),
        ("R+", f.r_up, 5.656854, 4.0),
        ("R-", f.r_down, 4.242641, 3.0),
        ("R", f.r, 5.656854, 4.0),
        ("A+", f.a_up, 7.828427, 2.019901),
        ("A-", f.a_down, 6.785534, f.a_down.u_um),
        ("A", f.a, 10.742641, 2.253886),
    ];
    for (name, got, value, u) in rows {
        close(got.value_um, value, name);
        close(got.u_um, u, &format!("u({name})"));
    }
    close(f.targets[3].repeatability(), 4.285534, "R_4");
    close(f.targets[0].repeatability(), 4.828427, "R_1");
    assert_eq!(run.environment[0].1, "20.2");
}

/// The same worked example in the layout of Renishaw's `.rtl` text
/// (tests/fixtures/laser/README.md): the passes' directions from their
/// target order, the runs counted per direction, the environment as the
/// file states it, and the same figures.
#[test]
fn the_rtl_export_of_the_worked_example_gives_the_same_figures() {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/laser/worked-example.rtl");
    let run = LaserRun::read(&path).unwrap();
    assert_eq!((run.line.as_str(), run.format), ("L1", "Renishaw .rtl"));
    assert_eq!(run.environment.len(), 8);
    assert_eq!(
        run.environment[6],
        ("Env factor".to_string(), "0.99999731".to_string())
    );
    let targets = [0.0, 100.0, 200.0, 300.0, 400.0];
    let inst = Instrument {
        reading_u_um: 0.2,
        length_u_ppm: 1.0,
    };
    let f = figures("L1", &targets, &tabulate(&run, &targets, 2).unwrap(), inst).unwrap();
    close(f.a.value_um, 10.742641, "A");
    close(f.r.value_um, 5.656854, "R");
    close(f.b_mean.value_um, 1.45, "mean reversal");
    close(f.e.value_um, 6.5, "E");
}

#[test]
fn a_missing_or_doubled_reading_is_refused_by_name() {
    let src = "line: L1\ntarget_mm,run,direction,deviation_um\n0,1,+,0\n10,1,+,1\n10,1,-,1\n";
    let run = LaserRun::parse(Path::new("L1.txt"), src).unwrap();
    let e = tabulate(&run, &[0.0, 10.0], 1).unwrap_err().to_string();
    assert!(e.contains("no reading at 0 mm, run 1, direction -"), "{e}");
    let twice = format!("{src}10,1,-,2\n");
    let run = LaserRun::parse(Path::new("L1.txt"), &twice).unwrap();
    let e = tabulate(&run, &[0.0, 10.0], 1).unwrap_err().to_string();
    assert!(e.contains("two readings at 10 mm"), "{e}");
    let e = tabulate(&run, &[0.0, 20.0], 1).unwrap_err().to_string();
    assert!(e.contains("no target of the plan"), "{e}");
}

#[test]
fn every_builtin_machine_and_dialect_plans_within_the_strokes() {
    for name in BUILTIN {
        for d in Dialect::ALL {
            let req = LaserRequest::new(Machine::builtin(name).unwrap(), d);
            let p = plan(&req).unwrap_or_else(|e| panic!("{name} {d}: {e}"));
            assert_eq!(p.lines.len(), 10);
            let m = &req.machine;
            for (l, prog) in p.lines.iter().zip(&p.programs) {
                assert_eq!(l.targets.len(), 41);
                for (what, q) in commanded_positions(&req, l) {
                    for k in 0..3 {
                        let (lo, hi) = m.strokes[k];
                        assert!(
                            q[k] >= lo - 1e-9 && q[k] <= hi + 1e-9,
                            "{name} {d} {}: {what}",
                            l.name
                        );
                    }
                }
                for i in 0..l.targets.len() {
                    for (v, (lo, hi)) in l.spindle_at(i).iter().zip(m.strokes) {
                        assert!(*v >= lo && *v <= hi, "{name} {d} {} target {i}", l.name);
                    }
                }
                // What the program is, first; a capture at every target in
                // both directions in every run.
                assert!(
                    prog.contains(&format!("laser-lines {} on {name}", l.name).to_uppercase())
                        || prog.contains(&format!("laser-lines {} on {name}", l.name))
                );
                let dwells = prog
                    .lines()
                    .filter(|b| b.contains("G4 ") || b.contains("9.1 DWELL"))
                    .count();
                assert_eq!(dwells, 2 * 41 * 5, "{name} {d} {}", l.name);
            }
        }
    }
}

#[test]
fn a_volume_beyond_the_strokes_is_refused_naming_the_line_and_the_stroke() {
    let mut req = LaserRequest::new(Machine::builtin("head-table").unwrap(), Dialect::Fanuc);
    req.volume = Some([0.0, 10.0, -500.0, 700.0, 600.0, -50.0]);
    let e = plan(&req).unwrap_err().to_string();
    assert!(
        e.starts_with("line L1 (X axis): the overrun before the first target puts X at -5.000 mm, outside its stroke [0, 735]"),
        "{e}"
    );
}

/// A DMU 100 monoBLOCK-like CZFXYB machine whose strokes hold the seed's
/// measuring volume (100, -650, -500) to (900, -50, -100) mm.
fn seed_machine() -> Machine {
    let src = seed_machine_yaml("dmu100-like");
    Machine::from_yaml(Path::new("dmu100-like.yaml"), &src).unwrap()
}

/// The machine file of [`seed_machine`], named `name`.
pub(crate) fn seed_machine_yaml(name: &str) -> String {
    Machine::builtin("head-table")
        .unwrap()
        .source
        .replace("name: head-table", &format!("name: {name}"))
        .replace("X: [0, 735]", "X: [0, 1000]")
        .replace("Y: [0, 650]", "Y: [-700, 0]")
        .replace("Z: [-560, 0]", "Z: [-600, 0]")
        .replace(
            "pivot: [367.5, 325.0, -480.0]",
            "pivot: [500.0, -350.0, -500.0]",
        )
}

#[test]
fn the_seeds_volume_plans_forty_divisions_with_the_offsets_the_seed_names() {
    let mut req = LaserRequest::new(seed_machine(), Dialect::Heidenhain);
    req.volume = Some([100.0, -650.0, -500.0, 900.0, -50.0, -100.0]);
    let p = plan(&req).unwrap();
    let by: Vec<(&str, &str)> = p
        .lines
        .iter()
        .map(|l| (l.name.as_str(), l.offset_by.as_str()))
        .collect();
    // The seed: on CZFXYB the Z axis' offset points are made by moving Y
    // and X; the Y axis' only by an attachment on the spindle.
    assert_eq!(
        by,
        [
            ("L1", "none"),
            ("L2", "none"),
            ("L3", "none"),
            ("L4", "axes"),
            ("L5", "bracket"),
            ("L6", "bracket"),
            ("L7", "bracket"),
            ("L8", "axes"),
            ("L9", "axes"),
            ("L10", "none")
        ]
    );
    let l1 = &p.lines[0];
    assert_eq!(l1.start, [100.0, -650.0, -500.0]);
    assert_eq!(l1.targets.len(), 41);
    close(l1.targets[1], 20.0, "step of L1");
    close(p.lines[2].targets[40], 400.0, "length of L3");
    // Targets are kept to the micrometre.
    let diagonal = (800.0f64.powi(2) + 600.0f64.powi(2) + 400.0f64.powi(2)).sqrt();
    assert!((p.lines[9].targets[40] - diagonal).abs() <= 5e-4);
    // L8: Z at X1 (the offset made by X holding 800 mm further).
    assert_eq!(p.lines[7].start, [900.0, -650.0, -500.0]);
    // The plan file reads back.
    let text = p.manifest().to_yaml();
    let back = LaserManifest::parse(Path::new("p.yaml"), &text).unwrap();
    assert_eq!(back, p.manifest());
}

#[test]
fn every_linuxcnc_program_runs_through_rs274_to_the_planned_targets() {
    let dir = crate::util::tempdir();
    for name in BUILTIN {
        let mut req = LaserRequest::new(Machine::builtin(name).unwrap(), Dialect::Linuxcnc);
        req.runs = 2;
        req.divisions = 8;
        let p = plan(&req).unwrap();
        for (l, prog) in p.lines.iter().zip(&p.programs) {
            let sub = dir.path().join(format!("{name}-{}", l.name));
            std::fs::create_dir_all(&sub).unwrap();
            let f = sub.join(format!("{}.ngc", l.name));
            std::fs::write(&f, prog).unwrap();
            let ends = crate::compensate_cli::trace(&f);
            // Every target (G54 on the volume's corner) is an end point,
            // reached once per run and direction (target 0's first time is
            // the approach on which the zero is set).
            for i in 0..l.targets.len() {
                let s = l.spindle_at(i);
                let want = [s[0] - p.volume[0], s[1] - p.volume[1], s[2] - p.volume[2]];
                let hits = ends
                    .iter()
                    .filter(|e| (0..3).all(|k| (e[k] - want[k]).abs() < 1e-3))
                    .count();
                assert_eq!(hits, 4, "{name} {} target {i}: {want:?}", l.name);
            }
        }
    }
}

/// Runs the binary with `args`, which must succeed: its standard output.
pub(crate) fn fivecal_ok<S: AsRef<std::ffi::OsStr> + std::fmt::Debug>(args: &[S]) -> String {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_fivecal"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The ten lines through the binary: `plan laser-lines` with `plan_args`
/// (the machine among them) into `dir/plan`, then `simulate` of the error
/// file `truth_yaml` (with `sim_args`, such as `--no-noise`) into
/// `dir/runs`. The plan file and the runs' directory.
pub(crate) fn simulated_lines(
    dir: &Path,
    plan_args: &[&str],
    truth_yaml: &str,
    sim_args: &[&str],
) -> (std::path::PathBuf, std::path::PathBuf) {
    let plan = dir.join("plan");
    let mut args = vec![
        "plan".as_ref(),
        "laser-lines".as_ref(),
        "-o".as_ref(),
        plan.as_os_str(),
    ];
    args.extend(plan_args.iter().map(std::ffi::OsStr::new));
    fivecal_ok(&args);
    let truth = dir.join("truth.yaml");
    std::fs::write(&truth, truth_yaml).unwrap();
    let plan_file = plan.join("laser-lines.plan.yaml");
    let runs = dir.join("runs");
    let mut args = vec![
        "simulate".as_ref(),
        "--plan".as_ref(),
        plan_file.as_os_str(),
        "--errors".as_ref(),
        truth.as_os_str(),
        "-o".as_ref(),
        runs.as_os_str(),
    ];
    args.extend(sim_args.iter().map(std::ffi::OsStr::new));
    fivecal_ok(&args);
    (plan_file, runs)
}

#[test]
fn simulate_then_analyze_finds_the_truths_scale_on_each_line() {
    let dir = crate::util::tempdir();
    let (plan_file, runs) = simulated_lines(
        dir.path(),
        &["--machine", "bc-trunnion", "--dialect", "fanuc"],
        "machine: bc-trunnion\nlocation_errors: {}\neffects:\n  linear_scale: {EXX: 10.0, EYY: -6.0, EZZ: 4.0}\n",
        &["--no-noise"],
    );
    let run = |args: &[&str]| fivecal_ok(args);
    let s = |p: &Path| p.to_string_lossy().into_owned();
    let result = dir.path().join("result.yaml");
    let report = dir.path().join("report");
    let mut args: Vec<String> = ["analyze", "--plan"].map(String::from).to_vec();
    args.extend([
        s(&plan_file),
        "-o".into(),
        s(&result),
        "--report".into(),
        s(&report),
    ]);
    args.push("--measured".into());
    args.extend((1..=10).map(|k| s(&runs.join(format!("L{k}.txt")))));
    let text = run(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(text.contains("line L1: ISO 230-2, 41 targets"), "{text}");
    let man = LaserManifest::read(&plan_file).unwrap();
    let y: serde_yaml::Value =
        serde_yaml::from_str(&std::fs::read_to_string(&result).unwrap()).unwrap();
    // Without noise or reversal: E = M = A = the scale times the length,
    // R = B = 0.
    for (k, want_per_m) in [
        (0usize, 10.0),
        (1, -6.0),
        (2, 4.0),
        (3, 10.0),
        (5, -6.0),
        (8, 4.0),
    ] {
        let l = &man.lines[k];
        let length = l.targets[l.targets.len() - 1];
        let want = (want_per_m * length / 1000.0f64).abs();
        let line = &y["lines"][k];
        for fig in ["e", "m", "a"] {
            let got = line[fig]["value_um"].as_f64().unwrap();
            assert!(
                (got - want).abs() < 2e-3,
                "{} {fig}: {got} vs {want}",
                l.name
            );
        }
        for fig in ["r", "b"] {
            assert!(line[fig]["value_um"].as_f64().unwrap().abs() < 1e-3);
        }
    }
    assert!(report.join("index.html").exists() && report.join("line-L10.svg").exists());
}

#[test]
fn the_readers_name_file_line_and_column() {
    for (src, want) in [
        (
            "line: L1\ntarget_mm,run,direction,deviation_um\n0,0,+,1\n",
            "r.txt:3:3: expected a run number",
        ),
        (
            "line: L1\ntarget_mm,run,direction,deviation_um\n0,1,+\n",
            "r.txt:3:1: expected four fields",
        ),
        ("line: L 1\n", "r.txt:1:7: expected a line name"),
        ("line: L1\nfoo: 1\n", "r.txt:2:1: unknown key `foo`"),
        (
            "HEADER::\nTARGET DATA::\nTarget-count: 3\nTargets :\n0 10\nRUNS::\nRun-count: 1\nDEVIATIONS::\nRun Target Data:\n1 1 0\n",
            "r.txt:3:1: Target-count: 3, but `Targets :` lists 2",
        ),
        (
            "HEADER::\nTARGET DATA::\nTarget-count: 2\nTargets :\n0 10\nRUNS::\nRun-count: 1\nDEVIATIONS::\nRun Target Data:\n1 1 0\n1 3 0\n",
            "r.txt:11:1: target 3: the file lists 2 targets",
        ),
    ] {
        let e = LaserRun::parse(Path::new("r.txt"), src)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with(want), "{e}\nwanted {want}");
    }
}

/// Hostile input on the command line: a damaged run file, an option of
/// the identification, a result naming an input. Each is refused with
/// exit 2 and a message naming what is wrong, and nothing is written.
#[test]
fn analyze_refuses_bad_runs_foreign_options_and_an_output_over_an_input() {
    let dir = crate::util::tempdir();
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/laser");
    let plan_file = dir.path().join("small.plan.yaml");
    std::fs::copy(fixtures.join("small.plan.yaml"), &plan_file).unwrap();
    let good = fixtures.join("L4.txt");
    let bad = dir.path().join("L4.txt");
    let text = std::fs::read_to_string(&good).unwrap();
    std::fs::write(&bad, text.replacen("0,1,+,0.0000", "0,1,+,zero", 1)).unwrap();
    let result = dir.path().join("result.yaml");
    let refused = |args: &[&std::ffi::OsStr], expect: &str| {
        let o = crate::cli::fivecal().args(args).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains(expect),
            "{args:?}: expected `{expect}` in {err}"
        );
        assert!(!result.exists());
    };
    let os = |s: &str| std::ffi::OsStr::new(s).to_os_string();
    let run = |extra: &[std::ffi::OsString], measured: &Path, out: &Path| {
        let mut v = vec![
            os("analyze"),
            os("--plan"),
            plan_file.clone().into_os_string(),
        ];
        v.extend(extra.iter().cloned());
        v.extend([os("-o"), out.as_os_str().to_os_string(), os("--measured")]);
        v.push(measured.as_os_str().to_os_string());
        v
    };
    let a = run(&[], &bad, &result);
    refused(
        &a.iter().map(|s| s.as_os_str()).collect::<Vec<_>>(),
        "L4.txt:10:7: expected a deviation in um",
    );
    let a = run(&[os("--mc"), os("10")], &good, &result);
    refused(
        &a.iter().map(|s| s.as_os_str()).collect::<Vec<_>>(),
        "--mc does not apply to a laser-lines plan",
    );
    let a = run(&[], &good, &plan_file);
    refused(
        &a.iter().map(|s| s.as_os_str()).collect::<Vec<_>>(),
        "small.plan.yaml",
    );
    // The good file: two runs each way, fewer than ISO 230-2's five.
    let a = run(&[], &good, &result);
    let o = crate::cli::fivecal().args(&a).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("ISO 230-2 asks five"));
    let y: serde_yaml::Value =
        serde_yaml::from_str(&std::fs::read_to_string(&result).unwrap()).unwrap();
    assert_eq!(
        y["lines"][0]["environment"]["compensation"].as_str(),
        Some("automatic")
    );
    assert_eq!(y["not_measured"].as_sequence().unwrap().len(), 9);
}
