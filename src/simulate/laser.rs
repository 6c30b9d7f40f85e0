//! Laser runs on the virtual machine: for each line of a ten-line plan,
//! the ISO 230-2 cycle run on the machine with the truth's errors (the
//! exact model, rotary axes at zero). The interferometer reads the
//! displacement of the measured point along the line, set to zero at
//! target 0 of the first + approach, with its reading noise.
//!
//! The model's linear-axis errors all act (docs/model.md): scale,
//! positioning maps, straightness, squareness and the angular error
//! motions, whose lever arm to the measured point runs through the
//! machine's chain and, on a bracket line, the bracket's offset; so an
//! offset line reads its base line plus the axis's pitch or yaw times the
//! offset. The model has no reversal (backlash): the reversal value is the
//! noise's. The rotary axes' location errors at zero shift every target
//! alike and cancel with the zero at target 0.

use nalgebra::Vector3;
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, Normal};

use crate::errorfile::{ErrorFile, LoadedErrors};
use crate::formats::laser::{LaserManifest, LaserRun, LineEntry, Reading};
use crate::kinematics::Axes;
use crate::kinematics::Kinematics;
use crate::machine::Machine;
use crate::model::Context;
use crate::source::SourceError;

/// How the runs are disturbed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LaserOptions {
    /// Standard deviation of a reading, um (`None`: the plan's reading
    /// uncertainty).
    pub noise_um: Option<f64>,
    /// Seed of the noise.
    pub seed: u64,
}

impl Default for LaserOptions {
    fn default() -> Self {
        LaserOptions {
            noise_um: None,
            seed: 1,
        }
    }
}

/// Why runs cannot be simulated.
#[derive(Debug, thiserror::Error)]
pub enum LaserSimError {
    /// The truth file does not fit the machine.
    #[error(transparent)]
    Truth(#[from] SourceError),
    /// A bad option.
    #[error("{0}")]
    Option(String),
}

/// The context of `line`'s target `i`: the gauge point in program
/// coordinates, the reflector's bracket as the measured offset.
pub fn line_context(machine: &Machine, line: &LineEntry, i: usize) -> Context {
    let spindle = Vector3::from(line.spindle_at(i));
    let measured_offset = if line.offset_by == "bracket" {
        Vector3::from(line.offset)
    } else {
        Vector3::zeros()
    };
    Context {
        axes: Axes {
            xyz: spindle - machine.pivot,
            tilt: 0.0,
            c: 0.0,
        },
        measured_offset,
        ..Default::default()
    }
}

/// The displacement of the measured point of `line` at target `i` from
/// where it is commanded, mm, in W (machine axes at rotary zero).
pub fn displacement(truth: &LoadedErrors, line: &LineEntry, i: usize) -> Vector3<f64> {
    let kin = &truth.model.kin;
    let ctx = line_context(kin.machine(), line, i);
    let p = truth.model.perturbation(&truth.theta, &ctx);
    kin.forward(&ctx.axes, &p).tip - kin.forward_nominal(&ctx.axes).tip
}

/// The reading of `line` at target `i` without noise, um: the displacement
/// along the line relative to target 0.
pub fn deviation_um(truth: &LoadedErrors, line: &LineEntry, i: usize) -> f64 {
    let u = Vector3::from(line.direction);
    (displacement(truth, line, i) - displacement(truth, line, 0)).dot(&u) * 1000.0
}

/// One run file per line of `plan` on `machine` with the errors of the
/// truth file `truth` (its text `src` at `path`).
pub fn simulate(
    plan: &LaserManifest,
    machine: &Machine,
    truth: &ErrorFile,
    path: &std::path::Path,
    src: &str,
    opts: &LaserOptions,
) -> Result<Vec<LaserRun>, LaserSimError> {
    let noise = opts.noise_um.unwrap_or(plan.reading_u_um);
    if !(noise.is_finite() && (0.0..=crate::limits::MAX_NOISE_UM).contains(&noise)) {
        return Err(LaserSimError::Option(format!(
            "noise {noise} um: expected 0 to {} um",
            crate::limits::MAX_NOISE_UM
        )));
    }
    let kin = Kinematics::with_gauge_length(machine, 0.0);
    let t = truth.to_model(&kin, path, src)?;
    let dist = Normal::new(0.0, noise).expect("noise >= 0");
    let mut rng = StdRng::seed_from_u64(opts.seed);
    let mut runs = Vec::new();
    for l in &plan.lines {
        let exact: Vec<f64> = (0..l.targets.len())
            .map(|i| deviation_um(&t, l, i))
            .collect();
        let mut readings = Vec::new();
        for run in 1..=plan.runs {
            let order: Vec<(usize, bool)> = (0..l.targets.len())
                .map(|i| (i, true))
                .chain((0..l.targets.len()).rev().map(|i| (i, false)))
                .collect();
            for (i, forward) in order {
                let e = if noise > 0.0 {
                    dist.sample(&mut rng)
                } else {
                    0.0
                };
                readings.push(Reading {
                    target_mm: l.targets[i],
                    run,
                    forward,
                    deviation_um: exact[i] + e,
                });
            }
        }
        // The zero is set on the first reading: it reads 0, and its noise
        // is in every other reading.
        let zero = readings[0].deviation_um;
        for r in &mut readings {
            r.deviation_um -= zero;
        }
        runs.push(LaserRun {
            line: l.name.clone(),
            format: "fivecal plain",
            environment: vec![("compensation".into(), "none (simulated)".into())],
            readings,
        });
    }
    Ok(runs)
}
