//! Loading a postprocessor definition: a built-in one by its dialect, a
//! user's by its path, each parsed (definition.rs) and then checked by
//! rendering every template once with sample values (render.rs), so a typo
//! is reported at load time, pointing into the template inside the YAML
//! file.

use std::path::Path;

use super::definition::{DefinitionError, PostDefinition};
use super::render;
use crate::machine::Dialect;
use crate::source::SourceError;

/// Built-in definitions: (name, YAML text).
pub(crate) const BUILTIN: [(&str, &str); 4] = [
    ("fanuc", include_str!("../../postprocessors/fanuc.yaml")),
    (
        "heidenhain",
        include_str!("../../postprocessors/heidenhain.yaml"),
    ),
    (
        "linuxcnc",
        include_str!("../../postprocessors/linuxcnc.yaml"),
    ),
    (
        "sinumerik",
        include_str!("../../postprocessors/sinumerik.yaml"),
    ),
];

impl PostDefinition {
    /// The built-in definition of a dialect.
    pub fn builtin(dialect: Dialect) -> PostDefinition {
        let (name, src) = BUILTIN
            .iter()
            .find(|(n, _)| *n == dialect.name())
            .expect("every dialect has a built-in definition");
        PostDefinition::parse(Path::new(&format!("<built-in {name}>")), src)
            .expect("built-in postprocessors are valid")
    }

    /// Loads a definition named on the command line: a built-in dialect
    /// name means the built-in definition; a file is taken only as a path,
    /// with a `/` or a `.yaml` extension (as machines are).
    pub fn load(spec: &str) -> Result<PostDefinition, DefinitionError> {
        if !crate::machine::is_path_spec(spec) {
            return match spec.parse::<Dialect>() {
                Ok(d) => Ok(PostDefinition::builtin(d)),
                Err(_) => Err(DefinitionError::NotFound(spec.to_string())),
            };
        }
        let path = Path::new(spec);
        let src = crate::input::read_text(path, "postprocessor", crate::limits::MAX_YAML_BYTES)?;
        Ok(PostDefinition::parse(path, &src)?)
    }

    /// Parses and validates a definition's text; `path` is used in errors.
    pub fn parse(path: &Path, src: &str) -> Result<PostDefinition, SourceError> {
        let def = PostDefinition::compile(path, src)?;
        // Render every template once with sample values: unknown variables
        // and filters surface now, with their position, rather than in the
        // middle of a plan.
        for (name, ctx) in render::sample_contexts(&def) {
            if def.has(name) {
                def.render_template(name, ctx)?;
            }
        }
        // The engine's safety rules rest on templates that do what their
        // names say: a retract moves Z alone, a rapid writes its words, a
        // rotary index moves no linear axis.
        render::check_motion_templates(&def).map_err(|(name, msg)| def.error_at(name, msg))?;
        Ok(def)
    }
}
