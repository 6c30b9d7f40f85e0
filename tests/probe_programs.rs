//! The probing programs themselves: LinuxCNC's interpreter runs every
//! `linuxcnc` probing program, each traced probe move runs along its
//! touch's planned normal, and the traced path between touches keeps clear
//! of the columns, the sphere, its stem and the table; FANUC and HEIDENHAIN
//! programs are pinned by golden files and checked by rule tests (decimal
//! points, signs, block numbers, line length, a retract before every rotary
//! move, angles and strokes inside the machine's limits, each probing move
//! followed by the log statements of its touch).

use std::process::{Command, Stdio};

use fivecal::post::PostDefinition;
use fivecal::procedure::probing::Checker;
use fivecal::procedure::{PlanConfig, ProbingPlan, Template};
use fivecal::{Axes, Dialect};
use nalgebra::Vector3;

use crate::simulate::PROBING as PROBING_TESTS;
use crate::util::{MACHINES, machine, tempdir};

pub fn probing(machine_name: &str, test: &str, dialect: Dialect) -> ProbingPlan {
    fivecal::procedure::probing::plan(&PlanConfig {
        kinematics: fivecal::formats::manifest::KinematicsMode::Post,
        tool: None,
        machine: machine(machine_name),
        template: Template::builtin(test.parse().unwrap()),
        post: PostDefinition::builtin(dialect),
    })
    .unwrap_or_else(|e| panic!("{test} on {machine_name} ({dialect}): {e}"))
}

// ---------------------------------------------------------------- rs274

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Traverse,
    Feed,
    Probe,
}

/// What rs274 traced: each move with its end point (X, Y, Z, A, B, C), and
/// the text of every LOG call.
struct Trace {
    moves: Vec<(Kind, [f64; 6])>,
    logs: Vec<String>,
}

fn run_rs274(p: &ProbingPlan) -> Trace {
    let dir = tempdir();
    let prog = dir.path().join(format!("{}.ngc", p.test));
    std::fs::write(&prog, &p.program.text).unwrap();
    let tbl = dir.path().join("tool.tbl");
    std::fs::write(
        &tbl,
        format!(
            "T{n} P{n} Z{} D{} ;{}\n",
            p.probe.length,
            p.probe.ball_diameter,
            p.probe.name,
            n = p.probe.number
        ),
    )
    .unwrap();
    // rs274 truncates $HOME/.tool.mmap on start: one home per run.
    let out = Command::new("rs274")
        .env("HOME", dir.path())
        .current_dir(dir.path())
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
        p.test,
        p.machine.name
    );
    let mut moves = Vec::new();
    let mut logs = Vec::new();
    for l in stdout.lines() {
        if let Some((_, rest)) = l.split_once("LOG(\"") {
            logs.push(rest.trim_end_matches("\")").to_string());
            continue;
        }
        let kind = if l.contains("STRAIGHT_TRAVERSE(") {
            Kind::Traverse
        } else if l.contains("STRAIGHT_FEED(") {
            Kind::Feed
        } else if l.contains("STRAIGHT_PROBE(") {
            Kind::Probe
        } else {
            continue;
        };
        let inner = &l[l.find('(').unwrap() + 1..l.rfind(')').unwrap()];
        let v: Vec<f64> = inner
            .split(',')
            .map(|s| s.trim().parse().unwrap())
            .collect();
        moves.push((kind, [v[0], v[1], v[2], v[3], v[4], v[5]]));
    }
    Trace { moves, logs }
}

fn axes_of(p: &ProbingPlan, v: &[f64; 6]) -> Axes {
    let tilt = if p.machine.tilt_letter() == 'A' {
        v[3]
    } else {
        v[4]
    };
    Axes::new(v[0], v[1], v[2], tilt, v[5])
}

/// Checks rs274's trace of a program against its plan: every probe move
/// starts at its touch's start point, is programmed to its overtravel end
/// and runs along the planned normal at the pose's angles; every touch
/// logs its label right after its probe move; and the path, taken as the
/// machine runs it (stopping at the contact, then retracting from there),
/// keeps the plan's margin from the setup between touches and only touches
/// it on probing moves. The collision check is the planner's checker run on
/// the traced moves, not on the plan's.
fn check_trace(p: &ProbingPlan, trace: &Trace) -> Result<(), String> {
    let plan = &p.plan;
    let who = format!("{} on {}", p.test, p.machine.name);
    let probes: Vec<usize> = (0..trace.moves.len())
        .filter(|&i| trace.moves[i].0 == Kind::Probe)
        .collect();
    if probes.len() != plan.touches.len() {
        return Err(format!(
            "{who}: {} probe moves for {} touches",
            probes.len(),
            plan.touches.len()
        ));
    }
    for (&i, t) in probes.iter().zip(&plan.touches) {
        let from = axes_of(p, &trace.moves[i - 1].1);
        let to = axes_of(p, &trace.moves[i].1);
        if (from.xyz - t.start.axes.xyz).norm() > 1e-3 || (to.xyz - t.end.axes.xyz).norm() > 1e-3 {
            return Err(format!(
                "{who}: touch {} runs from {:?} to {:?}",
                t.label, from.xyz, to.xyz
            ));
        }
        let pose = &plan.poses[t.pose];
        if (to.tilt - pose.tilt).abs() > 1e-9 || (to.c - pose.c).abs() > 1e-9 {
            return Err(format!(
                "{who}: touch {} probed at {} {}",
                t.label, to.tilt, to.c
            ));
        }
        // 4-decimal coordinates over an 8 mm move: 2e-5 rad at most.
        let off = (to.xyz - from.xyz).normalize().angle(&-t.normal_prog);
        if off > 1e-4 {
            return Err(format!(
                "{who}: touch {} runs {off} rad off its normal",
                t.label
            ));
        }
    }
    if trace.logs.first().map(String::as_str) != Some(format!("FIVECAL {}", p.test).as_str())
        || trace.logs.len() != plan.touches.len() + 1
    {
        return Err(format!(
            "{who}: log header or line count: {:?}",
            trace.logs.first()
        ));
    }
    for (l, t) in trace.logs[1..].iter().zip(&plan.touches) {
        if !l.starts_with(&format!("T {} X", t.label)) {
            return Err(format!("{who}: `{l}` logged for touch {}", t.label));
        }
    }
    // rs274 starts at the origin, wherever the real machine stands: the
    // check starts at the first traced position.
    let checker = Checker::new(&plan.kin, &plan.obstacles, &plan.probe);
    let margin = plan.settings.safe_margin - 0.01; // 4-decimal rounding
    let mut here = axes_of(p, &trace.moves[0].1);
    let mut touch = 0;
    let mut at_contact = false;
    for (kind, v) in &trace.moves[1..] {
        let to = axes_of(p, v);
        let r = if *kind == Kind::Probe {
            // The probe stops at the contact.
            let contact = plan.touches[touch].contact.axes;
            touch += 1;
            let r = checker.check_move(&here, &contact, -1e-3);
            (here, at_contact) = (contact, true);
            r
        } else {
            // Leaving a contact, the ball starts on the surface.
            let m = if at_contact { -1e-3 } else { margin };
            let r = checker.check_move(&here, &to, m);
            (here, at_contact) = (to, false);
            r
        };
        if let Err(c) = r {
            return Err(format!("{who}: traced {kind:?} move to {v:?}: {c}"));
        }
    }
    Ok(())
}

/// Every test on every example machine (both tests plan on all four).
#[test]
fn rs274_accepts_every_linuxcnc_probing_program_and_its_trace_keeps_clear_of_the_setup() {
    for m in MACHINES {
        for test in PROBING_TESTS {
            let p = probing(m, test, Dialect::Linuxcnc);
            let trace = run_rs274(&p);
            if let Err(e) = check_trace(&p, &trace) {
                panic!("{e}");
            }
        }
    }
}

/// The trace check fails a program whose first descent runs into a column,
/// and one whose probe move is turned off its normal.
#[test]
fn the_trace_check_catches_a_descent_into_a_column_and_a_skewed_probe_move() {
    let p = probing("ac-trunnion", "probe-columns", Dialect::Linuxcnc);
    // Over C1's top (Z100 in program coordinates at A = C = 0), going down
    // to Z50 instead of the clearance height.
    let mut bad = p.clone();
    bad.program.text = p
        .program
        .text
        .replacen("G0 Z109.0000\n", "G0 Z50.0000\n", 1);
    assert_ne!(bad.program.text, p.program.text);
    let e = check_trace(&bad, &run_rs274(&bad)).unwrap_err();
    assert!(e.contains("Traverse") && e.contains("C1"), "{e}");

    let mut bad = p.clone();
    bad.program.text = p.program.text.replacen(
        "G38.2 X-60.0000 Y-45.0000 Z100.0000",
        "G38.2 X-59.9000 Y-45.0000 Z100.0000",
        1,
    );
    assert_ne!(bad.program.text, p.program.text);
    let e = check_trace(&bad, &run_rs274(&bad)).unwrap_err();
    assert!(
        e.contains("runs from") || e.contains("off its normal"),
        "{e}"
    );
}

// ---------------------------------------------------------------- golden files

fn golden(name: &str, text: &str) {
    crate::util::golden("tests/fixtures/probe/golden", name, text);
}

#[test]
fn fanuc_and_heidenhain_probing_programs_match_their_golden_files() {
    let p = probing("ac-trunnion", "probe-columns", Dialect::Fanuc);
    golden("probe-columns.ac-trunnion.fanuc.nc", &p.program.text);
    let p = probing("head-table", "probe-sphere", Dialect::Heidenhain);
    golden("probe-sphere.head-table.heidenhain.h", &p.program.text);
    for a in &p.program.aux {
        golden(&format!("probe-sphere.head-table.{}", a.name), &a.text);
    }
}

// ---------------------------------------------------------------- rule tests

/// The words of a block: letter and raw value (`X-60.`, `F100.`), leaving
/// out macro text such as `#199=1` and `DPRNT[...]`.
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

/// One block: its number, the code without it, and its words.
struct Block<'a> {
    number: Option<u64>,
    code: &'a str,
    words: Vec<(char, &'a str)>,
}

impl Block<'_> {
    fn get(&self, c: char) -> Option<f64> {
        self.words
            .iter()
            .find(|w| w.0 == c)
            .map(|w| w.1.parse().unwrap())
    }
}

fn fanuc_blocks(text: &str) -> Vec<Block<'_>> {
    text.lines()
        .filter(|l| !l.starts_with('%') && !l.starts_with('O') && !l.starts_with('('))
        .map(|l| {
            let (number, code) = match l.strip_prefix('N').and_then(|r| r.split_once(' ')) {
                Some((n, rest)) => (n.parse().ok(), rest),
                None => (None, l),
            };
            let words = if code.starts_with('#') || code.starts_with("DPRNT") {
                Vec::new()
            } else {
                words_of(code.split('(').next().unwrap())
            };
            Block {
                number,
                code,
                words,
            }
        })
        .collect()
}

fn heidenhain_blocks(text: &str) -> Vec<Block<'_>> {
    text.lines()
        .filter(|l| !l.starts_with(' '))
        .map(|l| {
            let (n, code) = l.split_once(' ').unwrap();
            let c = code.split(';').next().unwrap();
            let words = if c.starts_with("L ") || c.starts_with("TCH PROBE 0.1") {
                words_of(c)
                    .into_iter()
                    .filter(|(c, _)| "XYZABCF".contains(*c))
                    .collect()
            } else if c.starts_with("BLK FORM") {
                words_of(
                    c.trim_start_matches("BLK FORM 0.1 Z")
                        .trim_start_matches("BLK FORM 0.2"),
                )
            } else {
                Vec::new()
            };
            Block {
                number: n.parse().ok(),
                code,
                words,
            }
        })
        .collect()
}

/// The rules both dialects keep, on blocks already split: every block
/// within 80 characters; a retract to the safe height (Z alone) right
/// before every rotary move, which moves the rotary axes alone and within
/// their limits, once per pose; every position inside the strokes; every
/// probe move, recognised by `is_probe`, from its touch's start point to
/// its end point at the pose's angles, and followed by `log(index)` (the
/// touch's log statements, in order).
/// `pre_position`: the probe block names the point the probe starts from
/// (HEIDENHAIN cycle 0 rapids there first, so it must be where the probe
/// already stands, and it returns there after the touch); otherwise the
/// probe block names the end of the probing move.
fn check_rules(
    p: &ProbingPlan,
    blocks: &[Block<'_>],
    pre_position: bool,
    is_probe: impl Fn(&Block<'_>) -> bool,
    log: impl Fn(usize) -> Vec<String>,
) -> Result<(), String> {
    let who = format!("{} on {} ({})", p.test, p.machine.name, p.dialect);
    let m = &p.machine;
    let plan = &p.plan;
    let tl = m.tilt_letter();
    let (mut x, mut y, mut z) = (None::<f64>, None::<f64>, None::<f64>);
    let (mut tilt, mut c) = (None::<f64>, None::<f64>);
    let mut retracted = false;
    let mut rotaries = 0;
    let mut touch = 0;
    let mut i = 0;
    while i < blocks.len() {
        let b = &blocks[i];
        let rot = b.words.iter().any(|w| w.0 == tl || w.0 == 'C');
        let lin: Vec<char> = b
            .words
            .iter()
            .map(|w| w.0)
            .filter(|c| "XYZ".contains(*c))
            .collect();
        if rot && !b.code.starts_with("BLK") {
            rotaries += 1;
            if !retracted {
                return Err(format!(
                    "{who}: rotary move without a retract before it: {}",
                    b.code
                ));
            }
            if !lin.is_empty() {
                return Err(format!(
                    "{who}: rotary and linear axes together: {}",
                    b.code
                ));
            }
            let (t, cc) = (b.get(tl).unwrap(), b.get('C').unwrap());
            if !(m.tilt.within(t, 1e-9) && m.c.within(cc, 1e-9)) {
                return Err(format!("{who}: {} outside the rotary limits", b.code));
            }
            (tilt, c) = (Some(t), Some(cc));
        }
        if !lin.is_empty() && !b.code.starts_with("BLK") {
            let before = (x, y, z);
            x = b.get('X').or(x);
            y = b.get('Y').or(y);
            z = b.get('Z').or(z);
            retracted = lin == ['Z'] && (z.unwrap() - plan.safe_z).abs() < 1e-3;
            // The first retract comes before X and Y are known.
            let (Some(xv), Some(yv), Some(zv)) = (x, y, z) else {
                i += 1;
                continue;
            };
            let gauge = Vector3::new(xv, yv, zv + p.probe.length);
            if let Err(e) = m.check_strokes(&gauge) {
                return Err(format!("{who}: {} leaves the strokes: {e:?}", b.code));
            }
            if is_probe(b) {
                let Some(t) = plan.touches.get(touch) else {
                    return Err(format!("{who}: more probe moves than touches"));
                };
                let (Some(bx), Some(by), Some(bz)) = before else {
                    return Err(format!("{who}: probe move from nowhere"));
                };
                let from = Vector3::new(bx, by, bz);
                let to = Vector3::new(xv, yv, zv);
                let pose = &plan.poses[t.pose];
                let named = if pre_position {
                    t.start.axes.xyz
                } else {
                    t.end.axes.xyz
                };
                if (from - t.start.axes.xyz).norm() > 1e-3
                    || (to - named).norm() > 1e-3
                    || tilt != Some(pose.tilt)
                    || c != Some(pose.c)
                {
                    return Err(format!(
                        "{who}: probe move {} from {from:?} at {tilt:?}, {c:?} is not touch {}",
                        b.code, t.label
                    ));
                }
                let want = log(t.index);
                let got: Vec<&str> = blocks[i + 1..]
                    .iter()
                    .take(want.len())
                    .map(|b| b.code)
                    .collect();
                if got != want {
                    return Err(format!(
                        "{who}: touch {} is logged by {got:?}, expected {want:?}",
                        t.label
                    ));
                }
                touch += 1;
                i += want.len();
            }
        }
        i += 1;
    }
    if rotaries != plan.poses.len() {
        return Err(format!(
            "{who}: {rotaries} rotary moves for {} poses",
            plan.poses.len()
        ));
    }
    if touch != plan.touches.len() {
        return Err(format!(
            "{who}: {touch} probe moves for {} touches",
            plan.touches.len()
        ));
    }
    Ok(())
}

fn check_fanuc(p: &ProbingPlan) -> Result<(), String> {
    let who = format!("{} on {} (fanuc)", p.test, p.machine.name);
    let text = &p.program.text;
    if !text.starts_with("%\nO200") || !text.ends_with("M30\n%\n") {
        return Err(format!("{who}: program frame"));
    }
    if let Some(l) = text.lines().find(|l| l.chars().count() > 80) {
        return Err(format!("{who}: over 80 characters: {l}"));
    }
    let blocks = fanuc_blocks(text);
    // Block numbers run on by 10; decimal points on every length, angle
    // and feed, none on T, H, M, G-free integers.
    let nums: Vec<u64> = blocks.iter().filter_map(|b| b.number).collect();
    if nums.len() != blocks.len() || nums[0] != 10 || nums.windows(2).any(|w| w[1] != w[0] + 10) {
        return Err(format!("{who}: block numbers"));
    }
    for b in &blocks {
        for (c, v) in &b.words {
            if "XYZABCF".contains(*c) && !v.contains('.') {
                return Err(format!(
                    "{who}: `{c}{v}` without a decimal point in {}",
                    b.code
                ));
            }
            if "THM".contains(*c) && v.contains('.') {
                return Err(format!("{who}: `{c}{v}` in {}", b.code));
            }
            // DPRNT prints the recorded positions in [44] fields.
            if "XYZ".contains(*c)
                && !fivecal::formats::probe_log::fanuc::fits_field(v.parse().unwrap())
            {
                return Err(format!("{who}: `{c}{v}` does not fit DPRNT's [44] field"));
            }
        }
        if b.words.iter().any(|w| w == &('M', "3") || w == &('M', "4")) {
            return Err(format!("{who}: spindle started: {}", b.code));
        }
    }
    let codes: Vec<&str> = blocks.iter().map(|b| b.code).collect();
    let popen = codes.iter().position(|c| *c == "POPEN");
    let first_probe = codes.iter().position(|c| c.starts_with("G31"));
    let pclos = codes.iter().position(|c| *c == "PCLOS");
    let last_probe = codes.iter().rposition(|c| c.starts_with("G31"));
    if !(popen < first_probe && last_probe < pclos && popen.is_some()) {
        return Err(format!("{who}: POPEN/PCLOS around the probe moves"));
    }
    if codes[popen.unwrap() + 1] != format!("DPRNT[FIVECAL*{}]", p.test.as_str().to_uppercase()) {
        return Err(format!("{who}: log header"));
    }
    // The probing feed is modal after G31: the next feed move names its own.
    for (i, b) in blocks.iter().enumerate() {
        if b.code.starts_with("G31") {
            if b.get('F') != Some(p.plan.settings.feed) {
                return Err(format!("{who}: {} without the probing feed", b.code));
            }
            let next = blocks[i + 1..].iter().find(|b| b.code.starts_with("G1 "));
            if let Some(n) = next
                && n.get('F') != Some(p.plan.settings.positioning_feed)
            {
                return Err(format!(
                    "{who}: `{}` after a G31 runs at the probing feed",
                    n.code
                ));
            }
        }
    }
    check_rules(
        p,
        &blocks,
        false,
        |b| b.code.starts_with("G31 "),
        |k| {
            vec![
                format!("#199={k}"),
                "DPRNT[T#199[50]*X#5061[44]*Y#5062[44]*Z#5063[44]]".to_string(),
            ]
        },
    )
}

fn check_heidenhain(p: &ProbingPlan) -> Result<(), String> {
    let who = format!("{} on {} (heidenhain)", p.test, p.machine.name);
    let text = &p.program.text;
    if let Some(l) = text.lines().find(|l| l.chars().count() > 80) {
        return Err(format!("{who}: over 80 characters: {l}"));
    }
    let blocks = heidenhain_blocks(text);
    for (i, b) in blocks.iter().enumerate() {
        if b.number != Some(i as u64) {
            return Err(format!("{who}: block {i} is numbered {:?}", b.number));
        }
        for (c, v) in &b.words {
            if "XYZABC".contains(*c) && !(v.starts_with('+') || v.starts_with('-')) {
                return Err(format!("{who}: `{c}{v}` unsigned in {}", b.code));
            }
        }
        if b.code == "M3" || b.code.contains(" S") && b.code.starts_with("TOOL CALL") {
            return Err(format!("{who}: spindle started: {}", b.code));
        }
    }
    if blocks[0].code != format!("BEGIN PGM {} MM", p.test)
        || blocks.last().unwrap().code != format!("END PGM {} MM", p.test)
    {
        return Err(format!("{who}: program frame"));
    }
    let head = "FN 16: F-PRINT TNC:\\fivecal\\";
    let log = fivecal::procedure::probing::log_name(p.test);
    let open = blocks
        .iter()
        .position(|b| b.code == format!("{head}{log}-head.A / TNC:\\fivecal\\{log}.txt"));
    let first_probe = blocks.iter().position(|b| b.code.starts_with("TCH PROBE"));
    if !(open.is_some() && open < first_probe) {
        return Err(format!(
            "{who}: the log header is not printed before the first touch"
        ));
    }
    // Each cycle 0 probes along its touch's approach axis.
    let mut k = 0;
    for b in &blocks {
        if let Some(dir) = b.code.strip_prefix("TCH PROBE 0.0 REF. PLANE Q1999 ") {
            let t = &p.plan.touches[k];
            let a = -t.normal_prog;
            let i = (0..3)
                .max_by(|&i, &j| a[i].abs().total_cmp(&a[j].abs()))
                .unwrap();
            let want = format!(
                "{}{}",
                ["X", "Y", "Z"][i],
                if a[i] > 0.0 { "+" } else { "-" }
            );
            if dir != want {
                return Err(format!("{who}: touch {} probes {dir}, not {want}", t.label));
            }
            k += 1;
        }
    }
    check_rules(
        p,
        &blocks,
        true,
        |b| b.code.starts_with("TCH PROBE 0.1"),
        |k| {
            vec![
                "FN 18: SYSREAD Q1901 = ID360 NR1 IDX1".to_string(),
                "FN 18: SYSREAD Q1902 = ID360 NR1 IDX2".to_string(),
                "FN 18: SYSREAD Q1903 = ID360 NR1 IDX3".to_string(),
                format!("Q1900 = {k}"),
                format!("{head}{log}-touch.A / TNC:\\fivecal\\{log}.txt"),
            ]
        },
    )?;
    // The format files the FN 16 blocks name, next to the program.
    let names: Vec<&str> = p.program.aux.iter().map(|a| a.name.as_str()).collect();
    if names != [format!("{log}-head.a"), format!("{log}-touch.a")] {
        return Err(format!("{who}: format files {names:?}"));
    }
    Ok(())
}

#[test]
fn fanuc_probing_programs_keep_the_rules() {
    for m in MACHINES {
        for test in PROBING_TESTS {
            if let Err(e) = check_fanuc(&probing(m, test, Dialect::Fanuc)) {
                panic!("{e}");
            }
        }
    }
}

#[test]
fn heidenhain_probing_programs_keep_the_rules() {
    for m in MACHINES {
        for test in PROBING_TESTS {
            let p = probing(m, test, Dialect::Heidenhain);
            // Cycle 0 probes along one axis: every touch's approach is one.
            for t in &p.plan.touches {
                let n = t.normal_prog;
                assert!(
                    (0..3).any(|i| (n[i].abs() - 1.0).abs() < 1e-9),
                    "{m} {test}: touch {} approaches along {n:?}",
                    t.label
                );
            }
            if let Err(e) = check_heidenhain(&p) {
                panic!("{e}");
            }
        }
    }
}

/// The rule checks catch a rotary move without a retract before it, a log
/// statement for the wrong touch, and a positioning move left at the
/// probing feed.
#[test]
fn the_rule_checks_catch_a_missing_retract_a_wrong_log_and_a_slow_retract() {
    let p = probing("ac-trunnion", "probe-columns", Dialect::Fanuc);
    assert!(check_fanuc(&p).is_ok());
    let edit = |from: &str, to: &str| {
        let mut bad = p.clone();
        bad.program.text = p.program.text.replacen(from, to, 1);
        assert_ne!(bad.program.text, p.program.text, "{from}");
        check_fanuc(&bad).unwrap_err()
    };
    let e = edit("N1160 G0 Z186.\n", "N1160 G0 Z150.\n");
    assert!(e.contains("without a retract"), "{e}");
    let e = edit("N140 #199=1\n", "N140 #199=2\n");
    assert!(e.contains("is logged by"), "{e}");
    let e = edit(
        "N160 G1 X-60. Y-45. Z108. F2000.\n",
        "N160 G1 X-60. Y-45. Z108.\n",
    );
    assert!(e.contains("runs at the probing feed"), "{e}");

    let h = probing("head-table", "probe-sphere", Dialect::Heidenhain);
    let mut bad = h.clone();
    bad.program.text = h
        .program
        .text
        .replacen("REF. PLANE Q1999 X+", "REF. PLANE Q1999 X-", 1);
    let e = check_heidenhain(&bad).unwrap_err();
    assert!(e.contains("probes X-, not X+"), "{e}");
}
