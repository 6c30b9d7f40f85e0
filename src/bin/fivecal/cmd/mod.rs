//! One module per subcommand: its raw arguments, their validation into one
//! configuration, and the call into the library.

pub mod analyze;
pub mod compensate;
pub mod contour;
pub mod demo;
pub mod discover;
pub mod docs;
pub mod machine;
pub mod measured;
pub mod plan;
pub mod simulate;
pub mod simulate_nc;
