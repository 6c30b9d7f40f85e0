//! The Monte Carlo at the speed of linear algebra (`analyze --mc`).
//!
//! At the errors a machine has (micrometres against a test piece of tens of
//! millimetres) both halves of a Monte-Carlo run are linear in what it
//! draws. The measurement: each measured point moves along its measuring
//! line (the nominal normal a CMM probes along, the line a probe travels)
//! by `S c + e`, `c` the drawn contributors (linear-axis errors, the
//! probe's pre-travel, the pieces' setups) and `e` the noise; `S` is the
//! simulator's forward model's Jacobian ([`crate::simulate::forward`]: which
//! cuts or touches make which point, taken once) at the estimate. The
//! re-identification: the estimate moves by `G (S c + e)`, `G` the global
//! fit's own first-order response ([`crate::identify::global::response`],
//! the Gauss-Newton step with the factorization of the fit already made).
//! A run is then a draw and two small matrix products. The other methods
//! are re-simulated: the sphere method's robust circle fits are not smooth
//! in the data, and central differences of them ([`finite_difference_gain`],
//! which the tests use to check `G`) do not predict a draw's effect.
//!
//! A straightness drawn on nodes 20 to 50 mm apart is taken on a 1 mm grid
//! over the stretch of each axis the test uses (linear in between, as the
//! model interpolates): at the slopes the contributors give (4 um over
//! 20 mm at most) the grid misses a kink by at most 0.05 um. What a
//! linear study cannot draw, the study refuses with the reason
//! ([`LinearStudy::new`]) and `analyze` re-simulates instead.
//!
//! The exact study ([`super::simulated`], `--mc-exact`) stays the
//! reference: the tests set each run of this one beside an exact run of the
//! same draw.

use std::sync::Arc;

use nalgebra::{DMatrix, DVector, Isometry3, Vector3};
use rand::Rng;
use rand_distr::{Distribution, Normal};
use rayon::prelude::*;

use super::{Contributors, Estimate};
use crate::analyze::method::{identify_with_plan, needs_plan};
use crate::formats::manifest::TestKind;
use crate::geom::Axis3;
use crate::identify::IdentifyError;
use crate::identify::forward::ForwardError;
use crate::identify::forward::ForwardModel;
use crate::identify::{self, Dataset, Method, Setup, lsq};
use crate::kinematics::Kinematics;
use crate::kinematics::maps::MapDim;
use crate::model::{Effect, Model, Squareness};
use crate::procedure::Plan;
use crate::simulate::forward::{MachiningForward, ProbingForward};

/// Spacing of the grid a drawn straightness is taken on, mm.
const STRAIGHTNESS_STEP_MM: f64 = 1.0;
/// Spacing of the first pass that finds the stretch of each axis the test
/// uses, mm.
const COARSE_STEP_MM: f64 = 20.0;
/// Shift of a measured point for the central differences, um: well inside
/// the linear range, far above the methods' convergence.
const FD_STEP_UM: f64 = 0.5;

/// Where the contributors sit among the columns of `S`.
#[derive(Clone, Debug, Default)]
pub(super) struct ColumnLayout {
    /// First column of the scale errors of X, Y, Z.
    pub(super) scale: Option<usize>,
    /// First column of the squareness errors ([`Squareness::ALL`]).
    pub(super) squareness: Option<usize>,
    /// Per straightness: moving axis, direction, grid nodes, first column.
    pub(super) straightness: Vec<(Axis3, Axis3, Vec<f64>, usize)>,
    /// First column of the six pre-travel values.
    pub(super) pretravel: Option<usize>,
    /// First column of the pieces' setups (the forward model's nuisance).
    pub(super) setup: Option<usize>,
    /// Number of columns.
    len: usize,
}

/// Why a linearized study cannot serve a plan (`analyze` then simulates
/// every run and says why), or why one of its runs failed.
#[derive(Debug, thiserror::Error)]
pub enum NotLinearized {
    /// A method whose estimate is not a smooth function of the data.
    #[error(
        "only the global fit's response is linearized, not the {0} method's (the sphere method's robust fits are not smooth in the data)"
    )]
    Method(Method),
    /// A contributor drawn as a new random shape on every run.
    #[error(
        "the sphere's form error is a new random shape every run, which a linear study does not draw"
    )]
    SphereForm,
    /// The simulator's forward model cannot serve the plan.
    #[error(transparent)]
    Forward(#[from] ForwardError),
    /// A measured point the plan does not touch.
    #[error("`{0}` is not a touch of the plan")]
    NotATouch(String),
    /// The global fit's response could not be taken.
    #[error(transparent)]
    Identify(#[from] IdentifyError),
    /// A drawn effect the study has no column for.
    #[error("the study has no column for {0}")]
    NoColumn(String),
    /// Fewer drawn values than the drawn effects take.
    #[error("fewer values than the effects take")]
    FewerValues,
    /// The measurement noise cannot be drawn with this spread.
    #[error("the noise's spread: {0}")]
    Noise(String),
}

/// The forward model of a plan, kept concrete for what only one kind has.
enum Forward {
    Machining(MachiningForward),
    Probing(ProbingForward),
}

impl Forward {
    fn new(model: &Model, plan: &Plan) -> Result<Forward, NotLinearized> {
        Ok(match plan {
            Plan::Machining(t) => {
                Forward::Machining(MachiningForward::new(model, Arc::new((**t).clone()))?)
            }
            Plan::Probing(p) => {
                Forward::Probing(ProbingForward::new(model, Arc::new((**p).clone()))?)
            }
        })
    }

    fn model(&self) -> &dyn ForwardModel {
        match self {
            Forward::Machining(f) => f,
            Forward::Probing(f) => f,
        }
    }
}

/// The contributor effects a study draws, on the given straightness grids.
fn contributor_effects(
    c: &Contributors,
    probing: bool,
    grids: &[(Axis3, Axis3, Vec<f64>)],
) -> (Vec<Effect>, ColumnLayout) {
    let mut effects = Vec::new();
    let mut layout = ColumnLayout::default();
    let mut col = 0;
    if c.linear_scale_um_per_m > 0.0 {
        layout.scale = Some(col);
        for axis in [Axis3::X, Axis3::Y, Axis3::Z] {
            effects.push(Effect::Scale { axis });
        }
        col += 3;
    }
    if c.squareness_urad > 0.0 {
        layout.squareness = Some(col);
        for kind in Squareness::ALL {
            effects.push(Effect::Squareness { kind });
        }
        col += 3;
    }
    if c.straightness_um > 0.0 {
        for (moving, direction, nodes) in grids {
            layout
                .straightness
                .push((*moving, *direction, nodes.clone(), col));
            col += nodes.len();
            effects.push(Effect::Straightness {
                moving: *moving,
                direction: *direction,
                nodes: nodes.clone(),
            });
        }
    }
    if probing && c.pretravel_um > 0.0 {
        layout.pretravel = Some(col);
        col += Effect::ProbePretravel.n_params();
        effects.push(Effect::ProbePretravel);
    }
    layout.len = col;
    (effects, layout)
}

/// Nodes `step` apart from `lo` to beyond `hi`.
fn grid(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    let n = ((hi - lo) / step).ceil().max(1.0) as usize;
    (0..=n).map(|i| lo + step * i as f64).collect()
}

/// Every straightness of the contributors (each linear axis in the two
/// others) on a grid of `step` over its stroke (program coordinates, as the
/// contributors draw it).
fn stroke_grids(kin: &Kinematics, step: f64) -> Vec<(Axis3, Axis3, Vec<f64>)> {
    let m = kin.machine();
    let mut out = Vec::new();
    for moving in [Axis3::X, Axis3::Y, Axis3::Z] {
        let i = moving.index();
        let (lo, hi) = (m.strokes[i].0 - m.pivot[i], m.strokes[i].1 - m.pivot[i]);
        for direction in [Axis3::X, Axis3::Y, Axis3::Z] {
            if direction != moving {
                out.push((moving, direction, grid(lo, hi, step)));
            }
        }
    }
    out
}

/// The unit direction each measured point moves along, in the frame the
/// identification compares in: the nominal normal of a machined point (the
/// CMM probes along it), the travel of a probing touch.
fn measuring_lines(fw: &Forward, data: &Dataset) -> Result<Vec<Vector3<f64>>, NotLinearized> {
    (0..data.obs.len())
        .map(|k| {
            let p = data.point(k);
            match fw {
                Forward::Machining(_) => Ok(p.n.normalize()),
                Forward::Probing(f) => f
                    .line_direction(&p.label)
                    .ok_or_else(|| NotLinearized::NotATouch(p.label.clone())),
            }
        })
        .collect()
}

/// The minutes of each observation's pose, as the fits take them.
fn pose_minutes(data: &Dataset) -> Vec<f64> {
    let mut minutes = vec![0.0; data.obs.len()];
    for pose in &data.poses {
        for &k in &pose.obs {
            minutes[k] = pose.minutes;
        }
    }
    minutes
}

/// `S`: the shift of each measured point along its line (um) per unit of
/// each column (the contributor effects after the model's own parameters,
/// then the forward model's nuisance when `with_setup`).
fn sensitivity(
    fw: &Forward,
    data: &Dataset,
    theta: &[f64],
    lines: &[Vector3<f64>],
    first: usize,
    with_setup: bool,
) -> Result<DMatrix<f64>, NotLinearized> {
    let fm = fw.model();
    let np = fm.model().n_params();
    let nk = fm.nuisance_names().len();
    let cols = np - first + if with_setup { nk } else { 0 };
    let nuisance = vec![0.0; nk];
    let minutes = pose_minutes(data);
    let rows: Vec<Result<Vec<f64>, NotLinearized>> = (0..data.obs.len())
        .into_par_iter()
        .map(|k| {
            let pred = fm.predict(theta, &nuisance, data.point(k), minutes[k])?;
            Ok((0..cols)
                .map(|c| {
                    let j = first + c;
                    let d = Vector3::new(
                        pred.d_point[(0, j)],
                        pred.d_point[(1, j)],
                        pred.d_point[(2, j)],
                    );
                    lines[k].dot(&d) * 1e3
                })
                .collect())
        })
        .collect();
    let mut s = DMatrix::zeros(data.obs.len(), cols);
    for (k, row) in rows.into_iter().enumerate() {
        for (c, v) in row?.into_iter().enumerate() {
            s[(k, c)] = v;
        }
    }
    Ok(s)
}

/// The response of an identification method to its data measured by
/// central differences: column `k` is how the estimate moves (per um) when
/// measured point `k` moves along `lines[k]` (given in the frame the
/// identification compares in; a machined piece's points are moved on the
/// CMM through its placement). Zero where a parameter is not identifiable.
pub fn finite_difference_gain(
    method: Method,
    setup: &Setup,
    data: &Dataset,
    sphere: &identify::sphere::SphereOptions,
    plan: Option<&Plan>,
    lines: &[Vector3<f64>],
) -> Result<DMatrix<f64>, IdentifyError> {
    let rotation = match data.kind {
        TestKind::Machining => identify::initial_placement(data)?
            .rotation
            .to_rotation_matrix()
            .into_inner(),
        TestKind::Probing => nalgebra::Matrix3::identity(),
    };
    let n = setup.model.n_params();
    let cols: Vec<Result<Vec<f64>, IdentifyError>> = (0..data.obs.len())
        .into_par_iter()
        .map(|k| {
            let shifted = |h: f64| -> Result<Vec<f64>, IdentifyError> {
                let mut d = data.clone();
                d.obs[k].m += rotation * lines[k] * (h * 1e-3);
                let r = identify_with_plan(method, setup, &d, sphere, plan)?;
                Ok(r.estimates_or_nan())
            };
            let (a, b) = (shifted(FD_STEP_UM)?, shifted(-FD_STEP_UM)?);
            Ok(a.iter()
                .zip(&b)
                .map(|(x, y)| {
                    let g = (x - y) / (2.0 * FD_STEP_UM);
                    if g.is_finite() { g } else { 0.0 }
                })
                .collect())
        })
        .collect();
    let mut g = DMatrix::zeros(n, data.obs.len());
    for (k, col) in cols.into_iter().enumerate() {
        for (i, v) in col?.into_iter().enumerate() {
            g[(i, k)] = v;
        }
    }
    Ok(g)
}

/// A linearized Monte-Carlo study of one identification (see the module
/// documentation).
pub struct LinearStudy {
    /// The estimate, NaN where not identifiable.
    base: Vec<f64>,
    /// `G`: the estimate's response to a 1 um shift of each measured point
    /// along its line (parameters x points).
    gain: DMatrix<f64>,
    /// `S`: each point's shift per unit of each contributor column.
    sensitivity: DMatrix<f64>,
    /// `G S`.
    response: DMatrix<f64>,
    layout: ColumnLayout,
    contributors: Contributors,
    kin: Kinematics,
    /// The probing forward model, for the pieces' setups.
    probing: Option<ProbingForward>,
    n_pieces: usize,
}

impl LinearStudy {
    /// The study of `e` for `plan` (the plan the points describe) with
    /// `contributors`. Refuses what a linear study cannot draw (a
    /// calibration sphere's form error, a random shape on every run) and a
    /// forward model that cannot serve the plan, with the reason.
    pub fn new(
        plan: &Plan,
        e: &Estimate<'_>,
        contributors: Contributors,
    ) -> Result<LinearStudy, NotLinearized> {
        if e.est.method != Method::Global {
            return Err(NotLinearized::Method(e.est.method));
        }
        if contributors.sphere_form_um > 0.0 {
            return Err(NotLinearized::SphereForm);
        }
        let est = e.est;
        let data = e.data;
        let kin = crate::simulate::plan_kinematics(plan);
        let probing = plan.kind() == TestKind::Probing;
        let c = &contributors;
        let with_setup = probing
            && c.setup_position_um
                .iter()
                .chain(&c.setup_orientation_urad)
                .any(|v| *v > 0.0);
        let first = est.model.n_params();
        let mut theta: Vec<f64> = (0..first)
            .map(|i| {
                if est.identifiable(i) {
                    est.theta[i]
                } else {
                    0.0
                }
            })
            .collect();
        let n_theta = theta.len();
        let build = |grids: &[(Axis3, Axis3, Vec<f64>)]| -> Result<_, NotLinearized> {
            let (extra, layout) = contributor_effects(c, probing, grids);
            let mut effects = est.model.effects.clone();
            effects.extend(extra);
            let model = Model::new(kin.clone(), effects);
            let fw = Forward::new(&model, plan)?;
            Ok((fw, layout))
        };
        // First pass: which stretch of each axis the test uses, on a
        // coarse grid over the stroke; then the fine grid over it.
        let coarse = stroke_grids(&kin, COARSE_STEP_MM);
        let (fw, layout) = build(&coarse)?;
        theta.resize(n_theta + layout.len, 0.0);
        let lines = measuring_lines(&fw, data)?;
        let s = sensitivity(&fw, data, &theta, &lines, first, false)?;
        let mut fine = Vec::new();
        for (moving, direction, nodes, col) in &layout.straightness {
            let used: Vec<usize> = (0..nodes.len())
                .filter(|&j| (0..s.nrows()).any(|k| s[(k, col + j)] != 0.0))
                .collect();
            if let (Some(&a), Some(&b)) = (used.first(), used.last()) {
                let lo = nodes[a.saturating_sub(1)];
                let hi = nodes[(b + 1).min(nodes.len() - 1)];
                fine.push((*moving, *direction, grid(lo, hi, STRAIGHTNESS_STEP_MM)));
            }
        }
        let (fw, mut layout) = build(&fine)?;
        theta.resize(n_theta + layout.len, 0.0);
        let sensitivity = sensitivity(&fw, data, &theta, &lines, first, with_setup)?;
        if with_setup {
            layout.setup = Some(layout.len);
        }
        let gain = match est.method {
            Method::Global => {
                let opts = lsq::Options::default();
                let fit_model = if needs_plan(&e.setup.model, plan.test()) {
                    crate::simulate::forward::for_plan(&e.setup.model, plan)
                } else {
                    identify::forward::rigid_for(e.setup.model.clone(), data)
                }?;
                identify::global::response(fit_model.as_ref(), e.setup, data, &lines, &opts)?.1
            }
            m => return Err(NotLinearized::Method(m)),
        };
        let response = &gain * &sensitivity;
        let probing_fw = match fw {
            Forward::Probing(f) => Some(f),
            Forward::Machining(_) => None,
        };
        let n_pieces = match plan.probing().map(|p| &p.setup) {
            Some(crate::procedure::probing::ProbedGeometry::Columns(cs)) => cs.len(),
            _ => 1,
        };
        Ok(LinearStudy {
            base: est.estimates_or_nan(),
            gain,
            sensitivity,
            response,
            layout,
            contributors,
            kin,
            probing: probing_fw,
            n_pieces,
        })
    }

    /// `G`: the estimate's response (parameters x measured points, per um
    /// along each point's measuring line).
    pub fn gain(&self) -> &DMatrix<f64> {
        &self.gain
    }

    /// `S`: each measured point's shift along its line (um) per unit of
    /// each contributor column.
    pub fn sensitivity(&self) -> &DMatrix<f64> {
        &self.sensitivity
    }

    /// `G S`: the estimate's response to each contributor column.
    pub fn response(&self) -> &DMatrix<f64> {
        &self.response
    }

    /// The contributors the study draws.
    pub fn contributors(&self) -> &Contributors {
        &self.contributors
    }

    pub(super) fn layout(&self) -> &ColumnLayout {
        &self.layout
    }

    pub(super) fn kinematics(&self) -> &Kinematics {
        &self.kin
    }

    pub(super) fn probing(&self) -> Option<&ProbingForward> {
        self.probing.as_ref()
    }

    pub(super) fn pieces(&self) -> usize {
        self.n_pieces
    }

    /// The contributor columns of drawn effects (contributor effects with
    /// their values, as [`Contributors::sample`] gives them) and of the
    /// pieces' setups (W nominal to W actual, one per piece).
    pub fn columns(
        &self,
        effects: &[Effect],
        values: &[f64],
        setups: Option<&[Isometry3<f64>]>,
    ) -> Result<DVector<f64>, NotLinearized> {
        let l = &self.layout;
        let mut c = DVector::zeros(self.sensitivity.ncols());
        let mut o = 0;
        for e in effects {
            let k = e.n_params();
            let v = values.get(o..o + k).ok_or(NotLinearized::FewerValues)?;
            o += k;
            if v.iter().all(|x| *x == 0.0) {
                continue;
            }
            let missing = || NotLinearized::NoColumn(format!("{e:?}"));
            match e {
                Effect::Scale { axis } => c[l.scale.ok_or_else(missing)? + axis.index()] = v[0],
                Effect::Squareness { kind } => {
                    let i = Squareness::ALL
                        .iter()
                        .position(|s| s == kind)
                        .ok_or_else(missing)?;
                    c[l.squareness.ok_or_else(missing)? + i] = v[0];
                }
                Effect::Straightness {
                    moving,
                    direction,
                    nodes,
                } => {
                    let Some((_, _, grid, first)) = l
                        .straightness
                        .iter()
                        .find(|s| s.0 == *moving && s.1 == *direction)
                    else {
                        // An axis stretch the test never uses.
                        continue;
                    };
                    let dim = MapDim {
                        angle: 0,
                        nodes: nodes.clone(),
                        periodic: false,
                    };
                    for (j, x) in grid.iter().enumerate() {
                        c[first + j] = dim.weights(*x).iter().map(|&(i, w)| w * v[i]).sum();
                    }
                }
                Effect::ProbePretravel => {
                    let first = l.pretravel.ok_or_else(missing)?;
                    for (i, x) in v.iter().enumerate() {
                        c[first + i] = *x;
                    }
                }
                _ => return Err(missing()),
            }
        }
        if let (Some(first), Some(setups)) = (l.setup, setups)
            && let Some(f) = &self.probing
        {
            for (i, x) in f.nuisance_of(setups).into_iter().enumerate() {
                c[first + i] = x;
            }
        }
        Ok(c)
    }

    /// How far the estimate moves for contributor columns `c` and noise
    /// `noise` (um along each measured point's line).
    pub fn deviation(&self, c: &DVector<f64>, noise: &[f64]) -> DVector<f64> {
        &self.response * c + &self.gain * DVector::from_column_slice(noise)
    }

    /// One run: the contributors drawn as the exact study draws them, the
    /// estimate moved by its response (NaN where not identifiable).
    pub fn run<R: Rng + ?Sized>(&self, rng: &mut R) -> Result<Vec<f64>, NotLinearized> {
        let ct = &self.contributors;
        let d = ct.sample(&self.kin, rng);
        let (mut effects, mut values) = (d.effects, d.theta);
        if self.probing.is_some()
            && let Some((e, v)) = ct.sample_pretravel(rng)
        {
            effects.push(e);
            values.extend(v);
        }
        let setups: Option<Vec<Isometry3<f64>>> = self
            .layout
            .setup
            .map(|_| (0..self.n_pieces).map(|_| ct.sample_setup(rng)).collect());
        let c = self.columns(&effects, &values, setups.as_deref())?;
        let noise: Vec<f64> = if ct.noise_um > 0.0 {
            let normal =
                Normal::new(0.0, ct.noise_um).map_err(|e| NotLinearized::Noise(e.to_string()))?;
            (0..self.gain.ncols()).map(|_| normal.sample(rng)).collect()
        } else {
            vec![0.0; self.gain.ncols()]
        };
        let dev = self.deviation(&c, &noise);
        Ok(self
            .base
            .iter()
            .zip(dev.iter())
            .map(|(b, d)| b + d)
            .collect())
    }
}
