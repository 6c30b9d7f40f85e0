//! The seeds' two-stage method.
//!
//! **Stage 1** (seed 001 eq. 7-9, seed 000 eq. 7-10): for each pose, the
//! six numbers `xi = (dx, dy, dz, a, b, c)` of the rigid motion `D(xi)` that
//! best moves the pose's nominal faces onto its measured points, by exact
//! point-to-plane least squares. A machined piece is compared in W (after
//! the CMM placement), a probed piece in the machine frame (nominal points
//! at `rTw* p`). Motions the pose's faces do not observe (a single face, say)
//! get no number; the pose's information matrix carries that on.
//!
//! **Stage 2** (seed 001 eq. 10, seed 000 eq. 13-17): the parameters whose
//! exact model reproduces the stage-1 motions, weighted by each pose's
//! information: for a machined piece `D(xi_j) = G rTw_j^-1 rTw*_j`, for
//! probing `D(xi_j) = rTw_j G rTw*_j^-1`. Seed 001 eq. 10 subtracts the
//! reference pose's motion; here `G` (six nuisance numbers: the reference
//! pose's own displacement, or the piece's setup error when probing) is
//! estimated with the parameters, so the reference step's own measurement
//! noise is weighted like any other pose's rather than copied into all of
//! them. The maps carry the seeds' averaging constraints ([`super::Setup`]),
//! which is what separates the tilt-axis and C-axis errors in seed 000
//! eq. 16-17.

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
pub const REFERENCE_NAMES: [&str; 6] = [
    "reference.dx",
    "reference.dy",
    "reference.dz",
    "reference.a",
    "reference.b",
    "reference.c",
];

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

/// The observed point, nominal point and nominal normal of observation `k`
/// in the frame stage 1 compares them in.
fn stage1_frame(
    data: &Dataset,
    kin: &Kinematics,
    placement: Option<&Isometry3<f64>>,
    k: usize,
) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
    let p = data.point(k);
    let m = data.obs[k].m;
    match data.kind {
        TestKind::Machining => {
            let u = match placement {
                Some(pl) => (pl.inverse() * Point3::from(m)).coords,
                None => m,
            };
            (u, p.p, p.n)
        }
        TestKind::Probing => {
            let t = kin.nominal_table_transform(p.tilt, p.c);
            (m, (t * Point3::from(p.p)).coords, t.rotation * p.n)
        }
    }
}

/// Stage 1: the motion of every pose, with its uncertainty from the pooled
/// residual variance of all poses.
pub fn pose_fits(
    data: &Dataset,
    kin: &Kinematics,
    placement: Option<&Isometry3<f64>>,
) -> Vec<PoseFit> {
    let mut fits = Vec::new();
    let mut rss = 0.0;
    let mut dof = 0usize;
    let mut designs = Vec::new();
    for pose in &data.poses {
        let mut pp = PoseProblem {
            q: Vec::new(),
            n: Vec::new(),
            u: Vec::new(),
        };
        for &k in &pose.obs {
            let (u, q, n) = stage1_frame(data, kin, placement, k);
            pp.u.push(u);
            pp.q.push(q);
            pp.n.push(n);
        }
        let sol = lsq::solve(&pp, &[0.0; 6], None, &lsq::Options::default());
        let d = lsq::design(&sol.jacobian, None, 1e-9);
        rss += sol.cost;
        dof += pose.obs.len().saturating_sub(d.rank);
        let j = lsq::to_nalgebra(&sol.jacobian);
        let info = j.transpose() * &j;
        let mut xi = [0.0; 6];
        xi.copy_from_slice(&sol.x);
        fits.push(PoseFit {
            pose: pose.id.clone(),
            seq: pose.seq,
            tilt: pose.tilt,
            c: pose.c,
            xi,
            u: [None; 6],
            observed: d.rank,
            points: pose.obs.len(),
            rms_um: (sol.cost / pose.obs.len().max(1) as f64).sqrt(),
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
    fits
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

/// The motion `D(xi)` the model predicts for a pose (um, urad).
fn predicted(model: &Model, kind: TestKind, theta: &[f64], g: &[f64], pose: &PoseObs) -> [f64; 6] {
    let (tilt, c) = (pose.tilt, pose.c);
    let ctx = Context {
        axes: Axes::new(0.0, 0.0, 0.0, tilt, c),
        seq: pose.seq as f64,
        minutes: pose.minutes,
        approach: None,
    };
    let p = model.perturbation(theta, &ctx);
    let rtw = model.kin.table_transform(tilt, c, &p);
    let nominal = model.kin.nominal_table_transform(tilt, c);
    let gi = d6_um(g);
    let iso = match kind {
        TestKind::Machining => gi * rtw.inverse() * nominal,
        TestKind::Probing => rtw * gi * nominal.inverse(),
    };
    d6_inverse_um(&iso)
}

struct Stage2<'a> {
    model: &'a Model,
    kind: TestKind,
    poses: Vec<PoseObs>,
    rows: usize,
}

impl Stage2<'_> {
    fn residuals(&self, x: &[f64], r: &mut [f64]) {
        let n = self.model.n_params();
        let (theta, g) = (&x[..n], &x[n..n + 6]);
        let mut row = 0;
        for pose in &self.poses {
            let f = predicted(self.model, self.kind, theta, g, pose);
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
        self.model.n_params() + 6
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
pub fn identify(
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
    let fits = pose_fits(data, kin, placement.as_ref());
    let stage1_dof: usize = fits
        .iter()
        .map(|f| f.points.saturating_sub(f.observed))
        .sum();
    let stage1_rss: f64 = fits
        .iter()
        .map(|f| f.rms_um * f.rms_um * f.points as f64)
        .sum();
    let mut poses = Vec::new();
    let mut rows = 0;
    for (f, pose) in fits.iter().zip(&data.poses) {
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
    let st2 = Stage2 {
        model: &setup.model,
        kind: data.kind,
        poses,
        rows,
    };
    let n = setup.model.n_params();
    let basis = setup.basis(6);
    let sol = lsq::solve(&st2, &vec![0.0; n + 6], Some(&basis), opts);
    if !sol.cost.is_finite() || fits.iter().any(|f| !f.rms_um.is_finite()) {
        return Err(IdentifyError::Data(
            "the fit failed: the residuals are not finite numbers".into(),
        ));
    }
    let design = lsq::design(&sol.jacobian, Some(&basis), opts.rank_rtol);
    // Identifiability is judged on the design at the nominal machine (see
    // `global`).
    let x0 = vec![0.0; n + 6];
    let mut r0 = vec![0.0; rows];
    let mut j0 = Mat::<f64>::zeros(rows, n + 6);
    st2.eval(&x0, &mut r0, Some(&mut j0));
    let nominal = lsq::design(&j0, Some(&basis), opts.rank_rtol);
    let mut notes = Vec::new();
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
    names.extend(REFERENCE_NAMES.iter().map(|s| s.to_string()));
    let report = identifiability::report(
        &nominal,
        rows,
        n,
        &names,
        &setup.constraint_names,
        &setup.quality_axes(),
    );
    let cov = design.cov_unit.view((0, 0), (n, n)).into_owned() * s2;
    let theta = sol.x[..n].to_vec();
    let g = &sol.x[n..n + 6];
    // Point residuals of the final model, for the residual table.
    let rigid = RigidPoseMachining::new(setup.model.clone())?;
    let mut residuals = vec![f64::NAN; data.obs.len()];
    for pose in &data.poses {
        for &k in &pose.obs {
            let p = data.point(k);
            let (u, _, _) = stage1_frame(data, kin, placement.as_ref(), k);
            residuals[k] = match data.kind {
                TestKind::Machining => {
                    let (q, _) = rigid.moved(&theta, p, pose.minutes, &p.p);
                    let (qn, _) = rigid.moved(&theta, p, pose.minutes, &(p.p + p.n));
                    face_residual(g, &q, &(qn - q), &u).r
                }
                TestKind::Probing => {
                    let ctx = Context {
                        axes: Axes::new(0.0, 0.0, 0.0, p.tilt, p.c),
                        seq: p.seq as f64,
                        minutes: pose.minutes,
                        approach: None,
                    };
                    let rtw =
                        kin.table_transform(p.tilt, p.c, &setup.model.perturbation(&theta, &ctx));
                    let t = rtw * d6_um(g);
                    let q = (t * Point3::from(p.p)).coords;
                    let nn = t.rotation * p.n;
                    nn.dot(&(u - q)) * 1e3
                }
            };
        }
    }
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
        cov_unit: design.cov_unit.view((0, 0), (n, n)).into_owned(),
        identifiability: report,
        sigma_um: sigma1,
        dof: stage1_dof,
        residuals,
        poses: fits,
        placement,
        notes,
    })
}
