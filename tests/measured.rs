//! Measurement files as real CMM software writes them, read from fixtures
//! the team wrote from the public specifications; each fixture imitates a
//! real public file named in its comments, and every value asserted here
//! was read by hand from the fixture. `fivecal measured` shows what a file
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
