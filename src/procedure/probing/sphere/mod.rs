//! The sphere test: a calibration sphere on a stem on the rotary table,
//! touched along the program's axes at every pose of a C and tilt sweep
//! (Cubas Brizuela & Yeh 2023) or of a spiral of poses. [`template`] reads
//! `templates/probe-sphere.yaml`; [`design`] places the sphere, lists the
//! poses and plans the touches and the safe path through them.

pub mod design;
pub mod template;

pub(crate) use design::touch_plan_with;
pub use design::{poses, sphere_centre, touch_plan};
pub use template::{BUILTIN_TEMPLATE, SpherePattern, SphereTemplate};
