//! Test templates: the YAML files in `templates/`, compiled in as defaults
//! and overridable by a path. A template fixes what its test's plan does
//! that the machine file and the command line do not: the piece or setup,
//! the poses, the tool or probe, the feeds and clearances. Each test reads
//! and checks its own template (`<test>/template.rs`); this module holds
//! what they share: the text with where it came from ([`TemplateSource`],
//! for `file:line:column` messages at the offending key), and the choice
//! among them by the template's `test:` key ([`Template`]).

use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::Test;
use super::machining::nine_section::NineSectionTemplate;
use super::machining::stepped_square::SteppedSquareTemplate;
use super::probing::ProbingSettings;
use super::probing::columns::ColumnsTemplate;
use super::probing::sphere::SphereTemplate;
use crate::source::SourceError;

/// A template's text and where it came from, for error positions.
#[derive(Clone, Debug, PartialEq)]
pub struct TemplateSource {
    /// The file as named (or `<built-in NAME>`).
    pub path: PathBuf,
    /// Its YAML text.
    pub text: String,
}

impl TemplateSource {
    /// The text `text` of the file `path`.
    pub fn new(path: &Path, text: &str) -> TemplateSource {
        TemplateSource {
            path: path.to_path_buf(),
            text: text.to_string(),
        }
    }

    /// The built-in template of a test.
    pub fn builtin(test: Test) -> TemplateSource {
        TemplateSource {
            path: PathBuf::from(format!("<built-in {test}>")),
            text: test.template_text().to_string(),
        }
    }

    /// A file when `spec` names one, else the built-in template of the test
    /// `spec` names.
    pub fn load(spec: &str) -> Result<TemplateSource, SourceError> {
        let path = Path::new(spec);
        if path.exists() {
            let text = crate::input::read_text(path, "template", crate::limits::MAX_YAML_BYTES)?;
            return Ok(TemplateSource {
                path: path.to_path_buf(),
                text,
            });
        }
        match spec.strip_suffix(".yaml").unwrap_or(spec).parse::<Test>() {
            Ok(test) => Ok(TemplateSource::builtin(test)),
            Err(_) => Err(SourceError::new(
                path,
                0,
                0,
                format!(
                    "no such template file, and no built-in template of that name (built-in: {})",
                    Test::ALL.map(Test::as_str).join(", ")
                ),
            )),
        }
    }

    /// An error at the key path `keys` (`"columns[1]"` selects the second
    /// item of the list `columns`).
    pub fn error(&self, keys: &[&str], msg: impl Into<String>) -> SourceError {
        let (line, column) = locate(&self.text, keys).unwrap_or((0, 0));
        SourceError::new(&self.path, line, column, msg)
    }

    /// Checks that the template's `test:` key names `want`.
    pub(crate) fn check_test(&self, got: &str, want: Test) -> Result<(), SourceError> {
        if got == want.as_str() {
            Ok(())
        } else {
            Err(self.error(
                &["test"],
                format!("this is a `{want}` template: expected `test: {want}`, got `{got}`"),
            ))
        }
    }
}

/// Finds a key path whose elements may be `name[i]` (the `i`-th item of a
/// block list, inline-flow items included).
fn locate(src: &str, keys: &[&str]) -> Option<(usize, usize)> {
    let Some(pos) = keys.iter().position(|k| k.ends_with(']')) else {
        return crate::source::locate_yaml_key(src, keys);
    };
    let (name, idx) = keys[pos].trim_end_matches(']').split_once('[')?;
    let idx: usize = idx.parse().ok()?;
    let mut head: Vec<&str> = keys[..pos].to_vec();
    head.push(name);
    let (line, _) = crate::source::locate_yaml_key(src, &head)?;
    let lines: Vec<&str> = src.lines().collect();
    let indent = |l: &str| l.len() - l.trim_start().len();
    let key_indent = indent(lines[line - 1]);
    let mut count = 0;
    for (i, l) in lines.iter().enumerate().skip(line) {
        let t = l.trim_start();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        if indent(l) <= key_indent && !t.starts_with("- ") {
            return None;
        }
        if t.starts_with("- ") {
            if count == idx {
                // Rest of the path inside this item: search from here.
                let rest = &keys[pos + 1..];
                if rest.is_empty() {
                    return Some((i + 1, indent(l) + 1));
                }
                // An inline item: the key on the item's own line.
                let own = lines[i];
                let pat = format!("{}:", rest[0]);
                let mut from = 0;
                while let Some(off) = own[from..].find(&pat) {
                    let at = from + off;
                    let before = own[..at].chars().last().unwrap_or(' ');
                    if before == '{' || before == ' ' || before == ',' {
                        return Some((i + 1, at + 1));
                    }
                    from = at + 1;
                }
                let tail: String = lines[i..].join("\n");
                let item = tail.replacen("- ", "  ", 1);
                return crate::source::locate_yaml_key(&item, rest).map(|(li, c)| (i + li, c));
            }
            count += 1;
        }
    }
    None
}

/// The template of any test, chosen by its `test:` key.
#[derive(Clone, Debug, PartialEq)]
pub enum Template {
    /// `stepped-square`.
    SteppedSquare(SteppedSquareTemplate),
    /// `nine-section`.
    NineSection(NineSectionTemplate),
    /// `probe-columns`.
    Columns(ColumnsTemplate),
    /// `probe-sphere`.
    Sphere(SphereTemplate),
}

impl Template {
    /// The built-in template of a test.
    pub fn builtin(test: Test) -> Template {
        Template::from_source(TemplateSource::builtin(test))
            .expect("the built-in templates are valid")
    }

    /// Parses and checks the template text `src` of the file `path`.
    pub fn parse(path: &Path, src: &str) -> Result<Template, SourceError> {
        Template::from_source(TemplateSource::new(path, src))
    }

    /// Parses and checks a template of any test, as its `test:` key says.
    pub fn from_source(source: TemplateSource) -> Result<Template, SourceError> {
        #[derive(Deserialize)]
        struct Head {
            #[serde(default)]
            test: Option<String>,
        }
        let head: Head = crate::input::parse_yaml(&source.path, &source.text)?;
        let Some(name) = head.test else {
            return Err(SourceError::new(
                &source.path,
                1,
                1,
                format!(
                    "missing field `test`: expected `test:` and one of {}",
                    Test::names()
                ),
            ));
        };
        let test = name
            .parse::<Test>()
            .map_err(|e| source.error(&["test"], e))?;
        Ok(match test {
            Test::SteppedSquare => Template::SteppedSquare(SteppedSquareTemplate::parse(source)?),
            Test::NineSection => Template::NineSection(NineSectionTemplate::parse(source)?),
            Test::ProbeColumns => Template::Columns(ColumnsTemplate::parse(source)?),
            Test::ProbeSphere => Template::Sphere(SphereTemplate::parse(source)?),
        })
    }

    /// The test.
    pub fn test(&self) -> Test {
        match self {
            Template::SteppedSquare(_) => Test::SteppedSquare,
            Template::NineSection(_) => Test::NineSection,
            Template::Columns(_) => Test::ProbeColumns,
            Template::Sphere(_) => Test::ProbeSphere,
        }
    }

    /// Where it came from, with its text.
    pub fn source(&self) -> &TemplateSource {
        match self {
            Template::SteppedSquare(t) => &t.source,
            Template::NineSection(t) => &t.source,
            Template::Columns(t) => &t.source,
            Template::Sphere(t) => &t.source,
        }
    }

    /// A probing test's probing settings.
    pub fn probing(&self) -> Option<&ProbingSettings> {
        match self {
            Template::Columns(t) => Some(&t.probing),
            Template::Sphere(t) => Some(&t.probing),
            Template::SteppedSquare(_) | Template::NineSection(_) => None,
        }
    }
}
