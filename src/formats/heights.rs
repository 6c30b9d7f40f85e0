//! Section heights of the nine-section test (Cubas Brizuela & Yeh 2023, section 6): the
//! depth of each machined section relative to section 1 (the centre,
//! machined at A = C = 0), in um, as read with a micrometer or a CMM.
//!
//! ```text
//! # nine-section test, values from the machine (Cubas Brizuela & Yeh 2023, table 4)
//! section,height_um
//! 1,0
//! 2,-5
//! 3,-9
//! ```

use std::path::Path;

use super::{csv_lines, parse_finite};
use crate::source::SourceError;

/// The height of one section.
#[derive(Clone, Debug, PartialEq)]
pub struct SectionHeight {
    /// Section number, from 1.
    pub section: u32,
    /// Height relative to section 1, um.
    pub height_um: f64,
    /// Source line.
    pub line: usize,
}

/// Writes a heights file: optional `#` comments, the header
/// `section,height_um`, one line per section (um, four decimals).
pub fn to_csv(heights: &[SectionHeight], comments: &[&str]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    for c in comments {
        let _ = writeln!(s, "# {c}");
    }
    s.push_str("section,height_um\n");
    for h in heights {
        let _ = writeln!(
            s,
            "{},{}",
            h.section,
            super::points::fmt_num(h.height_um, 4)
        );
    }
    s
}

/// Whether the text is a heights file (its header names `section` and
/// `height_um`).
pub(crate) fn looks_like_heights(src: &str) -> bool {
    csv_lines(src).next().is_some_and(|h| {
        let cols: Vec<String> = h.fields.iter().map(|f| f.1.to_ascii_lowercase()).collect();
        cols.iter().any(|c| c == "section") && cols.iter().any(|c| c == "height_um")
    })
}

/// Parses a heights file: header `section,height_um` (other columns
/// ignored), one line per section, section numbers unique, section 1 present
/// with height 0 (the reference).
pub fn parse(path: &Path, src: &str) -> Result<Vec<SectionHeight>, SourceError> {
    let mut cols: Option<(usize, usize)> = None;
    let mut out: Vec<SectionHeight> = Vec::new();
    for rec in csv_lines(src) {
        let line = rec.line;
        let Some((cs, ch)) = cols else {
            let find = |n: &str| rec.fields.iter().position(|f| f.1.eq_ignore_ascii_case(n));
            match (find("section"), find("height_um")) {
                (Some(a), Some(b)) => cols = Some((a, b)),
                _ => {
                    let got: Vec<&str> = rec.fields.iter().map(|f| f.1).collect();
                    return Err(SourceError::new(
                        path,
                        line,
                        1,
                        format!(
                            "expected the header `section,height_um`, got `{}`",
                            got.join(",")
                        ),
                    ));
                }
            }
            continue;
        };
        let at = |i: usize, m: String| SourceError::new(path, line, rec.col(i), m);
        let s = rec.get(cs);
        let section: u32 = match s.parse() {
            Ok(v) if v >= 1 => v,
            _ => {
                return Err(at(
                    cs,
                    format!("expected a section number (1, 2, ...), got `{s}`"),
                ));
            }
        };
        if let Some(first) = out.iter().find(|h| h.section == section) {
            return Err(at(
                cs,
                format!(
                    "section {section} appears twice (first at line {})",
                    first.line
                ),
            ));
        }
        let height_um = parse_finite(rec.get(ch)).map_err(|m| at(ch, m))?;
        // Sections are cut at one nominal depth: what sets them apart is
        // the machine's errors, which fivecal takes up to MAX_ERROR_UM
        // (10 mm). A larger height is a wrong unit or line, not a section
        // to average in.
        let max = crate::limits::MAX_ERROR_UM;
        if height_um.abs() > max {
            return Err(at(
                ch,
                format!(
                    "height {} um of section {section} is beyond the largest error fivecal takes ({max} um): a wrong unit or line?",
                    crate::numbers::echo(height_um)
                ),
            ));
        }
        out.push(SectionHeight {
            section,
            height_um,
            line,
        });
    }
    if cols.is_none() {
        return Err(SourceError::new(
            path,
            0,
            0,
            "empty file: expected a header section,height_um and one line per section",
        ));
    }
    match out.iter().find(|h| h.section == 1) {
        None => {
            return Err(SourceError::new(
                path,
                0,
                0,
                "no section 1: heights are relative to section 1, which must be listed with height 0",
            ));
        }
        Some(h) if h.height_um != 0.0 => {
            return Err(SourceError::new(
                path,
                h.line,
                0,
                format!(
                    "section 1 has height {} um: heights are relative to section 1, so it must be 0",
                    h.height_um
                ),
            ));
        }
        Some(_) => {}
    }
    out.sort_by_key(|h| h.section);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_and_checks_the_reference_section() {
        let src = "section,height_um\n2,-5\n1,0\n3,-9.5\n";
        let h = parse(Path::new("h.csv"), src).unwrap();
        assert_eq!(h.iter().map(|x| x.section).collect::<Vec<_>>(), [1, 2, 3]);
        assert_eq!(h[2].height_um, -9.5);
        let e = parse(Path::new("h.csv"), "section,height_um\n1,2\n")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("h.csv:2: section 1 has height 2 um"), "{e}");
        let e = parse(Path::new("h.csv"), "section,height_um\n1,0\n1,3\n")
            .unwrap_err()
            .to_string();
        assert_eq!(e, "h.csv:3:1: section 1 appears twice (first at line 2)");
    }
}
