//! Reading input files within bounds, so that no file, however hostile,
//! makes a run hang, exhaust memory or misread it quietly.
//!
//! [`read_text`] reads a whole text file up to a size limit (a device such
//! as `/dev/zero` is refused at once, a NUL byte ends the read with the
//! reason), drops a UTF-8 byte-order mark and reads old Mac files whose
//! lines end in a bare CR as lines. [`parse_yaml`] checks a YAML document's
//! nesting depth with a linear scan before the parser sees it (the parser's
//! time grows with the square of the depth), refuses a key that appears
//! twice in one mapping at any depth (serde keeps the last one silently
//! below the top level), and only then deserializes. [`open_stream`] opens
//! a file read line by line (an NC program) with the same refusal of
//! devices and a bound on the length of one line.
//!
//! The limits themselves are in [`crate::limits`].

use std::fs::File;
use std::io::{self, BufReader, Read};
use std::path::Path;

use serde::de::{self, DeserializeOwned, Deserializer, MapAccess, SeqAccess, Visitor};

use crate::limits::{MAX_LINE_BYTES, MAX_YAML_DEPTH};
use crate::source::SourceError;

fn mib(n: u64) -> String {
    if n >= 1 << 20 {
        format!("{} MiB", n >> 20)
    } else {
        format!("{} KiB", n >> 10)
    }
}

/// Refuses a path that is not a file that can be read to its end: a
/// directory, a character or block device (`/dev/zero` never ends), a FIFO
/// or a socket (opening a FIFO nobody writes waits for ever); the file
/// type is read from its metadata, before anything opens it. A file let
/// through is noted as an input of the run ([`crate::io::note_input`]),
/// so that no output of the run lands on it.
fn check_readable(path: &Path, what: &str) -> Result<(), SourceError> {
    check_file_type(path, what)?;
    crate::io::note_input(path, &format!("the {what}"));
    Ok(())
}

fn check_file_type(path: &Path, what: &str) -> Result<(), SourceError> {
    let meta = std::fs::metadata(path)
        .map_err(|e| SourceError::new(path, 0, 0, format!("cannot read {what}: {e}")))?;
    if meta.is_dir() {
        return Err(SourceError::new(
            path,
            0,
            0,
            format!("cannot read {what}: it is a directory"),
        ));
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = meta.file_type();
        if t.is_char_device() || t.is_block_device() {
            return Err(SourceError::new(
                path,
                0,
                0,
                format!("cannot read {what}: it is a device, not a file"),
            ));
        }
        if t.is_fifo() || t.is_socket() {
            let kind = if t.is_fifo() {
                "a FIFO (named pipe)"
            } else {
                "a socket"
            };
            return Err(SourceError::new(
                path,
                0,
                0,
                format!(
                    "cannot read {what}: it is {kind}, not a file (save the data to a file first)"
                ),
            ));
        }
    }
    Ok(())
}

/// Reads a text file of at most `limit` bytes; `what` names it in errors
/// ("machine file", "measurement file"). The text comes back without a
/// byte-order mark and with bare-CR line ends turned into LF.
pub fn read_text(path: &Path, what: &str, limit: u64) -> Result<String, SourceError> {
    check_readable(path, what)?;
    let file = File::open(path)
        .map_err(|e| SourceError::new(path, 0, 0, format!("cannot read {what}: {e}")))?;
    let mut bytes = Vec::new();
    let mut r = file.take(limit + 1);
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let n = match r.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) => {
                return Err(SourceError::new(
                    path,
                    0,
                    0,
                    format!("cannot read {what}: {e}"),
                ));
            }
        };
        if let Some(i) = buf[..n].iter().position(|&b| b == 0) {
            let at = bytes.len() + i;
            bytes.extend_from_slice(&buf[..i]);
            let (line, column) = line_col(&bytes, at);
            return Err(SourceError::new(
                path,
                line,
                column,
                format!("a NUL byte: this is not a text file (expected a {what})"),
            ));
        }
        bytes.extend_from_slice(&buf[..n]);
    }
    if bytes.len() as u64 > limit {
        return Err(SourceError::new(
            path,
            0,
            0,
            format!(
                "larger than {}, the limit for a {what}: not a file fivecal reads",
                mib(limit)
            ),
        ));
    }
    text_of(path, what, bytes)
}

fn line_col(bytes: &[u8], at: usize) -> (usize, usize) {
    let before = &bytes[..at.min(bytes.len())];
    let line = 1 + before.iter().filter(|&&b| b == b'\n').count();
    let col = 1 + before.iter().rev().take_while(|&&b| b != b'\n').count();
    (line, col)
}

/// Decodes bytes read from a text file: UTF-8 (a byte-order mark
/// dropped), bare CR line ends read as LF.
pub fn text_of(path: &Path, what: &str, bytes: Vec<u8>) -> Result<String, SourceError> {
    let mut text = String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let (line, column) = line_col(e.as_bytes(), at);
        SourceError::new(
            path,
            line,
            column,
            format!("not UTF-8 text (expected a {what}; save it as UTF-8)"),
        )
    })?;
    if text.starts_with('\u{feff}') {
        text.drain(..'\u{feff}'.len_utf8());
    }
    Ok(with_lf_lines(text))
}

/// Text whose lines end in a bare CR (old Mac files) with LF line ends;
/// CRLF and LF text unchanged.
pub(crate) fn with_lf_lines(text: String) -> String {
    let b = text.as_bytes();
    let bare_cr = b
        .iter()
        .enumerate()
        .any(|(i, &c)| c == b'\r' && b.get(i + 1) != Some(&b'\n'));
    if bare_cr {
        text.replace("\r\n", "\n").replace('\r', "\n")
    } else {
        text
    }
}

/// Reads a binary file (a mesh) of at most `limit` bytes.
pub(crate) fn read_bytes(path: &Path, what: &str, limit: u64) -> Result<Vec<u8>, SourceError> {
    check_readable(path, what)?;
    let file = File::open(path)
        .map_err(|e| SourceError::new(path, 0, 0, format!("cannot read {what}: {e}")))?;
    let mut bytes = Vec::new();
    file.take(limit + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| SourceError::new(path, 0, 0, format!("cannot read {what}: {e}")))?;
    if bytes.len() as u64 > limit {
        return Err(SourceError::new(
            path,
            0,
            0,
            format!("larger than {}, the limit for a {what}", mib(limit)),
        ));
    }
    Ok(bytes)
}

/// A file read line by line (an NC program of any length): a device is
/// refused, and a line longer than [`MAX_LINE_BYTES`] or a NUL byte ends
/// the read with an error instead of growing a line without end.
pub fn open_stream(path: &Path, what: &str) -> Result<BufReader<BoundedLines<File>>, SourceError> {
    check_readable(path, what)?;
    let f = File::open(path)
        .map_err(|e| SourceError::new(path, 0, 0, format!("cannot read {what}: {e}")))?;
    Ok(BufReader::with_capacity(
        1 << 16,
        BoundedLines::new(f, MAX_LINE_BYTES),
    ))
}

/// Why [`BoundedLines`] stopped, at which line: carried inside the
/// `io::Error` it returns, so that a reader that knows the file's name
/// can report `file:line: why` ([`LineError::located`]).
#[derive(Debug)]
pub struct LineError {
    /// 1-based line.
    pub line: usize,
    /// What is wrong with it.
    pub message: String,
}

impl std::fmt::Display for LineError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "line {}: {}", self.line, self.message)
    }
}

impl std::error::Error for LineError {}

impl LineError {
    fn io(line: usize, message: String) -> io::Error {
        io::Error::new(io::ErrorKind::InvalidData, LineError { line, message })
    }

    /// The error of file `path` that `e` carries, if it is one of these.
    pub fn located(path: &Path, e: &io::Error) -> Option<SourceError> {
        let l = e.get_ref()?.downcast_ref::<LineError>()?;
        Some(SourceError::new(path, l.line, 0, l.message.clone()))
    }
}

/// A reader that fails on a line longer than [`MAX_LINE_BYTES`] or on a
/// NUL byte (see [`open_stream`]).
pub struct BoundedLines<R> {
    inner: R,
    line: usize,
    run: usize,
    after_cr: bool,
    /// The longest line accepted ([`MAX_LINE_BYTES`]; shorter in tests).
    limit: usize,
}

impl<R> BoundedLines<R> {
    fn new(inner: R, limit: usize) -> BoundedLines<R> {
        BoundedLines {
            inner,
            line: 1,
            run: 0,
            after_cr: false,
            limit,
        }
    }

    /// `more` bytes of the line that is read.
    fn lengthen(&mut self, more: usize) -> io::Result<()> {
        self.run += more;
        if self.run > self.limit {
            return Err(LineError::io(
                self.line,
                format!(
                    "the line is longer than {} bytes: not a text file fivecal reads",
                    self.limit
                ),
            ));
        }
        Ok(())
    }
}

impl<R: Read> Read for BoundedLines<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        // Line ends and NULs are found a vector at a time: checked byte by
        // byte this reader took a tenth of the rewrite's reading thread.
        let mut rest = &buf[..n];
        while let Some(i) = memchr::memchr3(b'\n', b'\r', 0, rest) {
            self.lengthen(i)?;
            let b = rest[i];
            if b == 0 {
                return Err(LineError::io(
                    self.line,
                    "a NUL byte: this is not a text file".to_string(),
                ));
            }
            // LF, CRLF and a bare CR each end one line.
            if !(b == b'\n' && i == 0 && self.after_cr) {
                self.line += 1;
            }
            self.run = 0;
            self.after_cr = b == b'\r';
            rest = &rest[i + 1..];
        }
        if !rest.is_empty() {
            self.lengthen(rest.len())?;
            self.after_cr = false;
        }
        Ok(n)
    }
}

// ------------------------------------------------------------------- YAML

/// Parses a YAML (or JSON) document into `T` after the depth and duplicate
/// key checks; errors are located in `path`.
pub fn parse_yaml<T: DeserializeOwned>(path: &Path, src: &str) -> Result<T, SourceError> {
    check_yaml(path, src)?;
    serde_yaml::from_str(src).map_err(|e| SourceError::from_yaml(path, &e))
}

/// The checks of [`parse_yaml`] alone: nesting depth, then duplicate keys
/// (and YAML syntax).
pub fn check_yaml(path: &Path, src: &str) -> Result<(), SourceError> {
    if let Some((line, column)) = too_deep(src, MAX_YAML_DEPTH) {
        return Err(SourceError::new(
            path,
            line,
            column,
            format!(
                "nested more than {MAX_YAML_DEPTH} levels deep: fivecal's files nest a few levels"
            ),
        ));
    }
    match serde_yaml::from_str::<NoDuplicates>(src) {
        Ok(_) => Ok(()),
        Err(e) => {
            let mut err = SourceError::from_yaml(path, &e);
            // serde_yaml gives these two no position: the line is found
            // here, with what was expected.
            if err.message.contains("more than one document") {
                let (line, _) = second_document(src).unwrap_or((0, 0));
                return Err(SourceError::new(
                    path,
                    line,
                    if line > 0 { 1 } else { 0 },
                    "a second YAML document starts here (`---`): expected one document per file",
                ));
            }
            if err.message.contains("repetition limit exceeded") {
                let (line, column) = first_alias(src).unwrap_or((0, 0));
                return Err(SourceError::new(
                    path,
                    line,
                    column,
                    "the YAML aliases (`*name`) from here on expand beyond the limit of repeated values (an alias bomb?): expected plain keys and values, which fivecal's files need",
                ));
            }
            if let Some(key) = err
                .message
                .split_once(DUPLICATE)
                .and_then(|(_, r)| r.split('`').next())
                && let Some((l, c)) = locate_duplicate(src, err.line, err.column, key)
            {
                err.line = l;
                err.column = c;
            }
            Err(err)
        }
    }
}

/// The line and column of the first document marker after content (the
/// start of a second document).
fn second_document(src: &str) -> Option<(usize, usize)> {
    let mut content = false;
    for (i, l) in src.lines().enumerate() {
        let t = l.trim_end();
        if t == "---" || t.starts_with("--- ") {
            if content {
                return Some((i + 1, 1));
            }
            continue;
        }
        if t == "..." {
            continue;
        }
        let t = t.trim_start();
        if !t.is_empty() && !t.starts_with('#') {
            content = true;
        }
    }
    None
}

/// The line and column of the first alias (`*name` after a space, a `[`,
/// a `,`, a `:` or a `-`, outside comments), 1-based.
fn first_alias(src: &str) -> Option<(usize, usize)> {
    for (i, l) in src.lines().enumerate() {
        let code = l.split(" #").next().unwrap_or(l);
        if code.trim_start().starts_with('#') {
            continue;
        }
        let b = code.as_bytes();
        for (j, &c) in b.iter().enumerate() {
            if c == b'*'
                && (j == 0 || matches!(b[j - 1], b' ' | b'[' | b',' | b':' | b'-' | b'\t'))
                && b.get(j + 1)
                    .is_some_and(|n| n.is_ascii_alphanumeric() || *n == b'_')
            {
                return Some((i + 1, j + 1));
            }
        }
    }
    None
}

/// Where nesting (block indentation, compact `- - -` entries and flow
/// brackets together) first goes deeper than `limit`, as (line, column);
/// a linear scan that skips quoted scalars, comments and block scalars.
fn too_deep(src: &str, limit: usize) -> Option<(usize, usize)> {
    let mut flow = 0usize;
    let mut indents: Vec<usize> = Vec::new();
    let mut quote: Option<char> = None;
    let mut block_scalar: Option<usize> = None;
    for (li, line) in src.split('\n').enumerate() {
        let indent = line.len() - line.trim_start_matches(' ').len();
        let body = line.trim();
        if let Some(parent) = block_scalar {
            if body.is_empty() || indent > parent {
                continue;
            }
            block_scalar = None;
        }
        let mut level = 0;
        let mut rest_from = 0;
        if quote.is_none() && flow == 0 {
            if body.is_empty() || body.starts_with('#') {
                continue;
            }
            while indents.last().is_some_and(|&t| t > indent) {
                indents.pop();
            }
            if indents.last().is_none_or(|&t| t < indent) {
                indents.push(indent);
            }
            level = indents.len();
            // Compact nested entries: `- - - x`, `? ? x`.
            let bytes = line.as_bytes();
            let mut i = indent;
            while i + 1 < bytes.len()
                && (bytes[i] == b'-' || bytes[i] == b'?')
                && (bytes[i + 1] == b' ' || bytes[i + 1] == b'\t')
            {
                level += 1;
                i += 2;
                while i < bytes.len() && bytes[i] == b' ' {
                    i += 1;
                }
            }
            if level > limit {
                return Some((li + 1, i.min(line.len()) + 1));
            }
            rest_from = i;
        } else if quote.is_none() {
            level = indents.len();
        }
        let mut prev = ' ';
        let mut chars = line[rest_from..].char_indices().peekable();
        let mut content_end = line.len();
        while let Some((ci, c)) = chars.next() {
            let col = rest_from + ci;
            match quote {
                Some('"') => {
                    if c == '\\' {
                        chars.next();
                    } else if c == '"' {
                        quote = None;
                    }
                }
                Some(_) => {
                    if c == '\'' {
                        if chars.peek().is_some_and(|&(_, n)| n == '\'') {
                            chars.next();
                        } else {
                            quote = None;
                        }
                    }
                }
                None => match c {
                    '#' if prev == ' ' || prev == '\t' || col == 0 => {
                        content_end = col;
                        break;
                    }
                    '"' | '\''
                        if matches!(prev, ' ' | '\t' | '[' | '{' | ',' | ':' | '-' | '?') =>
                    {
                        quote = Some(c)
                    }
                    '[' | '{' => {
                        flow += 1;
                        if level + flow > limit {
                            return Some((li + 1, col + 1));
                        }
                    }
                    ']' | '}' => flow = flow.saturating_sub(1),
                    _ => {}
                },
            }
            prev = c;
        }
        if quote.is_none() && flow == 0 {
            let content = line[..content_end].trim_end();
            let ind =
                content.trim_end_matches(|c: char| c == '-' || c == '+' || c.is_ascii_digit());
            if (ind.ends_with('|') || ind.ends_with('>'))
                && (ind.len() == 1
                    || ind[..ind.len() - 1].ends_with(' ')
                    || ind[..ind.len() - 1].ends_with('\t'))
            {
                block_scalar = Some(indent);
            }
        }
    }
    None
}

const DUPLICATE: &str = "duplicate key `";

/// Deserializes anything and fails on a mapping key seen twice.
struct NoDuplicates;

impl<'de> de::Deserialize<'de> for NoDuplicates {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(NoDuplicatesVisitor)
    }
}

struct NoDuplicatesVisitor;

fn key_text(k: &serde_yaml::Value) -> String {
    match k {
        serde_yaml::Value::String(s) => s.clone(),
        serde_yaml::Value::Number(n) => n.to_string(),
        serde_yaml::Value::Bool(b) => b.to_string(),
        serde_yaml::Value::Null => "null".into(),
        other => serde_yaml::to_string(other)
            .unwrap_or_default()
            .trim()
            .to_string(),
    }
}

impl<'de> Visitor<'de> for NoDuplicatesVisitor {
    type Value = NoDuplicates;

    fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("any YAML value")
    }

    fn visit_bool<E>(self, _: bool) -> Result<NoDuplicates, E> {
        Ok(NoDuplicates)
    }
    fn visit_i64<E>(self, _: i64) -> Result<NoDuplicates, E> {
        Ok(NoDuplicates)
    }
    fn visit_u64<E>(self, _: u64) -> Result<NoDuplicates, E> {
        Ok(NoDuplicates)
    }
    fn visit_f64<E>(self, _: f64) -> Result<NoDuplicates, E> {
        Ok(NoDuplicates)
    }
    fn visit_str<E>(self, _: &str) -> Result<NoDuplicates, E> {
        Ok(NoDuplicates)
    }
    fn visit_unit<E>(self) -> Result<NoDuplicates, E> {
        Ok(NoDuplicates)
    }
    fn visit_none<E>(self) -> Result<NoDuplicates, E> {
        Ok(NoDuplicates)
    }
    fn visit_some<D: Deserializer<'de>>(self, d: D) -> Result<NoDuplicates, D::Error> {
        d.deserialize_any(NoDuplicatesVisitor)
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<NoDuplicates, A::Error> {
        while seq.next_element::<NoDuplicates>()?.is_some() {}
        Ok(NoDuplicates)
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<NoDuplicates, A::Error> {
        let mut keys: Vec<serde_yaml::Value> = Vec::new();
        while let Some(k) = map.next_key::<serde_yaml::Value>()? {
            if keys.contains(&k) {
                return Err(de::Error::custom(format!(
                    "{DUPLICATE}{}` appears twice in one mapping (each key once: which value was meant?)",
                    key_text(&k)
                )));
            }
            keys.push(k);
            map.next_value::<NoDuplicates>()?;
        }
        Ok(NoDuplicates)
    }
    fn visit_enum<A: de::EnumAccess<'de>>(self, data: A) -> Result<NoDuplicates, A::Error> {
        use de::VariantAccess;
        let (_, v) = data.variant::<serde_yaml::Value>()?;
        v.newtype_variant::<NoDuplicates>()
    }
}

/// The second occurrence of `key` in the mapping that starts at (`line`,
/// `column`): in a block mapping, the second line with `key:` at the
/// mapping's column; in a flow mapping, the second `key:` after its brace.
fn locate_duplicate(src: &str, line: usize, column: usize, key: &str) -> Option<(usize, usize)> {
    if line == 0 {
        return None;
    }
    let lines: Vec<&str> = src.lines().collect();
    let first = lines.get(line - 1)?;
    let col0 = column.saturating_sub(1);
    let is_key_at = |l: &str, at: usize| {
        let rest = l.get(at..).unwrap_or("");
        [
            format!("{key}:"),
            format!("\"{key}\":"),
            format!("'{key}':"),
        ]
        .iter()
        .any(|p| rest.starts_with(p.as_str()))
    };
    if first.get(col0..).is_some_and(|r| r.starts_with('{')) {
        let mut seen = 0;
        for (i, _) in first.char_indices().skip(col0) {
            let before = first[..i].chars().last().unwrap_or(' ');
            if matches!(before, '{' | ',' | ' ') && is_key_at(first, i) {
                seen += 1;
                if seen == 2 {
                    return Some((line, i + 1));
                }
            }
        }
        return None;
    }
    let mut seen = 0;
    for (i, l) in lines.iter().enumerate().skip(line - 1) {
        let ind = l.len() - l.trim_start_matches(' ').len();
        let body = l.trim();
        if body.is_empty() || body.starts_with('#') {
            continue;
        }
        // A `- ` entry opens the mapping on its own line.
        let at = if i == line - 1 { col0 } else { ind };
        if i > line - 1 && ind < col0 {
            break;
        }
        if at == col0 && is_key_at(l, at) {
            seen += 1;
            if seen == 2 {
                return Some((i + 1, at + 1));
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(src: &str) -> Result<(), String> {
        check_yaml(Path::new("f.yaml"), src).map_err(|e| e.to_string())
    }

    #[test]
    fn duplicate_keys_are_refused_at_every_depth_at_their_line() {
        let e = check("name: m\nrotary_axes:\n  B: {limits: [-90, 90]}\n  C: {limits: null}\n  B: {limits: [0, 1]}\n")
            .unwrap_err();
        assert!(e.starts_with("f.yaml:5:3: "), "{e}");
        assert!(e.contains("duplicate key `B`"), "{e}");
        let e = check("location_errors: {EX0B: 1.0, EZ0B: 2.0, EX0B: 3.0}\n").unwrap_err();
        assert!(e.starts_with("f.yaml:1:"), "{e}");
        assert!(e.contains("duplicate key `EX0B`"), "{e}");
        let e = check("a:\n  - x: 1\n    y: 2\n    x: 3\n").unwrap_err();
        assert!(e.starts_with("f.yaml:4:5: "), "{e}");
        assert!(e.contains("duplicate key `x`"), "{e}");
        assert!(check("a: {x: 1}\nb: {x: 1}\nc:\n  - x: 1\n  - x: 2\n").is_ok());
    }

    #[test]
    fn streamed_lines_are_counted_at_lf_crlf_and_a_bare_cr() {
        for (src, line) in [
            (&b"a\nb\nc\0"[..], 3),
            (b"a\r\nb\r\nc\0", 3),
            (b"a\rb\rc\0", 3),
            (b"a\r\rb\0", 3),
        ] {
            let mut r = BoundedLines::new(src, MAX_LINE_BYTES);
            let e = r.read_to_end(&mut Vec::new()).unwrap_err().to_string();
            assert!(e.starts_with(&format!("line {line}: a NUL byte")), "{e}");
        }
    }

    /// The reader read a byte at a time, as it was first written: the
    /// oracle for the vectorized one.
    fn bytewise(src: &[u8], limit: usize) -> Result<(), String> {
        let (mut line, mut run, mut after_cr) = (1, 0, false);
        for &b in src {
            let cr = std::mem::replace(&mut after_cr, b == b'\r');
            match b {
                b'\n' | b'\r' => {
                    if !(b == b'\n' && cr) {
                        line += 1;
                    }
                    run = 0;
                }
                0 => return Err(format!("line {line}: a NUL byte: this is not a text file")),
                _ => {
                    run += 1;
                    if run > limit {
                        return Err(format!(
                            "line {line}: the line is longer than {limit} bytes: not a text file fivecal reads"
                        ));
                    }
                }
            }
        }
        Ok(())
    }

    /// Hands out its bytes in the pieces given, so that line ends, CRLFs
    /// and NULs fall on every side of a read's boundary.
    struct Pieces<'a> {
        src: &'a [u8],
        sizes: Vec<usize>,
        k: usize,
    }

    impl Read for Pieces<'_> {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            let n = self.sizes[self.k % self.sizes.len()]
                .min(buf.len())
                .min(self.src.len());
            self.k += 1;
            buf[..n].copy_from_slice(&self.src[..n]);
            self.src = &self.src[n..];
            Ok(n)
        }
    }

    #[test]
    fn lines_nuls_and_long_lines_are_found_as_byte_by_byte_in_any_pieces() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(20261129);
        let alphabet = b"\n\r\0G1X.-  ";
        let (mut long, mut nul, mut fine) = (0, 0, 0);
        for _ in 0..3000 {
            let len = rng.random_range(0..60);
            let src: Vec<u8> = (0..len)
                .map(|_| {
                    // NULs rare, so that many inputs reach their end.
                    let k = rng.random_range(0..alphabet.len() * 8);
                    if k < alphabet.len() {
                        alphabet[k]
                    } else {
                        b'X'
                    }
                })
                .collect();
            let limit = rng.random_range(1..40);
            let sizes: Vec<usize> = (0..3).map(|_| rng.random_range(1..9)).collect();
            let want = bytewise(&src, limit);
            let mut r = BufReader::with_capacity(
                rng.random_range(1..16),
                BoundedLines::new(
                    Pieces {
                        src: &src,
                        sizes,
                        k: 0,
                    },
                    limit,
                ),
            );
            let mut out = Vec::new();
            let got = r
                .read_to_end(&mut out)
                .map(|_| ())
                .map_err(|e| e.to_string());
            assert_eq!(
                got,
                want,
                "{:?} limit {limit}",
                String::from_utf8_lossy(&src)
            );
            match &want {
                Ok(()) => {
                    assert_eq!(out, src);
                    fine += 1
                }
                Err(e) if e.contains("NUL") => nul += 1,
                Err(_) => long += 1,
            }
        }
        // Each way out taken often.
        assert!(long > 300 && nul > 200 && fine > 300, "{long} {nul} {fine}");
    }

    #[test]
    fn deep_nesting_is_refused_before_parsing() {
        let e = check(&"{a: ".repeat(100_000)).unwrap_err();
        assert!(e.contains("nested more than 64 levels"), "{e}");
        let e = check(&"[".repeat(200_000)).unwrap_err();
        assert!(e.contains("nested more than 64 levels"), "{e}");
        let e = check(&("- ".repeat(70) + "x\n")).unwrap_err();
        assert!(e.contains("nested more than 64 levels"), "{e}");
        let deep: String = (0..70)
            .map(|i| format!("{}k{i}:\n", " ".repeat(i)))
            .collect();
        assert!(check(&deep).unwrap_err().contains("nested more than"));
    }

    #[test]
    fn brackets_in_quotes_comments_and_block_scalars_do_not_count() {
        let many = "[".repeat(100);
        let src = format!(
            "a: \"{many}\"\nb: '{many}'\n# {many}\nc: |\n  {many}\n  {many}\nd: >-\n  {many}\ne: [1, [2, {{f: 3}}]]\n"
        );
        assert_eq!(check(&src), Ok(()));
    }

    #[test]
    fn text_without_bom_and_with_lf_lines() {
        let p = Path::new("x.csv");
        let t = text_of(p, "CSV file", b"\xef\xbb\xbfa,1\r\nb,2\n".to_vec()).unwrap();
        assert_eq!(t, "a,1\r\nb,2\n");
        let t = text_of(p, "CSV file", b"a,1\rb,2\r".to_vec()).unwrap();
        assert_eq!(t.lines().count(), 2);
        let e = text_of(p, "CSV file", b"a,1\nb,\xff\n".to_vec()).unwrap_err();
        assert_eq!((e.line, e.column), (2, 3));
    }

    #[cfg(unix)]
    #[test]
    fn devices_and_oversized_files_end_at_once() {
        let e = read_text(Path::new("/dev/zero"), "machine file", 1 << 20).unwrap_err();
        assert!(e.message.contains("a device"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let big = dir.path().join("big.yaml");
        std::fs::write(&big, vec![b'a'; 2048]).unwrap();
        let e = read_text(&big, "machine file", 1024).unwrap_err();
        assert!(e.message.contains("larger than 1 KiB"), "{e}");
        let nul = dir.path().join("nul.csv");
        std::fs::write(&nul, b"a,1\nb\0").unwrap();
        let e = read_text(&nul, "CSV file", 1024).unwrap_err();
        assert_eq!((e.line, e.column), (2, 2));
    }
}
