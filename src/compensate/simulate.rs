//! Running an NC program on a machine with known errors (`fivecal simulate
//! nc`): where the tool tip actually goes, and how far that is from where
//! the nominal machine would put it; and what a CMM would measure on a
//! part cut that way.
//!
//! The controller is modelled as it interpolates: axis values linearly
//! between end points (post-side programs), or tip and rotary positions
//! linearly with its nominal kinematics turning them into axis values
//! (TCP); arcs in their plane, SINUMERIK's `CIP` on the circle through its
//! three points. The machine is the exact model with the
//! errors. Samples are taken at every end point and, with a step, along
//! feed moves.

use std::io::BufRead;
use std::path::Path;

use indexmap::IndexMap;
use nalgebra::Vector3;

use super::solver::Solver;
use super::{Coordinates, Largest, Lines, Reason, ReasonKind};
use crate::kinematics::{Axes, ToolPose};
use crate::machine::Dialect;
use crate::model::Model;
use crate::nc::interp::approach::{Approach, Leg, Tangential};
use crate::nc::interp::coordinates::known;
use crate::nc::interp::corner::{Corner, corner_path};
use crate::nc::interp::interpolation::{ArcGeo, Path as MovePath};
use crate::nc::interp::{self, AXES, Event, Frame, Interpreter, MoveKind, Skip, Tcp};
use crate::nc::{Block, Blocks, ReadError, Syntax};
use crate::source::SourceError;

/// Settings of a simulation.
#[derive(Clone, Debug, PartialEq)]
pub struct SimSettings {
    /// Dialect.
    pub dialect: Dialect,
    /// Reject unknown words.
    pub strict: bool,
    /// Program zero in W at rotary zero, mm.
    pub origin: Vector3<f64>,
    /// How coordinates are meant.
    pub coordinates: Coordinates,
    /// FANUC axis values without a decimal point (mm per unit).
    pub fanuc_integer_unit: Option<f64>,
    /// Rotary positions before the first block, as the user states them.
    pub rotary_start: Vec<(char, f64)>,
    /// Sampling step along feed moves, mm of tool-tip path, and at least a
    /// sample a degree of turn of a rotary axis (0: end points only).
    pub step: f64,
    /// LinuxCNC: directories holding the subroutine files `o<name> call`
    /// runs, after the program's own ([`super::Settings::subroutine_path`]).
    pub subroutine_path: Vec<std::path::PathBuf>,
}

impl SimSettings {
    /// Defaults: end points only.
    pub fn new(dialect: Dialect) -> SimSettings {
        SimSettings {
            dialect,
            strict: false,
            origin: Vector3::zeros(),
            coordinates: Coordinates::Auto,
            fanuc_integer_unit: None,
            rotary_start: Vec::new(),
            step: 0.0,
            subroutine_path: Vec::new(),
        }
    }
}

/// One point along the program.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Source line.
    pub line: usize,
    /// Fraction of the block's move (1 at its end point).
    pub fraction: f64,
    /// Whether the move is a cutting (feed) move.
    pub feed: bool,
    /// Where the nominal machine puts the tool.
    pub nominal: ToolPose,
    /// Where the machine with the errors puts it.
    pub actual: ToolPose,
}

impl Sample {
    /// Tool-tip error, mm.
    pub fn error(&self) -> Vector3<f64> {
        self.actual.tip - self.nominal.tip
    }

    /// Tool-axis error, rad.
    pub fn axis_error(&self) -> f64 {
        self.actual
            .axis
            .normalize()
            .dot(&self.nominal.axis.normalize())
            .clamp(-1.0, 1.0)
            .acos()
    }
}

/// What a simulation found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SimSummary {
    /// Blocks read.
    pub blocks: usize,
    /// Moves simulated.
    pub moves: usize,
    /// Samples taken.
    pub samples: usize,
    /// Mean tool-tip error, um.
    pub mean_um: f64,
    /// RMS tool-tip error, um.
    pub rms_um: f64,
    /// Largest tool-tip error, um, and its line.
    pub max_um: Option<Largest>,
    /// Largest tool-axis error, urad.
    pub max_axis_urad: f64,
    /// Moves that could not be simulated, by reason, with lines.
    pub skipped: Vec<(Reason, Lines)>,
    /// Statements whose effect is not modelled (taken to move nothing).
    pub unmodelled: Vec<(String, Lines)>,
}

/// A program runner for one machine with one set of errors.
#[derive(Clone, Debug)]
pub struct Simulator {
    solver: Solver,
    settings: SimSettings,
}

impl Simulator {
    /// A runner for `model` with parameters `theta`.
    pub fn new(model: &Model, theta: &[f64], settings: SimSettings) -> Simulator {
        Simulator {
            solver: Solver::new(model, theta, 360.0),
            settings,
        }
    }

    /// Nominal and actual pose for a commanded point (program frame).
    fn poses(&self, f: &Frame, p: &[f64; 6], vector: Option<Vector3<f64>>) -> (ToolPose, ToolPose) {
        let a = f.model(p);
        match f.tcp {
            Tcp::Off => (self.solver.nominal_pose(&a), self.solver.actual_pose(&a)),
            _ => {
                let nominal = ToolPose {
                    tip: a.xyz,
                    axis: vector.unwrap_or_else(|| self.solver.nominal_pose(&a).axis),
                };
                let xyz = self
                    .solver
                    .nominal()
                    .position(&a.xyz, a.tilt, a.c, &Vector3::zeros());
                (nominal, self.solver.actual_pose(&Axes { xyz, ..a }))
            }
        }
    }

    /// Runs the program, calling `sink` with every sample.
    pub fn run<R: BufRead>(
        &self,
        path: &Path,
        input: R,
        sink: &mut dyn FnMut(&Sample),
    ) -> Result<SimSummary, SourceError> {
        let s = &self.settings;
        let mut interp = Interpreter::new(
            &interp::InterpreterSettings {
                dialect: s.dialect,
                coordinates: s.coordinates,
                origin: s.origin,
                integer_unit: s.fanuc_integer_unit,
                rotary_start: s.rotary_start.clone(),
            },
            self.solver.kinematics(),
        );
        let syntax = Syntax {
            dialect: s.dialect,
            strict: s.strict,
        };
        let mut blocks = Blocks::new(path, input, syntax);
        let mut run = Run {
            sim: self,
            summary: SimSummary::default(),
            sum: 0.0,
            sum2: 0.0,
            held: None,
            sink,
        };
        let mut skipped: IndexMap<Reason, Lines> = IndexMap::new();
        let mut unmodelled: IndexMap<String, Lines> = IndexMap::new();
        let st = s;
        // An `APPR LT` held back (its line) until the first contour element
        // after it places its auxiliary point.
        let mut approach_open: Option<usize> = None;
        let mut process = |block: &Block| -> Result<(), SourceError> {
            run.summary.blocks += 1;
            for si in 0..block.segments.len() {
                let seg = block.segments[si];
                let event = interp.step(block, &seg);
                super::take_unmodelled(&mut interp, block, path, st.strict, &mut unmodelled)?;
                let mv = match event {
                    Event::Move(mv) => mv,
                    // Not run: nothing to simulate, nothing missed.
                    Event::Skip(Skip::NeverRuns) => continue,
                    Event::Skip(s) => {
                        if let Some(at) = approach_open.take() {
                            skipped.entry(approach_straight()).or_default().push(at);
                        }
                        skipped.entry(s.into()).or_default().push(block.line);
                        continue;
                    }
                    Event::Quiet => {
                        if let Some(at) = approach_open.take() {
                            skipped.entry(approach_straight()).or_default().push(at);
                        }
                        continue;
                    }
                    _ => continue,
                };
                if let Some(at) = approach_open.take()
                    && mv.approach.is_none()
                {
                    skipped.entry(approach_straight()).or_default().push(at);
                }
                let f = interp.frame();
                if let Some(&a) = f.axes().iter().find(|&&a| mv.end[a].is_none()) {
                    skipped
                        .entry(Skip::PositionUnknown(AXES[a]).into())
                        .or_default()
                        .push(block.line);
                    continue;
                }
                run.summary.moves += 1;
                let vector = mv.vector;
                let p1 = known(&mv.end);
                let mut start_known = f.axes().iter().all(|&a| mv.start[a].is_some());
                let mut p0 = known(&mv.start);
                let mut feed = !matches!(mv.kind, MoveKind::Rapid);
                if let Some(d) = mv.drill {
                    // A hole: over it at the R level, then drilled along
                    // the drill axis to its bottom.
                    p0 = p1;
                    p0[d.axis] = d.r_level;
                    start_known = true;
                    feed = true;
                }
                let path2 = match mv.kind {
                    MoveKind::Arc(arc) => MovePath::Arc {
                        p0,
                        p1,
                        geo: ArcGeo::new(arc.plane.axes(), arc.center, &p0, &p1, arc.cw, arc.turns),
                    },
                    MoveKind::Through(t) => MovePath::Through { p0, p1, geo: t.geo },
                    _ => MovePath::Line { p0, p1 },
                };
                let mut job = Job {
                    line: block.line,
                    f,
                    path: path2,
                    feed,
                    start_known,
                    vector,
                    // A hole starts with its point at the R level (reached
                    // by a rapid).
                    first: usize::from(mv.drill.is_none()),
                };
                if let Some(a) = mv.approach
                    && let Err(why) = run.approach(&a)
                {
                    skipped
                        .entry(Reason::new(
                            ReasonKind::NotImplemented,
                            format!("{APPROACH_STRAIGHT}: {why}"),
                        ))
                        .or_default()
                        .push(a.line);
                }
                if matches!(mv.appr_dep, Some(Tangential::Approach { .. })) {
                    approach_open = Some(block.line);
                }
                match mv.corner {
                    Some(c) => {
                        if let Err(why) = run.cut_corner(&c, &mut job) {
                            skipped
                                .entry(Reason::new(
                                    ReasonKind::NotImplemented,
                                    format!(
                                        "rounding or chamfer not simulated (the corner is run sharp): {why}"
                                    ),
                                ))
                                .or_default()
                                .push(c.line);
                        }
                    }
                    None => run.flush(),
                }
                run.held = Some(job);
            }
            Ok(())
        };
        // Blocks stream through until the first one with macro logic; from
        // there the rest is read, run, and driven in the order it runs.
        let mut rest: Vec<Block> = Vec::new();
        loop {
            let block = match blocks.next_block() {
                Ok(Some(b)) => b,
                Ok(None) => break,
                Err(ReadError::Io(e)) => {
                    return Err(SourceError::new(path, 0, 0, format!("cannot read: {e}")));
                }
                Err(ReadError::Syntax(e)) => return Err(e),
            };
            if rest.is_empty() && !super::expand::needs_logic(block) {
                process(block)?;
            } else {
                rest.push(block.clone());
            }
        }
        let mut not_followed = None;
        if !rest.is_empty() {
            let lib =
                super::subroutines::load(syntax, path, &self.settings.subroutine_path, &mut rest)?;
            let trace = crate::nc::exec::run_with(syntax.dialect, &rest, lib.main)
                .map_err(|e| SourceError::new(path, e.line, 1, e.message))?;
            match super::expand::check(path, &lib, &rest, &trace) {
                Ok(()) => super::expand::flatten(path, &lib, syntax, &rest, &trace, &mut process)?,
                Err(e) => {
                    // Not followed to the end: in file order, moves with
                    // variables left out.
                    not_followed = Some((e.message.clone(), e.line));
                    for block in &rest[..lib.main] {
                        process(block)?;
                    }
                }
            }
        }
        // The move held back last (`process` is done with `run`).
        run.flush();
        if let Some(at) = approach_open {
            skipped.entry(approach_straight()).or_default().push(at);
        }
        if let Some((why, line)) = not_followed {
            let why = why.trim_start_matches("--expand ").to_string();
            skipped
                // Where the logic stops a value, a jump target or a count
                // is not in the file (a system variable, a caller's
                // argument, a label elsewhere).
                .entry(Reason::new(
                    ReasonKind::Unsaid,
                    format!("the macro logic is not followed: {why}"),
                ))
                .or_default()
                .push(line);
        }
        let (mut summary, sum, sum2) = (run.summary, run.sum, run.sum2);
        let unreadable = Reason::from(Skip::Unreadable);
        let skipped_moves: usize = skipped
            .iter()
            .filter(|(k, _)| **k != unreadable)
            .map(|(_, l)| l.count)
            .sum();
        if let Some(note) = blocks.finish(summary.moves + skipped_moves)? {
            return Err(SourceError::new(
                path,
                0,
                0,
                format!("{note}: nothing to simulate"),
            ));
        }
        if summary.samples > 0 {
            summary.mean_um = sum / summary.samples as f64;
            summary.rms_um = (sum2 / summary.samples as f64).sqrt();
        }
        summary.skipped = skipped.into_iter().collect();
        summary.unmodelled = unmodelled.into_iter().collect();
        Ok(summary)
    }
}

/// An `APPR LT`/`LN` whose auxiliary point is not known is run as a straight
/// line to its end.
/// An approach run straight: how the simulation follows it is not
/// implemented for the element after it.
fn approach_straight() -> Reason {
    Reason::new(ReasonKind::NotImplemented, APPROACH_STRAIGHT)
}

const APPROACH_STRAIGHT: &str = "approach (APPR LT, LN, CT) not simulated through its auxiliary point (run as a straight line to its end): the first contour element after it is not a line or circle in the XY plane that is simulated";

/// A move waiting to be sampled: the next one may cut its end (a
/// HEIDENHAIN rounding or chamfer) or place its auxiliary point (an
/// `APPR LT`).
struct Job {
    line: usize,
    f: Frame,
    path: MovePath,
    feed: bool,
    start_known: bool,
    vector: Option<Vector3<f64>>,
    /// 1: the start is the previous move's end, not sampled again.
    first: usize,
}

/// A simulation's running state: the tallies and the move held back.
struct Run<'a, 's> {
    sim: &'a Simulator,
    summary: SimSummary,
    sum: f64,
    sum2: f64,
    held: Option<Job>,
    sink: &'a mut (dyn FnMut(&Sample) + 's),
}

impl Run<'_, '_> {
    /// Samples the move held back, if any.
    fn flush(&mut self) {
        if let Some(job) = self.held.take() {
            self.sample(&job);
        }
    }

    /// A rounding or chamfer between the move held back and `next`: the
    /// first ends where the element starts, the element is sampled, the
    /// next starts where it ends.
    fn cut_corner(&mut self, c: &Corner, next: &mut Job) -> Result<(), &'static str> {
        let Some(mut before) = self.held.take() else {
            return Err("no line before it was simulated");
        };
        let (MovePath::Line { p0: a, p1: p }, MovePath::Line { p0: q, p1: b }) =
            (before.path, next.path)
        else {
            self.held = Some(before);
            self.flush();
            return Err("it is not between two straight lines");
        };
        let cut = match corner_path(&a, &p, &b, c.kind, next.f.u) {
            Ok(_)
                if !(p.iter().zip(&q)).all(|(x, y)| x == y || (x.is_nan() && y.is_nan()))
                    || !before.start_known
                    || !next.start_known =>
            {
                Err("the lines around it do not meet")
            }
            x => x,
        };
        let (_, _, path) = match cut {
            Ok(x) => x,
            Err(why) => {
                self.held = Some(before);
                self.flush();
                return Err(why);
            }
        };
        before.path = MovePath::Line {
            p0: a,
            p1: path.at(0.0),
        };
        self.sample(&before);
        let element = Job {
            line: c.line,
            f: next.f,
            path,
            feed: true,
            start_known: true,
            vector: next.vector,
            first: 1,
        };
        self.sample(&element);
        next.path = MovePath::Line {
            p0: path.at(1.0),
            p1: b,
        };
        Ok(())
    }

    /// An `APPR LT`/`LN`/`CT` held back: run from its start to the
    /// auxiliary point `a` places, then on to its end (round its arc for
    /// `CT`); the element after it starts there.
    fn approach(&mut self, a: &Approach) -> Result<(), &'static str> {
        let path = match a.path {
            Ok(p) => p,
            Err(why) => {
                self.flush();
                return Err(why);
            }
        };
        let Some(mut before) = self.held.take() else {
            return Err("the approach itself was not simulated");
        };
        let same = |p: &[f64; 6], q: &[f64; 6]| {
            p.iter()
                .zip(q)
                .all(|(x, y)| x == y || (x.is_nan() && y.is_nan()))
        };
        match before.path {
            MovePath::Line { p0, p1 } if same(&p0, &path[0]) && same(&p1, &path[2]) => {}
            _ => {
                self.held = Some(before);
                self.flush();
                return Err("the approach ran elsewhere than its path");
            }
        }
        before.path = MovePath::Line {
            p0: path[0],
            p1: path[1],
        };
        self.sample(&before);
        // A CT's leg to PA is its arc, the others a line.
        let leg = match (a.leg, a.arc) {
            (Leg::Arc { cw, .. }, Some(c)) => MovePath::Arc {
                p0: path[1],
                p1: path[2],
                geo: ArcGeo::new((0, 1, 2), c, &path[1], &path[2], cw, 0),
            },
            _ => MovePath::Line {
                p0: path[1],
                p1: path[2],
            },
        };
        let to_pa = Job {
            line: before.line,
            f: before.f,
            path: leg,
            feed: true,
            start_known: before.start_known,
            vector: before.vector,
            first: 1,
        };
        self.sample(&to_pa);
        Ok(())
    }

    /// Samples a move: its end point, and with a step points along it.
    fn sample(&mut self, job: &Job) {
        let sim = self.sim;
        let f = &job.f;
        let (p0, p1) = match job.path {
            MovePath::Line { p0, p1 }
            | MovePath::Arc { p0, p1, .. }
            | MovePath::Through { p0, p1, .. } => (p0, p1),
        };
        let n = if job.feed && job.start_known && sim.settings.step > 0.0 {
            let (a, _) = sim.poses(f, &p0, job.vector);
            let (b, _) = sim.poses(f, &p1, job.vector);
            let len = match job.path {
                MovePath::Arc { geo, .. } => {
                    (geo.sweep.abs() * geo.rs.max(geo.re) * f.u).max((b.tip - a.tip).norm())
                }
                MovePath::Through { geo, .. } => geo.sweep * geo.r * f.u,
                _ => (b.tip - a.tip).norm(),
            };
            let turn = super::largest_turn(&p0, &p1);
            let len = match f.tcp {
                Tcp::Off => len.max(swept_length(&job.path, &p0, turn, |p| {
                    sim.poses(f, p, job.vector).0.tip
                })),
                _ => len,
            };
            // And a sample a degree of turn: under TCP the axes may turn
            // round a tip that hardly moves, and the errors change with them.
            let by_length = (len / sim.settings.step).ceil();
            (by_length.max(turn.ceil()) as usize).clamp(1, 100_000)
        } else {
            1
        };
        for k in job.first..=n {
            let s = k as f64 / n as f64;
            let p = match k {
                0 => p0,
                _ if n == 1 => p1,
                _ => job.path.at(s),
            };
            let (nominal, actual) = sim.poses(f, &p, job.vector);
            let sample = Sample {
                line: job.line,
                fraction: s,
                feed: job.feed && k > 0,
                nominal,
                actual,
            };
            let e = sample.error().norm() * 1e3;
            self.sum += e;
            self.sum2 += e * e;
            let summary = &mut self.summary;
            summary.samples += 1;
            if summary.max_um.is_none_or(|l| e > l.value) {
                summary.max_um = Some(Largest {
                    value: e,
                    line: job.line,
                });
            }
            summary.max_axis_urad = summary.max_axis_urad.max(sample.axis_error() * 1e6);
            (self.sink)(&sample);
        }
    }
}

/// The length of the tip's path along `path` from `p0`, mm, where rotary
/// axes turn by `turn` deg without TCP (0 for a turn of a degree or less):
/// the tip then swings round the rotary axes, and a long turn's chord can be
/// far shorter than its path (a 359 deg turn ends a degree from where it
/// started). Measured through points a degree of turn apart, which is
/// within 1e-4 of the arc's length.
fn swept_length(
    path: &MovePath,
    p0: &[f64; 6],
    turn: f64,
    tip: impl Fn(&[f64; 6]) -> Vector3<f64>,
) -> f64 {
    if turn <= 1.0 {
        return 0.0;
    }
    let m = (turn.ceil() as usize).min(100_000);
    let mut prev = tip(p0);
    let mut sum = 0.0;
    for k in 1..=m {
        let q = tip(&path.at(k as f64 / m as f64));
        sum += (q - prev).norm();
        prev = q;
    }
    sum
}

/// The samples of a run as `simulate nc -o` writes them: `title` as the
/// first comment line, then one row per sample (nominal tip and axis in W,
/// tip error in um, axis error in urad); with `against` (the original a
/// compensated program was checked against), a last column with each
/// sample's distance from the original's path, um, empty for a rapid.
pub fn samples_csv(
    title: &str,
    samples: &[(Sample, Option<f64>)],
    against: Option<&Path>,
) -> String {
    use std::fmt::Write as _;
    let mut t = format!(
        "# {title}\n# nominal tip x,y,z (mm) and axis i,j,k in W; error = actual - nominal (um, urad)\n"
    );
    if let Some(a) = against {
        let _ = writeln!(
            t,
            "# deviation: um of the actual tip from the path {} asks for (feed moves only)",
            a.display()
        );
    }
    t.push_str("line,fraction,x,y,z,i,j,k,ex,ey,ez,error,axis_error");
    t.push_str(if against.is_some() {
        ",deviation\n"
    } else {
        "\n"
    });
    for (s, deviation) in samples {
        let (n, e) = (&s.nominal, s.error() * 1e3);
        let _ = write!(
            t,
            "{},{:.4},{:.6},{:.6},{:.6},{:.9},{:.9},{:.9},{:.4},{:.4},{:.4},{:.4},{:.3}",
            s.line,
            s.fraction,
            n.tip.x,
            n.tip.y,
            n.tip.z,
            n.axis.x,
            n.axis.y,
            n.axis.z,
            e.x,
            e.y,
            e.z,
            e.norm(),
            s.axis_error() * 1e6
        );
        match (against, deviation) {
            (Some(_), Some(d)) => {
                let _ = writeln!(t, ",{d:.4}");
            }
            (Some(_), None) => t.push_str(",\n"),
            (None, _) => t.push('\n'),
        }
    }
    t
}

/// What a CMM would measure at the nominal surface points `points` on a
/// part cut by the tool path `samples` (in order), for a tool that cuts at
/// its tip with its axis along the surface normal (a ball-end or flat tool
/// held normal to the surface): the surface moves by the tip's error along
/// the tool axis. Each point takes the nearest approach of the actual tip
/// path (feed moves only); a point farther than `max_distance` (mm) from it
/// is an error.
pub fn measure_surface(
    samples: &[Sample],
    points: &[(String, Vector3<f64>)],
    max_distance: f64,
) -> Result<Vec<(String, Vector3<f64>)>, String> {
    let mut out = Vec::with_capacity(points.len());
    for (label, q) in points {
        let mut best: Option<(f64, Vector3<f64>, Vector3<f64>)> = None;
        for w in samples.windows(2) {
            let (a, b) = (&w[0], &w[1]);
            if !b.feed {
                continue;
            }
            let t = crate::geom::nearest_on_segment(q, &a.actual.tip, &b.actual.tip);
            let p = a.actual.tip + (b.actual.tip - a.actual.tip) * t;
            let dist = (p - q).norm();
            if best.is_none_or(|(bd, _, _)| dist < bd) {
                let axis = (a.actual.axis * (1.0 - t) + b.actual.axis * t).normalize();
                best = Some((dist, p, axis));
            }
        }
        let Some((dist, p, n)) = best else {
            return Err("the program has no feed moves to cut a surface".into());
        };
        if dist > max_distance {
            return Err(format!(
                "point {label} is {dist:.3} mm from the tool path (more than {max_distance} mm): not a point this program cuts"
            ));
        }
        out.push((label.clone(), q + n * (p - q).dot(&n)));
    }
    Ok(out)
}
