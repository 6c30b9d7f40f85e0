//! The ball bar under tool-centre-point control (Jiang et al. 2013, its rotary-axis
//! method): each rotary axis is stepped through its range while the
//! control holds the spindle ball M still on the table frame W (TCP on),
//! and a telescoping ball bar between M and a ball N fixed on the table
//! reads how far M strays along the bar.
//!
//! A table axis is measured from three positions (K, L, H) of M with the
//! bar parallel to X, then Y, then Z of W; a head axis from three lengths S
//! (rotation centre to ball centre, set by the arbor) with the same three
//! bar directions. Per angle, each setup gives one equation in the six
//! error motions of the axis (three translations, three rotations); with
//! the setups' different lever arms they separate (the paper's eqs. 6-8 and
//! 11-14). [`plan`] chooses the setups from the machine's table and strokes
//! and the bars the user owns (or takes (K, L, H) and S as given), checks
//! every angle of every setup against the rotary limits and the strokes
//! (by fivecal's own inverse kinematics: what the control's TCP will
//! command), writes one program per setup ([`program`]), a setup sheet per
//! setup, and predicts what the runs identify and with which uncertainty
//! ([`mod@predict`]).

mod design;
pub mod predict;
pub mod program;
mod sheet;

use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use crate::formats::ball_bar::{BALL_BAR_VERSION, BallBarManifest, SetupEntry};
use crate::io::{OutputError, write_dir};
use crate::kinematics::{Axes, Kinematics};
use crate::machine::{Dialect, Machine};

pub use design::{MIN_BAR_ARBOR_DEG, choose_setups, head_angle_held};
pub use predict::{AxisPrediction, Prediction, predict};

/// What the user asks of a ball-bar plan.
#[derive(Clone, Debug)]
pub struct BallBarRequest {
    /// The machine.
    pub machine: Machine,
    /// The programs' dialect.
    pub dialect: Dialect,
    /// The bars the user owns, mm (calibrated lengths).
    pub bars: Vec<f64>,
    /// Positions (K, L, H) of the spindle ball in W for the table axes;
    /// empty: chosen from the table.
    pub balls: Vec<Vector3<f64>>,
    /// Lengths S (head rotation centre to ball centre) for the head axes,
    /// mm; empty: chosen from the strokes.
    pub swings: Vec<f64>,
    /// Gauge length of the spindle ball for the table axes, mm.
    pub gauge_mm: f64,
    /// Lowest centre of the table ball above the table top, mm (its
    /// magnetic cup on a post).
    pub min_ball_height: f64,
    /// Standard deviation of one reading, um.
    pub noise_um: f64,
    /// Standard uncertainty of the bar's calibrated length, um.
    pub calibration_um: f64,
    /// Step of a continuous C axis and of a tilt axis, deg.
    pub step_c_deg: f64,
    /// Step of a tilt axis, deg.
    pub step_tilt_deg: f64,
    /// Feed of the rotary steps, deg/min.
    pub feed_deg_min: f64,
    /// Dwell at each angle, s.
    pub dwell_s: f64,
    /// Tool number of the spindle-ball arbor (or the first of three, one
    /// per length S).
    pub tool_number: u32,
}

impl BallBarRequest {
    /// The defaults: the paper's steps (C: 60 divisions of a turn; tilt 2
    /// deg), a QC20-class bar (0.5 um noise, 1 um calibration), a 100 mm
    /// spindle-ball arbor, the table ball at least 40 mm above the table.
    pub fn new(machine: Machine, dialect: Dialect, bars: Vec<f64>) -> BallBarRequest {
        BallBarRequest {
            machine,
            dialect,
            bars,
            balls: Vec::new(),
            swings: Vec::new(),
            gauge_mm: 100.0,
            min_ball_height: 40.0,
            noise_um: 0.5,
            calibration_um: 1.0,
            step_c_deg: 6.0,
            step_tilt_deg: 2.0,
            feed_deg_min: 360.0,
            dwell_s: 2.0,
            tool_number: 1,
        }
    }
}

/// Why a ball-bar plan cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum BallBarError {
    /// A request value out of range.
    #[error("{0}")]
    Request(String),
    /// No setup of an axis can be carried out on this machine.
    #[error("{0}")]
    Impossible(String),
}

/// The bar from N to M.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BarDirection {
    /// 0, 1, 2: X, Y, Z of W.
    pub axis: usize,
    /// +1 or -1: M lies on the positive or negative side of N.
    pub sign: f64,
}

impl BarDirection {
    /// `+X`, `-Z`, ...
    pub fn label(&self) -> String {
        format!(
            "{}{}",
            if self.sign > 0.0 { '+' } else { '-' },
            ['X', 'Y', 'Z'][self.axis]
        )
    }

    /// The unit vector from N to M in W.
    pub fn unit(&self) -> Vector3<f64> {
        let mut v = Vector3::zeros();
        v[self.axis] = self.sign;
        v
    }
}

/// One setup: one bar, one swept axis.
#[derive(Clone, Debug)]
pub struct Setup {
    /// `C1-X`: the axis, the position or length index, the bar direction.
    pub name: String,
    /// The swept axis' letter.
    pub axis: char,
    /// Whether it turns the table.
    pub on_table: bool,
    /// 1-based index of the position (K, L, H) or length S.
    pub group: usize,
    /// The length S (head axes), mm.
    pub swing: Option<f64>,
    /// The spindle ball M in W, mm.
    pub m: Vector3<f64>,
    /// The table ball N in W, mm.
    pub n: Vector3<f64>,
    /// The bar's length, mm.
    pub bar: f64,
    /// From N to M.
    pub direction: BarDirection,
    /// Gauge length of the spindle ball, mm.
    pub gauge: f64,
    /// Angle the other rotary axis holds, deg.
    pub held: f64,
    /// The swept axis' angles in order, deg.
    pub angles: Vec<f64>,
    /// The commanded axes at each angle (what TCP commands), program
    /// coordinates.
    pub axes: Vec<Axes>,
    /// Tool number of its arbor.
    pub tool: u32,
    /// The smallest angle between the bar and the arbor over the sweep, deg.
    pub clearance_deg: f64,
}

impl Setup {
    /// Tilt and C (deg) at angle `i`.
    pub fn angles_at(&self, i: usize, tilt_letter: char) -> (f64, f64) {
        if self.axis == tilt_letter {
            (self.angles[i], self.held)
        } else {
            (self.held, self.angles[i])
        }
    }
}

/// A ball-bar plan: every setup with its program and what the plan will
/// identify.
#[derive(Clone, Debug)]
pub struct BallBarPlan {
    /// The request it answers.
    pub request: BallBarRequest,
    /// The setups, in the order run.
    pub setups: Vec<Setup>,
    /// The programs, one per setup, in the same order.
    pub programs: Vec<String>,
    /// What was adapted or left out, and why.
    pub notes: Vec<String>,
    /// What the runs will identify.
    pub prediction: Prediction,
}

/// Plans the ball-bar test of every rotary axis of the machine.
pub fn plan(req: &BallBarRequest) -> Result<BallBarPlan, BallBarError> {
    check_request(req)?;
    let (setups, notes) = choose_setups(req)?;
    let programs = setups
        .iter()
        .map(|s| program::write(req, s))
        .collect::<Vec<_>>();
    let prediction = predict(req, &setups);
    Ok(BallBarPlan {
        request: req.clone(),
        setups,
        programs,
        notes,
        prediction,
    })
}

fn check_request(req: &BallBarRequest) -> Result<(), BallBarError> {
    let bad = |m: String| Err(BallBarError::Request(m));
    if req.bars.is_empty() {
        return bad("no bar: give the bar lengths you own (--bar 100,150,300)".into());
    }
    for &b in &req.bars {
        if !(b.is_finite() && (50.0..=1500.0).contains(&b)) {
            return bad(format!(
                "bar length {b} mm: expected 50 to 1500 mm (a telescoping ball bar with its extensions)"
            ));
        }
    }
    for &s in &req.swings {
        if !(s.is_finite() && s > req.machine.pivot_length && s <= 2000.0) {
            return bad(format!(
                "length S = {s} mm: expected more than the head's pivot length {} mm (S runs from the rotation centre to the ball centre) and at most 2000 mm",
                req.machine.pivot_length
            ));
        }
    }
    for b in &req.balls {
        if !b
            .iter()
            .all(|v| v.is_finite() && v.abs() <= crate::limits::MAX_MACHINE_MM)
        {
            return bad(format!("ball position {b:?}: expected finite mm"));
        }
    }
    let positive = [
        ("gauge length", req.gauge_mm),
        ("step of C", req.step_c_deg),
        ("step of the tilt axis", req.step_tilt_deg),
        ("feed", req.feed_deg_min),
    ];
    for (what, v) in positive {
        if !(v.is_finite() && v > 0.0) {
            return bad(format!("{what} must be > 0, got {v}"));
        }
    }
    if !(req.dwell_s.is_finite() && (0.0..=60.0).contains(&req.dwell_s)) {
        return bad(format!("dwell {} s: expected 0 to 60 s", req.dwell_s));
    }
    for (what, v) in [("noise", req.noise_um), ("calibration", req.calibration_um)] {
        if !(v.is_finite() && (0.0..=100.0).contains(&v)) {
            return bad(format!("bar {what} {v} um: expected 0 to 100 um"));
        }
    }
    if req.noise_um == 0.0 && req.calibration_um == 0.0 {
        return bad("a bar with neither noise nor calibration uncertainty predicts u = 0: give the bar's noise".into());
    }
    Ok(())
}

impl BallBarPlan {
    /// The file names of setup `s`: program and sheet.
    fn names(&self, s: &Setup) -> (PathBuf, PathBuf) {
        let ext = match self.request.dialect {
            Dialect::Fanuc => "nc",
            Dialect::Heidenhain => "h",
            Dialect::Linuxcnc => "ngc",
            Dialect::Sinumerik => "mpf",
        };
        (
            PathBuf::from(format!("ball-bar-{}.{ext}", s.name)),
            PathBuf::from(format!("ball-bar-{}.md", s.name)),
        )
    }

    /// The plan file.
    pub fn manifest(&self) -> BallBarManifest {
        BallBarManifest {
            fivecal_ball_bar: BALL_BAR_VERSION,
            machine: self.request.machine.name.clone(),
            machine_file: PathBuf::from("ball-bar.machine.yaml"),
            dialect: self.request.dialect,
            noise_um: self.request.noise_um,
            calibration_um: self.request.calibration_um,
            setups: self
                .setups
                .iter()
                .map(|s| {
                    let (program, sheet) = self.names(s);
                    SetupEntry {
                        name: s.name.clone(),
                        axis: s.axis,
                        on_table: s.on_table,
                        spindle_ball: [s.m.x, s.m.y, s.m.z],
                        table_ball: [s.n.x, s.n.y, s.n.z],
                        bar_mm: s.bar,
                        direction: s.direction.label(),
                        gauge_mm: s.gauge,
                        held_deg: s.held,
                        angles: s.angles.clone(),
                        feed_deg_min: self.request.feed_deg_min,
                        dwell_s: self.request.dwell_s,
                        program,
                        sheet,
                    }
                })
                .collect(),
        }
    }

    /// Every output: (name in the plan directory, bytes), the plan file
    /// last.
    pub fn outputs(&self) -> Vec<(PathBuf, Vec<u8>)> {
        let mut v = Vec::new();
        for (s, p) in self.setups.iter().zip(&self.programs) {
            let (program, sheet) = self.names(s);
            v.push((program.clone(), p.clone().into_bytes()));
            v.push((sheet, sheet::setup_sheet(self, s, &program).into_bytes()));
        }
        v.push((
            PathBuf::from("ball-bar.md"),
            sheet::overview(self).into_bytes(),
        ));
        v.push((
            PathBuf::from("ball-bar.machine.yaml"),
            self.request.machine.source.as_bytes().to_vec(),
        ));
        v.push((
            PathBuf::from("ball-bar.plan.yaml"),
            self.manifest().to_yaml().into_bytes(),
        ));
        v
    }

    /// Writes every output into `dir` (staged: all or nothing), refusing
    /// to overwrite any of `inputs`.
    pub fn write(&self, dir: &Path, inputs: &[&Path]) -> Result<Vec<PathBuf>, OutputError> {
        write_dir(dir, &self.outputs(), inputs)
    }
}

/// The kinematics a setup runs with: the machine with the spindle ball's
/// gauge length.
pub fn setup_kinematics(machine: &Machine, gauge: f64) -> Kinematics {
    Kinematics::with_gauge_length(machine, gauge)
}
