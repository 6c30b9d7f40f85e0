//! One module per subcommand: its `run` turns the command's validated
//! configuration into library calls and prints. The four commands with
//! the most options (plan, analyze, discover, compensate) have their
//! options and validation in `config/`; the others still define their few
//! options beside their `run`.

pub mod analyze;
pub mod ball_bar;
pub mod compensate;
pub mod contour;
pub mod demo;
pub mod discover;
pub mod docs;
pub mod history;
pub mod machine;
pub mod measured;
pub mod plan;
pub mod record;
pub mod simulate;
pub mod simulate_nc;
pub mod verify;
pub mod vocabulary;
