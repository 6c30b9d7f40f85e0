//! The chain as a list of elementary factors and its exact derivatives.

use nalgebra::{Isometry3, Matrix3, SMatrix, Translation3, UnitQuaternion, Vector3};

use super::{
    Kinematics, N_VARS, PoseJacobian, SLOT_LIN, SLOT_LIN_ROT, SLOT_TOOL_LENGTH, ToolPose, VAR_C,
    VAR_TILT, pose_of,
};
use crate::geom::Axis3;
use crate::machine::{Machine, RotaryAxis, Structure};

/// An elementary transform.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChainOp {
    /// Translation along an axis.
    T(Axis3),
    /// Right-handed rotation about an axis.
    R(Axis3),
}

/// One factor: `op(c0 + sum coef * var)`.
#[derive(Clone, Debug)]
struct Factor {
    op: ChainOp,
    c0: f64,
    terms: Vec<(usize, f64)>,
}

impl Factor {
    fn value(&self, v: &[f64; N_VARS]) -> f64 {
        self.terms
            .iter()
            .fold(self.c0, |acc, &(i, k)| acc + k * v[i])
    }

    fn iso(&self, x: f64) -> Isometry3<f64> {
        match self.op {
            ChainOp::T(a) => {
                Isometry3::from_parts(Translation3::from(a.unit() * x), UnitQuaternion::identity())
            }
            ChainOp::R(a) => {
                let (s, c) = half_sin_cos(x);
                let e = a.unit() * s;
                let q = nalgebra::Quaternion::new(c, e.x, e.y, e.z);
                Isometry3::from_parts(Translation3::identity(), UnitQuaternion::new_unchecked(q))
            }
        }
    }
}

/// `sin(x / 2)` and `cos(x / 2)`. Most factors of a chain are error
/// rotations of microradians, where the Taylor series to the ninth power
/// is exact to the last bit (the first term left out is below 1e-27 of
/// the result for |x / 2| < 1e-3) and costs a fraction of `sin_cos`, which
/// the forward model calls for every factor of every point of every fit.
fn half_sin_cos(x: f64) -> (f64, f64) {
    let h = 0.5 * x;
    if h.abs() < 1e-3 {
        let h2 = h * h;
        let s = h * (1.0 - h2 / 6.0 * (1.0 - h2 / 20.0 * (1.0 - h2 / 42.0 * (1.0 - h2 / 72.0))));
        let c = 1.0 - h2 / 2.0 * (1.0 - h2 / 12.0 * (1.0 - h2 / 30.0 * (1.0 - h2 / 56.0)));
        (s, c)
    } else {
        h.sin_cos()
    }
}

/// The product of a chain's first factors, as a rotation and a translation,
/// and the index of the next factor.
#[derive(Clone, Copy, Debug)]
pub(super) struct Partial {
    rot: UnitQuaternion<f64>,
    t: Vector3<f64>,
    next: usize,
}

impl Partial {
    pub(super) const START: Partial = Partial {
        rot: UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(1.0, 0.0, 0.0, 0.0)),
        t: Vector3::new(0.0, 0.0, 0.0),
        next: 0,
    };

    pub(super) fn iso(&self) -> Isometry3<f64> {
        Isometry3::from_parts(Translation3::from(self.t), self.rot)
    }
}

/// The per-factor values, prefix rotations and turns of
/// [`Chain::jacobian`].
#[derive(Default)]
struct Scratch {
    values: Vec<f64>,
    pre: Vec<Matrix3<f64>>,
    turns: Vec<Option<UnitQuaternion<f64>>>,
}

#[derive(Clone, Debug)]
pub(super) struct Chain {
    factors: Vec<Factor>,
}

const SLOT0: usize = 5;
const LIN_AXES: [Axis3; 3] = [Axis3::X, Axis3::Y, Axis3::Z];
const ROT_AXES: [Axis3; 3] = [Axis3::X, Axis3::Y, Axis3::Z];

fn slot(s: usize) -> usize {
    SLOT0 + s
}

fn var_of(axis: &RotaryAxis) -> usize {
    if axis.letter == 'C' { VAR_C } else { VAR_TILT }
}

/// `D(terms of link)`: Tx Ty Tz Rx Ry Rz.
fn push_link(f: &mut Vec<Factor>, link: usize) {
    for (k, &a) in LIN_AXES.iter().enumerate() {
        f.push(Factor {
            op: ChainOp::T(a),
            c0: 0.0,
            terms: vec![(slot(link * 6 + k), 1.0)],
        });
    }
    for (k, &a) in ROT_AXES.iter().enumerate() {
        f.push(Factor {
            op: ChainOp::R(a),
            c0: 0.0,
            terms: vec![(slot(link * 6 + 3 + k), 1.0)],
        });
    }
}

/// `D(terms of link)^-1`: Rz(-c) Ry(-b) Rx(-a) Tz(-dz) Ty(-dy) Tx(-dx).
fn push_link_inverse(f: &mut Vec<Factor>, link: usize) {
    for k in (0..3).rev() {
        f.push(Factor {
            op: ChainOp::R(ROT_AXES[k]),
            c0: 0.0,
            terms: vec![(slot(link * 6 + 3 + k), -1.0)],
        });
    }
    for k in (0..3).rev() {
        f.push(Factor {
            op: ChainOp::T(LIN_AXES[k]),
            c0: 0.0,
            terms: vec![(slot(link * 6 + k), -1.0)],
        });
    }
}

fn rotary(f: &mut Vec<Factor>, axis: &RotaryAxis, sign: f64) {
    f.push(Factor {
        op: ChainOp::R(axis.about),
        c0: 0.0,
        terms: vec![(var_of(axis), sign * axis.direction)],
    });
}

/// Builds the chain for the tool tip in W; returns it with the number of
/// leading factors that make up `rTw^-1`.
pub(super) fn build(m: &Machine, gauge_length: f64) -> (Chain, usize) {
    let mut f = Vec::new();
    // rTw^-1 = prod over table links, W side first, of R(+angle) * E^-1.
    match m.structure {
        Structure::TableTable => {
            rotary(&mut f, &m.c, 1.0);
            push_link_inverse(&mut f, 1);
            rotary(&mut f, &m.tilt, 1.0);
            push_link_inverse(&mut f, 0);
        }
        Structure::HeadTable => {
            rotary(&mut f, &m.c, 1.0);
            push_link_inverse(&mut f, 0);
        }
        Structure::HeadHead => {}
    }
    let table_factors = f.len();
    for (k, &a) in LIN_AXES.iter().enumerate() {
        f.push(Factor {
            op: ChainOp::T(a),
            c0: 0.0,
            terms: vec![(k, 1.0), (slot(SLOT_LIN + k), 1.0)],
        });
    }
    // The linear axes' angular error motions turn the tool side about the
    // commanded point (their lever arms to it are in the linear slots, the
    // turn of what lies beyond it here; docs/model.md). At zero these
    // factors are skipped, so a machine without them keeps its bits.
    for (k, &a) in ROT_AXES.iter().enumerate() {
        f.push(Factor {
            op: ChainOp::R(a),
            c0: 0.0,
            terms: vec![(slot(SLOT_LIN_ROT + k), 1.0)],
        });
    }
    if m.structure != Structure::TableTable {
        let lh = m.pivot_length + gauge_length;
        f.push(Factor {
            op: ChainOp::T(Axis3::Z),
            c0: lh,
            terms: vec![],
        });
        if m.structure == Structure::HeadHead {
            push_link(&mut f, 0);
            rotary(&mut f, &m.c, 1.0);
        }
        push_link(&mut f, 1);
        rotary(&mut f, &m.tilt, 1.0);
        push_link(&mut f, 2);
        f.push(Factor {
            op: ChainOp::T(Axis3::Z),
            c0: -lh,
            terms: vec![],
        });
    }
    f.push(Factor {
        op: ChainOp::T(Axis3::Z),
        c0: 0.0,
        terms: vec![(slot(SLOT_TOOL_LENGTH), -1.0)],
    });
    (Chain { factors: f }, table_factors)
}

impl Chain {
    pub(super) fn eval(&self, v: &[f64; N_VARS]) -> Isometry3<f64> {
        self.eval_prefix(v, self.factors.len())
    }

    pub(super) fn eval_prefix(&self, v: &[f64; N_VARS], n: usize) -> Isometry3<f64> {
        self.advance(Partial::START, v, n).iso()
    }

    pub(super) fn len(&self) -> usize {
        self.factors.len()
    }

    /// The variables the first `n` factors depend on, increasing.
    pub(super) fn vars_of(&self, n: usize) -> Vec<usize> {
        let mut vars: Vec<usize> = self.factors[..n]
            .iter()
            .flat_map(|f| f.terms.iter().map(|&(i, _)| i))
            .collect();
        vars.sort_unstable();
        vars.dedup();
        vars
    }

    /// `from` multiplied on by the factors from its end up to `to`: the
    /// same operations, in the same order, as one product from the start.
    pub(super) fn advance(&self, from: Partial, v: &[f64; N_VARS], to: usize) -> Partial {
        // The product of the factors kept as a rotation and a translation:
        // a translation factor moves the origin along the rotated axis, a
        // rotation factor turns the rotation (no quaternion product with
        // an identity, no rotation of a zero translation).
        let Partial { mut rot, mut t, .. } = from;
        for f in &self.factors[from.next..to] {
            let x = f.value(v);
            if x == 0.0 {
                continue;
            }
            match f.op {
                ChainOp::T(a) => t += rot * (a.unit() * x),
                ChainOp::R(_) => rot *= f.iso(x).rotation,
            }
        }
        Partial { rot, t, next: to }
    }

    /// The pose of [`Chain::jacobian`] without its derivatives: the same
    /// products of the factors, the same bits.
    pub(super) fn jacobian_pose(&self, v: &[f64; N_VARS]) -> ToolPose {
        let mut acc = Isometry3::identity();
        for f in &self.factors {
            let x = f.value(v);
            if x != 0.0 {
                acc *= f.iso(x);
            }
        }
        pose_of(&acc)
    }

    pub(super) fn jacobian(&self, v: &[f64; N_VARS]) -> PoseJacobian {
        // The fits call this for every point of every evaluation: the
        // buffers are the thread's own, not allocated per call.
        thread_local! {
            static SCRATCH: std::cell::RefCell<Scratch> = Default::default();
        }
        SCRATCH.with_borrow_mut(|s| self.jacobian_in(v, s))
    }

    fn jacobian_in(&self, v: &[f64; N_VARS], scratch: &mut Scratch) -> PoseJacobian {
        let n = self.factors.len();
        let Scratch { values, pre, turns } = scratch;
        values.clear();
        values.extend(self.factors.iter().map(|f| f.value(v)));
        // Rotation of the prefix before each factor (P_{k-1}) and after (P_k).
        // A factor at zero is the identity and a translation keeps the
        // rotation, so the product and its matrix change only where they
        // must (as `eval_prefix` multiplies; the same bits but for the
        // sign of a zero); each rotation is kept for the pass back.
        pre.clear();
        turns.clear();
        let mut acc = Isometry3::identity();
        let mut m = Matrix3::identity();
        pre.push(m);
        for (f, &x) in self.factors.iter().zip(values.iter()) {
            let mut turn = None;
            if x != 0.0 {
                let iso = f.iso(x);
                acc *= iso;
                if let ChainOp::R(_) = f.op {
                    m = acc.rotation.to_rotation_matrix().into_inner();
                    turn = Some(iso.rotation);
                }
            }
            turns.push(turn);
            pre.push(m);
        }
        let pose = pose_of(&acc);
        let mut jt = SMatrix::<f64, 3, N_VARS>::zeros();
        let mut ja = SMatrix::<f64, 3, N_VARS>::zeros();
        // Suffix applied to the tip origin and to the tool axis.
        let mut q = Vector3::zeros();
        let mut u = Vector3::z();
        for k in (0..n).rev() {
            let f = &self.factors[k];
            match f.op {
                ChainOp::T(a) => {
                    let dt = pre[k] * a.unit();
                    for &(i, c) in &f.terms {
                        for r in 0..3 {
                            jt[(r, i)] += c * dt[r];
                        }
                    }
                    q += a.unit() * values[k];
                }
                ChainOp::R(a) => {
                    let e = a.unit();
                    let dt = pre[k + 1] * e.cross(&q);
                    let da = pre[k + 1] * e.cross(&u);
                    for &(i, c) in &f.terms {
                        for r in 0..3 {
                            jt[(r, i)] += c * dt[r];
                            ja[(r, i)] += c * da[r];
                        }
                    }
                    if let Some(rot) = turns[k] {
                        q = rot * q;
                        u = rot * u;
                    }
                }
            }
        }
        PoseJacobian {
            pose,
            tip: jt,
            axis: ja,
        }
    }

    pub(super) fn describe(&self, k: &Kinematics) -> String {
        let m = k.machine();
        let link = |l: usize| {
            let names: Vec<String> = (0..6).map(|i| k.slot_name(l * 6 + i).unwrap()).collect();
            format!("D({})", names.join(", "))
        };
        let r = |a: &RotaryAxis, table: bool| {
            let s = if table { -a.direction } else { a.direction };
            format!(
                "D{}({}{})",
                a.about.rot_letter().to_ascii_lowercase(),
                if s < 0.0 { "-" } else { "" },
                a.letter
            )
        };
        let lh = m.pivot_length + k.gauge_length();
        match m.structure {
            Structure::TableTable => format!(
                "rTw  = {} * {} * {} * {}\nrTw* = {} * {}\ntool = Trans(X + ex, Y + ey, Z + ez) * Rx(ea) Ry(eb) Rz(ec) * Dz(-dL)\nwq   = rTw^-1 * tool * 0",
                link(0),
                r(&m.tilt, true),
                link(1),
                r(&m.c, true),
                r(&m.tilt, true),
                r(&m.c, true)
            ),
            Structure::HeadTable => format!(
                "rTw  = {} * {}\nrTw* = {}\ntool = Trans(X + ex, Y + ey, Z + ez) * Rx(ea) Ry(eb) Rz(ec) * Dz({lh}) * {} * {} * {} * Dz(-{lh}) * Dz(-dL)\nwq   = rTw^-1 * tool * 0",
                link(0),
                r(&m.c, true),
                r(&m.c, true),
                link(1),
                r(&m.tilt, false),
                link(2)
            ),
            Structure::HeadHead => format!(
                "rTw  = I (fixed table)\ntool = Trans(X + ex, Y + ey, Z + ez) * Rx(ea) Ry(eb) Rz(ec) * Dz({lh}) * {} * {} * {} * {} * {} * Dz(-{lh}) * Dz(-dL)\nwq   = tool * 0",
                link(0),
                r(&m.c, false),
                link(1),
                r(&m.tilt, false),
                link(2)
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use rand::SeedableRng;
    use rand::rngs::StdRng;
    use rand_distr::{Distribution, Uniform};

    use super::*;

    #[test]
    fn the_small_angle_series_is_sin_cos_to_the_last_bit() {
        let mut rng = StdRng::seed_from_u64(11);
        for k in 0..20_000 {
            // Angles from 1e-12 rad up to past the switch at 2e-3.
            let x = 10f64.powf(Uniform::new(-12.0, -2.5).unwrap().sample(&mut rng))
                * if k % 2 == 0 { 1.0 } else { -1.0 };
            let (s, c) = half_sin_cos(x);
            let (s0, c0) = (0.5 * x).sin_cos();
            assert!(
                (s - s0).abs() <= 2.0 * f64::EPSILON * s0.abs(),
                "sin at {x}"
            );
            assert!((c - c0).abs() <= 2.0 * f64::EPSILON, "cos at {x}");
        }
    }

    #[test]
    fn the_split_product_is_the_product_of_the_factors() {
        let m = Machine::builtin("head-head").unwrap();
        let (chain, _) = build(&m, 150.0);
        let mut rng = StdRng::seed_from_u64(12);
        for _ in 0..200 {
            let mut v = [0.0; N_VARS];
            v[0] = Uniform::new(-400.0, 400.0).unwrap().sample(&mut rng);
            v[1] = Uniform::new(-300.0, 300.0).unwrap().sample(&mut rng);
            v[2] = Uniform::new(-300.0, 100.0).unwrap().sample(&mut rng);
            v[3] = Uniform::new(-1.5, 1.5).unwrap().sample(&mut rng);
            v[4] = Uniform::new(-3.0, 3.0).unwrap().sample(&mut rng);
            for x in v.iter_mut().skip(5) {
                *x = Uniform::new(-50e-6, 50e-6).unwrap().sample(&mut rng);
            }
            let fast = chain.eval(&v);
            let mut acc = Isometry3::identity();
            for f in &chain.factors {
                acc *= f.iso(f.value(&v));
            }
            assert!((fast.translation.vector - acc.translation.vector).norm() < 1e-10);
            assert!(fast.rotation.angle_to(&acc.rotation) < 1e-13);
        }
    }

    /// A pose from a table part made along the same line (other X Y Z, the
    /// same table errors) is the pose multiplied afresh, to the bit; with
    /// the table's errors or rotary positions changed, it is still right
    /// (the whole chain is multiplied). The Jacobian's pose without the
    /// derivatives is its pose to the bit.
    #[test]
    fn a_pose_after_a_table_part_is_the_pose_to_the_bit() {
        use crate::kinematics::{Axes, Kinematics, Perturbation};
        let mut rng = StdRng::seed_from_u64(29);
        let u = |rng: &mut StdRng, lo: f64, hi: f64| Uniform::new(lo, hi).unwrap().sample(rng);
        for (name, _) in crate::machine::BUILTIN {
            let k = Kinematics::with_gauge_length(&Machine::builtin(name).unwrap(), 120.0);
            for round in 0..100 {
                let mut p = Perturbation::zero();
                for x in p.0.iter_mut() {
                    *x = u(&mut rng, -50e-6, 50e-6);
                }
                let at = |rng: &mut StdRng, tilt: f64, c: f64| {
                    Axes::new(
                        u(rng, -400.0, 400.0),
                        u(rng, -300.0, 300.0),
                        u(rng, -300.0, 100.0),
                        tilt,
                        c,
                    )
                };
                let (tilt, c) = (u(&mut rng, -90.0, 90.0), u(&mut rng, -180.0, 180.0));
                let part = k.table_part(&at(&mut rng, tilt, c), &p);
                let mut q = p;
                // The linear axes' own errors change along a line; every
                // third round, a table link's error or the rotary position
                // changes as well.
                q.0[crate::kinematics::SLOT_LIN] += 1e-6;
                let (tilt2, c2) = match round % 3 {
                    0 => (tilt + 1.0, c),
                    1 => {
                        q.0[0] += 1e-6;
                        (tilt, c)
                    }
                    _ => (tilt, c),
                };
                let axes = at(&mut rng, tilt2, c2);
                let want = k.forward(&axes, &q);
                let got = k.forward_after(&part, &axes, &q);
                assert_eq!(
                    got.tip.map(f64::to_bits),
                    want.tip.map(f64::to_bits),
                    "{name}"
                );
                assert_eq!(
                    got.axis.map(f64::to_bits),
                    want.axis.map(f64::to_bits),
                    "{name}"
                );
                // And the pose of the Jacobian, without its derivatives.
                let want = k.jacobian(&axes, &q).pose;
                let got = k.jacobian_pose(&axes, &q);
                assert_eq!(got.tip.map(f64::to_bits), want.tip.map(f64::to_bits));
                assert_eq!(got.axis.map(f64::to_bits), want.axis.map(f64::to_bits));
            }
        }
    }
}
