//! The result every method returns, and what is made of it: the error file
//! of docs/formats.md (identifiable parameters with their standard
//! uncertainty, the rest under `not_identifiable` with the reason), and the
//! residual table per pose and face.

use nalgebra::{DMatrix, Isometry3, Vector3};

use super::Method;
use super::data::Dataset;
use super::identifiability::Identifiability;
use crate::errorfile::{ErrorFile, Noise, NotIdentified};
use crate::model::{Effect, Model};

/// The 6-DOF displacement of one pose from stage 1 of the two-stage method
/// (also computed for the other methods, for the plots): the face of the
/// pose is the nominal face moved by `D(xi)` (W frame for a machined piece,
/// machine frame for probing), relative to the reference pose.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PoseFit {
    /// Pose id.
    pub pose: String,
    /// Index of the pose in the dataset.
    #[serde(skip)]
    pub pose_index: usize,
    /// Index of the piece (probing with separately set-up pieces).
    pub piece: usize,
    /// Execution order.
    pub seq: u32,
    /// Tilt angle, deg.
    pub tilt: f64,
    /// C angle, deg.
    pub c: f64,
    /// dx, dy, dz (um), a, b, c (urad).
    pub xi: [f64; 6],
    /// Standard uncertainty of each, `None` where the pose's faces do not
    /// observe that motion.
    pub u: [Option<f64>; 6],
    /// How many of the six motions the faces observe.
    pub observed: usize,
    /// Number of points.
    pub points: usize,
    /// RMS point-to-plane residual of the pose fit, um.
    pub rms_um: f64,
    /// Information matrix `J^T J` of the pose fit (per um^2 of noise).
    #[serde(skip)]
    pub info: DMatrix<f64>,
}

/// An identification result.
#[derive(Clone, Debug)]
pub struct Identification {
    /// The method used.
    pub method: Method,
    /// The identified model (parameter layout).
    pub model: Model,
    /// Parameter values, file units.
    pub theta: Vec<f64>,
    /// Covariance of `theta`, residual-scaled, file units squared.
    pub cov: DMatrix<f64>,
    /// `(J^T J)^+` of the design for 1 um of noise per measured point: the
    /// covariance an efficient estimator reaches (Cramér-Rao) per um^2.
    pub cov_unit: DMatrix<f64>,
    /// The identifiability report (model parameters first, then nuisance).
    pub identifiability: Identifiability,
    /// Standard deviation of the measurement residuals, um.
    pub sigma_um: f64,
    /// Degrees of freedom of the residuals.
    pub dof: usize,
    /// Residual of each observation (same order as the dataset's), um:
    /// measured minus predicted along the surface normal.
    pub residuals: Vec<f64>,
    /// Per-pose displacements.
    pub poses: Vec<PoseFit>,
    /// The CMM placement (W to CMM) of a machined piece.
    pub placement: Option<Isometry3<f64>>,
    /// Things the user should know.
    pub notes: Vec<String>,
    /// Whether every iterative step of the method (its solver, its
    /// Newton inversion) converged; a fit that stopped is not a fit.
    pub converged: bool,
    /// The data a robust step of the method set aside (`the centres at C =
    /// 0, 10 deg of the C circle`): left out of its estimate, never out of
    /// its verdict.
    pub set_aside: Vec<String>,
}

/// One row of the residual table.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ResidualRow {
    /// Pose id.
    pub pose: String,
    /// Face, named by its outward normal in W (`+X`, `-Y`, ... or a vector).
    pub face: String,
    /// Number of points.
    pub points: usize,
    /// Mean residual, um.
    pub mean_um: f64,
    /// RMS residual, um.
    pub rms_um: f64,
    /// Largest absolute residual, um.
    pub max_um: f64,
}

/// Names a face by its normal.
pub(crate) fn face_name(n: &Vector3<f64>) -> String {
    for (i, l) in ['X', 'Y', 'Z'].iter().enumerate() {
        if (n[i].abs() - 1.0).abs() < 1e-6 {
            return format!("{}{l}", if n[i] > 0.0 { '+' } else { '-' });
        }
    }
    format!("({:.3},{:.3},{:.3})", n.x, n.y, n.z)
}

impl Identification {
    /// Whether model parameter `i` is identifiable.
    pub fn identifiable(&self, i: usize) -> bool {
        self.identifiability.is_identifiable(i)
    }

    /// The estimates, NaN where a parameter is not identifiable (what a
    /// Monte-Carlo run records).
    pub fn estimates_or_nan(&self) -> Vec<f64> {
        (0..self.theta.len())
            .map(|i| {
                if self.identifiable(i) {
                    self.theta[i]
                } else {
                    f64::NAN
                }
            })
            .collect()
    }

    /// Standard uncertainty of each model parameter, `None` where it is not
    /// identifiable.
    pub fn u(&self) -> Vec<Option<f64>> {
        (0..self.theta.len())
            .map(|i| {
                self.identifiable(i)
                    .then(|| self.cov[(i, i)].max(0.0).sqrt())
            })
            .collect()
    }

    /// Value and uncertainty of a parameter by name.
    pub fn get(&self, name: &str) -> Option<(f64, Option<f64>)> {
        let names = self.model.param_names();
        let i = names.iter().position(|n| n == name)?;
        Some((self.theta[i], self.u()[i]))
    }

    /// The error file: identifiable location symbols and fully identifiable
    /// maps with `u`; everything else listed under `not_identifiable` with
    /// the reason, never as a number. `u` overrides the covariance's
    /// uncertainties (e.g. from Monte Carlo) where given.
    pub fn error_file(&self, u_override: Option<&[Option<f64>]>) -> ErrorFile {
        let u_all = match u_override {
            Some(u) => u.to_vec(),
            None => self.u(),
        };
        let sym = &self.model.symbols;
        let names = self.model.param_names();
        let mut effects = Vec::new();
        let mut theta = Vec::new();
        let mut u = Vec::new();
        let mut not = Vec::new();
        let reason_for = |k: usize| self.identifiability.reason(k);
        for (ei, e) in self.model.effects.iter().enumerate() {
            let r = self.model.param_range(ei);
            match e {
                Effect::Location { symbols } => {
                    let mut keep = Vec::new();
                    for (k, &s) in symbols.iter().enumerate() {
                        let i = r.start + k;
                        if self.identifiable(i) {
                            keep.push(s);
                            theta.push(self.theta[i]);
                            u.push(u_all[i]);
                        } else {
                            not.push(NotIdentified {
                                symbol: sym.location[s].name.clone(),
                                reason: reason_for(i),
                            });
                        }
                    }
                    if !keep.is_empty() {
                        effects.push(Effect::Location { symbols: keep });
                    }
                }
                other => {
                    let bad: Vec<usize> = r.clone().filter(|&i| !self.identifiable(i)).collect();
                    if bad.is_empty() {
                        effects.push(other.clone());
                        theta.extend_from_slice(&self.theta[r.clone()]);
                        u.extend_from_slice(&u_all[r.clone()]);
                    } else {
                        let nodes: Vec<&str> = bad.iter().map(|&i| names[i].as_str()).collect();
                        not.push(NotIdentified {
                            symbol: other.id(sym),
                            reason: format!(
                                "{} of its {} values are not seen by the test ({}); {}",
                                bad.len(),
                                r.len(),
                                nodes.join(", "),
                                reason_for(bad[0])
                            ),
                        });
                    }
                }
            }
        }
        let reduced = Model::new(self.model.kin.clone(), effects);
        let mut f = ErrorFile::from_model(&reduced, &theta, &u, &Noise::default());
        f.not_identifiable = not;
        // Terms no test of this kind can see are listed by the symbol table.
        for (name, reason) in &sym.not_identifiable {
            if !f.not_identifiable.iter().any(|n| &n.symbol == name) {
                f.not_identifiable.push(NotIdentified {
                    symbol: name.clone(),
                    reason: reason.clone(),
                });
            }
        }
        f
    }

    /// Residuals grouped by pose and face.
    pub fn residual_table(&self, data: &Dataset) -> Vec<ResidualRow> {
        let mut rows: Vec<(String, String, Vec<f64>)> = Vec::new();
        for pose in &data.poses {
            for &k in &pose.obs {
                let face = face_name(&data.point(k).n);
                let r = self.residuals.get(k).copied().unwrap_or(f64::NAN);
                if !r.is_finite() {
                    // A point the method could not use.
                    continue;
                }
                match rows.iter_mut().find(|x| x.0 == pose.id && x.1 == face) {
                    Some(x) => x.2.push(r),
                    None => rows.push((pose.id.clone(), face, vec![r])),
                }
            }
        }
        rows.into_iter()
            .map(|(pose, face, v)| {
                let n = v.len() as f64;
                ResidualRow {
                    pose,
                    face,
                    points: v.len(),
                    mean_um: v.iter().sum::<f64>() / n,
                    rms_um: (v.iter().map(|x| x * x).sum::<f64>() / n).sqrt(),
                    max_um: v.iter().fold(0.0f64, |a, b| a.max(b.abs())),
                }
            })
            .collect()
    }

    /// A text summary: identifiability, the values with `u`, the residual
    /// level.
    pub fn summary(&self) -> String {
        self.summary_with(&self.u())
    }

    /// [`Self::summary`] with the uncertainties `u` reported (a Monte-Carlo
    /// study's, or the covariance's widened under a misfit), as the result
    /// file holds them.
    pub fn summary_with(&self, u: &[Option<f64>]) -> String {
        use std::fmt::Write as _;
        let mut s = self.identifiability.render();
        let names = self.model.param_names();
        let units = self.model.param_units();
        let _ = writeln!(
            s,
            "method {}: residual sigma {:.3} um ({} degrees of freedom)",
            self.method, self.sigma_um, self.dof
        );
        for i in 0..self.theta.len() {
            match u[i] {
                Some(ui) => {
                    let _ = writeln!(
                        s,
                        "  {:<24} {:>10.3} {:<5} u = {:.3}",
                        names[i], self.theta[i], units[i], ui
                    );
                }
                None => {
                    let _ = writeln!(
                        s,
                        "  {:<24} {:>10} {:<5} (not identifiable)",
                        names[i], "-", units[i]
                    );
                }
            }
        }
        for n in &self.notes {
            let _ = writeln!(s, "note: {n}");
        }
        s
    }
}
