//! Inverse kinematics: from a tool tip and tool axis in W to axis values.
//!
//! For every supported structure the tool axis in W is
//! `u = M * Rz(c) * N * R_T(t) * v`, where `M`, `N` and `v` are fixed
//! rotations and a vector made of the error terms (identities and +Z on the
//! nominal machine). Since `Rz` keeps the Z component, the tilt follows in
//! closed form from `(N R_T(t) v).z = (M^T u).z`, an equation
//! `beta cos t + gamma sin t = rhs` with exactly two roots, and C follows
//! from the azimuth. That gives both branches on the erroneous machine, even
//! next to the singular tilt where the errors decide which orientations are
//! reachable at all. When the errors depend on the angles (error maps),
//! each branch is then polished by Newton's method on the two angles. X, Y,
//! Z follow exactly from the position equation (linear-axis errors are
//! translations, so orientation does not depend on them). Among the branches
//! and the C turns within limits the solution nearest the hint (the previous
//! position) wins; without a hint, the one nearest rotary zero.

use nalgebra::{Matrix2, Vector2, Vector3};

use super::{Axes, Kinematics, Perturbation, SLOT_LIN, ToolPose, VAR_C, VAR_TILT};
use crate::geom::{self, d6, tangent_basis};
use crate::machine::Structure;

/// Why no axis values reach a tool pose.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IkError {
    /// The tool axis needs a tilt outside the limits on every branch.
    #[error(
        "tool axis ({ux:.6}, {uy:.6}, {uz:.6}) in W needs {letter} = {angle:.4} deg (or {alt:.4} deg), outside the limits [{lo}, {hi}]"
    )]
    TiltOutOfLimits {
        /// Tool axis.
        ux: f64,
        /// Tool axis.
        uy: f64,
        /// Tool axis.
        uz: f64,
        /// Tilt letter.
        letter: char,
        /// First branch.
        angle: f64,
        /// Second branch.
        alt: f64,
        /// Lower limit.
        lo: f64,
        /// Upper limit.
        hi: f64,
    },
    /// Next to the singular tilt, the erroneous machine cannot point the
    /// tool this way at any C angle.
    #[error(
        "tool axis ({ux:.6}, {uy:.6}, {uz:.6}) in W lies closer to the C axis than the machine's rotary-axis errors let it reach"
    )]
    OutOfReach {
        /// Tool axis.
        ux: f64,
        /// Tool axis.
        uy: f64,
        /// Tool axis.
        uz: f64,
    },
    /// No C turn of the solution lies inside the C limits.
    #[error("C = {angle:.4} deg (mod 360) is outside the C limits [{lo}, {hi}]")]
    COutOfLimits {
        /// The angle.
        angle: f64,
        /// Lower limit.
        lo: f64,
        /// Upper limit.
        hi: f64,
    },
    /// The iteration failed (a tool axis the erroneous machine cannot reach).
    #[error(
        "inverse kinematics did not converge for tip ({x:.4}, {y:.4}, {z:.4}): residual {residual:.3e}"
    )]
    NoConvergence {
        /// Tip.
        x: f64,
        /// Tip.
        y: f64,
        /// Tip.
        z: f64,
        /// Remaining residual (mm or rad).
        residual: f64,
    },
}

const MAX_ITER: usize = 50;

impl Kinematics {
    /// Nominal inverse kinematics.
    pub fn inverse_nominal(&self, target: &ToolPose, hint: Option<&Axes>) -> Result<Axes, IkError> {
        self.inverse(target, hint, |_| Perturbation::zero())
    }

    /// Inverse kinematics on the machine whose errors at a configuration are
    /// `perturb(axes)` (error maps and linear-axis errors depend on it).
    pub fn inverse<F>(
        &self,
        target: &ToolPose,
        hint: Option<&Axes>,
        perturb: F,
    ) -> Result<Axes, IkError>
    where
        F: Fn(&Axes) -> Perturbation,
    {
        let m = self.machine();
        let u_t = target.axis.normalize();
        let reference = hint.copied().unwrap_or_default();
        let mut best: Option<(f64, Axes)> = None;
        let mut tilts = Vec::new();
        let mut c_violation = None;
        let p_ref = perturb(&reference);
        let roots = self.orientation_roots(&u_t, &p_ref, reference.c);
        // Each closed-form root starts a branch; with error maps the
        // hint itself is one more start, since near the singular tilt the
        // angle-dependent errors can move roots far in C.
        let singular = roots.is_empty() || self.near_singular(&roots);
        // A tilt stroke of more than a turn reaches a root at several
        // turns: it is polished at the one nearest the hint (the errors
        // may depend on the tilt, so the turn matters before polishing).
        let mut starts: Vec<(f64, f64)> = roots
            .into_iter()
            .map(|(t, c)| {
                let t = geom::nearest_turn(t, reference.tilt, m.tilt.limits).unwrap_or(t);
                (t, c)
            })
            .collect();
        if hint.is_some() {
            starts.push((reference.tilt, reference.c));
        }
        // Next to the singular tilt, C-dependent errors can put the root
        // nearest the hint anywhere in C (or make the orientation reachable
        // only at other C angles): scan C for all of them.
        if singular && depends_on_c(&perturb, &reference) {
            starts.extend(self.scan_c(&u_t, &reference, &perturb));
        }
        let mut found: Vec<Axes> = Vec::new();
        for (t0, c0) in starts {
            let start = Axes {
                xyz: reference.xyz,
                tilt: t0,
                c: c0,
            };
            let Some(oriented) = self.polish_orientation(&u_t, start, &perturb) else {
                continue;
            };
            if found.iter().any(|f| {
                (f.tilt - oriented.tilt).abs() + geom::wrap180(f.c - oriented.c).abs() < 1e-9
            }) {
                continue;
            }
            found.push(oriented);
        }
        for oriented in found {
            tilts.push(oriented.tilt);
            if !m.tilt.within(oriented.tilt, 1e-9) {
                continue;
            }
            let c = match choose_c(oriented.c, reference.c, m.c.limits) {
                Ok(c) => c,
                Err(e) => {
                    c_violation = Some(e);
                    continue;
                }
            };
            let cand = Axes { c, ..oriented };
            let d = (cand.tilt - reference.tilt).abs() + (cand.c - reference.c).abs();
            if best.as_ref().is_none_or(|(bd, _)| d < *bd - 1e-12) {
                best = Some((d, cand));
            }
        }
        let Some((_, mut axes)) = best else {
            if let Some(e) = c_violation {
                return Err(e);
            }
            if tilts.is_empty() && u_t.z > 0.0 {
                return Err(IkError::OutOfReach {
                    ux: u_t.x,
                    uy: u_t.y,
                    uz: u_t.z,
                });
            }
            return Err(self.unreachable(&u_t, &tilts));
        };
        self.solve_position(target, &mut axes, &perturb)?;
        Ok(axes)
    }

    fn unreachable(&self, u_t: &Vector3<f64>, tilts: &[f64]) -> IkError {
        let m = self.machine();
        let (lo, hi) = m.tilt.limits.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
        let nominal = geom::deg(u_t.z.clamp(-1.0, 1.0).acos() / m.tilt.direction);
        let a = tilts.first().copied().unwrap_or(nominal);
        let alt = tilts.get(1).copied().unwrap_or(-a);
        IkError::TiltOutOfLimits {
            ux: u_t.x,
            uy: u_t.y,
            uz: u_t.z,
            letter: m.tilt.letter,
            angle: a,
            alt,
            lo,
            hi,
        }
    }

    /// The two (tilt, C) solutions, deg, for the orientation with the error
    /// terms of `p`, in a fixed branch order (tilt root `phi0 + acos`, then
    /// `phi0 - acos`). Empty when the orientation is out of reach.
    fn orientation_roots(
        &self,
        u_t: &Vector3<f64>,
        p: &Perturbation,
        c_ref: f64,
    ) -> Vec<(f64, f64)> {
        let m = self.machine();
        let rot = |l: usize| d6(&p.link(l)).rotation;
        let id = nalgebra::UnitQuaternion::identity();
        let (mm, nn, v) = match m.structure {
            Structure::TableTable => (id, rot(1).inverse(), rot(0).inverse() * Vector3::z()),
            Structure::HeadTable => (id, rot(0).inverse() * rot(1), rot(2) * Vector3::z()),
            Structure::HeadHead => (rot(0), rot(1), rot(2) * Vector3::z()),
        };
        let up = mm.inverse() * u_t;
        let e = m.tilt.about.unit();
        let n3 = nn.inverse() * Vector3::z();
        let v_par = e * e.dot(&v);
        let alpha = n3.dot(&v_par);
        let beta = n3.dot(&(v - v_par));
        let gamma = n3.dot(&e.cross(&v));
        let r = beta.hypot(gamma);
        let rhs = (up.z - alpha) / r;
        if rhs.is_nan() || rhs.abs() > 1.0 + 1e-12 {
            return Vec::new();
        }
        let phi0 = gamma.atan2(beta);
        let half = rhs.clamp(-1.0, 1.0).acos();
        let (st, sc) = (m.tilt.direction, m.c.direction);
        [phi0 + half, phi0 - half]
            .into_iter()
            .map(|phi| {
                let w = nn * geom::rot(m.tilt.about, phi).rotation * v;
                let psi = if w.xy().norm() < 1e-14 || up.xy().norm() < 1e-14 {
                    sc * geom::rad(c_ref)
                } else {
                    up.y.atan2(up.x) - w.y.atan2(w.x)
                };
                (geom::wrap180(geom::deg(phi / st)), geom::deg(psi / sc))
            })
            .collect()
    }

    fn near_singular(&self, roots: &[(f64, f64)]) -> bool {
        roots.iter().any(|&(t, _)| geom::rad(t).sin().abs() < 0.02)
    }

    /// Roots of the orientation equation found by scanning C in 2 deg steps:
    /// for each C the tilt follows from the Z equation with the errors at
    /// that C, and a root is where the C this implies equals the C assumed.
    fn scan_c<F>(&self, u_t: &Vector3<f64>, reference: &Axes, perturb: &F) -> Vec<(f64, f64)>
    where
        F: Fn(&Axes) -> Perturbation,
    {
        let mismatch = |c: f64, branch: usize| -> Option<(f64, f64)> {
            let mut t = 0.0;
            let mut implied = c;
            for _ in 0..4 {
                let p = perturb(&Axes {
                    xyz: reference.xyz,
                    tilt: t,
                    c,
                });
                let &(tb, cb) = self.orientation_roots(u_t, &p, c).get(branch)?;
                t = tb;
                implied = cb;
            }
            Some((t, geom::wrap180(implied - c)))
        };
        let mut out = Vec::new();
        for branch in 0..2 {
            let grid: Vec<(f64, Option<(f64, f64)>)> = (0..=180)
                .map(|k| {
                    let c = reference.c - 180.0 + 2.0 * k as f64;
                    (c, mismatch(c, branch))
                })
                .collect();
            for w in grid.windows(2) {
                let ((mut a, Some((_, fa))), (mut b, Some((_, fb)))) = (w[0], w[1]) else {
                    continue;
                };
                if fa.signum() == fb.signum() || fa.abs() > 90.0 || fb.abs() > 90.0 {
                    continue;
                }
                let mut fa = fa;
                for _ in 0..60 {
                    let mid = 0.5 * (a + b);
                    let Some((_, fm)) = mismatch(mid, branch) else {
                        break;
                    };
                    if fm.signum() == fa.signum() {
                        a = mid;
                        fa = fm;
                    } else {
                        b = mid;
                    }
                }
                let c = 0.5 * (a + b);
                if let Some((t, _)) = mismatch(c, branch) {
                    out.push((t, c));
                }
            }
        }
        out
    }

    /// Newton's method on the two angles from a start next to a root, with
    /// the exact total derivative: the chain's own plus, through the error
    /// terms, the slope of any error map (by central differences of
    /// `perturb`, which is piecewise linear in the angles). Steps that do
    /// not reduce the residual are halved.
    fn polish_orientation<F>(&self, u_t: &Vector3<f64>, start: Axes, perturb: &F) -> Option<Axes>
    where
        F: Fn(&Axes) -> Perturbation,
    {
        let (b1, b2) = tangent_basis(u_t);
        let residual = |a: &Axes| {
            let u = self.forward(a, &perturb(a)).axis;
            (Vector2::new(b1.dot(&u), b2.dot(&u)), u.dot(u_t))
        };
        let mut axes = start;
        let (mut r, mut dot) = residual(&axes);
        for _ in 0..MAX_ITER {
            if r.norm() < 1e-15 && dot > 0.0 {
                break;
            }
            let p = perturb(&axes);
            let j = self.jacobian(&axes, &p);
            // d axis / d angle with the map slope taken centrally (side 0),
            // from above (1) or from below (2): at a map node the slope
            // jumps, and only a one-sided slope points at a root there.
            let column = |k: usize, side: usize| {
                let var = if k == 0 { VAR_TILT } else { VAR_C };
                let mut d = Vector3::new(j.axis[(0, var)], j.axis[(1, var)], j.axis[(2, var)]);
                let h = 1e-7;
                let shift = |s: f64| {
                    let mut a = axes;
                    if k == 0 {
                        a.tilt += geom::deg(s);
                    } else {
                        a.c += geom::deg(s);
                    }
                    perturb(&a)
                };
                let (hi, lo, span) = match side {
                    0 => (shift(h), shift(-h), 2.0 * h),
                    1 => (shift(h), p, h),
                    _ => (p, shift(-h), h),
                };
                for slot in 0..SLOT_LIN {
                    let dp = (hi.0[slot] - lo.0[slot]) / span;
                    if dp != 0.0 {
                        d += Vector3::new(
                            j.axis[(0, 5 + slot)],
                            j.axis[(1, 5 + slot)],
                            j.axis[(2, 5 + slot)],
                        ) * dp;
                    }
                }
                d
            };
            let mut improved = false;
            'sides: for (st, sc) in [
                (0, 0),
                (1, 1),
                (1, 2),
                (2, 1),
                (2, 2),
                (0, 1),
                (0, 2),
                (1, 0),
                (2, 0),
            ] {
                let (ct, cc) = (column(0, st), column(1, sc));
                let jm = Matrix2::new(b1.dot(&ct), b1.dot(&cc), b2.dot(&ct), b2.dot(&cc));
                let Some(step) = jm.svd(true, true).solve(&r, 1e-14).ok() else {
                    continue;
                };
                let mut lambda = 1.0;
                for _ in 0..30 {
                    let trial = Axes {
                        tilt: axes.tilt - geom::deg(lambda * step[0]),
                        c: axes.c - geom::deg(lambda * step[1]),
                        ..axes
                    };
                    let (rt, dt) = residual(&trial);
                    if rt.norm() < r.norm() || (dt > 0.0 && dot <= 0.0) {
                        axes = trial;
                        r = rt;
                        dot = dt;
                        improved = true;
                        break 'sides;
                    }
                    lambda *= 0.5;
                }
            }
            if !improved {
                break;
            }
        }
        (r.norm() < 1e-12 && dot > 0.0).then_some(axes)
    }

    /// X, Y, Z from the position equation `tip = A.rot * (xyz + e(xyz)) + tip0`.
    fn solve_position<F>(
        &self,
        target: &ToolPose,
        axes: &mut Axes,
        perturb: &F,
    ) -> Result<(), IkError>
    where
        F: Fn(&Axes) -> Perturbation,
    {
        let mut residual = f64::INFINITY;
        for _ in 0..MAX_ITER {
            let p = perturb(axes);
            let mut p0 = p;
            for k in 0..3 {
                p0.0[SLOT_LIN + k] = 0.0;
            }
            let at_zero = Axes {
                xyz: Vector3::zeros(),
                ..*axes
            };
            let tip0 = self.forward(&at_zero, &p0).tip;
            let a = self.table_transform(axes.tilt, axes.c, &p0).inverse();
            let w = a.rotation.inverse() * (target.tip - tip0);
            let next = w - p.linear();
            let delta = (next - axes.xyz).norm();
            axes.xyz = next;
            let got = self.forward(axes, &perturb(axes)).tip;
            residual = (got - target.tip).norm();
            if delta < 1e-12 && residual < 1e-9 {
                return Ok(());
            }
        }
        if residual < 1e-9 {
            return Ok(());
        }
        Err(IkError::NoConvergence {
            x: target.tip.x,
            y: target.tip.y,
            z: target.tip.z,
            residual,
        })
    }
}

/// Whether the link terms change with C (an error map over C).
fn depends_on_c<F: Fn(&Axes) -> Perturbation>(perturb: &F, at: &Axes) -> bool {
    let p0 = perturb(at);
    [37.0, 131.0, 229.0].iter().any(|dc| {
        let p1 = perturb(&Axes {
            c: at.c + dc,
            ..*at
        });
        p0.0[..SLOT_LIN] != p1.0[..SLOT_LIN]
    })
}

/// The turn of `c` closest to `reference` that lies within the limits.
fn choose_c(c: f64, reference: f64, limits: Option<(f64, f64)>) -> Result<f64, IkError> {
    // An axis without limits reaches every turn: only limits refuse.
    let (lo, hi) = limits.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
    geom::nearest_turn(c, reference, limits).ok_or(IkError::COutOfLimits {
        angle: c.rem_euclid(360.0),
        lo,
        hi,
    })
}
