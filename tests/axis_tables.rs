//! The axes' compensation tables (`compensate --export` of a laser-lines
//! result) against models of the controls written here from their
//! documentation, not from the writers:
//!
//! - LinuxCNC (docs/src/config/ini-config.adoc `COMP_FILE`,
//!   `COMP_FILE_TYPE`; src/emc/motion/usrmotintf.cc, command.c, control.c):
//!   the loader reads lines of three blank-separated numbers and stops at
//!   the first line that is not; type 0 turns `nominal actual+ actual-` into
//!   trims `nominal - actual`; motion adds the trim of the direction of
//!   motion, linear between nominals and the end trims held beyond, to the
//!   motor's command.
//! - SINUMERIK LEC (function manual Extended Functions, K3): values at
//!   `MIN + N STEP` up to `MAX`, linear between, the end values held beyond;
//!   the control takes the value off its measured position: a positive
//!   value moves the axis negative.
//!
//! Each model drives a simulated erroneous axis (where the axis goes for a
//! motor or encoder position, per approach direction) through the written
//! file: every commanded position, at the nodes and between them, lands
//! within the table's u of the target; a file with the opposite sign lands
//! worse; at zero error the file is the identity.

use std::path::Path;

use fivecal::Dialect;
use fivecal::compensate::axis_tables::{AxisTable, TableLimits, TablePoint, laser, write};

const LIMITS: TableLimits = TableLimits {
    max_correction_um: 100.0,
    max_u_um: 10.0,
};

/// A table of axis X on nodes `-300, -200, ..., 300` mm whose error in
/// each direction is `err(x, plus)`, u 0.1 um.
fn table(err: &dyn Fn(f64, bool) -> f64) -> AxisTable {
    AxisTable {
        axis: 'X',
        from: "a worked example".into(),
        points: (0..7)
            .map(|i| {
                let x = -300.0 + 100.0 * i as f64;
                TablePoint {
                    position_mm: x,
                    plus_um: err(x, true),
                    minus_um: err(x, false),
                    u_plus_um: 0.1,
                    u_minus_um: 0.1,
                }
            })
            .collect(),
    }
}

/// The erroneous axis of the examples: a scale error of 40 um/m, a bend
/// that the nodes follow piecewise (its value at the nodes, linear
/// between: what a table can hold) and a reversal of 3 um, + going further.
fn truth(x: f64, plus: bool) -> f64 {
    let nodes = |x: f64| {
        let bend = |k: f64| 5.0 * ((k + 300.0) / 600.0 * std::f64::consts::PI).sin();
        let x = x.clamp(-300.0, 300.0);
        let k = ((x + 300.0) / 100.0).floor().min(5.0);
        let (a, b) = (-300.0 + 100.0 * k, -200.0 + 100.0 * k);
        bend(a) + (bend(b) - bend(a)) * (x - a) / 100.0
    };
    40e-3 * x + nodes(x) + if plus { 1.5 } else { -1.5 }
}

/// The file named `name` among `files`.
fn file<'a>(files: &'a [(std::path::PathBuf, String)], name: &str) -> &'a str {
    &files
        .iter()
        .find(|(n, _)| n == Path::new(name))
        .unwrap_or_else(|| panic!("no {name}"))
        .1
}

/// The commanded positions of the checks: every node and three points
/// between each two.
fn grid() -> Vec<f64> {
    (0..=24).map(|i| -300.0 + 25.0 * i as f64).collect()
}

/// LinuxCNC's loader and motion controller, from its documentation and
/// source: (nominal, fwd trim, rev trim) per entry.
mod linuxcnc_model {
    /// `usrmotLoadComp`: lines of three numbers while they last; type 0
    /// holds actual positions, turned into trims `nominal - actual`.
    pub fn load(text: &str, file_type: u8) -> Vec<(f64, f64, f64)> {
        let mut out = Vec::new();
        for line in text.lines() {
            let v: Vec<f64> = line
                .split_whitespace()
                .take(3)
                .map_while(|w| w.parse().ok())
                .collect();
            if v.len() != 3 {
                break;
            }
            let (nom, f, r) = (v[0], v[1], v[2]);
            out.push(if file_type == 0 {
                (nom, nom - f, nom - r)
            } else {
                (nom, f, r)
            });
        }
        out
    }

    /// The trim at commanded position `pos` moving + (`plus`) or -: linear
    /// between entries, the first entry's trim below it, the last's above.
    pub fn trim(table: &[(f64, f64, f64)], pos: f64, plus: bool) -> f64 {
        let t = |e: &(f64, f64, f64)| if plus { e.1 } else { e.2 };
        if pos < table[0].0 {
            return t(&table[0]);
        }
        let i = table.iter().rposition(|e| e.0 <= pos).unwrap();
        if i + 1 == table.len() {
            return t(&table[i]);
        }
        let (a, b) = (&table[i], &table[i + 1]);
        t(a) + (t(b) - t(a)) / (b.0 - a.0) * (pos - a.0)
    }
}

/// Where the LinuxCNC axis lands for commanded `pos`: the motor goes to
/// `pos + trim`, and the axis with it plus its error there.
fn linuxcnc_lands(text: &str, pos: f64, plus: bool, err: &dyn Fn(f64, bool) -> f64) -> f64 {
    let table = linuxcnc_model::load(text, 0);
    let motor = pos + linuxcnc_model::trim(&table, pos, plus);
    motor + err(motor, plus) * 1e-3
}

/// SINUMERIK's LEC as its function manual describes it: the table parsed
/// from the INI file (per machine axis: values, step, min, max).
mod sinumerik_model {
    use std::collections::BTreeMap;

    #[derive(Default, Debug)]
    pub struct Lec {
        pub values: BTreeMap<usize, f64>,
        pub step: f64,
        pub min: f64,
        pub max: f64,
        pub modulo: Option<i32>,
    }

    /// The tables of an `%_N_AX_EEC_INI` file, by machine axis.
    pub fn load(text: &str) -> BTreeMap<String, Lec> {
        let mut lines = text.lines();
        assert_eq!(lines.next(), Some("%_N_AX_EEC_INI"));
        assert!(text.contains("\nCHANDATA(1)\n") && text.ends_with("M17\n"));
        let mut out: BTreeMap<String, Lec> = BTreeMap::new();
        for l in lines {
            let l = l.split(';').next().unwrap().trim();
            let Some((lhs, rhs)) = l.split_once('=') else {
                continue;
            };
            let (name, idx) = lhs.trim_end_matches(']').split_once('[').unwrap();
            let idx: Vec<&str> = idx.split(',').collect();
            assert_eq!(idx[0], "0", "measuring system 0: {l}");
            let axis = idx[idx.len() - 1].to_string();
            let v: f64 = rhs.parse().unwrap();
            let t = out.entry(axis).or_default();
            match name {
                "$AA_ENC_COMP" => {
                    t.values.insert(idx[1].parse().unwrap(), v);
                }
                "$AA_ENC_COMP_STEP" => t.step = v,
                "$AA_ENC_COMP_MIN" => t.min = v,
                "$AA_ENC_COMP_MAX" => t.max = v,
                "$AA_ENC_COMP_IS_MODULO" => t.modulo = Some(v as i32),
                other => panic!("unknown variable {other}"),
            }
        }
        out
    }

    impl Lec {
        /// The compensation value at axis position `p`, mm.
        pub fn value(&self, p: f64) -> f64 {
            let n = self.values.len();
            assert!(self.step > 0.0 && self.modulo == Some(0));
            assert!((self.min + self.step * (n - 1) as f64 - self.max).abs() < 1e-6);
            let f = ((p - self.min) / self.step).clamp(0.0, (n - 1) as f64);
            let i = (f.floor() as usize).min(n - 2);
            let (a, b) = (self.values[&i], self.values[&(i + 1)]);
            a + (b - a) * (f - i as f64)
        }
    }
}

/// Where the SINUMERIK axis lands for commanded `pos`: the control drives
/// its actual value `r + c(r)` (r the encoder's reading) onto `pos`, and
/// the axis stands at `r` plus its error there.
fn sinumerik_lands(
    lec: &sinumerik_model::Lec,
    pos: f64,
    plus: bool,
    err: &dyn Fn(f64, bool) -> f64,
) -> f64 {
    let mut r = pos;
    for _ in 0..50 {
        r = pos - lec.value(r);
    }
    r + err(r, plus) * 1e-3
}

#[test]
fn linuxcnc_lands_every_commanded_position_within_u_and_the_opposite_sign_is_worse() {
    let t = table(&truth);
    let files = write(Dialect::Linuxcnc, std::slice::from_ref(&t), &LIMITS).unwrap();
    let comp = file(&files, "X.comp");
    assert_eq!(linuxcnc_model::load(comp, 0).len(), 7, "{comp}");
    // The opposite sign: actual positions mirrored about the nominal.
    let flipped: String = linuxcnc_model::load(comp, 0)
        .iter()
        .map(|(n, f, r)| format!("{n} {} {}\n", n + f, n + r))
        .collect();
    for pos in grid() {
        for plus in [true, false] {
            let landed = linuxcnc_lands(comp, pos, plus, &truth);
            let off_um = (landed - pos) * 1e3;
            assert!(off_um.abs() <= 0.1, "{pos} {plus}: landed {off_um} um off");
            // Where the axis errs by more than u, the opposite sign lands
            // further off than no compensation (twice the error).
            let uncompensated = truth(pos, plus).abs();
            let worse = (linuxcnc_lands(&flipped, pos, plus, &truth) - pos).abs() * 1e3;
            assert!(
                uncompensated <= 0.1 || worse > uncompensated,
                "{pos} {plus}: the opposite sign lands {worse} um off"
            );
        }
    }
    // Beyond the ends the end trims hold: the error there is the end's
    // plus the scale over the overhang.
    let beyond = linuxcnc_lands(comp, 310.0, true, &truth);
    assert!(((beyond - 310.0) * 1e3 - 40e-3 * 10.0).abs() < 0.01);
}

#[test]
fn linuxcnc_at_zero_error_writes_the_identity() {
    let files = write(Dialect::Linuxcnc, &[table(&|_, _| 0.0)], &LIMITS).unwrap();
    let comp = file(&files, "X.comp");
    for (n, f, r) in linuxcnc_model::load(comp, 0) {
        assert!(f == 0.0 && r == 0.0, "{n}: trims {f} {r}");
    }
    assert!(
        comp.lines().all(|l| {
            let v: Vec<&str> = l.split(' ').collect();
            v[0] == v[1] && v[1] == v[2]
        }),
        "{comp}"
    );
}

#[test]
fn linuxcncs_public_sample_layout_reads_and_the_written_file_holds_nothing_else() {
    // LinuxCNC's own sample (configs/sim/screwcompX.dat): leading blanks,
    // runs of blanks between the columns, eleven entries two units apart.
    // The numbers here are ours; the layout is the sample's.
    let sample = "-10 -10.002  -9.998\n -8  -8.001  -7.999\n  0  -0.003   0.002\n  2   1.997   2.003\n 10   9.999  10.000\n";
    let t = linuxcnc_model::load(sample, 0);
    assert_eq!(t.len(), 5);
    assert!((t[2].1 - 0.003).abs() < 1e-12 && (t[2].2 + 0.002).abs() < 1e-12);
    // A comment line ends the loading: the written file has none, every
    // line is read.
    let with_comment = format!("# note\n{sample}");
    assert!(linuxcnc_model::load(&with_comment, 0).is_empty());
    let files = write(Dialect::Linuxcnc, &[table(&truth)], &LIMITS).unwrap();
    let comp = file(&files, "X.comp");
    assert_eq!(linuxcnc_model::load(comp, 0).len(), comp.lines().count());
    // ...and the listing beside it says what each value is, with its u.
    let listing = file(&files, "axis-tables.txt");
    assert!(
        listing.contains("COMP_FILE = X.comp  COMP_FILE_TYPE = 0"),
        "{listing}"
    );
    assert!(listing.contains("0.100"), "{listing}");
}

#[test]
fn linuxcnc_refuses_more_points_than_a_joint_holds() {
    let mut t = table(&|_, _| 0.0);
    t.points = (0..257)
        .map(|i| TablePoint {
            position_mm: i as f64,
            plus_um: 0.0,
            minus_um: 0.0,
            u_plus_um: 0.1,
            u_minus_um: 0.1,
        })
        .collect();
    let e = write(Dialect::Linuxcnc, &[t.clone()], &LIMITS)
        .unwrap_err()
        .to_string();
    assert!(e.contains("257 points") && e.contains("256"), "{e}");
    t.points.truncate(256);
    assert!(write(Dialect::Linuxcnc, &[t], &LIMITS).is_ok());
}

#[test]
fn sinumerik_lands_within_u_and_half_the_reversal_and_the_opposite_sign_is_worse() {
    let t = table(&truth);
    let files = write(Dialect::Sinumerik, &[t], &LIMITS).unwrap();
    let ini = file(&files, "AX_EEC.INI");
    let tables = sinumerik_model::load(ini);
    let lec = &tables["X1"];
    assert_eq!(lec.values.len(), 7);
    assert_eq!((lec.min, lec.max, lec.step), (-300.0, 300.0, 100.0));
    let flipped = sinumerik_model::Lec {
        values: lec.values.iter().map(|(k, v)| (*k, -v)).collect(),
        step: lec.step,
        min: lec.min,
        max: lec.max,
        modulo: lec.modulo,
    };
    for pos in grid() {
        let mut offs = [0.0; 2];
        let mut flipped_offs = [0.0; 2];
        for (d, plus) in [true, false].into_iter().enumerate() {
            // One value for both directions: half the 3 um reversal stays.
            let off_um = (sinumerik_lands(lec, pos, plus, &truth) - pos) * 1e3;
            assert!(
                (off_um - if plus { 1.5 } else { -1.5 }).abs() <= 0.1,
                "{pos} {plus}: landed {off_um} um off"
            );
            offs[d] = off_um;
            flipped_offs[d] = (sinumerik_lands(&flipped, pos, plus, &truth) - pos) * 1e3;
        }
        // The opposite sign: the mean of the two directions lands off by
        // twice the mean error, where none would leave it off by once.
        let mean = (truth(pos, true) + truth(pos, false)) / 2.0;
        let flipped = (flipped_offs[0] + flipped_offs[1]) / 2.0;
        assert!(((offs[0] + offs[1]) / 2.0).abs() <= 0.1);
        assert!(
            mean.abs() <= 0.1 || flipped.abs() > mean.abs(),
            "{pos}: {flipped} vs {mean}"
        );
    }
    // Without a reversal, within u in both directions.
    let no_b = |x: f64, _: bool| truth(x, true) - 1.5;
    let files = write(Dialect::Sinumerik, &[table(&no_b)], &LIMITS).unwrap();
    let lec = &sinumerik_model::load(file(&files, "AX_EEC.INI"))["X1"];
    for pos in grid() {
        let off = (sinumerik_lands(lec, pos, false, &no_b) - pos) * 1e3;
        assert!(off.abs() <= 0.1, "{pos}: {off}");
    }
}

#[test]
fn sinumerik_at_zero_error_writes_zeros_and_refuses_unequal_spacing() {
    let files = write(Dialect::Sinumerik, &[table(&|_, _| 0.0)], &LIMITS).unwrap();
    let lec = &sinumerik_model::load(file(&files, "AX_EEC.INI"))["X1"];
    assert!(lec.values.values().all(|v| *v == 0.0));
    let mut t = table(&|_, _| 0.0);
    t.points[3].position_mm += 1.0;
    let e = write(Dialect::Sinumerik, &[t], &LIMITS)
        .unwrap_err()
        .to_string();
    assert!(e.contains("not equally spaced"), "{e}");
}

#[test]
fn fanuc_and_heidenhain_are_refused_with_what_to_enter_by_hand() {
    for d in [Dialect::Fanuc, Dialect::Heidenhain] {
        let e = write(d, &[table(&truth)], &LIMITS).unwrap_err().to_string();
        assert!(
            e.contains("not written") && e.contains("by hand") && e.contains("negated"),
            "{e}"
        );
    }
}

#[test]
fn a_correction_or_u_beyond_the_limits_is_refused_naming_the_point() {
    let e = write(
        Dialect::Linuxcnc,
        &[table(&truth)],
        &TableLimits {
            max_correction_um: 10.0,
            max_u_um: 10.0,
        },
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("X at -300 mm") && e.contains("13.50 um") && e.contains("--max-change"),
        "{e}"
    );
    let e = write(
        Dialect::Sinumerik,
        &[table(&truth)],
        &TableLimits {
            max_correction_um: 100.0,
            max_u_um: 0.05,
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("X at -300 mm") && e.contains("--max-u"), "{e}");
}

/// A laser result of one line `name` moving X from `start` along `dir`,
/// targets 0, 50, 100 with the given + and - means.
fn result_yaml(name: &str, axes: &str, dir: f64, offset: f64, means: [(f64, f64); 3]) -> String {
    let mut s = format!(
        "fivecal_laser_result: 1\nmachine: m\nuncertainty: words\nreading_u_um: 0.1\nlength_u_ppm: 1.0\nlines:\n- file: a.txt\n  format: fivecal\n  axes: {axes}\n  start: [100.0, 0.0, 0.0]\n  direction: [{dir}, 0.0, 0.0]\n  offset: [0.0, {offset}, 0.0]\n  environment: {{}}\n  line: {name}\n  runs: 4\n  targets:\n"
    );
    for (i, (up, down)) in means.iter().enumerate() {
        s += &format!(
            "  - position_mm: {}\n    up: {{mean_um: {up}, s_um: 0.4, n: 4}}\n    down: {{mean_um: {down}, s_um: 0.05, n: 4}}\n",
            50 * i
        );
    }
    s + "not_measured: []\n"
}

#[test]
fn a_laser_base_line_gives_the_axis_table_in_machine_coordinates_with_u() {
    let src = result_yaml("L1", "X", 1.0, 0.0, [(0.0, -1.0), (2.0, 1.0), (4.0, 3.0)]);
    let t = laser::tables(Path::new("r.yaml"), &src).unwrap();
    assert_eq!(t.missing, vec![('Y', "L2".into()), ('Z', "L3".into())]);
    let p = &t.tables[0].points;
    assert_eq!(
        p.iter().map(|p| p.position_mm).collect::<Vec<_>>(),
        [100.0, 150.0, 200.0]
    );
    assert_eq!((p[1].plus_um, p[1].minus_um), (2.0, 1.0));
    // u: s over sqrt(n) in +; the reading's 0.1 um (above s = 0.05) in -;
    // plus 1 ppm of 100 mm = 0.1 um at the last target.
    assert!((p[0].u_plus_um - 0.2).abs() < 1e-12);
    assert!((p[0].u_minus_um - 0.05).abs() < 1e-12);
    assert!((p[2].u_plus_um - (0.04f64 + 0.01).sqrt()).abs() < 1e-12);
}

#[test]
fn a_base_line_run_against_the_axis_is_turned_to_the_axis() {
    // Rising targets move X negative: target 100 is X = 0, and its +
    // approach (rising targets) is the axis's - approach; a deviation along
    // the line is minus one along X.
    let src = result_yaml("L1", "X", -1.0, 0.0, [(0.0, -1.0), (2.0, 1.0), (4.0, 3.0)]);
    let t = laser::tables(Path::new("r.yaml"), &src).unwrap();
    let p = &t.tables[0].points;
    assert_eq!(
        p.iter().map(|p| p.position_mm).collect::<Vec<_>>(),
        [0.0, 50.0, 100.0]
    );
    assert_eq!((p[0].plus_um, p[0].minus_um), (-3.0, -4.0));
    assert_eq!((p[2].plus_um, p[2].minus_um), (1.0, 0.0));
}

#[test]
fn a_result_without_a_base_line_or_with_an_offset_one_is_refused_by_name() {
    let src = result_yaml("L4", "X", 1.0, 150.0, [(0.0, 0.0); 3]);
    let e = laser::tables(Path::new("r.yaml"), &src)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("r.yaml")
            && e.contains("no base line")
            && e.contains("L1 (X)")
            && e.contains("L4"),
        "{e}"
    );
    let src = result_yaml("L1", "X", 1.0, 150.0, [(0.0, 0.0); 3]);
    let e = laser::tables(Path::new("r.yaml"), &src)
        .unwrap_err()
        .to_string();
    assert!(e.contains("line L1") && e.contains("offset"), "{e}");
    let src = result_yaml("L1", "Y", 1.0, 0.0, [(0.0, 0.0); 3]);
    let e = laser::tables(Path::new("r.yaml"), &src)
        .unwrap_err()
        .to_string();
    assert!(e.contains("not the base line of X"), "{e}");
}

/// The round trip: plan the ten lines on a machine, simulate the base
/// lines on a truth with the axes' scale errors, analyze, export; the
/// control's model then drives the truth's axis, whose error is the scale
/// times the program coordinate (zero at the W origin, docs/model.md),
/// through the table. The table is relative to the line's first target
/// (the interferometer's zero), so what is checked is every target's
/// distance from the first.
#[test]
fn simulate_analyze_export_corrects_the_truths_scales_for_linuxcnc_and_sinumerik() {
    let dir = crate::util::tempdir();
    let (plan_file, runs) = crate::laser_lines::simulated_lines(
        dir.path(),
        &[
            "--machine",
            "bc-trunnion",
            "--divisions",
            "8",
            "--runs",
            "2",
        ],
        "machine: bc-trunnion\nlocation_errors: {}\neffects:\n  linear_scale: {EXX: 40.0, EYY: -25.0, EZZ: 15.0}\n",
        &["--no-noise"],
    );
    let run = |args: &[&str]| crate::laser_lines::fivecal_ok(args);
    let s = |p: &Path| p.to_string_lossy().into_owned();
    let result = dir.path().join("laser.yaml");
    let mut args = vec![
        "analyze".to_string(),
        "--plan".into(),
        s(&plan_file),
        "-o".into(),
        s(&result),
        "--measured".into(),
    ];
    args.extend((1..=3).map(|k| s(&runs.join(format!("L{k}.txt")))));
    run(&args.iter().map(String::as_str).collect::<Vec<_>>());
    let man = fivecal::formats::laser::LaserManifest::read(&plan_file).unwrap();
    let machine = fivecal::Machine::builtin("bc-trunnion").unwrap();
    let lc = dir.path().join("lc");
    let sn = dir.path().join("sn");
    let text = run(&[
        "compensate",
        "--machine",
        "bc-trunnion",
        "--errors",
        &s(&result),
        "--export",
        "linuxcnc",
        "-o",
        &s(&lc),
    ]);
    assert!(text.contains("wrote") && text.contains("X.comp"), "{text}");
    run(&[
        "compensate",
        "--machine",
        "bc-trunnion",
        "--errors",
        &s(&result),
        "--export",
        "sinumerik",
        "-o",
        &s(&sn),
    ]);
    let lec = sinumerik_model::load(&std::fs::read_to_string(sn.join("AX_EEC.INI")).unwrap());
    for (k, axis, per_m) in [(0usize, 'X', 40.0), (1, 'Y', -25.0), (2, 'Z', 15.0)] {
        let line = &man.lines[k];
        // The truth's error: the scale times the program coordinate,
        // machine coordinate less the W origin's (the pivot).
        let w0 = machine.pivot[k];
        let err = move |x: f64, _: bool| per_m * (x - w0) * 1e-3;
        let comp = std::fs::read_to_string(lc.join(format!("{axis}.comp"))).unwrap();
        let lec = &lec[&format!("{axis}1")];
        let x0 = line.start[k];
        let targets: Vec<f64> = line
            .targets
            .iter()
            .map(|t| x0 + line.direction[k] * t)
            .collect();
        let between: Vec<f64> = targets.windows(2).map(|w| (w[0] + w[1]) / 2.0).collect();
        for plus in [true, false] {
            let zero_lc = linuxcnc_lands(&comp, x0, plus, &err);
            let zero_sn = sinumerik_lands(lec, x0, plus, &err);
            for &x in targets.iter().chain(&between) {
                // u of the table: the reading's 0.1 um over sqrt(2) and
                // 0.5 ppm of the distance; the check takes 0.1 um plus it.
                let u = 0.1 + 0.5e-3 * (x - x0).abs();
                let got = (linuxcnc_lands(&comp, x, plus, &err) - zero_lc - (x - x0)) * 1e3;
                assert!(got.abs() <= u, "linuxcnc {axis} {x} {plus}: {got} um");
                let got = (sinumerik_lands(lec, x, plus, &err) - zero_sn - (x - x0)) * 1e3;
                assert!(got.abs() <= u, "sinumerik {axis} {x} {plus}: {got} um");
                // Uncompensated, the scale shows.
                let raw = (err(x, plus) - err(x0, plus)).abs();
                assert!(raw > u || (x - x0).abs() < 30.0, "{axis} {x}: raw {raw}");
            }
        }
    }
    // FANUC: refused, nothing written, the table printed for entering by hand.
    let fa = dir.path().join("fa");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_fivecal"))
        .args([
            "compensate",
            "--machine",
            "bc-trunnion",
            "--errors",
            &s(&result),
            "--export",
            "fanuc",
            "-o",
            &s(&fa),
        ])
        .output()
        .unwrap();
    assert!(!o.status.success() && !fa.exists());
    assert!(String::from_utf8_lossy(&o.stdout).contains("X axis, from line L1"));
    assert!(
        String::from_utf8_lossy(&o.stderr)
            .contains("fanuc: the pitch error compensation is not written")
    );
}

#[test]
fn compensate_refuses_what_makes_no_sense_with_a_laser_result() {
    let dir = crate::util::tempdir();
    let bin = env!("CARGO_BIN_EXE_fivecal");
    let result = dir.path().join("laser.yaml");
    let mut src = result_yaml("L1", "X", 1.0, 0.0, [(0.0, -1.0), (2.0, 1.0), (4.0, 3.0)]);
    src = src
        .replace("machine: m\n", "machine: bc-trunnion\n")
        .replace("[100.0, 0.0, 0.0]", "[-100.0, 0.0, 0.0]");
    std::fs::write(&result, &src).unwrap();
    let prog = dir.path().join("p.ngc");
    std::fs::write(&prog, "G0 X0\nM2\n").unwrap();
    let r = result.to_string_lossy().into_owned();
    let out = dir.path().join("out").to_string_lossy().into_owned();
    let p = prog.to_string_lossy().into_owned();
    for (args, says) in [
        (
            vec!["--export", "linuxcnc", "-o", &out, &p],
            "no program is rewritten",
        ),
        (vec!["-o", &out], "give --export CONTROLLER -o DIR"),
        (vec!["--export", "linuxcnc"], "-o DIR"),
        (vec!["--export", "linuxcnc", "--export-to", &out], "-o DIR"),
        (
            vec!["--export", "linuxcnc", "-o", &out, "--entered"],
            "--entered does not apply",
        ),
        (vec!["--export", "linuxcnc", "-o", &r], "needs a directory"),
    ] {
        let mut a = vec!["compensate", "--machine", "bc-trunnion", "--errors", &r];
        a.extend(args.iter().copied());
        let o = std::process::Command::new(bin).args(&a).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(says), "{a:?}: {err}");
    }
    assert_eq!(std::fs::read_to_string(&result).unwrap(), src);
    let o = std::process::Command::new(bin)
        .args([
            "compensate",
            "--machine",
            "head-table",
            "--errors",
            &r,
            "--export",
            "linuxcnc",
            "-o",
            &out,
        ])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&o.stderr).contains("the result is of machine `bc-trunnion`"));
    let o = std::process::Command::new(bin)
        .args([
            "compensate",
            "--machine",
            "bc-trunnion",
            "--errors",
            &r,
            "--export",
            "linuxcnc",
            "-o",
            &out,
        ])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        text.contains("no table for Y: its base line L2 is not in the result"),
        "{text}"
    );
}
