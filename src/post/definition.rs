//! Postprocessor definitions: the YAML files in `postprocessors/`, embedded
//! as defaults and overridable by path. Loading (load.rs) compiles every
//! template here and renders it once with sample values (render.rs), so a typo in a user's definition is
//! reported at load time as `file:line:column: ...`, pointing into the
//! template inside the YAML file.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use indexmap::IndexMap;
use minijinja::{Environment, UndefinedBehavior};
use serde::{Deserialize, Serialize};

use super::number::NumberFormat;
use crate::machine::Dialect;
use crate::source::{SourceError, locate_yaml_key};

/// Every template a definition may hold, with whether it is required.
pub(crate) const TEMPLATE_NAMES: [(&str, bool); 27] = [
    ("header", true),
    ("preamble", true),
    ("footer", true),
    ("comment", true),
    ("section", false),
    ("tool_call", true),
    ("spindle_on", true),
    ("spindle_off", true),
    ("coolant_on", true),
    ("coolant_off", true),
    ("rapid", true),
    ("feed", true),
    ("retract", true),
    ("rotary", true),
    ("tilted_plane", false),
    ("tilted_plane_off", false),
    ("tcp_on", false),
    ("tcp_off", false),
    ("probe_move", false),
    ("probe_read", false),
    ("log_open", false),
    ("log_point", false),
    ("log_close", false),
    ("log_header_format", false),
    ("log_touch_format", false),
    ("dwell", false),
    ("stop", false),
];

/// How `--kinematics controller` positions are written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ControllerKinematics {
    /// A tilted working plane (FANUC G68.2/G53.1, HEIDENHAIN PLANE SPATIAL):
    /// coordinates in the plane frame.
    TiltedPlane,
    /// Tool centre point control (FANUC G43.4, HEIDENHAIN FUNCTION TCPM):
    /// coordinates in the work frame with the rotary positions.
    Tcp,
    /// The control has neither (stock LinuxCNC): `--kinematics controller`
    /// is refused.
    None,
}

/// Block numbering.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BlockNumbers {
    /// Prefix before the number (`N` for FANUC, empty for HEIDENHAIN).
    #[serde(default)]
    pub prefix: String,
    /// First number.
    pub start: u64,
    /// Increment.
    pub step: u64,
    /// Numbers wrap back to `start` after this.
    #[serde(default = "default_max")]
    pub max: u64,
    /// Lines starting with one of these are not numbered (`%`, `O`, `(`).
    #[serde(default)]
    pub skip: Vec<String>,
}

fn default_max() -> u64 {
    99_999
}

/// Comment rules.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CommentRules {
    /// Upper-case the text.
    #[serde(default)]
    pub upper: bool,
    /// Characters allowed in comments; others become spaces. Empty: all
    /// printable ASCII except the ones in `forbidden`.
    #[serde(default)]
    pub allowed: String,
    /// Characters never allowed (the comment delimiters).
    #[serde(default)]
    pub forbidden: String,
}

/// Number formats by kind.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Numbers {
    /// X, Y, Z and other lengths, mm.
    pub length: NumberFormat,
    /// Rotary positions and plane angles, deg.
    pub angle: NumberFormat,
    /// Feeds, mm/min.
    pub feed: NumberFormat,
    /// Spindle speeds, rpm.
    pub speed: NumberFormat,
    /// Dwell times, s.
    pub time: NumberFormat,
}

/// M-codes (or equivalent words) for coolant kinds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CoolantCodes {
    /// Flood.
    pub flood: String,
    /// Mist.
    pub mist: String,
    /// Air blow.
    pub air: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DefinitionFile {
    name: String,
    #[serde(default)]
    description: String,
    dialect: Dialect,
    extension: String,
    line_limit: usize,
    #[serde(default)]
    block_numbers: Option<BlockNumbers>,
    comment: CommentRules,
    numbers: Numbers,
    coolant: CoolantCodes,
    controller: ControllerKinematics,
    #[serde(default)]
    probe_axis_aligned: bool,
    #[serde(default)]
    log_limit_kb: Option<f64>,
    templates: IndexMap<String, String>,
}

/// Where a template's text sits in the definition file, to turn template
/// positions into file positions.
#[derive(Clone, Debug)]
struct TemplateSpot {
    /// 1-based file line of the template's first line.
    line: usize,
    /// 1-based column of the template's first character on its lines.
    column: usize,
    /// Block scalar (`|`): template line n is file line `line + n - 1`.
    block: bool,
}

/// Why a definition could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum DefinitionError {
    /// Neither a path nor a built-in definition.
    #[error(
        "no built-in postprocessor `{0}` (built-in: fanuc, heidenhain, linuxcnc, sinumerik); a postprocessor file is named by its path, with a `/` or a `.yaml` extension (./{0}.yaml)"
    )]
    NotFound(String),
    /// Malformed definition or template.
    #[error(transparent)]
    Invalid(#[from] SourceError),
}

/// A loaded, validated postprocessor definition.
#[derive(Clone)]
pub struct PostDefinition {
    /// Short name (`fanuc`).
    pub name: String,
    /// One line on what it is for.
    pub description: String,
    /// The dialect it writes.
    pub dialect: Dialect,
    /// Program file extension, without the dot.
    pub extension: String,
    /// Maximum characters per block, block number included.
    pub line_limit: usize,
    /// Block numbering, if any.
    pub block_numbers: Option<BlockNumbers>,
    /// Comment rules.
    pub comment: CommentRules,
    /// Number formats.
    pub numbers: Numbers,
    /// Coolant codes.
    pub coolant: CoolantCodes,
    /// How controller kinematics is written.
    pub controller: ControllerKinematics,
    /// Probe moves must run along one program axis (HEIDENHAIN cycle 0).
    pub probe_axis_aligned: bool,
    /// The largest probe log the control writes, kB (SINUMERIK: machine
    /// datum MD11420 LEN_PROTOCOL_FILE); a probing plan whose log would
    /// pass it is refused.
    pub log_limit_kb: Option<f64>,
    /// The file it was read from (or `<built-in NAME>`).
    pub path: PathBuf,
    /// Its text, for copying next to a plan.
    pub source: String,
    templates: IndexMap<String, String>,
    spots: IndexMap<String, TemplateSpot>,
    pub(super) env: Arc<Environment<'static>>,
}

impl std::fmt::Debug for PostDefinition {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PostDefinition")
            .field("name", &self.name)
            .field("path", &self.path)
            .finish_non_exhaustive()
    }
}

impl PostDefinition {
    /// Parses a definition's text and compiles its templates, without
    /// rendering them (`PostDefinition::parse`, in load.rs, renders each
    /// once to check it); `path` is used in errors.
    pub(super) fn compile(path: &Path, src: &str) -> Result<PostDefinition, SourceError> {
        let f: DefinitionFile = crate::input::parse_yaml(path, src)?;
        let err = |keys: &[&str], msg: String| SourceError::at_key(path, src, keys, msg);
        if f.line_limit < 20 {
            return Err(err(
                &["line_limit"],
                format!(
                    "line_limit must be at least 20 characters, got {}",
                    f.line_limit
                ),
            ));
        }
        if f.extension.is_empty() || !f.extension.chars().all(|c| c.is_ascii_alphanumeric()) {
            return Err(err(
                &["extension"],
                format!(
                    "extension must be letters and digits without the dot, got `{}`",
                    f.extension
                ),
            ));
        }
        if let Some(kb) = f.log_limit_kb {
            if f.dialect != Dialect::Sinumerik {
                return Err(err(
                    &["log_limit_kb"],
                    "log_limit_kb is the size limit of SINUMERIK's protocol files (MD11420); the other dialects' logs have none fivecal checks: remove it".to_string(),
                ));
            }
            if !(kb.is_finite() && (1.0..=1.0e6).contains(&kb)) {
                return Err(err(
                    &["log_limit_kb"],
                    format!(
                        "log_limit_kb is the control's MD11420 LEN_PROTOCOL_FILE in kB: expected 1 to 1000000, got {}",
                        crate::numbers::echo(kb)
                    ),
                ));
            }
        }
        if let Some(b) = &f.block_numbers
            && (b.step == 0 || b.max <= b.start)
        {
            return Err(err(
                &["block_numbers"],
                format!(
                    "block_numbers needs step > 0 and max > start, got start {}, step {}, max {}",
                    b.start, b.step, b.max
                ),
            ));
        }
        for (kind, nf) in [
            ("length", &f.numbers.length),
            ("angle", &f.numbers.angle),
            ("feed", &f.numbers.feed),
            ("speed", &f.numbers.speed),
            ("time", &f.numbers.time),
        ] {
            if nf.decimals > 9 {
                return Err(err(
                    &["numbers", kind, "decimals"],
                    format!("at most 9 decimals, got {}", nf.decimals),
                ));
            }
        }
        for key in f.templates.keys() {
            if !TEMPLATE_NAMES.iter().any(|(n, _)| n == key) {
                let names: Vec<&str> = TEMPLATE_NAMES.iter().map(|(n, _)| *n).collect();
                return Err(err(
                    &["templates", key],
                    format!(
                        "unknown template `{key}`: expected one of {}",
                        names.join(", ")
                    ),
                ));
            }
        }
        for (name, required) in TEMPLATE_NAMES {
            if required && !f.templates.contains_key(name) {
                return Err(err(
                    &["templates"],
                    format!("template `{name}` is missing (every definition needs it)"),
                ));
            }
        }
        match f.controller {
            ControllerKinematics::TiltedPlane => {
                for t in ["tilted_plane", "tilted_plane_off"] {
                    if !f.templates.contains_key(t) {
                        return Err(err(
                            &["controller"],
                            format!("controller: tilted_plane needs the template `{t}`"),
                        ));
                    }
                }
            }
            ControllerKinematics::Tcp => {
                for t in ["tcp_on", "tcp_off"] {
                    if !f.templates.contains_key(t) {
                        return Err(err(
                            &["controller"],
                            format!("controller: tcp needs the template `{t}`"),
                        ));
                    }
                }
            }
            ControllerKinematics::None => {}
        }

        let spots: IndexMap<String, TemplateSpot> = f
            .templates
            .keys()
            .map(|k| (k.clone(), spot_of(src, k)))
            .collect();

        let mut env = Environment::new();
        env.set_undefined_behavior(UndefinedBehavior::Strict);
        // A step budget per block: a runaway loop ends with an error.
        env.set_fuel(Some(crate::limits::TEMPLATE_FUEL));
        env.set_debug(true);
        let nums = f.numbers.clone();
        let fmt = |nf: NumberFormat| move |v: f64| nf.format(v);
        env.add_filter("mm", fmt(nums.length));
        env.add_filter("deg", fmt(nums.angle));
        env.add_filter("feed", fmt(nums.feed));
        env.add_filter("rpm", fmt(nums.speed));
        env.add_filter("sec", fmt(nums.time));
        env.add_filter("mpf_name", |s: String| super::sinumerik_program_name(&s));
        for (name, text) in &f.templates {
            if let Err(e) = env.add_template_owned(name.clone(), text.clone()) {
                return Err(template_error(path, &spots[name], text, name, &e));
            }
        }

        let def = PostDefinition {
            name: f.name,
            description: f.description,
            dialect: f.dialect,
            extension: f.extension,
            line_limit: f.line_limit,
            block_numbers: f.block_numbers,
            comment: f.comment,
            numbers: f.numbers,
            coolant: f.coolant,
            controller: f.controller,
            probe_axis_aligned: f.probe_axis_aligned,
            log_limit_kb: f.log_limit_kb,
            path: path.to_path_buf(),
            source: src.to_string(),
            templates: f.templates,
            spots,
            env: Arc::new(env),
        };
        Ok(def)
    }

    /// An error located at the start of template `name`.
    pub(super) fn error_at(&self, name: &str, message: String) -> SourceError {
        let spot = self.spots.get(name);
        SourceError::new(
            &self.path,
            spot.map_or(0, |s| s.line),
            spot.map_or(0, |s| s.column),
            format!("template `{name}`: {message}"),
        )
    }

    /// Whether the definition has a template.
    pub fn has(&self, name: &str) -> bool {
        self.templates.contains_key(name)
    }

    /// Renders one template; errors point into the definition file.
    pub(super) fn render_template(
        &self,
        name: &str,
        ctx: minijinja::Value,
    ) -> Result<String, SourceError> {
        let tmpl = self
            .env
            .get_template(name)
            .expect("templates were compiled at load");
        tmpl.render(ctx).map_err(|e| {
            template_error(
                &self.path,
                &self.spots[name],
                &self.templates[name],
                name,
                &e,
            )
        })
    }
}

/// Finds where template `key` starts in the file.
fn spot_of(src: &str, key: &str) -> TemplateSpot {
    let Some((line, col)) = locate_yaml_key(src, &["templates", key]) else {
        return TemplateSpot {
            line: 0,
            column: 0,
            block: false,
        };
    };
    let text = src.lines().nth(line - 1).unwrap_or("");
    let after = (col - 1) + key.len() + 1;
    let rest = text.get(after..).unwrap_or("");
    let value = rest.trim_start();
    let value_col = after + (rest.len() - value.len()) + 1;
    if value.starts_with('|') || value.starts_with('>') {
        // The block's indentation is that of its first non-blank line.
        let indent = src
            .lines()
            .skip(line)
            .find(|l| !l.trim().is_empty())
            .map(|l| l.len() - l.trim_start().len())
            .unwrap_or(0);
        TemplateSpot {
            line: line + 1,
            column: indent + 1,
            block: true,
        }
    } else {
        let quoted = value.starts_with('"') || value.starts_with('\'');
        TemplateSpot {
            line,
            column: value_col + usize::from(quoted),
            block: false,
        }
    }
}

fn template_error(
    path: &Path,
    spot: &TemplateSpot,
    text: &str,
    name: &str,
    e: &minijinja::Error,
) -> SourceError {
    let tline = e.line().unwrap_or(1).max(1);
    // Column of the failing expression inside its template line.
    let tcol = e
        .range()
        .map(|r| {
            let before = &text[..r.start.min(text.len())];
            before.len() - before.rfind('\n').map_or(0, |i| i + 1)
        })
        .unwrap_or(0);
    let (line, column) = if spot.line == 0 {
        (0, 0)
    } else if spot.block {
        (spot.line + tline - 1, spot.column + tcol)
    } else {
        (spot.line, spot.column + tcol)
    };
    let detail = if e.kind() == minijinja::ErrorKind::OutOfFuel {
        format!(
            ": more than {} steps to render one block (a loop without end?)",
            crate::limits::TEMPLATE_FUEL
        )
    } else {
        e.detail().map(|d| format!(": {d}")).unwrap_or_default()
    };
    SourceError::new(
        path,
        line,
        column,
        format!("template `{name}`: {}{detail}", e.kind()),
    )
}
