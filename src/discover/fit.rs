//! Fitting models to a test's measurements, sized for the hundreds of fits
//! a discovery makes.
//!
//! Every model a discovery fits is a subset of one catalogue model: the
//! machine's location symbols (one effect each) followed by every candidate
//! effect. Effects add their slot contributions linearly, so a model's
//! prediction is the catalogue model's with the other effects' parameters
//! at zero. The forward model is therefore built once, and its Jacobian at
//! the nominal machine (every parameter, the forward model's nuisance, the
//! CMM placement of a machined piece) computed once; a model's design is a
//! choice of columns.
//!
//! The fit is the `global` identification's (one least-squares fit of
//! every point, residuals in um along the predicted normal, the placement
//! `P0 D(rho)` with `P0` from the reference features), solved by the same
//! damped Gauss-Newton (`lsq::solve_ranked`, its damping adapted to how
//! well each step was predicted) on the exact residuals and Jacobians,
//! until a step gains nothing the noise could tell. The
//! rank and the directions the test does not see come from the nominal
//! design, as in `global` ("what the test identifies is a property of its
//! design"), and every step and the covariance are taken with that rank.
//!
//! A round of the search tries every candidate on the current model. One
//! evaluation of the catalogue model at the current estimate gives every
//! candidate's Jacobian columns there, and each candidate is first judged
//! by one Gauss-Newton step from the current estimate: the current model
//! is converged, and an added effect enters the chain linearly in its own
//! parameters, so the step lands within parts in 10^8 of the sum of
//! squares the iterated fit reaches. The step is not solved anew per
//! candidate: the current model's design is factorized once a round
//! ([`Fitter::screen`]) and each candidate scored by the update its own
//! columns make to it ([`Fitter::score`]). The candidates that come near
//! significance, and every model the story reports, are then iterated
//! exactly ([`Fitter::fit`]).
//!
//! A discovery may fit several tests of one machine together ([`Part`]: a
//! test and the supplementary test its ambiguity asked for). Their
//! residuals are stacked; each test has its own forward model (its plan,
//! its gauge length), its own nuisance and placement, and applies the
//! candidates its forward model serves, while the model's parameters are
//! shared.
//!
//! The forward model is chosen in one place, [`forward_model`]: the
//! simulator's general model ([`crate::simulate::forward`]) whenever the
//! plan is known, which applies every effect of the catalogue as the
//! virtual machine does; the rigid-pose models of `identify::forward`
//! (location errors, maps, drift) for bare point sets.

use std::cell::RefCell;
use std::ops::Range;
use std::sync::Arc;

use faer::Mat;
use nalgebra::{DMatrix, DVector, Isometry3, Vector3};

pub use super::catalogue::{ConstraintRow, Why};
pub use super::part::Part;

use super::catalogue::Candidate;
use crate::identify::forward::{ForwardError, ForwardModel, Wanted};
use crate::identify::global::PLACEMENT_NAMES;
use crate::identify::global::{Observed, observed};
use crate::identify::identifiability::{self, Identifiability};
use crate::identify::lsq::{self, Design};
use crate::identify::rigid::{d6_um, face_residual};
use crate::identify::{Dataset, IdentifyError, Setup};
use crate::kinematics::Kinematics;
use crate::model::{Effect, Model};
use crate::procedure::{MachiningPlan, Plan, ProbingPlan};
use crate::simulate::forward::{MachiningForward, ProbingForward};

/// The plan of a test, shared by every forward model built on it.
#[derive(Clone, Debug)]
pub enum PlanRef {
    /// A machining test.
    Machining(Arc<MachiningPlan>),
    /// A probing test.
    Probing(Arc<ProbingPlan>),
}

impl PlanRef {
    /// Shares a loaded plan.
    pub fn new(plan: &Plan) -> PlanRef {
        match plan {
            Plan::Machining(t) => PlanRef::Machining(Arc::new((**t).clone())),
            Plan::Probing(p) => PlanRef::Probing(Arc::new((**p).clone())),
        }
    }
}

/// The forward model `discover` fits with: the one seam between the
/// search and the physics.
pub fn forward_model(
    model: Model,
    data: &Dataset,
    plan: Option<&PlanRef>,
) -> Result<Box<dyn ForwardModel>, ForwardError> {
    match plan {
        Some(PlanRef::Machining(t)) => Ok(Box::new(MachiningForward::new(&model, t.clone())?)),
        Some(PlanRef::Probing(p)) => Ok(Box::new(ProbingForward::new(&model, p.clone())?)),
        None => crate::identify::forward::rigid_for(model, data),
    }
}

/// A model to fit: effects in order, each with its story name and its own
/// defining constraints, and where its parameters sit in the catalogue
/// model.
#[derive(Clone, Debug)]
pub struct Spec {
    /// The model.
    pub model: Model,
    /// Story name of each effect (`location`, `drift.EZ0B/seq`, ...).
    pub names: Vec<String>,
    /// Per effect: constraint rows on its own parameters, with what each
    /// says.
    pub constraints: Vec<Vec<ConstraintRow>>,
    /// Per parameter, its index in the catalogue model.
    full: Vec<usize>,
    /// Per effect, the free directions of its constraints as last computed
    /// (and the rows they were computed from): every design of a round
    /// shares them.
    blocks: Vec<Arc<Block>>,
}

/// The orthonormal basis of the directions an effect's constraint rows
/// leave free.
#[derive(Debug)]
struct Block {
    rows: Vec<Vec<f64>>,
    basis: DMatrix<f64>,
}

impl Block {
    fn new(n: usize, rows: &[ConstraintRow]) -> Arc<Block> {
        let c = DMatrix::from_fn(rows.len(), n, |i, j| rows[i].0[j]);
        Arc::new(Block {
            rows: rows.iter().map(|(r, _)| r.clone()).collect(),
            basis: lsq::constraint_basis(&c),
        })
    }

    fn holds(&self, rows: &[ConstraintRow]) -> bool {
        self.rows.len() == rows.len() && self.rows.iter().zip(rows).all(|(a, (b, _))| a == b)
    }

    /// This block with `more` rows: the free directions of the old rows
    /// that the new ones leave free, `B null(R B)`. A map fixes hundreds of
    /// combinations of its hundreds of values, and the decomposition of
    /// `R B` (as many columns as were free) is what that costs, where the
    /// stacked rows' would cost the whole map's.
    fn extended(&self, more: &[ConstraintRow]) -> Arc<Block> {
        let n = self.basis.nrows();
        let m = self.basis.ncols();
        let mut rows = self.rows.clone();
        rows.extend(more.iter().map(|(r, _)| r.clone()));
        let basis = if more.is_empty() || m == 0 {
            self.basis.clone()
        } else {
            let r = DMatrix::from_fn(more.len(), n, |i, j| more[i].0[j]);
            &self.basis * lsq::constraint_basis(&(r * &self.basis))
        };
        Arc::new(Block { rows, basis })
    }
}

/// An effect's constraints with further rows, and their free directions:
/// made once, applied to every model the effect is tried on
/// ([`Spec::apply`]).
#[derive(Clone, Debug)]
pub(crate) struct Constrained {
    rows: Vec<ConstraintRow>,
    block: Arc<Block>,
}

impl Spec {
    /// Index of the effect named `name`.
    pub fn find(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    /// The free directions of effect `ei`'s constraints: the cached ones
    /// while its rows are those they were computed from.
    fn block(&self, ei: usize) -> Arc<Block> {
        let rows = &self.constraints[ei];
        match self.blocks.get(ei) {
            Some(b) if b.holds(rows) => b.clone(),
            _ => Block::new(self.model.param_range(ei).len(), rows),
        }
    }

    /// Fixes the combinations `rows` of effect `ei`'s parameters at zero,
    /// each saying why.
    pub(crate) fn constrain(&mut self, ei: usize, rows: Vec<ConstraintRow>) {
        let c = self.constrained(ei, rows);
        self.apply(ei, &c);
    }

    /// Effect `ei`'s constraints with `rows` added, for [`Spec::apply`].
    pub(crate) fn constrained(&self, ei: usize, rows: Vec<ConstraintRow>) -> Constrained {
        let block = self.block(ei).extended(&rows);
        let mut all = self.constraints[ei].clone();
        all.extend(rows);
        Constrained { rows: all, block }
    }

    /// Sets effect `ei`'s constraints to `c` (made by
    /// [`Spec::constrained`] on a model with the same effect `ei`).
    pub(crate) fn apply(&mut self, ei: usize, c: &Constrained) {
        self.constraints[ei] = c.rows.clone();
        if let Some(slot) = self.blocks.get_mut(ei) {
            *slot = c.block.clone();
        }
    }

    /// Whether model parameter `i` is fixed by the constraints (no free
    /// direction moves it).
    pub fn fixed(&self, i: usize) -> bool {
        let Some(ei) =
            (0..self.constraints.len()).find(|&e| self.model.param_range(e).contains(&i))
        else {
            return false;
        };
        let b = self.block(ei);
        b.basis.row(i - self.model.param_range(ei).start).norm() < 1e-9
    }

    /// The orthonormal basis of the parameter directions the constraints
    /// leave free, block by block (so that each free direction belongs to
    /// one effect), extended by `extra` unconstrained nuisance parameters;
    /// and the range of basis columns of each effect.
    pub fn basis(&self, extra: usize) -> (DMatrix<f64>, Vec<Range<usize>>) {
        let n = self.model.n_params();
        let mut blocks = Vec::new();
        for ei in 0..self.constraints.len() {
            let r = self.model.param_range(ei);
            blocks.push((r, self.block(ei).basis.clone()));
        }
        let mut ranges = Vec::new();
        let mut free = 0;
        for (_, b) in &blocks {
            ranges.push(free..free + b.ncols());
            free += b.ncols();
        }
        let mut out = DMatrix::zeros(n + extra, free + extra);
        for ((r, b), zr) in blocks.iter().zip(&ranges) {
            out.view_mut((r.start, zr.start), (r.len(), zr.len()))
                .copy_from(b);
        }
        for i in 0..extra {
            out[(n + i, free + i)] = 1.0;
        }
        (out, ranges)
    }

    /// The same model as the identification's [`Setup`] (constraints
    /// stacked), for the reports built on it.
    pub fn setup(&self) -> Setup {
        let n = self.model.n_params();
        let rows: usize = self.constraints.iter().map(|c| c.len()).sum();
        let mut c = DMatrix::zeros(rows, n);
        let mut names = Vec::new();
        let mut k = 0;
        for (ei, rs) in self.constraints.iter().enumerate() {
            let o = self.model.param_range(ei).start;
            for (row, name) in rs {
                for (j, v) in row.iter().enumerate() {
                    c[(k, o + j)] = *v;
                }
                names.push(name.to_string());
                k += 1;
            }
        }
        Setup {
            model: self.model.clone(),
            constraints: c,
            constraint_names: names,
        }
    }
}

/// Why a fit cannot be made.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FitError {
    /// The forward model cannot serve the model.
    #[error(transparent)]
    Forward(#[from] ForwardError),
    /// The identification cannot start (placement, data).
    #[error(transparent)]
    Identify(#[from] IdentifyError),
    /// The residuals are not finite.
    #[error("the fit failed: the residuals are not finite numbers")]
    NotFinite,
}

/// A fitted model.
#[derive(Clone, Debug)]
pub struct Fit {
    /// The model.
    pub spec: Spec,
    /// Every parameter: the model's, then nuisance and placement.
    pub x: Vec<f64>,
    /// Number of model parameters.
    pub n: usize,
    /// Names of every parameter.
    pub names: Vec<String>,
    /// Residual of each observation, um (measured minus predicted along
    /// the predicted normal).
    pub residuals: Vec<f64>,
    /// Sum of squared residuals, um^2.
    pub rss: f64,
    /// Rank of the design at the nominal machine (free directions seen).
    pub rank: usize,
    /// `(J^T J)^+` (per um^2 of noise) at the estimate, every parameter.
    pub cov_unit: DMatrix<f64>,
    /// The design at the nominal machine.
    pub design: Design,
    /// Per part, the CMM placement (W to CMM) of a machined piece.
    pub placements: Vec<Option<Isometry3<f64>>>,
    /// Whether the fit was iterated until the sum of squares stopped
    /// falling (false for a one-step screening).
    pub converged: bool,
}

impl Fit {
    /// The model parameters.
    pub fn theta(&self) -> &[f64] {
        &self.x[..self.n]
    }

    /// Degrees of freedom of the residuals.
    pub fn dof(&self) -> usize {
        self.residuals.len().saturating_sub(self.rank)
    }

    /// Residual standard deviation, um (NaN without degrees of freedom).
    pub fn sigma(&self) -> f64 {
        match self.dof() {
            0 => f64::NAN,
            d => (self.rss / d as f64).sqrt(),
        }
    }

    /// Whether parameter `i` is identifiable (no unseen direction moves
    /// it; the rule of [`identifiability::report`]).
    pub fn identifiable(&self, i: usize) -> bool {
        (0..self.design.null.ncols()).all(|c| self.design.null[(i, c)].abs() < 1e-7)
    }

    /// Whether model parameter `i` is fixed by the constraints (no free
    /// direction moves it: a value the test does not see, held at zero).
    pub fn fixed(&self, i: usize) -> bool {
        self.spec.fixed(i)
    }

    /// Standard uncertainty of model parameter `i` (residual-scaled),
    /// `None` where the test does not identify it or it is fixed.
    pub fn u(&self, i: usize) -> Option<f64> {
        (self.identifiable(i) && !self.fixed(i))
            .then(|| (self.cov_unit[(i, i)].max(0.0)).sqrt() * self.sigma())
    }

    /// Covariance of the model parameters, residual-scaled.
    pub fn cov(&self) -> DMatrix<f64> {
        let s2 = self.sigma().powi(2);
        self.cov_unit.view((0, 0), (self.n, self.n)).into_owned() * s2
    }

    /// What the test identifies of this model.
    pub fn identifiability(&self) -> Identifiability {
        let setup = self.spec.setup();
        identifiability::report(
            &self.design,
            self.residuals.len(),
            self.n,
            &self.names,
            &setup.constraint_names,
        )
    }
}

/// One part as the fitter holds it.
struct FitPart<'a> {
    data: &'a Dataset,
    fm: Box<dyn ForwardModel>,
    /// Catalogue index of each parameter of the part's model (the location
    /// symbols and the candidates its forward model applies).
    cols: Vec<usize>,
    /// Number of the forward model's own nuisance parameters.
    k: usize,
    p0: Option<Isometry3<f64>>,
    u: Vec<Vector3<f64>>,
    minutes: Vec<f64>,
    /// Its observations' rows.
    rows: Range<usize>,
    /// Its nuisance (and placement) columns, after the catalogue's.
    extra: Range<usize>,
    /// The plan's machine with the gauge length, and the plan.
    kin: Kinematics,
    plan: Option<PlanRef>,
}

/// A part's forward model of one fitted model ([`Fitter::own`]).
struct Own {
    /// Its own, or none for the part's catalogue forward model.
    fm: Option<Box<dyn ForwardModel>>,
    /// The fitted model's parameter of each of the forward model's
    /// ([`UNUSED`]: none, held at zero).
    params: Vec<usize>,
}

impl FitPart<'_> {
    /// The part's residuals (its rows of `r`) with forward model `fm` at
    /// `theta` and the part's nuisance and placement `extra`; `jac` takes
    /// the forward model's parameters, then `extra`, into its columns
    /// `cols` (none if [`UNUSED`]).
    fn eval(
        &self,
        fm: &dyn ForwardModel,
        theta: &[f64],
        extra: &[f64],
        r: &mut [f64],
        mut jac: Option<(&mut DMatrix<f64>, &[usize])>,
    ) -> Result<(), FitError> {
        let nuisance = &extra[..self.k];
        let rho = if self.p0.is_some() {
            let o = &extra[self.k..self.k + 6];
            [o[0], o[1], o[2], o[3], o[4], o[5]]
        } else {
            [0.0; 6]
        };
        let nm = theta.len();
        // Only the columns the fit takes are differentiated: a machining
        // test's model is the whole catalogue (see `Fitter::own`).
        let wanted = match &jac {
            Some((_, cols)) => Wanted::new(fm.model(), |c| cols[c] != UNUSED),
            None => Wanted::new(fm.model(), |_| false),
        };
        for (i, row) in self.rows.clone().enumerate() {
            let point = self.data.point(i);
            let pred = fm.predict_wanted(theta, nuisance, point, self.minutes[i], &wanted)?;
            let fr = face_residual(&rho, &pred.point, &pred.normal, &self.u[i]);
            r[row] = fr.r;
            if let Some((j, cols)) = jac.as_mut() {
                for (c, &col) in cols[..nm + self.k].iter().enumerate() {
                    if col == UNUSED {
                        continue;
                    }
                    let mut v = 0.0;
                    for a in 0..3 {
                        v += fr.d_q[a] * pred.d_point[(a, c)] + fr.d_n[a] * pred.d_normal[(a, c)];
                    }
                    j[(row, col)] = v;
                }
                if self.p0.is_some() {
                    for (a, &col) in cols[nm + self.k..].iter().enumerate() {
                        if col != UNUSED {
                            j[(row, col)] = fr.d_rho[a];
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

/// The measurements prepared once for every fit: each part's catalogue
/// model, forward model and the observed points before the nuisance
/// placement, and the nominal Jacobian of every part together.
pub struct Fitter<'a> {
    parts: Vec<FitPart<'a>>,
    kin: Kinematics,
    /// Parameter range of each catalogue effect.
    ranges: Vec<Range<usize>>,
    n_full: usize,
    /// Catalogue index of each candidate, by candidate name.
    index: std::collections::HashMap<String, usize>,
    /// Forward-model nuisance and placement names, part by part.
    extra_names: Vec<String>,
    n_rows: usize,
    /// `d r / d (theta_full, nuisance, placement)` at the nominal machine.
    j0: DMatrix<f64>,
    /// Least-squares options.
    pub opts: lsq::Options,
    /// Each catalogue effect's constraint basis, made when first needed.
    blocks: Vec<std::sync::OnceLock<Arc<Block>>>,
}

/// The catalogue model a part's forward model takes: the location symbols
/// and the candidates it applies (it names the first it cannot apply,
/// which is left out with the reason).
fn part_model<'c>(
    part: &Part<'_>,
    plan: Option<&PlanRef>,
    location: &[Effect],
    candidates: &[&'c Candidate],
    refused: &mut Vec<(String, String)>,
) -> Result<(Box<dyn ForwardModel>, Vec<&'c Candidate>), FitError> {
    let sym = Model::new(part.kin.clone(), Vec::new()).symbols;
    let mut served: Vec<&Candidate> = candidates.to_vec();
    loop {
        let mut effects = location.to_vec();
        effects.extend(served.iter().map(|c| c.effect.clone()));
        let model = Model::new(part.kin.clone(), effects);
        match forward_model(model, part.data, plan) {
            Ok(fm) => return Ok((fm, served)),
            Err(ForwardError::UnsupportedEffect(id)) => {
                let before = served.len();
                served.retain(|c| {
                    if c.effect.id(&sym) == id {
                        refused.push((
                            c.name.clone(),
                            format!(
                                "the forward model cannot apply it ({})",
                                ForwardError::UnsupportedEffect(id.clone())
                            ),
                        ));
                        false
                    } else {
                        true
                    }
                });
                if served.len() == before {
                    return Err(ForwardError::UnsupportedEffect(id).into());
                }
            }
            Err(e) => return Err(e.into()),
        }
    }
}

impl<'a> Fitter<'a> {
    /// Prepares the measurements of `parts` (one test, or several tests of
    /// one machine fitted together) for the models made of the machine's
    /// location symbols and `candidates`. Returns the candidates no part's
    /// forward model can apply, with the reason; they are left out of the
    /// catalogue model. A candidate some parts apply and others do not (a
    /// tool radius beside a probing run) moves only the measurements of
    /// the parts that apply it.
    pub fn new(
        parts: &[Part<'a>],
        candidates: &[Candidate],
    ) -> Result<(Fitter<'a>, Vec<(String, String)>), FitError> {
        let kin = parts
            .first()
            .expect("a discovery has the measurements of one test at least")
            .kin;
        let sym = Model::new(kin.clone(), Vec::new()).symbols;
        let location: Vec<Effect> = (0..sym.location.len())
            .map(|s| Effect::Location { symbols: vec![s] })
            .collect();
        let all: Vec<&Candidate> = candidates.iter().collect();
        let mut built = Vec::new();
        let mut refusals = Vec::new();
        for part in parts {
            let mut refused = Vec::new();
            let plan = part.plan.map(PlanRef::new);
            let (fm, served) = part_model(part, plan.as_ref(), &location, &all, &mut refused)?;
            built.push((fm, served, plan));
            refusals.push(refused);
        }
        // The catalogue: every candidate some part applies, in catalogue
        // order; one no part applies is refused with the first part's
        // reason.
        let served: Vec<&Candidate> = all
            .iter()
            .copied()
            .filter(|c| {
                built
                    .iter()
                    .any(|(_, s, _)| s.iter().any(|x| x.name == c.name))
            })
            .collect();
        let refused: Vec<(String, String)> = refusals
            .into_iter()
            .next()
            .unwrap_or_default()
            .into_iter()
            .filter(|(n, _)| !served.iter().any(|c| &c.name == n))
            .collect();
        let mut full = location;
        full.extend(served.iter().map(|c| c.effect.clone()));
        let count = full.len();
        let model = Model::new(kin.clone(), full);
        let ranges: Vec<Range<usize>> = (0..count).map(|i| model.param_range(i)).collect();
        let n_full = model.n_params();
        let index: std::collections::HashMap<String, usize> = served
            .iter()
            .enumerate()
            .map(|(i, c)| (c.name.clone(), sym.location.len() + i))
            .collect();
        let mut fparts = Vec::new();
        let mut extra_names = Vec::new();
        let mut rows = 0;
        for (part, (fm, part_served, plan)) in parts.iter().zip(built) {
            let mut cols: Vec<usize> = (0..sym.location.len())
                .flat_map(|s| ranges[s].clone())
                .collect();
            for c in &part_served {
                cols.extend(ranges[index[&c.name]].clone());
            }
            let Observed { p0, u, minutes } = observed(part.data)?;
            let mut names = fm.nuisance_names();
            let k = names.len();
            if p0.is_some() {
                names.extend(PLACEMENT_NAMES.iter().map(|s| s.to_string()));
            }
            if parts.len() > 1 {
                names = names
                    .into_iter()
                    .map(|n| format!("{}:{n}", part.label))
                    .collect();
            }
            let extra = extra_names.len()..extra_names.len() + names.len();
            extra_names.extend(names);
            let n = u.len();
            fparts.push(FitPart {
                data: part.data,
                fm,
                cols,
                k,
                p0,
                u,
                minutes,
                rows: rows..rows + n,
                extra,
                kin: part.kin.clone(),
                plan,
            });
            rows += n;
        }
        let mut f = Fitter {
            parts: fparts,
            kin: kin.clone(),
            ranges,
            n_full,
            index,
            extra_names,
            n_rows: rows,
            j0: DMatrix::zeros(0, 0),
            opts: lsq::Options::default(),
            blocks: (0..count).map(|_| std::sync::OnceLock::new()).collect(),
        };
        let mut r = vec![0.0; f.len()];
        let mut j = DMatrix::zeros(f.len(), n_full + f.extra());
        let every: Vec<usize> = (0..n_full + f.extra()).collect();
        f.eval_full(
            &vec![0.0; n_full + f.extra()],
            &mut r,
            Some((&mut j, &every)),
        )?;
        f.j0 = j;
        Ok((f, refused))
    }

    /// Number of observations.
    pub fn len(&self) -> usize {
        self.n_rows
    }

    /// Whether there are no observations.
    pub fn is_empty(&self) -> bool {
        self.n_rows == 0
    }

    /// Number of nuisance parameters (forward models' and placements).
    pub fn extra(&self) -> usize {
        self.extra_names.len()
    }

    /// Whether the catalogue model holds the candidate `name`.
    pub fn serves(&self, name: &str) -> bool {
        self.index.contains_key(name)
    }

    /// A model of location symbols `symbols` (indices into the machine's).
    pub fn location(&self, symbols: &[usize]) -> Spec {
        let mut model = Model::new(self.kin.clone(), Vec::new());
        model.push(Effect::Location {
            symbols: symbols.to_vec(),
        });
        Spec {
            model,
            names: vec!["location".into()],
            constraints: vec![Vec::new()],
            full: symbols.iter().map(|&s| self.ranges[s].start).collect(),
            blocks: vec![Block::new(symbols.len(), &[])],
        }
    }

    /// `spec` with candidate `c` appended (`None` if the catalogue model
    /// does not hold it).
    pub fn extend(&self, spec: &Spec, c: &Candidate) -> Option<Spec> {
        let &i = self.index.get(&c.name)?;
        let mut s = spec.clone();
        s.model.push(c.effect.clone());
        s.names.push(c.name.clone());
        s.constraints.push(c.constraints.clone());
        s.blocks.push(
            self.blocks[i]
                .get_or_init(|| Block::new(self.ranges[i].len(), &c.constraints))
                .clone(),
        );
        s.full.extend(self.ranges[i].clone());
        Some(s)
    }

    /// Names of every parameter of `spec`, then the nuisance.
    pub fn names(&self, spec: &Spec) -> Vec<String> {
        let mut names = spec.model.param_names();
        names.extend(self.extra_names.iter().cloned());
        names
    }

    /// The catalogue columns of `spec`'s parameters, then the nuisance.
    fn columns(&self, spec: &Spec) -> Vec<usize> {
        spec.full
            .iter()
            .copied()
            .chain(self.n_full..self.n_full + self.extra())
            .collect()
    }

    /// What candidate `name` with parameters `values` does to the
    /// measurements at the nominal machine, to first order.
    pub fn signal(&self, name: &str, values: &[f64]) -> Option<DVector<f64>> {
        let r = self.ranges[*self.index.get(name)?].clone();
        if r.len() != values.len() {
            return None;
        }
        Some(self.j0.columns(r.start, r.len()) * DVector::from_column_slice(values))
    }

    /// The nominal Jacobian's columns of `spec` (and the nuisance).
    pub(crate) fn jacobian0(&self, spec: &Spec) -> DMatrix<f64> {
        let cols = self.columns(spec);
        DMatrix::from_fn(self.len(), cols.len(), |r, c| self.j0[(r, cols[c])])
    }

    /// The design of `spec` at the nominal machine, its constraint basis
    /// and the basis columns of each effect.
    pub fn design(&self, spec: &Spec) -> (Design, DMatrix<f64>, Vec<Range<usize>>) {
        let (basis, ranges) = spec.basis(self.extra());
        let j = self.jacobian0(spec);
        let jm = Mat::<f64>::from_fn(j.nrows(), j.ncols(), |r, c| j[(r, c)]);
        (
            lsq::design(&jm, Some(&basis), self.opts.rank_rtol),
            basis,
            ranges,
        )
    }

    /// Residuals (and the Jacobian) of the catalogue model at `x` (its
    /// parameters, then each part's nuisance and placement); `jac` takes
    /// the catalogue's column `c` into its column `map[c]` (none if
    /// [`UNUSED`]).
    fn eval_full(
        &self,
        x: &[f64],
        r: &mut [f64],
        mut jac: Option<(&mut DMatrix<f64>, &[usize])>,
    ) -> Result<(), FitError> {
        let n = self.n_full;
        for part in &self.parts {
            let theta: Vec<f64> = part.cols.iter().map(|&c| x[c]).collect();
            let e = n + part.extra.start;
            let cols: Vec<usize> = match &jac {
                Some((_, map)) => part
                    .cols
                    .iter()
                    .copied()
                    .chain(e..e + part.extra.len())
                    .map(|c| map[c])
                    .collect(),
                None => Vec::new(),
            };
            let j = jac.as_mut().map(|(j, _)| (&mut **j, cols.as_slice()));
            part.eval(&*part.fm, &theta, &x[e..e + part.extra.len()], r, j)?;
        }
        if r.iter().any(|v| !v.is_finite()) {
            return Err(FitError::NotFinite);
        }
        Ok(())
    }

    /// Each part's forward model of `spec` alone (the effects of it the
    /// part applies), and the spec's parameter of each of its parameters:
    /// an evaluation then costs what the model does, not what the whole
    /// catalogue does. Every other effect of the catalogue is at zero in
    /// the model's fits, where it adds nothing. A machining test keeps the
    /// catalogue's forward model (see below).
    fn own(&self, spec: &Spec) -> Result<Vec<Own>, FitError> {
        self.parts
            .iter()
            .map(|part| {
                if let Some(PlanRef::Machining(_)) = part.plan {
                    // A cut's surface is built with the breaks of every
                    // effect of its model (straightness nodes, the clock of
                    // a drift per minute): the catalogue's, with which the
                    // candidates are scored, serves.
                    let mut params = vec![UNUSED; part.cols.len()];
                    for (i, &c) in spec.full.iter().enumerate() {
                        if let Some(k) = part.cols.iter().position(|&p| p == c) {
                            params[k] = i;
                        }
                    }
                    return Ok(Own { fm: None, params });
                }
                let mut effects = Vec::new();
                let mut params = Vec::new();
                for (ei, e) in spec.model.effects.iter().enumerate() {
                    let r = spec.model.param_range(ei);
                    let applies = matches!(e, Effect::Location { .. })
                        || r.is_empty()
                        || part.cols.contains(&spec.full[r.start]);
                    if applies {
                        effects.push(e.clone());
                        params.extend(r);
                    }
                }
                let model = Model::new(part.kin.clone(), effects);
                Ok(Own {
                    fm: Some(forward_model(model, part.data, part.plan.as_ref())?),
                    params,
                })
            })
            .collect()
    }

    /// Residuals (and the Jacobian, the spec's columns) of `spec` at its
    /// parameters `x`, with its own forward models ([`Fitter::own`]).
    fn eval_own(
        &self,
        spec: &Spec,
        own: &[Own],
        x: &[f64],
        r: &mut [f64],
        mut jac: Option<&mut DMatrix<f64>>,
    ) -> Result<(), FitError> {
        let n = spec.model.n_params();
        for (part, o) in self.parts.iter().zip(own) {
            let theta: Vec<f64> = o
                .params
                .iter()
                .map(|&c| if c == UNUSED { 0.0 } else { x[c] })
                .collect();
            let e = n + part.extra.start;
            let cols: Vec<usize> = o
                .params
                .iter()
                .copied()
                .chain(e..e + part.extra.len())
                .collect();
            let j = jac.as_deref_mut().map(|j| (j, cols.as_slice()));
            let fm = o.fm.as_deref().unwrap_or(&*part.fm);
            part.eval(fm, &theta, &x[e..e + part.extra.len()], r, j)?;
        }
        if r.iter().any(|v| !v.is_finite()) {
            return Err(FitError::NotFinite);
        }
        Ok(())
    }

    /// The catalogue vector of `spec`'s parameters `x`.
    fn scatter(&self, spec: &Spec, x: &[f64]) -> Vec<f64> {
        let mut full = vec![0.0; self.n_full + self.extra()];
        for (c, v) in self.columns(spec).into_iter().zip(x) {
            full[c] = *v;
        }
        full
    }

    /// Residuals and Jacobian (the spec's columns) at `x`.
    fn eval_jac(
        &self,
        spec: &Spec,
        own: &[Own],
        x: &[f64],
    ) -> Result<(Vec<f64>, DMatrix<f64>), FitError> {
        let mut r = vec![0.0; self.len()];
        let mut j = DMatrix::zeros(self.len(), x.len());
        self.eval_own(spec, own, x, &mut r, Some(&mut j))?;
        Ok((r, j))
    }

    fn finish(
        &self,
        spec: &Spec,
        x: Vec<f64>,
        residuals: Vec<f64>,
        design: Design,
        cov_unit: DMatrix<f64>,
        converged: bool,
    ) -> Fit {
        let n = spec.model.n_params();
        let placements = self
            .parts
            .iter()
            .map(|p| {
                let o = n + p.extra.start + p.k;
                p.p0.map(|p0| p0 * d6_um(&x[o..o + 6]))
            })
            .collect();
        let rss = residuals.iter().map(|v| v * v).sum();
        Fit {
            spec: spec.clone(),
            names: self.names(spec),
            n,
            residuals,
            rss,
            rank: design.rank,
            cov_unit,
            design,
            placements,
            converged,
            x,
        }
    }

    /// Fits `spec` exactly, from `start` (its parameters, e.g. a smaller
    /// model's estimate padded with zeros; they must satisfy the
    /// constraints) or from the nominal machine, by the damped Gauss-Newton
    /// of [`lsq::solve_ranked`] along the directions the nominal design
    /// sees. The covariance is taken at the estimate.
    ///
    /// The damping matters: a test can see a direction only through terms
    /// of the order of the errors (a piece turned about its probed face
    /// points, seen a ten-millionth as well as the rest), and an undamped
    /// step sends such a direction metres away, where the linearization
    /// no longer holds and a line search along the step gains almost
    /// nothing: the fit would stop far from the minimum.
    pub fn fit(&self, spec: &Spec, start: Option<Vec<f64>>) -> Result<Fit, FitError> {
        let (d, basis, _) = self.design(spec);
        self.fit_designed(spec, d, &basis, start, None)
    }

    /// [`Fitter::fit`] with `spec`'s design at the nominal machine and its
    /// constraint basis as [`Fitter::design`] made them: a candidate is
    /// fitted with the design its identifiability was judged on, not one
    /// made again (for a map over C, the design costs what its fit does).
    ///
    /// `from`: the round whose base `start` is (`spec` that base with
    /// effects at zero appended), when the fit starts there: its
    /// linearization is then the fit's first evaluation (the same numbers,
    /// where every part is machined and so evaluated with the catalogue's
    /// model either way).
    pub(crate) fn fit_designed(
        &self,
        spec: &Spec,
        d: Design,
        basis: &DMatrix<f64>,
        start: Option<Vec<f64>>,
        from: Option<&Screen>,
    ) -> Result<Fit, FitError> {
        let p = spec.model.n_params() + self.extra();
        let x0 = start.unwrap_or_else(|| vec![0.0; p]);
        let own = self.own(spec)?;
        let first = from
            .filter(|_| own.iter().all(|o| o.fm.is_none()))
            .map(|screen| {
                let cols = self.columns(spec);
                let j = DMatrix::from_fn(self.len(), cols.len(), |r, c| screen.lin.j[(r, cols[c])]);
                (x0.clone(), screen.lin.r.clone(), j)
            });
        let problem = SpecProblem {
            fitter: self,
            spec,
            own: &own,
            last: RefCell::new(first),
        };
        // The start must evaluate: a failure there is the fit's; later, a
        // trial that fails is a step the damping shortens.
        problem.evaluate(&x0)?;
        let opts = lsq::Options {
            ftol: GAIN_IN_VARIANCES / self.len().max(1) as f64,
            stop_on_prediction: true,
            adapt_damping: true,
            ..self.opts
        };
        let sol = lsq::solve_ranked(&problem, &x0, Some(basis), &opts, Some(d.rank));
        let (r, j) = problem.evaluate(&sol.x)?;
        let jm = Mat::<f64>::from_fn(j.nrows(), j.ncols(), |a, b| j[(a, b)]);
        let cov = lsq::covariance_ranked(&jm, Some(basis), self.opts.rank_rtol, Some(d.rank));
        Ok(self.finish(spec, sol.x, r, d, cov, sol.converged))
    }

    /// The catalogue model's residuals and Jacobian at `fit`'s estimate
    /// (every other effect at zero): every candidate's columns there.
    pub(crate) fn linearize(&self, fit: &Fit) -> Result<Linearization, FitError> {
        let x = self.scatter(&fit.spec, &fit.x);
        let mut r = vec![0.0; self.len()];
        let mut j = DMatrix::zeros(self.len(), x.len());
        let every: Vec<usize> = (0..x.len()).collect();
        self.eval_full(&x, &mut r, Some((&mut j, &every)))?;
        Ok(Linearization { r, j })
    }
}

/// The gain of a Gauss-Newton step, in variances of one residual, below
/// which a fit has converged: a step that gains `g` variances moves the
/// parameters by about `sqrt(g)` standard uncertainties, so this is a
/// thousandth of one (the next step of a converging fit gains less).
const GAIN_IN_VARIANCES: f64 = 1e-6;

/// `spec`'s fit as a least-squares problem. Its forward models give the
/// Jacobian with every prediction, so each evaluation keeps it: the
/// solver asks for it at the point it has just accepted.
struct SpecProblem<'f, 'a> {
    fitter: &'f Fitter<'a>,
    spec: &'f Spec,
    own: &'f [Own],
    last: RefCell<Option<Evaluation>>,
}

/// A point and the residuals and Jacobian there.
type Evaluation = (Vec<f64>, Vec<f64>, DMatrix<f64>);

impl SpecProblem<'_, '_> {
    /// Residuals and Jacobian at `x`, from the last evaluation when it was
    /// there.
    fn evaluate(&self, x: &[f64]) -> Result<(Vec<f64>, DMatrix<f64>), FitError> {
        if let Some((lx, r, j)) = self.last.borrow().as_ref()
            && lx.as_slice() == x
        {
            return Ok((r.clone(), j.clone()));
        }
        let (r, j) = self.fitter.eval_jac(self.spec, self.own, x)?;
        *self.last.borrow_mut() = Some((x.to_vec(), r.clone(), j.clone()));
        Ok((r, j))
    }
}

impl lsq::Problem for SpecProblem<'_, '_> {
    fn n_residuals(&self) -> usize {
        self.fitter.len()
    }

    fn n_params(&self) -> usize {
        self.spec.model.n_params() + self.fitter.extra()
    }

    fn eval(&self, x: &[f64], r: &mut [f64], jac: Option<&mut Mat<f64>>) {
        match self.evaluate(x) {
            Ok((rv, j)) => {
                r.copy_from_slice(&rv);
                if let Some(jm) = jac {
                    for c in 0..j.ncols() {
                        for a in 0..j.nrows() {
                            jm[(a, c)] = j[(a, c)];
                        }
                    }
                }
            }
            // A point where the model cannot be evaluated (a probe that
            // misses its face) is a step the solver rejects.
            Err(_) => r.fill(f64::NAN),
        }
    }
}

/// A Jacobian column no output column takes.
const UNUSED: usize = usize::MAX;

/// The current model factorized once for a round of the candidate scan:
/// the catalogue model linearized at its estimate, the orthonormal basis of
/// what the model (with the nuisance) does there, and the residuals with
/// what it could still absorb removed.
///
/// A candidate adds columns `C` to the model's design `B`. The one
/// Gauss-Newton step of the extended model from the estimate minimises
/// `|r + B db + C dc|`; its candidate part is the regression of the
/// residuals on the part of `C` orthogonal to `B` (Frisch, Waugh and
/// Lovell), and the residuals it leaves are those with their projection
/// on that part removed. So every candidate of a round is scored with
/// the one factorization of `B` and a product and a small SVD of its own
/// columns, instead of a factorization of the whole extended design.
#[derive(Clone, Debug)]
pub struct Screen {
    lin: Linearization,
    q: DMatrix<f64>,
    r: DVector<f64>,
}

/// A candidate scored by the update of [`Screen`]: what one Gauss-Newton
/// step of the extended model from the current estimate reaches.
#[derive(Clone, Debug, PartialEq)]
pub struct Screened {
    /// The residuals the step leaves, um.
    pub residuals: Vec<f64>,
    /// Their sum of squares, um^2.
    pub rss: f64,
    /// The candidate's parameters.
    pub values: Vec<f64>,
}

impl Fitter<'_> {
    /// Factorizes `base` (a converged fit) once for a round of
    /// [`Fitter::score`].
    pub fn screen(&self, base: &Fit) -> Result<Screen, FitError> {
        let lin = self.linearize(base)?;
        let (basis, _) = base.spec.basis(self.extra());
        let cols = self.columns(&base.spec);
        let jm = Mat::<f64>::from_fn(self.len(), cols.len(), |r, c| lin.j[(r, cols[c])]);
        let q = lsq::column_basis(&jm, Some(&basis), self.opts.rank_rtol, Some(base.rank));
        let r0 = DVector::from_column_slice(&lin.r);
        let r = &r0 - &q * q.tr_mul(&r0);
        Ok(Screen { lin, q, r })
    }

    /// Scores `spec` (the model of `screen` with one effect appended, its
    /// last) by the update: `added` is the number of directions the effect
    /// adds to the model's design at the nominal machine (the rank
    /// increase), the number of directions of its own the step moves
    /// along.
    pub fn score(&self, screen: &Screen, spec: &Spec, added: usize) -> Screened {
        let ei = spec.names.len() - 1;
        let xr = spec.model.param_range(ei);
        let block = spec.block(ei);
        let n = self.len();
        let jc = DMatrix::from_fn(n, xr.len(), |r, c| {
            screen.lin.j[(r, spec.full[xr.start + c])]
        });
        let mut c = jc * &block.basis;
        // Columns scaled to unit length, as the designs are; round-off
        // columns are nothing the test sees.
        let norms: Vec<f64> = c.column_iter().map(|v| v.norm()).collect();
        let max = norms.iter().copied().fold(0.0, f64::max);
        let mut scale = vec![0.0; c.ncols()];
        for (k, mut col) in c.column_iter_mut().enumerate() {
            if norms[k] > 1e-12 * max {
                scale[k] = norms[k];
                col /= norms[k];
            } else {
                col.fill(0.0);
            }
        }
        let c = &c - &screen.q * screen.q.tr_mul(&c);
        let k = c.ncols();
        let svd = c.svd(true, true);
        let (u, vt) = (svd.u.expect("asked for U"), svd.v_t.expect("asked for V"));
        let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
        order.sort_by(|&a, &b| svd.singular_values[b].total_cmp(&svd.singular_values[a]));
        let mut residuals = screen.r.clone();
        let mut z = DVector::zeros(k);
        for &k in order.iter().take(added) {
            let s = svd.singular_values[k];
            if s <= 0.0 {
                continue;
            }
            let uk = u.column(k);
            let a = uk.dot(&screen.r);
            residuals -= uk * a;
            z -= vt.row(k).transpose() * (a / s);
        }
        for (k, zk) in z.iter_mut().enumerate() {
            *zk = if scale[k] > 0.0 { *zk / scale[k] } else { 0.0 };
        }
        let values = (&block.basis * z).as_slice().to_vec();
        Screened {
            rss: residuals.norm_squared(),
            residuals: residuals.as_slice().to_vec(),
            values,
        }
    }
}

/// The catalogue model linearized at an estimate.
#[derive(Clone, Debug)]
pub struct Linearization {
    r: Vec<f64>,
    j: DMatrix<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Machine;

    /// Rows added to a block leave free what the stacked rows leave free
    /// (the same projector onto the free directions, within round-off),
    /// with orthonormal directions; whether the added rows lie among the
    /// free directions (the unseen combinations a design finds) or not,
    /// and whether they repeat a direction already fixed.
    #[test]
    fn rows_added_to_a_block_free_what_the_stacked_rows_free() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let why = || Why::Text("test".into());
        for (n, first, more, within) in [
            (12, 2, 3, false),
            (40, 4, 20, true),
            (60, 0, 45, true),
            (30, 5, 6, false),
        ] {
            let mut row = |_| {
                (0..n)
                    .map(|_| rng.random_range(-1.0..1.0))
                    .collect::<Vec<f64>>()
            };
            let old: Vec<ConstraintRow> = (0..first).map(|i| (row(i), why())).collect();
            let block = Block::new(n, &old);
            let mut added: Vec<ConstraintRow> = (0..more)
                .map(|i| {
                    let r = row(i);
                    if !within {
                        return (r, why());
                    }
                    // Within the free directions, as an unseen combination is.
                    let v = &block.basis * (block.basis.transpose() * DVector::from_vec(r));
                    (v.iter().copied().collect(), why())
                })
                .collect();
            // One repeats a fixed direction (or an added one).
            let again = old.first().or(added.first()).unwrap().0.clone();
            added.push((again, why()));
            let ext = block.extended(&added);
            let mut all = old.clone();
            all.extend(added.iter().cloned());
            let stacked = Block::new(n, &all);
            assert_eq!(
                ext.basis.ncols(),
                stacked.basis.ncols(),
                "{n} {first} {more}"
            );
            let p = |b: &DMatrix<f64>| b * b.transpose();
            assert!((p(&ext.basis) - p(&stacked.basis)).amax() < 1e-10);
            let gram = ext.basis.transpose() * &ext.basis;
            assert!(
                (gram - DMatrix::identity(ext.basis.ncols(), ext.basis.ncols())).amax() < 1e-12
            );
            assert!(ext.holds(&all));
        }
    }

    #[test]
    fn basis_is_block_diagonal_and_respects_each_effects_constraints() {
        let kin = Kinematics::new(&Machine::builtin("bc-trunnion").unwrap());
        let mut model = Model::new(kin, Vec::new());
        model.push(Effect::Location {
            symbols: vec![0, 1],
        });
        let grid = crate::kinematics::maps::MapGrid {
            dims: vec![
                crate::kinematics::maps::MapDim::new(0, &[-90.0, 0.0, 90.0], false).unwrap(),
            ],
        };
        model.push(Effect::Map { symbol: 4, grid });
        let spec = Spec {
            model,
            names: vec!["location".into(), "map.EBB(B)".into()],
            constraints: vec![
                Vec::new(),
                vec![(vec![1.0, 1.0, 1.0], Why::Text("averages to zero".into()))],
            ],
            full: (0..5).collect(),
            blocks: Vec::new(),
        };
        let (b, ranges) = spec.basis(6);
        assert_eq!(b.shape(), (2 + 3 + 6, 2 + 2 + 6));
        assert_eq!(ranges, vec![0..2, 2..4]);
        // Orthonormal columns; the map's span its own rows and sum to zero.
        assert!((b.transpose() * &b - DMatrix::identity(10, 10)).norm() < 1e-12);
        for c in 2..4 {
            let col = b.column(c);
            assert!(col.rows(0, 2).norm() < 1e-15 && col.rows(5, 6).norm() < 1e-15);
            assert!(col.rows(2, 3).sum().abs() < 1e-12);
        }
        assert_eq!(spec.setup().constraints.shape(), (1, 5));
    }
}
