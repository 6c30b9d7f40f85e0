//! Runs `compensate` over a local copy of the real-file corpus (the files
//! `tests/corpus/fetch.sh` brings; they are never committed, so the test
//! suite cannot run them): every NC program of `nc/fanuc`, `nc/heidenhain`,
//! `nc/linuxcnc` and `nc/sinumerik` under DIR, once at zero error, where
//! the rewrite must be byte-identical to the input, and once with location
//! errors of about 20 um and 20 urad, where the run must go through or stop
//! with a reason at a line. The machine is a built-in one with the
//! program's rotary axes, its tilt stroke widened to at least +-120 deg
//! (ten turns each way for a program without C, written for a four-axis
//! machine whose rotary table turns without end).
//!
//! ```text
//! cargo run --release --example corpus -- tests/corpus
//! ```
//!
//! Prints one row per file and a total; exits non-zero on a panic, on a
//! zero-error rewrite that changed a byte, or on a refusal that does not
//! name a line (the issue's "unexplained refusal").
//!
//! Each file's dialect is also detected from its text as a run without
//! `--dialect` does, for a machine of each controller: a file detected as
//! another dialect than its directory's is a failure, except plain G-code
//! (no sign of FANUC or LinuxCNC) read by the ISO dialect of the machine,
//! which either controller runs; those are counted apart.
//!
//! Each run with errors also counts the file's motion blocks (blocks that
//! move an axis) and how many of them were corrected, with the others by
//! the reason they were left as written. A file is five-axis when it writes
//! a rotary axis word (A, B or C with a value) or switches on tool centre
//! point control or a tilted working plane; the row says which sign and
//! where. The table after the files gives the share of motion blocks
//! corrected over the five-axis files, and their reasons grouped.
//!
//! Where LinuxCNC's interpreter `rs274` is installed (Debian package
//! `linuxcnc-uspace`), each LinuxCNC program and its rewrite with errors
//! are run through it: the rewrite must make as many moves as the input
//! (plus the pieces the rewrite inserted); an input rs274 refuses itself
//! is shown with its reason.
//!
//! Every measurement file under `cmm/` (the QIF schemas aside) is then read
//! as `fivecal measured` reads it: it must give its format and entries or be
//! refused with a message naming the file; a panic is a failure.

use std::collections::BTreeMap;
use std::io::BufReader;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use fivecal::compensate::simulate::{SimSettings, Simulator};
use fivecal::compensate::{CompensateError, Compensator, Settings, Summary};
use fivecal::errorfile::{ErrorFile, LoadedErrors};
use fivecal::formats::detect::{self, ReadContext};
use fivecal::kinematics::Kinematics;
use fivecal::model::Model;
use fivecal::nc::dialect::{Detection, detect};
use fivecal::nc::{Addr, Block, Blocks, HhKind, Stmt, Syntax, TokenKind, Value};
use fivecal::{Dialect, Machine};

/// One run's outcome.
enum Outcome {
    /// Finished: the summary, the rewritten program, and (with errors)
    /// the simulation's check of its corrected end points.
    Done(Box<Summary>, Vec<u8>, Option<Check>),
    /// Stopped with a message that names the line.
    Refused(String),
    /// Stopped without a line.
    Unexplained(String),
    Panic(String),
}

fn main() {
    let dir = match std::env::args().nth(1) {
        Some(d) => PathBuf::from(d),
        None => {
            eprintln!(
                "usage: corpus DIR   (DIR holds nc/fanuc, nc/heidenhain, nc/linuxcnc, nc/sinumerik)"
            );
            std::process::exit(2);
        }
    };
    let mut files = Vec::new();
    for (sub, dialect) in [
        ("nc/fanuc", Dialect::Fanuc),
        ("nc/heidenhain", Dialect::Heidenhain),
        ("nc/linuxcnc", Dialect::Linuxcnc),
        ("nc/sinumerik", Dialect::Sinumerik),
    ] {
        let mut found = Vec::new();
        walk(&dir.join(sub), &mut found);
        found.sort();
        files.extend(found.into_iter().map(|p| (p, dialect)));
    }
    if files.is_empty() {
        eprintln!(
            "{}: no NC programs under nc/ (run tests/corpus/fetch.sh first)",
            dir.display()
        );
        std::process::exit(2);
    }
    // LinuxCNC's own interpreter checks every LinuxCNC output, where
    // installed.
    let rs274 = Rs274::find();
    let mut rs_tally = RsTally::default();
    // Silence the default panic message: the table reports it.
    std::panic::set_hook(Box::new(|_| {}));
    let mut failures = 0;
    let (mut identical, mut ran, mut refused, mut corrected) = (0, 0, 0, 0);
    let (mut moves, mut changed) = (0usize, 0usize);
    let (mut by_sign, mut by_hint, mut plain) = (0, 0, 0);
    // Over the five-axis files that ran through: motion blocks, corrected,
    // and the others by reason (blocks, files).
    let (mut five_files, mut five_refused) = (0, 0);
    let (mut five_motion, mut five_corrected, mut five_unreadable) = (0usize, 0usize, 0usize);
    let mut five_reasons: BTreeMap<String, (usize, usize)> = BTreeMap::new();
    // The same, file by file: (file, reason, blocks, first lines).
    let mut five_left: Vec<(String, String, usize, String)> = Vec::new();
    // The simulation's check of every corrected end point, and the files
    // where it found one missing.
    let mut checks = Check::default();
    let mut check_failed: Vec<(String, String)> = Vec::new();
    println!(
        "| file | dialect | detected | machine | five-axis | zero error | with errors | motion blocks corrected | rs274 moves, input -> output |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for (path, dialect) in &files {
        let shown = path
            .strip_prefix(&dir)
            .unwrap_or(path)
            .display()
            .to_string();
        let bytes = match std::fs::read(path) {
            Ok(b) => b,
            Err(e) => {
                failures += 1;
                println!("| {shown} | {dialect} | - | cannot read: {e} | - |");
                continue;
            }
        };
        let detected = match detection(path, &bytes, *dialect) {
            Ok(d) => {
                if d.why.starts_with("from the text") {
                    by_sign += 1;
                } else if d.why.starts_with("plain G-code") {
                    plain += 1;
                } else {
                    by_hint += 1;
                }
                d.why
            }
            Err(m) => {
                failures += 1;
                m
            }
        };
        let detected = one_line(&detected);
        let five = five_axis(path, &bytes, *dialect);
        let five_cell = five.clone().unwrap_or_else(|| "-".into());
        let machine_name = machine_for(&bytes);
        // A program that never writes C (an A-only or B-only four-axis
        // program) leaves C where it is: the runner states it at 0 before
        // the first block, as the user of such a program on this machine
        // would with --rotary-start C=0.
        let rotary_start = if has_word(&bytes, b'C') {
            vec![]
        } else {
            vec![('C', 0.0)]
        };
        let mut machine = Machine::builtin(machine_name).expect("built-in machine");
        // The programs come from machines of every size: a tilt stroke of
        // at least +-120 deg (a Haas UMC-750 tilts B to 120) keeps the
        // run on the interpreter rather than on the built-in's stroke.
        machine.tilt.limits = if rotary_start.is_empty() {
            machine
                .tilt
                .limits
                .map(|(lo, hi)| (lo.min(-TILT_STROKE), hi.max(TILT_STROKE)))
        } else {
            // Without C the program was written for a four-axis machine
            // (nc2csv's "ROBO 4X" turns A through -270 deg), whose rotary
            // table turns without end: its machine file would give that
            // axis several turns each way, and so does the runner.
            Some((-FOURTH_AXIS_STROKE, FOURTH_AXIS_STROKE))
        };
        let zero = run(path, &bytes, &machine, *dialect, &rotary_start, 0.0);
        let zero_cell = match &zero {
            Outcome::Done(_, out, _) if *out == bytes => {
                identical += 1;
                "identical".to_string()
            }
            Outcome::Done(..) => {
                failures += 1;
                "CHANGED BYTES".to_string()
            }
            other => cell(other, &mut failures),
        };
        let with = run(path, &bytes, &machine, *dialect, &rotary_start, 20.0);
        let mut blocks_cell = "-".to_string();
        let mut rs_cell = "-".to_string();
        if five.is_some() {
            five_files += 1;
        }
        let with_cell = match &with {
            Outcome::Done(s, out, chk) => {
                if let Some(chk) = chk {
                    checks.add(chk);
                    if let Some(why) = chk.failure() {
                        check_failed.push((shown.clone(), why));
                    }
                }
                blocks_cell = motion_cell(s);
                if *dialect == Dialect::Linuxcnc
                    && let Some(rs) = &rs274
                {
                    rs_cell = rs274_cell(rs, path, &bytes, out, s, &mut rs_tally);
                }
                if five.is_some() {
                    five_motion += s.motion_blocks;
                    five_corrected += s.corrected_blocks;
                    five_unreadable += s.unreadable.len();
                    for (reason, lines) in &s.uncorrected_blocks {
                        let e = five_reasons.entry(reason_group(reason)).or_default();
                        e.0 += lines.len();
                        e.1 += 1;
                        five_left.push((shown.clone(), reason.clone(), lines.len(), lines.list()));
                    }
                }
                ran += 1;
                moves += s.moves;
                changed += s.changed;
                if s.changed > 0 {
                    corrected += 1;
                }
                format!(
                    "{} moves, {} blocks changed, {} left as written",
                    s.moves,
                    s.changed,
                    s.skipped_count()
                )
            }
            Outcome::Refused(m) => {
                refused += 1;
                if five.is_some() {
                    five_refused += 1;
                }
                format!("refused: {}", one_line(m))
            }
            other => cell(other, &mut failures),
        };
        println!(
            "| {shown} | {dialect} | {detected} | {machine_name} | {five_cell} | {zero_cell} | {with_cell} | {blocks_cell} | {rs_cell} |"
        );
    }
    let run_files = files.len();
    println!();
    println!(
        "dialect from the text, whatever the machine's controller: {by_sign} by a sign of their own, {by_hint} by extension or machine with no sign, {plain} plain G-code read by the machine's ISO dialect"
    );
    println!(
        "{} files: zero error {}/{} byte-identical; with errors {} ran through ({} with a block corrected; {} moves, {} blocks changed), {} refused at a named line; {} failures (panics, changed bytes at zero error, refusals without a line)",
        files.len(),
        identical,
        run_files,
        ran,
        corrected,
        moves,
        changed,
        refused,
        failures
    );
    match &rs274 {
        Some(_) => {
            println!(
                "rs274 on the LinuxCNC outputs: {} as many moves as their input (with the pieces fivecal inserted), {} with another number; {} inputs rs274 refuses itself, {} outputs it refuses",
                rs_tally.same, rs_tally.different, rs_tally.input_refused, rs_tally.output_refused
            );
            failures += rs_tally.different + rs_tally.output_refused;
        }
        None => println!(
            "rs274 (LinuxCNC's interpreter, Debian package linuxcnc-uspace) is not installed: the LinuxCNC outputs were not run through it"
        ),
    }
    println!();
    let rate = if five_motion > 0 {
        format!(
            "{:.1} %",
            100.0 * five_corrected as f64 / five_motion as f64
        )
    } else {
        "-".into()
    };
    println!(
        "five-axis files: {five_files} ({} ran through, {five_refused} refused); motion blocks {five_motion}, corrected {five_corrected}: {rate}; {five_unreadable} unreadable blocks besides (whether they move is not known)",
        five_files - five_refused
    );
    println!(
        "corrected end points checked by simulation: {}; where the program goes on the nominal machine: {} not; reached in order by the rewrite on the machine with the errors (within {} um): {} not, the farthest {:.3} um off; {} files the simulator could not run",
        checks.points,
        checks.not_intended.len(),
        REACH * 1e3,
        checks.not_reached.len(),
        checks.worst * 1e3,
        check_failed
            .iter()
            .filter(|(_, w)| w.starts_with("simulator"))
            .count()
    );
    for (file, why) in &check_failed {
        println!("  {file}: {why}");
    }
    failures += checks.not_intended.len() + checks.not_reached.len();
    println!();
    println!("| why motion blocks of the five-axis files were left as written | blocks | files |");
    println!("|---|---|---|");
    let mut reasons: Vec<_> = five_reasons.into_iter().collect();
    reasons.sort_by(|a, b| b.1.0.cmp(&a.1.0).then(a.0.cmp(&b.0)));
    for (reason, (blocks, files)) in reasons {
        println!("| {} | {blocks} | {files} |", one_line(&reason));
    }
    println!();
    println!("| five-axis file | why motion blocks were left as written | blocks | lines |");
    println!("|---|---|---|---|");
    for (file, reason, blocks, lines) in &five_left {
        println!("| {file} | {} | {blocks} | {lines} |", one_line(reason));
    }
    failures += measurement_files(&dir);
    if failures > 0 {
        std::process::exit(1);
    }
}

/// Reads every measurement file under `cmm/` as `fivecal measured` does;
/// returns the failures (panics, refusals that do not name the file).
fn measurement_files(dir: &Path) -> usize {
    let mut found = Vec::new();
    walk(&dir.join("cmm"), &mut found);
    found.retain(|p| !p.components().any(|c| c.as_os_str() == "xsd"));
    found.sort();
    let (mut read, mut refused, mut failures) = (0, 0, 0);
    println!();
    println!("| measurement file | read as |");
    println!("|---|---|");
    for path in &found {
        let shown = path.strip_prefix(dir).unwrap_or(path).display().to_string();
        let outcome = catch_unwind(AssertUnwindSafe(|| {
            detect::inventory(path, &ReadContext::default())
        }));
        let cell = match outcome {
            Ok(Ok(inv)) => {
                read += 1;
                format!(
                    "{} {}, {} entries, {} warnings",
                    inv.format,
                    inv.version.as_deref().unwrap_or(""),
                    inv.entries.len(),
                    inv.warnings.len()
                )
            }
            Ok(Err(e)) => {
                let m = e.to_string();
                if m.contains(&path.display().to_string()) {
                    refused += 1;
                    format!("refused: {}", one_line(&m))
                } else {
                    failures += 1;
                    format!("REFUSED WITHOUT THE FILE: {}", one_line(&m))
                }
            }
            Err(_) => {
                failures += 1;
                "PANIC".to_string()
            }
        };
        println!("| {shown} | {cell} |");
    }
    println!();
    println!(
        "{} measurement files: {read} read, {refused} refused naming the file; {failures} failures",
        found.len()
    );
    failures
}

/// The dialect a run without `--dialect` reads `bytes` in, on a machine
/// of each controller: the detection on a machine of another controller
/// than `dialect` (the hard case), or why a detection went wrong.
fn detection(path: &Path, bytes: &[u8], dialect: Dialect) -> Result<Detection, String> {
    let mut shown = None;
    for machine in [Dialect::Fanuc, Dialect::Heidenhain, Dialect::Linuxcnc] {
        let d = detect(path, bytes, machine);
        let iso = |x: Dialect| x != Dialect::Heidenhain;
        let either = d.why.starts_with("plain G-code") && iso(dialect) && iso(d.dialect);
        if d.dialect != dialect && !either {
            return Err(format!(
                "WRONG on a {machine} machine: read as {} ({})",
                d.dialect, d.why
            ));
        }
        if machine != dialect && shown.is_none() {
            shown = Some(d);
        }
    }
    Ok(shown.expect("three controllers, one the file's"))
}

/// What rs274 made of the LinuxCNC outputs.
#[derive(Default)]
struct RsTally {
    same: usize,
    different: usize,
    input_refused: usize,
    output_refused: usize,
}

/// The rs274 cell of a LinuxCNC file: the moves rs274 makes of the input
/// and of the rewritten program, which must be as many as the input's
/// plus the blocks the rewrite inserted (pieces of subdivided moves and
/// linearized arcs).
fn rs274_cell(
    rs: &Rs274,
    path: &Path,
    input: &[u8],
    output: &[u8],
    s: &Summary,
    tally: &mut RsTally,
) -> String {
    let dir = path.parent().unwrap_or(Path::new("."));
    // A file that is one subroutine (`o<name> sub` ... `endsub`, as
    // LinuxCNC's nc_files keep them) is run by a call of it.
    let stem = path.file_stem().map(|s| s.to_string_lossy().to_lowercase());
    let sub = stem.filter(|stem| {
        let text = String::from_utf8_lossy(input)
            .to_lowercase()
            .replace([' ', '\t'], "");
        text.contains(&format!("o<{stem}>sub"))
    });
    let sub = sub.as_deref();
    let before = match rs.moves(input, dir, sub) {
        Ok(n) => n,
        Err(why) => {
            tally.input_refused += 1;
            return format!("refuses the input: {}", one_line(&why));
        }
    };
    match rs.moves(output, dir, sub) {
        Ok(after) if after == before + s.inserted => {
            tally.same += 1;
            if s.inserted > 0 {
                format!("{before} -> {after} ({} inserted)", s.inserted)
            } else {
                format!("{before} -> {after}")
            }
        }
        Ok(after) => {
            tally.different += 1;
            format!(
                "MOVES DIFFER: {before} -> {after} ({} inserted)",
                s.inserted
            )
        }
        Err(why) => {
            tally.output_refused += 1;
            format!("REFUSES THE OUTPUT: {}", one_line(&why))
        }
    }
}

/// LinuxCNC's standalone interpreter `rs274`, with an INI file that
/// remaps the 5-axis demos' TCP codes (M428-M430) to empty subroutines
/// and a tool table with tools 1 to 99, so that it runs the corpus's
/// programs as their configurations would.
struct Rs274 {
    dir: tempfile::TempDir,
}

impl Rs274 {
    /// `None` where rs274 is not installed.
    fn find() -> Option<Rs274> {
        let ok = std::process::Command::new("rs274")
            .arg("-h")
            .stdin(std::process::Stdio::null())
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .status()
            .is_ok();
        if !ok {
            return None;
        }
        let dir = tempfile::tempdir().expect("a temporary directory");
        for m in ["m428", "m429", "m430"] {
            std::fs::write(
                dir.path().join(format!("{m}.ngc")),
                format!("o<{m}> sub\no<{m}> endsub\nm2\n"),
            )
            .expect("subroutine written");
        }
        let tools: String = (1..100)
            .map(|n| format!("T{n} P{n} Z0 D6 ;corpus\n"))
            .collect();
        std::fs::write(dir.path().join("tool.tbl"), tools).expect("tool table written");
        Some(Rs274 { dir })
    }

    /// The moves rs274 makes of `program` (STRAIGHT_TRAVERSE,
    /// STRAIGHT_FEED, ARC_FEED, STRAIGHT_PROBE), its subroutines looked for
    /// in `dir` as well; or why it stopped. A program that is the
    /// subroutine `sub` is called (without arguments) from a main program.
    fn moves(&self, program: &[u8], dir: &Path, sub: Option<&str>) -> Result<usize, String> {
        let home = self.dir.path();
        let ini = home.join("corpus.ini");
        std::fs::write(
            &ini,
            format!(
                "[RS274NGC]\nSUBROUTINE_PATH = {}:{}\nREMAP = M428 modalgroup=10 ngc=m428\nREMAP = M429 modalgroup=10 ngc=m429\nREMAP = M430 modalgroup=10 ngc=m430\n",
                home.display(),
                dir.display()
            ),
        )
        .map_err(|e| e.to_string())?;
        let prog = home.join("program.ngc");
        match sub {
            Some(name) => {
                std::fs::write(home.join(format!("{name}.ngc")), program)
                    .map_err(|e| e.to_string())?;
                std::fs::write(&prog, format!("o<{name}> call\nm2\n"))
                    .map_err(|e| e.to_string())?;
            }
            None => std::fs::write(&prog, program).map_err(|e| e.to_string())?,
        }
        let canon = home.join("program.canon");
        let stderr = home.join("program.err");
        // rs274 keeps its tool table in $HOME/.tool.mmap.
        let mut child = std::process::Command::new("rs274")
            .env("HOME", home)
            .arg("-i")
            .arg(&ini)
            .arg("-t")
            .arg(home.join("tool.tbl"))
            .arg("-g")
            .arg(&prog)
            .stdin(std::process::Stdio::null())
            .stdout(std::fs::File::create(&canon).map_err(|e| e.to_string())?)
            .stderr(std::fs::File::create(&stderr).map_err(|e| e.to_string())?)
            .spawn()
            .map_err(|e| e.to_string())?;
        // A program that loops for ever is stopped after a minute.
        let start = std::time::Instant::now();
        let status = loop {
            if let Some(s) = child.try_wait().map_err(|e| e.to_string())? {
                break s;
            }
            if start.elapsed() > std::time::Duration::from_secs(60) {
                let _ = child.kill();
                let _ = child.wait();
                return Err("still running after 60 s".into());
            }
            std::thread::sleep(std::time::Duration::from_millis(5));
        };
        let err = std::fs::read_to_string(&stderr).unwrap_or_default();
        if !status.success() {
            let why: Vec<&str> = err
                .lines()
                .filter(|l| !l.trim().is_empty() && l.trim() != "executing")
                .take(2)
                .collect();
            return Err(why.join(": "));
        }
        let text = std::fs::read_to_string(&canon).map_err(|e| e.to_string())?;
        Ok(text
            .lines()
            .filter(|l| {
                [
                    "STRAIGHT_TRAVERSE(",
                    "STRAIGHT_FEED(",
                    "ARC_FEED(",
                    "STRAIGHT_PROBE(",
                ]
                .iter()
                .any(|m| l.contains(m))
            })
            .count())
    }
}

/// The motion blocks of a run, corrected, and the largest reason left.
fn motion_cell(s: &Summary) -> String {
    let mut cell = format!("{}/{}", s.corrected_blocks, s.motion_blocks);
    if let Some((reason, lines)) = s.uncorrected_blocks.iter().max_by_key(|(_, l)| l.len()) {
        cell.push_str(&format!(
            "; most left: {} ({})",
            one_line(&reason_group(reason)),
            lines.len()
        ));
    }
    cell
}

/// A reason with what varies from file to file taken out, so that
/// reasons group: the line and column numbers, the number of runs of a
/// loop, and what an unreadable block stopped at.
fn reason_group(reason: &str) -> String {
    let mut out = reason.to_string();
    if let Some(i) = out.find(" (column ") {
        out.truncate(i);
    }
    for key in ["line ", "lines ", "runs "] {
        let mut from = 0;
        while let Some(i) = out[from..].find(key) {
            let at = from + i + key.len();
            let digits = out[at..].bytes().take_while(u8::is_ascii_digit).count();
            if digits > 0 {
                out.replace_range(at..at + digits, "N");
            }
            from = at;
        }
    }
    out
}

/// Why a program is five-axis, with the line: its first rotary axis word
/// (A, B or C with a value, in a statement of words or a HEIDENHAIN
/// straight line, not the arguments of a macro call) or its first code for tool centre point control or a
/// tilted working plane; `None` for a program with neither.
fn five_axis(path: &Path, bytes: &[u8], dialect: Dialect) -> Option<String> {
    let syntax = Syntax {
        dialect,
        strict: false,
    };
    let mut blocks = Blocks::new(path, BufReader::new(bytes), syntax);
    while let Ok(Some(b)) = blocks.next_block() {
        if let Some(sign) = five_axis_sign(b) {
            return Some(format!("{sign} (line {})", b.line));
        }
    }
    None
}

fn five_axis_sign(b: &Block) -> Option<String> {
    for seg in &b.segments {
        match seg.stmt {
            Stmt::Hh(HhKind::Plane) => return Some("PLANE".into()),
            Stmt::Hh(HhKind::FunctionTcpm) => return Some("FUNCTION TCPM".into()),
            Stmt::Hh(HhKind::CyclDef { number: 19, .. }) => return Some("CYCL DEF 19".into()),
            Stmt::Words | Stmt::Hh(HhKind::L | HhKind::M) => {}
            _ => continue,
        }
        // The letters of a macro call (G65, G66) are its arguments.
        let call = b.words(seg).any(|(_, w)| {
            w.addr == Addr::new("G") && matches!(w.value, Value::Num(v) if v == 65.0 || v == 66.0)
        });
        for (_, w) in b.words(seg).filter(|_| !call) {
            let is = |s: &str| w.addr == Addr::new(s);
            if (is("A") || is("B") || is("C")) && w.value != Value::None {
                return Some(format!("{} word", w.addr));
            }
            let Value::Num(v) = w.value else { continue };
            let code = (v * 10.0).round() as i64;
            if is("G") && matches!(code, 434 | 435 | 682 | 683 | 684 | 531) {
                return Some(format!("G{v}"));
            }
            if is("M") && matches!(code, 1280 | 4280) {
                return Some(format!("M{v}"));
            }
        }
        for t in &b.tokens[seg.first as usize..seg.end as usize] {
            if t.kind == TokenKind::Keyword {
                let k = String::from_utf8_lossy(b.bytes(t.span)).to_ascii_uppercase();
                if k == "TRAORI" || k == "CYCLE800" {
                    return Some(k);
                }
            }
        }
    }
    None
}

/// The table cell of a run that did not finish.
fn cell(o: &Outcome, failures: &mut usize) -> String {
    match o {
        Outcome::Done(..) => unreachable!("finished runs are shown by the caller"),
        Outcome::Refused(m) => format!("refused: {}", one_line(m)),
        Outcome::Unexplained(m) => {
            *failures += 1;
            format!("UNEXPLAINED: {}", one_line(m))
        }
        Outcome::Panic(m) => {
            *failures += 1;
            format!("PANIC: {}", one_line(m))
        }
    }
}

fn one_line(m: &str) -> String {
    let first = m.lines().next().unwrap_or("").replace('|', "/");
    let mut s: String = first.chars().take(140).collect();
    if first.chars().count() > 140 {
        s.push_str("...");
    }
    s
}

/// Files under `dir`, depth first.
fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    for e in rd.flatten() {
        let p = e.path();
        if p.is_dir() {
            walk(&p, out);
        } else {
            out.push(p);
        }
    }
}

/// The tilt stroke the runs allow at least, deg.
const TILT_STROKE: f64 = 120.0;

/// The stroke of a four-axis program's rotary table, deg: ten turns
/// each way.
const FOURTH_AXIS_STROKE: f64 = 3600.0;

/// A built-in machine with the rotary axes the program uses: B and C
/// (bc-trunnion) when it writes B words and no A, else A and C.
fn machine_for(bytes: &[u8]) -> &'static str {
    if has_word(bytes, b'B') && !has_word(bytes, b'A') {
        "bc-trunnion"
    } else {
        "ac-trunnion"
    }
}

/// Whether the text has a word of this letter with a literal value
/// (`C0`, `c-12.5`), anywhere (comments too).
fn has_word(bytes: &[u8], letter: u8) -> bool {
    bytes.windows(2).enumerate().any(|(i, w)| {
        w[0].eq_ignore_ascii_case(&letter)
            && (w[1].is_ascii_digit() || matches!(w[1], b'-' | b'+' | b'.'))
            && (i == 0 || !bytes[i - 1].is_ascii_alphabetic())
    })
}

/// Location errors of `size` um / urad on every symbol (fixed pattern),
/// or all zero.
fn errors(machine: &Machine, size: f64) -> LoadedErrors {
    let k = Kinematics::new(machine);
    let model = Model::new(k.clone(), vec![]);
    let mut src = format!("machine: {}\nlocation_errors:\n", machine.name);
    for (i, s) in model.symbols.location.iter().enumerate() {
        // A fixed spread of signs and sizes, no randomness needed.
        let v = size * ((i as f64 * 2.399).sin());
        src.push_str(&format!("  {}: {v:.3}\n", s.name));
    }
    ErrorFile::parse(Path::new("corpus-errors.yaml"), &src)
        .and_then(|f| f.to_model(&k, Path::new("corpus-errors.yaml"), &src))
        .expect("generated error file reads")
}

fn run(
    path: &Path,
    bytes: &[u8],
    machine: &Machine,
    dialect: Dialect,
    rotary_start: &[(char, f64)],
    size: f64,
) -> Outcome {
    let e = errors(machine, size);
    let mut settings = Settings::new(dialect);
    settings.rotary_start = rotary_start.to_vec();
    let c = Compensator::new(&e.model, &e.theta, settings);
    let mut out = Vec::with_capacity(bytes.len() + 1024);
    let mut vertices = Vec::new();
    let r = catch_unwind(AssertUnwindSafe(|| {
        c.run_observed(path, BufReader::new(bytes), &mut out, &mut |v| {
            if !v.inserted {
                vertices.push((v.line, v.target.tip));
            }
        })
    }));
    match r {
        Ok(Ok(s)) => {
            let check = if size > 0.0 && !vertices.is_empty() {
                Some(check(
                    path,
                    bytes,
                    &out,
                    &e,
                    dialect,
                    rotary_start,
                    &vertices,
                ))
            } else {
                None
            };
            Outcome::Done(Box::new(s), out, check)
        }
        Ok(Err(err)) => {
            let m = err.to_string();
            match err {
                CompensateError::Syntax(_)
                | CompensateError::Unmodelled(_)
                | CompensateError::TooLarge { .. }
                | CompensateError::Tolerance { .. } => Outcome::Refused(m),
                CompensateError::Io(_) => Outcome::Unexplained(m),
            }
        }
        Err(p) => Outcome::Panic(
            p.downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "panic".into()),
        ),
    }
}

/// The simulation's check of one rewrite: every end point the rewrite
/// corrected, as `compensate` reports it, against the program itself run
/// on the nominal machine (the point it meant to reach is where the
/// program goes) and against the rewritten text run on the machine with
/// the errors (the text really reaches it).
#[derive(Default)]
struct Check {
    /// Corrected end points.
    points: usize,
    /// Whose target is not where the program goes on the nominal machine
    /// (lines).
    not_intended: Vec<usize>,
    /// That the rewrite run on the erroneous machine does not reach, in
    /// order (lines).
    not_reached: Vec<usize>,
    /// Why the simulator could not run one of the two.
    refused: Option<String>,
    /// The farthest a reached point is from its target, mm.
    worst: f64,
}

impl Check {
    /// What went wrong, if anything.
    fn failure(&self) -> Option<String> {
        let lines = |v: &[usize]| {
            v.iter()
                .take(8)
                .map(|l| l.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        };
        if let Some(why) = &self.refused {
            Some(format!("simulator refused {}", one_line(why)))
        } else if !self.not_intended.is_empty() || !self.not_reached.is_empty() {
            Some(format!(
                "{} end points not where the program goes (lines {}), {} not reached (lines {})",
                self.not_intended.len(),
                lines(&self.not_intended),
                self.not_reached.len(),
                lines(&self.not_reached)
            ))
        } else {
            None
        }
    }

    fn add(&mut self, o: &Check) {
        self.points += o.points;
        self.not_intended.extend(&o.not_intended);
        self.not_reached.extend(&o.not_reached);
        self.worst = self.worst.max(o.worst);
        if self.refused.is_none() {
            self.refused.clone_from(&o.refused);
        }
    }
}

/// How close a corrected end point must come to its target, mm: the
/// rewrite writes values to the program's own decimals, so a point is
/// off by at most half a unit of the last decimal per axis, 0.5 um on
/// the usual three-decimal programs; 1 um leaves room for the rotary
/// axes' rounding carried out to the tip.
const REACH: f64 = 1e-3;

/// How far ahead in the rewrite's samples a corrected end point is
/// looked for: the pieces of a subdivided move come before its end.
const LOOK_AHEAD: usize = 70_000;

fn check(
    path: &Path,
    bytes: &[u8],
    out: &[u8],
    e: &LoadedErrors,
    dialect: Dialect,
    rotary_start: &[(char, f64)],
    vertices: &[(usize, Vector3<f64>)],
) -> Check {
    let mut settings = SimSettings::new(dialect);
    settings.rotary_start = rotary_start.to_vec();
    let run = |model: &Model, theta: &[f64], text: &[u8]| {
        let sim = Simulator::new(model, theta, settings.clone());
        let mut ends = Vec::new();
        sim.run(path, BufReader::new(text), &mut |x| {
            if x.fraction == 1.0 {
                ends.push((x.line, x.nominal.tip, x.actual.tip));
            }
        })
        .map(|_| ends)
    };
    let mut c = Check {
        points: vertices.len(),
        ..Check::default()
    };
    let nominal = Model::new(e.model.kin.clone(), vec![]);
    let intended = match run(&nominal, &[], bytes) {
        Ok(x) => x,
        Err(err) => {
            c.refused = Some(format!("the program: {err}"));
            return c;
        }
    };
    let actual = match run(&e.model, &e.theta, out) {
        Ok(x) => x,
        Err(err) => {
            c.refused = Some(format!("the rewrite: {err}"));
            return c;
        }
    };
    let mut by_line: BTreeMap<usize, Vec<Vector3<f64>>> = BTreeMap::new();
    for (line, tip, _) in &intended {
        by_line.entry(*line).or_default().push(*tip);
    }
    let mut j = 0;
    for (line, target) in vertices {
        let meant = by_line
            .get(line)
            .is_some_and(|tips| tips.iter().any(|t| (t - target).norm() < REACH));
        if !meant {
            c.not_intended.push(*line);
        }
        let end = (j + LOOK_AHEAD).min(actual.len());
        match actual[j..end]
            .iter()
            .position(|(_, _, tip)| (tip - target).norm() < REACH)
        {
            Some(k) => {
                c.worst = c.worst.max((actual[j + k].2 - target).norm());
                j += k + 1;
            }
            None => c.not_reached.push(*line),
        }
    }
    c
}
