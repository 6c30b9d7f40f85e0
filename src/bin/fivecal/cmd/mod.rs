//! One module per subcommand: its raw arguments, their validation into a
//! configuration, and the call into the library.

pub mod machine;
pub mod pending;
