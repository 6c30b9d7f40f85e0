//! Before and after compensation: the change of every location error
//! between two results with its uncertainty, whether the compensated
//! machine's errors are within their uncertainty of zero, and whether it
//! is within its acceptance limits.
//!
//! The two results come from separate measurements (two pieces, two
//! probing runs), so their errors are independent and the change has
//! `u = sqrt(u_before² + u_after²)`. A change or a value counts as real
//! when it exceeds its expanded uncertainty (k = 2), as the decision rule
//! of [`crate::conformance`] does.

use std::fmt::Write as _;

use serde::Serialize;

use crate::analyze::series::{Series, SeriesValue};
use crate::conformance::{AcceptanceLimits, COVERAGE, ConformanceVerdict, unit_of};
use crate::errorfile::ErrorFile;

/// One symbol before and after.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SymbolChange {
    /// The symbol.
    pub symbol: String,
    /// um or urad.
    pub unit: &'static str,
    /// Value and u before (`None`: not in that result).
    pub before: Option<(f64, Option<f64>)>,
    /// After.
    pub after: Option<(f64, Option<f64>)>,
    /// after - before, with its standard uncertainty when both give u.
    pub change: Option<(f64, Option<f64>)>,
}

impl SymbolChange {
    /// Whether the change exceeds its expanded uncertainty.
    pub fn significant(&self) -> Option<bool> {
        let (d, u) = self.change?;
        Some(d.abs() > COVERAGE * u?)
    }

    /// Whether the value after is within its expanded uncertainty of zero.
    pub(crate) fn zero_after(&self) -> Option<bool> {
        let (v, u) = self.after?;
        Some(v.abs() <= COVERAGE * u?)
    }
}

/// Two results of one machine compared.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Comparison {
    /// The machine.
    pub machine: String,
    /// What the first result is (a file or a record).
    pub before: String,
    /// What the second is.
    pub after: String,
    /// Every location symbol of either, in the first result's order.
    pub changes: Vec<SymbolChange>,
    /// The compensated machine against its limits, when limits are given.
    pub verdict_after: Option<ConformanceVerdict>,
    /// The machine before, against the same limits.
    pub verdict_before: Option<ConformanceVerdict>,
}

/// Two results that cannot be compared.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum NotComparable {
    /// They are of different machines.
    #[error(
        "{before} is a result of machine `{before_machine}`, {after} of `{after_machine}`: compare results of one machine"
    )]
    DifferentMachines {
        /// The first result's name.
        before: String,
        /// Its machine.
        before_machine: String,
        /// The second result's name.
        after: String,
        /// Its machine.
        after_machine: String,
    },
    /// They are of different tests, which see the errors through different
    /// designs (what one cannot identify the other may, each with its own
    /// biases): their difference is no change of the machine.
    #[error(
        "{before} is a result of the {before_test} test, {after} of the {after_test} test: compare results of one test (measure the compensated machine with the test of the result before)"
    )]
    DifferentTests {
        /// The first result's name.
        before: String,
        /// Its test.
        before_test: String,
        /// The second result's name.
        after: String,
        /// Its test.
        after_test: String,
    },
    /// One of them is no fit: its values are biased by more than their u
    /// (a misfit) or no estimate at all (not converged).
    #[error(
        "{name}: its verdict is {verdict}: its values are not right within their u, so no change can be told from them. Compare results whose verdict is fits"
    )]
    NotAFit {
        /// The result's name.
        name: String,
        /// Its verdict.
        verdict: crate::errorfile::FitVerdict,
    },
}

impl Comparison {
    /// Compares `before` and `after` (named for the printout); with
    /// `limits`, decides both. Refuses results of different machines.
    pub fn new(
        before: (&str, &ErrorFile),
        after: (&str, &ErrorFile),
        limits: Option<&AcceptanceLimits>,
    ) -> Result<Comparison, NotComparable> {
        for (name, f) in [before, after] {
            if let Some(fit) = &f.fit
                && !fit.verdict.is_fit()
            {
                return Err(NotComparable::NotAFit {
                    name: name.to_string(),
                    verdict: fit.verdict,
                });
            }
        }
        Comparison::unjudged(before, after, limits)
    }

    /// [`Comparison::new`] without refusing results that do not fit: for a
    /// caller that states each result's verdict beside the comparison (the
    /// demo). Still refuses results of different machines or tests.
    pub fn unjudged(
        before: (&str, &ErrorFile),
        after: (&str, &ErrorFile),
        limits: Option<&AcceptanceLimits>,
    ) -> Result<Comparison, NotComparable> {
        let (bn, b) = before;
        let (an, a) = after;
        if b.machine != a.machine {
            return Err(NotComparable::DifferentMachines {
                before: bn.to_string(),
                before_machine: b.machine.clone(),
                after: an.to_string(),
                after_machine: a.machine.clone(),
            });
        }
        if let (Some(bt), Some(at)) = (&b.test, &a.test)
            && bt != at
        {
            return Err(NotComparable::DifferentTests {
                before: bn.to_string(),
                before_test: bt.clone(),
                after: an.to_string(),
                after_test: at.clone(),
            });
        }
        // The values side by side and the change with its combined u, as
        // `analyze --compare` tabulates them.
        let table = Series::new(&[(bn.to_string(), b.clone()), (an.to_string(), a.clone())]);
        let pair = |v: &Option<SeriesValue>| v.map(|v| (v.value, v.u));
        let changes = table
            .location_errors
            .iter()
            .map(|(s, row)| SymbolChange {
                symbol: s.clone(),
                unit: unit_of(s),
                before: pair(&row.values[0]),
                after: pair(&row.values[1]),
                change: pair(&row.change[1]),
            })
            .collect();
        Ok(Comparison {
            machine: a.machine.clone(),
            before: bn.to_string(),
            after: an.to_string(),
            changes,
            verdict_after: limits.map(|l| ConformanceVerdict::of(a, l)),
            verdict_before: limits.map(|l| ConformanceVerdict::of(b, l)),
        })
    }

    /// The comparison as printed.
    pub fn render(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "machine {}: before {}, after {}",
            self.machine, self.before, self.after
        );
        let _ = writeln!(
            s,
            "  {:<10} {:<5} {:>19} {:>19} {:>19}  change > 2u, after within 2u of 0",
            "symbol", "unit", "before (u)", "after (u)", "change (u)"
        );
        let q = |v: Option<(f64, Option<f64>)>| match v {
            Some((x, Some(u))) => format!("{x:>9.3} ({u:>6.3})"),
            Some((x, None)) => format!("{x:>9.3} (     -)"),
            None => format!("{:>19}", "-"),
        };
        let yes = |b: Option<bool>, t: &str, f: &str| match b {
            Some(true) => t.to_string(),
            Some(false) => f.to_string(),
            None => "?".to_string(),
        };
        for c in &self.changes {
            let _ = writeln!(
                s,
                "  {:<10} {:<5} {} {} {}  {}, {}",
                c.symbol,
                c.unit,
                q(c.before),
                q(c.after),
                q(c.change),
                yes(c.significant(), "changed", "no change"),
                yes(c.zero_after(), "zero", "not zero")
            );
        }
        let zero = self
            .changes
            .iter()
            .filter(|c| c.zero_after() == Some(true))
            .count();
        let _ = writeln!(
            s,
            "after: {zero} of {} errors within their expanded uncertainty (k = 2) of zero",
            self.changes.len()
        );
        match (&self.verdict_before, &self.verdict_after) {
            (Some(b), Some(a)) => {
                s.push_str(&a.render());
                let _ = writeln!(s, "(before: {})", b.machine);
            }
            _ => {
                let _ = writeln!(
                    s,
                    "no acceptance limits: give --limits FILE (a limits file or a machine file with a limits: section)"
                );
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(yaml: &str) -> ErrorFile {
        serde_yaml::from_str(yaml).unwrap()
    }

    /// EX0B from 12.0 (u 0.3) to 0.2 (u 0.4): a change of -11.8 with u 0.5,
    /// now within 2u of zero; EZ0B unchanged within u; EA0B only after.
    #[test]
    fn changes_carry_the_combined_uncertainty() {
        let b = file(
            "machine: m\nlocation_errors:\n  EX0B: {value: 12.0, u: 0.3}\n  EZ0B: {value: -1.0, u: 0.3}\n",
        );
        let a = file(
            "machine: m\nlocation_errors:\n  EX0B: {value: 0.2, u: 0.4}\n  EZ0B: {value: -1.5, u: 0.4}\n  EA0B: {value: 3.0, u: 1.0}\n",
        );
        let c = Comparison::new(("r1", &b), ("r2", &a), None).unwrap();
        let ex = &c.changes[0];
        let (d, u) = ex.change.unwrap();
        assert!((d + 11.8).abs() < 1e-12 && (u.unwrap() - 0.5).abs() < 1e-12);
        assert_eq!(
            (ex.significant(), ex.zero_after()),
            (Some(true), Some(true))
        );
        assert_eq!(c.changes[1].significant(), Some(false));
        assert_eq!(c.changes[2].symbol, "EA0B");
        assert_eq!(c.changes[2].change, None);
        assert_eq!(c.changes[2].zero_after(), Some(false));
        let text = c.render();
        assert!(text.contains("1 of 3 errors within"), "{text}");
        let other = file("machine: n\n");
        assert!(Comparison::new(("r1", &b), ("r3", &other), None).is_err());
    }

    /// A stepped-square result against a probe-sphere one, or a misfit
    /// against anything: refused, naming both tests or the result.
    #[test]
    fn other_tests_and_results_that_do_not_fit_are_refused() {
        let ss = file(
            "machine: m\ntest: stepped-square\nlocation_errors: {EX0B: {value: 12.0, u: 0.3}}\n",
        );
        let ps =
            file("machine: m\ntest: probe-sphere\nlocation_errors: {EX0B: {value: 0.2, u: 0.4}}\n");
        let e = Comparison::new(("ss.yaml", &ss), ("ps.yaml", &ps), None).unwrap_err();
        assert!(matches!(e, NotComparable::DifferentTests { .. }));
        assert!(
            e.to_string().starts_with(
                "ss.yaml is a result of the stepped-square test, ps.yaml of the probe-sphere test"
            ),
            "{e}"
        );
        let fit = |verdict: &str| {
            format!(
                "fit: {{sigma_um: 2.5, expected_um: 0.35, expected_from: x, ratio: 7.1, dof: 100, p_value: 0.0, verdict: {verdict}}}\n"
            )
        };
        let misfit = file(&format!(
            "machine: m\ntest: stepped-square\nlocation_errors: {{EX0B: {{value: 0.2, u: 0.4}}}}\n{}",
            fit("misfit")
        ));
        let e = Comparison::new(("ss.yaml", &ss), ("after.yaml", &misfit), None).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("after.yaml: its verdict is misfit"),
            "{e}"
        );
        let stopped = file(&format!("machine: m\n{}", fit("not-converged")));
        let e = Comparison::new(("stopped.yaml", &stopped), ("ss.yaml", &ss), None).unwrap_err();
        assert!(e.to_string().contains("not-converged"), "{e}");
        let fits = file(&format!(
            "machine: m\ntest: stepped-square\nlocation_errors: {{EX0B: {{value: 0.2, u: 0.4}}}}\n{}",
            fit("fits")
        ));
        assert!(Comparison::new(("ss.yaml", &ss), ("after.yaml", &fits), None).is_ok());
    }
}
