//! Error files as a user writes them: the full example, what each entry
//! does to the model, the round trip, and the messages for bad files.

use std::path::{Path, PathBuf};

use fivecal::errorfile::{ErrorFile, LoadedErrors};
use fivecal::kinematics::Kinematics;
use fivecal::model::Context;
use fivecal::{Axes, Machine};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/errors")
        .join(name)
}

fn load(name: &str, machine: &str) -> Result<LoadedErrors, String> {
    let k = Kinematics::new(&Machine::builtin(machine).unwrap());
    ErrorFile::load(&fixture(name), &k).map_err(|e| e.to_string())
}

#[test]
fn full_example_sets_the_canonical_terms() {
    let l = load("bc-full.yaml", "bc-trunnion").unwrap();
    let names = l.model.param_names();
    assert_eq!(
        &names[..8],
        [
            "EX0B", "EZ0B", "EA0B", "EC0B", "EB0B", "EX(0B)C", "EY0C", "EA(0B)C"
        ]
    );
    assert_eq!(l.u[0], Some(0.4));
    assert_eq!(l.u[1], None);
    assert_eq!(l.noise.cmm, Some(0.35));
    // At B = C = 0, seq 0, time 0: the location errors alone (maps are zero
    // at B = 0 for EBB and 2.0 um at (0, 0) for EXC).
    let ctx = Context::at(Axes::new(0.0, 0.0, 0.0, 0.0, 0.0));
    let p = l.model.perturbation(&l.theta, &ctx);
    let close = |a: f64, b: f64| (a - b).abs() < 1e-15;
    assert!(close(p.0[0], 12.0e-3), "dx_BY = EX0B");
    assert!(close(p.0[2], -25.0e-3), "dz_BY = EZ0B");
    assert!(
        close(p.0[4], 0.0) && close(p.0[6 + 4], 55.0e-6),
        "EB0B goes to b_CB"
    );
    assert!(
        close(p.0[1], 0.0) && close(p.0[6 + 1], 3.0e-3),
        "EY0C goes to dy_CB"
    );
    assert!(
        close(p.0[6], 8.0e-3 + 6.0e-3),
        "dx_CB = EX(0B)C + EXC(B=0, C=0)"
    );
    // The C nodes were given as -90, 0, 90, 180: C = 270 is the -90 column.
    let ctx = Context::at(Axes::new(0.0, 0.0, 0.0, -90.0, 270.0));
    let p = l.model.perturbation(&l.theta, &ctx);
    assert!(close(p.0[6], 8.0e-3 + 1.0e-3));
    assert!(close(p.0[4], 30.0e-6), "EBB(B=-90) on b_BY");
    // Drift: EZ0B grows by 1.5 um per pose, EY0C by 0.2 um per minute.
    let ctx = Context {
        seq: 4.0,
        minutes: 10.0,
        ..Context::at(Axes::default())
    };
    let p = l.model.perturbation(&l.theta, &ctx);
    assert!(close(p.0[2], (-25.0 + 6.0) * 1e-3));
    assert!(close(p.0[6 + 1], (3.0 + 2.0) * 1e-3));
    // Scale and squareness act on the slides at the commanded position.
    let ctx = Context::at(Axes::new(100.0, 50.0, -20.0, 0.0, 0.0));
    let p = l.model.perturbation(&l.theta, &ctx);
    let lin = p.linear();
    assert!(
        (lin.x - (4.0 * 0.1 - 15.0 * 50e-3) * 1e-3).abs() < 1e-15,
        "EXX * x - EC(0X)Y * y"
    );
    assert!(
        (lin.y - (-(-8.0) * -20e-3 + 0.0) * 1e-3).abs() < 1e-15,
        "-EA(0Y)Z * z + EYX(100) = 0"
    );
    assert!((lin.z - (-3.0 * -0.02) * 1e-3).abs() < 1e-15, "EZZ * z");
}

#[test]
fn round_trip_through_yaml_and_json_returns_what_went_in() {
    let l = load("bc-full.yaml", "bc-trunnion").unwrap();
    let written = ErrorFile::from_model(&l.model, &l.theta, &l.u, &l.noise);
    let k = l.model.kin.clone();
    for text in [written.to_yaml(), written.to_json()] {
        let back = ErrorFile::parse(Path::new("round-trip"), &text).unwrap();
        assert_eq!(back, written);
        let l2 = back.to_model(&k, Path::new("round-trip"), &text).unwrap();
        assert_eq!(l2.theta, l.theta);
        assert_eq!(l2.u, l.u);
        assert_eq!(l2.model.param_names(), l.model.param_names());
        assert_eq!(l2.noise, l.noise);
    }
}

#[test]
fn unknown_symbol_is_rejected_at_its_line() {
    let e = load("unknown-symbol.yaml", "bc-trunnion").unwrap_err();
    assert!(
        e.contains("unknown-symbol.yaml:4:3: unknown symbol `EX0Q`"),
        "{e}"
    );
    assert!(
        e.contains("EX0B, EZ0B, EA0B, EC0B, EB0B, EX(0B)C, EY0C, EA(0B)C"),
        "{e}"
    );
}

#[test]
fn non_identifiable_symbol_is_rejected_with_the_reason() {
    let e = load("not-identifiable.yaml", "bc-trunnion").unwrap_err();
    assert!(
        e.contains("not-identifiable.yaml:4:3: `EZ(0B)C` is not identifiable"),
        "{e}"
    );
    assert!(
        e.contains("dz_CB moves the C axis along its own direction"),
        "{e}"
    );
}

#[test]
fn map_symbol_under_location_errors_says_where_it_belongs() {
    let e = load("map-as-location.yaml", "bc-trunnion").unwrap_err();
    assert!(
        e.contains(":3:3:") && e.contains("belongs under position_dependent"),
        "{e}"
    );
}

#[test]
fn file_for_another_machine_is_refused() {
    let e = load("wrong-machine.yaml", "bc-trunnion").unwrap_err();
    assert!(e.contains("wrong-machine.yaml:1:1: error file is for machine `ac-trunnion` but the machine in use is `bc-trunnion`"), "{e}");
}

#[test]
fn map_with_a_short_row_names_the_expected_shape() {
    let e = load("bad-map-shape.yaml", "bc-trunnion").unwrap_err();
    assert!(
        e.contains("bad-map-shape.yaml:6:5: ECC(B,C): values must be 3 rows of 4 numbers"),
        "{e}"
    );
}

#[test]
fn misspelt_section_and_non_numeric_value_are_syntax_errors_with_position() {
    let e = load("unknown-key.yaml", "bc-trunnion").unwrap_err();
    assert!(
        e.contains("unknown-key.yaml:4:1: unknown field `efects`"),
        "{e}"
    );
    let e = load("non-numeric.yaml", "bc-trunnion").unwrap_err();
    assert!(
        e.contains("non-numeric.yaml:3:") && e.contains("expected a number"),
        "{e}"
    );
}
