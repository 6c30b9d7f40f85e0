//! What a discovery found, step by step: the story printed for the user and,
//! with `--json`, written as JSON (the same fields).

use std::fmt::Write as _;

use serde::Serialize;

use crate::identify::identifiability::Combination;

use super::gap::{Gap, GapSize};
use super::stats::NestedTest;

/// A fitted value.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FittedValue {
    /// Parameter name (`EX0B`, `drift.EZ0B/seq`, `map.EBB(B)@B=90`, `scale.EXX`).
    pub name: String,
    /// Value, in `unit`.
    pub value: f64,
    /// Standard uncertainty (k = 1), `None` where the test does not see it.
    pub u: Option<f64>,
    /// Unit (um, urad, um/m, um/seq, ...).
    pub unit: String,
    /// Why there is no `u`, where the test does not see the value.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// A correlation with a named parameter.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Correlation {
    /// The candidate's parameter.
    pub parameter: String,
    /// The model's (or nuisance) parameter.
    pub with: String,
    /// The correlation coefficient.
    pub value: f64,
}

/// How a candidate stands alongside the model so far.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Alongside {
    /// The candidate's parameters.
    pub parameters: usize,
    /// The directions it adds to what the model sees (rank increase).
    pub rank_increase: usize,
    /// Largest canonical correlation between what the candidate does to the
    /// measurements and what the model already does (1: aliased).
    pub canonical_correlation: f64,
    /// Largest correlation of one of its parameters with one of the
    /// model's (nuisance included), at the nominal machine.
    pub largest_correlation: Option<Correlation>,
    /// Combinations of its parameters the test does not see, fixed at zero
    /// (each named).
    pub unseen: Vec<Combination>,
    /// Condition number of the column-scaled design with it.
    pub condition: f64,
}

/// The verdict on one candidate in one round.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CandidateVerdict {
    /// Significant (F-test after the multiple-comparison adjustment, and
    /// the BIC falls).
    Significant,
    /// Tested, not significant.
    NotSignificant,
    /// Not tried: not identifiable alongside the model, nearly aliased, or
    /// beyond the forward model.
    Refused,
}

/// One candidate tried in one round.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Trial {
    /// Candidate name.
    pub name: String,
    /// Significant, not significant or refused.
    pub verdict: CandidateVerdict,
    /// Why it was refused.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// The gap with it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gap_after: Option<GapSize>,
    /// The comparison with the model so far.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub test: Option<NestedTest>,
    /// The p-value after the multiple-comparison adjustment.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub p_adjusted: Option<f64>,
    /// Identifiability alongside the model.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub alongside: Option<Alongside>,
}

/// A significant rival of a step's effect, and why the step's effect was
/// preferred (the encompassing test: fitted together, which adds to the
/// other).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Rival {
    /// Candidate name.
    pub name: String,
    /// The gap with it instead, um.
    pub gap_after: GapSize,
    /// p-value of the step's effect added to the rival.
    pub p_effect_over_rival: f64,
    /// p-value of the rival added to the step's effect.
    pub p_rival_over_effect: f64,
    /// Neither adds a direction the other does not already give: no
    /// measurement of this test can tell them apart, whatever its noise
    /// (their residuals differ at rounding level).
    pub exactly_indistinguishable: bool,
    /// RMS of the difference between the residuals with the step's effect
    /// and with the rival instead, um.
    pub residual_difference_um: f64,
    /// The later step that added the rival, if one did.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub added_at: Option<usize>,
    /// In words.
    pub verdict: String,
}

impl Rival {
    /// Whether the story shows the rival by name: it came next, or the
    /// data cannot tell it from the step's effect (exactly, or within the
    /// noise, or as the same effect on another clock). The others are
    /// significant candidates the step's effect, or a later one, explains
    /// away; they are counted.
    pub fn matters(&self) -> bool {
        self.added_at.is_some()
            || self.exactly_indistinguishable
            || self.verdict.contains("indistinguishable")
    }
}

/// One step of the discovery: an effect added.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Step {
    /// 1, 2, ...
    pub step: usize,
    /// The candidate's name (`drift.EZ0B/seq`).
    pub name: String,
    /// The effect's identifier in the model's catalogue (`drift.EZ0B`),
    /// for grouping; the story names the effect by `name` only (one name
    /// per effect in the text and the JSON).
    #[serde(skip)]
    pub effect: String,
    /// What it is.
    pub description: String,
    /// Its values as fitted at this step, with their uncertainty:
    /// provisional, since later steps refit them (the final model,
    /// [`Story::end`], is the one to quote).
    pub provisional_values: Vec<FittedValue>,
    /// The gap before the step.
    pub gap_before: GapSize,
    /// The gap after the step.
    pub gap_after: GapSize,
    /// Where the gap was concentrated before the step.
    pub concentrated: String,
    /// The significance test.
    pub test: NestedTest,
    /// Its p-value after the multiple-comparison adjustment.
    pub p_adjusted: f64,
    /// Number of candidates tested in this round.
    pub tested: usize,
    /// Identifiability alongside the model so far.
    pub alongside: Alongside,
    /// The other significant candidates, and why this one was preferred.
    pub rivals: Vec<Rival>,
    /// Every candidate of the round.
    pub trials: Vec<Trial>,
}

/// Candidates the data cannot tell apart: the discovery stops rather than
/// pick one.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Ambiguity {
    /// The candidates, each with its values and the gap it leaves.
    pub candidates: Vec<AmbiguousCandidate>,
    /// In words.
    pub reason: String,
    /// The supplementary test that separates them, when one was found.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub supplement: Option<crate::errorfile::Supplement>,
    /// Why none is proposed, when none is.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub no_supplement: Option<String>,
}

/// One of an ambiguous set.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AmbiguousCandidate {
    /// Candidate name.
    pub name: String,
    /// No measurement of this test can tell it from the first of the set
    /// (the best by the BIC), whatever its noise (the first has it too).
    pub exactly_indistinguishable: bool,
    /// Its fitted values.
    pub values: Vec<FittedValue>,
    /// The gap it leaves.
    pub gap_after: GapSize,
}

/// The model at the start or at the end.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct State {
    /// The effects, by name.
    pub model: Vec<String>,
    /// Every value with its uncertainty.
    pub values: Vec<FittedValue>,
    /// The gap, with its breakdowns.
    pub gap: Gap,
    /// Residual standard deviation, um.
    pub sigma_um: f64,
    /// Its degrees of freedom.
    pub dof: usize,
}

/// The whole story.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Story {
    /// Test name (from the plan).
    pub test: String,
    /// Machine name.
    pub machine: String,
    /// Number of measured points.
    pub points: usize,
    /// Number of poses.
    pub poses: usize,
    /// Significance level.
    pub alpha: f64,
    /// The starting model.
    pub start: State,
    /// The steps, in order.
    pub steps: Vec<Step>,
    /// The final model.
    pub end: State,
    /// Why the discovery stopped.
    pub stop: String,
    /// Candidates the data cannot tell apart, when that stopped it.
    pub ambiguity: Option<Ambiguity>,
    /// The last round, in which nothing was added.
    pub last_round: Vec<Trial>,
    /// Things the user should know.
    pub notes: Vec<String>,
}

fn fmt_p(p: f64) -> String {
    if p < 1e-300 {
        "< 1e-300".into()
    } else if p < 1e-3 {
        format!("{p:.1e}")
    } else {
        format!("{p:.3}")
    }
}

fn list(v: &[f64]) -> String {
    v.iter()
        .map(|a| crate::procedure::short(*a))
        .collect::<Vec<_>>()
        .join(", ")
}

fn values(s: &mut String, v: &[FittedValue], indent: &str) {
    for x in v {
        let _ = writeln!(s, "{indent}{}", value_line(x));
    }
}

fn value_line(x: &FittedValue) -> String {
    match x.u {
        Some(u) => format!(
            "{:<24} {:>10.3} {:<9} u = {:.3}",
            x.name, x.value, x.unit, u
        ),
        None => format!(
            "{:<24} {:>10.3} {:<9} ({})",
            x.name,
            x.value,
            x.unit,
            x.note.as_deref().unwrap_or("not identifiable")
        ),
    }
}

/// A step's values, provisional, each beside its value in the final
/// model (the one to quote).
fn provisional(s: &mut String, v: &[FittedValue], end: &[FittedValue]) {
    let _ = writeln!(
        s,
        "  provisional values (this step's fit; the final model at the end is the one to quote):"
    );
    for x in v {
        let last = end.iter().find(|e| e.name == x.name);
        let same = |a: f64, b: f64| format!("{a:.3}") == format!("{b:.3}");
        let fin = match last {
            Some(e) if same(e.value, x.value) && e.u.zip(x.u).is_none_or(|(a, b)| same(a, b)) => {
                "   (as final)".to_string()
            }
            Some(FittedValue {
                value, u: Some(u), ..
            }) => format!("   final {value:.3}, u = {u:.3}"),
            Some(FittedValue { value, u: None, .. }) => format!("   final {value:.3}"),
            None => String::new(),
        };
        let _ = writeln!(s, "    {}{fin}", value_line(x));
    }
}

impl Story {
    /// The printed story.
    pub fn render(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "discover: {} on {}, {} points in {} poses, alpha = {}",
            self.test, self.machine, self.points, self.poses, self.alpha
        );
        for n in &self.notes {
            let _ = writeln!(s, "note: {n}");
        }
        let _ = writeln!(
            s,
            "\nstart: {}: gap {:.3} um RMS, {:.3} um max",
            self.start.model.join(" + "),
            self.start.gap.rms_um,
            self.start.gap.max_um
        );
        let _ = writeln!(s, "  {}", self.start.gap.summary);
        for st in &self.steps {
            let _ = writeln!(s, "\nstep {}: add {}: {}", st.step, st.name, st.description);
            let _ = writeln!(s, "  before: {}", st.concentrated);
            provisional(&mut s, &st.provisional_values, &self.end.values);
            let _ = writeln!(
                s,
                "  gap {:.3} -> {:.3} um RMS, {:.3} -> {:.3} um max ({:.1} % of the squared gap explained)",
                st.gap_before.rms_um,
                st.gap_after.rms_um,
                st.gap_before.max_um,
                st.gap_after.max_um,
                100.0 * st.test.explained
            );
            let _ = writeln!(
                s,
                "  F = {:.4} ({}, {}), p = {}, {} after {} candidates; BIC {:+.1}, AIC {:+.1}",
                st.test.f,
                st.test.df1,
                st.test.df2,
                fmt_p(st.test.p),
                fmt_p(st.p_adjusted),
                st.tested,
                st.test.delta_bic,
                st.test.delta_aic
            );
            let a = &st.alongside;
            let corr = a
                .largest_correlation
                .as_ref()
                .map(|c| {
                    format!(
                        "; largest correlation {:.3} ({} with {})",
                        c.value, c.parameter, c.with
                    )
                })
                .unwrap_or_default();
            let _ = writeln!(
                s,
                "  alongside the model: +{} direction(s), canonical correlation {:.3}{corr}",
                a.rank_increase, a.canonical_correlation
            );
            if !a.unseen.is_empty() {
                let _ = writeln!(
                    s,
                    "  {} combination(s) of its values unseen by this test, fixed at zero",
                    a.unseen.len()
                );
            }
            for r in st.rivals.iter().filter(|r| r.matters()) {
                let _ = writeln!(
                    s,
                    "  rival {} (gap {:.3} um RMS): {}",
                    r.name, r.gap_after.rms_um, r.verdict
                );
            }
            let names = |f: &dyn Fn(&Rival) -> bool| -> Vec<&str> {
                st.rivals
                    .iter()
                    .filter(|r| !r.matters() && f(r))
                    .map(|r| r.name.as_str())
                    .collect()
            };
            let away = names(&|r| !r.verdict.starts_with("a different effect"));
            if !away.is_empty() {
                let _ = writeln!(
                    s,
                    "  also significant, explained away by {}: {}",
                    st.name,
                    away.join(", ")
                );
            }
            let other = names(&|r| r.verdict.starts_with("a different effect"));
            if !other.is_empty() {
                let _ = writeln!(
                    s,
                    "  also significant, different effects never added: {}",
                    other.join(", ")
                );
            }
        }
        if let Some(a) = &self.ambiguity {
            let _ = writeln!(s, "\nambiguous: {}", a.reason);
            for c in &a.candidates {
                let _ = writeln!(
                    s,
                    "  {} (gap {:.3} um RMS, {:.3} um max{}):",
                    c.name,
                    c.gap_after.rms_um,
                    c.gap_after.max_um,
                    if c.exactly_indistinguishable {
                        "; exactly indistinguishable on this test"
                    } else {
                        ""
                    }
                );
                values(&mut s, &c.values, "    ");
            }
            if let Some(p) = &a.supplement {
                let _ = writeln!(
                    s,
                    "  to separate them: a {} run at the tilt angles {} with C = {} ({} poses, {} touches; new poses {}), measured and given to the next discover with this test's measurements",
                    p.test,
                    list(&p.tilt),
                    list(&p.c),
                    p.poses,
                    p.touches,
                    p.new_poses.join(", ")
                );
                for q in &p.power {
                    let _ = writeln!(
                        s,
                        "    {} told from {}: +{} direction(s), power {:.3} at {:.3} um noise",
                        q.effect, q.against, q.directions, q.power, p.noise_um
                    );
                }
            }
            if let Some(why) = &a.no_supplement {
                let _ = writeln!(s, "  no supplementary test proposed: {why}");
            }
        }
        let _ = writeln!(s, "\nstop: {}", self.stop);
        let refused: Vec<&Trial> = self
            .last_round
            .iter()
            .filter(|t| t.verdict == CandidateVerdict::Refused)
            .collect();
        if !refused.is_empty() {
            let _ = writeln!(s, "refused in the last round:");
            for t in refused {
                let _ = writeln!(s, "  {}: {}", t.name, t.reason.as_deref().unwrap_or(""));
            }
        }
        let _ = writeln!(
            s,
            "\nfinal model ({}): {}: gap {:.3} um RMS, {:.3} um max; residual sigma {:.3} um ({} degrees of freedom)",
            if self.ambiguity.is_some() {
                "none of the ambiguous effects added: its values carry whichever is at work"
            } else {
                "the values to quote"
            },
            self.end.model.join(" + "),
            self.end.gap.rms_um,
            self.end.gap.max_um,
            self.end.sigma_um,
            self.end.dof
        );
        let _ = writeln!(s, "  {}", self.end.gap.summary);
        values(&mut s, &self.end.values, "  ");
        s
    }

    /// The names of the steps' effects, in order.
    pub fn found(&self) -> Vec<&str> {
        self.steps.iter().map(|s| s.name.as_str()).collect()
    }
}
