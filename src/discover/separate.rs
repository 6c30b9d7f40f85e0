//! After an ambiguity: the supplementary test that would separate the
//! rivals. Two effects a test cannot tell apart move its measurements
//! alike at its poses; at other poses they need not. The candidates are
//! short probing runs of the calibration sphere on the same machine (every
//! tilt of a sweep over the first test's tilt range with every C of a set,
//! from coarse to fine; the probe-sphere test takes any pose), each
//! planned and measured on the simulator without errors or noise (its
//! design, as `plan` predicts what a test identifies,
//! [`crate::analyze::preview`]), and fitted together with the first test's
//! measurements, as the next `discover` run will fit them. Each rival is
//! then set, with the values it was fitted with, against every other: the
//! directions it adds beside the other (the identifiability analysis of the
//! two tests' joint design) and the noncentrality of what the other cannot
//! explain of it, at the instruments' noise, give the chance that the next
//! run finds it significant beside the other (the power of the chi-square
//! test at the search's level after its adjustment). The first candidate
//! with which every rival is told from every other with a power of 0.9 or
//! more is proposed; `fivecal plan --supplement` writes it.

use std::sync::atomic::{AtomicUsize, Ordering};

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use super::catalogue::{self, Candidate};
use super::fit::{Fit, Fitter, Part, Spec};
use super::{DiscoverOptions, column_space, stats};
use crate::analyze::goodness::ExpectedNoise;
use crate::errorfile::{Separation, Supplement};
use crate::formats::manifest::KinematicsMode;
use crate::model::Effect;
use crate::post::PostDefinition;
use crate::procedure::{Plan, PlanConfig, Template, Test};

/// The power every rival must have against every other.
pub(crate) const POWER: f64 = 0.9;

/// The supplementary test's name.
const TEST: Test = Test::ProbeSphere;

/// The template of the supplementary test: the built-in probe-sphere
/// template with the pattern `grid` on the angles of `s`.
pub fn template_text(s: &Supplement) -> String {
    let list = |v: &[f64]| {
        v.iter()
            .map(|a| crate::procedure::short(*a))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let mut out = format!(
        "# The supplementary test `fivecal discover` asked for (new poses {}).\n",
        s.new_poses.join(", ")
    );
    let mut in_grid = false;
    for line in TEST.template_text().lines() {
        if in_grid && line.starts_with(' ') {
            continue;
        }
        in_grid = line.starts_with("grid:");
        if in_grid {
            continue;
        }
        if line.starts_with("pattern:") {
            out.push_str("pattern: grid                 # every tilt with every C\n");
        } else {
            out.push_str(line);
            out.push('\n');
        }
    }
    out.push_str(&format!(
        "\ngrid:\n  tilt: [{}]\n  c: [{}]\n",
        list(&s.tilt),
        list(&s.c)
    ));
    out
}

/// Why a supplementary test cannot be planned: its own template does not
/// read, or the plan refuses it.
#[derive(Debug, thiserror::Error)]
pub(crate) enum SupplementError {
    #[error(transparent)]
    Template(#[from] crate::source::SourceError),
    #[error(transparent)]
    Plan(#[from] crate::procedure::PlanError),
}

/// The supplementary test planned for the machine and dialect of `first`.
pub(crate) fn plan_supplement(first: &Plan, s: &Supplement) -> Result<Plan, SupplementError> {
    let text = template_text(s);
    let template = Template::parse(std::path::Path::new("<supplement>"), &text)?;
    Ok(crate::procedure::plan(&PlanConfig {
        machine: first.machine().clone(),
        template,
        post: PostDefinition::builtin(first.dialect()),
        kinematics: KinematicsMode::Post,
        tool: None,
    })?)
}

/// Why no supplementary test is proposed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum NoSupplement {
    /// Points without a plan: nothing to plan beside.
    #[error("the measurements come without their plan, so no test can be planned beside them")]
    NoPlan,
    /// The model lacks the location errors every joint model starts from.
    #[error("the model has no location errors")]
    NoLocation,
    /// An effect of the model has no counterpart on the two tests together.
    #[error("{0} has no counterpart on the two tests together")]
    NoCounterpart(String),
    /// An effect of the model the joint forward model cannot apply.
    #[error("{0} is not served")]
    NotServed(String),
    /// A rival's fitted values do not carry to the joint grid.
    #[error("{0} cannot be carried to the joint grid")]
    NotCarried(String),
    /// No run of the test can be planned on the machine.
    #[error("no {TEST} test can be planned on this machine beside the first test")]
    NothingPlannable,
    /// Runs were tried and none has the power asked for.
    #[error(
        "none of the {0} {TEST} runs tried (tilt steps of 45 to 10 deg over the test's tilt range, each tilt at its C angles or every 45 or 30 deg) tells every rival from every other with a power of {POWER} at the instruments' noise"
    )]
    NoneSeparates(usize),
}

/// A rival of the ambiguity: its candidate and its fit beside the model.
pub struct AmbiguityRival<'a> {
    /// The candidate.
    pub candidate: &'a Candidate,
    /// The model with it, fitted to the first test.
    pub fit: &'a Fit,
}

/// The values of `old`'s parameters (`values`) carried to `new`, the same
/// effect on another grid: a map or a straightness read at the new nodes
/// by its own interpolation, any other effect as it is.
pub(crate) fn regrid(old: &Effect, values: &[f64], new: &Effect) -> Option<Vec<f64>> {
    match (old, new) {
        (
            Effect::Map {
                symbol: a,
                grid: g0,
            },
            Effect::Map {
                symbol: b,
                grid: g1,
            },
        ) if a == b => Some(
            (0..g1.len())
                .map(|i| {
                    let at = g1.node_angles(i);
                    let angle = |k: usize| at.iter().find(|x| x.0 == k).map_or(0.0, |x| x.1);
                    g0.weights(angle(0), angle(1))
                        .iter()
                        .map(|&(j, w)| w * values[j])
                        .sum()
                })
                .collect(),
        ),
        (
            Effect::Straightness {
                moving,
                direction,
                nodes: n0,
            },
            Effect::Straightness {
                moving: m1,
                direction: d1,
                nodes: n1,
            },
        ) if moving == m1 && direction == d1 => {
            let dim = crate::kinematics::maps::MapDim::new(0, n0, false).ok()?;
            Some(
                n1.iter()
                    .map(|&x| dim.weights(x).iter().map(|&(j, w)| w * values[j]).sum())
                    .collect(),
            )
        }
        (a, b) if a == b => Some(values.to_vec()),
        _ => None,
    }
}

/// The span of what `spec` and the nuisance do to the measurements, at
/// the nominal machine (orthonormal columns).
fn span(fitter: &Fitter<'_>, spec: &Spec) -> DMatrix<f64> {
    let (basis, _) = spec.basis(fitter.extra());
    column_space(&(fitter.jacobian0(spec) * basis), fitter.opts.rank_rtol)
}

/// The distinct angles of the poses of `parts`, tilt and C.
fn angles(parts: &[Part<'_>]) -> (Vec<f64>, Vec<f64>) {
    let mut t: Vec<f64> = Vec::new();
    let mut c: Vec<f64> = Vec::new();
    for p in parts.iter().flat_map(|p| p.data.poses.iter()) {
        if !t.iter().any(|x| (x - p.tilt).abs() < 1e-6) {
            t.push(p.tilt);
        }
        let cc = p.c.rem_euclid(360.0);
        if !c.iter().any(|x| (x - cc).abs() < 1e-6) {
            c.push(cc);
        }
    }
    t.sort_by(f64::total_cmp);
    c.sort_by(f64::total_cmp);
    (t, c)
}

/// The candidate grids (tilt angles, C angles), fewest poses first: tilt
/// steps of 45 to 10 deg over the first test's tilt range (each adding
/// tilts it does not have), C angles its own (or four) or every 45 or 30
/// deg. `plan` tries the first of them too, where a design leaves
/// location errors unidentified ([`crate::discover::suggest`]).
pub fn candidates(first: &Plan, tilts: &[f64], cs: &[f64]) -> Vec<(Vec<f64>, Vec<f64>)> {
    let m = first.machine();
    let (mut lo, mut hi) = (tilts[0], tilts[tilts.len() - 1]);
    if hi - lo < 1.0 {
        // One tilt angle: sweep what the machine reaches, within +-90.
        let (a, b) = m.tilt.limits.unwrap_or((-90.0, 90.0));
        (lo, hi) = (a.max(-90.0), b.min(90.0));
    }
    let steps = |from: f64, to: f64, step: f64| -> Vec<f64> {
        let n = ((to - from) / step + 1e-9).floor() as usize;
        (0..=n).map(|i| from + i as f64 * step).collect()
    };
    let own = if cs.len() >= 2 {
        cs.to_vec()
    } else {
        steps(0.0, 270.0, 90.0)
    };
    let mut out = Vec::new();
    for ts in [45.0, 30.0, 15.0, 10.0] {
        if hi - lo < ts {
            continue;
        }
        let tilt = steps(lo, hi, ts);
        if tilt
            .iter()
            .all(|a| tilts.iter().any(|t| (t - a).abs() < 1e-6))
        {
            continue;
        }
        for c in [
            own.clone(),
            steps(0.0, 315.0, 45.0),
            steps(0.0, 330.0, 30.0),
        ] {
            if !out.contains(&(tilt.clone(), c.clone())) {
                out.push((tilt.clone(), c));
            }
        }
    }
    out.sort_by_key(|(t, c)| t.len() * c.len());
    out
}

/// The supplementary test that separates `rivals`, the effects that
/// explain the gap of the model `base` equally on `parts`; `tested`
/// candidates were tried in the round (the adjustment of the level).
/// `Err` says why none is proposed.
pub fn find(
    parts: &[Part<'_>],
    base: &Spec,
    rivals: &[AmbiguityRival<'_>],
    opts: &DiscoverOptions,
    tested: usize,
) -> Result<Supplement, NoSupplement> {
    let Some(first) = parts[0].plan else {
        return Err(NoSupplement::NoPlan);
    };
    let (tilts, cs) = angles(parts);
    // The next run tests each rival at the search's level, adjusted for
    // about as many candidates as this round tried.
    let alpha = opts.alpha / tested.max(rivals.len()).max(1) as f64;
    let expected = |p: &Part<'_>| {
        ExpectedNoise::new(
            opts.noise,
            p.data.kind,
            p.plan.map_or(Test::SteppedSquare, |pl| pl.test()),
        )
    };
    // Each grid is judged on its own, so they are judged in parallel; the
    // first in order (fewest poses first) that separates every rival, or
    // that shows none can, decides, as when they were judged one by one.
    // A grid the machine can probe counts as tried.
    let tried = AtomicUsize::new(0);
    let decided = candidates(first, &tilts, &cs)
        .into_par_iter()
        .find_map_first(|(tilt, c)| {
            let mut s = Supplement {
                test: TEST.as_str().to_string(),
                tilt,
                c,
                new_poses: Vec::new(),
                poses: 0,
                touches: 0,
                noise_um: 0.0,
                power: Vec::new(),
                plan: None,
            };
            // A grid the machine cannot probe (limits, collisions) is not a
            // candidate.
            let Ok(plan) = plan_supplement(first, &s) else {
                return None;
            };
            let Ok(nominal) = crate::analyze::preview::nominal_data(&plan) else {
                return None;
            };
            tried.fetch_add(1, Ordering::Relaxed);
            let kin = crate::simulate::plan_kinematics(&plan);
            let mut all: Vec<Part<'_>> = parts.to_vec();
            all.push(Part {
                kin: &kin,
                data: &nominal,
                plan: Some(&plan),
                label: TEST.as_str(),
            });
            let noises: Vec<(String, ExpectedNoise, usize)> = all
                .iter()
                .map(|p| (p.label.to_string(), expected(p), p.data.obs.len()))
                .collect();
            let pooled = ExpectedNoise::pooled(
                &noises
                    .iter()
                    .map(|(n, e, k)| (n.as_str(), e, *k))
                    .collect::<Vec<_>>(),
            );
            // The model's own effects and the rivals, on the joint grids.
            let cat = catalogue::catalogue(&all);
            let wanted: Vec<Candidate> = cat
                .candidates
                .iter()
                .filter(|c| {
                    base.names.contains(&c.name)
                        || rivals.iter().any(|r| r.candidate.name == c.name)
                })
                .cloned()
                .collect();
            let Ok((fitter, _)) = Fitter::new(&all, &wanted) else {
                return None;
            };
            let Some(Effect::Location { symbols }) = base.model.effects.first() else {
                return Some(Err(NoSupplement::NoLocation));
            };
            let mut model = fitter.location(symbols);
            for n in base.names.iter().skip(1) {
                let Some(c) = wanted.iter().find(|c| &c.name == n) else {
                    return Some(Err(NoSupplement::NoCounterpart(n.clone())));
                };
                let Some(with) = fitter.extend(&model, c) else {
                    return Some(Err(NoSupplement::NotServed(n.clone())));
                };
                model = with;
            }
            let joint: Vec<(&AmbiguityRival<'_>, &Candidate)> = rivals
                .iter()
                .filter_map(|r| {
                    wanted
                        .iter()
                        .find(|c| c.name == r.candidate.name)
                        .map(|c| (r, c))
                })
                .collect();
            if joint.len() < rivals.len() {
                return None;
            }
            let mut power = Vec::new();
            for (ra, ca) in &joint {
                let ei = ra.fit.spec.names.len() - 1;
                let range = ra.fit.spec.model.param_range(ei);
                let Some(values) = regrid(&ra.candidate.effect, &ra.fit.x[range], &ca.effect)
                else {
                    return Some(Err(NoSupplement::NotCarried(ca.name.clone())));
                };
                let signal = fitter
                    .signal(&ca.name, &values)
                    .unwrap_or_else(|| DVector::zeros(fitter.len()));
                for (rb, cb) in &joint {
                    if rb.candidate.name == ra.candidate.name {
                        continue;
                    }
                    let Some(with_b) = fitter.extend(&model, cb) else {
                        continue;
                    };
                    let Some(both) = fitter.extend(&with_b, ca) else {
                        continue;
                    };
                    let q = span(&fitter, &with_b);
                    let directions = span(&fitter, &both).ncols().saturating_sub(q.ncols());
                    let left = &signal - &q * (q.transpose() * &signal);
                    let lambda = left.norm_squared() / (pooled.um * pooled.um);
                    power.push(Separation {
                        effect: ca.name.clone(),
                        against: cb.name.clone(),
                        directions,
                        power: stats::power(directions, lambda, alpha),
                    });
                }
            }
            if power.iter().all(|p| p.power >= POWER) {
                s.new_poses = plan
                    .poses()
                    .iter()
                    .filter(|p| {
                        !(tilts.iter().any(|t| (t - p.tilt).abs() < 1e-6)
                            && cs.iter().any(|c| (c - p.c.rem_euclid(360.0)).abs() < 1e-6))
                    })
                    .map(|p| p.pose.clone())
                    .collect();
                s.poses = plan.poses().len();
                s.touches = nominal.obs.len();
                s.noise_um = pooled.um;
                s.power = power;
                return Some(Ok(s));
            }
            None
        });
    if let Some(d) = decided {
        return d;
    }
    let tried = tried.into_inner();
    Err(if tried == 0 {
        NoSupplement::NothingPlannable
    } else {
        NoSupplement::NoneSeparates(tried)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::maps::{MapDim, MapGrid};

    #[test]
    fn a_map_is_carried_to_finer_nodes_by_its_own_interpolation() {
        let grid = |nodes: &[f64]| MapGrid {
            dims: vec![MapDim::new(0, nodes, false).unwrap()],
        };
        let old = Effect::Map {
            symbol: 0,
            grid: grid(&[-90.0, 0.0, 90.0]),
        };
        let new = Effect::Map {
            symbol: 0,
            grid: grid(&[-90.0, -45.0, 0.0, 45.0, 90.0]),
        };
        let v = regrid(&old, &[4.0, -1.0, -3.0], &new).unwrap();
        assert_eq!(v, [4.0, 1.5, -1.0, -2.0, -3.0]);
        // Another map is not the same effect.
        let other = Effect::Map {
            symbol: 1,
            grid: grid(&[-90.0, 0.0, 90.0]),
        };
        assert!(regrid(&old, &[4.0, -1.0, -3.0], &other).is_none());
        assert_eq!(
            regrid(&Effect::ToolRadius, &[2.5], &Effect::ToolRadius).unwrap(),
            [2.5]
        );
    }

    #[test]
    fn the_supplements_template_is_a_probe_sphere_grid() {
        let s = Supplement {
            test: "probe-sphere".into(),
            tilt: vec![-90.0, -45.0, 0.0, 45.0, 90.0],
            c: vec![0.0, 90.0, 180.0, 270.0],
            new_poses: vec!["B-45C0".into()],
            poses: 20,
            touches: 92,
            noise_um: 0.35,
            power: Vec::new(),
            plan: None,
        };
        let text = template_text(&s);
        let t = crate::procedure::probing::sphere::SphereTemplate::parse(
            crate::procedure::TemplateSource::new(std::path::Path::new("s.yaml"), &text),
        )
        .unwrap();
        assert_eq!(
            t.pattern,
            crate::procedure::probing::sphere::SpherePattern::Grid {
                tilt: s.tilt.clone(),
                c: s.c.clone()
            }
        );
        assert!(text.starts_with("# The supplementary test") && text.contains("B-45C0"));
    }
}
