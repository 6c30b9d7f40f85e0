//! Probe logs as worked examples: each dialect's log of the six touches in
//! `fixtures/probe/small.points.csv` (ac-trunnion, ball radius 3 mm), read
//! into the contact points of `small.measured.csv`; malformed lines
//! rejected at file:line:column; logs that do not fit the plan refused;
//! and the writers a simulator uses, printing exactly what each control
//! prints, read back through the readers.

use std::path::Path;

use fivecal::formats::measured;
use fivecal::formats::points::PlanPoints;
use fivecal::formats::probe_log::{
    self, Logged, ProbeLog, ReadOptions, Repeats, fanuc, heidenhain, linuxcnc, sinumerik, write,
};
use fivecal::kinematics::Kinematics;
use fivecal::machine::Dialect;
use fivecal::procedure::Test;
use fivecal::procedure::probing::columns;
use fivecal::procedure::probing::columns::ColumnsTemplate;
use nalgebra::Vector3;

use crate::util::machine;

const DIR: &str = "tests/fixtures/probe";

fn fixture(name: &str) -> String {
    std::fs::read_to_string(format!("{DIR}/{name}")).unwrap()
}

fn small_plan() -> PlanPoints {
    PlanPoints::parse(Path::new("small.points.csv"), &fixture("small.points.csv")).unwrap()
}

fn kin() -> Kinematics {
    let m = machine("ac-trunnion");
    Kinematics::with_gauge_length(&m, m.probe.length)
}

fn opts() -> ReadOptions {
    ReadOptions {
        ball_radius: 3.0,
        window: (3.0, 5.0),
        lateral_tolerance: 0.1,
        repeats: Repeats::KeepLast,
        test: Some(Test::ProbeColumns),
    }
}

fn read(dialect: Dialect, name: &str, src: &str, o: &ReadOptions) -> Result<ProbeLog, String> {
    probe_log::read(dialect, Path::new(name), src, &small_plan(), &kin(), o)
        .map_err(|e| e.to_string())
}

fn expected() -> Vec<(String, Vector3<f64>)> {
    measured::parse_csv(
        Path::new("small.measured.csv"),
        &fixture("small.measured.csv"),
    )
    .unwrap()
    .into_iter()
    .map(|p| (p.label, p.p))
    .collect()
}

fn assert_points(log: &ProbeLog, want: &[(String, Vector3<f64>)]) {
    let got: Vec<(String, Vector3<f64>)> =
        log.points.iter().map(|p| (p.label.clone(), p.p)).collect();
    assert_eq!(got.len(), want.len(), "{got:?}");
    for (g, w) in got.iter().zip(want) {
        assert_eq!(g.0, w.0);
        assert!((g.1 - w.1).norm() < 1e-9, "{}: {:?} vs {:?}", g.0, g.1, w.1);
    }
}

#[test]
fn fanuc_dprnt_log_with_padded_fields_tape_marks_and_a_repeat_gives_the_contact_points() {
    let log = read(
        Dialect::Fanuc,
        "fanuc-dprnt.log",
        &fixture("fanuc-dprnt.log"),
        &opts(),
    )
    .unwrap();
    assert_points(&log, &expected());
    assert!(log.missing.is_empty());
    assert_eq!(
        log.notes,
        ["line 10: touch 6 (A-90C0_C2_xp) repeats line 9 with the same numbers; counted once"]
    );
    // The canonical file, as `analyze` will read it.
    let csv = measured::to_csv(
        &log.points,
        &["contact points in W at rotary zero (program coordinates), mm"],
    );
    assert_eq!(csv, fixture("small.measured.csv"));
    assert_eq!(log.points[2].line, 5, "points keep their log line");
}

#[test]
fn heidenhain_log_with_decimal_commas_and_an_appended_run_keeps_the_later_touch() {
    let src = fixture("heidenhain-fn16-comma.txt");
    let log = read(Dialect::Heidenhain, "probe.txt", &src, &opts()).unwrap();
    let mut want = expected();
    // Touch 4 was measured again in the second run; touch 6 is a `K`
    // line, a contact point the control compensated itself.
    want[3].1.y = 34.999;
    assert_points(&log, &want);
    assert_eq!(log.notes.len(), 2, "{:?}", log.notes);
    assert!(log.notes[0].starts_with("the log holds 2 runs (headers at lines 1, 7)"));
    assert_eq!(
        log.notes[1],
        "line 8: touch 4 (A0C90_C1_xp) logged again (first at line 5); the later value is used"
    );
    let strict = ReadOptions {
        repeats: Repeats::Reject,
        ..opts()
    };
    assert_eq!(
        read(Dialect::Heidenhain, "probe.txt", &src, &strict).unwrap_err(),
        "probe.txt:8:1: touch 4 (A0C90_C1_xp) is logged again with other numbers (first at line 5)"
    );
}

#[test]
fn linuxcnc_log_joins_by_label_and_lists_the_touch_it_lacks() {
    let log = read(
        Dialect::Linuxcnc,
        "probe.log",
        &fixture("linuxcnc-log.txt"),
        &opts(),
    )
    .unwrap();
    assert_points(&log, &expected()[..5]);
    assert_eq!(log.missing, ["A-90C0_C2_xp"]);
    assert_eq!(
        log.notes,
        ["1 of 6 planned touches are not in the log (first: A-90C0_C2_xp)"]
    );
}

#[test]
fn linuxcnc_probeopen_file_joins_by_order_and_a_shifted_one_is_caught() {
    let p = Path::new("probe.txt");
    let src = fixture("linuxcnc-probeopen.txt");
    let raw = linuxcnc::parse_probe_file(p, &src, 'A').unwrap();
    let log = probe_log::join(p, &raw, &small_plan(), &kin(), &opts()).unwrap();
    assert_points(&log, &expected());
    // A touch missing in the middle shifts every later line onto the wrong
    // touch; the rotary columns give it away at once.
    let shifted: String = src
        .lines()
        .enumerate()
        .filter(|(i, _)| *i != 2)
        .map(|(_, l)| format!("{l}\n"))
        .collect();
    let raw = linuxcnc::parse_probe_file(p, &shifted, 'A').unwrap();
    let e = probe_log::join(p, &raw, &small_plan(), &kin(), &opts()).unwrap_err();
    assert_eq!(
        e.to_string(),
        "probe.txt:3:1: touch 3 (A0C0_C3_t1) was logged at A = 0, C = 90, but its pose A0C0 is at A = 0, C = 0"
    );
    // Old three-column files carry no angles: the probing-line check finds
    // the shift instead.
    let three: String = shifted
        .lines()
        .map(|l| l.split(' ').take(3).collect::<Vec<_>>().join(" ") + "\n")
        .collect();
    let raw = linuxcnc::parse_probe_file(p, &three, 'A').unwrap();
    let e = probe_log::join(p, &raw, &small_plan(), &kin(), &opts()).unwrap_err();
    assert!(
        e.to_string()
            .starts_with("probe.txt:3:1: touch 3 (A0C0_C3_t1): the logged position lies"),
        "{e}"
    );
}

#[test]
fn malformed_lines_are_rejected_with_line_column_and_what_was_expected() {
    let fan = fixture("fanuc-dprnt.log");
    let cases = [
        (
            Dialect::Fanuc,
            fan.replace("Y   31.9992", "Q   31.9992"),
            "probe.log:7:21: expected `Y` and a number, found `Q   31.9992 Z   85.0000` (a touch line is `T<index> X<x> Y<y> Z<z>`)",
        ),
        (
            Dialect::Fanuc,
            fan.replace("T3 X-.4187", "PT3 X-.4187"),
            "probe.log:5:1: expected `T` and the touch index, found `PT3 X-.4187 Y0. Z103.000` (a touch line is `T<index> X<x> Y<y> Z<z>`)",
        ),
        (
            Dialect::Fanuc,
            fan.replace("Z  103.0021", "Z  103.0021 OK"),
            "probe.log:3:45: expected the end of the line, found `OK` (a touch line is `T<index> X<x> Y<y> Z<z>`)",
        ),
        (
            Dialect::Heidenhain,
            fixture("heidenhain-fn16-comma.txt").replace("T2 X-31,9987", "T2 X-31;9987"),
            "probe.log:3:8: expected `Y` and a number, found `;9987 Y-45,0000 Z85,0000` (a touch line is `T<index> X<x> Y<y> Z<z> (or K<index> ...)`)",
        ),
        (
            Dialect::Heidenhain,
            fixture("heidenhain-fn16-comma.txt").replace("T5 X60,0000", "T5 Xnan"),
            "probe.log:9:4: expected `X` and a number, found `Xnan Y-102,9985 Z-45,000` (a touch line is `T<index> X<x> Y<y> Z<z> (or K<index> ...)`)",
        ),
        (
            Dialect::Linuxcnc,
            fixture("linuxcnc-log.txt").replace(" Z85.000000\nT A0C0_C3", "\nT A0C0_C3"),
            "probe.log:3:37: expected `Z` and a number, found the end of the line (a touch line is `T <label> X<x> Y<y> Z<z>`)",
        ),
    ];
    for (dialect, src, want) in cases {
        assert_eq!(read(dialect, "probe.log", &src, &opts()).unwrap_err(), want);
    }
    let e = read(
        Dialect::Linuxcnc,
        "probe.log",
        &fixture("linuxcnc-log.txt").replace("A0C0_C1_xp", "A0C0_C9_xp"),
        &opts(),
    )
    .unwrap_err();
    assert_eq!(
        e,
        "probe.log:3:3: label `A0C0_C9_xp` is not a point of the plan"
    );
    let e = read(
        Dialect::Fanuc,
        "fanuc.log",
        &fan.replace("T     5 X", "T    15 X"),
        &opts(),
    )
    .unwrap_err();
    assert_eq!(
        e,
        "fanuc.log:8:1: touch index 15: the plan has touches 1 to 6"
    );
}

#[test]
fn logs_that_do_not_fit_the_plan_are_refused() {
    let fan = fixture("fanuc-dprnt.log");
    // Machine coordinates instead of W (work offset left at machine zero):
    // X -60 becomes -410.7675, far off the first touch's probing line.
    let e = read(
        Dialect::Fanuc,
        "f.log",
        &fan.replace("T     1 X-  60.0000", "T     1 X- 410.7675"),
        &opts(),
    )
    .unwrap_err();
    assert!(
        e.starts_with("f.log:3:1: touch 1 (A0C0_C1_t1): the logged position lies 350.767 mm off its probing line"),
        "{e}"
    );
    // No trigger: G31 leaves the programmed end point, 3 mm past the surface.
    let e = read(
        Dialect::Fanuc,
        "f.log",
        &fan.replace("Z  103.0021", "Z  100.0000"),
        &opts(),
    )
    .unwrap_err();
    assert_eq!(
        e,
        "f.log:3:1: touch 1 (A0C0_C1_t1): the contact lies 3.000 mm inside the nominal surface, at or past the 3 mm overtravel: the probe did not trigger"
    );
    // A log of another test.
    let other = ReadOptions {
        test: Some(Test::ProbeSphere),
        ..opts()
    };
    assert_eq!(
        read(Dialect::Fanuc, "f.log", &fan, &other).unwrap_err(),
        "f.log:2:1: this log is of `PROBE-COLUMNS`, but the plan is `probe-sphere`"
    );
}

#[test]
fn the_nc_text_the_post_must_emit_is_exactly_the_documented_one() {
    assert_eq!(
        fanuc::open_blocks("probe-columns"),
        ["POPEN", "DPRNT[FIVECAL*PROBE-COLUMNS]"]
    );
    assert_eq!(
        fanuc::touch_blocks(17),
        [
            "#199=17",
            "DPRNT[T#199[50]*X#5061[44]*Y#5062[44]*Z#5063[44]]"
        ]
    );
    assert_eq!(fanuc::close_blocks(), ["PCLOS"]);
    assert_eq!(
        heidenhain::header_format_file("probe-sphere"),
        "\"FIVECAL probe-sphere\";\n"
    );
    assert_eq!(
        heidenhain::touch_format_file(Logged::BallCentre),
        "M_APPEND;\n\"T%D X%.4LF Y%.4LF Z%.4LF\",Q1900,Q1901,Q1902,Q1903;\n"
    );
    assert_eq!(
        heidenhain::touch_statements(17, "TNC:\\fivecal\\t.A", "TNC:\\fivecal\\p.txt"),
        [
            "Q1900 = 17",
            "FN 16: F-PRINT TNC:\\fivecal\\t.A / TNC:\\fivecal\\p.txt"
        ]
    );
    assert_eq!(
        heidenhain::cycle0_reads(),
        [
            "FN 18: SYSREAD Q1901 = ID360 NR1 IDX1",
            "FN 18: SYSREAD Q1902 = ID360 NR1 IDX2",
            "FN 18: SYSREAD Q1903 = ID360 NR1 IDX3"
        ]
    );
    assert_eq!(
        linuxcnc::open_lines(
            "probe-columns",
            "probe-columns.log",
            Some("probe-columns.probe")
        ),
        [
            "(LOGOPEN,probe-columns.log)",
            "(LOG,FIVECAL probe-columns)",
            "(PROBEOPEN probe-columns.probe)"
        ]
    );
    assert_eq!(
        linuxcnc::touch_line("A0C0_C1_xp"),
        "(LOG,T A0C0_C1_xp X#5061 Y#5062 Z#5063)"
    );
    assert_eq!(linuxcnc::close_lines(true), ["(PROBECLOSE)", "(LOGCLOSE)"]);
}

#[test]
fn written_lines_match_the_fixtures_and_read_back() {
    let fan = fixture("fanuc-dprnt.log");
    let fan_lines: Vec<&str> = fan.lines().map(|l| l.trim_end_matches('\r')).collect();
    let b = Vector3::new(-60.0, -45.0, 103.0021);
    assert_eq!(fanuc::touch_line(1, &b, fanuc::Prt::Spaces), fan_lines[2]);
    assert_eq!(
        fanuc::touch_line(
            3,
            &Vector3::new(-0.4187, 0.0, 103.0),
            fanuc::Prt::Suppressed
        ),
        "T3 X-.4187 Y.0000 Z103.0000"
    );
    let hh = fixture("heidenhain-fn16-comma.txt");
    assert_eq!(
        heidenhain::touch_line(1, &b, Logged::BallCentre, true),
        hh.lines().nth(1).unwrap()
    );
    let lc = fixture("linuxcnc-log.txt");
    assert_eq!(
        linuxcnc::log_line("A0C0_C1_t1", &b),
        lc.lines().nth(1).unwrap()
    );
}

/// LinuxCNC's own interpreter runs a probe move followed by our LOG line:
/// the line it logs is one our reader parses (rs274 alone has no probe
/// input, so the probe position it reports is the programmed end point).
#[test]
fn rs274_expands_our_log_line_into_a_line_the_reader_parses() {
    let dir = crate::util::tempdir();
    let ngc = dir.path().join("t.ngc");
    let mut prog = String::from("G21 G90 G54\n");
    for l in linuxcnc::open_lines("probe-columns", "t.log", None) {
        prog += &format!("{l}\n");
    }
    prog += "G0 X-60 Y-45 Z108\nG38.2 X-60 Y-45 Z100 F100\n";
    prog += &format!("{}\n", linuxcnc::touch_line("A0C0_C1_t1"));
    for l in linuxcnc::close_lines(false) {
        prog += &format!("{l}\n");
    }
    prog += "M2\n";
    std::fs::write(&ngc, prog).unwrap();
    let out = std::process::Command::new("rs274")
        .arg("-g")
        .arg(&ngc)
        .current_dir(dir.path())
        .output()
        .expect("rs274 (linuxcnc-uspace) is installed");
    let text = String::from_utf8_lossy(&out.stdout);
    let logged: String = text
        .lines()
        .filter_map(|l| {
            l.split_once("LOG(\"")
                .map(|(_, r)| r.trim_end_matches("\")").to_string())
        })
        .map(|l| l + "\n")
        .collect();
    assert_eq!(
        logged, "FIVECAL probe-columns\nT A0C0_C1_t1 X-60.000000 Y-45.000000 Z100.000000\n",
        "rs274 said:\n{text}"
    );
    let raw = linuxcnc::parse_log(Path::new("t.log"), &logged).unwrap();
    assert_eq!(raw.headers, [(1, "probe-columns".to_string())]);
    assert_eq!(raw.records[0].position, Vector3::new(-60.0, -45.0, 100.0));
}

/// The whole default column plan, logged in each dialect with known
/// offsets of every surface along its normal, reads back to exactly those
/// offsets: the planner's points and the readers agree on every pose's
/// frame, on table-table and head machines.
#[test]
fn every_touch_of_a_plan_reads_back_through_each_dialect() {
    for name in ["ac-trunnion", "bc-trunnion", "head-table"] {
        let m = machine(name);
        let plan = columns::touch_plan(&m, &ColumnsTemplate::builtin()).unwrap();
        let points = plan.points();
        let offset = |i: usize| 0.001 * ((i * 37) % 2001) as f64 - 1.0; // -1 .. +1 mm
        let mut fan = String::from("%\nFIVECAL PROBE-COLUMNS\n");
        let mut hh = String::from("FIVECAL probe-columns\n");
        let mut lc = String::from("FIVECAL probe-columns\n");
        let mut si = String::from("FIVECAL probe-columns\n");
        for (i, t) in plan.touches.iter().enumerate() {
            // The controller reports commanded X, Y, Z at the trigger.
            let ball_w = t.contact.ball_w + t.normal_w * offset(i);
            let xyz = plan.frame(t.pose).commanded(&ball_w).xyz;
            fan += &(fanuc::touch_line(t.index, &xyz, fanuc::Prt::Spaces) + "\n");
            hh += &(heidenhain::touch_line(t.index, &xyz, Logged::BallCentre, true) + "\n");
            lc += &(linuxcnc::log_line(&t.label, &xyz) + "\n");
            si += &(sinumerik::touch_line(t.index, &xyz) + "\n");
            assert!(
                [t.start.axes.xyz, t.end.axes.xyz]
                    .iter()
                    .all(|v| v.iter().all(|c| fanuc::fits_field(*c))),
                "{name}: touch {} does not fit DPRNT's [44]",
                t.index
            );
        }
        let kin = &plan.kin;
        let o = ReadOptions::for_plan(&plan.settings, plan.probe.ball_radius);
        for (dialect, src) in [
            (Dialect::Fanuc, &fan),
            (Dialect::Heidenhain, &hh),
            (Dialect::Linuxcnc, &lc),
            (Dialect::Sinumerik, &si),
        ] {
            let log = probe_log::read(dialect, Path::new("log"), src, &points, kin, &o)
                .unwrap_or_else(|e| panic!("{name} {dialect}: {e}"));
            assert_eq!(log.points.len(), plan.touches.len());
            for (i, (p, t)) in log.points.iter().zip(&plan.touches).enumerate() {
                let want = t.contact_prog + t.normal_prog * offset(i);
                assert!(
                    (p.p - want).norm() < 1e-4,
                    "{name} {dialect} {}: {:?} vs {want:?}",
                    p.label,
                    p.p
                );
            }
        }
    }
}

// ---------------------------------------------------------------- writers

/// The log of a whole plan as its program makes the control write it, for
/// positions offset from each nominal surface by a known amount along the
/// normal; the reader turns it back into exactly those contact points.
fn round_trip(p: &fivecal::procedure::ProbingPlan, fmt: &write::LogFormat, what: &str) {
    let offset = |i: usize| 0.001 * ((i * 53) % 1801) as f64 - 0.9; // -0.9 .. +0.9 mm
    let plan = &p.plan;
    let recorded: Vec<_> = plan
        .touches
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let ball_w = t.contact.ball_w + t.normal_w * offset(i);
            (t, plan.frame(t.pose).commanded(&ball_w).xyz)
        })
        .collect();
    let text = fmt.write(plan, recorded);
    let log = probe_log::read(
        p.dialect,
        Path::new("log"),
        &text,
        &p.plan_points(),
        &plan.kin,
        &p.read_options(),
    )
    .unwrap_or_else(|e| panic!("{what}: {e}\n{}", &text[..text.len().min(400)]));
    assert!(
        log.missing.is_empty() && log.notes.is_empty(),
        "{what}: {log:?}"
    );
    // Four decimals (FANUC, HEIDENHAIN) or six (LinuxCNC) per coordinate.
    let tol = if p.dialect == Dialect::Linuxcnc {
        2e-6
    } else {
        2e-4
    };
    for (i, (got, t)) in log.points.iter().zip(&plan.touches).enumerate() {
        let want = t.contact_prog + t.normal_prog * offset(i);
        assert_eq!(got.label, t.label);
        assert!(
            (got.p - want).norm() < tol,
            "{what} {}: {:?} vs {want:?}",
            t.label,
            got.p
        );
    }
}

#[test]
fn log_writers_round_trip_through_the_readers_in_every_dialect_and_control_setting() {
    use crate::probe_programs::probing;
    for (m, test, d) in [
        ("ac-trunnion", "probe-columns", Dialect::Fanuc),
        ("head-table", "probe-sphere", Dialect::Fanuc),
        ("ac-trunnion", "probe-columns", Dialect::Heidenhain),
        ("head-table", "probe-sphere", Dialect::Heidenhain),
        ("head-table", "probe-columns", Dialect::Linuxcnc),
        ("head-head", "probe-sphere", Dialect::Linuxcnc),
        ("bc-trunnion", "probe-columns", Dialect::Sinumerik),
        ("head-head", "probe-sphere", Dialect::Sinumerik),
    ] {
        let p = probing(m, test, d);
        let base = p.log_format();
        assert_eq!(base, write::LogFormat::builtin(d));
        let mut variants = vec![base];
        variants.push(write::LogFormat {
            prt: fanuc::Prt::Suppressed,
            tape_marks: false,
            ..base
        });
        variants.push(write::LogFormat {
            comma: false,
            logged: Logged::BallCentre,
            crlf: true,
            ..base
        });
        for f in variants {
            round_trip(&p, &f, &format!("{test} on {m} ({d}, {f:?})"));
        }
    }
}

/// What the writers print, to the character: FANUC's padded fields and
/// tape marks, HEIDENHAIN's compensated `K` line with decimal commas,
/// LinuxCNC's `%lf` with the label.
#[test]
fn log_writers_print_exactly_what_the_control_prints() {
    use crate::probe_programs::probing;
    let first = |p: &fivecal::procedure::ProbingPlan| {
        let t = &p.plan.touches[0];
        p.log_format().write(&p.plan, [(t, t.contact.axes.xyz)])
    };
    // C1's top at Z100: the ball centre at Z103 when it touches.
    let f = probing("ac-trunnion", "probe-columns", Dialect::Fanuc);
    assert_eq!(
        first(&f),
        "%\nFIVECAL PROBE-COLUMNS\nT     1 X-  60.0000 Y-  45.0000 Z  103.0000\n%\n"
    );
    // The sphere (D30, centre X100 Z100): touched in +X at X85, ball centre
    // X82; cycle 0 reports the point compensated by the ball radius.
    let h = probing("head-table", "probe-sphere", Dialect::Heidenhain);
    assert_eq!(
        first(&h),
        "FIVECAL probe-sphere\nK1 X85,0000 Y0,0000 Z100,0000\n"
    );
    let l = probing("ac-trunnion", "probe-sphere", Dialect::Linuxcnc);
    assert_eq!(
        first(&l),
        "FIVECAL probe-sphere\nT A0C0_xp X82.000000 Y0.000000 Z50.000000\n"
    );
    // SINUMERIK: the program rounds to four decimals; `<<` leaves no zeros.
    let s = probing("ac-trunnion", "probe-sphere", Dialect::Sinumerik);
    assert_eq!(first(&s), "FIVECAL probe-sphere\nT1 X82 Y0 Z50\n");
}

/// A HEIDENHAIN definition whose format file prints ball centres (`T`)
/// gets logs of `T` lines, which read back with the radius applied.
#[test]
fn the_log_format_follows_the_programs_format_file() {
    use fivecal::post::PostDefinition;
    use fivecal::procedure::{PlanConfig, Template, Test};
    let builtin = PostDefinition::builtin(Dialect::Heidenhain);
    let src = builtin.source.replace("\"K%D X", "\"T%D X");
    assert_ne!(src, builtin.source);
    let post = PostDefinition::parse(Path::new("t.yaml"), &src).unwrap();
    let p = fivecal::procedure::probing::plan(&PlanConfig {
        kinematics: fivecal::formats::manifest::KinematicsMode::Post,
        tool: None,
        machine: machine("bc-trunnion"),
        template: Template::builtin(Test::ProbeSphere),
        post,
    })
    .unwrap();
    let f = p.log_format();
    assert_eq!(f.logged, Logged::BallCentre);
    let t = &p.plan.touches[0];
    assert!(
        f.touch_line(t, &t.contact.axes.xyz, 3.0)
            .starts_with("T1 X")
    );
    round_trip(&p, &f, "T lines");
}

/// FANUC drops the high digits of a value wider than its field; the writer
/// does the same, and the reader refuses the line it cannot trust.
#[test]
fn a_value_too_wide_for_dprnt_loses_its_high_digits_and_the_log_is_refused() {
    use crate::probe_programs::probing;
    let p = probing("ac-trunnion", "probe-columns", Dialect::Fanuc);
    let f = p.log_format();
    let t = &p.plan.touches[0];
    // X-60 + 20000 = 19940 mm has five integer digits: DPRNT prints 9940.
    let wide = t.contact.axes.xyz + Vector3::new(20000.0, 0.0, 0.0);
    assert_eq!(
        f.touch_line(t, &wide, 3.0),
        "T     1 X 9940.0000 Y-  45.0000 Z  103.0000"
    );
    let text = f.write(&p.plan, [(t, wide)]);
    let e = probe_log::read(
        Dialect::Fanuc,
        Path::new("wide.log"),
        &text,
        &p.plan_points(),
        &p.plan.kin,
        &p.read_options(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.starts_with("wide.log:3:1: touch 1 (A0C0_C1_t1)"), "{e}");
}
