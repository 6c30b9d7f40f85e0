//! File formats of measurements and plans, one module per format. Every
//! reader turns its format into the canonical meaning of docs/formats.md
//! and reports bad input as `file:line:column: what was expected`.

pub mod calypso;
pub mod cloud;
pub mod detect;
pub mod dmis;
pub mod dmis_program;
pub mod encoding;
pub mod heights;
pub mod inventory;
pub mod manifest;
pub mod measured;
pub mod points;
pub mod probe_log;
pub mod qif;
pub mod qif_write;
pub mod table;

/// A data line of a plain comma-separated file: its 1-based number and its
/// fields with their 1-based columns (fields trimmed). Our CSV formats
/// never quote, so splitting at commas keeps exact positions.
pub(crate) struct CsvLine<'a> {
    /// 1-based line number.
    pub line: usize,
    /// (column, field) pairs.
    pub fields: Vec<(usize, &'a str)>,
}

impl CsvLine<'_> {
    /// Field `i`.
    pub fn get(&self, i: usize) -> &str {
        self.fields.get(i).map_or("", |f| f.1)
    }

    /// Column of field `i`.
    pub fn col(&self, i: usize) -> usize {
        self.fields.get(i).map_or(1, |f| f.0)
    }
}

/// The non-blank, non-comment (`#`) lines of a CSV text.
pub(crate) fn csv_lines(src: &str) -> impl Iterator<Item = CsvLine<'_>> {
    src.lines().enumerate().filter_map(|(i, raw)| {
        let raw = raw.strip_suffix('\r').unwrap_or(raw);
        let t = raw.trim();
        if t.is_empty() || t.starts_with('#') {
            return None;
        }
        let mut fields = Vec::new();
        let mut start = 0;
        for part in raw.split(',') {
            let lead = part.len() - part.trim_start().len();
            fields.push((start + lead + 1, part.trim()));
            start += part.len() + 1;
        }
        Some(CsvLine {
            line: i + 1,
            fields,
        })
    })
}

/// Parses a finite number or explains what was expected.
pub(crate) fn parse_finite(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(format!("expected a finite number, got `{}`", s.trim())),
        Err(_) => Err(format!("expected a number, got `{}`", s.trim())),
    }
}

/// Whether a label uses only `[A-Za-z0-9_.-]` and is not empty.
pub fn valid_label(s: &str) -> bool {
    !s.is_empty()
        && s.bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'.' || b == b'-')
}
