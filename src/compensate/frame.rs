//! Program coordinates and the model frame, and the paths a controller
//! interpolates between end points.

use std::f64::consts::TAU;

use nalgebra::Vector3;

use crate::kinematics::Axes;
use crate::nc::modal::Tcp;

#[derive(Clone, Copy, Debug)]
pub(crate) struct Frame {
    pub u: f64,
    pub shift: [f64; 3],
    pub origin: Vector3<f64>,
    pub tlc: f64,
    pub tcp: Tcp,
    pub tilt: usize,
}

impl Frame {
    pub fn model(&self, p: &[f64; 6]) -> Axes {
        Axes {
            xyz: Vector3::new(
                (p[0] + self.shift[0]) * self.u + self.origin.x,
                (p[1] + self.shift[1]) * self.u + self.origin.y,
                (p[2] + self.shift[2]) * self.u + self.origin.z - self.tlc,
            ),
            tilt: p[self.tilt],
            c: p[5],
        }
    }

    pub fn program(&self, a: &Axes) -> [f64; 6] {
        let mut p = [f64::NAN; 6];
        p[0] = (a.xyz.x - self.origin.x) / self.u - self.shift[0];
        p[1] = (a.xyz.y - self.origin.y) / self.u - self.shift[1];
        p[2] = (a.xyz.z + self.tlc - self.origin.z) / self.u - self.shift[2];
        p[self.tilt] = a.tilt;
        p[5] = a.c;
        p
    }

    pub fn axes(&self) -> [usize; 5] {
        [0, 1, 2, self.tilt, 5]
    }
}

pub(crate) fn lerp(a: &[f64; 6], b: &[f64; 6], s: f64) -> [f64; 6] {
    let mut r = [0.0; 6];
    for i in 0..6 {
        r[i] = a[i] + s * (b[i] - a[i]);
    }
    r
}

pub(crate) fn round_to(v: f64, d: u8) -> f64 {
    let k = crate::nc::number::pow10(d);
    let x = v * k;
    // A cast rounds without a libm call on baseline x86-64.
    if x.abs() < 4.0e15 {
        let r = (x + 0.5f64.copysign(x)) as i64 as f64;
        r / k
    } else {
        x.round() / k
    }
}

pub(crate) fn known(p: &[Option<f64>; 6]) -> [f64; 6] {
    p.map(|x| x.unwrap_or(f64::NAN))
}

/// The nominal path of a move in program coordinates.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Path2 {
    Line {
        p0: [f64; 6],
        p1: [f64; 6],
    },
    Arc {
        p0: [f64; 6],
        p1: [f64; 6],
        geo: ArcGeo,
    },
}

#[derive(Clone, Copy, Debug)]
pub(crate) struct ArcGeo {
    pub a0: usize,
    pub a1: usize,
    pub center: [f64; 2],
    pub rs: f64,
    pub re: f64,
    pub th: f64,
    pub sweep: f64,
}

impl ArcGeo {
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

    pub fn at(&self, p0: &[f64; 6], p1: &[f64; 6], u: f64) -> [f64; 6] {
        let mut p = lerp(p0, p1, u);
        let th = self.th + u * self.sweep;
        let r = self.rs + u * (self.re - self.rs);
        p[self.a0] = self.center[0] + r * th.cos();
        p[self.a1] = self.center[1] + r * th.sin();
        p
    }
}

impl Path2 {
    pub fn at(&self, u: f64) -> [f64; 6] {
        match self {
            Path2::Line { p0, p1 } => lerp(p0, p1, u),
            Path2::Arc { p0, p1, geo } => geo.at(p0, p1, u),
        }
    }
}
