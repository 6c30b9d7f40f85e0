//! Machine files: the examples on disk are the built-in defaults, and bad
//! files are reported with file, line and key.

use std::path::Path;

use fivecal::Machine;
use fivecal::machine::Structure;

use crate::util::MACHINES;

fn example(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples/machines")
        .join(format!("{name}.yaml"))
}

fn bad(name: &str) -> String {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/machines")
        .join(name);
    Machine::load(p.to_str().unwrap()).unwrap_err().to_string()
}

#[test]
fn example_files_are_the_built_in_machines() {
    for name in MACHINES {
        let from_file = Machine::load(example(name).to_str().unwrap()).unwrap();
        let builtin = Machine::builtin(name).unwrap();
        assert_eq!(from_file, builtin, "{name}");
        assert_eq!(Machine::load(name).unwrap(), builtin);
    }
}

#[test]
fn example_machines_have_the_structures_the_seeds_describe() {
    let bc = Machine::builtin("bc-trunnion").unwrap();
    assert_eq!(
        (bc.structure, bc.tilt.letter, bc.tilt.limits),
        (Structure::TableTable, 'B', Some((-90.0, 90.0)))
    );
    assert_eq!(bc.tilt.parent, 'Y');
    assert_eq!(bc.c.parent, 'B');
    let ac = Machine::builtin("ac-trunnion").unwrap();
    assert_eq!(
        (ac.structure, ac.tilt.letter, ac.tilt.limits),
        (Structure::TableTable, 'A', Some((-120.0, 30.0)))
    );
    let ht = Machine::builtin("head-table").unwrap();
    assert_eq!(
        (ht.structure, ht.tilt.on_table, ht.c.on_table),
        (Structure::HeadTable, false, true)
    );
    assert_eq!(ht.chain, "CZFXYB");
    let hh = Machine::builtin("head-head").unwrap();
    assert_eq!(
        (hh.structure, hh.tilt.parent, hh.c.parent),
        (Structure::HeadHead, 'C', 'Z')
    );
}

#[test]
fn reversed_limits_are_reported_at_the_key() {
    let e = bad("reversed-limits.yaml");
    assert!(e.ends_with("reversed-limits.yaml:7:7: limits of B must be [min, max] in degrees with min < max, got [90, -90]"), "{e}");
}

#[test]
fn unknown_key_is_reported_with_position() {
    let e = bad("unknown-key.yaml");
    assert!(
        e.contains("unknown-key.yaml:11:") && e.contains("unknown field `helix`"),
        "{e}"
    );
}

#[test]
fn structure_must_match_the_chain() {
    let e = bad("structure-mismatch.yaml");
    assert!(e.contains("structure-mismatch.yaml:2:1: structure `head-table` does not match chain `CBYFXZ`, which describes a table-table machine"), "{e}");
}

#[test]
fn unknown_dialect_lists_the_supported_ones() {
    let e = bad("bad-dialect.yaml");
    assert!(
        e.contains("bad-dialect.yaml:4:") && e.contains("unknown variant `siemens`"),
        "{e}"
    );
}

#[test]
fn unknown_machine_name_lists_the_built_ins() {
    let e = Machine::load("no-such-machine").unwrap_err().to_string();
    assert!(
        e.contains("bc-trunnion, ac-trunnion, head-table, head-head"),
        "{e}"
    );
}

/// A machine file copied from an example with its name blanked out loads
/// no more: every output and the history would carry an empty machine.
#[test]
fn a_machine_file_with_a_blank_name_is_refused_at_the_name() {
    let text = std::fs::read_to_string(example("bc-trunnion")).unwrap();
    let line = text
        .lines()
        .position(|l| l.starts_with("name:"))
        .expect("the example names its machine")
        + 1;
    let dir = crate::util::tempdir();
    for blank in ["name: \"\"", "name: \"  \""] {
        let p = dir.path().join("mine.yaml");
        let edited: Vec<&str> = text
            .lines()
            .map(|l| if l.starts_with("name:") { blank } else { l })
            .collect();
        std::fs::write(&p, edited.join("\n")).unwrap();
        let e = Machine::load(p.to_str().unwrap()).unwrap_err().to_string();
        assert!(e.contains(&format!("mine.yaml:{line}:")), "{e}");
        assert!(e.contains("machine name is empty"), "{e}");
    }
}

/// The control's own M functions: `M` and a whole number, each in one
/// list; anything else is named at its entry.
#[test]
fn m_codes_are_read_and_a_malformed_one_is_named_at_its_entry() {
    let base = fivecal::Machine::builtin("head-head").unwrap().source;
    let ok = format!("{base}m_codes:\n  tcp_on: [M428]\n  tcp_off: [m429]\n  known: [M10, M11]\n");
    let m = fivecal::Machine::from_yaml(std::path::Path::new("m.yaml"), &ok).unwrap();
    assert_eq!(
        (m.m_codes.tcp_on, m.m_codes.tcp_off, m.m_codes.known),
        (vec![428], vec![429], vec![10, 11])
    );
    let lines = base.lines().count();
    for (list, msg) in [
        ("tcp_on: [G43.4]", "`G43.4` is not an M function"),
        (
            "tcp_on: [M428]\n  known: [M428]",
            "M428 is listed under both `tcp_on` and `known`",
        ),
    ] {
        let src = format!("{base}m_codes:\n  {list}\n");
        let e = fivecal::Machine::from_yaml(std::path::Path::new("m.yaml"), &src)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(&format!("m.yaml:{}:", lines + 2 + list.lines().count() - 1))
                && e.contains(msg),
            "{e}"
        );
    }
}
