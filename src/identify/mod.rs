//! Identification: from measured points joined to their plan, the location
//! errors and error maps of docs/model.md with their covariance, and first
//! of all what the test can identify at all.
//!
//! Three methods share one parameterisation ([`Setup`]: the model's
//! location symbols plus the requested maps, the maps tied by the papers'
//! averaging constraints) and one result ([`Identification`]):
//!
//! - `two_stage`: the papers' own; a 6-DOF pose per cut or station (seed
//!   001 eq. 7-9, Ibaraki, Iritani & Matsushita 2013, eq. 7-10), then the parameters from the poses
//!   relative to the reference pose (Ibaraki & Ota 2014, eq. 10, Ibaraki, Iritani & Matsushita 2013, eq. 13-17);
//! - [`global`]: one nonlinear least-squares fit of every point to the exact
//!   forward model ([`forward::ForwardModel`]) with the placement as
//!   nuisance parameters;
//! - [`sphere`]: sphere centre per pose, then circle and plane fits per
//!   rotary axis (Cubas Brizuela & Yeh 2023, sections 3-4).
//!
//! All of them rest on the numerical core [`lsq`] and report through
//! [`identifiability`] before any number.

pub mod data;
pub mod forward;
pub mod global;
pub mod identifiability;
pub mod lsq;
pub mod nine_section;
pub mod result;
pub(crate) mod rigid;
pub mod sphere;
pub mod synthetic;
pub(crate) mod two_stage;

use std::fmt;
use std::str::FromStr;

use nalgebra::{DMatrix, Isometry3};

use crate::formats::manifest::TestKind;
use crate::geom::wrap180;
use crate::kinematics::Kinematics;
use crate::kinematics::maps::{MapDim, MapGrid};
use crate::model::{Effect, Model};
use crate::placement::{self, PlaneObservation};

pub use data::{Dataset, Observation, Pose};
pub use identifiability::Identifiability;
pub use result::{Identification, PoseFit};

/// An identification method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Pose per cut or station, then parameters from the poses.
    TwoStage,
    /// One fit of all points to the exact model.
    Global,
    /// Sphere centres, then circle and plane fits per axis.
    Sphere,
}

impl Method {
    /// All methods.
    pub const ALL: [Method; 3] = [Method::TwoStage, Method::Global, Method::Sphere];

    /// Name as on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Method::TwoStage => "two-stage",
            Method::Global => "global",
            Method::Sphere => "sphere",
        }
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Method {
    type Err = String;
    fn from_str(s: &str) -> Result<Method, String> {
        Method::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| format!("unknown method `{s}`: expected two-stage, global or sphere"))
    }
}

/// Why an identification cannot run.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum IdentifyError {
    /// A requested map symbol is not a map of this machine.
    #[error("{0}")]
    Symbol(String),
    /// The forward model cannot serve this case.
    #[error(transparent)]
    Forward(#[from] forward::ForwardError),
    /// The piece cannot be placed.
    #[error("placement: {0}")]
    Placement(#[from] placement::PlacementError),
    /// The data do not suit the method.
    #[error("{0}")]
    Data(String),
}

/// What is identified: the model (location symbols and requested maps) and
/// the linear constraints that define the maps (papers' averaging).
#[derive(Clone, Debug)]
pub struct Setup {
    /// The model; its parameters are the unknowns.
    pub model: Model,
    /// Constraint rows `C theta = 0`.
    pub constraints: DMatrix<f64>,
    /// What each constraint says.
    pub constraint_names: Vec<String>,
}

fn distinct(values: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut v: Vec<f64> = Vec::new();
    for x in values {
        if !v.iter().any(|y| (y - x).abs() < 1e-6) {
            v.push(x);
        }
    }
    v.sort_by(f64::total_cmp);
    v
}

impl Setup {
    /// Every location symbol of the machine plus the maps named in `maps`
    /// (map symbols of docs/model.md such as `EBB(B)`, `EXC(B,C)`), each on the grid of
    /// the index angles of `poses`, with the papers' averaging constraints: a
    /// tilt-axis map averages to zero over its angles and a C-axis map over
    /// C at each tilt angle (Ibaraki & Ota 2014, eq. 1, Ibaraki, Iritani & Matsushita 2013, eq. 1), so that the
    /// location errors stay the axis average lines.
    pub fn new(kin: &Kinematics, poses: &[Pose], maps: &[String]) -> Result<Setup, IdentifyError> {
        let mut model = Model::new(kin.clone(), Vec::new());
        let n_loc = model.symbols.location.len();
        model.push(Effect::Location {
            symbols: (0..n_loc).collect(),
        });
        let tilts = distinct(poses.iter().map(|p| p.tilt));
        let cs = distinct(poses.iter().map(|p| p.c.rem_euclid(360.0)));
        let mut rows: Vec<Vec<(usize, f64)>> = Vec::new();
        let mut names = Vec::new();
        for name in maps {
            let si = model
                .symbols
                .map_index(name)
                .map_err(|e| IdentifyError::Symbol(e.to_string()))?;
            if model.find(&format!("map.{name}")).is_some() {
                return Err(IdentifyError::Symbol(format!(
                    "map {name} is requested twice"
                )));
            }
            let deps = model.symbols.maps[si].deps.clone();
            let mut dims = Vec::new();
            for &d in &deps {
                let (nodes, periodic) = if d == 0 { (&tilts, false) } else { (&cs, true) };
                dims.push(
                    MapDim::new(d, nodes, periodic)
                        .map_err(|e| IdentifyError::Symbol(e.to_string()))?,
                );
            }
            let grid = MapGrid { dims };
            let start = model.n_params();
            let len = grid.len();
            model.push(Effect::Map {
                symbol: si,
                grid: grid.clone(),
            });
            if deps.len() == 1 {
                if len > 1 {
                    rows.push((start..start + len).map(|i| (i, 1.0)).collect());
                    names.push(format!("{name} averages to zero over its angles"));
                }
            } else {
                let nc = grid.dims[1].nodes.len();
                if nc > 1 {
                    let letter = model.symbols.tilt;
                    for r in 0..grid.dims[0].nodes.len() {
                        rows.push((0..nc).map(|c| (start + r * nc + c, 1.0)).collect());
                        names.push(format!(
                            "{name} averages to zero over C at {letter} = {}",
                            grid.dims[0].nodes[r]
                        ));
                    }
                }
            }
        }
        let n = model.n_params();
        let mut c = DMatrix::zeros(rows.len(), n);
        for (r, row) in rows.iter().enumerate() {
            for &(i, v) in row {
                c[(r, i)] = v;
            }
        }
        Ok(Setup {
            model,
            constraints: c,
            constraint_names: names,
        })
    }

    /// Orthonormal basis of the parameter directions the constraints leave
    /// free, extended by `extra` unconstrained nuisance parameters.
    pub fn basis(&self, extra: usize) -> DMatrix<f64> {
        let b = lsq::constraint_basis(&self.constraints);
        let n = self.model.n_params();
        let mut out = DMatrix::zeros(n + extra, b.ncols() + extra);
        out.view_mut((0, 0), (n, b.ncols())).copy_from(&b);
        for i in 0..extra {
            out[(n + i, b.ncols() + i)] = 1.0;
        }
        out
    }
}

/// The CMM placement of a machined piece from its reference features: the
/// faces of the reference pose (tilt = C = 0), or all faces when those do
/// not fix the piece.
pub fn initial_placement(data: &Dataset) -> Result<Isometry3<f64>, IdentifyError> {
    let obs: Vec<PlaneObservation> = data
        .obs
        .iter()
        .map(|o| {
            let p = &data.plan.points[o.plan];
            PlaneObservation {
                p: p.p,
                n: p.n,
                m: o.m,
            }
        })
        .collect();
    let reference = &data.poses[data.reference_pose()].obs;
    Ok(placement::place_labeled(&obs, reference)?.iso)
}

/// Checks the data suit a method (poses, points, test kind).
pub(crate) fn check_data(data: &Dataset, method: Method) -> Result<(), IdentifyError> {
    if data.poses.len() < 2 {
        let mut planned: Vec<&str> = Vec::new();
        for p in &data.plan.points {
            if !planned.contains(&p.pose.as_str()) {
                planned.push(&p.pose);
            }
        }
        let files: Vec<String> = data
            .files
            .iter()
            .take(3)
            .map(|f| f.display().to_string())
            .collect();
        return Err(IdentifyError::Data(format!(
            "{}{}: the measurements cover {} of the plan's {} poses{}: identification needs several index angles; measure the other poses",
            files.join(", "),
            if data.files.len() > 3 {
                format!(" and {} more files", data.files.len() - 3)
            } else {
                String::new()
            },
            data.poses.len(),
            planned.len(),
            data.poses.first().map_or(String::new(), |p| format!(
                " (only {})",
                crate::source::cut(&p.id)
            ))
        )));
    }
    if method == Method::Sphere && data.kind != TestKind::Probing {
        return Err(IdentifyError::Data(
            "the sphere method needs on-machine probing of a calibration sphere (a probing plan)"
                .into(),
        ));
    }
    if data
        .poses
        .iter()
        .all(|p| wrap180(p.c).abs() < 1e-9 && p.tilt == data.poses[0].tilt)
    {
        return Err(IdentifyError::Data(
            "all poses are at the same index angles".into(),
        ));
    }
    Ok(())
}
