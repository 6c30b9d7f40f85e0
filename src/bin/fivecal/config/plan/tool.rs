//! `plan --tool`: the machine file's tool, a tool file, or an inline
//! mapping, read and checked as a machine file's tool is.

use std::path::{Path, PathBuf};

use anyhow::bail;
use fivecal::machine::{Machine, Tool, check_tool};
use fivecal::source::SourceError;

/// The tool `spec` names, and the file it was read from (an input).
pub(super) fn parse_tool(spec: &str, machine: &Machine) -> anyhow::Result<(Tool, Option<PathBuf>)> {
    if spec == "machine" {
        return Ok((machine.tool.clone(), None));
    }
    let (path, text, file) = if Path::new(spec).exists() {
        let p = PathBuf::from(spec);
        let t = fivecal::input::read_text(&p, "tool file", fivecal::limits::MAX_YAML_BYTES)?;
        (p.clone(), t, Some(p))
    } else if spec.trim_start().starts_with('{') {
        (PathBuf::from("<--tool>"), spec.to_string(), None)
    } else {
        bail!(
            "--tool `{spec}`: expected `machine`, a tool file, or an inline mapping such as '{{name: D6 ball, kind: ball, diameter: 6, length: 50}}'"
        );
    };
    let tool: Tool = fivecal::input::parse_yaml(&path, &text)?;
    check_tool(&tool).map_err(|(k, m)| SourceError::at_key(&path, &text, &[k], m))?;
    Ok((tool, file))
}
