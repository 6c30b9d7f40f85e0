//! What `compensate --export` may change: the limits of `--max-change`
//! and `--max-u`, and, for SINUMERIK, the swivel data record the machine
//! file must name.

use anyhow::bail;
use fivecal::Dialect;
use fivecal::compensate::export;
use fivecal::machine::MachineOrigin;

use super::CompensateArgs;
use crate::config::nc::Common;

/// `LEN[,ANG]` of --max-change and --max-u: a length in mm and an angle in
/// mrad, each > 0 (the angle keeps `default` when not given).
fn parse_limit(option: &str, s: &str, default: f64) -> anyhow::Result<(f64, f64)> {
    let parts: Vec<Option<f64>> = s
        .split(',')
        .map(|x| {
            x.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && *v > 0.0)
        })
        .collect();
    match parts.as_slice() {
        [Some(l)] => Ok((*l, default)),
        [Some(l), Some(a)] => Ok((*l, *a)),
        _ => bail!(
            "{option} `{s}`: expected LEN or LEN,ANG, a length in mm and an angle in mrad, each > 0"
        ),
    }
}

impl CompensateArgs {
    /// `--max-change` and `--max-u`, checked.
    pub(super) fn limits(&self) -> anyhow::Result<export::Limits> {
        let defaults = export::Limits::default();
        let (change_mm, change_mrad) =
            parse_limit("--max-change", &self.max_change, defaults.change_mrad)?;
        let (u_mm, u_mrad) = parse_limit("--max-u", &self.max_u, defaults.u_mrad)?;
        Ok(export::Limits {
            change_mm,
            change_mrad,
            u_mm,
            u_mrad,
        })
    }
}

/// An export for SINUMERIK writes the fine offsets of one swivel data
/// record: the machine file must say which.
pub(super) fn swivel_record_known(d: Dialect, common: &Common) -> anyhow::Result<()> {
    if d == Dialect::Sinumerik && common.machine.sinumerik.is_none() {
        // Named, never pasted: the file is the user's own.
        let fix = match &common.machine_origin {
            MachineOrigin::File(p) => {
                format!("add `sinumerik: {{swivel_record: N}}` to {}", p.display())
            }
            MachineOrigin::BuiltIn => format!(
                "copy it with `fivecal machine new NAME --from {}` and add `sinumerik: {{swivel_record: N}}` to the copy",
                common.machine.name
            ),
        };
        bail!(
            "--export sinumerik: {} ({}) does not say which swivel data record holds its kinematics: {fix} (N as in TCARR=N, the record CYCLE800 and CYCLE996 use); nothing written",
            common.machine_origin,
            common.machine.name
        );
    }
    Ok(())
}
