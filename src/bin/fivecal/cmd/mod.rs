//! One module per subcommand: its `run` turns the command's validated
//! configuration into library calls and prints. Every command's options
//! and their validation are in `config/`.

pub mod analyze;
pub mod ball_bar;
pub mod compensate;
pub mod compensate_json;
pub mod contour;
pub mod demo;
pub mod discover;
pub mod docs;
pub mod history;
pub mod laser;
pub mod machine;
pub mod measured;
pub mod plan;
pub mod record;
pub mod simulate;
pub mod simulate_nc;
pub mod verify;
pub mod vocabulary;
