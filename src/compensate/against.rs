//! A program's tool tip against an intended path: how far the tip of one
//! program, run on the machine with its errors, lies from the path another
//! program (the original) asks for on the nominal machine. This is the
//! check of a compensated program a user can run (`simulate nc
//! COMPENSATED --against ORIGINAL`), and the demo's "as written" and
//! "compensated" figures.
//!
//! The intended path is the polyline through the original's samples on the
//! nominal machine: every sample of a feed move and the end point of every
//! move (a feed move starts where the move before it, a rapid say, ends).
//! Each feed sample of the checked program is measured to that polyline.
//! Programs run forward, so each sample is matched a little ahead of where
//! the one before it was: along the path by up to twice the tip's travel
//! since that sample plus twice its deviation (and 10 um), and back by
//! twice its deviation (and 10 um) only, as far as the nearest point can
//! step back between samples taken at different places. A path that crosses
//! itself, or runs back over itself (a plunge and its retract), then cannot
//! hide a deviation behind a leg the tip happens to pass near; a match that
//! lost its place can only overstate a deviation. The first sample is
//! looked for from the path's start. Rapids are followed but not measured:
//! the control does not promise their path.

use std::io::BufRead;
use std::path::Path;

use nalgebra::Vector3;

use super::simulate::{Sample, SimSettings, Simulator};
use super::{Largest, Lines};
use crate::model::Model;
use crate::source::SourceError;

/// Why an intended path cannot be had.
#[derive(Debug, thiserror::Error)]
pub enum AgainstError {
    /// The original could not be run.
    #[error(transparent)]
    Source(#[from] SourceError),
    /// More samples than the simulator keeps.
    #[error("{0}: more than {1} samples along its path: choose a larger --step")]
    TooManySamples(String, usize),
}

/// The least arc length, mm, searched on either side of the last match.
const MIN_REACH_MM: f64 = 0.01;

/// The path a program asks for: the nominal tool tip and axis along it.
#[derive(Clone, Debug, Default)]
pub struct IntendedPath {
    tips: Vec<Vector3<f64>>,
    axes: Vec<Vector3<f64>>,
    /// Arc length from the first point to each point, mm.
    arc: Vec<f64>,
}

impl IntendedPath {
    /// An empty path.
    pub fn new() -> IntendedPath {
        IntendedPath::default()
    }

    /// Adds a sample of the original program on the nominal machine: kept
    /// when it lies on a feed move or ends a move.
    pub fn push(&mut self, s: &Sample) {
        if s.feed || s.fraction == 1.0 {
            let arc = match (self.tips.last(), self.arc.last()) {
                (Some(q), Some(a)) => a + (s.nominal.tip - q).norm(),
                _ => 0.0,
            };
            self.arc.push(arc);
            self.tips.push(s.nominal.tip);
            self.axes.push(s.nominal.axis.normalize());
        }
    }

    /// The path `program` (read from `input`) asks for: run on the nominal
    /// machine (`model` with every parameter zero) with `settings`; with the
    /// reasons of the moves that could not be run, by line.
    pub fn of_program<R: BufRead>(
        model: &Model,
        settings: SimSettings,
        program: &Path,
        input: R,
    ) -> Result<(IntendedPath, Vec<(super::Reason, Lines)>), AgainstError> {
        let zero = vec![0.0; model.n_params()];
        let sim = Simulator::new(model, &zero, settings);
        let mut path = IntendedPath::new();
        let max = crate::limits::MAX_SAMPLES;
        let mut too_many = false;
        let summary = sim.run(program, input, &mut |s| {
            too_many |= path.len() >= max;
            if !too_many {
                path.push(s);
            }
        })?;
        if too_many {
            return Err(AgainstError::TooManySamples(
                program.display().to_string(),
                max,
            ));
        }
        Ok((path, summary.skipped))
    }

    /// Points of the polyline.
    pub fn len(&self) -> usize {
        self.tips.len()
    }

    /// Whether the path has no point.
    pub fn is_empty(&self) -> bool {
        self.tips.is_empty()
    }

    /// Distance, mm, of `p` from segment `i`, and where along it (0..1).
    fn to_segment(&self, i: usize, p: &Vector3<f64>) -> (f64, f64) {
        let (a, b) = (&self.tips[i], &self.tips[i + 1]);
        let t = crate::geom::nearest_on_segment(p, a, b);
        ((a + (b - a) * t - p).norm(), t)
    }

    /// The intended tool axis at `t` along segment `i`.
    fn axis_at(&self, i: usize, t: f64) -> Vector3<f64> {
        let v = self.axes[i] * (1.0 - t) + self.axes[i + 1] * t;
        let n = v.norm();
        if n > 0.0 { v / n } else { self.axes[i] }
    }
}

/// How far a program's tool tip and axis ran from the intended path.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Deviation {
    /// Feed samples measured.
    pub samples: usize,
    /// Mean distance of the tip from the intended path, um.
    pub mean_um: f64,
    /// RMS distance, um.
    pub rms_um: f64,
    /// Largest distance, um, and the line of the checked program.
    pub max_um: Option<Largest>,
    /// Largest angle of the tool axis from the intended axis at the
    /// nearest point of the path, urad.
    pub max_axis_urad: f64,
}

/// Measures the samples of a checked program, one at a time and in the
/// order the program runs, against an intended path.
#[derive(Clone, Debug)]
pub struct Follower<'a> {
    path: &'a IntendedPath,
    /// Segment of the last match, and the arc length there, mm.
    at: usize,
    pos: f64,
    /// The last sample's tip and its distance from the path, mm.
    last: Option<(Vector3<f64>, f64)>,
    sum: f64,
    sum2: f64,
    out: Deviation,
}

impl<'a> Follower<'a> {
    /// A follower of `path`, which needs two points or more.
    pub fn new(path: &'a IntendedPath) -> Option<Follower<'a>> {
        (path.len() >= 2).then_some(Follower {
            path,
            at: 0,
            pos: 0.0,
            last: None,
            sum: 0.0,
            sum2: 0.0,
            out: Deviation::default(),
        })
    }

    /// Segments to search for `p`: those within reach (in arc length) of
    /// the last match, or of the path's start for the first sample.
    fn window(&self, p: &Vector3<f64>) -> std::ops::Range<usize> {
        let segments = self.path.len() - 1;
        let (q, dev) = self.last.unwrap_or((self.path.tips[0], 0.0));
        let back = 2.0 * dev + MIN_REACH_MM;
        let ahead = 2.0 * (p - q).norm() + back;
        let arc = &self.path.arc;
        let mut lo = self.at;
        while lo > 0 && arc[lo] >= self.pos - back {
            lo -= 1;
        }
        let mut hi = self.at + 1;
        while hi < segments && arc[hi] <= self.pos + ahead {
            hi += 1;
        }
        lo..hi
    }

    /// Follows `s` (a sample of the checked program on the machine with the
    /// errors) along the path and, for a sample of a feed move, returns its
    /// tip's distance from the path, um; a rapid is followed but not
    /// measured (`None`).
    pub fn add(&mut self, s: &Sample) -> Option<f64> {
        let p = s.actual.tip;
        let mut best = (f64::INFINITY, 0.0);
        for i in self.window(&p) {
            let (d, t) = self.path.to_segment(i, &p);
            // Ties move on: a turn round a still tip is many samples at one
            // point, and the match must pass beyond them.
            if d <= best.0 {
                best = (d, t);
                self.at = i;
            }
        }
        let arc = &self.path.arc;
        self.pos = arc[self.at] + best.1 * (arc[self.at + 1] - arc[self.at]);
        self.last = Some((p, best.0));
        if !s.feed {
            return None;
        }
        let um = best.0 * 1e3;
        let urad = s
            .actual
            .axis
            .normalize()
            .dot(&self.path.axis_at(self.at, best.1))
            .clamp(-1.0, 1.0)
            .acos()
            * 1e6;
        self.sum += um;
        self.sum2 += um * um;
        self.out.samples += 1;
        if self.out.max_um.is_none_or(|m| um > m.value) {
            self.out.max_um = Some(Largest {
                value: um,
                line: s.line,
            });
        }
        self.out.max_axis_urad = self.out.max_axis_urad.max(urad);
        Some(um)
    }

    /// The deviation over every feed sample added.
    pub fn finish(mut self) -> Deviation {
        let n = self.out.samples.max(1) as f64;
        self.out.mean_um = self.sum / n;
        self.out.rms_um = (self.sum2 / n).sqrt();
        self.out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::ToolPose;

    fn sample(line: usize, feed: bool, tip: Vector3<f64>, axis: Vector3<f64>) -> Sample {
        let pose = ToolPose { tip, axis };
        Sample {
            line,
            fraction: 1.0,
            feed,
            nominal: pose,
            actual: pose,
        }
    }

    /// A quarter circle of radius 50 mm sampled every 0.05 mm, and a
    /// checked path 3 um outside it with its axis tilted by 20 urad: every
    /// sample is 3 um from the polyline (less the chord's sag, 6 nm at
    /// most), and the axis 20 urad off.
    #[test]
    fn a_path_offset_by_three_microns_measures_three_microns() {
        let z = Vector3::z();
        let r = 50.0;
        let n = (r * std::f64::consts::FRAC_PI_2 / 0.05).ceil() as usize;
        let mut path = IntendedPath::new();
        for k in 0..=n {
            let a = std::f64::consts::FRAC_PI_2 * k as f64 / n as f64;
            path.push(&sample(
                1,
                true,
                Vector3::new(r * a.cos(), r * a.sin(), 0.0),
                z,
            ));
        }
        let mut f = Follower::new(&path).unwrap();
        let tilt: f64 = 20e-6;
        for k in 0..=97 {
            let a = std::f64::consts::FRAC_PI_2 * k as f64 / 97.0;
            let tip = Vector3::new((r + 0.003) * a.cos(), (r + 0.003) * a.sin(), 0.0);
            let axis = Vector3::new(tilt.sin(), 0.0, tilt.cos());
            let got = f.add(&sample(10 + k, true, tip, axis)).unwrap();
            assert!((got - 3.0).abs() < 0.01, "sample {k}: {got} um");
        }
        // A rapid is not measured.
        assert_eq!(f.add(&sample(200, false, Vector3::zeros(), z)), None);
        let d = f.finish();
        assert_eq!(d.samples, 98);
        assert!((d.mean_um - 3.0).abs() < 0.01 && (d.rms_um - 3.0).abs() < 0.01);
        assert!((d.max_axis_urad - 20.0).abs() < 0.01, "{}", d.max_axis_urad);
    }

    /// A path that crosses itself: the checked sample near the crossing is
    /// measured against the part of the path the program is on, so the
    /// 40 um it is off there is not hidden by the other leg passing 1 um
    /// away; the largest deviation names its line.
    #[test]
    fn a_crossing_leg_does_not_hide_a_deviation() {
        let z = Vector3::z();
        let mut path = IntendedPath::new();
        // Along X from -5 to 5, then back diagonally through (0, 0.041).
        for k in 0..=100 {
            path.push(&sample(
                1,
                true,
                Vector3::new(-5.0 + 0.1 * k as f64, 0.0, 0.0),
                z,
            ));
        }
        for k in 1..=100 {
            let x = 5.0 - 0.1 * k as f64;
            path.push(&sample(2, true, Vector3::new(x, 0.041 + 0.5 * x, 0.0), z));
        }
        let mut f = Follower::new(&path).unwrap();
        for k in 0..=100 {
            let x = -5.0 + 0.1 * k as f64;
            // On the first leg, 40 um off at x = 0 only.
            let y = if k == 50 { 0.040 } else { 0.0 };
            f.add(&sample(100 + k, true, Vector3::new(x, y, 0.0), z));
        }
        let d = f.finish();
        let max = d.max_um.unwrap();
        assert!((max.value - 40.0).abs() < 1e-6, "{max:?}");
        assert_eq!(max.line, 150);
    }

    /// Distances from an L-shaped path, by hand: beside the first leg (3
    /// um), past the corner (4 um), and on the path (0).
    #[test]
    fn the_deviation_is_the_distance_to_the_nearest_segment() {
        let z = Vector3::z();
        let mut path = IntendedPath::new();
        for p in [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]] {
            path.push(&sample(1, true, Vector3::new(p[0], p[1], 0.0), z));
        }
        let mut f = Follower::new(&path).unwrap();
        for (line, p) in [(7, [5.0, 0.003]), (8, [10.004, 5.0]), (9, [10.0, 2.0])] {
            f.add(&sample(line, true, Vector3::new(p[0], p[1], 0.0), z));
        }
        let d = f.finish();
        assert_eq!(d.max_um.map(|m| m.line), Some(8));
        assert!((d.max_um.unwrap().value - 4.0).abs() < 1e-9, "{d:?}");
        assert!((d.rms_um - ((9.0 + 16.0) / 3.0f64).sqrt()).abs() < 1e-9);
        assert!((d.mean_um - 7.0 / 3.0).abs() < 1e-9);
        assert_eq!(d.samples, 3);
    }

    /// A path of one point cannot be followed.
    #[test]
    fn one_point_is_no_path() {
        let mut path = IntendedPath::new();
        path.push(&sample(1, true, Vector3::zeros(), Vector3::z()));
        assert!(Follower::new(&path).is_none());
    }
}
