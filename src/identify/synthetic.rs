//! Synthetic measurements from the foundation's model, for tests, the
//! Monte-Carlo uncertainty and benchmarks until the simulator exists.
//!
//! They are exact for what the foundation models: the tool (or probe)
//! point of every plan point is the model's exact pose at that point's own
//! commanded position (so location errors, maps, drift and linear-axis
//! errors all act where they act), the machined face there is the face
//! through that point turned by the pose's `rTw^-1 rTw*`, and the CMM (or
//! the probe) measures along the nominal normal, with Gaussian noise along
//! it. What they leave out is what only the simulator can do: the tool's
//! shape sweeping the surface, probe pre-travel, tool deflection.
//!
//! The module also builds the plan point sets of the tests the planner will
//! write (a stepped-square-like piece, a calibration sphere), so that
//! identification can be exercised before the planner lands.

use std::collections::HashMap;

use nalgebra::{Isometry3, Point3, Vector3};
use rand::Rng;
use rand_distr::{Distribution, Normal};

use crate::formats::measured::MeasuredPoint;
use crate::formats::points::{PlanPoint, PlanPoints};
use crate::kinematics::{Axes, Kinematics};
use crate::model::{Context, Model};

fn context(p: &PlanPoint, commanded: Vector3<f64>, minutes: f64) -> Context {
    Context {
        axes: Axes {
            xyz: commanded,
            tilt: p.tilt,
            c: p.c,
        },
        seq: p.seq as f64,
        minutes,
        approach: None,
        ..Default::default()
    }
}

fn noise<R: Rng + ?Sized>(sigma_um: f64, rng: &mut R) -> f64 {
    if sigma_um > 0.0 {
        Normal::new(0.0, sigma_um * 1e-3).unwrap().sample(rng)
    } else {
        0.0
    }
}

/// A machined piece measured on a CMM: the measured point of each plan
/// point, in the CMM frame (`placement`: W to CMM), labelled.
pub fn machined<R: Rng + ?Sized>(
    model: &Model,
    theta: &[f64],
    plan: &PlanPoints,
    minutes: &HashMap<String, f64>,
    noise_um: f64,
    placement: &Isometry3<f64>,
    rng: &mut R,
) -> Vec<MeasuredPoint> {
    let k = &model.kin;
    plan.points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let nominal = k.nominal_table_transform(p.tilt, p.c);
            let commanded = (nominal * Point3::from(p.p)).coords;
            let min = minutes.get(&p.pose).copied().unwrap_or(0.0);
            let ctx = context(p, commanded, min);
            let pert = model.perturbation(theta, &ctx);
            let tip = k.forward(&ctx.axes, &pert).tip;
            let m = k.table_transform(p.tilt, p.c, &pert).inverse() * nominal;
            let nm = m.rotation * p.n;
            let s = nm.dot(&(tip - p.p)) / nm.dot(&p.n);
            let w = p.p + p.n * (s + noise(noise_um, rng));
            MeasuredPoint {
                label: p.label.clone(),
                p: (placement * Point3::from(w)).coords,
                line: i + 1,
                normal: None,
            }
        })
        .collect()
}

/// On-machine probing of plane faces: the contact point of each plan point
/// in W at rotary zero (the probe's commanded position, ball radius
/// applied), the piece set up at `setup` (W to where it really sits).
pub fn probed<R: Rng + ?Sized>(
    model: &Model,
    theta: &[f64],
    plan: &PlanPoints,
    minutes: &HashMap<String, f64>,
    noise_um: f64,
    setup: &Isometry3<f64>,
    rng: &mut R,
) -> Vec<MeasuredPoint> {
    probed_with(model, theta, plan, minutes, noise_um, &|_| *setup, rng)
}

/// [`probed`] with pieces set up separately: `setup` gives the setup of
/// the piece each plan point is on.
pub fn probed_with<R: Rng + ?Sized>(
    model: &Model,
    theta: &[f64],
    plan: &PlanPoints,
    minutes: &HashMap<String, f64>,
    noise_um: f64,
    setup: &dyn Fn(&PlanPoint) -> Isometry3<f64>,
    rng: &mut R,
) -> Vec<MeasuredPoint> {
    let k = &model.kin;
    plan.points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let nominal = k.nominal_table_transform(p.tilt, p.c);
            let q0 = (nominal * Point3::from(p.p)).coords;
            let d = nominal.rotation * p.n;
            let min = minutes.get(&p.pose).copied().unwrap_or(0.0);
            let ctx = context(p, q0, min);
            let pert = model.perturbation(theta, &ctx);
            let t = k.table_transform(p.tilt, p.c, &pert) * setup(p);
            // The probe's actual position is its commanded one plus the
            // linear-axis error there: contact when that reaches the face.
            let face = (t * Point3::from(p.p)).coords - pert.linear();
            let nf = t.rotation * p.n;
            let s = nf.dot(&(face - q0)) / nf.dot(&d);
            MeasuredPoint {
                label: p.label.clone(),
                p: q0 + d * (s + noise(noise_um, rng)),
                line: i + 1,
                normal: None,
            }
        })
        .collect()
}

/// On-machine probing of a calibration sphere of radius `radius` (contact
/// points, ball radius applied) whose centre sits at `centre` in W.
#[allow(clippy::too_many_arguments)]
pub fn probed_sphere<R: Rng + ?Sized>(
    model: &Model,
    theta: &[f64],
    plan: &PlanPoints,
    centre: &Vector3<f64>,
    radius: f64,
    noise_um: f64,
    rng: &mut R,
) -> Vec<MeasuredPoint> {
    let k = &model.kin;
    plan.points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let nominal = k.nominal_table_transform(p.tilt, p.c);
            let q0 = (nominal * Point3::from(p.p)).coords;
            let d = nominal.rotation * p.n;
            let ctx = context(p, q0, 0.0);
            let pert = model.perturbation(theta, &ctx);
            let c = (k.table_transform(p.tilt, p.c, &pert) * Point3::from(*centre)).coords
                - pert.linear();
            // |q0 + s d - c| = r, the root nearest the nominal contact.
            let w = q0 - c;
            let b = w.dot(&d);
            let disc = (b * b - (w.norm_squared() - radius * radius)).max(0.0);
            let s1 = -b + disc.sqrt();
            let s2 = -b - disc.sqrt();
            let s = if s1.abs() < s2.abs() { s1 } else { s2 };
            MeasuredPoint {
                label: p.label.clone(),
                p: q0 + d * (s + noise(noise_um, rng)),
                line: i + 1,
                normal: None,
            }
        })
        .collect()
}

fn push_pose(
    out: &mut Vec<PlanPoint>,
    pose: &str,
    seq: u32,
    tilt: f64,
    c: f64,
    pts: &[(Vector3<f64>, Vector3<f64>)],
) {
    for (k, (p, n)) in pts.iter().enumerate() {
        out.push(PlanPoint {
            label: format!("{pose}_{:02}", k + 1),
            pose: pose.to_string(),
            seq,
            tilt,
            c,
            p: *p,
            n: n.normalize(),
        });
    }
}

/// A stepped-square-like piece (Ibaraki & Ota 2014, fig. 2-4) for a table-table
/// machine: at every tilt in `tilts` and C in `cs`, a square step of
/// half-width `half` mm milled with X and Y moves only, its centre `h` mm
/// from the pivot along the tool axis (each pose at its own height, so the
/// steps do not overlap). Each step has four floor points (normal: the tool
/// axis) and two points on each of its four walls (normals: machine X and
/// Y seen from W), twelve points, observing all six motions of the pose.
pub fn stepped_square(kin: &Kinematics, tilts: &[f64], cs: &[f64], half: f64) -> PlanPoints {
    let mut out = Vec::new();
    let mut seq = 0;
    let letter = kin.machine().tilt.letter;
    for &t in tilts {
        for &c in cs {
            let inv = kin.nominal_table_transform(t, c).inverse();
            let u = inv.rotation * Vector3::z();
            let e1 = inv.rotation * Vector3::x();
            let e2 = inv.rotation * Vector3::y();
            let h = 60.0 - 2.5 * seq as f64;
            let centre = (inv * Point3::new(0.0, 0.0, h)).coords;
            let mut pts = Vec::new();
            for (a, b) in [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)] {
                pts.push((
                    centre + e1 * (a * (half + 6.0)) + e2 * (b * (half + 6.0)),
                    u,
                ));
            }
            for (dir, side) in [(e1, e2), (-e1, e2), (e2, e1), (-e2, e1)] {
                for s in [-0.6, 0.6] {
                    pts.push((centre + dir * half + side * (s * half) + u * 2.5, dir));
                }
            }
            let pose = format!("{letter}{}C{}", t as i64, c as i64).replace('-', "m");
            push_pose(&mut out, &pose, seq, t, c, &pts);
            seq += 1;
        }
    }
    PlanPoints {
        tilt_letter: letter,
        points: out,
    }
}

/// A calibration sphere of radius `radius` at `centre` (W), probed at
/// five points (X+, X-, Y+, Y- at its equator and Z- on top, approach
/// directions in the machine frame) at every pose in `poses` ((tilt, C)).
pub fn sphere_plan(
    kin: &Kinematics,
    centre: &Vector3<f64>,
    radius: f64,
    poses: &[(f64, f64)],
) -> PlanPoints {
    let mut out = Vec::new();
    let letter = kin.machine().tilt.letter;
    for (seq, &(t, c)) in poses.iter().enumerate() {
        let nominal = kin.nominal_table_transform(t, c);
        let inv = nominal.inverse();
        let cm = (nominal * Point3::from(*centre)).coords;
        let mut pts = Vec::new();
        // Outward normals (machine frame): the probe approaches along -n.
        for d in [
            -Vector3::x(),
            Vector3::x(),
            -Vector3::y(),
            Vector3::y(),
            Vector3::z(),
        ] {
            let pm = cm + d * radius;
            pts.push(((inv * Point3::from(pm)).coords, inv.rotation * d));
        }
        let pose = format!("{letter}{}C{}", t as i64, c as i64).replace('-', "m");
        push_pose(&mut out, &pose, seq as u32, t, c, &pts);
    }
    PlanPoints {
        tilt_letter: letter,
        points: out,
    }
}

/// Three square columns on one base (Ibaraki, Iritani & Matsushita 2013, fig. 2), probed on the
/// machine at every pose in `poses` ((tilt, C)): on each column two points
/// on each side face (at two heights) and one on top, keeping only the
/// faces a probe coming from above can reach (machine-frame normal not
/// pointing down).
pub fn columns(kin: &Kinematics, poses: &[(f64, f64)]) -> PlanPoints {
    let m = kin.machine();
    let base = m.table.surface;
    let centres = [(80.0, 0.0), (-40.0, 69.3), (-40.0, -69.3)];
    let (half, height) = (20.0, 100.0);
    let mut all: Vec<(Vector3<f64>, Vector3<f64>)> = Vec::new();
    for (cx, cy) in centres {
        for (n, off) in [
            (Vector3::<f64>::x(), Vector3::new(half, 0.0, 0.0)),
            (-Vector3::x(), Vector3::new(-half, 0.0, 0.0)),
            (Vector3::y(), Vector3::new(0.0, half, 0.0)),
            (-Vector3::y(), Vector3::new(0.0, -half, 0.0)),
        ] {
            for (z, t) in [(0.4, 0.5), (0.8, -0.5)] {
                let side = Vector3::new(-n.y, n.x, 0.0) * (t * half);
                all.push((Vector3::new(cx, cy, base + z * height) + off + side, n));
            }
        }
        all.push((
            Vector3::new(cx + 5.0, cy - 5.0, base + height),
            Vector3::z(),
        ));
    }
    let letter = m.tilt.letter;
    let mut out = Vec::new();
    for (seq, &(t, c)) in poses.iter().enumerate() {
        let r = kin.nominal_table_transform(t, c).rotation;
        let pose = format!("{letter}{}C{}", t as i64, c as i64).replace('-', "m");
        // Labels `<pose>_P<n>` with n the point of the piece, the same at
        // every pose, as the probing planner's `<pose>_<feature>`.
        for (i, (p, n)) in all.iter().enumerate() {
            if (r * n).z > -0.3 {
                out.push(PlanPoint {
                    label: format!("{pose}_P{:02}", i + 1),
                    pose: pose.clone(),
                    seq: seq as u32,
                    tilt: t,
                    c,
                    p: *p,
                    n: *n,
                });
            }
        }
    }
    PlanPoints {
        tilt_letter: letter,
        points: out,
    }
}
