//! HEIDENHAIN `RND R..` and `CHF ..` between two straight lines: the
//! controller cuts the corner the lines meet at. A rounding is the arc of
//! radius R tangent to both lines, a chamfer the straight line between the
//! points at the chamfer's side length from the corner along each line;
//! the corner point itself is not part of the path. Both lie in the XY
//! plane; an axis the lines also move (Z, by the micrometres a correction
//! adds) moves linearly between the two points where the element meets
//! the lines.

use super::interpolation::{ArcGeo, Path, lerp};

/// What cuts the corner.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CornerKind {
    /// `RND R..`: a tangent arc of this radius.
    Round(f64),
    /// `CHF ..`: a chamfer of this side length.
    Chamfer(f64),
}

/// A corner the controller rounds or chamfers, carried by the move after
/// it: the line before runs from `from` to the corner `at` (program
/// coordinates, absolute), the move carrying it from `at` on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Corner {
    /// 1-based line of the `RND`/`CHF` block.
    pub line: usize,
    /// Rounding or chamfer.
    pub kind: CornerKind,
    /// Start of the line before the corner.
    pub from: [f64; 6],
    /// The corner.
    pub at: [f64; 6],
}

/// Largest difference of Z (program units times `mm`, mm) or of a rotary
/// axis (deg) over the three points for which a corner is still taken to
/// lie in the XY plane: the micrometres a correction tilts a flat contour
/// by, never a contour that climbs.
const PLANE_MM: f64 = 0.01;
const PLANE_DEG: f64 = 0.001;

/// The element the controller puts at the corner `p` of the line from `a`
/// and the line to `b`: where it meets the first line (fraction of it),
/// where it meets the second (fraction), and its path. Refused, with the
/// reason, where the controller would refuse it or where fivecal does not
/// know what it does: lines that do not lie in the XY plane, that meet in
/// a straight line or turn back, or that are too short for the element.
pub fn corner_path(
    a: &[f64; 6],
    p: &[f64; 6],
    b: &[f64; 6],
    kind: CornerKind,
    mm: f64,
) -> Result<(f64, f64, Path), &'static str> {
    let flat = |i: usize, lim: f64| {
        if a[i].is_nan() && p[i].is_nan() && b[i].is_nan() {
            // An axis the machine does not have.
            return true;
        }
        let (lo, hi) = [a[i], p[i], b[i]]
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                (l.min(v), h.max(v))
            });
        hi - lo <= lim
    };
    if !(flat(2, PLANE_MM / mm) && (3..6).all(|i| flat(i, PLANE_DEG))) {
        return Err("the lines around it do not lie in the XY plane (Z or a rotary axis moves)");
    }
    let (l1, l2) = (
        (p[0] - a[0]).hypot(p[1] - a[1]),
        (b[0] - p[0]).hypot(b[1] - p[1]),
    );
    if !(l1 > 0.0 && l2 > 0.0) {
        return Err("a line next to it has no length in the XY plane");
    }
    let d1 = [(p[0] - a[0]) / l1, (p[1] - a[1]) / l1];
    let d2 = [(b[0] - p[0]) / l2, (b[1] - p[1]) / l2];
    let cross = d1[0] * d2[1] - d1[1] * d2[0];
    let dot = d1[0] * d2[0] + d1[1] * d2[1];
    // The turn from the first line's direction to the second's.
    let turn = cross.atan2(dot);
    if turn.abs() < 1e-9 || turn.abs() > std::f64::consts::PI - 1e-9 {
        return Err("the lines meet in a straight line or turn back");
    }
    let (s1, s2) = match kind {
        CornerKind::Round(r) => {
            let t = r.abs() * (turn.abs() / 2.0).tan();
            (t, t)
        }
        CornerKind::Chamfer(c) => (c.abs(), c.abs()),
    };
    if s1.is_nan() || s1 <= 0.0 {
        return Err("its radius or length is zero");
    }
    if s1 > l1 * (1.0 + 1e-12) || s2 > l2 * (1.0 + 1e-12) {
        return Err("it does not fit between the lines (a line is shorter than the element needs)");
    }
    let (f1, f2) = (1.0 - s1 / l1, s2 / l2);
    let t1 = lerp(a, p, f1);
    let t2 = lerp(p, b, f2);
    let path = match kind {
        CornerKind::Chamfer(_) => Path::Line { p0: t1, p1: t2 },
        CornerKind::Round(r) => {
            // The centre lies on the inside of the turn, R from the first
            // line at its tangent point.
            let r = r.abs();
            let side = turn.signum();
            let center = [t1[0] - side * d1[1] * r, t1[1] + side * d1[0] * r];
            let geo = ArcGeo::new((0, 1, 2), center, &t1, &t2, turn < 0.0, 0);
            Path::Arc {
                p0: t1,
                p1: t2,
                geo,
            }
        }
    };
    Ok((f1, f2, path))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rounding_is_tangent_to_both_lines_at_its_radius() {
        // A right-angle corner at (40, 25) from (10, 40), then to (10, 5):
        // the arc of R5 meets each line 5 tan(angle/2) from the corner.
        let a = [10.0, 40.0, -1.0, 0.0, 0.0, 0.0];
        let p = [40.0, 25.0, -1.0, 0.0, 0.0, 0.0];
        let b = [10.0, 5.0, -1.0, 0.0, 0.0, 0.0];
        let (f1, f2, path) = corner_path(&a, &p, &b, CornerKind::Round(5.0), 1.0).unwrap();
        let Path::Arc { p0, p1, geo } = path else {
            panic!("an arc")
        };
        let d1 = [(p[0] - a[0]), (p[1] - a[1])];
        let d2 = [(b[0] - p[0]), (b[1] - p[1])];
        let turn = (d1[0] * d2[1] - d1[1] * d2[0]).atan2(d1[0] * d2[0] + d1[1] * d2[1]);
        let t = 5.0 * (turn.abs() / 2.0).tan();
        let dist = |q: &[f64; 6]| (q[0] - p[0]).hypot(q[1] - p[1]);
        assert!((dist(&p0) - t).abs() < 1e-12 && (dist(&p1) - t).abs() < 1e-12);
        assert!((f1 - (1.0 - t / d1[0].hypot(d1[1]))).abs() < 1e-12 && f2 > 0.0);
        // Radius 5 at both ends, the centre square to each line from its
        // tangent point (finite differences of the arc give the tangent).
        assert!((geo.rs - 5.0).abs() < 1e-12 && (geo.re - 5.0).abs() < 1e-12);
        for (u, dir) in [(0.0, d1), (1.0, d2)] {
            let h = 1e-7;
            let (q0, q1) = if u == 0.0 {
                (path.at(0.0), path.at(h))
            } else {
                (path.at(1.0 - h), path.at(1.0))
            };
            let tang = [(q1[0] - q0[0]) / h, (q1[1] - q0[1]) / h];
            let n = dir[0].hypot(dir[1]);
            let cos = (tang[0] * dir[0] + tang[1] * dir[1]) / (tang[0].hypot(tang[1]) * n);
            assert!(cos > 1.0 - 1e-9, "tangent at {u}: cos {cos}");
        }
        // It cuts the corner: its middle is inside the turn, nearer the
        // corner than the centre.
        let m = path.at(0.5);
        let c = geo.center;
        assert!((m[0] - c[0]).hypot(m[1] - c[1]) - 5.0 < 1e-9);
        assert!((m[0] - p[0]).hypot(m[1] - p[1]) < (c[0] - p[0]).hypot(c[1] - p[1]));
    }

    #[test]
    fn a_chamfer_runs_between_the_points_at_its_side_length() {
        let a = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let p = [20.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let b = [20.0, 20.0, 0.0, 0.0, 0.0, 0.0];
        let (_, _, path) = corner_path(&a, &p, &b, CornerKind::Chamfer(2.0), 1.0).unwrap();
        assert_eq!(path.at(0.0)[..2], [18.0, 0.0]);
        assert_eq!(path.at(1.0)[..2], [20.0, 2.0]);
    }

    #[test]
    fn corners_the_controller_cannot_cut_are_refused() {
        let a = [0.0; 6];
        let p = [20.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let mut b = [20.0, 3.0, 0.0, 0.0, 0.0, 0.0];
        assert!(corner_path(&a, &p, &b, CornerKind::Round(5.0), 1.0).is_err());
        b[1] = 20.0;
        b[2] = -1.0;
        assert!(corner_path(&a, &p, &b, CornerKind::Round(5.0), 1.0).is_err());
        let straight = [40.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        assert!(corner_path(&a, &p, &straight, CornerKind::Chamfer(1.0), 1.0).is_err());
    }
}
