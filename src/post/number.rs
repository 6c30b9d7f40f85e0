//! Number formats of NC words. FANUC needs a decimal point on every length,
//! angle and feed (`X1` may mean 0.001 mm), HEIDENHAIN writes every
//! coordinate signed, and all of them must never print `-0`.

use serde::{Deserialize, Serialize};

/// When a decimal point is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PointRule {
    /// Always, also for whole numbers (`X10.`): FANUC's safe form.
    Always,
    /// Only when there is a fractional part (`X10`, `X10.5`).
    Auto,
    /// Never (integers such as spindle speeds): the value is rounded.
    Never,
}

/// How one kind of number is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NumberFormat {
    /// Digits after the decimal point (before trimming).
    pub decimals: usize,
    /// Drop trailing zeros of the fraction.
    #[serde(default)]
    pub trim: bool,
    /// When to write the decimal point.
    pub point: PointRule,
    /// Write `+` before positive numbers and zero.
    #[serde(default)]
    pub plus: bool,
}

impl NumberFormat {
    /// Formats `v`. Negative zero and values that round to zero print
    /// without a sign (or with `+`).
    pub fn format(&self, v: f64) -> String {
        let decimals = if self.point == PointRule::Never {
            0
        } else {
            self.decimals
        };
        let mut s = format!("{:.*}", decimals, v.abs());
        let negative = v < 0.0 && s.bytes().any(|b| (b'1'..=b'9').contains(&b));
        if decimals > 0 && self.trim {
            let t = s.trim_end_matches('0');
            s = t.to_string();
        }
        if s.ends_with('.') {
            if self.point != PointRule::Always {
                s.pop();
            }
        } else if !s.contains('.') && self.point == PointRule::Always {
            s.push('.');
        }
        if negative {
            format!("-{s}")
        } else if self.plus {
            format!("+{s}")
        } else {
            s
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fanuc_lengths_always_have_a_point() {
        let f = NumberFormat {
            decimals: 3,
            trim: true,
            point: PointRule::Always,
            plus: false,
        };
        assert_eq!(f.format(10.0), "10.");
        assert_eq!(f.format(-0.5), "-0.5");
        assert_eq!(f.format(-0.0), "0.");
        assert_eq!(f.format(-0.0004), "0.");
        assert_eq!(f.format(1.23456), "1.235");
        assert_eq!(f.format(900.0), "900.");
    }

    #[test]
    fn heidenhain_coordinates_are_signed() {
        let f = NumberFormat {
            decimals: 3,
            trim: false,
            point: PointRule::Auto,
            plus: true,
        };
        assert_eq!(f.format(10.0), "+10.000");
        assert_eq!(f.format(-0.0), "+0.000");
        assert_eq!(f.format(-2.5), "-2.500");
        let feed = NumberFormat {
            decimals: 0,
            trim: true,
            point: PointRule::Auto,
            plus: false,
        };
        assert_eq!(feed.format(900.4), "900");
        let rpm = NumberFormat {
            decimals: 3,
            trim: true,
            point: PointRule::Never,
            plus: false,
        };
        assert_eq!(rpm.format(3978.9), "3979");
    }
}
