//! The generated programs themselves: LinuxCNC's interpreter runs every
//! `linuxcnc` program and its traced moves reproduce the planned cuts;
//! FANUC and HEIDENHAIN programs are pinned by golden files and checked by
//! rule tests (decimal points, signs, block numbers, line length, a retract
//! before every rotary move, every axis value inside the machine's limits).

use std::process::{Command, Stdio};

use fivecal::formats::manifest::KinematicsMode;
use fivecal::kinematics::Kinematics;
use fivecal::procedure::MachiningPlan;
use fivecal::procedure::machining::plan;
use fivecal::{Axes, Dialect};
use nalgebra::Vector3;

use crate::plan::{TESTS, config, planned};
use crate::util::{MACHINES, tempdir};

// ---------------------------------------------------------------- rs274

struct Canon {
    feed: bool,
    axes: [f64; 6],
}

fn run_rs274(t: &MachiningPlan) -> Vec<Canon> {
    let dir = tempdir();
    let prog = dir.path().join(format!("{}.ngc", t.test));
    std::fs::write(&prog, &t.program.text).unwrap();
    let tbl = dir.path().join("tool.tbl");
    std::fs::write(
        &tbl,
        format!(
            "T{n} P{n} Z{} D{} ;{}\n",
            t.tool.length,
            t.tool.diameter,
            t.tool.name,
            n = t.tool.number
        ),
    )
    .unwrap();
    // rs274 keeps its tool table in $HOME/.tool.mmap, truncating it on
    // start: parallel runs sharing a home race on it, so each gets its own.
    let out = Command::new("rs274")
        .env("HOME", dir.path())
        .arg("-t")
        .arg(&tbl)
        .arg("-g")
        .arg(&prog)
        .stdin(Stdio::null())
        .output()
        .expect("LinuxCNC's rs274 must be installed (apt-get install linuxcnc-uspace)");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && !stderr.to_lowercase().contains("error"),
        "rs274 refused {} on {}:\n{stderr}",
        t.test,
        t.machine.name
    );
    stdout
        .lines()
        .filter_map(|l| {
            let feed = l.contains("STRAIGHT_FEED(");
            if !feed && !l.contains("STRAIGHT_TRAVERSE(") {
                return None;
            }
            let inner = &l[l.find('(').unwrap() + 1..l.rfind(')').unwrap()];
            let v: Vec<f64> = inner
                .split(',')
                .map(|s| s.trim().parse().unwrap())
                .collect();
            Some(Canon {
                feed,
                axes: [v[0], v[1], v[2], v[3], v[4], v[5]],
            })
        })
        .collect()
}

fn axes_of(t: &MachiningPlan, c: &Canon) -> Axes {
    let tilt = if t.machine.tilt_letter() == 'A' {
        c.axes[3]
    } else {
        c.axes[4]
    };
    Axes::new(c.axes[0], c.axes[1], c.axes[2], tilt, c.axes[5])
}

/// The planned feed moves the program writes (a move whose rounded
/// coordinates repeat the previous ones writes no block).
pub fn planned_feeds(t: &MachiningPlan) -> Vec<Vector3<f64>> {
    let fmt = |v: &Vector3<f64>| format!("{:.4} {:.4} {:.4}", v.x, v.y, v.z);
    let mut last = String::new();
    let mut out = Vec::new();
    for p in &t.poses {
        for mv in &p.moves {
            let f = fmt(&mv.program);
            if f != last && !mv.rapid {
                out.push(mv.tip);
            }
            last = f;
        }
    }
    out
}

#[test]
fn rs274_accepts_every_linuxcnc_program_and_its_moves_reproduce_the_cuts() {
    for m in MACHINES {
        for test in TESTS {
            let t = planned(m, test, Dialect::Linuxcnc);
            let k = Kinematics::with_gauge_length(&t.machine, t.tool.length);
            let canon = run_rs274(&t);
            let traced: Vec<Vector3<f64>> = canon
                .iter()
                .filter(|c| c.feed)
                .map(|c| k.forward_nominal(&axes_of(&t, c)).tip)
                .collect();
            let expected = planned_feeds(&t);
            assert_eq!(traced.len(), expected.len(), "{m} {test}: feed moves");
            let worst = traced
                .iter()
                .zip(&expected)
                .map(|(a, b)| (a - b).norm())
                .fold(0.0, f64::max);
            assert!(
                worst < 1e-3,
                "{m} {test}: traced cut {worst} mm off the plan"
            );

            // Rapids: each ends above the stock along the tool axis or with
            // the whole tool above the stock, like the move it continues.
            let mut corners = Vec::new();
            for b in std::iter::once(&t.piece.stock).chain(t.piece.fixture.as_ref()) {
                for i in 0..8 {
                    let s = Vector3::new(
                        if i & 1 == 0 { -1.0 } else { 1.0 },
                        if i & 2 == 0 { -1.0 } else { 1.0 },
                        if i & 4 == 0 { -1.0 } else { 1.0 },
                    );
                    corners.push(b.center + b.axes * s.component_mul(&b.half));
                }
            }
            let top = corners
                .iter()
                .map(|c| c.z)
                .fold(f64::NEG_INFINITY, f64::max);
            let r = t.cutter.radius;
            let class = |a: &Axes| {
                let pose = k.forward_nominal(a);
                let level = corners
                    .iter()
                    .map(|c| pose.axis.dot(c))
                    .fold(f64::NEG_INFINITY, f64::max);
                let above_axis = pose.axis.dot(&pose.tip) >= level - 1e-6;
                let lowest = pose.tip.z - r * (1.0 - pose.axis.z * pose.axis.z).max(0.0).sqrt();
                let above_top = lowest > top + 1e-6;
                (above_axis, above_top)
            };
            let mut prev: Option<Axes> = None;
            for c in &canon {
                let a = axes_of(&t, c);
                if !c.feed
                    && let Some(p) =
                        prev.filter(|p| p.tilt == a.tilt && p.c == a.c && p.xyz != a.xyz)
                {
                    let (s, e) = (class(&p), class(&a));
                    assert!(
                        (s.0 && e.0) || (s.1 && e.1),
                        "{m} {test}: rapid from {:?} to {:?} runs into the stock",
                        p.xyz,
                        a.xyz
                    );
                }
                prev = Some(a);
            }
        }
    }
}

// ---------------------------------------------------------------- golden files

fn golden(name: &str, text: &str) {
    crate::util::golden("tests/fixtures/plan/golden", name, text);
}

#[test]
fn fanuc_and_heidenhain_programs_match_their_golden_files() {
    for (m, test, d, mode, name) in [
        (
            "bc-trunnion",
            "stepped-square",
            Dialect::Fanuc,
            KinematicsMode::Post,
            "stepped-square.bc-trunnion.fanuc.nc",
        ),
        (
            "bc-trunnion",
            "stepped-square",
            Dialect::Fanuc,
            KinematicsMode::Controller,
            "stepped-square.bc-trunnion.fanuc-controller.nc",
        ),
        (
            "head-table",
            "stepped-square",
            Dialect::Heidenhain,
            KinematicsMode::Post,
            "stepped-square.head-table.heidenhain.h",
        ),
        (
            "ac-trunnion",
            "nine-section",
            Dialect::Heidenhain,
            KinematicsMode::Controller,
            "nine-section.ac-trunnion.heidenhain-controller.h",
        ),
    ] {
        let t = plan(&config(m, test, d, mode)).unwrap();
        golden(name, &t.program.text);
    }
}

// ---------------------------------------------------------------- rule tests

/// One parsed block: its number (if any), the words by letter with their
/// raw values, and the raw line.
struct Block<'a> {
    number: Option<u64>,
    words: Vec<(char, &'a str)>,
    line: &'a str,
}

fn words_of(s: &str) -> Vec<(char, &str)> {
    let b = s.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let c = b[i] as char;
        if c.is_ascii_alphabetic() && i + 1 < b.len() {
            let j0 = i + 1;
            let mut j = j0;
            while j < b.len()
                && (b[j].is_ascii_digit()
                    || b[j] == b'.'
                    || ((b[j] == b'-' || b[j] == b'+') && j == j0))
            {
                j += 1;
            }
            if j > j0 {
                out.push((c.to_ascii_uppercase(), &s[j0..j]));
                i = j;
                continue;
            }
        }
        i += 1;
    }
    out
}

fn fanuc_blocks(text: &str) -> Vec<Block<'_>> {
    text.lines()
        .filter(|l| !l.starts_with('%') && !l.starts_with('O') && !l.starts_with('('))
        .map(|l| {
            let code = l.split('(').next().unwrap();
            let mut words = words_of(code);
            let number = match words.first() {
                Some(('N', n)) => Some(n.parse().unwrap()),
                _ => None,
            };
            if number.is_some() {
                words.remove(0);
            }
            Block {
                number,
                words,
                line: l,
            }
        })
        .collect()
}

fn heidenhain_blocks(text: &str) -> Vec<Block<'_>> {
    text.lines()
        .filter(|l| !l.starts_with(' '))
        .map(|l| {
            let (n, rest) = l.split_once(' ').unwrap();
            let code = rest.split(';').next().unwrap();
            let words = if code.starts_with("L ")
                || code.starts_with("BLK FORM")
                || code.starts_with("TCH PROBE 0.1")
            {
                words_of(
                    code.trim_start_matches("BLK FORM 0.1 Z")
                        .trim_start_matches("BLK FORM 0.2"),
                )
                .into_iter()
                .filter(|(c, _)| "XYZABC".contains(*c))
                .collect()
            } else {
                Vec::new()
            };
            Block {
                number: n.parse().ok(),
                words,
                line: l,
            }
        })
        .collect()
}

/// Checks the rules every program must keep; `post` is true when X Y Z
/// are machine positions (kinematics post).
fn check_rules(t: &MachiningPlan, blocks: &[Block<'_>], post: bool) {
    let who = format!("{} {} {}", t.test, t.machine.name, t.dialect);
    let m = &t.machine;
    let tl = m.tilt_letter();
    let (mut x, mut y, mut z) = (None::<f64>, None::<f64>, None::<f64>);
    let mut retracted = false;
    let mut rotaries = 0;
    for b in blocks {
        assert!(
            b.line.chars().count() <= 80,
            "{who}: block over 80 characters: {}",
            b.line
        );
        let get = |c: char| {
            b.words
                .iter()
                .find(|w| w.0 == c)
                .map(|w| w.1.parse::<f64>().unwrap())
        };
        let rot = b.words.iter().any(|w| w.0 == tl || w.0 == 'C');
        // G68.2 names the plane's origin, it does not move.
        let lin: Vec<char> = if b.line.contains("G68.2") {
            Vec::new()
        } else {
            b.words
                .iter()
                .map(|w| w.0)
                .filter(|c| "XYZ".contains(*c))
                .collect()
        };
        if rot {
            rotaries += 1;
            assert!(
                retracted,
                "{who}: rotary move without a retract before it: {}",
                b.line
            );
            assert!(
                lin.is_empty(),
                "{who}: rotary and linear axes in one block: {}",
                b.line
            );
            let tilt = get(tl).unwrap();
            let c = get('C').unwrap();
            assert!(
                m.tilt.within(tilt, 1e-9) && m.c.within(c, 1e-9),
                "{who}: {} outside the rotary limits",
                b.line
            );
        }
        if !lin.is_empty() {
            x = get('X').or(x);
            y = get('Y').or(y);
            z = get('Z').or(z);
            retracted = lin == ['Z'] && z.unwrap() >= t.safe_z - 1e-3;
            if post && let (Some(x), Some(y), Some(z)) = (x, y, z) {
                let gauge = Vector3::new(x, y, z + t.tool.length);
                assert!(
                    m.check_strokes(&gauge).is_ok(),
                    "{who}: {} leaves the strokes: {:?}",
                    b.line,
                    m.check_strokes(&gauge)
                );
            }
        }
    }
    assert_eq!(rotaries, t.poses.len(), "{who}: one rotary index per pose");
}

#[test]
fn fanuc_programs_keep_the_rules() {
    for m in MACHINES {
        for test in TESTS {
            for mode in [KinematicsMode::Post, KinematicsMode::Controller] {
                let t = plan(&config(m, test, Dialect::Fanuc, mode)).unwrap();
                let blocks = fanuc_blocks(&t.program.text);
                // Decimal points on every length, angle and feed; none on
                // integers such as S, T, H, M, G codes.
                for b in &blocks {
                    for (c, v) in &b.words {
                        if "XYZABCIJKF".contains(*c) {
                            assert!(
                                v.contains('.'),
                                "{m} {test}: `{c}{v}` without a decimal point in {}",
                                b.line
                            );
                        }
                        if "STHM".contains(*c) {
                            assert!(!v.contains('.'), "{m} {test}: `{c}{v}` in {}", b.line);
                        }
                    }
                }
                // Block numbers run on by 10.
                let nums: Vec<u64> = blocks.iter().filter_map(|b| b.number).collect();
                assert!(nums.len() > 100 && nums[0] == 10);
                for w in nums.windows(2) {
                    assert_eq!(w[1], w[0] + 10, "{m} {test}: block numbers");
                }
                assert!(
                    t.program.text.starts_with("%\nO1") && t.program.text.ends_with("M30\n%\n")
                );
                check_rules(&t, &blocks, mode == KinematicsMode::Post);
            }
        }
    }
}

#[test]
fn heidenhain_programs_keep_the_rules() {
    for m in MACHINES {
        for test in TESTS {
            for mode in [KinematicsMode::Post, KinematicsMode::Controller] {
                let t = plan(&config(m, test, Dialect::Heidenhain, mode)).unwrap();
                let blocks = heidenhain_blocks(&t.program.text);
                // Every coordinate carries its sign, and numbers run 0, 1, 2, ...
                for b in &blocks {
                    for (c, v) in &b.words {
                        assert!(
                            v.starts_with('+') || v.starts_with('-'),
                            "{m} {test}: `{c}{v}` unsigned in {}",
                            b.line
                        );
                    }
                    if b.line.contains("PLANE SPATIAL") {
                        let angles: Vec<&str> = b
                            .line
                            .split_whitespace()
                            .filter(|w| {
                                w.len() > 3
                                    && ["SPA", "SPB", "SPC"].contains(&&w[..3])
                                    && *w != "SPATIAL"
                            })
                            .collect();
                        assert_eq!(angles.len(), 3, "{}", b.line);
                        for w in angles {
                            assert!(
                                w[3..].starts_with('+') || w[3..].starts_with('-'),
                                "{}",
                                b.line
                            );
                        }
                    }
                }
                for (i, b) in blocks.iter().enumerate() {
                    assert_eq!(b.number, Some(i as u64), "{m} {test}: {}", b.line);
                }
                assert!(blocks[0].line.ends_with(&format!("BEGIN PGM {test} MM")));
                assert!(
                    blocks
                        .last()
                        .unwrap()
                        .line
                        .ends_with(&format!("END PGM {test} MM"))
                );
                check_rules(&t, &blocks, mode == KinematicsMode::Post);
            }
        }
    }
}

/// The rule checker itself catches a rotary move without a retract.
#[test]
fn the_rule_check_catches_a_missing_retract() {
    let t = planned("bc-trunnion", "stepped-square", Dialect::Fanuc);
    // The retract before the second pose (its height follows the riser
    // the plan chose), lowered to Z100, below the safe height.
    let p = &t.program.text;
    let at = p.find("\n(POSE B0C90").unwrap();
    let retract = &p[p[..at].rfind('\n').unwrap() + 1..at];
    assert!(retract.contains("G0 Z") && t.safe_z > 100.0, "{retract}");
    let lowered = format!("{}Z100.", &retract[..retract.find('Z').unwrap()]);
    let text = p.replacen(
        &format!("{retract}\n(POSE B0C90"),
        &format!("{lowered}\n(POSE B0C90"),
        1,
    );
    assert_ne!(text, t.program.text);
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        check_rules(&t, &fanuc_blocks(&text), true)
    }));
    assert!(r.is_err());
}
