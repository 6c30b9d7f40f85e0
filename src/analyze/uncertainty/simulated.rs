//! Monte-Carlo runs on the simulator: the plan is run again on a virtual
//! machine that has the identified errors plus one draw of the
//! contributors, measured as the real test was (a fresh CMM placement of
//! the piece, fresh setups of the probed pieces, noise, directional
//! pre-travel, the sphere's form), and identified again by the same
//! method.
//!
//! This is the Monte Carlo of Ibaraki, Iritani & Matsushita 2013, section 6, and Ibaraki & Ota 2014, section 6
//! with the exact virtual machine ([`crate::simulate`]) in place of the
//! foundation's rigid-pose model: linear-axis errors act where the axes
//! really are during each cut or touch, the tool sweeps the surface, the
//! probe triggers on the actual surface. The synthetic path
//! ([`super::synthetic_run`]) remains for plans the simulator cannot
//! rebuild (a points file without its template).

use std::path::Path;

use nalgebra::Isometry3;
use rand::{Rng, RngExt};

use super::Contributors;
use crate::analyze::PlanContext;
use crate::analyze::method::identify_for_study;
use crate::errorfile::{LoadedErrors, Noise};
use crate::formats::manifest::TestKind;
use crate::formats::measured::MeasuredPoint;
use crate::identify::sphere::SphereOptions;
use crate::identify::{Dataset, Identification, IdentifyError, Method, Setup};
use crate::model::Model;
use crate::procedure::Plan;
use crate::procedure::probing::ProbedGeometry;
use crate::simulate::{self, NoiseOverrides, Placement, SetupErrors, SimOptions, SimOutput};

/// One simulated test and how it is identified.
#[derive(Clone, Debug)]
pub struct SimulatedTest<'a> {
    /// The plan, rebuilt from its manifest ([`crate::procedure::load`]).
    pub plan: &'a Plan,
    /// The machine's errors: the identified model, or a known truth.
    pub model: &'a Model,
    /// Their values (file units); contributors are added to them.
    pub theta: Vec<f64>,
    /// What to identify.
    pub setup: &'a Setup,
    /// The measured points the real test had: only these are simulated
    /// and identified, with the real test's pose times.
    pub data: &'a Dataset,
    /// The method.
    pub method: Method,
    /// Sphere-method options.
    pub sphere: SphereOptions,
    /// The contributors drawn for each run.
    pub contributors: Contributors,
}

impl<'a> SimulatedTest<'a> {
    /// The Monte Carlo of an identification: its values as the truth, those
    /// it could not identify at zero (nothing is known of them).
    pub fn from_estimate(
        plan: &'a Plan,
        est: &'a Identification,
        setup: &'a Setup,
        data: &'a Dataset,
        sphere: SphereOptions,
        contributors: Contributors,
    ) -> SimulatedTest<'a> {
        let theta = est
            .theta
            .iter()
            .enumerate()
            .map(|(i, v)| if est.identifiable(i) { *v } else { 0.0 })
            .collect();
        SimulatedTest {
            plan,
            model: &est.model,
            theta,
            setup,
            data,
            method: est.method,
            sphere,
            contributors,
        }
    }
}

/// Joins simulated (or any labelled) points to a rebuilt plan as `analyze`
/// joins a measured file ([`crate::analyze::inputs`]): the plan's points and
/// pose times, each probed piece on its own setup.
pub fn plan_dataset(
    plan: &Plan,
    name: &str,
    points: Vec<MeasuredPoint>,
) -> Result<Dataset, IdentifyError> {
    let source = Path::new(name);
    PlanContext::from_plan(plan, source)
        .join_points(points, "simulated", source)
        .map_err(|e| IdentifyError::Data(e.to_string()))
}

/// Number of separately set-up pieces of a plan (one for a machined piece
/// or a sphere).
fn n_pieces(plan: &Plan) -> usize {
    match plan.probing().map(|p| &p.setup) {
        Some(ProbedGeometry::Columns(cs)) => cs.len(),
        _ => 1,
    }
}

/// The truth of one run: the test's errors plus one draw of the
/// contributors' systematic effects.
pub fn draw_truth<R: Rng + ?Sized>(t: &SimulatedTest<'_>, rng: &mut R) -> LoadedErrors {
    let kin = simulate::plan_kinematics(t.plan);
    let d = t.contributors.sample(&kin, rng);
    let mut effects = t.model.effects.clone();
    effects.extend(d.effects);
    let mut theta = t.theta.clone();
    theta.extend(d.theta);
    if t.plan.kind() == TestKind::Probing
        && let Some((e, v)) = t.contributors.sample_pretravel(rng)
    {
        effects.push(e);
        theta.extend(v);
    }
    let model = Model::new(kin, effects);
    let n = model.n_params();
    LoadedErrors {
        model,
        theta,
        u: vec![None; n],
        noise: Noise::default(),
        not_identifiable: Vec::new(),
        fit: None,
    }
}

/// How one run is measured: a fresh seed for every random draw of the
/// simulator, the piece put down anywhere on the CMM, each probed piece
/// set up as the contributors say (exactly in place when they give no
/// setup error: the setup is estimated anyway), the contributors' noise.
pub fn sim_options<R: Rng + ?Sized>(t: &SimulatedTest<'_>, rng: &mut R) -> SimOptions {
    let c = &t.contributors;
    let setup = if c
        .setup_position_um
        .iter()
        .chain(&c.setup_orientation_urad)
        .any(|v| *v > 0.0)
    {
        SetupErrors::Given(
            (0..n_pieces(t.plan))
                .map(|_| c.sample_setup(rng))
                .collect::<Vec<Isometry3<f64>>>(),
        )
    } else {
        SetupErrors::Nominal
    };
    SimOptions {
        seed: rng.random(),
        placement: Placement::Random,
        setup,
        noise: NoiseOverrides {
            cmm_um: Some(c.noise_um),
            probe_um: Some(c.noise_um),
        },
        sphere_form_um: c.sphere_form_um,
    }
}

/// Simulates one run and joins it as the real measurement was joined:
/// the same points (those the real file had), the same pieces.
pub(crate) fn simulate_run<R: Rng + ?Sized>(
    t: &SimulatedTest<'_>,
    rng: &mut R,
) -> Result<(SimOutput, Dataset), String> {
    let truth = draw_truth(t, rng);
    let opts = sim_options(t, rng);
    let out = simulate::run(t.plan, &truth, &opts).map_err(|e| e.to_string())?;
    let observed: std::collections::HashSet<&str> = t
        .data
        .obs
        .iter()
        .map(|o| t.data.plan.points[o.plan].label.as_str())
        .collect();
    let points: Vec<MeasuredPoint> = out
        .points
        .iter()
        .filter(|p| observed.contains(p.label.as_str()))
        .cloned()
        .collect();
    if points.len() != observed.len() {
        return Err(format!(
            "the simulated plan has {} of the {} measured points: the plan rebuilt from the manifest is not the one measured",
            points.len(),
            observed.len()
        ));
    }
    let mut d = plan_dataset(t.plan, &format!("simulated seed {}", opts.seed), points)
        .map_err(|e| e.to_string())?;
    d.pieces = t.data.pieces.clone();
    d.piece_of = t.data.piece_of.clone();
    Ok((out, d))
}

/// One Monte-Carlo run on the simulator (see the module documentation):
/// the estimated parameters, NaN where the run cannot identify one.
pub fn simulated_run<R: Rng + ?Sized>(
    t: &SimulatedTest<'_>,
    rng: &mut R,
) -> Result<Vec<f64>, String> {
    let (_, d) = simulate_run(t, rng)?;
    let r = identify_for_study(t.method, t.setup, &d, &t.sphere, Some(t.plan))
        .map_err(|e| e.to_string())?;
    Ok(r.estimates_or_nan())
}

/// What a seeded study of one design found for one method.
#[derive(Clone, Debug)]
pub struct MethodStudy {
    /// The method.
    pub method: Method,
    /// Runs that returned estimates.
    pub runs: usize,
    /// Runs that failed, with the first failure's message.
    pub failed: (usize, Option<String>),
    /// Mean estimate of each parameter of the setup.
    pub mean: Vec<f64>,
    /// Spread (standard deviation) of the estimates over the runs.
    pub spread: Vec<f64>,
    /// Mean of the standard uncertainty each run reported (NaN where the
    /// method reports none).
    pub mean_u: Vec<f64>,
}

/// A seeded study of a design: `opts.runs` simulations of the test, each
/// identified by every method in `methods` (the same simulated measurement
/// for all of them), with the spread of the estimates and the mean of the
/// uncertainties the runs reported. The Monte-Carlo driver runs them in
/// parallel; the result does not depend on the number of threads.
pub fn study(
    t: &SimulatedTest<'_>,
    methods: &[Method],
    opts: &super::McOptions,
) -> Vec<MethodStudy> {
    let n = t.setup.model.n_params();
    let width = 2 * n * methods.len();
    let mc = super::montecarlo::run(opts, width, |_, rng| {
        let (_, d) = simulate_run(t, rng)?;
        let mut row = Vec::with_capacity(width);
        for &m in methods {
            let r = identify_for_study(m, t.setup, &d, &t.sphere, Some(t.plan))
                .map_err(|e| format!("{m}: {e}"))?;
            let u = r.u();
            row.extend(r.estimates_or_nan());
            row.extend(u.iter().map(|x| x.unwrap_or(f64::NAN)));
        }
        Ok::<_, String>(row)
    });
    methods
        .iter()
        .enumerate()
        .map(|(k, &method)| {
            let o = 2 * n * k;
            MethodStudy {
                method,
                runs: mc.runs,
                failed: mc.failed.clone(),
                mean: mc.mean[o..o + n].to_vec(),
                spread: mc.std[o..o + n].to_vec(),
                mean_u: mc.mean[o + n..o + 2 * n].to_vec(),
            }
        })
        .collect()
}

/// The Cramér-Rao bound of a simulated test's design
/// ([`super::cramer_rao_bound`]) with the simulator's general forward
/// model, at the test's true values (by parameter name; zero for a
/// parameter of the setup the truth does not have), the pieces at their
/// nominal places, for the contributors' noise.
pub fn design_bound(t: &SimulatedTest<'_>) -> Result<super::Bound, IdentifyError> {
    let fm = simulate::forward::for_plan(&t.setup.model, t.plan)?;
    let names = t.model.param_names();
    let theta: Vec<f64> = t
        .setup
        .model
        .param_names()
        .iter()
        .map(|s| {
            names
                .iter()
                .position(|x| x == s)
                .map_or(0.0, |i| t.theta[i])
        })
        .collect();
    let nuisance = vec![0.0; fm.nuisance_names().len()];
    super::cramer_rao_bound(
        fm.as_ref(),
        t.setup,
        t.data,
        &theta,
        &nuisance,
        t.contributors.noise_um,
    )
}
