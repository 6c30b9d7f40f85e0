//! The text of a measurement file from its bytes. Measurement files are
//! read as UTF-8 (a byte-order mark dropped). CMM software on older
//! Windows installations still writes legacy 8-bit code pages (German and
//! Spanish feature names in Windows-1252) and some writes UTF-16; such a
//! file is refused with the encoding named and the first offending byte
//! located, unless the user names the encoding (`--encoding windows-1252`),
//! which is then decoded exactly (encoding_rs, the WHATWG encodings).
//!
//! One real-writer quirk is mended here because it breaks UTF-8 itself:
//! DMIS writers wrap long statements at a byte count, and a break can fall
//! inside a multi-byte character (`Rect\xC3$` / `\xA1ngulo`). The bytes of
//! such a character are brought back together before the `$` (the line
//! numbers stay as they were) and a note says so.

use std::path::Path;

use encoding_rs::Encoding;

use crate::source::SourceError;

/// An encoding by the name the user gives (`latin1`, `windows-1252`,
/// `utf-16le`, `shift_jis`, ...: the WHATWG labels).
pub fn by_name(name: &str) -> Option<&'static Encoding> {
    Encoding::for_label(name.trim().as_bytes())
}

/// Line and column (1-based, column in bytes) of byte offset `at`.
fn line_col(bytes: &[u8], at: usize) -> (usize, usize) {
    let before = &bytes[..at.min(bytes.len())];
    let line = 1 + before.iter().filter(|&&b| b == b'\n').count();
    let col = 1 + before.iter().rev().take_while(|&&b| b != b'\n').count();
    (line, col)
}

/// Length of the UTF-8 sequence a lead byte starts (0 for a byte that is
/// not a lead byte).
fn utf8_len(lead: u8) -> usize {
    match lead {
        0xC2..=0xDF => 2,
        0xE0..=0xEF => 3,
        0xF0..=0xF4 => 4,
        _ => 0,
    }
}

/// Brings together the bytes of UTF-8 characters split by a `$` line
/// break (DMIS continuation): `lead $ EOL rest` becomes `lead rest $ EOL`.
/// Returns the mended bytes and how many characters were mended.
fn mend_split_characters(bytes: &[u8]) -> (Vec<u8>, usize) {
    let mut out = Vec::with_capacity(bytes.len());
    let mut mended = 0;
    let mut i = 0;
    while i < bytes.len() {
        let b = bytes[i];
        let n = utf8_len(b);
        if n == 0 {
            out.push(b);
            i += 1;
            continue;
        }
        // Bytes of this character before a `$` break.
        let mut have = 1;
        while have < n && bytes.get(i + have).is_some_and(|c| c & 0xC0 == 0x80) {
            have += 1;
        }
        if have < n {
            let brk = i + have;
            let eol = match bytes.get(brk..brk + 3) {
                Some([b'$', b'\r', b'\n']) => 3,
                _ => match bytes.get(brk..brk + 2) {
                    Some([b'$', b'\n']) => 2,
                    _ => 0,
                },
            };
            let rest = brk + eol;
            let tail = n - have;
            if eol > 0
                && bytes
                    .get(rest..rest + tail)
                    .is_some_and(|t| t.iter().all(|c| c & 0xC0 == 0x80))
            {
                out.extend_from_slice(&bytes[i..brk]);
                out.extend_from_slice(&bytes[rest..rest + tail]);
                out.extend_from_slice(&bytes[brk..rest]);
                mended += 1;
                i = rest + tail;
                continue;
            }
        }
        out.extend_from_slice(&bytes[i..i + have]);
        i += have;
    }
    (out, mended)
}

/// What an undecodable file most likely is, for the refusal.
fn guess(bytes: &[u8]) -> &'static str {
    let nul_odd = bytes
        .iter()
        .skip(1)
        .step_by(2)
        .take(200)
        .filter(|&&b| b == 0)
        .count();
    let nul_even = bytes
        .iter()
        .step_by(2)
        .take(200)
        .filter(|&&b| b == 0)
        .count();
    if bytes.starts_with(&[0xFF, 0xFE]) || nul_odd > 10 && nul_even == 0 {
        "UTF-16LE (give `--encoding utf-16le`)"
    } else if bytes.starts_with(&[0xFE, 0xFF]) || nul_even > 10 && nul_odd == 0 {
        "UTF-16BE (give `--encoding utf-16be`)"
    } else {
        "a legacy 8-bit code page such as Windows-1252 or ISO-8859-1 (give `--encoding windows-1252`, or the code page the CMM wrote)"
    }
}

/// The text of a measurement file, and notes on what was mended. With an
/// encoding named, the bytes are decoded with it (a byte-order mark wins
/// over it, as the WHATWG decoders do); otherwise they must be UTF-8.
pub(crate) fn decode(
    path: &Path,
    bytes: &[u8],
    encoding: Option<&'static Encoding>,
) -> Result<(String, Vec<String>), SourceError> {
    if let Some(enc) = encoding {
        let (text, used, errors) = enc.decode(bytes);
        if errors {
            return Err(SourceError::new(
                path,
                0,
                0,
                format!(
                    "not valid {} text: some bytes have no character in that encoding",
                    used.name()
                ),
            ));
        }
        return Ok((text.into_owned(), Vec::new()));
    }
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    match std::str::from_utf8(bytes) {
        // A NUL byte is no character of a text file: UTF-16 without a
        // byte-order mark is valid UTF-8 full of them.
        Ok(_) if bytes.contains(&0) => {
            let at = bytes.iter().position(|&b| b == 0).unwrap_or(0);
            let (line, col) = line_col(bytes, at);
            Err(SourceError::new(
                path,
                line,
                col,
                format!("a NUL byte: the file looks like {}", guess(bytes)),
            ))
        }
        Ok(s) => Ok((s.to_string(), Vec::new())),
        Err(e) => {
            let (mended, n) = mend_split_characters(bytes);
            if n > 0
                && let Ok(s) = String::from_utf8(mended)
            {
                return Ok((
                    s,
                    vec![format!(
                        "{n} UTF-8 characters were split by a `$` line break (a writer wrapping at a byte count) and were joined"
                    )],
                ));
            }
            let at = e.valid_up_to();
            let (line, col) = line_col(bytes, at);
            Err(SourceError::new(
                path,
                line,
                col,
                format!(
                    "not UTF-8 (byte 0x{:02X}): the file looks like {}",
                    bytes[at],
                    guess(bytes)
                ),
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mends_a_character_split_by_a_continuation() {
        // "Rectángulo" broken between the two bytes of `á` (0xC3 0xA1).
        let src = b"F(Rect\xC3$\r\n\xA1ngulo)=FEAT/POINT\r\n";
        let (t, notes) = decode(Path::new("x.dmo"), src, None).unwrap();
        assert_eq!(t, "F(Rect\u{e1}$\r\nngulo)=FEAT/POINT\r\n");
        assert_eq!(notes.len(), 1);
    }

    #[test]
    fn names_the_encoding_it_refuses_and_reads_it_when_named() {
        let src = b"label,x,y,z\nPunkt_\xFC1,1,2,3\n";
        let e = decode(Path::new("m.csv"), src, None)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("m.csv:2:7: not UTF-8 (byte 0xFC): the file looks like a legacy 8-bit"),
            "{e}"
        );
        let (t, _) = decode(Path::new("m.csv"), src, by_name("windows-1252")).unwrap();
        assert!(t.contains("Punkt_\u{fc}1"));
        let utf16: Vec<u8> = "x y z\n1 2 3\n"
            .encode_utf16()
            .flat_map(|u| u.to_le_bytes())
            .collect();
        let e = decode(Path::new("p.txt"), &utf16, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("UTF-16LE"), "{e}");
        let (t, _) = decode(Path::new("p.txt"), &utf16, by_name("utf-16le")).unwrap();
        assert_eq!(t, "x y z\n1 2 3\n");
    }
}
