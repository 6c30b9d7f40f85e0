//! Ball-bar runs on the virtual machine: for each setup of a ball-bar
//! plan and each angle of its sweep, the control's TCP commands the axes
//! that put the nominal spindle ball on M (fivecal's nominal inverse
//! kinematics), the machine with the truth's errors puts the ball
//! elsewhere (the exact model, no linearization), the ball sits off the
//! spindle axis by its run-out, and the bar reads the distance between
//! that ball and the table ball N minus its calibrated length, with the
//! bar's noise added.

use nalgebra::Vector3;
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, Normal};

use crate::errorfile::{ErrorFile, LoadedErrors};
use crate::formats::ball_bar::{BallBarManifest, BallBarRun, Readings, SetupEntry};
use crate::geom::{self, Axis3};
use crate::kinematics::pose_frame::PoseFrame;
use crate::kinematics::{Axes, Kinematics, Perturbation};
use crate::machine::Machine;
use crate::model::Context;
use crate::source::SourceError;

/// How the runs are disturbed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BallBarOptions {
    /// Radial run-out of the spindle ball: its centre's distance from the
    /// spindle axis, um.
    pub runout_um: f64,
    /// Direction of the run-out in the spindle's frame (oriented at 0),
    /// from the spindle's X towards its Y, deg.
    pub runout_phase_deg: f64,
    /// Standard deviation of a reading, um (`None`: the plan's).
    pub noise_um: Option<f64>,
    /// Seed of the noise.
    pub seed: u64,
}

impl Default for BallBarOptions {
    fn default() -> Self {
        BallBarOptions {
            runout_um: 0.0,
            runout_phase_deg: 0.0,
            noise_um: None,
            seed: 1,
        }
    }
}

/// The offset of the spindle ball from the spindle axis in W, mm, at the
/// pose `(tilt, c)`: fixed in the oriented spindle, turned by the head's
/// axes into the machine frame and by the table's into W.
pub fn runout_w(
    kin: &Kinematics,
    tilt: f64,
    c: f64,
    runout_um: f64,
    phase_deg: f64,
) -> Vector3<f64> {
    let m = kin.machine();
    let mut head = nalgebra::Isometry3::identity();
    if !m.c.on_table {
        head *= geom::rot(Axis3::Z, m.c.direction * geom::rad(c));
    }
    if !m.tilt.on_table {
        head *= geom::rot(m.tilt.about, m.tilt.direction * geom::rad(tilt));
    }
    let ph = geom::rad(phase_deg);
    let r_spindle = Vector3::new(ph.cos(), ph.sin(), 0.0) * (runout_um * 1e-3);
    let w_to_prog = PoseFrame::new(kin, tilt, c);
    let r_machine = head.rotation * r_spindle;
    // A direction of the machine frame in W.
    w_to_prog.to_w(&r_machine) - w_to_prog.to_w(&Vector3::zeros())
}

/// The commanded axes of `setup` at angle `i`: the nominal inverse
/// kinematics holding the ball on M, as TCP does.
pub fn commanded(kin: &Kinematics, setup: &SetupEntry, i: usize) -> Axes {
    let (t, c) = setup.angles_at(i, kin.machine().tilt.letter);
    let m = Vector3::from(setup.spindle_ball);
    PoseFrame::new(kin, t, c).commanded(&m)
}

/// The bar length minus its calibrated length, um, of `setup` at angle
/// `i`, on the machine of `truth` (built with the setup's gauge length),
/// without noise.
pub fn deviation_um(
    truth: &LoadedErrors,
    setup: &SetupEntry,
    i: usize,
    opts: &BallBarOptions,
) -> f64 {
    let kin = &truth.model.kin;
    let axes = commanded(kin, setup, i);
    let p = truth.model.perturbation(&truth.theta, &Context::at(axes));
    deviation_at(kin, &p, setup, i, opts)
}

/// [`deviation_um`] with the error terms given as the chain's slots.
pub fn deviation_at(
    kin: &Kinematics,
    p: &Perturbation,
    setup: &SetupEntry,
    i: usize,
    opts: &BallBarOptions,
) -> f64 {
    let axes = commanded(kin, setup, i);
    let tip = kin.forward(&axes, p).tip;
    let r = runout_w(
        kin,
        axes.tilt,
        axes.c,
        opts.runout_um,
        opts.runout_phase_deg,
    );
    let n = Vector3::from(setup.table_ball);
    ((tip + r - n).norm() - setup.bar_mm) * 1000.0
}

/// Why runs cannot be simulated.
#[derive(Debug, thiserror::Error)]
pub enum BallBarSimError {
    /// The truth file does not fit the machine.
    #[error(transparent)]
    Truth(#[from] SourceError),
    /// A bad option.
    #[error("{0}")]
    Option(String),
}

/// One run per setup of `plan` on `machine` with the errors of the truth
/// file `truth` (its text `src` at `path`, loaded once per gauge length).
pub fn simulate(
    plan: &BallBarManifest,
    machine: &Machine,
    truth: &ErrorFile,
    path: &std::path::Path,
    src: &str,
    opts: &BallBarOptions,
) -> Result<Vec<BallBarRun>, BallBarSimError> {
    let noise = opts.noise_um.unwrap_or(plan.noise_um);
    if !(noise.is_finite() && noise >= 0.0) {
        return Err(BallBarSimError::Option(format!(
            "noise {noise} um: expected >= 0"
        )));
    }
    let fine = (0.0..=1000.0).contains(&opts.runout_um) && opts.runout_phase_deg.is_finite();
    if !fine {
        return Err(BallBarSimError::Option(format!(
            "run-out {} um at {} deg: expected 0 to 1000 um and a finite phase",
            opts.runout_um, opts.runout_phase_deg
        )));
    }
    let dist = Normal::new(0.0, noise.max(0.0)).expect("noise >= 0");
    let mut rng = StdRng::seed_from_u64(opts.seed);
    let mut runs = Vec::new();
    let mut loaded: Vec<(f64, LoadedErrors)> = Vec::new();
    for s in &plan.setups {
        let t = match loaded.iter().find(|(g, _)| (*g - s.gauge_mm).abs() < 1e-12) {
            Some((_, t)) => t.clone(),
            None => {
                let kin = Kinematics::with_gauge_length(machine, s.gauge_mm);
                let t = truth.to_model(&kin, path, src)?;
                loaded.push((s.gauge_mm, t.clone()));
                t
            }
        };
        let readings = (0..s.angles.len())
            .map(|i| {
                let e = if noise > 0.0 {
                    dist.sample(&mut rng)
                } else {
                    0.0
                };
                (s.angles[i], deviation_um(&t, s, i, opts) + e)
            })
            .collect();
        runs.push(BallBarRun {
            setup: s.name.clone(),
            readings: Readings::Angles(readings),
        });
    }
    Ok(runs)
}
