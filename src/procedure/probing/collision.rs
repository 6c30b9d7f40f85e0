//! The collision checker: the probe (ball, stylus and body, each a capsule)
//! against the setup (column boxes, the calibration sphere and its stem,
//! the table), along any move of the machine.
//!
//! Everything is checked in W, where the setup stands still and the probe
//! moves: its ball centre and axis at given axis values come from the
//! nominal forward kinematics, so the same code serves table-table and head
//! machines. A move is linear in the axis values, which is what G1 does
//! and what G0 does when the program moves one group of axes at a time
//! (the safe path never relies on the shape of a multi-axis rapid).
//!
//! With the rotary axes standing still, the probe only translates, and the
//! volume a capsule sweeps is exactly a parallelogram grown by its radius;
//! it is tested against each obstacle with GJK (the distance between two
//! convex sets from their support functions), which gives lower and upper
//! bounds on the distance and stops as soon as they decide the question.
//! When a rotary axis moves, the move is sampled finely enough that no
//! point of the probe travels more than 0.5 mm between samples, and the
//! obstacles are grown by half that travel, which makes the test
//! conservative.

use std::fmt;

use nalgebra::{Matrix3, Vector3};

use crate::kinematics::{Axes, Kinematics};

/// A convex solid of the setup, in W.
#[derive(Clone, Debug, PartialEq)]
pub enum ConvexSolid {
    /// A box: centre, orientation (columns are the box's unit axes) and
    /// half sizes along them.
    Cuboid {
        /// Centre, mm.
        centre: Vector3<f64>,
        /// Columns: the box axes in W.
        axes: Matrix3<f64>,
        /// Half sizes, mm.
        half: Vector3<f64>,
    },
    /// A ball.
    Ball {
        /// Centre, mm.
        centre: Vector3<f64>,
        /// Radius, mm.
        radius: f64,
    },
    /// A finite cylinder between the centres of its end discs.
    Cylinder {
        /// One end's centre, mm.
        a: Vector3<f64>,
        /// The other end's centre, mm.
        b: Vector3<f64>,
        /// Radius, mm.
        radius: f64,
    },
}

impl ConvexSolid {
    /// The points of the solid span at most this far along `d` (unit)
    /// from the origin: the support function.
    fn support(&self, d: &Vector3<f64>) -> Vector3<f64> {
        match self {
            ConvexSolid::Cuboid { centre, axes, half } => {
                let mut p = *centre;
                for i in 0..3 {
                    let u = axes.column(i);
                    let s = if u.dot(d) >= 0.0 { 1.0 } else { -1.0 };
                    p += u * (s * half[i]);
                }
                p
            }
            ConvexSolid::Ball { centre, radius } => {
                let n = d.norm();
                if n > 0.0 {
                    centre + d * (radius / n)
                } else {
                    *centre
                }
            }
            ConvexSolid::Cylinder { a, b, radius } => {
                let ax = (b - a).normalize();
                let base = if d.dot(&(b - a)) >= 0.0 { b } else { a };
                let radial = d - ax * ax.dot(d);
                let n = radial.norm();
                if n > 1e-12 {
                    base + radial * (radius / n)
                } else {
                    *base
                }
            }
        }
    }

    /// A centre and a radius of a ball that contains the solid.
    pub(crate) fn bounding_ball(&self) -> (Vector3<f64>, f64) {
        match self {
            ConvexSolid::Cuboid { centre, half, .. } => (*centre, half.norm()),
            ConvexSolid::Ball { centre, radius } => (*centre, *radius),
            ConvexSolid::Cylinder { a, b, radius } => {
                ((a + b) / 2.0, ((b - a).norm() / 2.0).hypot(*radius))
            }
        }
    }

    /// The largest coordinate of the solid along the unit direction `d`,
    /// after the rigid map `m` (e.g. W to program coordinates).
    pub(crate) fn extent_along(&self, m: &nalgebra::Isometry3<f64>, d: &Vector3<f64>) -> f64 {
        let d_local = m.rotation.inverse() * d;
        let p = self.support(&d_local);
        (m * nalgebra::Point3::from(p)).coords.dot(d)
    }

    /// The largest distance of a point of the solid from `o`.
    pub(crate) fn farthest_from(&self, o: &Vector3<f64>) -> f64 {
        match self {
            ConvexSolid::Cuboid { centre, axes, half } => {
                let mut best = 0.0_f64;
                for k in 0..8 {
                    let s = Vector3::new(
                        if k & 1 == 0 { -1.0 } else { 1.0 },
                        if k & 2 == 0 { -1.0 } else { 1.0 },
                        if k & 4 == 0 { -1.0 } else { 1.0 },
                    );
                    let p = centre + axes * s.component_mul(half);
                    best = best.max((p - o).norm());
                }
                best
            }
            ConvexSolid::Ball { centre, radius } => (centre - o).norm() + radius,
            ConvexSolid::Cylinder { a, b, radius } => {
                // The farthest point lies on one of the two rim circles.
                let ax = (b - a).normalize();
                [a, b]
                    .iter()
                    .map(|e| {
                        let v = *e - o;
                        let along = v.dot(&ax);
                        let radial = (v - ax * along).norm();
                        along.hypot(radial + radius)
                    })
                    .fold(0.0, f64::max)
            }
        }
    }
}

/// An obstacle: a named solid of the setup.
#[derive(Clone, Debug, PartialEq)]
pub struct Obstacle {
    /// Name shown in messages (`C1`, `sphere`, `stem`, `table`).
    pub name: String,
    /// Its shape in W.
    pub solid: ConvexSolid,
}

/// Which part of the probe.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProbePart {
    /// The stylus ball.
    Ball,
    /// The stylus shaft.
    Stylus,
    /// The probe body up to the spindle nose.
    Body,
    /// The spindle nose above the gauge line.
    Spindle,
}

impl fmt::Display for ProbePart {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ProbePart::Ball => "stylus ball",
            ProbePart::Stylus => "stylus",
            ProbePart::Body => "probe body",
            ProbePart::Spindle => "spindle nose",
        })
    }
}

/// The probe as four capsules along its axis: the ball, the stylus shaft
/// from the ball centre, the body from the end of the stylus up to the
/// spindle gauge line, and the spindle nose above it (what a probe on a
/// tilted table meets first when it reaches between pieces).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeShape {
    /// Ball radius, mm.
    pub ball_radius: f64,
    /// Ball centre to the probe body, mm.
    pub stylus_length: f64,
    /// Stylus shaft radius, mm.
    pub stylus_radius: f64,
    /// Length of the body (from the stylus end to the spindle), mm.
    pub body_length: f64,
    /// Body radius, mm.
    pub body_radius: f64,
    /// Length of the spindle nose modelled above the gauge line, mm.
    pub spindle_length: f64,
    /// Spindle nose radius, mm.
    pub spindle_radius: f64,
}

/// A capsule: a segment grown by a radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Capsule {
    /// Which part it models.
    pub part: ProbePart,
    /// Segment start, mm.
    pub a: Vector3<f64>,
    /// Segment end, mm.
    pub b: Vector3<f64>,
    /// Radius, mm.
    pub radius: f64,
}

impl ProbeShape {
    /// The capsules with the ball centre at `ball` and the probe axis
    /// (ball towards spindle, unit) `axis`.
    pub(crate) fn capsules(&self, ball: &Vector3<f64>, axis: &Vector3<f64>) -> [Capsule; 4] {
        let s = ball + axis * self.stylus_length;
        let g = s + axis * self.body_length;
        [
            Capsule {
                part: ProbePart::Ball,
                a: *ball,
                b: *ball,
                radius: self.ball_radius,
            },
            Capsule {
                part: ProbePart::Stylus,
                a: *ball,
                b: s,
                radius: self.stylus_radius,
            },
            Capsule {
                part: ProbePart::Body,
                a: s,
                b: g,
                radius: self.body_radius,
            },
            Capsule {
                part: ProbePart::Spindle,
                a: g,
                b: g + axis * self.spindle_length,
                radius: self.spindle_radius,
            },
        ]
    }
}

/// A collision found by the checker.
#[derive(Clone, Debug, PartialEq)]
pub struct Collision {
    /// The part of the probe.
    pub part: ProbePart,
    /// The obstacle's name.
    pub obstacle: String,
    /// Axes where it first happens along the move (to within 0.5 mm of
    /// probe travel on a rotary move), mm/deg.
    pub at: Axes,
    /// The gap that was required, mm.
    pub margin: f64,
}

impl fmt::Display for Collision {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "the {} comes closer than {} mm to {} (at X{:.3} Y{:.3} Z{:.3} tilt {:.3} C {:.3})",
            self.part,
            self.margin.max(0.0),
            self.obstacle,
            self.at.xyz.x,
            self.at.xyz.y,
            self.at.xyz.z,
            self.at.tilt,
            self.at.c
        )
    }
}

/// Checks probe positions and moves against a setup.
#[derive(Clone, Copy, Debug)]
pub struct Checker<'a> {
    kin: &'a Kinematics,
    obstacles: &'a [Obstacle],
    probe: &'a ProbeShape,
}

/// Largest travel of a probe point between two samples of a rotary move, mm.
const SAMPLE_TRAVEL: f64 = 0.5;

impl<'a> Checker<'a> {
    /// A checker of `probe` (on the machine of `kin`, built with the probe's
    /// gauge length) against `obstacles`.
    pub fn new(kin: &'a Kinematics, obstacles: &'a [Obstacle], probe: &'a ProbeShape) -> Self {
        Checker {
            kin,
            obstacles,
            probe,
        }
    }

    fn capsules_at(&self, axes: &Axes) -> [Capsule; 4] {
        let pose = self.kin.forward_nominal(axes);
        self.probe.capsules(&pose.tip, &pose.axis.normalize())
    }

    /// Whether the probe at `axes` keeps at least `margin` from every
    /// obstacle; the first violation otherwise.
    pub fn check_at(&self, axes: &Axes, margin: f64) -> Result<(), Collision> {
        for cap in self.capsules_at(axes) {
            for ob in self.obstacles {
                let shape = Convex::Segment(cap.a, cap.b);
                if within(&shape, &ob.solid, cap.radius + margin) {
                    return Err(Collision {
                        part: cap.part,
                        obstacle: ob.name.clone(),
                        at: *axes,
                        margin,
                    });
                }
            }
        }
        Ok(())
    }

    /// Whether the probe keeps at least `margin` from every obstacle along
    /// the move from `from` to `to`, linear in the axis values. A negative
    /// margin lets the probe come that close: a probing move ends with the
    /// ball touching its surface.
    pub fn check_move(&self, from: &Axes, to: &Axes, margin: f64) -> Result<(), Collision> {
        let rotary = (from.tilt - to.tilt).abs() > 1e-12 || (from.c - to.c).abs() > 1e-12;
        if !rotary {
            let c0 = self.capsules_at(from);
            let c1 = self.capsules_at(to);
            for (a, b) in c0.iter().zip(&c1) {
                let shape = Convex::Swept {
                    a: a.a,
                    e1: a.b - a.a,
                    e2: b.a - a.a,
                };
                for ob in self.obstacles {
                    let t = a.radius + margin;
                    if within(&shape, &ob.solid, t) {
                        // Where along the move: the shortest prefix of the
                        // sweep that already collides.
                        let (mut lo, mut hi) = (0.0, 1.0);
                        for _ in 0..30 {
                            let mid = 0.5 * (lo + hi);
                            let part = Convex::Swept {
                                a: a.a,
                                e1: a.b - a.a,
                                e2: (b.a - a.a) * mid,
                            };
                            if within(&part, &ob.solid, t) {
                                hi = mid;
                            } else {
                                lo = mid;
                            }
                        }
                        return Err(Collision {
                            part: a.part,
                            obstacle: ob.name.clone(),
                            at: Axes {
                                xyz: from.xyz + (to.xyz - from.xyz) * hi,
                                ..*from
                            },
                            margin,
                        });
                    }
                }
            }
            return Ok(());
        }
        let lerp = |s: f64| Axes {
            xyz: from.xyz + (to.xyz - from.xyz) * s,
            tilt: from.tilt + (to.tilt - from.tilt) * s,
            c: from.c + (to.c - from.c) * s,
        };
        let travel = |n: usize| -> (Vec<[Capsule; 4]>, f64) {
            let caps: Vec<[Capsule; 4]> = (0..=n)
                .map(|i| self.capsules_at(&lerp(i as f64 / n as f64)))
                .collect();
            let mut worst = 0.0_f64;
            for w in caps.windows(2) {
                for (p, q) in w[0].iter().zip(&w[1]) {
                    worst = worst.max((p.a - q.a).norm()).max((p.b - q.b).norm());
                }
            }
            (caps, worst)
        };
        let (mut caps, worst) = travel(16);
        let mut n = 16;
        if worst > SAMPLE_TRAVEL {
            n = ((16.0 * worst / SAMPLE_TRAVEL).ceil() as usize).max(17);
            caps = travel(n).0;
        }
        // Between samples a point travels at most `worst'` along an arc,
        // so it stays within about half of that of one of the samples.
        let grow = 0.55 * SAMPLE_TRAVEL;
        for (i, set) in caps.iter().enumerate() {
            for cap in set {
                let (cc, cr) = (
                    (cap.a + cap.b) / 2.0,
                    (cap.b - cap.a).norm() / 2.0 + cap.radius,
                );
                for ob in self.obstacles {
                    let (oc, or) = ob.solid.bounding_ball();
                    if (cc - oc).norm() > cr + or + margin + grow {
                        continue;
                    }
                    let shape = Convex::Segment(cap.a, cap.b);
                    if within(&shape, &ob.solid, cap.radius + margin + grow) {
                        return Err(Collision {
                            part: cap.part,
                            obstacle: ob.name.clone(),
                            at: lerp(i as f64 / n as f64),
                            margin,
                        });
                    }
                }
            }
        }
        Ok(())
    }
}

/// The moving side of a distance query.
#[derive(Clone, Copy, Debug)]
enum Convex {
    /// A segment.
    Segment(Vector3<f64>, Vector3<f64>),
    /// The parallelogram `a + s e1 + t e2`, s, t in [0, 1]: a segment swept
    /// along a straight move.
    Swept {
        a: Vector3<f64>,
        e1: Vector3<f64>,
        e2: Vector3<f64>,
    },
    /// [`Convex::Swept`] grown by a disc of `radius` normal to `e1`: a
    /// flat-ended cylinder about the segment swept along a straight move.
    SweptDisc {
        a: Vector3<f64>,
        e1: Vector3<f64>,
        e2: Vector3<f64>,
        radius: f64,
    },
}

impl Convex {
    fn support(&self, d: &Vector3<f64>) -> Vector3<f64> {
        match self {
            Convex::Segment(a, b) => {
                if d.dot(b) > d.dot(a) {
                    *b
                } else {
                    *a
                }
            }
            Convex::Swept { a, e1, e2 } => {
                let mut p = *a;
                if d.dot(e1) > 0.0 {
                    p += e1;
                }
                if d.dot(e2) > 0.0 {
                    p += e2;
                }
                p
            }
            Convex::SweptDisc { a, e1, e2, radius } => {
                let u = e1.normalize();
                let radial = d - u * u.dot(d);
                let n = radial.norm();
                let disc = if n > 1e-12 {
                    radial * (radius / n)
                } else {
                    Vector3::zeros()
                };
                Convex::Swept {
                    a: *a,
                    e1: *e1,
                    e2: *e2,
                }
                .support(d)
                    + disc
            }
        }
    }
}

/// Whether the cylinder of `radius` about the segment from `a` to `a + e1`
/// (flat ends), swept along the straight move `e2`, comes within
/// `threshold` of `solid`: a tool holder or spindle nose along a cutting
/// move (the machining tests check theirs with it).
pub(crate) fn swept_within(
    a: Vector3<f64>,
    e1: Vector3<f64>,
    e2: Vector3<f64>,
    radius: f64,
    solid: &ConvexSolid,
    threshold: f64,
) -> bool {
    within(&Convex::SweptDisc { a, e1, e2, radius }, solid, threshold)
}

/// The distance between the swept cylinder of [`swept_within`] and
/// `solid`, to within `tol` mm, 0 when they meet: bisection on the
/// threshold GJK decides, so it inherits its safe side (never larger than
/// the true distance by more than `tol`).
pub(crate) fn swept_distance(
    a: Vector3<f64>,
    e1: Vector3<f64>,
    e2: Vector3<f64>,
    radius: f64,
    solid: &ConvexSolid,
    tol: f64,
) -> f64 {
    if swept_within(a, e1, e2, radius, solid, 0.0) {
        return 0.0;
    }
    // The centre of the solid's bounding ball lies inside every solid
    // here (box, ball and cylinder are symmetric about it), so `a` is no
    // farther than that from the solid.
    let (centre, _) = solid.bounding_ball();
    let (mut lo, mut hi) = (0.0, (a - centre).norm());
    while hi - lo > tol {
        let mid = 0.5 * (lo + hi);
        if swept_within(a, e1, e2, radius, solid, mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}

/// Whether the distance between `a` and `b` is at most `threshold` (GJK on
/// the Minkowski difference, stopping as soon as the bounds decide; when
/// it cannot decide within its iterations it answers yes, the safe side).
fn within(a: &Convex, b: &ConvexSolid, threshold: f64) -> bool {
    within_by(a, b, threshold, closest_on_simplex)
}

/// [`within`] with the simplex step `closest` (the tests pass the heap
/// version this module had before).
fn within_by(
    a: &Convex,
    b: &ConvexSolid,
    threshold: f64,
    closest: impl Fn(&[Vector3<f64>]) -> (Vector3<f64>, Simplex),
) -> bool {
    let support = |d: &Vector3<f64>| a.support(d) - b.support(&-d);
    let mut v = support(&Vector3::x());
    let mut simplex = Simplex::of(&[v]);
    for _ in 0..64 {
        let vn = v.norm();
        if vn <= threshold {
            return true;
        }
        let w = support(&-v);
        // Every point k of the difference has v.k >= v.w, so the distance
        // is at least v.w / |v|.
        let lower = v.dot(&w) / vn;
        if lower > threshold {
            return false;
        }
        if vn - lower <= 1e-9 * (1.0 + vn) {
            return vn <= threshold;
        }
        if simplex
            .points()
            .iter()
            .any(|p| (p - w).norm() <= 1e-12 * (1.0 + w.norm()))
        {
            return vn <= threshold + 1e-9;
        }
        if simplex.len == 4 {
            // The nearest point was inside a tetrahedron: the sets meet
            // (what is left of `v` is rounding). Space holds no fifth
            // independent direction.
            return true;
        }
        simplex.push(w);
        let (p, kept) = closest(simplex.points());
        simplex = kept;
        v = p;
        if v.norm() < 1e-12 {
            return true;
        }
    }
    true
}

/// Up to four points, on the stack: a planned grid runs this test a
/// million times, and heap simplices cost more than the geometry.
#[derive(Clone, Copy, Debug)]
struct Simplex {
    pts: [Vector3<f64>; 4],
    len: usize,
}

impl Simplex {
    fn of(pts: &[Vector3<f64>]) -> Simplex {
        let mut s = Simplex {
            pts: [Vector3::zeros(); 4],
            len: 0,
        };
        for p in pts {
            s.push(*p);
        }
        s
    }

    fn push(&mut self, p: Vector3<f64>) {
        self.pts[self.len] = p;
        self.len += 1;
    }

    fn points(&self) -> &[Vector3<f64>] {
        &self.pts[..self.len]
    }

    /// The points of `s` that `mask` marks, in order.
    fn subset(s: &[Vector3<f64>], mask: u32) -> Simplex {
        let mut out = Simplex::of(&[]);
        for (i, p) in s.iter().enumerate() {
            if mask & (1 << i) != 0 {
                out.push(*p);
            }
        }
        out
    }
}

/// The point of the convex hull of `s` (up to four points) nearest the
/// origin, and the smallest subset of `s` whose hull contains it.
fn closest_on_simplex(s: &[Vector3<f64>]) -> (Vector3<f64>, Simplex) {
    let n = s.len();
    let mut best: Option<(f64, Vector3<f64>, u32)> = None;
    for mask in 1u32..(1 << n) {
        let Some(p) = affine_closest(Simplex::subset(s, mask).points()) else {
            continue;
        };
        let d = p.norm();
        if best.as_ref().is_none_or(|b| d < b.0 - 1e-15) {
            best = Some((d, p, mask));
        }
    }
    let (_, p, mask) = best.expect("single points always qualify");
    (p, Simplex::subset(s, mask))
}

/// The point of the affine hull of `pts` nearest the origin when it lies
/// inside their convex hull (all barycentric weights >= 0).
fn affine_closest(pts: &[Vector3<f64>]) -> Option<Vector3<f64>> {
    // The normal equations of the barycentric weights, k x k for k + 1
    // points; a fixed size per k keeps them off the heap (nalgebra's
    // determinant and LU are the same code at every size).
    macro_rules! closest {
        ($k:literal, $mat:ty, $vec:ty) => {{
            let p0 = pts[0];
            let e: [Vector3<f64>; $k] = std::array::from_fn(|i| pts[i + 1] - p0);
            let mut g = <$mat>::zeros();
            let mut rhs = <$vec>::zeros();
            for i in 0..$k {
                for j in 0..$k {
                    g[(i, j)] = e[i].dot(&e[j]);
                }
                rhs[i] = -e[i].dot(&p0);
            }
            let scale = (0..$k).map(|i| g[(i, i)]).fold(0.0, f64::max);
            let det = g.determinant();
            if scale == 0.0 || det.abs() <= 1e-12 * scale.powi($k) {
                return None;
            }
            let mu = g.lu().solve(&rhs)?;
            let l0 = 1.0 - mu.iter().sum::<f64>();
            if l0 < -1e-12 || mu.iter().any(|&m| m < -1e-12) {
                return None;
            }
            let mut p = p0;
            for i in 0..$k {
                p += e[i] * mu[i];
            }
            Some(p)
        }};
    }
    match pts.len() {
        1 => Some(pts[0]),
        2 => closest!(1, nalgebra::Matrix1<f64>, nalgebra::Vector1<f64>),
        3 => closest!(2, nalgebra::Matrix2<f64>, nalgebra::Vector2<f64>),
        4 => closest!(3, Matrix3<f64>, Vector3<f64>),
        n => unreachable!("a simplex in 3-D has at most four points, not {n}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The heap simplex step this module used before, kept as the
    /// reference: the stack version must take the same decisions to the bit.
    mod reference {
        use super::*;

        /// The GJK loop with the heap simplex step.
        pub(super) fn within(a: &Convex, b: &ConvexSolid, threshold: f64) -> bool {
            within_by(a, b, threshold, |s| {
                let (p, kept) = closest_on_simplex(s);
                (p, Simplex::of(&kept))
            })
        }

        pub(super) fn closest_on_simplex(s: &[Vector3<f64>]) -> (Vector3<f64>, Vec<Vector3<f64>>) {
            let n = s.len();
            let mut best: Option<(f64, Vector3<f64>, u32)> = None;
            for mask in 1u32..(1 << n) {
                let idx: Vec<usize> = (0..n).filter(|i| mask & (1 << i) != 0).collect();
                let Some(p) = affine_closest(&idx.iter().map(|&i| s[i]).collect::<Vec<_>>()) else {
                    continue;
                };
                let d = p.norm();
                if best.as_ref().is_none_or(|b| d < b.0 - 1e-15) {
                    best = Some((d, p, mask));
                }
            }
            let (_, p, mask) = best.expect("single points always qualify");
            let kept = (0..n)
                .filter(|i| mask & (1 << i) != 0)
                .map(|i| s[i])
                .collect();
            (p, kept)
        }

        fn affine_closest(pts: &[Vector3<f64>]) -> Option<Vector3<f64>> {
            let p0 = pts[0];
            let k = pts.len() - 1;
            if k == 0 {
                return Some(p0);
            }
            let e: Vec<Vector3<f64>> = pts[1..].iter().map(|p| p - p0).collect();
            let mut g = nalgebra::DMatrix::<f64>::zeros(k, k);
            let mut rhs = nalgebra::DVector::<f64>::zeros(k);
            for i in 0..k {
                for j in 0..k {
                    g[(i, j)] = e[i].dot(&e[j]);
                }
                rhs[i] = -e[i].dot(&p0);
            }
            let scale = (0..k).map(|i| g[(i, i)]).fold(0.0, f64::max);
            let det = g.determinant();
            if scale == 0.0 || det.abs() <= 1e-12 * scale.powi(k as i32) {
                return None;
            }
            let mu = g.lu().solve(&rhs)?;
            let l0 = 1.0 - mu.iter().sum::<f64>();
            if l0 < -1e-12 || mu.iter().any(|&m| m < -1e-12) {
                return None;
            }
            let mut p = p0;
            for i in 0..k {
                p += e[i] * mu[i];
            }
            Some(p)
        }
    }

    #[test]
    fn the_stack_simplex_decides_as_the_heap_one_did_to_the_bit() {
        use rand::{RngExt, SeedableRng};
        let mut r = rand::rngs::StdRng::seed_from_u64(52);
        let v = |r: &mut rand::rngs::StdRng, s: f64| {
            Vector3::new(
                r.random_range(-s..s),
                r.random_range(-s..s),
                r.random_range(-s..s),
            )
        };
        let solids = [
            unit_box(),
            ConvexSolid::Cylinder {
                a: Vector3::new(0.0, 0.0, -1.0),
                b: Vector3::new(0.5, 0.0, 3.0),
                radius: 2.0,
            },
            ConvexSolid::Ball {
                centre: Vector3::new(1.0, 0.0, 2.0),
                radius: 1.5,
            },
        ];
        let (mut yes, mut no) = (0, 0);
        for i in 0..3000 {
            let a = v(&mut r, 6.0);
            let shape = if i % 2 == 0 {
                Convex::Segment(a, a + v(&mut r, 4.0))
            } else {
                Convex::Swept {
                    a,
                    e1: v(&mut r, 3.0),
                    e2: v(&mut r, 5.0),
                }
            };
            let t = r.random_range(0.0..2.0);
            for b in &solids {
                let got = within(&shape, b, t);
                assert_eq!(
                    got,
                    reference::within(&shape, b, t),
                    "case {i}: {shape:?}, {t}"
                );
                if got { yes += 1 } else { no += 1 }
            }
            // The nearest point and the simplex kept, to the bit.
            let pts: Vec<Vector3<f64>> = (0..1 + i % 4).map(|_| v(&mut r, 3.0)).collect();
            let (p, kept) = closest_on_simplex(&pts);
            let (q, kept_ref) = reference::closest_on_simplex(&pts);
            assert_eq!(p, q, "case {i}");
            assert_eq!(kept.points(), kept_ref.as_slice(), "case {i}");
        }
        // Both answers are exercised.
        assert!(yes > 1000 && no > 1000, "{yes} within, {no} apart");
    }

    fn unit_box() -> ConvexSolid {
        ConvexSolid::Cuboid {
            centre: Vector3::zeros(),
            axes: Matrix3::identity(),
            half: Vector3::new(1.0, 2.0, 3.0),
        }
    }

    #[test]
    fn overlapping_sets_are_within_a_zero_threshold_and_the_simplex_stops_at_four_points() {
        // Sets that overlap have distance zero: within at a zero threshold.
        // The simplex may then enclose the origin, and the search must stop
        // there rather than grow it past what space holds.
        use rand::{RngExt, SeedableRng};
        let mut r = rand::rngs::StdRng::seed_from_u64(53);
        let mut v = |s: f64| {
            Vector3::new(
                r.random_range(-s..s),
                r.random_range(-s..s),
                r.random_range(-s..s),
            )
        };
        for i in 0..3000 {
            // Through the box: from a point inside it, both ways.
            let inside = v(0.9);
            let d = v(4.0);
            let shape = if i % 2 == 0 {
                Convex::Segment(inside - d, inside + d)
            } else {
                Convex::Swept {
                    a: inside - d,
                    e1: d * 2.0,
                    e2: v(3.0),
                }
            };
            for t in [0.0, 1e-12] {
                assert!(within(&shape, &unit_box(), t), "case {i}: {shape:?} at {t}");
            }
        }
        // A step that keeps four points while what is left of the nearest
        // point is more than the threshold (rounding far from the origin):
        // the search stops there, within, rather than take a fifth point.
        let four = |s: &[Vector3<f64>]| (Vector3::new(1e-6, 0.0, 0.0), Simplex::of(&[s[0]; 4]));
        let through = Convex::Segment(Vector3::new(-5.0, 0.1, 0.2), Vector3::new(5.0, 0.1, 0.2));
        assert!(within_by(&through, &unit_box(), 0.0, four));
    }

    #[test]
    fn segment_box_distance_decisions_match_the_exact_distance() {
        // A segment parallel to Z at x = 1 + g: distance to the box is g.
        for g in [0.5, 0.999, 1.001, 2.0] {
            let s = Convex::Segment(
                Vector3::new(1.0 + g, 0.0, -1.0),
                Vector3::new(1.0 + g, 0.0, 1.0),
            );
            assert_eq!(within(&s, &unit_box(), 1.0), g <= 1.0, "gap {g}");
        }
        // A segment passing the box's top corner (1, 2, 3) diagonally, at
        // the corner's height: the nearest point is (2, 3, 3), sqrt(2) away.
        let s = Convex::Segment(Vector3::new(0.0, 5.0, 3.0), Vector3::new(5.0, 0.0, 3.0));
        let d = std::f64::consts::SQRT_2;
        assert!(within(&s, &unit_box(), d + 1e-6));
        assert!(!within(&s, &unit_box(), d - 1e-6));
    }

    #[test]
    fn swept_segment_catches_a_box_between_its_ends() {
        // The segment starts left of the box and ends right of it: neither
        // end position touches, the sweep does.
        let shape = Convex::Swept {
            a: Vector3::new(-5.0, 0.0, 0.0),
            e1: Vector3::new(0.0, 0.0, 1.0),
            e2: Vector3::new(10.0, 0.0, 0.0),
        };
        assert!(within(&shape, &unit_box(), 0.1));
        let above = Convex::Swept {
            a: Vector3::new(-5.0, 0.0, 3.5),
            e1: Vector3::new(0.0, 0.0, 1.0),
            e2: Vector3::new(10.0, 0.0, 0.0),
        };
        assert!(!within(&above, &unit_box(), 0.4));
        assert!(within(&above, &unit_box(), 0.6));
    }

    #[test]
    fn swept_distance_matches_the_closed_form_of_a_nose_over_a_disc_and_a_holder_above_a_box() {
        // A horizontal nose of radius 20 with its axis 37 mm above a disc
        // of radius 125 (top at z = 0), reaching over the rim from x = 107
        // and swept 20 mm along Y: 37 - 20 = 17 mm between them. Moved
        // beyond the rim to x = 135 its flat end faces the rim at
        // (125, 0, 0): the nearest point of the end disc is (135, 0, 17),
        // hypot(10, 17) away.
        let disc = ConvexSolid::Cylinder {
            a: Vector3::new(0.0, 0.0, -50.0),
            b: Vector3::zeros(),
            radius: 125.0,
        };
        let e1 = Vector3::new(150.0, 0.0, 0.0);
        let e2 = Vector3::new(0.0, 20.0, 0.0);
        let over = swept_distance(Vector3::new(107.0, -10.0, 37.0), e1, e2, 20.0, &disc, 1e-6);
        assert!((over - 17.0).abs() < 1e-5, "{over}");
        let beyond = swept_distance(Vector3::new(135.0, 0.0, 37.0), e1, e2, 20.0, &disc, 1e-6);
        assert!((beyond - 10.0_f64.hypot(17.0)).abs() < 1e-5, "{beyond}");
        assert!(swept_within(
            Vector3::new(107.0, 0.0, 37.0),
            e1,
            e2,
            20.0,
            &disc,
            17.001
        ));
        assert!(!swept_within(
            Vector3::new(107.0, 0.0, 37.0),
            e1,
            e2,
            20.0,
            &disc,
            16.999
        ));
        let through = swept_distance(Vector3::new(107.0, 0.0, 19.0), e1, e2, 20.0, &disc, 1e-6);
        assert_eq!(through, 0.0);
        // A vertical holder of radius 31.5 whose flat end is 20 mm above
        // the top of a box it overhangs: 20 mm, not the 20 - 31.5 a
        // rounded end would give.
        let block = ConvexSolid::Cuboid {
            centre: Vector3::new(0.0, 0.0, 50.0),
            axes: Matrix3::identity(),
            half: Vector3::new(50.0, 50.0, 50.0),
        };
        let up = Vector3::new(0.0, 0.0, 35.0);
        let run = Vector3::new(0.0, -88.4, 0.0);
        let holder = swept_distance(Vector3::new(44.2, 44.2, 120.0), up, run, 31.5, &block, 1e-6);
        assert!((holder - 20.0).abs() < 1e-5, "{holder}");
    }

    #[test]
    fn cylinder_and_ball_supports_give_exact_distances() {
        let cyl = ConvexSolid::Cylinder {
            a: Vector3::new(0.0, 0.0, -1.0),
            b: Vector3::new(0.0, 0.0, 1.0),
            radius: 2.0,
        };
        let p = Convex::Segment(Vector3::new(3.0, 4.0, 0.0), Vector3::new(3.0, 4.0, 0.0));
        assert!(within(&p, &cyl, 3.0 + 1e-6));
        assert!(!within(&p, &cyl, 3.0 - 1e-6));
        let ball = ConvexSolid::Ball {
            centre: Vector3::new(0.0, 0.0, 10.0),
            radius: 2.0,
        };
        let q = Convex::Segment(Vector3::new(0.0, -5.0, 14.0), Vector3::new(0.0, 5.0, 14.0));
        assert!(within(&q, &ball, 2.0 + 1e-6));
        assert!(!within(&q, &ball, 2.0 - 1e-6));
    }
}
