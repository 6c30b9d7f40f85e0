//! The column test (Ibaraki, Iritani & Matsushita 2013): square columns on
//! the rotary table, probed on their top and side faces at every pose of a
//! tilt x C grid. [`template`] reads `templates/probe-columns.yaml`;
//! [`design`] places the columns, chooses the touches each pose can make
//! and plans the safe path through them.

pub mod design;
pub mod template;

pub(crate) use design::column_obstacle;
pub use design::touch_plan;
pub(crate) use design::touch_plan_with;
pub use template::{BUILTIN_TEMPLATE, ColumnSpec, ColumnsTemplate, Side};
