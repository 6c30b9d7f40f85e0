//! `fivecal demo`: the whole mission on the built-in machine, with a
//! progress display on a terminal and plain lines otherwise.

use std::io::IsTerminal;
use std::time::{Duration, Instant};

use fivecal::demo::{self, DemoConfig, Stage};
use indicatif::{ProgressBar, ProgressStyle};

use crate::config::demo::DemoArgs;

pub fn run(a: DemoArgs) -> anyhow::Result<()> {
    fivecal::io::check_outputs(&[], &[("--out", &a.out, fivecal::io::Shape::Dir)])?;
    let cfg = DemoConfig {
        out: a.out,
        seed: a.seed,
    };
    let start = Instant::now();
    let total = Stage::ALL.len() as u64;
    let bar = std::io::stderr().is_terminal().then(|| {
        let b = ProgressBar::new(total);
        b.set_style(
            ProgressStyle::with_template("{spinner} [{pos}/{len}] {msg} ({elapsed})")
                .expect("a valid progress template"),
        );
        b.enable_steady_tick(Duration::from_millis(120));
        b
    });
    let mut n = 0;
    let result = demo::run(&cfg, &mut |stage| {
        n += 1;
        match &bar {
            Some(b) => {
                b.set_position(n - 1);
                b.set_message(stage.describe());
            }
            None => eprintln!("[{n}/{total}] {}", stage.describe()),
        }
    });
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let d = result?;
    out!("{}", d.summary());
    outln!("done in {:.1} s", start.elapsed().as_secs_f64());
    Ok(())
}
