//! What would identify more: when a plan leaves location errors
//! unidentified, a short list of known changes of its template, each a
//! concrete edit a user can make (more tilt or C angles, another column
//! position, another sphere height or position, another pose pattern), is
//! re-planned on the same machine and predicted as [`crate::analyze::preview`]
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
//!
//! Some aliases no pose of one run separates: on a head machine the B
//! head's offset and its angle move the probe's ball alike through the
//! lever of the pivot and the probe's gauge length. A second run of the
//! same test with another probe length does; the two runs are fitted
//! together as `discover` fits several tests of one machine (each run its
//! own setup and sphere-position nuisance, the location errors shared,
//! [`crate::discover::Fitter`]), and that joint design is what such a
//! suggestion predicts.

use std::fmt::Write as _;

use rayon::prelude::*;
use serde_yaml::{Mapping, Value};

use crate::analyze::preview::{Preview, PreviewRow, nominal_data, predict};
use crate::formats::manifest::{PredictedSymbol, SecondRunEntry, SuggestedChange};
use crate::identify::Dataset;
use crate::io::shell_word;
use crate::kinematics::Kinematics;
use crate::procedure::{Plan, PlanConfig, Template, Test};
use crate::source::SourceError;

/// Denser grids tried per probing test, cheapest first.
const GRIDS: usize = 2;

/// Suggestions shown, most errors added first.
const SHOWN: usize = 3;

/// Probe lengths tried for a second run, as fractions of the first run's.
const PROBE_LENGTHS: [f64; 2] = [1.6, 0.6];

/// A change of the template: what it is and the keys it sets.
#[derive(Clone, Debug, PartialEq)]
pub struct TemplateChange {
    /// In words (`more tilt angles`).
    pub what: String,
    /// Key paths of the template (`["poses", "tilt"]`) and their values.
    pub set: Vec<(Vec<String>, Value)>,
}

impl TemplateChange {
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

    /// `template` with the change made, or why the changed template does
    /// not read (named as the template with the keys set).
    pub fn apply(&self, template: &Template) -> Result<Template, SourceError> {
        let src = template.source();
        let path = format!("<{} with {}>", src.path.display(), self.keys());
        let path = std::path::Path::new(&path);
        let yaml = |e: serde_yaml::Error| SourceError::from_yaml(path, &e);
        let mut doc: Value = serde_yaml::from_str(&src.text).map_err(yaml)?;
        for (k, v) in &self.set {
            set(&mut doc, k, v.clone());
        }
        let text = serde_yaml::to_string(&doc).map_err(yaml)?;
        Template::parse(path, &text)
    }
}

/// A change that makes errors identifiable, with what it identifies.
#[derive(Clone, Debug)]
pub struct Suggestion {
    /// The change.
    pub change: TemplateChange,
    /// The errors it makes identifiable, with their predicted u.
    pub gains: Vec<PreviewRow>,
    /// What the changed plan identifies.
    pub prediction: Preview,
    /// Poses of the changed plan.
    pub poses: usize,
    /// Its estimated run time, min.
    pub run_min: f64,
    /// Where the change is a second run analysed together with the plan's:
    /// what differs (`poses` and `run_min` are the second run's,
    /// `prediction` the two runs' together).
    pub second: Option<SecondRun>,
}

/// A second run of the same test on the same machine with another probe,
/// measured beside the plan's run and analysed together with it.
#[derive(Clone, Debug, PartialEq)]
pub struct SecondRun {
    /// The machine's name (the copy of its file keeps it: `discover` fits
    /// one machine).
    pub machine: String,
    /// The first run's probe gauge length, mm.
    pub was: f64,
    /// The second run's, mm (the machine file's `probe.length`).
    pub probe_length: f64,
}

impl SecondRun {
    /// The keys to set in a copy of the machine file.
    pub(crate) fn machine_keys(&self) -> Value {
        let mut root = Value::Mapping(Mapping::new());
        set(
            &mut root,
            &["probe".to_string(), "length".to_string()],
            number(self.probe_length),
        );
        root
    }

    /// The name of that copy.
    pub fn machine_file(&self) -> String {
        format!(
            "{}-probe{}.machine.yaml",
            self.machine,
            crate::procedure::short(self.probe_length)
        )
    }

    fn what(&self) -> String {
        format!(
            "a second run with a {} mm probe (this one: {} mm), analysed together with this one",
            crate::procedure::short(self.probe_length),
            crate::procedure::short(self.was)
        )
    }
}

impl Suggestion {
    /// `8 of 8 (12 poses, about 18 min), adding EA0A (u = 1.328 urad), ...`.
    fn outcome(&self) -> String {
        let total = self.prediction.rows.len();
        format!(
            "{}{} of {total} ({}{} poses, about {:.0} min), adding {}",
            if self.second.is_some() {
                "together "
            } else {
                ""
            },
            total - self.prediction.missing().len(),
            if self.second.is_some() {
                "second run: "
            } else {
                ""
            },
            self.poses,
            self.run_min,
            self.gains
                .iter()
                .filter_map(|r| Some(format!(
                    "{} (u {} {:.3} {})",
                    r.symbol,
                    if self.second.is_some() { ">=" } else { "=" },
                    r.u?,
                    r.unit
                )))
                .collect::<Vec<_>>()
                .join(", ")
        ) + if self.second.is_some() {
            "; from the noise alone, a floor: the test's other contributors are not propagated through two runs fitted together"
        } else {
            ""
        }
    }
}

/// Where a user makes the change: the template file to edit (and what it
/// is a copy of, if it is to be made) and the `fivecal plan` command that
/// plans it, without its `--template`.
#[derive(Clone, Debug, Default)]
pub struct Recipe {
    /// The template file named in the text and in the command (as a path:
    /// commands quote it).
    pub file: String,
    /// What `file` is to be copied from first, if anything.
    pub copy_of: Option<String>,
    /// `fivecal plan TEST --machine M ...`, to which `--template FILE` is
    /// added.
    pub command: Option<String>,
    /// This plan's output directory (`--out`, as a path): its manifest and
    /// the copy of its machine file are there, for a second run beside it.
    pub out: Option<String>,
    /// The `--machine` argument of `command` as written there (a shell
    /// word), replaced by the copy of the machine file a second run is
    /// planned with.
    pub machine: Option<String>,
}

impl Recipe {
    /// The copy of the machine file this plan wrote beside itself.
    fn machine_copy(&self, test: Test) -> String {
        let name = format!("{test}.machine.yaml");
        match &self.out {
            Some(o) => std::path::Path::new(o).join(name).display().to_string(),
            None => name,
        }
    }

    /// The second run's directory, beside this plan's.
    pub fn second_out(&self) -> String {
        match self.out.as_deref().map(|o| o.trim_end_matches('/')) {
            Some(o) if !o.is_empty() && o != "." => format!("{o}-second"),
            _ => "second".into(),
        }
    }

    /// `fivecal plan` for the second run: this plan's command on the copy
    /// of the machine file (with the template given, if one was).
    fn second_command(&self, second: &SecondRun) -> Option<String> {
        let c = self.command.as_ref()?;
        let m = self.machine.as_ref()?;
        let c = c.replacen(
            &format!("--machine {m}"),
            &format!("--machine {}", shell_word(&second.machine_file())),
            1,
        );
        let template = match self.copy_of {
            None => format!(" --template {}", shell_word(&self.file)),
            Some(_) => String::new(),
        };
        Some(format!(
            "{c}{template} --out {}",
            shell_word(&self.second_out())
        ))
    }

    /// `fivecal discover` on both runs' measurements.
    fn together(&self, test: Test) -> String {
        let manifest = format!("{test}.plan.yaml");
        let first = match &self.out {
            Some(o) => std::path::Path::new(o).join(&manifest),
            None => manifest.clone().into(),
        };
        let second = std::path::Path::new(&self.second_out()).join(&manifest);
        format!(
            "fivecal discover --plan {} --measured FIRST-RUN-MEASURED --plan {} --measured SECOND-RUN-MEASURED",
            shell_word(&first.display().to_string()),
            shell_word(&second.display().to_string())
        )
    }

    /// How to make the second run's machine file.
    fn machine_edit(&self, test: Test, second: &SecondRun) -> String {
        format!(
            "copy {} (the machine file this plan used, as written beside it) to {} and set {} in it",
            self.machine_copy(test),
            second.machine_file(),
            TemplateChange {
                what: String::new(),
                set: vec![(
                    vec!["probe".into(), "length".into()],
                    number(second.probe_length)
                )],
            }
            .keys()
        )
    }

    /// `fivecal plan` again with the changed template, into a directory of
    /// its own beside this plan's: the template it reads lies in this
    /// plan's directory, which a new plan may not write over.
    fn command(&self) -> Option<String> {
        let out = match self.out.as_deref().map(|o| o.trim_end_matches('/')) {
            Some(o) if !o.is_empty() && o != "." => format!("{o}-revised"),
            _ => "revised".into(),
        };
        self.command.as_ref().map(|c| {
            format!(
                "{c} --template {} --out {}",
                shell_word(&self.file),
                shell_word(&out)
            )
        })
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
    /// The test suggested for.
    pub test: Option<Test>,
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
            if let (Some(second), Some(test)) = (&f.second, self.test) {
                let _ = writeln!(
                    s,
                    "  {}: {}",
                    f.change.what,
                    recipe.machine_edit(test, second)
                );
                let _ = writeln!(s, "    identifies {}", f.outcome());
                if let Some(c) = recipe.second_command(second) {
                    let _ = writeln!(s, "    {c}");
                }
                let _ = writeln!(s, "    then, both runs measured: {}", recipe.together(test));
                continue;
            }
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
             template (each replaces that key's value; keys not shown stay as they are) and plan again",
        );
        s.push_str(if self.found.iter().any(|f| f.second.is_some()) {
            "; a second run is planned on a copy of the machine file instead.\n"
        } else {
            ".\n"
        });
        for f in &self.found {
            if let (Some(second), Some(test)) = (&f.second, self.test) {
                let _ = write!(
                    s,
                    "\n### {}\n\nIdentifies {}. The two runs are analysed together by `fivecal discover` (each with its own setups or sphere position; the location errors shared). To plan the second run, {}:\n\n```yaml\n{}```\n",
                    f.change.what,
                    f.outcome(),
                    recipe.machine_edit(test, second),
                    block(&second.machine_keys(), 0),
                );
                let _ = writeln!(s, "\n```");
                if let Some(c) = recipe.second_command(second) {
                    let _ = writeln!(s, "{c}");
                }
                let _ = writeln!(
                    s,
                    "# then, both runs measured:\n{}\n```",
                    recipe.together(test)
                );
                continue;
            }
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
                command: match &f.second {
                    Some(second) => recipe.second_command(second),
                    None => recipe.command(),
                },
                second_run: f
                    .second
                    .as_ref()
                    .zip(self.test)
                    .map(|(second, test)| SecondRunEntry {
                        machine_file: second.machine_file(),
                        copy_of: recipe.machine_copy(test),
                        machine_set: second.machine_keys(),
                        together: recipe.together(test),
                    }),
            })
            .collect()
    }
}

/// The changes that would make what `plan` (planned from `cfg`) leaves
/// unidentified in `now` identifiable, predicted with the same method at
/// the same stated noise (`noise` um, else the instrument's default).
pub fn suggest(cfg: &PlanConfig, plan: &Plan, now: &Preview, noise: Option<f64>) -> Suggestions {
    if now.missing().is_empty() {
        return Suggestions::default();
    }
    let changes = changes(cfg, plan);
    let outcomes: Vec<Option<(Preview, usize, f64)>> = changes
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
        let gains: Vec<PreviewRow> = prediction
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
            second: None,
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
    out.test = Some(plan.test());
    if plan.kind() == crate::formats::manifest::TestKind::Probing {
        let (tried, refused, best) = second_runs(cfg, plan, now);
        out.tried.extend(tried);
        out.refused += refused;
        out.found.extend(best);
    }
    out
}

/// What the u of two runs fitted together hold: the noise alone. The
/// closed-form budget follows one run's fit; through a joint fit the
/// linear axes' errors (common to both runs) are not propagated, so these
/// u are floors, and the analysis of the measured runs says the rest.
pub const JOINT_BASIS: &str = "the measurement noise only, a floor: the test's other contributors are not propagated through two runs fitted together";

/// A run as `discover` takes it: its plan, its kinematics (with its
/// probe) and its measurements (here the nominal ones, its design).
pub type Run<'a> = (&'a Plan, &'a Kinematics, &'a Dataset);

/// What `runs` identify fitted together as `discover` fits several tests
/// of one machine: the location errors shared, each run with its own
/// nuisance (setup, sphere position). Every location error's row, with its
/// u at `noise` um where the joint design identifies it, and the design's
/// rank of its free parameters.
pub fn joint(
    runs: &[Run<'_>],
    noise: f64,
) -> Result<(Vec<PreviewRow>, (usize, usize)), crate::discover::FitError> {
    let labels: Vec<String> = (1..=runs.len()).map(|i| format!("run {i}")).collect();
    let parts: Vec<crate::discover::Part<'_>> = runs
        .iter()
        .zip(&labels)
        .map(|((plan, kin, data), label)| crate::discover::Part {
            kin,
            data,
            plan: Some(plan),
            label,
        })
        .collect();
    let (fitter, _) = crate::discover::Fitter::new(&parts, &[])?;
    let symbols = &crate::model::Model::new(runs[0].1.clone(), Vec::new()).symbols;
    let all: Vec<usize> = (0..symbols.location.len()).collect();
    // The nominal measurements fit the nominal machine exactly: the fit is
    // the design at it, with discover's own rule of what it identifies.
    let fit = fitter.fit(&fitter.location(&all), None)?;
    let rows = symbols
        .location
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let seen = fit.identifiable(i) && !fit.fixed(i);
            PreviewRow {
                symbol: l.name.clone(),
                unit: l.unit.to_string(),
                u: seen.then(|| fit.cov_unit[(i, i)].max(0.0).sqrt() * noise),
                reason: (!seen).then(|| "the runs together do not see it".to_string()),
            }
        })
        .collect();
    let id = fit.identifiability();
    Ok((rows, (id.rank, id.free)))
}

/// `machine` with its probe's gauge length set to `length` mm, as a user
/// sets it in a copy of the machine file (and as checked on reading one).
fn with_probe(machine: &crate::machine::Machine, length: f64) -> Option<crate::machine::Machine> {
    let mut doc: Value = serde_yaml::from_str(&machine.source).ok()?;
    set(
        &mut doc,
        &["probe".to_string(), "length".to_string()],
        number(length),
    );
    let text = serde_yaml::to_string(&doc).ok()?;
    let path = format!("<{} with probe.length: {length}>", machine.name);
    crate::machine::Machine::from_yaml(std::path::Path::new(&path), &text).ok()
}

/// The plan of a suggested second run: `cfg`'s test on its machine with
/// the second run's probe length, as `plan` writes it for `--require all`.
pub fn second_run_plan(cfg: &PlanConfig, run: &SecondRun) -> Option<Plan> {
    let machine = with_probe(&cfg.machine, run.probe_length)?;
    crate::procedure::plan(&PlanConfig {
        machine,
        ..cfg.clone()
    })
    .ok()
}

/// A second run of the plan with another probe length, fitted together
/// with the plan's: the lengths tried (in words), how many the planner
/// refused, and the best of those that identify more than the plan alone.
fn second_runs(
    cfg: &PlanConfig,
    plan: &Plan,
    now: &Preview,
) -> (Vec<String>, usize, Option<Suggestion>) {
    let was = plan.machine().probe.length;
    let first_kin = crate::simulate::plan_kinematics(plan);
    let Ok(first_data) = nominal_data(plan) else {
        return (Vec::new(), 0, None);
    };
    let noise = now.noise.um;
    let first: Run<'_> = (plan, &first_kin, &first_data);
    // What the plan's run alone gives in the same fit: a gain is what the
    // second run adds, not what another method would see.
    let Ok((alone, _)) = joint(&[first], noise) else {
        return (Vec::new(), 0, None);
    };
    let lengths: Vec<f64> = PROBE_LENGTHS
        .iter()
        .map(|f| (was * f).round())
        .filter(|l| *l > 0.0 && (l - was).abs() >= 1.0)
        .collect();
    let outcomes: Vec<Option<Suggestion>> = lengths
        .par_iter()
        .map(|&length| {
            let machine = with_probe(plan.machine(), length)?;
            let second = crate::procedure::plan(&PlanConfig {
                machine,
                ..cfg.clone()
            })
            .ok()?;
            let kin = crate::simulate::plan_kinematics(&second);
            let data = nominal_data(&second).ok()?;
            let (rows, rank) = joint(&[first, (&second, &kin, &data)], noise).ok()?;
            let had = |s: &str| {
                let seen =
                    |rows: &[PreviewRow]| rows.iter().any(|r| r.symbol == s && r.u.is_some());
                seen(&alone) || seen(&now.rows)
            };
            let gains: Vec<PreviewRow> = rows
                .iter()
                .filter(|r| r.u.is_some_and(f64::is_finite) && !had(&r.symbol))
                .cloned()
                .collect();
            let run = SecondRun {
                machine: plan.machine().name.clone(),
                was,
                probe_length: length,
            };
            Some(Suggestion {
                change: TemplateChange {
                    what: run.what(),
                    set: Vec::new(),
                },
                gains,
                prediction: Preview {
                    method: crate::identify::Method::Global,
                    noise: now.noise.clone(),
                    basis: JOINT_BASIS.into(),
                    rank,
                    rows,
                    unseen: Vec::new(),
                    summary: None,
                },
                poses: second.poses().len(),
                run_min: second.run_minutes(),
                second: Some(run),
            })
        })
        .collect();
    let mut tried = Vec::new();
    let mut refused = 0;
    let mut best: Option<Suggestion> = None;
    for (length, outcome) in lengths.iter().zip(outcomes) {
        let Some(s) = outcome else {
            refused += 1;
            continue;
        };
        tried.push(format!(
            "a second run with a {} mm probe",
            crate::procedure::short(*length)
        ));
        if s.gains.is_empty() {
            continue;
        }
        // The most errors added, then the smallest u of what is added.
        let worst = |s: &Suggestion| s.gains.iter().filter_map(|r| r.u).fold(0.0, f64::max);
        if best.as_ref().is_none_or(|b| {
            s.gains.len() > b.gains.len()
                || (s.gains.len() == b.gains.len() && worst(&s) < worst(b))
        }) {
            best = Some(s);
        }
    }
    (tried, refused, best)
}

/// The known changes of the plan's template, in the order they are tried.
pub fn changes(cfg: &PlanConfig, plan: &Plan) -> Vec<TemplateChange> {
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
        out.push(TemplateChange {
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
fn grids(plan: &Plan) -> Vec<TemplateChange> {
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
            TemplateChange { what, set }
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
pub(crate) fn flow(v: &Value) -> String {
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
        let c = TemplateChange {
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
        assert!(e.message.contains("pattern"), "{e}");
        let tilt_only = TemplateChange {
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
