//! `analyze` as a user meets it: measurement files as CMMs write them
//! (DMIS output with its quirks, CSV, plain exports), the nine-section
//! statistics of Cubas Brizuela & Yeh 2023, table 4, and the command line end to end on a
//! plan directory.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use fivecal::errorfile::ErrorFile;
use fivecal::formats::detect::{Measurement, PointSet, parse_measurement, read_measurement};
use fivecal::formats::dmis::{self, DmisPoint, WriteOptions};
use fivecal::formats::heights;
use fivecal::formats::manifest::{KinematicsMode, Manifest, PoseEntry, TestKind};
use fivecal::formats::measured::{self, MeasuredPoint};
use fivecal::formats::points::PlanPoints;
use fivecal::identify::data::join;
use fivecal::identify::nine_section::NineSection;
use fivecal::identify::synthetic;
use fivecal::kinematics::Kinematics;
use fivecal::model::{DriftBasis, Effect};
use fivecal::{Dialect, Machine};
use nalgebra::Vector3;

use crate::cli::{analyze_cmd, fivecal};
use crate::identify::{AC_TRUTH, BC_TRUTH, sphere_poses, stepped_plan, truth_model};
use crate::util::{machine, random_placement, rng, tempdir};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/cmm")
        .join(name)
}

fn points(m: Measurement) -> PointSet {
    match m {
        Measurement::Points(p) => p,
        Measurement::Heights(_) => panic!("expected points"),
    }
}

#[test]
fn dmis_output_with_real_world_quirks_reads_like_the_cmm_meant_it() {
    let p = fixture("quirks.dmo");
    let set = points(read_measurement(&p).unwrap());
    assert_eq!(set.format, "dmis");
    let labels: Vec<&str> = set.points.iter().map(|p| p.label.as_str()).collect();
    // Spheres and cylinders are not plan points; labels broken across lines
    // are joined by raw concatenation.
    assert_eq!(labels, ["P0001", "P0002", "P0003"]);
    assert_eq!(set.points[0].p, Vector3::new(13.89, -4.2917, 39.7539));
    assert_eq!(set.points[1].p, Vector3::new(20.0012, -29.9987, 45.0003));
    assert_eq!(set.points[1].line, 16);
    assert_eq!(set.points[2].p, Vector3::new(1.5, 2.25, -3.0));
    // The nominal with its extra trailing field is read too.
    assert_eq!(set.nominals[0].p, Vector3::new(13.9113, -4.2534, 39.7862));
    // `,$$` continuations are read, and said.
    assert!(
        set.warnings.iter().any(|w| w.contains("`,$$`")),
        "{:?}",
        set.warnings
    );
    // Both spellings of the out-of-tolerance verdict.
    let o = dmis::read(&p).unwrap();
    let v: Vec<(&str, bool)> = o
        .tolerances
        .iter()
        .map(|t| (t.label.as_str(), t.out_of_tolerance))
        .collect();
    assert_eq!(
        v,
        [("P0001_X", false), ("P0002_DN", true), ("P0003_DN", true)]
    );
    assert_eq!(o.tolerances[2].deviation, -0.0601);
}

#[test]
fn dmis_in_inches_and_polar_points_come_out_in_millimetres() {
    let set = points(read_measurement(&fixture("inch.dmo")).unwrap());
    assert!((set.points[0].p - Vector3::new(25.40254, 50.8, 76.20508)).norm() < 1e-9);
    // POL: radius 10 in at 90 deg, height 0.5 in.
    assert!((set.points[1].p - Vector3::new(0.0, 254.0, 12.7)).norm() < 1e-9);
}

#[test]
fn bad_measurement_files_name_the_file_line_and_column() {
    let cases = [
        (
            "nan.dmo",
            "nan.dmo:4:29: expected a finite number for y, got `NaN`",
        ),
        (
            "duplicate.dmo",
            "duplicate.dmo:5:1: FA(P0001) appears twice (first at line 3)",
        ),
        (
            "non-numeric.dmo",
            "non-numeric.dmo:4:29: expected a number for y, got `5.0.1`",
        ),
        (
            "missing-label.csv",
            "missing-label.csv:3:1: missing or invalid label `` (letters, digits, `_`, `.`, `-`)",
        ),
    ];
    for (file, expected) in cases {
        let e = read_measurement(&fixture(file)).unwrap_err().to_string();
        assert!(e.ends_with(expected), "{file}: {e}");
    }
}

#[test]
fn dmis_writer_output_reads_back_exactly() {
    let pts: Vec<DmisPoint> = (0..5)
        .map(|i| {
            let n = Vector3::new(0.0, 0.0, 1.0);
            let p = Vector3::new(i as f64 * 10.0, -5.0, 20.0);
            DmisPoint {
                label: format!("P{i:04}"),
                nominal: (p, n),
                actual: p + n * (0.01 * i as f64 - 0.02),
            }
        })
        .collect();
    let text = dmis::write_output(&pts, &WriteOptions::default());
    let o = dmis::parse(Path::new("w.dmo"), &text).unwrap();
    let m = o.measured_points();
    for (a, b) in pts.iter().zip(&m) {
        assert_eq!(a.label, b.label);
        assert!((a.actual - b.p).norm() < 1e-9);
    }
    // Deviation 0.02 mm against a tolerance of 0.05: in; none out here.
    assert_eq!(o.tolerances.len(), 5);
    assert!(o.tolerances.iter().all(|t| !t.out_of_tolerance));
    assert!((o.tolerances[4].deviation - 0.02).abs() < 1e-9);
}

fn machined_points(seed: u64) -> (PlanPoints, Vec<MeasuredPoint>, nalgebra::Isometry3<f64>) {
    let k = Kinematics::new(&machine("bc-trunnion"));
    let plan = stepped_plan(&k);
    let truth = truth_model(&k, vec![]);
    let mut r = rng(seed);
    let placement = random_placement(&mut r, 1000.0);
    let pts = synthetic::machined(
        &truth,
        &BC_TRUTH,
        &plan,
        &HashMap::new(),
        0.35,
        &placement,
        &mut r,
    );
    (plan, pts, placement)
}

fn labeled(pts: Vec<MeasuredPoint>) -> PointSet {
    PointSet {
        format: "csv",
        points: pts,
        labeled: true,
        nominals: Vec::new(),
        warnings: Vec::new(),
    }
}

#[test]
fn a_file_from_a_different_plan_is_refused() {
    let (plan, mut pts, _) = machined_points(1);
    pts[5].label = "Q9999".into();
    pts[5].line = 7;
    let e = join(
        &plan,
        TestKind::Machining,
        &HashMap::new(),
        &[("m.csv".into(), labeled(pts))],
        &|p| p.p,
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.starts_with("m.csv:7:1: label `Q9999` is not a point of the plan"),
        "{e}"
    );
    assert!(e.contains("different plan"), "{e}");
    // DMIS nominals that are not the plan's: another plan's CMM program.
    let (plan, pts, _) = machined_points(2);
    let mut set = labeled(pts);
    set.nominals = plan
        .points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let shift = if i == 10 { 0.5 } else { 0.0 };
            dmis::Nominal {
                label: p.label.clone(),
                p: p.p + Vector3::new(shift, 0.0, 0.0),
                n: Some(p.n),
                line: 100 + i,
            }
        })
        .collect();
    let e = join(
        &plan,
        TestKind::Machining,
        &HashMap::new(),
        &[("m.dmo".into(), set)],
        &|p| p.p,
    )
    .unwrap_err()
    .to_string();
    assert!(e.starts_with("m.dmo:110:1: the nominal of"), "{e}");
    // Unlabelled points that do not fit the piece.
    let (_, pts, _) = machined_points(3);
    let other = synthetic::stepped_square(
        &Kinematics::new(&machine("bc-trunnion")),
        &[0.0],
        &[0.0, 90.0],
        40.0,
    );
    let mut set = labeled(pts);
    set.labeled = false;
    let e = join(
        &other,
        TestKind::Machining,
        &HashMap::new(),
        &[("plain.txt".into(), set)],
        &|p| p.p,
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("plain.txt") && e.contains("different plan"),
        "{e}"
    );
    let _ = plan;
}

#[test]
fn a_plain_cmm_export_is_joined_by_nearest_nominal_point_with_a_warning() {
    let (plan, pts, _) = machined_points(4);
    // Written as a plain export: x y z per line, shuffled order, no labels.
    let mut lines: Vec<String> = pts
        .iter()
        .map(|p| format!("{:.5} {:.5} {:.5}", p.p.x, p.p.y, p.p.z))
        .collect();
    lines.reverse();
    let src = lines.join("\n") + "\n";
    let set = points(parse_measurement(Path::new("export.txt"), &src).unwrap());
    assert_eq!(set.format, "plain");
    let data = join(
        &plan,
        TestKind::Machining,
        &HashMap::new(),
        &[("export.txt".into(), set)],
        &|p| p.p,
    )
    .unwrap();
    assert!(
        data.warnings.iter().any(|w| w.contains("no labels")),
        "{:?}",
        data.warnings
    );
    // Every point found its own plan point.
    let n = pts.len();
    for (k, o) in data.obs.iter().enumerate() {
        assert_eq!(plan.points[o.plan].label, pts[n - 1 - k].label);
    }
}

/// A cloud `x y z i j k` as a CMM exports it: each direction the plan
/// normal as the piece lies on the CMM. The directions confirm the faces
/// the nearest-nominal join chose; one turned onto a neighbouring face is
/// refused at its line.
#[test]
fn a_point_cloud_with_directions_joins_only_onto_faces_its_directions_agree_with() {
    let (plan, pts, placement) = machined_points(5);
    let normal = |label: &str| {
        let p = plan.points.iter().find(|q| q.label == label).unwrap();
        placement.rotation * p.n
    };
    let line = |p: &MeasuredPoint, n: Vector3<f64>| {
        format!(
            "{:.5} {:.5} {:.5} {:.6} {:.6} {:.6}",
            p.p.x, p.p.y, p.p.z, n.x, n.y, n.z
        )
    };
    let lines: Vec<String> = pts.iter().map(|p| line(p, normal(&p.label))).collect();
    let read = |lines: &[String]| {
        let set =
            points(parse_measurement(Path::new("cloud.txt"), &(lines.join("\n") + "\n")).unwrap());
        join(
            &plan,
            TestKind::Machining,
            &HashMap::new(),
            &[("cloud.txt".into(), set)],
            &|p| p.p,
        )
    };
    let data = read(&lines).unwrap();
    assert!(
        data.warnings
            .iter()
            .any(|w| w.contains("every point's direction agrees with its plan point's normal")),
        "{:?}",
        data.warnings
    );
    for (k, o) in data.obs.iter().enumerate() {
        assert_eq!(plan.points[o.plan].label, pts[k].label);
    }
    // The seventh point's direction at right angles to its face.
    let mut bent = lines.clone();
    let n = normal(&pts[6].label);
    let side = n.cross(&Vector3::new(0.3, 0.5, 0.8)).normalize();
    bent[6] = line(&pts[6], side);
    let e = read(&bent).unwrap_err().to_string();
    assert!(
        e.starts_with(&format!(
            "cloud.txt:7:1: the point's direction ({:.4}, {:.4}, {:.4}) is 90.0 deg from the normal of plan point `{}`",
            side.x, side.y, side.z, pts[6].label
        )),
        "{e}"
    );
}

#[test]
fn nine_section_statistics_reproduce_seed_004_table_4() {
    let before = "section,height_um\n1,0\n2,-5\n3,-9\n4,-11\n5,-15\n6,-9\n7,-10\n8,-15\n9,-15\n";
    let after = "section,height_um\n1,0\n2,2\n3,2\n4,2\n5,-1\n6,-2\n7,-1\n8,-3\n9,0\n";
    let b = NineSection::new(&heights::parse(Path::new("b.csv"), before).unwrap());
    let a = NineSection::new(&heights::parse(Path::new("a.csv"), after).unwrap());
    let close = |x: f64, y: f64| (x - y).abs() < 5e-5;
    assert!(
        close(b.avg_um, -9.8889) && close(b.max_um, 15.0) && close(b.rms_um, 10.9697),
        "{b:?}"
    );
    assert!(
        close(a.avg_um, -0.1111) && close(a.max_um, 3.0) && close(a.rms_um, 1.7321),
        "{a:?}"
    );
    let r = a.improvement_over(&b).map(Option::unwrap);
    assert!(
        (r[0] - 98.88).abs() < 0.005 && (r[1] - 80.0).abs() < 1e-9 && (r[2] - 84.21).abs() < 0.005,
        "{r:?}"
    );
    // A piece that was flat before has no rate of improvement, rather
    // than an infinite one.
    let flat = "section,height_um\n1,0\n2,0\n3,0\n4,0\n5,0\n6,0\n7,0\n8,0\n9,0\n";
    let f = NineSection::new(&heights::parse(Path::new("f.csv"), flat).unwrap());
    assert_eq!(a.improvement_over(&f), [None, None, None]);
}

/// A plan directory as `fivecal plan` writes it: the machine file copy,
/// the points, a manifest.
pub fn plan_dir(
    dir: &Path,
    test: &str,
    kind: TestKind,
    machine_name: &str,
    plan: &PlanPoints,
) -> PathBuf {
    plan_dir_with(dir, test, kind, machine_name, plan, "# synthetic\n")
}

/// [`plan_dir`] with the template copy's text.
pub fn plan_dir_with(
    dir: &Path,
    test: &str,
    kind: TestKind,
    machine_name: &str,
    plan: &PlanPoints,
    template: &str,
) -> PathBuf {
    let m = Machine::builtin(machine_name).unwrap();
    let src = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join(format!("examples/machines/{machine_name}.yaml")),
    )
    .unwrap();
    std::fs::write(dir.join(format!("{test}.machine.yaml")), src).unwrap();
    std::fs::write(dir.join(format!("{test}.template.yaml")), template).unwrap();
    std::fs::write(
        dir.join(format!("{test}.points.csv")),
        plan.to_csv(&["synthetic"]),
    )
    .unwrap();
    let mut poses: Vec<PoseEntry> = Vec::new();
    for p in &plan.points {
        if !poses.iter().any(|q| q.pose == p.pose) {
            poses.push(PoseEntry {
                pose: p.pose.clone(),
                seq: p.seq,
                tilt: p.tilt,
                c: p.c,
                start_min: 2.0 * p.seq as f64,
                end_min: 2.0 * p.seq as f64 + 1.5,
            });
        }
    }
    let manifest = Manifest {
        fivecal_plan: 1,
        test: test.parse().unwrap(),
        kind,
        machine: m.name.clone(),
        machine_file: format!("{test}.machine.yaml").into(),
        template_file: format!("{test}.template.yaml").into(),
        dialect: Dialect::Fanuc,
        kinematics: KinematicsMode::Post,
        tool: (kind == TestKind::Machining).then(|| m.tool.clone()),
        probe: (kind == TestKind::Probing).then(|| m.probe.clone()),
        files: [(
            "points".to_string(),
            PathBuf::from(format!("{test}.points.csv")),
        )]
        .into_iter()
        .collect(),
        poses,
        identifies: None,
        suggestions: Vec::new(),
    };
    let path = dir.join(format!("{test}.plan.yaml"));
    std::fs::write(&path, manifest.to_yaml()).unwrap();
    path
}

fn write_dmis(path: &Path, plan: &PlanPoints, pts: &[MeasuredPoint]) {
    let dp: Vec<DmisPoint> = pts
        .iter()
        .zip(&plan.points)
        .map(|(m, p)| DmisPoint {
            label: m.label.clone(),
            nominal: (p.p, p.n),
            actual: m.p,
        })
        .collect();
    std::fs::write(path, dmis::write_output(&dp, &WriteOptions::default())).unwrap();
}

#[test]
fn analyze_a_stepped_square_from_dmis_end_to_end() {
    let dir = tempdir();
    let (plan, pts, _) = machined_points(21);
    let manifest = plan_dir(
        dir.path(),
        "stepped-square",
        TestKind::Machining,
        "bc-trunnion",
        &plan,
    );
    let measured = dir.path().join("piece1.dmo");
    write_dmis(&measured, &plan, &pts);
    let out = dir.path().join("result.yaml");
    let report = dir.path().join("report");
    let o = analyze_cmd(&manifest, &measured, &out)
        .arg("--report")
        .arg(&report)
        .args(["--maps", "EBB(B)"])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let text = String::from_utf8(o).unwrap();
    assert!(
        text.contains("identifiability:") && !text.contains("pose quality"),
        "{text}"
    );
    assert!(text.contains("residuals by pose and face"), "{text}");
    // The result is an error file the foundation reads back, every symbol
    // with its uncertainty, within four of them of the truth.
    let k = Kinematics::new(&machine("bc-trunnion"));
    let l = ErrorFile::load(&out, &k).unwrap();
    let (f, _) = ErrorFile::read(&out).unwrap();
    let names: Vec<&str> = f.location_errors.keys().map(|s| s.as_str()).collect();
    assert_eq!(
        names,
        [
            "EX0B", "EZ0B", "EA0B", "EC0B", "EB0B", "EX(0B)C", "EY0C", "EA(0B)C"
        ]
    );
    for (i, t) in BC_TRUTH.iter().enumerate() {
        let u = l.u[i].unwrap();
        assert!(
            (l.theta[i] - t).abs() < 4.0 * u,
            "{}: {} ({u}) vs {t}",
            names[i],
            l.theta[i]
        );
    }
    assert!(f.position_dependent.contains_key("EBB(B)"));
    assert!(f.not_identifiable.iter().any(|n| n.symbol == "EZ0C"));
    assert!(l.noise.cmm.is_some_and(|s| (s - 0.35).abs() < 0.1));
    for name in [
        "index.html",
        "location-um.svg",
        "location-urad.svg",
        "map-EBB_B_.svg",
        "residuals.svg",
        "piece.glb",
        "pose-B0C0.svg",
    ] {
        assert!(report.join(name).exists(), "{name} missing");
    }
    let html = std::fs::read_to_string(report.join("index.html")).unwrap();
    assert!(html.contains("<img src=\"pose-Bm90C0.svg\"") && html.contains("EA(0B)C"));
    // The same as JSON, by the two-stage method.
    let outj = dir.path().join("result.json");
    analyze_cmd(&manifest, &measured, &outj)
        .args(["--json", "--method", "two-stage"])
        .assert()
        .success();
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&outj).unwrap()).unwrap();
    assert!(j["location_errors"]["EX0B"]["u"].as_f64().unwrap() > 0.0);
}

#[test]
fn analyze_refuses_bad_input_with_file_and_line_and_writes_nothing() {
    let dir = tempdir();
    let (plan, mut pts, _) = machined_points(22);
    let manifest = plan_dir(
        dir.path(),
        "stepped-square",
        TestKind::Machining,
        "bc-trunnion",
        &plan,
    );
    pts[3].label = "Z0001".into();
    let measured = dir.path().join("other.csv");
    std::fs::write(&measured, measured::to_csv(&pts, &[])).unwrap();
    let out = dir.path().join("result.yaml");
    let e = analyze_cmd(&manifest, &measured, &out)
        .assert()
        .code(2)
        .get_output()
        .stderr
        .clone();
    let e = String::from_utf8(e).unwrap();
    assert!(
        e.contains("other.csv:5:1: label `Z0001` is not a point of the plan"),
        "{e}"
    );
    assert!(!out.exists());
    // Never overwrite an input.
    analyze_cmd(&manifest, &measured, &measured)
        .assert()
        .code(2)
        .stderr(predicates::str::contains(
            "refusing to overwrite input file",
        ));
}

/// A stepped-square plan directory on `bc-trunnion` and the DMIS files of
/// `n` pieces machined one after the other while the B axis rises 6 um in Z
/// per piece, each placed at random up to `offset` mm from the CMM origin
/// (seeds from `seed`).
fn drifting_pieces(dir: &Path, n: u64, seed: u64, offset: f64) -> (PathBuf, Vec<PathBuf>) {
    let k = Kinematics::new(&machine("bc-trunnion"));
    let plan = stepped_plan(&k);
    let manifest = plan_dir(
        dir,
        "stepped-square",
        TestKind::Machining,
        "bc-trunnion",
        &plan,
    );
    let truth = truth_model(&k, vec![]);
    let mut files = Vec::new();
    for piece in 0..n {
        let mut theta = BC_TRUTH;
        theta[1] += 6.0 * piece as f64;
        let mut r = rng(seed + piece);
        let placement = random_placement(&mut r, offset);
        let pts = synthetic::machined(
            &truth,
            &theta,
            &plan,
            &HashMap::new(),
            0.35,
            &placement,
            &mut r,
        );
        let f = dir.join(format!("piece{}.dmo", piece + 1));
        write_dmis(&f, &plan, &pts);
        files.push(f);
    }
    (manifest, files)
}

#[test]
fn series_of_pieces_shows_a_thermal_drift_of_ez0b() {
    // Three pieces machined one after the other while the B axis drifts
    // 6 um in Z per piece (Ibaraki & Ota 2014, section 5.4).
    let dir = tempdir();
    let (manifest, files) = drifting_pieces(dir.path(), 3, 300, 500.0);
    let out = dir.path().join("series.yaml");
    fivecal()
        .args(["analyze", "--plan"])
        .arg(&manifest)
        .arg("--measured")
        .args(&files)
        .arg("--out")
        .arg(&out)
        .arg("--series")
        .assert()
        .success();
    let s: serde_yaml::Value =
        serde_yaml::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let ez = &s["location_errors"]["EZ0B"];
    let slope = ez["trend_per_piece"]["value"].as_f64().unwrap();
    let u = ez["trend_per_piece"]["u"].as_f64().unwrap();
    assert!((slope - 6.0).abs() < 4.0 * u, "slope {slope} ({u})");
    let ex = &s["location_errors"]["EX0B"]["trend_per_piece"];
    assert!(ex["value"].as_f64().unwrap().abs() < 4.0 * ex["u"].as_f64().unwrap());
    for k in 1..=3 {
        assert!(dir.path().join(format!("series.{k}.yaml")).exists());
    }
}

/// `--compare` sets an earlier result beside the new one: both values with
/// their u, and the change from the earlier one with the combined u. Two
/// pieces of the same plan, the B axis 6 um higher in Z on the second.
#[test]
fn compare_shows_the_change_from_an_earlier_result() {
    let dir = tempdir();
    let (manifest, files) = drifting_pieces(dir.path(), 2, 400, 300.0);
    let before = dir.path().join("before.yaml");
    analyze_cmd(&manifest, &files[0], &before)
        .assert()
        .success();
    let after = dir.path().join("after.yaml");
    let a = analyze_cmd(&manifest, &files[1], &after)
        .arg("--compare")
        .arg(&before)
        .assert()
        .success();
    let text = String::from_utf8(a.get_output().stdout.clone()).unwrap();
    let table = &text[text.find("comparison with").expect("a comparison")..];
    let header = table.lines().nth(1).unwrap();
    assert!(header.trim_end().ends_with("change"), "{table}");
    assert!(!table.contains("trend"), "{table}");
    let load = |p: &Path| ErrorFile::read(p).unwrap().0.location_errors;
    let (b, f) = (load(&before), load(&after));
    for (sym, q) in &f {
        let row = table
            .lines()
            .find(|l| l.split_whitespace().next() == Some(sym.as_str()))
            .unwrap_or_else(|| panic!("no row for {sym}: {table}"));
        // The last cell is `+d.dd (u.uu)`.
        let cells: Vec<&str> = row.split_whitespace().collect();
        let change: f64 = cells[cells.len() - 2].parse().unwrap();
        let expected = q.value - b[sym].value;
        assert!((change - expected).abs() < 0.006, "{sym}: {row}");
    }
    let ez = table.lines().find(|l| l.starts_with("EZ0B")).unwrap();
    let cells: Vec<&str> = ez.split_whitespace().collect();
    let change: f64 = cells[cells.len() - 2].parse().unwrap();
    let u: f64 = cells[cells.len() - 1]
        .trim_matches(|c| c == '(' || c == ')')
        .parse()
        .unwrap();
    assert!((change - 6.0).abs() < 4.0 * u, "EZ0B change {change} ({u})");
}

#[test]
fn sphere_test_on_ac_trunnion_from_the_command_line() {
    let dir = tempdir();
    let k = Kinematics::with_gauge_length(&machine("ac-trunnion"), 110.0);
    let centre = Vector3::new(120.0, -40.0, 60.0);
    let plan = synthetic::sphere_plan(&k, &centre, 15.0, &sphere_poses());
    let truth = truth_model(&k, vec![]);
    let pts = synthetic::probed_sphere(&truth, &AC_TRUTH, &plan, &centre, 15.0, 0.35, &mut rng(8));
    let manifest = plan_dir_with(
        dir.path(),
        "probe-sphere",
        TestKind::Probing,
        "ac-trunnion",
        &plan,
        fivecal::procedure::probing::sphere::BUILTIN_TEMPLATE,
    );
    let measured = dir.path().join("sphere.csv");
    std::fs::write(
        &measured,
        measured::to_csv(&pts, &["contact points, W at rotary zero"]),
    )
    .unwrap();
    let out = dir.path().join("result.yaml");
    let o = analyze_cmd(&manifest, &measured, &out)
        .args(["--mc", "6"])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let text = String::from_utf8(o).unwrap();
    assert!(
        text.contains("method sphere") && text.contains("monte carlo: 6 runs"),
        "{text}"
    );
    // This plan directory has no template to rebuild the plan from: the
    // study falls back to the rigid-pose model and says so.
    assert!(
        text.contains("not the simulator: the plan cannot be rebuilt"),
        "{text}"
    );
    let l = ErrorFile::load(&out, &k).unwrap();
    // Six runs of a study with the probing contributors put some u above
    // the usefulness threshold: those values are listed as seen, but not
    // usefully; together they are every symbol the test identifies.
    let (file, _) = ErrorFile::read(&out).unwrap();
    let mut names = l.model.param_names();
    names.extend(file.seen_not_usefully.iter().map(|n| n.symbol.clone()));
    let order = [
        "EY0A", "EZ0A", "EB0A", "EC0A", "EA0A", "EY(0A)C", "EX0C", "EB(0A)C",
    ];
    names.sort_by_key(|n| order.iter().position(|o| o == n));
    assert_eq!(
        names,
        [
            "EY0A", "EZ0A", "EB0A", "EC0A", "EA0A", "EY(0A)C", "EX0C", "EB(0A)C"
        ]
    );
    for (i, name) in l.model.param_names().iter().enumerate() {
        let t = AC_TRUTH[order.iter().position(|o| o == name).unwrap()];
        let u = l.u[i].unwrap();
        assert!(
            u > 0.0 && (l.theta[i] - t).abs() < 50.0,
            "{name}: {} ({u})",
            l.theta[i]
        );
    }
}

#[test]
fn nine_section_heights_from_the_command_line() {
    let dir = tempdir();
    let plan_dir = dir.path().join("nine");
    fivecal()
        .args(["plan", "nine-section", "--machine", "ac-trunnion", "--out"])
        .arg(&plan_dir)
        .assert()
        .success();
    let manifest = plan_dir.join("nine-section.plan.yaml");
    let h = dir.path().join("heights.csv");
    std::fs::write(
        &h,
        "section,height_um\n1,0\n2,-5\n3,-9\n4,-11\n5,-15\n6,-9\n7,-10\n8,-15\n9,-15\n",
    )
    .unwrap();
    let out = dir.path().join("nine.yaml");
    analyze_cmd(&manifest, &h, &out)
        .assert()
        .success()
        .stdout(predicates::str::contains(
            "AVG -9.8889 um, MAX 15.0000 um, RMS 10.9697 um",
        ));
    assert!(std::fs::read_to_string(&out).unwrap().contains("rms_um"));
}

#[test]
fn drift_per_pose_is_identified_by_the_rigid_pose_model() {
    // A thermal drift of EZ0B per cut (Ibaraki & Ota 2014, section 5.4) is constant
    // within each pose, so the foundation model serves it exactly.
    let k = Kinematics::new(&machine("bc-trunnion"));
    let plan = stepped_plan(&k);
    let mut model = truth_model(&k, vec![]);
    model.push(Effect::Drift {
        symbol: 1,
        basis: DriftBasis::Seq,
    });
    let mut theta = BC_TRUTH.to_vec();
    theta.push(1.5);
    let mut r = rng(5);
    let pl = random_placement(&mut r, 300.0);
    let pts = synthetic::machined(&model, &theta, &plan, &HashMap::new(), 0.0, &pl, &mut r);
    let data = join(
        &plan,
        TestKind::Machining,
        &HashMap::new(),
        &[("d.csv".into(), labeled(pts))],
        &|p| p.p,
    )
    .unwrap();
    let setup = fivecal::identify::Setup {
        model: model.clone(),
        constraints: nalgebra::DMatrix::zeros(0, model.n_params()),
        constraint_names: vec![],
    };
    let fm = fivecal::identify::forward::RigidPoseMachining::new(model).unwrap();
    let est = fivecal::identify::global::identify(&fm, &setup, &data, &Default::default()).unwrap();
    assert!((est.theta[8] - 1.5).abs() < 1e-6, "{}", est.summary());
}

#[test]
fn the_sample_data_in_examples_analyze_returns_its_truth() {
    // `examples/analyze/` (planned by `fivecal plan`, measured by `fivecal
    // simulate` with `truth.yaml`) is what the README points newcomers to.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/analyze");
    let dir = tempdir();
    for (test, file, machine_name, maps) in [
        ("stepped-square", "piece1.dmo", "bc-trunnion", "EBB(B)"),
        ("probe-sphere", "PROBE.TXT", "ac-trunnion", ""),
    ] {
        let out = dir.path().join(format!("{test}.yaml"));
        let mut cmd = fivecal();
        cmd.args(["analyze", "--plan"])
            .arg(root.join(test).join(format!("{test}.plan.yaml")))
            .arg("--measured")
            .arg(root.join(test).join(file))
            .arg("--out")
            .arg(&out);
        if !maps.is_empty() {
            cmd.args(["--maps", maps]);
        }
        cmd.assert().success();
        let k = Kinematics::new(&machine(machine_name));
        let got = ErrorFile::load(&out, &k).unwrap();
        let truth = ErrorFile::load(&root.join(test).join("truth.yaml"), &k).unwrap();
        assert_eq!(got.model.param_names(), truth.model.param_names());
        for i in 0..got.theta.len() {
            let u = got.u[i].unwrap();
            assert!(
                (got.theta[i] - truth.theta[i]).abs() < 4.0 * u,
                "{test} {}: {} ({u}) vs {}",
                got.model.param_names()[i],
                got.theta[i],
                truth.theta[i]
            );
        }
    }
}

/// The planner's own stepped square (issue 3): `fivecal plan`, then a piece
/// machined with the eight errors and a B-axis map, measured in DMIS, then
/// `fivecal analyze` on the plan directory as written.
#[test]
fn analyze_measures_of_a_plan_written_by_fivecal_plan() {
    let dir = tempdir();
    let plan_dir = dir.path().join("ss");
    fivecal()
        .args([
            "plan",
            "stepped-square",
            "--machine",
            "bc-trunnion",
            "--out",
        ])
        .arg(&plan_dir)
        .assert()
        .success();
    let manifest = plan_dir.join("stepped-square.plan.yaml");
    let plan = PlanPoints::read(&plan_dir.join("stepped-square.points.csv")).unwrap();
    let k = Kinematics::new(&machine("bc-trunnion"));
    let sym = fivecal::model::Model::new(k.clone(), vec![]).symbols;
    let grid = fivecal::kinematics::maps::MapGrid {
        dims: vec![fivecal::kinematics::maps::MapDim::new(0, &[-90.0, 0.0, 90.0], false).unwrap()],
    };
    let truth = truth_model(
        &k,
        vec![Effect::Map {
            symbol: sym.map_index("EBB(B)").unwrap(),
            grid,
        }],
    );
    let mut theta = BC_TRUTH.to_vec();
    theta.extend([30.0, -8.0, -22.0]);
    let mut r = rng(77);
    let placement = random_placement(&mut r, 700.0);
    let pts = synthetic::machined(
        &truth,
        &theta,
        &plan,
        &HashMap::new(),
        0.35,
        &placement,
        &mut r,
    );
    let measured = dir.path().join("piece.dmo");
    write_dmis(&measured, &plan, &pts);
    let out = dir.path().join("result.yaml");
    for method in ["global", "two-stage"] {
        analyze_cmd(&manifest, &measured, &out)
            .args(["--maps", "EBB(B)", "--method", method])
            .assert()
            .success();
        let l = ErrorFile::load(&out, &k).unwrap();
        let names = l.model.param_names();
        assert_eq!(names.len(), 11);
        for i in 0..11 {
            let u = l.u[i].unwrap();
            assert!(
                (l.theta[i] - theta[i]).abs() < 4.0 * u,
                "{method} {}: {} ({u}) vs {}",
                names[i],
                l.theta[i],
                theta[i]
            );
        }
    }
}

/// The planner's nine-section piece (Cubas Brizuela & Yeh 2023, section 6) machined with
/// location errors and measured on a CMM in DMIS: the section heights are
/// the deviations along the nominal directions relative to section 1,
/// whatever the CMM alignment.
#[test]
fn nine_section_heights_from_the_cmm_output_of_a_planned_piece() {
    let dir = tempdir();
    let plan_dir = dir.path().join("nine");
    fivecal()
        .args(["plan", "nine-section", "--machine", "ac-trunnion", "--out"])
        .arg(&plan_dir)
        .assert()
        .success();
    let plan = PlanPoints::read(&plan_dir.join("nine-section.points.csv")).unwrap();
    let k = Kinematics::new(&machine("ac-trunnion"));
    let truth = truth_model(&k, vec![]);
    let mut r = rng(9);
    // The independent computation: the model's deviation of each point
    // along its normal, in W, averaged per section.
    let exact = synthetic::machined(
        &truth,
        &AC_TRUTH,
        &plan,
        &HashMap::new(),
        0.0,
        &nalgebra::Isometry3::identity(),
        &mut r,
    );
    let mut per: Vec<(String, f64, usize)> = Vec::new();
    for (m, p) in exact.iter().zip(&plan.points) {
        let d = p.n.dot(&(m.p - p.p)) * 1e3;
        match per.iter_mut().find(|x| x.0 == p.pose) {
            Some(x) => {
                x.1 += d;
                x.2 += 1;
            }
            None => per.push((p.pose.clone(), d, 1)),
        }
    }
    let want: Vec<f64> = per
        .iter()
        .map(|x| x.1 / x.2 as f64 - per[0].1 / per[0].2 as f64)
        .collect();
    assert!(
        want.iter().any(|h| h.abs() > 1.0),
        "the errors should show: {want:?}"
    );
    // Measured on a CMM whose alignment puts the piece anywhere.
    let placement = random_placement(&mut r, 400.0);
    let pts = synthetic::machined(
        &truth,
        &AC_TRUTH,
        &plan,
        &HashMap::new(),
        0.0,
        &placement,
        &mut r,
    );
    let dp: Vec<DmisPoint> = pts
        .iter()
        .zip(&plan.points)
        .map(|(m, p)| DmisPoint {
            label: m.label.clone(),
            nominal: (
                (placement * nalgebra::Point3::from(p.p)).coords,
                placement.rotation * p.n,
            ),
            actual: m.p,
        })
        .collect();
    let measured = dir.path().join("nine.dmo");
    std::fs::write(
        &measured,
        dmis::write_output(
            &dp,
            &WriteOptions {
                decimals: 6,
                ..Default::default()
            },
        ),
    )
    .unwrap();
    let out = dir.path().join("nine.yaml");
    fivecal()
        .args(["analyze", "--plan"])
        .arg(plan_dir.join("nine-section.plan.yaml"))
        .arg("--measured")
        .arg(&measured)
        .arg("--out")
        .arg(&out)
        .assert()
        .success()
        .stdout(predicates::str::contains("AVG"));
    let v: serde_yaml::Value =
        serde_yaml::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let sections = &v["pieces"][0]["sections"];
    for (i, h) in want.iter().enumerate() {
        assert_eq!(sections[i]["section"].as_u64(), Some(i as u64 + 1));
        let got = sections[i]["height_um"].as_f64().unwrap();
        // The DMIS file keeps six decimals of a mm: 0.5 nm per coordinate.
        assert!((got - h).abs() < 0.01, "section {}: {got} vs {h}", i + 1);
    }
}

/// The planner's own sphere test on `ac-trunnion` (issue 4's
/// `probing::sphere::plan`, Cubas Brizuela & Yeh's (2023) 36 + 13 positions): the touches as
/// the FANUC program logs them (ball centres, DPRNT), read through the
/// probe-log reader against the plan, identified by the sphere method.
#[test]
fn sphere_test_of_a_probing_plan_from_its_fanuc_probe_log() {
    use fivecal::formats::probe_log::fanuc;
    use fivecal::procedure::probing::sphere::{BUILTIN_TEMPLATE as BUILTIN_SPHERE, SphereTemplate};
    let m = machine("ac-trunnion");
    let t = SphereTemplate::builtin();
    let pplan = fivecal::procedure::probing::sphere::touch_plan(&m, &t).unwrap();
    let plan = pplan.points();
    let k = &pplan.kin;
    let centre = fivecal::procedure::probing::sphere::sphere_centre(&m, &t);
    let truth = truth_model(k, vec![]);
    let mut r = rng(31);
    let contacts = synthetic::probed_sphere(
        &truth,
        &AC_TRUTH,
        &plan,
        &centre,
        t.diameter / 2.0,
        0.35,
        &mut r,
    );
    // The controller logs the ball centre: contact + radius along the
    // touch's normal in program coordinates.
    let ball = m.probe.ball_diameter / 2.0;
    let mut log = String::from("%\nFIVECAL PROBE-SPHERE\n");
    for (c, p) in contacts.iter().zip(&plan.points) {
        let n = k.nominal_table_transform(p.tilt, p.c).rotation * p.n;
        let b = c.p + n * ball;
        let index = plan.points.iter().position(|q| q.label == p.label).unwrap() + 1;
        log += &(fanuc::touch_line(index, &b, fanuc::Prt::Spaces) + "\n");
    }
    log += "%\n";
    let dir = tempdir();
    let manifest = plan_dir_with(
        dir.path(),
        "probe-sphere",
        TestKind::Probing,
        "ac-trunnion",
        &plan,
        BUILTIN_SPHERE,
    );
    let measured = dir.path().join("PROBE.TXT");
    std::fs::write(&measured, log).unwrap();
    let out = dir.path().join("result.yaml");
    analyze_cmd(&manifest, &measured, &out)
        .assert()
        .success()
        .stdout(predicates::str::contains("method sphere"));
    let l = ErrorFile::load(&out, k).unwrap();
    for (i, t) in AC_TRUTH.iter().enumerate() {
        let u = l.u[i].unwrap();
        assert!(
            (l.theta[i] - t).abs() < 4.0 * u,
            "{}: {} ({u}) vs {t}",
            l.model.param_names()[i],
            l.theta[i]
        );
    }
}

/// The planner's three-column probing test on `ac-trunnion` (Ibaraki, Iritani & Matsushita's (2013)
/// stations): contact points as CSV, identified by the two-stage and the
/// global method with the columns set up 0.1 mm off.
#[test]
fn column_probing_of_a_probing_plan_by_both_methods() {
    use fivecal::procedure::probing::columns::{
        BUILTIN_TEMPLATE as BUILTIN_COLUMNS, ColumnsTemplate,
    };
    let m = machine("ac-trunnion");
    let pplan =
        fivecal::procedure::probing::columns::touch_plan(&m, &ColumnsTemplate::builtin()).unwrap();
    let plan = pplan.points();
    let k = &pplan.kin;
    let truth = truth_model(k, vec![]);
    let mut r = rng(32);
    // Each column clamped on its own, a tenth of a millimetre off.
    let mut setups: HashMap<String, nalgebra::Isometry3<f64>> = HashMap::new();
    for t in &pplan.touches {
        let k = setups.len() as f64;
        setups.entry(t.piece.clone()).or_insert_with(|| {
            nalgebra::Isometry3::new(
                Vector3::new(0.06 - 0.05 * k, -0.08 + 0.07 * k, 0.1 - 0.04 * k),
                Vector3::new(1e-4 * (k - 1.0), -2e-4 + 1e-4 * k, 1e-4),
            )
        });
    }
    assert_eq!(setups.len(), 3, "three columns");
    let piece: HashMap<String, String> = pplan
        .touches
        .iter()
        .map(|t| (t.label.clone(), t.piece.clone()))
        .collect();
    let pts = synthetic::probed_with(
        &truth,
        &AC_TRUTH,
        &plan,
        &HashMap::new(),
        0.35,
        &|p| setups[&piece[&p.label]],
        &mut r,
    );
    let dir = tempdir();
    let manifest = plan_dir_with(
        dir.path(),
        "probe-columns",
        TestKind::Probing,
        "ac-trunnion",
        &plan,
        BUILTIN_COLUMNS,
    );
    let measured = dir.path().join("columns.csv");
    std::fs::write(&measured, measured::to_csv(&pts, &[])).unwrap();
    let out = dir.path().join("result.yaml");
    for method in ["two-stage", "global"] {
        let o = analyze_cmd(&manifest, &measured, &out)
            .args(["--method", method])
            .assert()
            .success()
            .get_output()
            .stdout
            .clone();
        let text = String::from_utf8_lossy(&o);
        if method == "two-stage" {
            assert!(
                text.contains("Ibaraki, Iritani & Matsushita 2013"),
                "{text}"
            );
        }
        let l = ErrorFile::load(&out, k).unwrap();
        for (i, t) in AC_TRUTH.iter().enumerate() {
            let u = l.u[i].unwrap();
            assert!(
                (l.theta[i] - t).abs() < 4.0 * u,
                "{method} {}: {} ({u}) vs {t}",
                l.model.param_names()[i],
                l.theta[i]
            );
        }
    }
}
