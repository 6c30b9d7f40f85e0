//! The rewriter's state for one machine and one set of errors: the
//! settings, the solver of the corrected axes and what the rounding of the
//! written words allows. The rewrite itself ([`super::engine`]), the
//! correction of each move ([`super::correction`]) and the writing of the
//! blocks ([`super::writer`]) stand on it, so none of them needs another's
//! home for the type they share.

use super::Settings;
use super::solver::Solver;
use crate::model::{Effect, Model};
use crate::nc::interp::{self, Interpreter};

/// A program rewriter for one machine and one set of errors.
#[derive(Clone, Debug)]
pub struct Compensator {
    pub(super) settings: Settings,
    pub(super) solver: Solver,
    /// How far the rounding of the written words can move the tool tip,
    /// mm ([`super::tolerance::rounding_bound_mm`]): every path check holds
    /// the tolerance less this, so the path of the words as written (not
    /// only of the unrounded values checked) stays within the tolerance.
    pub(super) rounding: f64,
    pub(super) not_compensated: Vec<String>,
}

impl Compensator {
    /// A rewriter for `model` with parameters `theta` (file units).
    pub fn new(model: &Model, theta: &[f64], settings: Settings) -> Compensator {
        let solver = Solver::new(model, theta, settings.max_c_swing);
        let rounding = super::tolerance::rounding_bound_mm(
            model.kin.machine(),
            settings.linear_decimals,
            settings.rotary_decimals,
        );
        let mut not_compensated = Vec::new();
        for e in &model.effects {
            let id = e.id(&model.symbols);
            match e {
                Effect::Drift { .. } => not_compensated.push(format!(
                    "{id}: a thermal drift depends on when each block runs; compensated at its start value"
                )),
                Effect::ToolRadius => not_compensated.push(format!(
                    "{id}: a tool radius error does not move the tool pose; correct it in the tool table"
                )),
                Effect::ProbePretravel => {
                    not_compensated.push(format!("{id}: applies to probing only"))
                }
                _ => {}
            }
        }
        Compensator {
            settings,
            solver,
            rounding,
            not_compensated,
        }
    }

    /// The distance, mm, a checked path may keep from the intended one:
    /// the tolerance less what the rounding of the written words can add
    /// (none left when the tolerance is finer than the rounding, which the
    /// command line refuses).
    pub(super) fn path_tolerance(&self) -> f64 {
        (self.settings.tolerance - self.rounding).max(0.0)
    }

    /// How a message says a checked path missed: the tolerance and the
    /// rounding it leaves room for.
    pub(super) fn beyond_tolerance(&self) -> String {
        format!(
            "more than the {:.3} um --tolerance {} um leaves beside the {:.3} um the written decimals can round the tip by",
            self.path_tolerance() * 1e3,
            self.settings.tolerance * 1e3,
            self.rounding * 1e3
        )
    }

    /// The settings.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// The solver.
    pub fn solver(&self) -> &Solver {
        &self.solver
    }

    /// The interpreter for this machine and these settings, at power-on.
    pub fn interpreter(&self) -> Interpreter {
        let s = &self.settings;
        let settings = interp::InterpreterSettings {
            dialect: s.dialect,
            coordinates: s.coordinates,
            origin: s.origin,
            integer_unit: s.fanuc_integer_unit,
            rotary_start: s.rotary_start.clone(),
        };
        Interpreter::new(&settings, self.solver.kinematics())
    }
}
