//! The exact kinematic model of docs/model.md and its extension to
//! head-table and head-head machines: forward kinematics (axis values to the
//! tool tip and tool axis in W), inverse kinematics (by Newton from the
//! closed-form nominal solution), and analytic Jacobians of the tool pose
//! with respect to the axis values and to every error term.
//!
//! The chain is a product of elementary transforms (translations and
//! rotations about X, Y, Z), each an affine function of the *variables*:
//! the five axis values and the [`Perturbation`] slots (error terms of each
//! link, the linear-axis error at the commanded position, tool length).
//! For a table-table machine it is exactly
//!
//! ```text
//! wq = rTw^-1 * Trans(X, Y, Z) * Rx(ea) Ry(eb) Rz(ec) * Tz(-dL) * 0
//! rTw = D(dx_TY, ..., c_TY) * R_T(-t) * D(dx_CT, ..., c_CT) * Dc(-c)
//! ```
//!
//! with (X, Y, Z) = rTw* wq* for the nominal tool point, which is the form of docs/model.md,
//! `wq = rTw^-1 rTw* wq*`. Head machines append the head links to the tool
//! side: `Trans(X, Y, Z) * Tz(Lh) * E_C * Dc(c) * E_T * R_T(t) * E_S * Tz(-Lh)`
//! with `Lh` the pivot length plus the tool's gauge length, so that the
//! commanded X, Y, Z is the tool tip when the head is at zero (tool length
//! compensation along Z, as without TCP).
//!
//! Nothing here linearizes: the Jacobians are exact derivatives of the exact
//! model, used by identification and by Newton's method.

mod chain;
pub mod fast;
mod inverse;
pub mod maps;
pub mod pose_frame;
pub mod symbols;

use nalgebra::{Isometry3, SMatrix, Vector3};

use crate::geom::{self, Axis3};
use crate::machine::{Machine, Structure};

pub use chain::ChainOp;
pub use inverse::IkError;

/// Number of links with error terms (two rotary axes and the spindle).
pub(crate) const LINKS: usize = 3;
/// Slot of the linear-axis error in X (Y, Z follow), mm, machine frame.
pub const SLOT_LIN: usize = 18;
/// Slot of the tool (or probe) length error, mm: positive = longer.
pub const SLOT_TOOL_LENGTH: usize = 21;
/// Slot of the tool radius error, mm: positive = larger (machining only).
pub(crate) const SLOT_TOOL_RADIUS: usize = 22;
/// Slot of the probe pre-travel along the approach direction, mm (probing only).
pub const SLOT_PRETRAVEL: usize = 23;
/// Slot of the linear axes' rotation about X (Y, Z follow), rad, machine
/// frame: the turn of the tool side about the commanded point that the
/// angular error motions of the linear axes make (docs/model.md).
pub const SLOT_LIN_ROT: usize = 24;
/// Number of perturbation slots.
pub const N_SLOTS: usize = 27;
/// Number of chain variables: five axis values then the slots.
pub const N_VARS: usize = 5 + N_SLOTS;
/// Variable index of the tilt angle (rad) in Jacobians.
pub const VAR_TILT: usize = 3;
/// Variable index of the C angle (rad) in Jacobians.
pub const VAR_C: usize = 4;

/// Axis values of a five-axis machine: X, Y, Z in program coordinates
/// (work offset on the W origin at rotary zero), mm; tilt and C in degrees.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Axes {
    /// X, Y, Z, mm.
    pub xyz: Vector3<f64>,
    /// Tilt axis (A or B), deg.
    pub tilt: f64,
    /// C axis, deg.
    pub c: f64,
}

impl Axes {
    /// Axis values from their five numbers.
    pub fn new(x: f64, y: f64, z: f64, tilt: f64, c: f64) -> Axes {
        Axes {
            xyz: Vector3::new(x, y, z),
            tilt,
            c,
        }
    }
}

/// Tool tip and tool axis in W.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToolPose {
    /// Tool tip (or probe-ball centre), mm.
    pub tip: Vector3<f64>,
    /// Unit tool axis, pointing from the tip towards the spindle.
    pub axis: Vector3<f64>,
}

/// The values of all error terms and measurement slots for one
/// configuration, in mm and rad (see the `SLOT_*` constants; slots
/// `6 * link + k` hold the six terms of each link).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Perturbation(pub [f64; N_SLOTS]);

impl Default for Perturbation {
    fn default() -> Self {
        Perturbation([0.0; N_SLOTS])
    }
}

impl Perturbation {
    /// No error at all.
    pub fn zero() -> Self {
        Self::default()
    }

    /// The six terms of `link`.
    pub fn link(&self, link: usize) -> [f64; 6] {
        let mut t = [0.0; 6];
        t.copy_from_slice(&self.0[link * 6..link * 6 + 6]);
        t
    }

    /// The linear-axis error vector, mm.
    pub fn linear(&self) -> Vector3<f64> {
        Vector3::new(self.0[SLOT_LIN], self.0[SLOT_LIN + 1], self.0[SLOT_LIN + 2])
    }

    /// The linear axes' rotation of the tool side, rad (about X, Y, Z).
    pub fn linear_rotation(&self) -> Vector3<f64> {
        Vector3::new(
            self.0[SLOT_LIN_ROT],
            self.0[SLOT_LIN_ROT + 1],
            self.0[SLOT_LIN_ROT + 2],
        )
    }
}

/// The exact pose and its derivatives with respect to every chain variable
/// (columns: X, Y, Z in mm; tilt, C in rad; then the slots in their units).
#[derive(Clone, Debug)]
pub struct PoseJacobian {
    /// The pose.
    pub pose: ToolPose,
    /// d tip / d variable.
    pub tip: SMatrix<f64, 3, N_VARS>,
    /// d axis / d variable.
    pub axis: SMatrix<f64, 3, N_VARS>,
}

/// What a link is: its child body and parent body letters and which angle
/// variables its terms may depend on in a map.
#[derive(Clone, Debug, PartialEq)]
pub struct LinkInfo {
    /// Child body letter (`B`, `C`, or `S` for the spindle).
    pub child: char,
    /// Parent body letter.
    pub parent: char,
    /// Which angles (0 = tilt, 1 = C) a map of this link's terms runs over.
    pub map_deps: Vec<usize>,
}

/// The kinematic model of one machine with one tool (or probe) length.
#[derive(Clone, Debug)]
pub struct Kinematics {
    machine: Machine,
    links: Vec<LinkInfo>,
    gauge_length: f64,
    chain: chain::Chain,
    /// Number of leading chain factors that form `rTw^-1`.
    table_factors: usize,
    /// The variables those factors depend on.
    table_vars: Vec<usize>,
}

impl Kinematics {
    /// The model with the machine's default cutting tool.
    pub fn new(machine: &Machine) -> Kinematics {
        Kinematics::with_gauge_length(machine, machine.tool.length)
    }

    /// The model with a tool (or probe) of the given gauge length, mm. It
    /// matters only on head machines, where it sets the swing radius.
    pub fn with_gauge_length(machine: &Machine, gauge_length: f64) -> Kinematics {
        let links = link_infos(machine);
        let (chain, table_factors) = chain::build(machine, gauge_length);
        let table_vars = chain.vars_of(table_factors);
        Kinematics {
            machine: machine.clone(),
            links,
            gauge_length,
            chain,
            table_factors,
            table_vars,
        }
    }

    /// The machine.
    pub fn machine(&self) -> &Machine {
        &self.machine
    }

    /// The gauge length in use, mm.
    pub fn gauge_length(&self) -> f64 {
        self.gauge_length
    }

    /// Whether the linear axes at `axes` keep the spindle gauge point
    /// inside the machine's strokes; which axis leaves them, and where,
    /// otherwise.
    pub fn check_strokes(&self, axes: &Axes) -> Result<(), String> {
        let gauge = axes.xyz + Vector3::z() * self.gauge_length;
        self.machine()
            .check_strokes(&gauge)
            .map_err(|(axis, v, (lo, hi))| {
                format!(
                    "{axis} would be at {v:.3} in machine coordinates, outside its stroke [{lo}, {hi}]"
                )
            })
    }

    /// The links that carry error terms, in chain order from the base.
    pub fn links(&self) -> &[LinkInfo] {
        &self.links
    }

    /// Name of error-term slot `slot` (`dx_BY`, `a_CB`, ...) or of a
    /// measurement slot; `None` for a term slot the machine does not have.
    pub fn slot_name(&self, slot: usize) -> Option<String> {
        const COMP: [&str; 6] = ["dx", "dy", "dz", "a", "b", "c"];
        if slot < SLOT_LIN {
            let link = self.links.get(slot / 6)?;
            return Some(format!("{}_{}{}", COMP[slot % 6], link.child, link.parent));
        }
        Some(
            match slot {
                SLOT_LIN => "lin_x",
                19 => "lin_y",
                20 => "lin_z",
                SLOT_TOOL_LENGTH => "tool_length",
                SLOT_TOOL_RADIUS => "tool_radius",
                SLOT_PRETRAVEL => "pretravel",
                24 => "lin_a",
                25 => "lin_b",
                26 => "lin_c",
                _ => return None,
            }
            .to_string(),
        )
    }

    /// A human-readable description of the chain, as `machine show` prints it.
    pub fn describe_chain(&self) -> String {
        self.chain.describe(self)
    }

    fn vars(&self, axes: &Axes, p: &Perturbation) -> [f64; N_VARS] {
        let mut v = [0.0; N_VARS];
        v[0] = axes.xyz.x;
        v[1] = axes.xyz.y;
        v[2] = axes.xyz.z;
        v[VAR_TILT] = geom::rad(axes.tilt);
        v[VAR_C] = geom::rad(axes.c);
        v[5..].copy_from_slice(&p.0);
        v
    }

    /// Forward kinematics with errors: the actual tool tip and axis in W.
    pub fn forward(&self, axes: &Axes, p: &Perturbation) -> ToolPose {
        let iso = self.chain.eval(&self.vars(axes, p));
        pose_of(&iso)
    }

    /// The pose of [`Kinematics::jacobian`], the same bits, without the
    /// derivatives (for a search that differentiates only where it ends).
    pub fn jacobian_pose(&self, axes: &Axes, p: &Perturbation) -> ToolPose {
        self.chain.jacobian_pose(&self.vars(axes, p))
    }

    /// The part of the chain before the linear axes (the turning table's,
    /// nothing on a head-head machine) at `axes`' rotary positions and
    /// errors `p`: the same for every X, Y and Z.
    pub fn table_part(&self, axes: &Axes, p: &Perturbation) -> TablePart {
        let v = self.vars(axes, p);
        TablePart {
            product: self
                .chain
                .advance(chain::Partial::START, &v, self.table_factors),
            vars: v,
        }
    }

    /// [`Kinematics::forward`], the same bits, starting from a
    /// [`TablePart`]: its product is reused where the table's factors have
    /// the same values (the same rotary positions and the same errors of
    /// the table's links), and the whole chain multiplied otherwise.
    pub fn forward_after(&self, part: &TablePart, axes: &Axes, p: &Perturbation) -> ToolPose {
        let v = self.vars(axes, p);
        // The same variables give the same factors, and the same product.
        let same = self
            .table_vars
            .iter()
            .all(|&i| v[i].to_bits() == part.vars[i].to_bits());
        let from = if same {
            part.product
        } else {
            chain::Partial::START
        };
        pose_of(&self.chain.advance(from, &v, self.chain.len()).iso())
    }

    /// Nominal forward kinematics.
    pub fn forward_nominal(&self, axes: &Axes) -> ToolPose {
        self.forward(axes, &Perturbation::zero())
    }

    /// The pose with its derivatives with respect to every variable.
    pub fn jacobian(&self, axes: &Axes, p: &Perturbation) -> PoseJacobian {
        self.chain.jacobian(&self.vars(axes, p))
    }

    /// `rTw`: the transform from W to the machine frame (origin at the
    /// pivot) for the given rotary angles (deg), with errors. For head-head
    /// machines it is the identity.
    pub fn table_transform(&self, tilt: f64, c: f64, p: &Perturbation) -> Isometry3<f64> {
        let axes = Axes::new(0.0, 0.0, 0.0, tilt, c);
        self.chain
            .eval_prefix(&self.vars(&axes, p), self.table_factors)
            .inverse()
    }

    /// Nominal `rTw*`.
    pub fn nominal_table_transform(&self, tilt: f64, c: f64) -> Isometry3<f64> {
        self.table_transform(tilt, c, &Perturbation::zero())
    }

    /// The tool axis in the machine frame for the head angles, nominal
    /// (always +Z on a table-table machine).
    pub(crate) fn nominal_tool_axis_machine(&self, tilt: f64, c: f64) -> Vector3<f64> {
        let m = &self.machine;
        let mut r = Isometry3::identity();
        if !m.c.on_table {
            r *= geom::rot(Axis3::Z, m.c.direction * geom::rad(c));
        }
        if !m.tilt.on_table {
            r *= geom::rot(m.tilt.about, m.tilt.direction * geom::rad(tilt));
        }
        r.rotation * Vector3::z()
    }
}

/// See [`Kinematics::table_part`].
#[derive(Clone, Copy, Debug)]
pub struct TablePart {
    product: chain::Partial,
    /// The variables it was made at.
    vars: [f64; N_VARS],
}

fn pose_of(iso: &Isometry3<f64>) -> ToolPose {
    ToolPose {
        tip: iso.translation.vector,
        axis: iso.rotation * Vector3::z(),
    }
}

fn link_infos(m: &Machine) -> Vec<LinkInfo> {
    match m.structure {
        Structure::TableTable => vec![
            LinkInfo {
                child: m.tilt.letter,
                parent: m.tilt.parent,
                map_deps: vec![0],
            },
            LinkInfo {
                child: 'C',
                parent: m.c.parent,
                map_deps: vec![0, 1],
            },
        ],
        Structure::HeadTable => vec![
            LinkInfo {
                child: 'C',
                parent: m.c.parent,
                map_deps: vec![1],
            },
            LinkInfo {
                child: m.tilt.letter,
                parent: m.tilt.parent,
                map_deps: vec![0],
            },
            LinkInfo {
                child: 'S',
                parent: m.tilt.letter,
                map_deps: vec![],
            },
        ],
        Structure::HeadHead => vec![
            LinkInfo {
                child: 'C',
                parent: m.c.parent,
                map_deps: vec![1],
            },
            LinkInfo {
                child: m.tilt.letter,
                parent: 'C',
                map_deps: vec![1, 0],
            },
            LinkInfo {
                child: 'S',
                parent: m.tilt.letter,
                map_deps: vec![],
            },
        ],
    }
}
