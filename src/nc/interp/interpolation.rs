//! How a controller interpolates between end points: straight lines in the
//! values it is given (axis values, or tip and rotary positions under TCP)
//! and arcs in their plane, with the other axes moving linearly.

use std::f64::consts::TAU;

/// The point a fraction `s` of the way from `a` to `b`.
pub fn lerp(a: &[f64; 6], b: &[f64; 6], s: f64) -> [f64; 6] {
    let mut r = [0.0; 6];
    for i in 0..6 {
        r[i] = a[i] + s * (b[i] - a[i]);
    }
    r
}

/// The nominal path of a move in program coordinates.
#[derive(Clone, Copy, Debug)]
pub enum Path {
    /// A straight line.
    Line {
        /// Start.
        p0: [f64; 6],
        /// End.
        p1: [f64; 6],
    },
    /// An arc (helix, with the other axes linear).
    Arc {
        /// Start.
        p0: [f64; 6],
        /// End.
        p1: [f64; 6],
        /// Its geometry in the plane.
        geo: ArcGeo,
    },
}

/// An arc's geometry in its plane: centre, start and end radius (a spiral
/// when they differ), start angle and signed sweep.
#[derive(Clone, Copy, Debug)]
pub struct ArcGeo {
    /// First plane axis (index into X Y Z A B C).
    pub a0: usize,
    /// Second plane axis.
    pub a1: usize,
    /// Centre in the plane.
    pub center: [f64; 2],
    /// Radius at the start.
    pub rs: f64,
    /// Radius at the end.
    pub re: f64,
    /// Angle at the start, rad.
    pub th: f64,
    /// Signed sweep, rad (negative clockwise).
    pub sweep: f64,
}

impl ArcGeo {
    /// The arc from `p0` to `p1` around `center` in the plane of
    /// `plane_axes` (first, second, normal), with `turns` extra full turns.
    pub fn new(
        plane_axes: (usize, usize, usize),
        center: [f64; 2],
        p0: &[f64; 6],
        p1: &[f64; 6],
        cw: bool,
        turns: u32,
    ) -> ArcGeo {
        let (a0, a1, _) = plane_axes;
        let (c0, c1) = (center[0], center[1]);
        let rs = (p0[a0] - c0).hypot(p0[a1] - c1);
        let re = (p1[a0] - c0).hypot(p1[a1] - c1);
        let ts = (p0[a1] - c1).atan2(p0[a0] - c0);
        let te = (p1[a1] - c1).atan2(p1[a0] - c0);
        let mut d = te - ts;
        if cw {
            while d >= -1e-9 {
                d -= TAU;
            }
            d -= TAU * turns as f64;
        } else {
            while d <= 1e-9 {
                d += TAU;
            }
            d += TAU * turns as f64;
        }
        ArcGeo {
            a0,
            a1,
            center,
            rs,
            re,
            th: ts,
            sweep: d,
        }
    }

    /// The point at fraction `u` of the arc from `p0` to `p1`.
    pub fn at(&self, p0: &[f64; 6], p1: &[f64; 6], u: f64) -> [f64; 6] {
        let mut p = lerp(p0, p1, u);
        let th = self.th + u * self.sweep;
        let r = self.rs + u * (self.re - self.rs);
        p[self.a0] = self.center[0] + r * th.cos();
        p[self.a1] = self.center[1] + r * th.sin();
        p
    }
}

impl Path {
    /// The point at fraction `u` of the path.
    pub fn at(&self, u: f64) -> [f64; 6] {
        match self {
            Path::Line { p0, p1 } => lerp(p0, p1, u),
            Path::Arc { p0, p1, geo } => geo.at(p0, p1, u),
        }
    }
}
