//! Writes the program `compensate` is timed on (`benches/compensate.rs`)
//! to a file, with the error file it is compensated with, so that the
//! README's figure for `fivecal compensate` can be measured from file to
//! file as a user runs it (docs/speed.md):
//!
//! ```text
//! cargo run --release --example dome_program -- DIR [BLOCKS]
//! fivecal compensate --machine bc-trunnion --errors DIR/dome.errors.yaml DIR/dome.nc -o OUT
//! ```
//!
//! `DIR/dome.nc` has `BLOCKS` blocks of the spiral (default 1,000,000)
//! after five opening blocks; neither file is committed (55 MB).

#[path = "../benches/support/dome.rs"]
mod dome;

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, bail};
use fivecal::{Kinematics, Machine};

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let Some(dir) = args.next().map(PathBuf::from) else {
        bail!("usage: dome_program DIR [BLOCKS]");
    };
    let blocks: usize = match args.next() {
        Some(n) => n
            .parse()
            .with_context(|| format!("BLOCKS: not a count: {n}"))?,
        None => 1_000_000,
    };
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let machine = Machine::builtin("bc-trunnion").context("the built-in bc-trunnion")?;
    let kin = Kinematics::new(&machine);
    let lines = dome::blocks(&kin);
    let path = dir.join("dome.nc");
    let file = std::fs::File::create(&path).with_context(|| format!("{}", path.display()))?;
    let mut out = std::io::BufWriter::new(file);
    out.write_all(dome::HEADER)?;
    for k in 0..blocks {
        out.write_all(&lines[k % dome::DISTINCT])?;
    }
    out.flush()?;
    let errors = dir.join("dome.errors.yaml");
    std::fs::write(&errors, dome::ERRORS).with_context(|| format!("{}", errors.display()))?;
    println!(
        "wrote {} ({blocks} blocks) and {}",
        path.display(),
        errors.display()
    );
    Ok(())
}
