//! Which dialect a program's text shows: words and blocks that only one of
//! FANUC, HEIDENHAIN and LinuxCNC has, so that a program read in another
//! dialect is refused with the one it is written in rather than rewritten
//! into a copy of itself.
//!
//! Each sign is something the other two controllers reject (LinuxCNC's
//! `rs274` refuses `G43.4`, `G68.2`, `G31`, `G65`, `POPEN`, `GOTO` and
//! `WHILE`; no ISO dialect has a line starting `BEGIN PGM` or `L X+.. R0
//! FMAX`; FANUC has no o-words, `#<named>` parameters or `G38.2`). A
//! program shows a dialect only by such a sign: plain G-code (`G0 X10.`)
//! shows neither FANUC nor LinuxCNC, but it does show ISO G-code, which a
//! HEIDENHAIN Klartext program never has ([`Evidence::iso`]): that names
//! the dialect of a G-code program read as HEIDENHAIN in which no motion
//! block is understood.

use crate::machine::Dialect;

/// A sign of a dialect: the line and the word that shows it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Clue {
    /// The dialect shown.
    pub dialect: Dialect,
    /// 1-based line.
    pub line: usize,
    /// The word or block, as the dialect spells it.
    pub sign: &'static str,
}

/// What a program's blocks have shown so far.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Evidence {
    /// The first clue of each dialect (fanuc, heidenhain, linuxcnc,
    /// sinumerik).
    first: [Option<Clue>; 4],
    /// The first ISO G-code motion word (`G0`, `G01`...): line and word.
    iso: Option<(usize, String)>,
}

const DIALECTS: [Dialect; 4] = Dialect::ALL;

fn slot(d: Dialect) -> usize {
    match d {
        Dialect::Fanuc => 0,
        Dialect::Heidenhain => 1,
        Dialect::Linuxcnc => 2,
        Dialect::Sinumerik => 3,
    }
}

/// HEIDENHAIN blocks, by how they start (after the block number).
const HEIDENHAIN_STARTS: [&str; 12] = [
    "BEGIN PGM",
    "END PGM",
    "BLK FORM",
    "TOOL CALL",
    "TOOL DEF",
    "CYCL DEF",
    "CYCL CALL",
    "TCH PROBE",
    "CALL LBL",
    "CALL PGM",
    "FUNCTION TCPM",
    "PLANE ",
];

/// FANUC words no other dialect takes (outside comments).
const FANUC_WORDS: [&str; 11] = [
    "G43.4", "G43.5", "G68.2", "G53.1", "G31", "G65", "POPEN", "PCLOS", "DPRNT", "BPRNT", "GOTO",
];

/// LinuxCNC comment commands.
const LINUXCNC_COMMENTS: [&str; 8] = [
    "(PROBEOPEN",
    "(PROBECLOSE",
    "(LOGOPEN",
    "(LOGAPPEND",
    "(LOGCLOSE",
    "(LOG,",
    "(PRINT,",
    "(DEBUG,",
];

/// LinuxCNC o-word keywords.
const O_WORDS: [&str; 15] = [
    "SUB",
    "ENDSUB",
    "CALL",
    "RETURN",
    "IF",
    "ELSEIF",
    "ELSE",
    "ENDIF",
    "WHILE",
    "ENDWHILE",
    "DO",
    "REPEAT",
    "ENDREPEAT",
    "BREAK",
    "CONTINUE",
];

/// `text` without `( ... )` comments and anything after `;`.
fn code(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut depth = 0usize;
    for c in text.chars() {
        match c {
            ';' if depth == 0 => break,
            '(' => depth += 1,
            ')' if depth > 0 => depth -= 1,
            _ if depth == 0 => out.push(c),
            _ => {}
        }
    }
    out
}

/// Whether `word` occurs in `code` as a word (not inside a longer number:
/// `G31` but not `G310` or `G31.1`... `G43.4` but not `G43.45`).
fn has_word(code: &str, word: &str) -> bool {
    let b = code.as_bytes();
    let mut from = 0;
    while let Some(i) = code[from..].find(word) {
        let at = from + i;
        let before = at.checked_sub(1).map(|j| b[j]);
        let after = b.get(at + word.len()).copied();
        let letter_word = word.bytes().all(|c| c.is_ascii_alphabetic());
        let ok_before = before.is_none_or(|c| !c.is_ascii_alphanumeric() && c != b'.');
        let ok_after = if letter_word {
            // POPEN, DPRNT[...], GOTO10
            after.is_none_or(|c| !c.is_ascii_alphabetic())
        } else {
            after.is_none_or(|c| !c.is_ascii_digit() && c != b'.')
        };
        if ok_before && ok_after {
            return true;
        }
        from = at + word.len();
    }
    false
}

/// The first ISO motion word (`G0`..`G3`, with or without a leading zero)
/// of a block's code, as written: a HEIDENHAIN Klartext block has none.
fn iso_motion(code: &str) -> Option<String> {
    let b = code.as_bytes();
    for (i, _) in code.match_indices('G') {
        // `N10G01X5.` is one block without spaces: a digit may come before.
        if i > 0 && (b[i - 1].is_ascii_alphabetic() || b[i - 1] == b'.' || b[i - 1] == b'#') {
            continue;
        }
        let digits: String = code[i + 1..]
            .chars()
            .take_while(char::is_ascii_digit)
            .collect();
        // `G0.5` is another word.
        if b.get(i + 1 + digits.len()) == Some(&b'.') {
            continue;
        }
        if matches!(
            digits.as_str(),
            "0" | "00" | "1" | "01" | "2" | "02" | "3" | "03"
        ) {
            return Some(format!("G{digits}"));
        }
    }
    None
}

/// The signs in one block's text, by dialect.
fn signs(text: &str) -> Vec<(Dialect, &'static str)> {
    let upper = text.to_ascii_uppercase();
    let mut out = Vec::new();
    // After a block number (`N10`, or HEIDENHAIN's leading `10`) and block delete.
    let body = upper.trim_start().trim_start_matches('/');
    let body = body
        .strip_prefix('N')
        .filter(|r| r.starts_with(|c: char| c.is_ascii_digit()))
        .unwrap_or(body);
    let body = body
        .trim_start_matches(|c: char| c.is_ascii_digit())
        .trim_start();
    if let Some(s) = HEIDENHAIN_STARTS.iter().find(|s| body.starts_with(**s)) {
        out.push((Dialect::Heidenhain, *s));
    } else if (body.starts_with("L ") || body.starts_with("LN "))
        && [" FMAX", " R0", " RL", " RR"]
            .iter()
            .any(|w| body.contains(w))
    {
        out.push((Dialect::Heidenhain, "L ... R0/FMAX"));
    } else if body.starts_with("LBL ") {
        out.push((Dialect::Heidenhain, "LBL"));
    }
    let code = code(&upper);
    if let Some(w) = FANUC_WORDS.iter().find(|w| has_word(&code, w)) {
        out.push((Dialect::Fanuc, *w));
    } else if body.starts_with("WHILE") && code.contains(" DO") || body.starts_with("WHILE[") {
        // FANUC's loop starts its block; LinuxCNC's follows an o-word.
        out.push((Dialect::Fanuc, "WHILE [...] DO"));
    }
    if let Some(c) = LINUXCNC_COMMENTS.iter().find(|c| upper.contains(**c)) {
        out.push((Dialect::Linuxcnc, *c));
    } else if code.contains("O<") {
        out.push((Dialect::Linuxcnc, "o<name>"));
    } else if code.contains("#<") {
        out.push((Dialect::Linuxcnc, "#<name>"));
    } else if ["G38.2", "G38.3", "G38.4", "G38.5"]
        .iter()
        .any(|w| has_word(&code, w))
    {
        out.push((Dialect::Linuxcnc, "G38.2"));
    } else if let Some(rest) = code.trim_start().strip_prefix('O')
        && let Some(after) = rest.strip_prefix(|c: char| c.is_ascii_digit())
    {
        let kw = after
            .trim_start_matches(|c: char| c.is_ascii_digit())
            .split_whitespace()
            .next()
            .unwrap_or("");
        if O_WORDS.contains(&kw) {
            out.push((Dialect::Linuxcnc, "o-word"));
        }
    }
    out
}

impl Evidence {
    /// Looks at one block (`text`, starting at `line`).
    pub fn observe(&mut self, text: &[u8], line: usize) {
        if self.first.iter().all(Option::is_some) && self.iso.is_some() {
            return;
        }
        let text = String::from_utf8_lossy(text);
        if self.iso.is_none()
            && let Some(w) = iso_motion(&code(&text.to_ascii_uppercase()))
        {
            self.iso = Some((line, w));
        }
        for (d, sign) in signs(&text) {
            let s = &mut self.first[slot(d)];
            if s.is_none() {
                *s = Some(Clue {
                    dialect: d,
                    line,
                    sign,
                });
            }
        }
    }

    /// The first sign of `d`, if any.
    pub fn clue(&self, d: Dialect) -> Option<&Clue> {
        self.first[slot(d)].as_ref()
    }

    /// The first ISO G-code motion word (line, word): the text is
    /// FANUC's or LinuxCNC's, not HEIDENHAIN Klartext.
    pub fn iso(&self) -> Option<(usize, &str)> {
        self.iso.as_ref().map(|(l, w)| (*l, w.as_str()))
    }

    /// The dialect the text shows when read as `reading_as`: the first sign
    /// of another dialect, when the text has none of `reading_as`'s own.
    pub fn other_than(&self, reading_as: Dialect) -> Option<&Clue> {
        if self.clue(reading_as).is_some() {
            return None;
        }
        DIALECTS
            .iter()
            .filter(|&&d| d != reading_as)
            .filter_map(|&d| self.clue(d))
            .min_by_key(|c| c.line)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shown(src: &str) -> Vec<(Dialect, usize)> {
        let mut e = Evidence::default();
        for (i, l) in src.lines().enumerate() {
            e.observe(l.as_bytes(), i + 1);
        }
        DIALECTS
            .iter()
            .filter_map(|&d| e.clue(d).map(|c| (d, c.line)))
            .collect()
    }

    #[test]
    fn each_dialect_shows_by_what_only_it_has() {
        assert_eq!(
            shown("0 BEGIN PGM P MM\n1 L X+10 R0 FMAX\n2 END PGM P MM\n"),
            vec![(Dialect::Heidenhain, 1)]
        );
        assert_eq!(
            shown("%\nO1001 (P)\nN10 G90 G54\nN20 G43.4 H1\nN30 G0 X1.\n"),
            vec![(Dialect::Fanuc, 4)]
        );
        assert_eq!(
            shown("(probe)\no<touch> sub\nG38.2 Z-10 F100\no<touch> endsub\n"),
            vec![(Dialect::Linuxcnc, 2)]
        );
        assert_eq!(
            shown("(PROBEOPEN probe.txt)\nG0 X1\n"),
            vec![(Dialect::Linuxcnc, 1)]
        );
        assert_eq!(
            shown("POPEN\nDPRNT[X#5061[44]]\nPCLOS\n"),
            vec![(Dialect::Fanuc, 1)]
        );
    }

    #[test]
    fn plain_g_code_and_comments_show_nothing() {
        assert!(
            shown("%\nO1001 (TOOL CALL G43.4 POPEN)\nG0 X1. Y2.\nG1 Z-1. F100.\nM30\n%\n")
                .is_empty()
        );
        // A longer number is another word.
        assert!(shown("G310 X1\nG43.45\nG650\n").is_empty());
        // HEIDENHAIN's own words are not ISO motion words.
        let mut e = Evidence::default();
        for (i, l) in [
            "0 BEGIN PGM P MM",
            "1 L X+10 R0 FMAX",
            "2 CYCL DEF 7.0 DATUM SHIFT",
            "3 CC X+0 Y+0",
            "4 FN 9: IF +Q4 EQU +Q5 GOTO LBL 1",
        ]
        .iter()
        .enumerate()
        {
            e.observe(l.as_bytes(), i + 1);
        }
        assert_eq!(e.iso(), None);
        // HEIDENHAIN's comments are after `;`.
        assert_eq!(
            shown("5 L X+1 R0 FMAX ; G43.4 o<x>\n"),
            vec![(Dialect::Heidenhain, 1)]
        );
    }

    #[test]
    fn iso_motion_words_show_g_code_whatever_their_spelling() {
        for (block, word) in [
            ("N70 G0 Z190.", "G0"),
            ("N10G01X5.F100", "G01"),
            ("G90 G17 G2 X1 Y1 R1", "G2"),
            ("G1X1", "G1"),
        ] {
            let mut e = Evidence::default();
            e.observe(block.as_bytes(), 7);
            assert_eq!(e.iso(), Some((7, word)), "{block}");
        }
        for block in [
            "G90 G54 (G0 in a comment)",
            "G04 P1",
            "G10 L2 P1",
            "G0.5",
            "#G1",
        ] {
            let mut e = Evidence::default();
            e.observe(block.as_bytes(), 1);
            assert_eq!(e.iso(), None, "{block}");
        }
    }

    #[test]
    fn the_other_dialect_is_named_only_without_a_sign_of_ones_own() {
        let mut e = Evidence::default();
        e.observe(b"N10 G43.4 H1\n", 3);
        assert_eq!(
            e.other_than(Dialect::Heidenhain).map(|c| c.dialect),
            Some(Dialect::Fanuc)
        );
        assert_eq!(e.other_than(Dialect::Fanuc), None);
        e.observe(b"o100 sub\n", 9);
        // Signs of both G-code dialects: reading as either is not refused.
        assert_eq!(e.other_than(Dialect::Linuxcnc), None);
        assert_eq!(e.other_than(Dialect::Heidenhain).map(|c| c.line), Some(3));
    }
}
