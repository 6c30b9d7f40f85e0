//! Rigid-body geometry shared by every module: the elementary homogeneous
//! transforms of docs/model.md (`Dx`, `Dy`, `Dz`, `Da`, `Db`, `Dc` and their
//! product `D`), unit conversions between the mm/deg of NC programs and the
//! um/urad of error files, and small vector helpers.
//!
//! Transforms are `nalgebra::Isometry3<f64>` rather than raw 4x4 matrices so
//! that products stay exactly rigid; the HTM of docs/model.md is
//! `iso.to_homogeneous()`.

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};

/// The parameter `t` in 0..1 of the point of segment `a`-`b` nearest `p`
/// (0 for a segment of no length).
pub(crate) fn nearest_on_segment(p: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    let d = b - a;
    let l2 = d.norm_squared();
    if l2 > 0.0 {
        ((p - a).dot(&d) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Millimetres per micrometre.
pub(crate) const MM_PER_UM: f64 = 1e-3;
/// Radians per microradian.
pub(crate) const RAD_PER_URAD: f64 = 1e-6;

/// A coordinate axis of a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Axis3 {
    /// X
    X,
    /// Y
    Y,
    /// Z
    Z,
}

impl Axis3 {
    /// Unit vector along the axis.
    pub fn unit(self) -> Vector3<f64> {
        match self {
            Axis3::X => Vector3::x(),
            Axis3::Y => Vector3::y(),
            Axis3::Z => Vector3::z(),
        }
    }

    /// Index 0, 1, 2.
    pub fn index(self) -> usize {
        match self {
            Axis3::X => 0,
            Axis3::Y => 1,
            Axis3::Z => 2,
        }
    }

    /// The axis with index 0, 1 or 2.
    pub(crate) fn from_index(i: usize) -> Axis3 {
        match i {
            0 => Axis3::X,
            1 => Axis3::Y,
            _ => Axis3::Z,
        }
    }

    /// Letter of the linear axis (`X`, `Y`, `Z`).
    pub fn letter(self) -> char {
        ['X', 'Y', 'Z'][self.index()]
    }

    /// Letter of the rotation about this axis (`A`, `B`, `C`).
    pub(crate) fn rot_letter(self) -> char {
        ['A', 'B', 'C'][self.index()]
    }
}

/// Translation along `axis` by `v` (mm): `Dx`, `Dy` or `Dz`.
pub(crate) fn trans(axis: Axis3, v: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::from(axis.unit() * v),
        UnitQuaternion::identity(),
    )
}

/// Right-handed rotation about `axis` by `a` (rad): `Da`, `Db` or `Dc`.
pub fn rot(axis: Axis3, a: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_unchecked(axis.unit()), a),
    )
}

/// `D(dx,dy,dz,a,b,c) = Dx Dy Dz Da Db Dc` of docs/model.md (mm, rad).
pub fn d6(t: &[f64; 6]) -> Isometry3<f64> {
    trans(Axis3::X, t[0])
        * trans(Axis3::Y, t[1])
        * trans(Axis3::Z, t[2])
        * rot(Axis3::X, t[3])
        * rot(Axis3::Y, t[4])
        * rot(Axis3::Z, t[5])
}

/// Applies an isometry to a point given as a vector.
pub fn apply(iso: &Isometry3<f64>, p: &Vector3<f64>) -> Vector3<f64> {
    (iso * Point3::from(*p)).coords
}

/// Degrees to radians.
pub fn rad(deg: f64) -> f64 {
    deg.to_radians()
}

/// Radians to degrees.
pub fn deg(rad: f64) -> f64 {
    rad.to_degrees()
}

/// Wraps an angle in degrees into `(-180, 180]`.
pub(crate) fn wrap180(a: f64) -> f64 {
    // Within a turn of zero, what `rem_euclid` gives (the same bits)
    // without its `fmod`, a few percent of compensate's rewriting thread.
    let mut r = if (0.0..360.0).contains(&a) {
        a
    } else if a > -360.0 && a < 0.0 {
        a + 360.0
    } else {
        a.rem_euclid(360.0)
    };
    if r > 180.0 {
        r -= 360.0;
    }
    r
}

/// The turn of `angle` (deg) nearest `reference` that lies within
/// `limits` (none: an axis that turns without end), if any: a rotary axis
/// reaches an orientation at every turn its stroke holds, and the program
/// that `reference` comes from meant the nearest.
pub(crate) fn nearest_turn(angle: f64, reference: f64, limits: Option<(f64, f64)>) -> Option<f64> {
    let base = reference + wrap180(angle - reference);
    match limits {
        None => Some(base),
        // Every other turn is more than half a turn from the reference when
        // the base is within 179 deg of it (a degree clear of round-off),
        // so a reachable base is the answer: the search below, run on
        // every IK solution, took a few percent of compensate.
        Some((lo, hi))
            if base >= lo - 1e-9 && base <= hi + 1e-9 && (base - reference).abs() < 179.0 =>
        {
            Some(base)
        }
        Some((lo, hi)) => (-3..=3)
            .map(|k| base + 360.0 * k as f64)
            .filter(|&x| x >= lo - 1e-9 && x <= hi + 1e-9)
            .min_by(|a, b| (a - reference).abs().total_cmp(&(b - reference).abs())),
    }
}

/// Two unit vectors orthogonal to `u` and to each other (a tangent basis).
pub(crate) fn tangent_basis(u: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let helper = if u.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let b1 = u.cross(&helper).normalize();
    let b2 = u.cross(&b1);
    (b1, b2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn d6_is_the_product_of_the_six_elementary_transforms() {
        let t = [1.0, -2.0, 3.0, 0.1, -0.2, 0.3];
        let m = d6(&t).to_homogeneous();
        let (ca, sa) = (t[3].cos(), t[3].sin());
        let (cb, sb) = (t[4].cos(), t[4].sin());
        let (cc, sc) = (t[5].cos(), t[5].sin());
        let rx = nalgebra::Matrix3::new(1.0, 0.0, 0.0, 0.0, ca, -sa, 0.0, sa, ca);
        let ry = nalgebra::Matrix3::new(cb, 0.0, sb, 0.0, 1.0, 0.0, -sb, 0.0, cb);
        let rz = nalgebra::Matrix3::new(cc, -sc, 0.0, sc, cc, 0.0, 0.0, 0.0, 1.0);
        let r = rx * ry * rz;
        for i in 0..3 {
            for j in 0..3 {
                assert!((m[(i, j)] - r[(i, j)]).abs() < 1e-15);
            }
            assert!((m[(i, 3)] - t[i]).abs() < 1e-15);
        }
    }

    #[test]
    fn nearest_turn_is_the_reachable_turn_closest_to_the_reference() {
        // A stroke of two turns reaches A = 180 at -180 too; the program
        // coming from -179.5 means -180.
        assert_eq!(
            nearest_turn(180.0, -179.5, Some((-360.0, 360.0))),
            Some(-180.0)
        );
        // A tilt of -120..30 reaches 170 at no turn.
        assert_eq!(nearest_turn(170.0, 20.0, Some((-120.0, 30.0))), None);
        // Inside a stroke of less than a turn, the angle itself.
        assert_eq!(nearest_turn(-90.0, 0.0, Some((-120.0, 30.0))), Some(-90.0));
        // Without limits, the turn of the reference.
        assert_eq!(nearest_turn(1.0, 725.0, None), Some(721.0));
        // At the stroke's end the nearer reachable turn, not the nearest.
        assert_eq!(
            nearest_turn(-350.0, 355.0, Some((-360.0, 360.0))),
            Some(10.0)
        );
    }

    #[test]
    fn nearest_turn_is_the_search_over_seven_turns_to_the_bit() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let search = |angle: f64, reference: f64, (lo, hi): (f64, f64)| {
            let base = reference + wrap180(angle - reference);
            (-3..=3)
                .map(|k| base + 360.0 * k as f64)
                .filter(|&x| x >= lo - 1e-9 && x <= hi + 1e-9)
                .min_by(|a, b| (a - reference).abs().total_cmp(&(b - reference).abs()))
        };
        let strokes = [
            (-360.0, 360.0),
            (-120.0, 30.0),
            (-99999.0, 99999.0),
            (0.0, 360.0),
        ];
        for _ in 0..20_000 {
            let limits = strokes[rng.random_range(0..strokes.len())];
            let reference = rng.random_range(-400.0..400.0);
            // Near half a turn away as often as anywhere.
            let angle = if rng.random_bool(0.5) {
                reference
                    + 180.0 * if rng.random_bool(0.5) { 1.0 } else { -1.0 }
                    + rng.random_range(-2.0..2.0)
            } else {
                rng.random_range(-400.0..400.0)
            };
            let want = search(angle, reference, limits);
            let got = nearest_turn(angle, reference, Some(limits));
            assert_eq!(
                got.map(f64::to_bits),
                want.map(f64::to_bits),
                "{angle} {reference} {limits:?}"
            );
        }
        // Exactly half a turn away, two turns tie: the first of the search's.
        for (angle, reference) in [(180.0, 0.0), (-180.0, 0.0), (90.0, -90.0), (10.0, 190.0)] {
            for limits in strokes {
                let want = search(angle, reference, limits);
                let got = nearest_turn(angle, reference, Some(limits));
                assert_eq!(got, want, "{angle} {reference} {limits:?}");
            }
        }
    }

    #[test]
    fn wrap180_within_a_turn_is_rem_euclid_to_the_bit() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(360);
        let edges: [f64; 8] = [
            0.0,
            -0.0,
            360.0,
            -360.0,
            180.0,
            -180.0,
            359.99999999999994,
            -1e-300,
        ];
        let random = (0..10_000).map(|_| rng.random_range(-400.0..400.0));
        for a in edges.into_iter().chain(random) {
            let mut want = a.rem_euclid(360.0);
            if want > 180.0 {
                want -= 360.0;
            }
            assert_eq!(wrap180(a).to_bits(), want.to_bits(), "{a}");
        }
    }

    #[test]
    fn wrap180_maps_into_half_open_interval() {
        assert_eq!(wrap180(190.0), -170.0);
        assert_eq!(wrap180(-180.0), 180.0);
        assert_eq!(wrap180(540.0), 180.0);
        assert_eq!(wrap180(-10.0), -10.0);
    }
}
