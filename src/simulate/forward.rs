//! The general forward model: for every plan point of any test on any
//! machine, the measurement the simulator would return (noise off, CMM
//! placement removed), as a function of every effect's parameters, with its
//! exact Jacobian. It implements [`ForwardModel`], so `analyze`'s global
//! method and `discover` invert it like the rigid-pose models, without their
//! restrictions.
//!
//! # Machining ([`MachiningForward`])
//! A plan point knows which moves cut it and with which part of the tool
//! ([`crate::procedure::machining::Provenance`]). For each generating move the actual tool
//! is taken at the generating instant through the same code path as the
//! simulator ([`super::cutting::Cutting`]: commanded axes, time, context,
//! `Model::pose_jacobian`): its tip, its axis, and the actual direction of
//! its path there (a chord of the actual path about the instant, within the
//! affine piece of the move, so that linear-axis errors act where the tool
//! really is during the cut, not at the nominal surface point). The surface
//! that move leaves along the point's nominal normal line is then exact:
//! - flank: the envelope of the cylinder is the plane through the axis line
//!   offset by the actual radius, with the normal perpendicular to the
//!   actual tool axis and the actual path direction;
//! - flat end: the disc's plane where the path keeps perpendicular to the
//!   axis, else the lower sheet of its swept rim (`Z = kX - |k| sqrt(R^2 -
//!   Y^2)` in the tool's frame, `k` the path's slope along the axis): a
//!   tilted end mill cuts with its edge;
//! - ball: the capsule around the path of the ball's centre;
//! - torus and sharp corner: the exact swept solid of the tool along the
//!   local path ([`crate::procedure::machining::Cutter::entry_along`]) with the derivative
//!   from the envelope theorem.
//!
//! The moves considered are the point's generators and the other passes of
//! its pose that come within 0.15 mm of it with the same part of the tool
//! (large errors slide a ball's raster sideways, and the neighbouring pass
//! then cuts deepest); the deepest gives the measured point
//! ([`MachiningForward::surfaces`] lists them all). All of this is exact
//! where the actual path is straight (every effect except drift per minute,
//! which bends it by second-order amounts), but for a bull-nose's flat end
//! under a slope `k` of the path along the axis, whose torus rounds the rim
//! by `r k^2` (4e-8 mm at 200 urad). The Jacobian is the exact derivative of
//! each move's surface (the path direction differentiated through the
//! chord; the envelope has kinks where two passes tie); `d_normal` is first
//! order (the tool's rotation) except on the flank, where it is exact.
//!
//! Other poses are not considered: the planner keeps every other pose's
//! tool 0.05 mm from each point, which errors below that cannot bridge (the
//! simulator, which sweeps every move, would see it).
//!
//! # Probing ([`ProbingForward`])
//! Each touch's ball runs along its commanded line; the contact with the
//! face (a plane through the piece's setup, six nuisance numbers per
//! column, um and urad, as `RigidPoseProbing`) or with the sphere (three
//! nuisance numbers, its centre's offset in um) is solved by Newton's
//! method on the exact ball centre, then pre-travel is added along the
//! line, and the point is what the log reader reports: the ball centre in
//! program coordinates minus the ball radius along the nominal normal.
//!
//! # Time
//! `predict` receives the minutes `analyze` assigns to the point's pose
//! (the middle of its manifest interval); the model moves the clock to the
//! instant of the cut or touch by the plan's own timeline, so drift per
//! minute acts when the tool really was there.

use std::collections::HashMap;
use std::sync::Arc;

use nalgebra::{DMatrix, DVector, Point3, Vector3};
use rayon::prelude::*;

use super::cutting::{Cutting, actual_cutter};
use super::machining::LINE_DEPTH;
use super::probing::Probing;
use crate::formats::points::PlanPoint;
use crate::identify::forward::{ForwardError, ForwardModel, Prediction, SETUP_NAMES, Wanted};
use crate::identify::rigid::d6_apply;
use crate::kinematics::Kinematics;
use crate::model::{Model, Params};
use crate::procedure::machining::{Cutter, PlannedPoint, ToolPart};
use crate::procedure::probing::ProbedGeometry;
use crate::procedure::{MachiningPlan, Plan, ProbingPlan};

/// The model of `errors` rebuilt on the kinematics a plan runs with (its
/// tool's or probe's gauge length), after checking the machine.
pub(crate) fn model_for(kin: Kinematics, model: &Model) -> Result<Model, ForwardError> {
    if kin.machine().name != model.kin.machine().name {
        return Err(ForwardError::Other(format!(
            "the errors are for machine `{}` but the plan runs on `{}`",
            model.kin.machine().name,
            kin.machine().name
        )));
    }
    Ok(Model::new(kin, model.effects.clone()))
}

/// The forward model of a loaded plan, of either kind.
pub fn for_plan(model: &Model, plan: &Plan) -> Result<Box<dyn ForwardModel>, ForwardError> {
    Ok(match plan {
        Plan::Machining(t) => Box::new(MachiningForward::new(model, Arc::new((**t).clone()))?),
        Plan::Probing(p) => Box::new(ProbingForward::new(model, Arc::new((**p).clone()))?),
    })
}

/// One generating move's prediction: offset along the nominal normal and
/// its derivative, the surface normal and its derivative (the wanted
/// columns only, in [`Wanted::columns`]' order).
struct Local {
    s: f64,
    ds: DVector<f64>,
    normal: Vector3<f64>,
    dnormal: DMatrix<f64>,
}

fn col(m: &DMatrix<f64>, j: usize) -> Vector3<f64> {
    Vector3::new(m[(0, j)], m[(1, j)], m[(2, j)])
}

fn set_col(m: &mut DMatrix<f64>, j: usize, v: &Vector3<f64>) {
    for r in 0..3 {
        m[(r, j)] = v[r];
    }
}

/// The general machining forward model (see the module documentation).
#[derive(Clone, Debug)]
pub struct MachiningForward {
    cut: Cutting,
    index: HashMap<String, usize>,
    radius_grad: Vec<f64>,
    /// Per plan point, the moves that may leave its surface.
    candidates: Vec<Vec<Candidate>>,
    /// Every parameter (what `predict` differentiates).
    all: Wanted,
    /// No parameter (a surface's offset alone).
    none: Wanted,
}

/// A move that may leave a point's surface: the point's generators, and
/// the moves of its pose that pass near it (a neighbouring raster pass cuts
/// deepest when the errors shift the raster sideways by half a stepover).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Candidate {
    mv: usize,
    /// The instant taken as the local origin of the move.
    t: f64,
    part: ToolPart,
    /// One of the point's generators (always valid) or a neighbour (valid
    /// only where its contact falls within the move).
    generator: bool,
}

/// Moves of a point's pose within this nominal distance of it are
/// candidates besides its generators, mm.
const CANDIDATE_REACH: f64 = 0.15;

fn candidates_of(cut: &Cutting, pp: &PlannedPoint) -> Vec<Candidate> {
    let plan = &cut.plan;
    let pose = pp.provenance.pose;
    let p = pp.point.p;
    let mut out: Vec<Candidate> = pp
        .provenance
        .generators
        .iter()
        .map(|g| Candidate {
            mv: g.move_index,
            t: g.t,
            part: pp.provenance.part,
            generator: true,
        })
        .collect();
    for (mi, mv) in plan.poses[pose].moves.iter().enumerate() {
        if mv.rapid || out.iter().any(|c| c.mv == mi) {
            continue;
        }
        let (a, b, u) = cut.nominal_segment(pose, mi);
        if !plan.cutter.may_reach(&a, &b, &u, &p, CANDIDATE_REACH) {
            continue;
        }
        let (d, t_min) = plan.cutter.swept_distance(&a, &b, &u, &p);
        if d > CANDIDATE_REACH {
            continue;
        }
        // Where the axis passes closest (the middle of a flat end's touch).
        let perp = |v: Vector3<f64>| v - u * u.dot(&v);
        let (pa, ba) = (perp(p - a), perp(b - a));
        let t = if ba.norm_squared() > 1e-18 {
            (pa.dot(&ba) / ba.norm_squared()).clamp(0.0, 1.0)
        } else {
            t_min
        };
        // A neighbouring pass cuts the same surface with the same part of
        // the tool; where it does not, its contact falls off the move or off
        // that part, and the candidate drops out.
        let part = pp.provenance.part;
        out.push(Candidate {
            mv: mi,
            t,
            part,
            generator: false,
        });
    }
    out
}

impl MachiningForward {
    /// The model of `model`'s effects on the plan's machine and tool.
    pub fn new(model: &Model, plan: Arc<MachiningPlan>) -> Result<MachiningForward, ForwardError> {
        let kin = Kinematics::with_gauge_length(&plan.machine, plan.tool.length);
        let model = model_for(kin, model)?;
        let index = plan
            .points
            .iter()
            .enumerate()
            .map(|(i, p)| (p.point.label.clone(), i))
            .collect();
        let cut = Cutting::new(model, plan);
        let radius_grad = cut.radius_gradient();
        let candidates = cut
            .plan
            .points
            .par_iter()
            .map(|pp| candidates_of(&cut, pp))
            .collect();
        let all = Wanted::new(&cut.model, |_| true);
        let none = Wanted::new(&cut.model, |_| false);
        Ok(MachiningForward {
            cut,
            index,
            radius_grad,
            candidates,
            all,
            none,
        })
    }

    /// The plan.
    pub fn plan(&self) -> &MachiningPlan {
        &self.cut.plan
    }

    /// The minutes `analyze` gives the pose of a plan point (the middle of
    /// its manifest interval).
    pub fn minutes(&self, label: &str) -> Option<f64> {
        let i = *self.index.get(label)?;
        Some(
            self.cut
                .timeline
                .mid(self.cut.plan.points[i].provenance.pose),
        )
    }

    fn local(
        &self,
        at: &AtTheta,
        pp: &PlannedPoint,
        g: &Candidate,
        offset: f64,
        wanted: &Wanted,
    ) -> Result<Option<Local>, ForwardError> {
        let cut = &self.cut;
        let model = &cut.model;
        let label = &pp.point.label;
        let pose = pp.provenance.pose;
        let mv = g.mv;
        // Without derivatives (an offset only), the poses alone, the same
        // bits as the Jacobians'.
        let (dr, at) = (at.dr, &at.params);
        let derivatives = !wanted.columns().is_empty();
        let none = || DMatrix::zeros(3, 0);
        // The tool at the generating instant.
        let ctx = cut.context(pose, mv, g.t, offset);
        let (at_g, jt, ja) = if derivatives {
            let (pj, jt, ja) = model.pose_jacobian_at(at, &ctx, wanted);
            (pj.pose, jt, ja)
        } else {
            (model.jacobian_pose_at(at, &ctx), none(), none())
        };
        // The actual path direction: a chord about the instant within the
        // affine piece (exact on a straight piece, second-order on a bent one).
        let (lo, hi) = cut.piece(pose, mv, g.t);
        let (na, nb, _) = cut.nominal_segment(pose, mv);
        let len = (nb - na).norm().max(1e-9);
        let h = (0.5_f64).min(1.0 / len);
        let (t1, t2) = ((g.t - h).max(lo), (g.t + h).min(hi));
        if t2 - t1 < 1e-12 {
            return Err(ForwardError::Other(format!(
                "{label}: its generating move {} has no length",
                mv + 1
            )));
        }
        let (ctx1, ctx2) = (
            cut.context(pose, mv, t1, offset),
            cut.context(pose, mv, t2, offset),
        );
        let (p1, p2, dv) = if derivatives {
            let (p1, j1) = model.tip_jacobian_at(at, &ctx1, wanted);
            let (p2, j2) = model.tip_jacobian_at(at, &ctx2, wanted);
            let dv = (j2 - j1) / (t2 - t1);
            (p1.pose, p2.pose, dv)
        } else {
            let p1 = model.jacobian_pose_at(at, &ctx1);
            (p1, model.jacobian_pose_at(at, &ctx2), none())
        };
        let nominal = &cut.plan.cutter;
        let at = Instant {
            label,
            p: pp.point.p,
            n: pp.point.n,
            g,
            cols: wanted.columns(),
            tip: at_g.tip,
            u: at_g.axis,
            v: (p2.tip - p1.tip) / (t2 - t1),
            dv,
            jt,
            ja,
            lo,
            hi,
            nominal,
            dr,
            ra: nominal.radius + dr,
            ra_grad: &self.radius_grad,
        };
        match g.part {
            ToolPart::Flank => at.flank(),
            ToolPart::FlatEnd => at.flat_end(),
            ToolPart::Ball => at.ball(),
            ToolPart::Torus | ToolPart::Corner => at.torus(),
        }
    }
}

/// The parameters of a prediction, and what they make of the tool radius
/// (the same at every pose).
struct AtTheta<'a> {
    params: Params<'a>,
    dr: f64,
}

/// The tool at a point's generating instant (or a neighbour's), with the
/// derivatives with respect to the parameters that the intersection of the
/// point's normal line with the swept tool needs.
struct Instant<'a> {
    label: &'a String,
    /// The nominal point and its normal.
    p: Vector3<f64>,
    n: Vector3<f64>,
    g: &'a Candidate,
    /// The parameters whose derivatives are wanted: column `k` of every
    /// Jacobian here is parameter `cols[k]`'s.
    cols: &'a [usize],
    /// Tool tip and axis, and their Jacobians.
    tip: Vector3<f64>,
    u: Vector3<f64>,
    jt: DMatrix<f64>,
    ja: DMatrix<f64>,
    /// Tip velocity along the move and its Jacobian.
    v: Vector3<f64>,
    dv: DMatrix<f64>,
    /// The affine piece of the move around the instant.
    lo: f64,
    hi: f64,
    nominal: &'a Cutter,
    /// Radius error, actual radius and its gradient.
    dr: f64,
    ra: f64,
    ra_grad: &'a [f64],
}

impl Instant<'_> {
    /// The Jacobian of a normal turned with the tool axis.
    fn rot_normal(&self, normal: &Vector3<f64>) -> DMatrix<f64> {
        let mut d = DMatrix::zeros(3, self.cols.len());
        for k in 0..self.cols.len() {
            let w = self.u.cross(&col(&self.ja, k));
            set_col(&mut d, k, &w.cross(normal));
        }
        d
    }

    /// A contact whose normal turns with the tool axis.
    fn contact(&self, s: f64, ds: DVector<f64>, normal: Vector3<f64>) -> Option<Local> {
        Some(Local {
            s,
            ds,
            normal,
            dnormal: self.rot_normal(&normal),
        })
    }

    /// Whether a contact `tau` from the instant counts: a neighbour counts
    /// only where its contact instant lies on the move.
    fn on_move(&self, tau: f64) -> bool {
        let g = self.g;
        g.generator || (g.t + tau >= -1e-9 && g.t + tau <= 1.0 + 1e-9)
    }

    /// No intersection: an error for a generator, nothing for a neighbour.
    fn miss(&self, e: ForwardError) -> Result<Option<Local>, ForwardError> {
        if self.g.generator { Err(e) } else { Ok(None) }
    }

    /// The flank: the cylinder swept along the path.
    fn flank(&self) -> Result<Option<Local>, ForwardError> {
        let Instant {
            label,
            p,
            n,
            tip,
            u,
            v,
            ra,
            ra_grad,
            ..
        } = *self;
        let (jt, ja, dv) = (&self.jt, &self.ja, &self.dv);
        let vv = v.norm_squared();
        let w = u.cross(&v);
        let wn = w.norm();
        if wn < 1e-9 {
            return self.miss(ForwardError::Other(format!(
                "{label}: the tool moves along its own axis where its flank cuts"
            )));
        }
        let sign = if w.dot(&n) < 0.0 { -1.0 } else { 1.0 };
        let m = w * (sign / wn);
        let mn = m.dot(&n);
        if mn.abs() < 1e-6 {
            return self.miss(ForwardError::NoIntersection(label.clone()));
        }
        let s = (m.dot(&(tip - p)) - ra) / mn;
        if !self.on_move((p + n * s - tip).dot(&v) / vv) {
            return Ok(None);
        }
        let mut ds = DVector::zeros(self.cols.len());
        let mut dm = DMatrix::zeros(3, self.cols.len());
        for (k, &j) in self.cols.iter().enumerate() {
            let dw = (col(ja, k).cross(&v) + u.cross(&col(dv, k))) * sign;
            let dmj = (dw - m * m.dot(&dw)) / wn;
            set_col(&mut dm, k, &dmj);
            ds[k] = (dmj.dot(&(tip - p)) + m.dot(&col(jt, k)) - ra_grad[j] - s * dmj.dot(&n)) / mn;
        }
        Ok(Some(Local {
            s,
            ds,
            normal: m,
            dnormal: dm,
        }))
    }

    /// The flat end: the disc (with its edge) swept along the path.
    fn flat_end(&self) -> Result<Option<Local>, ForwardError> {
        let Instant {
            label,
            p,
            n,
            g,
            tip,
            u,
            v,
            ra,
            ra_grad,
            nominal,
            ..
        } = *self;
        let (jt, ja, dv) = (&self.jt, &self.ja, &self.dv);
        let beta = v.dot(&u);
        let vp = v - u * beta;
        let alpha = vp.norm();
        if alpha < 1e-9 {
            return self.miss(ForwardError::Other(format!(
                "{label}: the tool plunges along its axis where its end cuts"
            )));
        }
        let ev = vp / alpha;
        let ew = u.cross(&ev);
        let k = beta / alpha;
        // Below 1e-12 the edge term is under 1e-11 mm: the disc's plane.
        let (ak, sk) = if k.abs() < 1e-12 {
            (0.0, 0.0)
        } else {
            (k.abs(), k.signum())
        };
        // The flat part of the end: the whole end of a flat end mill,
        // the core of a bull-nose (its torus rounds the rim, which
        // lowers the edge by r (1 - cos) of the path's slope: below
        // 1e-7 mm for slopes under 1e-3).
        let rf = ra - nominal.corner;
        let parts = |s: f64| {
            let x = p + n * s - tip;
            let y = ew.dot(&x);
            let sq = (rf * rf - y * y).max(0.0).sqrt();
            (x, ev.dot(&x), y, u.dot(&x), sq)
        };
        let f = |s: f64| {
            let (_, xx, _, zz, sq) = parts(s);
            zz - k * xx + ak * sq
        };
        let fp = |s: f64| {
            let (_, _, y, _, sq) = parts(s);
            let edge = if sq > 1e-12 {
                ak * y * ew.dot(&n) / sq
            } else {
                0.0
            };
            u.dot(&n) - k * ev.dot(&n) - edge
        };
        let mut s = 0.0;
        for _ in 0..60 {
            let d = f(s) / fp(s);
            s -= d;
            if d.abs() < 1e-15 {
                break;
            }
        }
        let (x, xx, y, _, sq) = parts(s);
        if !g.generator {
            // Under the disc, and cut while the tool was on the move.
            if y.abs() > rf {
                return Ok(None);
            }
            let (t_lo, t_hi) = if ak == 0.0 {
                ((xx - sq) / alpha, (xx + sq) / alpha)
            } else {
                let tau = (xx - sk * sq) / alpha;
                (tau, tau)
            };
            if g.t + t_hi < -1e-9 || g.t + t_lo > 1.0 + 1e-9 {
                return Ok(None);
            }
        }
        let fps = fp(s);
        let mut ds = DVector::zeros(self.cols.len());
        for (c, &j) in self.cols.iter().enumerate() {
            let (dtip, du, dvj) = (col(jt, c), col(ja, c), col(dv, c));
            let dbeta = dvj.dot(&u) + v.dot(&du);
            let dvp = dvj - u * dbeta - du * beta;
            let dalpha = ev.dot(&dvp);
            let dev = (dvp - ev * ev.dot(&dvp)) / alpha;
            let dew = du.cross(&ev) + u.cross(&dev);
            let dk = (dbeta - k * dalpha) / alpha;
            let dx = -dtip;
            let mut df =
                du.dot(&x) + u.dot(&dx) - dk * xx - k * (dev.dot(&x) + ev.dot(&dx)) + sk * dk * sq;
            if sq > 1e-12 {
                df += ak * (rf * ra_grad[j] - y * (dew.dot(&x) + ew.dot(&dx))) / sq;
            }
            ds[c] = -df / fps;
        }
        let edge = if sq > 1e-12 { ak * y / sq } else { 0.0 };
        let normal = (u - ev * k - ew * edge).normalize();
        Ok(self.contact(s, ds, normal))
    }

    /// The ball end: the sphere swept along the path.
    fn ball(&self) -> Result<Option<Local>, ForwardError> {
        let Instant {
            label,
            p,
            n,
            tip,
            u,
            v,
            ra,
            ra_grad,
            ..
        } = *self;
        let (jt, ja, dv) = (&self.jt, &self.ja, &self.dv);
        let vv = v.norm_squared();
        let c = tip + u * ra;
        let vn = v.norm();
        let vh = v / vn;
        let perp = |x: &Vector3<f64>| x - vh * vh.dot(x);
        let a = perp(&n);
        let b = perp(&(p - c));
        let (aa, ab, bb) = (a.dot(&a), a.dot(&b), b.dot(&b) - ra * ra);
        let disc = ab * ab - aa * bb;
        if aa < 1e-12 || disc < 0.0 {
            return self.miss(ForwardError::NoIntersection(label.clone()));
        }
        let s = (-ab - disc.sqrt()) / aa;
        let w = p + n * s - c;
        if !self.on_move(w.dot(&v) / vv) {
            return Ok(None);
        }
        let wp = perp(&w);
        let dgs = 2.0 * wp.dot(&n);
        let mut ds = DVector::zeros(self.cols.len());
        for (k, &j) in self.cols.iter().enumerate() {
            let dc = col(jt, k) + u * ra_grad[j] + col(ja, k) * ra;
            let dvh = (col(dv, k) - vh * vh.dot(&col(dv, k))) / vn;
            let dg = 2.0 * (-wp.dot(&dc) - vh.dot(&w) * wp.dot(&dvh)) - 2.0 * ra * ra_grad[j];
            ds[k] = -dg / dgs;
        }
        let normal = wp.normalize();
        Ok(self.contact(s, ds, normal))
    }

    /// The torus (or corner) of a bull-nose: the actual cutter swept along
    /// the piece of the path, its signed distance differentiated.
    fn torus(&self) -> Result<Option<Local>, ForwardError> {
        let Instant {
            label,
            p,
            n,
            g,
            tip,
            u,
            v,
            lo,
            hi,
            nominal,
            dr,
            ra_grad,
            ..
        } = *self;
        let (jt, ja, dv) = (&self.jt, &self.ja, &self.dv);
        let cutter = actual_cutter(nominal, dr);
        let vn = v.norm();
        let w = (cutter.radius + 2.0) / vn;
        let (tl, th) = ((lo - g.t).max(-w), (hi - g.t).min(w));
        let a = tip + v * tl;
        let b = tip + v * th;
        let q0 = p - n * LINE_DEPTH;
        let Some(e) = cutter.entry_along(&a, &b, &u, &q0, &n, 0.0, 2.0 * LINE_DEPTH) else {
            return self.miss(ForwardError::NoIntersection(label.clone()));
        };
        let s = e - LINE_DEPTH;
        let x = q0 + n * e;
        let (_, tt) = cutter.swept_distance(&a, &b, &u, &x);
        let tau = tl + tt * (th - tl);
        let tc = tip + v * tau;
        let (gq, gu, gr) = sd_gradient(&cutter, &tc, &u, &x);
        let den = gq.dot(&n);
        if den.abs() < 1e-9 {
            return self.miss(ForwardError::NoIntersection(label.clone()));
        }
        let mut ds = DVector::zeros(self.cols.len());
        for (k, &j) in self.cols.iter().enumerate() {
            let dtip = col(jt, k) + col(dv, k) * tau;
            let dsd = -gq.dot(&dtip) + gu.dot(&col(ja, k)) + gr * ra_grad[j];
            ds[k] = -dsd / den;
        }
        let normal = -gq;
        Ok(self.contact(s, ds, normal))
    }
}

/// The gradient of [`Cutter::signed_distance`] at `q` with respect to `q`,
/// to the axis, and to the outer radius (corner fixed).
fn sd_gradient(
    c: &Cutter,
    tip: &Vector3<f64>,
    axis: &Vector3<f64>,
    q: &Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>, f64) {
    let d = q - tip;
    let zeta = d.dot(axis);
    let wv = d - axis * zeta;
    let rho = wv.norm();
    let er = if rho > 1e-15 {
        wv / rho
    } else {
        crate::geom::tangent_basis(axis).0
    };
    let r = c.corner;
    let core = c.radius - r;
    let cz = 0.5 * (r + c.length);
    let hz = 0.5 * (c.length - r);
    let dx = rho - core;
    let sz = if zeta >= cz { 1.0 } else { -1.0 };
    let dz = (zeta - cz).abs() - hz;
    let (g_rho, g_zeta) = if dx > 0.0 && dz > 0.0 {
        let o = dx.hypot(dz);
        (dx / o, dz * sz / o)
    } else if dx > 0.0 {
        (1.0, 0.0)
    } else if dz > 0.0 {
        (0.0, sz)
    } else if dx > dz {
        (1.0, 0.0)
    } else {
        (0.0, sz)
    };
    let gq = er * g_rho + axis * g_zeta;
    let gu = d * g_zeta - er * (g_rho * zeta);
    (gq, gu, -g_rho)
}

impl ForwardModel for MachiningForward {
    fn model(&self) -> &Model {
        &self.cut.model
    }

    fn predict(
        &self,
        theta: &[f64],
        nuisance: &[f64],
        point: &PlanPoint,
        minutes: f64,
    ) -> Result<Prediction, ForwardError> {
        self.predict_wanted(theta, nuisance, point, minutes, &self.all)
    }

    fn predict_wanted(
        &self,
        theta: &[f64],
        _nuisance: &[f64],
        point: &PlanPoint,
        minutes: f64,
        wanted: &Wanted,
    ) -> Result<Prediction, ForwardError> {
        // The deepest surface is the one measured (the first of equals):
        // each move's offset first, then the derivatives of that move's
        // surface alone (the same bits as differentiating every move's).
        let (i, offset) = self.point_of(point, minutes)?;
        let pp = &self.cut.plan.points[i];
        let at = self.at(theta);
        let mut deepest: Option<(&Candidate, Local)> = None;
        for g in &self.candidates[i] {
            if let Some(l) = self.local(&at, pp, g, offset, &self.none)?
                && deepest
                    .as_ref()
                    .is_none_or(|(_, d)| l.s.total_cmp(&d.s).is_lt())
            {
                deepest = Some((g, l));
            }
        }
        let Some((g, l)) = deepest else {
            return Err(ForwardError::NoIntersection(point.label.clone()));
        };
        let l = if wanted.columns().is_empty() {
            l
        } else {
            self.local(&at, pp, g, offset, wanted)?
                .ok_or_else(|| ForwardError::NoIntersection(point.label.clone()))?
        };
        Ok(self.surface(pp, l, wanted).prediction)
    }
}

/// What one move leaves at a plan point: the offset of its surface along
/// the nominal normal (mm, negative: deeper) and the prediction if it were
/// the deepest.
#[derive(Clone, Debug, PartialEq)]
pub struct MoveSurface {
    /// Offset along the nominal normal, mm.
    pub offset: f64,
    /// The measured point, normal and derivatives if this move made it.
    pub prediction: Prediction,
}

impl MachiningForward {
    /// The surface each move that may cut `point` leaves along its nominal
    /// normal line, by move index (in the point's pose): its generators and
    /// the neighbouring passes whose contact falls on the move. The
    /// measured point is the deepest ([`ForwardModel::predict`]); each is a
    /// smooth function of the parameters, the envelope has a kink where two
    /// of them tie.
    pub fn surfaces(
        &self,
        theta: &[f64],
        point: &PlanPoint,
        minutes: f64,
    ) -> Result<Vec<(usize, MoveSurface)>, ForwardError> {
        self.surfaces_wanted(theta, point, minutes, &self.all)
    }

    /// [`MachiningForward::surfaces`] differentiated by `wanted`'s
    /// parameters only (see [`ForwardModel::predict_wanted`]).
    fn surfaces_wanted(
        &self,
        theta: &[f64],
        point: &PlanPoint,
        minutes: f64,
        wanted: &Wanted,
    ) -> Result<Vec<(usize, MoveSurface)>, ForwardError> {
        let (i, offset) = self.point_of(point, minutes)?;
        let pp = &self.cut.plan.points[i];
        let at = self.at(theta);
        let mut out = Vec::new();
        for g in &self.candidates[i] {
            let Some(l) = self.local(&at, pp, g, offset, wanted)? else {
                continue;
            };
            out.push((g.mv, self.surface(pp, l, wanted)));
        }
        Ok(out)
    }

    fn at<'a>(&self, theta: &'a [f64]) -> AtTheta<'a> {
        AtTheta {
            params: self.cut.model.params(theta),
            dr: self.cut.radius_error(theta),
        }
    }

    /// The index of `point` in the plan, and the time from its pose's
    /// middle to `minutes`.
    fn point_of(&self, point: &PlanPoint, minutes: f64) -> Result<(usize, f64), ForwardError> {
        let i = *self.index.get(&point.label).ok_or_else(|| {
            ForwardError::Other(format!("`{}` is not a point of the plan", point.label))
        })?;
        let pose = self.cut.plan.points[i].provenance.pose;
        Ok((i, minutes - self.cut.timeline.mid(pose)))
    }

    /// The surface a move leaves at a point, from its local contact.
    fn surface(&self, pp: &PlannedPoint, l: Local, wanted: &Wanted) -> MoveSurface {
        let n = pp.point.n;
        let np = self.cut.model.n_params();
        // The other columns are zero.
        let (mut d_point, mut d_normal) = (DMatrix::zeros(3, np), DMatrix::zeros(3, np));
        for (k, &j) in wanted.columns().iter().enumerate() {
            set_col(&mut d_point, j, &(n * l.ds[k]));
            set_col(&mut d_normal, j, &col(&l.dnormal, k));
        }
        MoveSurface {
            offset: l.s,
            prediction: Prediction {
                point: pp.point.p + n * l.s,
                normal: l.normal,
                d_point,
                d_normal,
            },
        }
    }
}

/// Newton's method for the root of `g` along a touch's line from `tau`
/// (`slope`: g's derivative), 30 steps at most or until a step is below
/// 1e-14 mm; the root and the slope there, `None` where the slope vanishes.
///
/// Near the root `g` is round-off (a ball centre hundreds of millimetres
/// from the origin carries 1e-13 mm), and the steps often settle into a
/// two-cycle of one unit in the last place that never drops below the
/// tolerance. The iteration being a function of `tau` alone, a cycle
/// repeats to the last step: it is not run out, but the point it would end
/// on is taken, so the result is bit for bit that of the 30 steps (the
/// sphere method's judge is sensitive to the last bits of the nominal
/// predictions). The slopes already taken are reused for the same reason.
fn contact_search(
    mut tau: f64,
    slope: impl Fn(f64) -> f64,
    g: impl Fn(f64) -> f64,
) -> Option<(f64, f64)> {
    const STEPS: usize = 30;
    // The last two points and their slopes, the newest last.
    let mut seen = [(f64::NAN, f64::NAN); 2];
    for k in 1..=STEPS {
        let gp = slope(tau);
        if gp.abs() < 1e-9 {
            return None;
        }
        let d = g(tau) / gp;
        let next = tau - d;
        seen = [seen[1], (tau, gp)];
        if d.abs() < 1e-14 {
            tau = next;
            break;
        }
        if next == seen[0].0 {
            // next = tau_{k-2}: the points alternate from here; after
            // STEPS steps the iteration stands where parity puts it.
            if !(STEPS - k).is_multiple_of(2) {
                tau = seen[1].0;
            } else {
                tau = next;
            }
            break;
        }
        tau = next;
    }
    let gp = match seen.iter().find(|(t, _)| *t == tau) {
        Some(&(_, gp)) => gp,
        None => slope(tau),
    };
    Some((tau, gp))
}

/// The general probing forward model (see the module documentation).
#[derive(Clone, Debug)]
pub struct ProbingForward {
    probing: Probing,
    index: HashMap<String, usize>,
    /// Start of each piece's nuisance block, and the total.
    offsets: Vec<usize>,
}

impl ProbingForward {
    /// The model of `model`'s effects on the plan's machine and probe.
    pub fn new(model: &Model, plan: Arc<ProbingPlan>) -> Result<ProbingForward, ForwardError> {
        let model = model_for(plan.plan.kin.clone(), model)?;
        let index = plan
            .plan
            .touches
            .iter()
            .enumerate()
            .map(|(i, t)| (t.label.clone(), i))
            .collect();
        let probing = Probing::new(model, plan);
        let size = probing.nuisance_size();
        let mut offsets = vec![0];
        for _ in &probing.pieces {
            offsets.push(offsets.last().unwrap() + size);
        }
        Ok(ProbingForward {
            probing,
            index,
            offsets,
        })
    }

    /// The plan.
    pub fn plan(&self) -> &ProbingPlan {
        &self.probing.plan
    }

    /// The minutes `analyze` gives the pose of a touch (the middle of its
    /// manifest interval).
    pub fn minutes(&self, label: &str) -> Option<f64> {
        Some(self.probing.pose_mid(*self.index.get(label)?))
    }

    /// The unit direction the probe travels on the touch of `label`: the
    /// line its measured point moves along when anything moves the surface
    /// or the probe, in the frame of the predicted point.
    pub(crate) fn line_direction(&self, label: &str) -> Option<Vector3<f64>> {
        Some(self.probing.line(*self.index.get(label)?).1)
    }

    /// The nuisance vector of the pieces' actual setups (W nominal to W
    /// actual, one per piece as [`super::SimOutput::setups`] gives them).
    pub fn nuisance_of(&self, setups: &[nalgebra::Isometry3<f64>]) -> Vec<f64> {
        match &self.probing.plan.setup {
            ProbedGeometry::Columns(_) => setups
                .iter()
                .flat_map(crate::identify::rigid::d6_inverse_um)
                .collect(),
            ProbedGeometry::Sphere(s) => setups
                .iter()
                .flat_map(|iso| {
                    let d = (iso * Point3::from(s.centre)).coords - s.centre;
                    [d.x * 1e3, d.y * 1e3, d.z * 1e3]
                })
                .collect(),
        }
    }
}

impl Probing {
    fn nuisance_size(&self) -> usize {
        match self.plan.setup {
            ProbedGeometry::Columns(_) => 6,
            ProbedGeometry::Sphere(_) => 3,
        }
    }
}

impl ForwardModel for ProbingForward {
    fn model(&self) -> &Model {
        &self.probing.model
    }

    fn nuisance_names(&self) -> Vec<String> {
        let pr = &self.probing;
        crate::identify::forward::setup_names(&SETUP_NAMES[..pr.nuisance_size()], &pr.pieces)
    }

    fn predict(
        &self,
        theta: &[f64],
        nuisance: &[f64],
        point: &PlanPoint,
        minutes: f64,
    ) -> Result<Prediction, ForwardError> {
        let pr = &self.probing;
        let i = *self.index.get(&point.label).ok_or_else(|| {
            ForwardError::Other(format!("`{}` is not a touch of the plan", point.label))
        })?;
        let touch = &pr.plan.plan.touches[i];
        let np = theta.len();
        let total = np + *self.offsets.last().unwrap();
        let piece = pr.piece_of[i];
        let o = self.offsets[piece];
        let size = pr.nuisance_size();
        let nu = &nuisance[o..o + size];
        let offset = minutes - pr.pose_mid(i);
        let r = pr.plan.plan.probe.ball_radius;
        let (_, dir, _) = pr.line(i);
        // The actual surface: a face plane (point, normal and their
        // derivatives in the nuisance), or the sphere's centre.
        // One value on the stack per prediction: size does not matter.
        #[allow(clippy::large_enum_variant)]
        enum Surf {
            Plane {
                y: Vector3<f64>,
                dy: nalgebra::Matrix3x6<f64>,
                m: Vector3<f64>,
                dm: nalgebra::Matrix3x6<f64>,
            },
            Sphere {
                centre: Vector3<f64>,
                radius: f64,
            },
        }
        let surf = match &pr.plan.setup {
            ProbedGeometry::Columns(_) => {
                let (y, dy) = d6_apply(nu, &touch.contact_w);
                let (y2, dy2) = d6_apply(nu, &(touch.contact_w + touch.normal_w));
                Surf::Plane {
                    y,
                    dy,
                    m: y2 - y,
                    dm: dy2 - dy,
                }
            }
            ProbedGeometry::Sphere(s) => Surf::Sphere {
                centre: s.centre + Vector3::new(nu[0], nu[1], nu[2]) * 1e-3,
                radius: s.diameter / 2.0,
            },
        };
        let g = |c: &Vector3<f64>| match &surf {
            Surf::Plane { y, m, .. } => m.dot(&(c - y)) - r,
            Surf::Sphere { centre, radius } => (c - centre).norm() - radius - r,
        };
        let h = 1e-3;
        let line = pr.ball_line(theta, i, offset);
        let ball = |tau: f64| line.ball(tau);
        let slope = |tau: f64| {
            let c1 = ball(tau - h);
            let c2 = ball(tau + h);
            (g(&c2) - g(&c1)) / (2.0 * h)
        };
        let (tau, gp) = contact_search(pr.nominal_tau(i), slope, |tau| g(&ball(tau)))
            .ok_or_else(|| ForwardError::NoIntersection(point.label.clone()))?;
        let ctx = line.context(tau);
        let (pj, jt, _) = pr.model.pose_jacobian_with(&line.perturbation(&ctx), &ctx);
        let c = pj.pose.tip;
        let mut dg = DVector::zeros(total);
        let normal_w;
        let mut dnormal_w = DMatrix::zeros(3, total);
        match &surf {
            Surf::Plane { y, dy, m, dm } => {
                for j in 0..np {
                    dg[j] = m.dot(&col(&jt, j));
                }
                for k in 0..6 {
                    let dmk = dm.column(k).into_owned();
                    dg[np + o + k] = dmk.dot(&(c - y)) - m.dot(&dy.column(k).into_owned());
                    set_col(&mut dnormal_w, np + o + k, &dmk);
                }
                normal_w = *m;
            }
            Surf::Sphere { centre, .. } => {
                let e = (c - centre).normalize();
                for j in 0..np {
                    dg[j] = e.dot(&col(&jt, j));
                }
                for k in 0..3 {
                    dg[np + o + k] = -e[k] * 1e-3;
                }
                normal_w = e;
            }
        }
        let (pt, dpt) = pr.pretravel(theta, i);
        let tau_t = tau + pt;
        let frame = pr.frame(i);
        let reported = pr.reported(i, &pr.recorded(i, tau_t));
        let mut d_point = DMatrix::zeros(3, total);
        for j in 0..total {
            let mut dt = -dg[j] / gp;
            if j < np {
                dt += dpt[j];
            }
            set_col(&mut d_point, j, &(dir * dt));
        }
        // Only the plane's own columns turn the normal; a rotated zero
        // column is +0 to the bit (the quaternion adds the column last), so
        // the others stay as they start.
        let mut d_normal = DMatrix::zeros(3, total);
        if let Surf::Plane { .. } = surf {
            for j in np + o..np + o + 6 {
                set_col(&mut d_normal, j, &frame.dir_to_prog(&col(&dnormal_w, j)));
            }
        }
        Ok(Prediction {
            point: reported,
            normal: frame.dir_to_prog(&normal_w),
            d_point,
            d_normal,
        })
    }
}
