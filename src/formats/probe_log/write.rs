//! Writing probe logs as the controller would: the exact text a generated
//! probing program makes the control write for each touch, given the
//! position the control recorded at the trigger. This is what `simulate`
//! uses to produce a log that the readers of this module (and a user's
//! eyes) cannot tell from a real one.
//!
//! The recorded position is what the control holds in its skip or probe
//! variables (`#5061`-`#5063` on FANUC and LinuxCNC, the touch point of
//! cycle 0 on HEIDENHAIN): the commanded X, Y, Z at the instant of the
//! trigger, in program coordinates (work offset on the W origin at rotary
//! zero). On a table-table machine that is the ball centre in program
//! coordinates; on a head machine without TCP the ball sits off it by the
//! head's swing ([`crate::kinematics::pose_frame::PoseFrame::ball_prog`]), which the
//! reader adds back. A simulator finds it by moving the commanded axes
//! along the probing move (from [`crate::procedure::probing::Touch::start`] towards
//! [`crate::procedure::probing::Touch::end`]) until the actual ball meets the actual
//! surface, and writes the axes' X, Y, Z there.
//!
//! What each dialect writes ([`LogFormat`] holds the control settings that
//! change the text):
//!
//! - FANUC (`DPRNT[T#199[50]*X#5061[44]*Y#5062[44]*Z#5063[44]]`): fixed
//!   fields, rounded to 4 decimals, the integer part cut to its lowest 4
//!   digits (a value of 10000 mm or more loses its high digits, as on the
//!   control), leading zeros and the `+` sign printed as spaces with
//!   parameter PRT = 0 or suppressed with PRT = 1; `POPEN` and `PCLOS`
//!   punch a `%` before and after the output ([`LogFormat::tape_marks`]).
//! - HEIDENHAIN (`FN 16` with `"K%D X%.4LF Y%.4LF Z%.4LF"`): the built-in
//!   post reads the touch point of cycle 0 (`ID360 NR1`), which the
//!   control has compensated by the ball radius along the probing axis,
//!   and tags it `K`; a definition printing ball centres tags them `T`
//!   ([`LogFormat::logged`]). Four decimals, with a decimal comma when the
//!   control's language writes one ([`LogFormat::comma`]).
//! - LinuxCNC (`(LOG,T label X#5061 Y#5062 Z#5063)`): `%lf`, six
//!   decimals, the label instead of the index.
//! - SINUMERIK (`WRITE` of `"T17 X"<<ROUND(R1*10000)/10000<<...`, R1 to R3
//!   from `$AA_MW`): the index and the values rounded to four decimals,
//!   trailing zeros left out.
//!
//! Every log starts with the header line `FIVECAL <test>` (FANUC in
//! capitals, as DPRNT prints literal text).
//!
//! The lines for a plan's touches and a whole run of a plan
//! (`LogFormat::touch_line`, `LogFormat::write`) stand on the plan, so they
//! are written beside it, in `procedure/probing/log_format.rs`.

use nalgebra::Vector3;

use super::{Logged, fanuc, heidenhain, linuxcnc, sinumerik};
use crate::machine::Dialect;

/// The control settings that decide a log's exact text.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LogFormat {
    /// The dialect.
    pub dialect: Dialect,
    /// FANUC: how DPRNT prints leading zeros and signs (parameter PRT).
    pub prt: fanuc::Prt,
    /// FANUC: `%` before and after the output (POPEN/PCLOS on a punch or
    /// memory-card channel).
    pub tape_marks: bool,
    /// HEIDENHAIN: decimal commas (a control set to German or French).
    pub comma: bool,
    /// HEIDENHAIN: what the touch format file prints (`K` contact points
    /// compensated by the control, or `T` ball centres).
    pub logged: Logged,
    /// Lines end with CR LF instead of LF.
    pub crlf: bool,
}

impl LogFormat {
    /// The log the built-in postprocessor of `dialect` makes the control
    /// write, with the settings that make it hardest to read: FANUC with
    /// PRT = 0 (space-padded fields) and tape marks, HEIDENHAIN with
    /// decimal commas and `K` lines, LF line ends.
    pub fn builtin(dialect: Dialect) -> LogFormat {
        LogFormat {
            dialect,
            prt: fanuc::Prt::Spaces,
            tape_marks: true,
            comma: true,
            logged: Logged::Contact,
            crlf: false,
        }
    }

    /// The line end the control writes.
    pub(crate) fn eol(&self) -> &'static str {
        if self.crlf { "\r\n" } else { "\n" }
    }

    /// The lines a run writes before its first touch.
    pub fn header(&self, test: &str) -> Vec<String> {
        match self.dialect {
            Dialect::Fanuc => {
                let mut v = Vec::new();
                if self.tape_marks {
                    v.push("%".to_string());
                }
                v.push(format!("FIVECAL {}", test.to_ascii_uppercase()));
                v
            }
            Dialect::Heidenhain | Dialect::Linuxcnc | Dialect::Sinumerik => {
                vec![format!("FIVECAL {test}")]
            }
        }
    }

    /// The lines a run writes after its last touch.
    pub(crate) fn footer(&self) -> Vec<String> {
        match self.dialect {
            Dialect::Fanuc if self.tape_marks => vec!["%".to_string()],
            _ => Vec::new(),
        }
    }

    /// The line the program writes for a touch: its 1-based `index` (FANUC,
    /// HEIDENHAIN) or `label` (LinuxCNC), the `recorded` X, Y, Z (program
    /// coordinates, mm), and for HEIDENHAIN's compensated `K` lines the
    /// touch's nominal outward normal in program coordinates and the ball
    /// radius (the control subtracts the radius along the probing axis,
    /// which is the normal for an axis-parallel touch).
    pub fn line(
        &self,
        index: usize,
        label: &str,
        recorded: &Vector3<f64>,
        normal_prog: &Vector3<f64>,
        ball_radius: f64,
    ) -> String {
        match self.dialect {
            Dialect::Fanuc => fanuc::touch_line(index, recorded, self.prt),
            Dialect::Heidenhain => {
                let p = match self.logged {
                    Logged::BallCentre => *recorded,
                    Logged::Contact => recorded - normal_prog.normalize() * ball_radius,
                };
                heidenhain::touch_line(index, &p, self.logged, self.comma)
            }
            Dialect::Linuxcnc => linuxcnc::log_line(label, recorded),
            Dialect::Sinumerik => sinumerik::touch_line(index, recorded),
        }
    }
}
