//! `fivecal compensate` as a user runs it: summaries, malformed programs,
//! the correction limit, never overwriting an input, parameter export; and
//! LinuxCNC's own interpreter on a compensated program.

use std::path::{Path, PathBuf};
use std::process::Command as Proc;

use fivecal::compensate::{Compensator, Settings, Vertex};
use fivecal::errorfile::ErrorFile;
use fivecal::kinematics::Kinematics;
use fivecal::{Dialect, Machine};

use crate::cli::fivecal;
use crate::nc::fixture;
use crate::util::tempdir;

const ERRORS: &str = "machine: bc-trunnion\nlocation_errors: {EX0B: 30.0, EZ0B: -20.0, EA0B: 40.0, EC0B: -25.0, EB0B: 15.0, EX(0B)C: 12.0, EY0C: -18.0, EA(0B)C: 35.0}\n";

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn stderr_of(out: &std::process::Output) -> String {
    String::from_utf8_lossy(&out.stderr).to_string()
}

/// Nothing but the inputs in the directory: no output, no temporary file.
fn only(dir: &Path, names: &[&str]) {
    let mut got: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .collect();
    got.sort();
    let mut want: Vec<String> = names.iter().map(|s| s.to_string()).collect();
    want.sort();
    assert_eq!(got, want, "files left in {}", dir.display());
}

#[test]
fn malformed_programs_fail_with_file_line_column_and_write_nothing() {
    for (name, extra, want) in [
        (
            "unclosed_comment.nc",
            vec!["--dialect", "fanuc", "--strict"],
            "unclosed_comment.nc:4:14: unclosed comment",
        ),
        (
            "bad_number.ngc",
            vec!["--dialect", "linuxcnc", "--strict"],
            "bad_number.ngc:3:5: bad number `1.2.3` after X",
        ),
        (
            "unknown_word.ngc",
            vec!["--dialect", "linuxcnc", "--strict"],
            "unknown_word.ngc:3:7: unknown word `E5`",
        ),
        (
            "unknown_gcode.nc",
            vec!["--dialect", "fanuc", "--strict"],
            "unknown_gcode.nc:5:1: unknown word `G12.7`",
        ),
        (
            "unknown_block.h",
            vec!["--dialect", "heidenhain", "--strict"],
            "unknown_block.h:3:3: unknown block `LX`",
        ),
    ] {
        let dir = tempdir();
        let prog = dir.path().join(name);
        std::fs::copy(fixture(&format!("bad/{name}")), &prog).unwrap();
        let errs = write(dir.path(), "e.yaml", ERRORS);
        let machine = if name.ends_with(".h") {
            "head-table"
        } else {
            "bc-trunnion"
        };
        let errs = if machine == "head-table" {
            write(
                dir.path(),
                "e.yaml",
                "machine: head-table\nlocation_errors: {EX0C: 10.0}\n",
            )
        } else {
            errs
        };
        let out = fivecal()
            .args(["compensate", "--machine", machine, "--errors"])
            .arg(&errs)
            .arg(&prog)
            .arg("-o")
            .arg(dir.path().join("out.nc"))
            .args(&extra)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{name}: {}", stderr_of(&out));
        let err = stderr_of(&out);
        assert!(err.contains(want), "{name}: want `{want}` in\n{err}");
        assert!(!err.contains("panicked"), "{err}");
        only(dir.path(), &[name, "e.yaml"]);
    }
}

/// Issue 16, item 2: outside --strict a block that cannot be read does not
/// stop the run; it is kept byte for byte and reported with its line,
/// column and reason.
#[test]
fn malformed_blocks_outside_strict_mode_are_kept_and_reported_at_their_column() {
    let dir = tempdir();
    // The fixture with a readable move after the broken one: a program
    // whose only move cannot be read is refused (no_motion_block_...).
    let src = std::fs::read_to_string(fixture("bad/unclosed_comment.nc"))
        .unwrap()
        .replace(
            "M30\n",
            "G90 G0 X20. Y10. Z50. B0. C0.\nG1 X30. F300.\nM30\n",
        );
    let prog = write(dir.path(), "unclosed_comment.nc", &src);
    let errs = write(dir.path(), "e.yaml", ERRORS);
    let out = fivecal()
        .args([
            "compensate",
            "--machine",
            "bc-trunnion",
            "--dialect",
            "fanuc",
            "--errors",
        ])
        .arg(&errs)
        .arg(&prog)
        .arg("-o")
        .arg(dir.path().join("out.nc"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", stderr_of(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("1 unreadable blocks left as written")
            && text.contains("the block could not be read (column 14: unclosed comment")
            && text.contains(": lines 4"),
        "{text}"
    );
    let input = std::fs::read_to_string(&prog).unwrap();
    let output = std::fs::read_to_string(dir.path().join("out.nc")).unwrap();
    assert_eq!(output.lines().nth(3), input.lines().nth(3));
}

#[test]
fn unknown_words_outside_strict_mode_are_kept_and_reported() {
    let dir = tempdir();
    let prog = dir.path().join("p.ngc");
    std::fs::copy(fixture("bad/unknown_word.ngc"), &prog).unwrap();
    let errs = write(dir.path(), "e.yaml", ERRORS);
    let out = fivecal()
        .args([
            "compensate",
            "--machine",
            "bc-trunnion",
            "--dialect",
            "linuxcnc",
            "--errors",
        ])
        .arg(&errs)
        .arg(&prog)
        .arg("-o")
        .arg(dir.path().join("out.ngc"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr_of(&out));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("the block has a word fivecal does not know: lines 3"),
        "{text}"
    );
    let written = std::fs::read_to_string(dir.path().join("out.ngc")).unwrap();
    assert!(written.contains("G1 X1 E5 F100"), "{written}");
}

#[test]
fn a_correction_above_the_limit_stops_with_the_line_named() {
    let dir = tempdir();
    let prog = dir.path().join("five_axis.ngc");
    std::fs::copy(fixture("linuxcnc/five_axis.ngc"), &prog).unwrap();
    let errs = write(
        dir.path(),
        "e.yaml",
        "machine: bc-trunnion\nlocation_errors: {EX0B: 300.0}\n",
    );
    let out = fivecal()
        .args([
            "compensate",
            "--machine",
            "bc-trunnion",
            "--dialect",
            "linuxcnc",
            "--max-correction",
            "100",
            "--errors",
        ])
        .arg(&errs)
        .arg(&prog)
        .arg("-o")
        .arg(dir.path().join("out.ngc"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = stderr_of(&out);
    assert!(
        err.contains(
            "five_axis.ngc:3: correction of 300.0 um in X, Y, Z exceeds --max-correction 100 um"
        ),
        "{err}"
    );
    only(dir.path(), &["five_axis.ngc", "e.yaml"]);
}

#[test]
fn the_input_is_never_overwritten() {
    let dir = tempdir();
    let prog = dir.path().join("p.ngc");
    std::fs::copy(fixture("linuxcnc/five_axis.ngc"), &prog).unwrap();
    let before = std::fs::read(&prog).unwrap();
    let errs = write(dir.path(), "e.yaml", ERRORS);
    for target in [prog.clone(), errs.clone()] {
        let out = fivecal()
            .args(["compensate", "--machine", "bc-trunnion", "--errors"])
            .arg(&errs)
            .arg(&prog)
            .arg("-o")
            .arg(&target)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2));
        assert!(
            stderr_of(&out).contains("refusing to overwrite input"),
            "{}",
            stderr_of(&out)
        );
    }
    assert_eq!(std::fs::read(&prog).unwrap(), before);
}

#[test]
fn the_summary_names_changes_corrections_and_skipped_lines() {
    let dir = tempdir();
    let prog = write(
        dir.path(),
        "p.nc",
        "%\nO1\nG90 G21 G54 G43 H1\nG0 X10. Y10. Z30. B20. C20.\nG1 X[#1+2.] F300.\nG1 X12. Y10. Z20. B25. C40.\nG1 X15. Y12. Z18. B30. C50.\nM30\n%\n",
    );
    let errs = write(dir.path(), "e.yaml", ERRORS);
    let out_path = dir.path().join("out.nc");
    let out = fivecal()
        .args(["compensate", "--machine", "bc-trunnion", "--errors"])
        .arg(&errs)
        .arg(&prog)
        .arg("-o")
        .arg(&out_path)
        .args(["--export", "fanuc"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr_of(&out));
    let text = String::from_utf8(out.stdout).unwrap();
    for want in [
        "9 blocks, 4 moves: 3 blocks changed",
        "3 of 4 motion blocks (blocks that move an axis) corrected",
        "largest correction:",
        "um in X, Y, Z (line",
        "urad of tool orientation",
        "1 moves left as written:",
        // Under the kind of its reason: the value is the caller's.
        "    the file does not say (only the machine, its operator or the calling program knows",
        "      coordinates are expressions or variables: lines 5",
        "fanuc parameters written to",
    ] {
        assert!(text.contains(want), "`{want}` missing from\n{text}");
    }
    let params = std::fs::read_to_string(dir.path().join("out.nc.fanuc.txt")).unwrap();
    assert!(params.contains("19700 = +0.03000"), "{params}");
    assert!(params.contains("EA0B = 40.00 urad"), "{params}");
}

#[test]
fn zero_errors_through_the_command_line_leave_the_program_as_it_was() {
    let dir = tempdir();
    let errs = write(
        dir.path(),
        "zero.yaml",
        "machine: head-table\nlocation_errors: {EX0C: 0.0, EY0C: 0.0}\n",
    );
    // A program with moves to correct (the parser corpus klartext.h has
    // none a rewrite can take, and is refused: regression.rs).
    let prog = fixture("heidenhain/tcpm.h");
    let out_path = dir.path().join("out.h");
    let out = fivecal()
        .args(["compensate", "--machine", "head-table", "--errors"])
        .arg(&errs)
        .arg(&prog)
        .arg("-o")
        .arg(&out_path)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr_of(&out));
    assert_eq!(
        std::fs::read(&out_path).unwrap(),
        std::fs::read(&prog).unwrap()
    );
    // Never silently: the last line says the output is a copy.
    let text = String::from_utf8_lossy(&out.stdout);
    let last = text.lines().last().unwrap_or("");
    assert!(
        last.starts_with("nothing changed:") && last.contains("is a copy of"),
        "{text}"
    );
}

#[test]
fn linuxcnc_export_refuses_head_machines_and_names_what_trt_kins_cannot_hold() {
    let dir = tempdir();
    let errs = write(
        dir.path(),
        "e.yaml",
        "machine: head-table\nlocation_errors: {EX0C: 10.0}\n",
    );
    let out = fivecal()
        .args([
            "compensate",
            "--machine",
            "head-table",
            "--export",
            "linuxcnc",
            "--errors",
        ])
        .arg(&errs)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr_of(&out).contains("tilting-table machines"),
        "{}",
        stderr_of(&out)
    );
    let errs = write(dir.path(), "b.yaml", ERRORS);
    let out = fivecal()
        .args([
            "compensate",
            "--machine",
            "bc-trunnion",
            "--export",
            "linuxcnc",
            "--errors",
        ])
        .arg(&errs)
        .output()
        .unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("setp xyzbc-trt-kins.x-rot-point +0.04200"),
        "{text}"
    );
    assert!(
        text.contains("setp xyzbc-trt-kins.x-offset -0.01200"),
        "{text}"
    );
    assert!(
        text.contains("trt-kins takes no orientation errors"),
        "{text}"
    );
}

/// `STRAIGHT_TRAVERSE`, `STRAIGHT_FEED` and `ARC_FEED` end points of an
/// rs274 canonical trace: (X, Y, Z, B, C).
pub(crate) fn trace(program: &Path) -> Vec<[f64; 5]> {
    let dir = program.parent().unwrap();
    let canon = dir.join(format!(
        "{}.canon",
        program.file_name().unwrap().to_string_lossy()
    ));
    // rs274 keeps its tool table in $HOME/.tool.mmap, truncating it on
    // start: each run gets its own home so parallel runs do not race.
    let status = Proc::new("rs274")
        .env("HOME", dir)
        .arg("-g")
        .arg(program)
        .arg(&canon)
        .stdin(std::process::Stdio::null())
        .output()
        .expect("LinuxCNC's rs274 (package linuxcnc-uspace) must be installed for this test");
    assert!(
        status.status.success(),
        "rs274 rejected {}: {}",
        program.display(),
        String::from_utf8_lossy(&status.stderr)
    );
    let text = std::fs::read_to_string(&canon).unwrap();
    let mut out = Vec::new();
    for line in text.lines() {
        let Some(open) = line.find('(') else { continue };
        let call = line[..open].split_whitespace().last().unwrap_or("");
        let args: Vec<f64> = line[open + 1..line.rfind(')').unwrap()]
            .split(',')
            .filter_map(|x| x.trim().parse().ok())
            .collect();
        match call {
            "STRAIGHT_TRAVERSE" | "STRAIGHT_FEED" => {
                out.push([args[0], args[1], args[2], args[4], args[5]])
            }
            // ARC_FEED(first_end, second_end, first_axis, second_axis, rotation, axis_end, a, b, c)
            "ARC_FEED" => out.push([args[0], args[1], args[5], args[7], args[8]]),
            _ => {}
        }
    }
    out
}

#[test]
fn rs274_runs_the_compensated_program_and_its_trace_differs_by_the_predicted_corrections() {
    let dir = tempdir();
    let original = dir.path().join("five_axis.ngc");
    std::fs::copy(fixture("linuxcnc/five_axis.ngc"), &original).unwrap();
    let k = Kinematics::new(&Machine::builtin("bc-trunnion").unwrap());
    let l = ErrorFile::parse(Path::new("e.yaml"), ERRORS)
        .unwrap()
        .to_model(&k, Path::new("e.yaml"), ERRORS)
        .unwrap();
    let c = Compensator::new(&l.model, &l.theta, Settings::new(Dialect::Linuxcnc));
    let mut out = Vec::new();
    let mut vs: Vec<Vertex> = Vec::new();
    let input = std::fs::read(&original).unwrap();
    let s = c
        .run_observed(&original, input.as_slice(), &mut out, &mut |v| vs.push(*v))
        .unwrap();
    assert!(s.inserted > 0 && s.skipped.is_empty(), "{s:?}");
    let compensated = dir.path().join("compensated.ngc");
    std::fs::write(&compensated, &out).unwrap();

    let (t0, t1) = (trace(&original), trace(&compensated));
    // Every written end point is one move of the compensated trace...
    assert_eq!(t1.len(), vs.len(), "one traced move per written end point");
    let axes = [0usize, 1, 2, 4, 5];
    for (m, v) in t1.iter().zip(&vs) {
        for (k, &a) in axes.iter().enumerate() {
            // rs274 prints 4 decimals.
            assert!(
                (m[k] - v.program[a]).abs() <= 0.5e-4 + 1e-9,
                "line {}: traced {:?} written {:?}",
                v.line,
                m,
                v.program
            );
        }
    }
    // ... and at the original end points the two traces differ exactly by
    // the predicted corrections.
    let ends: Vec<&Vertex> = vs.iter().filter(|v| !v.inserted).collect();
    assert_eq!(t0.len(), ends.len());
    let comp_at_ends: Vec<&[f64; 5]> = t1
        .iter()
        .zip(&vs)
        .filter(|(_, v)| !v.inserted)
        .map(|(m, _)| m)
        .collect();
    let mut largest: f64 = 0.0;
    for ((m0, m1), v) in t0.iter().zip(comp_at_ends).zip(&ends) {
        for (k, &a) in axes.iter().enumerate() {
            let traced = m1[k] - m0[k];
            let predicted = v.program[a] - v.nominal_program[a];
            largest = largest.max(predicted.abs());
            assert!(
                (traced - predicted).abs() <= 1e-4 + 1e-9,
                "line {} axis {}: traces differ by {traced}, predicted {predicted}",
                v.line,
                ['X', 'Y', 'Z', 'A', 'B', 'C'][a]
            );
        }
    }
    assert!(
        largest > 0.01,
        "the corrections are visible in the trace: {largest}"
    );
}

/// The programs `fivecal plan` writes are what `compensate` meets first:
/// all three dialects parse strictly, come back byte for byte with zero
/// errors, and are compensated everywhere the position is known (B = 90
/// faces with B held at its limit); rs274 runs the LinuxCNC one.
#[test]
fn planned_stepped_square_programs_are_compensated_in_every_dialect() {
    let dir = tempdir();
    let d = dir.path();
    let zero = write(
        d,
        "zero.yaml",
        "machine: bc-trunnion\nlocation_errors: {EX0B: 0.0}\n",
    );
    let errs = write(d, "e.yaml", ERRORS);
    for (dialect, ext) in [("fanuc", "nc"), ("heidenhain", "h"), ("linuxcnc", "ngc")] {
        let out = d.join(format!("ss-{dialect}"));
        let st = fivecal()
            .args([
                "plan",
                "stepped-square",
                "--machine",
                "bc-trunnion",
                "--dialect",
                dialect,
                "--out",
            ])
            .arg(&out)
            .output()
            .unwrap();
        assert!(st.status.success(), "{}", stderr_of(&st));
        let prog = out.join(format!("stepped-square.{ext}"));
        let same = d.join(format!("zero.{ext}"));
        let st = fivecal()
            .args([
                "compensate",
                "--machine",
                "bc-trunnion",
                "--strict",
                "--dialect",
                dialect,
                "--errors",
            ])
            .arg(&zero)
            .arg(&prog)
            .arg("-o")
            .arg(&same)
            .output()
            .unwrap();
        assert!(st.status.success(), "{dialect}: {}", stderr_of(&st));
        assert_eq!(
            std::fs::read(&same).unwrap(),
            std::fs::read(&prog).unwrap(),
            "{dialect}"
        );
        let comp = d.join(format!("comp.{ext}"));
        let st = fivecal()
            .args([
                "compensate",
                "--machine",
                "bc-trunnion",
                "--dialect",
                dialect,
                "--errors",
            ])
            .arg(&errs)
            .arg(&prog)
            .arg("-o")
            .arg(&comp)
            .output()
            .unwrap();
        assert!(st.status.success(), "{dialect}: {}", stderr_of(&st));
        let text = String::from_utf8(st.stdout).unwrap();
        assert!(text.contains("B held at its limit"), "{dialect}: {text}");
        assert!(
            text.contains("2 moves left as written"),
            "{dialect}: {text}"
        );
        if dialect == "linuxcnc" {
            assert_eq!(trace(&comp).len(), trace(&prog).len());
        }
    }
}

/// Issue 14, item 4: every controller's export shows each parameter with
/// its u and its change, in the file and on the screen, counted from what
/// the control holds when the machine file says (else from nominal), and
/// its last line says what changes.
#[test]
fn every_export_shows_each_parameter_with_its_u_and_its_change() {
    let dir = tempdir();
    let errs = write(
        dir.path(),
        "result.yaml",
        "machine: bc-trunnion\nlocation_errors:\n  EX0B: {value: 12.0, u: 0.4}\n  EY0C: {value: -18.0, u: 0.7}\n  EX(0B)C: {value: 25.0, u: 0.6}\n",
    );
    let machine = write(
        dir.path(),
        "m.yaml",
        &format!(
            "{}controller_parameters:\n  fanuc: {{19700: 0.010, 19701: 0.0, 19702: -420.0, 19703: 0.027, 19704: 0.0, 19705: 0.0}}\n",
            Machine::builtin("bc-trunnion").unwrap().source
        ),
    );
    for (d, row, u, change) in [
        // 19700: 12 um where the control holds 10: a change of 2 um.
        ("fanuc", "19700", "0.40 um", "+2.00 um"),
        ("heidenhain", "C.Y", "0.70 um", "-18.00 um"),
        ("linuxcnc", "x-rot-point", "1.00 um", "+37.00 um"),
    ] {
        let to = dir.path().join(format!("p.{d}.txt"));
        let out = fivecal()
            .args(["compensate", "--machine"])
            .arg(&machine)
            .arg("--errors")
            .arg(&errs)
            .args(["--export", d, "--no-record", "--export-to"])
            .arg(&to)
            .output()
            .unwrap();
        assert!(out.status.success(), "{d}: {}", stderr_of(&out));
        let screen = String::from_utf8_lossy(&out.stdout);
        let file = std::fs::read_to_string(&to).unwrap();
        let line = |text: &str| {
            text.lines()
                .find(|l| {
                    l.trim_start_matches(['#', ';', ' '])
                        .starts_with(&format!("{row} "))
                })
                .unwrap_or_else(|| panic!("{d}: no {row} row in\n{text}"))
                .to_string()
        };
        for text in [&*screen, &file] {
            let l = line(text);
            assert!(l.contains(u) && l.contains(change), "{d}: {l}");
        }
        let from = if d == "fanuc" {
            "from what the control holds now"
        } else {
            "from the machine file's nominal geometry"
        };
        assert!(file.contains(from), "{d}: {file}");
        let last = screen.lines().last().unwrap_or("");
        assert!(
            last.contains(&format!("{d} parameters to enter change from")) && last.contains(row),
            "{d}: {screen}"
        );
    }
}

/// Issue 14, item 5: a run that changes nothing says so in its last line,
/// and exits non-zero, writing nothing, when that cannot be what was
/// asked: an export none of whose values the file's errors reach, or a
/// rewrite whose errors move no pose of the program. An export refused by
/// its limits takes the rewritten program down with it.
#[test]
fn a_run_that_changes_nothing_says_so_last_and_refuses_when_it_cannot_be_meant() {
    let dir = tempdir();
    let d = dir.path();
    write(
        d,
        "p.h",
        &std::fs::read_to_string(fixture("heidenhain/tcpm.h")).unwrap(),
    );
    let run = |args: &[&str]| fivecal().current_dir(d).args(args).output().unwrap();
    let last = |out: &std::process::Output| {
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .last()
            .unwrap_or("")
            .to_string()
    };
    // Zero errors, program and export: one last line says both.
    write(
        d,
        "zero.yaml",
        "machine: head-table\nlocation_errors: {EX0C: 0.0}\n",
    );
    let base = ["compensate", "--machine", "head-table", "--no-record"];
    let out = run(&[
        &base[..],
        &[
            "--errors",
            "zero.yaml",
            "p.h",
            "-o",
            "z.h",
            "--export",
            "fanuc",
        ],
    ]
    .concat());
    assert!(out.status.success(), "{}", stderr_of(&out));
    let l = last(&out);
    assert!(
        l.starts_with("nothing changed: zero.yaml holds no error")
            && l.contains("z.h is a copy of p.h")
            && l.contains("every fanuc parameter to enter equals"),
        "{l}"
    );
    // A zero point only: no parameter of any controller holds it.
    write(
        d,
        "zp.yaml",
        "machine: head-table\nlocation_errors: {EB0B: 120.0}\n",
    );
    for c in ["fanuc", "heidenhain"] {
        let out = run(&[
            &base[..],
            &["--errors", "zp.yaml", "p.h", "-o", "x.h", "--export", c],
        ]
        .concat());
        let err = stderr_of(&out);
        assert_eq!(out.status.code(), Some(2), "{c}: {err}");
        assert!(
            err.contains(&format!(
                "none of the errors in zp.yaml is held by {c}'s parameters"
            )) && err.contains("EB0B = 120.00 urad"),
            "{c}: {err}"
        );
    }
    // A tool radius error moves no pose: the rewrite is refused.
    write(
        d,
        "radius.yaml",
        "machine: head-table\nlocation_errors: {EX0C: 0.0}\neffects:\n  tool_radius: 3.0\n",
    );
    let out = run(&[
        &base[..2],
        &["head-table", "--errors", "radius.yaml", "p.h", "-o", "x.h"],
    ]
    .concat());
    let err = stderr_of(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("radius.yaml: its errors move no tool pose of p.h (tool_radius"),
        "{err}"
    );
    // A program that would be rewritten, with an export beyond its limit:
    // neither is written.
    write(
        d,
        "big.yaml",
        "machine: head-table\nlocation_errors: {EX0C: {value: 150.0, u: 0.5}}\n",
    );
    let out = run(&[
        &base[..],
        &[
            "--errors",
            "big.yaml",
            "p.h",
            "-o",
            "x.h",
            "--export",
            "heidenhain",
        ],
    ]
    .concat());
    let err = stderr_of(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("parameter C.X") && err.contains("--max-change"),
        "{err}"
    );
    only(
        d,
        &[
            "big.yaml",
            "p.h",
            "radius.yaml",
            "z.h",
            "z.h.fanuc.txt",
            "zero.yaml",
            "zp.yaml",
        ],
    );
    // An orientation HEIDENHAIN only lists: nothing to enter, said last,
    // the list named; exit 0 (the list is for the machine builder).
    write(
        d,
        "tilt.yaml",
        "machine: head-table\nlocation_errors: {EA0C: 40.0}\n",
    );
    let out = run(&[
        &base[..],
        &[
            "--errors",
            "tilt.yaml",
            "--export",
            "heidenhain",
            "--export-to",
            "t.txt",
        ],
    ]
    .concat());
    assert!(out.status.success(), "{}", stderr_of(&out));
    let l = last(&out);
    assert!(
        l.starts_with("nothing to change: every heidenhain parameter to enter equals")
            && l.contains("listed for the machine builder, not entered: C.A"),
        "{l}"
    );
}

/// Issue 14, item 4: every parameter an export writes, on every built-in
/// machine it supports, is explained in docs/controllers.md under its
/// controller (FANUC by its number range, the others by name), each
/// controller's section cites its public sources, every source cited is
/// listed with an address (a URL or a repository commit), and the export
/// points to the page.
#[test]
fn every_exported_parameter_is_documented_with_its_public_source() {
    let doc =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/controllers.md"))
            .unwrap();
    let section = |title: &str| {
        let a = doc
            .find(&format!("\n## {title}"))
            .unwrap_or_else(|| panic!("no section `{title}`"));
        let rest = &doc[a + 4..];
        rest[..rest.find("\n## ").unwrap_or(rest.len())].to_string()
    };
    // Each cited tag ([F-TCP 72/88], [L-SRC]) is listed once as a source
    // with an address.
    let listed = |tag: &str| {
        let at = doc
            .find(&format!("- **[{tag}]**"))
            .unwrap_or_else(|| panic!("source [{tag}] is cited but not listed"));
        let entry = &doc[at..];
        let entry = &entry[..entry[2..].find("\n- ").map_or(entry.len(), |e| e + 2)];
        entry.contains("http")
            || entry
                .split('`')
                .any(|w| w.len() == 40 && w.bytes().all(|b| b.is_ascii_hexdigit()))
    };
    for (d, title) in [
        (Dialect::Fanuc, "FANUC"),
        (Dialect::Heidenhain, "HEIDENHAIN"),
        (Dialect::Linuxcnc, "LinuxCNC"),
        (Dialect::Sinumerik, "SINUMERIK"),
    ] {
        let text = section(title);
        assert!(text.contains("Sources:"), "{title}");
        let tags: Vec<&str> = text
            .split('[')
            .skip(1)
            .filter_map(|t| t.split([' ', ']', ',']).next())
            .filter(|t| {
                t.starts_with(|c: char| c.is_ascii_uppercase())
                    && t.contains('-')
                    && t.chars().all(|c| c.is_ascii_alphanumeric() || c == '-')
            })
            .collect();
        assert!(tags.len() >= 3, "{title}: {tags:?}");
        for tag in &tags {
            assert!(listed(tag), "{title}: [{tag}] has no address");
        }
        for name in ["bc-trunnion", "ac-trunnion", "head-table", "head-head"] {
            // A SINUMERIK export needs the swivel record's number.
            let (_, yaml) = fivecal::machine::BUILTIN
                .iter()
                .find(|(n, _)| *n == name)
                .unwrap();
            let m = Machine::from_yaml(
                Path::new("m.yaml"),
                &format!("{yaml}\nsinumerik: {{swivel_record: 1}}\n"),
            )
            .unwrap();
            let kin = Kinematics::new(&m);
            let src = format!("machine: {name}\n");
            let path = Path::new("e.yaml");
            let e = ErrorFile::parse(path, &src)
                .unwrap()
                .to_model(&kin, path, &src)
                .unwrap();
            // Nothing to change on a perfect machine: the parameters are
            // written all the same.
            let x = match fivecal::compensate::export::export(
                &e.model,
                &e.theta,
                &e.u,
                d,
                "e.yaml",
                &fivecal::compensate::export::Limits::default(),
            ) {
                Ok(x) => x,
                Err(err) => {
                    assert!(
                        d == Dialect::Linuxcnc && name.starts_with("head"),
                        "{d} {name}: {err}"
                    );
                    continue;
                }
            };
            assert!(x.text.contains("docs/controllers.md"), "{d} {name}");
            for p in &x.parameters {
                let documented = if d == Dialect::Fanuc {
                    // A table row whose first cell names it or its range.
                    let n: u32 = p.name.parse().unwrap();
                    text.lines()
                        .filter_map(|l| l.strip_prefix("| ")?.split(" |").next())
                        .any(|cell| {
                            let (a, b) = cell.split_once('-').unwrap_or((cell, cell));
                            matches!(
                                (a.trim().parse::<u32>(), b.trim().parse::<u32>()),
                                (Ok(a), Ok(b)) if a <= n && n <= b
                            )
                        })
                } else {
                    text.contains(&format!("`{}`", p.name))
                };
                assert!(
                    documented,
                    "{d} {name}: {} is not in docs/controllers.md",
                    p.name
                );
            }
        }
    }
}

/// Issue 19, item 4: `--export sinumerik` end to end. The machine file
/// names the swivel data record; the export is a part program of fine
/// offset assignments to that record, beside a rewritten program as
/// `<NAME>_SWIVEL.MPF` with the `%_N_` lines a control loads a program
/// by (issue 46: it was `out.nc.sinumerik.MPF` without them); without the
/// record number, or with a malformed one, nothing is written and the
/// file is named.
#[test]
fn sinumerik_export_writes_the_fine_offsets_of_the_machine_file_s_swivel_record() {
    let dir = tempdir();
    let d = dir.path();
    let (_, bc) = fivecal::machine::BUILTIN
        .iter()
        .find(|(n, _)| *n == "bc-trunnion")
        .unwrap();
    let machine = write(
        d,
        "dmu.yaml",
        &format!("{bc}sinumerik: {{swivel_record: 2}}\n"),
    );
    let errs = write(d, "e.yaml", ERRORS);
    let out = fivecal()
        .args(["compensate", "--no-record", "--machine"])
        .arg(&machine)
        .arg("--errors")
        .arg(&errs)
        .args(["--export", "sinumerik"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr_of(&out));
    let text = String::from_utf8(out.stdout.clone()).unwrap();
    assert!(
        text.starts_with(
            "%_N_FIVECAL_SWIVEL_MPF\n;$PATH=/_N_MPF_DIR\n; fivecal: SINUMERIK swivel data record 2 ($TC_CARR..[2], type P)"
        ),
        "{text}"
    );
    // EX0B = 30 um is l2's X, EY0C = -18 um l3's Y; the directions and
    // the zero point of B are not written.
    assert!(
        text.contains("\n$TC_CARR44[2]=0.03000 ; fine l2 X"),
        "{text}"
    );
    assert!(
        text.contains("\n$TC_CARR56[2]=-0.01800 ; fine l3 Y"),
        "{text}"
    );
    assert!(text.contains("$TC_CARR45[2] (fine l2 Y"), "{text}");
    assert!(!text.contains("\n$TC_CARR7["), "{text}");
    assert!(text.contains("EB0B = 15.00 urad"), "{text}");
    assert!(text.ends_with("\nM30\n"), "{text}");
    let note = stderr_of(&out);
    assert!(
        note.contains("sinumerik parameters to enter change from the machine file's nominal geometry: $TC_CARR44")
            && note.contains("listed for the machine builder, not entered: $TC_CARR7"),
        "{note}"
    );

    // Beside a rewritten program: next to it, as a part program.
    let prog = write(
        d,
        "p.nc",
        "%\nO1\nG90 G21 G54 G43 H1\nG0 X10. Y10. Z30. B20. C20.\nG1 X12. Y10. Z20. B25. C40. F300.\nM30\n%\n",
    );
    let out = fivecal()
        .args(["compensate", "--no-record", "--machine"])
        .arg(&machine)
        .arg("--errors")
        .arg(&errs)
        .arg(&prog)
        .arg("-o")
        .arg(d.join("dmu-comp.nc"))
        .args(["--export", "sinumerik"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr_of(&out));
    let mpf = std::fs::read_to_string(d.join("DMU_COMP_SWIVEL.MPF")).unwrap();
    assert_eq!(
        mpf,
        text.replace("%_N_FIVECAL_SWIVEL_MPF", "%_N_DMU_COMP_SWIVEL_MPF")
    );

    // The built-in machine names no record: refused, nothing written.
    let out = fivecal()
        .args([
            "compensate",
            "--no-record",
            "--machine",
            "bc-trunnion",
            "--errors",
        ])
        .arg(&errs)
        .arg(&prog)
        .arg("-o")
        .arg(d.join("none.nc"))
        .args(["--export", "sinumerik"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = stderr_of(&out);
    assert!(err.contains("sinumerik: {swivel_record: N}"), "{err}");
    // Named, never pasted: the message once held the whole machine file.
    assert!(
        err.contains("built in (bc-trunnion)")
            && !err.contains("chain:")
            && err.lines().count() <= 2,
        "{err}"
    );
    assert!(!d.join("none.nc").exists() && !d.join("NONE_SWIVEL.MPF").exists());

    // A record 0 (TCARR=0 deselects) and an unknown key: the file, line
    // and what was expected.
    for (bad, want) in [
        ("sinumerik: {swivel_record: 0}\n", "1 or more"),
        (
            "sinumerik: {swivel_record: 1, type: P}\n",
            "unknown field `type`",
        ),
    ] {
        let m = write(d, "bad.yaml", &format!("{bc}{bad}"));
        let out = fivecal()
            .args(["compensate", "--no-record", "--machine"])
            .arg(&m)
            .arg("--errors")
            .arg(&errs)
            .args(["--export", "sinumerik"])
            .output()
            .unwrap();
        assert!(!out.status.success());
        let err = stderr_of(&out);
        assert!(err.contains("bad.yaml") && err.contains(want), "{err}");
    }
}

#[test]
fn expand_from_the_command_line_flattens_a_loop_and_reports_without_it() {
    let dir = tempdir();
    let errs = write(
        dir.path(),
        "e.yaml",
        "machine: ac-trunnion\nlocation_errors: {EY0A: 20.0, EX0C: -15.0, EC0A: 30.0}\n",
    );
    let prog = fixture("fanuc/macro_while.nc");
    let run = |extra: &[&str], out: &Path| {
        fivecal()
            .args(["compensate", "--machine", "ac-trunnion", "--errors"])
            .arg(&errs)
            .arg(&prog)
            .arg("-o")
            .arg(out)
            .args(extra)
            .output()
            .unwrap()
    };
    let kept = run(&[], &dir.path().join("kept.nc"));
    assert!(kept.status.success(), "{}", stderr_of(&kept));
    let text = String::from_utf8_lossy(&kept.stdout);
    assert!(
        text.contains("the block runs 5 times with different values (a macro loop or repeated call); use --expand: lines 16, 17"),
        "{text}"
    );
    let flat = run(&["--expand"], &dir.path().join("flat.nc"));
    assert!(flat.status.success(), "{}", stderr_of(&flat));
    let written = std::fs::read_to_string(dir.path().join("flat.nc")).unwrap();
    assert_eq!(written.matches("N100 G1 X").count(), 5, "{written}");
    assert!(!written.contains("WHILE ["), "{written}");
    let text = String::from_utf8_lossy(&flat.stdout);
    assert!(text.contains("no move left as written"), "{text}");
    // --expand is about a program: with --export alone it is refused.
    let out = fivecal()
        .args(["compensate", "--machine", "ac-trunnion", "--errors"])
        .arg(&errs)
        .args(["--export", "fanuc", "--expand"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(
        stderr_of(&out).contains("--expand flattens an NC program"),
        "{}",
        stderr_of(&out)
    );
    let help = fivecal().args(["compensate", "--help"]).output().unwrap();
    assert!(String::from_utf8_lossy(&help.stdout).contains("--expand"));
}
