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
//! nominal face moved by `rTw^-1 rTw*` (SPEC section 2) and the CMM measures
//! along the nominal normal. The simulator supplies the general model (tool
//! radius and shape, linear-axis errors along the path, probing with
//! pre-travel) through the same trait.

use nalgebra::{DMatrix, Point3, Vector3};

use crate::formats::points::PlanPoint;
use crate::kinematics::Axes;
use crate::machine::Structure;
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
    /// `d point / d theta`, 3 x n (mm per parameter unit).
    pub d_point: DMatrix<f64>,
    /// `d normal / d theta`, 3 x n.
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
    #[error("the rigid-pose machining model serves table-table machines only, not {0}")]
    UnsupportedMachine(String),
    /// The normal line of a point does not meet its moved face.
    #[error("the normal line of `{0}` does not meet its machined face")]
    NoIntersection(String),
    /// Anything the implementor needs to report.
    #[error("{0}")]
    Other(String),
}

/// A forward measurement model.
///
/// Implementors predict, for a plan point, the measured point and the
/// actual surface normal there as exact functions of the parameters
/// `theta` of [`ForwardModel::model`] (file units: um, urad, ...), with the
/// exact derivatives. The identification adds the CMM placement (machined
/// pieces) and compares along the predicted normal, so the tangential
/// position of the predicted point does not matter, only that it lies on
/// the predicted surface.
pub trait ForwardModel: Sync {
    /// The model; `theta` has `model().n_params()` entries in its order.
    fn model(&self) -> &Model;
    /// The predicted measurement of `point`, taken at `minutes` from the
    /// start of the program (the middle of its pose).
    fn predict(
        &self,
        theta: &[f64],
        point: &PlanPoint,
        minutes: f64,
    ) -> Result<Prediction, ForwardError>;
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
        let ctx = Context {
            axes: Axes {
                xyz: commanded.coords,
                tilt: point.tilt,
                c: point.c,
            },
            seq: point.seq as f64,
            minutes,
            approach: None,
        };
        let (pj, jt, _) = self.model.pose_jacobian(theta, &ctx);
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
        // Intersection of the nominal normal line p + s n with the moved
        // face {x : nm . (x - qm) = 0}.
        let den = nm.dot(&n);
        if den.abs() < 1e-6 {
            return Err(ForwardError::NoIntersection(point.label.clone()));
        }
        let num = nm.dot(&(qm - p));
        let s = num / den;
        let cols = dq.ncols();
        let mut d_point = DMatrix::zeros(3, cols);
        for j in 0..cols {
            let dnj = dnm.column(j);
            let dqj = dq.column(j);
            let dnum = dnj.dot(&(qm - p)) + nm.dot(&dqj);
            let dden = dnj.dot(&n);
            let ds = (dnum - s * dden) / den;
            for r in 0..3 {
                d_point[(r, j)] = n[r] * ds;
            }
        }
        Ok(Prediction {
            point: p + n * s,
            normal: nm,
            d_point,
            d_normal: dnm,
        })
    }
}
