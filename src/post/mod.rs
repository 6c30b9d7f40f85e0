//! The post-processor engine: a controller-neutral toolpath ([`Op`]) rendered
//! to a dialect by a definition in `postprocessors/` ([`PostDefinition`]).
//!
//! Plans (machining and probing) emit only neutral ops, in program
//! coordinates (mm, deg; work offset on the W origin at rotary zero, or in
//! the tilted-plane frame while a [`Op::TiltedPlane`] is active). A
//! definition is a YAML file with the dialect's number formats, block
//! numbering, comment rules, line-length limit and one MiniJinja template
//! per op; the four built-in definitions (`fanuc`, `heidenhain`,
//! `linuxcnc`, `sinumerik`) are embedded in the binary, and a user can copy one, edit it
//! and pass it by path. The engine, not the templates, enforces the safety
//! rules every program must keep: a [`Op::Retract`] before every
//! [`Op::Rotary`] index (no move in between), no rotary index while a tilted
//! plane or TCP is active, no cutting move without a spindle, no probe move
//! with the spindle on, no log line without an open log, and every block
//! within the line-length limit.
//!
//! What each op becomes in the built-in definitions:
//!
//! | op | FANUC | HEIDENHAIN | LinuxCNC | SINUMERIK |
//! |---|---|---|---|---|
//! | `Rapid` / `Feed` | `G0 X..` / `G1 X.. F..` | `L X+.. R0 FMAX` / `L X+.. R0 F..` | `G0` / `G1` | `G0` / `G1` |
//! | `Retract` | `G0 Z..` | `L Z+.. R0 FMAX` | `G0 Z..` | `G0 Z..` |
//! | `Rotary` | `G0 B.. C..` | `L B+.. C+.. R0 FMAX` | `G0 B.. C..` | `G0 B.. C..` |
//! | `TiltedPlane` | `G68.2 X0 Y0 Z0 I J K` + `G53.1` | `PLANE SPATIAL SPA SPB SPC STAY` | (none: refused) | `CYCLE800(0,"TC1",0,192,...)` (rotary positions) |
//! | `TcpOn` | `G43.4 H..` | `FUNCTION TCPM ...` | (none: refused) | `TRAORI` |
//! | `ProbeMove` | `G31 X.. F..` | `TCH PROBE 0.0 REF. PLANE Q.. Z-` / `0.1` start point | `G38.2 X.. F..` | `MEAS=1 G1 X.. Y.. Z.. F..`, `STOPRE`, alarm if `$AC_MEA[1]==0` |
//! | `ProbeRead` | `#101=#5061` ... | `FN 18: SYSREAD Q101 = ID360 NR1 IDX1` ... | `#101=#5061` ... | `R101=$AA_MW[X]` ... |
//! | `LogOpen` | `POPEN`, `DPRNT[FIVECAL*TEST]` | `FN 16: F-PRINT <log>-head.A / <log>.txt` | `(LOGOPEN,<log>.log)`, `(LOG,FIVECAL test)` | `DELETE` of an old log, `WRITE(FCERR,"FIVECAL_<LOG>","FIVECAL test")` |
//! | `LogPoint` | `#199=i`, `DPRNT[T#199[50]*X#5061[44]*...]` | `FN 18` reads of ID360, `Q1900 = i`, `FN 16: F-PRINT <log>-touch.A / ...` | `(LOG,T label X#5061 Y#5062 Z#5063)` | `R1=$AA_MW[X]`..., `FCLINE="T<i> X"<<ROUND(R1*10000)/10000<<...`, `WRITE` |
//! | `LogClose` | `PCLOS` | (nothing) | `(LOGCLOSE)` | (nothing) |
//!
//! The log lines are exactly what [`crate::formats::probe_log`] reads
//! (FANUC, HEIDENHAIN and SINUMERIK by touch index, LinuxCNC by label; HEIDENHAIN's
//! cycle-0 touch point is already radius-compensated and logged as a `K`
//! line). HEIDENHAIN prints through two format files that
//! [`PostDefinition::render`] returns as auxiliary files (`<log>-head.a`,
//! `<log>-touch.a`); their syntax follows the TNC manuals' examples and
//! should be checked on the target control (`notes/nc-dialects.md` 2.6).

mod definition;
mod load;
mod number;
mod render;

use nalgebra::{Matrix3, Vector3};

pub use definition::{ControllerKinematics, DefinitionError, PostDefinition};
pub use number::{NumberFormat, PointRule};
pub use render::{AuxFile, PostError, ProgramInfo, RenderedProgram};

/// Coolant (or air blow) kinds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Coolant {
    /// No coolant.
    Off,
    /// Flood coolant.
    Flood,
    /// Mist.
    Mist,
    /// Air blow (Ibaraki & Ota 2014).
    Air,
}

impl Coolant {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Coolant::Off => "off",
            Coolant::Flood => "flood",
            Coolant::Mist => "mist",
            Coolant::Air => "air",
        }
    }
}

/// A linear move's target in program coordinates; `None` keeps an axis.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Target {
    /// X, mm.
    pub x: Option<f64>,
    /// Y, mm.
    pub y: Option<f64>,
    /// Z, mm.
    pub z: Option<f64>,
}

impl Target {
    /// All three axes.
    pub fn xyz(p: Vector3<f64>) -> Target {
        Target {
            x: Some(p.x),
            y: Some(p.y),
            z: Some(p.z),
        }
    }
}

/// One controller-neutral operation. Coordinates are program coordinates
/// (mm, deg).
#[derive(Clone, Debug, PartialEq)]
pub enum Op {
    /// A comment block.
    Comment(String),
    /// A structure comment opening a section of the program (a pose).
    Section(String),
    /// Tool change (also for probes), with the spindle speed the tool
    /// will run at (HEIDENHAIN writes it into `TOOL CALL`).
    ToolCall {
        /// Tool number.
        number: u32,
        /// Free text.
        name: String,
        /// The tool's name in the control's tool list, when it calls tools
        /// by name.
        id: Option<String>,
        /// Spindle speed, rpm (`None` for probes).
        rpm: Option<f64>,
    },
    /// Spindle on, clockwise.
    SpindleOn {
        /// rpm.
        rpm: f64,
    },
    /// Spindle stop.
    SpindleOff,
    /// Coolant on (or off with [`Coolant::Off`]).
    Coolant(Coolant),
    /// Rapid linear move.
    Rapid(Target),
    /// Feed linear move.
    Feed {
        /// Target.
        to: Target,
        /// Feed, mm/min.
        feed: f64,
    },
    /// Rapid move along program Z to the safe height; required before
    /// every rotary index.
    Retract {
        /// Program Z of the safe height, mm.
        z: f64,
    },
    /// Index the rotary axes (tilt, then C), deg.
    Rotary {
        /// Tilt axis (A or B), deg.
        tilt: f64,
        /// C, deg.
        c: f64,
    },
    /// Activate a tilted working plane: the program frame becomes `origin`
    /// + `rotation` (columns: the plane's X, Y, Z axes in the work frame).
    TiltedPlane {
        /// Plane axes in the work coordinate system (W at rotary zero).
        rotation: Matrix3<f64>,
        /// Plane origin in the work coordinate system, mm.
        origin: Vector3<f64>,
        /// The rotary angles the plane is meant for (already indexed).
        tilt: f64,
        /// C, deg.
        c: f64,
    },
    /// Cancel the tilted working plane.
    TiltedPlaneOff,
    /// Tool centre point control on (coordinates in the work frame).
    TcpOn,
    /// Tool centre point control off.
    TcpOff,
    /// Probe move towards `to` until contact (FANUC `G31`, LinuxCNC
    /// `G38.2`, HEIDENHAIN `TCH PROBE 0`).
    ProbeMove {
        /// Where the probing move starts (the probe is already there),
        /// program coordinates, mm. HEIDENHAIN's cycle 0 takes this as its
        /// pre-position point (`TCH PROBE 0.1`), which it reaches at rapid
        /// before probing along the axis of `TCH PROBE 0.0`.
        from: Vector3<f64>,
        /// End point if no contact, program coordinates, mm.
        to: Vector3<f64>,
        /// Probing feed, mm/min.
        feed: f64,
        /// Unit approach direction in program coordinates.
        direction: Vector3<f64>,
    },
    /// Store the last probed position (X, Y, Z) in three variables.
    ProbeRead {
        /// Variable numbers for X, Y, Z (`#n` on FANUC/LinuxCNC, `Qn` on HEIDENHAIN).
        vars: [u32; 3],
    },
    /// Open the measurement log and write its header line `FIVECAL <test>`.
    LogOpen {
        /// Log file name without extension.
        name: String,
        /// Test name for the header.
        test: String,
    },
    /// Log the last probed position as touch `index` / `label` (FANUC and
    /// HEIDENHAIN lines carry the index, LinuxCNC lines the label; the
    /// readers of [`crate::formats::probe_log`] read them back).
    LogPoint {
        /// 1-based touch index: the row in points.csv.
        index: usize,
        /// Point label.
        label: String,
    },
    /// Close the measurement log.
    LogClose,
    /// Dwell, seconds.
    Dwell(f64),
    /// Program stop with a message (tool check, part turnover, ...).
    Stop(String),
}

impl Op {}

/// Rotating Z-X'-Z'' Euler angles (deg) of a rotation: `R = Rz(i) Rx(j) Rz(k)`
/// (FANUC `G68.2 I J K`).
pub fn euler_zxz(r: &Matrix3<f64>) -> [f64; 3] {
    let j = r[(2, 2)].clamp(-1.0, 1.0).acos();
    let (i, k) = if j.sin().abs() > 1e-12 {
        (r[(0, 2)].atan2(-r[(1, 2)]), r[(2, 0)].atan2(r[(2, 1)]))
    } else if r[(2, 2)] > 0.0 {
        (0.0, r[(1, 0)].atan2(r[(0, 0)]))
    } else {
        (0.0, (-r[(0, 1)]).atan2(r[(0, 0)]))
    };
    [clean_deg(i), clean_deg(j), clean_deg(k)]
}

/// Static X, then Y, then Z angles (deg) of a rotation: `R = Rz(c) Ry(b) Rx(a)`
/// (HEIDENHAIN `PLANE SPATIAL SPA SPB SPC`).
pub(crate) fn euler_spatial(r: &Matrix3<f64>) -> [f64; 3] {
    let sb = (-r[(2, 0)]).clamp(-1.0, 1.0);
    let b = sb.asin();
    let (a, c) = if b.cos().abs() > 1e-12 {
        (r[(2, 1)].atan2(r[(2, 2)]), r[(1, 0)].atan2(r[(0, 0)]))
    } else if sb > 0.0 {
        // R = Ry(90) Rx(a - c) Rz-part folded into a.
        (r[(0, 1)].atan2(r[(1, 1)]), 0.0)
    } else {
        ((-r[(0, 1)]).atan2(r[(1, 1)]), 0.0)
    };
    [clean_deg(a), clean_deg(b), clean_deg(c)]
}

/// Degrees from radians with tiny values and negative zero cleaned, so
/// that 90-degree poses print as exact numbers.
fn clean_deg(rad: f64) -> f64 {
    let d = rad.to_degrees();
    let r = (d * 1e9).round() / 1e9;
    if r == 0.0 { 0.0 } else { r }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{Axis3, rot};

    fn m(axis: Axis3, deg: f64) -> Matrix3<f64> {
        rot(axis, deg.to_radians())
            .rotation
            .to_rotation_matrix()
            .into_inner()
    }

    #[test]
    fn euler_angles_compose_back() {
        let cases = [
            (10.0, 20.0, 30.0),
            (-90.0, 90.0, 0.0),
            (0.0, 0.0, 45.0),
            (170.0, -35.0, -120.0),
            (0.0, 90.0, 0.0),
            (0.0, -90.0, 30.0),
            (0.0, 180.0, 20.0),
        ];
        for (a, b, c) in cases {
            let r = m(Axis3::Z, a) * m(Axis3::Y, b) * m(Axis3::X, c);
            let [i, j, k] = euler_zxz(&r);
            let back = m(Axis3::Z, i) * m(Axis3::X, j) * m(Axis3::Z, k);
            assert!((back - r).norm() < 1e-9, "zxz {a} {b} {c}: {i} {j} {k}");
            let [sa, sb, sc] = euler_spatial(&r);
            let back = m(Axis3::Z, sc) * m(Axis3::Y, sb) * m(Axis3::X, sa);
            assert!((back - r).norm() < 1e-9, "xyz {a} {b} {c}: {sa} {sb} {sc}");
        }
    }

    #[test]
    fn a_b90_table_pose_is_a_plain_spb90_plane() {
        // B = 90 on a B/C table: the plane is the W frame turned by +90 about Y.
        let r = m(Axis3::Y, 90.0);
        assert_eq!(euler_spatial(&r), [0.0, 90.0, 0.0]);
        assert_eq!(euler_zxz(&r), [90.0, 90.0, -90.0]);
    }
}

/// A SINUMERIK program name made from `stem` (a file name without its
/// extension): what the control accepts as the `<NAME>` of
/// `%_N_<NAME>_MPF` and calls by that name alone. Letters, digits and `_`,
/// upper case; the first two characters letters (or `_` and a letter),
/// else `FC_` is put in front; at most 24 characters.
pub fn sinumerik_program_name(stem: &str) -> String {
    let mut name: String = stem
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_uppercase()
            } else {
                '_'
            }
        })
        .collect();
    let b = name.as_bytes();
    let callable =
        b.len() >= 2 && (b[0].is_ascii_alphabetic() || b[0] == b'_') && b[1].is_ascii_alphabetic();
    if !callable {
        name.insert_str(0, "FC_");
    }
    name.truncate(24);
    name
}

#[cfg(test)]
mod program_name_tests {
    use super::sinumerik_program_name as name;

    #[test]
    fn a_file_name_becomes_a_name_the_control_calls() {
        assert_eq!(name("stepped-square"), "STEPPED_SQUARE");
        assert_eq!(name("ss comp.2"), "SS_COMP_2");
        // A name must open with two letters (or `_` and a letter).
        assert_eq!(name("5ax"), "FC_5AX");
        assert_eq!(name("a1"), "FC_A1");
        assert_eq!(name("_ab"), "_AB");
        assert_eq!(name(""), "FC_");
        // Non-ASCII letters are not letters to the control.
        assert_eq!(name("prüfung"), "PR_FUNG");
        // 24 characters at most.
        assert_eq!(
            name("long-program-name-for-a-part"),
            "LONG_PROGRAM_NAME_FOR_A_"
        );
    }
}
