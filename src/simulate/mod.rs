//! The virtual machine: a plan run on a machine whose errors are known (a
//! truth file, docs/formats.md), measured as a real CMM or the machine's own
//! probe would measure it, written in the files they would write.
//!
//! # Machining tests
//! Every cutting move of every pose runs on the exact model (full HTMs,
//! docs/model.md, with every effect of the truth: location errors, maps,
//! drift per pose or per minute along the cut, linear-axis scale,
//! squareness and straightness where the axes really are during the cut,
//! tool radius and length). The surface left is the envelope of the actual
//! tool's sweeps ([`machining`]); the CMM probes each plan point along its
//! nominal normal and records the exact intersection with it, with its
//! noise along that line, and the piece lies on the CMM where a seeded
//! placement put it ([`cmm::Placement`]). The nine-section test also yields
//! its section heights.
//!
//! # Probing tests
//! Each touch's probing move runs along its commanded line; the probe
//! triggers where the actual ball meets the actual surface of the pieces
//! (each column set up with a seeded error up to 0.1 mm and 1 mrad) or of
//! the sphere (seeded shift and form error), then travels on by the truth's
//! pre-travel for its approach direction, with the probe's repeatability
//! as noise along the line ([`probing`]). The control records the commanded
//! X, Y, Z there, and the log is written exactly as the plan's program
//! makes the control write it.
//!
//! # The forward model
//! [`forward`] predicts every measured point from the parameters with its
//! exact Jacobian through the same code path ([`cutting`], [`probing`]);
//! it is what `analyze` and `discover` invert.
//!
//! ```no_run
//! use fivecal::simulate::{self, Format, SimOptions};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let plan = fivecal::procedure::load(std::path::Path::new("plans/stepped-square.plan.yaml"))?;
//! let kin = simulate::plan_kinematics(&plan);
//! let truth = fivecal::ErrorFile::load(std::path::Path::new("truth.yaml"), &kin)?;
//! let out = simulate::run(&plan, &truth, &SimOptions { seed: 7, ..SimOptions::default() })?;
//! out.write(Format::Csv, std::path::Path::new("piece.csv"))?;
//! # Ok(())
//! # }
//! ```

pub mod ball_bar;
pub mod cmm;
pub mod cutting;
pub mod forward;
pub mod laser;
pub mod machining;
pub mod output;
pub mod probing;
pub mod truth;

use std::sync::Arc;

use nalgebra::{Isometry3, Vector3};
use rand::SeedableRng;
use rand::rngs::StdRng;

use crate::errorfile::LoadedErrors;
use crate::formats::heights::SectionHeight;
use crate::formats::manifest::TestKind;
use crate::formats::measured::MeasuredPoint;
use crate::identify::forward::ForwardError;
use crate::io::OutputError;
use crate::kinematics::Kinematics;
use crate::procedure::{Plan, Test};

pub use cmm::Placement;
pub use output::Format;

/// Measurement noise when the truth file gives none, um (Ibaraki & Ota 2014, table 4:
/// non-systematic error, sigma 0.35 um).
pub(crate) const DEFAULT_NOISE_UM: f64 = 0.35;
/// Largest setup shift of a probed piece, mm.
pub const SETUP_SHIFT_MM: f64 = 0.1;
/// Largest setup rotation of a probed piece, rad.
pub const SETUP_ANGLE_RAD: f64 = 1e-3;
/// Form error of a calibration sphere when not given, um (largest radial
/// deviation; a grade-10 ball is within 0.25 um).
pub(crate) const DEFAULT_SPHERE_FORM_UM: f64 = 0.1;

/// How probed pieces sit on the table.
#[derive(Clone, Debug, PartialEq)]
pub enum SetupErrors {
    /// Seeded: each piece shifted by up to `shift` mm and turned about its
    /// own centre by up to `angle` rad (the sphere only shifted).
    Random {
        /// Largest shift, mm.
        shift: f64,
        /// Largest rotation, rad.
        angle: f64,
    },
    /// Exactly at their nominal places.
    Nominal,
    /// Given, one per piece (W nominal to W actual).
    Given(Vec<Isometry3<f64>>),
}

/// Noise levels replacing the truth file's, um (standard deviation).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NoiseOverrides {
    /// CMM noise.
    pub cmm_um: Option<f64>,
    /// Probe repeatability.
    pub probe_um: Option<f64>,
}

/// How a simulation is run.
#[derive(Clone, Debug, PartialEq)]
pub struct SimOptions {
    /// Seed of every random draw (placement, setups, form, noise).
    pub seed: u64,
    /// Where the machined piece lies on the CMM.
    pub placement: Placement,
    /// How probed pieces are set up.
    pub setup: SetupErrors,
    /// Noise levels replacing the truth's.
    pub noise: NoiseOverrides,
    /// Form error of a probed calibration sphere, um.
    pub sphere_form_um: f64,
}

impl Default for SimOptions {
    /// Seed 1, random placement, random setups, the truth's noise (0.35 um
    /// where it gives none), a sphere with 0.1 um form error.
    fn default() -> Self {
        SimOptions {
            seed: 1,
            placement: Placement::Random,
            setup: SetupErrors::Random {
                shift: SETUP_SHIFT_MM,
                angle: SETUP_ANGLE_RAD,
            },
            noise: NoiseOverrides::default(),
            sphere_form_um: DEFAULT_SPHERE_FORM_UM,
        }
    }
}

impl SimOptions {
    /// The machine's errors alone: no noise, the piece aligned on W, probed
    /// pieces at their nominal places, a perfect sphere. What the forward
    /// model predicts.
    pub fn exact() -> SimOptions {
        SimOptions {
            seed: 0,
            placement: Placement::Aligned,
            setup: SetupErrors::Nominal,
            noise: NoiseOverrides {
                cmm_um: Some(0.0),
                probe_um: Some(0.0),
            },
            sphere_form_um: 0.0,
        }
    }
}

/// Why a simulation failed.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The truth does not fit the plan (another machine, ...).
    #[error(transparent)]
    Model(#[from] ForwardError),
    /// The geometry cannot be simulated (errors too large for the plan).
    #[error("{0}")]
    Geometry(String),
    /// The requested output does not suit the test.
    #[error("{0}")]
    Format(String),
    /// Options out of range.
    #[error("{0}")]
    Options(String),
    /// Writing failed.
    #[error(transparent)]
    Output(#[from] OutputError),
}

/// What a simulation produced.
#[derive(Clone, Debug, PartialEq)]
pub struct SimOutput {
    /// The test.
    pub test: Test,
    /// Machining or probing.
    pub kind: TestKind,
    /// Machine name.
    pub machine: String,
    /// The seed.
    pub seed: u64,
    /// The measured points in plan order: in the CMM frame for a machined
    /// piece, the contact points in W at rotary zero for probing.
    pub points: Vec<MeasuredPoint>,
    /// The same points before the CMM placement (W); for probing, the
    /// points themselves.
    pub points_w: Vec<Vector3<f64>>,
    /// Each point's nominal position and direction as the CMM program has
    /// them (W), for DMIS output.
    pub nominals: Vec<(Vector3<f64>, Vector3<f64>)>,
    /// W to the CMM frame (the identity for probing).
    pub placement: Isometry3<f64>,
    /// Probing: each piece's name and setup (W nominal to W actual).
    pub setups: Vec<(String, Isometry3<f64>)>,
    /// Probing: the commanded X, Y, Z the control recorded per touch.
    pub recorded: Vec<Vector3<f64>>,
    /// Nine-section: heights relative to section 1.
    pub heights: Option<Vec<SectionHeight>>,
    /// Probing: the log as the control writes it.
    pub log: Option<String>,
}

/// The kinematics a plan runs with: the machine with the gauge length of
/// its tool (machining) or probe (probing). Load truth files with it.
pub fn plan_kinematics(plan: &Plan) -> Kinematics {
    match plan {
        Plan::Machining(t) => Kinematics::with_gauge_length(&t.machine, t.tool.length),
        Plan::Probing(p) => p.plan.kin.clone(),
    }
}

fn check_sigma(name: &str, v: f64) -> Result<f64, SimError> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(SimError::Options(format!(
            "{name} noise {v} um: expected a standard deviation >= 0"
        )))
    }
}

/// Runs a plan on the machine of `errors` (see the module documentation).
pub fn run(plan: &Plan, errors: &LoadedErrors, opts: &SimOptions) -> Result<SimOutput, SimError> {
    let mut rng = StdRng::seed_from_u64(opts.seed);
    let model = forward::model_for(plan_kinematics(plan), &errors.model)?;
    let theta = &errors.theta;
    match plan {
        Plan::Machining(t) => {
            let sigma = check_sigma(
                "CMM",
                opts.noise
                    .cmm_um
                    .or(errors.noise.cmm)
                    .unwrap_or(DEFAULT_NOISE_UM),
            )?;
            let cut = cutting::Cutting::new(model, Arc::new((**t).clone()));
            let offsets = machining::surface_offsets(&cut, theta)?;
            let placement = opts.placement.draw(&mut rng);
            let mut points = Vec::new();
            let mut points_w = Vec::new();
            let mut nominals = Vec::new();
            for (pp, off) in t.points.iter().zip(&offsets) {
                let (p, n) = (pp.point.p, pp.point.n);
                let w = p + n * (off + cmm::noise_mm(sigma, &mut rng));
                points.push(MeasuredPoint {
                    label: pp.point.label.clone(),
                    p: cmm::place(&placement, &w),
                    line: 0,
                    normal: None,
                });
                points_w.push(w);
                nominals.push((p, n));
            }
            let heights = (t.test == Test::NineSection).then(|| {
                let pts: Vec<_> = t.points.iter().map(|p| p.point.clone()).collect();
                cmm::heights(&pts, &points_w)
            });
            Ok(SimOutput {
                test: t.test,
                kind: TestKind::Machining,
                machine: t.machine.name.clone(),
                seed: opts.seed,
                points,
                points_w,
                nominals,
                placement,
                setups: Vec::new(),
                recorded: Vec::new(),
                heights,
                log: None,
            })
        }
        Plan::Probing(p) => {
            let sigma = check_sigma(
                "probe",
                opts.noise
                    .probe_um
                    .or(errors.noise.probe)
                    .unwrap_or(DEFAULT_NOISE_UM),
            )?;
            if !(opts.sphere_form_um.is_finite() && opts.sphere_form_um >= 0.0) {
                return Err(SimError::Options(format!(
                    "sphere form error {} um: expected a number >= 0",
                    opts.sphere_form_um
                )));
            }
            let pr = probing::Probing::new(model, Arc::new((**p).clone()));
            let n_pieces = pr.pieces.len();
            let art = match &opts.setup {
                SetupErrors::Random { shift, angle } => probing::Artefact::random(
                    &p.setup,
                    *shift,
                    *angle,
                    opts.sphere_form_um,
                    &mut rng,
                ),
                SetupErrors::Nominal => {
                    let mut a = probing::Artefact::nominal(n_pieces);
                    if opts.sphere_form_um > 0.0
                        && matches!(
                            p.setup,
                            crate::procedure::probing::ProbedGeometry::Sphere(_)
                        )
                    {
                        a.form = probing::Form::random(opts.sphere_form_um, &mut rng);
                    }
                    a
                }
                SetupErrors::Given(v) => {
                    if v.len() != n_pieces {
                        return Err(SimError::Options(format!(
                            "{} setups given for {} pieces ({})",
                            v.len(),
                            n_pieces,
                            pr.pieces.join(", ")
                        )));
                    }
                    let mut a = probing::Artefact::nominal(n_pieces);
                    a.setups = v.clone();
                    if opts.sphere_form_um > 0.0
                        && matches!(
                            p.setup,
                            crate::procedure::probing::ProbedGeometry::Sphere(_)
                        )
                    {
                        a.form = probing::Form::random(opts.sphere_form_um, &mut rng);
                    }
                    a
                }
            };
            let taus = probing::contacts(&pr, theta, &art)?;
            let mut points = Vec::new();
            let mut recorded = Vec::new();
            for (i, tau) in taus.iter().enumerate() {
                let (pt, _) = pr.pretravel(theta, i);
                let tt = tau + pt + cmm::noise_mm(sigma, &mut rng);
                let rec = pr.recorded(i, tt);
                points.push(MeasuredPoint {
                    label: p.plan.touches[i].label.clone(),
                    p: pr.reported(i, &rec),
                    line: 0,
                    normal: None,
                });
                recorded.push(rec);
            }
            let log = p
                .log_format()
                .write(&p.plan, p.plan.touches.iter().zip(recorded.iter().copied()));
            let nominals = p
                .plan
                .touches
                .iter()
                .map(|t| (t.contact_prog, t.normal_prog))
                .collect();
            Ok(SimOutput {
                test: p.test,
                kind: TestKind::Probing,
                machine: p.machine.name.clone(),
                seed: opts.seed,
                points_w: points.iter().map(|m| m.p).collect(),
                points,
                nominals,
                placement: Isometry3::identity(),
                setups: pr.pieces.iter().cloned().zip(art.setups).collect(),
                recorded,
                heights: None,
                log: Some(log),
            })
        }
    }
}
