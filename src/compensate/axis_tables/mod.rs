//! A linear axis's positioning error as the controllers' own compensation
//! tables (docs/controllers.md, "Axis compensation tables").
//!
//! [`AxisTable`] is the one controller-neutral form: the axis, its
//! positions in machine coordinates (mm, rising) and at each the
//! positioning error approached in the axis's + and - direction (actual
//! minus commanded, um) with its standard uncertainty. Builders fill it
//! from what measured it ([`laser`]: the base lines L1, L2, L3 of a
//! laser-lines result); writers turn it into one controller's file
//! ([`linuxcnc`]: the joint's `COMP_FILE`, [`sinumerik`]: the leadscrew
//! error compensation's `$AA_ENC_COMP` table). FANUC's pitch error
//! compensation and HEIDENHAIN's compensation tables are refused by
//! [`write()`] with what to enter by hand: their public documentation does
//! not settle their layout and sign well enough to write them.
//!
//! The sign is what every writer has to get right: a table holds either
//! where the axis actually goes (LinuxCNC's type 0 file) or the error
//! itself that the control takes off its measured position (SINUMERIK), and
//! each writer's module says which, from which source. The tests model
//! each control from its documentation and drive a simulated erroneous axis
//! through the written file.

pub mod laser;
pub mod linuxcnc;
pub mod sinumerik;

use std::path::PathBuf;

use crate::machine::Dialect;

/// One point of an axis table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TablePoint {
    /// The axis position, machine coordinates, mm.
    pub position_mm: f64,
    /// Positioning error approached in the axis's + direction (rising
    /// positions): actual minus commanded, um.
    pub plus_um: f64,
    /// The same approached in the - direction, um.
    pub minus_um: f64,
    /// Standard uncertainty of `plus_um`, um.
    pub u_plus_um: f64,
    /// Standard uncertainty of `minus_um`, um.
    pub u_minus_um: f64,
}

impl TablePoint {
    /// The bidirectional mean error, um.
    pub fn mean_um(&self) -> f64 {
        (self.plus_um + self.minus_um) / 2.0
    }
    /// Standard uncertainty of the mean (the two directions' readings are
    /// independent), um.
    pub fn u_mean_um(&self) -> f64 {
        (self.u_plus_um.powi(2) + self.u_minus_um.powi(2)).sqrt() / 2.0
    }
    /// The reversal value, + minus -, um.
    pub fn reversal_um(&self) -> f64 {
        self.plus_um - self.minus_um
    }
}

/// A linear axis's positioning error over its positions.
#[derive(Clone, Debug, PartialEq)]
pub struct AxisTable {
    /// `X`, `Y` or `Z`.
    pub axis: char,
    /// What measured it, in words (`line L1 of laser.yaml`).
    pub from: String,
    /// The points, positions strictly rising.
    pub points: Vec<TablePoint>,
}

/// Why a table cannot be built or written.
#[derive(Debug, thiserror::Error)]
pub enum TableError {
    /// The input cannot be read as what it should be.
    #[error(transparent)]
    Source(#[from] crate::source::SourceError),
    /// A table a controller's format cannot hold, or a value beyond a limit.
    #[error("{0}")]
    Refused(String),
}

/// What an export may write.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TableLimits {
    /// Largest correction at any point, um.
    pub max_correction_um: f64,
    /// Largest standard uncertainty of any point, um.
    pub max_u_um: f64,
}

impl AxisTable {
    /// Checks the table: at least two points, positions finite and
    /// strictly rising, every value and u finite (u not negative).
    pub fn check(&self) -> Result<(), TableError> {
        let bad = |m: String| {
            Err(TableError::Refused(format!(
                "{} table ({}): {m}",
                self.axis, self.from
            )))
        };
        if self.points.len() < 2 {
            return bad(format!("{} point(s), a table needs two", self.points.len()));
        }
        for (i, p) in self.points.iter().enumerate() {
            let vals = [
                p.position_mm,
                p.plus_um,
                p.minus_um,
                p.u_plus_um,
                p.u_minus_um,
            ];
            if vals.iter().any(|v| !v.is_finite()) || p.u_plus_um < 0.0 || p.u_minus_um < 0.0 {
                return bad(format!("point {i} holds a value that is not a number"));
            }
            if i > 0 && p.position_mm <= self.points[i - 1].position_mm {
                return bad(format!(
                    "positions must rise: point {i} at {} mm follows {} mm",
                    p.position_mm,
                    self.points[i - 1].position_mm
                ));
            }
        }
        Ok(())
    }

    /// Refuses (naming the point) a correction or a u beyond `limits`.
    pub fn within(&self, limits: &TableLimits) -> Result<(), TableError> {
        for p in &self.points {
            let worst = p.plus_um.abs().max(p.minus_um.abs());
            if worst > limits.max_correction_um {
                return Err(TableError::Refused(format!(
                    "{} at {} mm: a correction of {:.2} um is beyond --max-change ({} um); nothing written",
                    self.axis,
                    crate::numbers::echo(p.position_mm),
                    worst,
                    crate::numbers::echo(limits.max_correction_um)
                )));
            }
            let u = p.u_plus_um.max(p.u_minus_um);
            if u > limits.max_u_um {
                return Err(TableError::Refused(format!(
                    "{} at {} mm: u {:.2} um is beyond --max-u ({} um); nothing written",
                    self.axis,
                    crate::numbers::echo(p.position_mm),
                    u,
                    crate::numbers::echo(limits.max_u_um)
                )));
            }
        }
        Ok(())
    }

    /// The step between the points when they are equally spaced (within
    /// 1 nm over the table), else `None`.
    pub fn equal_step(&self) -> Option<f64> {
        let n = self.points.len();
        let first = self.points[0].position_mm;
        let step = (self.points[n - 1].position_mm - first) / (n - 1) as f64;
        self.points
            .iter()
            .enumerate()
            .all(|(i, p)| (p.position_mm - (first + step * i as f64)).abs() < 1e-6)
            .then_some(step)
    }

    /// The listing every export writes beside the controller's file: each
    /// point's errors in both directions with their u, the reversal, and
    /// what the controller's file enters there (`entered`, a column name
    /// and the value at a point).
    pub fn listing(&self, entered: (&str, &dyn Fn(&TablePoint) -> String)) -> String {
        let mut s = format!(
            "{} axis, from {}: positioning error = actual minus commanded position, um, k = 1 for u\n",
            self.axis, self.from
        );
        s += &format!(
            "  {:>12}  {:>9} {:>7}  {:>9} {:>7}  {:>9}  {}\n",
            "position mm", "+ dir um", "u", "- dir um", "u", "B um", entered.0
        );
        for p in &self.points {
            s += &format!(
                "  {:>12.4}  {:>+9.3} {:>7.3}  {:>+9.3} {:>7.3}  {:>+9.3}  {}\n",
                p.position_mm,
                p.plus_um,
                p.u_plus_um,
                p.minus_um,
                p.u_minus_um,
                p.reversal_um(),
                (entered.1)(p)
            );
        }
        s
    }
}

/// The files an export of `tables` for `dialect` writes, by name, with
/// their text; refused for a controller whose table format is not written
/// (the reason says what to enter by hand), for a table its format cannot
/// hold, and for a value beyond `limits`.
pub fn write(
    dialect: Dialect,
    tables: &[AxisTable],
    limits: &TableLimits,
) -> Result<Vec<(PathBuf, String)>, TableError> {
    if tables.is_empty() {
        return Err(TableError::Refused("no axis table to write".into()));
    }
    for t in tables {
        t.check()?;
        t.within(limits)?;
    }
    match dialect {
        Dialect::Linuxcnc => linuxcnc::files(tables),
        Dialect::Sinumerik => sinumerik::files(tables),
        Dialect::Fanuc => Err(TableError::Refused(format!(
            "fanuc: the pitch error compensation is not written: its parameters (3620-3624) enter \
             each point as a signed increment from the point before, in the axis's detection unit \
             and times a magnification, counted from the point of the reference position, and no \
             public FANUC document consulted settles the sign of an increment nor the interval it \
             applies to. {BY_HAND}"
        ))),
        Dialect::Heidenhain => Err(TableError::Refused(format!(
            "heidenhain: the compensation tables (*.COM with their *.CMA configuration) are not \
             written: their layout is in HEIDENHAIN's technical manual, given to machine builders, \
             and the public material consulted does not settle the sign of an entry. {BY_HAND}"
        ))),
    }
}

/// What a refused controller's message says to do instead.
const BY_HAND: &str = "Enter the table printed above by hand as your control's manual says: \
    its values are errors, actual minus commanded position, so a control that takes a correction \
    to add needs them negated (docs/controllers.md, \"Axis compensation tables\")";

/// The machine-coordinate letter index of `axis` (0 for X).
pub(crate) fn axis_index(axis: char) -> usize {
    match axis {
        'X' => 0,
        'Y' => 1,
        _ => 2,
    }
}
