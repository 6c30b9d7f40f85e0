//! The nine-section test (Cubas Brizuela & Yeh 2023): the top face of a
//! block cut in 3 x 3 sections, each at its own rotary pose, with a ball or
//! bull-nose end mill; the heights of the sections relative to the centre
//! one show the machine's error at each pose. [`template`] reads
//! `templates/nine-section.yaml`; `design` lays out the sections, their
//! raster passes and the points in W.

pub(crate) mod design;
pub mod template;

pub use template::{BUILTIN_TEMPLATE, NineSectionTemplate, SectionAngles};
