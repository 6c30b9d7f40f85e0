use nalgebra::{Point3, Vector3};

use super::*;
use crate::Machine;
use crate::errorfile::{ErrorFile, LoadedErrors};

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
        h.text.contains("ADD +0.0120 TO Trans X before MachAxis B"),
        "{}",
        h.text
    );
    assert!(
        h.text
            .contains("ADD -0.0180 TO Trans Y between MachAxis B and MachAxis C"),
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
        // Zero points are not part of the lines: take them out of the chain.
        let mut theta = e.theta.clone();
        for (i, n) in e.model.param_names().iter().enumerate() {
            if n.ends_with("EB0B") || n.ends_with("EA0A") {
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
        "+0.0120 mm",
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
    // The zero of B is no direction of C.
    assert!(param(&h, "C.B").value.abs() < 0.01, "{}", h.text);
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
