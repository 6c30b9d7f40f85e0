//! What would identify more: when a plan leaves location errors
//! unidentified, a short list of known changes of its template, each a
//! concrete edit a user can make (more tilt or C angles, another column
//! position, another sphere height or position, another pose pattern), is
//! re-planned on the same machine and predicted as [`super::design`]
//! predicts the plan itself. A change the machine cannot do (strokes, the
//! table, collisions) is refused by the planner and never shown; a change
//! that loses an error the plan identifies is not a suggestion. What is
//! left are the changes that make errors identifiable, each with the
//! template keys to set and the predicted u of what it adds.
//!
//! The changes are of two kinds: a key of the test's template where the
//! template departs from the built-in one, set back to the built-in value
//! (the pose set the paper's test was designed with); and for the probing
//! tests, denser tilt x C grids over the tilt range, the same grids,
//! coarse to fine, that `discover` tries for its supplementary test
//! ([`crate::discover::separate::candidates`]).

use std::fmt::Write as _;

use rayon::prelude::*;
use serde_yaml::{Mapping, Value};

use super::design::{Prediction, Row, predict};
use crate::formats::manifest::{PredictedSymbol, SuggestedChange};
use crate::procedure::{Plan, PlanConfig, Template, Test};

/// Denser grids tried per probing test, cheapest first.
const GRIDS: usize = 2;

/// Suggestions shown, most errors added first.
const SHOWN: usize = 3;

/// A change of the template: what it is and the keys it sets.
#[derive(Clone, Debug, PartialEq)]
pub struct Change {
    /// In words (`more tilt angles`).
    pub what: String,
    /// Key paths of the template (`["poses", "tilt"]`) and their values.
    pub set: Vec<(Vec<String>, Value)>,
}

impl Change {
    /// The keys as `poses.tilt: [0, -30]`, one after the other.
    pub fn keys(&self) -> String {
        self.set
            .iter()
            .map(|(k, v)| format!("{}: {}", k.join("."), flow(v)))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The keys as a fragment of the template (nested mappings).
    pub fn fragment(&self) -> Value {
        let mut root = Value::Mapping(Mapping::new());
        for (k, v) in &self.set {
            set(&mut root, k, v.clone());
        }
        root
    }

    /// `template` with the change made.
    pub fn apply(&self, template: &Template) -> Result<Template, String> {
        let src = template.source();
        let mut doc: Value = serde_yaml::from_str(&src.text).map_err(|e| e.to_string())?;
        for (k, v) in &self.set {
            set(&mut doc, k, v.clone());
        }
        let text = serde_yaml::to_string(&doc).map_err(|e| e.to_string())?;
        let path = format!("<{} with {}>", src.path.display(), self.keys());
        Template::parse(std::path::Path::new(&path), &text).map_err(|e| e.to_string())
    }
}

/// A change that makes errors identifiable, with what it identifies.
#[derive(Clone, Debug)]
pub struct Suggestion {
    /// The change.
    pub change: Change,
    /// The errors it makes identifiable, with their predicted u.
    pub gains: Vec<Row>,
    /// What the changed plan identifies.
    pub prediction: Prediction,
    /// Poses of the changed plan.
    pub poses: usize,
    /// Its estimated run time, min.
    pub run_min: f64,
}

impl Suggestion {
    /// `8 of 8 (12 poses, about 18 min), adding EA0A (u = 1.328 urad), ...`.
    fn outcome(&self) -> String {
        let total = self.prediction.rows.len();
        format!(
            "{} of {total} ({} poses, about {:.0} min), adding {}",
            total - self.prediction.missing().len(),
            self.poses,
            self.run_min,
            self.gains
                .iter()
                .filter_map(|r| Some(format!("{} (u = {:.3} {})", r.symbol, r.u?, r.unit)))
                .collect::<Vec<_>>()
                .join(", ")
        )
    }
}

/// Where a user makes the change: the template file to edit (and what it
/// is a copy of, if it is to be made) and the `fivecal plan` command that
/// plans it, without its `--template`.
#[derive(Clone, Debug, Default)]
pub struct Recipe {
    /// The template file named in the text and in the command.
    pub file: String,
    /// What `file` is to be copied from first, if anything.
    pub copy_of: Option<String>,
    /// `fivecal plan TEST --machine M ...`, to which `--template FILE` is
    /// added.
    pub command: Option<String>,
}

impl Recipe {
    fn command(&self) -> Option<String> {
        self.command
            .as_ref()
            .map(|c| format!("{c} --template {}", self.file))
    }

    fn in_file(&self) -> String {
        match &self.copy_of {
            Some(c) => format!("in {} (a copy of {c})", self.file),
            None => format!("in {}", self.file),
        }
    }
}

/// The known changes tried for a plan and those that identify more.
#[derive(Clone, Debug, Default)]
pub struct Suggestions {
    /// Every change planned and predicted, in words.
    pub tried: Vec<String>,
    /// Changes the planner refused (the machine cannot do them): never
    /// shown.
    pub refused: usize,
    /// The changes that make errors identifiable, most added first.
    pub found: Vec<Suggestion>,
    /// Whether the plan left anything to suggest for.
    pub wanted: bool,
}

impl Suggestions {
    /// The lines `plan` prints under the table (empty when the design
    /// identifies every error).
    pub fn render(&self, recipe: &Recipe) -> String {
        let mut s = String::new();
        if !self.wanted {
            return s;
        }
        if self.found.is_empty() {
            let _ = writeln!(
                s,
                "no known change of the template identifies more ({})",
                if self.tried.is_empty() {
                    "none applies to this test as planned".to_string()
                } else {
                    format!("tried: {}", self.tried.join(", "))
                }
            );
            return s;
        }
        let _ = writeln!(
            s,
            "changes that identify more (each planned on this machine and predicted as above):"
        );
        for f in &self.found {
            let _ = writeln!(
                s,
                "  {}: set {} {}",
                f.change.what,
                f.change.keys(),
                recipe.in_file()
            );
            let _ = writeln!(s, "    identifies {}", f.outcome());
            if let Some(c) = recipe.command() {
                let _ = writeln!(s, "    {c}");
            }
        }
        s
    }

    /// The setup sheet's section (Markdown); empty when there is nothing
    /// to suggest for.
    pub fn markdown(&self, recipe: &Recipe) -> String {
        if !self.wanted {
            return String::new();
        }
        let mut s = String::from("\n## What would identify more\n\n");
        if self.found.is_empty() {
            let _ = writeln!(s, "```\n{}```", self.render(recipe));
            return s;
        }
        s.push_str(
            "Each change below was planned on this machine and predicted as above: set its keys in the \
             template (each replaces that key's value; keys not shown stay as they are) and plan again.\n",
        );
        for f in &self.found {
            let fragment = block(&f.change.fragment(), 0);
            let _ = write!(
                s,
                "\n### {}\n\nIdentifies {}. Set {}:\n\n```yaml\n{fragment}```\n",
                f.change.what,
                f.outcome(),
                recipe.in_file(),
            );
            if let Some(c) = recipe.command() {
                let _ = writeln!(s, "\n```\n{c}\n```");
            }
        }
        s
    }

    /// The manifest's `suggestions:` entries.
    pub fn manifest_entries(&self, recipe: &Recipe) -> Vec<SuggestedChange> {
        self.found
            .iter()
            .map(|f| SuggestedChange {
                change: f.change.what.clone(),
                set: f.change.fragment(),
                identifies: f
                    .gains
                    .iter()
                    .filter_map(|r| {
                        let u = r.u.filter(|u| u.is_finite())?;
                        Some((
                            r.symbol.clone(),
                            PredictedSymbol {
                                unit: r.unit.clone(),
                                u: Some(u),
                                reason: None,
                            },
                        ))
                    })
                    .collect(),
                identified: f.prediction.rows.len() - f.prediction.missing().len(),
                poses: f.poses,
                run_min: crate::procedure::round(f.run_min, 1),
                command: recipe.command(),
            })
            .collect()
    }
}

/// The changes that would make what `plan` (planned from `cfg`) leaves
/// unidentified in `now` identifiable, predicted with the same method at
/// the same stated noise (`noise` um, else the instrument's default).
pub fn suggest(cfg: &PlanConfig, plan: &Plan, now: &Prediction, noise: Option<f64>) -> Suggestions {
    if now.missing().is_empty() {
        return Suggestions::default();
    }
    let changes = changes(cfg, plan);
    let outcomes: Vec<Option<(Prediction, usize, f64)>> = changes
        .par_iter()
        .map(|c| {
            let template = c.apply(&cfg.template).ok()?;
            let planned = crate::procedure::plan(&PlanConfig {
                template,
                ..cfg.clone()
            })
            .ok()?;
            let p = predict(&planned, Some(now.method), noise).ok()?;
            Some((p, planned.poses().len(), planned.run_minutes()))
        })
        .collect();
    let mut out = Suggestions {
        wanted: true,
        ..Default::default()
    };
    for (change, outcome) in changes.into_iter().zip(outcomes) {
        let Some((prediction, poses, run_min)) = outcome else {
            out.refused += 1;
            continue;
        };
        out.tried.push(change.what.clone());
        let was = |s: &str| now.rows.iter().find(|r| r.symbol == s).and_then(|r| r.u);
        let lost = prediction
            .rows
            .iter()
            .any(|r| r.u.is_none() && was(&r.symbol).is_some());
        let gains: Vec<Row> = prediction
            .rows
            .iter()
            .filter(|r| r.u.is_some_and(f64::is_finite) && was(&r.symbol).is_none())
            .cloned()
            .collect();
        if lost || gains.is_empty() {
            continue;
        }
        out.found.push(Suggestion {
            change,
            gains,
            prediction,
            poses,
            run_min,
        });
    }
    // Most errors added first, then the shortest run.
    out.found.sort_by(|a, b| {
        b.gains
            .len()
            .cmp(&a.gains.len())
            .then(a.run_min.total_cmp(&b.run_min))
    });
    out.found.truncate(SHOWN);
    out
}

/// The known changes of the plan's template, in the order they are tried.
pub fn changes(cfg: &PlanConfig, plan: &Plan) -> Vec<Change> {
    let test = plan.test();
    let Ok(user) = serde_yaml::from_str::<Value>(&cfg.template.source().text) else {
        return Vec::new();
    };
    let Ok(builtin) = serde_yaml::from_str::<Value>(test.template_text()) else {
        return Vec::new();
    };
    let list_len = |v: Option<&Value>| v.and_then(Value::as_sequence).map(Vec::len);
    // (key path, what the built-in value is, what it is when there are fewer)
    let knobs: &[(&[&str], &str, &str)] = match test {
        Test::SteppedSquare => &[
            (&["angles", "tilt"], "more tilt angles", "other tilt angles"),
            (&["angles", "c"], "more C angles", "other C angles"),
        ],
        Test::ProbeColumns => &[
            (&["poses", "tilt"], "more tilt angles", "other tilt angles"),
            (&["poses", "c"], "more C angles", "other C angles"),
            (
                &["columns"],
                "more column positions",
                "other column positions",
            ),
        ],
        Test::ProbeSphere => &[
            (
                &["pattern"],
                "the built-in pose pattern",
                "the built-in pose pattern",
            ),
            (
                &["sphere", "position"],
                "another sphere position",
                "another sphere position",
            ),
            (
                &["sphere", "height"],
                "another sphere height",
                "another sphere height",
            ),
        ],
        Test::NineSection => &[],
    };
    let mut out = Vec::new();
    for (key, more, other) in knobs {
        let (Some(want), have) = (get(&builtin, key), get(&user, key)) else {
            continue;
        };
        if have == Some(want) {
            continue;
        }
        let mut set = vec![(key.iter().map(|s| s.to_string()).collect(), want.clone())];
        // A pattern comes with its own section.
        if key == &["pattern"]
            && let Some(name) = want.as_str()
            && let Some(section) = get(&builtin, &[name])
        {
            set.push((vec![name.to_string()], section.clone()));
        }
        let what = match (list_len(Some(want)), list_len(have)) {
            (Some(a), Some(b)) if a <= b => other,
            _ => more,
        };
        out.push(Change {
            what: what.to_string(),
            set,
        });
    }
    if matches!(test, Test::ProbeColumns | Test::ProbeSphere) {
        out.extend(grids(plan));
    }
    out
}

/// Denser tilt x C grids over the plan's tilt range, cheapest first.
fn grids(plan: &Plan) -> Vec<Change> {
    let poses = plan.poses();
    let mut tilts: Vec<f64> = Vec::new();
    let mut cs: Vec<f64> = Vec::new();
    for p in &poses {
        if !tilts.iter().any(|t| (t - p.tilt).abs() < 1e-6) {
            tilts.push(p.tilt);
        }
        let c = p.c.rem_euclid(360.0);
        if !cs.iter().any(|x| (x - c).abs() < 1e-6) {
            cs.push(c);
        }
    }
    if tilts.is_empty() {
        return Vec::new();
    }
    tilts.sort_by(f64::total_cmp);
    cs.sort_by(f64::total_cmp);
    let list = |v: &[f64]| Value::Sequence(v.iter().map(|a| number(*a)).collect());
    crate::discover::separate::candidates(plan, &tilts, &cs)
        .into_iter()
        .take(GRIDS)
        .map(|(tilt, c)| {
            let what = format!("a grid of {} tilt x {} C angles", tilt.len(), c.len());
            let set = match plan.test() {
                Test::ProbeSphere => vec![
                    (vec!["pattern".to_string()], Value::String("grid".into())),
                    (vec!["grid".to_string()], {
                        let mut m = Mapping::new();
                        m.insert("tilt".into(), list(&tilt));
                        m.insert("c".into(), list(&c));
                        Value::Mapping(m)
                    }),
                ],
                _ => vec![
                    (vec!["poses".into(), "tilt".into()], list(&tilt)),
                    (vec!["poses".into(), "c".into()], list(&c)),
                ],
            };
            Change { what, set }
        })
        .collect()
}

/// An angle as a YAML number: an integer where it is one.
fn number(v: f64) -> Value {
    if v.fract() == 0.0 && v.abs() < 1e9 {
        Value::Number((v as i64).into())
    } else {
        Value::Number(v.into())
    }
}

fn get<'a>(v: &'a Value, key: &[&str]) -> Option<&'a Value> {
    key.iter().try_fold(v, |v, k| v.as_mapping()?.get(*k))
}

/// Sets `key` in `doc` to `value`, making the mappings on the way.
fn set(doc: &mut Value, key: &[String], value: Value) {
    let Some((last, head)) = key.split_last() else {
        return;
    };
    let mut at = doc;
    for k in head {
        if !at.is_mapping() {
            *at = Value::Mapping(Mapping::new());
        }
        let m = at.as_mapping_mut().expect("made a mapping above");
        at = m
            .entry(Value::String(k.clone()))
            .or_insert_with(|| Value::Mapping(Mapping::new()));
    }
    if !at.is_mapping() {
        *at = Value::Mapping(Mapping::new());
    }
    at.as_mapping_mut()
        .expect("made a mapping above")
        .insert(Value::String(last.clone()), value);
}

/// A fragment of a template as a user writes it: mappings as blocks, a
/// list of mappings item by item, everything else in flow style.
fn block(v: &Value, indent: usize) -> String {
    let pad = " ".repeat(indent);
    match v {
        Value::Mapping(m) => m
            .iter()
            .map(|(k, v)| match v {
                Value::Mapping(_) => format!("{pad}{}:\n{}", flow(k), block(v, indent + 2)),
                Value::Sequence(items) if items.iter().any(Value::is_mapping) => format!(
                    "{pad}{}:\n{}",
                    flow(k),
                    items
                        .iter()
                        .map(|i| format!("{pad}  - {}\n", flow(i)))
                        .collect::<String>()
                ),
                _ => format!("{pad}{}: {}\n", flow(k), flow(v)),
            })
            .collect(),
        _ => format!("{pad}{}\n", flow(v)),
    }
}

/// A value in YAML flow style, as a user types it into a template.
pub fn flow(v: &Value) -> String {
    match v {
        Value::Null => "null".into(),
        Value::Bool(b) => b.to_string(),
        Value::Number(n) => match (n.as_i64(), n.as_f64()) {
            (Some(i), _) => i.to_string(),
            (None, Some(f)) => crate::procedure::short(f),
            _ => n.to_string(),
        },
        Value::String(s) => s.clone(),
        Value::Sequence(s) => format!("[{}]", s.iter().map(flow).collect::<Vec<_>>().join(", ")),
        Value::Mapping(m) => format!(
            "{{{}}}",
            m.iter()
                .map(|(k, v)| format!("{}: {}", flow(k), flow(v)))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        Value::Tagged(t) => format!("{} {}", t.tag, flow(&t.value)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_change_sets_nested_keys_and_reads_as_the_user_types_it() {
        let c = Change {
            what: "more tilt angles".into(),
            set: vec![
                (
                    vec!["poses".into(), "tilt".into()],
                    Value::Sequence(vec![number(0.0), number(-30.0), number(-7.5)]),
                ),
                (vec!["pattern".into()], Value::String("grid".into())),
            ],
        };
        assert_eq!(c.keys(), "poses.tilt: [0, -30, -7.5], pattern: grid");
        assert_eq!(
            block(&c.fragment(), 0),
            "poses:\n  tilt: [0, -30, -7.5]\npattern: grid\n"
        );
        // As YAML, the fragment reads back as what it sets.
        let back: Value = serde_yaml::from_str(&block(&c.fragment(), 0)).unwrap();
        assert_eq!(back, c.fragment());
        // The columns template has no `pattern`: the change is refused as
        // the template would be, with the key named.
        let t = Template::builtin(Test::ProbeColumns);
        let e = c.apply(&t).unwrap_err();
        assert!(e.contains("pattern"), "{e}");
        let tilt_only = Change {
            set: c.set[..1].to_vec(),
            ..c
        };
        let Ok(Template::Columns(changed)) = tilt_only.apply(&t) else {
            panic!("a columns template with other tilts")
        };
        assert_eq!(changed.tilts, [0.0, -30.0, -7.5]);
        // The rest of the template is as it was.
        let Template::Columns(before) = t else {
            unreachable!()
        };
        assert_eq!((changed.cs, changed.columns), (before.cs, before.columns));
    }
}
