//! Acceptance limits per error symbol and the decision whether a machine
//! conforms to them, taking the measurement uncertainty into account as
//! ISO 14253-1 asks: conformance is proven only when the value lies inside
//! the limits shrunk by the expanded uncertainty U = 2u (k = 2), and
//! non-conformance only when it lies outside the limits widened by U; in
//! between, the measurement cannot decide.
//!
//! Limits come from a machine file's optional `limits:` section or from a
//! limits file of the same shape:
//!
//! ```yaml
//! machine: bc-trunnion   # optional: results of another machine are refused
//! limits:                # um for positions, urad for orientations
//!   EX0B: 10             # within -10 .. +10
//!   EA0B: [-20, 35]      # within -20 .. +35
//! ```
//!
//! Only location symbols take limits. A symbol the test did not identify,
//! or a value without its uncertainty, cannot be decided.

use std::fmt;
use std::path::Path;

use serde::{Deserialize, Serialize};

pub use crate::machine::acceptance::{AcceptanceLimits, Limit};

use crate::errorfile::ErrorFile;
use crate::kinematics::symbols::SymbolTable;
use crate::machine::Machine;
use crate::source::SourceError;

/// Coverage factor of the expanded uncertainty the decision uses.
pub(crate) const COVERAGE: f64 = 2.0;

impl AcceptanceLimits {
    /// Checks every name against the machine's location symbols; `path`
    /// and `src` (the file the limits were read from) locate the error.
    pub(crate) fn check_symbols(
        &self,
        symbols: &SymbolTable,
        path: &Path,
        src: &str,
    ) -> Result<(), SourceError> {
        for name in self.0.keys() {
            if symbols.location.iter().all(|s| &s.name != name) {
                return Err(SourceError::at_key(
                    path,
                    src,
                    &["limits", name],
                    format!(
                        "`{name}` takes no limit: expected a location symbol of this machine ({})",
                        symbols.location_names()
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// Where a set of limits came from, for messages.
#[derive(Clone, Debug, PartialEq)]
pub struct LimitsSource {
    /// The limits.
    pub limits: AcceptanceLimits,
    /// The machine they are for, when the file says.
    pub machine: Option<String>,
    /// The file, as named.
    pub path: std::path::PathBuf,
    /// Its text (to locate errors).
    pub src: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LimitsFile {
    #[serde(default)]
    machine: Option<String>,
    limits: AcceptanceLimits,
}

impl LimitsSource {
    /// Reads a limits file, or the `limits:` section of a machine file (a
    /// file with a `chain:` key is read as a machine file and validated as
    /// one).
    pub fn read(path: &Path) -> Result<LimitsSource, SourceError> {
        let src = crate::input::read_text(path, "limits file", crate::limits::MAX_YAML_BYTES)?;
        let value: serde_yaml::Value =
            serde_yaml::from_str(&src).map_err(|e| SourceError::from_yaml(path, &e))?;
        if value.get("chain").is_some() {
            let m = Machine::from_yaml(path, &src).map_err(|e| match e {
                crate::machine::MachineError::Invalid(s) => s,
                other => SourceError::new(path, 0, 0, other.to_string()),
            })?;
            return Ok(LimitsSource::of_machine(&m, path));
        }
        let f: LimitsFile =
            serde_yaml::from_str(&src).map_err(|e| SourceError::from_yaml(path, &e))?;
        Ok(LimitsSource {
            limits: f.limits,
            machine: f.machine,
            path: path.to_path_buf(),
            src,
        })
    }

    /// The limits of a machine file read from `path`.
    pub(crate) fn of_machine(m: &Machine, path: &Path) -> LimitsSource {
        LimitsSource {
            limits: m.limits.clone(),
            machine: Some(m.name.clone()),
            path: path.to_path_buf(),
            src: m.source.clone(),
        }
    }

    /// Checks that the limits fit the machine (`machine` name, location
    /// symbols of `symbols`).
    pub fn check(&self, machine: &str, symbols: &SymbolTable) -> Result<(), SourceError> {
        if let Some(m) = &self.machine
            && m != machine
        {
            return Err(SourceError::at_key(
                &self.path,
                &self.src,
                &["machine"],
                format!("the limits are for machine `{m}`, the result is for `{machine}`"),
            ));
        }
        self.limits.check_symbols(symbols, &self.path, &self.src)
    }

    /// Checks that the limits fit a result: its machine, and every limited
    /// name among the location symbols the result lists (as a value or as
    /// not identifiable, which together are all of the machine's).
    pub fn check_result(&self, result: &ErrorFile) -> Result<(), SourceError> {
        if let Some(m) = &self.machine
            && *m != result.machine
        {
            return Err(SourceError::at_key(
                &self.path,
                &self.src,
                &["machine"],
                format!(
                    "the limits are for machine `{m}`, the result is for `{}`",
                    result.machine
                ),
            ));
        }
        let known: Vec<&str> = result
            .location_errors
            .keys()
            .map(String::as_str)
            .chain(result.not_identifiable.iter().map(|n| n.symbol.as_str()))
            .collect();
        for name in self.limits.0.keys() {
            if !known.contains(&name.as_str()) {
                return Err(SourceError::at_key(
                    &self.path,
                    &self.src,
                    &["limits", name],
                    format!(
                        "`{name}` takes no limit: expected a location symbol of machine `{}` ({})",
                        result.machine,
                        known.join(", ")
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// The outcome of the decision rule.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Decision {
    /// Inside the limits by at least U: conformance proven.
    Pass,
    /// Outside the limits by more than U: non-conformance proven.
    Fail,
    /// Within U of a limit, or no value or no uncertainty to decide with.
    CannotDecide,
}

impl fmt::Display for Decision {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Decision::Pass => "PASS",
            Decision::Fail => "FAIL",
            Decision::CannotDecide => "cannot decide",
        })
    }
}

/// ISO 14253-1 with expanded uncertainty `expanded` (U, same unit as the
/// value): PASS inside `[lower + U, upper - U]` (edges included), FAIL
/// beyond `[lower - U, upper + U]` (edges excluded), else cannot decide.
/// When U is half the interval or more, PASS is impossible.
pub fn decide(value: f64, expanded: f64, limit: Limit) -> Decision {
    if !(value.is_finite() && expanded.is_finite() && expanded >= 0.0) {
        return Decision::CannotDecide;
    }
    if value < limit.lower - expanded || value > limit.upper + expanded {
        Decision::Fail
    } else if value >= limit.lower + expanded && value <= limit.upper - expanded {
        Decision::Pass
    } else {
        Decision::CannotDecide
    }
}

/// The decision for one symbol.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SymbolDecision {
    /// The symbol.
    pub symbol: String,
    /// Its limit.
    pub limit: Limit,
    /// The value, when the result has one.
    pub value: Option<f64>,
    /// Expanded uncertainty U = 2u, when the result gives u.
    pub expanded: Option<f64>,
    /// The decision.
    pub decision: Decision,
    /// Why it could not be decided, when it could not.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
}

/// The decisions for every limited symbol and for the machine.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ConformanceVerdict {
    /// One per limited symbol, in the limits' order.
    pub symbols: Vec<SymbolDecision>,
    /// FAIL if any symbol fails, PASS if every one passes, else cannot
    /// decide.
    pub machine: Decision,
}

impl ConformanceVerdict {
    /// Decides every limited symbol of `result`.
    pub fn of(result: &ErrorFile, limits: &AcceptanceLimits) -> ConformanceVerdict {
        let symbols: Vec<SymbolDecision> = limits
            .0
            .iter()
            .map(|(name, &limit)| {
                let q = result.location_errors.get(name);
                let unseen = result
                    .not_identifiable
                    .iter()
                    .find(|n| n.symbol == *name)
                    .map(|n| n.reason.clone());
                let (decision, reason) = match (q, unseen) {
                    (_, Some(why)) => (
                        Decision::CannotDecide,
                        Some(format!("not identifiable: {why}")),
                    ),
                    (None, None) => (
                        Decision::CannotDecide,
                        Some("the result has no value for it".to_string()),
                    ),
                    (Some(q), None) => match q.u {
                        None => (
                            Decision::CannotDecide,
                            Some("the result gives no uncertainty".to_string()),
                        ),
                        Some(u) => (decide(q.value, COVERAGE * u, limit), None),
                    },
                };
                SymbolDecision {
                    symbol: name.clone(),
                    limit,
                    value: q.map(|q| q.value),
                    expanded: q.and_then(|q| q.u).map(|u| COVERAGE * u),
                    decision,
                    reason,
                }
            })
            .collect();
        let machine = combine(symbols.iter().map(|s| s.decision));
        ConformanceVerdict { symbols, machine }
    }

    /// The verdict as printed: one line per symbol, then the machine's.
    pub fn render(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "acceptance (ISO 14253-1: PASS inside the limit by U = 2u, FAIL beyond it by U):"
        );
        let _ = writeln!(
            s,
            "  {:<10} {:>10} {:>8} {:>16}  {:<5} decision",
            "symbol", "value", "U", "limit", "unit"
        );
        for d in &self.symbols {
            let num = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3}"));
            let _ = write!(
                s,
                "  {:<10} {:>10} {:>8} {:>16}  {:<5} {}",
                d.symbol,
                num(d.value),
                num(d.expanded),
                d.limit.to_string(),
                unit_of(&d.symbol),
                d.decision
            );
            if let Some(r) = &d.reason {
                let _ = write!(s, " ({r})");
            }
            s.push('\n');
        }
        let _ = writeln!(s, "machine: {}", self.machine);
        s
    }
}

/// The unit of a location symbol, from its ISO 230-1 name: `EX..`, `EY..`,
/// `EZ..` are positions (um), `EA..`, `EB..`, `EC..` orientations (urad).
pub(crate) fn unit_of(symbol: &str) -> &'static str {
    match symbol.as_bytes().get(1) {
        Some(b'X' | b'Y' | b'Z') => "um",
        Some(b'A' | b'B' | b'C') => "urad",
        _ => "",
    }
}

/// FAIL if any fails, PASS if all pass (and there is at least one), else
/// cannot decide.
pub(crate) fn combine(decisions: impl Iterator<Item = Decision>) -> Decision {
    let mut any = false;
    let mut all_pass = true;
    for d in decisions {
        any = true;
        match d {
            Decision::Fail => return Decision::Fail,
            Decision::Pass => {}
            Decision::CannotDecide => all_pass = false,
        }
    }
    if any && all_pass {
        Decision::Pass
    } else {
        Decision::CannotDecide
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEN: Limit = Limit {
        lower: -10.0,
        upper: 10.0,
    };

    /// A limit of ±10 um, u = 0.5 um (U = 1): PASS up to 9 inclusive, FAIL
    /// from just above 11, cannot decide from just above 9 to 11; the same
    /// mirrored at the lower limit.
    #[test]
    fn decision_at_the_edges_of_a_symmetric_limit() {
        let u = 1.0;
        for (v, want) in [
            (0.0, Decision::Pass),
            (9.0, Decision::Pass),
            (9.0 + 1e-9, Decision::CannotDecide),
            (10.0, Decision::CannotDecide),
            (11.0, Decision::CannotDecide),
            (11.0 + 1e-9, Decision::Fail),
            (-9.0, Decision::Pass),
            (-9.0 - 1e-9, Decision::CannotDecide),
            (-11.0, Decision::CannotDecide),
            (-11.0 - 1e-9, Decision::Fail),
            (1e6, Decision::Fail),
        ] {
            assert_eq!(decide(v, u, TEN), want, "value {v}");
        }
    }

    /// With U of half the interval or more nothing can pass: at U = 10 on
    /// ±10, 0 is the only PASS; at U = 12 not even 0.
    #[test]
    fn an_uncertainty_as_wide_as_the_limit_proves_nothing() {
        assert_eq!(decide(0.0, 10.0, TEN), Decision::Pass);
        assert_eq!(decide(0.1, 10.0, TEN), Decision::CannotDecide);
        assert_eq!(decide(0.0, 12.0, TEN), Decision::CannotDecide);
        assert_eq!(decide(22.0, 12.0, TEN), Decision::CannotDecide);
        assert_eq!(decide(22.5, 12.0, TEN), Decision::Fail);
    }

    /// An asymmetric limit, and U = 0 (a perfect measurement) reducing the
    /// rule to the plain limit.
    #[test]
    fn asymmetric_limits_and_zero_uncertainty() {
        let l = Limit {
            lower: -20.0,
            upper: 35.0,
        };
        assert_eq!(decide(33.0, 2.0, l), Decision::Pass);
        assert_eq!(decide(33.5, 2.0, l), Decision::CannotDecide);
        assert_eq!(decide(-18.0, 2.0, l), Decision::Pass);
        assert_eq!(decide(-22.5, 2.0, l), Decision::Fail);
        assert_eq!(decide(35.0, 0.0, l), Decision::Pass);
        assert_eq!(decide(35.0 + 1e-9, 0.0, l), Decision::Fail);
        assert_eq!(decide(f64::NAN, 1.0, l), Decision::CannotDecide);
    }

    #[test]
    fn units_follow_the_symbol_names() {
        for (s, u) in [
            ("EX0B", "um"),
            ("EY0C", "um"),
            ("EX(0B)C", "um"),
            ("EA(0B)C", "urad"),
            ("EB0B", "urad"),
            ("EC0A", "urad"),
        ] {
            assert_eq!(unit_of(s), u, "{s}");
        }
    }

    #[test]
    fn the_machine_fails_on_one_failure_and_passes_only_when_all_pass() {
        use Decision::*;
        assert_eq!(combine([Pass, Pass].into_iter()), Pass);
        assert_eq!(combine([Pass, CannotDecide].into_iter()), CannotDecide);
        assert_eq!(combine([CannotDecide, Fail, Pass].into_iter()), Fail);
        assert_eq!(combine(std::iter::empty()), CannotDecide);
    }

    #[test]
    fn limits_read_as_a_bound_or_an_interval_and_refuse_the_rest() {
        let l: AcceptanceLimits = serde_yaml::from_str("EX0B: 10\nEA0B: [-20, 35]\n").unwrap();
        assert_eq!(l.get("EX0B"), Some(Limit::symmetric(10.0)));
        assert_eq!(
            l.get("EA0B"),
            Some(Limit {
                lower: -20.0,
                upper: 35.0
            })
        );
        for bad in ["EX0B: -1", "EX0B: [5, 1]", "EX0B: .nan", "EX0B: abc"] {
            let e = serde_yaml::from_str::<AcceptanceLimits>(bad)
                .unwrap_err()
                .to_string();
            assert!(e.contains("expected a bound > 0"), "{bad}: {e}");
        }
        assert_eq!(
            serde_yaml::to_string(&l).unwrap(),
            "EX0B: 10.0\nEA0B:\n- -20.0\n- 35.0\n"
        );
    }

    /// A result whose EX0B passes, EZ0B fails, EA0B is too close to call,
    /// EC0B has no u and EY0C was not identified.
    #[test]
    fn a_result_is_decided_symbol_by_symbol() {
        let result: ErrorFile = serde_yaml::from_str(
            "machine: bc-trunnion\nlocation_errors:\n  EX0B: {value: 3.0, u: 0.5}\n  EZ0B: {value: -14.0, u: 0.5}\n  EA0B: {value: 19.5, u: 1.0}\n  EC0B: 1.0\nnot_identifiable:\n  - {symbol: EY0C, reason: no pose turns C}\n",
        )
        .unwrap();
        let limits: AcceptanceLimits =
            serde_yaml::from_str("EX0B: 10\nEZ0B: 10\nEA0B: 20\nEC0B: 20\nEY0C: 10\n").unwrap();
        let v = ConformanceVerdict::of(&result, &limits);
        let d: Vec<Decision> = v.symbols.iter().map(|s| s.decision).collect();
        use Decision::*;
        assert_eq!(d, [Pass, Fail, CannotDecide, CannotDecide, CannotDecide]);
        assert_eq!(v.machine, Fail);
        assert!(
            v.symbols[4]
                .reason
                .as_ref()
                .unwrap()
                .contains("no pose turns C")
        );
        assert_eq!(v.symbols[1].expanded, Some(1.0));
        let text = v.render();
        assert!(
            text.contains("EZ0B") && text.contains("FAIL") && text.contains("machine: FAIL"),
            "{text}"
        );
    }
}
