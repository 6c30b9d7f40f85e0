//! Error files (docs/formats.md): the input of `simulate` (a truth file) and
//! the output of `analyze` (a result file), in YAML or JSON.
//!
//! ```yaml
//! machine: bc-trunnion
//! location_errors:               # um / urad, docs/model.md symbols
//!   EX0B: {value: 12.0, u: 0.4}  # u = standard uncertainty (k = 1)
//!   EZ0B: -5.0                   # a truth file may give a bare number
//! position_dependent:            # added to the location errors
//!   EBB(B): {B: [-90, 0, 90], values: [8.0, 0.0, -6.0]}
//!   EXC(B,C):
//!     B: [0]
//!     C: [0, 90, 180, 270]
//!     values: [[1.0, -1.0, 1.0, -1.0]]
//! effects:
//!   thermal_drift: {EZ0B: {per: seq, rate: 1.5}}   # um per pose
//!   linear_scale: {EXX: 4.0}                       # um/m
//!   squareness: {EC(0X)Y: 15.0}                    # urad
//!   straightness: {EYX: {X: [-100, 0, 100], values: [0.0, 2.0, 0.0]}}
//!   positioning: {EXX: {X: [0, 400, 800], values: [0.0, 3.0, 5.0]}}   # um
//!   angular: {EBX: {X: [0, 400, 800], values: [0.0, 4.0, -2.0]}}     # urad
//!   tool_radius: 3.0                               # um
//!   tool_length: -2.0                              # um
//!   probe_pretravel: {X+: 1.0, X-: 1.0, Y+: 1.0, Y-: 1.0, Z-: 0.5}
//!   noise: {cmm: 0.35, probe: 0.35}                # um, standard deviation
//! ```
//!
//! Reading validates every name against the machine's symbols (unknown and
//! non-identifiable symbols are rejected at their line) and builds the
//! [`Model`] with its parameter vector; writing goes the other way, so
//! `simulate` -> `analyze` is a round trip on the same shape.

use std::path::Path;

use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

use crate::geom::Axis3;
use crate::kinematics::Kinematics;
use crate::kinematics::maps::{MapDim, MapGrid};
use crate::kinematics::symbols::{SymbolTable, Unit};
use crate::limits::{
    MAX_ERROR_UM, MAX_ERROR_URAD, MAX_NOISE_UM, MAX_PRETRAVEL_UM, MAX_SCALE_UM_PER_M,
};
use crate::model::{DriftBasis, Effect, Model, PROBE_DIRECTIONS, Squareness};
use crate::numbers::echo;
use crate::source::SourceError;

/// A value with an optional standard uncertainty.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quantity {
    /// The value.
    pub value: f64,
    /// Standard uncertainty (k = 1), when known.
    pub u: Option<f64>,
}

impl Quantity {
    /// A value without uncertainty.
    pub fn bare(value: f64) -> Quantity {
        Quantity { value, u: None }
    }
}

#[derive(Serialize, Deserialize)]
#[serde(untagged)]
enum QuantityRepr {
    Bare(f64),
    Full {
        value: f64,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        u: Option<f64>,
    },
}

impl Serialize for Quantity {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self.u {
            None => QuantityRepr::Bare(self.value),
            Some(u) => QuantityRepr::Full {
                value: self.value,
                u: Some(u),
            },
        }
        .serialize(s)
    }
}

impl<'de> Deserialize<'de> for Quantity {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        match QuantityRepr::deserialize(d).map_err(|_| {
            serde::de::Error::custom("expected a number or {value: <number>, u: <number>}")
        })? {
            QuantityRepr::Bare(v) => Ok(Quantity::bare(v)),
            QuantityRepr::Full { value, u } => Ok(Quantity { value, u }),
        }
    }
}

/// Node values of a map: a list (one dimension) or a list of rows.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Values {
    /// One dimension.
    Flat(Vec<f64>),
    /// Two dimensions, one row per node of the first.
    Rows(Vec<Vec<f64>>),
}

impl Values {
    /// The values in node order (rows one after the other).
    pub fn flatten(&self) -> Vec<f64> {
        match self {
            Values::Flat(v) => v.clone(),
            Values::Rows(r) => r.iter().flatten().copied().collect(),
        }
    }

    fn shaped(flat: &[f64], dims: &[usize]) -> Values {
        if dims.len() < 2 {
            Values::Flat(flat.to_vec())
        } else {
            Values::Rows(flat.chunks(dims[1]).map(|c| c.to_vec()).collect())
        }
    }
}

/// A map over index angles (or over a linear axis, for straightness): the
/// node lists keyed by axis letter, then `values` and optional `u`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MapEntry {
    /// Node positions per axis letter (`B: [-90, 0, 90]`).
    #[serde(flatten)]
    pub nodes: IndexMap<String, Vec<f64>>,
    /// Values at the nodes.
    pub values: Values,
    /// Standard uncertainties at the nodes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub u: Option<Values>,
}

/// A thermal drift.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DriftEntry {
    /// `seq` or `minute`.
    pub per: String,
    /// Rate, symbol unit per `per`.
    pub rate: Quantity,
}

/// Noise levels, um (standard deviation).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct Noise {
    /// CMM probing noise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cmm: Option<f64>,
    /// On-machine probe repeatability.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub probe: Option<f64>,
}

impl Noise {
    /// A noise of `sigma_um` (if finite) as the CMM's for a machined piece
    /// or the probe's for on-machine probing.
    pub(crate) fn of_kind(kind: crate::formats::manifest::TestKind, sigma_um: f64) -> Noise {
        let sigma = sigma_um.is_finite().then_some(sigma_um);
        match kind {
            crate::formats::manifest::TestKind::Machining => Noise {
                cmm: sigma,
                probe: None,
            },
            crate::formats::manifest::TestKind::Probing => Noise {
                cmm: None,
                probe: sigma,
            },
        }
    }
}

/// Further named effects.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct Effects {
    /// Drift of location symbols.
    #[serde(default, skip_serializing_if = "IndexMap::is_empty")]
    pub thermal_drift: IndexMap<String, DriftEntry>,
    /// EXX, EYY, EZZ, um/m.
    #[serde(default, skip_serializing_if = "IndexMap::is_empty")]
    pub linear_scale: IndexMap<String, Quantity>,
    /// EC(0X)Y, EB(0X)Z, EA(0Y)Z, urad.
    #[serde(default, skip_serializing_if = "IndexMap::is_empty")]
    pub squareness: IndexMap<String, Quantity>,
    /// EYX, EZX, EXY, EZY, EXZ, EYZ: um at positions along the moving axis.
    #[serde(default, skip_serializing_if = "IndexMap::is_empty")]
    pub straightness: IndexMap<String, MapEntry>,
    /// EXX, EYY, EZZ: um at positions along the axis.
    #[serde(default, skip_serializing_if = "IndexMap::is_empty")]
    pub positioning: IndexMap<String, MapEntry>,
    /// EAX .. ECZ (the turn about X, Y, Z as X, Y, Z moves): urad at
    /// positions along the moving axis.
    #[serde(default, skip_serializing_if = "IndexMap::is_empty")]
    pub angular: IndexMap<String, MapEntry>,
    /// Tool radius error, um.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tool_radius: Option<Quantity>,
    /// Tool length error, um.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tool_length: Option<Quantity>,
    /// Probe pre-travel by approach direction, um.
    #[serde(default, skip_serializing_if = "IndexMap::is_empty")]
    pub probe_pretravel: IndexMap<String, Quantity>,
    /// Measurement noise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise: Option<Noise>,
}

impl Effects {
    /// Whether nothing is set.
    pub fn is_empty(&self) -> bool {
        *self == Effects::default()
    }
}

/// A symbol the test could not identify, with the reason (written by
/// `analyze` instead of a number).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NotIdentified {
    /// Symbol or combination.
    pub symbol: String,
    /// Why.
    pub reason: String,
}

/// Whether the model fitted the measurements (the `fit:` section of a
/// result file). Records of results without one have no verdict.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FitVerdict {
    /// The residuals are as large as the measurement noise.
    Fits,
    /// The residuals are larger: the model misses something.
    Misfit,
    /// The fit stopped before it converged: its values are no estimate,
    /// whatever its residuals.
    #[serde(rename = "not-converged")]
    NotConverged,
}

impl FitVerdict {
    /// The name stored and printed.
    pub fn name(self) -> &'static str {
        match self {
            FitVerdict::Fits => "fits",
            FitVerdict::Misfit => "misfit",
            FitVerdict::NotConverged => "not-converged",
        }
    }

    /// Whether a result with this verdict may be acted on (compensated,
    /// exported, compared, trended): only a fit.
    pub fn is_fit(self) -> bool {
        self == FitVerdict::Fits
    }

    /// The verdict a result file states in `fit: {verdict: ...}`, if any.
    pub(crate) fn of_result(content: &str) -> Option<FitVerdict> {
        let v: serde_yaml::Value = serde_yaml::from_str(content).ok()?;
        v.get("fit")?.get("verdict")?.as_str()?.parse().ok()
    }
}

impl std::fmt::Display for FitVerdict {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for FitVerdict {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "fits" => Ok(FitVerdict::Fits),
            "misfit" => Ok(FitVerdict::Misfit),
            "not-converged" => Ok(FitVerdict::NotConverged),
            _ => Err(format!(
                "unknown fit verdict `{s}`: expected fits, misfit or not-converged"
            )),
        }
    }
}

/// How well the identified model explains the measurements: the `fit:`
/// section of a result file. The residuals' standard deviation is set
/// against the noise the instrument should show, by a chi-square test; a
/// misfit means the model misses an effect, and `compensate` refuses such
/// a result unless told to accept it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitSection {
    /// Standard deviation of the residuals, um.
    pub sigma_um: f64,
    /// The noise expected from the instrument, um.
    pub expected_um: f64,
    /// Where the expected noise comes from.
    pub expected_from: String,
    /// `sigma_um / expected_um`, the Birge ratio.
    pub ratio: f64,
    /// Degrees of freedom of the residuals.
    pub dof: usize,
    /// Probability of residuals at least this large if the model were
    /// complete (chi-square upper tail).
    pub p_value: f64,
    /// The verdict.
    pub verdict: FitVerdict,
    /// What the residuals are: every measured point against the complete
    /// measurement model at the method's estimate (absent in files written
    /// before the verdict was computed that way).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub on: Option<String>,
    /// The data a robust step of the method set aside from its estimate,
    /// judged here with the rest.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub set_aside: Vec<String>,
    /// Why the verdict is not-converged: which fit stopped.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stopped: Option<String>,
    /// In noise variances: how much more than a least-squares fit's the
    /// squared residuals may be at an estimate made another way, as far as
    /// the method's own u allows (its estimate may lie that far from the
    /// least-squares one); judged with the noise ([`crate::analyze::goodness`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub allowance: Option<f64>,
}

/// The `uncertainty:` section of a result: what the `u` beside each value
/// includes, and how much of it comes from where.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UncertaintySection {
    /// What the `u` of the values includes, in words: the contributors,
    /// or why only the measurement noise.
    pub basis: String,
    /// The noise per measured point the budget draws, um.
    pub noise_um: f64,
    /// The Birge ratio every `u` is widened by because the model does not
    /// fit (absent when it fits).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub widened_by: Option<f64>,
    /// Contributors of the method's source that the tool cannot draw, so
    /// no `u` holds them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub not_included: Vec<String>,
    /// Per identified parameter (its name as the fit gives it).
    #[serde(default, skip_serializing_if = "IndexMap::is_empty")]
    pub values: IndexMap<String, ValueUncertainty>,
}

/// A location error seen, but too loosely to act on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NotUseful {
    /// The symbol.
    pub symbol: String,
    /// Its estimate, um or urad.
    pub value: f64,
    /// Its standard uncertainty.
    pub u: f64,
    /// The largest useful `u`.
    pub threshold: f64,
    /// Where the threshold comes from.
    pub from: String,
}

/// One value's uncertainty, explained.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ValueUncertainty {
    /// The `u` reported with the value (k = 1).
    pub u: f64,
    /// The `u` from the measurement noise alone: the fit's covariance,
    /// scaled by its residuals.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub u_noise: Option<f64>,
    /// The largest contributors to `u`, largest first.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub largest: Vec<Share>,
    /// The part of `u` that varies from one run of the test to the next
    /// (noise, setup, the probe's pre-travel); the rest (the linear axes'
    /// errors seen through the design) biases every run on the machine
    /// alike, so a trend's slope is judged against this part.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub u_random: Option<f64>,
}

/// One contributor's share of a value's variance.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Share {
    /// The contributor.
    pub contributor: String,
    /// Its share of the variance, 0..1.
    pub share: f64,
}

/// An error file as written.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ErrorFile {
    /// The machine it refers to.
    pub machine: String,
    /// Result files: the test whose measurements it was identified from
    /// (`stepped-square`, `probe-sphere`, ...), so that results of
    /// different tests are not compared or trended as one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test: Option<String>,
    /// Location errors, um / urad.
    #[serde(default, skip_serializing_if = "IndexMap::is_empty")]
    pub location_errors: IndexMap<String, Quantity>,
    /// Position-dependent errors, added to the location errors.
    #[serde(default, skip_serializing_if = "IndexMap::is_empty")]
    pub position_dependent: IndexMap<String, MapEntry>,
    /// Further effects.
    #[serde(default, skip_serializing_if = "Effects::is_empty")]
    pub effects: Effects,
    /// What could not be identified (result files).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub not_identifiable: Vec<NotIdentified>,
    /// How well the model fitted the measurements (result files).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit: Option<FitSection>,
    /// What each value's `u` holds (result files): the contributors, and
    /// per value the noise-only `u` beside the full one with its largest
    /// contributors.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uncertainty: Option<UncertaintySection>,
    /// Location errors the test saw, but with a `u` above the usefulness
    /// threshold (result files): listed here rather than among the values,
    /// so that nothing exports or compensates them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub seen_not_usefully: Vec<NotUseful>,
    /// `discover` results: the effects the measurements could not tell
    /// apart, none of which the model holds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ambiguity: Option<AmbiguitySection>,
    /// Ball-bar results: each run's circularity figure (ISO 230-4 / ISO
    /// 10791-6 style), what an acceptance engineer reads first.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub circularity: Vec<Circularity>,
}

/// One ball-bar run's deviation range: the bar's length deviation over the
/// sweep, largest minus smallest, with nothing removed (a fixed-length bar
/// under TCP has no centre to fit: its pivot is the table ball).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Circularity {
    /// The run's setup (`C1-X`).
    pub setup: String,
    /// Largest minus smallest deviation, um.
    pub range_um: f64,
    /// Largest deviation, um.
    pub max_um: f64,
    /// Smallest deviation, um.
    pub min_um: f64,
    /// The range once the spindle ball's stated run-out is taken out of
    /// each reading, um (absent when no run-out was stated).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub range_without_runout_um: Option<f64>,
}

/// The `ambiguity:` section of a `discover` result: the search stopped
/// because several effects explain the gap equally, so the file's model
/// holds none of them (its fit says what is left unexplained).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AmbiguitySection {
    /// Why the search stopped, in words.
    pub reason: String,
    /// The effects that explain the gap equally, best (lowest BIC) first.
    pub rivals: Vec<RivalEntry>,
    /// The supplementary test that would separate them (`plan --supplement`
    /// writes it), when one was found.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub supplement: Option<Supplement>,
    /// Why no supplementary test is proposed, when none is.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub no_supplement: Option<String>,
}

/// The supplementary test an ambiguity asks for: a probing run of the
/// calibration sphere (probe-sphere) on the same machine, at the poses
/// that separate the rivals, measured once more and given to `discover`
/// with the first test's measurements.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Supplement {
    /// The test (`probe-sphere`).
    pub test: String,
    /// Its tilt angles, deg: each probed at every C angle.
    pub tilt: Vec<f64>,
    /// Its C angles, deg.
    pub c: Vec<f64>,
    /// The poses the first test does not have that separate the rivals
    /// (`B-45C0`).
    pub new_poses: Vec<String>,
    /// Poses and touches of the planned supplement.
    pub poses: usize,
    /// Touches (measured points) of the planned supplement.
    pub touches: usize,
    /// The noise the separation was judged at, um (pooled over the tests).
    pub noise_um: f64,
    /// For each rival against each other: the chance that the two tests
    /// together tell it from the other, were it the one at work with the
    /// values fitted here.
    pub power: Vec<Separation>,
    /// The first test's plan manifest, as given to `discover` (its machine
    /// and dialect are the supplement's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plan: Option<String>,
}

/// How well the two tests together tell one rival from another.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Separation {
    /// The rival at work.
    pub effect: String,
    /// The rival it must be told from.
    pub against: String,
    /// Directions it adds beside the other.
    pub directions: usize,
    /// Probability that the step's test finds it significant beside the
    /// other (at the search's level, after its adjustment).
    pub power: f64,
}

/// One effect of an ambiguity, as it would be were it the one at work.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RivalEntry {
    /// The effect's identifier (`map.EXB(B)`, `drift.EZ0B/seq`).
    pub effect: String,
    /// The gap (RMS residual, um) the model leaves with this effect added.
    pub gap_rms_um: f64,
    /// Its values fitted alongside the model, by parameter name.
    pub values: IndexMap<String, Quantity>,
}

/// An error file turned into a model and its parameter values.
#[derive(Clone, Debug)]
pub struct LoadedErrors {
    /// The model (kinematics plus the file's effects).
    pub model: Model,
    /// Parameter values, model order, file units.
    pub theta: Vec<f64>,
    /// Standard uncertainties where the file has them.
    pub u: Vec<Option<f64>>,
    /// Noise levels.
    pub noise: Noise,
    /// What the file said was not identifiable.
    pub not_identifiable: Vec<NotIdentified>,
    /// The result file's fit verdict, if it has one.
    pub fit: Option<FitSection>,
}

impl LoadedErrors {
    /// The file's fit, if it says the model does not fit its measurements.
    pub fn misfit(&self) -> Option<&FitSection> {
        self.fit
            .as_ref()
            .filter(|f| f.verdict == FitVerdict::Misfit)
    }

    /// The file's fit, if it says the fit did not converge.
    pub fn not_converged(&self) -> Option<&FitSection> {
        self.fit
            .as_ref()
            .filter(|f| f.verdict == FitVerdict::NotConverged)
    }
}

/// The model of an error file built section by section: each effect
/// appended with its values (checked finite and plausible) in model order.
struct ModelBuilder<'a> {
    path: &'a Path,
    src: &'a str,
    sym: SymbolTable,
    model: Model,
    theta: Vec<f64>,
    u: Vec<Option<f64>>,
}

/// The largest plausible size of a value in `unit`, and the unit's name.
fn bound(unit: Unit) -> (f64, &'static str) {
    match unit {
        Unit::Um => (MAX_ERROR_UM, "um"),
        Unit::Urad => (MAX_ERROR_URAD, "urad"),
    }
}

impl<'a> ModelBuilder<'a> {
    fn new(kin: &Kinematics, path: &'a Path, src: &'a str) -> Self {
        let model = Model::new(kin.clone(), Vec::new());
        ModelBuilder {
            path,
            src,
            sym: model.symbols.clone(),
            model,
            theta: Vec::new(),
            u: Vec::new(),
        }
    }

    /// An error at `keys` of the file.
    fn err(&self, keys: &[&str], msg: String) -> SourceError {
        SourceError::at_key(self.path, self.src, keys, msg)
    }

    /// Refuses a value beyond what a machine can have (limits module): a
    /// location error of a metre is a unit mistake.
    fn plausible(
        &self,
        keys: &[&str],
        what: &str,
        v: f64,
        (max, unit): (f64, &str),
    ) -> Result<(), SourceError> {
        if v.abs() > max {
            return Err(self.err(
                keys,
                format!(
                    "{what} {} {unit} is not plausible: expected at most {max} {unit} in size (is it in the wrong unit?)",
                    echo(v)
                ),
            ));
        }
        Ok(())
    }

    /// Appends one value with its uncertainty, both checked.
    fn push(&mut self, q: &Quantity, keys: &[&str], limit: (f64, &str)) -> Result<(), SourceError> {
        if !q.value.is_finite() || q.u.is_some_and(|x| !x.is_finite() || x < 0.0) {
            return Err(self.err(
                keys,
                "value must be a finite number and u a finite number >= 0".to_string(),
            ));
        }
        let name = keys.last().copied().unwrap_or("value");
        self.plausible(keys, name, q.value, limit)?;
        if let Some(x) = q.u {
            self.plausible(keys, &format!("u of {name}"), x, limit)?;
        }
        self.theta.push(q.value);
        self.u.push(q.u);
        Ok(())
    }

    /// `location_errors:`, one effect for all of them.
    fn location_errors(&mut self, entries: &IndexMap<String, Quantity>) -> Result<(), SourceError> {
        let mut loc = Vec::new();
        for (name, q) in entries {
            let i = self
                .sym
                .location_index(name)
                .map_err(|e| self.err(&["location_errors", name], e.to_string()))?;
            if loc.contains(&i) {
                return Err(self.err(&["location_errors", name], format!("{name} appears twice")));
            }
            loc.push(i);
            let limit = bound(self.sym.location[i].unit);
            self.push(q, &["location_errors", name], limit)?;
        }
        if !loc.is_empty() {
            self.model.push(Effect::Location { symbols: loc });
        }
        Ok(())
    }

    /// `position_dependent:`, the error maps over the rotary axes: node
    /// angles per axis (C wrapping at 360, tilt in order) and the values on
    /// their grid.
    fn maps(&mut self, entries: &IndexMap<String, MapEntry>) -> Result<(), SourceError> {
        for (name, entry) in entries {
            let keys = ["position_dependent", name.as_str()];
            let i = self
                .sym
                .map_index(name)
                .map_err(|e| self.err(&keys, e.to_string()))?;
            let ms = &self.sym.maps[i];
            let letters: Vec<String> = ms
                .deps
                .iter()
                .map(|&d| {
                    if d == 0 {
                        self.sym.tilt.to_string()
                    } else {
                        "C".to_string()
                    }
                })
                .collect();
            for k in entry.nodes.keys() {
                if !letters.contains(k) {
                    return Err(self.err(
                        &keys,
                        format!(
                            "{name} runs over {}; unexpected key `{k}` (expected {}, values and u)",
                            letters.join(" and "),
                            letters.join(", ")
                        ),
                    ));
                }
            }
            let mut dims = Vec::new();
            let mut perms = Vec::new();
            for (l, &d) in letters.iter().zip(&ms.deps) {
                let nodes = entry.nodes.get(l).ok_or_else(|| {
                    self.err(
                        &keys,
                        format!("{name} needs its node angles `{l}: [...]` (degrees)"),
                    )
                })?;
                // C wraps at 360; a tilt map must list its angles in order.
                let (dim, order) = MapDim::sorted(d, nodes, d == 1)
                    .and_then(|(dim, order)| {
                        if d == 0 && order.iter().enumerate().any(|(i, &o)| i != o) {
                            Err(crate::kinematics::maps::NodeError::NotIncreasing)
                        } else {
                            Ok((dim, order))
                        }
                    })
                    .map_err(|e| {
                        self.err(&[&keys[..], &[l.as_str()]].concat(), format!("{name}: {e}"))
                    })?;
                dims.push(dim);
                perms.push(order);
            }
            let grid = MapGrid { dims };
            let shape: Vec<usize> = grid.dims.iter().map(|d| d.nodes.len()).collect();
            let vals = map_values(&entry.values, &shape, &perms, |m| {
                self.err(&[&keys[..], &["values"]].concat(), format!("{name}: {m}"))
            })?;
            let us = match &entry.u {
                None => vec![None; vals.len()],
                Some(uv) => map_values(uv, &shape, &perms, |m| {
                    self.err(&[&keys[..], &["u"]].concat(), format!("{name} u: {m}"))
                })?
                .into_iter()
                .map(Some)
                .collect(),
            };
            for v in vals.iter().chain(us.iter().flatten()) {
                self.plausible(&keys, name, *v, bound(ms.unit))?;
            }
            self.theta.extend(vals);
            self.u.extend(us);
            self.model.push(Effect::Map { symbol: i, grid });
        }
        Ok(())
    }

    /// `effects.thermal_drift:`, a location error's rate per cut or minute.
    fn drifts(&mut self, e: &Effects) -> Result<(), SourceError> {
        for (name, d) in &e.thermal_drift {
            let keys = ["effects", "thermal_drift", name.as_str()];
            let i = self
                .sym
                .location_index(name)
                .map_err(|x| self.err(&keys, format!("thermal drift of {}", x)))?;
            let basis = match d.per.as_str() {
                "seq" => DriftBasis::Seq,
                "minute" | "min" => DriftBasis::Minute,
                other => {
                    return Err(self.err(
                        &[&keys[..], &["per"]].concat(),
                        format!("drift `per: {other}`: expected seq or minute"),
                    ));
                }
            };
            let (max, unit) = bound(self.sym.location[i].unit);
            let per = match basis {
                DriftBasis::Seq => format!("{unit} per cut"),
                DriftBasis::Minute => format!("{unit} per minute"),
            };
            self.push(&d.rate, &keys, (max, per.as_str()))?;
            self.model.push(Effect::Drift { symbol: i, basis });
        }
        Ok(())
    }

    /// `effects.linear_scale:`, EXX, EYY or EZZ in um/m.
    fn linear_scales(&mut self, e: &Effects) -> Result<(), SourceError> {
        for (name, q) in &e.linear_scale {
            let keys = ["effects", "linear_scale", name.as_str()];
            let axis = match name.as_str() {
                "EXX" => Axis3::X,
                "EYY" => Axis3::Y,
                "EZZ" => Axis3::Z,
                _ => {
                    return Err(self.err(
                        &keys,
                        format!(
                            "unknown linear scale error `{name}`: expected EXX, EYY or EZZ (um/m)"
                        ),
                    ));
                }
            };
            self.push(q, &keys, (MAX_SCALE_UM_PER_M, "um/m"))?;
            self.model.push(Effect::Scale { axis });
        }
        Ok(())
    }

    /// `effects.squareness:`, between two linear axes in urad.
    fn squareness(&mut self, e: &Effects) -> Result<(), SourceError> {
        for (name, q) in &e.squareness {
            let keys = ["effects", "squareness", name.as_str()];
            let kind = Squareness::from_symbol(name).ok_or_else(|| {
                self.err(&keys, format!("unknown squareness error `{name}`: expected EC(0X)Y, EB(0X)Z or EA(0Y)Z (urad)"))
            })?;
            self.push(q, &keys, (MAX_ERROR_URAD, "urad"))?;
            self.model.push(Effect::Squareness { kind });
        }
        Ok(())
    }

    /// `effects.straightness:`, a linear axis's deviation across its motion
    /// at node positions along it.
    fn straightness(&mut self, e: &Effects) -> Result<(), SourceError> {
        for (name, entry) in &e.straightness {
            let keys = ["effects", "straightness", name.as_str()];
            let ch: Vec<char> = name.chars().collect();
            let parsed = (ch.len() == 3 && ch[0] == 'E')
                .then(|| (axis_of(ch[1]), axis_of(ch[2])))
                .and_then(|(d, m)| Some((d?, m?)))
                .filter(|(d, m)| d != m);
            let Some((direction, moving)) = parsed else {
                return Err(self.err(
                    &keys,
                    format!(
                        "unknown straightness error `{name}`: expected EYX, EZX, EXY, EZY, EXZ or EYZ"
                    ),
                ));
            };
            let nodes = self.axis_map(&keys, name, entry, moving, (MAX_ERROR_UM, "um"))?;
            self.model.push(Effect::Straightness {
                moving,
                direction,
                nodes,
            });
        }
        Ok(())
    }

    /// `effects.positioning:`, a linear axis's error along itself (um) at
    /// node positions along it.
    fn positioning(&mut self, e: &Effects) -> Result<(), SourceError> {
        for (name, entry) in &e.positioning {
            let keys = ["effects", "positioning", name.as_str()];
            let ch: Vec<char> = name.chars().collect();
            let axis = (ch.len() == 3 && ch[0] == 'E' && ch[1] == ch[2])
                .then(|| axis_of(ch[1]))
                .flatten();
            let Some(axis) = axis else {
                return Err(self.err(
                    &keys,
                    format!("unknown positioning error `{name}`: expected EXX, EYY or EZZ (um)"),
                ));
            };
            let nodes = self.axis_map(&keys, name, entry, axis, (MAX_ERROR_UM, "um"))?;
            self.model.push(Effect::Positioning { axis, nodes });
        }
        Ok(())
    }

    /// `effects.angular:`, a linear axis's angular error motion (urad) at
    /// node positions along it: `E<about><moving>` after ISO 230-1.
    fn angular(&mut self, e: &Effects) -> Result<(), SourceError> {
        for (name, entry) in &e.angular {
            let keys = ["effects", "angular", name.as_str()];
            let ch: Vec<char> = name.chars().collect();
            let about = |c: char| match c {
                'A' => Some(Axis3::X),
                'B' => Some(Axis3::Y),
                'C' => Some(Axis3::Z),
                _ => None,
            };
            let parsed = (ch.len() == 3 && ch[0] == 'E')
                .then(|| (about(ch[1]), axis_of(ch[2])))
                .and_then(|(a, m)| Some((a?, m?)));
            let Some((about, moving)) = parsed else {
                return Err(self.err(
                    &keys,
                    format!(
                        "unknown angular error `{name}`: expected E<A|B|C><X|Y|Z>, the turn about X, Y or Z as X, Y or Z moves (EAX, EBX, ECX, EAY, EBY, ECY, EAZ, EBZ, ECZ; urad)"
                    ),
                ));
            };
            let nodes = self.axis_map(&keys, name, entry, moving, (MAX_ERROR_URAD, "urad"))?;
            self.model.push(Effect::Angular {
                about,
                moving,
                nodes,
            });
        }
        Ok(())
    }

    /// A map along the linear axis `moving` (straightness, positioning,
    /// angular): its nodes checked and returned, its values and u pushed.
    fn axis_map(
        &mut self,
        keys: &[&str],
        name: &str,
        entry: &MapEntry,
        moving: Axis3,
        limit: (f64, &str),
    ) -> Result<Vec<f64>, SourceError> {
        let keys = keys.to_vec();
        let l = moving.letter().to_string();
        for k in entry.nodes.keys() {
            if *k != l {
                return Err(self.err(
                    &keys,
                    format!(
                        "{name} runs along {l}; unexpected key `{k}` (expected {l}, values and u)"
                    ),
                ));
            }
        }
        let nodes = entry.nodes.get(&l).ok_or_else(|| {
            self.err(
                &keys,
                format!("{name} needs its node positions `{l}: [...]` (mm)"),
            )
        })?;
        let dim =
            MapDim::new(0, nodes, false).map_err(|m| self.err(&keys, format!("{name}: {m}")))?;
        let grid = MapGrid { dims: vec![dim] };
        let ident = vec![(0..nodes.len()).collect::<Vec<_>>()];
        let vals = map_values(&entry.values, &[nodes.len()], &ident, |m| {
            self.err(&keys, format!("{name}: {m}"))
        })?;
        let us: Vec<Option<f64>> = match &entry.u {
            None => vec![None; vals.len()],
            Some(uv) => map_values(uv, &[nodes.len()], &ident, |m| {
                self.err(&keys, format!("{name} u: {m}"))
            })?
            .into_iter()
            .map(Some)
            .collect(),
        };
        for v in vals.iter().chain(us.iter().flatten()) {
            self.plausible(&keys, name, *v, limit)?;
        }
        self.theta.extend(vals);
        self.u.extend(us);
        Ok(grid.dims[0].nodes.clone())
    }

    /// `effects.tool_radius`, `tool_length` and `probe_pretravel` (one value
    /// per approach direction, 0 where not given).
    fn tool_and_probe(&mut self, e: &Effects) -> Result<(), SourceError> {
        if let Some(q) = &e.tool_radius {
            self.push(q, &["effects", "tool_radius"], (MAX_ERROR_UM, "um"))?;
            self.model.push(Effect::ToolRadius);
        }
        if let Some(q) = &e.tool_length {
            self.push(q, &["effects", "tool_length"], (MAX_ERROR_UM, "um"))?;
            self.model.push(Effect::ToolLength);
        }
        if !e.probe_pretravel.is_empty() {
            for k in e.probe_pretravel.keys() {
                if !PROBE_DIRECTIONS.contains(&k.as_str()) {
                    return Err(self.err(
                        &["effects", "probe_pretravel", k],
                        format!(
                            "unknown approach direction `{k}`: expected {}",
                            PROBE_DIRECTIONS.join(", ")
                        ),
                    ));
                }
            }
            for d in PROBE_DIRECTIONS {
                let q = e
                    .probe_pretravel
                    .get(d)
                    .copied()
                    .unwrap_or(Quantity::bare(0.0));
                self.push(
                    &q,
                    &["effects", "probe_pretravel", d],
                    (MAX_PRETRAVEL_UM, "um"),
                )?;
            }
            self.model.push(Effect::ProbePretravel);
        }
        Ok(())
    }

    /// `effects.noise:`, each level a standard deviation in range.
    fn noise(&self, e: &Effects) -> Result<Noise, SourceError> {
        let noise = e.noise.clone().unwrap_or_default();
        for (k, v) in [("cmm", noise.cmm), ("probe", noise.probe)] {
            if v.is_some_and(|x| !(x.is_finite() && (0.0..=MAX_NOISE_UM).contains(&x))) {
                return Err(self.err(
                    &["effects", "noise", k],
                    format!(
                        "noise {k} {} um: expected a standard deviation from 0 to {MAX_NOISE_UM} um",
                        echo(v.unwrap_or_default())
                    ),
                ));
            }
        }
        Ok(noise)
    }
}

fn axis_of(c: char) -> Option<Axis3> {
    match c {
        'X' => Some(Axis3::X),
        'Y' => Some(Axis3::Y),
        'Z' => Some(Axis3::Z),
        _ => None,
    }
}

impl ErrorFile {
    /// Parses YAML (JSON is YAML too) without validating names.
    pub fn parse(path: &Path, src: &str) -> Result<ErrorFile, SourceError> {
        crate::input::parse_yaml(path, src)
    }

    /// Reads a file.
    pub fn read(path: &Path) -> Result<(ErrorFile, String), SourceError> {
        let src = crate::input::read_text(path, "error file", crate::limits::MAX_YAML_BYTES)?;
        Ok((ErrorFile::parse(path, &src)?, src))
    }

    /// YAML text.
    pub fn to_yaml(&self) -> String {
        serde_yaml::to_string(self).expect("error files serialize")
    }

    /// Pretty JSON text.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("error files serialize")
    }

    /// Validates every name against the machine and builds the model.
    /// `path` and `src` locate errors.
    pub fn to_model(
        &self,
        kin: &Kinematics,
        path: &Path,
        src: &str,
    ) -> Result<LoadedErrors, SourceError> {
        let mut b = ModelBuilder::new(kin, path, src);
        if self.machine != kin.machine().name {
            return Err(b.err(
                &["machine"],
                format!(
                    "error file is for machine `{}` but the machine in use is `{}`",
                    self.machine,
                    kin.machine().name
                ),
            ));
        }
        b.location_errors(&self.location_errors)?;
        b.maps(&self.position_dependent)?;
        let e = &self.effects;
        b.drifts(e)?;
        b.linear_scales(e)?;
        b.squareness(e)?;
        b.straightness(e)?;
        b.positioning(e)?;
        b.angular(e)?;
        b.tool_and_probe(e)?;
        let noise = b.noise(e)?;
        Ok(LoadedErrors {
            model: b.model,
            theta: b.theta,
            u: b.u,
            noise,
            not_identifiable: self.not_identifiable.clone(),
            fit: self.fit.clone(),
        })
    }

    /// Loads and validates a file against a machine.
    pub fn load(path: &Path, kin: &Kinematics) -> Result<LoadedErrors, SourceError> {
        let (f, src) = ErrorFile::read(path)?;
        f.to_model(kin, path, &src)
    }

    /// The file that describes `model` with values `theta` and
    /// uncertainties `u` (the inverse of [`ErrorFile::to_model`]).
    pub fn from_model(model: &Model, theta: &[f64], u: &[Option<f64>], noise: &Noise) -> ErrorFile {
        let sym = &model.symbols;
        let mut f = ErrorFile {
            machine: model.kin.machine().name.clone(),
            test: None,
            location_errors: IndexMap::new(),
            position_dependent: IndexMap::new(),
            effects: Effects::default(),
            not_identifiable: Vec::new(),
            fit: None,
            uncertainty: None,
            seen_not_usefully: Vec::new(),
            ambiguity: None,
            circularity: Vec::new(),
        };
        let q = |i: usize| Quantity {
            value: theta[i],
            u: u[i],
        };
        for (ei, e) in model.effects.iter().enumerate() {
            let r = model.param_range(ei);
            let o = r.start;
            match e {
                Effect::Location { symbols } => {
                    for (k, &s) in symbols.iter().enumerate() {
                        f.location_errors
                            .insert(sym.location[s].name.clone(), q(o + k));
                    }
                }
                Effect::Map { symbol, grid } => {
                    let ms = &sym.maps[*symbol];
                    let mut nodes = IndexMap::new();
                    for d in &grid.dims {
                        let l = if d.angle == 0 {
                            sym.tilt.to_string()
                        } else {
                            "C".to_string()
                        };
                        nodes.insert(l, d.nodes.clone());
                    }
                    let shape: Vec<usize> = grid.dims.iter().map(|d| d.nodes.len()).collect();
                    let uu: Option<Vec<f64>> = u[r.clone()].iter().copied().collect();
                    f.position_dependent.insert(
                        ms.name.clone(),
                        MapEntry {
                            nodes,
                            values: Values::shaped(&theta[r.clone()], &shape),
                            u: uu.map(|v| Values::shaped(&v, &shape)),
                        },
                    );
                }
                Effect::Drift { symbol, basis } => {
                    f.effects.thermal_drift.insert(
                        sym.location[*symbol].name.clone(),
                        DriftEntry {
                            per: basis.name().to_string(),
                            rate: q(o),
                        },
                    );
                }
                Effect::Scale { axis } => {
                    f.effects
                        .linear_scale
                        .insert(format!("E{0}{0}", axis.letter()), q(o));
                }
                Effect::Squareness { kind } => {
                    f.effects.squareness.insert(kind.symbol().to_string(), q(o));
                }
                Effect::Straightness {
                    moving,
                    direction,
                    nodes,
                } => {
                    let mut n = IndexMap::new();
                    n.insert(moving.letter().to_string(), nodes.clone());
                    let uu: Option<Vec<f64>> = u[r.clone()].iter().copied().collect();
                    f.effects.straightness.insert(
                        format!("E{}{}", direction.letter(), moving.letter()),
                        MapEntry {
                            nodes: n,
                            values: Values::Flat(theta[r.clone()].to_vec()),
                            u: uu.map(Values::Flat),
                        },
                    );
                }
                Effect::Positioning { axis, nodes } => {
                    let mut n = IndexMap::new();
                    n.insert(axis.letter().to_string(), nodes.clone());
                    let uu: Option<Vec<f64>> = u[r.clone()].iter().copied().collect();
                    f.effects.positioning.insert(
                        format!("E{0}{0}", axis.letter()),
                        MapEntry {
                            nodes: n,
                            values: Values::Flat(theta[r.clone()].to_vec()),
                            u: uu.map(Values::Flat),
                        },
                    );
                }
                Effect::Angular {
                    about,
                    moving,
                    nodes,
                } => {
                    let mut n = IndexMap::new();
                    n.insert(moving.letter().to_string(), nodes.clone());
                    let uu: Option<Vec<f64>> = u[r.clone()].iter().copied().collect();
                    f.effects.angular.insert(
                        format!("E{}{}", about.rot_letter(), moving.letter()),
                        MapEntry {
                            nodes: n,
                            values: Values::Flat(theta[r.clone()].to_vec()),
                            u: uu.map(Values::Flat),
                        },
                    );
                }
                Effect::ToolRadius => f.effects.tool_radius = Some(q(o)),
                Effect::ToolLength => f.effects.tool_length = Some(q(o)),
                Effect::ProbePretravel => {
                    for (k, d) in PROBE_DIRECTIONS.iter().enumerate() {
                        f.effects.probe_pretravel.insert(d.to_string(), q(o + k));
                    }
                }
            }
        }
        if noise.cmm.is_some() || noise.probe.is_some() {
            f.effects.noise = Some(noise.clone());
        }
        f
    }
}

/// Checks the shape of node values and reorders them to the sorted node
/// order (`perms[d][k]` = input index of sorted node `k` of dimension `d`).
fn map_values<E>(
    v: &Values,
    shape: &[usize],
    perms: &[Vec<usize>],
    err: impl Fn(String) -> E,
) -> Result<Vec<f64>, E> {
    let ok_shape = match (v, shape.len()) {
        (Values::Flat(x), 1) => x.len() == shape[0],
        (Values::Rows(r), 2) => r.len() == shape[0] && r.iter().all(|row| row.len() == shape[1]),
        // A single-row grid may be written flat.
        (Values::Flat(x), 2) => shape[0] == 1 && x.len() == shape[1],
        _ => false,
    };
    if !ok_shape {
        let want = if shape.len() == 1 {
            format!("a list of {} numbers", shape[0])
        } else {
            format!("{} rows of {} numbers", shape[0], shape[1])
        };
        return Err(err(format!("values must be {want} (one per node)")));
    }
    let flat = v.flatten();
    if flat.iter().any(|x| !x.is_finite()) {
        return Err(err("values must be finite numbers".to_string()));
    }
    let out = if shape.len() == 1 {
        perms[0].iter().map(|&i| flat[i]).collect()
    } else {
        let mut out = Vec::with_capacity(flat.len());
        for &i in &perms[0] {
            for &j in &perms[1] {
                out.push(flat[i * shape[1] + j]);
            }
        }
        out
    };
    Ok(out)
}
