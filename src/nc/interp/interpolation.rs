//! How a controller interpolates between end points: straight lines in the
//! values it is given (axis values, or tip and rotary positions under TCP),
//! arcs in their plane and SINUMERIK's circles through an intermediate
//! point in space, with the other axes moving linearly.

use std::f64::consts::TAU;

use nalgebra::Vector3;

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
    /// A circle through an intermediate point (SINUMERIK `CIP`), in
    /// space, with the rotary axes linear.
    Through {
        /// Start.
        p0: [f64; 6],
        /// End.
        p1: [f64; 6],
        /// The circle.
        geo: CircleGeo,
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

/// The circle a SINUMERIK `CIP` cuts: the one through its start, its
/// intermediate point and its end (X, Y, Z), run from the start through
/// the intermediate point to the end. The three points fix its plane,
/// which need not be the working plane: the programming manual (840D
/// Fundamentals 10.2004, 4.10) says such arcs "can also be inclined in
/// space", the intermediate and end points then given with three
/// coordinates, and that the order of start, intermediate and end point
/// fixes the direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CircleGeo {
    /// Centre.
    pub center: [f64; 3],
    /// Radius.
    pub r: f64,
    /// Unit vector from the centre to the start.
    pub u: [f64; 3],
    /// Unit vector in the circle's plane a quarter turn from `u` in the
    /// direction of travel.
    pub v: [f64; 3],
    /// Angle from the start to the end, rad, in (0, 2 pi).
    pub sweep: f64,
    /// Angle from the start to the intermediate point, rad, in (0, sweep).
    pub through_at: f64,
}

/// Why no circle passes through a `CIP`'s three points.
pub const CIP_FULL: &str = "its end point is its start point (a full circle cannot be programmed through an intermediate point)";
/// See [`CIP_FULL`].
pub const CIP_LINE: &str = "its start, intermediate and end point lie on one straight line (no circle passes through them)";

impl CircleGeo {
    /// The circle from `s` through `m` to `e` (program units, `mm`
    /// millimetres each). Refused where no circle passes through them: two
    /// of the points within 0.1 nm of each other, or the intermediate
    /// point within 0.1 nm of the line through the other two (a circle
    /// there would be a line; its radius, beyond the numbers a control
    /// takes, would be noise).
    pub fn through(
        s: [f64; 3],
        m: [f64; 3],
        e: [f64; 3],
        mm: f64,
    ) -> Result<CircleGeo, &'static str> {
        const MIN_MM: f64 = 1e-7;
        let (s, m, e) = (Vector3::from(s), Vector3::from(m), Vector3::from(e));
        let (a, b) = (m - s, e - s);
        // NaN anywhere fails these tests too.
        if (b.norm() * mm).partial_cmp(&MIN_MM) != Some(std::cmp::Ordering::Greater) {
            return Err(CIP_FULL);
        }
        let n = a.cross(&b);
        // The intermediate point's distance from the chord's line.
        if (n.norm() / b.norm() * mm).partial_cmp(&MIN_MM) != Some(std::cmp::Ordering::Greater) {
            return Err(CIP_LINE);
        }
        // The circumcentre, from the start: equidistant from the three
        // points, in their plane.
        let c = (b * a.norm_squared() - a * b.norm_squared()).cross(&n) / (2.0 * n.norm_squared());
        let r = c.norm();
        let center = s + c;
        let u = -c / r;
        // a x b turns from the start towards the intermediate point and
        // then the end (the triangle's vertices are in the circle's order):
        // the travel is positive about it.
        let v = n.normalize().cross(&u);
        let angle = |p: Vector3<f64>| {
            let d = p - center;
            let t = d.dot(&v).atan2(d.dot(&u));
            if t <= 0.0 { t + TAU } else { t }
        };
        let (through_at, sweep) = (angle(m), angle(e));
        if !(r.is_finite() && through_at < sweep) {
            return Err(CIP_LINE);
        }
        Ok(CircleGeo {
            center: center.into(),
            r,
            u: u.into(),
            v: v.into(),
            sweep,
            through_at,
        })
    }

    /// The point at fraction `t` of the circle from `p0` to `p1` (the
    /// rotary axes linear).
    pub fn at(&self, p0: &[f64; 6], p1: &[f64; 6], t: f64) -> [f64; 6] {
        let mut p = lerp(p0, p1, t);
        let (sin, cos) = (t * self.sweep).sin_cos();
        for (i, x) in p.iter_mut().take(3).enumerate() {
            *x = self.center[i] + self.r * (cos * self.u[i] + sin * self.v[i]);
        }
        p
    }
}

impl Path {
    /// The point at fraction `u` of the path.
    pub fn at(&self, u: f64) -> [f64; 6] {
        match self {
            Path::Line { p0, p1 } => lerp(p0, p1, u),
            Path::Arc { p0, p1, geo } => geo.at(p0, p1, u),
            Path::Through { p0, p1, geo } => geo.at(p0, p1, u),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_circle_through_three_points_passes_them_in_order() {
        // In the XY plane: from (30, 40) through (40, 45) to (50, 40),
        // the 808D manual's example, at Z 0: the centre on X 40, below.
        let g = CircleGeo::through([30.0, 40.0, 0.0], [40.0, 45.0, 0.0], [50.0, 40.0, 0.0], 1.0)
            .unwrap();
        // By hand: (40 - 30)^2 + (40 - cy)^2 = (45 - cy)^2 gives cy = 32.5.
        assert!((Vector3::from(g.center) - Vector3::new(40.0, 32.5, 0.0)).norm() < 1e-12);
        assert!((g.r - 12.5).abs() < 1e-12);
        // Clockwise in XY (over the top): the travel's normal is -Z.
        assert!((Vector3::from(g.u).cross(&Vector3::from(g.v)) + Vector3::z()).norm() < 1e-12);
        let p0 = [30.0, 40.0, 0.0, 0.0, 0.0, 0.0];
        let p1 = [50.0, 40.0, 0.0, 0.0, 20.0, 0.0];
        let mid = g.at(&p0, &p1, g.through_at / g.sweep);
        assert!((mid[0] - 40.0).abs() < 1e-12 && (mid[1] - 45.0).abs() < 1e-12);
        let end = g.at(&p0, &p1, 1.0);
        assert!((end[0] - 50.0).abs() < 1e-12 && (end[1] - 40.0).abs() < 1e-12);
        assert_eq!(end[4], 20.0);
        // Every point on the circle, in its plane.
        for k in 0..=10 {
            let p = g.at(&p0, &p1, k as f64 / 10.0);
            let d = Vector3::new(p[0], p[1], p[2]) - Vector3::from(g.center);
            assert!((d.norm() - 12.5).abs() < 1e-12 && d.z.abs() < 1e-12);
        }
    }

    #[test]
    fn a_circle_inclined_in_space_and_one_of_more_than_half_a_turn() {
        // The great circle of the unit sphere through X, Y and Z: from
        // (1, 0, 0) through (0, 1, 0) to (0, 0, 1) is more than half of
        // it (the three points are 120 deg apart on a circle of radius
        // sqrt(2/3) about (1, 1, 1) / 3).
        let g = CircleGeo::through([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], 1.0).unwrap();
        assert!((Vector3::from(g.center) - Vector3::repeat(1.0 / 3.0)).norm() < 1e-12);
        assert!((g.r - (2.0f64 / 3.0).sqrt()).abs() < 1e-12);
        assert!((g.through_at - TAU / 3.0).abs() < 1e-12);
        assert!((g.sweep - 2.0 * TAU / 3.0).abs() < 1e-12);
    }

    #[test]
    fn three_points_on_a_line_or_a_closed_circle_are_refused() {
        let line = CircleGeo::through([0.0; 3], [1.0, 1.0, 1.0], [2.0, 2.0, 2.0], 1.0);
        assert_eq!(line, Err(CIP_LINE));
        // The intermediate point behind the end, on the same line.
        let behind = CircleGeo::through([0.0; 3], [3.0, 0.0, 0.0], [2.0, 0.0, 0.0], 1.0);
        assert_eq!(behind, Err(CIP_LINE));
        let on_start = CircleGeo::through([0.0; 3], [0.0; 3], [2.0, 0.0, 0.0], 1.0);
        assert_eq!(on_start, Err(CIP_LINE));
        let on_end = CircleGeo::through([0.0; 3], [2.0, 0.0, 0.0], [2.0, 0.0, 0.0], 1.0);
        assert_eq!(on_end, Err(CIP_LINE));
        let closed = CircleGeo::through([0.0; 3], [1.0, 1.0, 0.0], [0.0; 3], 1.0);
        assert_eq!(closed, Err(CIP_FULL));
        // Within 0.1 nm of the line is on it, in inches too.
        let nearly = CircleGeo::through([0.0; 3], [1.0, 3e-9, 0.0], [2.0, 0.0, 0.0], 25.4);
        assert_eq!(nearly, Err(CIP_LINE));
        assert!(CircleGeo::through([0.0; 3], [1.0, 1e-6, 0.0], [2.0, 0.0, 0.0], 1.0).is_ok());
        let nan = CircleGeo::through([0.0; 3], [1.0, f64::NAN, 0.0], [2.0, 0.0, 0.0], 1.0);
        assert!(nan.is_err());
    }
}
