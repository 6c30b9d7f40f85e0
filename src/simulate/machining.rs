//! The exact machining simulation: every cutting move of every pose runs
//! on the machine with errors, the actual tool sweeps the stock, and the
//! CMM's probing line of each plan point (its nominal normal line) meets
//! the surface the sweeps leave.
//!
//! The surface at a plan point is found without the point's provenance:
//! every feed move whose nominal sweep passes within 1 mm of the point is a
//! candidate, and the measured surface is where the line, coming out of the
//! material, first enters one of the actual sweeps (the envelope of all
//! cuts). A sweep is exact: on the pieces of a move where the actual tool
//! runs straight with a fixed axis ([`super::cutting`]) it is the planner's
//! exact swept solid ([`Cutter::entry_along`]); where drift in time bends
//! the path, the actual tool is evaluated wherever the search needs it and
//! the entry is the least over the move's instants of the entry into the
//! tool at that instant, found by a fixed-point iteration that converges to
//! machine precision.

use nalgebra::Vector3;
use rayon::prelude::*;

use super::SimError;
use super::cutting::{Cutting, actual_cutter};
use crate::procedure::machining::Cutter;

/// How far inside the material the probing line starts, mm: the surface
/// may lie this far on either side of its nominal place.
pub(crate) const LINE_DEPTH: f64 = 0.5;

/// A cutting move with its nominal swept box.
#[derive(Clone, Debug)]
struct Candidate {
    pose: usize,
    mv: usize,
    lo: Vector3<f64>,
    hi: Vector3<f64>,
    a: Vector3<f64>,
    b: Vector3<f64>,
    axis: Vector3<f64>,
}

fn candidates(cut: &Cutting) -> Vec<Candidate> {
    let c = &cut.plan.cutter;
    let mut out = Vec::new();
    for (pi, pose) in cut.plan.poses.iter().enumerate() {
        for (mi, mv) in pose.moves.iter().enumerate() {
            if mv.rapid {
                continue;
            }
            let (a, b, axis) = cut.nominal_segment(pi, mi);
            let pts = [a, b, a + axis * c.length, b + axis * c.length];
            let mut lo = pts[0];
            let mut hi = pts[0];
            for p in &pts {
                lo = lo.inf(p);
                hi = hi.sup(p);
            }
            let r = Vector3::repeat(c.radius);
            out.push(Candidate {
                pose: pi,
                mv: mi,
                lo: lo - r,
                hi: hi + r,
                a,
                b,
                axis,
            });
        }
    }
    out
}

/// The offset of the actual surface from each nominal plan point along its
/// nominal normal, mm (negative: cut deeper), in plan order.
pub(crate) fn surface_offsets(cut: &Cutting, theta: &[f64]) -> Result<Vec<f64>, SimError> {
    let cands = candidates(cut);
    let cutter = actual_cutter(&cut.plan.cutter, cut.radius_error(theta));
    let reach = 1.0;
    cut.plan
        .points
        .par_iter()
        .map(|pp| {
            let (p, n) = (pp.point.p, pp.point.n);
            let q0 = p - n * LINE_DEPTH;
            let mut best = f64::INFINITY;
            for c in &cands {
                let near = (0..3).all(|i| p[i] + reach >= c.lo[i] && p[i] - reach <= c.hi[i]);
                if !near {
                    continue;
                }
                if cut.plan.cutter.swept_distance(&c.a, &c.b, &c.axis, &p).0 > reach {
                    continue;
                }
                if let Some(s) = entry(cut, theta, &cutter, c, &q0, &n)? {
                    if s <= 0.0 {
                        return Err(SimError::Geometry(format!(
                            "point {}: move {} of pose {} cuts {} mm or more below its nominal surface; the errors are too large for this plan",
                            pp.point.label,
                            c.mv + 1,
                            cut.plan.poses[c.pose].id,
                            LINE_DEPTH
                        )));
                    }
                    best = best.min(s);
                }
            }
            if !best.is_finite() {
                return Err(SimError::Geometry(format!(
                    "point {}: no cut reaches its surface within {LINE_DEPTH} mm of the nominal place; the errors are too large for this plan",
                    pp.point.label
                )));
            }
            Ok(best - LINE_DEPTH)
        })
        .collect()
}

/// Where the line `q0 + s n`, `s` in `[0, 2 LINE_DEPTH]`, first enters the
/// actual sweep of a move.
fn entry(
    cut: &Cutting,
    theta: &[f64],
    cutter: &Cutter,
    c: &Candidate,
    q0: &Vector3<f64>,
    n: &Vector3<f64>,
) -> Result<Option<f64>, SimError> {
    let hi = 2.0 * LINE_DEPTH;
    if !cut.drifts_in_time {
        let mut ts = vec![0.0];
        ts.extend(cut.bends(c.pose, c.mv));
        ts.push(1.0);
        let mut best: Option<f64> = None;
        for w in ts.windows(2) {
            let a = cut.pose(theta, c.pose, c.mv, w[0], 0.0);
            let b = cut.pose(theta, c.pose, c.mv, w[1], 0.0);
            if let Some(s) = cutter.entry_along(&a.tip, &b.tip, &a.axis, q0, n, 0.0, hi) {
                best = Some(best.map_or(s, |x: f64| x.min(s)));
            }
        }
        return Ok(best);
    }
    Ok(curved_entry(cut, theta, cutter, c, q0, n, hi))
}

/// The entry into the sweep of a move whose actual path bends (drift in
/// time): the least over instants `t` of the entry into the tool at `t`
/// (where the tool misses the line, `hi` plus its distance from it, so that
/// the function stays unimodal for the golden-section search).
fn curved_entry(
    cut: &Cutting,
    theta: &[f64],
    cutter: &Cutter,
    c: &Candidate,
    q0: &Vector3<f64>,
    n: &Vector3<f64>,
    hi: f64,
) -> Option<f64> {
    // Only instants whose nominal tool comes near the line matter.
    let d = c.b - c.a;
    let len = d.norm();
    let p = q0 + n * LINE_DEPTH;
    let (lo_t, hi_t) = if len < 1e-12 {
        (0.0, 1.0)
    } else {
        let tc = ((p - c.a).dot(&d) / (len * len)).clamp(0.0, 1.0);
        let w = (cutter.radius + cutter.length + 1.0) / len;
        ((tc - w).max(0.0), (tc + w).min(1.0))
    };
    let entry_at = |t: f64| {
        let tp = cut.pose(theta, c.pose, c.mv, t, 0.0);
        match cutter.entry_along(&tp.tip, &tp.tip, &tp.axis, q0, n, 0.0, hi) {
            Some(s) => s,
            None => {
                let (_, gap) = golden(
                    |s| cutter.signed_distance(&tp.tip, &tp.axis, &(q0 + n * s)),
                    0.0,
                    hi,
                );
                hi + gap.max(0.0) + 1e-9
            }
        }
    };
    let (_, e) = golden(entry_at, lo_t, hi_t);
    (e <= hi).then_some(e)
}

/// Golden-section minimum of a unimodal function on `[lo, hi]`, with the
/// ends as candidates: (argmin, min).
pub(crate) fn golden<F: Fn(f64) -> f64>(f: F, lo: f64, hi: f64) -> (f64, f64) {
    const G: f64 = 0.618_033_988_749_894_9;
    let (mut a, mut b) = (lo, hi);
    let mut c = b - G * (b - a);
    let mut d = a + G * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..80 {
        if (b - a).abs() < 1e-15 {
            break;
        }
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - G * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + G * (b - a);
            fd = f(d);
        }
    }
    let best = if fc < fd { (c, fc) } else { (d, fd) };
    [(lo, f(lo)), (hi, f(hi))]
        .into_iter()
        .fold(best, |acc, x| if x.1 < acc.1 { x } else { acc })
}
