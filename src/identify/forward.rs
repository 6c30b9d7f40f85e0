//! The forward measurement model that the `global` method inverts: for each
//! plan point, the point a measurement of it returns and the actual surface
//! normal there, as exact functions of the model parameters, with their
//! Jacobians.
//!
//! [`ForwardModel`] is the seam between identification and simulation. The
//! foundation alone serves one case exactly, implemented here as
//! [`RigidPoseMachining`]: a table-table machining test whose errors are
//! constant within each pose (location errors, maps, drift per pose or per
//! minute at the pose's middle), where the machined face of a pose is the
//! nominal face moved by `rTw^-1 rTw*` (docs/model.md) and the CMM measures
//! along the nominal normal. The simulator supplies the general model (tool
//! radius and shape, linear-axis errors along the path, probing with
//! pre-travel) through the same trait. [`RigidPoseProbing`] is the same
//! for on-machine probing of a piece set up anywhere on the table, the
//! setup being six nuisance parameters of the model.

use nalgebra::{DMatrix, Point3, Vector3};

use crate::formats::points::PlanPoint;
use crate::kinematics::Axes;
use crate::machine::Structure;
pub use crate::model::Wanted;
use crate::model::{Context, Effect, Model};

/// The predicted measurement of one plan point.
#[derive(Clone, Debug, PartialEq)]
pub struct Prediction {
    /// Predicted measured point, mm, in the frame of the test before any
    /// placement: W for a machined piece, W at rotary zero for on-machine
    /// probing.
    pub point: Vector3<f64>,
    /// Unit normal of the actual surface at that point (same frame).
    pub normal: Vector3<f64>,
    /// `d point / d (theta, nuisance)`, 3 x (n + nuisance) (mm per unit).
    pub d_point: DMatrix<f64>,
    /// `d normal / d (theta, nuisance)`, 3 x (n + nuisance).
    pub d_normal: DMatrix<f64>,
}

/// Why a forward model cannot serve a model or a point.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ForwardError {
    /// The model has an effect this forward model cannot apply exactly.
    #[error(
        "effect `{0}` varies within a pose; the rigid-pose model cannot apply it exactly (it needs the simulator's forward model)"
    )]
    UnsupportedEffect(String),
    /// The machine structure is not served.
    #[error(
        "the rigid-pose model serves table-table machines only, not {0}: `--method global` serves every structure"
    )]
    UnsupportedMachine(String),
    /// The normal line of a point does not meet its moved face.
    #[error("the normal line of `{0}` does not meet its face")]
    NoIntersection(String),
    /// Anything the implementor needs to report.
    #[error("{0}")]
    Other(String),
}

/// A forward measurement model.
///
/// Implementors predict, for a plan point, the measured point and the
/// actual surface normal there as exact functions of the parameters
/// `theta` of [`ForwardModel::model`] (file units: um, urad, ...) and of
/// their own nuisance parameters (e.g. the setup of a probed piece), with
/// the exact derivatives. The identification adds the CMM placement of a
/// machined piece and compares along the predicted normal, so the
/// tangential position of the predicted point does not matter, only that it
/// lies on the predicted surface.
pub trait ForwardModel: Sync {
    /// The model; `theta` has `model().n_params()` entries in its order.
    fn model(&self) -> &Model;
    /// Names of the model's own nuisance parameters (um, urad), estimated
    /// with `theta` and reported only through identifiability.
    fn nuisance_names(&self) -> Vec<String> {
        Vec::new()
    }
    /// The predicted measurement of `point`, taken at `minutes` from the
    /// start of the program (the middle of its pose).
    fn predict(
        &self,
        theta: &[f64],
        nuisance: &[f64],
        point: &PlanPoint,
        minutes: f64,
    ) -> Result<Prediction, ForwardError>;
    /// [`ForwardModel::predict`] for a caller that uses the derivatives
    /// with respect to `wanted`'s parameters only: the other columns of
    /// `d_point` and `d_normal` may be left zero. A fit of a few effects
    /// with a model that carries a whole catalogue (a machining test, whose
    /// cuts are built with every effect's breaks) then pays for its own
    /// columns. The wanted columns are those of `predict`, to the bit.
    fn predict_wanted(
        &self,
        theta: &[f64],
        nuisance: &[f64],
        point: &PlanPoint,
        minutes: f64,
        wanted: &Wanted,
    ) -> Result<Prediction, ForwardError> {
        let _ = wanted;
        self.predict(theta, nuisance, point, minutes)
    }
}

fn check_rigid(model: &Model) -> Result<(), ForwardError> {
    let m = model.kin.machine();
    if m.structure != Structure::TableTable {
        return Err(ForwardError::UnsupportedMachine(m.structure.to_string()));
    }
    for e in &model.effects {
        match e {
            Effect::Location { .. } | Effect::Map { .. } | Effect::Drift { .. } => {}
            other => {
                return Err(ForwardError::UnsupportedEffect(other.id(&model.symbols)));
            }
        }
    }
    Ok(())
}

fn context(point: &PlanPoint, xyz: Vector3<f64>, minutes: f64) -> Context {
    Context {
        axes: Axes {
            xyz,
            tilt: point.tilt,
            c: point.c,
        },
        seq: point.seq as f64,
        minutes,
        approach: None,
        ..Default::default()
    }
}

/// The intersection of the line `q0 + s d` with the plane through `y` with
/// normal `nm`, and its derivative given those of `y` and `nm`.
fn intersect(
    label: &str,
    q0: &Vector3<f64>,
    d: &Vector3<f64>,
    y: &Vector3<f64>,
    dy: &DMatrix<f64>,
    nm: &Vector3<f64>,
    dn: &DMatrix<f64>,
) -> Result<(Vector3<f64>, DMatrix<f64>), ForwardError> {
    let den = nm.dot(d);
    if den.abs() < 1e-6 {
        return Err(ForwardError::NoIntersection(label.to_string()));
    }
    let s = nm.dot(&(y - q0)) / den;
    let cols = dy.ncols();
    let mut dp = DMatrix::zeros(3, cols);
    for j in 0..cols {
        let dnj = dn.column(j);
        let dnum = dnj.dot(&(y - q0)) + nm.dot(&dy.column(j));
        let ds = (dnum - s * dnj.dot(d)) / den;
        for r in 0..3 {
            dp[(r, j)] = d[r] * ds;
        }
    }
    Ok((q0 + d * s, dp))
}

/// The rigid-pose machining model (see the module documentation).
#[derive(Clone, Debug)]
pub struct RigidPoseMachining {
    model: Model,
}

impl RigidPoseMachining {
    /// Wraps a model, refusing effects that vary within a pose and
    /// machines other than table-table ones.
    pub fn new(model: Model) -> Result<RigidPoseMachining, ForwardError> {
        check_rigid(&model)?;
        Ok(RigidPoseMachining { model })
    }

    /// `M = rTw^-1 rTw*` applied to `q`, and `d (M q) / d theta` (3 x n).
    pub fn moved(
        &self,
        theta: &[f64],
        point: &PlanPoint,
        minutes: f64,
        q: &Vector3<f64>,
    ) -> (Vector3<f64>, DMatrix<f64>) {
        let k = &self.model.kin;
        let commanded = k.nominal_table_transform(point.tilt, point.c) * Point3::from(*q);
        let (pj, jt, _) = self
            .model
            .pose_jacobian(theta, &context(point, commanded.coords, minutes));
        (pj.pose.tip, jt)
    }
}

impl ForwardModel for RigidPoseMachining {
    fn model(&self) -> &Model {
        &self.model
    }

    fn predict(
        &self,
        theta: &[f64],
        _nuisance: &[f64],
        point: &PlanPoint,
        minutes: f64,
    ) -> Result<Prediction, ForwardError> {
        let (p, n) = (point.p, point.n);
        // The tool point in W is M q for the commanded nominal q, with M
        // the same for every q of the pose: q' = M p, and R n = M(p+n) - M p.
        let (qm, dq) = self.moved(theta, point, minutes, &p);
        let (qn, dqn) = self.moved(theta, point, minutes, &(p + n));
        let nm = qn - qm;
        let dnm = &dqn - &dq;
        // The CMM measures along the nominal normal line p + s n.
        let (point_w, d_point) = intersect(&point.label, &p, &n, &qm, &dq, &nm, &dnm)?;
        Ok(Prediction {
            point: point_w,
            normal: nm,
            d_point,
            d_normal: dnm,
        })
    }
}

/// Names of the setup nuisance of [`RigidPoseProbing`].
pub(crate) const SETUP_NAMES: [&str; 6] = [
    "setup.dx", "setup.dy", "setup.dz", "setup.a", "setup.b", "setup.c",
];

/// The names of each piece's setup nuisance: `names` as they are for a
/// single piece, `setup[<piece>].dx` ... for several.
pub(crate) fn setup_names(names: &[&str], pieces: &[String]) -> Vec<String> {
    if pieces.len() == 1 {
        return names.iter().map(|s| s.to_string()).collect();
    }
    pieces
        .iter()
        .flat_map(|p| {
            names
                .iter()
                .map(move |s| s.replacen("setup", &format!("setup[{p}]"), 1))
        })
        .collect()
}

/// The rigid-pose probing model: pieces fixed on the table of a
/// table-table machine, each set up at `D(setup)` from its nominal place
/// (six nuisance numbers per piece, um and urad), probed on the machine
/// along the nominal approach `-rTw* n` with errors constant within each
/// pose. The contact point, reported in W at rotary zero, is the
/// intersection of the approach line through `rTw* p` with the face
/// through `rTw D(setup) p`.
#[derive(Clone, Debug)]
pub struct RigidPoseProbing {
    model: Model,
    pieces: Vec<String>,
    piece_of: std::collections::HashMap<String, usize>,
}

impl RigidPoseProbing {
    /// One piece (or pieces fixed together), with the restrictions of
    /// [`RigidPoseMachining`].
    pub fn new(model: Model) -> Result<RigidPoseProbing, ForwardError> {
        RigidPoseProbing::with_pieces(model, vec!["piece".into()], Default::default())
    }

    /// Separately set-up pieces: their names, and the piece of each plan
    /// point by label (points not listed belong to the first).
    pub(crate) fn with_pieces(
        model: Model,
        pieces: Vec<String>,
        piece_of: std::collections::HashMap<String, usize>,
    ) -> Result<RigidPoseProbing, ForwardError> {
        check_rigid(&model)?;
        Ok(RigidPoseProbing {
            model,
            pieces,
            piece_of,
        })
    }
}

impl ForwardModel for RigidPoseProbing {
    fn model(&self) -> &Model {
        &self.model
    }

    fn nuisance_names(&self) -> Vec<String> {
        setup_names(&SETUP_NAMES, &self.pieces)
    }

    fn predict(
        &self,
        theta: &[f64],
        nuisance: &[f64],
        point: &PlanPoint,
        minutes: f64,
    ) -> Result<Prediction, ForwardError> {
        let k = &self.model.kin;
        let n = theta.len();
        let total = n + 6 * self.pieces.len();
        let piece = self.piece_of.get(&point.label).copied().unwrap_or(0);
        let o = n + 6 * piece;
        let setup = &nuisance[6 * piece..6 * piece + 6];
        let nominal = k.nominal_table_transform(point.tilt, point.c);
        let q0 = (nominal * Point3::from(point.p)).coords;
        let dir = nominal.rotation * point.n;
        let ctx = context(point, q0, minutes);
        let rtw = k.table_transform(point.tilt, point.c, &self.model.perturbation(theta, &ctx));
        let r = rtw.rotation.to_rotation_matrix().into_inner();
        // A W point x sits at y = rTw x in the machine frame. The tool
        // Jacobian gives d(rTw^-1 y)/d theta at fixed y, and
        // rTw^-1 y = x gives dy = -R d(rTw^-1 y).
        let face = |x: &Vector3<f64>, dx: &nalgebra::Matrix3x6<f64>| {
            let y = (rtw * Point3::from(*x)).coords;
            let (_, jt, _) = self.model.pose_jacobian(theta, &context(point, y, minutes));
            let mut dy = DMatrix::zeros(3, total);
            dy.view_mut((0, 0), (3, n)).copy_from(&(-r * jt));
            dy.view_mut((0, o), (3, 6)).copy_from(&(r * dx));
            (y, dy)
        };
        let (gp, dgp) = super::rigid::d6_apply(setup, &point.p);
        let (gpn, dgpn) = super::rigid::d6_apply(setup, &(point.p + point.n));
        let (y, dy) = face(&gp, &dgp);
        let (y2, dy2) = face(&gpn, &dgpn);
        let nm = y2 - y;
        let dn = &dy2 - &dy;
        let (p, dp) = intersect(&point.label, &q0, &dir, &y, &dy, &nm, &dn)?;
        Ok(Prediction {
            point: p,
            normal: nm,
            d_point: dp,
            d_normal: dn,
        })
    }
}

/// The rigid-pose model of a dataset's test: [`RigidPoseMachining`] for a
/// machined piece, [`RigidPoseProbing`] with one setup per separately
/// set-up piece for on-machine probing.
pub(crate) fn rigid_for(
    model: Model,
    data: &crate::identify::Dataset,
) -> Result<Box<dyn ForwardModel>, ForwardError> {
    match data.kind {
        crate::formats::manifest::TestKind::Machining => {
            Ok(Box::new(RigidPoseMachining::new(model)?))
        }
        crate::formats::manifest::TestKind::Probing => {
            let piece_of = data
                .plan
                .points
                .iter()
                .zip(&data.piece_of)
                .map(|(p, &k)| (p.label.clone(), k))
                .collect();
            Ok(Box::new(RigidPoseProbing::with_pieces(
                model,
                data.pieces.clone(),
                piece_of,
            )?))
        }
    }
}
