//! What `discover` says when the measurements cannot tell two effects
//! apart, as a worked example: the planner's stepped square on
//! `bc-trunnion`, cut on a virtual machine whose B axis line wanders in X
//! with B (`EXB(B)`: +4 um at B = -90, 0 at 0, -4 um at +90) and measured
//! with 0.35 um of noise. Its tilt angles are -90, 0 and 90 only, and on
//! three angles a map of the B axis line in X and one in Z move every cut
//! alike: the test cannot say which it is.

use std::sync::OnceLock;

use fivecal::analyze::goodness::ExpectedNoise;
use fivecal::discover::{DiscoverOptions, Discovery, Inputs};
use fivecal::errorfile::{ErrorFile, FitVerdict};

use crate::discover::{NOISE, simulated, stepped_square, tilt_map};
use crate::util::machine;

/// The B axis line's X position over B, um, at B = -90, 0, 90.
pub const EXB: [f64; 3] = [4.0, 0.0, -4.0];

/// The simulated piece and its discovery, made once for every test here.
fn ambiguous() -> &'static (Inputs, Discovery) {
    static CASE: OnceLock<(Inputs, Discovery)> = OnceLock::new();
    CASE.get_or_init(|| {
        let plan = stepped_square();
        let inputs = simulated(&plan, &[(tilt_map(&plan, "EXB(B)"), EXB.to_vec())], 21);
        let d = inputs.discover(&DiscoverOptions::default()).unwrap();
        (inputs, d)
    })
}

fn expected(inputs: &Inputs) -> ExpectedNoise {
    ExpectedNoise::new(None, inputs.data.kind, inputs.plan.test())
}

#[test]
fn the_stepped_square_cannot_tell_exb_from_ezb_and_adds_neither() {
    let (_, d) = ambiguous();
    let s = &d.story;
    assert!(s.steps.is_empty(), "{}", s.render());
    let a = s.ambiguity.as_ref().expect("an ambiguity");
    let names: Vec<&str> = a.candidates.iter().map(|c| c.name.as_str()).collect();
    assert!(
        names.contains(&"map.EXB(B)") && names.contains(&"map.EZB(B)"),
        "{names:?}"
    );
    // Either closes the gap to the noise.
    for c in &a.candidates {
        assert!(c.gap_after.rms_um < 1.2 * NOISE, "{}", c.name);
    }
}

/// The result file after an ambiguity: the location-only model, judged a
/// misfit against the instrument's noise, which is the noise it writes
/// (not the gap the model leaves); the rivals with their values; and it
/// reads back as an error file.
#[test]
fn after_an_ambiguity_the_result_file_states_it_and_writes_the_instruments_noise() {
    let (inputs, d) = ambiguous();
    let f = d.error_file(&inputs.data, &[expected(inputs)]);
    let noise = f.effects.noise.as_ref().unwrap();
    assert_eq!((noise.cmm, noise.probe), (Some(NOISE), None));
    let fit = f.fit.as_ref().unwrap();
    assert_eq!(fit.verdict, FitVerdict::Misfit);
    assert!(fit.sigma_um > 2.0 * NOISE, "{fit:?}");
    assert_eq!(fit.expected_um, NOISE);
    // No effect of the rivals in the model itself.
    assert!(f.position_dependent.is_empty() && f.effects.thermal_drift.is_empty());
    let a = f.ambiguity.as_ref().expect("the ambiguity is stated");
    assert!(a.reason.contains("map.EXB(B)"), "{}", a.reason);
    let rival = |e: &str| a.rivals.iter().find(|r| r.effect == e).unwrap();
    let x = rival("map.EXB(B)");
    assert_eq!(x.values.len(), 3);
    assert!(x.values.values().all(|q| q.u.is_some_and(|u| u > 0.0)));
    assert!(x.gap_rms_um < 1.2 * NOISE);
    rival("map.EZB(B)");
    // YAML and JSON read back to the same file, and load as a model.
    for text in [f.to_yaml(), f.to_json()] {
        let path = std::path::Path::new("discovered.yaml");
        let back = ErrorFile::parse(path, &text).unwrap();
        assert_eq!(back, f);
        let kin = fivecal::Kinematics::with_gauge_length(&machine("bc-trunnion"), 60.0);
        back.to_model(&kin, path, &text).unwrap();
    }
}

/// The two maps are not merely close: neither adds a direction the other
/// does not give, so no measurement of this test can separate them, and
/// the story says so in those words (not as weak evidence).
#[test]
fn exact_aliases_are_called_exactly_indistinguishable() {
    let (inputs, d) = ambiguous();
    let a = d.story.ambiguity.as_ref().unwrap();
    assert!(
        a.candidates.iter().all(|c| c.exactly_indistinguishable),
        "{:?}",
        a.candidates
    );
    assert!(
        a.reason.contains("exactly indistinguishable on this test"),
        "{}",
        a.reason
    );
    let text = d.story.render();
    assert!(text.contains("map.EXB(B) (gap"), "{text}");
    assert!(
        text.contains("; exactly indistinguishable on this test):"),
        "{text}"
    );
    // The final model is the location-only one, and the story does not
    // offer its values as the ones to quote.
    assert!(
        text.contains("final model (none of the ambiguous effects added"),
        "{text}"
    );
    // Exactness is a property of the design: the residuals of the two
    // rivals differ far below the noise, at the level the fits converge to.
    let f = d.error_file(&inputs.data, &[expected(inputs)]);
    let gaps: Vec<f64> = f
        .ambiguity
        .unwrap()
        .rivals
        .iter()
        .map(|r| r.gap_rms_um)
        .collect();
    assert!((gaps[0] - gaps[1]).abs() < 1e-4 * NOISE, "{gaps:?}");
}

/// After the ambiguity, discover names the extra poses that separate the
/// rivals, found from the two tests' joint design: a probing run of the
/// calibration sphere at tilts the stepped square does not have (B = +-45),
/// each at four C angles, with which each map adds directions the other
/// does not give and is found beside the other with a power of 0.9.
#[test]
fn discover_names_the_poses_that_separate_the_rivals() {
    let (_, d) = ambiguous();
    let a = d.story.ambiguity.as_ref().unwrap();
    let s = a.supplement.as_ref().expect("a supplementary test");
    assert_eq!(s.test, "probe-sphere");
    assert!(s.tilt.contains(&-45.0) && s.tilt.contains(&45.0), "{s:?}");
    assert!(!s.new_poses.is_empty());
    assert!(
        s.new_poses
            .iter()
            .all(|p| p.starts_with("B-45C") || p.starts_with("B45C")),
        "{:?}",
        s.new_poses
    );
    // Both ways round: each map told from the other.
    assert_eq!(s.power.len(), 2);
    for p in &s.power {
        assert!(p.directions >= 1 && p.power >= 0.9, "{p:?}");
    }
    assert!(s.touches > 0 && s.poses == s.tilt.len() * s.c.len());
    let text = d.story.render();
    assert!(
        text.contains("to separate them: a probe-sphere run"),
        "{text}"
    );
    assert!(
        a.reason.contains("fivecal plan --supplement"),
        "{}",
        a.reason
    );
}
