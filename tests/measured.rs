//! Measurement files as real CMM software writes them, read from fixtures
//! the team wrote from the public specifications (each imitates a real
//! public file named in its comments) and from real public files whose
//! licence lets them be committed (`tests/fixtures/measured/real/`); every
//! value asserted here was read by hand from the file. `fivecal measured` shows what a file
//! holds before any plan is involved.

use std::path::{Path, PathBuf};

use fivecal::formats::detect::{self, Measurement, PointSet, ReadContext};
use fivecal::formats::inventory::Inventory;
use nalgebra::Vector3;

use crate::cli::fivecal;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/measured")
        .join(name)
}

fn inventory(name: &str) -> Inventory {
    detect::inventory(&fixture(name), &ReadContext::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn points(name: &str) -> PointSet {
    match detect::read_measurement(&fixture(name)).unwrap_or_else(|e| panic!("{e}")) {
        Measurement::Points(p) => p,
        Measurement::Heights(_) => panic!("expected points"),
    }
}

fn close(a: Option<Vector3<f64>>, b: [f64; 3], tol: f64) -> bool {
    a.is_some_and(|a| (a - Vector3::from(b)).norm() < tol)
}

#[test]
fn dmis_wrapped_at_a_byte_count_reads_as_the_writer_meant_it() {
    let inv = inventory("wrapped.dmo");
    assert_eq!(inv.format, "dmis");
    assert_eq!(inv.version.as_deref(), Some("04.0"));
    let labels: Vec<&str> = inv.entries.iter().map(|e| e.label.as_str()).collect();
    // Non-ASCII labels, `_` and `-` as separators in one file.
    assert_eq!(
        labels,
        [
            "Punto_\u{e1}1",
            "SP_00",
            "SP-01",
            "C\u{ed}rculo_13",
            "SP_00_DN"
        ]
    );
    let p = &inv.entries[0];
    // The nominal wrapped inside `0.0$`/`464` and carrying an extra field.
    assert!(close(p.nominal, [10.8494, 0.5135, 41.0631], 1e-12));
    assert!(close(p.actual, [10.8501, 0.5139, 41.0644], 1e-12));
    // The 4-decimal normal renormalized: |(0.9806, 0.0464, 0.1907)| = 1.0000479.
    assert!(close(p.normal, [0.980553, 0.046398, 0.190691], 1e-6));
    // Spaces around every token and empty i,j,k in the actual: the
    // nominal's direction stands in.
    let sp = &inv.entries[1];
    assert!(close(sp.actual, [23.0389, -12.7569, 40.3647], 1e-12));
    assert!(close(sp.normal, [-0.443145, -0.685769, 0.577358], 1e-6));
    // A circle wrapped inside its normal, with its diameter.
    let c = &inv.entries[3];
    assert_eq!(c.kind, "circle");
    assert_eq!(c.value, Some(14.9137));
    // TA(SP_00_DN) answers T(SP_00_PROFP): kept by its own label.
    assert_eq!(inv.entries[4].kind, "tol/profp");
    assert_eq!(inv.entries[4].value, Some(-0.0544));
    // The cylinder without a position is skipped, and said.
    assert_eq!(inv.skipped.len(), 1);
    assert_eq!(inv.skipped[0].line, 20);
    assert!(inv.skipped[0].why.contains("without a position"));
    let w = inv.warnings.join("\n");
    assert!(w.contains("line 10: a line starting with `,`"), "{w}");
    assert!(w.contains("1 UTF-8 characters were split"), "{w}");
    // What analyze reads: the three points, by label.
    let set = points("wrapped.dmo");
    assert_eq!(set.points.len(), 3);
    assert!(set.labeled);
}

#[test]
fn a_dmis_program_given_as_a_measurement_says_what_it_is() {
    let e = detect::read_measurement(&fixture("program.dmi"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("program.dmi: this is a DMIS program, not DMIS output"),
        "{e}"
    );
}

#[test]
fn malformed_dmis_points_name_line_column_and_what_was_expected() {
    let cases = [
        (
            "UNITS/MM,ANGDEC\nFA(P1)=FEAT/POINT,CART,1,,3\n",
            "m.dmo:2:26: expected a number for y, got ``",
        ),
        (
            "UNITS/MM,ANGDEC\nFA(P1)=FEAT/POINT,CART,1,2,3,0,$\n0\n",
            "m.dmo:2:30: a point carries x,y,z or x,y,z,i,j,k; got 5 numbers",
        ),
        (
            "UNITS/MM,ANGDEC\nFA(P1)=FEAT/POINT,INNER,1,2,3\n",
            "m.dmo:2:19: expected CART or POL after FEAT/POINT, got `INNER`",
        ),
    ];
    for (src, expected) in cases {
        let e = detect::parse_measurement(Path::new("m.dmo"), src)
            .unwrap_err()
            .to_string();
        assert_eq!(e, expected);
    }
}

#[test]
fn measured_command_shows_a_file_before_any_plan() {
    let out = fivecal()
        .args(["measured", "--json"])
        .arg(fixture("wrapped.dmo"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["format"], "dmis");
    assert_eq!(v["units"], "mm");
    let p = &v["points"][2];
    assert_eq!(p["label"], "SP-01");
    assert_eq!(p["nominal"], serde_json::json!([13.9113, -4.2534, 39.7862]));
    assert_eq!(p["actual"], serde_json::json!([13.89, -4.2917, 39.7539]));
    assert_eq!(v["skipped"][0]["line"], 20);
    let out = fivecal()
        .arg("measured")
        .arg(fixture("wrapped.dmo"))
        .output()
        .unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.starts_with("format   dmis 04.0\nunits    mm"),
        "{text}"
    );
    assert!(
        text.contains("skipped  line 20: F(Upper_Cylinder)"),
        "{text}"
    );
    let out = fivecal()
        .arg("measured")
        .arg(fixture("program.dmi"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("this is a DMIS program"));
}

#[test]
fn qif_results_join_names_nominals_and_point_sets_per_run() {
    let inv = inventory("results.qif");
    assert_eq!(inv.format, "qif");
    assert_eq!(inv.version.as_deref(), Some("3.0.0"));
    assert_eq!(inv.units, "mm");
    assert_eq!(
        inv.runs,
        [
            "SN-1 (MeasurementResults id 100)",
            "SN-2 (MeasurementResults id 300)"
        ]
    );
    let get = |run: usize, label: &str| {
        inv.entries
            .iter()
            .find(|e| e.run == run && e.label == label)
            .unwrap_or_else(|| panic!("{label} in run {run}"))
    };
    // The id chain: measurement 101 -> item 21 (P0001) -> nominal 11.
    let p1 = get(0, "P0001");
    assert!(close(p1.nominal, [10.0, 20.0, 30.0], 1e-12));
    assert!(close(p1.actual, [10.002, 20.001, 29.998], 1e-12));
    assert!(close(p1.normal, [0.0, 0.0, 1.0], 1e-12));
    // No Location: the probe centre 42.503 of set 201, compensated by the
    // 2.5 mm ProbeRadius against the nominal normal +x: 40.003.
    assert!(close(get(0, "P0002").actual, [40.003, 20.0, 30.0], 1e-12));
    // Run 2 takes point 2 of set 401 by index: 42.497 - 2.5 = 39.997.
    assert!(close(get(1, "P0002").actual, [39.997, 20.001, 30.0], 1e-12));
    // The circle's range "2 3" picks two of its four points (the comment
    // inside <Points> is not a number); its diameter is kept as a value.
    let c = get(0, "C1");
    assert_eq!(c.points.len(), 2);
    assert!(close(Some(c.points[0]), [0.0, 6.05, 0.0], 1e-12));
    assert_eq!(c.value, Some(12.0915));
    // A characteristic is reported with its value, not turned into a point.
    let d = get(0, "DIAM1");
    assert_eq!(d.kind, "diameter (characteristic)");
    assert_eq!((d.value, d.actual), (Some(12.0915), None));
    // A reference to a point set that is not there is skipped, and said.
    assert!(inv.skipped[0].why.contains("MeasuredPointSet id 105"));

    // What analyze reads: one run at a time.
    let e = detect::read_measurement(&fixture("results.qif"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("holds 2 measurement runs") && e.contains("--run N"),
        "{e}"
    );
    let ctx = ReadContext {
        options: detect::MeasuredOptions {
            run: Some(2),
            ..Default::default()
        },
        ..Default::default()
    };
    let Measurement::Points(set) =
        detect::read_measurement_in(&fixture("results.qif"), &ctx).unwrap()
    else {
        panic!("points")
    };
    let labels: Vec<&str> = set.points.iter().map(|p| p.label.as_str()).collect();
    assert_eq!(labels, ["P0001", "P0002"]);
}

#[test]
fn qif_files_that_cannot_be_read_say_why_and_where() {
    let parse = |src: &str| {
        detect::parse_measurement(Path::new("r.qif"), src)
            .unwrap_err()
            .to_string()
    };
    let head = "<?xml version=\"1.0\"?>\n<QIFDocument xmlns=\"http://qifstandards.org/xsd/qif3\" versionQIF=\"3.0.0\">\n";
    let feature = "<Results><MeasurementResultsSet n=\"1\"><MeasurementResults id=\"1\"><MeasuredFeatures n=\"1\">\n<PointFeatureMeasurement id=\"2\">\n<Location>1 2 x</Location>\n</PointFeatureMeasurement></MeasuredFeatures></MeasurementResults></MeasurementResultsSet></Results>\n</QIFDocument>\n";
    let units = "<FileUnits><PrimaryUnits><LinearUnit><SIUnitName>meter</SIUnitName><UnitName>mm</UnitName></LinearUnit></PrimaryUnits></FileUnits>\n";
    assert_eq!(
        parse(&format!("{head}{units}{feature}")),
        "r.qif:6:1: <Location>: expected numbers, got `x`"
    );
    // Without units, coordinates are refused unless the user names them.
    let e = parse(&format!("{head}{}", feature.replace("1 2 x", "1 2 3")));
    assert!(
        e.starts_with("r.qif:4:1: the file states no length unit") && e.contains("--units"),
        "{e}"
    );
    // Not well-formed XML: line and column of the parser.
    let e = parse(&format!("{head}<Results>\n  <Oops></Results>\n"));
    assert!(
        e.starts_with("r.qif:4:") && e.contains("not well-formed XML"),
        "{e}"
    );
    // A plan, and results kept in another file.
    let e = parse(&format!("{head}<MeasurementPlan/></QIFDocument>\n"));
    assert!(e.contains("nothing measured: this is a QIF plan"), "{e}");
    let e = parse(&format!(
        "{head}<ExternalQIFReferences n=\"1\"><ExternalQIFDocument id=\"1\"><URI>./plan.QIF</URI></ExternalQIFDocument></ExternalQIFReferences>\n<Results><MeasurementResultsSet n=\"1\"><MeasurementResults id=\"2\"/></MeasurementResultsSet></Results></QIFDocument>\n"
    ));
    assert!(
        e.contains("the results are kept in another QIF file (./plan.QIF)"),
        "{e}"
    );
}

#[test]
fn tables_with_a_header_and_point_clouds_read_by_column_name() {
    // Semicolons, decimal commas, columns in any order, an ignored column:
    // as a spreadsheet in a German shop exports a CMM's points.
    let inv = inventory("points-de.csv");
    assert_eq!(inv.format, "table");
    let e = &inv.entries[1];
    assert_eq!(e.label, "P0002");
    assert!(close(e.actual, [20.0012, -29.9987, 45.0003], 1e-12));
    assert!(close(e.nominal, [20.0, -30.0, 45.0], 1e-12));
    assert!(close(e.normal, [0.0, -1.0, 0.0], 1e-12));
    assert_eq!(inv.skipped[0].what, "columns Abw");
    // A point cloud x y z i j k without labels: joined by nearest nominal.
    let set = points("cloud.txt");
    assert!(!set.labeled);
    assert_eq!(set.points.len(), 3);
    assert_eq!(set.points[2].p, Vector3::new(1.5, 2.25, -3.0));
    // Its directions travel with the points to the join, where they are
    // checked against the faces the points land on.
    assert_eq!(set.points[2].normal, Some(Vector3::new(0.0, 0.0, -1.0)));
    assert!(close(
        inventory("cloud.txt").entries[1].normal,
        [1.0, 0.0, 0.0],
        1e-15
    ));
    let e = detect::parse_measurement(Path::new("t.csv"), "x;y;z\n1;2\n")
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "t.csv:2:4: expected a value for column `z`, the line has 2 fields"
    );
}

#[test]
fn legacy_encodings_are_named_or_read_when_given() {
    let dir = crate::util::tempdir();
    let p = dir.path().join("latin1.csv");
    std::fs::write(&p, b"label;x;y;z\nP\xfcnkt1;1;2;3\n").unwrap();
    let out = fivecal().arg("measured").arg(&p).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("latin1.csv:2:2: not UTF-8 (byte 0xFC)") && err.contains("Windows-1252"),
        "{err}"
    );
    let out = fivecal()
        .args(["measured", "--json", "--encoding", "windows-1252"])
        .arg(&p)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["points"][0]["label"], "P\u{fc}nkt1");
}

/// A CALYPSO `_fet` table as the public readers of CALYPSO tables read it
/// (columns found by name: `id`, `idsymbol`, `x y z`, `nx ny nz`, `x_nom
/// y_nom z_nom`, `nx_nom ny_nom nz_nom`, `unit`), CRLF, a header ending in a
/// tab, a row shorter than the header.
#[test]
fn calypso_features_give_positions_nominals_and_directions() {
    let inv = inventory("run_fet.txt");
    assert_eq!(
        (inv.format, inv.version.as_deref(), inv.units.as_str()),
        ("calypso", Some("fet"), "mm")
    );
    assert_eq!(inv.runs, ["STEPPED_SQUARE part 3"]);
    let labels: Vec<(&str, &str)> = inv
        .entries
        .iter()
        .map(|e| (e.label.as_str(), e.kind.as_str()))
        .collect();
    assert_eq!(
        labels,
        [
            ("P0001", "point"),
            ("P0002", "point"),
            ("Kreis_B", "circle"),
            ("P0003", "point")
        ]
    );
    let p1 = &inv.entries[0];
    assert!(close(p1.actual, [-20.0012, -30.0004, 45.0021], 1e-12));
    assert!(close(p1.nominal, [-20.0, -30.0, 45.0], 1e-12));
    // The measured direction (0.0001, -1, 0.0002), renormalized.
    let n = 1.0f64 + 0.0001f64.powi(2) + 0.0002f64.powi(2);
    assert!(close(
        p1.normal,
        [0.0001 / n.sqrt(), -1.0 / n.sqrt(), 0.0002 / n.sqrt()],
        1e-15
    ));
    // No measured direction: the nominal's stands in.
    assert!(close(inv.entries[1].normal, [0.0, -1.0, 0.0], 1e-15));
    // The circle is a feature, not a point analyze joins; the row of P0003
    // stops before its position: not measured, and said.
    assert!(close(
        inv.entries[2].actual,
        [0.0003798, 15.2871745, -0.0004345],
        1e-12
    ));
    assert_eq!(inv.entries[3].actual, None);
    assert!(
        inv.skipped
            .iter()
            .any(|s| s.line == 5 && s.what == "feature `P0003`"),
        "{:?}",
        inv.skipped
    );
    let set = points("run_fet.txt");
    let labels: Vec<&str> = set.points.iter().map(|p| p.label.as_str()).collect();
    assert_eq!(labels, ["P0001", "P0002"]);
    assert_eq!(set.nominals.len(), 2);
}

/// A CALYPSO `_chr` table as CALYPSO writes it (the public test file of
/// EricRosenfeld1/CalypsoAPI, `CalypsoAPI.Test/files/test_chr.txt`, has the
/// same header): `type` in German, rows shorter than the header, LF, `END`,
/// no `unit` column. Points come from `xValue`/`yValue`/`zValue`
/// characteristics of one feature.
#[test]
fn calypso_characteristics_are_reported_and_coordinate_triples_become_points() {
    let inv = inventory("run_chr.txt");
    assert_eq!(inv.version.as_deref(), Some("chr"));
    assert_eq!(inv.units, "mm (not stated)");
    assert!(
        inv.warnings[0].contains("no `unit` column"),
        "{:?}",
        inv.warnings
    );
    let d = inv.entries.iter().find(|e| e.label == "Bohrung_D").unwrap();
    assert_eq!((d.kind.as_str(), d.value), ("diameter", Some(23.4009393)));
    assert_eq!(d.actual, None);
    let pts: Vec<_> = inv.entries.iter().filter(|e| e.is_point()).collect();
    assert_eq!(pts.len(), 2, "P0003 has no zValue: no point");
    assert_eq!(pts[0].label, "P0001");
    assert!(close(pts[0].actual, [-20.0012, -30.0004, 45.0021], 1e-12));
    assert!(close(pts[0].nominal, [-20.0, -30.0, 45.0], 1e-12));
    // P0002's zValue comes after another feature's characteristic.
    assert!(close(pts[1].actual, [20.0008, -29.9991, 45.0007], 1e-12));
    // The same table read as an inch program.
    let ctx = ReadContext {
        options: detect::MeasuredOptions {
            units: Some(detect::LengthUnit::Inch),
            ..Default::default()
        },
        ..Default::default()
    };
    let inch = detect::inventory(&fixture("run_chr.txt"), &ctx).unwrap();
    assert!(inch.units.starts_with("inch (given with --units"));
    let p = inch.entries.iter().find(|e| e.is_point()).unwrap();
    assert!(close(
        p.actual,
        [-20.0012 * 25.4, -30.0004 * 25.4, 45.0021 * 25.4],
        1e-9
    ));
}

#[test]
fn a_calypso_run_header_is_named_and_refused_as_a_measurement() {
    let inv = inventory("run_hdr.txt");
    assert_eq!(inv.version.as_deref(), Some("hdr"));
    assert!(inv.entries.is_empty());
    assert!(inv.skipped[0].why.contains("_fet table"));
    let e = detect::read_measurement(&fixture("run_hdr.txt"))
        .unwrap_err()
        .to_string();
    assert!(
        e.ends_with("run_hdr.txt: a CALYPSO run header (_hdr) holds no measurement: the features and their positions are in the run's _fet table, the characteristics in its _chr table"),
        "{e}"
    );
}

#[test]
fn malformed_calypso_tables_name_line_column_and_what_was_expected() {
    let fet = std::fs::read_to_string(fixture("run_fet.txt")).unwrap();
    let parse = |src: &str| {
        detect::parse_measurement(Path::new("r_fet.txt"), src)
            .unwrap_err()
            .to_string()
    };
    assert_eq!(
        parse(&fet.replace("20.0008000", "20.0O08")),
        "r_fet.txt:3:59: column `x`: expected a number with a decimal point, got `20.0O08`"
    );
    // A direction with one component missing.
    assert_eq!(
        parse(&fet.replace("0.0001000\t-1.0000000\t0.0002000", "0.0001000\t\t0.0002000")),
        "r_fet.txt:2:104: expected all of nx, ny, nz or none, `ny` is empty"
    );
    assert_eq!(
        parse(&fet.replace("\tmm\r\n", "\tmm\t\tx\r\n")),
        "r_fet.txt:2:216: expected at most 25 fields (the header's columns), got `x` beyond them"
    );
    assert_eq!(
        parse(
            &fet.replacen("\tmm\r\n", "\tinch\r\n", 1)
                .replace("Kreis_B", "P0001")
        ),
        "r_fet.txt:3:182: unit `mm` here but `inch` at line 2: expected one length unit in a table"
    );
    let chr = std::fs::read_to_string(fixture("run_chr.txt")).unwrap();
    assert_eq!(
        detect::parse_measurement(Path::new("r_chr.txt"), &format!("{chr}P0004_X\n"))
            .unwrap_err()
            .to_string(),
        "r_chr.txt:12:1: expected nothing after the `END` line at line 11"
    );
}

/// A plan of the stepped-square test written by `fivecal plan` and a
/// truth file of location errors for it: (manifest, truth).
fn planned_with_truth(dir: &Path) -> (PathBuf, PathBuf) {
    let manifest =
        crate::analyze_sim::plan_with_cli(&dir.join("plan"), "stepped-square", "bc-trunnion", None);
    let truth = dir.join("truth.yaml");
    std::fs::write(
        &truth,
        format!("machine: bc-trunnion\n{}", crate::analyze_sim::BC_ERRORS),
    )
    .unwrap();
    (manifest, truth)
}

/// A plan of the stepped-square test, its truth, and a simulated
/// measurement as DMIS output with what that file holds.
fn simulated_dmis(dir: &Path) -> (PathBuf, PathBuf, Inventory) {
    let (manifest, truth) = planned_with_truth(dir);
    let dmo = dir.join("piece.dmo");
    crate::analyze_sim::simulate_as(&manifest, &truth, &dmo, 3, None);
    let inv = detect::inventory(&dmo, &ReadContext::default()).unwrap();
    (manifest, dmo, inv)
}

/// `analyze` writes the same result file, byte for byte, from two
/// measurement files of one piece.
fn assert_same_analysis(manifest: &Path, one: &Path, other: &Path, dir: &Path) {
    let (a, b) = (dir.join("one.yaml"), dir.join("other.yaml"));
    crate::cli::analyze_cmd(manifest, one, &a)
        .assert()
        .success();
    crate::cli::analyze_cmd(manifest, other, &b)
        .assert()
        .success();
    let (a, b) = (
        std::fs::read_to_string(a).unwrap(),
        std::fs::read_to_string(b).unwrap(),
    );
    assert!(a.contains("EX0B:"), "{a}");
    assert_eq!(a, b);
}

/// A CALYPSO `_fet` table of the points of `inv`, lengths divided by
/// `per_mm` (25.4 for an inch program), one run per part number, rows
/// ending in CRLF; `unit` names the unit column's value (none: no column).
fn fet_table(inv: &Inventory, parts: &[&str], per_mm: f64, unit: Option<&str>) -> String {
    let mut fet = String::from(
        "planid\tpartnb\tid\ttype\tidsymbol\tx\ty\tz\tnx\tny\tnz\tx_nom\ty_nom\tz_nom\tnx_nom\tny_nom\tnz_nom",
    );
    fet.push_str(if unit.is_some() {
        "\tunit\t\r\n"
    } else {
        "\t\r\n"
    });
    let f = |v: Option<Vector3<f64>>, s: f64| {
        let v = v.unwrap() / s;
        format!("{:.10}\t{:.10}\t{:.10}", v.x, v.y, v.z)
    };
    for part in parts {
        for e in inv.entries.iter().filter(|e| e.is_point()) {
            fet.push_str(&format!(
                "stepped-square\t{part}\t{}\tRaumpunkt\tspacePoint\t{}\t{}\t{}\t{}",
                e.label,
                f(e.actual, per_mm),
                f(e.normal, 1.0),
                f(e.nominal, per_mm),
                f(e.normal, 1.0)
            ));
            if let Some(u) = unit {
                fet.push_str(&format!("\t{u}"));
            }
            fet.push_str("\r\n");
        }
    }
    fet
}

/// The same simulated measurement as DMIS output and as a CALYPSO `_fet`
/// table made from it: `analyze` finds the same errors from both.
#[test]
fn analyze_reads_a_calypso_table_as_it_reads_the_dmis_output() {
    let dir = crate::util::tempdir();
    let (manifest, dmo, inv) = simulated_dmis(dir.path());
    let table = dir.path().join("piece_fet.txt");
    std::fs::write(&table, fet_table(&inv, &["1"], 1.0, Some("mm"))).unwrap();
    assert_same_analysis(&manifest, &dmo, &table, dir.path());
}

/// `--encoding`, `--run` and `--units` reach the readers of `analyze` and
/// `discover` as they reach `fivecal measured`: a CALYPSO table of two
/// parts in an inch program, without a unit column, written by a German
/// Windows (`Länge` in Windows-1252).
#[test]
fn analyze_and_discover_take_the_run_units_and_encoding_of_a_measured_file() {
    let dir = crate::util::tempdir();
    let (manifest, dmo, inv) = simulated_dmis(dir.path());
    let text =
        fet_table(&inv, &["1", "2"], 25.4, None).replace("Raumpunkt", "Raumpunkt L\u{e4}nge");
    let (bytes, _, _) = encoding_rs::WINDOWS_1252.encode(&text);
    let table = dir.path().join("piece_fet.txt");
    std::fs::write(&table, &bytes).unwrap();
    let out = dir.path().join("r.yaml");
    let err = |args: &[&str]| {
        let o = crate::cli::analyze_cmd(&manifest, &table, &out)
            .args(args)
            .assert()
            .failure();
        String::from_utf8_lossy(&o.get_output().stderr).to_string()
    };
    let e = err(&[]);
    assert!(e.contains("not UTF-8") && e.contains("--encoding"), "{e}");
    let e = err(&["--encoding", "windows-1252"]);
    assert!(e.contains("holds 2 measurement runs"), "{e}");
    crate::cli::analyze_cmd(&manifest, &table, &out)
        .args([
            "--encoding",
            "windows-1252",
            "--run",
            "2",
            "--units",
            "inch",
        ])
        .assert()
        .success();
    let reference = dir.path().join("dmis.yaml");
    crate::cli::analyze_cmd(&manifest, &dmo, &reference)
        .assert()
        .success();
    let values = |p: &Path| -> Vec<f64> {
        let v: serde_yaml::Value =
            serde_yaml::from_str(&std::fs::read_to_string(p).unwrap()).unwrap();
        v["location_errors"]
            .as_mapping()
            .unwrap()
            .values()
            .map(|e| e["value"].as_f64().unwrap())
            .collect()
    };
    let (a, b) = (values(&out), values(&reference));
    assert_eq!(a.len(), 8);
    // Inches to 10 decimals are mm to 2.5e-9: the errors (um, urad) agree
    // far below their uncertainty.
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() < 1e-3, "{a:?} {b:?}");
    }
    // discover reads the file through the same flags.
    let o = crate::cli::fivecal()
        .args(["discover", "--plan"])
        .arg(&manifest)
        .arg("--measured")
        .arg(&table)
        .args([
            "--encoding",
            "windows-1252",
            "--units",
            "inch",
            "--run",
            "3",
        ])
        .assert()
        .failure();
    let e = String::from_utf8_lossy(&o.get_output().stderr);
    assert!(
        e.contains("--run 3: the file holds 2 measurement run(s), expected 1 to 2"),
        "{e}"
    );
}

/// The plan's QIF 3 measurement plan and the QIF results `simulate` writes
/// for it: the same features by the same ids and names, each plan point
/// once with its nominal and normal, the plan's steps pose by pose; and
/// `analyze` finds from the QIF results exactly what it finds from the CSV
/// output of the same simulation.
#[test]
fn a_plans_qif_and_its_simulated_qif_results_analyze_as_the_csv_does() {
    let dir = crate::util::tempdir();
    let (manifest, truth) = planned_with_truth(dir.path());
    let (qif, csv) = (dir.path().join("piece.qif"), dir.path().join("piece.csv"));
    crate::analyze_sim::simulate_as(&manifest, &truth, &qif, 9, None);
    crate::cli::fivecal()
        .args(["simulate", "--plan"])
        .arg(&manifest)
        .arg("--errors")
        .arg(&truth)
        .arg("--out")
        .arg(&csv)
        .args(["--seed", "9", "--placement", "aligned"])
        .assert()
        .success();

    let plan_path = dir.path().join("plan/stepped-square.qif");
    let plan_text = std::fs::read_to_string(&plan_path).unwrap();
    let results_text = std::fs::read_to_string(&qif).unwrap();
    let plan = roxmltree::Document::parse(&plan_text).unwrap();
    let results = roxmltree::Document::parse(&results_text).unwrap();
    let items = |d: &roxmltree::Document<'_>| -> Vec<(String, String)> {
        d.descendants()
            .filter(|n| n.has_tag_name("PointFeatureItem"))
            .map(|n| {
                let name = n
                    .children()
                    .find(|c| c.has_tag_name("FeatureName"))
                    .and_then(|c| c.text())
                    .unwrap()
                    .to_string();
                (n.attribute("id").unwrap().to_string(), name)
            })
            .collect()
    };
    let points = fivecal::formats::points::PlanPoints::read(
        &dir.path().join("plan/stepped-square.points.csv"),
    )
    .unwrap();
    let plan_items = items(&plan);
    assert_eq!(plan_items.len(), points.points.len());
    assert_eq!(plan_items, items(&results), "same ids, same names");
    for ((_, name), p) in plan_items.iter().zip(&points.points) {
        assert_eq!(name, &p.label);
    }
    // Each nominal as points.csv gives it (6 decimals, normals 9).
    let nominal = plan
        .descendants()
        .find(|n| n.has_tag_name("PointFeatureNominal"))
        .unwrap();
    let child = |tag: &str| -> Vec<f64> {
        nominal
            .children()
            .find(|c| c.has_tag_name(tag))
            .and_then(|c| c.text())
            .unwrap()
            .split_whitespace()
            .map(|x| x.parse().unwrap())
            .collect()
    };
    let p0 = &points.points[0];
    assert_eq!(child("Location"), [p0.p.x, p0.p.y, p0.p.z]);
    assert_eq!(child("Normal"), [p0.n.x, p0.n.y, p0.n.z]);
    // The plan's steps: one per pose in execution order, every item once.
    let steps: Vec<Vec<String>> = plan
        .descendants()
        .filter(|n| n.has_tag_name("MeasureSpecifiedFeatures"))
        .map(|s| {
            s.descendants()
                .filter(|n| n.has_tag_name("Id"))
                .map(|n| n.text().unwrap().to_string())
                .collect()
        })
        .collect();
    let mut seqs: Vec<u32> = points.points.iter().map(|p| p.seq).collect();
    seqs.dedup();
    assert_eq!(steps.len(), seqs.len());
    let flat: Vec<&String> = steps.iter().flatten().collect();
    let ids: Vec<&String> = plan_items.iter().map(|i| &i.0).collect();
    assert_eq!(flat, ids);

    // The results read back by label with the plan's nominals.
    let inv = detect::inventory(&qif, &ReadContext::default()).unwrap();
    assert_eq!((inv.format, inv.units.as_str()), ("qif", "mm"));
    let e = &inv.entries[0];
    assert_eq!(e.label, p0.label);
    assert!(close(e.nominal, [p0.p.x, p0.p.y, p0.p.z], 0.0 + 1e-12));
    // The plan itself is no measurement.
    let o = crate::cli::analyze_cmd(&manifest, &plan_path, &dir.path().join("x.yaml"))
        .assert()
        .failure();
    assert!(
        String::from_utf8_lossy(&o.get_output().stderr)
            .contains("nothing measured: this is a QIF plan (what to measure), not results"),
    );
    assert_valid_qif(&[&plan_path, &qif]);
    assert_same_analysis(&manifest, &qif, &csv, dir.path());
}

/// Runs `xmllint` against the QIF 3.0 schemas committed under
/// tests/fixtures/qif-xsd (with the catalog that keeps it offline) and
/// returns its verdict and messages.
fn qif_schema_check(files: &[&Path]) -> (bool, String) {
    let xsd = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/qif-xsd");
    let out = std::process::Command::new("xmllint")
        .env("XML_CATALOG_FILES", xsd.join("catalog.xml"))
        .args(["--nonet", "--noout", "--schema"])
        .arg(xsd.join("QIFApplications/QIFDocument.xsd"))
        .args(files)
        .output()
        .expect("xmllint (Debian's libxml2-utils; .ci/run installs it)");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn assert_valid_qif(files: &[&Path]) {
    let (ok, msg) = qif_schema_check(files);
    assert!(ok, "QIF 3.0 schema validation failed:\n{msg}");
}

/// What a CMM importing QIF plans checks first: the files `plan` and
/// `simulate --format qif` write are valid QIF 3.0 documents, for both
/// machining tests and for other machines and dialects; a plan spoiled by
/// one misplaced element is not, so the check can fail.
#[test]
fn qif_plans_and_results_validate_against_the_qif_3_schemas() {
    let dir = crate::util::tempdir();
    crate::cli::fivecal()
        .args(["plan", "nine-section", "--machine", "head-table"])
        .args(["--dialect", "heidenhain", "--out"])
        .arg(dir.path().join("plan"))
        .assert()
        .success();
    let manifest = dir.path().join("plan/nine-section.plan.yaml");
    let plan = dir.path().join("plan/nine-section.qif");
    let results = dir.path().join("sim.qif");
    let truth = dir.path().join("truth.yaml");
    std::fs::write(&truth, "machine: head-table\n").unwrap();
    crate::analyze_sim::simulate_as(&manifest, &truth, &results, 3, None);
    // The real sample files of the QIF community validate too: the check
    // is the schema, not something tuned to what fivecal writes.
    let real = fixture("real/QIF_PTS_SAMPLE.QIF");
    assert_valid_qif(&[&plan, &results, &real]);

    let text = std::fs::read_to_string(&plan).unwrap();
    let spoiled = dir.path().join("spoiled.qif");
    std::fs::write(
        &spoiled,
        text.replacen("<FileUnits>", "<FileUnit>", 1)
            .replacen("</FileUnits>", "</FileUnit>", 1),
    )
    .unwrap();
    let (ok, msg) = qif_schema_check(&[&spoiled]);
    assert!(!ok && msg.contains("FileUnit"), "{msg}");
}

// Real files: the QIF community's own sample files (BSL-1.0; sources in
// tests/fixtures/measured/real/SOURCES.md), every value below read by hand
// at the line named.

/// QIF_PTS_SAMPLE: a QIF 3 results file with raw point sets whose ball
/// centres are not compensated (`Compensated` false, `ProbeRadius`), and
/// whose point features give that same ball centre as their `Location`.
#[test]
fn the_qif_community_point_sample_reads_with_its_ball_centres_compensated() {
    let inv = detect::inventory(&fixture("real/QIF_PTS_SAMPLE.QIF"), &ReadContext::default())
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        (inv.format, inv.version.as_deref(), inv.units.as_str()),
        ("qif", Some("3.0.0"), "mm")
    );
    assert_eq!(inv.runs, ["MeasurementResults id 857"]);
    let get = |label: &str| {
        inv.entries
            .iter()
            .find(|e| e.label == label)
            .unwrap_or_else(|| panic!("{label}"))
    };
    // POINT1: nominal 754 (lines 225-226), ball centre of set 757 (line
    // 1828) with ProbeRadius 2.49978271104 (line 1831), equal to the
    // feature's Location (line 1033).
    let n = Vector3::new(-0.642788056925063, 0.0, 0.766044067841075);
    let centre = Vector3::new(-51.726518705386, 54.198959479609, -1.276811288879);
    let p1 = get("POINT1");
    assert!(close(
        p1.nominal,
        [-50.175094015692, 54.198959479609, -3.125725044257],
        1e-12
    ));
    let surface = centre - n * 2.49978271104;
    assert!(close(p1.actual, surface.into(), 1e-9), "{:?}", p1.actual);
    assert!(close(p1.points.first().copied(), surface.into(), 1e-9));
    assert!(
        inv.warnings
            .iter()
            .any(|w| w
                .starts_with("line 1028: `POINT1` gives its Location as the probe-ball centre")),
        "{:?}",
        inv.warnings
    );
    // POINT3 has no raw points: its Location (line 1045) stays, flagged
    // as 2.4161 mm off its nominal along the normal.
    let p3 = get("POINT3");
    assert!(close(
        p3.actual,
        [-69.387091135231, 46.222132399832, -16.092462288988],
        1e-12
    ));
    assert!(
        inv.warnings
            .iter()
            .any(|w| w.starts_with("line 1042: `POINT3` lies 2.4161 mm"))
    );
    // CIRCLE1: its 219 raw points and diameter 12.095569950907 (line 1025).
    let c1 = get("CIRCLE1");
    assert_eq!((c1.points.len(), c1.value), (219, Some(12.095569950907)));
    // A characteristic keeps its value and invents no coordinates.
    let flat = get("FLATA");
    assert_eq!((flat.value, flat.actual), (Some(0.00676025187), None));
}

/// Six serial numbers measured in one file: six runs, each feature once
/// per run, and `--run` picks one.
#[test]
fn the_qif_community_six_sample_sheet_metal_file_is_six_runs() {
    let path = fixture("real/SheetMetal_QIF_Results_6_samples.QIF");
    let inv = detect::inventory(&path, &ReadContext::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(inv.runs.len(), 6);
    assert_eq!(inv.runs[2], "SN5802803 (MeasurementResults id 321)");
    let edge: Vec<_> = inv
        .entries
        .iter()
        .filter(|e| e.label == "W1RFTMRA02")
        .collect();
    assert_eq!(edge.len(), 6);
    // Run 3, measurement 262 (line 1991) of item 10 -> nominal 9.
    assert_eq!(edge[2].run, 2);
    assert!(close(edge[2].actual, [2460.74, 770.62, 944.97], 1e-12));
    assert!(close(
        edge[2].normal,
        [-0.735465884156764, -0.307902932144901, 0.603560864882807],
        1e-12
    ));
    let e = detect::read_measurement(&path).unwrap_err().to_string();
    assert!(e.contains("holds 6 measurement runs"), "{e}");
}

/// Files that hold no coordinates say so: a pass/fail summary, and results
/// whose features live in another file (characteristic values reported,
/// nothing invented); and a QIF 2 sample with `Location` and `Normal`
/// swapped is refused at the line, not read as a 2.7 m normal.
#[test]
fn real_qif_files_without_coordinates_or_with_swapped_fields_say_so() {
    let e = detect::inventory(
        &fixture("real/mitutoyo_results_serialized_pass_fail_sample.QIF"),
        &ReadContext::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("nothing measured"), "{e}");

    let inv = inventory("real/Exploded_Results1.QIF");
    assert_eq!(inv.units, "none stated");
    let values: Vec<(&str, Option<f64>)> = inv
        .entries
        .iter()
        .map(|e| (e.kind.as_str(), e.value))
        .collect();
    assert_eq!(
        values,
        [
            ("spherical diameter (characteristic)", Some(25.008279671621)),
            ("sphericity (characteristic)", Some(0.251457258827))
        ]
    );
    assert!(
        inv.warnings
            .iter()
            .any(|w| w.contains("./Exploded_Plan.QIF"))
    );

    let e = detect::inventory(
        &fixture("real/2.0_QIF_Results_Sample.QIF"),
        &ReadContext::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.ends_with("2.0_QIF_Results_Sample.QIF:242:9: <Normal> has length 2712.454424: expected a unit vector (length 1 within 0.01); is another quantity, such as a location, written in its place?"),
        "{e}"
    );
}
