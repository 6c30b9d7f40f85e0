//! File formats of measurements and plans, one module per format. Every
//! reader turns its format into the canonical meaning of docs/formats.md
//! and reports bad input as `file:line:column: what was expected`.

pub mod ball_bar;
pub(crate) mod calypso;
pub(crate) mod cloud;
pub mod detect;
pub mod dmis;
pub mod dmis_program;
pub mod encoding;
pub mod heights;
pub mod inventory;
pub mod laser;
pub mod manifest;
pub mod measured;
pub mod points;
pub mod probe_log;
pub(crate) mod qif;
pub mod qif_write;
pub(crate) mod table;

/// How far from 1 the length of a written direction may be: writers round
/// unit vectors to 4 decimals (a length off by up to about 1e-4), some to
/// 3; anything further off is not a rounded unit vector but another number
/// in its place (a real QIF 2 sample has `Location` and `Normal` swapped,
/// a "normal" 2,700 mm long), and renormalizing it would invent a direction.
pub(crate) const DIRECTION_SLACK: f64 = 0.01;

/// A written direction as the unit vector it stands for, renormalized, or
/// why it is none: `what` names it in the message (`the direction i,j,k`).
pub(crate) fn unit_direction(
    v: nalgebra::Vector3<f64>,
    what: &str,
) -> Result<nalgebra::Vector3<f64>, String> {
    let len = v.norm();
    if len < 1e-9 {
        return Err(format!("{what} must not be zero"));
    }
    if (len - 1.0).abs() > DIRECTION_SLACK {
        return Err(format!(
            "{what} has length {len:.6}: expected a unit vector (length 1 within {DIRECTION_SLACK}); is another quantity, such as a location, written in its place?"
        ));
    }
    Ok(v / len)
}

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
    pub(crate) fn get(&self, i: usize) -> &str {
        self.fields.get(i).map_or("", |f| f.1)
    }

    /// Column of field `i`.
    pub(crate) fn col(&self, i: usize) -> usize {
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

/// Whether the first line of `src` that is neither blank nor a comment
/// starts with `key` (how an instrument plan file names its kind, as
/// `fivecal_ball_bar: 1`).
pub(crate) fn first_key_is(src: &str, key: &str) -> bool {
    src.lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'))
        .is_some_and(|l| l.starts_with(key))
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
pub(crate) fn valid_label(s: &str) -> bool {
    !s.is_empty()
        && s.bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'.' || b == b'-')
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::unit_direction;

    #[test]
    fn a_rounded_unit_vector_is_renormalized_and_anything_else_refused() {
        // (0.5774, 0.5774, 0.5774): 4 decimals, length 1.00008.
        let n = unit_direction(Vector3::new(0.5774, 0.5774, 0.5774), "n").unwrap();
        assert!((n.norm() - 1.0).abs() < 1e-15 && (n.x - n.z).abs() < 1e-15);
        assert_eq!(
            unit_direction(Vector3::zeros(), "the direction").unwrap_err(),
            "the direction must not be zero"
        );
        let e = unit_direction(Vector3::new(2433.97, 800.62, 890.05), "<Normal>").unwrap_err();
        assert!(e.starts_with("<Normal> has length 2712.4"), "{e}");
        // The edge: 1.0101 is out, 1.0099 in.
        assert!(unit_direction(Vector3::new(0.0, 0.0, 1.0101), "n").is_err());
        assert!(unit_direction(Vector3::new(0.0, 0.0, 1.0099), "n").is_ok());
    }
}
