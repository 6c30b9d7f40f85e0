//! fivecal: geometric calibration of five-axis machine tools.
//!
//! The library is organised by capability. [`machine`] reads machine files;
//! [`kinematics`] is the exact model of docs/model.md with its inverse and
//! Jacobians; [`model`] adds the named effects (location errors, error maps,
//! drift, linear-axis, tool and probe errors) that `simulate` runs forward,
//! `analyze` inverts and `discover` searches; [`errorfile`] reads and writes
//! the error files of docs/formats.md.
//!
//! Units: mm and degrees in NC programs, plans and machine files; um and
//! urad in error files and model parameters; mm and rad inside the chain.

#![warn(missing_docs)]
#![deny(unreachable_pub)]

pub mod analyze;
pub mod compensate;
pub mod conformance;
pub mod contour;
pub mod demo;
pub mod discover;
pub mod errorfile;
pub mod formats;
pub mod geom;
pub mod history;
pub mod identify;
pub mod input;
pub mod io;
pub mod kinematics;
pub mod limits;
pub mod machine;
pub mod mesh;
pub mod model;
pub mod nc;
pub mod numbers;
pub mod placement;
pub mod post;
pub mod procedure;
pub mod report;
pub mod shape_fit;
pub mod simulate;
pub mod source;
pub mod store;

pub use errorfile::ErrorFile;
pub use kinematics::{Axes, Kinematics, Perturbation, ToolPose};
pub use machine::{Dialect, Machine};
pub use model::{Context, Effect, Model};
