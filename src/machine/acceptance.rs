//! Acceptance limits per error symbol, as a machine file's optional
//! `limits:` section (or a limits file of the same shape) writes them: a
//! bound `b` (within -b .. +b) or an interval `[lower, upper]`, in um for
//! positions and urad for orientations. The decision whether a machine
//! conforms to them is [`crate::conformance`]'s; they live here because
//! the machine file holds them.

use std::fmt;

use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

/// The acceptance interval of one symbol, in the symbol's unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limit {
    /// Lowest acceptable value.
    pub lower: f64,
    /// Highest acceptable value.
    pub upper: f64,
}

impl Limit {
    /// `-bound .. +bound`.
    pub fn symmetric(bound: f64) -> Limit {
        Limit {
            lower: -bound,
            upper: bound,
        }
    }

    /// The limit a value moving in direction `sign` (+1 up, -1 down) meets.
    pub fn toward(&self, sign: f64) -> f64 {
        if sign >= 0.0 { self.upper } else { self.lower }
    }
}

impl fmt::Display for Limit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.lower == -self.upper {
            write!(f, "±{}", self.upper)
        } else {
            write!(f, "{} .. {}", self.lower, self.upper)
        }
    }
}

#[derive(Serialize, Deserialize)]
#[serde(untagged)]
enum LimitRepr {
    Symmetric(f64),
    Interval([f64; 2]),
}

impl Serialize for Limit {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if self.lower == -self.upper {
            LimitRepr::Symmetric(self.upper)
        } else {
            LimitRepr::Interval([self.lower, self.upper])
        }
        .serialize(s)
    }
}

impl<'de> Deserialize<'de> for Limit {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let expected =
            "expected a bound > 0 (within -bound .. +bound) or [lower, upper] with lower < upper";
        match LimitRepr::deserialize(d).map_err(|_| D::Error::custom(expected))? {
            LimitRepr::Symmetric(b) if b.is_finite() && b > 0.0 => Ok(Limit::symmetric(b)),
            LimitRepr::Interval([lo, hi]) if lo.is_finite() && hi.is_finite() && lo < hi => {
                Ok(Limit {
                    lower: lo,
                    upper: hi,
                })
            }
            _ => Err(D::Error::custom(expected)),
        }
    }
}

/// Acceptance limits by symbol name, in the order written.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct AcceptanceLimits(pub IndexMap<String, Limit>);

impl AcceptanceLimits {
    /// Whether no symbol has a limit.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The limit of `symbol`, if it has one.
    pub fn get(&self, symbol: &str) -> Option<Limit> {
        self.0.get(symbol).copied()
    }
}
