//! What `simulate` writes: every format read back by the project's own
//! readers (the format recognized from the content, as `analyze` does),
//! seeded runs byte for byte, and the command line with written plan
//! directories, bad truth files and outputs that would overwrite an input.

use std::path::{Path, PathBuf};

use fivecal::errorfile::{ErrorFile, LoadedErrors};
use fivecal::formats::detect::{self, Measurement, ReadContext};
use fivecal::formats::measured::MeasuredPoint;
use fivecal::procedure::Plan;
use fivecal::simulate::{self, Format, Placement, SimOptions, SimOutput};
use fivecal::{Dialect, Kinematics, Machine};

use crate::cli::{analyze_cmd, fivecal};
use crate::probe_programs::probing;
use crate::simulate::{planned, truth};
use crate::util::{MACHINES, tempdir};

const TRUTH: &str = "location_errors: {EX0B: 12, EZ0B: -25, EA0B: 80, EC0B: -60, EB0B: 150, EX(0B)C: 25, EY0C: -18, EA(0B)C: 45}\n\
effects: {linear_scale: {EXX: 4}, tool_radius: 3, probe_pretravel: {X+: 1, X-: 1.2, Y+: 0.9, Y-: 1.1, Z-: 0.6}, noise: {cmm: 0.35, probe: 0.35}}\n";

const AC_TRUTH: &str = "location_errors: {EY0A: 12, EZ0A: -25, EB0A: 80, EC0A: -60, EA0A: 150, EY(0A)C: 25, EX0C: -18, EB(0A)C: 45}\n\
effects: {probe_pretravel: {X+: 1, X-: 1.2, Y+: 0.9, Y-: 1.1, Z-: 0.6}, noise: {cmm: 0.35, probe: 0.35}}\n";

fn errors_for(plan: &Plan) -> LoadedErrors {
    match plan.machine().name.as_str() {
        "bc-trunnion" => truth(plan, TRUTH),
        _ => truth(plan, AC_TRUTH),
    }
}

/// Reads a written measurement the way `analyze` does.
fn read_back(plan: &Plan, path: &Path) -> Measurement {
    let points = plan.plan_points();
    let kin = simulate::plan_kinematics(plan);
    let opts = plan.probing().map(|p| p.read_options());
    let ctx = ReadContext {
        plan: Some(&points),
        kin: Some(&kin),
        dialect: Some(plan.dialect()),
        probe: opts.as_ref(),
        ..Default::default()
    };
    detect::read_measurement_in(path, &ctx).unwrap_or_else(|e| panic!("{e}"))
}

/// Largest coordinate difference between read-back points and the
/// simulated ones, joined by label (every simulated point must be there).
fn worst(read: &[MeasuredPoint], out: &SimOutput) -> f64 {
    assert_eq!(read.len(), out.points.len());
    out.points
        .iter()
        .map(|m| {
            let r = read
                .iter()
                .find(|r| r.label == m.label)
                .unwrap_or_else(|| panic!("{} not read back", m.label));
            (r.p - m.p).amax()
        })
        .fold(0.0, f64::max)
}

fn points_of(m: Measurement) -> Vec<MeasuredPoint> {
    match m {
        Measurement::Points(s) => {
            assert!(s.labeled);
            s.points
        }
        Measurement::Heights(_) => panic!("heights where points were expected"),
    }
}

/// Each format, written and read back by the project's readers, gives the
/// simulated points to the digits the format prints: CSV (6 decimals),
/// DMIS output (5), QIF results (6), the FANUC and HEIDENHAIN logs (4, as the controls
/// print), the LinuxCNC log (6), nine-section heights (4 decimals of um).
#[test]
fn every_output_format_reads_back_into_the_simulated_points() {
    let dir = tempdir();
    let opts = |placement| SimOptions {
        seed: 4,
        placement,
        ..SimOptions::default()
    };
    // A machined piece: CSV anywhere on the CMM, DMIS in the aligned frame.
    let plan = planned("bc-trunnion", "stepped-square");
    let errors = errors_for(&plan);
    for (format, placement, name, tol) in [
        (Format::Csv, Placement::Random, "piece.csv", 5e-7),
        (Format::Dmis, Placement::Aligned, "piece.dmo", 5e-6),
        (Format::Qif, Placement::Aligned, "piece.qif", 5e-7),
    ] {
        let out = simulate::run(&plan, &errors, &opts(placement)).unwrap();
        let path = dir.path().join(name);
        out.write(format, &path).unwrap();
        let m = read_back(&plan, &path);
        if let Measurement::Points(s) = &m {
            assert_eq!(s.format, format.name());
        }
        let w = worst(&points_of(m), &out);
        assert!(w <= tol, "{format}: read back {w:e} mm off");
    }
    // Nine-section heights.
    let plan = planned("ac-trunnion", "nine-section");
    let errors = errors_for(&plan);
    let out = simulate::run(&plan, &errors, &opts(Placement::Aligned)).unwrap();
    let path = dir.path().join("heights.csv");
    out.write(Format::Heights, &path).unwrap();
    let Measurement::Heights(h) = read_back(&plan, &path) else {
        panic!("not heights")
    };
    let want = out.heights.as_ref().unwrap();
    assert_eq!(h.len(), 9);
    for (a, b) in h.iter().zip(want) {
        assert_eq!(a.section, b.section);
        assert!((a.height_um - b.height_um).abs() <= 5e-5);
    }
    // Probe logs of every dialect, and the canonical CSV of the contacts.
    for dialect in Dialect::ALL {
        for test in ["probe-columns", "probe-sphere"] {
            let plan = Plan::Probing(Box::new(probing("ac-trunnion", test, dialect)));
            let errors = errors_for(&plan);
            let out = simulate::run(&plan, &errors, &opts(Placement::Aligned)).unwrap();
            let digits = if dialect == Dialect::Linuxcnc {
                5e-7
            } else {
                5e-5
            };
            for (format, tol) in [(Format::Log, digits), (Format::Csv, 5e-7)] {
                let path = dir.path().join(format!("{test}-{dialect}.{format}"));
                out.write(format, &path).unwrap();
                let w = worst(&points_of(read_back(&plan, &path)), &out);
                assert!(w <= tol, "{test} {dialect} {format}: {w:e} mm off");
            }
        }
    }
}

/// The same seed writes the same bytes in every format; another seed
/// writes another measurement (placement, setups and noise all move).
#[test]
fn seeded_runs_are_reproducible_byte_for_byte_and_other_seeds_differ() {
    let cases: [(&str, &str, Format); 5] = [
        ("bc-trunnion", "stepped-square", Format::Csv),
        ("bc-trunnion", "stepped-square", Format::Dmis),
        ("bc-trunnion", "stepped-square", Format::Qif),
        ("ac-trunnion", "nine-section", Format::Heights),
        ("ac-trunnion", "probe-columns", Format::Log),
    ];
    for (m, test, format) in cases {
        let plan = planned(m, test);
        let errors = errors_for(&plan);
        let text = |seed: u64| {
            let o = SimOptions {
                seed,
                ..SimOptions::default()
            };
            simulate::run(&plan, &errors, &o)
                .unwrap()
                .render(format)
                .unwrap()
        };
        let a = text(7);
        assert_eq!(a, text(7), "{test} {format}: seed 7 twice differs");
        assert_ne!(a, text(8), "{test} {format}: seeds 7 and 8 agree");
    }
}

/// A plan directory written by the planner, with a truth file beside it.
fn plan_dir(machine: &str, test: &str) -> (tempfile::TempDir, PathBuf, PathBuf) {
    let dir = tempdir();
    let plan = planned(machine, test);
    plan.write(dir.path(), test, &[]).unwrap();
    let manifest = dir.path().join(format!("{test}.plan.yaml"));
    let truth = dir.path().join("truth.yaml");
    let body = if machine == "bc-trunnion" {
        TRUTH
    } else {
        AC_TRUTH
    };
    std::fs::write(&truth, format!("machine: {machine}\n{body}")).unwrap();
    (dir, manifest, truth)
}

/// `fivecal simulate` on a written plan: the format follows the file's
/// extension, the same seed gives the same file, and what it writes reads
/// back as the library's own run.
#[test]
fn cli_simulates_a_written_plan_in_the_format_its_extension_names() {
    let (dir, manifest, truth_path) = plan_dir("bc-trunnion", "stepped-square");
    let out = dir.path().join("piece.dmo");
    let run = |out: &Path| {
        fivecal()
            .args(["simulate", "--plan"])
            .arg(&manifest)
            .arg("--errors")
            .arg(&truth_path)
            .arg("--out")
            .arg(out)
            .args(["--seed", "5"])
            .assert()
            .success()
    };
    let a = run(&out);
    let stdout = String::from_utf8_lossy(&a.get_output().stdout).to_string();
    assert!(
        stdout.contains("(dmis)") && stdout.contains("seed 5"),
        "{stdout}"
    );
    let first = std::fs::read(&out).unwrap();
    run(&out);
    assert_eq!(first, std::fs::read(&out).unwrap());
    // The library with the same options writes the same bytes.
    let plan = fivecal::procedure::load(&manifest).unwrap();
    let kin = simulate::plan_kinematics(&plan);
    let errors = ErrorFile::load(&truth_path, &kin).unwrap();
    let lib = simulate::run(
        &plan,
        &errors,
        &SimOptions {
            seed: 5,
            placement: Placement::Aligned,
            ..SimOptions::default()
        },
    )
    .unwrap();
    assert_eq!(
        String::from_utf8(first).unwrap(),
        lib.render(Format::Dmis).unwrap()
    );
    // A probing plan writes the control's log by default.
    let (dir, manifest, truth_path) = plan_dir("ac-trunnion", "probe-sphere");
    let log = dir.path().join("PROBE");
    fivecal()
        .args(["simulate", "--plan"])
        .arg(&manifest)
        .arg("--errors")
        .arg(&truth_path)
        .arg("--out")
        .arg(&log)
        .assert()
        .success();
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(text.starts_with("%\nFIVECAL PROBE-SPHERE\n"), "{text:.80}");
}

/// A bad truth file stops the run with `file:line:column` and what was
/// expected, exit status 2, and no output written.
#[test]
fn cli_reports_a_bad_truth_file_at_its_line_and_writes_nothing() {
    let (dir, manifest, truth_path) = plan_dir("bc-trunnion", "stepped-square");
    let out = dir.path().join("piece.csv");
    for (body, line, says) in [
        (
            "machine: bc-trunnion\nlocation_errors:\n  EX0B: 12\n  EQ0B: 5\n",
            4,
            "unknown symbol `EQ0B`",
        ),
        (
            "machine: bc-trunnion\neffects:\n  linear_scale: {EXX: 4, EWW: 2}\n",
            3,
            "unknown linear scale error `EWW`",
        ),
        (
            "machine: ac-trunnion\nlocation_errors: {EY0A: 3}\n",
            1,
            "error file is for machine `ac-trunnion`",
        ),
        (
            "machine: bc-trunnion\nlocation_errors: {EX0B: twelve}\n",
            2,
            "expected a number",
        ),
    ] {
        std::fs::write(&truth_path, body).unwrap();
        let a = fivecal()
            .args(["simulate", "--plan"])
            .arg(&manifest)
            .arg("--errors")
            .arg(&truth_path)
            .arg("--out")
            .arg(&out)
            .assert()
            .failure()
            .code(2);
        let err = String::from_utf8_lossy(&a.get_output().stderr).to_string();
        let at = format!("{}:{line}:", truth_path.display());
        assert!(err.contains(&at) && err.contains(says), "{err}");
        assert!(!out.exists(), "a failed run wrote {}", out.display());
    }
}

/// The output never overwrites an input: the truth file, the manifest or
/// any file of the plan directory.
#[test]
fn cli_never_overwrites_an_input() {
    let (dir, manifest, truth_path) = plan_dir("bc-trunnion", "stepped-square");
    let points = dir.path().join("stepped-square.points.csv");
    for victim in [&truth_path, &manifest, &points] {
        let before = std::fs::read(victim).unwrap();
        let a = fivecal()
            .args(["simulate", "--plan"])
            .arg(&manifest)
            .arg("--errors")
            .arg(&truth_path)
            .arg("--out")
            .arg(victim)
            .assert()
            .failure()
            .code(2);
        let err = String::from_utf8_lossy(&a.get_output().stderr).to_string();
        assert!(err.contains("refusing to overwrite input"), "{err}");
        assert_eq!(before, std::fs::read(victim).unwrap());
    }
    // A format the test cannot write is refused before anything runs.
    let a = fivecal()
        .args(["simulate", "--plan"])
        .arg(&manifest)
        .arg("--errors")
        .arg(&truth_path)
        .arg("--out")
        .arg(dir.path().join("x.log"))
        .assert()
        .failure()
        .code(2);
    let err = String::from_utf8_lossy(&a.get_output().stderr).to_string();
    assert!(
        err.contains("only on-machine probing writes a probe log"),
        "{err}"
    );
}

/// `fivecal simulate --truth-example` prints, for every built-in machine,
/// a commented truth file that loads back with every supported effect.
#[test]
fn cli_truth_example_loads_back_with_every_effect_on_every_machine() {
    let dir = tempdir();
    for m in MACHINES {
        let a = fivecal()
            .args(["simulate", "--truth-example", "--machine", m])
            .assert()
            .success();
        let text = String::from_utf8(a.get_output().stdout.clone()).unwrap();
        assert!(
            text.lines()
                .filter(|l| l.trim_start().starts_with('#'))
                .count()
                > 10
        );
        let path = dir.path().join(format!("{m}.yaml"));
        std::fs::write(&path, &text).unwrap();
        let kin = Kinematics::new(&Machine::builtin(m).unwrap());
        let l = ErrorFile::load(&path, &kin).unwrap_or_else(|e| panic!("{m}: {e}"));
        let ids: Vec<String> = l
            .model
            .effects
            .iter()
            .map(|e| e.id(&l.model.symbols))
            .collect();
        for want in [
            "location",
            "map.",
            "drift.",
            "scale.EXX",
            "scale.EYY",
            "scale.EZZ",
            "squareness.EC(0X)Y",
            "squareness.EB(0X)Z",
            "squareness.EA(0Y)Z",
            "straightness.",
            "tool_radius",
            "tool_length",
            "probe_pretravel",
        ] {
            assert!(
                ids.iter().any(|i| i.starts_with(want)),
                "{m}: no `{want}` in {ids:?}"
            );
        }
        assert_eq!(
            l.model
                .find("location")
                .map(|i| l.model.param_range(i).len()),
            Some(l.model.symbols.location.len()),
            "{m}: not every location symbol"
        );
        assert!(ids.iter().filter(|i| i.starts_with("map.")).count() >= 2);
        assert!(ids.iter().filter(|i| i.starts_with("drift.")).count() >= 2);
        assert_eq!((l.noise.cmm, l.noise.probe), (Some(0.35), Some(0.35)));
    }
}

/// The walk-through of `examples/simulate/README.md`, as written: plan the
/// stepped square, simulate it on the machine of `truth.yaml` (DMIS
/// output), analyze it with the B map: every location error comes back
/// within four standard uncertainties (the map's mean moves into EB0B, so
/// EB0B is compared with 150 plus that mean).
#[test]
fn the_examples_walk_through_gives_the_truth_back() {
    let dir = tempdir();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let truth_path = root.join("examples/simulate/truth.yaml");
    let plans = dir.path().join("plans/ss");
    fivecal()
        .args([
            "plan",
            "stepped-square",
            "--machine",
            "bc-trunnion",
            "--dialect",
            "fanuc",
            "--out",
        ])
        .arg(&plans)
        .assert()
        .success();
    let manifest = plans.join("stepped-square.plan.yaml");
    let piece = dir.path().join("piece.dmo");
    let a = fivecal()
        .args(["simulate", "--plan"])
        .arg(&manifest)
        .arg("--errors")
        .arg(&truth_path)
        .arg("--out")
        .arg(&piece)
        .args(["--seed", "1"])
        .assert()
        .success();
    let said = String::from_utf8_lossy(&a.get_output().stdout).to_string();
    assert!(
        said.contains(
            "144 points of the machined piece, measured on a CMM (part frame aligned on W)"
        ),
        "{said}"
    );
    let result = dir.path().join("result.yaml");
    analyze_cmd(&manifest, &piece, &result)
        .args(["--maps", "EBB(B)"])
        .assert()
        .success();
    let got = ErrorFile::read(&result).unwrap().0;
    let want = ErrorFile::read(&truth_path).unwrap().0;
    let map = &want.position_dependent["EBB(B)"];
    let fivecal::errorfile::Values::Flat(v) = &map.values else {
        panic!()
    };
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    for (name, q) in &want.location_errors {
        let t = q.value + if name == "EB0B" { mean } else { 0.0 };
        let e = &got.location_errors[name];
        let u = e.u.unwrap();
        assert!(
            (e.value - t).abs() < 4.0 * u,
            "{name}: {:.3} +- {u:.3}, truth {t:.3}",
            e.value
        );
    }
}

/// `examples/simulate/truth-all-effects.yaml` is what `--truth-example`
/// prints for the B/C trunnion (kept true by this test).
#[test]
fn the_examples_truth_file_is_the_truth_example() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let file =
        std::fs::read_to_string(root.join("examples/simulate/truth-all-effects.yaml")).unwrap();
    let kin = Kinematics::new(&Machine::builtin("bc-trunnion").unwrap());
    assert_eq!(file, simulate::truth::example(&kin));
}
