//! `fivecal simulate` (issue 5): run a plan on the virtual machine and write
//! what the CMM or the probe would have written. The options are validated
//! into one configuration in `config/simulate.rs`. The `nc` mode (issue 7)
//! lives in `simulate_nc.rs`.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use fivecal::ErrorFile;
use fivecal::formats::manifest::{Manifest, TestKind};
use fivecal::io::{Shape, check_outputs};
use fivecal::simulate::{self, Format, Placement, SimOptions, SimOutput};
use fivecal::{Kinematics, Machine};
use serde::Serialize;

use crate::config::simulate::{Config, SimulateCli, SimulateMode, validate};

pub fn run(cli: SimulateCli) -> anyhow::Result<()> {
    match cli.mode {
        Some(SimulateMode::Nc(a)) => super::simulate_nc::run(a),
        None if cli.args.truth_example => truth_example(&cli.args.machine),
        None => simulate(validate(cli.args)?),
    }
}

fn truth_example(machine: &str) -> anyhow::Result<()> {
    let (m, origin) =
        Machine::resolve(machine).with_context(|| format!("cannot load machine `{machine}`"))?;
    // Standard output is the truth file itself.
    eprintln!("note: machine {}: {origin}", m.name);
    out!("{}", simulate::truth::example(&Kinematics::new(&m)));
    Ok(())
}

/// Every file of the plan directory the manifest names, and the manifest.
fn plan_inputs(manifest_path: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let m = Manifest::read(manifest_path)?;
    let mut v = vec![
        manifest_path.to_path_buf(),
        m.resolve(manifest_path, &m.machine_file),
        m.resolve(manifest_path, &m.template_file),
    ];
    v.extend(m.files.values().map(|f| m.resolve(manifest_path, f)));
    Ok(v)
}

fn simulate(c: Config) -> anyhow::Result<()> {
    if super::ball_bar::is_ball_bar(&c.plan_path) {
        return super::ball_bar::simulate(&c.plan_path, &c.errors, &c.out, c.ball_bar);
    }
    if super::laser::is_laser(&c.plan_path) {
        let opts = fivecal::simulate::laser::LaserOptions {
            noise_um: c.ball_bar.noise_um,
            seed: c.ball_bar.seed,
        };
        return super::laser::simulate(&c.plan_path, &c.errors, &c.out, opts);
    }
    if c.json {
        // Standard output is the JSON's: what the run says goes to
        // standard error.
        crate::out::to_stderr();
    }
    let mut inputs = plan_inputs(&c.plan_path)?;
    inputs.push(c.errors.clone());
    let refs: Vec<&Path> = inputs.iter().map(|p| p.as_path()).collect();
    check_outputs(&refs, &[("--out", &c.out, Shape::File)])?;
    let plan = fivecal::procedure::load(&c.plan_path)?;
    let kind = plan.kind();
    let format = c
        .format
        .unwrap_or_else(|| Format::for_path(&c.out, kind, plan.test()));
    simulate::output::check(format, kind, plan.test())?;
    let kin = simulate::plan_kinematics(&plan);
    let truth = ErrorFile::load(&c.errors, &kin)?;
    let mut opts = c.opts;
    opts.placement = c.placement.unwrap_or(match format {
        Format::Csv => Placement::Random,
        _ => Placement::Aligned,
    });
    let out = simulate::run(&plan, &truth, &opts).with_context(|| {
        format!(
            "cannot simulate {} with the errors of {}",
            c.plan_path.display(),
            c.errors.display()
        )
    })?;
    out.write(format, &c.out)?;
    summary(&out, format, &c.out, &opts);
    if c.json {
        crate::out::json_of(&Simulated::new(&out, format, &c.out, &opts))?;
    }
    Ok(())
}

/// What `simulate --json` prints: what was simulated and the file written.
#[derive(Serialize)]
struct Simulated {
    test: String,
    /// `machining` or `probing`.
    kind: &'static str,
    machine: String,
    seed: u64,
    /// The measurement file's format (csv, dmis, qif, log, heights).
    format: String,
    /// Machining: where the piece lay on the CMM (`random`, `aligned`).
    #[serde(skip_serializing_if = "Option::is_none")]
    placement: Option<&'static str>,
    /// Points measured (machining) or touches probed (probing).
    points: usize,
    /// Probing: pieces set up with seeded errors (0: at their nominal
    /// places).
    #[serde(skip_serializing_if = "Option::is_none")]
    setups_with_errors: Option<usize>,
    /// Nine-section heights written, um.
    #[serde(skip_serializing_if = "Option::is_none")]
    heights: Option<Vec<Height>>,
    /// The files written.
    files: Vec<String>,
}

#[derive(Serialize)]
struct Height {
    section: u32,
    height_um: f64,
}

impl Simulated {
    fn new(out: &SimOutput, format: Format, path: &Path, opts: &SimOptions) -> Simulated {
        let probing = out.kind == TestKind::Probing;
        Simulated {
            test: out.test.to_string(),
            kind: if probing { "probing" } else { "machining" },
            machine: out.machine.clone(),
            seed: out.seed,
            format: format.to_string(),
            placement: (!probing).then_some(match opts.placement {
                Placement::Aligned => "aligned",
                Placement::Random => "random",
                Placement::Given(_) => "given",
            }),
            points: out.points.len(),
            setups_with_errors: probing.then(|| {
                out.setups
                    .iter()
                    .filter(|s| s.1 != nalgebra::Isometry3::identity())
                    .count()
            }),
            heights: out.heights.as_ref().map(|h| {
                h.iter()
                    .map(|s| Height {
                        section: s.section,
                        height_um: s.height_um,
                    })
                    .collect()
            }),
            files: vec![path.display().to_string()],
        }
    }
}

fn summary(out: &SimOutput, format: Format, path: &Path, opts: &SimOptions) {
    let what = match out.kind {
        TestKind::Machining if format == Format::Heights => format!(
            "heights of {} sections from {} points of the machined piece",
            out.heights.as_ref().map_or(0, |h| h.len()),
            out.points.len()
        ),
        TestKind::Machining => format!(
            "{} points of the machined piece, measured on a CMM ({})",
            out.points.len(),
            if opts.placement == Placement::Aligned {
                "part frame aligned on W"
            } else {
                "placed at random"
            }
        ),
        TestKind::Probing => format!(
            "{} touches probed on the machine ({})",
            out.points.len(),
            if out
                .setups
                .iter()
                .all(|s| s.1 == nalgebra::Isometry3::identity())
            {
                "pieces at their nominal places".to_string()
            } else {
                let n = out.setups.len();
                format!(
                    "{n} {} set up with seeded errors",
                    if n == 1 { "piece" } else { "pieces" }
                )
            }
        ),
    };
    outln!(
        "wrote {} ({format}): {} on {}, seed {}: {what}",
        path.display(),
        out.test,
        out.machine,
        out.seed
    );
    if let Some(h) = &out.heights {
        for s in h {
            outln!("  section {:>2}: {:>9.3} um", s.section, s.height_um);
        }
    }
}
