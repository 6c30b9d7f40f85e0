//! `discover`: find where the model and the measurements disagree, name the
//! missing effect, add it, and show the gap shrink.
//!
//! Starting from a model (by default the location errors the test
//! identifies: the LAMDAMAP 2015 paper's question of which parameter sets a test can
//! identify, answered greedily in the order of docs/model.md), the loop fits the model,
//! measures the gap ([`gap`]: the residuals overall and by pose, face,
//! direction and sequence), and tries every candidate effect of the shared
//! catalogue ([`catalogue`]) in parallel: it checks that the candidate is
//! identifiable alongside the model (rank increase, the combinations the
//! test does not see, fixed at zero and named, the canonical and the
//! largest pairwise correlation with what the model already does), fits it
//! ([`fit`]: screened by one Gauss-Newton step from the current estimate,
//! iterated where it comes near significance), and tests the reduction of
//! the gap ([`stats`]: F-test with Bonferroni's adjustment over the
//! candidates of the round, and the BIC). The significant candidate with
//! the lowest BIC is then checked against every other significant one by
//! fitting both together (does each add to the other?); when the data
//! cannot tell two different effects apart, the discovery says so and
//! stops rather than pick one, saying whether they are exactly
//! indistinguishable on this test, and names the supplementary test that
//! would separate them ([`separate`]). Otherwise the effect is added and the
//! loop repeats until no candidate is significant. The measurements may be
//! those of several tests of one machine fitted together ([`Part`],
//! [`run_parts`]). The result is a [`Story`] ([`story`]) and the fits behind
//! it; [`report`] draws it.

pub mod catalogue;
pub mod fit;
pub mod gap;
pub mod inputs;
pub mod part;
pub mod report;
pub mod separate;
pub mod stats;
pub mod story;
pub mod suggest;

use std::sync::Arc;

use nalgebra::DMatrix;
use rayon::prelude::*;

use crate::analyze::goodness::ExpectedNoise;
use crate::errorfile::{AmbiguitySection, ErrorFile, Noise, NotIdentified, Quantity, RivalEntry};
use crate::formats::manifest::TestKind;
use crate::identify::identifiability::Combination;
use crate::identify::lsq::Design;
use crate::identify::{Dataset, Identification, Method, two_stage};
use crate::kinematics::Kinematics;
use crate::model::{DriftBasis, Effect, Model, PROBE_DIRECTIONS};
use crate::procedure::Plan;
use fit::Why;

pub use catalogue::{Candidate, Catalogue};
pub use fit::{Fit, FitError, Fitter, Part, Spec};
pub use gap::{Gap, GapSize};
pub use inputs::{InputError, Inputs};
pub use story::{CandidateVerdict, Story, Trial};

/// What a discovery is asked to do.
#[derive(Clone, Debug, PartialEq)]
pub struct DiscoverOptions {
    /// The starting model: `location` (the location errors the test
    /// identifies) and any candidate names.
    pub start: Vec<String>,
    /// Only these candidates (names or family prefixes: `drift`,
    /// `map.EBB(B)`, `scale`); empty: the whole catalogue.
    pub only: Vec<String>,
    /// Candidates left out (names or prefixes).
    pub exclude: Vec<String>,
    /// Significance level of a step (after the adjustment for the number
    /// of candidates tried).
    pub alpha: f64,
    /// At most this many steps.
    pub max_steps: usize,
    /// A candidate whose every new direction has a canonical correlation
    /// above this with what the model already does is refused as nearly
    /// aliased.
    pub near_alias: f64,
    /// Test name for the story.
    pub test: String,
    /// The instruments' noise per measured point, um (`--noise`; else each
    /// test's default): what a supplementary test's power is judged at.
    pub noise: Option<f64>,
}

impl Default for DiscoverOptions {
    fn default() -> Self {
        DiscoverOptions {
            start: vec!["location".into()],
            only: Vec::new(),
            exclude: Vec::new(),
            alpha: 0.01,
            max_steps: 12,
            near_alias: 0.999,
            test: String::new(),
            noise: None,
        }
    }
}

/// Why a discovery cannot run.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DiscoverError {
    /// A fit failed.
    #[error(transparent)]
    Fit(#[from] FitError),
    /// The starting model cannot be built.
    #[error("{0}")]
    Start(String),
    /// The options are not usable.
    #[error("{0}")]
    Options(String),
}

/// The story and the fits behind it.
#[derive(Clone, Debug)]
pub struct Discovery {
    /// The story.
    pub story: Story,
    /// The fit of the starting model, then the fit after each step.
    pub fits: Vec<Fit>,
    /// The tests fitted together: name, kind and number of points, in the
    /// order of the residuals.
    pub parts: Vec<(String, TestKind, usize)>,
}

impl Discovery {
    /// The fit of the starting model.
    pub fn start(&self) -> &Fit {
        &self.fits[0]
    }

    /// The final fit.
    pub fn end(&self) -> &Fit {
        self.fits.last().expect("a discovery has a starting fit")
    }

    /// The noise the final model's residuals should show: each part's
    /// instrument noise (`expected`, in the order of [`Discovery::parts`]),
    /// pooled over their points.
    pub fn expected(&self, expected: &[ExpectedNoise]) -> ExpectedNoise {
        let parts: Vec<(&str, &ExpectedNoise, usize)> = self
            .parts
            .iter()
            .zip(expected)
            .map(|((name, _, n), e)| (name.as_str(), e, *n))
            .collect();
        ExpectedNoise::pooled(&parts)
    }

    /// The final model as an identification (for the error file and the
    /// report).
    pub fn identification(&self, data: &Dataset) -> Identification {
        identification(self.end(), data)
    }

    /// The final model as an error file (docs/formats.md): every value the
    /// test identifies with its `u`; a value the test does not see is
    /// written without `u` (or left out, where absence means zero) and
    /// listed under `not_identifiable` with the reason, as is every
    /// combination of values it does not see.
    ///
    /// Its `fit:` section judges the final model against `expected`, the
    /// instrument's noise, which is also the noise it writes: what is left
    /// of the gap is the model's shortfall, not the instrument's scatter.
    /// After an ambiguity its `ambiguity:` section names the effects the
    /// measurements could not tell apart, none of which the model holds.
    ///
    /// `expected` holds each part's noise, in the order of [`Discovery::parts`]
    /// (one for a discovery on one test); several are pooled for the fit.
    pub fn error_file(&self, data: &Dataset, expected: &[ExpectedNoise]) -> ErrorFile {
        let f = self.end();
        let est = identification(f, data);
        let u: Vec<Option<f64>> = (0..f.n).map(|i| f.u(i)).collect();
        let mut file = est.error_file(Some(&u));
        let mut noise = Noise::default();
        for ((_, kind, _), e) in self.parts.iter().zip(expected) {
            let n = Noise::of_kind(*kind, e.um);
            noise.cmm = noise.cmm.or(n.cmm);
            noise.probe = noise.probe.or(n.probe);
        }
        file.effects.noise = Some(noise);
        file.fit = crate::analyze::goodness::of(&est, &self.expected(expected));
        file.ambiguity = self.story.ambiguity.as_ref().map(|a| AmbiguitySection {
            reason: a.reason.clone(),
            rivals: a
                .candidates
                .iter()
                .map(|c| RivalEntry {
                    effect: c.name.clone(),
                    gap_rms_um: c.gap_after.rms_um,
                    values: c
                        .values
                        .iter()
                        .map(|v| {
                            (
                                v.name.clone(),
                                Quantity {
                                    value: v.value,
                                    u: v.u,
                                },
                            )
                        })
                        .collect(),
                })
                .collect(),
            supplement: a.supplement.clone(),
            no_supplement: a.no_supplement.clone(),
        });
        for (ei, e) in f.spec.model.effects.iter().enumerate() {
            let r = f.spec.model.param_range(ei);
            for i in r.clone().filter(|&i| f.fixed(i)) {
                if let Effect::ProbePretravel = e {
                    let d = PROBE_DIRECTIONS[i - r.start];
                    file.effects.probe_pretravel.shift_remove(d);
                }
                file.not_identifiable.push(NotIdentified {
                    symbol: f.names[i].clone(),
                    reason: "this test does not see it: fixed at zero".into(),
                });
            }
            for (_, why) in f.spec.constraints[ei]
                .iter()
                .filter(|(_, w)| matches!(w, Why::Unseen(_)))
            {
                let why = why.to_string();
                if r.clone().any(|i| f.fixed(i)) && !why.contains(" + ") && !why.contains(" - ") {
                    continue;
                }
                file.not_identifiable.push(NotIdentified {
                    symbol: f.spec.names[ei].clone(),
                    reason: why,
                });
            }
        }
        file
    }
}

/// A fit as the identification's result type.
pub fn identification(f: &Fit, data: &Dataset) -> Identification {
    let n = f.n;
    // Pose fits for one test; of several, the residuals say it all.
    let placement = f.placements.first().copied().flatten();
    let poses = if f.placements.len() == 1 {
        two_stage::pose_fits(data, &f.spec.model.kin, placement.as_ref())
    } else {
        Vec::new()
    };
    let mut notes = Vec::new();
    if !f.converged {
        notes.push("the final fit stopped without converging".to_string());
    }
    Identification {
        method: Method::Global,
        model: f.spec.model.clone(),
        theta: f.theta().to_vec(),
        cov: f.cov(),
        cov_unit: f.cov_unit.view((0, 0), (n, n)).into_owned(),
        identifiability: f.identifiability(),
        sigma_um: f.sigma(),
        dof: f.dof(),
        residuals: f.residuals.clone(),
        poses,
        placement,
        notes,
        converged: f.converged,
        set_aside: Vec::new(),
    }
}

/// The values of effect `ei` of a fit.
fn effect_values(f: &Fit, ei: usize) -> Vec<story::FittedValue> {
    let r = f.spec.model.param_range(ei);
    let units = f.spec.model.param_units();
    r.map(|i| story::FittedValue {
        name: f.names[i].clone(),
        // No free direction moves a fixed value: what the fit left there
        // is round-off, which must not print as -0.000.
        value: if f.fixed(i) { 0.0 } else { f.x[i] },
        u: f.u(i),
        unit: units[i].clone(),
        note: if f.fixed(i) {
            Some("not seen by this test: fixed at zero".into())
        } else if !f.identifiable(i) {
            Some("not identifiable".into())
        } else {
            None
        },
    })
    .collect()
}

fn state(kin: &Kinematics, data: &Dataset, f: &Fit) -> story::State {
    story::State {
        model: f.spec.names.clone(),
        values: (0..f.spec.names.len())
            .flat_map(|ei| effect_values(f, ei))
            .collect(),
        gap: gap::gap(kin, data, &f.residuals),
        sigma_um: f.sigma(),
        dof: f.dof(),
    }
}

/// The best candidate of a round against its significant rivals.
#[derive(Default)]
struct Rivalry {
    rivals: Vec<(usize, story::Rival)>,
    /// Rivals the data cannot tell from the best.
    same: Vec<usize>,
    /// A rival that explains the best away.
    encompassed_by: Option<usize>,
}

/// A candidate tried against a model.
struct Tried {
    trial: Trial,
    /// The iterated fit (none for a candidate only screened).
    fit: Option<Fit>,
    /// The model with the candidate, its unseen combinations fixed, and
    /// its design.
    model: Option<Arc<Designed>>,
    /// Whether it was fitted (screened or iterated), not refused.
    fitted: bool,
}

fn refused(name: &str, reason: String) -> Tried {
    Tried {
        trial: Trial {
            name: name.to_string(),
            verdict: CandidateVerdict::Refused,
            reason: Some(reason),
            gap_after: None,
            test: None,
            p_adjusted: None,
            alongside: None,
        },
        fit: None,
        model: None,
        fitted: false,
    }
}

/// A candidate's model with the design its identifiability was judged on
/// (at the nominal machine) and its constraint basis: its fit starts from
/// them.
struct Designed {
    spec: Spec,
    design: Design,
    basis: DMatrix<f64>,
}

/// The singular values and left singular vectors of `m` (thin), without
/// the right ones, which a column space and the unseen combinations do not
/// need: the same bits as faer's `thin_svd` gives for them, at less work.
fn left_svd(m: &faer::Mat<f64>) -> Option<(Vec<f64>, faer::Mat<f64>)> {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::svd::{self, ComputeSvdVectors};
    let (r, c) = (m.nrows(), m.ncols());
    let k = r.min(c);
    let par = faer::get_global_parallelism();
    let req = svd::svd_scratch::<f64>(
        r,
        c,
        ComputeSvdVectors::Thin,
        ComputeSvdVectors::No,
        par,
        Default::default(),
    );
    let mut buf = MemBuffer::new(req);
    let mut s = faer::diag::Diag::<f64>::zeros(k);
    let mut u = faer::Mat::<f64>::zeros(r, k);
    svd::svd(
        m.as_ref(),
        s.as_mut(),
        Some(u.as_mut()),
        None,
        par,
        MemStack::new(&mut buf),
        Default::default(),
    )
    .ok()?;
    let s = s.column_vector();
    Some(((0..k).map(|i| s[i]).collect(), u))
}

/// Orthonormal basis (columns) of the column space of `a`, columns scaled
/// to unit length first, directions below `rtol` of the largest dropped.
pub(crate) fn column_space(a: &DMatrix<f64>, rtol: f64) -> DMatrix<f64> {
    let mut a = a.clone();
    for mut c in a.column_iter_mut() {
        let n = c.norm();
        if n > 0.0 {
            c /= n;
        }
    }
    if a.ncols() == 0 || a.nrows() == 0 {
        return DMatrix::zeros(a.nrows(), 0);
    }
    // faer's SVD without the right singular vectors: the span of a map's
    // columns (hundreds, and the rows of a supplementary test) is what
    // `separate` waits for, and nalgebra's unblocked SVD takes several
    // times as long. The basis is another of the same span.
    let (rows, cols) = a.shape();
    let k = rows.min(cols);
    let m = faer::Mat::<f64>::from_fn(rows, cols, |r, c| a[(r, c)]);
    let Some((s, u)) = left_svd(&m) else {
        // Non-finite columns span nothing to rely on.
        return DMatrix::zeros(rows, 0);
    };
    let smax = (0..k).fold(0.0f64, |a, i| a.max(s[i]));
    let keep: Vec<usize> = (0..k)
        .filter(|&i| s[i] > rtol * smax && smax > 0.0)
        .collect();
    DMatrix::from_fn(rows, keep.len(), |r, c| u[(r, keep[c])])
}

/// The model of a round, factorized once for every candidate tried on it.
struct Round {
    /// The linearized model for the scores ([`Fitter::score`]).
    screen: fit::Screen,
    /// Orthonormal basis of what the model and the nuisance do at the
    /// nominal machine, for the canonical correlations.
    others: DMatrix<f64>,
}

impl Round {
    fn new(fitter: &Fitter<'_>, base: &Fit) -> Result<Round, FitError> {
        Ok(Round {
            screen: fitter.screen(base)?,
            others: others(fitter, base),
        })
    }
}

/// Orthonormal basis of what `base`'s model and the nuisance do at the
/// nominal machine: the columns a candidate added to it is compared with
/// for the canonical correlation, the same for every candidate tried on
/// it, so made once for them all.
fn others(fitter: &Fitter<'_>, base: &Fit) -> DMatrix<f64> {
    let (basis, _) = base.spec.basis(fitter.extra());
    column_space(&(fitter.jacobian0(&base.spec) * &basis), 1e-9)
}

/// How a candidate's fit is made.
#[derive(Clone, Copy)]
enum Mode<'a> {
    /// Scored by the update of the round's factorization: one
    /// Gauss-Newton step from the base's estimate; with what the search
    /// keeps, if anything.
    Screen(&'a Round, Option<&'a Fits>),
    /// Iterated to convergence; with [`others`] of the base, and the fits
    /// the search keeps, if any.
    Exact(&'a DMatrix<f64>, Option<&'a Fits>),
}

/// The exact fits of candidates on a base, kept: the rivals of a step are
/// fitted beside the effect it adds, and the next round, on that model,
/// fits those candidates again, from the same start with the same design,
/// to the same bits. Each is keyed by the base's estimate (its bits) and
/// the names of the model fitted. Beside them, each candidate's
/// [`Prepared`] design on a model, keyed by the model's names and the
/// candidate's.
#[derive(Default)]
struct Fits {
    fits: Memo<FitKey, Result<Fit, FitError>>,
    designs: Memo<DesignKey, Result<Prepared, String>>,
    /// Kept for the whole search: it does not depend on the model.
    alone: AloneMemo,
}

type FitKey = (Vec<u64>, Vec<String>);

/// A model's names and a candidate's.
type DesignKey = (Vec<String>, String);

/// Values made once per key, shared between the threads of a round.
struct Memo<K, V>(std::sync::Mutex<std::collections::HashMap<K, V>>);

impl<K, V> Default for Memo<K, V> {
    fn default() -> Self {
        Memo(Default::default())
    }
}

impl<K: Eq + std::hash::Hash, V: Clone> Memo<K, V> {
    /// The value kept for `key`, or the one `make` makes (and kept).
    fn get_or(&self, key: K, make: impl FnOnce() -> V) -> V {
        if let Some(v) = self.0.lock().expect("not poisoned").get(&key) {
            return v.clone();
        }
        let v = make();
        self.0.lock().expect("not poisoned").insert(key, v.clone());
        v
    }

    /// Forgets the values whose key fails `keep`.
    fn retain(&self, keep: impl Fn(&K) -> bool) {
        self.0.lock().expect("not poisoned").retain(|k, _| keep(k));
    }

    #[cfg(test)]
    fn len(&self) -> usize {
        self.0.lock().expect("not poisoned").len()
    }
}

impl Fits {
    /// The fit of `spec` on `base`, made by `fit` unless kept.
    fn get_or(
        &self,
        base: &Fit,
        spec: &Spec,
        fit: impl FnOnce() -> Result<Fit, FitError>,
    ) -> Result<Fit, FitError> {
        let key = (
            base.x.iter().map(|v| v.to_bits()).collect(),
            spec.names.clone(),
        );
        self.fits.get_or(key, fit)
    }

    /// `cand` prepared on `base`'s model, by `prepare` unless kept.
    fn prepared(
        &self,
        base: &Fit,
        cand: &Candidate,
        prepare: impl FnOnce() -> Result<Prepared, String>,
    ) -> Result<Prepared, String> {
        let key = (base.spec.names.clone(), cand.name.clone());
        self.designs.get_or(key, prepare)
    }

    /// Forgets the fits and designs on any base but `base` (a map's fit
    /// holds megabytes).
    fn keep_on(&self, base: &Fit) {
        let bits: Vec<u64> = base.x.iter().map(|v| v.to_bits()).collect();
        self.fits.retain(|k| k.0 == bits);
        self.designs.retain(|k| k.0 == base.spec.names);
    }
}

/// Tries `cand` on top of `base`: identifiability alongside the model,
/// then the fit and the comparison. `near_alias`: refuse above this
/// canonical correlation (`None`: fit anyway, as the encompassing test
/// needs).
fn try_candidate(
    fitter: &Fitter<'_>,
    base: &Fit,
    cand: &Candidate,
    near_alias: Option<f64>,
    mode: Mode<'_>,
) -> Tried {
    let (qa, kept) = match mode {
        Mode::Screen(round, kept) => (&round.others, kept),
        Mode::Exact(others, kept) => (others, kept),
    };
    let prepared = match kept {
        Some(k) => k.prepared(base, cand, || {
            prepare(fitter, base, cand, qa, Some(&k.alone))
        }),
        None => prepare(fitter, base, cand, qa, None),
    };
    let Prepared { model, alongside } = match prepared {
        Ok(p) => p,
        Err(why) => return refused(&cand.name, why),
    };
    let canonical = alongside.canonical_correlation;
    let rank_increase = alongside.rank_increase;
    if let Some(limit) = near_alias
        && canonical > limit
    {
        let with = alongside
            .largest_correlation
            .as_ref()
            .map(|c| {
                format!(
                    "; largest correlation {:.4}, {} with {}",
                    c.value, c.parameter, c.with
                )
            })
            .unwrap_or_default();
        let mut t = refused(
            &cand.name,
            format!(
                "nearly aliased with the model: canonical correlation {canonical:.5} (limit {limit}){with}: the test cannot separate them"
            ),
        );
        t.trial.alongside = Some(alongside);
        return t;
    }
    let trial = |rss: f64, rank: usize, residuals: &[f64]| Trial {
        name: cand.name.clone(),
        verdict: CandidateVerdict::NotSignificant,
        reason: None,
        gap_after: Some(gap::size(residuals)),
        test: Some(stats::compare(fitter.len(), base.rss, base.rank, rss, rank)),
        p_adjusted: None,
        alongside: Some(alongside.clone()),
    };
    match mode {
        Mode::Screen(round, _) => {
            let s = fitter.score(&round.screen, &model.spec, rank_increase);
            Tried {
                trial: trial(s.rss, model.design.rank, &s.residuals),
                fit: None,
                model: Some(model),
                fitted: true,
            }
        }
        Mode::Exact(_, fits) => match exact(fitter, base, &model, fits, None) {
            Ok(f) => Tried {
                trial: trial(f.rss, f.rank, &f.residuals),
                fit: Some(f),
                model: Some(model),
                fitted: true,
            },
            Err(e) => refused(&cand.name, format!("the fit failed ({e})")),
        },
    }
}

/// The combinations of a candidate's values that the test does not see
/// even beside the nuisance alone (no model effect to trade against), and
/// its constraints extended to fix them. They are the same on every model
/// the candidate is tried on, so they are found once. A C-axis map has
/// hundreds of values of which the test sees a few dozen combinations:
/// with the rest fixed first, its design on each round's model has a few
/// dozen columns where it had hundreds, and only the combinations traded
/// against the model are left to find there. In exact arithmetic the free
/// directions, the rank and the fit are those of designing it whole.
struct Alone {
    constrained: fit::Constrained,
    unseen: Vec<Combination>,
}

/// Candidates with more values than this are designed on their own first
/// ([`Alone`]); fewer cost little designed whole, in one decomposition.
const ALONE_ABOVE: usize = 32;

/// [`Alone`] for each candidate, by name.
type AloneMemo = Memo<String, Result<Option<Arc<Alone>>, String>>;

/// [`Alone`] for `cand` if it has more than `above` values and the test
/// leaves some combination of them unseen, or why they cannot be found.
fn seen_alone(
    fitter: &Fitter<'_>,
    cand: &Candidate,
    above: usize,
) -> Result<Option<Arc<Alone>>, String> {
    let Some(spec) = fitter.extend(&fitter.location(&[]), cand) else {
        return Ok(None);
    };
    let ei = spec.names.len() - 1;
    let xr = spec.model.param_range(ei);
    if xr.len() <= above {
        return Ok(None);
    }
    let names = fitter.names(&spec);
    let (d, _, _) = fitter.design(&spec);
    if d.null.ncols() == 0 {
        return Ok(None);
    }
    let (unseen, rows) = unseen_rows(&d.null, xr.clone(), &names[xr])?;
    if rows.is_empty() {
        return Ok(None);
    }
    Ok(Some(Arc::new(Alone {
        constrained: spec.constrained(ei, rows),
        unseen,
    })))
}

/// The combinations of the parameters `xr` (named `names`) that the null
/// directions `null` (columns) hold: the column space of their rows, each
/// as a constraint row fixing it at zero.
fn unseen_rows(
    null: &DMatrix<f64>,
    xr: std::ops::Range<usize>,
    names: &[String],
) -> Result<(Vec<Combination>, Vec<fit::ConstraintRow>), String> {
    let named: std::sync::Arc<[String]> = names.to_vec().into();
    let mut unseen = Vec::new();
    let mut rows = Vec::new();
    // The candidate's rows of the null directions: their column space
    // is what the test does not see of it. faer's thin SVD, since the
    // C-axis maps make this hundreds by hundreds.
    let vc = null.rows(xr.start, xr.len());
    let m = faer::Mat::<f64>::from_fn(vc.nrows(), vc.ncols(), |i, j| vc[(i, j)]);
    let Some((sv, u)) = left_svd(&m) else {
        return Err("the candidate's unseen combinations could not be computed".to_string());
    };
    for i in 0..sv.len() {
        if sv[i] > 1e-6 {
            // A singular vector's sign is arbitrary: the largest
            // coefficient is made positive, so the name reads the same
            // whichever solver made it.
            let mut row: Vec<f64> = (0..u.nrows()).map(|r| u[(r, i)]).collect();
            let lead = row
                .iter()
                .fold(0.0f64, |a, &b| if b.abs() > a.abs() { b } else { a });
            if lead < 0.0 {
                row.iter_mut().for_each(|x| *x = -*x);
            }
            let what = Combination::new(row.clone(), named.clone());
            unseen.push(what.clone());
            rows.push((row, Why::Unseen(what)));
        }
    }
    Ok((unseen, rows))
}

/// What trying a candidate on a model finds before any fit: its design
/// with the combinations the test does not see fixed, and how it stands
/// alongside the model; or why it is refused. The design is at the
/// nominal machine, so this depends on the base's model alone, not on its
/// estimate: a rival tried beside a step's effect is the next round's
/// candidate on that model, designed once for both.
#[derive(Clone)]
struct Prepared {
    model: Arc<Designed>,
    alongside: story::Alongside,
}

/// [`Prepared`] for `cand` on `base`, or why it is refused; `qa`:
/// [`others`] of `base`; `alone`: where [`seen_alone`] is kept, if
/// anywhere.
fn prepare(
    fitter: &Fitter<'_>,
    base: &Fit,
    cand: &Candidate,
    qa: &DMatrix<f64>,
    alone: Option<&AloneMemo>,
) -> Result<Prepared, String> {
    let Some(mut spec) = fitter.extend(&base.spec, cand) else {
        return Err("the forward model cannot apply it".into());
    };
    let ei = spec.names.len() - 1;
    let xr = spec.model.param_range(ei);
    let names = fitter.names(&spec);
    let cand_names: Vec<String> = names[xr.clone()].to_vec();
    let alone = match alone {
        Some(kept) => kept.get_or(cand.name.clone(), || seen_alone(fitter, cand, ALONE_ABOVE)),
        None => seen_alone(fitter, cand, ALONE_ABOVE),
    }?;
    let alone = alone.as_deref();
    if let Some(a) = alone {
        spec.apply(ei, &a.constrained);
    }
    let (mut d, mut basis, mut ranges) = fitter.design(&spec);
    if d.rank <= base.rank {
        let setup = spec.setup();
        let rep = crate::identify::identifiability::report(
            &d,
            fitter.len(),
            spec.model.n_params(),
            &names,
            &setup.constraint_names,
        );
        let why: Vec<String> = rep
            .null_combinations
            .iter()
            .filter(|c| cand_names.iter().any(|n| c.contains(n.as_str())))
            .cloned()
            .collect();
        return Err(if why.is_empty() {
            "no measurement of this test sees it".to_string()
        } else {
            format!("not identifiable alongside the model: {}", why.join("; "))
        });
    }
    // Combinations of the candidate's parameters that the test does not
    // see (alone or traded against the model's) are fixed at zero, each
    // named: what is left is what the test identifies. Those it does not
    // see alone, if found beforehand, are fixed already.
    let mut unseen = alone.map(|a| a.unseen.clone()).unwrap_or_default();
    let mut rows = Vec::new();
    if d.null.ncols() > 0 {
        let (u, r) = unseen_rows(&d.null, xr.clone(), &cand_names)?;
        unseen.extend(u);
        rows = r;
    }
    if !rows.is_empty() {
        spec.constrain(ei, rows);
        (d, basis, ranges) = fitter.design(&spec);
    }
    let rank_increase = d.rank.saturating_sub(base.rank);
    // Canonical correlation of the candidate's free directions with
    // everything else (model and nuisance), in the scaled design.
    let zc = ranges[ei].clone();
    let j0 = fitter.jacobian0(&spec);
    let b = j0.columns(xr.start, xr.len()) * basis.view((xr.start, zc.start), (xr.len(), zc.len()));
    let qb = column_space(&b, 1e-9);
    let canonical = if qa.ncols() == 0 || qb.ncols() == 0 {
        0.0
    } else {
        (qa.transpose() * &qb).singular_values().max().min(1.0)
    };
    let mut largest: Option<story::Correlation> = None;
    for i in xr.clone() {
        let vi = d.cov_unit[(i, i)];
        if vi <= 0.0 {
            continue;
        }
        for j in (0..names.len()).filter(|j| !xr.contains(j)) {
            let vj = d.cov_unit[(j, j)];
            if vj <= 0.0 {
                continue;
            }
            let c = d.cov_unit[(i, j)] / (vi * vj).sqrt();
            if stronger(c, largest.as_ref()) {
                largest = Some(story::Correlation {
                    parameter: names[i].clone(),
                    with: names[j].clone(),
                    value: c,
                });
            }
        }
    }
    let alongside = story::Alongside {
        parameters: xr.len(),
        rank_increase,
        canonical_correlation: canonical,
        largest_correlation: largest,
        unseen,
        condition: d.condition,
    };
    Ok(Prepared {
        model: Arc::new(Designed {
            spec,
            design: d,
            basis,
        }),
        alongside,
    })
}

/// How much stronger (relatively) a correlation must be to be named in
/// place of one found before it: far above the round-off of the
/// covariance (parts in 10^13 here), far below the four decimals shown.
const STRONGER_BY: f64 = 1e-9;

/// Whether correlation `c` is named in place of `best`. Among pairs
/// equally correlated (the nodes of a map that the test sees alike, the
/// pre-travels of opposite directions) the first in parameter order is
/// named, whatever round-off makes of their last bits.
fn stronger(c: f64, best: Option<&story::Correlation>) -> bool {
    best.is_none_or(|l| c.abs() > l.value.abs() * (1.0 + STRONGER_BY))
}

/// The exact fit of `spec` (`base` with one effect appended), from the
/// base's estimate with the new effect at zero; `screen`: the round of
/// `base`, whose linearization is where the fit starts.
fn exact(
    fitter: &Fitter<'_>,
    base: &Fit,
    model: &Designed,
    fits: Option<&Fits>,
    screen: Option<&fit::Screen>,
) -> Result<Fit, FitError> {
    let fit = || {
        let added = model.spec.model.n_params() - base.n;
        let mut start = base.theta().to_vec();
        start.extend(std::iter::repeat_n(0.0, added));
        start.extend_from_slice(&base.x[base.n..]);
        fitter.fit_designed(
            &model.spec,
            model.design.clone(),
            &model.basis,
            Some(start),
            screen,
        )
    };
    match fits {
        Some(kept) => kept.get_or(base, &model.spec, fit),
        None => fit(),
    }
}

/// A screened candidate fitted exactly: the same identifiability, the fit
/// and the comparison of the iterated fit.
fn refit(
    fitter: &Fitter<'_>,
    base: &Fit,
    screened: Tried,
    fits: &Fits,
    screen: &fit::Screen,
) -> Tried {
    let Some(model) = screened.model else {
        return screened;
    };
    match exact(fitter, base, &model, Some(fits), Some(screen)) {
        Ok(f) => Tried {
            trial: Trial {
                gap_after: Some(gap::size(&f.residuals)),
                test: Some(stats::compare(
                    fitter.len(),
                    base.rss,
                    base.rank,
                    f.rss,
                    f.rank,
                )),
                ..screened.trial
            },
            fit: Some(f),
            model: Some(model),
            fitted: true,
        },
        Err(e) => refused(&screened.trial.name, format!("the fit failed ({e})")),
    }
}

fn selected(c: &Candidate, opts: &DiscoverOptions, sym: &Model) -> bool {
    let id = c.effect.id(&sym.symbols);
    let hit = |p: &String| c.matches(p, &id);
    (opts.only.is_empty() || opts.only.iter().any(hit)) && !opts.exclude.iter().any(hit)
}

/// The starting model: the location errors the test identifies (those it
/// does not are left out, with the reason), then any named candidates.
fn start(
    fitter: &Fitter<'_>,
    kin: &Kinematics,
    cat: &Catalogue,
    names: &[String],
    notes: &mut Vec<String>,
) -> Result<Fit, DiscoverError> {
    let model = Model::new(kin.clone(), Vec::new());
    if !names.iter().any(|n| n == "location") {
        return Err(DiscoverError::Start(
            "the starting model needs `location`: every other effect is added to the location errors".into(),
        ));
    }
    // The LAMDAMAP 2015 paper's question, answered greedily in the order of docs/model.md: the largest
    // set of location symbols the test identifies together. A symbol that
    // adds no direction to those kept is left out; what it does is carried
    // by the kept ones it is aliased with.
    let all: Vec<usize> = (0..model.symbols.location.len()).collect();
    let spec_all = fitter.location(&all);
    let j = fitter.jacobian0(&spec_all);
    let rank_of = |cols: &[usize]| -> usize {
        let a = DMatrix::from_fn(j.nrows(), cols.len(), |r, c| j[(r, cols[c])]);
        column_space(&a, fitter.opts.rank_rtol).ncols()
    };
    let mut kept: Vec<usize> = Vec::new();
    let mut cols: Vec<usize> = (all.len()..j.ncols()).collect();
    let mut rank = rank_of(&cols);
    for &i in &all {
        cols.push(i);
        let r = rank_of(&cols);
        if r > rank {
            kept.push(i);
            rank = r;
        } else {
            cols.pop();
        }
    }
    if kept.len() < all.len() {
        let (d, _, _) = fitter.design(&spec_all);
        let rep = crate::identify::identifiability::report(
            &d,
            fitter.len(),
            all.len(),
            &fitter.names(&spec_all),
            &[],
        );
        for &i in all.iter().filter(|i| !kept.contains(i)) {
            let name = &model.symbols.location[i].name;
            let why = rep
                .null_combinations
                .iter()
                .find(|c| c.contains(name.as_str()))
                .cloned()
                .unwrap_or_else(|| "no measurement of this test sees it".into());
            notes.push(format!(
                "{name} is left out of the starting model: this test does not separate it from the symbols kept ({why})"
            ));
        }
    }
    let spec = fitter.location(&kept);
    let mut fit = fitter.fit(&spec, None)?;
    for n in names.iter().filter(|n| *n != "location") {
        let Some(c) = cat.candidates.iter().find(|c| &c.name == n) else {
            let known: Vec<&str> = cat.candidates.iter().map(|c| c.name.as_str()).collect();
            return Err(DiscoverError::Start(format!(
                "`{n}` is not a candidate of this test: expected `location` or one of {}",
                known.join(", ")
            )));
        };
        let t = try_candidate(
            fitter,
            &fit,
            c,
            None,
            Mode::Exact(&others(fitter, &fit), None),
        );
        match t.fit {
            Some(f) => fit = f,
            None => {
                return Err(DiscoverError::Start(format!(
                    "cannot start with `{n}`: {}",
                    t.trial.reason.unwrap_or_default()
                )));
            }
        }
    }
    Ok(fit)
}

/// Runs a discovery on the measurements of one test, fitted with the
/// simulator's general forward model when the plan is given (else with
/// the rigid-pose models, which serve location errors, maps and drift).
pub fn run(
    kin: &Kinematics,
    data: &Dataset,
    plan: Option<&Plan>,
    opts: &DiscoverOptions,
) -> Result<Discovery, DiscoverError> {
    run_parts(
        &[Part {
            kin,
            data,
            plan,
            label: &opts.test,
        }],
        opts,
    )
}

/// The measurements of several parts seen as one dataset, for the gap's
/// breakdowns and the report: their points, poses and files one after the
/// other, each pose and point named `label:id` when there are several.
pub fn merged(parts: &[Part<'_>]) -> Dataset {
    let mut out = parts[0].data.clone();
    if parts.len() == 1 {
        return out;
    }
    let named = |label: &str, id: &str| format!("{label}:{id}");
    out.plan.points.clear();
    out.obs.clear();
    out.poses.clear();
    out.files.clear();
    out.warnings.clear();
    out.pieces.clear();
    out.piece_of.clear();
    for part in parts {
        let d = part.data;
        let (np, no, nf, npc) = (
            out.plan.points.len(),
            out.obs.len(),
            out.files.len(),
            out.pieces.len(),
        );
        out.plan.points.extend(
            d.plan
                .points
                .iter()
                .map(|p| crate::formats::points::PlanPoint {
                    label: named(part.label, &p.label),
                    pose: named(part.label, &p.pose),
                    ..p.clone()
                }),
        );
        out.obs
            .extend(d.obs.iter().map(|o| crate::identify::data::Observation {
                plan: o.plan + np,
                file: o.file + nf,
                ..o.clone()
            }));
        out.poses
            .extend(d.poses.iter().map(|p| crate::identify::data::Pose {
                id: named(part.label, &p.id),
                obs: p.obs.iter().map(|k| k + no).collect(),
                ..p.clone()
            }));
        out.files.extend(d.files.iter().cloned());
        out.warnings
            .extend(d.warnings.iter().map(|w| named(part.label, w)));
        out.pieces
            .extend(d.pieces.iter().map(|p| named(part.label, p)));
        out.piece_of.extend(d.piece_of.iter().map(|i| i + npc));
    }
    out
}

/// Runs a discovery on the measurements of one test or of several tests
/// of one machine fitted together (`parts`; a test and the supplementary
/// test its ambiguity asked for): one model, each part with its own
/// forward model and nuisance.
pub fn run_parts(parts: &[Part<'_>], opts: &DiscoverOptions) -> Result<Discovery, DiscoverError> {
    check_parts(parts, opts)?;
    let kin = parts[0].kin;
    let view = merged(parts);
    let data = &view;
    let cat = catalogue::catalogue(parts);
    let mut notes = cat.notes.clone();
    let model0 = Model::new(kin.clone(), Vec::new());
    check_names(opts, &cat, &model0)?;
    // The catalogue model holds the candidates the search may try and those
    // the start names.
    let wanted: Vec<Candidate> = cat
        .candidates
        .iter()
        .filter(|c| selected(c, opts, &model0) || opts.start.contains(&c.name))
        .cloned()
        .collect();
    let (fitter, unserved) = Fitter::new(parts, &wanted)?;
    let unserved: std::collections::HashMap<String, String> = unserved.into_iter().collect();
    let current = start(&fitter, kin, &cat, &opts.start, &mut notes)?;
    let start_state = state(kin, data, &current);
    let ctx = Search {
        parts,
        data,
        fitter: &fitter,
        cat: &cat,
        model0: &model0,
        unserved: &unserved,
        opts,
        fits: Fits::default(),
    };
    let Searched {
        current,
        fits,
        mut steps,
        ambiguity,
        stop,
        last_round,
    } = ctx.search(current)?;
    let ambiguous: Vec<String> = ambiguity
        .as_ref()
        .map(|a: &story::Ambiguity| a.candidates.iter().map(|c| c.name.clone()).collect())
        .unwrap_or_default();
    mark_added(&mut steps, &last_round, &ambiguous);
    let end_state = state(kin, data, &current);
    part_notes(parts, &mut notes);
    let story = Story {
        test: opts.test.clone(),
        machine: kin.machine().name.clone(),
        points: fitter.len(),
        poses: data.poses.len(),
        alpha: opts.alpha,
        start: start_state,
        steps,
        end: end_state,
        stop,
        ambiguity,
        last_round,
        notes,
    };
    Ok(Discovery {
        story,
        fits,
        parts: parts
            .iter()
            .map(|p| (p.label.to_string(), p.data.kind, p.data.obs.len()))
            .collect(),
    })
}

/// Refuses a discovery without measurements, over several machines or
/// with a level outside (0, 1).
fn check_parts(parts: &[Part<'_>], opts: &DiscoverOptions) -> Result<(), DiscoverError> {
    let Some(first) = parts.first() else {
        return Err(DiscoverError::Options(
            "a discovery needs the measurements of one test at least".into(),
        ));
    };
    let kin = first.kin;
    if let Some(p) = parts
        .iter()
        .find(|p| p.kin.machine().name != kin.machine().name)
    {
        return Err(DiscoverError::Options(format!(
            "the tests measure different machines (`{}` and `{}`): a discovery fits one machine",
            kin.machine().name,
            p.kin.machine().name
        )));
    }
    if !(opts.alpha > 0.0 && opts.alpha < 1.0) {
        return Err(DiscoverError::Options(format!(
            "alpha must lie between 0 and 1, not {}",
            opts.alpha
        )));
    }
    Ok(())
}

/// Refuses an `--only` or `--exclude` name that matches no candidate of
/// the catalogue.
fn check_names(
    opts: &DiscoverOptions,
    cat: &Catalogue,
    model0: &Model,
) -> Result<(), DiscoverError> {
    for n in opts.only.iter().chain(&opts.exclude) {
        if !cat
            .candidates
            .iter()
            .any(|c| c.matches(n, &c.effect.id(&model0.symbols)))
        {
            return Err(DiscoverError::Options(format!(
                "`{n}` names no candidate of this test: expected one of {}",
                cat.candidates
                    .iter()
                    .map(|c| c.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
    }
    Ok(())
}

/// The notes on the parts themselves: probing pieces set up separately,
/// several tests fitted together.
fn part_notes(parts: &[Part<'_>], notes: &mut Vec<String>) {
    for p in parts {
        let d = p.data;
        if d.kind == TestKind::Probing && d.pieces.len() > 1 {
            notes.push(format!(
                "{}{} separately set-up pieces, each with its own setup (nuisance)",
                if parts.len() > 1 {
                    format!("{}: ", p.label)
                } else {
                    String::new()
                },
                d.pieces.len()
            ));
        }
    }
    if parts.len() > 1 {
        notes.push(format!(
            "{} tests fitted together ({}): one model, each test with its own nuisance; their residuals weigh alike",
            parts.len(),
            parts
                .iter()
                .map(|p| format!("{}, {} points", p.label, p.data.obs.len()))
                .collect::<Vec<_>>()
                .join("; ")
        ));
    }
}

/// What the search works with, fixed for all its rounds.
struct Search<'a, 'p> {
    parts: &'a [Part<'p>],
    /// The measurements of all parts as one dataset.
    data: &'a Dataset,
    fitter: &'a Fitter<'p>,
    cat: &'a Catalogue,
    /// The machine's symbols, without effects.
    model0: &'a Model,
    /// Why the forward model cannot serve a candidate, by name.
    unserved: &'a std::collections::HashMap<String, String>,
    opts: &'a DiscoverOptions,
    /// The exact fits on the current model.
    fits: Fits,
}

/// Where the search ended.
struct Searched {
    /// The final model's fit.
    current: Fit,
    /// The start's fit and each step's.
    fits: Vec<Fit>,
    steps: Vec<story::Step>,
    ambiguity: Option<story::Ambiguity>,
    /// Why the search stopped.
    stop: String,
    /// The trials of the round that added nothing.
    last_round: Vec<Trial>,
}

/// One round's candidates and what came of trying each (`tried[i]` is
/// `pool[i]`).
struct Roundup<'c> {
    pool: Vec<&'c Candidate>,
    tried: Vec<Tried>,
    /// How many were fitted: the round's multiplicity for the adjustment.
    m: usize,
}

impl<'a, 'p> Search<'a, 'p> {
    /// The rounds from `current`: each adds the best significant
    /// candidate, until none is, the best is ambiguous, or the step limit.
    fn search(&self, mut current: Fit) -> Result<Searched, DiscoverError> {
        let opts = self.opts;
        let mut fits = vec![current.clone()];
        let mut steps: Vec<story::Step> = Vec::new();
        loop {
            let round = self.round(&current)?;
            let sig = round.significant();
            if sig.is_empty() {
                return Ok(Searched {
                    stop: round.none_significant(opts.alpha),
                    last_round: round.tried.into_iter().map(|t| t.trial).collect(),
                    current,
                    fits,
                    steps,
                    ambiguity: None,
                });
            }
            let (best, r) = self.choose(&round, &sig);
            let same: Vec<usize> = r
                .same
                .iter()
                .copied()
                .filter(|&c| self.id_of(&round, c) != self.id_of(&round, best))
                .collect();
            let rivals = self.rivals_worded(&round, best, &r);
            let bf = round.tried[best].fit.clone().expect("tested");
            let before = gap::gap(self.parts[0].kin, self.data, &current.residuals);
            if !same.is_empty() {
                let (ambiguity, stop) = self.ambiguity(&round, &current, best, &same, &r, &before);
                return Ok(Searched {
                    stop,
                    last_round: round.tried.into_iter().map(|t| t.trial).collect(),
                    current,
                    fits,
                    steps,
                    ambiguity: Some(ambiguity),
                });
            }
            steps.push(self.step(&round, steps.len() + 1, best, &bf, &before, rivals));
            current = bf;
            fits.push(current.clone());
            if steps.len() >= opts.max_steps {
                return Ok(Searched {
                    stop: format!("stopped after {} steps (--max-steps)", opts.max_steps),
                    last_round: Vec::new(),
                    current,
                    fits,
                    steps,
                    ambiguity: None,
                });
            }
        }
    }

    /// One round on `current`: every candidate not in it screened by one
    /// Gauss-Newton step from the current estimate; those that come near
    /// significance (adjusted p below 100 alpha) fitted again, iterated;
    /// then each judged at the adjusted level.
    fn round(&self, current: &Fit) -> Result<Roundup<'a>, DiscoverError> {
        let opts = self.opts;
        let pool: Vec<&Candidate> = self
            .cat
            .candidates
            .iter()
            .filter(|c| current.spec.find(&c.name).is_none())
            .filter(|c| selected(c, opts, self.model0))
            .collect();
        self.fits.keep_on(current);
        let round = Round::new(self.fitter, current)?;
        let mut tried: Vec<Tried> = pool
            .par_iter()
            .map(|c| match self.unserved.get(&c.name) {
                Some(why) => refused(&c.name, why.clone()),
                None => try_candidate(
                    self.fitter,
                    current,
                    c,
                    Some(opts.near_alias),
                    Mode::Screen(&round, Some(&self.fits)),
                ),
            })
            .collect();
        let m = tried.iter().filter(|t| t.fitted).count();
        self.refit_near(current, &round.screen, &mut tried, m);
        judge(&mut tried, m, opts.alpha);
        Ok(Roundup { pool, tried, m })
    }

    /// The screened candidates near significance fitted exactly, in
    /// parallel.
    fn refit_near(&self, current: &Fit, screen: &fit::Screen, tried: &mut [Tried], m: usize) {
        let near: Vec<usize> = (0..tried.len())
            .filter(|&i| {
                tried[i]
                    .trial
                    .test
                    .as_ref()
                    .is_some_and(|c| stats::adjusted(c.p, m) < 100.0 * self.opts.alpha)
            })
            .collect();
        let screened: Vec<(usize, Tried)> = near
            .iter()
            .map(|&i| {
                (
                    i,
                    std::mem::replace(&mut tried[i], refused("", String::new())),
                )
            })
            .collect();
        let iterated: Vec<(usize, Tried)> = screened
            .into_par_iter()
            .map(|(i, t)| (i, refit(self.fitter, current, t, &self.fits, screen)))
            .collect();
        for (i, t) in iterated {
            tried[i] = t;
        }
    }

    /// The best of the significant (`sig`, by BIC) and its rivalry: a
    /// rival that explains it away takes its place, and so does the same
    /// drift per pose when the test cannot tell it from the drift per
    /// minute.
    fn choose(&self, round: &Roundup<'_>, sig: &[usize]) -> (usize, Rivalry) {
        let mut best = sig[0];
        let mut r = self.rivalry(round, sig, best);
        // A rival that explains the best away becomes the best (once: two
        // candidates cannot each explain the other away).
        if let Some(c) = r.encompassed_by {
            best = c;
            r = self.rivalry(round, sig, best);
        }
        // The same drift on the other clock (per pose or per minute) is
        // the same effect, not a rival cause: when the test cannot tell
        // the clocks apart (poses of nearly equal duration), the drift is
        // kept per pose, as the papers' thermal tests count it, and the
        // story says so.
        if round.basis_of(best) == Some(DriftBasis::Minute)
            && let Some(&c) = r.same.iter().find(|&&c| {
                self.id_of(round, c) == self.id_of(round, best)
                    && round.basis_of(c) == Some(DriftBasis::Seq)
            })
        {
            best = c;
            r = self.rivalry(round, sig, best);
        }
        (best, r)
    }

    /// The encompassing test: `best` fitted together with each other
    /// significant candidate, the pairs fitted in parallel, judged in order.
    fn rivalry(&self, round: &Roundup<'_>, sig: &[usize], best: usize) -> Rivalry {
        let (tried, m, n, alpha) = (&round.tried, round.m, self.fitter.len(), self.opts.alpha);
        let mut out = Rivalry::default();
        let rivals: Vec<usize> = sig.iter().copied().filter(|&c| c != best).collect();
        let fb = tried[best].fit.as_ref().expect("tested");
        let with_best = others(self.fitter, fb);
        let pairs: Vec<Tried> = rivals
            .par_iter()
            .map(|&c| {
                try_candidate(
                    self.fitter,
                    fb,
                    round.candidate(c),
                    None,
                    Mode::Exact(&with_best, Some(&self.fits)),
                )
            })
            .collect();
        for (&c, both) in rivals.iter().zip(pairs) {
            let fc = tried[c].fit.as_ref().expect("tested");
            let (rss_both, rank_both) = match &both.fit {
                Some(f) => (f.rss, f.rank),
                // Nothing of the rival is seen beside the best:
                // together they are the best alone.
                None => (fb.rss, fb.rank),
            };
            // Neither adds a direction to the other: the design itself
            // cannot tell them apart, whatever the noise.
            let exact = rank_both == fb.rank && rank_both == fc.rank;
            let p_c_over_b = stats::compare(n, fb.rss, fb.rank, rss_both, rank_both).p;
            let p_b_over_c = stats::compare(n, fc.rss, fc.rank, rss_both, rank_both).p;
            // At the round's adjusted level: overriding the ranking
            // by the BIC, or calling two candidates different, needs
            // the evidence a step needs.
            let b_adds = stats::adjusted(p_b_over_c, m) < alpha;
            let c_adds = stats::adjusted(p_c_over_b, m) < alpha;
            let (bn, cn) = (tried[best].trial.name.clone(), tried[c].trial.name.clone());
            let verdict = match (b_adds, c_adds) {
                (true, false) => {
                    format!("{bn} explains it away: {cn} adds nothing to {bn}, {bn} adds to {cn}")
                }
                (true, true) => {
                    "a different effect: each adds to the other (it may come next)".to_string()
                }
                (false, false) if exact => format!(
                    "exactly indistinguishable from {bn} on this test: neither adds a direction the other does not give, so no measurement of this test can tell them apart"
                ),
                (false, false) => format!(
                    "indistinguishable from {bn} on this test: neither adds significantly to the other"
                ),
                (false, true) => format!("{cn} explains {bn} away"),
            };
            if !b_adds && c_adds && out.encompassed_by.is_none() {
                out.encompassed_by = Some(c);
            }
            if !b_adds && !c_adds {
                out.same.push(c);
            }
            out.rivals.push((
                c,
                story::Rival {
                    name: cn,
                    gap_after: gap::size(&fc.residuals),
                    p_effect_over_rival: p_b_over_c,
                    p_rival_over_effect: p_c_over_b,
                    exactly_indistinguishable: exact,
                    residual_difference_um: gap::size(
                        &fb.residuals
                            .iter()
                            .zip(&fc.residuals)
                            .map(|(a, b)| a - b)
                            .collect::<Vec<_>>(),
                    )
                    .rms_um,
                    added_at: None,
                    verdict,
                },
            ));
        }
        out
    }

    /// The effect identifier of the `i`-th candidate of the round.
    fn id_of(&self, round: &Roundup<'_>, i: usize) -> String {
        round.candidate(i).effect.id(&self.model0.symbols)
    }

    /// The best's rivals for the story, the same drift on another clock
    /// worded as such.
    fn rivals_worded(&self, round: &Roundup<'_>, best: usize, r: &Rivalry) -> Vec<story::Rival> {
        r.rivals
            .iter()
            .cloned()
            .map(|(c, mut rv)| {
                if self.id_of(round, c) == self.id_of(round, best) && r.same.contains(&c) {
                    rv.verdict = format!(
                        "the same effect on another clock, indistinguishable on this test (its poses take nearly equal times): kept as {}",
                        round.tried[best].trial.name
                    );
                }
                rv
            })
            .collect()
    }

    /// The ambiguity of `best` and the different effects the data cannot
    /// tell from it (`same`), with the supplementary test that would
    /// separate them, and the stop it words.
    fn ambiguity(
        &self,
        round: &Roundup<'_>,
        current: &Fit,
        best: usize,
        same: &[usize],
        r: &Rivalry,
        before: &Gap,
    ) -> (story::Ambiguity, String) {
        let tried = &round.tried;
        let mut cands = vec![best];
        cands.extend(same);
        let list: Vec<String> = cands.iter().map(|&i| tried[i].trial.name.clone()).collect();
        let rival = |c: usize| r.rivals.iter().find(|(i, _)| *i == c).map(|(_, rv)| rv);
        let exact: Vec<bool> = cands
            .iter()
            .map(|&c| c == best || rival(c).is_some_and(|rv| rv.exactly_indistinguishable))
            .collect();
        let why = if exact.iter().all(|&e| e) {
            let diff = same
                .iter()
                .filter_map(|&c| rival(c))
                .map(|rv| rv.residual_difference_um)
                .fold(0.0, f64::max);
            format!(
                "exactly indistinguishable on this test: none adds a direction another does not give (their residuals differ by {diff:.1e} um RMS), so no measurement of this test can tell which is at work"
            )
        } else {
            "fitted together, none adds significantly to another, so this test cannot tell which is at work".to_string()
        };
        let rivals: Vec<separate::AmbiguityRival<'_>> = cands
            .iter()
            .map(|&i| separate::AmbiguityRival {
                candidate: round.candidate(i),
                fit: tried[i].fit.as_ref().expect("tested"),
            })
            .collect();
        let (supplement, no_supplement) =
            match separate::find(self.parts, &current.spec, &rivals, self.opts, round.m) {
                Ok(s) => (Some(s), None),
                Err(why) => (None, Some(why.to_string())),
            };
        let next = match &supplement {
            Some(s) => format!(
                "a {} run with the new poses {} separates them (power {:.2} or more at {:.3} um noise): `fivecal plan --supplement RESULT.yaml` writes it from the result of `discover --out RESULT.yaml`; measure it and give both tests to the next discover",
                s.test,
                s.new_poses.join(", "),
                s.power.iter().map(|p| p.power).fold(1.0, f64::min),
                s.noise_um
            ),
            None => "add a test that separates them".to_string(),
        };
        let ambiguity = story::Ambiguity {
            supplement,
            no_supplement,
            candidates: cands
                .iter()
                .zip(&exact)
                .map(|(&i, &exactly)| {
                    let f = tried[i].fit.as_ref().expect("tested");
                    story::AmbiguousCandidate {
                        name: tried[i].trial.name.clone(),
                        exactly_indistinguishable: exactly,
                        values: effect_values(f, f.spec.names.len() - 1),
                        gap_after: gap::size(&f.residuals),
                    }
                })
                .collect(),
            reason: format!(
                "the gap ({}) is explained equally by {}: {why}. Nothing is added: rerun with --exclude naming all but one (if another measurement tells which), or {next}",
                before.summary,
                list.join(" or ")
            ),
        };
        let stop = format!(
            "ambiguous: {} explain the gap equally; nothing is added",
            list.join(", ")
        );
        (ambiguity, stop)
    }

    /// Step `step` of the story: `best` added, its fit `bf`, the gap
    /// `before` it.
    fn step(
        &self,
        round: &Roundup<'_>,
        step: usize,
        best: usize,
        bf: &Fit,
        before: &Gap,
        rivals: Vec<story::Rival>,
    ) -> story::Step {
        let t = &round.tried[best].trial;
        let cand = round.candidate(best);
        story::Step {
            step,
            name: t.name.clone(),
            effect: cand.effect.id(&self.model0.symbols),
            description: cand.description.clone(),
            provisional_values: effect_values(bf, bf.spec.names.len() - 1),
            gap_before: before.size(),
            gap_after: gap::size(&bf.residuals),
            concentrated: before.summary.clone(),
            test: t.test.expect("tested"),
            p_adjusted: t.p_adjusted.expect("tested"),
            tested: round.m,
            alongside: t.alongside.clone().expect("tested"),
            rivals,
            trials: round.tried.iter().map(|t| t.trial.clone()).collect(),
        }
    }
}

impl Roundup<'_> {
    /// The candidate tried as `tried[i]`.
    fn candidate(&self, i: usize) -> &Candidate {
        let name = &self.tried[i].trial.name;
        self.pool[self.pool.iter().position(|c| &c.name == name).unwrap()]
    }

    /// The clock of the `i`-th candidate, if it is a drift.
    fn basis_of(&self, i: usize) -> Option<DriftBasis> {
        match self.candidate(i).effect {
            Effect::Drift { basis, .. } => Some(basis),
            _ => None,
        }
    }

    /// The significant candidates, the lowest BIC first.
    fn significant(&self) -> Vec<usize> {
        let tried = &self.tried;
        let mut sig: Vec<usize> = (0..tried.len())
            .filter(|&i| tried[i].trial.verdict == CandidateVerdict::Significant)
            .collect();
        sig.sort_by(|&a, &b| {
            let ba = tried[a].trial.test.as_ref().map_or(0.0, |c| c.delta_bic);
            let bb = tried[b].trial.test.as_ref().map_or(0.0, |c| c.delta_bic);
            ba.total_cmp(&bb)
        });
        sig
    }

    /// The stop of a round without a significant candidate, naming the best.
    fn none_significant(&self, alpha: f64) -> String {
        let best = self
            .tried
            .iter()
            .filter_map(|t| {
                t.trial
                    .test
                    .as_ref()
                    .map(|c| (t.trial.name.clone(), c.p, t.trial.p_adjusted.unwrap_or(1.0)))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1));
        match best {
            Some((name, p, pa)) => format!(
                "no candidate is significant at alpha = {} (the best, {name}, has p = {}, {} after the adjustment for {} candidates)",
                alpha,
                story_p(p),
                story_p(pa),
                self.m
            ),
            None => "no candidate is left to try".to_string(),
        }
    }
}

/// Each fitted candidate's adjusted p, and significant where it is below
/// `alpha` and lowers the BIC.
fn judge(tried: &mut [Tried], m: usize, alpha: f64) {
    for t in tried.iter_mut() {
        if let Some(c) = &t.trial.test {
            let pa = stats::adjusted(c.p, m);
            t.trial.p_adjusted = Some(pa);
            if pa < alpha && c.delta_bic < 0.0 {
                t.trial.verdict = CandidateVerdict::Significant;
            }
        }
    }
}

/// Each step's rivals that a later step added, marked and worded so; a
/// "different effect" that no later step added is worded by where the
/// search left it (`last_round`, in which nothing was added, and the
/// ambiguous set, if that stopped the search).
fn mark_added(steps: &mut [story::Step], last_round: &[Trial], ambiguous: &[String]) {
    let names: Vec<String> = steps.iter().map(|s| s.name.clone()).collect();
    for st in steps.iter_mut() {
        let k = st.step;
        for rv in &mut st.rivals {
            rv.added_at = names
                .iter()
                .skip(k)
                .position(|n| *n == rv.name)
                .map(|j| k + j + 1);
            let different = rv.verdict.starts_with("a different effect");
            let left = || {
                if ambiguous.contains(&rv.name) {
                    return "one of the effects the search could not tell apart at the end"
                        .to_string();
                }
                match last_round.iter().find(|t| t.name == rv.name) {
                    Some(t) if t.verdict == CandidateVerdict::Refused => format!(
                        "refused in the last round ({})",
                        t.reason.as_deref().unwrap_or("")
                    ),
                    Some(_) => "not significant once the later steps were added".to_string(),
                    None => "not added before the search stopped".to_string(),
                }
            };
            rv.verdict = match (rv.added_at, different) {
                (Some(j), true) => {
                    format!("a different effect: each adds to the other; added at step {j}")
                }
                (Some(j), false) => format!("{}; added at step {j}", rv.verdict),
                (None, true) => format!(
                    "a different effect here (each adds to the other), but {}",
                    left()
                ),
                (None, false) => continue,
            };
        }
    }
}

fn story_p(p: f64) -> String {
    if p < 1e-3 {
        format!("{p:.1e}")
    } else {
        format!("{p:.3}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pair named as most correlated does not hang on round-off: an
    /// equal correlation in the last bits (either sign) keeps the first
    /// pair, a correlation stronger in the ninth digit takes its place.
    #[test]
    fn a_tie_in_the_last_bits_keeps_the_first_pair_named() {
        let first = story::Correlation {
            parameter: "probe_pretravel.Y+".into(),
            with: "EY0A".into(),
            value: -0.0231_f64,
        };
        assert!(stronger(0.3, None));
        for c in [-0.0231 * (1.0 + 1e-13), 0.0231 * (1.0 + 4e-16), -0.0231] {
            assert!(!stronger(c, Some(&first)), "{c}");
        }
        assert!(stronger(-0.0231 * (1.0 + 1e-8), Some(&first)));
        assert!(stronger(0.0232, Some(&first)));
        assert!(!stronger(0.0230, Some(&first)));
    }

    /// A candidate's exact fit that starts from its round's linearization
    /// (the screened base's residuals and Jacobian, in place of a first
    /// evaluation) is the fit started by evaluating, to the bit, on the
    /// worked example's machined piece. A linearization of another base
    /// changes the fit, so the one given is the one used.
    #[test]
    fn a_fit_started_from_the_rounds_linearization_is_the_fit_made_afresh() {
        on_the_worked_example(|fitter, cat, loc| {
            let cand = cat
                .candidates
                .iter()
                .find(|c| c.name == "tool_radius")
                .unwrap();
            let afresh = try_candidate(
                fitter,
                loc,
                cand,
                None,
                Mode::Exact(&others(fitter, loc), None),
            )
            .fit
            .unwrap();
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            let started = |screen: &fit::Screen| {
                let round = Round::new(fitter, loc).unwrap();
                let screened =
                    try_candidate(fitter, loc, cand, Some(0.999), Mode::Screen(&round, None));
                refit(fitter, loc, screened, &Fits::default(), screen)
                    .fit
                    .unwrap()
            };
            let round = Round::new(fitter, loc).unwrap();
            let f = started(&round.screen);
            assert_eq!(bits(&f.x), bits(&afresh.x));
            assert_eq!(bits(&f.residuals), bits(&afresh.residuals));
            let other = Round::new(fitter, &afresh).unwrap();
            assert_ne!(bits(&started(&other.screen).x), bits(&afresh.x));
        });
    }

    /// Runs `f` on the worked example of `examples/discover/` (its
    /// machined stepped square): the fitter, the catalogue and the fit of
    /// the location errors alone.
    fn on_the_worked_example(f: impl FnOnce(&Fitter<'_>, &catalogue::Catalogue, &Fit)) {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/discover");
        let inputs = Inputs::load(
            &dir.join("stepped-square.plan.yaml"),
            &[dir.join("piece.dmo")],
            &Default::default(),
        )
        .unwrap();
        on(&inputs, f);
    }

    /// The planner's probed sphere on `ac-trunnion` (49 poses, 242 touches;
    /// its C-axis maps have 468 values each), on the virtual machine with
    /// its location errors at zero and the probe's noise.
    fn on_a_probed_sphere(f: impl FnOnce(&Fitter<'_>, &catalogue::Catalogue, &Fit)) {
        use crate::formats::manifest::KinematicsMode;
        use crate::procedure::{PlanConfig, Template, Test};
        let plan = crate::procedure::plan(&PlanConfig {
            machine: crate::Machine::builtin("ac-trunnion").unwrap(),
            template: Template::builtin(Test::ProbeSphere),
            post: crate::post::PostDefinition::builtin(crate::Dialect::Fanuc),
            kinematics: KinematicsMode::Post,
            tool: None,
        })
        .unwrap();
        let kin = crate::simulate::plan_kinematics(&plan);
        let errors = crate::errorfile::LoadedErrors {
            model: Model::new(kin, vec![Effect::Location { symbols: vec![0] }]),
            theta: vec![0.0],
            u: vec![None],
            noise: Noise {
                cmm: None,
                probe: Some(0.35),
            },
            not_identifiable: Vec::new(),
            fit: None,
        };
        let out = crate::simulate::run(&plan, &errors, &Default::default()).unwrap();
        let inputs =
            Inputs::from_points(plan, out.points, std::path::Path::new("sphere.csv")).unwrap();
        on(&inputs, f);
    }

    fn on(inputs: &Inputs, f: impl FnOnce(&Fitter<'_>, &catalogue::Catalogue, &Fit)) {
        let parts = [inputs.part()];
        let cat = catalogue::catalogue(&parts);
        let (fitter, _) = Fitter::new(&parts, &cat.candidates).unwrap();
        let mut notes = Vec::new();
        let loc = start(&fitter, &inputs.kin, &cat, &["location".into()], &mut notes).unwrap();
        f(&fitter, &cat, &loc);
    }

    /// A candidate whose unseen combinations are fixed on its own first
    /// ([`Alone`]) is the candidate designed whole, within round-off: the
    /// same refusals, rank increase, number of unseen combinations, span
    /// of free directions, canonical correlation, largest correlation and
    /// screened fit, on every candidate of the probed sphere that leaves
    /// something unseen (its maps and pre-travels among them), tried on its
    /// location model.
    #[test]
    fn a_candidate_designed_alone_first_is_the_candidate_designed_whole() {
        on_a_probed_sphere(|fitter, cat, loc| {
            let round = Round::new(fitter, loc).unwrap();
            let qa = &round.others;
            let (mut compared, mut large) = (0, 0);
            for cand in &cat.candidates {
                let alone = seen_alone(fitter, cand, 0).unwrap();
                if alone.is_none() {
                    continue;
                }
                let with = |a: Option<Arc<Alone>>| {
                    let memo = AloneMemo::default();
                    let _ = memo.get_or(cand.name.clone(), || Ok(a));
                    prepare(fitter, loc, cand, qa, Some(&memo))
                };
                let (first, whole) = (with(alone), with(None));
                let (first, whole) = match (first, whole) {
                    (Ok(a), Ok(b)) => (a, b),
                    (Err(a), Err(b)) => {
                        assert_eq!(a, b, "{}", cand.name);
                        continue;
                    }
                    (a, b) => panic!("{}: {:?} against {:?}", cand.name, a.err(), b.err()),
                };
                compared += 1;
                let (a, b) = (&first.alongside, &whole.alongside);
                if a.parameters > ALONE_ABOVE {
                    large += 1;
                }
                let name = &cand.name;
                assert_eq!(a.rank_increase, b.rank_increase, "{name}");
                assert_eq!(a.unseen.len(), b.unseen.len(), "{name}");
                assert!(
                    (a.canonical_correlation - b.canonical_correlation).abs() < 1e-9,
                    "{name}"
                );
                let (ca, cb) = (
                    a.largest_correlation.as_ref().unwrap(),
                    b.largest_correlation.as_ref().unwrap(),
                );
                assert!((ca.value - cb.value).abs() < 1e-9, "{name}");
                assert_eq!(
                    (&ca.parameter, &ca.with),
                    (&cb.parameter, &cb.with),
                    "{name}"
                );
                // The same free directions: the same projector.
                let ei = loc.spec.names.len();
                let proj = |p: &Prepared| {
                    let (basis, ranges) = p.model.spec.basis(fitter.extra());
                    let xr = p.model.spec.model.param_range(ei);
                    let zr = ranges[ei].clone();
                    let b = basis.view((xr.start, zr.start), (xr.len(), zr.len()));
                    b * b.transpose()
                };
                assert!((proj(&first) - proj(&whole)).amax() < 1e-9, "{name}");
                let score = |p: &Prepared| {
                    fitter
                        .score(&round.screen, &p.model.spec, a.rank_increase)
                        .rss
                };
                let (sa, sb) = (score(&first), score(&whole));
                assert!((sa - sb).abs() <= 1e-9 * sb.max(1.0), "{name}: {sa} {sb}");
            }
            // The six C-axis maps (468 values each) and the pre-travels.
            assert!(
                compared >= 7,
                "only {compared} candidates leave something unseen"
            );
            assert!(large >= 6, "only {large} large candidates");
        });
    }

    /// The left singular vectors made without the right ones are
    /// `thin_svd`'s to the bit, on tall, wide, square and rank-deficient
    /// matrices (the candidates' null-direction rows are all of these).
    #[test]
    fn left_svd_is_thin_svd_to_the_bit() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        for (r, c, rank) in [
            (40, 12, 12),
            (12, 40, 12),
            (30, 30, 30),
            (60, 45, 20),
            (8, 90, 5),
            (300, 200, 150),
            (150, 400, 100),
        ] {
            let a = faer::Mat::<f64>::from_fn(r, rank, |_, _| rng.random_range(-1.0..1.0));
            let b = faer::Mat::<f64>::from_fn(rank, c, |_, _| rng.random_range(-1.0..1.0));
            let m = &a * &b;
            let thin = m.thin_svd().unwrap();
            let (s, u) = left_svd(&m).unwrap();
            let ts = thin.S().column_vector();
            assert_eq!(s.len(), ts.nrows());
            for i in 0..s.len() {
                assert_eq!(s[i].to_bits(), ts[i].to_bits(), "{r}x{c}: s{i}");
                for j in 0..r {
                    assert_eq!(
                        u[(j, i)].to_bits(),
                        thin.U()[(j, i)].to_bits(),
                        "{r}x{c}: u{j},{i}"
                    );
                }
            }
        }
    }

    /// A fit the search keeps is the fit made again: a rival fitted beside
    /// the chosen effect (exact, kept) and the same candidate screened on
    /// that model in the next round (with the design kept from the first)
    /// and refitted give the same bits as a fit made afresh, as the worked
    /// example's second step has them.
    #[test]
    fn a_kept_fit_is_the_fit_made_again() {
        on_the_worked_example(|fitter, cat, loc| {
            let named = |n: &str| cat.candidates.iter().find(|c| c.name == n).unwrap();
            let with = |base: &Fit, n: &str| {
                try_candidate(
                    fitter,
                    base,
                    named(n),
                    None,
                    Mode::Exact(&others(fitter, base), None),
                )
                .fit
                .unwrap()
            };
            let base = with(loc, "tool_radius");
            let fits = Fits::default();
            let cand = named("drift.EZ0B/seq");
            let kept = try_candidate(
                fitter,
                &base,
                cand,
                None,
                Mode::Exact(&others(fitter, &base), Some(&fits)),
            );
            assert_eq!(fits.fits.len(), 1);
            assert_eq!(fits.designs.len(), 1);
            let round = Round::new(fitter, &base).unwrap();
            let screened = try_candidate(
                fitter,
                &base,
                cand,
                Some(0.999),
                Mode::Screen(&round, Some(&fits)),
            );
            assert!(screened.fit.is_none());
            // Screened with the design the exact fit made (none made again).
            assert_eq!(fits.designs.len(), 1);
            let again = refit(fitter, &base, screened, &fits, &round.screen);
            let afresh = with(&base, "drift.EZ0B/seq");
            for f in [kept.fit.unwrap(), again.fit.unwrap()] {
                assert_eq!(f.spec.names, afresh.spec.names);
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&f.x), bits(&afresh.x));
                assert_eq!(bits(&f.residuals), bits(&afresh.residuals));
                assert_eq!(f.rss.to_bits(), afresh.rss.to_bits());
                assert_eq!(
                    bits(f.cov_unit.as_slice()),
                    bits(afresh.cov_unit.as_slice())
                );
            }
            // Moving on to the next model forgets the fits on this one.
            fits.keep_on(&afresh);
            assert_eq!(fits.fits.len(), 0);
        });
    }

    #[test]
    fn canonical_correlation_is_the_cosine_of_the_smallest_angle() {
        // span(a) = the x-y plane; b's column leaves it at 30 degrees, at
        // any length.
        let a = DMatrix::from_row_slice(4, 2, &[1.0, 1.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0]);
        let t = 30f64.to_radians();
        let b = DMatrix::from_row_slice(4, 1, &[5.0 * t.cos(), 0.0, 5.0 * t.sin(), 0.0]);
        let (qa, qb) = (column_space(&a, 1e-9), column_space(&b, 1e-9));
        assert_eq!((qa.ncols(), qb.ncols()), (2, 1));
        let c = (qa.transpose() * &qb).singular_values().max();
        assert!((c - t.cos()).abs() < 1e-12);
        // A repeated column adds no direction.
        let r = DMatrix::from_row_slice(3, 2, &[1.0, 2.0, 1.0, 2.0, 0.0, 0.0]);
        assert_eq!(column_space(&r, 1e-9).ncols(), 1);
    }
}
