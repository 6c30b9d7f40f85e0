//! `fivecal plan <test>`: writes a machining test as an NC program with its
//! nominal points, CMM program, 3-D model and setup sheet, or a probing test
//! as an NC program that logs its touches, with its nominal points, a 3-D
//! model of the setup and a setup sheet. The options are validated into
//! one configuration in `config/plan.rs`; this plans, predicts what the
//! plan identifies, and writes.

use std::path::{Path, PathBuf};

use anyhow::{Context as _, bail};
use fivecal::analyze::preview::Preview;
use fivecal::formats::manifest::Identifies;
use fivecal::formats::manifest::KinematicsMode;
use fivecal::procedure::{Plan, plan};
use serde::Serialize;

use crate::config::plan::{PlanArgs, Route, recipe, route};

pub fn run(args: PlanArgs) -> anyhow::Result<()> {
    let cfg = match route(args)? {
        Route::Test(cfg) => *cfg,
        Route::BallBar { cfg, json } => return super::ball_bar::plan(cfg, json),
        Route::LaserLines { cfg, json } => return super::laser::plan(cfg, json),
    };
    if cfg.json {
        // Standard output is the JSON's: what the run says goes to
        // standard error.
        crate::out::to_stderr();
    }
    let inputs: Vec<&Path> = cfg.inputs.iter().map(|p| p.as_path()).collect();
    fivecal::io::check_outputs(&inputs, &[("--out", &cfg.out, fivecal::io::Shape::Dir)])?;
    let p = &cfg.plan;
    let planned = plan(p).with_context(|| {
        format!(
            "cannot plan {} on {} ({})",
            p.test(),
            p.machine.name,
            p.post.dialect
        )
    })?;
    let predicted = fivecal::analyze::preview::predict_useful(&planned, None, None, &cfg.useful)
        .with_context(|| format!("cannot predict what {} identifies", planned.test()))?;
    // What would identify what the design leaves unidentified.
    let suggested = fivecal::discover::suggest::suggest(p, &planned, &predicted, None);
    let recipe = recipe(&cfg, planned.test());
    // `--require all` met by two runs analysed together (a second probe
    // length): both programs are written, the second beside the first.
    let mut second_run = None;
    if cfg.require_all {
        let missing = predicted.missing();
        if !missing.is_empty() {
            let pair = suggested.found.iter().find_map(|s| {
                let run = s.second.as_ref()?;
                if !s.prediction.missing().is_empty() {
                    return None;
                }
                let plan = fivecal::discover::suggest::second_run_plan(p, run)?;
                Some((run.clone(), plan))
            });
            match pair {
                Some(pair) => second_run = Some(pair),
                None => bail!(
                    "--require all: {} on {} does not identify {} (nothing written):\n{}{}\
                     (the files this advice copies are written beside the plan by the same command without --require all)",
                    planned.test(),
                    planned.machine().name,
                    missing.join(", "),
                    predicted.render(),
                    suggested.render(&recipe)
                ),
            }
        }
    }
    let second_dir = PathBuf::from(recipe.second_out());
    if second_run.is_some() {
        fivecal::io::check_outputs(&inputs, &[("--out", &second_dir, fivecal::io::Shape::Dir)])?;
    }
    // The error already names the path and its cause.
    let written = planned
        .write_with(
            &cfg.out,
            planned.test().as_str(),
            &inputs,
            &(predicted.markdown() + &suggested.markdown(&recipe)),
            Some(&predicted.manifest_entry()),
            &suggested.manifest_entries(&recipe),
        )
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    match &planned {
        Plan::Machining(t) => outln!(
            "{} on {}: {} poses, {} points, about {:.0} min ({} dialect, kinematics {})",
            t.test,
            t.machine.name,
            t.poses.len(),
            t.points.len(),
            t.run_minutes,
            t.dialect,
            match t.kinematics {
                KinematicsMode::Post => "post",
                KinematicsMode::Controller => "controller",
            }
        ),
        Plan::Probing(p) => outln!(
            "{} on {}: {} poses, {} touches, about {:.0} min ({} dialect)",
            p.test,
            p.machine.name,
            p.plan.poses.len(),
            p.plan.touches.len(),
            p.run_minutes(),
            p.dialect
        ),
    }
    out!("{}", predicted.render());
    out!("{}", suggested.render(&recipe));
    if predicted.method != fivecal::identify::Method::Global {
        let global = fivecal::analyze::preview::predict(
            &planned,
            Some(fivecal::identify::Method::Global),
            None,
        );
        if let Ok(global) = global
            && global.missing().len() < predicted.missing().len()
        {
            let b = global.missing().len();
            outln!(
                "note: the global method identifies {} of {} (fivecal analyze --method global)",
                global.rows.len() - b,
                global.rows.len()
            );
        }
    }
    outln!("note: {}", cfg.origin);
    for n in planned.notes() {
        outln!("note: {n}");
    }
    for w in &written {
        outln!("wrote {}", w.display());
    }
    let mut report = Planned::new(&planned, &predicted, &written);
    if let Some((run, second)) = second_run {
        let alone = fivecal::analyze::preview::predict_useful(&second, None, None, &cfg.useful)
            .with_context(|| format!("cannot predict what {} identifies", second.test()))?;
        let written = second
            .write_with(
                &second_dir,
                second.test().as_str(),
                &inputs,
                &alone.markdown(),
                Some(&alone.manifest_entry()),
                &[],
            )
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        outln!(
            "--require all: met by two runs analysed together (their u from the noise alone, a floor: analyze or discover of the measured runs states the full u); the second, with a {} mm probe, is in {}",
            run.probe_length,
            second_dir.display()
        );
        for w in &written {
            outln!("wrote {}", w.display());
        }
        report.second_run = Some(SecondRun {
            dir: second_dir.display().to_string(),
            probe_length_mm: run.probe_length,
            identifies: alone.manifest_entry(),
            files: written.iter().map(|w| w.display().to_string()).collect(),
        });
    }
    if cfg.json {
        crate::out::json_of(&report)?;
    }
    Ok(())
}

/// What `plan --json` prints.
#[derive(Serialize)]
struct Planned {
    test: String,
    machine: String,
    dialect: String,
    /// Machining tests: how 3+2 positions are written (`post`,
    /// `controller`).
    #[serde(skip_serializing_if = "Option::is_none")]
    kinematics: Option<&'static str>,
    poses: usize,
    /// Points of the machined piece (machining) or touches (probing).
    points: usize,
    run_minutes: f64,
    /// What the test identifies, as the manifest's `identifies:`.
    identifies: Identifies,
    /// The location errors it leaves unidentified.
    missing: Vec<String>,
    notes: Vec<String>,
    files: Vec<String>,
    /// `--require all` met by a second run with another probe length.
    #[serde(skip_serializing_if = "Option::is_none")]
    second_run: Option<SecondRun>,
}

#[derive(Serialize)]
struct SecondRun {
    dir: String,
    probe_length_mm: f64,
    identifies: Identifies,
    files: Vec<String>,
}

impl Planned {
    fn new(planned: &Plan, predicted: &Preview, written: &[PathBuf]) -> Planned {
        let (kinematics, poses, points, run_minutes) = match planned {
            Plan::Machining(t) => (
                Some(match t.kinematics {
                    KinematicsMode::Post => "post",
                    KinematicsMode::Controller => "controller",
                }),
                t.poses.len(),
                t.points.len(),
                t.run_minutes,
            ),
            Plan::Probing(p) => (
                None,
                p.plan.poses.len(),
                p.plan.touches.len(),
                p.run_minutes(),
            ),
        };
        Planned {
            test: planned.test().to_string(),
            machine: planned.machine().name.clone(),
            dialect: match planned {
                Plan::Machining(t) => t.dialect.to_string(),
                Plan::Probing(p) => p.dialect.to_string(),
            },
            kinematics,
            poses,
            points,
            run_minutes,
            identifies: predicted.manifest_entry(),
            missing: predicted.missing().iter().map(|s| s.to_string()).collect(),
            notes: planned.notes().iter().map(|n| n.to_string()).collect(),
            files: written.iter().map(|w| w.display().to_string()).collect(),
            second_run: None,
        }
    }
}
