//! The post engine: neutral ops rendered by the built-in definitions, the
//! probing and logging ops the probing plans use, the engine's safety
//! rules, and user definitions given by path.

use std::path::Path;

use fivecal::Dialect;
use fivecal::formats::probe_log::{Logged, fanuc, heidenhain, linuxcnc};
use fivecal::post::{Coolant, Op, PostDefinition, PostError, ProgramInfo, Target};
use nalgebra::{Matrix3, Vector3};

use crate::util::tempdir;

fn info() -> ProgramInfo {
    ProgramInfo {
        name: "probe-demo".into(),
        number: 1003,
        title: "probe demo".into(),
        lines: vec!["what the program is".into()],
        stock_min: Vector3::new(-50.0, -50.0, 0.0),
        stock_max: Vector3::new(50.0, 50.0, 70.0),
        tilt_letter: 'B',
    }
}

/// A probing sequence as a probing plan would emit it: probe tool, index,
/// approach above the point, probe down, read, log.
fn probing_ops() -> Vec<Op> {
    vec![
        Op::ToolCall {
            number: 99,
            name: "touch probe".into(),
            id: None,
            rpm: None,
        },
        Op::Retract { z: 150.0 },
        Op::Rotary { tilt: 0.0, c: 90.0 },
        Op::LogOpen {
            name: "probe-demo".into(),
            test: "probe-demo".into(),
        },
        Op::Rapid(Target::xyz(Vector3::new(10.0, -20.0, 80.0))),
        Op::Feed {
            to: Target::xyz(Vector3::new(10.0, -20.0, 75.0)),
            feed: 1000.0,
        },
        Op::ProbeMove {
            from: Vector3::new(10.0, -20.0, 75.0),
            to: Vector3::new(10.0, -20.0, 65.0),
            feed: 100.0,
            direction: -Vector3::z(),
        },
        Op::ProbeRead {
            vars: [101, 102, 103],
        },
        Op::LogPoint {
            index: 7,
            label: "A0C90_xm".into(),
        },
        Op::Rapid(Target {
            z: Some(80.0),
            ..Target::default()
        }),
        Op::LogClose,
        Op::Retract { z: 150.0 },
    ]
}

fn render(d: Dialect, ops: &[Op]) -> Result<fivecal::post::RenderedProgram, PostError> {
    PostDefinition::builtin(d).render(&info(), ops)
}

/// The blocks of `expected` appear in `text` one after another, in order.
fn blocks_in_order(text: &str, expected: &[String]) -> bool {
    let body: Vec<String> = text
        .lines()
        .map(|l| {
            // Drop a block number (`N120 ` or HEIDENHAIN's `12 `).
            let t = l.trim_start_matches('N');
            match t.split_once(' ') {
                Some((n, rest)) if n.chars().all(|c| c.is_ascii_digit()) && !n.is_empty() => {
                    rest.to_string()
                }
                _ => l.to_string(),
            }
        })
        .collect();
    body.windows(expected.len()).any(|w| w == expected)
}

#[test]
fn fanuc_probes_with_g31_and_logs_what_the_fanuc_reader_reads() {
    let p = render(Dialect::Fanuc, &probing_ops()).unwrap();
    let t = &p.text;
    for expected in [
        "T99 M6",
        "G0 B0. C90.",
        "G31 X10. Y-20. Z65. F100.",
        "#101=#5061",
        "#103=#5063",
        "PCLOS",
    ] {
        assert!(t.contains(expected), "`{expected}` missing in\n{t}");
    }
    assert!(blocks_in_order(t, &fanuc::open_blocks("probe-demo")), "{t}");
    assert!(blocks_in_order(t, &fanuc::touch_blocks(7)), "{t}");
    assert!(blocks_in_order(t, &fanuc::close_blocks()), "{t}");
    assert!(t.find("G31").unwrap() < t.find("DPRNT[T#199").unwrap());
    assert!(p.aux.is_empty());
}

#[test]
fn linuxcnc_probes_with_g38_2_and_logs_what_the_linuxcnc_reader_reads() {
    let p = render(Dialect::Linuxcnc, &probing_ops()).unwrap();
    let t = &p.text;
    assert!(
        t.contains("G38.2 X10.0000 Y-20.0000 Z65.0000 F100.0"),
        "{t}"
    );
    assert!(t.contains("#101=#5061"), "{t}");
    assert!(
        blocks_in_order(
            t,
            &linuxcnc::open_lines("probe-demo", "probe-demo.log", None)
        ),
        "{t}"
    );
    assert!(
        blocks_in_order(t, &[linuxcnc::touch_line("A0C90_xm")]),
        "{t}"
    );
    assert!(blocks_in_order(t, &linuxcnc::close_lines(false)), "{t}");
    // LinuxCNC's own interpreter accepts it (its simulated probe trips at
    // the programmed point).
    let dir = tempdir();
    let prog = dir.path().join("probe.ngc");
    std::fs::write(&prog, t).unwrap();
    let tbl = dir.path().join("tool.tbl");
    std::fs::write(&tbl, "T99 P99 Z0 D6 ;probe\n").unwrap();
    // rs274 keeps its tool table in $HOME/.tool.mmap: one home per run.
    let out = std::process::Command::new("rs274")
        .env("HOME", dir.path())
        .arg("-t")
        .arg(&tbl)
        .arg("-g")
        .arg(&prog)
        .stdin(std::process::Stdio::null())
        .output()
        .expect("rs274 (linuxcnc-uspace) must be installed");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}\n{}",
        stdout,
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("STRAIGHT_PROBE(10.0000, -20.0000, 65.0000"),
        "{stdout}"
    );
}

#[test]
fn heidenhain_probes_with_cycle_0_and_logs_what_the_heidenhain_reader_reads() {
    let p = render(Dialect::Heidenhain, &probing_ops()).unwrap();
    let t = &p.text;
    for expected in [
        "TOOL CALL 99 Z\n",
        "TCH PROBE 0.0 REF. PLANE Q1999 Z-",
        "TCH PROBE 0.1 X+10.000 Y-20.000 Z+75.000",
        "FN 18: SYSREAD Q101 = ID360 NR1 IDX1",
    ] {
        assert!(t.contains(expected), "`{expected}` missing in\n{t}");
    }
    let dir = r"TNC:\fivecal\";
    let out = format!("{dir}probe-demo.txt");
    assert!(
        blocks_in_order(
            t,
            &[heidenhain::f_print(
                &format!("{dir}probe-demo-head.A"),
                &out
            )]
        ),
        "{t}"
    );
    let mut touch = heidenhain::cycle0_reads();
    touch.extend(heidenhain::touch_statements(
        7,
        &format!("{dir}probe-demo-touch.A"),
        &out,
    ));
    assert!(blocks_in_order(t, &touch), "{t}");
    let aux: Vec<(&str, &str)> = p
        .aux
        .iter()
        .map(|a| (a.name.as_str(), a.text.as_str()))
        .collect();
    let touch_file = heidenhain::touch_format_file(Logged::Contact);
    let head_file = heidenhain::header_format_file("probe-demo");
    assert_eq!(
        aux,
        [
            ("probe-demo-head.a", head_file.as_str()),
            ("probe-demo-touch.a", touch_file.as_str())
        ]
    );
    // Block numbers run 0, 1, 2, ... from BEGIN PGM to END PGM.
    let numbered: Vec<&str> = t.lines().filter(|l| !l.starts_with(' ')).collect();
    for (i, l) in numbered.iter().enumerate() {
        assert!(l.starts_with(&format!("{i} ")), "block {i}: {l}");
    }
    assert!(numbered.last().unwrap().ends_with("END PGM probe-demo MM"));
}

#[test]
fn heidenhain_refuses_a_probe_move_off_the_axes() {
    let mut ops = probing_ops();
    ops[6] = Op::ProbeMove {
        from: Vector3::new(10.0, -20.0, 75.0),
        to: Vector3::new(12.0, -20.0, 65.0),
        feed: 100.0,
        direction: Vector3::new(0.2, 0.0, -1.0).normalize(),
    };
    let e = render(Dialect::Heidenhain, &ops).unwrap_err().to_string();
    assert!(e.contains("probes along one axis only"), "{e}");
    // FANUC and LinuxCNC probe along any direction.
    assert!(render(Dialect::Fanuc, &ops).is_ok());
    assert!(render(Dialect::Linuxcnc, &ops).is_ok());
}

#[test]
fn the_engine_refuses_a_rotary_index_without_a_retract() {
    for d in Dialect::ALL {
        let ops = vec![
            Op::ToolCall {
                number: 1,
                name: "t".into(),
                id: None,
                rpm: Some(1000.0),
            },
            Op::SpindleOn { rpm: 1000.0 },
            Op::Retract { z: 100.0 },
            Op::Rapid(Target::xyz(Vector3::new(0.0, 0.0, 20.0))),
            Op::Rotary { tilt: 90.0, c: 0.0 },
        ];
        let e = render(d, &ops).unwrap_err();
        assert!(matches!(e, PostError::Rule { index: 4, .. }), "{d}: {e}");
        assert!(e.to_string().contains("must follow a retract"), "{e}");
    }
}

#[test]
fn the_engine_refuses_unsafe_or_unfinished_sequences() {
    let cases: Vec<(Vec<Op>, &str)> = vec![
        (
            vec![
                Op::SpindleOn { rpm: 1000.0 },
                Op::ProbeMove {
                    from: Vector3::new(0.0, 0.0, 10.0),
                    to: Vector3::zeros(),
                    feed: 50.0,
                    direction: -Vector3::z(),
                },
            ],
            "spindle stopped",
        ),
        (
            vec![Op::LogPoint {
                index: 1,
                label: "P1".into(),
            }],
            "no log is open",
        ),
        (
            vec![Op::LogOpen {
                name: "x".into(),
                test: "x".into(),
            }],
            "never closed",
        ),
        (
            vec![
                Op::TiltedPlane {
                    rotation: Matrix3::identity(),
                    origin: Vector3::zeros(),
                    tilt: 0.0,
                    c: 0.0,
                },
                Op::Retract { z: 10.0 },
                Op::Rotary { tilt: 0.0, c: 0.0 },
            ],
            "cancel the tilted working plane",
        ),
        (
            vec![Op::Feed {
                to: Target::xyz(Vector3::zeros()),
                feed: 0.0,
            }],
            "feed must be > 0",
        ),
    ];
    for (ops, expect) in cases {
        let e = render(Dialect::Fanuc, &ops).unwrap_err().to_string();
        assert!(e.contains(expect), "{e}");
    }
}

#[test]
fn comments_wrap_to_the_line_limit_and_lose_forbidden_characters() {
    let long = "a long comment (with parentheses) that goes on and on past the eighty characters a FANUC block may hold; and more";
    let p = render(Dialect::Fanuc, &[Op::Comment(long.into())]).unwrap();
    let lines: Vec<&str> = p
        .text
        .lines()
        .filter(|l| l.starts_with("(A LONG") || l.contains("EIGHTY"))
        .collect();
    assert!(!lines.is_empty());
    for l in p.text.lines() {
        assert!(l.chars().count() <= 80, "{l}");
        if l.starts_with('(') {
            assert_eq!(l.matches('(').count(), 1, "{l}");
            assert!(l.ends_with(')'), "{l}");
        }
    }
    assert!(p.text.contains("WITH PARENTHESES"));
}

#[test]
fn controller_kinematics_angles_compose_to_the_plane() {
    // B = 90 on a B/C table: the plane frame is W turned +90 about Y.
    let r = Matrix3::new(0.0, 0.0, 1.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0);
    let ops = vec![
        Op::Retract { z: 100.0 },
        Op::Rotary { tilt: 90.0, c: 0.0 },
        Op::TiltedPlane {
            rotation: r,
            origin: Vector3::zeros(),
            tilt: 90.0,
            c: 0.0,
        },
        Op::TiltedPlaneOff,
    ];
    let f = render(Dialect::Fanuc, &ops).unwrap().text;
    assert!(
        f.contains("G68.2 X0. Y0. Z0. I90. J90. K-90.\nN")
            && f.contains("G53.1")
            && f.contains("G69"),
        "{f}"
    );
    let h = render(Dialect::Heidenhain, &ops).unwrap().text;
    assert!(
        h.contains("PLANE SPATIAL SPA+0.0000 SPB+90.0000 SPC+0.0000 STAY")
            && h.contains("PLANE RESET STAY"),
        "{h}"
    );
    let e = render(Dialect::Linuxcnc, &ops).unwrap_err().to_string();
    assert!(e.contains("no `tilted_plane` template"), "{e}");
}

#[test]
fn coolant_and_dwell_use_the_definitions_codes() {
    let ops = vec![
        Op::Coolant(Coolant::Flood),
        Op::Dwell(1.5),
        Op::Coolant(Coolant::Off),
    ];
    let f = render(Dialect::Fanuc, &ops).unwrap().text;
    assert!(
        f.contains("M8") && f.contains("G4 X1.5") && f.contains("M9"),
        "{f}"
    );
    let h = render(Dialect::Heidenhain, &ops).unwrap().text;
    assert!(h.contains("CYCL DEF 9.1 DWELL 1.5"), "{h}");
}

#[test]
fn a_user_definition_by_path_changes_the_output() {
    let dir = tempdir();
    let path = dir.path().join("my-fanuc.yaml");
    let src = PostDefinition::builtin(Dialect::Fanuc).source;
    std::fs::write(
        &path,
        src.replace(
            "  comment: \"({{ text }})\"",
            "  comment: \"(* {{ text }} *)\"",
        )
        .replace(
            "{prefix: \"N\", start: 10, step: 10",
            "{prefix: \"N\", start: 100, step: 2",
        ),
    )
    .unwrap();
    let def = PostDefinition::load(path.to_str().unwrap()).unwrap();
    let p = def
        .render(&info(), &[Op::Retract { z: 10.0 }])
        .unwrap()
        .text;
    assert!(p.contains("(* WHAT THE PROGRAM IS *)"), "{p}");
    assert!(p.contains("N100 G90") && p.contains("N102 G54"), "{p}");
}

#[test]
fn a_broken_definition_names_file_line_and_column() {
    let src = PostDefinition::builtin(Dialect::Fanuc).source;
    // An unknown variable inside a block template.
    let bad = src.replace("G43 H{{ number }}", "G43 H{{ numbr }}");
    let line = bad.lines().position(|l| l.contains("numbr")).unwrap() + 1;
    let col = bad.lines().nth(line - 1).unwrap().find("numbr").unwrap() + 1;
    let e = PostDefinition::parse(Path::new("p.yaml"), &bad)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with(&format!("p.yaml:{line}:")),
        "{e} (expected line {line}, column near {col})"
    );
    assert!(
        e.contains("template `tool_call`") && e.contains("undefined"),
        "{e}"
    );
    // A syntax error in an inline template.
    let bad = src.replace("spindle_off: \"M5\"", "spindle_off: \"M5 {{\"");
    let line = bad.lines().position(|l| l.contains("M5 {{")).unwrap() + 1;
    let e = PostDefinition::parse(Path::new("p.yaml"), &bad)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with(&format!("p.yaml:{line}:")), "{e}");
    // An unknown template and a missing one.
    let e = PostDefinition::parse(Path::new("p.yaml"), &src.replace("  dwell:", "  dwel:"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("unknown template `dwel`"), "{e}");
    let e = PostDefinition::parse(
        Path::new("p.yaml"),
        &src.replace("  rapid: \"G0 {{ words }}\"\n", ""),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("template `rapid` is missing"), "{e}");
}

#[test]
fn a_block_over_the_limit_is_an_error() {
    let src = PostDefinition::builtin(Dialect::Fanuc)
        .source
        .replace("line_limit: 80", "line_limit: 20");
    let def = PostDefinition::parse(Path::new("p.yaml"), &src).unwrap();
    let e = def
        .render(
            &info(),
            &[Op::Rapid(Target::xyz(Vector3::new(
                -123.456, -234.567, -345.678,
            )))],
        )
        .unwrap_err();
    assert!(matches!(e, PostError::LineTooLong { limit: 20, .. }), "{e}");
}
