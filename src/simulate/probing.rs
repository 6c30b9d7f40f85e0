//! On-machine probing on the machine with errors: each touch's probing
//! move runs along its commanded line (from [`crate::procedure::probing::Touch::start`] towards
//! [`crate::procedure::probing::Touch::end`], rotary axes still), the actual ball centre is the exact
//! model's tool point there, and the probe triggers where the ball meets
//! the actual surface of the pieces (each set up with its own error) or of
//! the sphere (with its form error), then travels on by its pre-travel.
//!
//! [`Probing`] is the geometry both the exact simulation ([`contacts`])
//! and the forward model share: the commanded line of a touch, the context
//! of the effects there (the time of the touch, the approach direction in
//! the probe's own frame for pre-travel), the actual ball centre, and what
//! the log reader turns a recorded position into.

use std::sync::Arc;

use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};
use rand::{Rng, RngExt};

use super::SimError;
use super::machining::golden;
use crate::geom::{self, Axis3};
use crate::kinematics::{Axes, Perturbation, TablePart};
use crate::machine::Machine;
use crate::model::{Context, Model};
use crate::procedure::ProbingPlan;
use crate::procedure::probing::PoseFrame;
use crate::procedure::probing::ProbedGeometry;

/// A probing plan on a machine with errors.
#[derive(Clone, Debug)]
pub struct Probing {
    /// The model (with the probe's gauge length).
    pub model: Model,
    /// The plan.
    pub plan: Arc<ProbingPlan>,
    frames: Vec<PoseFrame>,
    /// Names of the separately set-up pieces (the columns, or the sphere).
    pub pieces: Vec<String>,
    /// The piece of each touch.
    pub piece_of: Vec<usize>,
    /// The middle of each pose's manifest interval, minutes.
    mid: Vec<f64>,
    /// Per touch, its commanded line and its approach direction in the
    /// probe's frame: a contact search asks for them at every trial
    /// position, and they do not depend on it.
    lines: Vec<(Vector3<f64>, Vector3<f64>, f64)>,
    approaches: Vec<Vector3<f64>>,
}

/// The nominal head rotation at a pose (identity on a table-table machine):
/// it turns the probe's own frame into the machine frame.
pub(crate) fn head_rotation(m: &Machine, tilt: f64, c: f64) -> UnitQuaternion<f64> {
    let mut r = Isometry3::identity();
    if !m.c.on_table {
        r *= geom::rot(Axis3::Z, m.c.direction * geom::rad(c));
    }
    if !m.tilt.on_table {
        r *= geom::rot(m.tilt.about, m.tilt.direction * geom::rad(tilt));
    }
    r.rotation
}

impl Probing {
    /// The plan on the machine of `model`.
    pub fn new(model: Model, plan: Arc<ProbingPlan>) -> Probing {
        let frames = (0..plan.plan.poses.len())
            .map(|i| plan.plan.frame(i))
            .collect();
        let pieces: Vec<String> = match &plan.setup {
            ProbedGeometry::Columns(cs) => cs.iter().map(|c| c.name.clone()).collect(),
            ProbedGeometry::Sphere(_) => vec!["sphere".into()],
        };
        let piece_of = plan
            .plan
            .touches
            .iter()
            .map(|t| pieces.iter().position(|p| *p == t.piece).unwrap_or(0))
            .collect();
        let mid = plan
            .pose_entries()
            .iter()
            .map(|p| 0.5 * (p.start_min + p.end_min))
            .collect();
        let touches = &plan.plan.touches;
        let lines = touches
            .iter()
            .map(|t| {
                let d = t.end.axes.xyz - t.start.axes.xyz;
                let len = d.norm();
                (t.start.axes.xyz, d / len, len)
            })
            .collect();
        let approaches = touches
            .iter()
            .map(|t| {
                let p = &plan.plan.poses[t.pose];
                let r = head_rotation(&plan.machine, p.tilt, p.c);
                (r.inverse() * -t.normal_prog).normalize()
            })
            .collect();
        Probing {
            model,
            plan,
            frames,
            pieces,
            piece_of,
            mid,
            lines,
            approaches,
        }
    }

    /// The commanded probing line of touch `i`: start (program X, Y, Z),
    /// unit direction, and length to the programmed end.
    pub fn line(&self, i: usize) -> (Vector3<f64>, Vector3<f64>, f64) {
        self.lines[i]
    }

    /// Where along its line touch `i` meets the nominal surface, mm.
    pub(crate) fn nominal_tau(&self, i: usize) -> f64 {
        let (s, d, _) = self.line(i);
        (self.plan.plan.touches[i].contact.axes.xyz - s).dot(&d)
    }

    /// The middle of the manifest interval of touch `i`'s pose, minutes.
    pub(crate) fn pose_mid(&self, i: usize) -> f64 {
        self.mid[self.plan.plan.touches[i].pose]
    }

    /// The approach direction of touch `i` in the probe's own frame.
    pub fn approach(&self, i: usize) -> Vector3<f64> {
        self.approaches[i]
    }

    /// The context of touch `i` at `tau` mm along its line; `offset`
    /// (minutes) shifts the clock from the plan's time of the touch.
    pub fn context(&self, i: usize, tau: f64, offset: f64) -> Context {
        let t = &self.plan.plan.touches[i];
        let p = &self.plan.plan.poses[t.pose];
        let (s, d, _) = self.line(i);
        Context {
            axes: Axes {
                xyz: s + d * tau,
                tilt: p.tilt,
                c: p.c,
            },
            seq: p.seq as f64,
            minutes: self.plan.run_time.touch_min[i] + offset,
            approach: Some(self.approach(i)),
            ..Default::default()
        }
    }

    /// The actual ball centre in W at `tau` along touch `i`'s line.
    pub fn ball(&self, theta: &[f64], i: usize, tau: f64, offset: f64) -> Vector3<f64> {
        self.model.pose(theta, &self.context(i, tau, offset)).tip
    }

    /// Touch `i`'s line for [`Probing::ball`] and the perturbation along
    /// it, the same bits. Along one line only X, Y and Z change: the
    /// table's part of the chain is multiplied once, and the errors are
    /// worked out once unless a linear-axis error is at work, not at every
    /// step of the contact search.
    pub fn ball_line<'a>(&'a self, theta: &'a [f64], i: usize, offset: f64) -> BallLine<'a> {
        let varies = self.model.varies_with_xyz(theta);
        let ctx = self.context(i, 0.0, offset);
        let p0 = self.model.perturbation(theta, &ctx);
        let part = self.model.kin.table_part(&ctx.axes, &p0);
        BallLine {
            probing: self,
            theta,
            i,
            offset,
            varies,
            p0,
            part,
        }
    }

    /// The probe's pre-travel on touch `i`, mm, and its gradient (mm per
    /// parameter unit).
    pub fn pretravel(&self, theta: &[f64], i: usize) -> (f64, Vec<f64>) {
        self.model.pretravel(theta, &self.context(i, 0.0, 0.0))
    }

    /// The commanded X, Y, Z at `tau` along touch `i`'s line: what the
    /// control records.
    pub fn recorded(&self, i: usize, tau: f64) -> Vector3<f64> {
        let (s, d, _) = self.line(i);
        s + d * tau
    }

    /// What the log reader makes of a recorded position of touch `i`: the
    /// contact point in program coordinates (ball radius applied along the
    /// nominal normal).
    pub fn reported(&self, i: usize, recorded: &Vector3<f64>) -> Vector3<f64> {
        let t = &self.plan.plan.touches[i];
        self.frames[t.pose].ball_prog(recorded) - t.normal_prog * self.plan.plan.probe.ball_radius
    }

    /// The pose frame of touch `i`.
    pub fn frame(&self, i: usize) -> &PoseFrame {
        &self.frames[self.plan.plan.touches[i].pose]
    }
}

/// A touch's line with what stays the same along it ([`Probing::ball_line`]).
pub struct BallLine<'a> {
    probing: &'a Probing,
    theta: &'a [f64],
    i: usize,
    offset: f64,
    /// Whether the errors change along the line (a linear-axis error).
    varies: bool,
    /// The errors at the line's start.
    p0: Perturbation,
    part: TablePart,
}

impl BallLine<'_> {
    /// The context at `tau` along the line.
    pub fn context(&self, tau: f64) -> Context {
        self.probing.context(self.i, tau, self.offset)
    }

    /// The model's perturbation at [`BallLine::context`], the same bits.
    pub fn perturbation(&self, ctx: &Context) -> Perturbation {
        if self.varies {
            self.probing
                .model
                .perturbation_moved(self.theta, ctx, &self.p0)
        } else {
            self.p0
        }
    }

    /// [`Probing::ball`] at `tau`, the same bits.
    pub fn ball(&self, tau: f64) -> Vector3<f64> {
        let ctx = self.context(tau);
        let p = self.perturbation(&ctx);
        self.probing
            .model
            .kin
            .forward_after(&self.part, &ctx.axes, &p)
            .tip
    }
}

/// The form error of a calibration sphere: a smooth radial deviation made
/// of a few low-order zonal waves about random directions, mm.
#[derive(Clone, Debug, PartialEq)]
pub struct Form {
    waves: Vec<(Vector3<f64>, f64, f64)>,
}

impl Form {
    /// A seeded form error whose deviations stay within `amplitude_um`.
    pub fn random<R: Rng + ?Sized>(amplitude_um: f64, rng: &mut R) -> Form {
        let k = 4;
        let waves = (0..k)
            .map(|j| {
                let d = random_unit(rng);
                let order = 2.0 + (j % 3) as f64;
                let a = rng.random_range(-1.0..1.0) * amplitude_um * 1e-3 / k as f64;
                (d, order, a)
            })
            .collect();
        Form { waves }
    }

    /// No form error.
    pub fn none() -> Form {
        Form { waves: Vec::new() }
    }

    /// The radial deviation in the direction `d` (unit, sphere frame), mm.
    pub fn at(&self, d: &Vector3<f64>) -> f64 {
        self.waves
            .iter()
            .map(|(e, l, a)| a * (l * e.dot(d).clamp(-1.0, 1.0).acos()).cos())
            .sum()
    }
}

/// A uniformly random unit vector.
pub(crate) fn random_unit<R: Rng + ?Sized>(rng: &mut R) -> Vector3<f64> {
    loop {
        let v = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let n = v.norm();
        if n > 1e-3 && n <= 1.0 {
            return v / n;
        }
    }
}

/// The probed artefact as it really is: the setup of each piece (W
/// nominal to W actual) and the sphere's form error.
#[derive(Clone, Debug, PartialEq)]
pub struct Artefact {
    /// One rigid setup per piece, in the order of [`Probing::pieces`].
    pub setups: Vec<Isometry3<f64>>,
    /// The sphere's form error (none for columns).
    pub form: Form,
}

impl Artefact {
    /// Pieces exactly at their nominal places.
    pub fn nominal(n: usize) -> Artefact {
        Artefact {
            setups: vec![Isometry3::identity(); n],
            form: Form::none(),
        }
    }

    /// Seeded setup errors: each column turned about its own centre by up to
    /// `angle` rad and shifted by up to `shift` mm, the sphere shifted (a
    /// turn of a sphere shows only through its form error, which turns with
    /// it: it is drawn in the sphere's frame).
    pub fn random<R: Rng + ?Sized>(
        setup: &ProbedGeometry,
        shift: f64,
        angle: f64,
        form_um: f64,
        rng: &mut R,
    ) -> Artefact {
        let mut draw = |centre: Vector3<f64>, turn: bool| {
            let t = random_unit(rng) * (shift * rng.random_range(0.0..1.0));
            let r = if turn {
                UnitQuaternion::from_scaled_axis(
                    random_unit(rng) * (angle * rng.random_range(0.0..1.0)),
                )
            } else {
                UnitQuaternion::identity()
            };
            // x' = c + t + R (x - c)
            Isometry3::from_parts((centre + t - r * centre).into(), r)
        };
        match setup {
            ProbedGeometry::Columns(cs) => Artefact {
                setups: cs.iter().map(|c| draw(c.centre, true)).collect(),
                form: Form::none(),
            },
            ProbedGeometry::Sphere(s) => {
                let setups = vec![draw(s.centre, false)];
                let form = if form_um > 0.0 {
                    Form::random(form_um, rng)
                } else {
                    Form::none()
                };
                Artefact { setups, form }
            }
        }
    }

    /// Signed distance from a point of W to the actual probed surfaces.
    pub fn signed_distance(&self, setup: &ProbedGeometry, x: &Vector3<f64>) -> f64 {
        match setup {
            ProbedGeometry::Columns(cs) => cs
                .iter()
                .zip(&self.setups)
                .map(|(c, s)| c.signed_distance(&(s.inverse() * Point3::from(*x)).coords))
                .fold(f64::INFINITY, f64::min),
            ProbedGeometry::Sphere(sp) => {
                let s = &self.setups[0];
                let local = (s.inverse() * Point3::from(*x)).coords - sp.centre;
                let r = local.norm();
                let d = if r > 0.0 { local / r } else { Vector3::z() };
                r - (sp.diameter / 2.0 + self.form.at(&d))
            }
        }
    }
}

/// Where each touch's ball first meets the actual surface, mm along its
/// commanded line (before pre-travel), by bisection on the exact ball
/// centre.
pub fn contacts(p: &Probing, theta: &[f64], art: &Artefact) -> Result<Vec<f64>, SimError> {
    use rayon::prelude::*;
    let r = p.plan.plan.probe.ball_radius;
    (0..p.plan.plan.touches.len())
        .into_par_iter()
        .map(|i| {
            let (_, _, len) = p.line(i);
            let g = |tau: f64| art.signed_distance(&p.plan.setup, &p.ball(theta, i, tau, 0.0)) - r;
            if g(0.0) <= 0.0 {
                return Err(SimError::Geometry(format!(
                    "touch {}: the probe already touches the piece where its probing move starts",
                    p.plan.plan.touches[i].label
                )));
            }
            let (tm, gm) = golden(g, 0.0, len);
            if gm > 0.0 {
                return Err(SimError::Geometry(format!(
                    "touch {}: the probe did not trigger within the programmed overtravel; the errors or the setup are too large for this plan",
                    p.plan.plan.touches[i].label
                )));
            }
            let (mut lo, mut hi) = (0.0, tm);
            for _ in 0..100 {
                let mid = 0.5 * (lo + hi);
                if g(mid) > 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
                if hi - lo < 1e-15 {
                    break;
                }
            }
            Ok(0.5 * (lo + hi))
        })
        .collect()
}
