//! `analyze`: from the measurements of a planned test to its result. A
//! [`Request`] (the plan's manifest, the measured files, the method, the
//! maps, and whether to make a series, compare with an earlier result or
//! run a Monte-Carlo study) becomes an [`Outcome`]: per piece the joined
//! measurements, the identification, the reported uncertainties and the
//! result file, plus the series and comparison tables; or, for the
//! nine-section test, its statistics. Nothing is printed or written here:
//! [`result::write`] writes the result files, [`crate::report`] the HTML
//! report.
//!
//! The way through, module by module:
//! - [`inputs`]: the measured files read in whatever format and joined to
//!   the plan's points (also what `discover` and the demo read with);
//! - [`method`]: which identification runs, and with which forward model;
//! - [`preview`]: what a plan will identify, before anything is measured;
//! - [`goodness`]: whether the model explains the measurements as well as the
//!   instrument's noise allows, and what a result that does not must say;
//! - [`verdict`]: that judgement for every method on the raw measurements
//!   (every point against the complete model at the method's estimate),
//!   and whether the fit converged;
//! - [`uncertainty`]: the covariance each method reports and the
//!   Monte-Carlo study that replaces it on request;
//! - [`result`]: the result file, every entry of it added in one place;
//! - [`series`]: several pieces side by side, and an earlier result beside
//!   the new one;
//! - [`ball_bar`]: the ball bar under TCP, which has its own plan file and
//!   its own identification (the rotary axes' error motions per angle).

pub mod ball_bar;
pub mod goodness;
pub mod inputs;
pub mod iso230_2;
pub mod laser;
pub mod laser_identify;
pub mod method;
pub mod preview;
pub mod result;
pub mod series;
pub mod uncertainty;
pub mod usefulness;
pub mod verdict;

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use crate::errorfile::{ErrorFile, NotIdentified};
use crate::formats::detect::MeasuredOptions;
use crate::formats::manifest::TestKind;
use crate::identify::nine_section::NineSection;
use crate::identify::sphere::{CircleMethod, SphereOptions};
use crate::identify::{Dataset, Identification, IdentifyError, Method, Setup};
use crate::io::OutputError;
use crate::machine::MachineError;
use crate::procedure::{LoadError, Plan, Test};
use crate::source::SourceError;

pub use inputs::{Measurements, Pieces, PlanContext};
pub use series::{EarlierComparison, Series};
pub use uncertainty::{Contributors, McOptions, Study};

/// Why an analysis cannot run.
#[derive(Debug, thiserror::Error)]
pub enum AnalyzeError {
    /// A file of the plan or a measurement file is malformed, or belongs
    /// to another plan (file, line and column named).
    #[error(transparent)]
    Source(#[from] SourceError),
    /// The plan's copy of the machine file cannot be loaded.
    #[error("cannot load the plan's machine file {}", path.display())]
    Machine {
        /// The copy.
        path: PathBuf,
        /// Why.
        source: MachineError,
    },
    /// The plan directory or the files do not make an analysis (the
    /// message says which file and why).
    #[error("{0}")]
    Plan(String),
    /// The plan cannot be rebuilt from its manifest where the analysis
    /// needs it (a head machine's global fit).
    #[error(transparent)]
    Rebuild(#[from] LoadError),
    /// The request does not suit the plan (a method or maps the test
    /// cannot take).
    #[error("{0}")]
    Request(String),
    /// The method asked for does not suit the test.
    #[error(transparent)]
    Method(#[from] method::MethodError),
    /// The identification failed.
    #[error(transparent)]
    Identify(#[from] IdentifyError),
    /// The Monte-Carlo study failed.
    #[error("the Monte-Carlo study failed: {0}")]
    MonteCarlo(String),
    /// A result file cannot be written.
    #[error(transparent)]
    Output(#[from] OutputError),
}

/// Which contributors a Monte-Carlo study draws.
#[derive(Clone, Debug, PartialEq)]
pub enum ContributorChoice {
    /// The test's own: the machining study's table for a machined piece,
    /// the probing study's for on-machine probing.
    TestDefault,
    /// These.
    Given(Contributors),
    /// Measurement noise only, at the residual sigma of the fit.
    NoiseOnly,
}

impl ContributorChoice {
    /// The contributors of a test of `kind`: the test's own table drawn at
    /// the noise the fit is judged against (`stated_um`), so that the
    /// budget, a Monte-Carlo study and the verdict speak of one
    /// instrument; noise only at the fit's residual sigma `sigma_um`.
    pub fn resolve(&self, kind: TestKind, stated_um: f64, sigma_um: f64) -> Contributors {
        match self {
            ContributorChoice::TestDefault => Contributors {
                noise_um: stated_um,
                ..match kind {
                    TestKind::Machining => Contributors::seed001(),
                    TestKind::Probing => Contributors::seed000(),
                }
            },
            ContributorChoice::Given(c) => c.clone(),
            ContributorChoice::NoiseOnly => Contributors::noise_only(sigma_um),
        }
    }

    /// What the contributors are, in words.
    pub fn describe(&self, kind: TestKind) -> String {
        match (self, kind) {
            (ContributorChoice::TestDefault, TestKind::Machining) => {
                "the machining test's contributors (Ibaraki & Ota 2014, table 4: linear-axis positioning, straightness and squareness) and the measurement noise".into()
            }
            (ContributorChoice::TestDefault, TestKind::Probing) => {
                "the probing test's contributors (Ibaraki, Iritani & Matsushita 2013, table 4: linear-axis positioning, straightness, squareness and the test pieces' setup) and the measurement noise".into()
            }
            (ContributorChoice::Given(_), _) => "the contributors given with --contributors".into(),
            (ContributorChoice::NoiseOnly, _) => {
                "the measurement noise only, at the fit's residual sigma (--contributors noise)".into()
            }
        }
    }
}

/// A Monte-Carlo study asked for.
#[derive(Clone, Debug)]
pub struct MonteCarlo {
    /// Runs, seed, progress bar (each run draws the request's
    /// contributors).
    pub options: McOptions,
    /// Simulate and identify every run again rather than linearize
    /// ([`uncertainty::linear`]): the reference, slower by orders.
    pub exact: bool,
}

/// What to analyse, and how.
#[derive(Clone, Debug)]
pub struct Request {
    /// The plan manifest written by `fivecal plan`.
    pub manifest: PathBuf,
    /// The plan already rebuilt from that manifest, if the caller has it:
    /// its points are then used at full precision and nothing of the plan
    /// is read again.
    pub rebuilt: Option<Plan>,
    /// The measurement files (several make one piece unless `series`).
    pub measured: Vec<PathBuf>,
    /// The method; `None`: the test's own ([`method::default_for`]).
    pub method: Option<Method>,
    /// Error maps identified with the location errors (`EBB(B)`, ...).
    pub maps: Vec<String>,
    /// Each measured file is one piece of a series.
    pub series: bool,
    /// An earlier result to set beside this one.
    pub compare: Option<PathBuf>,
    /// The contributors every `u` holds (the budget's and a Monte-Carlo
    /// study's).
    pub contributors: ContributorChoice,
    /// A Monte-Carlo study replacing the budget's uncertainties.
    pub monte_carlo: Option<MonteCarlo>,
    /// The largest `u` a location error may have to count as identified
    /// (where the machine file gives no acceptance limit).
    pub usefulness: usefulness::Usefulness,
    /// How the sphere method fits the axis lines.
    pub circle: CircleMethod,
    /// The instrument's noise per measured point, um, that the fit is
    /// judged against; `None`: the instrument's default ([`goodness::ExpectedNoise`]).
    pub noise: Option<f64>,
    /// What the user said about the measurement files (run, units,
    /// encoding).
    pub options: MeasuredOptions,
}

impl Request {
    /// The analysis of `measured` against the plan of `manifest` with the
    /// test's own method and nothing else asked for.
    pub fn new(manifest: &Path, measured: Vec<PathBuf>) -> Request {
        Request {
            manifest: manifest.to_path_buf(),
            rebuilt: None,
            measured,
            method: None,
            maps: Vec::new(),
            series: false,
            compare: None,
            contributors: ContributorChoice::TestDefault,
            monte_carlo: None,
            usefulness: usefulness::Usefulness::default(),
            circle: CircleMethod::Robust,
            noise: None,
            options: MeasuredOptions::default(),
        }
    }
}

/// One identified piece.
#[derive(Clone, Debug)]
pub struct IdentifiedPiece {
    /// Its number in a series, from 1.
    pub number: Option<usize>,
    /// The measurements joined to the plan.
    pub data: Dataset,
    /// The identification.
    pub est: Identification,
    /// The uncertainties reported: the Monte-Carlo study's where it ran,
    /// else the covariance's.
    pub u: Vec<Option<f64>>,
    /// The Monte-Carlo study, if asked for.
    pub monte_carlo: Option<Study>,
    /// The verdict ([`verdict::of`]): how well the model at the method's
    /// estimate fits every measurement, or that the fit did not converge;
    /// `None` where nothing is left to judge it by (no degrees of freedom).
    pub fit: Option<crate::errorfile::FitSection>,
    /// The result file.
    pub file: ErrorFile,
}

impl IdentifiedPiece {
    /// The fit, if the model does not fit.
    pub fn misfit(&self) -> Option<&crate::errorfile::FitSection> {
        self.fit
            .as_ref()
            .filter(|f| f.verdict == crate::errorfile::FitVerdict::Misfit)
    }

    /// The fit, if it did not converge.
    pub fn not_converged(&self) -> Option<&crate::errorfile::FitSection> {
        self.fit
            .as_ref()
            .filter(|f| f.verdict == crate::errorfile::FitVerdict::NotConverged)
    }
}

impl IdentifiedPiece {
    /// The name of the piece: its (first) measurement file.
    pub fn name(&self) -> String {
        self.data.files[0].display().to_string()
    }

    /// Where its report goes under `dir` (a folder per piece in a series).
    pub fn report_dir(&self, dir: &Path) -> PathBuf {
        match self.number {
            Some(k) => dir.join(format!("piece{k}")),
            None => dir.to_path_buf(),
        }
    }
}

/// The identification of one piece or of a series.
#[derive(Clone, Debug)]
pub struct Identified {
    /// The test.
    pub test: Test,
    /// The pieces, in the order of the files.
    pub pieces: Vec<IdentifiedPiece>,
    /// With `series`: every piece side by side.
    pub series: Option<Series>,
    /// With `compare`: the earlier result beside the new ones.
    pub comparison: Option<EarlierComparison>,
}

/// The nine-section test's evaluation: section heights, no location error.
#[derive(Clone, Debug)]
pub struct NineSectionOutcome {
    /// The machine's name.
    pub machine: String,
    /// The statistics of each piece, by file.
    pub stats: Vec<(PathBuf, NineSection)>,
    /// From the first piece to the last, when there are several: the rate
    /// of improvement of AVG, MAX and RMS, % (`None` for a statistic that
    /// was zero on the first piece).
    pub improvement: Option<[Option<f64>; 3]>,
    /// Every location symbol, with why the test cannot identify it.
    pub not_identifiable: Vec<NotIdentified>,
}

/// What an analysis found.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// What the reader should know before the results (a probing plan
    /// that cannot be rebuilt, ...).
    pub warnings: Vec<String>,
    /// The results.
    pub found: Found,
}

/// The results of an analysis, by kind of test.
#[derive(Clone, Debug)]
pub enum Found {
    /// Location errors and maps identified.
    Identified(Identified),
    /// Nine-section statistics.
    NineSection(NineSectionOutcome),
}

/// Runs an analysis.
pub fn run(req: &Request) -> Result<Outcome, AnalyzeError> {
    let mut ctx = match &req.rebuilt {
        Some(plan) => PlanContext::from_plan(plan, &req.manifest),
        None => PlanContext::from_manifest(&req.manifest)?,
    };
    ctx.options = req.options;
    let method = req
        .method
        .unwrap_or(method::default_for(ctx.test, ctx.kin.machine().structure));
    method::check(method, ctx.test, ctx.kind, &req.maps)?;
    let measured = ctx.read(&req.measured)?;
    // What each file measures, by label, kept for the error path below.
    let labels: Vec<(PathBuf, Vec<(String, usize)>)> = measured
        .points
        .iter()
        .filter(|(_, set)| set.labeled)
        .map(|(path, set)| {
            (
                path.clone(),
                set.points
                    .iter()
                    .map(|m| (m.label.clone(), m.line))
                    .collect(),
            )
        })
        .collect();
    let found = find(req, &ctx, method, measured)
        .map_err(|e| blame_points_file(req, &ctx, &labels).unwrap_or(e))?;
    Ok(Outcome {
        warnings: ctx.warnings,
        found,
    })
}

/// Where a measurement names points the plan's points file lacks but the
/// plan itself (rebuilt from the template and machine copies) has, the
/// points file lost rows: the error names it, not the measurement. Only
/// on the error path, so a points file edited by hand still serves.
fn blame_points_file(
    req: &Request,
    ctx: &PlanContext,
    labels: &[(PathBuf, Vec<(String, usize)>)],
) -> Option<AnalyzeError> {
    let points = ctx.points.as_ref()?;
    let have: std::collections::HashSet<&str> =
        points.points.iter().map(|p| p.label.as_str()).collect();
    let unknown: Vec<(&Path, &str, usize)> = labels
        .iter()
        .flat_map(|(path, l)| {
            l.iter()
                .filter(|(label, _)| !have.contains(label.as_str()))
                .map(move |(label, line)| (path.as_path(), label.as_str(), *line))
        })
        .collect();
    if unknown.is_empty() {
        return None;
    }
    let plan = rebuilt(req).ok()?;
    let planned: std::collections::HashSet<String> = plan
        .plan_points()
        .points
        .into_iter()
        .map(|p| p.label)
        .collect();
    let lost: Vec<&(&Path, &str, usize)> = unknown
        .iter()
        .filter(|(_, label, _)| planned.contains(*label))
        .collect();
    let (path, label, line) = lost.first()?;
    let file = crate::formats::manifest::Manifest::read(&req.manifest)
        .ok()
        .and_then(|m| m.file(&req.manifest, "points"))
        .map_or_else(
            || "the plan's points file".to_string(),
            |p| p.display().to_string(),
        );
    Some(AnalyzeError::Plan(format!(
        "{file}: the plan's points file lacks {} point{} the plan has (rebuilt from its template and machine copies) and the measurement names (first: `{}`, {}:{line}); its {} rows are fewer than the plan's {}: rows were lost or cut from it; restore it or plan again",
        lost.len(),
        if lost.len() > 1 { "s" } else { "" },
        crate::source::cut(label),
        path.display(),
        points.points.len(),
        planned.len()
    )))
}

/// The results of the measurements read.
fn find(
    req: &Request,
    ctx: &PlanContext,
    method: Method,
    measured: inputs::Measurements,
) -> Result<Found, AnalyzeError> {
    let found = if !measured.heights.is_empty() {
        if !measured.points.is_empty() {
            return Err(AnalyzeError::Request(
                "nine-section heights and measured points cannot be analysed together".into(),
            ));
        }
        Found::NineSection(nine_section_heights(ctx, measured.heights)?)
    } else {
        let pieces: Vec<Vec<_>> = if req.series {
            measured.points.into_iter().map(|s| vec![s]).collect()
        } else {
            vec![measured.points]
        };
        if ctx.test == Test::NineSection {
            Found::NineSection(nine_section_points(ctx, &pieces)?)
        } else {
            Found::Identified(identify_pieces(req, ctx, method, &pieces)?)
        }
    };
    Ok(found)
}

/// The plan rebuilt from the manifest (or the caller's).
fn rebuilt(req: &Request) -> Result<Cow<'_, Plan>, LoadError> {
    match &req.rebuilt {
        Some(p) => Ok(Cow::Borrowed(p)),
        None => crate::procedure::load(&req.manifest).map(Cow::Owned),
    }
}

fn identify_pieces(
    req: &Request,
    ctx: &PlanContext,
    method: Method,
    pieces: &[Vec<(PathBuf, crate::formats::detect::PointSet)>],
) -> Result<Identified, AnalyzeError> {
    let sphere = SphereOptions {
        circle: req.circle,
        check: ctx.sphere_check,
    };
    let mut out = Vec::new();
    for (i, piece) in pieces.iter().enumerate() {
        let data = ctx.join(piece)?;
        let number = req.series.then_some(i + 1);
        out.push(identify_piece(req, ctx, method, &sphere, data, number)?);
    }
    let named: Vec<(String, ErrorFile)> = out.iter().map(|p| (p.name(), p.file.clone())).collect();
    let series = req.series.then(|| Series::new(&named));
    let comparison = match &req.compare {
        Some(path) => {
            let before = ErrorFile::load(path, &ctx.kin)?;
            let before =
                ErrorFile::from_model(&before.model, &before.theta, &before.u, &before.noise);
            Some(EarlierComparison::new(
                (path.display().to_string(), before),
                &named,
            ))
        }
        None => None,
    };
    Ok(Identified {
        test: ctx.test,
        pieces: out,
        series,
        comparison,
    })
}

fn identify_piece(
    req: &Request,
    ctx: &PlanContext,
    method: Method,
    sphere: &SphereOptions,
    data: Dataset,
    number: Option<usize>,
) -> Result<IdentifiedPiece, AnalyzeError> {
    let setup = Setup::new(&ctx.kin, &data.poses, &req.maps)?;
    // The complete measurement model of a model the rigid-pose models
    // refuse (a head machine) or of the sphere test is the simulator's
    // forward model of the plan: the global method inverts it, the sphere
    // method on a head machine is judged by it, and every method's verdict
    // is computed with it.
    let plan = if method::needs_plan(&setup.model, ctx.test) {
        match rebuilt(req) {
            Ok(p) => Some(p),
            // A table-table machine's rigid-pose models serve where the
            // plan cannot be rebuilt (a points file without its template):
            // the method and its verdict fall back to them, as the study
            // does, and the plan context's warning says so.
            Err(_) if !method::rigid_refuses(&setup.model) => None,
            Err(e) => return Err(e.into()),
        }
    } else {
        None
    };
    let mut est = method::identify_with_plan(method, &setup, &data, sphere, plan.as_deref())?;
    let judged = verdict::judged(
        &est,
        &setup,
        &data,
        ctx.test,
        plan.as_deref(),
        &goodness::ExpectedNoise::new(req.noise, data.kind, ctx.test),
    )?;
    let fit = judged.fit;
    // The global method's covariance is scaled by the verdict's residual
    // variance, so its u already carries the Birge ratio; another method's
    // is scaled by its own residuals and is widened to the verdict's; a
    // Monte-Carlo study draws at the stated noise and is widened below.
    let w = verdict::widening(&est, fit.as_ref());
    let mut u: Vec<Option<f64>> = est.u().into_iter().map(|u| u.map(|u| u * w)).collect();
    // The residuals shown (the table by pose and face, the report's plots)
    // are the verdict's: every point against the complete model, where a
    // method's own (a sphere per pose, a plane per station) hide what its
    // steps absorbed.
    est.residuals = judged.residuals;
    let stated = goodness::ExpectedNoise::new(req.noise, data.kind, ctx.test);
    let widened = goodness::widening(fit.as_ref());
    // Under a misfit the points scatter more than the instrument's noise:
    // the budget's noise is the residuals' then. The systematic
    // contributors are what they are whatever the fit; a Monte-Carlo
    // study, which draws at the stated noise, is widened by the ratio.
    let budget_noise = match fit.as_ref() {
        Some(f) if widened > 1.0 && f.sigma_um.is_finite() => f.sigma_um.max(stated.um),
        _ => stated.um,
    };
    let contributors = req
        .contributors
        .resolve(ctx.kind, budget_noise, est.sigma_um);
    // The budget and the Monte Carlo run the plan again on the simulator
    // when the plan can be rebuilt from its manifest (it always can for
    // what `fivecal plan` wrote); a points file without its template
    // leaves the Monte Carlo the synthetic model, and the study says so.
    let study_plan = match &plan {
        Some(p) => Ok(Cow::Borrowed(&**p)),
        None => rebuilt(req).map_err(|e| e.to_string()),
    };
    let estimate = uncertainty::Estimate {
        est: &est,
        setup: &setup,
        data: &data,
        sphere: *sphere,
    };
    let u_noise = u.clone();
    // The u printed beside a value holds every contributor the tool knows
    // for the test: the budget's closed form where the method's response
    // is linear (the global fit), else the noise alone, and the section
    // says why.
    let budget = uncertainty::budget_of(
        &estimate,
        study_plan.as_deref().map_err(Clone::clone),
        contributors.clone(),
    );
    if let Ok(b) = &budget {
        for (i, ui) in u.iter_mut().enumerate() {
            if est.identifiable(i) {
                *ui = Some(b.u(i));
            }
        }
    }
    let mut study = None;
    if let Some(mc) = &req.monte_carlo {
        let s = uncertainty::study(
            &mc.options,
            req.contributors.resolve(ctx.kind, stated.um, est.sigma_um),
            &estimate,
            study_plan.as_deref().map_err(Clone::clone),
            mc.exact,
        )
        .map_err(AnalyzeError::MonteCarlo)?;
        let mut s = s;
        s.widen(widened);
        u = s.u(&est);
        study = Some(s);
    }
    let mut explained = explain(
        &est,
        &u,
        &u_noise,
        &budget,
        &req.contributors.describe(ctx.kind),
        contributors.noise_um,
        study.as_ref(),
    );
    if study.is_none() && budget.is_ok() && budget_noise > stated.um {
        explained.basis += &format!(
            "; the noise taken at the residuals' {budget_noise:.3} um, not the stated {:.3} um, as the model does not fit",
            stated.um
        );
    }
    let mut file = result::error_file(&est, &u, data.kind);
    file.test = Some(ctx.test.to_string());
    file.fit = fit.clone();
    file.uncertainty = Some(explained);
    set_aside_not_useful(&mut file, &est.model, &req.usefulness);
    Ok(IdentifiedPiece {
        number,
        data,
        est,
        u,
        monte_carlo: study,
        fit,
        file,
    })
}

/// Moves every location error whose `u` exceeds its usefulness threshold
/// from the values to `seen_not_usefully:` ([`usefulness`]).
fn set_aside_not_useful(
    file: &mut ErrorFile,
    model: &crate::model::Model,
    useful: &usefulness::Usefulness,
) {
    let symbols = &model.symbols;
    let limits = &model.kin.machine().limits;
    let mut out = Vec::new();
    file.location_errors.retain(|name, q| {
        let unit = symbols
            .location_index(name)
            .ok()
            .map(|k| symbols.location[k].unit);
        let (Some(u), Some(unit)) = (q.u, unit) else {
            return true;
        };
        let t = useful.threshold(name, unit, limits);
        if u <= t.u {
            return true;
        }
        out.push(crate::errorfile::NotUseful {
            symbol: name.clone(),
            value: q.value,
            u,
            threshold: t.u,
            from: t.from,
        });
        false
    });
    file.seen_not_usefully = out;
}

/// The result's `uncertainty:` section: what the reported `u` holds and,
/// per identified value, the noise-only `u` beside it with the three
/// largest contributors of the budget.
fn explain(
    est: &Identification,
    u: &[Option<f64>],
    u_noise: &[Option<f64>],
    budget: &Result<uncertainty::Budget, String>,
    contributors: &str,
    noise_um: f64,
    study: Option<&Study>,
) -> crate::errorfile::UncertaintySection {
    use crate::errorfile::{Share, UncertaintySection, ValueUncertainty};
    let basis = match (study, budget) {
        (Some(s), _) => format!(
            "a Monte-Carlo study of {} runs drawing {contributors}",
            s.result.runs
        ),
        (None, Ok(_)) => format!(
            "{contributors}, propagated in closed form through the fit's first-order response"
        ),
        (None, Err(why)) => format!(
            "the measurement noise only (the fit's covariance): the other contributors cannot be propagated in closed form here ({why}); `--mc N` draws them"
        ),
    };
    let names = est.model.param_names();
    let mut values = indexmap::IndexMap::new();
    for (i, name) in names.iter().enumerate() {
        let Some(ui) = u[i].filter(|v| v.is_finite()) else {
            continue;
        };
        if !est.identifiable(i) {
            continue;
        }
        let largest = match budget {
            Ok(b) => b
                .largest(i, 3)
                .into_iter()
                .map(|(g, share)| Share {
                    contributor: g.name().to_string(),
                    share,
                })
                .collect(),
            Err(_) => Vec::new(),
        };
        values.insert(
            name.clone(),
            ValueUncertainty {
                u: ui,
                u_noise: u_noise[i].filter(|v| v.is_finite()),
                largest,
                // Where u is the budget's; a Monte Carlo's spread does not
                // split by contributor.
                u_random: match (study, budget) {
                    (None, Ok(b)) => Some(b.u_random(i)).filter(|v| v.is_finite()),
                    _ => None,
                },
            },
        );
    }
    UncertaintySection {
        basis,
        noise_um,
        widened_by: study.and_then(|s| s.widened),
        not_included: match (study, budget) {
            (Some(s), _) => s.not_included.clone(),
            (None, Ok(_)) => Contributors::unmapped()
                .iter()
                .map(|s| s.to_string())
                .collect(),
            (None, Err(_)) => Vec::new(),
        },
        values,
    }
}

/// Why the nine-section test identifies nothing, which its result says
/// rather than print numbers: it evaluates a machine (before and after a
/// compensation, say).
pub(crate) const NINE_SECTION_REASON: &str = "the nine-section test evaluates a machine, it does not calibrate one: its section heights \
     mix the location errors (`fivecal plan` shows how), and `analyze` reports their AVG, MAX and RMS to compare \
     before and after a compensation; identify with the stepped-square, column or sphere test";

fn nine_section_outcome(
    ctx: &PlanContext,
    stats: Vec<(PathBuf, NineSection)>,
) -> NineSectionOutcome {
    let improvement = (stats.len() > 1).then(|| {
        stats
            .last()
            .expect("several pieces")
            .1
            .improvement_over(&stats[0].1)
    });
    let not_identifiable = crate::kinematics::symbols::SymbolTable::for_kinematics(&ctx.kin)
        .location
        .iter()
        .map(|l| NotIdentified {
            symbol: l.name.clone(),
            reason: NINE_SECTION_REASON.into(),
        })
        .collect();
    NineSectionOutcome {
        machine: ctx.kin.machine().name.clone(),
        stats,
        improvement,
        not_identifiable,
    }
}

/// The nine-section statistics from measured heights, one file per piece.
fn nine_section_heights(
    ctx: &PlanContext,
    heights: Vec<(PathBuf, Vec<crate::formats::heights::SectionHeight>)>,
) -> Result<NineSectionOutcome, AnalyzeError> {
    if ctx.test != Test::NineSection {
        return Err(AnalyzeError::Plan(format!(
            "{}: section heights belong to a nine-section plan, this plan is `{}`",
            heights[0].0.display(),
            ctx.test
        )));
    }
    let planned = ctx.minutes.len();
    for (p, h) in &heights {
        check_sections(p, h, planned, &ctx.manifest)?;
    }
    let stats = heights
        .into_iter()
        .map(|(p, h)| {
            let s = NineSection::new(&h);
            (p, s)
        })
        .collect();
    Ok(nine_section_outcome(ctx, stats))
}

/// Refuses heights that do not cover the plan's sections (one per pose,
/// numbered from 1 in execution order) exactly: statistics over six of
/// nine sections, or over sections the plan does not cut, are not the
/// test's AVG, MAX and RMS.
fn check_sections(
    path: &std::path::Path,
    heights: &[crate::formats::heights::SectionHeight],
    planned: usize,
    manifest: &std::path::Path,
) -> Result<(), AnalyzeError> {
    /// Section numbers listed in a message before `and N more`.
    const LISTED: usize = 10;
    let list = |v: &[String]| {
        let mut s = v
            .iter()
            .take(LISTED)
            .cloned()
            .collect::<Vec<_>>()
            .join(", ");
        if v.len() > LISTED {
            s += &format!(" and {} more", v.len() - LISTED);
        }
        s
    };
    if planned == 0 {
        return Err(AnalyzeError::Plan(format!(
            "{}: the manifest lists no poses, so the sections {} should cover are not known",
            manifest.display(),
            path.display()
        )));
    }
    let extra: Vec<String> = heights
        .iter()
        .filter(|h| h.section as usize > planned)
        .map(|h| format!("{} (line {})", h.section, h.line))
        .collect();
    if !extra.is_empty() {
        return Err(AnalyzeError::Plan(format!(
            "{}: section{} {} not in the plan, which has {planned} sections (1 to {planned}, {}): heights of another piece or plan?",
            path.display(),
            if extra.len() > 1 { "s" } else { "" },
            list(&extra) + if extra.len() > 1 { " are" } else { " is" },
            manifest.display()
        )));
    }
    let missing: Vec<String> = (1..=planned as u32)
        .filter(|k| !heights.iter().any(|h| h.section == *k))
        .map(|k| k.to_string())
        .collect();
    if !missing.is_empty() {
        return Err(AnalyzeError::Plan(format!(
            "{}: {} of the plan's {planned} sections are listed; missing section{} {} (a file that lost its last lines?): the nine-section statistics need every section",
            path.display(),
            planned - missing.len(),
            if missing.len() > 1 { "s" } else { "" },
            list(&missing)
        )));
    }
    Ok(())
}

/// The nine-section statistics from the CMM's deviations of the nine
/// sections: heights relative to section 1, one file per piece.
fn nine_section_points(
    ctx: &PlanContext,
    pieces: &[Vec<(PathBuf, crate::formats::detect::PointSet)>],
) -> Result<NineSectionOutcome, AnalyzeError> {
    let mut stats = Vec::new();
    for piece in pieces {
        // Every planned point first (a file of a few points is named for
        // what it lacks), then joining checks labels and nominals against
        // the plan.
        if let Some(plan) = &ctx.points {
            for (path, set) in piece {
                NineSection::check_coverage(plan, set)
                    .map_err(|e| AnalyzeError::Plan(format!("{}: {e}", path.display())))?;
            }
        }
        let data = ctx.join(piece)?;
        for (path, set) in piece {
            let s = NineSection::from_deviations(&data.plan, set)
                .map_err(|e| AnalyzeError::Plan(format!("{}: {e}", path.display())))?;
            stats.push((path.clone(), s));
        }
    }
    Ok(nine_section_outcome(ctx, stats))
}
