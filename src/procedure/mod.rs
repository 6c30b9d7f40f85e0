//! The calibration tests as procedures: what each test asks of the machine
//! and how it is carried out, planned as an NC program for any supported
//! machine and dialect. Each test has its own folder, holding its template
//! and its design: the machining tests under [`machining`]
//! (`stepped_square`, Ibaraki & Ota 2014; `nine_section`, Cubas Brizuela &
//! Yeh 2023), a piece cut at a set of poses and measured on a CMM, and the
//! probing tests under [`probing`] (`columns`, Ibaraki, Iritani & Matsushita
//! 2013; `sphere`), pieces touched by the machine's own probe.
//!
//! A test is named by [`Test`] and configured by its [`Template`]
//! (read from a [`TemplateSource`]); [`plan`] turns a [`PlanConfig`]
//! (machine, template, postprocessor, kinematics mode, optional tool) into
//! a [`Plan`]: a [`MachiningPlan`] or a [`ProbingPlan`], each holding its
//! poses, program and nominal points (their module docs say what a
//! simulator finds there). [`Plan::write`] writes the plan's files with its
//! manifest `<test>.plan.yaml`, and [`load`] rebuilds the very same plan
//! from a written manifest.

pub mod ball_bar;
mod bounds;
mod instrument_nc;
pub mod laser_lines;
mod load;
pub mod machining;
mod outputs;
pub mod probing;
mod template;
mod test;

use std::path::PathBuf;

use crate::formats::manifest::{KinematicsMode, TestKind};
use crate::formats::points::PlanPoints;
use crate::kinematics::IkError;
use crate::machine::{Dialect, Machine, Tool};
use crate::post::{PostDefinition, PostError, RenderedProgram};
use crate::source::SourceError;

pub use crate::formats::manifest::Test;
pub use load::{LoadError, load};
pub use machining::MachiningPlan;
pub use probing::ProbingPlan;
pub use template::{Template, TemplateSource};

pub(crate) use bounds::echo;
pub(crate) use outputs::{capitalised, push_notes, round, short};

/// Everything `plan` needs, validated.
#[derive(Clone, Debug)]
pub struct PlanConfig {
    /// The machine.
    pub machine: Machine,
    /// The test template (it names the test).
    pub template: Template,
    /// The postprocessor definition (its dialect is the program's).
    pub post: PostDefinition,
    /// How 3+2 positions are written (machining tests; a probing program
    /// always positions every axis itself).
    pub kinematics: KinematicsMode,
    /// A tool replacing the template's (machining tests; the probing tests
    /// use the machine file's probe).
    pub tool: Option<Tool>,
}

impl PlanConfig {
    /// The configuration of the built-in template of `test` on `machine`,
    /// with the machine's own dialect, kinematics computed by fivecal and
    /// the template's tool.
    pub fn builtin(machine: Machine, test: Test) -> PlanConfig {
        let post = PostDefinition::builtin(machine.dialect);
        PlanConfig {
            machine,
            template: Template::builtin(test),
            post,
            kinematics: KinematicsMode::Post,
            tool: None,
        }
    }
}

/// Why a plan failed.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// A bad template value (points into the template).
    #[error(transparent)]
    Template(#[from] SourceError),
    /// The request cannot be carried out on this machine.
    #[error("{0}")]
    Impossible(String),
    /// The probing path would leave the machine's travel.
    #[error("{0}")]
    Unreachable(String),
    /// A move is outside a linear axis' stroke.
    #[error(
        "pose {pose}: {what} needs {axis} = {value:.3} (machine coordinate of the spindle gauge point), outside the {axis} stroke [{lo}, {hi}] of {machine}"
    )]
    Stroke {
        /// Pose id.
        pose: String,
        /// Which move.
        what: String,
        /// Axis letter.
        axis: char,
        /// Machine coordinate needed, mm.
        value: f64,
        /// Stroke minimum.
        lo: f64,
        /// Stroke maximum.
        hi: f64,
        /// Machine name.
        machine: String,
    },
    /// Inverse kinematics failed.
    #[error("{context}: {source}")]
    Kinematics {
        /// Where.
        context: String,
        /// Cause.
        source: IkError,
    },
    /// The planned probing path collides (a bug: the planner checks every
    /// move).
    #[error("move {move_index} ({kind:?}) of the planned path collides: {collision}")]
    Collision {
        /// Index into [`probing::TouchPlan::moves`].
        move_index: usize,
        /// Its kind.
        kind: probing::ProbingMoveKind,
        /// What.
        collision: Box<probing::Collision>,
    },
    /// The tool holder or spindle nose of a machining test would meet the
    /// table, the riser or the block.
    #[error("{0}")]
    Assembly(Box<machining::assembly::AssemblyCollision>),
    /// The postprocessor could not render the toolpath.
    #[error(transparent)]
    Post(#[from] PostError),
}

/// A planned test of either kind.
#[derive(Clone, Debug)]
pub enum Plan {
    /// A machining test (stepped-square, nine-section).
    Machining(Box<MachiningPlan>),
    /// An on-machine probing test (probe-columns, probe-sphere).
    Probing(Box<ProbingPlan>),
}

impl Plan {
    /// The test.
    pub fn test(&self) -> Test {
        match self {
            Plan::Machining(t) => t.test,
            Plan::Probing(p) => p.test,
        }
    }

    /// Machining or probing.
    pub fn kind(&self) -> TestKind {
        self.test().kind()
    }

    /// The machine.
    pub fn machine(&self) -> &Machine {
        match self {
            Plan::Machining(t) => &t.machine,
            Plan::Probing(p) => &p.machine,
        }
    }

    /// The template.
    pub fn template(&self) -> &Template {
        match self {
            Plan::Machining(t) => &t.template,
            Plan::Probing(p) => &p.template,
        }
    }

    /// The postprocessor.
    pub fn post(&self) -> &PostDefinition {
        match self {
            Plan::Machining(t) => &t.post,
            Plan::Probing(p) => &p.post,
        }
    }

    /// The program's dialect.
    pub fn dialect(&self) -> Dialect {
        match self {
            Plan::Machining(t) => t.dialect,
            Plan::Probing(p) => p.dialect,
        }
    }

    /// The rendered program.
    pub fn program(&self) -> &RenderedProgram {
        match self {
            Plan::Machining(t) => &t.program,
            Plan::Probing(p) => &p.program,
        }
    }

    /// Notes for the setup sheet (adaptations to the machine, warnings,
    /// left-out touches).
    pub fn notes(&self) -> &[String] {
        match self {
            Plan::Machining(t) => &t.notes,
            Plan::Probing(p) => &p.notes,
        }
    }

    /// The estimated run time, min.
    pub fn run_minutes(&self) -> f64 {
        match self {
            Plan::Machining(t) => t.run_minutes,
            Plan::Probing(p) => p.run_minutes(),
        }
    }

    /// The nominal points, as points.csv holds them.
    pub fn plan_points(&self) -> PlanPoints {
        match self {
            Plan::Machining(t) => t.plan_points(),
            Plan::Probing(p) => p.plan_points(),
        }
    }

    /// The machining plan, if it is one.
    pub fn machining(&self) -> Option<&MachiningPlan> {
        match self {
            Plan::Machining(t) => Some(t),
            Plan::Probing(_) => None,
        }
    }

    /// The probing plan, if it is one.
    pub fn probing(&self) -> Option<&ProbingPlan> {
        match self {
            Plan::Probing(p) => Some(p),
            Plan::Machining(_) => None,
        }
    }

    /// Output file names by role, for a plan named `stem`.
    pub(crate) fn file_names(&self, stem: &str) -> Vec<(&'static str, PathBuf)> {
        outputs::file_names(self, stem)
    }
}

impl From<MachiningPlan> for Plan {
    fn from(p: MachiningPlan) -> Plan {
        Plan::Machining(Box::new(p))
    }
}

impl From<ProbingPlan> for Plan {
    fn from(p: ProbingPlan) -> Plan {
        Plan::Probing(Box::new(p))
    }
}

/// Plans the test its template names: a machining test with the cutting
/// tool (with `stock.raise` in the template, a piece the spindle cannot
/// reach low enough within the Z stroke is put on a higher riser), a
/// probing test with the machine's probe.
pub fn plan(cfg: &PlanConfig) -> Result<Plan, PlanError> {
    Ok(match cfg.test().kind() {
        TestKind::Machining => Plan::Machining(Box::new(machining::plan(cfg)?)),
        TestKind::Probing => Plan::Probing(Box::new(probing::plan(cfg)?)),
    })
}

impl PlanConfig {
    /// The test the template names.
    pub fn test(&self) -> Test {
        self.template.test()
    }
}
