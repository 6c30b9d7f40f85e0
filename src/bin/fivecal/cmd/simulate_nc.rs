//! `fivecal simulate nc`: the predicted tool-tip error along an NC program
//! on a machine with known errors, and what a CMM would measure on a part
//! cut by it.

use std::path::{Path, PathBuf};

use anyhow::bail;
use clap::Args;
use fivecal::compensate::against::{Deviation, Follower, IntendedPath};
use fivecal::compensate::reasons;
use fivecal::compensate::simulate::{Sample, SimSettings, Simulator, measure_surface, samples_csv};
use fivecal::formats::measured::{self, MeasuredPoint};
use fivecal::numbers::count;

use crate::config::nc::{MachineArgs, load_errors};

#[derive(Args, Debug)]
pub struct SimulateNcArgs {
    #[command(flatten)]
    machine: MachineArgs,
    /// Error file of the machine (a truth file, or an analyze result).
    #[arg(long, value_name = "TRUTH.yaml")]
    errors: PathBuf,
    /// The NC program to run.
    #[arg(value_name = "P.nc")]
    program: PathBuf,
    /// Sample feed moves every STEP mm of tool path (and at least every
    /// degree a rotary axis turns) as well as at their end points.
    #[arg(
        long,
        value_name = "MM",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    step: f64,
    /// Write every sample (nominal tip and axis, tip error) as CSV.
    #[arg(short = 'o', long = "out", value_name = "ERRORS.csv")]
    output: Option<PathBuf>,
    /// Nominal surface points a CMM measures on the part the program cuts
    /// (canonical `label,x,y,z`, in W): with --measured, write what it would
    /// find (the tool cutting at its tip, normal to the surface).
    #[arg(long, value_name = "POINTS.csv", requires = "measured")]
    cmm: Option<PathBuf>,
    /// Where the simulated CMM points go (canonical `label,x,y,z`).
    #[arg(long, value_name = "CMM.csv", requires = "cmm")]
    measured: Option<PathBuf>,
    /// The program P.nc was made from (the original of a compensated
    /// program): measure P.nc's tool tip, run on the machine with the
    /// errors, against the path ORIGINAL.nc asks for on the nominal
    /// machine, instead of against P.nc's own nominal path. Feed moves are
    /// sampled every --step mm (0.5 mm when --step is not given).
    #[arg(long, value_name = "ORIGINAL.nc")]
    against: Option<PathBuf>,
    /// Largest distance of a CMM point from the tool path, mm.
    #[arg(long, value_name = "MM", default_value_t = 0.5)]
    max_distance: f64,
}

pub fn run(args: SimulateNcArgs) -> anyhow::Result<()> {
    let common = args.machine.validate()?;
    let errors = load_errors(&args.errors, &common.kin)?;
    let min_step = fivecal::limits::MIN_SAMPLE_STEP_MM;
    if !(args.step.is_finite() && (args.step == 0.0 || args.step >= min_step)) {
        bail!(
            "--step {}: expected 0 (end points only) or a distance of at least {min_step} mm",
            args.step
        );
    }
    if !(args.max_distance.is_finite() && args.max_distance > 0.0) {
        bail!(
            "--max-distance {}: expected a distance > 0 mm from the tool path",
            args.max_distance
        );
    }
    let mut inputs: Vec<&Path> = common.inputs.iter().map(|p| p.as_path()).collect();
    inputs.push(&args.errors);
    inputs.push(&args.program);
    if let Some(a) = &args.against {
        inputs.push(a);
    }
    if let Some(c) = &args.cmm {
        inputs.push(c);
    }
    let outputs: Vec<_> = [("--out", &args.output), ("--measured", &args.measured)]
        .into_iter()
        .filter_map(|(f, p)| Some((f, p.as_deref()?, fivecal::io::Shape::File)))
        .collect();
    fivecal::io::check_outputs(&inputs, &outputs)?;
    let cmm_points = match &args.cmm {
        Some(p) => {
            let src = fivecal::input::read_text(
                p,
                "points file",
                fivecal::limits::MAX_MEASUREMENT_BYTES,
            )?;
            Some(measured::parse_csv(p, &src)?)
        }
        None => None,
    };
    // Against an original, the path between end points is what is
    // compared: feed moves are sampled along, never only at their ends.
    let step = match (&args.against, args.step) {
        (Some(_), 0.0) => AGAINST_STEP_MM,
        (_, s) => s,
    };
    let settings_for = |dialect| {
        let mut settings = SimSettings::new(dialect);
        settings.strict = common.strict;
        settings.origin = common.origin;
        settings.coordinates = common.coordinates;
        settings.fanuc_integer_unit = common.integer_unit;
        settings.rotary_start = common.rotary_start.clone();
        settings.subroutine_path = common.subroutine_path.clone();
        settings.step = step;
        settings
    };
    let intended = match &args.against {
        Some(original) => {
            let (detection, file) = common.open_program(original)?;
            let settings = settings_for(detection.dialect);
            Some(IntendedPath::of_program(
                &errors.model,
                settings,
                original,
                file,
            )?)
        }
        None => None,
    };
    let mut follower = match &intended {
        Some((path, _)) => Some(Follower::new(path).ok_or_else(|| {
            anyhow::anyhow!(
                "{}: its moves make no path to measure against (fewer than two points)",
                args.against.as_ref().unwrap().display()
            )
        })?),
        None => None,
    };
    let (detection, file) = common.open_program(&args.program)?;
    let sim = Simulator::new(
        &errors.model,
        &errors.theta,
        settings_for(detection.dialect),
    );
    // Samples are kept only when a CSV or the CMM points need them.
    let keep = args.output.is_some() || cmm_points.is_some();
    let mut samples: Vec<(Sample, Option<f64>)> = Vec::new();
    let mut too_many = false;
    let summary = sim.run(&args.program, file, &mut |s| {
        let deviation = follower.as_mut().and_then(|f| f.add(s));
        if keep && !too_many {
            too_many = samples.len() >= fivecal::limits::MAX_SAMPLES;
            if !too_many {
                samples.push((*s, deviation));
            }
        }
    })?;
    let against: Option<Deviation> = follower.map(Follower::finish);
    if too_many {
        bail!(
            "{}: more than {} samples to keep at --step {} mm: choose a larger --step",
            args.program.display(),
            fivecal::limits::MAX_SAMPLES,
            step
        );
    }
    if summary.samples == 0 {
        // Moves there were (the library refuses a program without), and
        // none could be followed: an empty prediction is no prediction.
        bail!(
            "{}: no move of it could be simulated ({}); nothing written",
            args.program.display(),
            reasons(&summary.skipped)
        );
    }
    if let Some(out) = &args.output {
        let title = format!(
            "fivecal simulate nc: {} on {} with {}",
            args.program.display(),
            common.machine.name,
            args.errors.display()
        );
        let t = samples_csv(&title, &samples, args.against.as_deref());
        fivecal::io::write_atomic(out, t.as_bytes())?;
    }
    if let (Some(points), Some(out)) = (&cmm_points, &args.measured) {
        let pts: Vec<(String, nalgebra::Vector3<f64>)> =
            points.iter().map(|p| (p.label.clone(), p.p)).collect();
        let samples: Vec<Sample> = samples.iter().map(|(s, _)| *s).collect();
        let got = measure_surface(&samples, &pts, args.max_distance).map_err(anyhow::Error::msg)?;
        let mp: Vec<MeasuredPoint> = got
            .into_iter()
            .map(|(label, p)| MeasuredPoint {
                label,
                p,
                line: 0,
                normal: None,
            })
            .collect();
        let comment = format!(
            "simulated CMM points: {} cut by {} on {} with {}",
            args.cmm.as_ref().unwrap().display(),
            args.program.display(),
            common.machine.name,
            args.errors.display()
        );
        fivecal::io::write_atomic(out, measured::to_csv(&mp, &[&comment]).as_bytes())?;
    }
    outln!(
        "simulated {} on {} ({}) with {}",
        args.program.display(),
        common.machine.name,
        common.machine_origin,
        args.errors.display()
    );
    outln!("  read as {detection}");
    if let Some(n) = fivecal::compensate::rotary_start_note(&common.rotary_start) {
        outln!("  {n}");
    }
    outln!(
        "  {}, {}, {}",
        count(summary.blocks, "block", "blocks"),
        count(summary.moves, "move", "moves"),
        count(summary.samples, "sample", "samples")
    );
    if let Some(m) = summary.max_um {
        outln!(
            "  tool-tip error (actual minus where the nominal machine puts the program as written): mean {:.2} um, RMS {:.2} um, max {:.2} um (line {}); tool axis up to {:.1} urad",
            summary.mean_um,
            summary.rms_um,
            m.value,
            m.line,
            summary.max_axis_urad
        );
    }
    if let (Some(d), Some(original), Some((_, skipped))) = (&against, &args.against, &intended) {
        match d.max_um {
            Some(m) => outln!(
                "  tool tip from the path {} asks for on the nominal machine: mean {:.2} um, RMS {:.2} um, max {:.2} um (line {}); tool axis up to {:.1} urad; {} every {} mm",
                original.display(),
                d.mean_um,
                d.rms_um,
                m.value,
                m.line,
                d.max_axis_urad,
                count(d.samples, "feed sample", "feed samples"),
                step
            ),
            None => outln!(
                "  no feed move to measure against the path {} asks for",
                original.display()
            ),
        }
        for (reason, lines) in skipped {
            outln!(
                "  not simulated in {} ({}): {reason}: lines {}",
                original.display(),
                reason.kind,
                lines.list()
            );
        }
    }
    for (reason, lines) in &summary.skipped {
        outln!(
            "  not simulated ({}): {reason}: lines {}",
            reason.kind,
            lines.list()
        );
    }
    for (what, lines) in &summary.unmodelled {
        outln!("  effect not modelled: {what}: lines {}", lines.list());
    }
    if let Some(out) = &args.output {
        outln!("  samples written to {}", out.display());
    }
    if let Some(out) = &args.measured {
        outln!("  simulated CMM points written to {}", out.display());
    }
    // A machine on which the program runs as on the nominal one: an answer
    // (a compensated program, a perfect machine), but never a silent one.
    if summary
        .max_um
        .is_some_and(|m| m.value < 0.005 && summary.max_axis_urad < 0.05)
    {
        outln!(
            "no error: on this machine every sample of the program lies where the nominal machine puts it (within 0.005 um and 0.05 urad): {} moves none of them",
            args.errors.display()
        );
    }
    Ok(())
}

/// The step along feed moves, mm, of a run `--against` an original when no
/// `--step` is given (the demo's).
const AGAINST_STEP_MM: f64 = 0.5;
