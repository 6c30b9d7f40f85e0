//! The correction of one move: the tool pose the program asks for, the axis
//! values that reach it on the machine with the errors, the limit on the
//! size of a correction, and how many pieces the move needs (or whether an
//! arc stays an arc) so the actual path stays within the tolerance. The
//! result is a [`WritePlan`] of corrected points; writing them into the
//! program's text is the writer's business.

use std::f64::consts::PI;
use std::path::PathBuf;

use nalgebra::Vector3;

use super::{CompensateError, Compensator, Reason, ReasonKind, Solution};
use crate::kinematics::{Axes, ToolPose};
use crate::limits::MAX_PIECES;
use crate::nc::interp::approach::{Leg, arc_center, departure_end};
use crate::nc::interp::coordinates::known;
use crate::nc::interp::corner::{Corner, corner_path};
use crate::nc::interp::interpolation::{ArcGeo, CircleGeo, Path, lerp};
use crate::nc::interp::tangent::tangent_arc;
use crate::nc::interp::{AXES, Arc, Drill, Frame, Move, MoveKind, Skip, Tcp};

/// A corrected point: what the program asked for and what to write.
#[derive(Clone, Copy, Debug)]
pub(super) struct CorrectedPoint {
    pub nominal: Axes,
    pub target: ToolPose,
    /// Written values in the model frame (unrounded).
    pub written: Axes,
    /// Written values in program units and frame (unrounded).
    pub program: [f64; 6],
    pub held: Option<f64>,
    pub held_tilt: Option<f64>,
    /// 3+2 in a tilted plane: the rotary positions are the controller's
    /// and stay; the angle left between the actual and the intended tool
    /// axis, rad.
    pub plane_axis: Option<f64>,
    /// A hole of a canned cycle: the rotary positions stay (a cycle moves
    /// the linear axes only); the angle left between the actual and the
    /// intended hole axis, rad, and how far that puts the tip at the R
    /// level from the intended hole axis, mm.
    pub drill: Option<(f64, f64)>,
}

/// How a move is written.
#[derive(Clone, Debug)]
pub(super) enum WritePlan {
    /// Its end point, corrected, in the block itself.
    End(CorrectedPoint),
    /// Pieces along it (fraction of the move, point): the block carries the
    /// first, the others follow as new blocks; `linearize` turns an arc
    /// into lines.
    Pieces {
        pieces: Vec<(f64, CorrectedPoint)>,
        linearize: bool,
    },
    /// An arc kept as an arc around the corrected centre (program frame),
    /// or a `CIP` kept through the corrected intermediate point `through`
    /// (program frame, X Y Z; `center` is then its circle's centre on the
    /// first two axes, which no word holds).
    Arc {
        end: CorrectedPoint,
        center: [f64; 2],
        through: Option<[f64; 3]>,
    },
}

/// Why a move is not corrected.
#[derive(Debug)]
pub(super) enum Refusal {
    /// Left as written, with the reason.
    Skip(Reason),
    /// The run stops.
    Fatal(CompensateError),
}

impl From<CompensateError> for Refusal {
    fn from(e: CompensateError) -> Self {
        Refusal::Fatal(e)
    }
}

impl Compensator {
    fn target(&self, f: &Frame, n: &Axes, vector: Option<Vector3<f64>>) -> ToolPose {
        match f.tcp {
            Tcp::Off => self.solver.nominal_pose(n),
            _ => ToolPose {
                tip: n.xyz,
                axis: vector.unwrap_or_else(|| self.solver.nominal_pose(n).axis),
            },
        }
    }

    /// What is written for corrected axis values: the axes themselves, or
    /// under TCP the tip the nominal controller turns into them.
    pub(super) fn written_model(&self, f: &Frame, corrected: &Axes) -> Axes {
        match f.tcp {
            Tcp::Off => *corrected,
            _ => Axes {
                xyz: self.solver.nominal_pose(corrected).tip,
                ..*corrected
            },
        }
    }

    /// The actual tool pose for written values (model frame).
    fn actual(&self, f: &Frame, w: &Axes) -> ToolPose {
        match f.tcp {
            Tcp::Off => self.solver.actual_pose(w),
            _ => {
                let xyz = self
                    .solver
                    .nominal()
                    .position(&w.xyz, w.tilt, w.c, &Vector3::zeros());
                self.solver.actual_pose(&Axes { xyz, ..*w })
            }
        }
    }

    /// The corrected point for the program point `p`; `hold` holds C at its
    /// nominal value plus `hold` degrees.
    pub(super) fn correct(
        &self,
        f: &Frame,
        p: &[f64; 6],
        vector: Option<Vector3<f64>>,
        hold: Option<f64>,
    ) -> Result<CorrectedPoint, String> {
        let nominal = f.model(p);
        self.check_strokes(&nominal)?;
        let m = self.solver.kinematics().machine();
        let target = self.target(f, &nominal, vector);
        if f.plane.is_some() {
            // 3+2: the rotary positions are the plane's, and only X, Y, Z
            // in the plane are rewritten: the tip lands exactly, the tool
            // axis stays as the erroneous machine tilts it.
            let (mut pt, left) = self.tip_only(f, nominal, target, (nominal.tilt, nominal.c));
            pt.plane_axis = Some(left);
            self.check_linear_strokes(f, &nominal, &pt)?;
            return Ok(pt);
        }
        let why = |e| format!("no axis values reach the intended tool pose on this machine ({e})");
        let sol = match hold {
            Some(dc) => self.solver.solve_held(
                &target,
                &Axes {
                    c: nominal.c + dc,
                    ..nominal
                },
            ),
            None => self.solver.solve(&target, &nominal),
        }
        .map_err(why)?;
        let mut pt = self.point(f, nominal, target, &sol);
        for (axis, v) in [(&m.tilt, sol.axes.tilt), (&m.c, sol.axes.c)] {
            if let Some((lo, hi)) = axis.limits
                && !axis.within(v, 1e-9)
            {
                return Err(format!(
                    "the correction drives {} to {v:.4} deg, beyond its stroke {lo}..{hi} deg",
                    axis.letter
                ));
            }
        }
        self.check_linear_strokes(f, &nominal, &pt)?;
        let (lin, rot) = size(&pt);
        let limit = self.settings.max_correction;
        if sol.held_c.is_none() && lin > limit && rot <= limit {
            // A swing of C that drags X, Y, Z past the limit (the tool
            // turns little, the table a lot): hold C if that keeps the
            // correction inside.
            if let Ok(held) = self.solver.solve_held(&target, &nominal) {
                let alt = self.point(f, nominal, target, &held);
                if !self.exceeds(&alt) {
                    pt = alt;
                }
            }
        }
        Ok(pt)
    }

    /// A program point whose rotary positions are beyond the machine's
    /// strokes is not this machine's.
    fn check_strokes(&self, nominal: &Axes) -> Result<(), String> {
        let m = self.solver.kinematics().machine();
        for (axis, v) in [(&m.tilt, nominal.tilt), (&m.c, nominal.c)] {
            if let Some((lo, hi)) = axis.limits
                && !axis.within(v, 1e-9)
            {
                return Err(format!(
                    "the program puts {} at {v:.4} deg, beyond the machine's stroke {lo}..{hi} deg (a program for another machine?)",
                    axis.letter
                ));
            }
        }
        Ok(())
    }

    /// A correction that drives X, Y or Z beyond its stroke, where the
    /// program as written stays inside it, is refused. Where the program
    /// itself is beyond (a program for another machine, or placed by
    /// another `--origin`) the correction is not what takes it there, and
    /// the strokes say nothing about it.
    fn check_linear_strokes(
        &self,
        f: &Frame,
        nominal: &Axes,
        pt: &CorrectedPoint,
    ) -> Result<(), String> {
        let kin = self.solver.kinematics();
        let machine_axes = |written: &Axes| match f.tcp {
            Tcp::Off => *written,
            // The control turns the written tip into axis values with
            // its nominal kinematics.
            _ => Axes {
                xyz: self.solver.nominal().position(
                    &written.xyz,
                    written.tilt,
                    written.c,
                    &Vector3::zeros(),
                ),
                ..*written
            },
        };
        let Err(why) = kin.check_strokes(&machine_axes(&pt.written)) else {
            return Ok(());
        };
        match kin.check_strokes(&machine_axes(nominal)) {
            Ok(()) => Err(format!(
                "the correction puts the machine beyond its stroke: {why} (the program as written stays inside)"
            )),
            Err(_) => Ok(()),
        }
    }

    /// The point that puts the tip on `target` with the rotary axes at
    /// `rotary` (tilt, C), and the angle left between the actual and the
    /// intended tool axis, rad.
    fn tip_only(
        &self,
        f: &Frame,
        nominal: Axes,
        target: ToolPose,
        (tilt, c): (f64, f64),
    ) -> (CorrectedPoint, f64) {
        let axes = Axes {
            xyz: self.solver.position_at(&target.tip, tilt, c),
            tilt,
            c,
        };
        let sol = Solution {
            axes,
            held_c: None,
            held_tilt: None,
        };
        let pt = self.point(f, nominal, target, &sol);
        let got = self.solver.actual_pose(&axes).axis.normalize();
        let left = got.dot(&target.axis.normalize()).clamp(-1.0, 1.0).acos();
        (pt, left)
    }

    /// The bottom of a hole of a canned cycle: the cycle moves the linear
    /// axes only, so the tip is put on the intended bottom with the rotary
    /// axes where the blocks before left them (`emit`, as written: an
    /// orientation corrected there carries over); the drill then runs
    /// along the actual tool axis, off the intended one by what is left of
    /// the machine's orientation error.
    fn correct_hole(
        &self,
        f: &Frame,
        p: &[f64; 6],
        drill: &Drill,
        emit: &[Option<f64>; 6],
    ) -> Result<CorrectedPoint, String> {
        if f.plane.is_some() {
            // In a tilted plane every point keeps the plane's positions.
            return self.correct(f, p, None, None);
        }
        let nominal = f.model(p);
        self.check_strokes(&nominal)?;
        let target = self.target(f, &nominal, None);
        let mut at = *p;
        for a in [f.tilt, 5] {
            if let Some(v) = emit[a] {
                at[a] = v;
            }
        }
        let written = f.model(&at);
        let (mut pt, left) = self.tip_only(f, nominal, target, (written.tilt, written.c));
        let depth = (p[drill.axis] - drill.r_level).abs() * f.u;
        pt.drill = Some((left, left * depth));
        Ok(pt)
    }

    fn point(&self, f: &Frame, nominal: Axes, target: ToolPose, sol: &Solution) -> CorrectedPoint {
        let written = self.written_model(f, &sol.axes);
        CorrectedPoint {
            nominal,
            target,
            written,
            program: f.program(&written),
            held: sol.held_c,
            held_tilt: sol.held_tilt,
            plane_axis: None,
            drill: None,
        }
    }

    fn exceeds(&self, pt: &CorrectedPoint) -> bool {
        let (l, r) = size(pt);
        let limit = self.settings.max_correction;
        l > limit || r > limit
    }

    /// The correction limit: an error naming the line when `pt` exceeds it.
    pub(super) fn check_limit(
        &self,
        pt: &CorrectedPoint,
        line: usize,
    ) -> Result<(), CompensateError> {
        let (lin_um, rot_urad) = size(pt);
        let limit = self.settings.max_correction;
        let m = self.solver.kinematics().machine();
        if lin_um > limit {
            return Err(CompensateError::TooLarge {
                path: PathBuf::new(),
                line,
                what: format!(
                    "correction of {lin_um:.1} um in X, Y, Z exceeds --max-correction {limit} um; nothing written"
                ),
            });
        }
        if rot_urad > limit {
            return Err(CompensateError::TooLarge {
                path: PathBuf::new(),
                line,
                what: format!(
                    "correction of the tool orientation by {rot_urad:.1} urad ({} and C) exceeds --max-correction {limit} urad; nothing written",
                    m.tilt.letter
                ),
            });
        }
        Ok(())
    }

    /// Tip distance between the actual path of written values interpolated
    /// from `w0` to `w1` and the intended path, at fraction `t` of a piece
    /// spanning `u0..u1` of the nominal path.
    #[allow(clippy::too_many_arguments)]
    fn deviation(
        &self,
        f: &Frame,
        path: &Path,
        u0: f64,
        u1: f64,
        w0: &[f64; 6],
        w1: &[f64; 6],
        t: f64,
        vector: Option<Vector3<f64>>,
    ) -> f64 {
        let n = f.model(&path.at(u0 + t * (u1 - u0)));
        let target = self.target(f, &n, vector);
        let w = f.model(&lerp(w0, w1, t));
        (self.actual(f, &w).tip - target.tip).norm()
    }

    #[allow(clippy::too_many_arguments)]
    fn piece_deviation(
        &self,
        f: &Frame,
        path: &Path,
        u0: f64,
        u1: f64,
        w0: &[f64; 6],
        w1: &[f64; 6],
        vector: Option<Vector3<f64>>,
    ) -> f64 {
        let tol = self.path_tolerance();
        // Along a piece that turns far, the deviation goes round with the
        // turn: at the middle of two whole turns of a head's C the tool is
        // back where it started, and the middle and quarters can all miss
        // the worst. Such a piece is sampled every 5 deg of turn or less.
        // Over 20 deg or less the deviation is near a parabola between the
        // ends, which the middle and quarters find.
        let turn = super::largest_turn(w0, w1);
        if turn > 20.0 {
            let k = every_5_deg(turn);
            return (1..k)
                .map(|j| self.deviation(f, path, u0, u1, w0, w1, j as f64 / k as f64, vector))
                .fold(0.0, f64::max);
        }
        let mid = self.deviation(f, path, u0, u1, w0, w1, 0.5, vector);
        if mid > tol / 8.0 {
            mid.max(self.deviation(f, path, u0, u1, w0, w1, 0.25, vector))
                .max(self.deviation(f, path, u0, u1, w0, w1, 0.75, vector))
        } else {
            mid
        }
    }

    /// Whether a line needs no subdivision by the cheap bound of
    /// [`super::Solver::deviation_bound`] (post-side, constant errors):
    /// most blocks of a real program are short and are settled here without
    /// evaluating the path.
    fn short_enough(&self, f: &Frame, p0: &[f64; 6], w0: &[f64; 6], end: &CorrectedPoint) -> bool {
        if f.tcp != Tcp::Off || !self.solver.is_fast() {
            return false;
        }
        let (n0, w0m) = (f.model(p0), f.model(w0));
        // The written start may be off by the rounding of its lexemes.
        let ends = 1e-4;
        self.solver
            .deviation_bound(&n0, &end.nominal, &w0m, &end.written, ends)
            <= self.path_tolerance() / 2.0
    }

    /// Pieces (end points) along `path` from the written start `w0` so that
    /// each stays within the tolerance; the last is `end`. `ramp`: C is
    /// held at either end, so the correction of C ramps between them.
    #[allow(clippy::too_many_arguments)]
    fn pieces(
        &self,
        f: &Frame,
        path: &Path,
        w0: &[f64; 6],
        end: &CorrectedPoint,
        n0: usize,
        vector: Option<Vector3<f64>>,
        ramp: bool,
        line: usize,
    ) -> Result<Vec<(f64, CorrectedPoint)>, CompensateError> {
        let tol = self.path_tolerance();
        let mut n = n0.max(1);
        // Where C is held at either end, the pieces do not switch between
        // held and exact solutions (which would jump): the correction of C
        // ramps from its value at the start to its value at the end, the
        // tilt is the best for that C and the tip stays exact.
        let mut ramp = ramp || end.held.is_some();
        let mut saw_held = false;
        let dc0 = w0[5] - path.at(0.0)[5];
        let dc1 = end.written.c - end.nominal.c;
        loop {
            // Checked before the pieces are made: an arc of many turns
            // (LinuxCNC's P word) asks for billions at once.
            if n > MAX_PIECES {
                // A move that passes the singularity between exact ends (the
                // tilt through zero while C turns): its pieces jump between
                // the exact C correction, which grows without bound there,
                // and C held, which no number of pieces mends. The held
                // ends' ramp is tried before the move is refused.
                if saw_held && !ramp {
                    ramp = true;
                    n = n0.max(1);
                    continue;
                }
                return Err(CompensateError::Tolerance {
                    path: PathBuf::new(),
                    line,
                    what: format!(
                        "the move cannot be followed within --tolerance {} um (of which the written decimals take {:.3} um) even in {MAX_PIECES} pieces",
                        self.settings.tolerance * 1e3,
                        self.rounding * 1e3,
                    ),
                });
            }
            let mut pts = Vec::with_capacity(n);
            for k in 1..=n {
                let u = k as f64 / n as f64;
                if k == n {
                    pts.push((1.0, *end));
                } else {
                    let hold = ramp.then_some(dc0 + u * (dc1 - dc0));
                    let p = self.correct(f, &path.at(u), vector, hold).map_err(|what| {
                        CompensateError::Tolerance {
                            path: PathBuf::new(),
                            line,
                            what: format!("a point along the move cannot be corrected: {what}"),
                        }
                    })?;
                    pts.push((u, p));
                }
            }
            saw_held |= pts[..n - 1].iter().any(|(_, p)| p.held.is_some());
            let mut worst: f64 = 0.0;
            let mut prev = (0.0, *w0);
            for (u, p) in &pts {
                worst = worst
                    .max(self.piece_deviation(f, path, prev.0, *u, &prev.1, &p.program, vector));
                prev = (*u, p.program);
            }
            if worst <= tol {
                return Ok(pts);
            }
            n = if n == 1 {
                (((worst / tol).sqrt() * 1.25).ceil() as usize).max(2)
            } else {
                n * 2
            };
        }
    }

    /// How to write `mv` from the written position `emit` (what the
    /// controller has after the blocks written so far); `ramp`: the last
    /// written end point had C held.
    pub(super) fn plan(
        &self,
        f: &Frame,
        mv: &Move,
        emit: &[Option<f64>; 6],
        ramp: bool,
        line: usize,
    ) -> Result<WritePlan, Refusal> {
        if let Some(&a) = f.axes().iter().find(|&&a| mv.end[a].is_none()) {
            return Err(Refusal::Skip(Skip::PositionUnknown(AXES[a]).into()));
        }
        let vector = mv.vector;
        let p1 = known(&mv.end);
        let pt = match &mv.drill {
            Some(d) => self.correct_hole(f, &p1, d, emit),
            None => self.correct(f, &p1, vector, None),
        }
        // Both fail only where this machine cannot take the pose: no axis
        // values reach it, or they lie beyond its strokes.
        .map_err(|why| Refusal::Skip(Reason::new(ReasonKind::OtherMachine, why)))?;
        self.check_limit(&pt, line)?;
        let start_known = f
            .axes()
            .iter()
            .all(|&a| mv.start[a].is_some() && emit[a].is_some());
        let p0 = known(&mv.start);
        let w0 = known(emit);
        match mv.kind {
            MoveKind::Rapid => Ok(WritePlan::End(pt)),
            MoveKind::Linear if !start_known || vector.is_some() => Ok(WritePlan::End(pt)),
            MoveKind::Linear => {
                if self.short_enough(f, &p0, &w0, &pt) {
                    return Ok(WritePlan::End(pt));
                }
                // The move before, left as written, leaves the tool off this
                // line's intended start: no pieces from there follow the
                // line, but its corrected end puts the program back on the
                // intended path (the engine reports the line, OFF_START_LINE).
                if !self.starts_on(f, &p0, &w0) {
                    return Ok(WritePlan::End(pt));
                }
                let path = Path::Line { p0, p1 };
                let pieces = self.pieces(f, &path, &w0, &pt, 1, vector, ramp, line)?;
                for (_, p) in &pieces[..pieces.len() - 1] {
                    self.check_limit(p, line)?;
                }
                if pieces.len() == 1 {
                    return Ok(WritePlan::End(pt));
                }
                Ok(WritePlan::Pieces {
                    pieces,
                    linearize: false,
                })
            }
            MoveKind::Arc(_) | MoveKind::Through(_) if !start_known => {
                Err(Refusal::Skip(Skip::PositionUnknown(b'X').into()))
            }
            MoveKind::Arc(_) | MoveKind::Through(_) if !self.starts_on(f, &p0, &w0) => {
                // A path back from where the move before leaves the tool
                // is not implemented.
                Err(Refusal::Skip(Reason::new(
                    ReasonKind::NotImplemented,
                    OFF_START,
                )))
            }
            MoveKind::Arc(arc) => self.plan_arc(f, &arc, &p0, &w0, &p1, pt, ramp, line),
            MoveKind::Through(t) => {
                let path = Path::Through { p0, p1, geo: t.geo };
                self.plan_through(f, &path, &w0, pt, ramp, line)
            }
        }
    }

    /// Whether the written start `w0` puts the tip on the intended start
    /// `p0` within the tolerance: not so after a move left as written,
    /// whose end the errors move.
    pub(super) fn starts_on(&self, f: &Frame, p0: &[f64; 6], w0: &[f64; 6]) -> bool {
        let target = self.target(f, &f.model(p0), None);
        (self.actual(f, &f.model(w0)).tip - target.tip).norm() <= self.settings.tolerance
    }

    /// A `CIP` stays a `CIP` through the corrected intermediate point when
    /// the circle the control then cuts (through the written start, that
    /// point and the corrected end) stays within the tolerance of the
    /// intended one; otherwise it is written as lines. The intermediate
    /// point is corrected as plan_arc corrects a centre: the machine axes
    /// that put the actual tip on the intended one, with the rotary
    /// positions the written move has there. With the rotary axes fixed
    /// the correction is a rigid motion, which carries the intended
    /// circle into the written one; sixteen points along both check it.
    fn plan_through(
        &self,
        f: &Frame,
        path: &Path,
        w0: &[f64; 6],
        pt: CorrectedPoint,
        ramp: bool,
        line: usize,
    ) -> Result<WritePlan, Refusal> {
        let Path::Through { geo, .. } = *path else {
            unreachable!("a CIP's path")
        };
        let tol = self.path_tolerance();
        let um = geo.through_at / geo.sweep;
        let tip = self.target(f, &f.model(&path.at(um)), None).tip;
        // The rotary positions the written move has at the intermediate
        // point: linear from the written start to the corrected end.
        let w1 = pt.program;
        let at = f.model(&lerp(w0, &w1, um));
        let m = Axes {
            xyz: self.solver.position_at(&tip, at.tilt, at.c),
            ..at
        };
        let wm = f.program(&self.written_model(f, &m));
        let written = CircleGeo::through(
            [w0[0], w0[1], w0[2]],
            [wm[0], wm[1], wm[2]],
            [w1[0], w1[1], w1[2]],
            f.u,
        );
        let keep = written.is_ok_and(|wg| {
            let written = Path::Through {
                p0: *w0,
                p1: w1,
                geo: wg,
            };
            (wg.sweep - geo.sweep).abs() < 0.5
                && (1..16).all(|k| {
                    let u = k as f64 / 16.0;
                    let target = self.target(f, &f.model(&path.at(u)), None);
                    let w = f.model(&written.at(u));
                    (self.actual(f, &w).tip - target.tip).norm() <= tol
                })
        });
        if keep {
            return Ok(WritePlan::Arc {
                end: pt,
                center: [geo.center[0], geo.center[1]],
                through: Some([wm[0], wm[1], wm[2]]),
            });
        }
        let r = geo.r * f.u;
        self.linearize_path(f, path, r, geo.sweep, w0, pt, ramp, line)
    }

    /// An arc stays an arc around the corrected centre when the corrected
    /// arc stays within the tolerance; otherwise it is linearized. With the
    /// rotary axes fixed the correction is a rigid motion and sixteen
    /// points along the arc check it; an arc during which they move is
    /// kept only within one turn, where the same points follow the change
    /// of the correction (at zero error the program stays as written).
    #[allow(clippy::too_many_arguments)]
    fn plan_arc(
        &self,
        f: &Frame,
        arc: &Arc,
        p0: &[f64; 6],
        w0: &[f64; 6],
        p1: &[f64; 6],
        pt: CorrectedPoint,
        ramp: bool,
        line: usize,
    ) -> Result<WritePlan, Refusal> {
        let tol = self.path_tolerance();
        let axes = arc.plane.axes();
        let geo = ArcGeo::new(axes, arc.center, p0, p1, arc.cw, arc.turns);
        let rotary_fixed = p0[f.tilt] == p1[f.tilt] && p0[5] == p1[5];
        // The corrected centre, with the rotary axes where the arc runs
        // (where it ends when they move: the corrected centre is written
        // with the end's corrected rotary positions).
        let (a0, a1, _) = axes;
        let mut pc = *p0;
        pc[a0] = arc.center[0];
        pc[a1] = arc.center[1];
        pc[f.tilt] = p1[f.tilt];
        pc[5] = p1[5];
        let nc = f.model(&pc);
        let tip = self.target(f, &nc, None).tip;
        // The machine axes that put the actual tip on the centre with the
        // corrected rotary positions; under TCP, written as the W point the
        // nominal controller turns into them.
        let m = Axes {
            xyz: self.solver.position_at(&tip, pt.written.tilt, pt.written.c),
            tilt: pt.written.tilt,
            c: pt.written.c,
        };
        let cprog = f.program(&self.written_model(f, &m));
        let center = [cprog[a0], cprog[a1]];
        let mut keep = rotary_fixed || arc.turns == 0;
        if keep {
            let wg = ArcGeo::new(axes, center, w0, &pt.program, arc.cw, arc.turns);
            // The program's own arc may spiral a little (its radii differ
            // within the control's tolerance): the corrected one may
            // spiral as much, not more, so that a zero correction keeps
            // the arc as written.
            let spiral = ((wg.rs - wg.re) - (geo.rs - geo.re)).abs() * f.u;
            keep = spiral <= tol && (wg.sweep - geo.sweep).abs() < 0.5;
            if keep {
                // Sixteen points, or one every 5 deg of turn: a C that turns
                // whole turns over the arc is back where it started at each
                // sixteenth once it turns 16 turns.
                let m = samples_along(super::largest_turn(w0, &pt.program));
                for k in 1..m {
                    let u = k as f64 / m as f64;
                    let n = f.model(&geo.at(p0, p1, u));
                    let target = self.target(f, &n, None);
                    let w = f.model(&wg.at(w0, &pt.program, u));
                    if (self.actual(f, &w).tip - target.tip).norm() > tol {
                        keep = false;
                        break;
                    }
                }
            }
        }
        if keep {
            return Ok(WritePlan::Arc {
                end: pt,
                center,
                through: None,
            });
        }
        self.linearize_arc(f, &geo, p0, w0, p1, pt, ramp, line)
    }

    /// The arc `geo` from `p0` to `p1` as lines from the written start
    /// `w0`, each within the tolerance of it.
    #[allow(clippy::too_many_arguments)]
    fn linearize_arc(
        &self,
        f: &Frame,
        geo: &ArcGeo,
        p0: &[f64; 6],
        w0: &[f64; 6],
        p1: &[f64; 6],
        pt: CorrectedPoint,
        ramp: bool,
        line: usize,
    ) -> Result<WritePlan, Refusal> {
        let path = Path::Arc {
            p0: *p0,
            p1: *p1,
            geo: *geo,
        };
        let r = geo.rs.max(geo.re) * f.u;
        self.linearize_path(f, &path, r, geo.sweep, w0, pt, ramp, line)
    }

    /// A circular `path` of radius `r` (mm) turning through `sweep` (rad)
    /// as lines from the written start `w0`, each within the tolerance of
    /// it.
    #[allow(clippy::too_many_arguments)]
    fn linearize_path(
        &self,
        f: &Frame,
        path: &Path,
        r: f64,
        sweep: f64,
        w0: &[f64; 6],
        pt: CorrectedPoint,
        ramp: bool,
        line: usize,
    ) -> Result<WritePlan, Refusal> {
        let tol = self.path_tolerance();
        let step = if r > tol / 2.0 {
            2.0 * (1.0 - tol / 2.0 / r).clamp(-1.0, 1.0).acos()
        } else {
            PI / 2.0
        };
        let n0 = ((sweep.abs() / step.max(1e-4)).ceil() as usize).max(2);
        let pieces = self.pieces(f, path, w0, &pt, n0, None, ramp, line)?;
        for (_, p) in &pieces[..pieces.len() - 1] {
            self.check_limit(p, line)?;
        }
        Ok(WritePlan::Pieces {
            pieces,
            linearize: true,
        })
    }
}

impl Compensator {
    /// A HEIDENHAIN `CT`: the control cuts the arc from where the written
    /// program leaves the tool, in the direction `tangent` the written
    /// element before it ends in, to the written end point. Where that
    /// arc, with the corrected X and Y and the other axes where they
    /// are, stays on the intended one within the tolerance (its end
    /// included), the corrected X and Y are written into the `CT` itself
    /// (with the rotary axes fixed the correction is a rigid motion,
    /// which carries the intended arc and the direction it starts in into
    /// the written ones, up to the micrometres it tilts the plane by);
    /// otherwise the arc is written as lines, which do not depend
    /// on the element before.
    pub(super) fn plan_tangential(
        &self,
        f: &Frame,
        mv: &Move,
        emit: &[Option<f64>; 6],
        tangent: Option<[f64; 2]>,
        ramp: bool,
        line: usize,
    ) -> Result<WritePlan, Refusal> {
        let plan = self.plan(f, mv, emit, ramp, line)?;
        let (WritePlan::Arc { end, .. }, MoveKind::Arc(arc)) = (&plan, mv.kind) else {
            return Ok(plan);
        };
        let (p0, p1, w0) = (known(&mv.start), known(&mv.end), known(emit));
        let geo = ArcGeo::new((0, 1, 2), arc.center, &p0, &p1, arc.cw, 0);
        let intended = Path::Arc { p0, p1, geo };
        // A CT carries the two axes of its plane only (TNC7 user's manual,
        // 81762x-16, "Circular path CT": at most two axes define the end
        // point): the others stay where the written program has them.
        let mut w1 = end.program;
        w1[2..].copy_from_slice(&w0[2..]);
        let written = tangent.and_then(|t| {
            let (c, cw) = tangent_arc([w0[0], w0[1]], t, [w1[0], w1[1]], f.u).ok()?;
            let wg = ArcGeo::new((0, 1, 2), c, &w0, &w1, cw, 0);
            ((wg.sweep - geo.sweep).abs() < 0.5).then_some(Path::Arc {
                p0: w0,
                p1: w1,
                geo: wg,
            })
        });
        if let Some(w) = written
            && self.path_deviation(f, &intended, &w) <= self.path_tolerance()
        {
            let written = f.model(&w1);
            return Ok(WritePlan::End(CorrectedPoint {
                written,
                program: w1,
                ..*end
            }));
        }
        self.linearize_arc(f, &geo, &p0, &w0, &p1, *end, ramp, line)
    }

    /// The largest tip distance, mm, between the intended path and the
    /// actual one of the written path (program frame), at seventeen points
    /// along both, or one every 5 deg of turn if more.
    fn path_deviation(&self, f: &Frame, intended: &Path, written: &Path) -> f64 {
        let mut worst: f64 = 0.0;
        let m = samples_along(super::largest_turn(&written.at(0.0), &written.at(1.0)));
        for k in 0..=m {
            let u = k as f64 / m as f64;
            let target = self.target(f, &f.model(&intended.at(u)), None);
            let w = f.model(&written.at(u));
            worst = worst.max((self.actual(f, &w).tip - target.tip).norm());
        }
        worst
    }

    /// A HEIDENHAIN `APPR LT`/`LN`: its end point PA corrected, the rotary axes
    /// where the written program has them before it (the control builds
    /// the approach as a two-dimensional element; a tool-axis word it
    /// reaches by the auxiliary point, [`super::engine`] bounds how); the
    /// end must still land within the tolerance. Its path through the
    /// auxiliary point is checked once the first contour element after it
    /// is written ([`Compensator::approach_deviation`]); a line that would
    /// have to be written in pieces is left as written, since pieces would
    /// move the start the control builds the approach from.
    pub(super) fn plan_approach(
        &self,
        f: &Frame,
        mv: &Move,
        emit: &[Option<f64>; 6],
        ramp: bool,
        line: usize,
    ) -> Result<WritePlan, Refusal> {
        let refuse = |kind, why: String| {
            Refusal::Skip(Reason::new(
                kind,
                format!("approach or departure (APPR/DEP) left as written: {why}"),
            ))
        };
        if f.axes().iter().any(|&a| emit[a].is_none()) {
            return Err(refuse(
                ReasonKind::Unsaid,
                "where the written program has the tool before it is not known (the control starts the approach there)".into(),
            ));
        }
        let WritePlan::End(end) = self.plan(f, mv, emit, ramp, line)? else {
            return Err(refuse(
                ReasonKind::NotImplemented,
                "its corrected line would have to be written in pieces, which would move the start the control builds the approach from".into(),
            ));
        };
        let w0 = known(emit);
        let mut w1 = end.program;
        w1[3..].copy_from_slice(&w0[3..]);
        let p1 = known(&mv.end);
        let miss = self.path_deviation(
            f,
            &Path::Line { p0: p1, p1 },
            &Path::Line { p0: w1, p1: w1 },
        );
        let tol = self.path_tolerance();
        if miss > tol {
            return Err(refuse(
                ReasonKind::NotImplemented,
                format!(
                    "with the rotary axes where the block before leaves them, its corrected end lands {:.2} um from the intended one, {}",
                    miss * 1e3,
                    self.beyond_tolerance()
                ),
            ));
        }
        Ok(WritePlan::End(CorrectedPoint {
            written: f.model(&w1),
            program: w1,
            ..end
        }))
    }

    /// How far the tip leaves the intended path of an `APPR LT`/`LN`/`CT`
    /// (`want`: start, auxiliary point, first contour point, program
    /// frame) where the control runs the one it builds from the written
    /// blocks (`written`, likewise), mm: seventeen points along each of
    /// its two legs. The second is an arc for `CT` (`arc`: whether it
    /// turns clockwise, the intended centre and the written one). With the
    /// rotary axes fixed the correction is a rigid motion, which carries
    /// the first element's direction, and so the auxiliary point and the
    /// arc placed from it, into the intended ones.
    pub(super) fn approach_deviation(
        &self,
        f: &Frame,
        want: &[[f64; 6]; 3],
        written: &[[f64; 6]; 3],
        arc: Option<(bool, [f64; 2], [f64; 2])>,
    ) -> f64 {
        let leg = |k: usize, c: Option<(bool, [f64; 2])>, p: &[[f64; 6]; 3]| match c {
            Some((cw, c)) if k == 1 => Path::Arc {
                p0: p[1],
                p1: p[2],
                geo: ArcGeo::new((0, 1, 2), c, &p[1], &p[2], cw, 0),
            },
            _ => Path::Line {
                p0: p[k],
                p1: p[k + 1],
            },
        };
        let (a, b) = (arc.map(|(cw, c, _)| (cw, c)), arc.map(|(cw, _, c)| (cw, c)));
        let dev = |k: usize| self.path_deviation(f, &leg(k, a, want), &leg(k, b, written));
        dev(0).max(dev(1))
    }

    /// A HEIDENHAIN `DEP LT|LN LEN..` or `DEP CT CCA.. R..`: the control
    /// leaves the written last contour point `emit` along the direction
    /// `tangent` the written last element ends in (LT), square to it on
    /// the tool's side (LN), or on the arc tangent to it (CT). The
    /// block has no word to correct: where the path the control runs
    /// stays within the tolerance of the intended one (seventeen points
    /// along both: with the rotary axes fixed the correction is a rigid
    /// motion, which carries the direction, its square and the arc
    /// tangent to it into the intended ones) its end is returned, where the written program now
    /// has the tool; otherwise the reason to report it.
    pub(super) fn plan_departure(
        &self,
        f: &Frame,
        mv: &Move,
        emit: &[Option<f64>; 6],
        tangent: Option<[f64; 2]>,
        len: f64,
        leg: Leg,
    ) -> Result<[f64; 6], Reason> {
        let refuse = |kind, why: String| {
            Reason::new(
                kind,
                format!("approach or departure (APPR/DEP) left as written: {why}"),
            )
        };
        let Some(t) = tangent else {
            return Err(refuse(
                ReasonKind::NotImplemented,
                "the direction the written contour ends in is not known (the last element before it is left as written or not a line or circle in XY)".into(),
            ));
        };
        if f.axes().iter().any(|&a| emit[a].is_none()) {
            return Err(refuse(
                ReasonKind::Unsaid,
                "where the written program has the tool before it is not known".into(),
            ));
        }
        let w0 = known(emit);
        let pn = departure_end([w0[0], w0[1]], t, len, leg);
        let mut w1 = w0;
        w1[0] = pn[0];
        w1[1] = pn[1];
        let (p0, p1) = (known(&mv.start), known(&mv.end));
        // A DEP CT's move is its arc; the control's leaves the written
        // contour's end in the written direction.
        let (intended, written) = match (mv.kind, arc_center([w0[0], w0[1]], t, leg)) {
            (MoveKind::Arc(a), Some(c)) => (
                Path::Arc {
                    p0,
                    p1,
                    geo: ArcGeo::new((0, 1, 2), a.center, &p0, &p1, a.cw, 0),
                },
                Path::Arc {
                    p0: w0,
                    p1: w1,
                    geo: ArcGeo::new((0, 1, 2), c, &w0, &w1, a.cw, 0),
                },
            ),
            _ => (Path::Line { p0, p1 }, Path::Line { p0: w0, p1: w1 }),
        };
        let miss = self.path_deviation(f, &intended, &written);
        let tol = self.path_tolerance();
        if miss > tol {
            return Err(refuse(
                ReasonKind::NotImplemented,
                format!(
                    "the DEP {} the control runs from the corrected contour leaves the intended one by up to {:.2} um, {}",
                    leg.name(),
                    miss * 1e3,
                    self.beyond_tolerance()
                ),
            ));
        }
        Ok(w1)
    }

    /// How far the tip leaves the intended rounding or chamfer `c` where
    /// the controller cuts the corner of the written lines `a`-`p`-`b`
    /// (program frame: the last piece written before the corner, and the
    /// first after it), mm; the intended element is the one it cuts
    /// between the program's own lines, ending at `end`. With the rotary
    /// axes fixed the correction is a rigid motion, which carries a
    /// tangent arc of the same radius (a chamfer of the same side length)
    /// into the intended one; seventeen points along both compare them.
    pub(super) fn corner_deviation(
        &self,
        f: &Frame,
        c: &Corner,
        end: &[f64; 6],
        [a, p, b]: [&[f64; 6]; 3],
    ) -> Result<f64, &'static str> {
        let (_, _, intended) = corner_path(&c.from, &c.at, end, c.kind, f.u)?;
        let (_, _, written) = corner_path(a, p, b, c.kind, f.u)?;
        Ok(self.path_deviation(f, &intended, &written))
    }
}

/// Why an arc is left as written where the tool does not start on its
/// intended start: no arc or lines from there follow the intended path
/// within the tolerance.
const OFF_START: &str = "the arc starts where the move before it, left as written, leaves the tool: off its intended start by more than --tolerance, so neither an arc nor lines from there follow it";

/// A line after a move left as written: its end point is corrected (the
/// program is back on the intended path there), the stretch from where the
/// move before leaves the tool is not.
pub(super) const OFF_START_LINE: &str = "the line starts where the move before it, left as written, leaves the tool: off its intended start by more than --tolerance; its end point is corrected, the path to it is not within the tolerance";

/// Size of a correction: X, Y, Z (um, length of the vector) and the
/// change of tool orientation the rotary corrections make (urad; a C
/// correction counts with the sine of the tilt, since next to the
/// singular tilt turning C barely turns the tool).
pub(super) fn size(pt: &CorrectedPoint) -> (f64, f64) {
    let lin_um = (pt.written.xyz - pt.nominal.xyz).norm() * 1e3;
    let dt = (pt.written.tilt - pt.nominal.tilt).to_radians().abs();
    let dc = (pt.written.c - pt.nominal.c).to_radians().abs();
    // |dc sin t| cannot exceed dt when dc does not: skip the sine then.
    // |sin t| of the nominal tilt from the target's tool axis: every
    // nominal chain turns +Z by the tilt first (z component cos t).
    let dc = if dc <= dt {
        0.0
    } else {
        let uz = pt.target.axis.z / pt.target.axis.norm();
        dc * (1.0 - uz * uz).max(0.0).sqrt()
    };
    (lin_um, dt.max(dc) * 1e6)
}

/// Intervals of at most 5 deg each over a turn of `turn` deg, a multiple of
/// four (so the quarters are among the points).
fn every_5_deg(turn: f64) -> usize {
    4 * (turn / 20.0).ceil().min(1e5) as usize
}

/// Intervals a checked arc is cut into: sixteen, or one every 5 deg of
/// `turn` (deg) if more, so that whole turns of a rotary axis cannot bring
/// the tool back where it started at every point checked.
fn samples_along(turn: f64) -> usize {
    16.max(every_5_deg(turn))
}
