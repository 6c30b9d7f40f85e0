//! `simulate`: the virtual machine, as worked examples. Each test plans a
//! test with the planners, gives the machine known errors through a truth
//! file, runs the simulator and checks what comes out against a closed form
//! written here, against the forward model, or against the project's own
//! readers.

use std::collections::HashMap;
use std::path::Path;
use std::sync::{Arc, Mutex, OnceLock};

use fivecal::errorfile::{ErrorFile, LoadedErrors};
use fivecal::formats::manifest::TestKind;
use fivecal::plan::{LoadedPlan, plan};
use fivecal::simulate::{self, Placement, SimOptions};
use fivecal::{Dialect, Kinematics};
use nalgebra::Vector3;

use crate::plan::config;
use crate::probe_programs::probing;
use crate::util::MACHINES;

pub const MACHINING: [&str; 2] = ["stepped-square", "nine-section"];
pub const PROBING: [&str; 2] = ["probe-columns", "probe-sphere"];

type Plans = Mutex<HashMap<(String, String), Arc<LoadedPlan>>>;

/// A plan of the built-in template, planned once per test binary.
pub fn planned(machine: &str, test: &str) -> Arc<LoadedPlan> {
    static PLANS: OnceLock<Plans> = OnceLock::new();
    let key = (machine.to_string(), test.to_string());
    if let Some(p) = PLANS
        .get_or_init(Default::default)
        .lock()
        .unwrap()
        .get(&key)
    {
        return p.clone();
    }
    let p = Arc::new(if MACHINING.contains(&test) {
        LoadedPlan::Machining(Box::new(
            plan(&config(
                machine,
                test,
                Dialect::Fanuc,
                fivecal::formats::manifest::KinematicsMode::Post,
            ))
            .unwrap(),
        ))
    } else {
        LoadedPlan::Probing(Box::new(probing(machine, test, Dialect::Fanuc)))
    });
    PLANS
        .get_or_init(Default::default)
        .lock()
        .unwrap()
        .insert(key, p.clone());
    p
}

/// A truth file's text loaded for a plan.
pub fn truth(plan: &LoadedPlan, yaml: &str) -> LoadedErrors {
    let kin: Kinematics = simulate::plan_kinematics(plan);
    let src = format!("machine: {}\n{yaml}", kin.machine().name);
    let path = Path::new("truth.yaml");
    ErrorFile::parse(path, &src)
        .and_then(|f| f.to_model(&kin, path, &src))
        .unwrap_or_else(|e| panic!("{e}"))
}

fn nominal_points(plan: &LoadedPlan) -> Vec<Vector3<f64>> {
    match plan {
        LoadedPlan::Machining(t) => t.points.iter().map(|p| p.point.p).collect(),
        LoadedPlan::Probing(p) => p.plan.touches.iter().map(|t| t.contact_prog).collect(),
    }
}

// ---------------------------------------------------------------- zero errors

/// With all errors zero and no noise, every simulated point is its nominal
/// point, for every template on every machine; with the piece placed at
/// random on the CMM, once the placement is removed.
#[test]
fn with_no_errors_every_point_is_its_nominal_point_on_every_machine() {
    for m in MACHINES {
        for test in MACHINING.iter().chain(&PROBING) {
            let plan = planned(m, test);
            let zero = truth(&plan, "");
            let mut opts = SimOptions::exact();
            if plan.kind() == TestKind::Machining {
                opts.placement = Placement::Random;
                opts.seed = 11;
            }
            let out = simulate::run(&plan, &zero, &opts).unwrap();
            let nominal = nominal_points(&plan);
            assert_eq!(out.points.len(), nominal.len());
            let back = out.placement.inverse();
            let mut worst: f64 = 0.0;
            for (m_pt, n) in out.points.iter().zip(&nominal) {
                let w = (back * nalgebra::Point3::from(m_pt.p)).coords;
                worst = worst.max((w - n).norm());
            }
            assert!(worst < 1e-9, "{m} {test}: {worst:e} mm from nominal");
            if plan.kind() == TestKind::Machining {
                assert!(
                    out.placement.translation.vector.norm() > 1.0,
                    "{m} {test}: the piece was not moved on the CMM"
                );
            }
        }
    }
}
