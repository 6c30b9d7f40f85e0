use nalgebra::{Point3, Vector3};

use super::*;
use crate::Machine;
use crate::errorfile::{ErrorFile, LoadedErrors};
use crate::machine::Structure;

fn load(machine: &Machine, yaml: &str) -> LoadedErrors {
    load_with(&Kinematics::new(machine), yaml)
}

fn load_with(kin: &Kinematics, yaml: &str) -> LoadedErrors {
    let path = std::path::Path::new("errors.yaml");
    ErrorFile::parse(path, yaml)
        .unwrap()
        .to_model(kin, path, yaml)
        .unwrap()
}

fn builtin(name: &str) -> Machine {
    Machine::builtin(name).unwrap()
}

fn run(machine: &Machine, yaml: &str, d: Dialect) -> Result<Export, ExportError> {
    let e = load(machine, yaml);
    export(
        &e.model,
        &e.theta,
        &e.u,
        d,
        "errors.yaml",
        &Limits::default(),
    )
}

fn value(x: &Export, name: &str) -> f64 {
    x.parameters
        .iter()
        .find(|p| p.name == name)
        .unwrap_or_else(|| panic!("no {name} in {}", x.text))
        .value
}

fn param<'a>(x: &'a Export, name: &str) -> &'a Parameter {
    x.parameters.iter().find(|p| p.name == name).unwrap()
}

const BC: &str = "machine: bc-trunnion\nlocation_errors:\n  EX0B: {value: 12.0, u: 0.4}\n  EZ0B: {value: -25.0, u: 0.5}\n  EA0B: {value: 80.0, u: 2.0}\n  EC0B: {value: -60.0, u: 2.0}\n  EB0B: {value: 150.0, u: 3.0}\n  EX(0B)C: {value: 25.0, u: 0.6}\n  EY0C: {value: -18.0, u: 0.7}\n  EA(0B)C: {value: 45.0, u: 2.5}\n";

#[test]
fn the_zero_points_are_the_angular_positions_of_each_machine() {
    for (name, zeros) in [
        ("bc-trunnion", vec!["EB0B"]),
        ("ac-trunnion", vec!["EA0A"]),
        ("head-table", vec!["EB0B"]),
        ("head-head", vec!["EC0C", "EA0A"]),
    ] {
        let k = Kinematics::new(&builtin(name));
        let s = crate::kinematics::symbols::SymbolTable::for_kinematics(&k);
        let mut got: Vec<&str> = s
            .location
            .iter()
            .filter(|l| l.is_zero_point())
            .map(|l| l.name.as_str())
            .collect();
        got.sort();
        let mut want = zeros.clone();
        want.sort();
        assert_eq!(got, want, "{name}");
    }
}

#[test]
fn positions_alone_give_the_closed_form_pivot_data_of_a_trunnion() {
    // Pure position errors move the axis lines by exactly those amounts.
    let m = builtin("bc-trunnion");
    let yaml = "machine: bc-trunnion\nlocation_errors: {EX0B: 12.0, EZ0B: -25.0, EX(0B)C: 25.0, EY0C: -18.0}\n";
    let f = run(&m, yaml, Dialect::Fanuc).unwrap();
    for (name, want) in [
        ("19700", 0.012),
        ("19701", -0.018),
        ("19702", -420.025),
        ("19703", 0.025),
        ("19704", 0.0),
        ("19705", 0.0),
    ] {
        assert!((value(&f, name) - want).abs() < 1e-9, "{name}: {}", f.text);
    }
    let l = run(&m, yaml, Dialect::Linuxcnc).unwrap();
    for (name, want) in [
        ("x-rot-point", 0.037),
        ("y-rot-point", -0.018),
        ("z-rot-point", -420.025),
        ("x-offset", -0.025),
        ("z-offset", 0.0),
    ] {
        assert!((value(&l, name) - want).abs() < 1e-9, "{name}: {}", l.text);
    }
    let h = run(&m, yaml, Dialect::Heidenhain).unwrap();
    for (name, want) in [
        ("B.X", 0.012),
        ("B.Z", -420.025),
        ("C.X", 0.025),
        ("C.Y", -0.018),
    ] {
        assert!((value(&h, name) - want).abs() < 1e-9, "{name}: {}", h.text);
    }
    // Incremental: the rows get the change, the absolute value is only a comment.
    assert!(
        h.text.contains("ADD +0.01200 TO Trans X before MachAxis B"),
        "{}",
        h.text
    );
    assert!(
        h.text
            .contains("ADD -0.01800 TO Trans Y between MachAxis B and MachAxis C"),
        "{}",
        h.text
    );
    assert!(
        h.text.contains("INCREMENTAL entries, never absolute"),
        "{}",
        h.text
    );
}

#[test]
fn the_exported_points_lie_on_the_axes_the_kinematic_chain_turns_about() {
    // Independent of the axis-line construction: a table point on the C
    // axis stays where it is when C turns, a point on the tilt axis when
    // the tilt turns (the chain's own transforms, all errors at work).
    for name in ["bc-trunnion", "ac-trunnion"] {
        let m = builtin(name);
        let yaml = BC
            .replace("bc-trunnion", name)
            .replace(
                "EX0B",
                if name == "ac-trunnion" {
                    "EY0A"
                } else {
                    "EX0B"
                },
            )
            .replace(
                "EZ0B",
                if name == "ac-trunnion" {
                    "EZ0A"
                } else {
                    "EZ0B"
                },
            )
            .replace(
                "EA0B",
                if name == "ac-trunnion" {
                    "EB0A"
                } else {
                    "EA0B"
                },
            )
            .replace(
                "EC0B",
                if name == "ac-trunnion" {
                    "EC0A"
                } else {
                    "EC0B"
                },
            )
            .replace(
                "EB0B",
                if name == "ac-trunnion" {
                    "EA0A"
                } else {
                    "EB0B"
                },
            )
            .replace(
                "EX(0B)C",
                if name == "ac-trunnion" {
                    "EY(0A)C"
                } else {
                    "EX(0B)C"
                },
            )
            .replace(
                "EY0C",
                if name == "ac-trunnion" {
                    "EX0C"
                } else {
                    "EY0C"
                },
            )
            .replace(
                "EA(0B)C",
                if name == "ac-trunnion" {
                    "EB(0A)C"
                } else {
                    "EA(0B)C"
                },
            );
        let e = load(&m, &yaml);
        // Zero points are not part of the lines, and the controls hold
        // positions only (with the axes' nominal directions): take the
        // angles out of the chain.
        let mut theta = e.theta.clone();
        for (i, n) in e.model.param_names().iter().enumerate() {
            let symbol = n.rsplit(':').next().unwrap_or(n).trim();
            if !(symbol.starts_with("EX") || symbol.starts_with("EY") || symbol.starts_with("EZ")) {
                theta[i] = 0.0;
            }
        }
        let f = export(
            &e.model,
            &theta,
            &e.u,
            Dialect::Fanuc,
            "e",
            &Limits::default(),
        )
        .unwrap();
        let a = Vector3::new(value(&f, "19700"), value(&f, "19701"), value(&f, "19702"));
        let b = a + Vector3::new(value(&f, "19703"), value(&f, "19704"), value(&f, "19705"));
        let p = e.model.perturbation(&theta, &Context::default());
        let kin = &e.model.kin;
        // Machine point of a table point at (tilt, c), relative to the pivot.
        let at =
            |t: f64, c: f64, q: &Point3<f64>| (kin.table_transform(t, c, &p) * q).coords + m.pivot;
        let table = |t: f64, c: f64, x: &Vector3<f64>| {
            kin.table_transform(t, c, &p).inverse() * Point3::from(x - m.pivot)
        };
        let qc = table(0.0, 0.0, &b);
        for c in [90.0, 200.0] {
            let d = (at(0.0, c, &qc) - b).norm();
            assert!(d < 2e-7, "{name}: C point moves {d} mm when C turns");
        }
        let qt = table(0.0, 0.0, &a);
        for t in [-60.0, 45.0] {
            let d = (at(t, 0.0, &qt) - a).norm();
            assert!(
                d < 2e-7,
                "{name}: tilt point moves {d} mm when the tilt turns"
            );
        }
    }
}

#[test]
fn every_value_carries_its_u_and_its_change() {
    let m = builtin("bc-trunnion");
    let f = run(&m, BC, Dialect::Fanuc).unwrap();
    // 19700 X is EX0B alone, 19701 Y is EY0C alone: their u is the symbol's.
    assert!((param(&f, "19700").u.unwrap() - 0.4e-3).abs() < 1e-6);
    assert!((param(&f, "19701").u.unwrap() - 0.7e-3).abs() < 1e-6);
    assert!((param(&f, "19703").u.unwrap() - 0.6e-3).abs() < 1e-6);
    // (The axis tilts move the feet of the common perpendicular by nanometres.)
    assert!((param(&f, "19700").change() - 0.012).abs() < 1e-5);
    for line in [
        "19700",
        "+0.01200 mm",
        "+12.00 um",
        "0.40 um",
        "change: from the machine file's nominal geometry",
    ] {
        assert!(f.text.contains(line), "`{line}` missing:\n{}", f.text);
    }
    let h = run(&m, BC, Dialect::Heidenhain).unwrap();
    // The orientations go to the builder with their own u: the B axis
    // turned about X by EA0B, C by EA0B + EA(0B)C.
    let ba = param(&h, "B.A");
    assert!((ba.value - 80.0).abs() < 0.01 && (ba.u.unwrap() - 2.0).abs() < 1e-3);
    let ca = param(&h, "C.A");
    assert!((ca.value - 125.0).abs() < 0.01 && (ca.u.unwrap() - 4.5).abs() < 1e-3);
    // The zero of B is no direction of C: no error held moves C's
    // direction about Y, and its 0 is a convention, not a measured 0 with
    // a u of 0.
    let cb = param(&h, "C.B");
    assert!(cb.value.abs() < 0.01 && cb.fixed, "{}", h.text);
    assert!(!ba.fixed && !ca.fixed);
    assert!(
        h.text
            .contains("C.B = +0.00, fixed: no error held here moves it"),
        "{}",
        h.text
    );
    assert!(!h.text.contains("u 0.00 urad"), "{}", h.text);
    assert!(h.text.contains("EB0B = 150.00 urad"), "{}", h.text);
    // A truth file (no u) says so instead of inventing one.
    let t = run(
        &m,
        "machine: bc-trunnion\nlocation_errors: {EX0B: 12.0}\n",
        Dialect::Fanuc,
    )
    .unwrap();
    assert_eq!(param(&t, "19700").u, None);
    assert!(t.text.contains("not given"), "{}", t.text);
}

#[test]
fn a_map_adds_nothing_to_the_pivot_data() {
    let m = builtin("bc-trunnion");
    let plain = "machine: bc-trunnion\nlocation_errors: {EX0B: 12.0, EB0B: 150.0}\n";
    let mapped = format!(
        "{plain}position_dependent:\n  EBB(B): {{B: [-90, 0, 90], values: [38.79, -9.59, -29.2]}}\n  EXC(B,C): {{B: [0], C: [0, 90, 180, 270], values: [[2, -1, -2, 1]]}}\n"
    );
    for d in [Dialect::Fanuc, Dialect::Heidenhain, Dialect::Linuxcnc] {
        let a = run(&m, plain, d).unwrap();
        let b = run(&m, &mapped, d).unwrap();
        for (p, q) in a.parameters.iter().zip(&b.parameters) {
            assert!(
                (p.value - q.value).abs() < 1e-12,
                "{d} {}: {} vs {}",
                p.name,
                p.value,
                q.value
            );
        }
        assert!(b.text.contains("map.EBB(B)"), "{}", b.text);
    }
}

#[test]
fn a_head_keeps_its_pivot_length_error() {
    // EZ0B, the height of the B head's line above the tool tip, is a
    // position of the head's axis from the tool reference point.
    let m = builtin("head-table");
    let yaml = "machine: head-table\nlocation_errors: {EX0B: {value: 8.0, u: 0.3}, EZ0B: {value: 25.0, u: 0.5}, EX0C: 5.0, EY0C: -4.0}\n";
    let f = run(&m, yaml, Dialect::Fanuc).unwrap();
    assert!((value(&f, "19709") - 0.008).abs() < 1e-9, "{}", f.text);
    assert!((value(&f, "19711") - 0.025).abs() < 1e-9, "{}", f.text);
    assert!((param(&f, "19711").u.unwrap() - 0.5e-3).abs() < 1e-6);
    assert!((value(&f, "19700") - (m.pivot.x + 0.005)).abs() < 1e-9);
    let h = run(&m, yaml, Dialect::Heidenhain).unwrap();
    assert!(
        (value(&h, "B.Z") - (m.pivot_length + 0.025)).abs() < 1e-9,
        "{}",
        h.text
    );
    assert!((param(&h, "B.Z").nominal - m.pivot_length).abs() < 1e-12);
    // The same machine with a longer tool: the same parameters.
    let e = load_with(&Kinematics::with_gauge_length(&m, 150.0), yaml);
    for d in [Dialect::Fanuc, Dialect::Heidenhain] {
        let long = export(&e.model, &e.theta, &e.u, d, "e", &Limits::default()).unwrap();
        let short = run(&m, yaml, d).unwrap();
        for (p, q) in long.parameters.iter().zip(&short.parameters) {
            assert!(
                (p.value - q.value).abs() < 1e-9,
                "{d} {}: {} vs {}",
                p.name,
                p.value,
                q.value
            );
        }
    }
}

#[test]
fn a_change_beyond_the_limit_is_refused_with_the_parameter_named() {
    let m = builtin("bc-trunnion");
    let yaml = "machine: bc-trunnion\nlocation_errors: {EX0B: {value: 150.0, u: 0.5}}\n";
    for (d, name) in [
        (Dialect::Fanuc, "19700"),
        (Dialect::Heidenhain, "B.X"),
        (Dialect::Linuxcnc, "x-rot-point"),
    ] {
        let e = run(&m, yaml, d).unwrap_err();
        let msg = e.to_string();
        assert!(
            matches!(&e, ExportError::TooLarge { name: n, .. } if n == name),
            "{d}: {msg}"
        );
        assert!(
            msg.contains("+150.00 um") && msg.contains("--max-change 0.1 mm"),
            "{msg}"
        );
    }
    // The axis directions HEIDENHAIN's export only lists for the machine
    // builder are not entered: beyond their limit they are marked, not
    // refused (the rows to enter do not depend on them).
    let h = run(
        &m,
        "machine: bc-trunnion\nlocation_errors: {EA0B: {value: 600.0, u: 1.0}, EA(0B)C: {value: -590.0, u: 80.0}}\n",
        Dialect::Heidenhain,
    )
    .unwrap();
    assert_eq!(
        param(&h, "B.A").beyond.as_deref(),
        Some("change +600.00 urad beyond --max-change 0.5 mrad")
    );
    assert!(
        h.text.contains(
            "B.A = +600.00, u 1.00 urad  (direction of the B axis, turned about X): change +600.00 urad beyond --max-change 0.5 mrad, not to be entered"
        ),
        "{}",
        h.text
    );
    // C's direction, turned by EA0B + EA(0B)C = 10 urad, is within the
    // change limit but carries EA(0B)C's u of 80 urad.
    assert_eq!(
        param(&h, "C.A").beyond.as_deref(),
        Some("u 81.00 urad beyond --max-u 0.05 mrad")
    );
    assert!(param(&h, "C.B").beyond.is_none(), "{}", h.text);
    assert!(h.changes_nothing(), "{:?}", h.changed());
    // A larger limit lets it through.
    let l = load(&m, yaml);
    let wide = Limits {
        change_mm: 0.2,
        ..Limits::default()
    };
    assert!(export(&l.model, &l.theta, &l.u, Dialect::Fanuc, "e", &wide).is_ok());
}

#[test]
fn an_uncertain_value_is_refused_with_the_parameter_named() {
    let m = builtin("bc-trunnion");
    let yaml = "machine: bc-trunnion\nlocation_errors: {EX0B: {value: 12.0, u: 0.4}, EX(0B)C: {value: 5.0, u: 15.0}}\n";
    for (d, name) in [
        (Dialect::Fanuc, "19703"),
        (Dialect::Heidenhain, "C.X"),
        (Dialect::Linuxcnc, "x-rot-point"),
    ] {
        let e = run(&m, yaml, d).unwrap_err();
        assert!(
            matches!(&e, ExportError::Uncertain { name: n, .. } if n == name),
            "{d}: {e}"
        );
        assert!(e.to_string().contains("--max-u 0.01 mm"), "{e}");
    }
}

#[test]
fn no_value_drives_an_axis_beyond_its_stroke() {
    // The pivot 30 um inside the X stroke: 50 um more X puts the W origin,
    // and the tool on it, beyond the end.
    let src = builtin("bc-trunnion")
        .source
        .replace("X: [-365, 365]", "X: [-365, 0.03]");
    let m = Machine::from_yaml(std::path::Path::new("m.yaml"), &src).unwrap();
    let yaml = "machine: bc-trunnion\nlocation_errors: {EX0B: 50.0}\n";
    for d in [Dialect::Fanuc, Dialect::Heidenhain, Dialect::Linuxcnc] {
        let e = run(&m, yaml, d).unwrap_err();
        assert!(
            matches!(e, ExportError::Stroke { axis: 'X', .. }),
            "{d}: {e}"
        );
        assert!(
            e.to_string().contains("beyond its stroke [-365, 0.03]"),
            "{e}"
        );
    }
    // 20 um stays inside.
    let ok = "machine: bc-trunnion\nlocation_errors: {EX0B: 20.0}\n";
    for d in [Dialect::Fanuc, Dialect::Heidenhain, Dialect::Linuxcnc] {
        assert!(run(&m, ok, d).is_ok(), "{d}");
    }
    // A head machine: the table's C axis 50 um further in X takes the W
    // origin, and the spindle over it at B = 0, beyond an X stroke that
    // ends 30 um past the pivot (the poses at B = 30 and -120 are out of
    // reach already nominally, so only B = 0 decides).
    let src = builtin("head-table")
        .source
        .replace("X: [0, 735]", "X: [0, 367.53]");
    let m = Machine::from_yaml(std::path::Path::new("m.yaml"), &src).unwrap();
    for d in [Dialect::Fanuc, Dialect::Heidenhain] {
        let e = run(
            &m,
            "machine: head-table\nlocation_errors: {EX0C: 50.0}\n",
            d,
        )
        .unwrap_err();
        assert!(
            matches!(e, ExportError::Stroke { axis: 'X', tilt, .. } if tilt == 0.0),
            "{d}: {e}"
        );
        assert!(e.to_string().contains("drive X to 367.5500 mm"), "{d}: {e}");
        assert!(
            run(
                &m,
                "machine: head-table\nlocation_errors: {EX0C: 20.0}\n",
                d
            )
            .is_ok(),
            "{d}"
        );
    }
}

#[test]
fn changes_count_from_what_the_control_holds_when_the_machine_file_says() {
    let src = format!(
        "{}controller_parameters:\n  fanuc: {{19700: 0.010, 19703: 0.027}}\n",
        builtin("bc-trunnion").source
    );
    let m = Machine::from_yaml(std::path::Path::new("m.yaml"), &src).unwrap();
    let yaml = "machine: bc-trunnion\nlocation_errors: {EX0B: 12.0, EX(0B)C: 25.0}\n";
    let f = run(&m, yaml, Dialect::Fanuc).unwrap();
    assert!(f.from_current);
    assert!((param(&f, "19700").change() - 0.002).abs() < 1e-9);
    assert!((param(&f, "19703").change() + 0.002).abs() < 1e-9);
    assert!(
        f.text.contains("from what the control holds now"),
        "{}",
        f.text
    );
    let bad = format!(
        "{}controller_parameters:\n  fanuc: {{19770: 0.010}}\n",
        builtin("bc-trunnion").source
    );
    let m = Machine::from_yaml(std::path::Path::new("m.yaml"), &bad).unwrap();
    let e = run(&m, yaml, Dialect::Fanuc).unwrap_err();
    assert!(
        e.to_string().contains("controller_parameters.fanuc.19770"),
        "{e}"
    );
}

#[test]
fn an_export_of_zero_errors_changes_nothing_and_says_so() {
    let m = builtin("bc-trunnion");
    let f = run(
        &m,
        "machine: bc-trunnion\nlocation_errors: {EX0B: 0.0}\n",
        Dialect::Fanuc,
    )
    .unwrap();
    assert!(f.changes_nothing());
    let f = run(
        &m,
        "machine: bc-trunnion\nlocation_errors: {EX0B: 1.0}\n",
        Dialect::Fanuc,
    )
    .unwrap();
    assert!(!f.changes_nothing());
    assert_eq!(f.changed(), vec!["19700"]);
}

#[test]
fn an_export_that_holds_none_of_the_errors_is_refused() {
    // A zero point and an orientation: no position parameter holds them
    // (FANUC, LinuxCNC); the zero point is no axis direction either
    // (HEIDENHAIN's list for the machine builder).
    let m = builtin("bc-trunnion");
    for (d, yaml) in [
        (
            Dialect::Fanuc,
            "machine: bc-trunnion\nlocation_errors: {EB0B: 150.0, EA0B: 30.0}\n",
        ),
        (
            Dialect::Linuxcnc,
            "machine: bc-trunnion\nlocation_errors: {EB0B: 150.0, EA0B: 30.0}\n",
        ),
        (
            Dialect::Heidenhain,
            "machine: bc-trunnion\nlocation_errors: {EB0B: 150.0}\n",
        ),
    ] {
        let e = run(&m, yaml, d).unwrap_err();
        assert!(
            matches!(&e, ExportError::NothingHeld { not_held, .. } if not_held.contains("EB0B = 150.00 urad")),
            "{d}: {e}"
        );
        assert!(e.to_string().contains("nothing written"), "{e}");
    }
    // A map alone, likewise.
    let map = "machine: bc-trunnion\nlocation_errors: {EX0B: 0.0}\nposition_dependent:\n  EBB(B): {B: [-90, 0, 90], values: [38.79, -9.59, -29.2]}\n";
    let e = run(&m, map, Dialect::Fanuc).unwrap_err();
    assert!(e.to_string().contains("map.EBB(B)"), "{e}");
    // An orientation HEIDENHAIN lists for the builder: written, nothing to
    // enter, the list named.
    let h = run(
        &m,
        "machine: bc-trunnion\nlocation_errors: {EA0B: 30.0}\n",
        Dialect::Heidenhain,
    )
    .unwrap();
    assert!(h.changes_nothing());
    assert_eq!(h.listed_changed(), vec!["B.A", "C.A"]);
    // A file of zeros holds nothing to refuse: it changes nothing, and the
    // command says so.
    let z = run(
        &m,
        "machine: bc-trunnion\nlocation_errors: {EX0B: 0.0, EB0B: 0.0}\n",
        Dialect::Fanuc,
    )
    .unwrap();
    assert!(z.changes_nothing());
    assert!(z.text.contains("(nothing)"), "{}", z.text);
}

#[test]
fn linuxcnc_is_told_which_way_the_table_turns() {
    let m = builtin("bc-trunnion");
    let l = run(&m, BC, Dialect::Linuxcnc).unwrap();
    assert!(
        l.text
            .contains("setp xyzbc-trt-kins.conventional-directions 1"),
        "{}",
        l.text
    );
    let src = m.source.replace("direction: 1}", "direction: -1}");
    let rev = Machine::from_yaml(std::path::Path::new("m.yaml"), &src).unwrap();
    let l = run(&rev, BC, Dialect::Linuxcnc).unwrap();
    assert!(!l.text.contains("conventional-directions 1"), "{}", l.text);
    assert!(l.text.contains("trt-kins's default"), "{}", l.text);
}

/// A swivel data record read back from a SINUMERIK export's text: every
/// `$TC_CARRn[r]=value`, written or listed in a comment, as written
/// (rounded), with the record number `r` it names.
fn swivel_fields(text: &str) -> (std::collections::BTreeMap<u32, f64>, Vec<u32>) {
    let mut fields = std::collections::BTreeMap::new();
    let mut records = Vec::new();
    for word in text.split_whitespace() {
        let Some(rest) = word.strip_prefix("$TC_CARR") else {
            continue;
        };
        let Some((n, rest)) = rest.split_once('[') else {
            continue;
        };
        let Some((r, v)) = rest.split_once("]=") else {
            continue;
        };
        let (Ok(n), Ok(r), Ok(v)) = (n.parse::<u32>(), r.parse::<u32>(), v.parse::<f64>()) else {
            continue;
        };
        fields.insert(n, v);
        records.push(r);
    }
    (fields, records)
}

/// The kinematic chain of a swivel data record as its definition gives
/// it, written apart from the export: offset vectors l1..l4 and axis
/// directions v1, v2 in machine coordinates, unswivelled; each axis turns
/// what it carries right-handed about its v by its position; axis 2 is
/// carried by axis 1. Type T: the tool adapter hangs from the reference
/// point by -l1 - R1 (l2 + R2 l3); P: a table point p sits at
/// l2 + R1 (l3 + R2 (l4 + p)); M: the head (axis 1) carries the tool by
/// -l1 - R1 l2, the table (axis 2) is l3 + R2 (l4 + p).
struct SwivelRecord {
    ty: char,
    l: [Vector3<f64>; 4],
    v: [Vector3<f64>; 2],
}

impl SwivelRecord {
    fn r(&self, j: usize, deg: f64) -> nalgebra::Rotation3<f64> {
        nalgebra::Rotation3::from_axis_angle(
            &nalgebra::Unit::new_normalize(self.v[j]),
            deg.to_radians(),
        )
    }

    /// A table point given at rotary zero, machine coordinates, at the
    /// record's axis positions `a`.
    fn table(&self, a: [f64; 2], p: &Vector3<f64>) -> Vector3<f64> {
        let l = &self.l;
        match self.ty {
            'P' => l[1] + self.r(0, a[0]) * (l[2] + self.r(1, a[1]) * (l[3] + p)),
            'M' => l[2] + self.r(1, a[1]) * (l[3] + p),
            _ => *p,
        }
    }

    /// The tool tip and axis, the tool adapter's reference at `reference`
    /// and the tool hanging from it by `u` (adapter minus tip, unswivelled).
    fn tool(
        &self,
        a: [f64; 2],
        reference: &Vector3<f64>,
        u: &Vector3<f64>,
        axis: &Vector3<f64>,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let l = &self.l;
        match self.ty {
            'T' => {
                let r12 = self.r(0, a[0]) * self.r(1, a[1]);
                (
                    reference - l[0] - self.r(0, a[0]) * l[1] - r12 * (l[2] + u),
                    r12 * axis,
                )
            }
            'M' => (
                reference - l[0] - self.r(0, a[0]) * (l[1] + u),
                self.r(0, a[0]) * axis,
            ),
            _ => (reference - u, *axis),
        }
    }
}

/// Issue 19, item 4: the export's round trip. Every position error a line
/// of the machine is made of, on a B/C and an
/// A/C trunnion (type P), a head-table (M) and a head-head (T) machine: the
/// nominal swivel record (from the machine file, by the record's own
/// conventions) plus the fine offsets and directions the export writes,
/// read back from its text as rounded there, run through the record's
/// chain, moves the table and the tool as the exact kinematic chain of the
/// erroneous machine does, within 0.1 um and 0.1 urad, at rotary positions
/// across the range. Relative to rotary zero: the record, closed, changes
/// nothing there, where the errors shift the tool by what a work offset
/// takes up.
#[test]
fn the_sinumerik_swivel_record_reproduces_the_erroneous_machine() {
    use crate::kinematics::symbols::{SymbolTable, Unit};
    for name in ["bc-trunnion", "ac-trunnion", "head-table", "head-head"] {
        let mut m = builtin(name);
        m.sinumerik = Some(crate::machine::SinumerikFile { swivel_record: 3 });
        let kin = Kinematics::new(&m);
        let symbols = SymbolTable::for_kinematics(&kin);
        // The fields entered hold positions only: the position errors a
        // line is made of. Orientation errors are listed as not held, and
        // what they leave is checked against a model of the control in
        // tests/controller_models.rs.
        let mut um = [23.0, -17.0, 31.0, -9.0, 14.0].iter().cycle();
        let mut yaml = format!("machine: {name}\nlocation_errors:\n");
        for s in symbols.location.iter().filter(|s| s.unit == Unit::Um) {
            yaml += &format!("  {}: {}\n", s.name, um.next().unwrap());
        }
        let e = load(&m, &yaml);
        let x = export(
            &e.model,
            &e.theta,
            &e.u,
            Dialect::Sinumerik,
            "errors.yaml",
            &Limits::default(),
        )
        .unwrap_or_else(|err| panic!("{name}: {err}"));
        let (fields, records) = swivel_fields(&x.text);
        assert!(records.iter().all(|&r| r == 3), "{name}: {records:?}");
        // The nominal record, from the machine file: a table's axis turns
        // the part, so its vector is the machine file's direction turned
        // round; the tool adapter is the spindle gauge point, a head's
        // pivot `pivot_length` above it; the chains closed.
        let e_t = m.tilt.about.unit();
        let (dt, dc) = (m.tilt.direction, m.c.direction);
        let z = Vector3::z();
        let zero = Vector3::zeros();
        let h = m.pivot_length * z;
        let mut rec = match m.structure {
            Structure::TableTable => SwivelRecord {
                ty: 'P',
                l: [zero, m.pivot, zero, -m.pivot],
                v: [-dt * e_t, -dc * z],
            },
            Structure::HeadHead => SwivelRecord {
                ty: 'T',
                l: [-h, zero, h, zero],
                v: [dc * z, dt * e_t],
            },
            Structure::HeadTable => SwivelRecord {
                ty: 'M',
                l: [-h, h, m.pivot, -m.pivot],
                v: [dt * e_t, -dc * z],
            },
        };
        assert!(
            x.text.contains(&format!("$TC_CARR23[3]=\"{}\"", rec.ty)),
            "{name}"
        );
        for (k, first) in [41u32, 44, 55, 58].into_iter().enumerate() {
            for i in 0..3 {
                rec.l[k][i] += fields.get(&(first + i as u32)).copied().unwrap_or(0.0);
            }
        }
        for (j, first) in [7u32, 10].into_iter().enumerate() {
            rec.v[j] = Vector3::new(fields[&first], fields[&(first + 1)], fields[&(first + 2)]);
        }
        // No coarse field is written.
        for line in x.text.lines().filter(|l| !l.starts_with(';')) {
            if let Some(n) = line.strip_prefix("$TC_CARR") {
                let n: u32 = n.split('[').next().unwrap().parse().unwrap();
                assert!(
                    (41..=46).contains(&n) || (55..=60).contains(&n),
                    "{name}: {line}"
                );
            }
        }
        let p = e.model.perturbation(&e.theta, &Context::default());
        let lg = kin.gauge_length();
        let tilts: Vec<f64> = [-90.0, -40.0, 0.0, 35.0, 90.0]
            .into_iter()
            .filter(|&t| m.tilt.within(t, 0.0))
            .collect();
        // The tool's pose in machine coordinates, and the table's motion.
        let tool = |t: f64, c: f64| {
            let pose = kin.forward(&Axes::new(0.0, 0.0, 0.0, t, c), &p);
            let w = kin.table_transform(t, c, &p);
            ((w * Point3::from(pose.tip)).coords + m.pivot, w * pose.axis)
        };
        let (tip0, axis0) = tool(0.0, 0.0);
        let reference = m.pivot + lg * z;
        let w0 = kin.table_transform(0.0, 0.0, &p).inverse();
        let (mut worst_um, mut worst_urad) = (0.0f64, 0.0f64);
        for &t in &tilts {
            for c in [0.0, 90.0, 200.0, -135.0] {
                let a = match m.structure {
                    Structure::HeadHead => [c, t],
                    _ => [t, c],
                };
                // The table: points on it, relative to rotary zero. A
                // type M record places the table's pivot as seen from the
                // tool (l1 = -l2 puts the tool adapter at the readout), so
                // its table alone is off by the tool's offset turned with
                // C; the tool against the table is checked by the model of
                // the control in tests/controller_models.rs.
                let w = kin.table_transform(t, c, &p) * w0;
                for q in [
                    Vector3::zeros(),
                    Vector3::new(200.0, 0.0, 0.0),
                    Vector3::new(0.0, 200.0, 0.0),
                    Vector3::new(0.0, 0.0, 150.0),
                ]
                .into_iter()
                .filter(|_| rec.ty != 'M')
                {
                    let exact = (w * Point3::from(q)).coords + m.pivot;
                    let d = (rec.table(a, &(q + m.pivot)) - exact).norm();
                    worst_um = worst_um.max(d * 1e3);
                }
                // Its turn: the images of unit steps.
                let o = rec.table(a, &m.pivot);
                for e_i in [Vector3::x(), Vector3::y(), Vector3::z()] {
                    let d = (rec.table(a, &(m.pivot + e_i)) - o) - w.rotation * e_i;
                    worst_urad = worst_urad.max(d.norm() * 1e6);
                }
                // The tool, hanging from the gauge point along its own
                // axis, relative to rotary zero.
                let (tip, axis) = tool(t, c);
                let (rt, ra) = rec.tool(a, &reference, &(lg * axis0), &axis0);
                let (rt0, _) = rec.tool([0.0, 0.0], &reference, &(lg * axis0), &axis0);
                worst_um = worst_um.max(((rt - rt0) - (tip - tip0)).norm() * 1e3);
                worst_urad = worst_urad.max((ra - axis).norm() * 1e6);
            }
        }
        assert!(
            worst_um < 0.1 && worst_urad < 0.1,
            "{name}: the record misses the machine by {worst_um:.4} um, {worst_urad:.4} urad\n{}",
            x.text
        );
        // And the errors are large enough to matter: the nominal record
        // misses by far more.
        assert!(x.changed().len() >= 4, "{name}: {:?}", x.changed());
    }
}

fn with_record(name: &str, n: u32) -> Machine {
    let mut m = builtin(name);
    m.sinumerik = Some(crate::machine::SinumerikFile { swivel_record: n });
    m
}

#[test]
fn a_sinumerik_export_needs_the_record_number_from_the_machine_file() {
    let e = run(&builtin("bc-trunnion"), BC, Dialect::Sinumerik).unwrap_err();
    let t = e.to_string();
    assert!(
        t.contains("sinumerik: {swivel_record: N}") && t.contains("nothing written"),
        "{t}"
    );
}

#[test]
fn a_sinumerik_export_is_refused_and_counted_like_the_others() {
    let m = with_record("bc-trunnion", 1);
    // A change beyond --max-change names the fine field.
    let big = "machine: bc-trunnion\nlocation_errors: {EX0B: 150.0}\n";
    match run(&m, big, Dialect::Sinumerik).unwrap_err() {
        ExportError::TooLarge { name, .. } => assert_eq!(name, "$TC_CARR44"),
        other => panic!("{other}"),
    }
    // A u beyond --max-u too.
    let vague = "machine: bc-trunnion\nlocation_errors:\n  EY0C: {value: 5.0, u: 20.0}\n";
    match run(&m, vague, Dialect::Sinumerik).unwrap_err() {
        ExportError::Uncertain { name, .. } => assert_eq!(name, "$TC_CARR56"),
        other => panic!("{other}"),
    }
    // What the fine fields hold now: the change is counted from it, and
    // a field the export does not write is refused.
    let mut now = m.clone();
    now.controller_parameters.insert(
        Dialect::Sinumerik,
        [("$TC_CARR44".to_string(), 0.010)].into_iter().collect(),
    );
    let x = run(&now, BC, Dialect::Sinumerik).unwrap();
    let p = param(&x, "$TC_CARR44");
    assert!((p.value - 0.012).abs() < 1e-9 && (p.change() - 0.002).abs() < 1e-9);
    assert!(
        x.text.contains("controller_parameters.sinumerik"),
        "{}",
        x.text
    );
    // The free component along B is not a field the export writes.
    now.controller_parameters
        .get_mut(&Dialect::Sinumerik)
        .unwrap()
        .insert("$TC_CARR45".into(), 0.0);
    assert!(matches!(
        run(&now, BC, Dialect::Sinumerik).unwrap_err(),
        ExportError::UnknownCurrent { name, .. } if name == "$TC_CARR45"
    ));
    // Only a zero point: nothing a field holds, refused.
    let zero = "machine: bc-trunnion\nlocation_errors: {EB0B: 100.0}\n";
    assert!(matches!(
        run(&m, zero, Dialect::Sinumerik).unwrap_err(),
        ExportError::NothingHeld { .. }
    ));
}

#[test]
fn a_head_s_tool_tilt_at_rotary_zero_is_not_held_by_the_swivel_record() {
    // The spindle leaning in its head: the record has no field for the
    // tool's direction unswivelled; said, with its size, not written.
    let m = with_record("head-table", 1);
    let k = Kinematics::new(&m);
    let s = crate::kinematics::symbols::SymbolTable::for_kinematics(&k);
    let spindle = s
        .location
        .iter()
        .find(|l| l.name.ends_with(")S"))
        .unwrap()
        .name
        .clone();
    let yaml = format!("machine: head-table\nlocation_errors: {{EX0C: 10.0, {spindle}: 40.0}}\n");
    let x = run(&m, &yaml, Dialect::Sinumerik).unwrap();
    assert!(
        x.text.contains(&format!("{spindle} = 40.00 urad"))
            && x.text.contains("the tool axis at rotary zero, turned"),
        "{}",
        x.text
    );
    assert!(x.text.ends_with("M30\n"));
}
