//! The one error model that `simulate` runs forward, `analyze` inverts and
//! `discover` searches: the machine's exact kinematics plus a list of named
//! [`Effect`]s, each owning a slice of the parameter vector.
//!
//! Every effect is linear in its own parameters at the level of the
//! kinematic chain's [`Perturbation`] slots (a location error sets a term, a
//! map node contributes through interpolation weights, a drift adds
//! `rate * seq`, a scale error adds `EXX * x` to the X slide, ...). The
//! chain itself is exact and nonlinear. So the tool pose's Jacobian with
//! respect to the parameters is the chain's slot Jacobian times the sparse
//! slot-per-parameter coefficients, with no approximation anywhere.
//!
//! Parameters are in the units of error files (um, urad, um/m, ...); the
//! chain works in mm and rad.

mod effect;

use nalgebra::{DMatrix, Vector3};

use crate::kinematics::symbols::SymbolTable;
use crate::kinematics::{
    Axes, IkError, Kinematics, Perturbation, PoseJacobian, SLOT_PRETRAVEL, ToolPose,
};

pub use effect::PROBE_DIRECTIONS;
pub use effect::{DriftBasis, Effect, Squareness};

/// Where and when the machine is: what the effects depend on.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Context {
    /// Commanded axis values.
    pub axes: Axes,
    /// Execution order of the pose (`seq` of docs/formats.md).
    pub seq: f64,
    /// Elapsed time since the program started, minutes.
    pub minutes: f64,
    /// Probing: unit approach direction in the probe's own frame (the
    /// machine frame when the head is at zero); `None` when not probing.
    pub approach: Option<Vector3<f64>>,
}

impl Context {
    /// A context at the given axes, sequence 0, time 0, not probing.
    pub fn at(axes: Axes) -> Context {
        Context {
            axes,
            ..Default::default()
        }
    }
}

/// Kinematics plus effects.
#[derive(Clone, Debug)]
pub struct Model {
    /// The machine's kinematics.
    pub kin: Kinematics,
    /// Its symbols.
    pub symbols: SymbolTable,
    /// The effects, in order.
    pub effects: Vec<Effect>,
    offsets: Vec<usize>,
}

impl Model {
    /// A model of `kin` with the given effects.
    pub fn new(kin: Kinematics, effects: Vec<Effect>) -> Model {
        let symbols = SymbolTable::for_kinematics(&kin);
        let mut m = Model {
            kin,
            symbols,
            effects,
            offsets: Vec::new(),
        };
        m.reindex();
        m
    }

    fn reindex(&mut self) {
        self.offsets.clear();
        let mut o = 0;
        for e in &self.effects {
            self.offsets.push(o);
            o += e.n_params();
        }
        self.offsets.push(o);
    }

    /// Adds an effect; its parameters go at the end of the vector.
    pub fn push(&mut self, e: Effect) {
        self.effects.push(e);
        self.reindex();
    }

    /// Total number of parameters.
    pub fn n_params(&self) -> usize {
        *self.offsets.last().unwrap_or(&0)
    }

    /// Index range of effect `i`'s parameters.
    pub fn param_range(&self, i: usize) -> std::ops::Range<usize> {
        self.offsets[i]..self.offsets[i + 1]
    }

    /// Parameter names, in vector order.
    pub fn param_names(&self) -> Vec<String> {
        self.effects
            .iter()
            .flat_map(|e| e.param_names(&self.symbols))
            .collect()
    }

    /// Parameter units, in vector order.
    pub fn param_units(&self) -> Vec<String> {
        self.effects
            .iter()
            .flat_map(|e| e.param_units(&self.symbols))
            .collect()
    }

    /// Sparse `d slot / d parameter` at a context: (slot, parameter, coefficient).
    pub(crate) fn slot_coefficients(&self, ctx: &Context) -> Vec<(usize, usize, f64)> {
        let mut out = Vec::new();
        for (i, e) in self.effects.iter().enumerate() {
            let o = self.offsets[i];
            e.coefficients(&self.symbols, ctx, &mut |slot, p, c| {
                out.push((slot, o + p, c))
            });
        }
        out
    }

    /// The slot values for parameters `theta` at a context.
    pub fn perturbation(&self, theta: &[f64], ctx: &Context) -> Perturbation {
        debug_assert_eq!(theta.len(), self.n_params());
        let mut p = Perturbation::zero();
        for (i, e) in self.effects.iter().enumerate() {
            let o = self.offsets[i];
            // An effect at zero adds nothing (a catalogue model fitted a
            // few effects at a time is mostly such effects).
            if self.at_zero(theta, i) {
                continue;
            }
            e.coefficients(&self.symbols, ctx, &mut |slot, k, c| {
                p.0[slot] += c * theta[o + k]
            });
        }
        p
    }

    /// Whether the perturbation at `theta` changes with the linear axes'
    /// positions: a linear-axis error (scale, squareness, straightness)
    /// not at zero. Every other effect depends on the rotary positions,
    /// the time or the approach only.
    pub fn varies_with_xyz(&self, theta: &[f64]) -> bool {
        self.effects.iter().enumerate().any(|(i, e)| {
            matches!(
                e,
                Effect::Scale { .. } | Effect::Squareness { .. } | Effect::Straightness { .. }
            ) && !self.at_zero(theta, i)
        })
    }

    /// Whether every parameter of effect `i` is zero in `theta`.
    fn at_zero(&self, theta: &[f64], i: usize) -> bool {
        theta[self.offsets[i]..self.offsets[i + 1]]
            .iter()
            .all(|&t| t == 0.0)
    }

    /// The probe's pre-travel slot of the perturbation at `ctx`, the same
    /// bits, and its gradient: the pre-travel effect's own terms alone (no
    /// other effect moves that slot), not the whole perturbation.
    pub(crate) fn pretravel(&self, theta: &[f64], ctx: &Context) -> (f64, Vec<f64>) {
        let mut v = 0.0;
        let mut g = vec![0.0; self.n_params()];
        for (i, e) in self.effects.iter().enumerate() {
            if !matches!(e, Effect::ProbePretravel) {
                continue;
            }
            let o = self.offsets[i];
            let at_zero = self.at_zero(theta, i);
            e.coefficients(&self.symbols, ctx, &mut |slot, k, c| {
                debug_assert_eq!(slot, SLOT_PRETRAVEL);
                // Added as the perturbation adds them: nothing at zero.
                if !at_zero {
                    v += c * theta[o + k];
                }
                g[o + k] += c;
            });
        }
        (v, g)
    }

    /// The actual tool pose in W at `ctx.axes`.
    pub fn pose(&self, theta: &[f64], ctx: &Context) -> ToolPose {
        self.kin.forward(&ctx.axes, &self.perturbation(theta, ctx))
    }

    /// The pose, the chain Jacobian, and the derivatives of tip and axis
    /// with respect to the parameters (3 x n_params each).
    pub fn pose_jacobian(
        &self,
        theta: &[f64],
        ctx: &Context,
    ) -> (PoseJacobian, DMatrix<f64>, DMatrix<f64>) {
        self.pose_jacobian_of(theta, ctx, None)
    }

    /// [`Model::pose_jacobian`] with the derivatives of the effects
    /// `effects` marks only (`None`: all); the other columns are zero. Each
    /// column is computed on its own, so a marked one is the same to the
    /// bit either way.
    pub fn pose_jacobian_of(
        &self,
        theta: &[f64],
        ctx: &Context,
        effects: Option<&[bool]>,
    ) -> (PoseJacobian, DMatrix<f64>, DMatrix<f64>) {
        let n = self.n_params();
        let mut ja = DMatrix::zeros(3, n);
        let (j, jt) = self.jacobians_of(theta, ctx, effects, Some(&mut ja));
        (j, jt, ja)
    }

    /// The pose of [`Model::pose_jacobian`], the same bits, without any
    /// derivative.
    pub fn jacobian_pose(&self, theta: &[f64], ctx: &Context) -> ToolPose {
        self.kin
            .jacobian_pose(&ctx.axes, &self.perturbation(theta, ctx))
    }

    /// [`Model::pose_jacobian_of`] without the tool axis's derivatives (the
    /// tip's are the same bits).
    pub fn tip_jacobian_of(
        &self,
        theta: &[f64],
        ctx: &Context,
        effects: Option<&[bool]>,
    ) -> (PoseJacobian, DMatrix<f64>) {
        self.jacobians_of(theta, ctx, effects, None)
    }

    fn jacobians_of(
        &self,
        theta: &[f64],
        ctx: &Context,
        effects: Option<&[bool]>,
        mut ja: Option<&mut DMatrix<f64>>,
    ) -> (PoseJacobian, DMatrix<f64>) {
        let p = self.perturbation(theta, ctx);
        let j = self.kin.jacobian(&ctx.axes, &p);
        let mut jt = DMatrix::zeros(3, self.n_params());
        for (i, e) in self.effects.iter().enumerate() {
            if effects.is_some_and(|m| !m[i]) {
                continue;
            }
            let o = self.offsets[i];
            e.coefficients(&self.symbols, ctx, &mut |slot, p, c| {
                for r in 0..3 {
                    jt[(r, o + p)] += c * j.tip[(r, 5 + slot)];
                }
                if let Some(ja) = ja.as_deref_mut() {
                    for r in 0..3 {
                        ja[(r, o + p)] += c * j.axis[(r, 5 + slot)];
                    }
                }
            });
        }
        (j, jt)
    }

    /// Axis values that put the actual tool at `target` at the given
    /// sequence and time (errors depend on where the axes end up, so the
    /// context follows the iteration).
    pub fn inverse(
        &self,
        theta: &[f64],
        target: &ToolPose,
        hint: Option<&Axes>,
        ctx: &Context,
    ) -> Result<Axes, IkError> {
        self.kin.inverse(target, hint, |a| {
            self.perturbation(theta, &Context { axes: *a, ..*ctx })
        })
    }

    /// Indices of the effects with the given identifier.
    pub fn find(&self, id: &str) -> Option<usize> {
        self.effects.iter().position(|e| e.id(&self.symbols) == id)
    }
}
