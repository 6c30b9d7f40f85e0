//! Whether an error is drifting, since when, and when it will reach its
//! limit at the current rate: a straight line fitted to the values over
//! time, each weighted by 1/u², with the uncertainty of its slope and of
//! the forecast.
//!
//! The drift that matters is the current one, so the fit uses the longest
//! run of latest results that a straight line explains (the chi-square of
//! the weighted residuals against the results' own u, at the 1 % level):
//! a machine that was stable for months and has drifted since the last
//! warm-up trends from the warm-up on. When no run of three or more is
//! explained by a line, the whole series is fitted and the slope's u
//! widened by the Birge ratio (the scatter beyond the stated u). A slope
//! smaller than its 95 % two-sided bound (1.96 u, or Student's t after the
//! widening) is no trend.

use jiff::Timestamp;
use statrs::distribution::{ChiSquared, ContinuousCDF, StudentsT};

use crate::conformance::Limit;

const MICROS_PER_DAY: f64 = 86_400e6;

/// Significance of a chi-square that rejects a straight line.
const LINE_ALPHA: f64 = 0.01;

/// Two-sided level of the slope's significance.
const SLOPE_LEVEL: f64 = 0.95;

/// One result in time: when, the value and its standard uncertainty, split
/// into the part that varies from one run to the next and the part common
/// to every run of the test on the machine.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrendSample {
    /// When the machine was measured.
    pub at: Timestamp,
    /// The value (um or urad).
    pub value: f64,
    /// The standard uncertainty of what varies from run to run (> 0): the
    /// instrument's noise and the setup. The line is fitted against it.
    pub u: f64,
    /// The standard uncertainty common to every run of the test on this
    /// machine (its linear axes' errors seen through the same design, the
    /// probe's pre-travel): it moves every value of the series alike, so
    /// it leaves the slope alone and adds to the line's level.
    pub u_common: f64,
}

/// A weighted straight line through samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrendLine {
    /// Number of samples.
    pub n: usize,
    /// The first sample's time.
    pub since: Timestamp,
    /// The last sample's time, where `value` is given.
    pub at: Timestamp,
    /// The line's value at `at`.
    pub value: f64,
    /// Its standard uncertainty.
    pub u_value: f64,
    /// Slope, unit per day.
    pub slope: f64,
    /// Its standard uncertainty.
    pub u_slope: f64,
    /// Covariance of `value` and `slope`.
    pub cov: f64,
    /// Weighted residual sum of squares.
    pub chi2: f64,
    /// The factor the u were widened by (1 when the scatter is within the
    /// stated u).
    pub birge: f64,
}

impl TrendLine {
    /// Fits `samples` (at least three, each with u > 0), time in days from
    /// the last sample. `None` when fewer or when they share one instant.
    pub fn fit(samples: &[TrendSample]) -> Option<TrendLine> {
        let n = samples.len();
        if n < 3
            || samples
                .iter()
                .any(|s| !(s.u > 0.0 && s.value.is_finite() && s.u_common.is_finite()))
        {
            return None;
        }
        let t0 = samples[n - 1].at;
        let x = |s: &TrendSample| days_between(t0, s.at);
        let (mut sw, mut sx, mut sxx, mut sy, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for s in samples {
            let w = 1.0 / (s.u * s.u);
            let xi = x(s);
            sw += w;
            sx += w * xi;
            sxx += w * xi * xi;
            sy += w * s.value;
            sxy += w * xi * s.value;
        }
        let det = sw * sxx - sx * sx;
        if det <= 1e-12 * sw * sxx.max(f64::MIN_POSITIVE) {
            return None;
        }
        let a = (sxx * sy - sx * sxy) / det;
        let b = (sw * sxy - sx * sy) / det;
        let chi2: f64 = samples
            .iter()
            .map(|s| ((s.value - a - b * x(s)) / s.u).powi(2))
            .sum();
        let dof = (n - 2) as f64;
        let birge = (chi2 / dof).sqrt().max(1.0);
        let scale = birge * birge;
        Some(TrendLine {
            n,
            since: samples[0].at,
            at: t0,
            value: a,
            u_value: (scale * sxx / det + samples[n - 1].u_common.powi(2)).sqrt(),
            slope: b,
            u_slope: (scale * sw / det).sqrt(),
            cov: -scale * sx / det,
            chi2,
            birge,
        })
    }

    /// Whether a straight line explains the samples within their u (the
    /// chi-square's upper tail above 1 %).
    pub(crate) fn is_straight(&self) -> bool {
        let dof = (self.n - 2) as f64;
        ChiSquared::new(dof).is_ok_and(|c| 1.0 - c.cdf(self.chi2) >= LINE_ALPHA)
    }

    /// The bound the slope must exceed, in units of its u.
    pub(crate) fn critical(&self) -> f64 {
        let q = 0.5 + SLOPE_LEVEL / 2.0;
        if self.birge > 1.0 {
            StudentsT::new(0.0, 1.0, (self.n - 2) as f64)
                .map(|t| t.inverse_cdf(q))
                .unwrap_or(f64::INFINITY)
        } else {
            statrs::distribution::Normal::standard().inverse_cdf(q)
        }
    }

    /// Whether the slope differs from zero at the 95 % level.
    pub fn significant(&self) -> bool {
        self.slope.abs() > self.critical() * self.u_slope
    }
}

/// Days from `from` to `to`.
pub fn days_between(from: Timestamp, to: Timestamp) -> f64 {
    (to.as_microsecond() - from.as_microsecond()) as f64 / MICROS_PER_DAY
}

/// `t` moved by `days`.
pub fn add_days(t: Timestamp, days: f64) -> Option<Timestamp> {
    let us = t.as_microsecond() as f64 + days * MICROS_PER_DAY;
    if !us.is_finite() || us.abs() > 9.0e18 {
        return None;
    }
    Timestamp::from_microsecond(us as i64).ok()
}

/// When the drifting value reaches its limit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Forecast {
    /// No limit for the symbol.
    NoLimit,
    /// The line is already beyond the limit it moves toward.
    Beyond {
        /// The limit.
        limit: f64,
    },
    /// It reaches `limit` at `at`, with standard uncertainty `u_days`.
    Reaches {
        /// The limit it moves toward.
        limit: f64,
        /// When.
        at: Timestamp,
        /// Standard uncertainty of the date, days.
        u_days: f64,
    },
}

/// The shortest span of results a trend is fitted over, days: results
/// taken minutes apart say nothing about a drift per day (three of them
/// once gave "+20760 um/day").
pub const MIN_SPAN_DAYS: f64 = 1.0;

/// What the series says.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outlook {
    /// Fewer than three results with an uncertainty.
    TooFew {
        /// How many there are.
        n: usize,
    },
    /// The results span less than [`MIN_SPAN_DAYS`].
    TooShort {
        /// How many there are.
        n: usize,
        /// The days from the first to the last.
        days: f64,
    },
    /// The slope is within its 95 % bound of zero.
    NoTrend {
        /// The line fitted.
        line: TrendLine,
    },
    /// Drifting since `line.since`.
    Drifting {
        /// The line fitted.
        line: TrendLine,
        /// When it reaches its limit.
        forecast: Forecast,
    },
}

/// The outlook of `samples` (oldest first) against `limit`.
pub fn outlook(samples: &[TrendSample], limit: Option<Limit>) -> Outlook {
    let n = samples.len();
    if n < 3 {
        return Outlook::TooFew { n };
    }
    let days = days_between(samples[0].at, samples[n - 1].at);
    if days < MIN_SPAN_DAYS {
        return Outlook::TooShort { n, days };
    }
    let line = (0..=n - 3)
        .filter_map(|k| TrendLine::fit(&samples[k..]))
        .find(TrendLine::is_straight)
        .or_else(|| TrendLine::fit(samples));
    let Some(line) = line else {
        return Outlook::TooFew { n };
    };
    if !line.significant() {
        return Outlook::NoTrend { line };
    }
    let forecast = match limit {
        None => Forecast::NoLimit,
        Some(l) => forecast(&line, l),
    };
    Outlook::Drifting { line, forecast }
}

/// When `line` reaches the limit it moves toward: `d = (L - a) / b` days
/// after its last sample, u by first-order propagation of the covariance
/// of (a, b).
fn forecast(line: &TrendLine, limit: Limit) -> Forecast {
    let (a, b) = (line.value, line.slope);
    let l = limit.toward(b.signum());
    if (l - a) * b.signum() <= 0.0 {
        return Forecast::Beyond { limit: l };
    }
    let d = (l - a) / b;
    let var = line.u_value.powi(2) / (b * b)
        + (l - a).powi(2) * line.u_slope.powi(2) / b.powi(4)
        + 2.0 * (l - a) * line.cov / b.powi(3);
    match add_days(line.at, d) {
        Some(at) => Forecast::Reaches {
            limit: l,
            at,
            u_days: var.max(0.0).sqrt(),
        },
        // Beyond any date: as good as no drift toward it.
        None => Forecast::NoLimit,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn day(k: f64) -> Timestamp {
        add_days("2026-01-01T00:00:00Z".parse().unwrap(), k).unwrap()
    }

    /// Exact points on y = 2 + 0.5 x (x in days): the line comes back
    /// exactly, its value at the last sample is 2 + 0.5 * 8, and the
    /// covariance matches the closed form for equal weights.
    #[test]
    fn a_straight_line_is_recovered_with_the_closed_form_covariance() {
        let s: Vec<TrendSample> = [0.0, 2.0, 4.0, 6.0, 8.0]
            .iter()
            .map(|&x| TrendSample {
                at: day(x),
                value: 2.0 + 0.5 * x,
                u: 0.1,
                u_common: 0.0,
            })
            .collect();
        let l = TrendLine::fit(&s).unwrap();
        assert!((l.slope - 0.5).abs() < 1e-12 && (l.value - 6.0).abs() < 1e-12);
        assert!(l.chi2 < 1e-18 && l.birge == 1.0);
        // Equal weights: var(b) = u^2 / sum (x - xbar)^2 = 0.01 / 40.
        assert!((l.u_slope - (0.01f64 / 40.0).sqrt()).abs() < 1e-12);
        // At the last sample (x - xbar = 4): var(a) = u^2 (1/n + 16/40).
        assert!((l.u_value - (0.01f64 * (0.2 + 0.4)).sqrt()).abs() < 1e-12);
        assert!(l.significant() && l.is_straight());
    }

    /// A bias common to every run (the machine's linear axes seen through
    /// the same design, 2 um here) moves each value alike: the slope and
    /// its u are those of the run-to-run part alone, the level's u holds
    /// both. Weighted by the whole u as if independent, the same clear
    /// drift (0.2 per day against 0.1 of noise) would not count.
    #[test]
    fn a_bias_common_to_every_run_leaves_the_slope_alone() {
        let at = |u_common: f64| -> Vec<TrendSample> {
            (0..6)
                .map(|k| TrendSample {
                    at: day(k as f64),
                    value: 0.2 * k as f64 + if k % 2 == 0 { 0.05 } else { -0.05 },
                    u: 0.1,
                    u_common,
                })
                .collect()
        };
        let (alone, common) = (
            TrendLine::fit(&at(0.0)).unwrap(),
            TrendLine::fit(&at(2.0)).unwrap(),
        );
        assert_eq!(common.slope, alone.slope);
        assert_eq!(common.u_slope, alone.u_slope);
        assert!((common.u_value.powi(2) - alone.u_value.powi(2) - 4.0).abs() < 1e-12);
        assert!(common.significant());
        let whole = (0.1f64.powi(2) + 4.0).sqrt();
        let as_independent: Vec<TrendSample> = at(0.0)
            .into_iter()
            .map(|s| TrendSample { u: whole, ..s })
            .collect();
        assert!(!TrendLine::fit(&as_independent).unwrap().significant());
    }

    /// Scatter three times the stated u widens the slope's u threefold.
    #[test]
    fn scatter_beyond_u_widens_by_the_birge_ratio() {
        let noise = [0.3, -0.3, 0.3, -0.3, 0.3, -0.3];
        let s: Vec<TrendSample> = noise
            .iter()
            .enumerate()
            .map(|(k, e)| TrendSample {
                at: day(k as f64),
                value: 1.0 + e,
                u: 0.1,
                u_common: 0.0,
            })
            .collect();
        let l = TrendLine::fit(&s).unwrap();
        assert!(l.birge > 2.5, "{l:?}");
        assert!(!l.is_straight());
        let unscaled = (0.01f64 / 17.5).sqrt();
        assert!((l.u_slope / unscaled - l.birge).abs() < 1e-9);
    }

    /// Flat for five days, then rising 1 per day: the drift is dated from
    /// the last flat day (the longest run a line explains), and the
    /// forecast of reaching 10 follows from the closed form.
    #[test]
    fn the_drift_is_dated_from_where_it_starts_and_forecast_to_the_limit() {
        let mut s: Vec<TrendSample> = (0..5)
            .map(|k| TrendSample {
                at: day(k as f64),
                value: 0.0,
                u: 0.05,
                u_common: 0.0,
            })
            .collect();
        for k in 5..9 {
            s.push(TrendSample {
                at: day(k as f64),
                value: (k - 4) as f64,
                u: 0.05,
                u_common: 0.0,
            });
        }
        let Outlook::Drifting { line, forecast } = outlook(&s, Some(Limit::symmetric(10.0))) else {
            panic!("{:?}", outlook(&s, None))
        };
        assert_eq!(line.since, day(4.0));
        assert!((line.slope - 1.0).abs() < 1e-9);
        let Forecast::Reaches { limit, at, u_days } = forecast else {
            panic!("{forecast:?}")
        };
        assert_eq!(limit, 10.0);
        // 4 at day 8, 1 per day: 10 on day 14.
        assert!(days_between(day(14.0), at).abs() < 1e-6, "{at}");
        assert!(u_days > 0.0 && u_days < 0.5, "{u_days}");
    }

    /// Noise around a constant: no trend. A fall toward the lower limit
    /// forecasts that one; a value already past it says so.
    #[test]
    fn no_trend_downward_drift_and_beyond() {
        let flat: Vec<TrendSample> = [0.02, -0.03, 0.01, 0.0, -0.01]
            .iter()
            .enumerate()
            .map(|(k, &v)| TrendSample {
                at: day(k as f64 * 7.0),
                value: v,
                u: 0.05,
                u_common: 0.0,
            })
            .collect();
        assert!(matches!(outlook(&flat, None), Outlook::NoTrend { .. }));
        let fall: Vec<TrendSample> = (0..4)
            .map(|k| TrendSample {
                at: day(k as f64),
                value: -2.0 * k as f64,
                u: 0.1,
                u_common: 0.0,
            })
            .collect();
        let lim = Limit {
            lower: -10.0,
            upper: 3.0,
        };
        match outlook(&fall, Some(lim)) {
            Outlook::Drifting {
                forecast: Forecast::Reaches { limit, at, .. },
                ..
            } => {
                assert_eq!(limit, -10.0);
                assert!(days_between(day(5.0), at).abs() < 1e-6);
            }
            o => panic!("{o:?}"),
        }
        let past = Limit {
            lower: -5.0,
            upper: 3.0,
        };
        assert!(matches!(
            outlook(&fall, Some(past)),
            Outlook::Drifting {
                forecast: Forecast::Beyond { limit: -5.0 },
                ..
            }
        ));
        assert_eq!(outlook(&fall[..2], None), Outlook::TooFew { n: 2 });
    }

    /// Three results minutes apart, from 0 to 20 um: no trend is drawn
    /// from them, however steep (they once made "+20760 um/day").
    #[test]
    fn results_minutes_apart_are_too_short_for_a_trend() {
        let s: Vec<TrendSample> = (0..3)
            .map(|k| TrendSample {
                at: add_days(day(0.0), k as f64 * 5.0 / 1440.0).unwrap(),
                value: 10.0 * k as f64,
                u: 0.5,
                u_common: 0.0,
            })
            .collect();
        match outlook(&s, Some(Limit::symmetric(5.0))) {
            Outlook::TooShort { n: 3, days } => assert!((days - 10.0 / 1440.0).abs() < 1e-9),
            o => panic!("{o:?}"),
        }
    }

    /// The forecast's u against a Monte Carlo of the fitted line: the
    /// spread of the crossing day over 4000 seeded noisy series is within
    /// 10 % of the propagated u.
    #[test]
    fn the_forecast_uncertainty_matches_a_monte_carlo() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let noise = Normal::new(0.0, 0.2).unwrap();
        let truth = |x: f64| 1.0 + 0.3 * x;
        let xs = [0.0, 3.0, 6.0, 9.0, 12.0, 15.0];
        let lim = Limit::symmetric(12.0);
        let one = |rng: &mut rand::rngs::StdRng| {
            let s: Vec<TrendSample> = xs
                .iter()
                .map(|&x| TrendSample {
                    at: day(x),
                    value: truth(x) + noise.sample(rng),
                    u: 0.2,
                    u_common: 0.0,
                })
                .collect();
            let line = TrendLine::fit(&s).unwrap();
            (line, forecast(&line, lim))
        };
        let mut days = Vec::new();
        for _ in 0..4000 {
            if let (_, Forecast::Reaches { at, .. }) = one(&mut rng) {
                days.push(days_between(day(0.0), at));
            }
        }
        let mean = days.iter().sum::<f64>() / days.len() as f64;
        let sd =
            (days.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (days.len() - 1) as f64).sqrt();
        // The propagated u at the true line (u does not depend on the noise
        // draw when the scatter is within u).
        let exact: Vec<TrendSample> = xs
            .iter()
            .map(|&x| TrendSample {
                at: day(x),
                value: truth(x),
                u: 0.2,
                u_common: 0.0,
            })
            .collect();
        let Forecast::Reaches { u_days, .. } = forecast(&TrendLine::fit(&exact).unwrap(), lim)
        else {
            panic!()
        };
        assert!((sd / u_days - 1.0).abs() < 0.1, "spread {sd}, u {u_days}");
        assert!((mean - 110.0 / 3.0).abs() < 0.5, "{mean}");
    }
}
