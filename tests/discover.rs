//! `discover` as worked examples on the virtual machine: the planner's
//! stepped-square test on `bc-trunnion` (and its column-probing test on
//! `ac-trunnion`), run by `simulate::run` on a machine with the eight
//! location errors and one or two hidden effects, measured with 0.35 um of
//! noise (the piece anywhere on the CMM; each column clamped with its own
//! setup error), and analysed from the location errors alone. Discover must
//! name the hidden effect first and close the gap to the noise; on pieces
//! without a hidden effect it must add nothing.

use std::path::Path;

use fivecal::discover::{self, CandidateVerdict, DiscoverOptions, Discovery, Inputs};
use fivecal::errorfile::{LoadedErrors, Noise};
use fivecal::formats::manifest::KinematicsMode;
use fivecal::geom::Axis3;
use fivecal::identify::synthetic;
use fivecal::kinematics::maps::{MapDim, MapGrid};
use fivecal::model::{DriftBasis, Effect, Model, Squareness};
use fivecal::post::PostDefinition;
use fivecal::procedure::{Plan, PlanConfig, Template, Test};
use fivecal::simulate::{self, SimOptions};
use fivecal::{Dialect, Kinematics};
use rayon::prelude::*;

use crate::identify::{AC_TRUTH, BC_TRUTH};
use crate::util::machine;

/// Measurement noise of the simulated tests, um (Ibaraki & Ota 2014, table 4).
pub const NOISE: f64 = 0.35;

/// The planner's stepped square on `bc-trunnion` (FANUC, post kinematics).
pub fn stepped_square() -> Plan {
    fivecal::procedure::plan(&PlanConfig {
        machine: machine("bc-trunnion"),
        template: Template::builtin(Test::SteppedSquare),
        post: PostDefinition::builtin(Dialect::Fanuc),
        kinematics: KinematicsMode::Post,
        tool: None,
    })
    .unwrap()
}

/// The probing planner's three columns on `ac-trunnion` (Ibaraki, Iritani & Matsushita's (2013) 24
/// stations).
fn columns() -> Plan {
    fivecal::procedure::plan(&PlanConfig {
        kinematics: fivecal::formats::manifest::KinematicsMode::Post,
        tool: None,
        machine: machine("ac-trunnion"),
        template: Template::builtin(Test::ProbeColumns),
        post: PostDefinition::builtin(Dialect::Fanuc),
    })
    .unwrap()
}

/// The plan run on a machine with the eight location errors (Ibaraki & Ota's (2014)
/// table 1 magnitudes) and `hidden`, measured; as a discovery's inputs.
pub fn simulated(plan: &Plan, hidden: &[(Effect, Vec<f64>)], seed: u64) -> Inputs {
    let kin = simulate::plan_kinematics(plan);
    let mut effects = vec![Effect::Location {
        symbols: (0..8).collect(),
    }];
    let mut theta = match plan {
        Plan::Machining(_) => BC_TRUTH.to_vec(),
        Plan::Probing(_) => AC_TRUTH.to_vec(),
    };
    for (e, v) in hidden {
        effects.push(e.clone());
        theta.extend(v);
    }
    let n = theta.len();
    let errors = LoadedErrors {
        model: Model::new(kin, effects),
        theta,
        u: vec![None; n],
        noise: Noise {
            cmm: Some(NOISE),
            probe: Some(NOISE),
        },
        not_identifiable: Vec::new(),
        fit: None,
    };
    let out = simulate::run(
        plan,
        &errors,
        &SimOptions {
            seed,
            ..SimOptions::default()
        },
    )
    .unwrap();
    Inputs::from_points(plan.clone(), out.points, Path::new("simulated.csv")).unwrap()
}

fn discover(inputs: &Inputs) -> Discovery {
    inputs.discover(&DiscoverOptions::default()).unwrap()
}

fn symbols(kin: &Kinematics) -> fivecal::kinematics::symbols::SymbolTable {
    Model::new(kin.clone(), vec![]).symbols
}

pub fn tilt_map(plan: &Plan, name: &str) -> Effect {
    Effect::Map {
        symbol: symbols(&simulate::plan_kinematics(plan))
            .map_index(name)
            .unwrap(),
        grid: MapGrid {
            dims: vec![MapDim::new(0, &[-90.0, 0.0, 90.0], false).unwrap()],
        },
    }
}

fn drift(plan: &Plan, symbol: &str) -> Effect {
    Effect::Drift {
        symbol: symbols(&simulate::plan_kinematics(plan))
            .location_index(symbol)
            .unwrap(),
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
    }
}

/// Each value of the effect added at step `k`, in the final model, within
/// four standard uncertainties of `truth` (`None`: a value the test does
/// not see, which must be reported as such).
fn assert_values(d: &Discovery, k: usize, truth: &[Option<f64>]) {
    let st = &d.story.steps[k];
    assert_eq!(st.provisional_values.len(), truth.len());
    for (sv, t) in st.provisional_values.iter().zip(truth) {
        let v = d
            .story
            .end
            .values
            .iter()
            .find(|v| v.name == sv.name)
            .unwrap();
        match (t, v.u) {
            (Some(t), Some(u)) => assert!(
                (v.value - t).abs() < 4.0 * u,
                "{}: {:.3} +- {u:.3} against {t}",
                v.name,
                v.value
            ),
            (None, None) => assert!(v.note.is_some(), "{}", v.name),
            _ => panic!("{}: u = {:?} against the truth {t:?}", v.name, v.u),
        }
    }
}

fn all(v: &[f64]) -> Vec<Option<f64>> {
    v.iter().map(|x| Some(*x)).collect()
}

#[test]
fn thermal_drift_of_ez0b_over_the_cut_sequence_is_named_and_closes_the_gap() {
    let plan = stepped_square();
    // 1 um per cut: 11 um between the first and the last of the twelve.
    let inputs = simulated(&plan, &[(drift(&plan, "EZ0B"), vec![1.0])], 11);
    let d = discover(&inputs);
    assert_found(&d, &["drift.EZ0B/seq"]);
    assert_values(&d, 0, &all(&[1.0]));
    // The starting gap is well above the noise, and the story says where.
    let s = &d.story;
    assert!(s.start.gap.rms_um > 3.0 * NOISE, "{}", s.render());
    assert!(!s.steps[0].concentrated.contains("as noise is"));
}

#[test]
fn x_axis_scale_error_is_named_and_closes_the_gap() {
    let plan = stepped_square();
    let inputs = simulated(&plan, &[(Effect::Scale { axis: Axis3::X }, vec![40.0])], 12);
    let d = discover(&inputs);
    assert_found(&d, &["scale.EXX"]);
    assert_values(&d, 0, &all(&[40.0]));
}

#[test]
fn xy_squareness_is_named_and_closes_the_gap() {
    let plan = stepped_square();
    let hidden = [(
        Effect::Squareness {
            kind: Squareness::CXY,
        },
        vec![60.0],
    )];
    let d = discover(&simulated(&plan, &hidden, 13));
    assert_found(&d, &["squareness.EC(0X)Y"]);
    assert_values(&d, 0, &all(&[60.0]));
    // The straightness of Y in X could mimic a squareness on the few Y
    // positions the walls are cut at, were it not taken from its reference
    // line where the test senses it.
    assert!(
        d.story.steps[0]
            .trials
            .iter()
            .any(|t| t.name == "straightness.EXY")
    );
}

#[test]
fn tool_radius_error_is_named_and_the_tool_length_refused_as_an_alias() {
    let plan = stepped_square();
    // The end mill cuts 4 um larger than its nominal radius.
    let d = discover(&simulated(&plan, &[(Effect::ToolRadius, vec![4.0])], 14));
    assert_found(&d, &["tool_radius"]);
    assert_values(&d, 0, &all(&[4.0]));
    // On a table-table machine a tool-length error moves every pose's tool
    // point as EZ0B does: refused, with the alias named.
    let t = d
        .story
        .last_round
        .iter()
        .find(|t| t.name == "tool_length")
        .unwrap();
    assert_eq!(t.verdict, CandidateVerdict::Refused);
    let why = t.reason.as_deref().unwrap();
    assert!(
        why.starts_with("not identifiable alongside the model") && why.contains("EZ0B"),
        "{why}"
    );
}

#[test]
fn b_axis_angular_positioning_map_is_named_and_closes_the_gap() {
    let plan = stepped_square();
    // EBB(B): the B axis turns 60 urad (12") too far at -90 and 45 urad
    // too short at +90 (averaging to zero, as the papers define a map).
    let truth = [60.0, -15.0, -45.0];
    let d = discover(&simulated(
        &plan,
        &[(tilt_map(&plan, "EBB(B)"), truth.to_vec())],
        15,
    ));
    assert_found(&d, &["map.EBB(B)"]);
    assert_values(&d, 0, &all(&truth));
}

#[test]
fn c_axis_angular_positioning_map_is_named_and_closes_the_gap() {
    let plan = stepped_square();
    let sym = symbols(&simulate::plan_kinematics(&plan));
    // ECC(B,C), up to 60 urad (12"), averaging to zero over C at each B.
    let truth = [
        50.0, -20.0, 30.0, -60.0, 0.0, 40.0, -40.0, 0.0, -50.0, 20.0, 10.0, 20.0,
    ];
    let map = Effect::Map {
        symbol: sym.map_index("ECC(B,C)").unwrap(),
        grid: MapGrid {
            dims: vec![
                MapDim::new(0, &[-90.0, 0.0, 90.0], false).unwrap(),
                MapDim::new(1, &[0.0, 90.0, 180.0, 270.0], true).unwrap(),
            ],
        },
    };
    let d = discover(&simulated(&plan, &[(map, truth.to_vec())], 16));
    assert_found(&d, &["map.ECC(B,C)"]);
    assert_values(&d, 0, &all(&truth));
}

#[test]
fn probe_pretravel_on_the_column_probing_test_is_named_with_what_it_cannot_see() {
    let plan = columns();
    // 3 um of pre-travel sideways, 2 um from above; the probe never
    // approaches upwards (Z+).
    let truth = [3.0, 3.0, 3.0, 3.0, 0.0, 2.0];
    let inputs = simulated(&plan, &[(Effect::ProbePretravel, truth.to_vec())], 17);
    assert_eq!(inputs.data.pieces.len(), 3);
    let d = discover(&inputs);
    assert_found(&d, &["probe_pretravel"]);
    assert_values(
        &d,
        0,
        &[Some(3.0), Some(3.0), Some(3.0), Some(3.0), None, Some(2.0)],
    );
    let unseen: Vec<String> = d.story.steps[0]
        .alongside
        .unseen
        .iter()
        .map(|c| c.to_string())
        .collect();
    assert_eq!(unseen, ["probe_pretravel.Z+"]);
    // The error file writes what the test saw and says what it did not.
    let f = d.error_file(
        &inputs.data,
        &[fivecal::analyze::goodness::ExpectedNoise::new(
            None,
            inputs.data.kind,
            inputs.plan.test(),
        )],
    );
    assert_eq!(f.effects.probe_pretravel.len(), 5);
    assert!(f.effects.probe_pretravel.values().all(|q| q.u.is_some()));
    assert!(
        f.not_identifiable
            .iter()
            .any(|n| n.symbol == "probe_pretravel.Z+" && n.reason.contains("does not see"))
    );
}

#[test]
fn drift_on_the_column_probing_test_is_named_on_its_own_clock() {
    let plan = columns();
    let d = discover(&simulated(&plan, &[(drift(&plan, "EZ0A"), vec![0.5])], 18));
    assert_found(&d, &["drift.EZ0A/seq"]);
    assert_values(&d, 0, &all(&[0.5]));
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

/// The stepped square cut with two hidden effects: an end mill 3 um
/// larger than nominal and the B axis's positioning map EBB(B) = 60, -15,
/// -45 urad at -90, 0, 90 deg (seed 19).
fn two_hidden_effects() -> Inputs {
    let plan = stepped_square();
    let hidden = [
        (Effect::ToolRadius, vec![3.0]),
        (tilt_map(&plan, "EBB(B)"), vec![60.0, -15.0, -45.0]),
    ];
    simulated(&plan, &hidden, 19)
}

#[test]
fn two_hidden_effects_are_both_found_the_larger_first() {
    let d = discover(&two_hidden_effects());
    assert_found(&d, &["tool_radius", "map.EBB(B)"]);
    // "Larger": alone, the radius closes more of the starting gap than the
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
    assert!(alone("tool_radius") < alone("map.EBB(B)"));
    assert_values(&d, 0, &all(&[3.0]));
    assert_values(&d, 1, &all(&[60.0, -15.0, -45.0]));
}

#[test]
fn without_a_hidden_effect_nothing_is_added_in_at_least_95_of_100_runs() {
    // With Bonferroni's adjustment a round adds a chance effect with
    // probability at most alpha = 0.01: about one run in a hundred.
    let plan = stepped_square();
    let added: Vec<(u64, Vec<String>)> = (0..100u64)
        .into_par_iter()
        .filter_map(|seed| {
            let d = discover(&simulated(&plan, &[], 1000 + seed));
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
    let plan = stepped_square();
    let d = discover(&simulated(&plan, &[], 3));
    let s = &d.story;
    assert!(s.steps.is_empty());
    // The whole catalogue: 8 drifts per pose and 8 per minute, 3 scales, 3
    // squarenesses, 6 straightnesses, 12 maps, tool radius and length.
    assert_eq!(s.last_round.len(), 42);
    for t in &s.last_round {
        match t.verdict {
            CandidateVerdict::Refused => assert!(
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
fn effects_a_test_cannot_tell_apart_are_reported_and_none_is_picked() {
    // A stepped square cut at B = 0 only (C = 0, 90, 180, 270): the B
    // axis's and the C axis's X positions move the piece alike, so the
    // test cannot say which of them drifts; the C-axis X map can mimic any
    // such per-pose shift too. Bare points (no plan): the rigid-pose model.
    let kin = Kinematics::new(&machine("bc-trunnion"));
    let plan = synthetic::stepped_square(&kin, &[0.0], &[0.0, 90.0, 180.0, 270.0], 15.0);
    let sym = symbols(&kin);
    let model = Model::new(
        kin.clone(),
        vec![
            Effect::Location {
                symbols: (0..8).collect(),
            },
            Effect::Drift {
                symbol: sym.location_index("EX0B").unwrap(),
                basis: DriftBasis::Seq,
            },
        ],
    );
    let mut theta = BC_TRUTH.to_vec();
    theta.push(1.0);
    let data = crate::identify::machined(&model, &theta, &plan, NOISE, 5);
    let d = discover::run(&kin, &data, None, &DiscoverOptions::default()).unwrap();
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

#[test]
fn the_fast_scan_picks_what_full_refits_pick_with_the_same_values() {
    // A round's candidate scan scores each candidate by an update of the
    // current model's one factorization (one Gauss-Newton step from its
    // estimate); here every candidate is also fitted anew to convergence.
    // On a piece with two hidden effects both rank the same effect first,
    // and agree on every candidate's values within a tenth of their
    // uncertainty, except the effects whose cut surface the forward model
    // builds piece by piece (a straightness between its nodes, a drift per
    // minute along the clock of each cut): there the one step from the
    // location errors' estimate falls short of the converged fit by up to
    // 0.15 u (their sums of squares by 0.3 %), within 0.2 u. Those that
    // come near significance are iterated in every round anyway.
    let inputs = two_hidden_effects();
    let parts = [inputs.part()];
    let cat = discover::catalogue::catalogue(&parts);
    let (fitter, _) = discover::Fitter::new(&parts, &cat.candidates).unwrap();
    let base = fitter
        .fit(&fitter.location(&(0..8).collect::<Vec<_>>()), None)
        .unwrap();
    let screen = fitter.screen(&base).unwrap();
    let n = fitter.len();
    let mut compared = 0;
    let mut best_fast: Option<(f64, String)> = None;
    let mut best_full: Option<(f64, String)> = None;
    for c in &cat.candidates {
        let Some(spec) = fitter.extend(&base.spec, c) else {
            continue;
        };
        let (d, _, ranges) = fitter.design(&spec);
        let free = ranges.last().unwrap().len();
        // Only what the test sees whole: a candidate it sees in part is
        // first constrained, as discover does.
        if d.rank != base.rank + free {
            continue;
        }
        let fast = fitter.score(&screen, &spec, free);
        let k = spec.model.n_params() - base.n;
        let mut start = base.theta().to_vec();
        start.extend(std::iter::repeat_n(0.0, k));
        start.extend_from_slice(&base.x[base.n..]);
        let full = fitter.fit(&spec, Some(start)).unwrap();
        let kinked = c.name.ends_with("/minute") || c.name.starts_with("straightness.");
        for (i, v) in fast.values.iter().enumerate() {
            let Some(u) = full.u(base.n + i) else {
                continue;
            };
            let exact = full.x[base.n + i];
            let within = if kinked { 0.2 } else { 0.1 };
            assert!(
                (v - exact).abs() <= within * u,
                "{}: parameter {i}: scan {v} against refit {exact} (u {u})",
                c.name
            );
        }
        let bic =
            |rss: f64| discover::stats::compare(n, base.rss, base.rank, rss, d.rank).delta_bic;
        for (best, rss) in [(&mut best_fast, fast.rss), (&mut best_full, full.rss)] {
            if best.as_ref().is_none_or(|(b, _)| bic(rss) < *b) {
                *best = Some((bic(rss), c.name.clone()));
            }
        }
        compared += 1;
    }
    assert!(compared >= 25, "only {compared} candidates compared");
    let (fast, full) = (best_fast.unwrap().1, best_full.unwrap().1);
    assert_eq!(fast, full);
    assert_eq!(full, "tool_radius");
}
