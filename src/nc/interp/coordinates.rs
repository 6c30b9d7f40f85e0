//! Program coordinates and the model frame of the kinematics: units, datum
//! shifts, where the program zero lies in W, and the tool length the
//! program leaves to the controller or not.

use nalgebra::{Matrix3, Vector3};

use super::Tcp;
use super::plane::WorkPlane;
use crate::kinematics::Axes;

/// How program coordinates (X Y Z A B C, program units and degrees) map to
/// the axes of the kinematic model (mm, degrees) in the current state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Millimetres per program unit.
    pub u: f64,
    /// Datum shift per linear axis, program units.
    pub shift: [f64; 3],
    /// Rotary zero shift of the work offset (tilt, C), deg: the machine
    /// axis is at the programmed angle plus this.
    pub rotary: [f64; 2],
    /// Where the program zero lies in W at rotary zero, mm.
    pub origin: Vector3<f64>,
    /// Tool length the program's Z includes (tool length compensation off
    /// and no TCP), mm.
    pub tlc: f64,
    /// TCP mode the coordinates are meant in.
    pub tcp: Tcp,
    /// Index of the tilt axis among X Y Z A B C.
    pub tilt: usize,
    /// The tilted working plane X, Y, Z are written in (then `tcp` is
    /// [`Tcp::Axes`]: the tip in W at the rotary positions in force).
    pub plane: Option<WorkPlane>,
    /// The rotation of a programmable frame (SINUMERIK `ROT`/`AROT`):
    /// X, Y, Z are turned by it before the plane and the shifts, so that
    /// with the shift it forms the frame `R p + t` (identity elsewhere).
    pub rot: Matrix3<f64>,
}

impl Frame {
    /// What the program's coordinates are in this frame: as the TCP mode
    /// says, or X Y Z in a tilted working plane.
    pub(crate) fn meaning(&self) -> &'static str {
        match self.plane {
            Some(_) => {
                "X Y Z in a tilted working plane (3+2: the plane's rotary positions, tool length along the tool)"
            }
            None => self.tcp.meaning(),
        }
    }

    /// Program coordinates to model axes (or, under TCP, tip and rotary
    /// positions).
    pub fn model(&self, p: &[f64; 6]) -> Axes {
        let mut q = self.rot * Vector3::new(p[0], p[1], p[2]);
        if let Some(w) = &self.plane {
            q = w.to_workpiece(&q);
        }
        Axes {
            xyz: Vector3::new(
                (q.x + self.shift[0]) * self.u + self.origin.x,
                (q.y + self.shift[1]) * self.u + self.origin.y,
                (q.z + self.shift[2]) * self.u + self.origin.z - self.tlc,
            ),
            tilt: p[self.tilt] + self.rotary[0],
            c: p[5] + self.rotary[1],
        }
    }

    /// Model axes to program coordinates (NaN for the rotary axis the
    /// machine does not have).
    pub fn program(&self, a: &Axes) -> [f64; 6] {
        let mut p = [f64::NAN; 6];
        let mut q = Vector3::new(
            (a.xyz.x - self.origin.x) / self.u - self.shift[0],
            (a.xyz.y - self.origin.y) / self.u - self.shift[1],
            (a.xyz.z + self.tlc - self.origin.z) / self.u - self.shift[2],
        );
        if let Some(w) = &self.plane {
            q = w.to_plane(&q);
        }
        let q = self.rot.transpose() * q;
        p[0] = q.x;
        p[1] = q.y;
        p[2] = q.z;
        p[self.tilt] = a.tilt - self.rotary[0];
        p[5] = a.c - self.rotary[1];
        p
    }

    /// The five axes of the machine among X Y Z A B C.
    pub fn axes(&self) -> [usize; 5] {
        [0, 1, 2, self.tilt, 5]
    }
}

/// Tracked positions with NaN where unknown.
pub fn known(p: &[Option<f64>; 6]) -> [f64; 6] {
    p.map(|x| x.unwrap_or(f64::NAN))
}
