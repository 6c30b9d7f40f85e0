//! Where in an input file something went wrong: the `file:line:column`
//! prefix every user-facing parse or validation error carries, and a locator
//! that finds the line of a key path in a YAML document.
//!
//! serde reports positions only for syntax and type errors; semantic checks
//! (a limit the wrong way round, an unknown symbol used as a map key) happen
//! after deserialization, when positions are gone. [`locate_yaml_key`]
//! recovers them from the text, for the block and inline-flow styles our own
//! files and hand-edited ones use.

use std::fmt;
use std::path::{Path, PathBuf};

use crate::limits::ECHO_CHARS;

/// An error in an input file, pointing at a line and column (both 1-based;
/// 0 when unknown).
#[derive(Debug, Clone, PartialEq)]
pub struct SourceError {
    /// The file as the user named it.
    pub path: PathBuf,
    /// 1-based line, 0 when unknown.
    pub line: usize,
    /// 1-based column, 0 when unknown.
    pub column: usize,
    /// What was wrong and what was expected.
    pub message: String,
}

impl SourceError {
    /// An error at a known line and column.
    pub fn new(path: &Path, line: usize, column: usize, message: impl Into<String>) -> Self {
        SourceError {
            path: path.to_path_buf(),
            line,
            column,
            message: message.into(),
        }
    }

    /// An error located at the YAML key path `keys` in `src` (at the
    /// nearest key above it the file has, or at the top of the file when
    /// none is found).
    pub fn at_key(path: &Path, src: &str, keys: &[&str], message: impl Into<String>) -> Self {
        // A key the file lacks (a bull-nose tool without corner_radius) is
        // placed at the nearest key above it that the file has.
        let (line, column) = (1..=keys.len())
            .rev()
            .find_map(|n| locate_yaml_key(src, &keys[..n]))
            .unwrap_or((0, 0));
        SourceError::new(path, line, column, message)
    }

    /// Converts a serde_yaml error, keeping its position.
    pub fn from_yaml(path: &Path, err: &serde_yaml::Error) -> Self {
        let (line, column) = err
            .location()
            .map(|l| (l.line(), l.column()))
            .unwrap_or((0, 0));
        // serde_yaml appends " at line L column C" to its message; drop it,
        // the prefix says it already.
        let mut msg = err.to_string();
        if let Some(i) = msg.find(" at line ") {
            msg.truncate(i);
        }
        SourceError::new(path, line, column, in_users_words(&msg))
    }
}

/// serde's type names as a user of the file reads them: "expected f64"
/// says nothing to a machinist, "expected a number" does.
fn in_users_words(msg: &str) -> String {
    const WORDS: &[(&str, &str)] = &[
        ("expected f64", "expected a number"),
        ("expected f32", "expected a number"),
        ("expected u8", "expected a whole number"),
        ("expected u16", "expected a whole number"),
        ("expected u32", "expected a whole number"),
        ("expected u64", "expected a whole number"),
        ("expected usize", "expected a whole number"),
        ("expected i32", "expected a whole number"),
        ("expected i64", "expected a whole number"),
        ("expected a boolean", "expected true or false"),
    ];
    let mut out = msg.to_string();
    for (serde, user) in WORDS {
        // Only whole words: "expected u8" must not rewrite "expected u80".
        let mut from = 0;
        while let Some(i) = out[from..].find(serde) {
            let at = from + i;
            let end = at + serde.len();
            if out[end..]
                .chars()
                .next()
                .is_none_or(|c| !c.is_ascii_alphanumeric())
            {
                out.replace_range(at..end, user);
                from = at + user.len();
            } else {
                from = end;
            }
        }
    }
    out
}

impl fmt::Display for SourceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let m = shorten_echoes(&self.message);
        match (self.line, self.column) {
            (0, _) => write!(f, "{}: {m}", self.path.display()),
            (l, 0) => write!(f, "{}:{}: {m}", self.path.display(), l),
            (l, c) => write!(f, "{}:{}:{}: {m}", self.path.display(), l, c),
        }
    }
}

/// `s` as a message quotes it: its first line, at most `ECHO_CHARS` (60)
/// characters, `…` where it was cut (a name ten kilobytes long is named,
/// not printed).
pub fn cut(s: &str) -> String {
    let first = s.split(['\n', '\r']).next().unwrap_or("");
    if first.len() < s.len() || first.chars().count() > ECHO_CHARS {
        let mut out: String = first.chars().take(ECHO_CHARS).collect();
        out.push('…');
        out
    } else {
        s.to_string()
    }
}

/// A whole message as fivecal prints it: each line at most
/// [`crate::limits::MESSAGE_CHARS`] characters, the whole at most
/// [`crate::limits::MESSAGE_TOTAL_CHARS`]. A longer line (a rendered
/// template or a name of ten kilobytes that reached a message whole) keeps
/// its start, which names the file and what is wrong, and its end, which
/// says what to do; the middle is cut, and the message says how much. A
/// message of many short lines (what a plan would identify, and what would
/// identify more) is the information asked for, and stays whole up to the
/// total.
pub fn short_message(msg: &str) -> String {
    let lines: Vec<String> = msg
        .split('\n')
        .map(|l| cut_middle(l, crate::limits::MESSAGE_CHARS))
        .collect();
    cut_middle(&lines.join("\n"), crate::limits::MESSAGE_TOTAL_CHARS)
}

/// `msg` with its middle cut to keep at most `max` characters.
fn cut_middle(msg: &str, max: usize) -> String {
    let n = msg.chars().count();
    if n <= max {
        return msg.to_string();
    }
    let head: String = msg.chars().take(max / 2).collect();
    let tail: String = msg.chars().skip(n - max / 2).collect();
    format!("{head} … ({} characters cut) … {tail}", n - 2 * (max / 2))
}

/// The message with every quoted echo of the input (`"..."` as serde
/// writes it, `` `...` `` as fivecal does) cut to the first line and
/// [`ECHO_CHARS`] characters: a file dumped into a string field, or a
/// number ten megabytes long, is named, not printed.
pub(crate) fn shorten_echoes(msg: &str) -> String {
    let mut out = String::with_capacity(msg.len().min(512));
    let mut rest = msg;
    while let Some(i) = rest.find(['"', '`']) {
        let q = rest.as_bytes()[i] as char;
        out.push_str(&rest[..=i]);
        let after = &rest[i + 1..];
        // The closing quote (serde escapes inner quotes as \").
        let mut end = None;
        let mut escaped = false;
        for (j, c) in after.char_indices() {
            if escaped {
                escaped = false;
            } else if c == '\\' && q == '"' {
                escaped = true;
            } else if c == q {
                end = Some(j);
                break;
            }
        }
        let Some(j) = end else {
            out.push_str(after);
            return out;
        };
        let inner = &after[..j];
        let first = inner.split(['\n', '\r']).next().unwrap_or("");
        let first = first.split("\\n").next().unwrap_or("");
        if first.len() < inner.len() || first.chars().count() > ECHO_CHARS {
            out.extend(first.chars().take(ECHO_CHARS));
            out.push('…');
        } else {
            out.push_str(inner);
        }
        out.push(q);
        rest = &after[j + 1..];
    }
    out.push_str(rest);
    out
}

impl std::error::Error for SourceError {}

fn indent_of(line: &str) -> usize {
    line.len() - line.trim_start_matches(' ').len()
}

fn is_content(line: &str) -> bool {
    let t = line.trim();
    !t.is_empty() && !t.starts_with('#')
}

/// Finds `key:` as a mapping key in `text` (not inside a longer word),
/// returning its byte offset.
fn find_key_in(text: &str, key: &str) -> Option<usize> {
    let candidates = [
        format!("{key}:"),
        format!("\"{key}\":"),
        format!("'{key}':"),
    ];
    let mut best: Option<usize> = None;
    for pat in &candidates {
        let mut from = 0;
        while let Some(i) = text[from..].find(pat.as_str()) {
            let at = from + i;
            let before_ok = at == 0 || {
                let b = text.as_bytes()[at - 1];
                b == b' ' || b == b'{' || b == b',' || b == b'-' || b == b'\t'
            };
            if before_ok {
                best = Some(best.map_or(at, |x: usize| x.min(at)));
                break;
            }
            from = at + 1;
        }
    }
    best
}

/// Finds the 1-based (line, column) of the last key of `keys`, descending
/// through nested block mappings (and inline flow mappings on a key's own
/// line). Returns `None` when the path is not present as written.
pub fn locate_yaml_key(src: &str, keys: &[&str]) -> Option<(usize, usize)> {
    let lines: Vec<&str> = src.lines().collect();
    let (mut start, mut end) = (0usize, lines.len());
    let mut parent_indent: Option<usize> = None;
    let mut found: Option<(usize, usize)> = None;
    // When a key's value is inline on its line, deeper keys are searched in
    // the rest of that line only.
    let mut inline: Option<(usize, usize)> = None;
    for key in keys {
        if let Some((li, from)) = inline {
            let rest = &lines[li][from..];
            let off = find_key_in(rest, key)?;
            found = Some((li + 1, from + off + 1));
            inline = Some((li, from + off + key.len() + 1));
            continue;
        }
        let mut hit = None;
        for (i, line) in lines.iter().enumerate().take(end).skip(start) {
            if !is_content(line) {
                continue;
            }
            let ind = indent_of(line);
            if parent_indent.is_some_and(|p| ind <= p) {
                break;
            }
            let body = line.trim_start_matches(' ');
            let body = body.strip_prefix("- ").unwrap_or(body);
            let shift = line.len() - body.len();
            let starts = body.starts_with(key)
                || body.starts_with(&format!("\"{key}\""))
                || body.starts_with(&format!("'{key}'"));
            if starts && find_key_in(body, key) == Some(0) {
                hit = Some((i, shift));
                break;
            }
        }
        let (i, col) = hit?;
        found = Some((i + 1, col + 1));
        let line = lines[i];
        let after = col + key.len() + 1;
        let rest = line.get(after..).unwrap_or("").trim();
        if !rest.is_empty() && !rest.starts_with('#') {
            inline = Some((i, after.min(line.len())));
        } else {
            parent_indent = Some(indent_of(line));
            start = i + 1;
            end = lines.len();
        }
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A number written as text in a YAML file is reported in the file's
    /// own terms, at its line and column, not with serde's type name.
    #[test]
    fn a_wrong_type_is_named_in_the_user_s_words() {
        #[derive(serde::Deserialize, Debug)]
        #[allow(dead_code)]
        struct T {
            size: f64,
            count: u32,
        }
        let src = "size: ten\ncount: 3\n";
        let e = serde_yaml::from_str::<T>(src).unwrap_err();
        let err = SourceError::from_yaml(Path::new("t.yaml"), &e);
        assert!(err.message.contains("expected a number"), "{}", err.message);
        assert!(!err.message.contains("f64"), "{}", err.message);
        assert_eq!(err.line, 1);
        assert_eq!(in_users_words("expected u80"), "expected u80");
        assert_eq!(
            in_users_words("expected u32, got"),
            "expected a whole number, got"
        );
    }

    const DOC: &str = "name: m\nrotary_axes:\n  B: {limits: [-90, 90], direction: 1}\n  C:\n    limits: null\n    direction: -1\ntool:\n  diameter: 8\n";

    #[test]
    fn finds_block_and_inline_keys() {
        assert_eq!(locate_yaml_key(DOC, &["name"]), Some((1, 1)));
        assert_eq!(locate_yaml_key(DOC, &["rotary_axes", "B"]), Some((3, 3)));
        assert_eq!(
            locate_yaml_key(DOC, &["rotary_axes", "B", "limits"]),
            Some((3, 7))
        );
        assert_eq!(
            locate_yaml_key(DOC, &["rotary_axes", "B", "direction"]),
            Some((3, 26))
        );
        assert_eq!(
            locate_yaml_key(DOC, &["rotary_axes", "C", "direction"]),
            Some((6, 5))
        );
        assert_eq!(locate_yaml_key(DOC, &["tool", "diameter"]), Some((8, 3)));
    }

    #[test]
    fn does_not_cross_into_a_sibling_mapping() {
        assert_eq!(locate_yaml_key(DOC, &["rotary_axes", "diameter"]), None);
        assert_eq!(locate_yaml_key(DOC, &["tool", "limits"]), None);
    }

    #[test]
    fn long_echoes_are_cut_to_a_line() {
        let long = "9".repeat(10_000);
        let e = SourceError::new(
            Path::new("m.yaml"),
            2,
            8,
            format!("invalid type: string \"{long}\", expected f64"),
        );
        let s = e.to_string();
        assert!(s.len() < 150, "{s}");
        assert!(s.ends_with("…\", expected f64"), "{s}");
        let e = SourceError::new(
            Path::new("m.yaml"),
            1,
            1,
            "invalid type: string \"name: other\\nlines: 2\", expected a machine",
        );
        assert_eq!(
            e.to_string(),
            "m.yaml:1:1: invalid type: string \"name: other…\", expected a machine"
        );
        assert_eq!(
            shorten_echoes("unknown symbol `EXC(B`"),
            "unknown symbol `EXC(B`"
        );
    }

    #[test]
    fn display_has_file_line_column() {
        let e = SourceError::new(Path::new("m.yaml"), 3, 7, "expected two numbers");
        assert_eq!(e.to_string(), "m.yaml:3:7: expected two numbers");
    }
}
