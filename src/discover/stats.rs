//! Is a candidate worth adding? The classical tests for nested
//! least-squares models with Gaussian noise.
//!
//! - **F-test** on the reduction of the residual sum of squares: with `n`
//!   observations, the current model of rank `r0` and the extended one of
//!   rank `r1 > r0`,
//!   `F = ((RSS0 - RSS1) / (r1 - r0)) / (RSS1 / (n - r1))` follows
//!   `F(r1 - r0, n - r1)` when the candidate is absent. The degrees of
//!   freedom are ranks, not parameter counts: a candidate constrained to
//!   what the test sees adds only the directions it is free in.
//! - **Information criteria** against over-fitting: `BIC = n ln(RSS/n) +
//!   r ln n` (Schwarz) and `AIC = n ln(RSS/n) + 2 r`; a candidate must
//!   lower the BIC.
//! - **Multiple comparisons**: the best of `m` candidates is the best of `m`
//!   chances, so its p-value is multiplied by `m` (Bonferroni) before it is
//!   compared with `alpha`; on data without a missing effect a step then
//!   adds something with probability at most `alpha`.

use serde::Serialize;
use statrs::function::beta::beta_reg;

/// The comparison of a model with one more effect against the current one.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct NestedTest {
    /// Number of observations.
    pub n: usize,
    /// Directions the candidate adds (rank increase).
    pub df1: usize,
    /// Residual degrees of freedom of the extended model.
    pub df2: usize,
    /// The F statistic.
    pub f: f64,
    /// Its p-value (upper tail of F(df1, df2)).
    pub p: f64,
    /// Change of the Bayesian information criterion (negative: better).
    pub delta_bic: f64,
    /// Change of Akaike's information criterion (negative: better).
    pub delta_aic: f64,
    /// Fraction of the squared gap the candidate explains.
    pub explained: f64,
}

/// Upper tail of the F distribution, `P(F(d1, d2) > f)`, computed as
/// `I_x(d2/2, d1/2)` with `x = d2 / (d2 + d1 f)` so that small tails keep
/// their relative precision.
pub(crate) fn f_upper_tail(f: f64, d1: f64, d2: f64) -> f64 {
    if f.is_nan() {
        return f64::NAN;
    }
    if f <= 0.0 {
        return 1.0;
    }
    if f.is_infinite() {
        return 0.0;
    }
    let x = d2 / (d2 + d1 * f);
    beta_reg(d2 / 2.0, d1 / 2.0, x).clamp(0.0, 1.0)
}

/// Compares the extended model (`rss1`, rank `r1`) with the current one
/// (`rss0`, rank `r0`) on `n` observations.
pub fn compare(n: usize, rss0: f64, r0: usize, rss1: f64, r1: usize) -> NestedTest {
    let df1 = r1.saturating_sub(r0);
    let df2 = n.saturating_sub(r1);
    let nf = n as f64;
    // A floor far below any measurement noise keeps the logarithms finite
    // on exact (noise-free) data.
    let floor = 1e-24 * nf;
    let (a, b) = (rss0.max(floor), rss1.max(floor));
    let dll = nf * (b / a).ln();
    let f = if df1 == 0 || df2 == 0 {
        f64::NAN
    } else if rss1 <= 0.0 {
        f64::INFINITY
    } else {
        ((rss0 - rss1).max(0.0) / df1 as f64) / (rss1 / df2 as f64)
    };
    let p = if df1 == 0 || df2 == 0 {
        1.0
    } else {
        f_upper_tail(f, df1 as f64, df2 as f64)
    };
    NestedTest {
        n,
        df1,
        df2,
        f,
        p,
        delta_bic: dll + df1 as f64 * nf.ln(),
        delta_aic: dll + 2.0 * df1 as f64,
        explained: if rss0 > 0.0 {
            ((rss0 - rss1) / rss0).clamp(0.0, 1.0)
        } else {
            0.0
        },
    }
}

/// Upper tail of the noncentral chi-square distribution with `k` degrees of
/// freedom and noncentrality `lambda` at `x`: the Poisson mixture
/// `sum_j e^(-lambda/2) (lambda/2)^j / j! P(chi2(k + 2j) > x)`, summed from
/// the Poisson mode outwards until the weights no longer count.
pub(crate) fn noncentral_chi2_sf(x: f64, k: f64, lambda: f64) -> f64 {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    use statrs::function::gamma::ln_gamma;
    if !(x.is_finite() && k > 0.0 && lambda >= 0.0 && lambda.is_finite()) {
        return f64::NAN;
    }
    let h = lambda / 2.0;
    let weight = |j: f64| {
        if h == 0.0 {
            if j == 0.0 { 1.0 } else { 0.0 }
        } else {
            (-h + j * h.ln() - ln_gamma(j + 1.0)).exp()
        }
    };
    let tail = |j: f64| ChiSquared::new(k + 2.0 * j).map_or(f64::NAN, |c| c.sf(x));
    let mode = h.floor();
    let mut total = 0.0;
    let mut j = mode;
    loop {
        let w = weight(j);
        total += w * tail(j);
        if (w < 1e-17 && j < mode) || j == 0.0 {
            break;
        }
        j -= 1.0;
    }
    let mut j = mode + 1.0;
    loop {
        let w = weight(j);
        total += w * tail(j);
        if w < 1e-17 {
            break;
        }
        j += 1.0;
    }
    total.clamp(0.0, 1.0)
}

/// The power of the chi-square test at level `alpha` of an effect that adds
/// `df` directions and moves the measurements by a noncentrality `lambda`
/// (its unexplained signal's sum of squares over the noise variance).
pub fn power(df: usize, lambda: f64, alpha: f64) -> f64 {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    if df == 0 {
        return 0.0;
    }
    let Ok(c) = ChiSquared::new(df as f64) else {
        return 0.0;
    };
    noncentral_chi2_sf(c.inverse_cdf(1.0 - alpha), df as f64, lambda)
}

/// Bonferroni's adjustment of the best of `m` p-values.
pub(crate) fn adjusted(p: f64, m: usize) -> f64 {
    (p * m.max(1) as f64).min(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f_tail_matches_closed_forms_and_tables() {
        // F(2, d2): P(F > f) = (1 + 2 f / d2)^(-d2/2) exactly.
        for (f, d2) in [(0.5, 10.0), (3.0, 40.0), (25.0, 130.0)] {
            let closed = (1.0f64 + 2.0 * f / d2).powf(-d2 / 2.0);
            let p = f_upper_tail(f, 2.0, d2);
            assert!(
                (p - closed).abs() < 1e-12 * closed.max(1e-300),
                "{f} {d2}: {p} vs {closed}"
            );
        }
        // Tables: F(1, 120) at 0.01 is 6.851, F(5, 100) at 0.05 is 2.305.
        assert!((f_upper_tail(6.851, 1.0, 120.0) - 0.01).abs() < 2e-5);
        assert!((f_upper_tail(2.305, 5.0, 100.0) - 0.05).abs() < 2e-4);
        // Far tails keep their relative precision.
        let closed = (1.0f64 + 2.0 * 400.0 / 130.0).powf(-65.0);
        assert!((f_upper_tail(400.0, 2.0, 130.0) / closed - 1.0).abs() < 1e-9);
    }

    #[test]
    fn noncentral_chi_square_matches_the_normal_form_for_one_degree() {
        // chi2'(1, lambda) is (Z + sqrt(lambda))^2.
        use statrs::distribution::{ContinuousCDF, Normal};
        let n = Normal::standard();
        for (x, lambda) in [(3.84, 0.0), (6.63, 4.0), (10.83, 25.0), (2.0, 400.0)] {
            let (a, b) = (f64::sqrt(x), f64::sqrt(lambda));
            let closed = n.sf(a - b) + n.cdf(-a - b);
            let p = noncentral_chi2_sf(x, 1.0, lambda);
            assert!((p - closed).abs() < 1e-10, "{x} {lambda}: {p} vs {closed}");
        }
        // With no noncentrality it is the central tail; power at zero
        // signal is the level, and grows with the signal.
        assert!((noncentral_chi2_sf(9.488, 4.0, 0.0) - 0.05).abs() < 1e-4);
        assert!((power(2, 0.0, 0.01) - 0.01).abs() < 1e-9);
        assert!(power(2, 30.0, 0.01) > power(2, 10.0, 0.01));
        assert_eq!(power(0, 100.0, 0.01), 0.0);
    }

    #[test]
    fn comparison_counts_ranks_and_penalises_parameters() {
        let c = compare(100, 200.0, 10, 100.0, 11);
        assert_eq!((c.df1, c.df2), (1, 89));
        assert!((c.f - 89.0).abs() < 1e-12);
        assert!((c.explained - 0.5).abs() < 1e-12);
        assert!((c.delta_bic - (100.0 * 0.5f64.ln() + 100f64.ln())).abs() < 1e-12);
        // No reduction: nothing gained, the criteria get worse.
        let c = compare(100, 200.0, 10, 200.0, 12);
        assert_eq!(c.p, 1.0);
        assert!(c.delta_bic > 0.0 && c.delta_aic > 0.0);
        assert_eq!(adjusted(0.004, 30), 0.12);
    }
}
