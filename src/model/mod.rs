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
    Axes, IkError, Kinematics, Perturbation, PoseJacobian, SLOT_LIN, SLOT_LIN_ROT, SLOT_PRETRAVEL,
    ToolPose,
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
    /// Where the measured point sits from the commanded point, mm, machine
    /// axes at head zero: a laser's reflector on a spindle bracket. It is
    /// the part of the lever arm of the linear axes' angular error motions
    /// ([`Effect::Angular`]) that the chain does not hold. Zero where not
    /// filled: the lever is taken from the commanded point (the tool tip of
    /// a compensated tool length), docs/model.md.
    pub measured_offset: Vector3<f64>,
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

/// A parameter vector and the effects it moves ([`Model::params`]).
#[derive(Clone, Debug)]
pub struct Params<'a> {
    /// The parameters.
    pub theta: &'a [f64],
    /// The effects not at zero, in order.
    moving: Vec<usize>,
}

/// The parameters of a model whose derivatives a caller uses, by column
/// and by effect (a forward model's `predict_wanted`).
#[derive(Clone, Debug, PartialEq)]
pub struct Wanted {
    /// The wanted parameters' columns, increasing.
    columns: Vec<usize>,
    /// Per effect of the model, whether any of its parameters is wanted.
    effects: Vec<bool>,
    /// Per parameter, its place in `columns` (`usize::MAX`: not wanted).
    index: Vec<usize>,
}

impl Wanted {
    /// The parameters of `model` for which `used` holds.
    pub fn new(model: &Model, used: impl Fn(usize) -> bool) -> Wanted {
        let columns: Vec<usize> = (0..model.n_params()).filter(|&c| used(c)).collect();
        let effects = (0..model.effects.len())
            .map(|e| model.param_range(e).any(&used))
            .collect();
        let mut index = vec![usize::MAX; model.n_params()];
        for (k, &c) in columns.iter().enumerate() {
            index[c] = k;
        }
        Wanted {
            columns,
            effects,
            index,
        }
    }

    /// The wanted parameters' columns, increasing.
    pub fn columns(&self) -> &[usize] {
        &self.columns
    }
}

/// Whether effect `e` depends on the linear axes' positions (a
/// linear-axis error; it writes the linear slots, which no other effect
/// writes).
fn reads_xyz(e: &Effect) -> bool {
    e.is_linear_axis_error()
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
        for i in 0..self.effects.len() {
            // An effect at zero adds nothing (a catalogue model fitted a
            // few effects at a time is mostly such effects).
            if !self.at_zero(theta, i) {
                self.add_effect(i, theta, ctx, &mut p);
            }
        }
        p
    }

    /// `theta` with the effects not at zero found once, for the many poses
    /// a forward model evaluates at one parameter vector (looking at every
    /// effect at every pose cost as much as the perturbations themselves).
    pub fn params<'a>(&self, theta: &'a [f64]) -> Params<'a> {
        debug_assert_eq!(theta.len(), self.n_params());
        Params {
            theta,
            moving: (0..self.effects.len())
                .filter(|&i| !self.at_zero(theta, i))
                .collect(),
        }
    }

    /// [`Model::perturbation`] at `at`, the same bits (the same effects
    /// added in the same order).
    pub fn perturbation_at(&self, at: &Params, ctx: &Context) -> Perturbation {
        let mut p = Perturbation::zero();
        for &i in &at.moving {
            self.add_effect(i, at.theta, ctx, &mut p);
        }
        p
    }

    fn add_effect(&self, i: usize, theta: &[f64], ctx: &Context, p: &mut Perturbation) {
        let o = self.offsets[i];
        self.effects[i].coefficients(&self.symbols, ctx, &mut |slot, k, c| {
            p.0[slot] += c * theta[o + k]
        });
    }

    /// Whether the perturbation at `theta` changes with the linear axes'
    /// positions: a linear-axis error (scale, squareness, straightness,
    /// positioning or angular map) not at zero. Every other effect depends on the rotary positions,
    /// the time or the approach only.
    pub fn varies_with_xyz(&self, theta: &[f64]) -> bool {
        self.effects
            .iter()
            .enumerate()
            .any(|(i, e)| reads_xyz(e) && !self.at_zero(theta, i))
    }

    /// The perturbation at `ctx` from `p`, the one at the same context but
    /// for the linear axes' positions: the same bits as
    /// [`Model::perturbation`] at `ctx`. Only the linear-axis errors read
    /// X, Y and Z, and only they write the linear slots (translation and
    /// rotation), so those slots are worked out again (in the same order,
    /// from zero) and the rest is kept.
    pub fn perturbation_moved(
        &self,
        theta: &[f64],
        ctx: &Context,
        p: &Perturbation,
    ) -> Perturbation {
        let mut out = *p;
        out.0[SLOT_LIN..SLOT_LIN + 3].fill(0.0);
        out.0[SLOT_LIN_ROT..SLOT_LIN_ROT + 3].fill(0.0);
        for (i, e) in self.effects.iter().enumerate() {
            if reads_xyz(e) && !self.at_zero(theta, i) {
                self.add_effect(i, theta, ctx, &mut out);
            }
        }
        out
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
        self.pose_jacobian_with(&self.perturbation(theta, ctx), ctx)
    }

    /// [`Model::pose_jacobian`] where the perturbation `p` at `ctx` is
    /// known already (the Jacobian does not depend on `theta` otherwise).
    pub fn pose_jacobian_with(
        &self,
        p: &Perturbation,
        ctx: &Context,
    ) -> (PoseJacobian, DMatrix<f64>, DMatrix<f64>) {
        let mut ja = DMatrix::zeros(3, self.n_params());
        let (j, jt) = self.jacobians_of(p, ctx, None, Some(&mut ja));
        (j, jt, ja)
    }

    /// [`Model::pose_jacobian`] at `at` with the derivatives of `wanted`'s
    /// columns only, in that order (3 x `wanted.columns.len()`). Each column
    /// is computed on its own, the same bits as `pose_jacobian`'s.
    pub fn pose_jacobian_at(
        &self,
        at: &Params,
        ctx: &Context,
        wanted: &Wanted,
    ) -> (PoseJacobian, DMatrix<f64>, DMatrix<f64>) {
        let mut ja = DMatrix::zeros(3, wanted.columns.len());
        let p = self.perturbation_at(at, ctx);
        let (j, jt) = self.jacobians_of(&p, ctx, Some(wanted), Some(&mut ja));
        (j, jt, ja)
    }

    /// The pose of [`Model::pose_jacobian`] at `at`, the same bits, without
    /// any derivative.
    pub fn jacobian_pose_at(&self, at: &Params, ctx: &Context) -> ToolPose {
        self.kin
            .jacobian_pose(&ctx.axes, &self.perturbation_at(at, ctx))
    }

    /// [`Model::pose_jacobian_at`] without the tool axis's derivatives (the
    /// tip's are the same bits).
    pub fn tip_jacobian_at(
        &self,
        at: &Params,
        ctx: &Context,
        wanted: &Wanted,
    ) -> (PoseJacobian, DMatrix<f64>) {
        let p = self.perturbation_at(at, ctx);
        self.jacobians_of(&p, ctx, Some(wanted), None)
    }

    /// The chain Jacobian at `p` and the tip's (and, into `ja`, the axis's)
    /// derivatives with respect to `wanted`'s parameters, in its columns'
    /// order (`None`: every parameter, in the model's).
    fn jacobians_of(
        &self,
        p: &Perturbation,
        ctx: &Context,
        wanted: Option<&Wanted>,
        mut ja: Option<&mut DMatrix<f64>>,
    ) -> (PoseJacobian, DMatrix<f64>) {
        let j = self.kin.jacobian(&ctx.axes, p);
        let mut jt = DMatrix::zeros(3, wanted.map_or(self.n_params(), |w| w.columns.len()));
        for (i, e) in self.effects.iter().enumerate() {
            if wanted.is_some_and(|w| !w.effects[i]) {
                continue;
            }
            let o = self.offsets[i];
            e.coefficients(&self.symbols, ctx, &mut |slot, p, c| {
                let col = wanted.map_or(o + p, |w| w.index[o + p]);
                if col == usize::MAX {
                    return;
                }
                for r in 0..3 {
                    jt[(r, col)] += c * j.tip[(r, 5 + slot)];
                }
                if let Some(ja) = ja.as_deref_mut() {
                    for r in 0..3 {
                        ja[(r, col)] += c * j.axis[(r, 5 + slot)];
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
