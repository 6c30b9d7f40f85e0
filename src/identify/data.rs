//! Measured points joined to the plan points they measure.
//!
//! Points with labels join by label. A label the plan does not have, or a
//! DMIS nominal that does not match the plan's nominal point (up to the
//! rigid transform of the CMM program's own alignment), means the file
//! belongs to a different plan, and the file is refused. Points without
//! labels (a plain CMM export) are joined to the nearest nominal point once
//! the piece is placed, with a warning; if they do not fit the piece, or two
//! of them land on the same nominal point, the file is refused too.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use crate::formats::detect::PointSet;
use crate::formats::manifest::TestKind;
use crate::formats::points::{PlanPoint, PlanPoints};
use crate::placement;
use crate::source::SourceError;

/// Coordinates beyond this (mm) are not measurements of a machine tool or
/// a piece on a CMM; they are refused before any arithmetic can overflow.
pub(crate) const MAX_COORDINATE_MM: f64 = 1.0e5;

/// Measured points of a machined piece land within a fraction of a
/// millimetre of their nominal points once the piece is placed (machine
/// errors move them by tens of um); farther means they do not measure this
/// plan's piece, mm.
pub(crate) const FIT_LIMIT_MM: f64 = 1.0;

/// One measured point and the plan point it measures.
#[derive(Clone, Debug, PartialEq)]
pub struct Observation {
    /// Index into the plan points.
    pub plan: usize,
    /// Measured position (CMM frame for machining tests, W at rotary zero
    /// for on-machine probing), mm.
    pub m: Vector3<f64>,
    /// Index of the source file in [`Dataset::files`].
    pub file: usize,
    /// Source line.
    pub line: usize,
}

/// One pose (cut or station) of the plan with its observations.
#[derive(Clone, Debug, PartialEq)]
pub struct Pose {
    /// Pose id.
    pub id: String,
    /// Execution order.
    pub seq: u32,
    /// Tilt angle, deg.
    pub tilt: f64,
    /// C angle, deg.
    pub c: f64,
    /// Minutes from program start (middle of the pose), for drift per minute.
    pub minutes: f64,
    /// Indices into [`Dataset::obs`].
    pub obs: Vec<usize>,
}

/// The measurements of one test (one piece, or one probing run).
#[derive(Clone, Debug, PartialEq)]
pub struct Dataset {
    /// Machined piece on a CMM, or on-machine probing.
    pub kind: TestKind,
    /// The plan's points.
    pub plan: PlanPoints,
    /// Source files.
    pub files: Vec<PathBuf>,
    /// Observations in file order.
    pub obs: Vec<Observation>,
    /// Poses in execution order (only those with observations).
    pub poses: Vec<Pose>,
    /// Things the user should know (unlabelled joins, quirks, unmeasured
    /// plan points).
    pub warnings: Vec<String>,
    /// The separately set-up pieces of a probing test (one name for a
    /// single piece).
    pub pieces: Vec<String>,
    /// The piece of each plan point (index into `pieces`).
    pub piece_of: Vec<usize>,
}

/// A plan point that no piece of a multi-piece setup holds.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("plan point `{label}` belongs to no piece")]
pub struct NoPiece {
    /// The point's label.
    pub label: String,
}

impl Dataset {
    /// The plan point of observation `k`.
    pub fn point(&self, k: usize) -> &PlanPoint {
        &self.plan.points[self.obs[k].plan]
    }

    /// Index of the reference pose: the one at tilt = C = 0 if measured,
    /// otherwise the first in execution order.
    pub(crate) fn reference_pose(&self) -> usize {
        self.poses
            .iter()
            .position(|p| p.tilt.abs() < 1e-9 && crate::geom::wrap180(p.c).abs() < 1e-9)
            .unwrap_or(0)
    }

    /// Assigns the plan points to separately set-up pieces (by label, e.g.
    /// from the probing plan's touches); fails naming a point without one.
    pub fn set_pieces(&mut self, piece: &HashMap<String, String>) -> Result<(), NoPiece> {
        let mut names: Vec<String> = Vec::new();
        let mut of = Vec::with_capacity(self.plan.points.len());
        for p in &self.plan.points {
            let Some(name) = piece.get(&p.label) else {
                return Err(NoPiece {
                    label: p.label.clone(),
                });
            };
            let i = match names.iter().position(|n| n == name) {
                Some(i) => i,
                None => {
                    names.push(name.clone());
                    names.len() - 1
                }
            };
            of.push(i);
        }
        self.pieces = names;
        self.piece_of = of;
        Ok(())
    }

    /// The piece of observation `k`.
    pub fn piece(&self, k: usize) -> usize {
        self.piece_of[self.obs[k].plan]
    }

    /// `file:line` of observation `k`.
    pub fn source(&self, k: usize) -> String {
        let o = &self.obs[k];
        format!("{}:{}", self.files[o.file].display(), o.line)
    }
}

/// Joins the point sets of `files` to the plan.
///
/// `minutes` gives each pose's (start, end) minutes when known (from the
/// manifest). `nominal` is where a plan point would be measured without any
/// error, in the frame of the measured points before placement: the W
/// point itself for a CMM, `rTw* p` for on-machine probing.
pub fn join(
    plan: &PlanPoints,
    kind: TestKind,
    minutes: &HashMap<String, (f64, f64)>,
    files: &[(PathBuf, PointSet)],
    nominal: &dyn Fn(&PlanPoint) -> Vector3<f64>,
) -> Result<Dataset, SourceError> {
    let by_label: HashMap<&str, usize> = plan
        .points
        .iter()
        .enumerate()
        .map(|(i, p)| (p.label.as_str(), i))
        .collect();
    let mut obs: Vec<Observation> = Vec::new();
    let mut seen: HashMap<usize, (usize, usize)> = HashMap::new();
    let mut warnings = Vec::new();
    for p in &plan.points {
        if p.p.amax() > MAX_COORDINATE_MM {
            return Err(SourceError::new(
                Path::new("<plan points>"),
                0,
                0,
                format!(
                    "plan point `{}` lies {:.0} mm from W: beyond {MAX_COORDINATE_MM} mm no machine tool reaches",
                    p.label,
                    p.p.norm()
                ),
            ));
        }
    }
    for (fi, (path, set)) in files.iter().enumerate() {
        for p in &set.points {
            if p.p.amax() > MAX_COORDINATE_MM {
                return Err(SourceError::new(
                    path,
                    p.line,
                    1,
                    format!(
                        "a coordinate of {:.6e} mm is beyond any CMM ({MAX_COORDINATE_MM} mm): expected a measured point in mm",
                        p.p.amax()
                    ),
                ));
            }
        }
        for w in &set.warnings {
            warnings.push(format!("{}: {w}", path.display()));
        }
        if set.points.is_empty() {
            return Err(SourceError::new(
                path,
                0,
                0,
                "no measured points in the file",
            ));
        }
        let matched: Vec<usize> = if set.labeled {
            let m = check_labels(plan, &by_label, path, set)?;
            if kind == TestKind::Machining {
                check_fit(plan, path, set, &m)?;
            }
            m
        } else {
            match_unlabeled(plan, kind, path, set, nominal, &mut warnings)?
        };
        for (p, &pi) in set.points.iter().zip(&matched) {
            if let Some(&(f0, l0)) = seen.get(&pi) {
                let first = &files[f0].0;
                return Err(SourceError::new(
                    path,
                    p.line,
                    1,
                    format!(
                        "plan point `{}` is measured twice (first at {}:{l0})",
                        plan.points[pi].label,
                        first.display()
                    ),
                ));
            }
            let _ = seen.insert(pi, (fi, p.line));
            obs.push(Observation {
                plan: pi,
                m: p.p,
                file: fi,
                line: p.line,
            });
        }
    }
    let missing = plan.points.len() - seen.len();
    if missing > 0 {
        let first = plan
            .points
            .iter()
            .enumerate()
            .find(|(i, _)| !seen.contains_key(i))
            .map(|(_, p)| p.label.clone())
            .unwrap_or_default();
        warnings.push(format!(
            "{missing} of the plan's {} points were not measured (first: `{first}`)",
            plan.points.len()
        ));
    }
    // Poses in execution order.
    let mut poses: Vec<Pose> = Vec::new();
    let mut index: HashMap<String, usize> = HashMap::new();
    for (k, o) in obs.iter().enumerate() {
        let p = &plan.points[o.plan];
        let i = *index.entry(p.pose.clone()).or_insert_with(|| {
            let min = minutes
                .get(&p.pose)
                .map(|(a, b)| 0.5 * (a + b))
                .unwrap_or(0.0);
            poses.push(Pose {
                id: p.pose.clone(),
                seq: p.seq,
                tilt: p.tilt,
                c: p.c,
                minutes: min,
                obs: Vec::new(),
            });
            poses.len() - 1
        });
        poses[i].obs.push(k);
    }
    poses.sort_by_key(|p| p.seq);
    Ok(Dataset {
        kind,
        plan: plan.clone(),
        files: files.iter().map(|f| f.0.clone()).collect(),
        obs,
        poses,
        warnings,
        pieces: vec!["piece".into()],
        piece_of: vec![0; plan.points.len()],
    })
}

fn check_labels(
    plan: &PlanPoints,
    by_label: &HashMap<&str, usize>,
    path: &Path,
    set: &PointSet,
) -> Result<Vec<usize>, SourceError> {
    let mut out = Vec::with_capacity(set.points.len());
    for p in &set.points {
        match by_label.get(p.label.as_str()) {
            Some(&i) => out.push(i),
            None => {
                let known = set
                    .points
                    .iter()
                    .filter(|q| by_label.contains_key(q.label.as_str()))
                    .count();
                let example = plan.points.first().map_or("", |q| q.label.as_str());
                return Err(SourceError::new(
                    path,
                    p.line,
                    1,
                    format!(
                        "label `{}` is not a point of the plan ({known} of the file's {} labels are; the plan's labels look like `{example}`): this file belongs to a different plan",
                        p.label,
                        set.points.len()
                    ),
                ));
            }
        }
    }
    // The nominals a DMIS file states must be the plan's, up to the rigid
    // transform of the CMM program's alignment.
    let pairs: Vec<(usize, Vector3<f64>, usize)> = set
        .nominals
        .iter()
        .filter_map(|n| by_label.get(n.label.as_str()).map(|&i| (i, n.p, n.line)))
        .collect();
    if pairs.len() >= 3 {
        let w: Vec<Vector3<f64>> = pairs.iter().map(|x| plan.points[x.0].p).collect();
        let c: Vec<Vector3<f64>> = pairs.iter().map(|x| x.1).collect();
        if let Ok(t) = placement::kabsch(&w, &c) {
            // The worst point names the mismatch (one bad nominal spreads a
            // little error over the others through the rigid fit).
            let worst = pairs
                .iter()
                .enumerate()
                .map(|(k, x)| (((t * nalgebra::Point3::from(w[k])).coords - x.1).norm(), x))
                .max_by(|a, b| a.0.total_cmp(&b.0));
            if let Some((d, (i, _, line))) = worst
                && d > 0.005
            {
                return Err(SourceError::new(
                    path,
                    *line,
                    1,
                    format!(
                        "the nominal of `{}` in the file is {:.3} mm away from the plan's nominal point: this file was measured with a different plan's CMM program",
                        plan.points[*i].label, d
                    ),
                ));
            }
        }
    }
    Ok(out)
}

/// Labelled points of a machined piece against the plan's geometry: the
/// same labels on another piece (a plan made from an edited template) would
/// otherwise be identified as huge errors. The piece is placed on all
/// points (Kabsch) and every point must lie within [`FIT_LIMIT_MM`] of its
/// nominal point; a file too small to place is left to the identification.
fn check_fit(
    plan: &PlanPoints,
    path: &Path,
    set: &PointSet,
    matched: &[usize],
) -> Result<(), SourceError> {
    let noms: Vec<Vector3<f64>> = matched.iter().map(|&i| plan.points[i].p).collect();
    let meas: Vec<Vector3<f64>> = set.points.iter().map(|p| p.p).collect();
    let Ok(iso) = placement::kabsch(&noms, &meas) else {
        return Ok(());
    };
    let (worst, d) = noms
        .iter()
        .zip(&meas)
        .map(|(n, m)| ((iso * nalgebra::Point3::from(*n)).coords - m).norm())
        .enumerate()
        .fold((0, 0.0f64), |a, (k, d)| if d > a.1 { (k, d) } else { a });
    if d > FIT_LIMIT_MM {
        let p = &set.points[worst];
        return Err(SourceError::new(
            path,
            p.line,
            1,
            format!(
                "`{}` lies {d:.3} mm from its nominal point once the piece is placed (limit {FIT_LIMIT_MM} mm): the points do not measure this plan's piece; this file belongs to a different plan, or its labels are mixed up",
                plan.points[matched[worst]].label
            ),
        ));
    }
    Ok(())
}

/// A measured direction this far from the normal of the plan point its
/// point was joined to means the point lies on another face, deg. Probing
/// directions and measured normals stay within a few degrees of the
/// surface normal; a face beside it is 90 deg away.
pub(crate) const DIRECTION_LIMIT_DEG: f64 = 45.0;

/// Points that carry a direction (a cloud `x y z i j k`) must lie on a
/// face whose normal agrees with it: the nearest nominal point can be on
/// the neighbouring face near an edge, which the direction tells.
/// `normal_in_file` carries a plan point's normal into the frame of the
/// file's points.
fn check_directions(
    plan: &PlanPoints,
    path: &Path,
    set: &PointSet,
    matches: &[usize],
    normal_in_file: &dyn Fn(&PlanPoint) -> Vector3<f64>,
) -> Result<(), SourceError> {
    for (p, &i) in set.points.iter().zip(matches) {
        let Some(d) = p.normal else {
            continue;
        };
        let n = normal_in_file(&plan.points[i]);
        let angle = d.angle(&n).to_degrees();
        if angle > DIRECTION_LIMIT_DEG {
            return Err(SourceError::new(
                path,
                p.line,
                1,
                format!(
                    "the point's direction ({:.4}, {:.4}, {:.4}) is {angle:.1} deg from the normal of plan point `{}`, its nearest nominal point (limit {DIRECTION_LIMIT_DEG} deg): it is not on that face; the export does not follow the plan's points",
                    d.x, d.y, d.z, plan.points[i].label
                ),
            ));
        }
    }
    Ok(())
}

fn match_unlabeled(
    plan: &PlanPoints,
    kind: TestKind,
    path: &Path,
    set: &PointSet,
    nominal: &dyn Fn(&PlanPoint) -> Vector3<f64>,
    warnings: &mut Vec<String>,
) -> Result<Vec<usize>, SourceError> {
    let noms: Vec<(Vector3<f64>, Vector3<f64>)> =
        plan.points.iter().map(|p| (nominal(p), p.n)).collect();
    let measured: Vec<Vector3<f64>> = set.points.iter().map(|p| p.p).collect();
    // The rotation from W to the frame of the measured points.
    let (matches, distances, rotation) = match kind {
        TestKind::Machining => {
            let fit = placement::place_unlabeled(&noms, &measured).map_err(|e| {
                SourceError::new(
                    path,
                    0,
                    0,
                    format!("the points do not fit the plan's piece ({e}): this file belongs to a different plan"),
                )
            })?;
            if let Some(other) = fit.ambiguous_with {
                warnings.push(format!(
                    "{}: the piece is symmetric: another orientation fits almost as well (rms {other:.1} um); the unlabelled points may be joined to the wrong faces",
                    path.display()
                ));
            }
            (fit.matches, fit.distances, fit.fit.iso.rotation)
        }
        TestKind::Probing => {
            let mut out = Vec::new();
            let mut dist = Vec::new();
            for m in &measured {
                let (i, d) = noms
                    .iter()
                    .enumerate()
                    .map(|(i, (q, _))| (i, (q - m).norm()))
                    .min_by(|a, b| a.1.total_cmp(&b.1))
                    .unwrap_or((0, f64::INFINITY));
                out.push(i);
                dist.push(d);
            }
            (out, dist, nalgebra::UnitQuaternion::identity())
        }
    };
    let (worst, max_distance) =
        distances.iter().enumerate().fold(
            (0, 0.0f64),
            |acc, (k, &d)| if d > acc.1 { (k, d) } else { acc },
        );
    if max_distance > FIT_LIMIT_MM {
        let worst = set.points[worst].line;
        return Err(SourceError::new(
            path,
            worst,
            1,
            format!(
                "the points do not fit the plan's piece: one lies {max_distance:.3} mm from the nearest nominal point (limit {FIT_LIMIT_MM} mm): this file belongs to a different plan"
            ),
        ));
    }
    check_directions(plan, path, set, &matches, &|p| {
        // The nominal map is rigid: the difference of two mapped points
        // carries the normal as it carries the piece.
        let tip = PlanPoint {
            p: p.p + p.n,
            ..p.clone()
        };
        rotation * (nominal(&tip) - nominal(p))
    })?;
    let mut first: HashMap<usize, usize> = HashMap::new();
    for (p, &i) in set.points.iter().zip(&matches) {
        if let Some(l) = first.insert(i, p.line) {
            return Err(SourceError::new(
                path,
                p.line,
                1,
                format!(
                    "this point and the one at line {l} are both nearest to plan point `{}`: the export does not follow the plan's points",
                    plan.points[i].label
                ),
            ));
        }
    }
    let directed = set.points.iter().filter(|p| p.normal.is_some()).count();
    let directions = match directed {
        0 => "each takes its plan point's nominal normal as its direction".to_string(),
        n if n == matches.len() => format!(
            "every point's direction agrees with its plan point's normal within {DIRECTION_LIMIT_DEG} deg"
        ),
        n => format!(
            "{n} directions agree with their plan point's normal within {DIRECTION_LIMIT_DEG} deg, the other points take the nominal normal"
        ),
    };
    warnings.push(format!(
        "{}: no labels: {} points joined to the nearest nominal point after placement (largest distance {:.3} mm; {directions}); label the points (DMIS or label,x,y,z) to avoid this",
        path.display(),
        matches.len(),
        max_distance
    ));
    Ok(matches)
}
