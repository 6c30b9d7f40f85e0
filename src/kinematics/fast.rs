//! Closed-form forward and inverse kinematics for errors that do not depend
//! on the axis positions (location errors, a tool-length error, a constant
//! linear-axis offset): the fast path of `compensate`, which needs an
//! inverse on every block of multi-million-block programs.
//!
//! The chain is the one [`super::Kinematics`] builds, with the three link
//! transforms precomputed as rotation matrices and translations:
//!
//! ```text
//! table-table: pose = Rz(C) E1^-1 R_T(t) E0^-1 Trans(xyz + e) Tz(-dL)
//! head-table:  pose = Rz(C) E0^-1 Trans(xyz + e) Tz(Lh) E1 R_T(t) E2 Tz(-Lh - dL)
//! head-head:   pose = Trans(xyz + e) Tz(Lh) E0 Rz(C) E1 R_T(t) E2 Tz(-Lh - dL)
//! ```
//!
//! The tool axis is `M Rz(C) N R_T(t) v` with fixed `M`, `N`, `v`, so the
//! tilt follows exactly from one `acos` (two branches) and C from the
//! azimuth, the same closed form as [`super::Kinematics::inverse`] uses
//! before its Newton polish (which, with constant errors, has nothing left
//! to do). X, Y, Z then follow from the position equation. Nothing is
//! approximated; the tests check every result against the generic inverse.

use nalgebra::{Matrix3, Vector3};

use super::{Axes, IkError, Kinematics, Perturbation, ToolPose};
use crate::geom::{self, Axis3, d6};
use crate::machine::Structure;

/// A rigid transform `p -> r p + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rigid {
    /// Rotation.
    pub r: Matrix3<f64>,
    /// Translation.
    pub t: Vector3<f64>,
}

impl Rigid {
    fn apply(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.r * p + self.t
    }
}

fn rot(axis: Axis3, a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    match axis {
        Axis3::X => Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c),
        Axis3::Y => Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c),
        Axis3::Z => Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0),
    }
}

/// `v` turned about `axis` by the angle with sine `s` and cosine `c`.
fn rot_vec(axis: Axis3, s: f64, c: f64, v: &Vector3<f64>) -> Vector3<f64> {
    match axis {
        Axis3::X => Vector3::new(v.x, c * v.y - s * v.z, s * v.y + c * v.z),
        Axis3::Y => Vector3::new(c * v.x + s * v.z, v.y, -s * v.x + c * v.z),
        Axis3::Z => Vector3::new(c * v.x - s * v.y, s * v.x + c * v.y, v.z),
    }
}

fn rot_sc(axis: Axis3, s: f64, c: f64) -> Matrix3<f64> {
    match axis {
        Axis3::X => Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c),
        Axis3::Y => Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c),
        Axis3::Z => Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0),
    }
}

/// The chain with constant errors, ready for closed-form evaluation.
#[derive(Clone, Debug)]
pub struct FastChain {
    structure: Structure,
    tilt_about: Axis3,
    tilt_letter: char,
    dt: f64,
    dc: f64,
    lh: f64,
    dl: f64,
    lin: Vector3<f64>,
    /// Link transforms `E_l`.
    e: [Rigid; 3],
    /// Their inverses.
    ei: [Rigid; 3],
    tilt_limits: Option<(f64, f64)>,
    c_limits: Option<(f64, f64)>,
    /// No errors at all: forward kinematics takes a shortcut.
    exact_nominal: bool,
    // Orientation equation u = M Rz(psi) N R_T(phi) v.
    m: Matrix3<f64>,
    n: Matrix3<f64>,
    v_par: Vector3<f64>,
    v_perp: Vector3<f64>,
    e_x_v: Vector3<f64>,
    alpha: f64,
    r: f64,
    phi0: f64,
}

impl FastChain {
    /// The chain of `kin` with the (constant) errors `p`: link terms,
    /// linear-axis offset and tool-length error are taken as they are.
    pub fn new(kin: &Kinematics, p: &Perturbation) -> FastChain {
        let m = kin.machine();
        let rigid = |l: usize| {
            let iso = d6(&p.link(l));
            Rigid {
                r: iso.rotation.to_rotation_matrix().into_inner(),
                t: iso.translation.vector,
            }
        };
        let e = [rigid(0), rigid(1), rigid(2)];
        let ei = e.map(|x| {
            let rt = x.r.transpose();
            Rigid {
                r: rt,
                t: -(rt * x.t),
            }
        });
        let z = Vector3::z();
        let (mm, nn, v) = match m.structure {
            Structure::TableTable => (Matrix3::identity(), ei[1].r, ei[0].r * z),
            Structure::HeadTable => (Matrix3::identity(), ei[0].r * e[1].r, e[2].r * z),
            Structure::HeadHead => (e[0].r, e[1].r, e[2].r * z),
        };
        let ax = m.tilt.about.unit();
        let v_par = ax * ax.dot(&v);
        let v_perp = v - v_par;
        let e_x_v = ax.cross(&v);
        let n3 = nn.transpose() * z;
        let alpha = n3.dot(&v_par);
        let beta = n3.dot(&v_perp);
        let gamma = n3.dot(&e_x_v);
        let exact_nominal = p.0.iter().all(|&x| x == 0.0);
        FastChain {
            exact_nominal,
            structure: m.structure,
            tilt_about: m.tilt.about,
            tilt_letter: m.tilt.letter,
            dt: m.tilt.direction,
            dc: m.c.direction,
            lh: if m.structure == Structure::TableTable {
                0.0
            } else {
                m.pivot_length + kin.gauge_length()
            },
            dl: p.0[super::SLOT_TOOL_LENGTH],
            lin: p.linear(),
            e,
            ei,
            tilt_limits: m.tilt.limits,
            c_limits: m.c.limits,
            m: mm,
            n: nn,
            v_par,
            v_perp,
            e_x_v,
            alpha,
            r: beta.hypot(gamma),
            phi0: gamma.atan2(beta),
        }
    }

    /// The nominal chain of `kin`.
    pub fn nominal(kin: &Kinematics) -> FastChain {
        FastChain::new(kin, &Perturbation::zero())
    }

    /// The constant linear-axis offset the chain was built with, mm.
    pub fn linear(&self) -> Vector3<f64> {
        self.lin
    }

    /// The table part `rTw^-1` and the head part of the chain at the given
    /// angles (deg): `pose = T * Trans(xyz + e) * H`.
    pub fn parts(&self, tilt: f64, c: f64) -> (Rigid, Rigid) {
        let (st, ct) = (self.dt * geom::rad(tilt)).sin_cos();
        let (sc, cc) = (self.dc * geom::rad(c)).sin_cos();
        self.parts_sc(st, ct, sc, cc)
    }

    fn parts_sc(&self, st: f64, ct: f64, sc: f64, cc: f64) -> (Rigid, Rigid) {
        let rt = rot_sc(self.tilt_about, st, ct);
        let rz = rot_sc(Axis3::Z, sc, cc);
        let z = Vector3::z();
        let tail = -(self.lh + self.dl) * z;
        match self.structure {
            Structure::TableTable => {
                let (p0, p1) = (&self.ei[0], &self.ei[1]);
                let b_r = p1.r * rt * p0.r;
                let b_t = p1.r * (rt * p0.t) + p1.t;
                (
                    Rigid {
                        r: rz * b_r,
                        t: rz * b_t,
                    },
                    Rigid {
                        r: Matrix3::identity(),
                        t: tail,
                    },
                )
            }
            Structure::HeadTable => {
                let p0 = &self.ei[0];
                let (e1, e2) = (&self.e[1], &self.e[2]);
                let r1t = e1.r * rt;
                (
                    Rigid {
                        r: rz * p0.r,
                        t: rz * p0.t,
                    },
                    Rigid {
                        r: r1t * e2.r,
                        t: self.lh * z + e1.t + r1t * (e2.t + e2.r * tail),
                    },
                )
            }
            Structure::HeadHead => {
                let (e0, e1, e2) = (&self.e[0], &self.e[1], &self.e[2]);
                let r0z = e0.r * rz;
                let r1t = e1.r * rt;
                (
                    Rigid {
                        r: Matrix3::identity(),
                        t: Vector3::zeros(),
                    },
                    Rigid {
                        r: r0z * r1t * e2.r,
                        t: self.lh * z + e0.t + r0z * (e1.t + r1t * (e2.t + e2.r * tail)),
                    },
                )
            }
        }
    }

    /// Forward kinematics: tool tip and axis in W.
    pub fn forward(&self, a: &Axes) -> ToolPose {
        self.forward_lin(a, &self.lin)
    }

    /// Forward kinematics with a given linear-axis error (for errors that
    /// depend on X, Y, Z), mm.
    pub(crate) fn forward_lin(&self, a: &Axes, lin: &Vector3<f64>) -> ToolPose {
        if self.exact_nominal && *lin == Vector3::zeros() {
            return self.forward_nominal(a);
        }
        let (t, h) = self.parts(a.tilt, a.c);
        ToolPose {
            tip: t.apply(&(a.xyz + lin + h.t)),
            axis: t.r * (h.r * Vector3::z()),
        }
    }

    /// [`FastChain::position`] from the sines and cosines of the chain
    /// angles, undoing the chain with rotations of vectors (no matrix
    /// products).
    fn position_sc(&self, tip: &Vector3<f64>, sc: [f64; 4], lin: &Vector3<f64>) -> Vector3<f64> {
        let (st, ct, ss, cs) = (sc[0], sc[1], sc[2], sc[3]);
        let z = Vector3::z();
        let tail = -(self.lh + self.dl) * z;
        let rt = |v: &Vector3<f64>| rot_vec(self.tilt_about, st, ct, v);
        let rt_inv = |v: &Vector3<f64>| rot_vec(self.tilt_about, -st, ct, v);
        let rz = |v: &Vector3<f64>| rot_vec(Axis3::Z, ss, cs, v);
        let rz_inv = |v: &Vector3<f64>| rot_vec(Axis3::Z, -ss, cs, v);
        match self.structure {
            Structure::TableTable => {
                // tip = Rz (E1^-1 (Rt (E0^-1 p)))
                let (i0, i1) = (&self.ei[0], &self.ei[1]);
                let v = i1.r.tr_mul(&(rz_inv(tip) - i1.t));
                i0.r.tr_mul(&(rt_inv(&v) - i0.t)) - tail - lin
            }
            Structure::HeadTable => {
                let i0 = &self.ei[0];
                let (e1, e2) = (&self.e[1], &self.e[2]);
                let ht = self.lh * z + e1.t + e1.r * rt(&(e2.t + e2.r * tail));
                i0.r.tr_mul(&(rz_inv(tip) - i0.t)) - ht - lin
            }
            Structure::HeadHead => {
                let (e0, e1, e2) = (&self.e[0], &self.e[1], &self.e[2]);
                let ht = self.lh * z + e0.t + e0.r * rz(&(e1.t + e1.r * rt(&(e2.t + e2.r * tail))));
                tip - ht - lin
            }
        }
    }

    /// Forward kinematics without errors: the rotations applied to vectors
    /// directly (what a controller computes, and the target of every block).
    fn forward_nominal(&self, a: &Axes) -> ToolPose {
        let (st, ct) = (self.dt * geom::rad(a.tilt)).sin_cos();
        let (sc, cc) = (self.dc * geom::rad(a.c)).sin_cos();
        let z = Vector3::z();
        let rt = |v: Vector3<f64>| rot_vec(self.tilt_about, st, ct, &v);
        let rz = |v: Vector3<f64>| rot_vec(Axis3::Z, sc, cc, &v);
        let axis = rz(rt(z));
        let tip = match self.structure {
            Structure::TableTable => rz(rt(a.xyz)),
            Structure::HeadTable => rz(a.xyz + self.lh * z + rt(-self.lh * z)),
            Structure::HeadHead => a.xyz + self.lh * z + rz(rt(-self.lh * z)),
        };
        ToolPose { tip, axis }
    }

    /// X, Y, Z that put the tip at `tip` with the rotary axes at (tilt, c)
    /// (deg) and the linear-axis error `lin`.
    pub fn position(
        &self,
        tip: &Vector3<f64>,
        tilt: f64,
        c: f64,
        lin: &Vector3<f64>,
    ) -> Vector3<f64> {
        let (t, h) = self.parts(tilt, c);
        t.r.transpose() * (tip - t.t) - h.t - lin
    }

    /// The two (tilt, C) solutions (deg; C not yet turned to any reference)
    /// that point the tool along `u`, or `None` when no tilt reaches it.
    /// `c_ref` (deg) is used when C is indeterminate (tool along the C axis).
    pub(crate) fn orientation_roots(
        &self,
        u: &Vector3<f64>,
        c_ref: f64,
    ) -> Option<[(f64, f64); 2]> {
        self.roots(u, c_ref).map(|r| r.map(|x| (x.tilt, x.c)))
    }

    /// The roots with the sines and cosines of their chain angles, so that
    /// the position needs no more trigonometry.
    fn roots(&self, u: &Vector3<f64>, c_ref: f64) -> Option<[Root; 2]> {
        let b = self.branches(u)?;
        Some([self.root(&b, 0, c_ref), self.root(&b, 1, c_ref)])
    }

    /// The tilt equation's two solutions `phi0 +- acos(..)`, before C.
    fn branches(&self, u: &Vector3<f64>) -> Option<Branches> {
        let up = self.m.transpose() * u;
        let rhs = (up.z - self.alpha) / self.r;
        if rhs.is_nan() || rhs.abs() > 1.0 + 1e-12 {
            return None;
        }
        let half = rhs.clamp(-1.0, 1.0).acos();
        let phi = [self.phi0 + half, self.phi0 - half];
        Some(Branches {
            up,
            u_xy: (up.x * up.x + up.y * up.y).sqrt(),
            phi,
            tilt: phi.map(|p| geom::wrap180(geom::deg(p / self.dt))),
        })
    }

    /// Root `k` of the branches: C from the azimuth.
    fn root(&self, b: &Branches, k: usize, c_ref: f64) -> Root {
        let (sp, cp) = b.phi[k].sin_cos();
        let w = self.n * (self.v_par + self.v_perp * cp + self.e_x_v * sp);
        let w_xy = (w.x * w.x + w.y * w.y).sqrt();
        // psi = azimuth(up) - azimuth(w), from the unit vectors.
        let (ss, cs) = if w_xy < 1e-14 || b.u_xy < 1e-14 {
            (self.dc * geom::rad(c_ref)).sin_cos()
        } else {
            let (cu, su) = (b.up.x / b.u_xy, b.up.y / b.u_xy);
            let (cw, sw) = (w.x / w_xy, w.y / w_xy);
            (su * cw - cu * sw, cu * cw + su * sw)
        };
        let psi = ss.atan2(cs);
        Root {
            tilt: b.tilt[k],
            c: geom::deg(psi / self.dc),
            sc: [sp, cp, ss, cs],
        }
    }

    /// The tilt (deg) that brings the tool axis closest to `u` with C held
    /// at `c` (deg): the exact maximum of `u . axis(t)` over the tilt.
    pub(crate) fn tilt_for_c(&self, u: &Vector3<f64>, c: f64) -> f64 {
        let k = self.m * rot(Axis3::Z, self.dc * geom::rad(c)) * self.n;
        let ku = k.transpose() * u;
        let phi = ku.dot(&self.e_x_v).atan2(ku.dot(&self.v_perp));
        geom::wrap180(geom::deg(phi / self.dt))
    }

    /// Inverse kinematics: the exact solution nearest `reference` (sum of
    /// the rotary differences, C turned to the nearest allowed turn), within
    /// the rotary limits.
    pub fn inverse(&self, target: &ToolPose, reference: &Axes) -> Result<Axes, IkError> {
        let u = target.axis.normalize();
        let Some(br) = self.branches(&u) else {
            return Err(IkError::OutOfReach {
                ux: u.x,
                uy: u.y,
                uz: u.z,
            });
        };
        // The branch whose tilt is nearer the reference first; the other
        // needs its C (trigonometry) only if it could still be nearer: its
        // distance is at least its tilt difference.
        let order = if (br.tilt[1] - reference.tilt).abs() < (br.tilt[0] - reference.tilt).abs() {
            [1, 0]
        } else {
            [0, 1]
        };
        let mut best: Option<(f64, f64, f64, [f64; 4], usize)> = None;
        let mut c_err = None;
        for k in order {
            // A tilt stroke of more than a turn reaches the branch at
            // several turns: the one nearest the reference, as for C.
            let Some(t) = geom::nearest_turn(br.tilt[k], reference.tilt, self.tilt_limits) else {
                continue;
            };
            if best.is_some_and(|b| (t - reference.tilt).abs() > b.0 + 1e-9) {
                continue;
            }
            let r = self.root(&br, k, reference.c);
            match geom::nearest_turn(r.c, reference.c, self.c_limits) {
                Some(c) => {
                    let d = (t - reference.tilt).abs() + (c - reference.c).abs();
                    // Ties go to the first branch, as in the generic inverse.
                    let better =
                        best.is_none_or(|b| d < b.0 - 1e-12 || (d < b.0 + 1e-12 && k < b.4));
                    if better {
                        best = Some((d, t, c, r.sc, k));
                    }
                }
                None => c_err = Some(r.c),
            }
        }
        let roots = br.tilt;
        let Some((_, tilt, c, sc, _)) = best else {
            if let (Some(c), Some((lo, hi))) = (c_err, self.c_limits) {
                return Err(IkError::COutOfLimits {
                    angle: c.rem_euclid(360.0),
                    lo,
                    hi,
                });
            }
            let (lo, hi) = self
                .tilt_limits
                .unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
            return Err(IkError::TiltOutOfLimits {
                ux: u.x,
                uy: u.y,
                uz: u.z,
                letter: self.tilt_letter,
                angle: roots[0],
                alt: roots[1],
                lo,
                hi,
            });
        };
        Ok(Axes {
            xyz: self.position_sc(&target.tip, sc, &self.lin),
            tilt,
            c,
        })
    }
}

/// The two tilt branches of an orientation.
#[derive(Clone, Copy, Debug)]
struct Branches {
    up: Vector3<f64>,
    u_xy: f64,
    phi: [f64; 2],
    tilt: [f64; 2],
}

/// One closed-form root: angles (deg) and the sine and cosine of the chain
/// angles (tilt, then C, with their directions).
#[derive(Clone, Copy, Debug)]
struct Root {
    tilt: f64,
    c: f64,
    sc: [f64; 4],
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Machine;
    use crate::kinematics::SLOT_LIN;
    use rand::rngs::StdRng;
    use rand::{RngExt, SeedableRng};

    const MACHINES: [&str; 4] = ["bc-trunnion", "ac-trunnion", "head-table", "head-head"];

    fn random_p(k: &Kinematics, r: &mut StdRng) -> Perturbation {
        let mut p = Perturbation::zero();
        for slot in 0..SLOT_LIN {
            if k.slot_name(slot).is_some() {
                let s: f64 = r.random_range(-1.0..1.0);
                p.0[slot] = if slot % 6 < 3 { s * 0.05 } else { s * 100e-6 };
            }
        }
        for i in 0..3 {
            p.0[SLOT_LIN + i] = r.random_range(-0.01..0.01);
        }
        p.0[super::super::SLOT_TOOL_LENGTH] = r.random_range(-0.02..0.02);
        p
    }

    fn random_axes(m: &Machine, r: &mut StdRng) -> Axes {
        let mut xyz = [0.0; 3];
        for (i, v) in xyz.iter_mut().enumerate() {
            let (lo, hi) = m.strokes[i];
            *v = r.random_range(lo..hi) - m.pivot[i];
        }
        let (tlo, thi) = m.tilt.limits.unwrap();
        let (clo, chi) = m.c.limits.unwrap_or((-180.0, 180.0));
        Axes::new(
            xyz[0],
            xyz[1],
            xyz[2],
            r.random_range(tlo..thi),
            r.random_range(clo..chi),
        )
    }

    #[test]
    fn forward_equals_the_generic_chain() {
        for (mi, name) in MACHINES.iter().enumerate() {
            let m = Machine::builtin(name).unwrap();
            let k = Kinematics::new(&m);
            let mut r = StdRng::seed_from_u64(700 + mi as u64);
            for _ in 0..2000 {
                let p = random_p(&k, &mut r);
                let f = FastChain::new(&k, &p);
                let a = random_axes(&m, &mut r);
                let want = k.forward(&a, &p);
                let got = f.forward(&a);
                assert!((got.tip - want.tip).norm() < 1e-10, "{name} {a:?}");
                assert!((got.axis - want.axis).norm() < 1e-14, "{name} {a:?}");
            }
        }
    }

    #[test]
    fn position_by_rotating_vectors_equals_position_by_matrices() {
        for (mi, name) in MACHINES.iter().enumerate() {
            let m = Machine::builtin(name).unwrap();
            let k = Kinematics::new(&m);
            let mut r = StdRng::seed_from_u64(950 + mi as u64);
            for _ in 0..500 {
                let f = FastChain::new(&k, &random_p(&k, &mut r));
                let a = random_axes(&m, &mut r);
                let tip = Vector3::new(
                    r.random_range(-100.0..100.0),
                    r.random_range(-100.0..100.0),
                    r.random_range(-50.0..50.0),
                );
                let lin = Vector3::new(0.01, -0.02, 0.005);
                let phi = f.dt * geom::rad(a.tilt);
                let psi = f.dc * geom::rad(a.c);
                let sc = [phi.sin(), phi.cos(), psi.sin(), psi.cos()];
                let want = f.position(&tip, a.tilt, a.c, &lin);
                let got = f.position_sc(&tip, sc, &lin);
                assert!((got - want).norm() < 1e-10, "{name}: {got} {want}");
            }
        }
    }

    #[test]
    fn nominal_shortcut_equals_the_generic_chain() {
        for (mi, name) in MACHINES.iter().enumerate() {
            let m = Machine::builtin(name).unwrap();
            let k = Kinematics::new(&m);
            let f = FastChain::nominal(&k);
            let mut r = StdRng::seed_from_u64(900 + mi as u64);
            for _ in 0..2000 {
                let a = random_axes(&m, &mut r);
                let (want, got) = (k.forward_nominal(&a), f.forward(&a));
                assert!((got.tip - want.tip).norm() < 1e-10, "{name} {a:?}");
                assert!((got.axis - want.axis).norm() < 1e-14, "{name} {a:?}");
            }
        }
    }

    #[test]
    fn inverse_equals_the_generic_inverse() {
        for (mi, name) in MACHINES.iter().enumerate() {
            let m = Machine::builtin(name).unwrap();
            let k = Kinematics::new(&m);
            let mut r = StdRng::seed_from_u64(800 + mi as u64);
            for i in 0..1000 {
                let p = random_p(&k, &mut r);
                let f = FastChain::new(&k, &p);
                let a = random_axes(&m, &mut r);
                let target = k.forward(&a, &p);
                let hint = Axes {
                    tilt: a.tilt + r.random_range(-10.0..10.0),
                    c: a.c + r.random_range(-10.0..10.0),
                    ..a
                };
                let want = k.inverse(&target, Some(&hint), |_| p).unwrap();
                let got = f.inverse(&target, &hint).unwrap();
                // Both must reach the pose; next to the singular tilt (tool
                // along C) C is ill-conditioned, so the two exact answers
                // may differ by more than rounding there.
                let back = k.forward(&got, &p);
                assert!(
                    (back.tip - target.tip).norm() < 1e-9
                        && (back.axis - target.axis).norm() < 1e-12,
                    "{name} pose {i}: fast {got:?} misses the target"
                );
                let tol = if geom::rad(a.tilt).sin().abs() < 0.02 {
                    1e-6
                } else {
                    1e-9
                };
                assert!(
                    (got.xyz - want.xyz).norm() < tol
                        && (got.tilt - want.tilt).abs() < tol
                        && (got.c - want.c).abs() < tol,
                    "{name} pose {i}: fast {got:?} generic {want:?}"
                );
            }
        }
    }

    #[test]
    fn held_c_tilt_is_the_best_tilt() {
        let m = Machine::builtin("bc-trunnion").unwrap();
        let k = Kinematics::new(&m);
        let mut r = StdRng::seed_from_u64(9);
        let p = random_p(&k, &mut r);
        let f = FastChain::new(&k, &p);
        let u = Vector3::new(0.3, -0.2, 0.9).normalize();
        let c = 37.0;
        let t = f.tilt_for_c(&u, c);
        let score = |t: f64| f.forward(&Axes::new(0.0, 0.0, 0.0, t, c)).axis.dot(&u);
        for d in [-1e-3, 1e-3, -1.0, 1.0] {
            assert!(score(t) >= score(t + d), "{t} vs {}", t + d);
        }
    }
}
