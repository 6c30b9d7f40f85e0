//! `fivecal demo`: the whole mission on the built-in `bc-trunnion` machine
//! with a built-in truth, as a newcomer's first run: plan the FANUC
//! stepped-square test, machine and measure it on the virtual machine,
//! identify the location errors with their uncertainty, discover the
//! effect the starting model lacks, and compensate an example five-axis
//! program, comparing where its tool tip goes before and after.
//!
//! Every step goes through the same library calls and files as the
//! commands a user runs by hand (`plan`, `simulate`, `analyze`, `discover`,
//! `compensate`, `simulate nc`), so the demo is also their end-to-end test.

pub(crate) mod program;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::analyze;
use crate::compensate::against::{Follower, IntendedPath};
use crate::compensate::simulate::{Sample, SimSettings, Simulator};
use crate::compensate::{AtomicOutput, Compensator, Settings};
use crate::discover::{self, DiscoverOptions, Discovery, GapSize};
use crate::errorfile::{ErrorFile, LoadedErrors};
use crate::formats::manifest::KinematicsMode;
use crate::history::compare::Comparison;
use crate::identify::Identification;
use crate::io::write_atomic;
use crate::kinematics::Kinematics;
use crate::machine::{Dialect, Machine};
use crate::post::PostDefinition;
use crate::procedure::{self, PlanConfig, Template, Test};
use crate::simulate::{self, Format, SimOptions};
use crate::store::runs::{self, RunNotes};
use crate::store::{Location, Store};

/// The built-in truth: eight location errors and a thermal drift of EZ0B
/// that the starting model lacks (`examples/demo/truth.yaml`).
pub const TRUTH: &str = include_str!("../../examples/demo/truth.yaml");

/// The machine the demo runs on.
pub const MACHINE: &str = "bc-trunnion";

/// What to run.
#[derive(Clone, Debug, PartialEq)]
pub struct DemoConfig {
    /// Where every artefact goes.
    pub out: PathBuf,
    /// Seed of the simulation (placement on the CMM, noise).
    pub seed: u64,
}

/// The steps, in order, for progress displays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Writing the test's program, points and manifest.
    Plan,
    /// Machining and measuring on the virtual machine.
    Simulate,
    /// Identifying the location errors.
    Analyze,
    /// Searching for the missing effect.
    Discover,
    /// Rewriting the example program and checking it.
    Compensate,
    /// Exporting the errors to the control, measuring the compensated
    /// machine and comparing it with the machine before.
    Verify,
}

impl Stage {
    /// All stages in order.
    pub const ALL: [Stage; 6] = [
        Stage::Plan,
        Stage::Simulate,
        Stage::Analyze,
        Stage::Discover,
        Stage::Compensate,
        Stage::Verify,
    ];

    /// What the stage does, for a progress line.
    pub fn describe(self) -> &'static str {
        match self {
            Stage::Plan => "plan the stepped-square test (FANUC)",
            Stage::Simulate => "machine it on the virtual machine and measure it on a CMM",
            Stage::Analyze => "identify the location errors with their uncertainty",
            Stage::Discover => "discover what the model is missing",
            Stage::Compensate => "compensate an example five-axis program",
            Stage::Verify => "export to the control, measure again and verify",
        }
    }
}

/// Why the demo stopped.
#[derive(Debug, thiserror::Error)]
pub enum DemoError {
    /// A step failed; the message names it and its cause.
    #[error("{stage}: {message}")]
    Step {
        /// The step.
        stage: &'static str,
        /// What went wrong.
        message: String,
    },
}

/// Attaches the stage to a failure.
trait AtStage<T> {
    fn at(self, stage: Stage) -> Result<T, DemoError>;
}

impl<T, E: std::fmt::Display> AtStage<T> for Result<T, E> {
    fn at(self, stage: Stage) -> Result<T, DemoError> {
        self.map_err(|e| DemoError::Step {
            stage: stage.describe(),
            message: e.to_string(),
        })
    }
}

/// One location error: the truth, the first analysis and the final model.
#[derive(Clone, Debug, PartialEq)]
pub struct DemoRow {
    /// symbol of docs/model.md.
    pub symbol: String,
    /// Unit (um or urad).
    pub unit: String,
    /// The truth.
    pub truth: f64,
    /// The analysis with the starting model: value and standard
    /// uncertainty (`None` when not identifiable).
    pub analyzed: Option<(f64, f64)>,
    /// After discovery.
    pub discovered: Option<(f64, f64)>,
}

/// How far a program's tool tip runs from the intended path, um.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathError {
    /// RMS over the samples.
    pub rms_um: f64,
    /// Largest.
    pub max_um: f64,
    /// Samples.
    pub samples: usize,
}

/// A fitted parameter of a discovered effect: name, value, and the truth
/// where the truth has it.
pub type FoundValue = (String, f64, Option<f64>);

/// Everything the demo found, and where it put the files.
#[derive(Clone, Debug)]
pub struct Demo {
    /// Location errors.
    pub rows: Vec<DemoRow>,
    /// The effects discovery added, with their fitted values and the
    /// truth where the truth has them.
    pub added: Vec<(String, Vec<FoundValue>)>,
    /// The truth's effects beyond the location errors (id, parameter,
    /// value).
    pub hidden: Vec<(String, String, f64)>,
    /// How well the first analysis' model (location errors only) fits.
    pub fit_before: Option<crate::errorfile::FitSection>,
    /// How well the discovered model fits.
    pub fit_after: Option<crate::errorfile::FitSection>,
    /// The gap before discovery.
    pub gap_before: GapSize,
    /// The gap after.
    pub gap_after: GapSize,
    /// The simulated CMM noise, um.
    pub noise_um: f64,
    /// The example program's tool-tip deviation before compensation.
    pub tip_before: PathError,
    /// After.
    pub tip_after: PathError,
    /// The discovery's story, as printed by `fivecal discover`.
    pub story: String,
    /// Files written, relative to the output directory.
    pub files: Vec<PathBuf>,
    /// The output directory.
    pub out: PathBuf,
    /// The machine before (`analyzed.yaml`) and after the export
    /// (`analyzed.after.yaml`).
    pub verify: Comparison,
    /// The verdict of the location-only analysis of the piece measured
    /// after the export (`fivecal verify` refuses it unless it fits).
    pub fit_verified: Option<crate::errorfile::FitSection>,
    /// The results store the runs were recorded in, and their ids.
    pub store: (PathBuf, Vec<i64>),
}

/// Runs the demo, calling `progress` as each stage starts.
pub fn run(cfg: &DemoConfig, progress: &mut dyn FnMut(Stage)) -> Result<Demo, DemoError> {
    let out = &cfg.out;
    let mut files: Vec<PathBuf> = Vec::new();

    progress(Stage::Plan);
    let (machine, manifest_path, loaded) = plan_stage(out, &mut files)?;

    progress(Stage::Simulate);
    let (kin, truth_path, truth, measured) = simulate_stage(cfg, &loaded, &mut files)?;

    progress(Stage::Analyze);
    let e = Stage::Analyze;
    let outcome = analyze::run(&analyze::Request {
        rebuilt: Some(loaded.clone()),
        ..analyze::Request::new(&manifest_path, vec![measured.clone()])
    })
    .at(e)?;
    // Every run is kept in a results store beside the files, as `analyze`,
    // `discover` and `compensate --export` keep theirs.
    let store_path = out.join("history.db");
    let mut store = Store::open(&Location::Sqlite(store_path.clone())).at(e)?;
    let mut ids = Vec::new();
    let analyzed_path = out.join("analyzed.yaml");
    for p in analyze::result::write(&outcome, &analyzed_path, false).at(e)? {
        files.push(rel(out, &p));
    }
    let written = analyze::result::files(&outcome, &analyzed_path, false).at(e)?;
    let notes = RunNotes {
        note: Some("fivecal demo: the machine as built".into()),
        ..RunNotes::default()
    };
    for r in runs::analysis(
        &outcome,
        &manifest_path,
        std::slice::from_ref(&measured),
        &written,
        &notes,
    )
    .at(e)?
    {
        ids.push(store.record(&r).at(e)?);
    }
    let analyze::Found::Identified(identified) = outcome.found else {
        return Err("the stepped-square test identifies location errors").at(e);
    };
    let analysis = &identified.pieces[0];
    let (data, est) = (&analysis.data, &analysis.est);
    let report_dir = out.join("report");
    for p in crate::report::write(
        &report_dir,
        &crate::report::ReportInput::for_piece(identified.test.as_str(), analysis, &manifest_path),
    )
    .at(e)?
    {
        files.push(rel(out, &p));
    }

    progress(Stage::Discover);
    let e = Stage::Discover;
    let discovery = discover::run(&kin, data, Some(&loaded), &DiscoverOptions::default()).at(e)?;
    let story = discovery.story.render();
    let story_path = out.join("discover.txt");
    write_atomic(&story_path, story.as_bytes()).at(e)?;
    files.push(rel(out, &story_path));
    let final_est = discovery.identification(data);
    // Judged against the same noise as the first analysis, as `discover
    // --out` writes it.
    let expected = crate::analyze::goodness::ExpectedNoise::new(None, data.kind, identified.test);
    let final_file = discovery.error_file(data, std::slice::from_ref(&expected));
    let final_path = out.join("discovered.yaml");
    let final_text = final_file.to_yaml();
    write_atomic(&final_path, final_text.as_bytes()).at(e)?;
    files.push(rel(out, &final_path));
    let rec = runs::discovery(
        MACHINE,
        identified.test.as_str(),
        std::slice::from_ref(&manifest_path),
        std::slice::from_ref(&measured),
        &final_path,
        &final_text,
        &notes,
    )
    .at(e)?;
    ids.push(store.record(&rec).at(e)?);

    progress(Stage::Compensate);
    let (identified, tip_before, tip_after) =
        compensate_stage(out, &machine, &final_path, &truth_path, &mut files)?;

    progress(Stage::Verify);
    let (verify, fit_verified) = verify_stage(
        cfg,
        &Exported {
            loaded: &loaded,
            kin: &kin,
            manifest_path: &manifest_path,
            truth_path: &truth_path,
            identified: &identified,
            final_path: &final_path,
            final_text: &final_text,
            final_file: &final_file,
        },
        (&mut store, &mut ids),
        &mut files,
    )?;
    files.push(rel(out, &store_path));

    Ok(Demo {
        verify,
        fit_verified,
        store: (store_path, ids),
        rows: rows(&truth, est, &final_est),
        added: added(&discovery, &truth),
        hidden: hidden(&truth),
        fit_before: analysis.fit.clone(),
        fit_after: final_file.fit.clone(),
        gap_before: GapSize {
            rms_um: discovery.story.start.gap.rms_um,
            max_um: discovery.story.start.gap.max_um,
        },
        gap_after: GapSize {
            rms_um: discovery.story.end.gap.rms_um,
            max_um: discovery.story.end.gap.max_um,
        },
        noise_um: truth.noise.cmm.unwrap_or(simulate::DEFAULT_NOISE_UM),
        tip_before,
        tip_after,
        story,
        files,
        out: out.clone(),
    })
}

/// The plan stage: the stepped-square test planned for the built-in machine
/// in FANUC and written; the machine, the plan's manifest and the plan as
/// `analyze` loads it.
fn plan_stage(
    out: &Path,
    files: &mut Vec<PathBuf>,
) -> Result<(Machine, PathBuf, procedure::Plan), DemoError> {
    let e = Stage::Plan;
    let machine = Machine::builtin(MACHINE)
        .ok_or("the built-in machine is missing")
        .at(e)?;
    let template = Template::builtin(Test::SteppedSquare);
    let planned = procedure::plan(&PlanConfig {
        machine: machine.clone(),
        template,
        post: PostDefinition::builtin(Dialect::Fanuc),
        kinematics: KinematicsMode::Post,
        tool: None,
    })
    .at(e)?;
    let plan_dir = out.join("plan");
    let stem = planned.test().as_str();
    for p in planned.write(&plan_dir, stem, &[]).at(e)? {
        files.push(rel(out, &p));
    }
    let manifest_path = plan_dir.join(format!("{stem}.plan.yaml"));
    let loaded = procedure::load(&manifest_path).at(e)?;
    Ok((machine, manifest_path, loaded))
}

/// The simulate stage: the truth written and the plan run on the machine
/// it describes, the measurements written as DMIS; the plan's kinematics,
/// the truth (path and loaded) and the measured file.
fn simulate_stage(
    cfg: &DemoConfig,
    loaded: &procedure::Plan,
    files: &mut Vec<PathBuf>,
) -> Result<(Kinematics, PathBuf, LoadedErrors, PathBuf), DemoError> {
    let out = &cfg.out;
    let e = Stage::Simulate;
    let kin = simulate::plan_kinematics(loaded);
    let truth_path = out.join("truth.yaml");
    write_atomic(&truth_path, TRUTH.as_bytes()).at(e)?;
    files.push(rel(out, &truth_path));
    let truth = ErrorFile::load(&truth_path, &kin).at(e)?;
    let sim = simulate::run(
        loaded,
        &truth,
        &SimOptions {
            seed: cfg.seed,
            ..SimOptions::default()
        },
    )
    .at(e)?;
    let measured = out.join("measured.dmo");
    sim.write(Format::Dmis, &measured).at(e)?;
    files.push(rel(out, &measured));
    Ok((kin, truth_path, truth, measured))
}

/// The compensate stage: the example program written, compensated with the
/// discovered errors, and its tool-tip deviation under the truth before and
/// after; the discovered errors loaded for the tool's kinematics.
fn compensate_stage(
    out: &Path,
    machine: &Machine,
    final_path: &Path,
    truth_path: &Path,
    files: &mut Vec<PathBuf>,
) -> Result<(LoadedErrors, PathError, PathError), DemoError> {
    let e = Stage::Compensate;
    let tool_kin = Kinematics::new(machine);
    let text = program::frustum_program(&tool_kin).at(e)?;
    let original = out.join("frustum.nc");
    write_atomic(&original, text.as_bytes()).at(e)?;
    files.push(rel(out, &original));
    let identified = ErrorFile::load(final_path, &tool_kin).at(e)?;
    let compensated = out.join("frustum.compensated.nc");
    let c = Compensator::new(
        &identified.model,
        &identified.theta,
        Settings::new(Dialect::Fanuc),
    );
    let mut w = AtomicOutput::create(&compensated).at(e)?;
    c.run(&original, text.as_bytes(), &mut w).at(e)?;
    w.commit().at(e)?;
    files.push(rel(out, &compensated));
    let truth_tool = ErrorFile::load(truth_path, &tool_kin).at(e)?;
    let (tip_before, tip_after) = tip_errors(&truth_tool, &original, &compensated).at(e)?;
    Ok((identified, tip_before, tip_after))
}

/// What the verify stage starts from: the plan and its kinematics, the
/// truth, the discovered errors (loaded, as written and as a file) and the
/// first analysis' result file.
struct Exported<'a> {
    loaded: &'a procedure::Plan,
    kin: &'a Kinematics,
    manifest_path: &'a Path,
    truth_path: &'a Path,
    identified: &'a LoadedErrors,
    final_path: &'a Path,
    final_text: &'a str,
    final_file: &'a ErrorFile,
}

/// The verify stage: the discovered location errors exported into the
/// control, the machine after the export (the truth less what was exported)
/// measured and analysed again, and its result compared with the first;
/// the runs recorded in the store.
fn verify_stage(
    cfg: &DemoConfig,
    x: &Exported<'_>,
    (store, ids): (&mut Store, &mut Vec<i64>),
    files: &mut Vec<PathBuf>,
) -> Result<(Comparison, Option<crate::errorfile::FitSection>), DemoError> {
    let out = &cfg.out;
    let Exported {
        loaded,
        kin,
        manifest_path,
        truth_path,
        identified,
        final_path,
        final_text,
        final_file,
    } = *x;
    let e = Stage::Verify;
    // The control takes the discovered location errors as its pivot
    // parameters: the machine after the export keeps, of each location
    // error, what the export missed (the truth less the value exported),
    // and all of its other effects.
    let exported = crate::compensate::export::export(
        &identified.model,
        &identified.theta,
        &identified.u,
        Dialect::Fanuc,
        &final_path.display().to_string(),
        &crate::compensate::export::Limits::default(),
    )
    .at(e)?
    .text;
    let export_path = out.join("export.fanuc.txt");
    write_atomic(&export_path, exported.as_bytes()).at(e)?;
    files.push(rel(out, &export_path));
    let rec = runs::export(
        MACHINE,
        final_path,
        final_text,
        "fanuc",
        &exported,
        &RunNotes {
            note: Some("fivecal demo: the discovered location errors into the control".into()),
            ..RunNotes::default()
        },
    )
    .at(e)?;
    ids.push(store.record(&rec).at(e)?);
    let mut after_truth: ErrorFile = ErrorFile::parse(truth_path, TRUTH).at(e)?;
    for (sym, q) in after_truth.location_errors.iter_mut() {
        if let Some(x) = final_file.location_errors.get(sym) {
            q.value -= x.value;
        }
    }
    let after_truth_path = out.join("truth.after.yaml");
    write_atomic(&after_truth_path, after_truth.to_yaml().as_bytes()).at(e)?;
    files.push(rel(out, &after_truth_path));
    let after_truth = ErrorFile::load(&after_truth_path, kin).at(e)?;
    let sim_after = simulate::run(
        loaded,
        &after_truth,
        &SimOptions {
            seed: cfg.seed.wrapping_add(1),
            ..SimOptions::default()
        },
    )
    .at(e)?;
    let measured_after = out.join("measured.after.dmo");
    sim_after.write(Format::Dmis, &measured_after).at(e)?;
    files.push(rel(out, &measured_after));
    let outcome_after = analyze::run(&analyze::Request {
        rebuilt: Some(loaded.clone()),
        ..analyze::Request::new(manifest_path, vec![measured_after.clone()])
    })
    .at(e)?;
    let after_path = out.join("analyzed.after.yaml");
    for p in analyze::result::write(&outcome_after, &after_path, false).at(e)? {
        files.push(rel(out, &p));
    }
    let written = analyze::result::files(&outcome_after, &after_path, false).at(e)?;
    for r in runs::analysis(
        &outcome_after,
        manifest_path,
        std::slice::from_ref(&measured_after),
        &written,
        &RunNotes {
            note: Some("fivecal demo: after the export".into()),
            ..RunNotes::default()
        },
    )
    .at(e)?
    {
        ids.push(store.record(&r).at(e)?);
    }
    let analyze::Found::Identified(after) = &outcome_after.found else {
        return Err("the stepped-square test identifies location errors").at(e);
    };
    // Before: the discovered model, the first result that fits (the
    // first analysis is a misfit, whose values verify refuses).
    let before_name = final_path
        .file_name()
        .map_or("discovered.yaml".into(), |n| {
            n.to_string_lossy().to_string()
        });
    // The new piece drifts as the first did (the control holds location
    // errors only): its location-only analysis is judged, and the summary
    // says whether `fivecal verify` takes it.
    let verify = Comparison::unjudged(
        (&before_name, final_file),
        ("analyzed.after.yaml", &after.pieces[0].file),
        None,
    )
    .at(e)?;
    Ok((verify, after.pieces[0].fit.clone()))
}

fn rel(base: &Path, p: &Path) -> PathBuf {
    p.strip_prefix(base).unwrap_or(p).to_path_buf()
}

fn value(est: &Identification, name: &str) -> Option<(f64, f64)> {
    match est.get(name) {
        Some((v, Some(u))) => Some((v, u)),
        _ => None,
    }
}

fn rows(truth: &LoadedErrors, first: &Identification, last: &Identification) -> Vec<DemoRow> {
    let names = truth.model.param_names();
    let units = truth.model.param_units();
    let range = match truth.model.find("location") {
        Some(i) => truth.model.param_range(i),
        None => 0..0,
    };
    range
        .map(|i| DemoRow {
            symbol: names[i].clone(),
            unit: units[i].clone(),
            truth: truth.theta[i],
            analyzed: value(first, &names[i]),
            discovered: value(last, &names[i]),
        })
        .collect()
}

fn hidden(truth: &LoadedErrors) -> Vec<(String, String, f64)> {
    let m = &truth.model;
    let names = m.param_names();
    let mut v = Vec::new();
    for (k, eff) in m.effects.iter().enumerate() {
        let id = eff.id(&m.symbols);
        if id == "location" {
            continue;
        }
        for i in m.param_range(k) {
            v.push((id.clone(), names[i].clone(), truth.theta[i]));
        }
    }
    v
}

fn added(d: &Discovery, truth: &LoadedErrors) -> Vec<(String, Vec<FoundValue>)> {
    let tn = truth.model.param_names();
    d.story
        .steps
        .iter()
        .map(|s| {
            // The values of the final model, not the step's provisional
            // ones: later steps refit them.
            let vals = s
                .provisional_values
                .iter()
                .map(|p| {
                    let v = d
                        .story
                        .end
                        .values
                        .iter()
                        .find(|v| v.name == p.name)
                        .unwrap_or(p);
                    let t = tn.iter().position(|n| *n == v.name).map(|i| truth.theta[i]);
                    (v.name.clone(), v.value, t)
                })
                .collect();
            (s.effect.clone(), vals)
        })
        .collect()
}

/// Runs `program` on the machine of `errors` with parameters `theta`,
/// feed moves sampled every half millimetre, calling `sink` with each
/// sample.
fn run_program(
    errors: &LoadedErrors,
    theta: &[f64],
    program: &Path,
    sink: &mut dyn FnMut(&Sample),
) -> Result<(), String> {
    let mut s = SimSettings::new(Dialect::Fanuc);
    s.step = 0.5;
    let sim = Simulator::new(&errors.model, theta, s);
    let text =
        std::fs::read_to_string(program).map_err(|e| format!("{}: {e}", program.display()))?;
    sim.run(program, text.as_bytes(), &mut |x| sink(x))
        .map_err(|e| e.to_string())?;
    Ok(())
}

/// How far `program`, run on the machine of the truth, puts the tool tip
/// from `intended` (as `simulate nc PROGRAM --against ORIGINAL --step 0.5`
/// reports it).
fn deviation(
    truth: &LoadedErrors,
    intended: &IntendedPath,
    program: &Path,
) -> Result<PathError, String> {
    let mut f = Follower::new(intended)
        .ok_or_else(|| format!("{}: no path to follow", program.display()))?;
    run_program(truth, &truth.theta, program, &mut |x| {
        f.add(x);
    })?;
    let d = f.finish();
    Ok(PathError {
        rms_um: d.rms_um,
        max_um: d.max_um.map_or(0.0, |m| m.value),
        samples: d.samples,
    })
}

/// How far the original and the compensated program put the tool tip from
/// the path the original asks for, on the machine of the truth.
fn tip_errors(
    truth: &LoadedErrors,
    original: &Path,
    compensated: &Path,
) -> Result<(PathError, PathError), String> {
    let zero = vec![0.0; truth.theta.len()];
    let mut intended = IntendedPath::new();
    run_program(truth, &zero, original, &mut |x| intended.push(x))?;
    Ok((
        deviation(truth, &intended, original)?,
        deviation(truth, &intended, compensated)?,
    ))
}

impl Demo {
    /// The one-screen summary.
    pub fn summary(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "fivecal demo: stepped-square test on the virtual {MACHINE} (FANUC), CMM noise {:.2} um",
            self.noise_um
        );
        let _ = writeln!(s);
        let _ = writeln!(
            s,
            "location errors       truth   analyzed (u)         after discovery (u)   |err|/u"
        );
        for r in &self.rows {
            let f = |v: Option<(f64, f64)>| match v {
                Some((x, u)) => format!("{x:>8.2} ({u:>5.2})"),
                None => format!("{:>16}", "not identifiable"),
            };
            let z = match r.discovered {
                Some((x, u)) if u > 0.0 => format!("{:>6.1}", (x - r.truth).abs() / u),
                _ => "     -".into(),
            };
            let _ = writeln!(
                s,
                "  {:<8} {:<5} {:>8.2}   {}     {}    {z}",
                r.symbol,
                r.unit,
                r.truth,
                f(r.analyzed),
                f(r.discovered)
            );
        }
        let _ = writeln!(s);
        let hidden: Vec<String> = self
            .hidden
            .iter()
            .map(|(id, p, v)| format!("{id} ({p} = {v})"))
            .collect();
        let _ = writeln!(s, "hidden in the truth: {}", hidden.join(", "));
        if self.added.is_empty() {
            let _ = writeln!(s, "discovered: nothing");
        }
        for (id, vals) in &self.added {
            let v: Vec<String> = vals
                .iter()
                .map(|(n, x, t)| match t {
                    Some(t) => format!("{n} = {x:.3} (truth {t})"),
                    None => format!("{n} = {x:.3}"),
                })
                .collect();
            let _ = writeln!(s, "discovered: {id}: {}", v.join(", "));
        }
        let judged = |f: &Option<crate::errorfile::FitSection>| match f {
            Some(f) => format!(
                "{} (residuals {:.2} um against {:.2} um expected, ratio {:.2})",
                match f.verdict {
                    crate::errorfile::FitVerdict::Fits => "fits",
                    crate::errorfile::FitVerdict::Misfit => "does NOT fit",
                    crate::errorfile::FitVerdict::NotConverged => "did NOT converge",
                },
                f.sigma_um,
                f.expected_um,
                f.ratio
            ),
            None => "cannot be judged (no degrees of freedom)".into(),
        };
        let _ = writeln!(
            s,
            "first analysis: the location-only model {}",
            judged(&self.fit_before)
        );
        if self
            .fit_before
            .as_ref()
            .is_some_and(|f| f.verdict == crate::errorfile::FitVerdict::Misfit)
        {
            let _ = writeln!(
                s,
                "  why the analyzed column is off: the measurements carry an effect the location errors cannot express \
                 (hidden in the truth, above), so the fit bends them to absorb it; analyzed.yaml says so (fit: misfit) \
                 and compensate refuses it without --accept-misfit"
            );
        }
        let _ = writeln!(
            s,
            "after discovery: the refined model {}",
            judged(&self.fit_after)
        );
        let _ = writeln!(
            s,
            "gap (measured - model): {:.2} um RMS, {:.2} um max before discovery; {:.2} um RMS, {:.2} um max after",
            self.gap_before.rms_um,
            self.gap_before.max_um,
            self.gap_after.rms_um,
            self.gap_after.max_um
        );
        let _ = writeln!(
            s,
            "example program frustum.nc, tool tip from the intended path: {:.1} um RMS, {:.1} um max as written; {:.1} um RMS, {:.1} um max compensated",
            self.tip_before.rms_um,
            self.tip_before.max_um,
            self.tip_after.rms_um,
            self.tip_after.max_um
        );
        let _ = writeln!(
            s,
            "  the same figures by hand: fivecal simulate nc --machine {MACHINE} --errors {} {} --against {} --step 0.5 (and the program itself in place of the compensated one)",
            self.out.join("truth.yaml").display(),
            self.out.join("frustum.compensated.nc").display(),
            self.out.join("frustum.nc").display()
        );
        let zero = self
            .verify
            .changes
            .iter()
            .filter(|c| c.zero_after() == Some(true))
            .count();
        match self.fit_verified.as_ref().filter(|f| !f.verdict.is_fit()) {
            None => {
                let _ = writeln!(
                    s,
                    "after exporting the discovered errors to the control and measuring again: {zero} of {} location errors within 2u of zero (fivecal verify --before {d}/{} --after {d}/analyzed.after.yaml)",
                    self.verify.changes.len(),
                    self.verify.before,
                    d = self.out.display()
                );
            }
            Some(f) => {
                let _ = writeln!(
                    s,
                    "after exporting the discovered errors to the control and measuring again: the new piece's location-only analysis {} too (the control holds location errors; the drift is still there), so fivecal verify refuses analyzed.after.yaml: discover its model (fivecal discover --plan {d}/plan/stepped-square.plan.yaml --measured {d}/measured.after.dmo) before verifying",
                    judged(&Some(f.clone())),
                    d = self.out.display()
                );
            }
        }
        let _ = writeln!(
            s,
            "recorded as records {} in {} (fivecal history --db {})",
            self.store
                .1
                .iter()
                .map(|i| i.to_string())
                .collect::<Vec<_>>()
                .join(", "),
            self.store.0.display(),
            self.store.0.display()
        );
        let _ = writeln!(s);
        let _ = writeln!(
            s,
            "files in {}: plan/ (program, points, DMIS, model, setup sheet), measured.dmo, analyzed.yaml, report/index.html, discover.txt, discovered.yaml, frustum.nc, frustum.compensated.nc, export.fanuc.txt, truth.after.yaml, measured.after.dmo, analyzed.after.yaml, history.db",
            self.out.display()
        );
        s
    }
}
