//! `fivecal simulate nc`: the predicted tool-tip error along an NC program
//! on a machine with known errors, and what a CMM would measure on a part
//! cut by it.

use anyhow::bail;
use fivecal::compensate::against::{Deviation, Follower, IntendedPath};
use fivecal::compensate::reasons;
use fivecal::compensate::simulate::{Sample, SimSettings, Simulator, measure_surface, samples_csv};
use fivecal::formats::measured::{self, MeasuredPoint};
use fivecal::numbers::count;

use serde::Serialize;

use crate::config::{nc::load_errors, simulate::NcConfig, simulate::SimulateNcArgs};
use crate::out::{AtLine, ReasonLines};

pub fn run(args: SimulateNcArgs) -> anyhow::Result<()> {
    let args: NcConfig = args.validate()?;
    if args.json {
        // Standard output is the JSON's: what the run says goes to
        // standard error.
        crate::out::to_stderr();
    }
    let common = &args.common;
    let errors = load_errors(&args.errors, &common.kin)?;
    let cmm_points = args
        .cmm
        .as_ref()
        .map(|p| -> anyhow::Result<_> {
            let limit = fivecal::limits::MAX_MEASUREMENT_BYTES;
            let src = fivecal::input::read_text(p, "points file", limit)?;
            Ok(measured::parse_csv(p, &src)?)
        })
        .transpose()?;
    let step = args.step;
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
    let intended = args
        .against
        .as_ref()
        .map(|original| -> anyhow::Result<_> {
            let (detection, file) = common.open_program(original)?;
            let settings = settings_for(detection.dialect);
            Ok(IntendedPath::of_program(
                &errors.model,
                settings,
                original,
                file,
            )?)
        })
        .transpose()?;
    let mut follower = match (&intended, &args.against) {
        (Some((path, _)), Some(original)) => Some(Follower::new(path).ok_or_else(|| {
            let why = "its moves make no path to measure against (fewer than two points)";
            anyhow::anyhow!("{}: {why}", original.display())
        })?),
        _ => None,
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
    let no_error = summary
        .max_um
        .is_some_and(|m| m.value < 0.005 && summary.max_axis_urad < 0.05);
    if args.json {
        let against = match (&against, &args.against, &intended) {
            (Some(d), Some(original), Some((_, skipped))) => Some(AgainstJson {
                original: original.display().to_string(),
                samples: d.samples,
                step_mm: step,
                mean_um: d.mean_um,
                rms_um: d.rms_um,
                max_um: d.max_um.map(AtLine::from),
                max_axis_urad: d.max_axis_urad,
                skipped: ReasonLines::all(skipped),
            }),
            _ => None,
        };
        crate::out::json_of(&SimulatedNc {
            program: args.program.display().to_string(),
            machine: common.machine.name.clone(),
            errors: args.errors.display().to_string(),
            dialect: detection.dialect.to_string(),
            blocks: summary.blocks,
            moves: summary.moves,
            samples: summary.samples,
            mean_um: summary.mean_um,
            rms_um: summary.rms_um,
            max_um: summary.max_um.map(AtLine::from),
            max_axis_urad: summary.max_axis_urad,
            against,
            skipped: ReasonLines::all(&summary.skipped),
            unmodelled: ReasonLines::all(&summary.unmodelled),
            no_error,
            files: [&args.output, &args.measured]
                .into_iter()
                .flatten()
                .map(|p| p.display().to_string())
                .collect(),
        })?;
    }
    if no_error {
        outln!(
            "no error: on this machine every sample of the program lies where the nominal machine puts it (within 0.005 um and 0.05 urad): {} moves none of them",
            args.errors.display()
        );
    }
    Ok(())
}

/// What `simulate nc --json` prints: the tool-tip error along the program
/// (actual minus where the nominal machine puts the program as written),
/// and with `--against` the tool tip from the original's path.
#[derive(Serialize)]
struct SimulatedNc {
    program: String,
    machine: String,
    errors: String,
    /// The dialect the program was read in.
    dialect: String,
    blocks: usize,
    moves: usize,
    samples: usize,
    mean_um: f64,
    rms_um: f64,
    max_um: Option<AtLine>,
    max_axis_urad: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    against: Option<AgainstJson>,
    /// Moves not simulated, by reason.
    skipped: Vec<ReasonLines>,
    /// Effects of the program the model does not hold, by kind.
    unmodelled: Vec<ReasonLines>,
    /// Every sample lies where the nominal machine puts it.
    no_error: bool,
    /// The files written (`--out`, `--measured`).
    files: Vec<String>,
}

#[derive(Serialize)]
struct AgainstJson {
    original: String,
    samples: usize,
    step_mm: f64,
    mean_um: f64,
    rms_um: f64,
    max_um: Option<AtLine>,
    max_axis_urad: f64,
    /// Moves of the original not simulated, by reason.
    skipped: Vec<ReasonLines>,
}
