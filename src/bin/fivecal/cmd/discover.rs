//! `fivecal discover`: find the effect the model is missing, add it, show
//! the gap shrink. The options are validated into one configuration in
//! `config/discover.rs`; everything else is the library's
//! ([`fivecal::discover`]).

use std::path::PathBuf;

use fivecal::analyze;
use fivecal::discover::{self, Inputs};
use fivecal::io::shell_word;
use fivecal::io::write_atomic;
use fivecal::store::runs;

use crate::config::discover::{DiscoverArgs, validate};

pub fn run(args: DiscoverArgs) -> anyhow::Result<()> {
    let c = validate(args)?;
    // Only the final model written to --out is a result to keep.
    let mut recorder = match &c.out {
        Some(_) => Some(c.record.open()?),
        None => None,
    };
    let mut inputs = Vec::new();
    for (manifest, measured) in &c.tests {
        inputs.push(Inputs::load(manifest, measured, &c.measured_options)?);
    }
    for i in &inputs {
        for w in &i.data.warnings {
            eprintln!("warning: {w}");
        }
    }
    let d = discover::inputs::discover_together(&inputs, &c.options)?;
    if c.json {
        outln!("{}", serde_json::to_string_pretty(&d.story)?);
    } else {
        out!("{}", d.story.render());
    }
    let say = |s: String| {
        if c.json {
            eprintln!("{s}");
        } else {
            outln!("{s}");
        }
    };
    let labels = discover::inputs::labels(&inputs);
    let view = discover::merged(&discover::inputs::parts(&inputs, &labels));
    // The report first: it is the part that can fail (a plot), and a
    // failed run leaves no result file behind.
    if let Some(dir) = &c.report {
        let files = discover::report::write(dir, &d, &view)?;
        say(format!(
            "report: {} ({} files)",
            dir.join("index.html").display(),
            files.len()
        ));
    }
    if let Some(out) = &c.out {
        let expected: Vec<analyze::goodness::ExpectedNoise> = inputs
            .iter()
            .map(|i| analyze::goodness::ExpectedNoise::new(c.noise, i.data.kind, i.plan.test()))
            .collect();
        let mut f = d.error_file(&view, &expected);
        if let Some(s) = f.ambiguity.as_mut().and_then(|a| a.supplement.as_mut()) {
            s.plan = Some(c.tests[0].0.display().to_string());
        }
        if let Some(fit) = &f.fit {
            say(format!(
                "fit of the final model: {} (residuals {:.3} um against {:.3} um expected, {}; ratio {:.2})",
                fit.verdict, fit.sigma_um, fit.expected_um, fit.expected_from, fit.ratio
            ));
        }
        let json = out.extension().is_some_and(|e| e == "json");
        let text = if json {
            f.to_json() + "\n"
        } else {
            f.to_yaml()
        };
        write_atomic(out, text.as_bytes())?;
        say(format!("wrote {}", out.display()));
        if let Some(a) = &f.ambiguity {
            say(format!(
                "{} states the ambiguity: its model holds none of {}",
                out.display(),
                a.rivals
                    .iter()
                    .map(|r| r.effect.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
            if a.supplement.is_some() {
                let mut again = String::new();
                for (m, files) in &c.tests {
                    again.push_str(&format!(
                        " --plan {} --measured",
                        shell_word(&m.display().to_string())
                    ));
                    for f in files {
                        again.push_str(&format!(" {}", shell_word(&f.display().to_string())));
                    }
                }
                say(format!(
                    "next: fivecal plan --supplement {} --out supplement\n  run supplement/probe-sphere.nc on the machine, then\n  fivecal discover{again} --plan supplement/probe-sphere.plan.yaml --measured LOG",
                    shell_word(&out.display().to_string())
                ));
            }
        }
        if let Some(r) = &mut recorder {
            let measured: Vec<PathBuf> = c.tests.iter().flat_map(|t| t.1.clone()).collect();
            let manifests: Vec<PathBuf> = c.tests.iter().map(|t| t.0.clone()).collect();
            let rec = runs::discovery(
                &f.machine,
                &d.story.test,
                &manifests,
                &measured,
                out,
                &text,
                &c.record.notes,
            )?;
            r.save(&[rec], &say)?;
        }
    }
    Ok(())
}
