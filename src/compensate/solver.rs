//! Axis values that put the actual tool where the nominal program meant it,
//! on the machine with the identified errors.
//!
//! Location errors, a tool-length error and linear-axis errors (scale,
//! squareness, straightness, positioning) leave the rotary link transforms
//! constant, so
//! the closed form of [`FastChain`] is exact; linear-axis errors that
//! depend on X, Y, Z are folded in by a short fixed-point iteration on the
//! position alone (the orientation does not depend on them). Error maps over
//! the rotary angles, and the linear axes' angular error motions (which turn
//! the tool axis with X, Y, Z), go through the model's own inverse.
//!
//! Next to the tilt singularity (tool axis along C) the exact solution
//! nearest the nominal axes may need C to turn a long way for a few urad of
//! orientation, or may not exist (`IkError::OutOfReach`). The policy: when
//! the exact solution would move C by more than `max_c_swing` from its
//! nominal value, or there is none, C is held at its nominal value, the
//! tilt is the one that brings the tool axis closest to the target, and X,
//! Y, Z put the tool tip exactly on target. The tip is then exact; the
//! remaining tool-axis error is at most the orientation error of the
//! machine there, and it is reported. The rewriter also holds C when the
//! exact solution's swing would push the correction past its limit while
//! the held one stays inside. Along a move written in pieces, the pieces do
//! not switch between held and exact solutions, which would jump: where an
//! end is held, or where the move passes the singularity between exact ends
//! and exact pieces cannot follow the path, C's correction ramps from the
//! start's to the end's, with the tilt and the tip as when held. At the
//! other end of the tilt's range, where a program runs the tilt to its
//! limit and the correction needs a few urad beyond it, the tilt is held at
//! the limit with the tip exact.

use nalgebra::Vector3;

use crate::kinematics::fast::FastChain;
use crate::kinematics::{Axes, IkError, Kinematics, SLOT_LIN, ToolPose};
use crate::model::{Context, Effect, Model};

/// How far beyond its limit (deg) a tilt may be needed and still be held
/// at the limit: more than an error model's few hundred urad means a
/// program that leaves the tilt's range, not a correction.
pub(crate) const TILT_OVERRUN: f64 = 0.1;

/// How the actual machine is evaluated (one per solver: the size
/// difference between the variants does not matter).
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
enum Actual {
    /// Constant link errors (closed form), optionally with linear-axis
    /// errors that depend on X, Y, Z.
    Fast {
        chain: FastChain,
        lin: Option<(Model, Vec<f64>)>,
    },
    /// Errors that depend on the rotary angles: the model itself.
    Exact { model: Model, theta: Vec<f64> },
}

/// A corrected configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Solution {
    /// Axis values on the erroneous machine.
    pub axes: Axes,
    /// C was held at its nominal value (singularity policy): the remaining
    /// angle between actual and target tool axis, rad.
    pub held_c: Option<f64>,
    /// The tilt was held at its limit (the exact correction lies a little
    /// beyond it): the remaining angle between actual and target tool
    /// axis, rad.
    pub held_tilt: Option<f64>,
}

/// Nominal and actual kinematics of one machine with one error model.
#[derive(Clone, Debug)]
pub struct Solver {
    kin: Kinematics,
    nominal: FastChain,
    actual: Actual,
    max_c_swing: f64,
    /// Sum of the angular link errors, rad (fast path).
    eps: f64,
    /// Sum of the translational errors, mm (fast path).
    offsets: f64,
    /// Lever of the head (pivot plus tool length), mm.
    lever: f64,
}

impl Solver {
    /// The solver for `model` with parameters `theta` (file units). Thermal
    /// drift is evaluated at its start (sequence 0, minute 0).
    pub fn new(model: &Model, theta: &[f64], max_c_swing_deg: f64) -> Solver {
        let kin = model.kin.clone();
        let nominal = FastChain::nominal(&kin);
        // The linear axes' angular error motions turn the tool axis with
        // X, Y and Z: the orientation no longer follows from the rotary
        // axes alone, so they go through the model's own inverse, as the
        // maps over the rotary angles do.
        let maps = model
            .effects
            .iter()
            .any(|e| matches!(e, Effect::Map { .. } | Effect::Angular { .. }));
        let lin_varies = model.effects.iter().any(Effect::is_linear_axis_error);
        let p0 = model.perturbation(theta, &Context::default());
        let eps: f64 = (0..3)
            .flat_map(|l| (3..6).map(move |k| l * 6 + k))
            .map(|i| p0.0[i].abs())
            .sum();
        let offsets: f64 = (0..3)
            .flat_map(|l| (0..3).map(move |k| l * 6 + k))
            .map(|i| p0.0[i].abs())
            .sum::<f64>()
            + p0.linear().norm()
            + p0.0[crate::kinematics::SLOT_TOOL_LENGTH].abs();
        let m = kin.machine();
        let lever = m.pivot_length + kin.gauge_length();
        let actual = if maps {
            Actual::Exact {
                model: model.clone(),
                theta: theta.to_vec(),
            }
        } else {
            let p = model.perturbation(theta, &Context::default());
            Actual::Fast {
                chain: FastChain::new(&kin, &p),
                lin: lin_varies.then(|| (model.clone(), theta.to_vec())),
            }
        };
        Solver {
            kin,
            nominal,
            actual,
            max_c_swing: max_c_swing_deg,
            eps,
            offsets,
            lever,
        }
    }

    /// An upper bound of how far the actual tip strays, half-way along a
    /// move, from the intended path when the controller interpolates axis
    /// values linearly from `w0` to `w1` where the nominal program goes from
    /// `n0` to `n1` (post-side, both ends exact up to `ends`, mm). Infinite
    /// unless the errors are constant (closed-form fast path).
    ///
    /// With `F(s) = A(w(s)) - N(n(s))`, `|F(1/2)| <= (|F(0)| + |F(1)|) / 2 +
    /// max|F''| / 8`. Both chains are rotations by angles linear in `s`
    /// applied to positions linear in `s`, so with `K` the rotary step (sum
    /// of |dt| and |dc|, rad), `k` the difference of the two rotary steps,
    /// `V`, `dV` the linear steps and their difference, `L` the lever arm,
    /// `d`, `g` the largest position and angle correction and `eps`, `e`
    /// the angular and translational errors:
    /// `|F''| <= 2 (4 eps V K + dV K + V k) + K^2 (4 eps L + e + d + g L) + L (2K + k) k`.
    /// The bound is checked against the exact deviation in the tests.
    pub fn deviation_bound(&self, n0: &Axes, n1: &Axes, w0: &Axes, w1: &Axes, ends: f64) -> f64 {
        if !self.is_fast() {
            return f64::INFINITY;
        }
        let rot = |a: &Axes, b: &Axes| {
            (b.tilt - a.tilt).to_radians().abs() + (b.c - a.c).to_radians().abs()
        };
        let kn = rot(n0, n1);
        let kw = rot(w0, w1);
        let k = kn.max(kw);
        let kappa = ((w1.tilt - w0.tilt) - (n1.tilt - n0.tilt))
            .to_radians()
            .abs()
            + ((w1.c - w0.c) - (n1.c - n0.c)).to_radians().abs();
        let (dn, dw) = (n1.xyz - n0.xyz, w1.xyz - w0.xyz);
        let v = dn.norm().max(dw.norm());
        let dv = (dw - dn).norm();
        let l = n0
            .xyz
            .norm()
            .max(n1.xyz.norm())
            .max(w0.xyz.norm())
            .max(w1.xyz.norm())
            + self.lever
            + self.offsets
            + 1.0;
        let d = (w0.xyz - n0.xyz).norm().max((w1.xyz - n1.xyz).norm());
        let g = rot(n0, w0).max(rot(n1, w1));
        let e = self.eps;
        let f2 = 2.0 * (4.0 * e * v * k + dv * k + v * kappa)
            + k * k * (4.0 * e * l + self.offsets + d + g * l)
            + l * (2.0 * k + kappa) * kappa;
        ends + f2 / 8.0
    }

    /// Whether the closed-form fast path is in use.
    pub fn is_fast(&self) -> bool {
        matches!(self.actual, Actual::Fast { lin: None, .. })
    }

    /// The kinematics.
    pub fn kinematics(&self) -> &Kinematics {
        &self.kin
    }

    /// The nominal chain (what the controller believes).
    pub fn nominal(&self) -> &FastChain {
        &self.nominal
    }

    fn lin_at(&self, axes: &Axes) -> Vector3<f64> {
        match &self.actual {
            Actual::Fast { chain, lin: None } => chain.linear(),
            Actual::Fast {
                lin: Some((model, theta)),
                ..
            } => model.perturbation(theta, &Context::at(*axes)).linear(),
            Actual::Exact { model, theta } => {
                model.perturbation(theta, &Context::at(*axes)).linear()
            }
        }
    }

    /// The actual tool pose at `axes`.
    pub fn actual_pose(&self, axes: &Axes) -> ToolPose {
        match &self.actual {
            Actual::Fast { chain, lin: None } => chain.forward(axes),
            Actual::Fast { chain, .. } => chain.forward_lin(axes, &self.lin_at(axes)),
            Actual::Exact { model, theta } => model.pose(theta, &Context::at(*axes)),
        }
    }

    /// The nominal tool pose at `axes`.
    pub fn nominal_pose(&self, axes: &Axes) -> ToolPose {
        self.nominal.forward(axes)
    }

    /// The exact inverse nearest `reference`.
    fn inverse_exact(&self, target: &ToolPose, reference: &Axes) -> Result<Axes, IkError> {
        match &self.actual {
            Actual::Fast { chain, lin: None } => chain.inverse(target, reference),
            Actual::Fast { chain, .. } => {
                let mut a = chain.inverse(target, reference)?;
                self.refine_position(chain, target, &mut a);
                Ok(a)
            }
            Actual::Exact { model, theta } => {
                model.inverse(theta, target, Some(reference), &Context::at(*reference))
            }
        }
    }

    /// X, Y, Z for the tip with the rotary axes fixed, iterating on the
    /// linear-axis errors that depend on the position.
    fn refine_position(&self, chain: &FastChain, target: &ToolPose, a: &mut Axes) {
        for _ in 0..8 {
            let lin = self.lin_at(a);
            let next = chain.position(&target.tip, a.tilt, a.c, &lin);
            let done = (next - a.xyz).norm() < 1e-13;
            a.xyz = next;
            if done {
                break;
            }
        }
    }

    /// The chain with the link errors at the given angles (for error maps).
    fn chain_at(&self, axes: &Axes) -> FastChain {
        match &self.actual {
            Actual::Fast { chain, .. } => chain.clone(),
            Actual::Exact { model, theta } => {
                let mut p = model.perturbation(theta, &Context::at(*axes));
                for k in 0..3 {
                    p.0[SLOT_LIN + k] = 0.0;
                }
                FastChain::new(&self.kin, &p)
            }
        }
    }

    /// Axis values with C held at `c`: best tilt, exact tip.
    fn hold_c(&self, target: &ToolPose, nominal: &Axes) -> Result<Axes, IkError> {
        let u = target.axis.normalize();
        let m = self.kin.machine();
        // The tilt at the turn nearest the nominal one (a stroke of more
        // than a turn reaches it at several).
        let turned =
            |t: f64| crate::geom::nearest_turn(t, nominal.tilt, m.tilt.limits).unwrap_or(t);
        let mut a = *nominal;
        let fixed;
        let chain = match &self.actual {
            Actual::Fast { chain, .. } => chain,
            Actual::Exact { .. } => {
                // The link errors depend on the tilt: iterate.
                let mut ch = self.chain_at(&a);
                for _ in 0..6 {
                    a.tilt = turned(ch.tilt_for_c(&u, a.c));
                    ch = self.chain_at(&a);
                }
                fixed = ch;
                &fixed
            }
        };
        a.tilt = turned(chain.tilt_for_c(&u, a.c));
        if !m.tilt.within(a.tilt, 1e-9) {
            let (lo, hi) = m.tilt.limits.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
            return Err(IkError::TiltOutOfLimits {
                ux: u.x,
                uy: u.y,
                uz: u.z,
                letter: m.tilt.letter,
                angle: a.tilt,
                alt: a.tilt,
                lo,
                hi,
            });
        }
        a.xyz = chain.position(&target.tip, a.tilt, a.c, &Vector3::zeros());
        for _ in 0..8 {
            let lin = self.lin_at(&a);
            let ch = self.chain_at(&a);
            let next = ch.position(&target.tip, a.tilt, a.c, &lin);
            let done = (next - a.xyz).norm() < 1e-13;
            a.xyz = next;
            if done {
                break;
            }
        }
        Ok(a)
    }

    /// The corrected axes for `target`, nearest the nominal axes `nominal`,
    /// with the singularity policy of the module documentation.
    pub fn solve(&self, target: &ToolPose, nominal: &Axes) -> Result<Solution, IkError> {
        let exact = self.inverse_exact(target, nominal);
        match exact {
            Ok(a) if (a.c - nominal.c).abs() <= self.max_c_swing => Ok(Solution {
                axes: a,
                held_c: None,
                held_tilt: None,
            }),
            Ok(_) | Err(IkError::OutOfReach { .. }) | Err(IkError::NoConvergence { .. }) => {
                // (An exact solution far in C may be the other branch,
                // flipped by 180 deg because the near one lies past the
                // tilt's limit: then the limit is what holds.)
                match self.solve_held(target, nominal) {
                    Err(e @ IkError::TiltOutOfLimits { .. }) => {
                        self.at_tilt_limit(target, nominal).ok_or(e)
                    }
                    other => other,
                }
            }
            Err(e @ IkError::TiltOutOfLimits { .. }) => {
                self.at_tilt_limit(target, nominal).ok_or(e)
            }
            Err(e) => Err(e),
        }
    }

    /// A program that runs the tilt to its limit (a face machined at
    /// B = 90) may need the tilt a few urad beyond it on the erroneous
    /// machine. Up to [`TILT_OVERRUN`] beyond, the tilt is held at the limit,
    /// C takes the exact solution's value and the tip is exact; the tool
    /// axis is then off by the overrun. Further beyond, there is no
    /// correction (the move is left as written).
    fn at_tilt_limit(&self, target: &ToolPose, nominal: &Axes) -> Option<Solution> {
        let m = self.kin.machine();
        let (lo, hi) = m.tilt.limits?;
        let u = target.axis.normalize();
        let chain = self.chain_at(nominal);
        let roots = chain.orientation_roots(&u, nominal.c)?;
        let dist = |&(t, c): &(f64, f64)| {
            (t - nominal.tilt).abs() + crate::geom::wrap180(c - nominal.c).abs()
        };
        let (t, c) = roots
            .into_iter()
            .min_by(|a, b| dist(a).total_cmp(&dist(b)))?;
        let held = t.clamp(lo, hi);
        if (t - held).abs() > TILT_OVERRUN {
            return None;
        }
        let c = nominal.c + crate::geom::wrap180(c - nominal.c);
        if !m.c.within(c, 1e-9) {
            return None;
        }
        let mut a = Axes {
            xyz: nominal.xyz,
            tilt: held,
            c,
        };
        a.xyz = chain.position(&target.tip, a.tilt, a.c, &Vector3::zeros());
        for _ in 0..8 {
            let lin = self.lin_at(&a);
            let next = self.chain_at(&a).position(&target.tip, a.tilt, a.c, &lin);
            let done = (next - a.xyz).norm() < 1e-13;
            a.xyz = next;
            if done {
                break;
            }
        }
        let got = self.actual_pose(&a).axis.normalize();
        Some(Solution {
            axes: a,
            held_c: None,
            held_tilt: Some(got.dot(&u).clamp(-1.0, 1.0).acos()),
        })
    }

    /// The correction with C held at its nominal value (the fallback of
    /// the singularity policy, also used when the exact solution's swing of
    /// C would exceed the correction limit).
    pub(crate) fn solve_held(
        &self,
        target: &ToolPose,
        nominal: &Axes,
    ) -> Result<Solution, IkError> {
        let a = self.hold_c(target, nominal)?;
        let got = self.actual_pose(&a).axis;
        let residual = got
            .normalize()
            .dot(&target.axis.normalize())
            .clamp(-1.0, 1.0)
            .acos();
        Ok(Solution {
            axes: a,
            held_c: Some(residual),
            held_tilt: None,
        })
    }

    /// X, Y, Z that put the tip at `tip` with the rotary axes fixed.
    pub(crate) fn position_at(&self, tip: &Vector3<f64>, tilt: f64, c: f64) -> Vector3<f64> {
        let mut a = Axes {
            xyz: Vector3::zeros(),
            tilt,
            c,
        };
        let chain = self.chain_at(&a);
        a.xyz = chain.position(tip, tilt, c, &self.lin_at(&a));
        if !self.is_fast() {
            let target = ToolPose {
                tip: *tip,
                axis: Vector3::z(),
            };
            self.refine_position(&chain, &target, &mut a);
        }
        a.xyz
    }
}
