//! The catalogue of named effects. Each knows its stable identifier, its
//! parameters and their units, and its (linear) contribution to the chain's
//! perturbation slots at a context.

use nalgebra::Vector3;

use super::Context;
use crate::geom::{Axis3, MM_PER_UM, RAD_PER_URAD};
use crate::kinematics::maps::MapGrid;
use crate::kinematics::symbols::SymbolTable;
use crate::kinematics::{
    SLOT_LIN, SLOT_LIN_ROT, SLOT_PRETRAVEL, SLOT_TOOL_LENGTH, SLOT_TOOL_RADIUS,
};

/// What a thermal drift is proportional to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DriftBasis {
    /// The pose's execution order `seq` (per cut or station).
    Seq,
    /// Elapsed time, minutes.
    Minute,
}

impl DriftBasis {
    /// `seq` or `minute`, as in error files.
    pub fn name(self) -> &'static str {
        match self {
            DriftBasis::Seq => "seq",
            DriftBasis::Minute => "minute",
        }
    }
}

/// Squareness errors of the linear axes (ISO 230-1 symbols).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Squareness {
    /// `EC(0X)Y`: the Y axis turned about +Z, so that moving Y by y moves X by -EC*y.
    CXY,
    /// `EB(0X)Z`: the Z axis turned about +Y, moving Z by z moves X by +EB*z.
    BXZ,
    /// `EA(0Y)Z`: the Z axis turned about +X, moving Z by z moves Y by -EA*z.
    AYZ,
}

impl Squareness {
    /// All three.
    pub const ALL: [Squareness; 3] = [Squareness::CXY, Squareness::BXZ, Squareness::AYZ];

    /// ISO symbol.
    pub fn symbol(self) -> &'static str {
        match self {
            Squareness::CXY => "EC(0X)Y",
            Squareness::BXZ => "EB(0X)Z",
            Squareness::AYZ => "EA(0Y)Z",
        }
    }

    /// (displaced axis, moving axis, sign).
    fn action(self) -> (Axis3, Axis3, f64) {
        match self {
            Squareness::CXY => (Axis3::X, Axis3::Y, -1.0),
            Squareness::BXZ => (Axis3::X, Axis3::Z, 1.0),
            Squareness::AYZ => (Axis3::Y, Axis3::Z, -1.0),
        }
    }

    /// From the ISO symbol.
    pub(crate) fn from_symbol(s: &str) -> Option<Squareness> {
        Squareness::ALL.into_iter().find(|q| q.symbol() == s)
    }
}

/// Approach directions of probe pre-travel parameters, in order.
pub const PROBE_DIRECTIONS: [&str; 6] = ["X+", "X-", "Y+", "Y-", "Z+", "Z-"];

/// One named effect.
#[derive(Clone, Debug, PartialEq)]
pub enum Effect {
    /// Constant location errors, one parameter per listed symbol (indices
    /// into the machine's location symbols). Identifier `location`.
    Location {
        /// Which symbols.
        symbols: Vec<usize>,
    },
    /// A position-dependent map of one term over the grid's nodes: the
    /// values add to the location error. Identifier `map.<SYMBOL>`.
    Map {
        /// Index into the machine's map symbols.
        symbol: usize,
        /// The grid.
        grid: MapGrid,
    },
    /// Thermal drift of a location symbol: `value += rate * seq` (or
    /// minutes). Identifier `drift.<SYMBOL>`.
    Drift {
        /// Index into the location symbols.
        symbol: usize,
        /// Per pose or per minute.
        basis: DriftBasis,
    },
    /// Linear positioning (scale) error of one axis, um/m, zero at the W
    /// origin. Identifier `scale.EXX` (`EYY`, `EZZ`).
    Scale {
        /// The axis.
        axis: Axis3,
    },
    /// A squareness error, urad. Identifier `squareness.<SYMBOL>`.
    Squareness {
        /// Which.
        kind: Squareness,
    },
    /// Straightness of the `moving` axis in the `direction` axis, um at
    /// nodes along the moving axis (program coordinates, mm), linear in
    /// between and constant beyond. Identifier `straightness.E<dir><moving>`.
    Straightness {
        /// The axis that moves.
        moving: Axis3,
        /// The direction it deviates in.
        direction: Axis3,
        /// Node positions, mm, increasing.
        nodes: Vec<f64>,
    },
    /// Positioning error of one linear axis, um at nodes along it (program
    /// coordinates, mm), linear in between and constant beyond: moving the
    /// axis to x displaces it along itself by the map's value there.
    /// Identifier `positioning.EXX` (`EYY`, `EZZ`).
    Positioning {
        /// The axis.
        axis: Axis3,
        /// Node positions, mm, increasing.
        nodes: Vec<f64>,
    },
    /// Angular error motion `E<about><moving>` of a linear axis (ISO 230-1:
    /// `EBX` is the turn about Y as X moves), urad at nodes along the
    /// moving axis, linear in between and constant beyond: the tool side
    /// turns relative to the workpiece by the value about `about`, about a
    /// point of the moving axis's carriage, so the tip moves by
    /// `eps x lever` with the lever of [`SymbolTable::levers`] plus the
    /// context's measured offset (docs/model.md). Identifier
    /// `angular.E<about><moving>`.
    Angular {
        /// The axis turned about.
        about: Axis3,
        /// The axis that moves.
        moving: Axis3,
        /// Node positions, mm, increasing.
        nodes: Vec<f64>,
    },
    /// Tool radius error, um (actual minus nominal). Identifier `tool_radius`.
    ToolRadius,
    /// Tool (or probe) length error, um. Identifier `tool_length`.
    ToolLength,
    /// Probe pre-travel by approach direction, um, six parameters
    /// ([`PROBE_DIRECTIONS`]): the trigger point lies this far beyond the
    /// contact along the approach. Identifier `probe_pretravel`.
    ProbePretravel,
}

fn fmt_angle(v: f64) -> String {
    let s = format!("{v:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.').to_string();
    if s == "-0" { "0".into() } else { s }
}

impl Effect {
    /// The stable identifier (also used by `discover` and in reports).
    pub fn id(&self, sym: &SymbolTable) -> String {
        match self {
            Effect::Location { .. } => "location".into(),
            Effect::Map { symbol, .. } => format!("map.{}", sym.maps[*symbol].name),
            Effect::Drift { symbol, .. } => format!("drift.{}", sym.location[*symbol].name),
            Effect::Scale { axis } => format!("scale.E{0}{0}", axis.letter()),
            Effect::Squareness { kind } => format!("squareness.{}", kind.symbol()),
            Effect::Straightness {
                moving, direction, ..
            } => {
                format!("straightness.E{}{}", direction.letter(), moving.letter())
            }
            Effect::Positioning { axis, .. } => format!("positioning.E{0}{0}", axis.letter()),
            Effect::Angular { about, moving, .. } => {
                format!("angular.E{}{}", about.rot_letter(), moving.letter())
            }
            Effect::ToolRadius => "tool_radius".into(),
            Effect::ToolLength => "tool_length".into(),
            Effect::ProbePretravel => "probe_pretravel".into(),
        }
    }

    /// Number of parameters.
    pub fn n_params(&self) -> usize {
        match self {
            Effect::Location { symbols } => symbols.len(),
            Effect::Map { grid, .. } => grid.len(),
            Effect::Straightness { nodes, .. }
            | Effect::Positioning { nodes, .. }
            | Effect::Angular { nodes, .. } => nodes.len(),
            Effect::ProbePretravel => PROBE_DIRECTIONS.len(),
            _ => 1,
        }
    }

    /// Parameter names, in one scheme for every effect: a location error
    /// by its symbol (`EX0B`), every other value by its effect's
    /// identifier ([`Effect::id`]), a drift with its clock
    /// (`drift.EZ0B/seq`), a value at a node with the node after `@`
    /// (`map.EBB(B)@B=90`, `straightness.EYX@X=-100`), a pre-travel with its
    /// approach direction (`probe_pretravel.Z-`).
    pub fn param_names(&self, sym: &SymbolTable) -> Vec<String> {
        match self {
            Effect::Location { symbols } => symbols
                .iter()
                .map(|&s| sym.location[s].name.clone())
                .collect(),
            Effect::Map { symbol, grid } => {
                let name = &sym.maps[*symbol].name;
                let letters = |a: usize| if a == 0 { sym.tilt } else { 'C' };
                (0..grid.len())
                    .map(|i| {
                        let at: Vec<String> = grid
                            .node_angles(i)
                            .iter()
                            .map(|&(a, v)| format!("{}={}", letters(a), fmt_angle(v)))
                            .collect();
                        format!("map.{name}@{}", at.join(","))
                    })
                    .collect()
            }
            Effect::Drift { symbol, basis } => vec![format!(
                "drift.{}/{}",
                sym.location[*symbol].name,
                basis.name()
            )],
            Effect::Scale { axis } => vec![format!("scale.E{0}{0}", axis.letter())],
            Effect::Squareness { kind } => vec![format!("squareness.{}", kind.symbol())],
            Effect::Straightness {
                moving,
                direction,
                nodes,
            } => nodes
                .iter()
                .map(|n| {
                    format!(
                        "straightness.E{}{}@{}={}",
                        direction.letter(),
                        moving.letter(),
                        moving.letter(),
                        fmt_angle(*n)
                    )
                })
                .collect(),
            Effect::Positioning {
                axis: moving,
                nodes,
            }
            | Effect::Angular { moving, nodes, .. } => {
                let id = self.id(sym);
                nodes
                    .iter()
                    .map(|n| format!("{id}@{}={}", moving.letter(), fmt_angle(*n)))
                    .collect()
            }
            Effect::ToolRadius => vec!["tool_radius".into()],
            Effect::ToolLength => vec!["tool_length".into()],
            Effect::ProbePretravel => PROBE_DIRECTIONS
                .iter()
                .map(|d| format!("probe_pretravel.{d}"))
                .collect(),
        }
    }

    /// Whether this is an error of the linear axes, which reads their
    /// positions and writes the linear slots (translation and rotation).
    pub fn is_linear_axis_error(&self) -> bool {
        matches!(
            self,
            Effect::Scale { .. }
                | Effect::Squareness { .. }
                | Effect::Straightness { .. }
                | Effect::Positioning { .. }
                | Effect::Angular { .. }
        )
    }

    /// Parameter units.
    pub fn param_units(&self, sym: &SymbolTable) -> Vec<String> {
        let n = self.n_params();
        match self {
            Effect::Location { symbols } => symbols
                .iter()
                .map(|&s| sym.location[s].unit.to_string())
                .collect(),
            Effect::Map { symbol, .. } => vec![sym.maps[*symbol].unit.to_string(); n],
            Effect::Drift { symbol, basis } => {
                vec![format!("{}/{}", sym.location[*symbol].unit, basis.name())]
            }
            Effect::Scale { .. } => vec!["um/m".into()],
            Effect::Squareness { .. } => vec!["urad".into()],
            Effect::Angular { .. } => vec!["urad".into(); n],
            _ => vec!["um".into(); n],
        }
    }

    /// Calls `sink(slot, local parameter index, coefficient)` for every
    /// nonzero `d slot / d parameter` at `ctx`.
    pub(crate) fn coefficients(
        &self,
        sym: &SymbolTable,
        ctx: &Context,
        sink: &mut dyn FnMut(usize, usize, f64),
    ) {
        let (tilt, c) = (ctx.axes.tilt, ctx.axes.c);
        match self {
            Effect::Location { symbols } => {
                for (k, &s) in symbols.iter().enumerate() {
                    let ls = &sym.location[s];
                    let (slot, coef) = ls.canonical;
                    sink(slot, k, ls.unit.scale() / coef);
                }
            }
            Effect::Map { symbol, grid } => {
                let ms = &sym.maps[*symbol];
                for (i, w) in grid.weights(tilt, c) {
                    sink(ms.slot, i, w * ms.unit.scale());
                }
            }
            Effect::Drift { symbol, basis } => {
                let ls = &sym.location[*symbol];
                let (slot, coef) = ls.canonical;
                let x = match basis {
                    DriftBasis::Seq => ctx.seq,
                    DriftBasis::Minute => ctx.minutes,
                };
                if x != 0.0 {
                    sink(slot, 0, x * ls.unit.scale() / coef);
                }
            }
            Effect::Scale { axis } => {
                let pos = ctx.axes.xyz[axis.index()];
                sink(SLOT_LIN + axis.index(), 0, pos * 1e-3 * MM_PER_UM);
            }
            Effect::Squareness { kind } => {
                let (disp, moving, sign) = kind.action();
                let pos = ctx.axes.xyz[moving.index()];
                sink(SLOT_LIN + disp.index(), 0, sign * pos * RAD_PER_URAD);
            }
            Effect::Straightness {
                moving,
                direction,
                nodes,
            } => {
                let x = ctx.axes.xyz[moving.index()];
                for (i, w) in crate::kinematics::maps::dim_weights(nodes, false, x) {
                    if w != 0.0 {
                        sink(SLOT_LIN + direction.index(), i, w * MM_PER_UM);
                    }
                }
            }
            Effect::Positioning { axis, nodes } => {
                let x = ctx.axes.xyz[axis.index()];
                for (i, w) in crate::kinematics::maps::dim_weights(nodes, false, x) {
                    if w != 0.0 {
                        sink(SLOT_LIN + axis.index(), i, w * MM_PER_UM);
                    }
                }
            }
            Effect::Angular {
                about,
                moving,
                nodes,
            } => {
                // The tip relative to the turning point of the carriage:
                // the positions the lever holds, the measured point's
                // offset; what the chain carries beyond the commanded
                // point (a head's swing) turns with the rotation slot.
                let mut lever = ctx.measured_offset;
                for (m, &on) in sym.levers[moving.index()].iter().enumerate() {
                    if on {
                        lever[m] += ctx.axes.xyz[m];
                    }
                }
                let arm = about.unit().cross(&lever);
                let x = ctx.axes.xyz[moving.index()];
                for (i, w) in crate::kinematics::maps::dim_weights(nodes, false, x) {
                    if w == 0.0 {
                        continue;
                    }
                    sink(SLOT_LIN_ROT + about.index(), i, w * RAD_PER_URAD);
                    for k in 0..3 {
                        if arm[k] != 0.0 {
                            sink(SLOT_LIN + k, i, w * RAD_PER_URAD * arm[k]);
                        }
                    }
                }
            }
            Effect::ToolRadius => sink(SLOT_TOOL_RADIUS, 0, MM_PER_UM),
            Effect::ToolLength => sink(SLOT_TOOL_LENGTH, 0, MM_PER_UM),
            Effect::ProbePretravel => {
                if let Some(d) = ctx.approach {
                    for (k, w) in pretravel_weights(&d).iter().enumerate() {
                        if *w != 0.0 {
                            sink(SLOT_PRETRAVEL, k, w * MM_PER_UM);
                        }
                    }
                }
            }
        }
    }
}

/// Weights of the six pre-travel parameters for a unit approach direction:
/// the squared positive components, which sum to one.
pub(crate) fn pretravel_weights(d: &Vector3<f64>) -> [f64; 6] {
    let d = d.normalize();
    let mut w = [0.0; 6];
    for i in 0..3 {
        let v = d[i];
        if v > 0.0 {
            w[2 * i] = v * v;
        } else {
            w[2 * i + 1] = v * v;
        }
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::maps::MapDim;
    use crate::{Kinematics, Machine};

    /// Every value is named after its effect (the issue that led here:
    /// `EXX`, `EC(0X)Y`, `drift.EZ0B/seq` and `EZB(B)@B=-90` side by side).
    #[test]
    fn every_value_is_named_after_its_effect() {
        let kin = Kinematics::new(&Machine::builtin("bc-trunnion").unwrap());
        let sym = crate::model::Model::new(kin, Vec::new()).symbols;
        let grid = MapGrid {
            dims: vec![MapDim::new(0, &[-90.0, 0.0, 90.0], false).unwrap()],
        };
        let effects = [
            (
                Effect::Map {
                    symbol: sym.map_index("EZB(B)").unwrap(),
                    grid,
                },
                "map.EZB(B)@B=-90",
            ),
            (
                Effect::Drift {
                    symbol: sym.location_index("EZ0B").unwrap(),
                    basis: DriftBasis::Minute,
                },
                "drift.EZ0B/minute",
            ),
            (Effect::Scale { axis: Axis3::X }, "scale.EXX"),
            (
                Effect::Squareness {
                    kind: Squareness::CXY,
                },
                "squareness.EC(0X)Y",
            ),
            (
                Effect::Straightness {
                    moving: Axis3::X,
                    direction: Axis3::Y,
                    nodes: vec![-100.0, 100.0],
                },
                "straightness.EYX@X=-100",
            ),
            (Effect::ToolRadius, "tool_radius"),
            (Effect::ToolLength, "tool_length"),
            (Effect::ProbePretravel, "probe_pretravel.X+"),
        ];
        for (e, first) in effects {
            let names = e.param_names(&sym);
            assert_eq!(names.len(), e.n_params());
            assert_eq!(names[0], first);
            // The effect's identifier, then its clock, node or direction.
            let id = e.id(&sym);
            for n in &names {
                let rest = n
                    .strip_prefix(&id)
                    .unwrap_or_else(|| panic!("{n} from {id}"));
                assert!(rest.is_empty() || rest.starts_with(['@', '/', '.']), "{n}");
            }
        }
        let loc = Effect::Location {
            symbols: vec![0, 1],
        };
        assert_eq!(loc.param_names(&sym), ["EX0B", "EZ0B"]);
    }
}
