//! What the probe-log format takes from a probing plan: the reader's
//! options for the plan's settings and the writer for its program, its
//! touches and its run. The format itself (src/formats/probe_log/) knows
//! no plan; these stand on both.

use nalgebra::Vector3;

use super::{ProbingSettings, Touch, TouchPlan};
use crate::formats::probe_log::write::LogFormat;
use crate::formats::probe_log::{Logged, ReadOptions, Repeats};
use crate::machine::Dialect;
use crate::post::RenderedProgram;

impl ReadOptions {
    /// Options for a plan made with `settings` and a ball of radius
    /// `ball_radius`: the window is the plan's overtravel and clearance,
    /// the lateral tolerance 0.1 mm (the controller records a point of the
    /// commanded line; 0.1 mm leaves room for servo lag at the trigger).
    pub fn for_plan(settings: &ProbingSettings, ball_radius: f64) -> ReadOptions {
        ReadOptions {
            ball_radius,
            window: (settings.overtravel, settings.clearance),
            lateral_tolerance: 0.1,
            repeats: Repeats::KeepLast,
            test: None,
        }
    }
}

impl LogFormat {
    /// The log a rendered program writes: as [`LogFormat::builtin`], with
    /// the HEIDENHAIN tag taken from the program's touch format file
    /// (`"K%D ...` or `"T%D ...`).
    pub(crate) fn for_program(dialect: Dialect, program: &RenderedProgram) -> LogFormat {
        let mut f = LogFormat::builtin(dialect);
        if let Some(a) = program.aux.iter().find(|a| a.name.ends_with("-touch.a")) {
            if a.text.contains("\"T%") {
                f.logged = Logged::BallCentre;
            } else if a.text.contains("\"K%") {
                f.logged = Logged::Contact;
            }
        }
        f
    }

    /// The line for `touch` of a plan whose probe ball has radius
    /// `ball_radius`.
    pub fn touch_line(&self, touch: &Touch, recorded: &Vector3<f64>, ball_radius: f64) -> String {
        self.line(
            touch.index,
            &touch.label,
            recorded,
            &touch.normal_prog,
            ball_radius,
        )
    }

    /// A whole run of `plan`: the header, one line per `(touch, recorded
    /// X, Y, Z)` in the order given (a touch that did not trigger, or was
    /// skipped, is simply not given), and the footer.
    pub fn write<'a>(
        &self,
        plan: &TouchPlan,
        recorded: impl IntoIterator<Item = (&'a Touch, Vector3<f64>)>,
    ) -> String {
        let eol = self.eol();
        let mut s = String::new();
        for l in self.header(plan.test.as_str()) {
            s.push_str(&l);
            s.push_str(eol);
        }
        for (t, xyz) in recorded {
            s.push_str(&self.touch_line(t, &xyz, plan.probe.ball_radius));
            s.push_str(eol);
        }
        for l in self.footer() {
            s.push_str(&l);
            s.push_str(eol);
        }
        s
    }
}
