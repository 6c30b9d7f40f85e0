//! The papers' two-stage method.
//!
//! **Stage 1** (Ibaraki & Ota 2014, eq. 7-9, Ibaraki, Iritani & Matsushita 2013, eq. 7-10): for each pose, the
//! six numbers `xi = (dx, dy, dz, a, b, c)` of the rigid motion `D(xi)` that
//! best moves the pose's nominal faces onto its measured points, by exact
//! point-to-plane least squares. Motions the pose's faces do not observe (a
//! single face, say) get no number; the pose's information matrix carries
//! that on. The nominal points depend on the test ([`NominalFrame`]):
//!
//! - a machined piece is compared in W, after the CMM placement;
//! - probing, when the touches name their feature (`<pose>_<feature>`, as
//!   the probing planner labels them) and the reference pose touched the
//!   same features: Ibaraki, Iritani & Matsushita's (2013) form (eq. 5-8), the point measured at the
//!   reference pose carried to the pose by the nominal rotation,
//!   `rTw*_j rTw*_ref^-1 p_ref`, in the machine frame. The setup of every
//!   piece cancels, however many pieces were clamped separately;
//! - probing otherwise: the nominal point `rTw*_j p`, the piece (one rigid
//!   setup) estimated in stage 2.
//!
//! **Stage 2** (Ibaraki & Ota 2014, eq. 10, Ibaraki, Iritani & Matsushita 2013, eq. 13-17): the parameters whose
//! exact model reproduces the stage-1 motions, weighted by each pose's
//! information: for a machined piece `D(xi_j) = G rTw_j^-1 rTw*_j`; for
//! Ibaraki, Iritani & Matsushita's (2013) form `D(xi_j) = rTw_j rTw_ref^-1 rTw*_ref rTw*_j^-1`; for
//! plain probing `D(xi_j) = rTw_j G rTw*_j^-1`. Ibaraki & Ota 2014, eq. 10 subtracts the
//! reference pose's motion; here `G` (six nuisance numbers: the reference
//! pose's own displacement, or the piece's setup error) is estimated with
//! the parameters, so the reference step's own measurement noise is
//! weighted like any other pose's rather than copied into all of them. The
//! maps carry the papers' averaging constraints ([`super::Setup`]), which is
//! what separates the tilt-axis and C-axis errors in Ibaraki, Iritani & Matsushita 2013, eq. 16-17.

use std::collections::HashMap;

use faer::Mat;
use nalgebra::{DMatrix, DVector, Isometry3, Point3, Vector3};

use super::forward::RigidPoseMachining;
use super::lsq::{self, Problem};
use super::result::PoseFit;
use super::rigid::{d6_inverse_um, d6_um, face_residual};
use super::{Dataset, Identification, IdentifyError, Method, Setup, identifiability};
use crate::formats::manifest::TestKind;
use crate::kinematics::{Axes, Kinematics};
use crate::model::{Context, Model};

/// Names of the stage-2 nuisance numbers.
pub(crate) const REFERENCE_NAMES: [&str; 6] = [
    "reference.dx",
    "reference.dy",
    "reference.dz",
    "reference.a",
    "reference.b",
    "reference.c",
];

/// How stage 1 frames the nominal points (see the module documentation).
#[derive(Clone, Debug)]
pub(crate) enum NominalFrame {
    /// A machined piece in W, placed on the CMM by this placement.
    Piece(Option<Isometry3<f64>>),
    /// Probing against the nominal points `rTw* p`.
    Probed,
    /// Probing relative to the reference pose (Ibaraki, Iritani & Matsushita 2013).
    Relative {
        /// Index of the reference pose.
        reference: usize,
        /// The points measured there, by feature.
        measured: HashMap<String, Vector3<f64>>,
    },
}

/// The feature a touch probes: its label without the `<pose>_` prefix.
fn feature(data: &Dataset, k: usize) -> Option<&str> {
    let p = data.point(k);
    p.label.strip_prefix(&p.pose)?.strip_prefix('_')
}

/// The reference pose's touch of the same feature as touch `k`, when it is
/// the same point of the piece (same nominal point and normal in W).
fn reference_touch(data: &Dataset, reference: usize, k: usize) -> Option<usize> {
    let f = feature(data, k)?;
    let p = data.point(k);
    data.poses[reference].obs.iter().copied().find(|&r| {
        let q = data.point(r);
        feature(data, r) == Some(f) && (q.p - p.p).norm() < 1e-6 && (q.n - p.n).norm() < 1e-9
    })
}

impl NominalFrame {
    /// The frame a dataset is analysed in: Ibaraki, Iritani & Matsushita's (2013) relative form for a
    /// probing test whose touches are mostly tied to the reference pose by
    /// their feature names.
    pub(crate) fn for_data(data: &Dataset, placement: Option<Isometry3<f64>>) -> NominalFrame {
        match data.kind {
            TestKind::Machining => NominalFrame::Piece(placement),
            TestKind::Probing => {
                let reference = data.reference_pose();
                let measured: HashMap<String, Vector3<f64>> = data.poses[reference]
                    .obs
                    .iter()
                    .filter_map(|&k| Some((feature(data, k)?.to_string(), data.obs[k].m)))
                    .collect();
                let others: Vec<usize> = data
                    .poses
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| *i != reference)
                    .flat_map(|(_, p)| p.obs.iter().copied())
                    .collect();
                let tied = others
                    .iter()
                    .filter(|&&k| reference_touch(data, reference, k).is_some())
                    .count();
                if !others.is_empty() && 2 * tied >= others.len() {
                    NominalFrame::Relative {
                        reference,
                        measured,
                    }
                } else {
                    NominalFrame::Probed
                }
            }
        }
    }

    /// Number of stage-2 nuisance numbers.
    fn nuisance(&self) -> usize {
        match self {
            NominalFrame::Relative { .. } => 0,
            _ => 6,
        }
    }

    /// The observed point, nominal point and nominal normal of observation
    /// `k`, or `None` when this frame cannot use it.
    fn observation(
        &self,
        data: &Dataset,
        kin: &Kinematics,
        k: usize,
    ) -> Option<(Vector3<f64>, Vector3<f64>, Vector3<f64>)> {
        let p = data.point(k);
        let m = data.obs[k].m;
        match self {
            NominalFrame::Piece(placement) => {
                let u = match placement {
                    Some(pl) => (pl.inverse() * Point3::from(m)).coords,
                    None => m,
                };
                Some((u, p.p, p.n))
            }
            NominalFrame::Probed => {
                let t = kin.nominal_table_transform(p.tilt, p.c);
                Some((m, (t * Point3::from(p.p)).coords, t.rotation * p.n))
            }
            NominalFrame::Relative {
                reference,
                measured,
            } => {
                let r = &data.poses[*reference];
                reference_touch(data, *reference, k)?;
                let p_ref = measured.get(feature(data, k)?)?;
                let t = kin.nominal_table_transform(p.tilt, p.c);
                let carry = t * kin.nominal_table_transform(r.tilt, r.c).inverse();
                Some((m, (carry * Point3::from(*p_ref)).coords, t.rotation * p.n))
            }
        }
    }
}

struct PoseProblem {
    q: Vec<Vector3<f64>>,
    n: Vec<Vector3<f64>>,
    u: Vec<Vector3<f64>>,
}

impl Problem for PoseProblem {
    fn n_residuals(&self) -> usize {
        self.q.len()
    }
    fn n_params(&self) -> usize {
        6
    }
    fn eval(&self, x: &[f64], r: &mut [f64], mut jac: Option<&mut Mat<f64>>) {
        for k in 0..self.q.len() {
            let f = face_residual(x, &self.q[k], &self.n[k], &self.u[k]);
            r[k] = f.r;
            if let Some(j) = jac.as_deref_mut() {
                for i in 0..6 {
                    j[(k, i)] = f.d_rho[i];
                }
            }
        }
    }
}

/// Stage 1 in the frame [`NominalFrame::for_data`] chooses (used by every method
/// for the per-pose plots).
pub(crate) fn pose_fits(
    data: &Dataset,
    kin: &Kinematics,
    placement: Option<&Isometry3<f64>>,
) -> Vec<PoseFit> {
    pose_fits_in(data, kin, &NominalFrame::for_data(data, placement.copied()))
}

/// Stage 1: the motion of every pose, with its uncertainty from the pooled
/// residual variance of all poses. In Ibaraki, Iritani & Matsushita's (2013) form the reference pose,
/// which defines the frame, has no fit of its own.
pub(crate) fn pose_fits_in(data: &Dataset, kin: &Kinematics, frame: &NominalFrame) -> Vec<PoseFit> {
    stage1(data, kin, frame).0
}

/// What stage 2's covariance needs of a stage-1 fit: the observations it
/// used and the linear map `P` from their residuals to the six numbers
/// (`d xi = -P d r`).
struct Stage1Map {
    obs: Vec<usize>,
    p: DMatrix<f64>,
}

fn stage1(
    data: &Dataset,
    kin: &Kinematics,
    frame: &NominalFrame,
) -> (Vec<PoseFit>, Vec<Stage1Map>) {
    let mut maps = Vec::new();
    let mut fits = Vec::new();
    let mut rss = 0.0;
    let mut dof = 0usize;
    let mut designs = Vec::new();
    for (pi, pose) in data.poses.iter().enumerate() {
        if matches!(frame, NominalFrame::Relative { reference, .. } if *reference == pi) {
            continue;
        }
        let mut pp = PoseProblem {
            q: Vec::new(),
            n: Vec::new(),
            u: Vec::new(),
        };
        let mut used = Vec::new();
        for &k in &pose.obs {
            if let Some((u, q, n)) = frame.observation(data, kin, k) {
                pp.u.push(u);
                pp.q.push(q);
                pp.n.push(n);
                used.push(k);
            }
        }
        if pp.q.is_empty() {
            continue;
        }
        let sol = lsq::solve(&pp, &[0.0; 6], None, &lsq::Options::default());
        let mut j0 = Mat::<f64>::zeros(pp.q.len(), 6);
        let mut r0 = vec![0.0; pp.q.len()];
        pp.eval(&[0.0; 6], &mut r0, Some(&mut j0));
        let rank0 = lsq::design(&j0, None, 1e-9).rank;
        let d = lsq::design_ranked(&sol.jacobian, None, 1e-9, Some(rank0));
        rss += sol.cost;
        dof += pp.q.len().saturating_sub(d.rank);
        let j = lsq::to_nalgebra(&sol.jacobian);
        let info = j.transpose() * &j;
        maps.push(Stage1Map {
            obs: used,
            p: &d.cov_unit * j.transpose(),
        });
        let mut xi = [0.0; 6];
        xi.copy_from_slice(&sol.x);
        fits.push(PoseFit {
            pose: pose.id.clone(),
            pose_index: pi,
            piece: 0,
            seq: pose.seq,
            tilt: pose.tilt,
            c: pose.c,
            xi,
            u: [None; 6],
            observed: d.rank,
            points: pp.q.len(),
            rms_um: (sol.cost / pp.q.len() as f64).sqrt(),
            info,
        });
        designs.push(d);
    }
    let sigma = if dof > 0 {
        (rss / dof as f64).sqrt()
    } else {
        f64::NAN
    };
    for (f, d) in fits.iter_mut().zip(&designs) {
        for i in 0..6 {
            let seen = (0..d.null.ncols()).all(|c| d.null[(i, c)].abs() < 1e-7);
            if seen {
                f.u[i] = Some(sigma * d.cov_unit[(i, i)].max(0.0).sqrt());
            }
        }
    }
    (fits, maps)
}

/// A pose as stage 2 sees it: where and when, its stage-1 motion and the
/// weight rows of its information.
struct PoseObs {
    tilt: f64,
    c: f64,
    seq: u32,
    minutes: f64,
    xi: [f64; 6],
    w: DMatrix<f64>,
}

/// The exact `rTw` of the model at a pose.
fn rtw(model: &Model, theta: &[f64], tilt: f64, c: f64, seq: u32, minutes: f64) -> Isometry3<f64> {
    let ctx = Context {
        axes: Axes::new(0.0, 0.0, 0.0, tilt, c),
        seq: seq as f64,
        minutes,
        approach: None,
        ..Default::default()
    };
    model
        .kin
        .table_transform(tilt, c, &model.perturbation(theta, &ctx))
}

struct Stage2<'a> {
    model: &'a Model,
    frame: &'a NominalFrame,
    data: &'a Dataset,
    poses: Vec<PoseObs>,
    rows: usize,
}

impl Stage2<'_> {
    /// The motion `D(xi)` the model predicts for a pose (um, urad).
    fn predicted(&self, theta: &[f64], g: &[f64], pose: &PoseObs) -> [f64; 6] {
        let m = self.model;
        let a = rtw(m, theta, pose.tilt, pose.c, pose.seq, pose.minutes);
        let nominal = m.kin.nominal_table_transform(pose.tilt, pose.c);
        let iso = match self.frame {
            NominalFrame::Piece(_) => d6_um(g) * a.inverse() * nominal,
            NominalFrame::Probed => a * d6_um(g) * nominal.inverse(),
            NominalFrame::Relative { reference, .. } => {
                let r = &self.data.poses[*reference];
                let a_ref = rtw(m, theta, r.tilt, r.c, r.seq, r.minutes);
                let n_ref = m.kin.nominal_table_transform(r.tilt, r.c);
                a * a_ref.inverse() * n_ref * nominal.inverse()
            }
        };
        d6_inverse_um(&iso)
    }

    fn residuals(&self, x: &[f64], r: &mut [f64]) {
        let n = self.model.n_params();
        let (theta, g) = (&x[..n], &x[n..]);
        let g = if g.is_empty() { &[0.0; 6][..] } else { g };
        let mut row = 0;
        for pose in &self.poses {
            let f = self.predicted(theta, g, pose);
            let d = DVector::from_fn(6, |i, _| pose.xi[i] - f[i]);
            let e = &pose.w * d;
            for v in e.iter() {
                r[row] = *v;
                row += 1;
            }
        }
    }
}

impl Problem for Stage2<'_> {
    fn n_residuals(&self) -> usize {
        self.rows
    }
    fn n_params(&self) -> usize {
        self.model.n_params() + self.frame.nuisance()
    }
    fn eval(&self, x: &[f64], r: &mut [f64], jac: Option<&mut Mat<f64>>) {
        self.residuals(x, r);
        if let Some(j) = jac {
            // Central differences of the exact pose model: the motions are
            // smooth and nearly linear over micrometres, so a step of
            // 1e-3 um (urad) leaves truncation far below round-off.
            let h = 1e-3;
            let mut rp = vec![0.0; self.rows];
            let mut rm = vec![0.0; self.rows];
            let mut xp = x.to_vec();
            for c in 0..x.len() {
                xp[c] = x[c] + h;
                self.residuals(&xp, &mut rp);
                xp[c] = x[c] - h;
                self.residuals(&xp, &mut rm);
                xp[c] = x[c];
                for i in 0..self.rows {
                    j[(i, c)] = (rp[i] - rm[i]) / (2.0 * h);
                }
            }
        }
    }
}

/// Weight rows `W` with `W^T W = info`, dropping unobserved directions.
fn weight_rows(info: &DMatrix<f64>) -> DMatrix<f64> {
    let e = info.clone().symmetric_eigen();
    let max = e.eigenvalues.iter().fold(0.0f64, |a, &b| a.max(b));
    let keep: Vec<usize> = (0..6)
        .filter(|&k| e.eigenvalues[k] > 1e-10 * max.max(1e-300))
        .collect();
    DMatrix::from_fn(keep.len(), 6, |r, c| {
        e.eigenvalues[keep[r]].sqrt() * e.eigenvectors[(c, keep[r])]
    })
}

/// Runs both stages.
pub(crate) fn identify(
    setup: &Setup,
    data: &Dataset,
    opts: &lsq::Options,
) -> Result<Identification, IdentifyError> {
    super::check_data(data, Method::TwoStage)?;
    // The pose model is exact only for errors constant within a pose.
    let _ = RigidPoseMachining::new(setup.model.clone())?;
    let kin = &setup.model.kin;
    let placement = match data.kind {
        TestKind::Machining => Some(super::initial_placement(data)?),
        TestKind::Probing => None,
    };
    let frame = NominalFrame::for_data(data, placement);
    let mut notes = frame_notes(data, kin, &frame);
    let (fits, maps) = stage1(data, kin, &frame);
    let stage1_dof: usize = fits
        .iter()
        .map(|f| f.points.saturating_sub(f.observed))
        .sum();
    let stage1_rss: f64 = fits
        .iter()
        .map(|f| f.rms_um * f.rms_um * f.points as f64)
        .sum();
    let (poses, rows) = stage2_poses(data, &fits);
    let k = frame.nuisance();
    let st2 = Stage2 {
        model: &setup.model,
        frame: &frame,
        data,
        poses,
        rows,
    };
    let n = setup.model.n_params();
    let basis = setup.basis(k);
    let sol = lsq::solve(&st2, &vec![0.0; n + k], Some(&basis), opts);
    if !sol.cost.is_finite() || fits.iter().any(|f| !f.rms_um.is_finite()) {
        return Err(IdentifyError::Data(
            "the fit failed: the residuals are not finite numbers".into(),
        ));
    }
    // Identifiability is judged on the design at the nominal machine (see
    // `global`), and the covariance at the estimate keeps that rank.
    let x0 = vec![0.0; n + k];
    let mut r0 = vec![0.0; rows];
    let mut j0 = Mat::<f64>::zeros(rows, n + k);
    st2.eval(&x0, &mut r0, Some(&mut j0));
    let nominal = lsq::design(&j0, Some(&basis), opts.rank_rtol);
    let design = lsq::design_ranked(
        &sol.jacobian,
        Some(&basis),
        opts.rank_rtol,
        Some(nominal.rank),
    );
    let sigma1 = if stage1_dof > 0 {
        (stage1_rss / stage1_dof as f64).sqrt()
    } else {
        f64::NAN
    };
    let dof2 = rows.saturating_sub(design.rank);
    // Stage 2 residuals are in um of point residual: their variance
    // estimates the noise when stage 2 has redundancy; otherwise stage 1's
    // pooled variance does.
    let s2 = if dof2 > 0 {
        sol.cost / dof2 as f64
    } else {
        notes.push(
            "stage 2 has no redundancy: the covariance uses stage 1's pooled residual variance"
                .into(),
        );
        sigma1 * sigma1
    };
    let mut names = setup.model.param_names();
    if k > 0 {
        names.extend(REFERENCE_NAMES.iter().map(|s| s.to_string()));
    }
    let report = identifiability::report(&nominal, rows, n, &names, &setup.constraint_names);
    let (cov_unit, cov) = match &frame {
        NominalFrame::Relative { reference, .. } => {
            let m = design.cov_unit.view((0, 0), (n, n + k)).into_owned()
                * lsq::to_nalgebra(&sol.jacobian).transpose()
                * stacked_weights(&fits, rows, 6 * maps.len());
            relative_covariance(data, *reference, &maps, &m, sigma1)
        }
        _ => {
            let cov_unit = design.cov_unit.view((0, 0), (n, n)).into_owned();
            let cov = &cov_unit * s2;
            (cov_unit, cov)
        }
    };
    let theta = sol.x[..n].to_vec();
    let g: Vec<f64> = if k > 0 {
        sol.x[n..n + 6].to_vec()
    } else {
        vec![0.0; 6]
    };
    let residuals = point_residuals(&st2, &theta, &g);
    if !sol.converged {
        notes.push(format!(
            "stage 2 stopped after {} steps without converging",
            sol.iterations
        ));
    }
    Ok(Identification {
        method: Method::TwoStage,
        model: setup.model.clone(),
        theta,
        cov,
        cov_unit,
        identifiability: report,
        // Per touch: in Ibaraki, Iritani & Matsushita's (2013) form a stage-1 residual holds two
        // touches' noise.
        sigma_um: if matches!(frame, NominalFrame::Relative { .. }) {
            sigma1 / 2f64.sqrt()
        } else {
            sigma1
        },
        dof: stage1_dof,
        residuals,
        poses: fits,
        placement,
        notes,
        converged: sol.converged,
        set_aside: unused_touches(data, kin, &frame),
    })
}

/// The touches stage 1 cannot use (relative to a reference pose, those of
/// features not touched there), named for the verdict, which judges them
/// with the rest.
fn unused_touches(data: &Dataset, kin: &Kinematics, frame: &NominalFrame) -> Vec<String> {
    let NominalFrame::Relative { reference, .. } = frame else {
        return Vec::new();
    };
    let unused: Vec<&str> = data
        .obs
        .iter()
        .enumerate()
        .filter(|(k, _)| {
            !data.poses[*reference].obs.contains(k) && frame.observation(data, kin, *k).is_none()
        })
        .map(|(k, _)| data.point(k).label.as_str())
        .collect();
    if unused.is_empty() {
        Vec::new()
    } else {
        let shown = unused.len().min(6);
        vec![format!(
            "{} touches of features not touched at the reference pose {}, by stage 1 ({}{})",
            unused.len(),
            data.poses[*reference].id,
            unused[..shown].join(", "),
            if unused.len() > shown { ", ..." } else { "" }
        )]
    }
}

/// What the frame of stage 1 means for the user: relative to a reference
/// pose (and the touches that cannot be used), or several probed pieces
/// taken as one setup.
fn frame_notes(data: &Dataset, kin: &Kinematics, frame: &NominalFrame) -> Vec<String> {
    let mut notes = Vec::new();
    match frame {
        NominalFrame::Relative { reference, .. } => {
            let unused = data
                .obs
                .iter()
                .enumerate()
                .filter(|(k, _)| {
                    !data.poses[*reference].obs.contains(k)
                        && frame.observation(data, kin, *k).is_none()
                })
                .count();
            notes.push(format!(
                "stage 1 relative to the touches of pose {} (Ibaraki, Iritani & Matsushita 2013): the setup of the pieces cancels{}",
                data.poses[*reference].id,
                if unused > 0 {
                    format!("; {unused} touches of features not touched there are not used")
                } else {
                    String::new()
                }
            ));
        }
        NominalFrame::Probed if data.pieces.len() > 1 => notes.push(format!(
            "the {} pieces are taken as one rigid setup: their touches cannot be tied to the reference pose by feature (use the global method, which estimates each piece's setup)",
            data.pieces.len()
        )),
        _ => {}
    }
    notes
}

/// Stage 2's observations: each pose's motion from stage 1 with its weight
/// rows, and the number of rows in all.
fn stage2_poses(data: &Dataset, fits: &[PoseFit]) -> (Vec<PoseObs>, usize) {
    let mut poses = Vec::new();
    let mut rows = 0;
    for f in fits {
        let pose = &data.poses[f.pose_index];
        let w = weight_rows(&f.info);
        rows += w.nrows();
        poses.push(PoseObs {
            tilt: pose.tilt,
            c: pose.c,
            seq: pose.seq,
            minutes: pose.minutes,
            xi: f.xi,
            w,
        });
    }
    (poses, rows)
}

/// Every pose's weight rows stacked block-diagonally, `rows` by `n_xi`
/// (six columns a pose).
fn stacked_weights(fits: &[PoseFit], rows: usize, n_xi: usize) -> DMatrix<f64> {
    let mut w_all = DMatrix::zeros(rows, n_xi);
    let mut row = 0;
    for (j, f) in fits.iter().enumerate() {
        let w = weight_rows(&f.info);
        w_all.view_mut((row, 6 * j), (w.nrows(), 6)).copy_from(&w);
        row += w.nrows();
    }
    w_all
}

/// The covariance (per unit variance, and at stage 1's noise) of a fit
/// relative to a reference pose. Every pose's motion carries the reference
/// touches' own noise: the motions are correlated through it, and treating
/// them as independent would understate the uncertainty. Propagated
/// instead: theta = M xi (stage 2 linearized, `m` = C J2^T W), xi_j = -P_j
/// r_j (stage 1), and r_k = e_k - e_ref(k) for a touch k and its reference
/// touch, with every touch's noise independent, sigma^2 each.
fn relative_covariance(
    data: &Dataset,
    reference: usize,
    maps: &[Stage1Map],
    m: &DMatrix<f64>,
    sigma1: f64,
) -> (DMatrix<f64>, DMatrix<f64>) {
    let ref_of = |k: usize| reference_touch(data, reference, k);
    let n_xi = 6 * maps.len();
    let mut z = DMatrix::zeros(n_xi, data.obs.len());
    for (j, mp) in maps.iter().enumerate() {
        for (c, &k) in mp.obs.iter().enumerate() {
            let pcol = mp.p.column(c);
            for i in 0..6 {
                z[(6 * j + i, k)] -= pcol[i];
                if let Some(rk) = ref_of(k) {
                    z[(6 * j + i, rk)] += pcol[i];
                }
            }
        }
    }
    let mz = m * z;
    let cov_unit = &mz * mz.transpose();
    // Stage-1 residuals are a touch's noise minus its reference's:
    // twice the touches' variance.
    let cov = &cov_unit * (0.5 * sigma1 * sigma1);
    (cov_unit, cov)
}

/// Point residuals of the final model, for the residual table: each point
/// against its face moved as the model predicts for its pose (the
/// reference touches, which define the frame, left at 0).
fn point_residuals(st2: &Stage2<'_>, theta: &[f64], g: &[f64]) -> Vec<f64> {
    let (data, frame, kin) = (st2.data, st2.frame, &st2.model.kin);
    let mut residuals = vec![0.0; data.obs.len()];
    for (pi, pose) in data.poses.iter().enumerate() {
        let po = PoseObs {
            tilt: pose.tilt,
            c: pose.c,
            seq: pose.seq,
            minutes: pose.minutes,
            xi: [0.0; 6],
            w: DMatrix::zeros(0, 6),
        };
        let xi = st2.predicted(theta, g, &po);
        for &kk in &pose.obs {
            if matches!(frame, NominalFrame::Relative { reference, .. } if *reference == pi) {
                continue;
            }
            if let Some((u, q, nn)) = frame.observation(data, kin, kk) {
                residuals[kk] = face_residual(&xi, &q, &nn, &u).r;
            } else {
                residuals[kk] = f64::NAN;
            }
        }
    }
    residuals
}
