//! SINUMERIK programs end to end: every test planned in `sinumerik` on
//! every built-in machine is read back by fivecal's own SINUMERIK reader
//! (strict: every block and statement known), keeps the safety rules
//! (archive header, a retract to the safe height before every rotary
//! move, rotary positions inside the machine's limits, each CYCLE800 plane
//! cancelled before the next index), and its moves, driven through the
//! simulator on the nominal machine, land where the plan says: the cuts of
//! the machining tests (axis positions, tool-tip coordinates under TRAORI,
//! coordinates in the CYCLE800 swivel plane), and every measuring block of the probing tests starts at its
//! touch's start point and is programmed to its overtravel end, followed by
//! the trigger check and the log line of its touch.

use std::path::Path;

use fivecal::compensate::simulate::{SimSettings, Simulator};
use fivecal::formats::manifest::KinematicsMode;
use fivecal::kinematics::Kinematics;
use fivecal::model::Model;
use fivecal::nc::interp::{self, Event, Interpreter};
use fivecal::nc::{Block, BlockReader, Syntax, Value};
use fivecal::post::PostDefinition;
use fivecal::procedure::MachiningPlan;
use fivecal::procedure::machining::plan;
use fivecal::procedure::probing::ProbingMoveKind;
use fivecal::{Dialect, Machine};
use nalgebra::Vector3;

use crate::plan::{TESTS, config};
use crate::plan_programs::planned_feeds;
use crate::probe_programs::probing;
use crate::simulate::PROBING;
use crate::util::MACHINES;

/// The built-in SINUMERIK postprocessor with `controller:` set to `mode`
/// (`tilted_plane`: CYCLE800, `tcp`: TRAORI).
fn post(mode: &str) -> PostDefinition {
    let builtin = PostDefinition::builtin(Dialect::Sinumerik);
    let src = builtin
        .source
        .replace("controller: tilted_plane", &format!("controller: {mode}"));
    PostDefinition::parse(Path::new("sinumerik.yaml"), &src).unwrap()
}

fn machining(m: &str, test: &str, mode: Option<&str>) -> MachiningPlan {
    let mut cfg = config(m, test, Dialect::Sinumerik, KinematicsMode::Post);
    if let Some(mode) = mode {
        cfg.kinematics = KinematicsMode::Controller;
        cfg.post = post(mode);
    }
    plan(&cfg).unwrap_or_else(|e| panic!("{test} on {m} ({mode:?}): {e}"))
}

/// The program's blocks, read strictly by the SINUMERIK reader.
fn blocks(text: &str) -> Vec<Block> {
    let mut r = BlockReader::new(text.as_bytes(), Dialect::Sinumerik);
    let syn = Syntax {
        dialect: Dialect::Sinumerik,
        strict: true,
    };
    let mut out = Vec::new();
    let mut b = Block::default();
    while r.read(&mut b).unwrap() {
        syn.parse(&mut b)
            .unwrap_or_else(|e| panic!("line {}: {}", b.line, e.message));
        out.push(b.clone());
    }
    out
}

/// The literal value of each address word of a block, by address.
fn words(b: &Block) -> Vec<(String, Option<f64>)> {
    b.segments
        .iter()
        .flat_map(|s| b.words(s).collect::<Vec<_>>())
        .map(|(_, w)| {
            (
                w.addr.to_string(),
                match w.value {
                    Value::Num(v) => Some(v),
                    _ => None,
                },
            )
        })
        .collect()
}

/// A block's code: without its block number and comment.
fn code(b: &Block) -> String {
    let t = String::from_utf8_lossy(&b.text);
    let t = t.split(';').next().unwrap_or("").trim();
    match t.strip_prefix('N') {
        Some(r) if r.starts_with(|c: char| c.is_ascii_digit()) => r
            .trim_start_matches(|c: char| c.is_ascii_digit())
            .trim_start()
            .to_string(),
        _ => t.to_string(),
    }
}

/// The safety rules, checked on the text: header, a retract to the safe
/// height (Z alone) right before every rotary move, rotary positions within
/// the machine's limits, CYCLE800 planes cancelled before the next index.
fn check_rules(text: &str, m: &Machine, test: &str, safe_z: f64) -> Result<(), String> {
    let head = format!("%_N_{}_MPF", test.to_ascii_uppercase().replace('-', "_"));
    if text.lines().next() != Some(head.as_str()) {
        return Err(format!("first line is not `{head}`"));
    }
    let tilt = m.tilt.letter.to_string();
    let mut last_motion: Option<Vec<(String, Option<f64>)>> = None;
    let mut plane = false;
    let mut rotaries = 0;
    for b in blocks(text) {
        let w = words(&b);
        let has = |a: &str| w.iter().any(|(n, _)| n == a);
        let c = code(&b);
        if c.contains("CYCLE800(") {
            let open = !c.contains("CYCLE800()");
            if open && plane {
                return Err(format!("line {}: a second CYCLE800 plane", b.line));
            }
            plane = open;
        }
        if has(&tilt) || has("C") {
            rotaries += 1;
            if has("X") || has("Y") || has("Z") {
                return Err(format!("line {}: a rotary move with a linear axis", b.line));
            }
            if plane {
                return Err(format!(
                    "line {}: a rotary index inside a CYCLE800 plane",
                    b.line
                ));
            }
            let retract = last_motion.as_ref().is_some_and(|lm| {
                lm.iter()
                    .any(|(n, v)| n == "Z" && v.is_some_and(|z| (z - safe_z).abs() < 1e-3))
                    && !lm.iter().any(|(n, _)| n == "X" || n == "Y")
            });
            if !retract {
                return Err(format!(
                    "line {}: rotary move not right after a retract to Z{safe_z}",
                    b.line
                ));
            }
            for (n, v) in &w {
                let v = v.ok_or(format!("line {}: rotary value not a number", b.line))?;
                let limits = if *n == tilt {
                    m.tilt.limits
                } else {
                    m.c.limits
                };
                if let Some((lo, hi)) = limits
                    && !(lo - 1e-9..=hi + 1e-9).contains(&v)
                {
                    return Err(format!("line {}: {n}{v} outside {lo}..{hi}", b.line));
                }
            }
        }
        if ["X", "Y", "Z", tilt.as_str(), "C"].iter().any(|a| has(a)) && !c.starts_with("SUPA") {
            last_motion = Some(w);
        }
    }
    if plane {
        return Err("the program ends inside a CYCLE800 plane".into());
    }
    if rotaries == 0 {
        return Err("no rotary move".into());
    }
    Ok(())
}

/// The tool tip the nominal machine reaches at the end of every feed move
/// of the program, through fivecal's SINUMERIK reader and simulator.
fn traced_feeds(t: &MachiningPlan) -> Vec<Vector3<f64>> {
    let k = Kinematics::with_gauge_length(&t.machine, t.tool.length);
    let model = Model::new(k, vec![]);
    let mut s = SimSettings::new(Dialect::Sinumerik);
    s.strict = true;
    let sim = Simulator::new(&model, &[], s);
    let mut out = Vec::new();
    let summary = sim
        .run(
            Path::new("program.mpf"),
            t.program.text.as_bytes(),
            &mut |s| {
                if s.feed && s.fraction == 1.0 {
                    out.push(s.nominal.tip);
                }
            },
        )
        .unwrap_or_else(|e| panic!("{e}"));
    // Every move is driven but the rapids after the tool change, until
    // X and Y are programmed again (the change left them where the
    // machine has its change position): a CYCLE800 plane the interpreter
    // did not model would leave its cuts out of the trace, with a reason.
    assert!(
        summary
            .skipped
            .iter()
            .all(|(why, _)| why.starts_with("the position of")),
        "{:?}",
        summary.skipped
    );
    assert!(summary.unmodelled.is_empty(), "{:?}", summary.unmodelled);
    out
}

#[test]
fn sinumerik_machining_programs_keep_the_rules_and_cut_where_the_plan_says() {
    for m in MACHINES {
        for test in TESTS {
            for mode in [None, Some("tcp"), Some("tilted_plane")] {
                let t = machining(m, test, mode);
                let what = format!("{m} {test} {mode:?}");
                check_rules(&t.program.text, &t.machine, test, t.safe_z)
                    .unwrap_or_else(|e| panic!("{what}: {e}"));
                if mode == Some("tilted_plane") {
                    // CYCLE800 in direct mode: the plane the rotary
                    // positions turn the tool into, whose coordinates the
                    // simulator turns into the tip below.
                    assert!(t.program.text.contains(",192,"), "{what}");
                }
                let traced = traced_feeds(&t);
                let expected = planned_feeds(&t);
                assert_eq!(traced.len(), expected.len(), "{what}: feed moves");
                let worst = traced
                    .iter()
                    .zip(&expected)
                    .map(|(a, b)| (a - b).norm())
                    .fold(0.0, f64::max);
                assert!(worst < 1e-3, "{what}: traced cut {worst} mm off the plan");
            }
        }
    }
}

#[test]
fn sinumerik_probing_programs_measure_each_touch_along_its_planned_line() {
    for m in MACHINES {
        for test in PROBING {
            let p = probing(m, test, Dialect::Sinumerik);
            let what = format!("{m} {test}");
            check_rules(&p.program.text, &p.machine, test, p.plan.safe_z)
                .unwrap_or_else(|e| panic!("{what}: {e}"));
            let expected: Vec<(usize, Vector3<f64>, Vector3<f64>)> = p
                .plan
                .moves
                .iter()
                .filter_map(|mv| match mv.kind {
                    ProbingMoveKind::Probe(i) => Some((
                        p.plan.touches[i].index,
                        p.plan.touches[i].start.axes.xyz,
                        mv.to.axes.xyz,
                    )),
                    _ => None,
                })
                .collect();
            let kin = Kinematics::with_gauge_length(&p.machine, p.probe.length);
            let mut interp =
                Interpreter::new(&interp::InterpreterSettings::new(Dialect::Sinumerik), &kin);
            let bs = blocks(&p.program.text);
            let mut found = 0;
            for (bi, b) in bs.iter().enumerate() {
                let before = interp.pos;
                for s in &b.segments {
                    let ev = interp.step(b, s);
                    assert!(
                        interp.unmodelled.take().is_none(),
                        "{what}: line {} not modelled",
                        b.line
                    );
                    if !code(b).starts_with("MEAS=1") {
                        continue;
                    }
                    assert_eq!(ev, Event::Quiet, "{what}: line {}", b.line);
                    let (index, start, to) = expected[found];
                    found += 1;
                    let w = words(b);
                    let get = |a: &str| {
                        w.iter()
                            .find(|(n, _)| n == a)
                            .and_then(|x| x.1)
                            .unwrap_or_else(|| panic!("{what}: line {}: no {a}", b.line))
                    };
                    let target = Vector3::new(get("X"), get("Y"), get("Z"));
                    assert!((target - to).norm() < 1e-4, "{what}: line {}", b.line);
                    let at = Vector3::new(
                        before[0].expect("X known"),
                        before[1].expect("Y known"),
                        before[2].expect("Z known"),
                    );
                    assert!(
                        (at - start).norm() < 1e-4,
                        "{what}: line {}: starts at {at:?}, not at {start:?}",
                        b.line
                    );
                    // The trigger check, then the touch's log line.
                    let next: Vec<String> = bs[bi + 1..bi + 12].iter().map(code).collect();
                    assert_eq!(next[0], "STOPRE", "{what}: line {}", b.line);
                    assert_eq!(next[1], "IF $AC_MEA[1]==0", "{what}: line {}", b.line);
                    let line = format!("FCLINE=\"T{index} X\"");
                    assert!(
                        next.iter().any(|l| l.starts_with(&line))
                            && next.iter().any(|l| l.starts_with("WRITE(FCERR,")),
                        "{what}: line {}: no log of touch {index} after it: {next:?}",
                        b.line
                    );
                }
            }
            assert_eq!(found, expected.len(), "{what}: measuring blocks");
            // Every word of the program is one the reader knows.
            assert!(
                bs.iter()
                    .all(|b| b.segments.iter().all(|s| s.unknown.is_none()))
            );
        }
    }
}

#[test]
fn a_missing_retract_or_a_rotary_out_of_limits_is_caught() {
    let t = machining("bc-trunnion", "stepped-square", None);
    let m = &t.machine;
    // The retract before the first side pose (its height follows the
    // riser the plan chose), taken out.
    let p = &t.program.text;
    let at = p.find("\n; pose B90").unwrap();
    let retract = &p[p[..at].rfind('\n').unwrap() + 1..at];
    assert!(retract.contains("G0 Z"), "{retract}");
    // (its block number stays: the block is left empty)
    let kept = &retract[..retract.find("G0").unwrap()];
    let broken = p.replacen(
        &format!("{retract}\n; pose B90"),
        &format!("{kept}; pose B90"),
        1,
    );
    assert_ne!(broken, t.program.text);
    let e = check_rules(&broken, m, "stepped-square", t.safe_z).unwrap_err();
    assert!(e.contains("not right after a retract"), "{e}");
    let broken = t.program.text.replacen("B90 C0", "B95 C0", 1);
    let e = check_rules(&broken, m, "stepped-square", t.safe_z).unwrap_err();
    assert!(e.contains("outside"), "{e}");
}

/// A user's loop on a SINUMERIK machine: plan the column test in
/// `sinumerik`, let the simulator write the log exactly as the program's
/// `WRITE` would, and analyze it: the eight location errors come back
/// within four standard uncertainties of the truth.
#[test]
fn the_simulated_write_log_of_a_sinumerik_probing_plan_is_analyzed() {
    use crate::analyze_sim::BC_ERRORS;
    use crate::cli::{analyze_cmd, fivecal};
    use fivecal::ErrorFile;
    let dir = crate::util::tempdir();
    let plan_dir = dir.path().join("plan");
    fivecal()
        .args([
            "plan",
            "probe-columns",
            "--machine",
            "bc-trunnion",
            "--dialect",
            "sinumerik",
            "--out",
        ])
        .arg(&plan_dir)
        .assert()
        .success();
    let manifest = plan_dir.join("probe-columns.plan.yaml");
    let program = std::fs::read_to_string(plan_dir.join("probe-columns.mpf")).unwrap();
    assert!(program.contains("WRITE(FCERR,\"FIVECAL_COLUMNS\",FCLINE)"));
    let truth = dir.path().join("truth.yaml");
    std::fs::write(&truth, format!("machine: bc-trunnion\n{BC_ERRORS}")).unwrap();
    let log = dir.path().join("FIVECAL_COLUMNS.TXT");
    fivecal()
        .args(["simulate", "--plan"])
        .arg(&manifest)
        .arg("--errors")
        .arg(&truth)
        .arg("--out")
        .arg(&log)
        .args(["--seed", "4", "--format", "log"])
        .assert()
        .success();
    let text = std::fs::read_to_string(&log).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("FIVECAL probe-columns"));
    let first = lines.next().unwrap();
    assert!(
        first.starts_with("T1 X") && !first.contains(".00000"),
        "{first}"
    );
    let out = dir.path().join("result.yaml");
    analyze_cmd(&manifest, &log, &out).assert().success();
    let k = Kinematics::with_gauge_length(
        &Machine::builtin("bc-trunnion").unwrap(),
        Machine::builtin("bc-trunnion").unwrap().probe.length,
    );
    let got = ErrorFile::load(&out, &k).unwrap();
    let names = got.model.param_names();
    for line in BC_ERRORS.lines().skip(1) {
        let (name, v) = line.trim().split_once(':').unwrap();
        let want: f64 = v.trim().parse().unwrap();
        let i = names.iter().position(|n| n == name).unwrap();
        let u = got.u[i].unwrap();
        assert!(
            (got.theta[i] - want).abs() < 4.0 * u + 0.05,
            "{name}: {} +- {u} against {want}",
            got.theta[i]
        );
    }
}
