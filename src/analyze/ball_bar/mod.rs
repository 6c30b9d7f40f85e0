//! `analyze` on ball-bar runs (docs/ball-bar.md): from the runs of every
//! setup of a ball-bar plan to an ordinary error file. Per swept rotary
//! axis the six error motions are identified as maps over the angles of
//! the sweep, with the machine's location errors, by one least-squares
//! fit of every reading against the exact model ([`design`], [`fit`]):
//! the seed's per-angle equations (Jiang et al. 2013, eqs. 6-8 and 11-14)
//! are that model's first-order form, which the tests check term by term.
//! The linear axes' errors an error file gives are taken out (its eq. 9:
//! they act at the positions the linear axes take), and so is the stated
//! run-out of the spindle ball (its eqs. 10 and 15).
//!
//! What no reading sees is named before any number: the fit's null
//! directions, each parameter with a share in one left without a value.
//! Each value's `u` holds the bar's noise and calibration, the table
//! ball's placement along the bar and the run-out as measured, propagated
//! through the fit's gain; the verdict judges every reading against the
//! model at the estimate, and a fit that did not converge is none. The
//! runs' circularity figures ([`circularity`]) come first.

pub mod circularity;
pub mod design;
pub mod fit;

use std::path::{Path, PathBuf};

use indexmap::IndexMap;
use nalgebra::DVector;

use super::AnalyzeError;
use super::goodness::{self, ExpectedNoise};
use super::usefulness::Usefulness;
use crate::errorfile::{
    ErrorFile, FitSection, FitVerdict, Noise, NotIdentified, Share, UncertaintySection,
    ValueUncertainty,
};
use crate::formats::ball_bar::{BallBarManifest, BallBarRun};
use crate::machine::Machine;
use crate::source::SourceError;

pub use design::{Design, KnownLinear, Reading, Runout};
pub use fit::Fit;

/// Default standard uncertainty of the table ball's centre along the bar
/// as set, um: the centre mount set from the spindle with the setting
/// ball and clamped (a few um), which every reading of the run carries
/// alike.
pub const DEFAULT_PLACEMENT_UM: f64 = 2.0;

/// Default standard uncertainty of each component of the stated run-out,
/// um: a dial indicator's reading of the spindle ball turned by hand.
pub const DEFAULT_RUNOUT_U_UM: f64 = 0.5;

/// How the runs are analysed, beyond the plan.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// The spindle ball's run-out as measured (zero: none stated).
    pub runout: Runout,
    /// Standard uncertainty of each run-out component, um.
    pub runout_u_um: f64,
    /// Standard uncertainty of the table ball's placement along the bar,
    /// um.
    pub placement_um: f64,
    /// The bar's noise per reading, um (`None`: the plan's).
    pub noise_um: Option<f64>,
    /// The largest `u` of a location error that counts as identified.
    pub usefulness: Usefulness,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            runout: Runout::default(),
            runout_u_um: DEFAULT_RUNOUT_U_UM,
            placement_um: DEFAULT_PLACEMENT_UM,
            noise_um: None,
            usefulness: Usefulness::default(),
        }
    }
}

/// What `analyze` asks of a ball-bar plan: files.
#[derive(Clone, Debug)]
pub struct Request {
    /// The plan file `ball-bar.plan.yaml`.
    pub plan: PathBuf,
    /// One run file per setup.
    pub runs: Vec<PathBuf>,
    /// An error file whose linear-axis errors are taken out.
    pub linear_errors: Option<PathBuf>,
    /// The rest.
    pub options: Options,
}

/// What the analysis found.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The result file.
    pub file: ErrorFile,
    /// The parameters and model.
    pub design: Design,
    /// The fit.
    pub fit: Fit,
    /// Per parameter, the full `u` (`None`: unseen).
    pub u: Vec<Option<f64>>,
    /// Per parameter, the bar noise's share of it alone.
    pub u_noise: Vec<Option<f64>>,
    /// What the reader should know (what was taken out, from where).
    pub notes: Vec<String>,
}

/// Whether `src` is a ball-bar plan file.
pub fn is_plan(src: &str) -> bool {
    BallBarManifest::sniff(src)
}

/// Reads the files of `req` and analyses them.
pub fn run(req: &Request) -> Result<Outcome, AnalyzeError> {
    let plan = BallBarManifest::read(&req.plan)?;
    let dir = req.plan.parent().unwrap_or(Path::new("."));
    let machine_path = dir.join(&plan.machine_file);
    let machine =
        Machine::from_file(&machine_path, "ball-bar plan's machine copy").map_err(|source| {
            AnalyzeError::Machine {
                path: machine_path.clone(),
                source,
            }
        })?;
    let runs = req
        .runs
        .iter()
        .map(|p| Ok((p.clone(), BallBarRun::read(p)?)))
        .collect::<Result<Vec<_>, SourceError>>()?;
    let linear = match &req.linear_errors {
        Some(p) => {
            let (f, src) = ErrorFile::read(p)?;
            Some((f, p.clone(), src))
        }
        None => None,
    };
    analyze(
        &plan,
        &req.plan,
        &machine,
        &runs,
        linear
            .as_ref()
            .map(|(f, p, s)| (f, p.as_path(), s.as_str())),
        &req.options,
    )
}

/// Analyses the runs `runs` (file, run) of `plan` (read from `plan_path`)
/// on `machine`, taking out the linear-axis errors of `linear` (an error
/// file, its path and text).
pub fn analyze(
    plan: &BallBarManifest,
    plan_path: &Path,
    machine: &Machine,
    runs: &[(PathBuf, BallBarRun)],
    linear: Option<(&ErrorFile, &Path, &str)>,
    opts: &Options,
) -> Result<Outcome, AnalyzeError> {
    check_options(opts)?;
    let design = Design::new(plan, machine).map_err(AnalyzeError::Plan)?;
    let mut rows = design.rows();
    let by_setup = match_runs(plan, plan_path, runs)?;
    let mut readings: Vec<Vec<f64>> = Vec::new();
    for (k, s) in plan.setups.iter().enumerate() {
        let (path, run) = &runs[by_setup[k]];
        let y = run.at_angles(s).map_err(|e| {
            AnalyzeError::Plan(format!("{}: setup {}: {e}", path.display(), s.name))
        })?;
        if let Some(bad) = y.iter().position(|v| !v.is_finite()) {
            return Err(AnalyzeError::Plan(format!(
                "{}: the reading at {} deg is not a finite number",
                path.display(),
                s.angles[bad]
            )));
        }
        readings.push(y);
    }
    for r in rows.iter_mut() {
        r.um = readings[r.setup][r.step];
    }
    let mut notes = Vec::new();
    let known = match linear {
        Some((f, path, src)) => Some(known_linear(&design, machine, f, path, src, &mut notes)?),
        None => None,
    };
    if opts.runout.um > 0.0 {
        notes.push(format!(
            "the spindle ball's run-out of {} um at {} deg (as stated) taken out of every reading",
            opts.runout.um, opts.runout.phase_deg
        ));
    }
    let fitted = fit::fit(&design, &rows, known.as_ref(), &opts.runout);
    let m = rows.len();
    let dof = m.saturating_sub(fitted.rank);
    let sigma = if dof > 0 {
        (fitted.residuals.norm_squared() / dof as f64).sqrt()
    } else {
        f64::NAN
    };
    let expected = match opts.noise_um {
        Some(um) => ExpectedNoise {
            um,
            from: "stated with --noise".into(),
        },
        None => ExpectedNoise {
            um: plan.noise_um,
            from: "the bar's noise in the plan".into(),
        },
    };
    let mut verdict = goodness::judge(sigma, dof, &expected);
    if let Some(f) = verdict.as_mut() {
        f.on = Some(format!(
            "every reading of the {} runs ({m} readings) against the exact model at the estimate",
            runs.len()
        ));
        if !fitted.converged {
            f.verdict = FitVerdict::NotConverged;
            f.stopped = Some(format!(
                "the ball-bar fit stopped after {} Gauss-Newton steps without converging: its values are no estimate",
                fitted.steps
            ));
        }
    }
    // Under a misfit the readings scatter more than the bar's noise: the
    // budget's noise is the residuals' then.
    let noise = match verdict.as_ref() {
        Some(f) if f.verdict == FitVerdict::Misfit && f.sigma_um > expected.um => f.sigma_um,
        _ => expected.um,
    };
    let budget = Budget::new(&design, &rows, &fitted, plan, opts, noise);
    let file = result_file(&design, &fitted, &budget, verdict, opts, &readings, noise);
    Ok(Outcome {
        file,
        u: budget.total(),
        u_noise: budget.noise_only(),
        design,
        fit: fitted,
        notes,
    })
}

fn check_options(o: &Options) -> Result<(), AnalyzeError> {
    let ok = |v: f64, hi: f64| v.is_finite() && (0.0..=hi).contains(&v);
    if !(ok(o.runout.um, 1000.0) && o.runout.phase_deg.is_finite()) {
        return Err(AnalyzeError::Request(format!(
            "run-out {} um at {} deg: expected 0 to 1000 um and a finite angle",
            o.runout.um, o.runout.phase_deg
        )));
    }
    for (what, v) in [
        ("u of the run-out", o.runout_u_um),
        ("u of the table ball's placement", o.placement_um),
    ] {
        if !ok(v, 1000.0) {
            return Err(AnalyzeError::Request(format!(
                "{what} {v} um: expected 0 to 1000 um"
            )));
        }
    }
    if let Some(n) = o.noise_um
        && !(n.is_finite() && n > 0.0 && n <= 100.0)
    {
        return Err(AnalyzeError::Request(format!(
            "--noise {n} um: expected more than 0 and at most 100 um"
        )));
    }
    Ok(())
}

/// For each setup of the plan, the index of its run: every setup one run,
/// every run a setup of the plan.
fn match_runs(
    plan: &BallBarManifest,
    plan_path: &Path,
    runs: &[(PathBuf, BallBarRun)],
) -> Result<Vec<usize>, AnalyzeError> {
    let mut by_setup: Vec<Option<usize>> = vec![None; plan.setups.len()];
    for (i, (path, run)) in runs.iter().enumerate() {
        let Some(k) = plan.setups.iter().position(|s| s.name == run.setup) else {
            return Err(AnalyzeError::Plan(format!(
                "{}: setup `{}` is not in the plan {} (its setups: {})",
                path.display(),
                crate::source::cut(&run.setup),
                plan_path.display(),
                plan.setups
                    .iter()
                    .map(|s| s.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        };
        if let Some(j) = by_setup[k] {
            return Err(AnalyzeError::Plan(format!(
                "{}: setup {} was measured already by {}: give one run per setup",
                path.display(),
                run.setup,
                runs[j].0.display()
            )));
        }
        by_setup[k] = Some(i);
    }
    let missing: Vec<&str> = plan
        .setups
        .iter()
        .zip(&by_setup)
        .filter(|(_, r)| r.is_none())
        .map(|(s, _)| s.name.as_str())
        .collect();
    if !missing.is_empty() {
        return Err(AnalyzeError::Plan(format!(
            "no run of setup{} {} of the plan {}: the analysis needs every setup's run (one file per setup, `setup: NAME` in it)",
            if missing.len() > 1 { "s" } else { "" },
            missing.join(", "),
            plan_path.display()
        )));
    }
    Ok(by_setup.into_iter().map(|r| r.expect("checked")).collect())
}

/// The linear-axis errors of an error file as a known model per arbor.
fn known_linear(
    design: &Design,
    machine: &Machine,
    f: &ErrorFile,
    path: &Path,
    src: &str,
    notes: &mut Vec<String>,
) -> Result<KnownLinear, AnalyzeError> {
    let mut models = Vec::new();
    let mut theta = Vec::new();
    for &g in &design.gauges {
        let kin = crate::kinematics::Kinematics::with_gauge_length(machine, g);
        let loaded = f.to_model(&kin, path, src)?;
        let keep: Vec<usize> = (0..loaded.model.effects.len())
            .filter(|&i| loaded.model.effects[i].is_linear_axis_error())
            .collect();
        theta = keep
            .iter()
            .flat_map(|&i| loaded.theta[loaded.model.param_range(i)].to_vec())
            .collect();
        let effects = keep
            .iter()
            .map(|&i| loaded.model.effects[i].clone())
            .collect();
        models.push(crate::model::Model::new(kin, effects));
    }
    let names = models[0].param_names();
    notes.push(if names.is_empty() {
        format!(
            "{} holds no linear-axis error (scale, squareness, straightness, positioning, angular): nothing taken out",
            path.display()
        )
    } else {
        format!(
            "the linear axes' errors of {} taken out at the positions the axes take ({}); its other entries are not used",
            path.display(),
            names.join(", ")
        )
    });
    Ok(KnownLinear { models, theta })
}

/// The contributors' shares of each parameter's variance.
struct Budget {
    /// Per contributor, its name and per parameter its variance.
    parts: Vec<(&'static str, Vec<f64>)>,
    seen: Vec<bool>,
}

impl Budget {
    fn new(
        d: &Design,
        rows: &[Reading],
        fit: &Fit,
        plan: &BallBarManifest,
        opts: &Options,
        noise: f64,
    ) -> Budget {
        let n = d.n_params();
        let g = &fit.gain;
        // Sums of the gain over groups of readings that one source moves
        // alike, weighted by the source's effect on each reading.
        let grouped = |key: &dyn Fn(&Reading) -> usize, weight: &dyn Fn(usize) -> f64| {
            let groups = rows.iter().map(key).max().map_or(0, |k| k + 1);
            let mut var = vec![0.0; n];
            for grp in 0..groups {
                let w = DVector::from_iterator(
                    rows.len(),
                    rows.iter()
                        .enumerate()
                        .map(|(j, r)| if key(r) == grp { weight(j) } else { 0.0 }),
                );
                let s = g * w;
                for (v, x) in var.iter_mut().zip(s.iter()) {
                    *v += x * x;
                }
            }
            var
        };
        let noise_var: Vec<f64> = (0..n)
            .map(|k| noise * noise * g.row(k).norm_squared())
            .collect();
        let mut bars: Vec<f64> = Vec::new();
        for s in &plan.setups {
            if !bars.iter().any(|b| (b - s.bar_mm).abs() < 1e-9) {
                bars.push(s.bar_mm);
            }
        }
        let bar_of = |r: &Reading| {
            let b = plan.setups[r.setup].bar_mm;
            bars.iter().position(|x| (x - b).abs() < 1e-9).unwrap_or(0)
        };
        let calibration = grouped(&bar_of, &|_| plan.calibration_um);
        let placement = grouped(&|r: &Reading| r.setup, &|_| opts.placement_um);
        let ro: Vec<[f64; 2]> = rows.iter().map(|r| d.runout_row(r)).collect();
        let runout: Vec<f64> = {
            let x = grouped(&|r: &Reading| r.gauge, &|j| ro[j][0] * opts.runout_u_um);
            let y = grouped(&|r: &Reading| r.gauge, &|j| ro[j][1] * opts.runout_u_um);
            x.iter().zip(&y).map(|(a, b)| a + b).collect()
        };
        Budget {
            parts: vec![
                ("bar noise", noise_var),
                ("bar calibration", calibration),
                ("table ball placement", placement),
                ("spindle-ball run-out", runout),
            ],
            seen: fit.seen.clone(),
        }
    }

    fn total(&self) -> Vec<Option<f64>> {
        (0..self.seen.len())
            .map(|k| self.seen[k].then(|| self.parts.iter().map(|p| p.1[k]).sum::<f64>().sqrt()))
            .collect()
    }

    fn noise_only(&self) -> Vec<Option<f64>> {
        (0..self.seen.len())
            .map(|k| self.seen[k].then(|| self.parts[0].1[k].sqrt()))
            .collect()
    }

    /// The three largest contributors of parameter `k`.
    fn largest(&self, k: usize) -> Vec<Share> {
        let total: f64 = self.parts.iter().map(|p| p.1[k]).sum();
        let mut v: Vec<Share> = self
            .parts
            .iter()
            .filter(|p| p.1[k] > 0.0 && total > 0.0)
            .map(|p| Share {
                contributor: p.0.to_string(),
                share: p.1[k] / total,
            })
            .collect();
        v.sort_by(|a, b| b.share.total_cmp(&a.share));
        v.truncate(3);
        v
    }
}

/// The symbol a parameter belongs to: a location error's name, a map's
/// symbol without its node.
fn symbol_of(name: &str) -> &str {
    name.strip_prefix("map.")
        .map_or(name, |m| m.split('@').next().unwrap_or(m))
}

/// What the readings do not see, per symbol, with why.
fn unseen(d: &Design, fit: &Fit) -> Vec<NotIdentified> {
    let names = d.model().param_names();
    let mut out: IndexMap<String, (usize, usize, Vec<String>)> = IndexMap::new();
    for (k, name) in names.iter().enumerate() {
        let e = out.entry(symbol_of(name).to_string()).or_default();
        e.1 += 1;
        if fit.seen[k] {
            continue;
        }
        e.0 += 1;
        // The others in a null direction with this parameter.
        for v in &fit.null {
            let big = v.amax();
            if v[k].abs() <= 1e-6 * big {
                continue;
            }
            for (j, other) in names.iter().enumerate() {
                let s = symbol_of(other).to_string();
                if j != k && v[j].abs() > 1e-3 * big && !e.2.contains(&s) && s != symbol_of(name) {
                    e.2.push(s);
                }
            }
        }
    }
    out.into_iter()
        .filter(|(_, (unseen, _, _))| *unseen > 0)
        .map(|(symbol, (unseen, all, with))| {
            let at = if all > 1 {
                format!("at {unseen} of its {all} angles ")
            } else {
                String::new()
            };
            /// Partners named before `and N more`.
            const NAMED: usize = 4;
            let reason = if with.is_empty() {
                format!("no ball-bar reading depends on it {at}(with the plan's setups)")
            } else {
                let more = with.len().saturating_sub(NAMED);
                format!(
                    "{at}the readings see it only in combination with {}{} (a null direction of the ball-bar readings)",
                    with[..with.len().min(NAMED)].join(", "),
                    if more > 0 { format!(" and {more} more") } else { String::new() }
                )
            };
            NotIdentified { symbol, reason }
        })
        .collect()
}

fn result_file(
    d: &Design,
    fit: &Fit,
    budget: &Budget,
    verdict: Option<FitSection>,
    opts: &Options,
    readings: &[Vec<f64>],
    noise: f64,
) -> ErrorFile {
    let model = d.model();
    let u = budget.total();
    let mut file = ErrorFile::from_model(model, &fit.theta, &u, &Noise::default());
    let not = unseen(d, fit);
    // Nothing unseen is written: no location error, no map with a node
    // the readings do not see.
    for n in &not {
        file.location_errors.shift_remove(&n.symbol);
        file.position_dependent.shift_remove(&n.symbol);
    }
    file.test = Some("ball-bar".into());
    file.not_identifiable = not;
    file.fit = verdict;
    let names = model.param_names();
    let mut values = IndexMap::new();
    for (k, name) in names.iter().enumerate() {
        let sym = symbol_of(name);
        let written =
            file.location_errors.contains_key(sym) || file.position_dependent.contains_key(sym);
        if let (true, Some(uk)) = (written, u[k]) {
            values.insert(
                name.clone(),
                ValueUncertainty {
                    u: uk,
                    u_noise: budget.noise_only()[k],
                    largest: budget.largest(k),
                    // Not split: a trend takes all of it as varying from
                    // run to run, which can only hide a drift.
                    u_random: None,
                },
            );
        }
    }
    file.uncertainty = Some(UncertaintySection {
        basis: format!(
            "the bar's noise ({noise:.3} um per reading) and calibration, the table ball's placement along the bar ({:.3} um per run) and the spindle ball's run-out as measured ({:.3} um per component), propagated in closed form through the fit's gain",
            opts.placement_um, opts.runout_u_um
        ),
        noise_um: noise,
        widened_by: None,
        not_included: vec![
            "the uncertainty of the linear-axis errors taken out".into(),
            "the spindle ball's gauge length (taken as set)".into(),
        ],
        values,
    });
    super::set_aside_not_useful(&mut file, model, &opts.usefulness);
    file.circularity = d
        .plan
        .setups
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let effect: Option<Vec<f64>> = (opts.runout.um > 0.0).then(|| {
                d.rows()
                    .iter()
                    .filter(|r| r.setup == k)
                    .map(|r| {
                        let zero = vec![0.0; d.n_params()];
                        d.predict(r, &zero, None, &opts.runout).0
                            - d.predict(r, &zero, None, &Runout::default()).0
                    })
                    .collect()
            });
            circularity::of_run(&s.name, &readings[k], effect.as_deref())
        })
        .collect();
    file
}

impl Outcome {
    /// The circularity figures, the verdict, what stays unseen, then the
    /// values: as `analyze` prints them.
    pub fn render(&self) -> String {
        use std::fmt::Write as _;
        let f = &self.file;
        let mut s = circularity::render(&f.circularity);
        s.push_str(&super::verdict::render(f.fit.as_ref()));
        for n in &self.notes {
            let _ = writeln!(s, "note: {n}");
        }
        let _ = writeln!(
            s,
            "design: {} readings, {} parameters, rank {} ({} Gauss-Newton steps)",
            self.fit.residuals.len(),
            self.design.n_params(),
            self.fit.rank,
            self.fit.steps
        );
        if !f.not_identifiable.is_empty() {
            let _ = writeln!(s, "not identified (no value is given for these):");
            for n in &f.not_identifiable {
                let _ = writeln!(s, "  {:<12} {}", n.symbol, n.reason);
            }
        }
        let sym = &self.design.model().symbols;
        if !f.location_errors.is_empty() {
            let _ = writeln!(s, "location errors (u, k = 1):");
            for (name, q) in &f.location_errors {
                let unit = sym
                    .location_index(name)
                    .map_or(String::new(), |k| sym.location[k].unit.to_string());
                let _ = writeln!(
                    s,
                    "  {:<12} {:>10.3} {unit:<5} u {:.3}",
                    name,
                    q.value,
                    q.u.unwrap_or(f64::NAN)
                );
            }
        }
        s.push_str(&super::result::render_not_useful(
            &f.seen_not_usefully,
            &|n| {
                sym.location_index(n)
                    .map_or(String::new(), |k| sym.location[k].unit.to_string())
            },
        ));
        if !f.position_dependent.is_empty() {
            let _ = writeln!(
                s,
                "error motions (maps over the angle: smallest, largest value and largest u):"
            );
            for (name, m) in &f.position_dependent {
                let v = flat(&m.values);
                let u = m.u.as_ref().map(flat).unwrap_or_default();
                let unit = sym
                    .map_index(name)
                    .map_or(String::new(), |k| sym.maps[k].unit.to_string());
                let _ = writeln!(
                    s,
                    "  {:<12} {:>9.3} .. {:>9.3} {unit:<5} u <= {:.3} ({} nodes)",
                    name,
                    v.iter().cloned().fold(f64::INFINITY, f64::min),
                    v.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
                    u.iter().cloned().fold(0.0, f64::max),
                    v.len()
                );
            }
        }
        if let Some(u) = &f.uncertainty {
            let _ = writeln!(s, "u holds {}", u.basis);
        }
        s
    }
}

fn flat(v: &crate::errorfile::Values) -> Vec<f64> {
    match v {
        crate::errorfile::Values::Flat(x) => x.clone(),
        crate::errorfile::Values::Rows(r) => r.iter().flatten().copied().collect(),
    }
}
