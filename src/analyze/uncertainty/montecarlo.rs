//! The Monte-Carlo driver: runs a "simulate one run and identify" closure
//! many times, in parallel (rayon), each run with its own random stream
//! derived from one seed, so the result does not depend on the number of
//! threads; shows a progress bar when stderr is a terminal, and a line
//! every [`NOTE_SECONDS`] s when it is not (a log), so a long study is never
//! silent; stops at `max_seconds` when given, saying how far it came
//! ([`McResult::stopped`]), and the caller refuses such a study rather
//! than report a u from fewer runs than asked.
//!
//! The closure is where the simulator plugs in: it gets the run index and
//! a seeded generator and returns the estimated parameters (NaN where a run
//! cannot estimate one).

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};

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
    /// Whether to show progress on stderr: a bar on a terminal, a line
    /// every [`NOTE_SECONDS`] s otherwise.
    pub progress: bool,
    /// Stop starting runs after this many seconds (the study is then
    /// [`McResult::stopped`]); `None`: no bound.
    pub max_seconds: Option<f64>,
}

/// Seconds between the progress lines written to a stderr that is not a
/// terminal; a study shorter than this writes none.
pub const NOTE_SECONDS: u64 = 10;

/// How far a study stopped at its time bound came.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stopped {
    /// Runs finished (returned estimates or failed).
    pub done: usize,
    /// Seconds the study ran.
    pub seconds: f64,
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
    /// The study hit `max_seconds` before every run was done: its spread
    /// is of fewer runs than asked, and of those that happened to finish.
    pub stopped: Option<Stopped>,
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
    let terminal = std::io::stderr().is_terminal();
    let pb = if opts.progress && terminal {
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
    let start = std::time::Instant::now();
    let done = AtomicUsize::new(0);
    // The second of the last progress line written (by whichever thread
    // passes the next multiple of NOTE_SECONDS first).
    let noted = AtomicU64::new(0);
    let out_of_time = AtomicBool::new(false);
    let results: Vec<Option<Result<Vec<f64>, E>>> = (0..opts.runs)
        .into_par_iter()
        .map(|i| {
            if let Some(limit) = opts.max_seconds
                && (out_of_time.load(Ordering::Relaxed) || start.elapsed().as_secs_f64() >= limit)
            {
                out_of_time.store(true, Ordering::Relaxed);
                return None;
            }
            let mut rng = StdRng::seed_from_u64(run_seed(opts.seed, i));
            let r = f(i, &mut rng);
            pb.inc(1);
            let k = done.fetch_add(1, Ordering::Relaxed) + 1;
            if opts.progress && !terminal {
                let t = start.elapsed().as_secs();
                let last = noted.load(Ordering::Relaxed);
                if t >= last + NOTE_SECONDS
                    && noted
                        .compare_exchange(last, t, Ordering::Relaxed, Ordering::Relaxed)
                        .is_ok()
                {
                    let left = (opts.runs - k) as f64 * start.elapsed().as_secs_f64() / k as f64;
                    eprintln!(
                        "monte carlo: {k} of {} runs in {t} s, about {:.0} s left{}",
                        opts.runs,
                        left,
                        if opts.max_seconds.is_some() {
                            ""
                        } else {
                            " (--max-seconds bounds it)"
                        }
                    );
                }
            }
            Some(r)
        })
        .collect();
    pb.finish_and_clear();
    let stopped = out_of_time.load(Ordering::Relaxed).then(|| Stopped {
        done: done.load(Ordering::Relaxed),
        seconds: start.elapsed().as_secs_f64(),
    });
    let results = results.into_iter().flatten();
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
        stopped,
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
            max_seconds: None,
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

    /// A bound of no time stops the study before its first run, and says
    /// so; a bound the runs outlast stops it part way, with the count of
    /// runs done.
    #[test]
    fn a_study_stopped_at_its_time_bound_says_how_far_it_came() {
        let f = |_: usize, _: &mut StdRng| {
            std::thread::sleep(std::time::Duration::from_millis(5));
            Ok::<_, String>(vec![1.0])
        };
        let mut opts = McOptions {
            runs: 10_000,
            seed: 1,
            progress: false,
            max_seconds: Some(0.0),
        };
        let r = run(&opts, 1, f);
        assert_eq!(r.stopped.map(|s| s.done), Some(0));
        assert_eq!(r.runs, 0);
        opts.max_seconds = Some(0.05);
        let r = run(&opts, 1, f);
        let s = r.stopped.expect("10,000 runs of 5 ms outlast 0.05 s");
        assert!(s.done > 0 && s.done < 10_000 && r.runs == s.done, "{s:?}");
        opts.max_seconds = Some(60.0);
        opts.runs = 4;
        assert_eq!(run(&opts, 1, f).stopped, None);
    }
}
