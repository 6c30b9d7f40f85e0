//! Goodness of fit: does the identified model explain the measurements as
//! well as the instrument's noise allows? Each identification's residual
//! standard deviation is set against the noise the measurement should show
//! (stated with `--noise`, or the documented default of the instrument)
//! by a chi-square test. A model that does not fit is missing an effect
//! (drift, a map, a scale error, ...) or the stated noise is too small;
//! either way its values are biased by more than their `u` says, so the
//! result file carries the verdict, the uncertainties are widened by the
//! Birge ratio, and `compensate` refuses the result unless told otherwise.

use statrs::distribution::{ChiSquared, ContinuousCDF};

use crate::errorfile::{FitSection, FitVerdict};
use crate::formats::manifest::TestKind;
use crate::identify::Identification;
use crate::procedure::Test;

/// A fit is refused when residuals at least this large would occur by
/// chance with this probability or less, were the model complete. Small,
/// because a wrong refusal costs a `discover` run while a right one keeps
/// biased values out of a control: one clean run in a thousand is flagged.
pub(crate) const MISFIT_SIGNIFICANCE: f64 = 1e-3;

/// The noise a measurement should show, um, and where that figure comes
/// from.
#[derive(Clone, Debug, PartialEq)]
pub struct ExpectedNoise {
    /// Standard deviation per measured point, um.
    pub um: f64,
    /// Where the figure comes from, for the result file and the screen.
    pub from: String,
}

impl ExpectedNoise {
    /// The noise stated by the user (`--noise UM`), else the default of the
    /// instrument that measured a test of `kind`: the non-systematic error
    /// of a machined and CMM-measured piece (Ibaraki & Ota 2014, table 4),
    /// or an on-machine probe's repeatability, with the form error of the
    /// calibration sphere added in quadrature for the sphere test.
    pub fn new(stated: Option<f64>, kind: TestKind, test: Test) -> ExpectedNoise {
        use crate::simulate::{DEFAULT_NOISE_UM, DEFAULT_SPHERE_FORM_UM};
        match stated {
            Some(um) => ExpectedNoise {
                um,
                from: "stated with --noise".into(),
            },
            None => match (kind, test) {
                (TestKind::Machining, _) => ExpectedNoise {
                    um: DEFAULT_NOISE_UM,
                    from: "default for a machined piece on a CMM (Ibaraki & Ota 2014, table 4)"
                        .into(),
                },
                (TestKind::Probing, Test::ProbeSphere) => ExpectedNoise {
                    um: DEFAULT_NOISE_UM.hypot(DEFAULT_SPHERE_FORM_UM),
                    from: "default probe repeatability with the sphere's form error".into(),
                },
                (TestKind::Probing, _) => ExpectedNoise {
                    um: DEFAULT_NOISE_UM,
                    from: "default probe repeatability".into(),
                },
            },
        }
    }
}

impl ExpectedNoise {
    /// The noise of several tests' residuals fitted together, each with
    /// its instrument's noise and number of points: the root mean square
    /// of the noises over the points (a residual's expected square is its
    /// instrument's variance).
    pub(crate) fn pooled(parts: &[(&str, &ExpectedNoise, usize)]) -> ExpectedNoise {
        if let [(_, one, _)] = parts {
            return (*one).clone();
        }
        let n: usize = parts.iter().map(|p| p.2).sum();
        let ss: f64 = parts.iter().map(|p| p.1.um * p.1.um * p.2 as f64).sum();
        ExpectedNoise {
            um: (ss / n.max(1) as f64).sqrt(),
            from: format!(
                "pooled over the tests' points: {}",
                parts
                    .iter()
                    .map(|(name, e, k)| format!("{name} {:.3} um ({}, {k} points)", e.um, e.from))
                    .collect::<Vec<_>>()
                    .join("; ")
            ),
        }
    }
}

/// Judges the fit of residuals with standard deviation `sigma_um` over
/// `dof` degrees of freedom against the expected noise. `None` when it
/// cannot be judged: no degrees of freedom left, or no finite sigma.
pub fn judge(sigma_um: f64, dof: usize, expected: &ExpectedNoise) -> Option<FitSection> {
    judge_allowing(sigma_um, dof, expected, &[])
}

/// [`judge`] for residuals taken at an estimate that is not the
/// least-squares one: besides the chi-square of the noise, the squared
/// residuals (in noise variances) carry `sum l_i z_i^2` with independent
/// standard normal `z_i`, the `allowance` `l_i` being what the method's own
/// uncertainty allows beyond the least-squares fit's along each direction
/// ([`super::verdict`]). The sum is judged by its scaled chi-square of the
/// same mean and variance (Satterthwaite, Welch): exact for no allowance.
pub fn judge_allowing(
    sigma_um: f64,
    dof: usize,
    expected: &ExpectedNoise,
    allowance: &[f64],
) -> Option<FitSection> {
    if dof == 0 || !sigma_um.is_finite() || !(expected.um.is_finite() && expected.um > 0.0) {
        return None;
    }
    let ratio = sigma_um / expected.um;
    let chi2 = dof as f64 * ratio * ratio;
    let extra: f64 = allowance.iter().filter(|l| l.is_finite()).sum();
    let extra2: f64 = allowance
        .iter()
        .filter(|l| l.is_finite())
        .map(|l| l * l)
        .sum();
    let mean = dof as f64 + extra;
    let var = 2.0 * dof as f64 + 2.0 * extra2;
    let (g, h) = (var / (2.0 * mean), 2.0 * mean * mean / var);
    let p_value = ChiSquared::new(h).ok()?.sf(chi2 / g);
    // A chi-square this far out underflows to 0, which is the right answer.
    let p_value = if p_value.is_finite() { p_value } else { 0.0 };
    let verdict = if p_value < MISFIT_SIGNIFICANCE {
        FitVerdict::Misfit
    } else {
        FitVerdict::Fits
    };
    Some(FitSection {
        sigma_um,
        expected_um: expected.um,
        expected_from: expected.from.clone(),
        ratio,
        dof,
        p_value,
        verdict,
        on: None,
        set_aside: Vec::new(),
        stopped: None,
        allowance: (extra > 0.0).then_some(extra),
    })
}

/// The fit of an identification judged by its own residuals (what the
/// global method and `discover` fit: every point against the complete
/// model; every other method is judged by [`super::verdict::of`]). A fit
/// that did not converge is no fit, whatever its residuals.
pub fn of(est: &Identification, expected: &ExpectedNoise) -> Option<FitSection> {
    let mut f = judge(est.sigma_um, est.dof, expected)?;
    if !est.converged {
        f.verdict = FitVerdict::NotConverged;
        f.stopped = Some(format!(
            "the {} method's fit stopped without converging: its values are no estimate",
            est.method
        ));
    }
    Some(f)
}

/// The factor the uncertainties of a result are widened by: the Birge
/// ratio when the model does not fit, else 1. Covariance uncertainties
/// scaled by the residual variance carry it already; uncertainties drawn
/// at the stated noise (a Monte-Carlo study) do not.
pub(crate) fn widening(fit: Option<&FitSection>) -> f64 {
    match fit {
        Some(f) if f.verdict == FitVerdict::Misfit && f.ratio > 1.0 => f.ratio,
        _ => 1.0,
    }
}

/// The banner shown above a result whose model does not fit, with what to
/// do next: `next` is the `fivecal discover` command that looks for the
/// missing effect.
pub fn banner(f: &FitSection, next: &str) -> String {
    format!(
        "THE MODEL DOES NOT FIT: residuals {:.3} um against {:.3} um expected ({}), ratio {:.2}, \
         p {} over {} degrees of freedom.\n\
         The values below are biased by an effect the model lacks (or the stated noise is too \
         small); their u is widened by the ratio, and compensate refuses this result without \
         --accept-misfit.\n\
         Find the missing effect with:\n  {next}",
        f.sigma_um,
        f.expected_um,
        f.expected_from,
        f.ratio,
        crate::numbers::p_value(f.p_value),
        f.dof
    )
}

/// The `fivecal discover` command that looks for the effect missing from
/// a model fitted to `measured` against the plan `manifest`.
pub fn discover_command(manifest: &std::path::Path, measured: &[std::path::PathBuf]) -> String {
    let mut c = format!("fivecal discover --plan {} --measured", quote(manifest));
    for m in measured {
        c.push(' ');
        c.push_str(&quote(m));
    }
    c.push_str(" --out model.yaml");
    c
}

/// A path as a POSIX shell word.
fn quote(p: &std::path::Path) -> String {
    crate::io::shell_word(&p.display().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn expected(um: f64) -> ExpectedNoise {
        ExpectedNoise {
            um,
            from: "test".into(),
        }
    }

    #[test]
    fn residuals_at_the_noise_fit() {
        let f = judge(0.36, 200, &expected(0.35)).unwrap();
        assert_eq!(f.verdict, FitVerdict::Fits);
        assert!((f.ratio - 0.36 / 0.35).abs() < 1e-12);
    }

    #[test]
    fn the_demo_drift_is_a_misfit() {
        // The README demo's drifting piece: 2.55 um residuals against a
        // 0.35 um CMM.
        let f = judge(2.55, 150, &expected(0.35)).unwrap();
        assert_eq!(f.verdict, FitVerdict::Misfit);
        assert_eq!(f.p_value, 0.0);
        assert!((widening(Some(&f)) - 2.55 / 0.35).abs() < 1e-12);
    }

    #[test]
    fn the_threshold_is_the_chi_square_quantile() {
        // statrs' inverse CDF gives the ratio at which the verdict turns.
        let dof = 50usize;
        let q = ChiSquared::new(dof as f64)
            .unwrap()
            .inverse_cdf(1.0 - MISFIT_SIGNIFICANCE);
        let r = (q / dof as f64).sqrt();
        assert_eq!(
            judge(0.35 * r * 0.999, dof, &expected(0.35))
                .unwrap()
                .verdict,
            FitVerdict::Fits
        );
        assert_eq!(
            judge(0.35 * r * 1.001, dof, &expected(0.35))
                .unwrap()
                .verdict,
            FitVerdict::Misfit
        );
        // Wilson-Hilferty: the 0.999 quantile of chi-square(50) is 86.66.
        assert!((q - 86.66).abs() < 0.05, "{q}");
    }

    #[test]
    fn the_next_command_survives_the_shell() {
        let c = discover_command(
            std::path::Path::new("ss/stepped-square.plan.yaml"),
            &["piece one.dmo".into(), "it's.csv".into()],
        );
        assert_eq!(
            c,
            "fivecal discover --plan ss/stepped-square.plan.yaml --measured 'piece one.dmo' 'it'\\''s.csv' --out model.yaml"
        );
    }

    #[test]
    fn pooled_noise_is_the_rms_over_the_points() {
        let (a, b) = (expected(0.3), expected(0.4));
        let p = ExpectedNoise::pooled(&[("ss", &a, 100), ("ps", &b, 300)]);
        // (100 * 0.09 + 300 * 0.16) / 400 = 0.1425
        assert!((p.um - 0.1425f64.sqrt()).abs() < 1e-12);
        assert!(p.from.contains("ss 0.300 um") && p.from.contains("300 points"));
        assert_eq!(ExpectedNoise::pooled(&[("ss", &a, 100)]), a);
    }

    #[test]
    fn an_allowance_is_judged_by_the_moments_of_the_sum() {
        // No allowance: the chi-square itself.
        let plain = judge(0.4, 200, &expected(0.35)).unwrap();
        let none = judge_allowing(0.4, 200, &expected(0.35), &[]).unwrap();
        assert_eq!(plain.p_value, none.p_value);
        // 200 variances of noise and 50 more the method allows along one
        // direction: the sum has mean 250 and variance 400 + 2 * 2500.
        // Its 0.999 quantile, by a Monte Carlo of the sum itself, lies
        // near 250 + 3.1 sqrt(5400) = 478; at a chi-square of 300 the
        // residuals fit, at 700 they do not.
        let at = |chi2: f64| (chi2 / 200.0f64).sqrt() * 0.35;
        let ok = judge_allowing(at(300.0), 200, &expected(0.35), &[50.0]).unwrap();
        assert_eq!(ok.verdict, FitVerdict::Fits, "{ok:?}");
        assert_eq!(ok.allowance, Some(50.0));
        let bad = judge_allowing(at(700.0), 200, &expected(0.35), &[50.0]).unwrap();
        assert_eq!(bad.verdict, FitVerdict::Misfit, "{bad:?}");
        // Without the allowance, 300 is already a misfit.
        assert_eq!(
            judge(at(300.0), 200, &expected(0.35)).unwrap().verdict,
            FitVerdict::Misfit
        );
        // The moment match against a direct simulation of the sum.
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        let mut r = rand::rngs::StdRng::seed_from_u64(7);
        let mut gauss = || -> f64 { StandardNormal.sample(&mut r) };
        let n = 20000;
        let mut above = 0;
        for _ in 0..n {
            let mut t = 0.0;
            for _ in 0..200 {
                t += gauss().powi(2);
            }
            t += 50.0 * gauss().powi(2);
            if t > 400.0 {
                above += 1;
            }
        }
        let mc = above as f64 / n as f64;
        let p = judge_allowing(at(400.0), 200, &expected(0.35), &[50.0])
            .unwrap()
            .p_value;
        assert!((p - mc).abs() < 0.02, "moment match {p}, simulated {mc}");
    }

    #[test]
    fn nothing_left_to_judge_gives_no_verdict() {
        assert!(judge(0.3, 0, &expected(0.35)).is_none());
        assert!(judge(f64::NAN, 10, &expected(0.35)).is_none());
        assert_eq!(widening(None), 1.0);
    }
}
