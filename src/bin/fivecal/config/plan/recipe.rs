//! Where the changes `plan` suggests are made, and the command that plans
//! them: this run's command line without its template and output options.

use fivecal::procedure::Test;

use super::Config;

/// Where a user makes a change `plan` suggests: the template file given,
/// else a copy of the one this plan used, as written beside the plan (the
/// built-in one, or the supplement's).
pub fn recipe(cfg: &Config, test: Test) -> fivecal::discover::suggest::Recipe {
    use fivecal::discover::suggest::Recipe;
    match &cfg.template_file {
        Some(p) => Recipe {
            file: p.display().to_string(),
            copy_of: None,
            command: Some(cfg.command.clone()),
            out: Some(cfg.out.display().to_string()),
            machine: Some(cfg.machine_arg.clone()),
        },
        None => Recipe {
            file: format!("my-{test}.yaml"),
            // The plan writes the template it used beside itself: a user
            // without the repository's templates/ has that copy.
            copy_of: Some(format!(
                "{}, the {} template this plan used, as written beside it",
                cfg.out.join(format!("{test}.template.yaml")).display(),
                if cfg.supplement {
                    "supplementary test's"
                } else {
                    "built-in"
                }
            )),
            command: Some(cfg.command.clone()),
            out: Some(cfg.out.display().to_string()),
            machine: Some(cfg.machine_arg.clone()),
        },
    }
}
