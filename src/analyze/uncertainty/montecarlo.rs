//! The Monte-Carlo driver: runs a "simulate one run and identify" closure
//! many times, in parallel (rayon), each run with its own random stream
//! derived from one seed, so the result does not depend on the number of
//! threads; shows a progress bar when stderr is a terminal.
//!
//! The closure is where the simulator plugs in: it gets the run index and
//! a seeded generator and returns the estimated parameters (NaN where a run
//! cannot estimate one).

use std::io::IsTerminal;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use nalgebra::DMatrix;
use rand::SeedableRng;
use rand::rngs::StdRng;
use rayon::prelude::*;

/// Options of a Monte-Carlo run.
#[derive(Clone, Copy, Debug)]
pub struct McOptions {
    /// Number of runs.
    pub runs: usize,
    /// Seed of the whole study.
    pub seed: u64,
    /// Whether to show a progress bar (only ever on a terminal).
    pub progress: bool,
}

/// The spread of the estimates.
#[derive(Clone, Debug)]
pub struct McResult {
    /// Runs that returned estimates.
    pub runs: usize,
    /// Runs that failed, with the first failure's message.
    pub failed: (usize, Option<String>),
    /// Mean of each parameter over the runs.
    pub mean: Vec<f64>,
    /// Standard deviation of each parameter (the Monte-Carlo standard
    /// uncertainty), NaN where no run estimated it.
    pub std: Vec<f64>,
    /// Covariance of the parameters (runs where every one is finite).
    pub cov: DMatrix<f64>,
    /// Every run's estimates, in run order.
    pub samples: Vec<Vec<f64>>,
}

/// The seed of run `i` of a study seeded `seed` (SplitMix64 of both).
pub(crate) fn run_seed(seed: u64, i: usize) -> u64 {
    let mut z = seed ^ (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Runs the study; a run's error is kept as its message (the first one is
/// reported with the count of failed runs).
pub fn run<F, E>(opts: &McOptions, n_params: usize, f: F) -> McResult
where
    F: Fn(usize, &mut StdRng) -> Result<Vec<f64>, E> + Sync,
    E: std::fmt::Display + Send,
{
    let pb = if opts.progress && std::io::stderr().is_terminal() {
        let pb =
            ProgressBar::with_draw_target(Some(opts.runs as u64), ProgressDrawTarget::stderr());
        if let Ok(style) =
            ProgressStyle::with_template("monte carlo {bar:40} {pos}/{len} runs, {eta} left")
        {
            pb.set_style(style);
        }
        pb
    } else {
        ProgressBar::hidden()
    };
    let results: Vec<Result<Vec<f64>, E>> = (0..opts.runs)
        .into_par_iter()
        .map(|i| {
            let mut rng = StdRng::seed_from_u64(run_seed(opts.seed, i));
            let r = f(i, &mut rng);
            pb.inc(1);
            r
        })
        .collect();
    pb.finish_and_clear();
    let mut samples = Vec::new();
    let mut failed = 0;
    let mut first_error = None;
    for r in results {
        match r {
            Ok(v) if v.len() == n_params => samples.push(v),
            Ok(v) => {
                failed += 1;
                first_error
                    .get_or_insert(format!("a run returned {} values, not {n_params}", v.len()));
            }
            Err(e) => {
                failed += 1;
                first_error.get_or_insert_with(|| e.to_string());
            }
        }
    }
    let mut mean = vec![f64::NAN; n_params];
    let mut std = vec![f64::NAN; n_params];
    for k in 0..n_params {
        let v: Vec<f64> = samples
            .iter()
            .map(|s| s[k])
            .filter(|x| x.is_finite())
            .collect();
        if !v.is_empty() {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            mean[k] = m;
            if v.len() > 1 {
                std[k] =
                    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt();
            }
        }
    }
    let full: Vec<&Vec<f64>> = samples
        .iter()
        .filter(|s| s.iter().all(|x| x.is_finite()))
        .collect();
    let mut cov = DMatrix::from_element(n_params, n_params, f64::NAN);
    if full.len() > 1 {
        let nf = full.len() as f64;
        let m: Vec<f64> = (0..n_params)
            .map(|k| full.iter().map(|s| s[k]).sum::<f64>() / nf)
            .collect();
        for a in 0..n_params {
            for b in 0..n_params {
                cov[(a, b)] = full
                    .iter()
                    .map(|s| (s[a] - m[a]) * (s[b] - m[b]))
                    .sum::<f64>()
                    / (nf - 1.0);
            }
        }
    }
    McResult {
        runs: samples.len(),
        failed: (failed, first_error),
        mean,
        std,
        cov,
        samples,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_distr::{Distribution, Normal};

    #[test]
    fn reproduces_a_known_spread_and_is_thread_independent() {
        let opts = McOptions {
            runs: 400,
            seed: 7,
            progress: false,
        };
        let f = |_: usize, r: &mut StdRng| {
            let d = Normal::new(0.0, 2.0).unwrap();
            Ok::<_, String>(vec![d.sample(r), 5.0 + 0.5 * d.sample(r)])
        };
        let a = run(&opts, 2, f);
        // Standard error of a standard deviation from 400 samples: 3.5 %.
        assert!((a.std[0] - 2.0).abs() < 0.25, "{}", a.std[0]);
        assert!((a.std[1] - 1.0).abs() < 0.13, "{}", a.std[1]);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let b = pool.install(|| run(&opts, 2, f));
        assert_eq!(a.samples, b.samples);
    }
}
