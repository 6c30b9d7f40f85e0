//! `discover` as worked examples: a piece of the planner's stepped-square
//! test on `bc-trunnion` machined with the eight location errors and one
//! or two hidden effects, measured on a CMM with 0.35 um of noise in a
//! random placement, analysed from the location errors alone. Discover must
//! name the hidden effect first and close the gap to the noise; on pieces
//! without a hidden effect it must add nothing.
//!
//! The measurements are made with the foundation's exact model
//! (`identify::synthetic`: the tool point at each plan point's own
//! commanded position, the face turned with its pose), and fitted with the
//! rigid-pose forward model; both serve the location errors, maps and
//! drift.

use std::collections::HashMap;
use std::path::Path;

use fivecal::discover::{self, DiscoverOptions, Discovery, Inputs, Verdict};
use fivecal::formats::manifest::KinematicsMode;
use fivecal::identify::synthetic;
use fivecal::kinematics::maps::{MapDim, MapGrid};
use fivecal::model::{DriftBasis, Effect, Model};
use fivecal::plan::{LoadedPlan, PlanConfig, PlannedTest, Template};
use fivecal::post::PostDefinition;
use fivecal::{Dialect, Kinematics};
use rayon::prelude::*;

use crate::identify::BC_TRUTH;
use crate::util::{machine, random_placement, rng};

/// CMM noise of the simulated measurements, um (seed 001 table 4).
const NOISE: f64 = 0.35;

/// The planner's stepped square on `bc-trunnion` (FANUC, post kinematics).
pub fn stepped_square() -> PlannedTest {
    fivecal::plan::plan(&PlanConfig {
        machine: machine("bc-trunnion"),
        template: Template::builtin("stepped-square").unwrap(),
        post: PostDefinition::builtin(Dialect::Fanuc),
        kinematics: KinematicsMode::Post,
        tool: None,
    })
    .unwrap()
}

/// The truth: the eight location errors and `hidden` with its values.
fn truth(kin: &Kinematics, hidden: &[(Effect, Vec<f64>)]) -> (Model, Vec<f64>) {
    let mut effects = vec![Effect::Location {
        symbols: (0..8).collect(),
    }];
    let mut theta = BC_TRUTH.to_vec();
    for (e, v) in hidden {
        effects.push(e.clone());
        theta.extend(v);
    }
    (Model::new(kin.clone(), effects), theta)
}

/// The piece machined with the truth, measured on a CMM, as a
/// discovery's inputs.
fn measured(planned: &PlannedTest, hidden: &[(Effect, Vec<f64>)], seed: u64) -> Inputs {
    let kin = Kinematics::with_gauge_length(&planned.machine, planned.tool.length);
    let (model, theta) = truth(&kin, hidden);
    let plan = planned.plan_points();
    // Each pose machined at the middle of its time in the program.
    let minutes: HashMap<String, f64> = planned
        .manifest(&planned.test)
        .poses
        .iter()
        .map(|p| (p.pose.clone(), 0.5 * (p.start_min + p.end_min)))
        .collect();
    let mut r = rng(seed);
    let placement = random_placement(&mut r, 800.0);
    let pts = synthetic::machined(&model, &theta, &plan, &minutes, NOISE, &placement, &mut r);
    Inputs::from_points(
        LoadedPlan::Machining(Box::new(planned.clone())),
        pts,
        Path::new("piece.csv"),
    )
    .unwrap()
}

fn discover(inputs: &Inputs) -> Discovery {
    discover::run(&inputs.kin, &inputs.data, &DiscoverOptions::default()).unwrap()
}

fn symbols(kin: &Kinematics) -> fivecal::kinematics::symbols::SymbolTable {
    Model::new(kin.clone(), vec![]).symbols
}

fn b_map(kin: &Kinematics, name: &str) -> Effect {
    Effect::Map {
        symbol: symbols(kin).map_index(name).unwrap(),
        grid: MapGrid {
            dims: vec![MapDim::new(0, &[-90.0, 0.0, 90.0], false).unwrap()],
        },
    }
}

fn c_map(kin: &Kinematics, name: &str) -> Effect {
    Effect::Map {
        symbol: symbols(kin).map_index(name).unwrap(),
        grid: MapGrid {
            dims: vec![
                MapDim::new(0, &[-90.0, 0.0, 90.0], false).unwrap(),
                MapDim::new(1, &[0.0, 90.0, 180.0, 270.0], true).unwrap(),
            ],
        },
    }
}

fn drift(kin: &Kinematics, symbol: &str) -> Effect {
    Effect::Drift {
        symbol: symbols(kin).location_index(symbol).unwrap(),
        basis: DriftBasis::Seq,
    }
}

/// Asserts the story: `expected` named in order, and the final gap within
/// 20 % of the noise.
fn assert_found(d: &Discovery, expected: &[&str]) {
    let s = &d.story;
    assert_eq!(s.found(), expected, "\n{}", s.render());
    let rms = s.end.gap.rms_um;
    assert!(
        (rms / NOISE - 1.0).abs() < 0.2,
        "final gap {rms:.3} um RMS against {NOISE} um of noise\n{}",
        s.render()
    );
    for st in &s.steps {
        assert!(st.gap_after.rms_um < st.gap_before.rms_um);
        assert!(st.p_adjusted < s.alpha && st.test.delta_bic < 0.0);
        assert!(st.values.iter().all(|v| v.u.is_some_and(|u| u > 0.0)));
    }
}

/// Each value of the effect added at step `k`, in the final model, within
/// four standard uncertainties of `truth`.
fn assert_values(d: &Discovery, k: usize, truth: &[f64]) {
    let st = &d.story.steps[k];
    assert_eq!(st.values.len(), truth.len());
    for (sv, t) in st.values.iter().zip(truth) {
        let v = d
            .story
            .end
            .values
            .iter()
            .find(|v| v.name == sv.name)
            .unwrap();
        let u = v.u.unwrap();
        assert!(
            (v.value - t).abs() < 4.0 * u,
            "{}: {:.3} +- {u:.3} against {t}",
            v.name,
            v.value
        );
    }
}

#[test]
fn thermal_drift_of_ez0b_over_the_cut_sequence_is_named_and_closes_the_gap() {
    let planned = stepped_square();
    let kin = Kinematics::with_gauge_length(&planned.machine, planned.tool.length);
    // 1 um per cut: 11 um between the first and the last of the twelve.
    let inputs = measured(&planned, &[(drift(&kin, "EZ0B"), vec![1.0])], 11);
    let d = discover(&inputs);
    assert_found(&d, &["drift.EZ0B/seq"]);
    assert_values(&d, 0, &[1.0]);
    // The starting gap is well above the noise, and the story says where.
    let s = &d.story;
    assert!(s.start.gap.rms_um > 3.0 * NOISE, "{}", s.render());
    assert!(!s.steps[0].concentrated.contains("as noise is"));
}

#[test]
fn b_axis_angular_positioning_map_is_named_and_closes_the_gap() {
    let planned = stepped_square();
    let kin = Kinematics::with_gauge_length(&planned.machine, planned.tool.length);
    // EBB(B): the B axis turns 60 urad (12") too far at -90 and 45 urad
    // too short at +90 (averaging to zero, as the seeds define a map).
    let truth = [60.0, -15.0, -45.0];
    let inputs = measured(&planned, &[(b_map(&kin, "EBB(B)"), truth.to_vec())], 12);
    let d = discover(&inputs);
    assert_found(&d, &["map.EBB(B)"]);
    assert_values(&d, 0, &truth);
}

#[test]
fn c_axis_angular_positioning_map_is_named_and_closes_the_gap() {
    let planned = stepped_square();
    let kin = Kinematics::with_gauge_length(&planned.machine, planned.tool.length);
    // ECC(B,C), up to 60 urad (12"), averaging to zero over C at each B.
    let truth = [
        50.0, -20.0, 30.0, -60.0, 0.0, 40.0, -40.0, 0.0, -50.0, 20.0, 10.0, 20.0,
    ];
    let inputs = measured(&planned, &[(c_map(&kin, "ECC(B,C)"), truth.to_vec())], 13);
    let d = discover(&inputs);
    assert_found(&d, &["map.ECC(B,C)"]);
    assert_values(&d, 0, &truth);
}

#[test]
fn two_hidden_effects_are_both_found_the_larger_first() {
    let planned = stepped_square();
    let kin = Kinematics::with_gauge_length(&planned.machine, planned.tool.length);
    let hidden = [
        (drift(&kin, "EZ0B"), vec![1.5]),
        (b_map(&kin, "EBB(B)"), vec![60.0, -15.0, -45.0]),
    ];
    let inputs = measured(&planned, &hidden, 14);
    let d = discover(&inputs);
    assert_found(&d, &["drift.EZ0B/seq", "map.EBB(B)"]);
    // "Larger": alone, the drift closes more of the starting gap than the
    // map does.
    let alone = |name: &str| {
        d.story.steps[0]
            .trials
            .iter()
            .find(|t| t.name == name)
            .and_then(|t| t.gap_after)
            .unwrap()
            .rms_um
    };
    assert!(alone("drift.EZ0B/seq") < alone("map.EBB(B)"));
    assert_values(&d, 0, &[1.5]);
    assert_values(&d, 1, &[60.0, -15.0, -45.0]);
}

#[test]
fn without_a_hidden_effect_nothing_is_added_in_at_least_95_of_100_runs() {
    // With Bonferroni's adjustment a round adds a chance effect with
    // probability at most alpha = 0.01: about one run in a hundred.
    let planned = stepped_square();
    let added: Vec<(u64, Vec<String>)> = (0..100u64)
        .into_par_iter()
        .filter_map(|seed| {
            let d = discover(&measured(&planned, &[], 1000 + seed));
            let found: Vec<String> = d.story.found().iter().map(|s| s.to_string()).collect();
            (!found.is_empty()).then_some((seed, found))
        })
        .collect();
    assert!(
        added.len() <= 5,
        "{} of 100 runs added {added:?}",
        added.len()
    );
}

#[test]
fn every_candidate_of_a_round_is_tested_or_refused_with_a_reason() {
    let planned = stepped_square();
    let d = discover(&measured(&planned, &[], 3));
    let s = &d.story;
    assert!(s.steps.is_empty());
    assert!(!s.last_round.is_empty());
    for t in &s.last_round {
        match t.verdict {
            Verdict::Refused => assert!(
                t.reason.as_ref().is_some_and(|r| !r.is_empty()),
                "{}",
                t.name
            ),
            _ => {
                assert!(t.test.is_some() && t.alongside.is_some(), "{}", t.name);
                let a = t.alongside.as_ref().unwrap();
                assert!(a.rank_increase >= 1 && a.canonical_correlation <= 0.999);
            }
        }
    }
    assert!(
        s.stop.starts_with("no candidate is significant"),
        "{}",
        s.stop
    );
    // The story as JSON has the documented shape.
    let j = serde_json::to_value(s).unwrap();
    assert!(j["steps"].as_array().unwrap().is_empty());
    assert!(j["end"]["gap"]["rms_um"].as_f64().is_some());
}

#[test]
fn drift_on_the_column_probing_test_is_named_with_each_column_set_up_apart() {
    // The probing planner's three columns on ac-trunnion (seed 000's 24
    // stations), each clamped on its own up to 0.1 mm and 0.2 mrad off
    // (six nuisance numbers per column), probed with 0.35 um of noise
    // while EZ0A drifts 0.5 um per station.
    use fivecal::plan::probing::{ProbingConfig, plan_probing};
    use fivecal::probing::template::ProbeTemplate;
    use nalgebra::{Isometry3, Vector3};
    use rand::RngExt;
    let planned = plan_probing(&ProbingConfig {
        machine: machine("ac-trunnion"),
        template: ProbeTemplate::builtin("probe-columns").unwrap(),
        post: PostDefinition::builtin(Dialect::Fanuc),
    })
    .unwrap();
    let kin = planned.plan.kin.clone();
    let plan = planned.plan_points();
    let minutes: HashMap<String, f64> = planned
        .manifest(&planned.test)
        .poses
        .iter()
        .map(|p| (p.pose.clone(), 0.5 * (p.start_min + p.end_min)))
        .collect();
    let piece: HashMap<String, String> = planned
        .plan
        .touches
        .iter()
        .map(|t| (t.label.clone(), t.piece.clone()))
        .collect();
    let ac = [15.0, -30.0, 60.0, -90.0, 120.0, 20.0, -25.0, 40.0];
    let mut theta = ac.to_vec();
    theta.push(0.5);
    let model = Model::new(
        kin.clone(),
        vec![
            Effect::Location {
                symbols: (0..8).collect(),
            },
            drift(&kin, "EZ0A"),
        ],
    );
    let mut r = rng(77);
    let mut setups: HashMap<String, Isometry3<f64>> = HashMap::new();
    for t in &planned.plan.touches {
        setups.entry(t.piece.clone()).or_insert_with(|| {
            let mut v = || r.random_range(-1.0..1.0);
            Isometry3::new(
                Vector3::new(v(), v(), v()) * 0.1,
                Vector3::new(v(), v(), v()) * 2e-4,
            )
        });
    }
    let pts = synthetic::probed_with(
        &model,
        &theta,
        &plan,
        &minutes,
        NOISE,
        &|p| setups[&piece[&p.label]],
        &mut r,
    );
    let inputs = Inputs::from_points(
        LoadedPlan::Probing(Box::new(planned.clone())),
        pts,
        Path::new("probe.csv"),
    )
    .unwrap();
    assert_eq!(inputs.data.pieces.len(), 3);
    let d = discover(&inputs);
    assert_found(&d, &["drift.EZ0A/seq"]);
    assert_values(&d, 0, &[0.5]);
    // Its per-minute twin is a different clock here (the stations take
    // unequal times), and the data prefer the right one.
    let twin = d.story.steps[0]
        .rivals
        .iter()
        .find(|r| r.name == "drift.EZ0A/minute")
        .unwrap();
    assert!(
        twin.verdict.contains("explains it away"),
        "{}",
        twin.verdict
    );
}

#[test]
fn effects_a_test_cannot_tell_apart_are_reported_and_none_is_picked() {
    // A stepped square cut at B = 0 only (C = 0, 90, 180, 270): the B
    // axis's and the C axis's X positions move the piece alike, so the
    // test cannot say which of them drifts; the C-axis X map can mimic any
    // such per-pose shift too.
    let kin = Kinematics::new(&machine("bc-trunnion"));
    let plan = synthetic::stepped_square(&kin, &[0.0], &[0.0, 90.0, 180.0, 270.0], 15.0);
    let (model, theta) = truth(&kin, &[(drift(&kin, "EX0B"), vec![1.0])]);
    let data = crate::identify::machined(&model, &theta, &plan, NOISE, 5);
    let d = discover::run(&kin, &data, &DiscoverOptions::default()).unwrap();
    let s = &d.story;
    assert!(s.steps.is_empty(), "{}", s.render());
    let a = s.ambiguity.as_ref().expect("an ambiguity");
    let names: Vec<&str> = a.candidates.iter().map(|c| c.name.as_str()).collect();
    for n in ["drift.EX0B/seq", "drift.EX(0B)C/seq"] {
        assert!(names.contains(&n), "{names:?}");
    }
    // Each explains the gap down to the noise, and says so.
    for c in &a.candidates {
        assert!(c.gap_after.rms_um < 1.2 * NOISE, "{}", c.name);
    }
    assert!(s.stop.starts_with("ambiguous"));
    // The starting model keeps one of each pair the test cannot separate.
    assert!(
        s.notes
            .iter()
            .any(|n| n.starts_with("EX(0B)C is left out") && n.contains("EX0B - EX(0B)C")),
        "{:?}",
        s.notes
    );
}
