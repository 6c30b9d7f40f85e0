//! The gap between measurement and model: the residuals of a fit (um,
//! measured minus predicted along the surface normal), overall and broken
//! down by pose, by face of the piece, by the machine direction the
//! measurement is taken along, and by execution order, with a one-line
//! account of where it is concentrated (the LAMDAMAP 2015 paper's residual analysis: a
//! residual that is not noise has a pattern, and the pattern names its
//! cause: a drift grows with the sequence, a scale error lives along one
//! machine axis, a map in some poses).

use nalgebra::Vector3;
use serde::Serialize;
use statrs::function::gamma::{gamma_lr, gamma_ur};

use crate::identify::Dataset;
use crate::identify::result::face_name;
use crate::kinematics::Kinematics;

/// RMS and maximum of a set of residuals.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct GapSize {
    /// Root mean square, um.
    pub rms_um: f64,
    /// Largest absolute value, um.
    pub max_um: f64,
}

/// One group of residuals.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Group {
    /// The group (`B90C0`, `+Z`, `machine +X`, `seq 4`).
    pub name: String,
    /// Number of points.
    pub points: usize,
    /// Mean residual, um (a shift the group shares).
    pub mean_um: f64,
    /// RMS residual, um.
    pub rms_um: f64,
    /// Largest absolute residual, um.
    pub max_um: f64,
    /// Share of the squared gap, 0..1.
    pub share: f64,
}

/// The gap of one fit, with its breakdowns.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Gap {
    /// RMS, um.
    pub rms_um: f64,
    /// Largest absolute residual, um.
    pub max_um: f64,
    /// Number of points.
    pub points: usize,
    /// By pose, in execution order.
    pub by_pose: Vec<Group>,
    /// By face of the piece (outward normal in W).
    pub by_face: Vec<Group>,
    /// By the machine-frame direction of the measurement (the surface
    /// normal at its pose, to the nearest axis).
    pub by_direction: Vec<Group>,
    /// By execution order: the first, middle and last third of the poses.
    pub by_sequence: Vec<Group>,
    /// Where the gap is concentrated, in words.
    pub summary: String,
}

impl Gap {
    /// RMS and maximum.
    pub fn size(&self) -> GapSize {
        GapSize {
            rms_um: self.rms_um,
            max_um: self.max_um,
        }
    }
}

/// RMS and maximum of residuals.
pub fn size(r: &[f64]) -> GapSize {
    let n = r.len().max(1) as f64;
    GapSize {
        rms_um: (r.iter().map(|v| v * v).sum::<f64>() / n).sqrt(),
        max_um: r.iter().fold(0.0f64, |a, v| a.max(v.abs())),
    }
}

fn direction_name(n: &Vector3<f64>) -> String {
    let (i, v) = (0..3)
        .map(|i| (i, n[i]))
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .unwrap_or((2, 1.0));
    format!(
        "machine {}{}",
        if v >= 0.0 { '+' } else { '-' },
        ['X', 'Y', 'Z'][i]
    )
}

fn groups(keys: &[(String, f64)], total: f64) -> Vec<Group> {
    let mut order: Vec<String> = Vec::new();
    let mut vals: Vec<Vec<f64>> = Vec::new();
    for (k, r) in keys {
        match order.iter().position(|o| o == k) {
            Some(i) => vals[i].push(*r),
            None => {
                order.push(k.clone());
                vals.push(vec![*r]);
            }
        }
    }
    order
        .into_iter()
        .zip(vals)
        .map(|(name, v)| {
            let n = v.len() as f64;
            let ss: f64 = v.iter().map(|x| x * x).sum();
            Group {
                name,
                points: v.len(),
                mean_um: v.iter().sum::<f64>() / n,
                rms_um: (ss / n).sqrt(),
                max_um: v.iter().fold(0.0f64, |a, x| a.max(x.abs())),
                share: if total > 0.0 { ss / total } else { 0.0 },
            }
        })
        .collect()
}

/// The gap of residuals `r` (one per observation of `data`).
pub fn gap(kin: &Kinematics, data: &Dataset, r: &[f64]) -> Gap {
    let s = size(r);
    let total: f64 = r.iter().map(|v| v * v).sum();
    let mut pose_keys = Vec::new();
    let mut seq_keys = Vec::new();
    let np = data.poses.len();
    let third = |i: usize| -> &'static str {
        if np < 3 {
            return "all poses";
        }
        match 3 * i / np {
            0 => "first third of the poses",
            1 => "middle third of the poses",
            _ => "last third of the poses",
        }
    };
    for (i, pose) in data.poses.iter().enumerate() {
        for &k in &pose.obs {
            pose_keys.push((pose.id.clone(), r[k]));
            seq_keys.push((third(i).to_string(), r[k]));
        }
    }
    let mut face_keys = Vec::new();
    let mut dir_keys = Vec::new();
    for (k, &rk) in r.iter().enumerate() {
        let p = data.point(k);
        face_keys.push((face_name(&p.n), rk));
        let nm = kin.nominal_table_transform(p.tilt, p.c).rotation * p.n;
        dir_keys.push((direction_name(&nm), rk));
    }
    let mut g = Gap {
        rms_um: s.rms_um,
        max_um: s.max_um,
        points: r.len(),
        by_pose: groups(&pose_keys, total),
        by_face: groups(&face_keys, total),
        by_direction: groups(&dir_keys, total),
        by_sequence: groups(&seq_keys, total),
        summary: String::new(),
    };
    g.summary = summarize(&g);
    g
}

/// Fewest points a group must have to be named.
const MIN_POINTS: usize = 4;

/// Whether a group's residuals differ from the overall level by more than
/// chance: with every residual of variance `ms` (the overall mean square),
/// `points * (rms/overall)^2` follows chi-square with `points` degrees of
/// freedom; the tail must fall below `0.01 / groups` (Bonferroni over the
/// groups of the breakdown), and the group must be at least 1.4 times
/// (`high`) or at most 0.6 times (`!high`) the overall RMS to be worth
/// naming.
fn stands_out(g: &Group, rms: f64, groups: usize, high: bool) -> bool {
    // A group of a few points (a touch of a sphere is its own "face") says
    // nothing about a pattern.
    if g.points < MIN_POINTS || rms <= 0.0 {
        return false;
    }
    let ratio = g.rms_um / rms;
    if (high && ratio < 1.4) || (!high && ratio > 0.6) {
        return false;
    }
    let k = g.points as f64;
    let x = k * ratio * ratio;
    let tail = if high {
        gamma_ur(k / 2.0, x / 2.0)
    } else {
        gamma_lr(k / 2.0, x / 2.0)
    };
    tail < 0.01 / groups.max(1) as f64
}

/// The groups that stand out high (or low), largest (smallest) first, at
/// most three.
fn standouts(groups: &[Group], rms: f64, high: bool) -> Vec<&Group> {
    let mut v: Vec<&Group> = groups
        .iter()
        .filter(|g| stands_out(g, rms, groups.len(), high))
        .collect();
    v.sort_by(|a, b| {
        if high {
            b.rms_um.total_cmp(&a.rms_um)
        } else {
            a.rms_um.total_cmp(&b.rms_um)
        }
    });
    v.truncate(3);
    v
}

fn summarize(g: &Gap) -> String {
    let list = |v: &[&Group]| -> String {
        v.iter()
            .map(|x| format!("{} ({:.2} um RMS)", x.name, x.rms_um))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let mut high = Vec::new();
    let mut low = Vec::new();
    for (what, groups) in [
        ("in poses", &g.by_pose),
        ("on faces", &g.by_face),
        ("along", &g.by_direction),
    ] {
        let h = standouts(groups, g.rms_um, true);
        if !h.is_empty() {
            high.push(format!("{what} {}", list(&h)));
        }
        let l = standouts(groups, g.rms_um, false);
        if !l.is_empty() {
            low.push(format!("small {what} {}", list(&l)));
        }
    }
    let mut parts = Vec::new();
    if !high.is_empty() {
        parts.push(format!("concentrated {}", high.join("; ")));
    }
    parts.extend(low);
    // A group whose residuals share a sign is displaced as a whole (a
    // tool that cuts every wall deeper, a pre-travel on every touch of an
    // approach): its mean stands out from the noise of a mean of that
    // many points (3.5 standard errors) and is half the overall RMS or
    // more.
    let mut shifted: Vec<&Group> = g
        .by_face
        .iter()
        .filter(|x| {
            if x.points < MIN_POINTS {
                return false;
            }
            let se = g.rms_um / (x.points as f64).sqrt();
            x.mean_um.abs() > 3.5 * se && x.mean_um.abs() >= 0.5 * g.rms_um
        })
        .collect();
    shifted.sort_by(|a, b| b.mean_um.abs().total_cmp(&a.mean_um.abs()));
    if !shifted.is_empty() {
        let list: Vec<String> = shifted
            .iter()
            .take(4)
            .map(|x| format!("{} {:+.2} um", x.name, x.mean_um))
            .collect();
        parts.push(format!(
            "faces shifted as a whole (mean residual: {}{})",
            list.join(", "),
            if shifted.len() > 4 { ", ..." } else { "" }
        ));
    }
    if g.by_sequence.len() == 3 {
        // A drift shifts the late poses against the early ones: the mean
        // residuals of the first and the last third part by more than
        // their noise (a difference of 3.5 standard errors).
        let (a, c) = (&g.by_sequence[0], &g.by_sequence[2]);
        let se = g.rms_um * (1.0 / a.points as f64 + 1.0 / c.points as f64).sqrt();
        if se > 0.0 && (c.mean_um - a.mean_um).abs() > 3.5 * se {
            parts.push(format!(
                "drifting over the sequence (mean residual {:+.2} um in the first third of the poses, {:+.2} um in the last)",
                a.mean_um, c.mean_um
            ));
        }
    }
    if parts.is_empty() {
        "spread evenly over poses, faces, directions and the sequence, as noise is".to_string()
    } else {
        parts.join("; ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_keep_order_and_shares_sum_to_one() {
        let keys: Vec<(String, f64)> = [("a", 1.0), ("b", 2.0), ("a", -3.0)]
            .iter()
            .map(|(k, v)| (k.to_string(), *v))
            .collect();
        let g = groups(&keys, 14.0);
        assert_eq!(g[0].name, "a");
        assert_eq!(g[0].points, 2);
        assert!((g[0].mean_um + 1.0).abs() < 1e-12);
        assert!((g[0].rms_um - 5f64.sqrt()).abs() < 1e-12);
        assert_eq!(g[0].max_um, 3.0);
        assert!((g[0].share + g[1].share - 1.0).abs() < 1e-12);
        assert_eq!(direction_name(&Vector3::new(0.1, -0.9, 0.2)), "machine -Y");
    }
}
