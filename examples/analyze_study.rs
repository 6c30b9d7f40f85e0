//! The full-size studies behind issue 6's uncertainty claims, on the
//! simulator (the test suite runs them sized down, see
//! `tests/analyze_sim.rs`):
//!
//! 1. recovery: the planners' stepped square on `bc-trunnion`, column
//!    probing and the calibration sphere on `ac-trunnion`, all eight
//!    location errors set, 0.35 um of noise, 20 seeds, every method that
//!    applies: how many symbols fall within two and four reported standard
//!    uncertainties of the truth;
//! 2. spread: 200 seeded simulations of each test (noise only), each
//!    identified by every method: the spread of the estimates against the
//!    mean reported uncertainty and the Cramér-Rao bound of the design
//!    (from the simulator's forward model).
//!
//! Run `cargo run --release --example analyze_study [RUNS]` (RUNS = 200 by
//! default; under a minute on two cores).

use fivecal::analyze::uncertainty::simulated::{self, SimulatedTest};
use fivecal::analyze::uncertainty::{Contributors, McOptions};
use fivecal::errorfile::{ErrorFile, LoadedErrors};
use fivecal::formats::manifest::KinematicsMode;
use fivecal::identify::sphere::SphereOptions;
use fivecal::identify::{Method, Setup};
use fivecal::post::PostDefinition;
use fivecal::procedure::{Plan, PlanConfig, Template};
use fivecal::simulate::{self, NoiseOverrides, SimOptions};
use fivecal::{Dialect, Machine};

const NOISE_UM: f64 = 0.35;

const BC_ERRORS: &str = "location_errors:
  EX0B: 12.0
  EZ0B: -40.0
  EA0B: 80.0
  EC0B: -60.0
  EB0B: 150.0
  EX(0B)C: 25.0
  EY0C: -18.0
  EA(0B)C: 45.0
";

const AC_ERRORS: &str = "location_errors:
  EY0A: 15.0
  EZ0A: -30.0
  EB0A: 60.0
  EC0A: -90.0
  EA0A: 120.0
  EY(0A)C: 20.0
  EX0C: -25.0
  EB(0A)C: 40.0
";

fn planned(machine: &str, test: &str) -> Plan {
    fivecal::procedure::plan(&PlanConfig {
        machine: Machine::builtin(machine).unwrap(),
        template: Template::builtin(test.parse().unwrap()),
        post: PostDefinition::builtin(Dialect::Fanuc),
        kinematics: KinematicsMode::Post,
        tool: None,
    })
    .unwrap()
}

fn truth(plan: &Plan, yaml: &str) -> LoadedErrors {
    let kin = simulate::plan_kinematics(plan);
    let src = format!("machine: {}\n{yaml}", kin.machine().name);
    let path = std::path::Path::new("truth.yaml");
    ErrorFile::parse(path, &src)
        .and_then(|f| f.to_model(&kin, path, &src))
        .unwrap()
}

fn options(seed: u64) -> SimOptions {
    SimOptions {
        seed,
        noise: NoiseOverrides {
            cmm_um: Some(NOISE_UM),
            probe_um: Some(NOISE_UM),
        },
        ..SimOptions::default()
    }
}

fn short(m: Method) -> &'static str {
    match m {
        Method::Global => "G",
        Method::TwoStage => "2S",
        Method::Sphere => "S",
    }
}

fn main() {
    let runs: usize = std::env::args()
        .nth(1)
        .map(|s| s.parse().expect("RUNS: a number of simulations"))
        .unwrap_or(200);
    let both = [Method::Global, Method::TwoStage];
    let sphere = [Method::Sphere, Method::Global];
    for (machine, test, errors, methods) in [
        ("bc-trunnion", "stepped-square", BC_ERRORS, &both),
        ("ac-trunnion", "probe-columns", AC_ERRORS, &both),
        ("ac-trunnion", "probe-sphere", AC_ERRORS, &sphere),
    ] {
        let plan = planned(machine, test);
        let t = truth(&plan, errors);
        let names = t.model.param_names();
        println!("== {test} on {machine}: eight location errors, {NOISE_UM} um noise");

        // 1. Twenty seeds, every method.
        let mut z_all: Vec<(Method, Vec<f64>)> = methods.iter().map(|&m| (m, Vec::new())).collect();
        for seed in 0..20 {
            let out = simulate::run(&plan, &t, &options(100 + seed)).unwrap();
            let data = simulated::plan_dataset(&plan, "sim", out.points).unwrap();
            let setup = Setup::new(&simulate::plan_kinematics(&plan), &data.poses, &[]).unwrap();
            for (m, zs) in z_all.iter_mut() {
                let est = fivecal::analyze::method::identify_with_plan(
                    *m,
                    &setup,
                    &data,
                    &SphereOptions::default(),
                    Some(&plan),
                )
                .unwrap();
                for (i, name) in names.iter().enumerate() {
                    let (v, u) = est.get(name).unwrap();
                    zs.push((v - t.theta[i]).abs() / u.expect("identifiable"));
                }
            }
        }
        println!("recovery over 20 seeds (|estimate - truth| / reported u):");
        for (m, zs) in &z_all {
            let within = |k: f64| zs.iter().filter(|z| **z < k).count();
            println!(
                "  {:<10} {} symbols: {} within 2 u ({:.1} %), {} within 4 u, largest {:.2} u",
                m.name(),
                zs.len(),
                within(2.0),
                100.0 * within(2.0) as f64 / zs.len() as f64,
                within(4.0),
                zs.iter().copied().fold(0.0, f64::max)
            );
        }

        // 2. The spread of `runs` simulations.
        let out = simulate::run(&plan, &t, &options(1)).unwrap();
        let data = simulated::plan_dataset(&plan, "sim", out.points).unwrap();
        let setup = Setup::new(&simulate::plan_kinematics(&plan), &data.poses, &[]).unwrap();
        let st = SimulatedTest {
            plan: &plan,
            model: &t.model,
            theta: t.theta.clone(),
            setup: &setup,
            data: &data,
            method: Method::Global,
            sphere: SphereOptions::default(),
            contributors: Contributors::noise_only(NOISE_UM),
        };
        let bound = simulated::design_bound(&st).unwrap();
        let start = std::time::Instant::now();
        let studies = simulated::study(
            &st,
            methods,
            &McOptions {
                runs,
                seed: 2026,
                progress: true,
                max_seconds: None,
            },
        );
        println!(
            "spread of {runs} simulations ({:.0} s): spread / mean reported u, mean reported u / Cramer-Rao bound",
            start.elapsed().as_secs_f64()
        );
        let mut head = format!("  {:<9} {:>8} {:>8}", "symbol", "truth", "CRB");
        for m in methods {
            head += &format!(
                " | {:>10} {:>8} {:>7} {:>7}",
                format!("{} spread", short(*m)),
                format!("{} u", short(*m)),
                "sp/u",
                "u/CRB"
            );
        }
        println!("{head}");
        let mut worst = [0.0f64; 4];
        for (i, name) in names.iter().enumerate() {
            let crb = bound.u(i).unwrap_or(f64::NAN);
            let mut line = format!("  {name:<9} {:>8.1} {crb:>8.3}", t.theta[i]);
            for (k, s) in studies.iter().enumerate() {
                let (sp, u) = (s.spread[i], s.mean_u[i]);
                worst[2 * k] = worst[2 * k].max((sp / u - 1.0).abs());
                worst[2 * k + 1] = worst[2 * k + 1].max((u / crb - 1.0).abs());
                line += &format!(" | {sp:>10.3} {u:>8.3} {:>7.3} {:>7.3}", sp / u, u / crb);
            }
            println!("{line}");
        }
        for (k, s) in studies.iter().enumerate() {
            println!(
                "  {}: {} runs, {} failed; largest |spread/u - 1| {:.1} %, largest |u/CRB - 1| {:.1} %",
                s.method,
                s.runs,
                s.failed.0,
                100.0 * worst[2 * k],
                100.0 * worst[2 * k + 1]
            );
        }
        println!();
    }
}
