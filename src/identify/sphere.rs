//! The `sphere` method (Cubas Brizuela & Yeh 2023, sections 3-5): a calibration sphere probed
//! at many index angles; its centre per pose; circle and plane fits of the
//! centres per rotary axis give each axis line; the location errors are
//! the values for which the exact model has these axis lines.
//!
//! - Sphere centre per pose: least squares on all contact points (free
//!   radius), from the algebraic fit (Cubas Brizuela & Yeh 2023, eq. 3.1-3.2) refined
//!   geometrically. Cubas Brizuela & Yeh 2023 averages four 4-point fits instead; with five
//!   points the least-squares fit is the same estimate with less variance.
//!   The fit is [`crate::shape_fit::fit_sphere`]; [`fit_centre`] adds the
//!   centre's covariance the line fits weigh by.
//! - Axis lines: the centres at one tilt angle and many C angles lie on a
//!   circle about the C axis; those at one C angle and many tilt angles on an
//!   arc about the tilt axis. A 3-D circle fit (plane and circle together,
//!   geometric) gives each line: its centre and the plane's normal. The
//!   default fit is robust (least squares on the centres within four robust
//!   standard deviations of the circle, [`fit_circle`]), so a failed
//!   probing shows as an outlier instead of a bias. [`CircleMethod::Combinations`] reproduces Cubas Brizuela & Yeh's (2023) filtering for
//!   comparison: a circle through every three centres that are at least 30
//!   deg apart (the C gaps closing the circle), then trimming of each line
//!   number to mean +- sigma/2 (eq. 5.1-5.3).
//! - Location errors: the eight symbols for which the axes of the exact
//!   model's motions `rTw(t1) rTw(t0)^-1` (tilt) and `rTw(t0, c1) rTw(t0,
//!   c0)^-1` (C) are the fitted lines, by Newton's method: an exact inverse,
//!   with no small-angle formula (Cubas Brizuela & Yeh 2023, eq. 4.1 is its first-order form).
//!
//! The covariance follows the centres' covariance (pooled sphere-fit
//! residuals) linearly through the circle fits with their final weights.

use std::fmt;
use std::str::FromStr;

use faer::Mat;
use nalgebra::{DMatrix, Isometry3, Matrix3, Point3, Vector3};

use super::forward::ForwardModel;
use super::lsq::{self, Problem};
use super::result::PoseFit;
use super::{Dataset, Identification, IdentifyError, Method, Setup, identifiability};
use crate::geom::{tangent_basis, wrap180};
use crate::kinematics::Axes;
use crate::model::{Context, Effect, Model};
use crate::shape_fit::SphereCheck;

/// How the axis lines are fitted to the centres.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CircleMethod {
    /// Robust geometric circle fit (outliers set aside, least squares on
    /// the rest): the default.
    Robust,
    /// Plain least-squares geometric circle fit.
    LeastSquares,
    /// Cubas Brizuela & Yeh's (2023) three-point combinations with filtering.
    Combinations,
}

impl fmt::Display for CircleMethod {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            CircleMethod::Robust => "robust",
            CircleMethod::LeastSquares => "least-squares",
            CircleMethod::Combinations => "combinations",
        })
    }
}

impl FromStr for CircleMethod {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "robust" => Ok(CircleMethod::Robust),
            "least-squares" => Ok(CircleMethod::LeastSquares),
            "combinations" => Ok(CircleMethod::Combinations),
            _ => Err(format!(
                "unknown circle fit `{s}`: expected robust, least-squares or combinations"
            )),
        }
    }
}

/// A fitted sphere with its centre's covariance.
#[derive(Clone, Debug, PartialEq)]
pub struct CentreFit {
    /// Centre, mm.
    pub centre: Vector3<f64>,
    /// Radius, mm.
    pub radius: f64,
    /// Sum of squared residuals, mm^2.
    pub rss: f64,
    /// Unit-noise covariance of the centre (mm^2 per mm^2 of noise).
    pub cov_unit: Matrix3<f64>,
}

/// Fits a sphere (free radius) to at least four points: the geometric
/// least-squares fit of [`crate::shape_fit::fit_sphere`], with the centre's
/// covariance per unit noise from the fit's Jacobian at the solution.
pub fn fit_centre(pts: &[Vector3<f64>]) -> Option<CentreFit> {
    let fit = crate::shape_fit::fit_sphere(pts).ok()?;
    let c = fit.sphere.centre;
    // Rows d(|p - c| - r)/d(c, r) = (-(p - c)/|p - c|, -1).
    let mut jtj = nalgebra::Matrix4::<f64>::zeros();
    for p in pts {
        let d = p - c;
        let n = d.norm();
        if n == 0.0 {
            return None;
        }
        let row = nalgebra::Vector4::new(-d.x / n, -d.y / n, -d.z / n, -1.0);
        jtj += row * row.transpose();
    }
    let inv = jtj.try_inverse()?;
    Some(CentreFit {
        centre: c,
        radius: fit.sphere.radius,
        rss: fit.residuals.iter().map(|r| r * r).sum(),
        cov_unit: inv.fixed_view::<3, 3>(0, 0).into_owned(),
    })
}

/// A line in space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    /// A point on it (the circle centre for a fitted axis), mm.
    pub point: Vector3<f64>,
    /// Unit direction.
    pub dir: Vector3<f64>,
}

/// A fitted circle in space.
#[derive(Clone, Debug, PartialEq)]
pub struct Circle {
    /// Centre, mm.
    pub centre: Vector3<f64>,
    /// Unit normal of its plane.
    pub normal: Vector3<f64>,
    /// Radius, mm.
    pub radius: f64,
    /// Final weight of each point (1 for plain least squares).
    pub weights: Vec<f64>,
}

struct CircleProblem<'a> {
    pts: &'a [Vector3<f64>],
    w: &'a [f64],
    n0: Vector3<f64>,
    e: (Vector3<f64>, Vector3<f64>),
}

impl CircleProblem<'_> {
    fn normal(&self, x: &[f64]) -> Vector3<f64> {
        (self.n0 + self.e.0 * x[3] + self.e.1 * x[4]).normalize()
    }

    fn res(&self, x: &[f64], r: &mut [f64]) {
        let c = Vector3::new(x[0], x[1], x[2]);
        let n = self.normal(x);
        for (k, p) in self.pts.iter().enumerate() {
            let d = p - c;
            let h = n.dot(&d);
            let radial = (d - n * h).norm();
            let w = self.w[k].sqrt();
            r[2 * k] = w * h;
            r[2 * k + 1] = w * (radial - x[5]);
        }
    }
}

impl Problem for CircleProblem<'_> {
    fn n_residuals(&self) -> usize {
        2 * self.pts.len()
    }
    fn n_params(&self) -> usize {
        6
    }
    fn eval(&self, x: &[f64], r: &mut [f64], jac: Option<&mut Mat<f64>>) {
        self.res(x, r);
        if let Some(j) = jac {
            let m = r.len();
            let mut rp = vec![0.0; m];
            let mut rm = vec![0.0; m];
            for c in 0..6 {
                let h = if c < 3 || c == 5 { 1e-6 } else { 1e-8 };
                let mut xp = x.to_vec();
                xp[c] += h;
                self.res(&xp, &mut rp);
                xp[c] -= 2.0 * h;
                self.res(&xp, &mut rm);
                for i in 0..m {
                    j[(i, c)] = (rp[i] - rm[i]) / (2.0 * h);
                }
            }
        }
    }
}

fn plane_normal(pts: &[Vector3<f64>], w: &[f64]) -> (Vector3<f64>, Vector3<f64>) {
    let sw: f64 = w.iter().sum();
    let g = pts.iter().zip(w).map(|(p, w)| p * *w).sum::<Vector3<f64>>() / sw;
    let mut cov = Matrix3::zeros();
    for (p, w) in pts.iter().zip(w) {
        cov += (p - g) * (p - g).transpose() * *w;
    }
    let e = cov.symmetric_eigen();
    let k = (0..3)
        .min_by(|&a, &b| e.eigenvalues[a].total_cmp(&e.eigenvalues[b]))
        .unwrap_or(2);
    (g, e.eigenvectors.column(k).into_owned())
}

/// Least-squares circle with fixed weights, from a plane fit and the
/// algebraic circle in that plane.
fn fit_circle_weighted(pts: &[Vector3<f64>], w: &[f64], hint: &Vector3<f64>) -> Option<Circle> {
    if pts.len() < 3 {
        return None;
    }
    let (g, mut n0) = plane_normal(pts, w);
    if n0.dot(hint) < 0.0 {
        n0 = -n0;
    }
    let (e1, e2) = tangent_basis(&n0);
    // Algebraic (Kasa) circle in the plane: x^2 + y^2 + D x + E y + F = 0.
    let a = DMatrix::from_fn(pts.len(), 3, |r, c| {
        let q = pts[r] - g;
        [q.dot(&e1), q.dot(&e2), 1.0][c] * w[r].sqrt()
    });
    let b = nalgebra::DVector::from_fn(pts.len(), |r, _| {
        let q = pts[r] - g;
        -(q.dot(&e1).powi(2) + q.dot(&e2).powi(2)) * w[r].sqrt()
    });
    let s = a.svd(true, true).solve(&b, 1e-12).ok()?;
    let (cx, cy) = (-0.5 * s[0], -0.5 * s[1]);
    let r0 = (cx * cx + cy * cy - s[2]).max(0.0).sqrt();
    let c0 = g + e1 * cx + e2 * cy;
    let p = CircleProblem {
        pts,
        w,
        n0,
        e: (e1, e2),
    };
    let sol = lsq::solve(
        &p,
        &[c0.x, c0.y, c0.z, 0.0, 0.0, r0],
        None,
        &lsq::Options::default(),
    );
    let mut normal = p.normal(&sol.x);
    if normal.dot(hint) < 0.0 {
        normal = -normal;
    }
    Some(Circle {
        centre: Vector3::new(sol.x[0], sol.x[1], sol.x[2]),
        normal,
        radius: sol.x[5],
        weights: w.to_vec(),
    })
}

fn circle_residual(c: &Circle, p: &Vector3<f64>) -> f64 {
    let d = p - c.centre;
    let h = c.normal.dot(&d);
    let radial = (d - c.normal * h).norm() - c.radius;
    (h * h + radial * radial).sqrt()
}

/// Fits a circle in space; `robust` sets outliers aside. `hint` orients
/// the normal.
///
/// The robust fit is least squares on the centres that are not outliers:
/// a centre more than four robust standard deviations off the circle (the
/// scale from the median distance, which for a 2-D normal deviation is
/// 1.1774 sigma) is set aside and the circle refitted until the set stops
/// changing. Clean centres then give exactly the least-squares circle and
/// its covariance; a continuous reweighting (Tukey's biweight) down-weights
/// good centres of a short arc as well, which biased the C-axis tilt of a
/// head-table by 6 u while its u stayed the least-squares one. At most a
/// third of the centres is set aside: beyond that the "outliers" are the
/// pattern, and the fit keeps them all.
pub fn fit_circle(pts: &[Vector3<f64>], robust: bool, hint: &Vector3<f64>) -> Option<Circle> {
    let all = fit_circle_weighted(pts, &vec![1.0; pts.len()], hint)?;
    if !robust {
        return Some(all);
    }
    // Rayleigh median over sigma; four sigma leave a clean centre out with
    // probability exp(-8) = 3e-4.
    const MEDIAN_OVER_SIGMA: f64 = 1.1774;
    const OUTLIER_SIGMAS: f64 = 4.0;
    // Centres agree to far better than this only on exact data, which must
    // keep every centre.
    const SCALE_FLOOR_MM: f64 = 1e-4;
    let min_kept = (pts.len() - pts.len() / 3).max(3);
    let mut c = all.clone();
    let mut kept = vec![true; pts.len()];
    for _ in 0..10 {
        let res: Vec<f64> = pts.iter().map(|p| circle_residual(&c, p)).collect();
        let mut sorted = res.clone();
        sorted.sort_by(f64::total_cmp);
        let sigma = (sorted[sorted.len() / 2] / MEDIAN_OVER_SIGMA).max(SCALE_FLOOR_MM);
        let next: Vec<bool> = res.iter().map(|r| *r <= OUTLIER_SIGMAS * sigma).collect();
        if next.iter().filter(|&&k| k).count() < min_kept {
            return Some(all);
        }
        if next == kept {
            break;
        }
        kept = next;
        let w: Vec<f64> = kept.iter().map(|&k| if k { 1.0 } else { 0.0 }).collect();
        c = fit_circle_weighted(pts, &w, hint)?;
    }
    Some(c)
}

/// One axis's centres with their index angles.
#[derive(Clone, Debug)]
pub struct AxisCentres {
    /// Angle of each centre on this axis, deg.
    pub angles: Vec<f64>,
    /// Whether the axis turns fully (C) or only over a range (tilt).
    pub periodic: bool,
    /// The centres, mm.
    pub centres: Vec<Vector3<f64>>,
}

/// Cubas Brizuela & Yeh's (2023) combinations: the lines of every admissible three-centre
/// circle, trimmed to mean +- sigma/2 per line number, averaged. Returns
/// the line and the number of combinations (all, admissible, kept).
pub(crate) fn combinations_line(
    axis: &AxisCentres,
    hint: &Vector3<f64>,
    reference: &Vector3<f64>,
) -> Option<(Line, [usize; 3])> {
    let n = axis.centres.len();
    let (e1, e2) = tangent_basis(hint);
    let mut params: Vec<[f64; 4]> = Vec::new();
    let mut all = 0;
    for i in 0..n {
        for j in i + 1..n {
            for k in j + 1..n {
                all += 1;
                let mut a = [axis.angles[i], axis.angles[j], axis.angles[k]];
                if axis.periodic {
                    for x in &mut a {
                        *x = x.rem_euclid(360.0);
                    }
                }
                a.sort_by(f64::total_cmp);
                let mut gaps = vec![a[1] - a[0], a[2] - a[1]];
                if axis.periodic {
                    gaps.push(360.0 - (a[2] - a[0]));
                }
                if gaps.iter().any(|&g| g < 30.0 - 1e-9) {
                    continue;
                }
                let Ok(circle) = crate::shape_fit::circle_through_three(
                    &axis.centres[i],
                    &axis.centres[j],
                    &axis.centres[k],
                ) else {
                    continue;
                };
                let (c, mut nrm) = (circle.centre, circle.normal);
                if nrm.dot(hint) < 0.0 {
                    nrm = -nrm;
                }
                // Line numbers: where the line crosses the plane through
                // `reference` normal to the nominal axis, and its tilt.
                let s = (reference - c).dot(hint) / nrm.dot(hint);
                let x = c + nrm * s;
                params.push([
                    (x - reference).dot(&e1),
                    (x - reference).dot(&e2),
                    nrm.dot(&e1) / nrm.dot(hint),
                    nrm.dot(&e2) / nrm.dot(hint),
                ]);
            }
        }
    }
    let admissible = params.len();
    if admissible == 0 {
        return None;
    }
    let mut keep = vec![true; admissible];
    for q in 0..4 {
        let v: Vec<f64> = params.iter().map(|p| p[q]).collect();
        let mu = v.iter().sum::<f64>() / v.len() as f64;
        let sigma = (v.iter().map(|x| (x - mu).powi(2)).sum::<f64>() / v.len() as f64).sqrt();
        for (k, x) in v.iter().enumerate() {
            if (x - mu).abs() > sigma / 2.0 + 1e-15 {
                keep[k] = false;
            }
        }
    }
    let kept: Vec<&[f64; 4]> = params
        .iter()
        .zip(&keep)
        .filter(|x| *x.1)
        .map(|x| x.0)
        .collect();
    let chosen: Vec<&[f64; 4]> = if kept.is_empty() {
        params.iter().collect()
    } else {
        kept
    };
    let mut mean = [0.0; 4];
    for p in &chosen {
        for q in 0..4 {
            mean[q] += p[q] / chosen.len() as f64;
        }
    }
    let point = reference + e1 * mean[0] + e2 * mean[1];
    let dir = (hint + e1 * mean[2] + e2 * mean[3]).normalize();
    Some((Line { point, dir }, [all, admissible, chosen.len()]))
}

/// The screw axis of an isometry that is (nearly) a pure rotation.
fn rotation_axis(iso: &Isometry3<f64>, hint: &Vector3<f64>) -> Line {
    let mut d = iso.rotation.axis().map(|a| a.into_inner()).unwrap_or(*hint);
    if d.dot(hint) < 0.0 {
        d = -d;
    }
    let r = iso.rotation.to_rotation_matrix().into_inner();
    let t = iso.translation.vector;
    let t_perp = t - d * t.dot(&d);
    // (I - R) x = t_perp, minimum norm within the plane normal to d.
    let a = Matrix3::identity() - r;
    let x = a
        .svd(true, true)
        .solve(&t_perp, 1e-12)
        .unwrap_or_else(|_| Vector3::zeros());
    Line { point: x, dir: d }
}

/// The tilt-axis line and the C-axis line (at tilt `t0`) of the model with
/// parameters `theta`, in the machine frame (origin at the W origin).
pub(crate) fn model_lines(
    model: &Model,
    theta: &[f64],
    t0: f64,
    tilt_span: (f64, f64),
) -> (Line, Line) {
    let rtw = |t: f64, c: f64| {
        let ctx = Context::at(Axes::new(0.0, 0.0, 0.0, t, c));
        model
            .kin
            .table_transform(t, c, &model.perturbation(theta, &ctx))
    };
    let m = model.kin.machine();
    let tilt_hint = m.tilt.about.unit();
    let lt = rotation_axis(
        &(rtw(tilt_span.1, 0.0) * rtw(tilt_span.0, 0.0).inverse()),
        &tilt_hint,
    );
    let c_hint = model.kin.nominal_table_transform(t0, 0.0).rotation * Vector3::z();
    let lc = rotation_axis(&(rtw(t0, 90.0) * rtw(t0, 0.0).inverse()), &c_hint);
    (lt, lc)
}

/// Distance numbers between a model line and a fitted one: the angle
/// (urad) and offset (um, at the fitted line's point) in the two directions
/// normal to the fitted line.
fn line_gap(model: &Line, fitted: &Line) -> [f64; 4] {
    let (e1, e2) = tangent_basis(&fitted.dir);
    let d = if model.dir.dot(&fitted.dir) < 0.0 {
        -model.dir
    } else {
        model.dir
    };
    let x = model.point + d * (fitted.point - model.point).dot(&d);
    let off = x - fitted.point;
    [
        d.dot(&e1) * 1e6,
        d.dot(&e2) * 1e6,
        off.dot(&e1) * 1e3,
        off.dot(&e2) * 1e3,
    ]
}

struct LineProblem<'a> {
    model: &'a Model,
    tilt: Line,
    c: Line,
    t0: f64,
    span: (f64, f64),
}

impl LineProblem<'_> {
    fn res(&self, x: &[f64], r: &mut [f64]) {
        let (lt, lc) = model_lines(self.model, x, self.t0, self.span);
        // An axis in the head does not move the table: the model's line
        // for it is then the axis of an identity rotation, a direction
        // round-off picks, and the fitted one the degenerate arc of centres
        // the head's errors shift alike. Neither says anything about the
        // parameters, and fitting one to the other made the estimate hang
        // on round-off (a different but equally exact SVD moved EA0C on
        // head-table by 9.6 u).
        let m = self.model.kin.machine();
        if m.tilt.on_table {
            r[..4].copy_from_slice(&line_gap(&lt, &self.tilt));
        } else {
            r[..4].fill(0.0);
        }
        if m.c.on_table {
            r[4..].copy_from_slice(&line_gap(&lc, &self.c));
        } else {
            r[4..].fill(0.0);
        }
    }
}

impl Problem for LineProblem<'_> {
    fn n_residuals(&self) -> usize {
        8
    }
    fn n_params(&self) -> usize {
        self.model.n_params()
    }
    fn eval(&self, x: &[f64], r: &mut [f64], jac: Option<&mut Mat<f64>>) {
        self.res(x, r);
        if let Some(j) = jac {
            let h = 1e-2;
            let mut rp = [0.0; 8];
            let mut rm = [0.0; 8];
            let mut xp = x.to_vec();
            for c in 0..x.len() {
                xp[c] = x[c] + h;
                self.res(&xp, &mut rp);
                xp[c] = x[c] - h;
                self.res(&xp, &mut rm);
                xp[c] = x[c];
                for i in 0..8 {
                    j[(i, c)] = (rp[i] - rm[i]) / (2.0 * h);
                }
            }
        }
    }
}

/// The location symbols whose model has the given axis lines.
pub(crate) fn symbols_from_lines(
    model: &Model,
    tilt: &Line,
    c: &Line,
    t0: f64,
    span: (f64, f64),
) -> Vec<f64> {
    inverse_lines(model, tilt, c, t0, span).0
}

/// [`symbols_from_lines`], and whether its Newton inversion converged.
fn inverse_lines(
    model: &Model,
    tilt: &Line,
    c: &Line,
    t0: f64,
    span: (f64, f64),
) -> (Vec<f64>, bool) {
    let p = LineProblem {
        model,
        tilt: *tilt,
        c: *c,
        t0,
        span,
    };
    let opts = lsq::Options {
        max_iter: 30,
        ..Default::default()
    };
    let sol = lsq::solve(&p, &vec![0.0; model.n_params()], None, &opts);
    (sol.x, sol.converged)
}

/// Options of the sphere method.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereOptions {
    /// How the lines are fitted.
    pub circle: CircleMethod,
    /// The plausibility check of each pose's sphere (a controller's
    /// sphere check, with the sphere's radius for contact points): a pose
    /// that fails it is reported.
    pub check: Option<SphereCheck>,
}

impl Default for SphereOptions {
    fn default() -> Self {
        SphereOptions {
            circle: CircleMethod::Robust,
            check: None,
        }
    }
}

/// The two sets of centres and what the lines came from.
struct Groups {
    tilt: AxisCentres,
    tilt_idx: Vec<usize>,
    c: AxisCentres,
    c_idx: Vec<usize>,
    t0: f64,
}

fn groups(data: &Dataset, centres: &[Vector3<f64>]) -> Result<Groups, IdentifyError> {
    // C circle: the tilt angle with the most distinct C angles (0 first);
    // tilt arc: the C angle with the most distinct tilt angles.
    let mut best_t: Option<(f64, Vec<usize>)> = None;
    let mut best_c: Option<(f64, Vec<usize>)> = None;
    for p in &data.poses {
        let same_t: Vec<usize> = (0..data.poses.len())
            .filter(|&j| (data.poses[j].tilt - p.tilt).abs() < 1e-9)
            .collect();
        let same_c: Vec<usize> = (0..data.poses.len())
            .filter(|&j| wrap180(data.poses[j].c - p.c).abs() < 1e-9)
            .collect();
        let better = |cur: &Option<(f64, Vec<usize>)>, v: &Vec<usize>, zero: bool| match cur {
            None => true,
            Some((a, w)) => v.len() > w.len() || (v.len() == w.len() && zero && a.abs() > 1e-9),
        };
        if better(&best_t, &same_t, p.tilt.abs() < 1e-9) {
            best_t = Some((p.tilt, same_t));
        }
        if better(&best_c, &same_c, wrap180(p.c).abs() < 1e-9) {
            best_c = Some((p.c, same_c));
        }
    }
    let (t0, mut c_idx) = best_t.unwrap_or((0.0, Vec::new()));
    let (_, mut tilt_idx) = best_c.unwrap_or((0.0, Vec::new()));
    // Each measurement in one group, as Cubas Brizuela & Yeh form their
    // combinations (36 C centres, 13 tilt centres: 7140 and 286 three-centre
    // circles): the pose where the sweeps cross is measured once per sweep,
    // the first measurement goes to the C circle and the later ones to the
    // tilt arc. Measured only once, it stays in both: without it one of the
    // two would lack a point.
    let crossing: Vec<usize> = c_idx
        .iter()
        .copied()
        .filter(|j| tilt_idx.contains(j))
        .collect();
    if let Some((&first, later)) = crossing.split_first()
        && !later.is_empty()
    {
        c_idx.retain(|j| !later.contains(j));
        tilt_idx.retain(|&j| j != first);
    }
    let letter = data.plan.tilt_letter;
    if c_idx.len() < 3 {
        return Err(IdentifyError::Data(format!(
            "the sphere method needs the sphere at three or more C angles at one {letter} angle (a circle about C); the measurements have {}",
            c_idx.len()
        )));
    }
    if tilt_idx.len() < 3 {
        return Err(IdentifyError::Data(format!(
            "the sphere method needs the sphere at three or more {letter} angles at one C angle (an arc about {letter}); the measurements have {}",
            tilt_idx.len()
        )));
    }
    Ok(Groups {
        tilt: AxisCentres {
            angles: tilt_idx.iter().map(|&j| data.poses[j].tilt).collect(),
            periodic: false,
            centres: tilt_idx.iter().map(|&j| centres[j]).collect(),
        },
        tilt_idx,
        c: AxisCentres {
            angles: c_idx.iter().map(|&j| data.poses[j].c).collect(),
            periodic: true,
            centres: c_idx.iter().map(|&j| centres[j]).collect(),
        },
        c_idx,
        t0,
    })
}

/// The two fitted axis lines with the final weights of their centres.
struct FittedLines {
    tilt: Line,
    c: Line,
    w_tilt: Vec<f64>,
    w_c: Vec<f64>,
    notes: Vec<String>,
    set_aside: Vec<String>,
}

/// Fits the two axis lines to the centres.
fn lines(
    g: &Groups,
    model: &Model,
    method: CircleMethod,
    weights: Option<(&[f64], &[f64])>,
) -> Option<FittedLines> {
    let m = model.kin.machine();
    let tilt_hint = m.tilt.about.unit();
    let c_hint = model.kin.nominal_table_transform(g.t0, 0.0).rotation * Vector3::z();
    let mut notes = Vec::new();
    let mut set_aside = Vec::new();
    match method {
        CircleMethod::Combinations => {
            let (lt, nt) = combinations_line(&g.tilt, &tilt_hint, &Vector3::zeros())?;
            let (lc, nc) = combinations_line(&g.c, &c_hint, &Vector3::zeros())?;
            notes.push(format!(
                "Cubas Brizuela & Yeh 2023 combinations: {} axis {} of {} three-centre circles admissible, {} kept; C axis {} of {}, {} kept",
                m.tilt.letter, nt[1], nt[0], nt[2], nc[1], nc[0], nc[2]
            ));
            for (name, n) in [(m.tilt.letter, nt), ('C', nc)] {
                if n[2] < n[1] {
                    set_aside.push(format!(
                        "{} of the {} admissible three-centre circles of the {name} axis, by the trimming of the combinations",
                        n[1] - n[2],
                        n[1]
                    ));
                }
            }
            Some(FittedLines {
                tilt: lt,
                c: lc,
                w_tilt: vec![1.0; g.tilt.centres.len()],
                w_c: vec![1.0; g.c.centres.len()],
                notes,
                set_aside,
            })
        }
        _ => {
            let robust = method == CircleMethod::Robust;
            let (ct, cc) = match weights {
                Some((wt, wc)) => (
                    fit_circle_weighted(&g.tilt.centres, wt, &tilt_hint)?,
                    fit_circle_weighted(&g.c.centres, wc, &c_hint)?,
                ),
                None => (
                    fit_circle(&g.tilt.centres, robust, &tilt_hint)?,
                    fit_circle(&g.c.centres, robust, &c_hint)?,
                ),
            };
            for (name, c, angles) in [
                (m.tilt.letter, &ct, &g.tilt.angles),
                ('C', &cc, &g.c.angles),
            ] {
                let out: Vec<String> = c
                    .weights
                    .iter()
                    .zip(angles)
                    .filter(|(w, _)| **w == 0.0)
                    .map(|(_, a)| format!("{a}"))
                    .collect();
                if !out.is_empty() {
                    notes.push(format!(
                        "robust fit of the {name} axis set aside the centres at {name} = {} deg as outliers",
                        out.join(", ")
                    ));
                    set_aside.push(format!(
                        "the centres at {name} = {} deg, by the robust circle fit of the {name} axis",
                        out.join(", ")
                    ));
                }
            }
            Some(FittedLines {
                tilt: Line {
                    point: ct.centre,
                    dir: ct.normal,
                },
                c: Line {
                    point: cc.centre,
                    dir: cc.normal,
                },
                w_tilt: ct.weights,
                w_c: cc.weights,
                notes,
                set_aside,
            })
        }
    }
}

/// Runs the sphere method, judged by the design of its own centres only:
/// what [`identify_judged`] does without a forward model of the points.
pub fn identify(
    setup: &Setup,
    data: &Dataset,
    opts: &SphereOptions,
) -> Result<Identification, IdentifyError> {
    identify_judged(setup, data, opts, None)
}

/// The sphere method's estimate from measured points `m` (one per
/// observation of `data`), the circle fits' weights held at `w`: what the
/// judge differentiates.
fn estimate_fixed(
    model: &Model,
    data: &Dataset,
    g: &Groups,
    m: &[Vector3<f64>],
    circle: CircleMethod,
    w: (&[f64], &[f64]),
    span: (f64, f64),
) -> Option<Vec<f64>> {
    let centre = |j: usize| -> Option<Vector3<f64>> {
        let pts: Vec<Vector3<f64>> = data.poses[j].obs.iter().map(|&k| m[k]).collect();
        fit_centre(&pts).map(|s| s.centre)
    };
    let mut g2 = Groups {
        tilt: g.tilt.clone(),
        tilt_idx: g.tilt_idx.clone(),
        c: g.c.clone(),
        c_idx: g.c_idx.clone(),
        t0: g.t0,
    };
    for (pos, &j) in g.tilt_idx.iter().enumerate() {
        g2.tilt.centres[pos] = centre(j)?;
    }
    for (pos, &j) in g.c_idx.iter().enumerate() {
        g2.c.centres[pos] = centre(j)?;
    }
    let fitted = lines(&g2, model, circle, Some(w))?;
    Some(symbols_from_lines(
        model,
        &fitted.tilt,
        &fitted.c,
        g.t0,
        span,
    ))
}

/// The design of the sphere test for the complete measurement model `fm`
/// (every location symbol, the head's included, and the sphere's setup as
/// nuisance): one row per probed point, its distance along the predicted
/// normal, judged at the nominal machine as the global method judges.
/// Returns the design, the nominal points and their derivatives (mm per
/// unit, 3 x parameters per observation), and the nuisance names.
#[allow(clippy::type_complexity)]
fn full_design(
    fm: &dyn ForwardModel,
    data: &Dataset,
) -> Result<
    (
        lsq::Design,
        Vec<Vector3<f64>>,
        Vec<DMatrix<f64>>,
        Vec<String>,
    ),
    IdentifyError,
> {
    let n = fm.model().n_params();
    let nuisance = fm.nuisance_names();
    let theta = vec![0.0; n];
    let zeros = vec![0.0; nuisance.len()];
    let mut minutes = vec![0.0; data.obs.len()];
    for pose in &data.poses {
        for &k in &pose.obs {
            minutes[k] = pose.minutes;
        }
    }
    let mut j = Mat::<f64>::zeros(data.obs.len(), n + nuisance.len());
    let mut points = Vec::with_capacity(data.obs.len());
    let mut d_points = Vec::with_capacity(data.obs.len());
    for (k, &t) in minutes.iter().enumerate() {
        let pred = fm.predict(&theta, &zeros, data.point(k), t)?;
        for c in 0..n + nuisance.len() {
            let col = pred.d_point.column(c);
            j[(k, c)] = pred.normal.dot(&Vector3::new(col[0], col[1], col[2])) * 1e3;
        }
        points.push(pred.point);
        d_points.push(pred.d_point);
    }
    let design = lsq::design(&j, None, lsq::Options::default().rank_rtol);
    Ok((design, points, d_points, nuisance))
}

/// How the sphere method's estimates move with every parameter of the
/// complete model, `d theta_hat / d (theta, nuisance)`: central
/// differences of the estimator at the nominal machine's points (unit
/// weights), as the design is judged there too.
fn sensitivity(
    model: &Model,
    data: &Dataset,
    g: &Groups,
    circle: CircleMethod,
    span: (f64, f64),
    (nominal, d_points): (&[Vector3<f64>], &[DMatrix<f64>]),
    cols: usize,
) -> Option<DMatrix<f64>> {
    let n = model.n_params();
    let mut sens = DMatrix::zeros(n, cols);
    let hh = 1.0;
    let (wt, wc) = (vec![1.0; g.tilt_idx.len()], vec![1.0; g.c_idx.len()]);
    for c in 0..cols {
        let shifted = |sign: f64| -> Vec<Vector3<f64>> {
            nominal
                .iter()
                .zip(d_points)
                .map(|(p, d)| p + Vector3::new(d[(0, c)], d[(1, c)], d[(2, c)]) * (sign * hh))
                .collect()
        };
        let tp = estimate_fixed(model, data, g, &shifted(1.0), circle, (&wt, &wc), span)?;
        let tm = estimate_fixed(model, data, g, &shifted(-1.0), circle, (&wt, &wc), span)?;
        for i in 0..n {
            sens[(i, c)] = (tp[i] - tm[i]) / (2.0 * hh);
        }
    }
    Some(sens)
}

/// Runs the sphere method. With `fm`, the forward model of every probed
/// point (a head machine's included), what it reports is decided by the
/// complete design and by the judge of its estimator
/// ([`identifiability::Identifiability::judge_estimator`]): the axis lines
/// of the centres see only the table's motion, and on a head machine the
/// head's terms shift every centre of a circle alike, which moves the line
/// found for C; such an estimate is refused, naming the terms it moves
/// with. Without `fm` only the centres' own design judges (what the
/// Monte-Carlo runs need, which take the reporting from the first fit).
pub fn identify_judged(
    setup: &Setup,
    data: &Dataset,
    opts: &SphereOptions,
    fm: Option<&dyn ForwardModel>,
) -> Result<Identification, IdentifyError> {
    super::check_data(data, Method::Sphere)?;
    if setup.model.effects.len() != 1 || !matches!(setup.model.effects[0], Effect::Location { .. })
    {
        return Err(IdentifyError::Data(
            "the sphere method identifies location errors only; error maps need the two-stage or global method".into(),
        ));
    }
    let model = &setup.model;
    let mut notes = Vec::new();
    let spheres = pose_spheres(data, opts, &mut notes)?;
    let rss: f64 = spheres.iter().map(|s| s.rss).sum();
    let dof: usize = data.poses.iter().map(|p| p.obs.len() - 4).sum();
    let sigma_mm = if dof > 0 {
        (rss / dof as f64).sqrt()
    } else {
        f64::NAN
    };
    let centres: Vec<Vector3<f64>> = spheres.iter().map(|s| s.centre).collect();
    let g = groups(data, &centres)?;
    let span = (
        g.tilt.angles.iter().copied().fold(f64::INFINITY, f64::min),
        g.tilt
            .angles
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max),
    );
    let fitted = lines(&g, model, opts.circle, None)
        .ok_or_else(|| IdentifyError::Data("the centres do not determine a circle".into()))?;
    notes.extend(fitted.notes.iter().cloned());
    let (theta, converged) = inverse_lines(model, &fitted.tilt, &fitted.c, g.t0, span);
    if !converged {
        notes.push(
            "the inversion of the axis lines into location errors stopped without converging"
                .into(),
        );
    }
    let (mut cov, mut cov_unit) = propagate(
        model,
        &g,
        opts.circle,
        &fitted,
        &theta,
        span,
        &spheres,
        sigma_mm,
    );
    let n = theta.len();

    // Where the sphere sits on the table, from the first pose's centre.
    let s_w = {
        let t = model
            .kin
            .nominal_table_transform(data.poses[0].tilt, data.poses[0].c);
        (t.inverse() * Point3::from(centres[0])).coords
    };
    let report = match fm {
        None => {
            let design = centre_design(model, data, n, s_w);
            let mut names = model.param_names();
            names.extend(
                ["sphere.x", "sphere.y", "sphere.z"]
                    .iter()
                    .map(|s| s.to_string()),
            );
            identifiability::report(&design, 3 * data.poses.len(), n, &names, &[])
        }
        Some(fm) => {
            if fm.model().n_params() != n {
                return Err(IdentifyError::Data(
                    "the forward model's parameters differ from the setup's".into(),
                ));
            }
            let (full, nominal, d_points, nuisance) = full_design(fm, data)?;
            let mut names = model.param_names();
            names.extend(nuisance);
            let mut report = identifiability::report(&full, data.obs.len(), n, &names, &[]);
            let sens = sensitivity(
                model,
                data,
                &g,
                opts.circle,
                span,
                (&nominal, &d_points),
                names.len(),
            )
            .ok_or_else(|| {
                IdentifyError::Data("the nominal centres do not determine a circle".into())
            })?;
            report.judge_estimator(&sens);
            if at_least_bound(&full, &mut cov, &mut cov_unit) {
                notes.push(
                    "the centres' propagation promised less than the design's Cramér-Rao bound for some symbols; their u is that bound".into(),
                );
            }
            report
        }
    };
    let (residuals, poses) = pose_fits(model, data, &spheres, s_w, sigma_mm);
    notes.push(format!(
        "sphere radius {:.4} mm (mean of {} fits); lines fitted by the {} circle fit",
        spheres.iter().map(|s| s.radius).sum::<f64>() / spheres.len() as f64,
        spheres.len(),
        opts.circle
    ));
    Ok(Identification {
        method: Method::Sphere,
        model: model.clone(),
        theta,
        cov,
        cov_unit,
        identifiability: report,
        sigma_um: sigma_mm * 1e3,
        dof,
        residuals,
        poses,
        placement: None,
        notes,
        converged,
        set_aside: fitted.set_aside.clone(),
    })
}

/// The sphere fitted to each pose's points, with a note for each pose that
/// fails the plausibility check.
fn pose_spheres(
    data: &Dataset,
    opts: &SphereOptions,
    notes: &mut Vec<String>,
) -> Result<Vec<CentreFit>, IdentifyError> {
    let mut spheres = Vec::new();
    for pose in &data.poses {
        let pts: Vec<Vector3<f64>> = pose.obs.iter().map(|&k| data.obs[k].m).collect();
        let s = fit_centre(&pts).ok_or_else(|| {
            IdentifyError::Data(format!(
                "pose `{}`: a sphere needs four or more probed points not on one circle ({} given)",
                pose.id,
                pts.len()
            ))
        })?;
        if let Some(check) = &opts.check
            && let Err(bad) = check.check(&pose.id, &pts)
        {
            notes.push(format!(
                "pose {} fails the sphere check: {} (the robust circle fit sets a bad centre aside)",
                bad.pose, bad.reason
            ));
        }
        spheres.push(s);
    }
    Ok(spheres)
}

/// The covariance of the symbols (and per unit noise variance) by linear
/// propagation of the centres' covariance: through each circle fit (final
/// weights fixed) to its line, then through the line inversion,
/// d theta = Jr^-1 d gap (Jr: the inversion's Jacobian).
#[allow(clippy::too_many_arguments)]
fn propagate(
    model: &Model,
    g: &Groups,
    circle: CircleMethod,
    fitted: &FittedLines,
    theta: &[f64],
    span: (f64, f64),
    spheres: &[CentreFit],
    sigma_mm: f64,
) -> (DMatrix<f64>, DMatrix<f64>) {
    let n = theta.len();
    let mut used: Vec<usize> = g.tilt_idx.iter().chain(&g.c_idx).copied().collect();
    used.sort_unstable();
    used.dedup();
    let tilt_hint = model.kin.machine().tilt.about.unit();
    let c_hint = model.kin.nominal_table_transform(g.t0, 0.0).rotation * Vector3::z();
    let refit = |axis: &AxisCentres, hint: &Vector3<f64>, w: &[f64]| -> Option<Line> {
        match circle {
            CircleMethod::Combinations => {
                combinations_line(axis, hint, &Vector3::zeros()).map(|x| x.0)
            }
            _ => fit_circle_weighted(&axis.centres, w, hint).map(|c| Line {
                point: c.centre,
                dir: c.normal,
            }),
        }
    };
    let mut dl = DMatrix::zeros(8, 3 * used.len());
    let h = 1e-5;
    for (u, &j) in used.iter().enumerate() {
        for i in 0..3 {
            for (row, axis, idx, base, hint, w) in [
                (
                    0,
                    &g.tilt,
                    &g.tilt_idx,
                    &fitted.tilt,
                    &tilt_hint,
                    &fitted.w_tilt,
                ),
                (4, &g.c, &g.c_idx, &fitted.c, &c_hint, &fitted.w_c),
            ] {
                let Some(pos) = idx.iter().position(|&x| x == j) else {
                    continue;
                };
                let (mut ap, mut am) = (axis.clone(), axis.clone());
                ap.centres[pos][i] += h;
                am.centres[pos][i] -= h;
                if let (Some(lp), Some(lm)) = (refit(&ap, hint, w), refit(&am, hint, w)) {
                    let (gp, gm) = (line_gap(&lp, base), line_gap(&lm, base));
                    for r in 0..4 {
                        dl[(row + r, 3 * u + i)] = (gp[r] - gm[r]) / (2.0 * h);
                    }
                }
            }
        }
    }
    let lp = LineProblem {
        model,
        tilt: fitted.tilt,
        c: fitted.c,
        t0: g.t0,
        span,
    };
    let mut r0 = [0.0; 8];
    let mut jr = Mat::<f64>::zeros(8, n);
    lp.eval(theta, &mut r0, Some(&mut jr));
    let jr = lsq::to_nalgebra(&jr);
    let jr_inv = jr
        .clone()
        .svd(true, true)
        .pseudo_inverse(1e-12 * jr.norm())
        .unwrap_or_else(|_| DMatrix::zeros(n, 8));
    let jac = &jr_inv * dl;
    let mut cc = DMatrix::zeros(3 * used.len(), 3 * used.len());
    for (u, &j) in used.iter().enumerate() {
        let c = spheres[j].cov_unit * (sigma_mm * sigma_mm);
        cc.view_mut((3 * u, 3 * u), (3, 3)).copy_from(&c);
    }
    let cov = &jac * &cc * jac.transpose();
    let cov_unit = &cov * (1e-6 / (sigma_mm * sigma_mm));
    (cov, cov_unit)
}

/// The design of the sphere test on its own: the centres as exact functions
/// of the `n` symbols and of the sphere's position `s_w` on the table, judged
/// at the nominal machine (see `global`).
fn centre_design(model: &Model, data: &Dataset, n: usize, s_w: Vector3<f64>) -> lsq::Design {
    let centre_of = |x: &[f64], j: usize| -> Vector3<f64> {
        let p = &data.poses[j];
        let ctx = Context::at(Axes::new(0.0, 0.0, 0.0, p.tilt, p.c));
        let t = model
            .kin
            .table_transform(p.tilt, p.c, &model.perturbation(&x[..n], &ctx));
        (t * Point3::new(x[n], x[n + 1], x[n + 2])).coords
    };
    let mut x = vec![0.0; n];
    x.extend_from_slice(&[s_w.x, s_w.y, s_w.z]);
    let mut d = Mat::<f64>::zeros(3 * data.poses.len(), n + 3);
    for j in 0..data.poses.len() {
        for c in 0..n + 3 {
            let hh = if c < n { 1e-2 } else { 1e-5 };
            let mut xp = x.clone();
            xp[c] += hh;
            let mut xm = x.clone();
            xm[c] -= hh;
            let diff = (centre_of(&xp, j) - centre_of(&xm, j)) / (2.0 * hh) * 1e3;
            for i in 0..3 {
                d[(3 * j + i, c)] = diff[i];
            }
        }
    }
    lsq::design(&d, None, 1e-9)
}

/// Raises the covariance to the complete design's Cramér-Rao bound at the
/// points' noise where the lines' propagation claims less (the head's
/// degenerate arc on a head machine feeds it), the correlations kept: no
/// estimator does better. Whether any was raised.
fn at_least_bound(full: &lsq::Design, cov: &mut DMatrix<f64>, cov_unit: &mut DMatrix<f64>) -> bool {
    let n = cov.nrows();
    let mut scale = vec![1.0; n];
    for (i, f) in scale.iter_mut().enumerate() {
        let bound = full.cov_unit[(i, i)].max(0.0);
        if cov_unit[(i, i)] > 0.0 && cov_unit[(i, i)] < bound {
            *f = (bound / cov_unit[(i, i)]).sqrt();
        }
    }
    if scale.iter().any(|&f| f > 1.0) {
        let d = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(scale));
        *cov = &d * &*cov * &d;
        *cov_unit = &d * &*cov_unit * &d;
        return true;
    }
    false
}

/// Each point's residual (its distance from its pose's sphere, um) and each
/// pose's fit: its centre's shift from where the nominal machine puts the
/// sphere at `s_w`, with its u.
fn pose_fits(
    model: &Model,
    data: &Dataset,
    spheres: &[CentreFit],
    s_w: Vector3<f64>,
    sigma_mm: f64,
) -> (Vec<f64>, Vec<PoseFit>) {
    let mut residuals = vec![0.0; data.obs.len()];
    let mut poses = Vec::new();
    for (pose, s) in data.poses.iter().zip(spheres) {
        for &k in &pose.obs {
            residuals[k] = ((data.obs[k].m - s.centre).norm() - s.radius) * 1e3;
        }
        let nominal = model.kin.nominal_table_transform(pose.tilt, pose.c) * Point3::from(s_w);
        let dc = (s.centre - nominal.coords) * 1e3;
        let uc = sigma_mm * 1e3;
        poses.push(PoseFit {
            pose: pose.id.clone(),
            pose_index: poses.len(),
            piece: 0,
            seq: pose.seq,
            tilt: pose.tilt,
            c: pose.c,
            xi: [dc.x, dc.y, dc.z, 0.0, 0.0, 0.0],
            u: [
                Some(uc * s.cov_unit[(0, 0)].sqrt()),
                Some(uc * s.cov_unit[(1, 1)].sqrt()),
                Some(uc * s.cov_unit[(2, 2)].sqrt()),
                None,
                None,
                None,
            ],
            observed: 3,
            points: pose.obs.len(),
            rms_um: (s.rss / pose.obs.len() as f64).sqrt() * 1e3,
            info: DMatrix::zeros(6, 6),
        });
    }
    (residuals, poses)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_fit_recovers_centre_and_radius_exactly() {
        let c = Vector3::new(369.7, -296.1, -110.0);
        let r = 15.0;
        let dirs = [
            Vector3::new(-1.0, 0.0, 0.0),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.0, 1.0, 0.0),
            Vector3::new(0.0, -1.0, 0.0),
            Vector3::new(0.0, 0.0, 1.0),
        ];
        let pts: Vec<Vector3<f64>> = dirs.iter().map(|d| c + d * r).collect();
        let s = fit_centre(&pts).unwrap();
        assert!((s.centre - c).norm() < 1e-9 && (s.radius - r).abs() < 1e-9);
    }

    #[test]
    fn circle_fits_agree_and_the_robust_one_ignores_an_outlier() {
        let centre = Vector3::new(10.0, -5.0, 2.0);
        let n = Vector3::new(0.001, -0.002, 1.0).normalize();
        let (e1, e2) = tangent_basis(&n);
        let mut pts: Vec<Vector3<f64>> = (0..12)
            .map(|i| {
                let a = (i as f64 * 30.0).to_radians();
                centre + (e1 * a.cos() + e2 * a.sin()) * 120.0
            })
            .collect();
        let ls = fit_circle(&pts, false, &Vector3::z()).unwrap();
        assert!((ls.centre - centre).norm() < 1e-9 && (ls.normal - n).norm() < 1e-12);
        let c3 = crate::shape_fit::circle_through_three(&pts[0], &pts[4], &pts[8]).unwrap();
        assert!((c3.centre - centre).norm() < 1e-9 && c3.normal.cross(&n).norm() < 1e-9);
        pts[3] += n * 0.05;
        let rb = fit_circle(&pts, true, &Vector3::z()).unwrap();
        assert_eq!(rb.weights[3], 0.0);
        assert!(
            (rb.centre - centre).norm() < 1e-9,
            "{}",
            (rb.centre - centre).norm()
        );
    }
}
