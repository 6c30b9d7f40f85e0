//! The one integration-test binary (as ripgrep and uv do): topic modules
//! below, shared helpers in `util`, and `regression` for pinned cases named
//! after what they pin.

mod util;

mod analyze;
mod analyze_sim;
mod architecture;
mod ball_bar;
mod ball_bar_analyze;
mod cli;
mod cli_json;
mod compensate;
mod compensate_cli;
mod contour;
mod controller_models;
mod controller_semantics;
mod discover;
mod discover_ambiguity;
mod discover_cli;
mod doc_commands;
mod elements;
mod errorfile;
mod fuzz_readers;
mod goodness;
mod history;
mod hostile;
mod hostile_round2;
mod identifiability;
mod identify;
mod kinematics;
mod laser_lines;
mod machine;
mod macros;
mod measured;
mod montecarlo;
mod nc;
mod offsets;
mod plan;
mod plan_programs;
mod planes;
mod post;
mod preview;
mod probe_fit;
mod probe_log;
mod probe_outputs;
mod probe_plan;
mod probe_programs;
mod readme;
mod regression;
mod shop_floor;
mod simulate;
mod simulate_forward;
mod simulate_outputs;
mod sinumerik;
mod sinumerik_programs;
mod store;
