//! The verdict of an analysis, one for every method, computed on the raw
//! measurements. Whatever a method does inside (a sphere fitted per pose
//! and circles through the centres, planes per station and a second stage,
//! a robust step that sets data aside), its values are judged by the
//! residuals of every measured touch or point against the complete
//! measurement model at those values, with the stated noise
//! ([`super::goodness`]'s chi-square test). What the method reports is
//! held at its estimate; what it does not report, and what no method
//! reports (the setups of the probed pieces, the sphere's place, a
//! machined piece's CMM placement), is fitted to the points. A method's
//! own residuals can hide what its steps absorbed: the sphere method's
//! per-pose spheres fit each pose as well as the probe allows even when
//! the machine drifted between poses, and its robust circle fit then sets
//! the drifted centres aside. Here they count.
//!
//! A fit that did not converge (the method's solver, its inversion, or the
//! fit of the setups at its estimate) is no fit: the verdict is
//! `not-converged` whatever its residuals, and `compensate`, its export
//! and `verify` refuse it.

use nalgebra::DMatrix;

use super::goodness::{self, ExpectedNoise};
use super::method;
use crate::errorfile::{FitSection, FitVerdict};
use crate::identify::{Dataset, Identification, IdentifyError, Method, Setup, global, lsq};
use crate::procedure::{Plan, Test};

/// What the verdict's residuals are, in the result file's words.
fn on(m: usize, method: Method) -> String {
    format!(
        "every one of the {m} measured points against the complete measurement model at the {method} method's estimate"
    )
}

/// The verdict of `est` (the estimate of `est.method`) on the measurements
/// `data` of a `test`, with the instrument's `expected` noise. `plan` is
/// the test's plan where the complete model needs it
/// ([`method::needs_plan`]); without it the rigid-pose models serve.
/// `None` when nothing is left to judge by (no degrees of freedom) and the
/// fit converged.
pub fn of(
    est: &Identification,
    setup: &Setup,
    data: &Dataset,
    test: Test,
    plan: Option<&Plan>,
    expected: &ExpectedNoise,
) -> Result<Option<FitSection>, IdentifyError> {
    judged(est, setup, data, test, plan, expected).map(|v| v.fit)
}

/// A verdict and the residuals it was computed from.
#[derive(Clone, Debug)]
pub struct Verdict {
    /// The verdict ([`of`]).
    pub fit: Option<FitSection>,
    /// The residual of every measured point against the complete model at
    /// the method's estimate, um (the dataset's order): the method's own
    /// for the global method.
    pub residuals: Vec<f64>,
}

/// [`of`], with the residuals.
pub fn judged(
    est: &Identification,
    setup: &Setup,
    data: &Dataset,
    test: Test,
    plan: Option<&Plan>,
    expected: &ExpectedNoise,
) -> Result<Verdict, IdentifyError> {
    let m = data.obs.len();
    // The global method fitted every point to the complete model already:
    // its residuals are the verdict's.
    let (sigma, dof, setup_converged, residuals, allowance) = if est.method == Method::Global {
        (
            est.sigma_um,
            est.dof,
            true,
            est.residuals.clone(),
            Vec::new(),
        )
    } else {
        let fm = match plan {
            Some(p) if method::needs_plan(&setup.model, test) => {
                crate::simulate::forward::for_plan(&setup.model, p)?
            }
            _ => crate::identify::forward::rigid_for(setup.model.clone(), data)?,
        };
        let held: Vec<bool> = (0..est.theta.len()).map(|i| est.identifiable(i)).collect();
        let j = global::judge_at(
            fm.as_ref(),
            setup,
            data,
            &est.theta,
            &held,
            &lsq::Options::default(),
        )?;
        let sigma = if j.dof > 0 {
            (j.cost / j.dof as f64).sqrt()
        } else {
            f64::NAN
        };
        let allowance = allowance(est, &held, &j.information, expected.um);
        (sigma, j.dof, j.converged, j.residuals, allowance)
    };
    let stopped = (!est.converged).then(|| {
        format!(
            "the {} method's fit stopped without converging: its values are no estimate",
            est.method
        )
    });
    let judged = goodness::judge_allowing(sigma, dof, expected, &allowance);
    let mut f = match (judged, &stopped) {
        (Some(f), _) => f,
        (None, None) => {
            return Ok(Verdict {
                fit: None,
                residuals,
            });
        }
        // Nothing to judge the residuals by, and still no fit: the
        // verdict says so without a number it cannot give.
        (None, Some(_)) => FitSection {
            sigma_um: 0.0,
            expected_um: expected.um,
            expected_from: expected.from.clone(),
            ratio: 0.0,
            dof,
            p_value: 1.0,
            verdict: FitVerdict::NotConverged,
            on: None,
            set_aside: Vec::new(),
            stopped: None,
            allowance: None,
        },
    };
    if stopped.is_some() {
        f.verdict = FitVerdict::NotConverged;
    }
    f.stopped = stopped;
    // Setups fitted short of their optimum leave residuals larger than
    // they need be: a fit stays a fit, a misfit says it may be that.
    f.on = Some(if setup_converged {
        on(m, est.method)
    } else {
        format!(
            "{} (the fit of the setups to the points stopped before converging: the residuals are at most this large)",
            on(m, est.method)
        )
    });
    f.set_aside = est.set_aside.clone();
    Ok(Verdict {
        fit: Some(f),
        residuals,
    })
}

/// What a method's own uncertainty allows its squared residuals beyond a
/// least-squares fit's, in noise variances, direction by direction. Its
/// estimate of the held parameters lies `d` from the least-squares one,
/// which adds `d^T I d` (`I`: the points' information on them, the rest
/// fitted) to the squared residuals. Were the method unbiased with
/// covariance `C` (its u), `d` would have covariance `C - C_ls`, `C_ls =
/// sigma^2 I^-1` (the least-squares fit is the efficient one), so the
/// added sum is `sum l_i z_i^2` with `l_i` the eigenvalues of `I C /
/// sigma^2` less 1, none below 0. An estimate further off than its u
/// says is what the verdict then catches; one as far as its u allows is
/// no misfit.
fn allowance(est: &Identification, held: &[bool], info: &DMatrix<f64>, sigma: f64) -> Vec<f64> {
    let idx: Vec<usize> = (0..held.len()).filter(|&i| held[i]).collect();
    if idx.is_empty() || info.nrows() != idx.len() {
        return Vec::new();
    }
    let c = DMatrix::from_fn(idx.len(), idx.len(), |r, k| est.cov[(idx[r], idx[k])]);
    // R = C^(1/2); the eigenvalues of R I R / sigma^2 are those of I C /
    // sigma^2.
    let e = c.symmetric_eigen();
    let root = DMatrix::from_diagonal(&e.eigenvalues.map(|v| v.max(0.0).sqrt()));
    let r = &e.eigenvectors * root * e.eigenvectors.transpose();
    let s = (&r * info * &r) / (sigma * sigma);
    let s = (&s + s.transpose()) * 0.5;
    s.symmetric_eigen()
        .eigenvalues
        .iter()
        .map(|&mu| (mu - 1.0).max(0.0))
        .filter(|l| l.is_finite())
        .collect()
}

/// The factor a method's covariance uncertainties are widened by under a
/// misfit: the residuals of the verdict over those the covariance was
/// scaled by (the method's own), at least 1. The global method's
/// covariance is scaled by the verdict's residuals already.
pub fn widening(est: &Identification, fit: Option<&FitSection>) -> f64 {
    match fit {
        Some(f) if f.verdict == FitVerdict::Misfit && est.method != Method::Global => {
            let w = f.sigma_um / est.sigma_um;
            if w.is_finite() { w.max(1.0) } else { 1.0 }
        }
        _ => 1.0,
    }
}

/// The verdict as `analyze` prints it first: one line, then what was set
/// aside and why a fit that stopped is none.
pub fn render(f: Option<&FitSection>) -> String {
    let Some(f) = f else {
        return "verdict: not judged (no degrees of freedom left)\n".into();
    };
    let mut s = match f.verdict {
        FitVerdict::NotConverged => format!(
            "verdict: NOT CONVERGED: {}; compensate, its export and verify refuse this result\n",
            f.stopped.as_deref().unwrap_or("the fit stopped")
        ),
        v => format!(
            "verdict: {} (residuals {:.3} um against {:.3} um expected, {}; ratio {:.2}, p {} over {} degrees of freedom)\n",
            v,
            f.sigma_um,
            f.expected_um,
            f.expected_from,
            f.ratio,
            crate::numbers::p_value(f.p_value),
            f.dof
        ),
    };
    if let Some(on) = &f.on {
        s.push_str(&format!("  judged on {on}\n"));
    }
    if let Some(a) = f.allowance {
        s.push_str(&format!(
            "  allowing {a:.1} noise variances for the method's estimate lying as far from the least-squares one as its u says\n"
        ));
    }
    for a in &f.set_aside {
        s.push_str(&format!(
            "  set aside from the estimate, judged here with the rest: {a}\n"
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn section(verdict: FitVerdict) -> FitSection {
        FitSection {
            sigma_um: 2.0,
            expected_um: 0.5,
            expected_from: "test".into(),
            ratio: 4.0,
            dof: 100,
            p_value: 0.0,
            verdict,
            on: Some(on(120, Method::Sphere)),
            set_aside: vec!["the centres at C = 0, 10 deg".into()],
            stopped: None,
            allowance: None,
        }
    }

    #[test]
    fn the_rendered_verdict_names_what_was_set_aside() {
        let s = render(Some(&section(FitVerdict::Misfit)));
        assert!(s.starts_with("verdict: misfit (residuals 2.000 um"), "{s}");
        assert!(s.contains("every one of the 120 measured points"), "{s}");
        assert!(s.contains("judged here with the rest: the centres at C = 0, 10 deg"));
    }

    #[test]
    fn a_fit_that_stopped_is_rendered_as_none() {
        let mut f = section(FitVerdict::NotConverged);
        f.stopped = Some("the global method's fit stopped without converging".into());
        let s = render(Some(&f));
        assert!(s.starts_with("verdict: NOT CONVERGED: the global"), "{s}");
        assert!(s.contains("refuse"));
        assert!(!FitVerdict::NotConverged.is_fit());
    }
}
