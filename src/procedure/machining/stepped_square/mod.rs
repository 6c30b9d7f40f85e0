//! The stepped-square test (Ibaraki & Ota 2014): squares stepped into the
//! top and the side faces of a block, each step finished at its own rotary
//! pose by a flat end mill moving the linear axes only, then measured on a
//! CMM. [`template`] reads `templates/stepped-square.yaml`; `design` lays
//! out the piece, the poses, their cutting strokes and the points in W.

pub(crate) mod design;
pub mod template;

pub use template::{Angles, BUILTIN_TEMPLATE, StepPoints, SteppedSquareTemplate, Steps, TiltSet};
