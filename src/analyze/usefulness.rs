//! When an identified value is worth acting on. A test may see an error
//! (its estimate responds to it) and still pin it so loosely that
//! compensating it could make the machine worse: a location error with a
//! standard uncertainty of 48 um is seen, but not usefully. Each location
//! error is counted as identified, written among the result's values and
//! so exported or compensated, only when its full `u` is at most a
//! threshold:
//! - the machine file's acceptance limit for the symbol, where one is
//!   given: its half-width divided by two, so that the expanded
//!   uncertainty `U = 2u` (k = 2, as the conformance decision takes it)
//!   fits inside the limit;
//! - else a default per unit, 10 um for a position and 50 urad for an
//!   orientation (50 urad tilts a tool 200 mm long by 10 um at its tip):
//!   the loosest a compensation of a machining centre can act on, which
//!   `--useful-u UM,URAD` tightens or loosens.
//!
//! Above it the value is listed as seen but not usefully, with its `u` and
//! the threshold, in `plan`'s prediction and in `analyze`'s result.

use crate::kinematics::symbols::Unit;
use crate::machine::acceptance::AcceptanceLimits;

/// The default threshold for a position, um.
pub const DEFAULT_UM: f64 = 10.0;
/// The default threshold for an orientation, urad.
pub const DEFAULT_URAD: f64 = 50.0;

/// The thresholds per unit a user set (or the defaults).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Usefulness {
    /// Largest useful `u` of a position, um.
    pub um: f64,
    /// Largest useful `u` of an orientation, urad.
    pub urad: f64,
}

impl Default for Usefulness {
    fn default() -> Self {
        Usefulness {
            um: DEFAULT_UM,
            urad: DEFAULT_URAD,
        }
    }
}

/// The threshold one symbol is held to, and where it comes from.
#[derive(Clone, Debug, PartialEq)]
pub struct Threshold {
    /// Largest useful `u`, in the symbol's unit.
    pub u: f64,
    /// Where it comes from, in words.
    pub from: String,
}

impl Usefulness {
    /// Parses `UM,URAD` (`--useful-u 10,50`).
    pub fn parse(s: &str) -> Result<Usefulness, String> {
        let bad = || {
            format!(
                "`{s}`: expected two numbers > 0, the largest useful u of a position (um) and of an orientation (urad), e.g. 10,50"
            )
        };
        let v: Vec<f64> = s
            .split(',')
            .map(|x| x.trim().parse::<f64>().map_err(|_| bad()))
            .collect::<Result<_, _>>()?;
        match v[..] {
            [um, urad] if um.is_finite() && um > 0.0 && urad.is_finite() && urad > 0.0 => {
                Ok(Usefulness { um, urad })
            }
            _ => Err(bad()),
        }
    }

    /// The threshold of `symbol` (of `unit`): the machine file's limit
    /// where it gives one, else the threshold of the unit.
    pub fn threshold(&self, symbol: &str, unit: Unit, limits: &AcceptanceLimits) -> Threshold {
        if let Some(l) = limits.get(symbol) {
            let half = (l.upper - l.lower) / 2.0;
            return Threshold {
                u: half / 2.0,
                from: format!(
                    "half the half-width of the machine file's acceptance limit {l} {unit}, so that U = 2u fits inside it"
                ),
            };
        }
        let (u, flag) = match unit {
            Unit::Um => (self.um, "um"),
            Unit::Urad => (self.urad, "urad"),
        };
        let default = match unit {
            Unit::Um => DEFAULT_UM,
            Unit::Urad => DEFAULT_URAD,
        };
        Threshold {
            u,
            from: if u == default {
                format!("the default for {flag}; --useful-u UM,URAD sets it")
            } else {
                format!("--useful-u for {flag}")
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine::acceptance::Limit;

    #[test]
    fn a_limit_of_plus_minus_20_um_asks_for_u_at_most_10_um() {
        let mut limits = AcceptanceLimits::default();
        limits.0.insert("EX0B".into(), Limit::symmetric(20.0));
        // An interval 40 um wide: the same half-width.
        limits.0.insert(
            "EZ0B".into(),
            Limit {
                lower: -10.0,
                upper: 30.0,
            },
        );
        let u = Usefulness::default();
        assert_eq!(u.threshold("EX0B", Unit::Um, &limits).u, 10.0);
        assert_eq!(u.threshold("EZ0B", Unit::Um, &limits).u, 10.0);
        assert_eq!(u.threshold("EY0C", Unit::Um, &limits).u, DEFAULT_UM);
        assert_eq!(u.threshold("EA0B", Unit::Urad, &limits).u, DEFAULT_URAD);
    }

    #[test]
    fn useful_u_takes_two_positive_numbers() {
        assert_eq!(
            Usefulness::parse("2, 10"),
            Ok(Usefulness {
                um: 2.0,
                urad: 10.0
            })
        );
        for bad in ["2", "2,0", "x,1", "1,2,3", "-1,2", "inf,2"] {
            assert!(Usefulness::parse(bad).is_err(), "{bad}");
        }
    }
}
