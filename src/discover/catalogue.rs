//! The candidate effects `discover` tries: the model's own catalogue of
//! named effects ([`crate::model::Effect`], shared with `simulate`)
//! instantiated for one machine and one test: each location symbol's
//! thermal drift per pose and per minute, the linear axes' scale,
//! squareness and straightness, the tilt-axis and C-axis error maps on the
//! plan's angles, the tool's radius and length, the probe's pre-travel.
//!
//! Some candidates carry their own defining constraints, so that they mean
//! what their symbols mean and do not duplicate the model: a map averages
//! to zero over its angles (Ibaraki & Ota 2014, eq. 1, Ibaraki, Iritani & Matsushita 2013, eq. 1; the location
//! error stays the axis average line), a straightness is taken from its
//! least-squares reference line (ISO 230-1: its mean and slope are a
//! position and a squareness, not a straightness), the line fitted over the
//! positions where the test senses it: a few sampled positions are all a
//! test can tell a squareness by.

use nalgebra::{DVector, Point3};

use super::part::Part;
use crate::formats::manifest::TestKind;
use crate::geom::Axis3;
use crate::identify::identifiability::Combination;
use crate::identify::{Dataset, Setup};
use crate::kinematics::Kinematics;
use crate::kinematics::maps::MapDim;
use crate::kinematics::symbols::SymbolTable;
use crate::model::{DriftBasis, Effect, Squareness};

/// A constraint row on an effect's parameters (their combination that is
/// fixed at zero), with what it says.
pub type ConstraintRow = (Vec<f64>, Why);

/// What a constraint row says.
#[derive(Clone, Debug, PartialEq)]
pub enum Why {
    /// A defining constraint, in words.
    Text(String),
    /// A combination of the effect's parameters the test does not see,
    /// fixed at zero (named when shown).
    Unseen(Combination),
}

/// How the words of a constraint fixing an unseen combination end.
const UNSEEN: &str = "= 0: this test does not see it";

impl std::fmt::Display for Why {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Why::Text(t) => f.write_str(t),
            Why::Unseen(c) => write!(f, "{c} {UNSEEN}"),
        }
    }
}

impl From<String> for Why {
    fn from(t: String) -> Why {
        Why::Text(t)
    }
}

/// One candidate effect.
#[derive(Clone, Debug, PartialEq)]
pub struct Candidate {
    /// Unique name in the story: the effect's identifier, with `/seq` or
    /// `/minute` for a drift (`drift.EZ0B/seq`).
    pub name: String,
    /// The effect.
    pub effect: Effect,
    /// Defining constraints on the effect's own parameters (rows of
    /// coefficients, one per parameter) and what each says.
    pub constraints: Vec<ConstraintRow>,
    /// What it is, in words.
    pub description: String,
}

impl Candidate {
    fn new(name: String, effect: Effect, description: String) -> Candidate {
        Candidate {
            name,
            effect,
            constraints: Vec::new(),
            description,
        }
    }

    /// Whether `pattern` selects this candidate: its full name, its
    /// effect identifier, or a family prefix (`drift`, `map`, `scale`,
    /// `squareness`, `straightness`, `drift.EZ0B`).
    pub fn matches(&self, pattern: &str, id: &str) -> bool {
        let p = pattern.trim();
        self.name == p
            || id == p
            || self.name.starts_with(&format!("{p}."))
            || self.name.starts_with(&format!("{p}/"))
    }
}

/// The candidates for one test, and what the user should know about the
/// choice.
#[derive(Clone, Debug, Default)]
pub struct Catalogue {
    /// The candidates, in catalogue order.
    pub candidates: Vec<Candidate>,
    /// Notes (e.g. why the per-minute drifts are not offered).
    pub notes: Vec<String>,
}

/// The commanded machine position of a plan point: `rTw* p` (docs/model.md,
/// frames; for head machines the table part of the chain, which is what the
/// straightness nodes need to span).
fn commanded(kin: &Kinematics, tilt: f64, c: f64, p: &nalgebra::Vector3<f64>) -> [f64; 3] {
    let q = kin.nominal_table_transform(tilt, c) * Point3::from(*p);
    [q.x, q.y, q.z]
}

/// Whether `y` is an affine function of `x` (to round-off).
fn affine(x: &[f64], y: &[f64]) -> bool {
    let n = x.len() as f64;
    if x.len() < 2 {
        return true;
    }
    let mx = x.iter().sum::<f64>() / n;
    let my = y.iter().sum::<f64>() / n;
    let sxx: f64 = x.iter().map(|v| (v - mx).powi(2)).sum();
    let syy: f64 = y.iter().map(|v| (v - my).powi(2)).sum();
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    if syy <= 1e-18 * (1.0 + my * my) || sxx <= 1e-18 {
        return true;
    }
    let r2 = sxy * sxy / (sxx * syy);
    1.0 - r2 < 1e-12
}

/// The catalogue for the measurements of one test, or of several tests of
/// one machine fitted together (`parts`): their poses give the map grids
/// (the union of their angles), the times and the axis ranges; each part's
/// own clock runs from its program's start.
pub fn catalogue(parts: &[Part<'_>]) -> Catalogue {
    let mut out = Catalogue::default();
    let kin = parts[0].kin;
    let sym = crate::model::Model::new(kin.clone(), Vec::new()).symbols;
    drifts(&mut out, parts, &sym);
    scales(&mut out);
    squarenesses(&mut out);
    straightnesses(&mut out, parts);
    maps(&mut out, parts, &sym);
    tool_and_probe(&mut out, parts);
    out
}

/// A thermal drift of each location error, per pose and, where the
/// parts' clocks tell it apart, per minute.
fn drifts(out: &mut Catalogue, parts: &[Part<'_>], sym: &SymbolTable) {
    let clock = |d: &Dataset| -> (bool, bool) {
        let seqs: Vec<f64> = d.poses.iter().map(|p| p.seq as f64).collect();
        let mins: Vec<f64> = d.poses.iter().map(|p| p.minutes).collect();
        let timed = mins.iter().any(|m| (m - mins[0]).abs() > 1e-9);
        (timed, timed && affine(&seqs, &mins))
    };
    let clocks: Vec<(bool, bool)> = parts.iter().map(|p| clock(p.data)).collect();
    let timed = clocks.iter().any(|c| c.0);
    let minutes_as_seq = timed && clocks.iter().all(|c| !c.0 || c.1);
    if !timed {
        out.notes
            .push("the plan gives no times: drifts are tried per pose (seq) only".to_string());
    } else if minutes_as_seq {
        out.notes.push(
            "the poses' times are proportional to their order: a drift per minute is a drift per pose (seq) on this test, so it is tried per pose only"
                .to_string(),
        );
    }
    for (i, ls) in sym.location.iter().enumerate() {
        let mut bases = vec![DriftBasis::Seq];
        if timed && !minutes_as_seq {
            bases.push(DriftBasis::Minute);
        }
        for basis in bases {
            let per = match basis {
                DriftBasis::Seq => "per pose in execution order (seq)",
                DriftBasis::Minute => "per minute",
            };
            out.candidates.push(Candidate::new(
                format!("drift.{}/{}", ls.name, basis.name()),
                Effect::Drift { symbol: i, basis },
                format!("thermal drift of {} ({}) {per}", ls.name, ls.description),
            ));
        }
    }
}

/// The linear positioning (scale) error of each linear axis.
fn scales(out: &mut Catalogue) {
    for axis in [Axis3::X, Axis3::Y, Axis3::Z] {
        out.candidates.push(Candidate::new(
            format!("scale.E{0}{0}", axis.letter()),
            Effect::Scale { axis },
            format!(
                "linear positioning (scale) error of the {} axis",
                axis.letter()
            ),
        ));
    }
}

/// The three squareness errors of the linear axes.
fn squarenesses(out: &mut Catalogue) {
    for kind in Squareness::ALL {
        let what = match kind {
            Squareness::CXY => "squareness of Y to X",
            Squareness::BXZ => "squareness of Z to X",
            Squareness::AYZ => "squareness of Z to Y",
        };
        out.candidates.push(Candidate::new(
            format!("squareness.{}", kind.symbol()),
            Effect::Squareness { kind },
            what.to_string(),
        ));
    }
}

/// The straightness of each linear axis the test moves, in each direction
/// it senses.
fn straightnesses(out: &mut Catalogue, parts: &[Part<'_>]) {
    let kin = parts[0].kin;
    // Straightness: five nodes over the commanded range of the moving axis,
    // taken from its least-squares reference line over the positions where
    // the test senses it (each measured point weighted by the square of its
    // normal's component along the straightness direction), so that on this
    // test it is neither a position nor a squareness.
    let points = || {
        parts
            .iter()
            .flat_map(|part| part.data.obs.iter().map(|o| &part.data.plan.points[o.plan]))
    };
    let cmd: Vec<[f64; 3]> = points()
        .map(|p| commanded(kin, p.tilt, p.c, &p.p))
        .collect();
    let normals: Vec<nalgebra::Vector3<f64>> = points()
        .map(|p| kin.nominal_table_transform(p.tilt, p.c).rotation * p.n)
        .collect();
    for moving in [Axis3::X, Axis3::Y, Axis3::Z] {
        let i = moving.index();
        let (lo, hi) = cmd.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, q| {
            (a.0.min(q[i]), a.1.max(q[i]))
        });
        if hi - lo <= 1.0 || !(hi - lo).is_finite() {
            continue;
        }
        let nodes: Vec<f64> = (0..5)
            .map(|k| ((lo + (hi - lo) * k as f64 / 4.0) * 1e3).round() / 1e3)
            .collect();
        let dim = MapDim {
            angle: 0,
            nodes: nodes.clone(),
            periodic: false,
        };
        for direction in [Axis3::X, Axis3::Y, Axis3::Z] {
            if direction == moving {
                continue;
            }
            let j = direction.index();
            let sense: Vec<f64> = normals.iter().map(|n| n[j] * n[j]).collect();
            let total: f64 = sense.iter().sum();
            if total < 1e-9 {
                continue;
            }
            let mean = cmd.iter().zip(&sense).map(|(q, w)| w * q[i]).sum::<f64>() / total;
            let (mut level, mut slope) = (vec![0.0; nodes.len()], vec![0.0; nodes.len()]);
            for (q, s) in cmd.iter().zip(&sense) {
                for (k, w) in dim.weights(q[i]) {
                    level[k] += s * w;
                    slope[k] += s * w * (q[i] - mean);
                }
            }
            let mut c = Candidate::new(
                format!("straightness.E{}{}", direction.letter(), moving.letter()),
                Effect::Straightness {
                    moving,
                    direction,
                    nodes: nodes.clone(),
                },
                format!(
                    "straightness of the {} axis in {} (5 nodes from {:.0} to {:.0} mm)",
                    moving.letter(),
                    direction.letter(),
                    lo,
                    hi
                ),
            );
            c.constraints = vec![
                (
                    level,
                    "a straightness has no mean where the test senses it (that is a position)"
                        .to_string()
                        .into(),
                ),
                (
                    slope,
                    "a straightness has no slope where the test senses it (that is a squareness)"
                        .to_string()
                        .into(),
                ),
            ];
            out.candidates.push(c);
        }
    }
}

/// An error map of each location error on the plan's angles, with the
/// papers' averaging constraints.
fn maps(out: &mut Catalogue, parts: &[Part<'_>], sym: &SymbolTable) {
    let kin = parts[0].kin;
    // Built by the identification's own setup, so both agree.
    let poses: Vec<crate::identify::data::Pose> = parts
        .iter()
        .flat_map(|p| p.data.poses.iter().cloned())
        .collect();
    for ms in &sym.maps {
        let Ok(s) = Setup::new(kin, &poses, std::slice::from_ref(&ms.name)) else {
            continue;
        };
        let Some(ei) = s.model.find(&format!("map.{}", ms.name)) else {
            continue;
        };
        let r = s.model.param_range(ei);
        if r.len() < 2 {
            continue;
        }
        let mut c = Candidate::new(
            format!("map.{}", ms.name),
            s.model.effects[ei].clone(),
            format!(
                "error map of {} over {} index-angle nodes, added to the location error",
                ms.name,
                r.len()
            ),
        );
        for (row, name) in s.constraints.row_iter().zip(&s.constraint_names) {
            let v: DVector<f64> = row.transpose().rows(r.start, r.len()).into_owned();
            c.constraints
                .push((v.as_slice().to_vec(), Why::Text(name.clone())));
        }
        out.candidates.push(c);
    }
}

/// The tool's radius and length errors where a piece was machined, the
/// probe's length and pre-travel where it probed.
fn tool_and_probe(out: &mut Catalogue, parts: &[Part<'_>]) {
    let has = |kind: TestKind| parts.iter().any(|p| p.data.kind == kind);
    if has(TestKind::Machining) {
        out.candidates.push(Candidate::new(
            "tool_radius".into(),
            Effect::ToolRadius,
            "tool radius error (actual minus nominal)".into(),
        ));
    }
    // One length error for a tool and a probe would say the probe is as
    // much too long as the tool: not a candidate across both.
    if has(TestKind::Machining) && has(TestKind::Probing) {
        out.notes.push(
            "tool_length is not tried: the machined piece's tool and the probing run's probe each have a length error of their own".to_string(),
        );
    } else {
        out.candidates.push(Candidate::new(
            "tool_length".into(),
            Effect::ToolLength,
            if has(TestKind::Machining) {
                "tool length error (actual minus nominal)".into()
            } else {
                "probe length error (actual minus nominal)".into()
            },
        ));
    }
    if has(TestKind::Probing) {
        out.candidates.push(Candidate::new(
            "probe_pretravel".into(),
            Effect::ProbePretravel,
            "probe pre-travel by approach direction (trigger beyond contact)".into(),
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn affine_tells_proportional_times_from_uneven_ones() {
        assert!(affine(&[0.0, 1.0, 2.0], &[1.0, 3.0, 5.0]));
        assert!(!affine(&[0.0, 1.0, 2.0], &[1.0, 3.0, 5.5]));
        assert!(affine(&[0.0, 1.0, 2.0], &[2.0, 2.0, 2.0]));
    }
}
