//! The exact solid of a cutting tool and of its sweep along a straight
//! move, for provenance (which move and which part of the tool made a
//! surface point) and for simulation (where an erroneous move leaves the
//! surface).
//!
//! Flat, ball and bull-nose end mills are all solids of revolution about the
//! tool axis whose meridian profile is a rounded rectangle: the core
//! `[0, R - r] x [r, H]` (radial, axial from the tip) grown by the corner
//! radius `r` (0 for a flat end mill, `R` for a ball). The signed distance
//! to such a solid is exact and convex along any line, and so is the
//! distance to its sweep along a straight move (a Minkowski sum with a
//! segment), which the searches below rely on.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::machine::{Tool, ToolKind};

/// Which part of the tool made a surface.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ToolPart {
    /// The cylindrical flank (side) of the tool.
    Flank,
    /// The flat end (a flat end mill's face, or a bull-nose's flat centre).
    FlatEnd,
    /// The ball of a ball end mill.
    Ball,
    /// The corner torus of a bull-nose end mill.
    Torus,
    /// The sharp corner edge of a flat end mill.
    Corner,
}

impl ToolPart {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            ToolPart::Flank => "flank",
            ToolPart::FlatEnd => "flat_end",
            ToolPart::Ball => "ball",
            ToolPart::Torus => "torus",
            ToolPart::Corner => "corner",
        }
    }
}

/// A tool's solid: radius, corner radius and length from the tip.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cutter {
    /// Radius, mm.
    pub radius: f64,
    /// Corner radius, mm (0 flat, `radius` ball).
    pub corner: f64,
    /// Length of the solid from the tip along the axis, mm.
    pub length: f64,
}

const GOLDEN: f64 = 0.618_033_988_749_894_9;

impl Cutter {
    /// The solid of a tool (its gauge length as the solid's length).
    pub fn of(tool: &Tool) -> Cutter {
        let radius = tool.diameter / 2.0;
        let corner = match tool.kind {
            ToolKind::Flat => 0.0,
            ToolKind::Ball => radius,
            ToolKind::Bull => tool.corner_radius.unwrap_or(0.0).min(radius),
        };
        Cutter {
            radius,
            corner,
            length: tool.length,
        }
    }

    /// Meridian coordinates (radial, axial from the tip) of `q`.
    fn meridian(&self, tip: &Vector3<f64>, axis: &Vector3<f64>, q: &Vector3<f64>) -> (f64, f64) {
        let d = q - tip;
        let zeta = d.dot(axis);
        let rho = (d - axis * zeta).norm();
        (rho, zeta)
    }

    /// Signed distance from `q` to the tool with its tip at `tip` and unit
    /// axis `axis` (tip towards spindle): negative inside, mm.
    pub fn signed_distance(
        &self,
        tip: &Vector3<f64>,
        axis: &Vector3<f64>,
        q: &Vector3<f64>,
    ) -> f64 {
        let (rho, zeta) = self.meridian(tip, axis, q);
        let r = self.corner;
        let w = self.radius - r;
        let cz = 0.5 * (r + self.length);
        let hz = 0.5 * (self.length - r);
        let dx = rho - w;
        let dz = (zeta - cz).abs() - hz;
        // hypot(x, 0) is |x| to the bit: beside or below the core, the
        // square root is skipped (this runs thousands of times per point).
        let outside = match (dx > 0.0, dz > 0.0) {
            (true, true) => dx.hypot(dz),
            (true, false) => dx,
            (false, true) => dz,
            (false, false) => 0.0,
        };
        let inside = dx.max(dz).min(0.0);
        outside + inside - r
    }

    /// The part of the tool nearest to `q`.
    pub(crate) fn part_at(
        &self,
        tip: &Vector3<f64>,
        axis: &Vector3<f64>,
        q: &Vector3<f64>,
    ) -> ToolPart {
        let (rho, zeta) = self.meridian(tip, axis, q);
        let r = self.corner;
        let w = self.radius - r;
        let c_rho = rho.min(w);
        let c_zeta = zeta.clamp(r, self.length);
        let at_bottom = c_zeta <= r;
        let at_side = c_rho >= w;
        match (at_bottom, at_side) {
            (true, false) => ToolPart::FlatEnd,
            (true, true) => {
                if r == 0.0 {
                    // On the end plane itself the face made it.
                    if zeta.abs() < 1e-9 && rho <= w + 1e-9 {
                        ToolPart::FlatEnd
                    } else if (rho - w).abs() < 1e-9 && zeta >= 0.0 {
                        ToolPart::Flank
                    } else {
                        ToolPart::Corner
                    }
                } else if w <= 0.0 {
                    ToolPart::Ball
                } else {
                    ToolPart::Torus
                }
            }
            _ => ToolPart::Flank,
        }
    }

    /// Whether the tool swept from tip `a` to tip `b` may come within
    /// `reach` of `q`: false only where its bounding box, inflated by the
    /// radius, is further than `reach` away, so that
    /// [`Cutter::swept_distance`] would exceed `reach` (a cheap test before
    /// the search).
    pub(crate) fn may_reach(
        &self,
        a: &Vector3<f64>,
        b: &Vector3<f64>,
        axis: &Vector3<f64>,
        q: &Vector3<f64>,
        reach: f64,
    ) -> bool {
        let pts = [a, b, &(a + axis * self.length), &(b + axis * self.length)];
        let mut lo = *pts[0];
        let mut hi = *pts[0];
        for p in pts {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        let r = Vector3::repeat(self.radius + 1e-6);
        let (lo, hi) = (lo - r, hi + r);
        (0..3).all(|i| q[i] + reach >= lo[i] && q[i] - reach <= hi[i])
    }

    /// Signed distance from `q` to the tool swept from tip `a` to tip `b`
    /// (constant axis), with the move parameter in [0, 1] where it is least.
    pub(crate) fn swept_distance(
        &self,
        a: &Vector3<f64>,
        b: &Vector3<f64>,
        axis: &Vector3<f64>,
        q: &Vector3<f64>,
    ) -> (f64, f64) {
        let ab = b - a;
        let f = |t: f64| self.signed_distance(&(a + ab * t), axis, q);
        if ab.norm() < 1e-12 {
            return (f(0.0), 0.0);
        }
        let (t, d) = golden_min(f, 0.0, 1.0, 70);
        // The ends are candidates too (the minimum of a convex function on
        // an interval may sit at an end, where golden search converges
        // only up to its tolerance).
        [(d, t), (f(0.0), 0.0), (f(1.0), 1.0)]
            .into_iter()
            .fold(
                (f64::INFINITY, 0.0),
                |acc, x| if x.0 < acc.0 { x } else { acc },
            )
    }

    /// Where the line `q + s n` first enters the tool swept from `a` to `b`:
    /// the least `s` in `[s_lo, s_hi]` with the point on or inside the
    /// swept solid. `None` when the line misses it in that interval.
    /// Returns `s_lo` when the line starts inside.
    #[allow(clippy::too_many_arguments)]
    pub fn entry_along(
        &self,
        a: &Vector3<f64>,
        b: &Vector3<f64>,
        axis: &Vector3<f64>,
        q: &Vector3<f64>,
        n: &Vector3<f64>,
        s_lo: f64,
        s_hi: f64,
    ) -> Option<f64> {
        self.entry_within(a, b, axis, q, n, s_lo, s_hi, 0.0)
    }

    /// [`Cutter::entry_along`] to within `tol`: an `s` inside the swept
    /// solid and less than `tol` beyond the entry, for callers that only
    /// compare the entry with thresholds far wider than `tol` (a plan's
    /// provenance). The search stops at the first point found inside, and
    /// the bisection once its bracket is narrower than `tol`; `tol = 0`
    /// is `entry_along`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn entry_within(
        &self,
        a: &Vector3<f64>,
        b: &Vector3<f64>,
        axis: &Vector3<f64>,
        q: &Vector3<f64>,
        n: &Vector3<f64>,
        s_lo: f64,
        s_hi: f64,
        tol: f64,
    ) -> Option<f64> {
        let g = |s: f64| self.swept_distance(a, b, axis, &(q + n * s)).0;
        if g(s_lo) <= 0.0 {
            return Some(s_lo);
        }
        // Exact: the least value, whose point is inside if any is. Within a
        // tolerance: any point inside brackets the entry as well.
        let stop = if tol > 0.0 { 0.0 } else { f64::NEG_INFINITY };
        let (s_min, g_min) = golden_min_until(g, s_lo, s_hi, 70, stop);
        let (s_min, g_min) = if g_min > stop && g(s_hi) < g_min {
            (s_hi, g(s_hi))
        } else {
            (s_min, g_min)
        };
        if g_min > 0.0 {
            return None;
        }
        let (mut lo, mut hi) = (s_lo, s_min);
        for _ in 0..80 {
            let mid = 0.5 * (lo + hi);
            // `lo` is outside and `hi` inside throughout, so a midpoint at
            // either end would leave both where they are for the remaining
            // steps: stopping there gives the same bits.
            if mid == lo || mid == hi || hi - lo < tol {
                break;
            }
            if g(mid) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Some(hi)
    }
}

/// Golden-section minimum of a convex function on `[lo, hi]`: (argmin, min).
fn golden_min<F: Fn(f64) -> f64>(f: F, lo: f64, hi: f64, iters: usize) -> (f64, f64) {
    golden_min_until(f, lo, hi, iters, f64::NEG_INFINITY)
}

/// [`golden_min`], returning the first point whose value is at or below
/// `stop` as soon as it is found.
fn golden_min_until<F: Fn(f64) -> f64>(
    f: F,
    lo: f64,
    hi: f64,
    iters: usize,
    stop: f64,
) -> (f64, f64) {
    let (mut a, mut b) = (lo, hi);
    let mut c = b - GOLDEN * (b - a);
    let mut d = a + GOLDEN * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    if fc <= stop {
        return (c, fc);
    }
    if fd <= stop {
        return (d, fd);
    }
    for _ in 0..iters {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - GOLDEN * (b - a);
            fc = f(c);
            if fc <= stop {
                return (c, fc);
            }
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + GOLDEN * (b - a);
            fd = f(d);
            if fd <= stop {
                return (d, fd);
            }
        }
    }
    if fc < fd { (c, fc) } else { (d, fd) }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tool(kind: ToolKind, corner: Option<f64>) -> Cutter {
        Cutter::of(&Tool {
            name: "t".into(),
            kind,
            diameter: 8.0,
            length: 50.0,
            corner_radius: corner,
            flutes: None,
            number: 1,
            id: None,
        })
    }

    #[test]
    fn signed_distance_matches_closed_forms() {
        let z = Vector3::z();
        let o = Vector3::zeros();
        let flat = tool(ToolKind::Flat, None);
        assert!((flat.signed_distance(&o, &z, &Vector3::new(6.0, 0.0, 10.0)) - 2.0).abs() < 1e-12);
        assert!((flat.signed_distance(&o, &z, &Vector3::new(1.0, 0.0, -3.0)) - 3.0).abs() < 1e-12);
        assert!((flat.signed_distance(&o, &z, &Vector3::new(1.0, 0.0, 1.0)) + 1.0).abs() < 1e-12);
        let ball = tool(ToolKind::Ball, None);
        // Below the ball centre (0, 0, 4) at distance 5 along a skew line.
        let q = Vector3::new(3.0, 0.0, 0.0);
        assert!((ball.signed_distance(&o, &z, &q) - 1.0).abs() < 1e-12);
        let bull = tool(ToolKind::Bull, Some(1.0));
        // Corner torus: tube centre at radius 3, height 1.
        let q = Vector3::new(3.0 + 2.0_f64.sqrt(), 0.0, 1.0 - 2.0_f64.sqrt());
        assert!((bull.signed_distance(&o, &z, &q) - 1.0).abs() < 1e-12);
        assert_eq!(bull.part_at(&o, &z, &q), ToolPart::Torus);
        assert_eq!(
            bull.part_at(&o, &z, &Vector3::new(1.0, 0.0, -0.5)),
            ToolPart::FlatEnd
        );
        assert_eq!(
            flat.part_at(&o, &z, &Vector3::new(4.0, 0.0, 2.0)),
            ToolPart::Flank
        );
        assert_eq!(
            flat.part_at(&o, &z, &Vector3::new(2.0, 0.0, 0.0)),
            ToolPart::FlatEnd
        );
        assert_eq!(
            ball.part_at(&o, &z, &Vector3::new(0.0, 0.0, 0.0)),
            ToolPart::Ball
        );
    }

    /// Random tools, tilted moves and lines near them (fixed seed), as
    /// plans and the simulator meet them.
    fn random_cases(n: usize) -> Vec<(Cutter, [Vector3<f64>; 5])> {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Uniform};
        let mut rng = rand::rngs::StdRng::seed_from_u64(41);
        let u = Uniform::new(-1.0, 1.0).unwrap();
        let mut v = |scale: f64| {
            Vector3::new(u.sample(&mut rng), u.sample(&mut rng), u.sample(&mut rng)) * scale
        };
        (0..n)
            .map(|i| {
                let kind = [ToolKind::Flat, ToolKind::Ball, ToolKind::Bull][i % 3];
                let cutter = tool(kind, Some(1.0));
                let a = v(3.0);
                // Every fifth move stands still (a plunge's end).
                let b = if i % 5 == 0 { a } else { a + v(8.0) };
                let axis = (Vector3::z() + v(0.5)).normalize();
                let n = (v(1.0) + Vector3::z() * 0.2).normalize();
                let q = (a + b) * 0.5 + v(4.0) - n * 9.0;
                (cutter, [a, b, axis, q, n])
            })
            .collect()
    }

    /// The box test never rules out a point the sweep comes within reach
    /// of, and rules out most of those far away.
    #[test]
    fn may_reach_rules_out_only_points_out_of_reach() {
        let reach = 0.15;
        let (mut out, mut far) = (0, 0);
        for (c, [a, b, axis, q, n]) in random_cases(200) {
            for k in 0..30 {
                let p = q + n * (0.5 * k as f64) + axis.cross(&n) * (0.7 * k as f64);
                let d = c.swept_distance(&a, &b, &axis, &p).0;
                let may = c.may_reach(&a, &b, &axis, &p, reach);
                assert!(may || d > reach, "{d}");
                far += usize::from(d > reach + 2.0 * c.radius + 1.0);
                out += usize::from(!may);
            }
        }
        assert!(far > 500 && out > far / 2, "{out} of {far}");
    }

    /// The square root skipped beside or below the core changes no bit.
    #[test]
    fn signed_distance_is_the_hypot_formula_to_the_bit() {
        for (c, [a, _, axis, q, n]) in random_cases(300) {
            for k in 0..40 {
                let p = q + n * (0.25 * k as f64);
                let (rho, zeta) = c.meridian(&a, &axis, &p);
                let w = c.radius - c.corner;
                let dx = rho - w;
                let dz = (zeta - 0.5 * (c.corner + c.length)).abs() - 0.5 * (c.length - c.corner);
                let want = dx.max(0.0).hypot(dz.max(0.0)) + dx.max(dz).min(0.0) - c.corner;
                assert_eq!(c.signed_distance(&a, &axis, &p).to_bits(), want.to_bits());
            }
        }
    }

    /// The bisection's early stop (its midpoint at either end of the
    /// bracket) gives the bits of the full eighty steps.
    #[test]
    fn entry_along_is_the_full_search_to_the_bit() {
        let full = |c: &Cutter, [a, b, axis, q, n]: &[Vector3<f64>; 5]| {
            let g = |s: f64| c.swept_distance(a, b, axis, &(q + n * s)).0;
            let (s_lo, s_hi) = (0.0, 12.0);
            if g(s_lo) <= 0.0 {
                return Some(s_lo);
            }
            let (mut s_min, mut g_min) = golden_min(g, s_lo, s_hi, 70);
            if g(s_hi) < g_min {
                (s_min, g_min) = (s_hi, g(s_hi));
            }
            if g_min > 0.0 {
                return None;
            }
            let (mut lo, mut hi) = (s_lo, s_min);
            for _ in 0..80 {
                let mid = 0.5 * (lo + hi);
                if g(mid) > 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            Some(hi)
        };
        let mut entered = 0;
        for (c, [a, b, axis, q, n]) in random_cases(200) {
            let got = c.entry_along(&a, &b, &axis, &q, &n, 0.0, 12.0);
            let want = full(&c, &[a, b, axis, q, n]);
            assert_eq!(got.map(f64::to_bits), want.map(f64::to_bits));
            entered += usize::from(got.is_some_and(|s| s > 0.0));
        }
        // Most lines cross the sweep, and start outside it.
        assert!(entered > 80, "{entered}");
    }

    /// Within a tolerance, the entry is found inside the sweep, beyond the
    /// exact entry by less than the tolerance, and a line that misses
    /// misses.
    #[test]
    fn entry_within_is_at_most_its_tolerance_beyond_the_entry() {
        let tol = 1e-9;
        let mut misses = 0;
        for (c, [a, b, axis, q, n]) in random_cases(200) {
            let exact = c.entry_along(&a, &b, &axis, &q, &n, 0.0, 12.0);
            let within = c.entry_within(&a, &b, &axis, &q, &n, 0.0, 12.0, tol);
            match (exact, within) {
                (Some(s), Some(w)) => {
                    assert!(w >= s && w - s < tol, "{s} {w}");
                    assert!(c.swept_distance(&a, &b, &axis, &(q + n * w)).0 <= 0.0);
                }
                (None, None) => misses += 1,
                other => panic!("{other:?}"),
            }
        }
        assert!(misses > 5, "{misses}");
    }

    #[test]
    fn sweep_entry_finds_the_surface_a_move_leaves() {
        // A flat end mill moving along X at height 2, axis tilted: the
        // floor it leaves at x = 5 is where its lowest point passed.
        let flat = tool(ToolKind::Flat, None);
        let axis = Vector3::new(0.0, 0.6, 0.8);
        let a = Vector3::new(0.0, 0.0, 2.0);
        let b = Vector3::new(10.0, 0.0, 2.0);
        // Lowest point of the tilted end disc: tip - 4 * (0, 0.8, -0.6).
        let low = 2.0 - 4.0 * 0.6;
        let q = Vector3::new(5.0, 0.0, -3.0);
        let s = flat
            .entry_along(&a, &b, &axis, &q, &Vector3::z(), -1.0, 10.0)
            .unwrap();
        // The line x=5, y=0 enters the sweep where the tilted disc crosses y=0: z = 2.
        assert!((q.z + s - 2.0).abs() < 1e-9, "{}", q.z + s);
        let q2 = Vector3::new(5.0, 4.0 * 0.8, -3.0);
        let s2 = flat
            .entry_along(&a, &b, &axis, &q2, &Vector3::z(), -1.0, 10.0)
            .unwrap();
        assert!((q2.z + s2 - low).abs() < 1e-9, "{}", q2.z + s2);
        assert!(
            flat.entry_along(
                &a,
                &b,
                &axis,
                &Vector3::new(20.0, 0.0, 0.0),
                &Vector3::z(),
                -1.0,
                1.0
            )
            .is_none()
        );
    }
}
