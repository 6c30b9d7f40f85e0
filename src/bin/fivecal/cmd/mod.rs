//! One module per subcommand: its raw arguments, their validation into one
//! configuration, and the call into the library.

pub mod analyze;
pub mod compensate;
pub mod contour;
pub mod demo;
pub mod discover;
pub mod docs;
pub mod history;
pub mod machine;
pub mod plan;
pub mod record;
pub mod simulate;
pub mod simulate_nc;
pub mod verify;
