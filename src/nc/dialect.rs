//! Which dialect a program's text shows: words and blocks that only one of
//! FANUC, HEIDENHAIN and LinuxCNC has, so that a program read in another
//! dialect is refused with the one it is written in rather than rewritten
//! into a copy of itself.
//!
//! Each sign is something the other two controllers reject (LinuxCNC's
//! `rs274` refuses `G43.4`, `G31`, `G65`, `POPEN`, `GOTO` and
//! `WHILE`; no ISO dialect has a line starting `BEGIN PGM` or `L X+.. R0
//! FMAX`; FANUC has no o-words, `#<named>` parameters or `G38.2`). A
//! program shows a dialect only by such a sign: plain G-code (`G0 X10.`)
//! shows neither FANUC nor LinuxCNC, but it does show ISO G-code, which a
//! HEIDENHAIN Klartext program never has ([`Evidence::iso`]): that names
//! the dialect of a G-code program read as HEIDENHAIN in which no motion
//! block is understood.

use std::path::Path;

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

/// FANUC words no other dialect takes (outside comments). `G68.2` and
/// `G53.1` are not among them: LinuxCNC's five-axis configurations remap
/// them (the tilted-work-plane remap).
const FANUC_WORDS: [&str; 9] = [
    "G43.4", "G43.5", "G31", "G65", "POPEN", "PCLOS", "DPRNT", "BPRNT", "GOTO",
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

/// A FANUC program number: `O1001` (or `:1001`, the ISO spelling) alone in
/// its block, comments apart. LinuxCNC's o-words always carry a keyword
/// (`o100 sub`), and `rs274` refuses a bare one.
fn program_number(code: &str) -> bool {
    let t = code.trim();
    let Some(digits) = t.strip_prefix(['O', ':']) else {
        return false;
    };
    !digits.is_empty() && digits.len() <= 8 && digits.bytes().all(|c| c.is_ascii_digit())
}

/// SINUMERIK blocks, by how they start (after the block number).
const SINUMERIK_STARTS: [&str; 12] = [
    "%_N_",
    "DEF REAL",
    "DEF INT",
    "DEF BOOL",
    "DEF STRING",
    "DEF CHAR",
    "DEF AXIS",
    "DEF FRAME",
    "PROC ",
    "ENDIF",
    "ENDWHILE",
    "ENDLOOP",
];

/// SINUMERIK words no other dialect takes (outside comments): its
/// transformations, swivel cycle, frame suppression, pre-processing stop,
/// jumps and measuring words.
const SINUMERIK_WORDS: [&str; 10] = [
    "TRAORI", "TRAFOOF", "CYCLE800", "CYCLE832", "SUPA", "STOPRE", "GOTOF", "GOTOB", "TRANS",
    "ATRANS",
];

/// SINUMERIK spellings inside a block: `X=AC(..)`, `=IC(..)`, `=DC(..)`,
/// a measuring block, system variables, a tool called by name.
const SINUMERIK_SPELLINGS: [&str; 8] =
    ["=AC", "=IC", "=DC", "MEAS=", "$AA_", "$AC_", "$P_", "T=\""];

/// The SINUMERIK sign of a block, if it has one: `upper` is the whole
/// block, `body` after its number, `code` without comments. A `;` comment
/// is no sign: HEIDENHAIN writes them too.
fn sinumerik_sign(upper: &str, body: &str, code: &str) -> Option<&'static str> {
    if upper.trim_start().starts_with(";$PATH=") {
        return Some(";$PATH=");
    }
    if let Some(s) = SINUMERIK_STARTS.iter().find(|s| body.starts_with(**s)) {
        return Some(s);
    }
    if let Some(w) = SINUMERIK_WORDS.iter().find(|w| has_word(code, w)) {
        return Some(w);
    }
    SINUMERIK_SPELLINGS
        .iter()
        .find(|w| code.contains(**w))
        .copied()
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
    } else if program_number(&code) {
        out.push((Dialect::Fanuc, "O-number"));
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
    if let Some(sign) = sinumerik_sign(&upper, body, &code) {
        out.push((Dialect::Sinumerik, sign));
    }
    out
}

/// The words and spellings of every sign above, by the text they are
/// looked for in: the code (comments removed) or the whole upper-case
/// block (block starts, comment commands).
const CODE_SIGNS: [&[&str]; 4] = [
    &FANUC_WORDS,
    &["G38.2", "G38.3", "G38.4", "G38.5", "O<", "#<"],
    &SINUMERIK_WORDS,
    &SINUMERIK_SPELLINGS,
];
const TEXT_SIGNS: [&[&str]; 4] = [
    &HEIDENHAIN_STARTS,
    &["L ", "LN ", "LBL ", "WHILE", ";$PATH="],
    &LINUXCNC_COMMENTS,
    &SINUMERIK_STARTS,
];

/// The first two and three bytes of every sign, as bit sets.
struct Grams {
    /// Bytes a sign starts with.
    first: [bool; 256],
    /// Signs of two bytes.
    two: [u64; 1024],
    /// First two bytes of the longer signs.
    pre: [u64; 1024],
    /// First three bytes of the longer signs, sorted.
    three: Vec<[u8; 3]>,
    /// Bytes (either case) where [`may_show`] stops to look: a sign's
    /// first byte, or `(`, `;`, `O`, `:` or `G`. One lookup passes over
    /// the rest, most of a block.
    stop: [bool; 256],
}

impl Grams {
    fn get() -> &'static Grams {
        static GRAMS: std::sync::OnceLock<Grams> = std::sync::OnceLock::new();
        GRAMS.get_or_init(|| {
            let mut g = Grams {
                first: [false; 256],
                two: [0; 1024],
                pre: [0; 1024],
                three: Vec::new(),
                stop: [false; 256],
            };
            let set = |bits: &mut [u64; 1024], a: u8, b: u8| {
                let i = (a as usize) << 8 | b as usize;
                bits[i / 64] |= 1 << (i % 64);
            };
            for w in CODE_SIGNS.iter().chain(&TEXT_SIGNS).flat_map(|l| l.iter()) {
                let b = w.as_bytes();
                g.first[b[0] as usize] = true;
                if b.len() == 2 {
                    set(&mut g.two, b[0], b[1]);
                } else {
                    set(&mut g.pre, b[0], b[1]);
                    g.three.push([b[0], b[1], b[2]]);
                }
            }
            g.three.sort_unstable();
            g.three.dedup();
            for b in 0..=255u8 {
                let c = b.to_ascii_uppercase();
                g.stop[b as usize] =
                    g.first[c as usize] || matches!(c, b'(' | b';' | b'O' | b':' | b'G');
            }
            g
        })
    }

    /// Whether a sign begins with the bytes `a b c` (or `a b`, a sign of two).
    #[inline]
    fn hit(&self, a: u8, b: u8, c: u8) -> bool {
        if !self.first[a as usize] {
            return false;
        }
        let i = (a as usize) << 8 | b as usize;
        self.two[i / 64] >> (i % 64) & 1 == 1
            || self.pre[i / 64] >> (i % 64) & 1 == 1 && self.three.binary_search(&[a, b, c]).is_ok()
    }
}

/// Whether a block may show a sign ([`signs`]), and whether its code has a
/// `G` (an ISO motion word, [`iso_motion`]): `false` is certain, `true` a
/// maybe. Every sign is a word or spelling of two or more ASCII bytes in
/// the upper-case text or in its code (where removing a comment joins the
/// bytes on either side), or a code starting with `O` or `:`; so a block
/// in neither text of which any sign's first three bytes (two for the
/// signs of two) occur shows none.
fn may_show(text: &[u8]) -> (bool, bool) {
    let g = Grams::get();
    let up = |i: usize| text.get(i).map_or(0, u8::to_ascii_uppercase);
    // Without a comment the code is the text up to its `;`: one pass
    // looking only at the bytes a sign or the code's first byte may be.
    let mut in_code = true;
    let mut has_g = false;
    for (i, &c) in text.iter().enumerate() {
        if !g.stop[c as usize] {
            continue;
        }
        let c = c.to_ascii_uppercase();
        match c {
            b'(' => return may_show_commented(g, text),
            b';' => in_code = false,
            b'O' | b':' if in_code => return (true, true),
            b'G' if in_code => has_g = true,
            _ => {}
        }
        if g.hit(c, up(i + 1), up(i + 2)) {
            return (true, true);
        }
    }
    (false, has_g)
}

/// [`may_show`] of a block with a comment: the text and its code, where
/// taking a comment out joins the bytes on either side, followed byte by
/// byte.
fn may_show_commented(g: &Grams, text: &[u8]) -> (bool, bool) {
    // The last two bytes of the text and of the code (0: none).
    let (mut t, mut k) = ([0u8; 2], [0u8; 2]);
    let mut depth = 0usize;
    let mut in_code = true;
    let mut has_g = false;
    for &c in text {
        let c = c.to_ascii_uppercase();
        if g.hit(t[0], t[1], c) || g.hit(t[1], c, 0) {
            return (true, true);
        }
        t = [t[1], c];
        if !in_code {
            continue;
        }
        match c {
            b';' if depth == 0 => in_code = false,
            b'(' => depth += 1,
            b')' if depth > 0 => depth -= 1,
            _ if depth == 0 => {
                if matches!(c, b'O' | b':') || g.hit(k[0], k[1], c) || g.hit(k[1], c, 0) {
                    return (true, true);
                }
                has_g |= c == b'G';
                k = [k[1], c];
            }
            _ => {}
        }
    }
    (false, has_g)
}

impl Evidence {
    /// Looks at one block (`text`, starting at `line`).
    pub(crate) fn observe(&mut self, text: &[u8], line: usize) {
        if self.first.iter().all(Option::is_some) && self.iso.is_some() {
            return;
        }
        // Most blocks (the moves) show nothing: settled in one pass over
        // the bytes without building the upper-case text and its code.
        let (sign, g) = may_show(text);
        if !sign && (self.iso.is_some() || !g) {
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
    pub(crate) fn clue(&self, d: Dialect) -> Option<&Clue> {
        self.first[slot(d)].as_ref()
    }

    /// The first ISO G-code motion word (line, word): the text is
    /// FANUC's or LinuxCNC's, not HEIDENHAIN Klartext.
    pub fn iso(&self) -> Option<(usize, &str)> {
        self.iso.as_ref().map(|(l, w)| (*l, w.as_str()))
    }

    /// The dialect the text shows when read as `reading_as`: the first sign
    /// of another dialect, when the text has none of `reading_as`'s own.
    pub(crate) fn other_than(&self, reading_as: Dialect) -> Option<&Clue> {
        if self.clue(reading_as).is_some() {
            return None;
        }
        DIALECTS
            .iter()
            .filter(|&&d| d != reading_as)
            .filter_map(|&d| self.clue(d))
            .filter(|c| !shared_with(c, reading_as))
            .min_by_key(|c| c.line)
    }
}

/// Whether `c`, a sign of its dialect among the three others, is also
/// good `d`: FANUC's macro `GOTO` is SINUMERIK's jump as well.
fn shared_with(c: &Clue, d: Dialect) -> bool {
    c.dialect == Dialect::Fanuc && c.sign == "GOTO" && d == Dialect::Sinumerik
}

/// The dialect a file's name suggests: `.h` is HEIDENHAIN Klartext (the
/// extension the TNC gives it), `.ngc` LinuxCNC's, `.mpf` and `.spf`
/// SINUMERIK's main programs and subprograms. Other extensions
/// (`.nc`, `.tap`, `.txt`...) are used by every G-code control.
pub(crate) fn hinted(path: &Path) -> Option<Dialect> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    match ext.as_str() {
        "h" => Some(Dialect::Heidenhain),
        "ngc" => Some(Dialect::Linuxcnc),
        "mpf" | "spf" => Some(Dialect::Sinumerik),
        _ => None,
    }
}

/// How much of a program's beginning [`detect`] reads: the signs of a
/// dialect are in a program's first blocks (its number, `BEGIN PGM`, the
/// TCP call, the first subroutine), and a sign of another dialect further
/// on still refuses the read ([`super::Blocks::finish`]).
pub const DETECT_BYTES: usize = 256 * 1024;

/// The dialect a run reads a program in, and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Detection {
    /// The dialect used.
    pub dialect: Dialect,
    /// Why, in words: the sign and its line, `--dialect`, or the fallback.
    pub why: String,
}

impl std::fmt::Display for Detection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} ({})", self.dialect, self.why)
    }
}

/// The dialect of the program whose beginning is `head` (at most
/// [`DETECT_BYTES`] of it is looked at), named `path`, for a machine whose
/// controller speaks `machine`.
///
/// The text decides where it shows a sign ([`Evidence`]): HEIDENHAIN
/// Klartext (`BEGIN PGM`, `L X+.. R0 FMAX`), FANUC (a program number
/// `O1001`, `G43.4`, macro `GOTO`...) or LinuxCNC (o-words, `#<named>`
/// parameters, `G38.2`...). Where it shows signs of both G-code dialects,
/// the file's extension and then the machine choose between them. Plain
/// G-code with no sign is read as the machine's dialect if that is a
/// G-code one, else as the extension says, else as FANUC, the usual ISO
/// control (said, with `--dialect` to change it).
pub fn detect(path: &Path, head: &[u8], machine: Dialect) -> Detection {
    let head = &head[..head.len().min(DETECT_BYTES)];
    let mut e = Evidence::default();
    for (i, line) in head.split(|&c| c == b'\n' || c == b'\r').enumerate() {
        e.observe(line, i + 1);
    }
    detect_from(&e, hinted(path), machine)
}

fn detect_from(e: &Evidence, hint: Option<Dialect>, machine: Dialect) -> Detection {
    let by_sign = |c: &Clue| Detection {
        dialect: c.dialect,
        why: format!("from the text: `{}` at line {}", c.sign, c.line),
    };
    let iso = [Dialect::Fanuc, Dialect::Linuxcnc, Dialect::Sinumerik];
    let shown: Vec<&Clue> = DIALECTS.iter().filter_map(|&d| e.clue(d)).collect();
    // Klartext has no ISO motion word: a G-code program with a block that
    // merely starts like one of its blocks is still G-code.
    let klartext = e.clue(Dialect::Heidenhain);
    if let Some(k) = klartext
        && (e.iso().is_none() || shown.len() == 1 && e.iso().is_some_and(|(l, _)| l > k.line))
    {
        return by_sign(k);
    }
    // A SINUMERIK sign (`%_N_`, TRAORI, `X=AC(`...) is nothing FANUC or
    // LinuxCNC takes, while its `GOTO label` reads as FANUC's GOTO.
    if let Some(si) = e.clue(Dialect::Sinumerik) {
        return by_sign(si);
    }
    let g: Vec<&Clue> = shown
        .iter()
        .copied()
        .filter(|c| c.dialect != Dialect::Heidenhain)
        .collect();
    // FANUC's `GOTO` alone is SINUMERIK's too: the extension or the
    // machine says which.
    let sinumerik = hint.or(Some(machine)).filter(|&d| d == Dialect::Sinumerik);
    match g.as_slice() {
        [one] if sinumerik.is_some_and(|d| shared_with(one, d)) => {
            return Detection {
                dialect: Dialect::Sinumerik,
                why: format!(
                    "from the text: `{}` at line {}, FANUC's or SINUMERIK's; {} chose",
                    one.sign,
                    one.line,
                    if hint.is_some() {
                        "the file's extension"
                    } else {
                        "the machine's controller"
                    }
                ),
            };
        }
        [one] => return by_sign(one),
        [a, b] => {
            let pick = hint
                .filter(|h| iso.contains(h))
                .or(Some(machine).filter(|m| iso.contains(m)));
            let (chosen, other) = match pick {
                Some(d) if d == b.dialect => (b, a),
                Some(_) => (a, b),
                None if a.line <= b.line => (a, b),
                None => (b, a),
            };
            return Detection {
                dialect: chosen.dialect,
                why: format!(
                    "from the text: `{}` at line {}; it also shows {} (`{}` at line {}), {}",
                    chosen.sign,
                    chosen.line,
                    other.dialect,
                    other.sign,
                    other.line,
                    match pick {
                        Some(d) if hint == Some(d) => "the file's extension chose",
                        Some(_) => "the machine's controller chose",
                        None => "the first sign chose",
                    }
                ),
            };
        }
        _ => {}
    }
    if let Some((line, word)) = e.iso() {
        let (dialect, why) = match (hint, machine) {
            (Some(h), _) if iso.contains(&h) => (h, "the file's extension".to_string()),
            (_, m) if iso.contains(&m) => (m, "the machine's controller".to_string()),
            (_, m) => (
                Dialect::Fanuc,
                format!("the usual ISO control, the machine's being {m}"),
            ),
        };
        return Detection {
            dialect,
            why: format!(
                "plain G-code, `{word}` at line {line}, shows neither FANUC nor LinuxCNC: read as {dialect}, {why}; give --dialect to read it otherwise"
            ),
        };
    }
    let dialect = hint.unwrap_or(machine);
    Detection {
        dialect,
        why: if hint.is_some() {
            "no dialect's sign in the text: the file's extension".to_string()
        } else {
            "no dialect's sign in the text: the machine's controller".to_string()
        },
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
            shown("%\n(P)\nN10 G90 G54\nN20 G43.4 H1\nN30 G0 X1.\n"),
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
            shown("%\n(O1001 TOOL CALL G43.4 POPEN)\nG0 X1. Y2.\nG1 Z-1. F100.\nM30\n%\n")
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

    fn detected(path: &str, src: &str, machine: Dialect) -> Detection {
        detect(Path::new(path), src.as_bytes(), machine)
    }

    #[test]
    fn the_text_decides_the_dialect_whatever_the_machine() {
        let klartext = "0 BEGIN PGM P MM\n1 L X+10 R0 FMAX\n2 END PGM P MM\n";
        let fanuc = "%\nO1001 (P)\nN10 G90 G54\nN20 G0 X1.\n%\n";
        let linuxcnc = "(probe)\no<touch> sub\nG38.2 Z-10 F100\no<touch> endsub\nG0 X1\n";
        for m in DIALECTS {
            let d = detected("p.nc", klartext, m);
            assert_eq!(d.dialect, Dialect::Heidenhain, "{m}");
            assert_eq!(d.why, "from the text: `BEGIN PGM` at line 1");
            let d = detected("p.h", fanuc, m);
            assert_eq!(d.dialect, Dialect::Fanuc, "{m}");
            assert_eq!(d.why, "from the text: `O-number` at line 2");
            assert_eq!(detected("p.nc", linuxcnc, m).dialect, Dialect::Linuxcnc);
        }
        // A ~ continuation or a comment does not hide Klartext.
        let d = detected("x", "1 L X+10 Y+5 R0 FMAX ; G1\n", Dialect::Fanuc);
        assert_eq!(d.dialect, Dialect::Heidenhain);
    }

    #[test]
    fn plain_g_code_goes_by_extension_then_machine_then_fanuc() {
        let plain = "G90 G21\nG0 X10 Y10\nG1 Z-1 F100\nM2\n";
        let d = detected("p.ngc", plain, Dialect::Fanuc);
        assert_eq!(d.dialect, Dialect::Linuxcnc);
        assert!(d.why.contains("`G0` at line 2") && d.why.contains("extension"));
        assert_eq!(
            detected("p.nc", plain, Dialect::Linuxcnc).dialect,
            Dialect::Linuxcnc
        );
        assert_eq!(
            detected("p.nc", plain, Dialect::Fanuc).dialect,
            Dialect::Fanuc
        );
        let d = detected("p.nc", plain, Dialect::Heidenhain);
        assert_eq!(d.dialect, Dialect::Fanuc);
        assert!(
            d.why
                .contains("the usual ISO control, the machine's being heidenhain"),
            "{}",
            d.why
        );
        // A .h extension does not make G-code Klartext.
        assert_eq!(
            detected("p.h", plain, Dialect::Heidenhain).dialect,
            Dialect::Fanuc
        );
    }

    #[test]
    fn signs_of_both_g_code_dialects_are_settled_by_extension_or_machine() {
        let both = "N10 G43.4 H1\n#<depth> = 2\nG1 X1 F100\n";
        let d = detected("p.ngc", both, Dialect::Fanuc);
        assert_eq!(d.dialect, Dialect::Linuxcnc);
        assert!(d.why.contains("extension chose"), "{}", d.why);
        let d = detected("p.nc", both, Dialect::Linuxcnc);
        assert_eq!(d.dialect, Dialect::Linuxcnc);
        assert!(d.why.contains("machine's controller chose"), "{}", d.why);
        let d = detected("p.nc", both, Dialect::Heidenhain);
        assert_eq!(d.dialect, Dialect::Fanuc);
        assert!(d.why.contains("first sign chose"), "{}", d.why);
    }

    #[test]
    fn a_program_number_is_fanuc_but_an_o_word_is_not() {
        for block in ["O1001", "O0001 (MAIN)", ":1234", "%O12"] {
            let mut e = Evidence::default();
            e.observe(block.as_bytes(), 1);
            let want = !block.starts_with('%');
            assert_eq!(e.clue(Dialect::Fanuc).is_some(), want, "{block}");
        }
        for block in ["o100 sub", "O<x> call", "O1001 X5", "OX1"] {
            let mut e = Evidence::default();
            e.observe(block.as_bytes(), 1);
            assert!(e.clue(Dialect::Fanuc).is_none(), "{block}");
        }
    }

    #[test]
    fn nothing_to_go_by_is_the_extension_or_the_machine() {
        let d = detected("p.h", "(nothing)\n", Dialect::Fanuc);
        assert_eq!(d.dialect, Dialect::Heidenhain);
        assert_eq!(d.why, "no dialect's sign in the text: the file's extension");
        assert_eq!(
            detected("p.txt", "", Dialect::Linuxcnc).dialect,
            Dialect::Linuxcnc
        );
    }

    // SINUMERIK's signs.

    fn first_sign(src: &str) -> Option<(Dialect, usize, &'static str)> {
        let mut e = Evidence::default();
        for (i, l) in src.lines().enumerate() {
            e.observe(l.as_bytes(), i + 1);
        }
        e.clue(Dialect::Sinumerik)
            .map(|c| (c.dialect, c.line, c.sign))
    }

    #[test]
    fn sinumerik_shows_by_its_header_transformations_cycles_and_spellings() {
        for (block, sign) in [
            ("%_N_SHAFT123_MPF", "%_N_"),
            (";$PATH=/_N_MPF_DIR", ";$PATH="),
            ("N30 DEF REAL _camtolerance", "DEF REAL"),
            ("N10 TRAORI", "TRAORI"),
            (
                "CYCLE800(0,\"TC1\",0,192,0,0,0,0,30,45,0,0,0,1)",
                "CYCLE800",
            ),
            ("SUPA G0 Z0 D0", "SUPA"),
            ("IF R6<R3 GOTOF END", "GOTOF"),
            ("G1 X=AC(10) Y5", "=AC"),
            ("MEAS=1 G1 X10 Y0 Z5 F100", "MEAS="),
            ("R1=$AA_MW[X]", "$AA_"),
            ("T=\"D8 MILL\" M6", "T=\""),
            ("ENDIF", "ENDIF"),
        ] {
            assert_eq!(
                first_sign(block),
                Some((Dialect::Sinumerik, 1, sign)),
                "{block}"
            );
        }
        // A `;` comment is HEIDENHAIN's too; plain words are everyone's.
        for block in [
            "G0 X1 Y2 ; TRAORI in a comment",
            "5 L X+1 R0 FMAX ; comment",
            "G1 X10 F100",
            "(CYCLE800 in a FANUC comment)",
        ] {
            assert_eq!(first_sign(block), None, "{block}");
        }
    }

    #[test]
    fn a_sinumerik_program_is_read_as_sinumerik_whatever_the_machine() {
        let program = "N10 G17 G90 G710\nN20 LBL1:\nN30 GOTO LBL1\nN40 TRAORI\nN50 G1 X1 F100\n";
        for m in DIALECTS {
            let d = detect(Path::new("p.nc"), program.as_bytes(), m);
            assert_eq!(d.dialect, Dialect::Sinumerik, "{m}");
            assert_eq!(d.why, "from the text: `TRAORI` at line 4");
        }
        // Plain G-code: the .mpf extension, or a SINUMERIK machine.
        let plain = "G90 G0 X10 Y10\nG1 Z-1 F100\nM30\n";
        assert_eq!(
            detect(Path::new("P.MPF"), plain.as_bytes(), Dialect::Fanuc).dialect,
            Dialect::Sinumerik
        );
        assert_eq!(
            detect(Path::new("p.nc"), plain.as_bytes(), Dialect::Sinumerik).dialect,
            Dialect::Sinumerik
        );
        assert_eq!(hinted(Path::new("sub.spf")), Some(Dialect::Sinumerik));
    }

    #[test]
    fn a_lone_goto_is_sinumerik_s_where_the_extension_or_machine_says_so() {
        let src = "; jumps\nGOTO\nN10 G1 X1 F100\n";
        let d = detected("jumps.spf", src, Dialect::Fanuc);
        assert_eq!(d.dialect, Dialect::Sinumerik);
        assert!(d.why.contains("the file's extension chose"), "{}", d.why);
        assert_eq!(
            detected("jumps.nc", src, Dialect::Sinumerik).dialect,
            Dialect::Sinumerik
        );
        assert_eq!(
            detected("jumps.nc", src, Dialect::Fanuc).dialect,
            Dialect::Fanuc
        );
        // Read as SINUMERIK, its GOTO is no sign of another dialect.
        let mut e = Evidence::default();
        e.observe(b"GOTO", 2);
        assert_eq!(e.other_than(Dialect::Sinumerik), None);
        assert_eq!(
            e.other_than(Dialect::Linuxcnc).map(|c| c.dialect),
            Some(Dialect::Fanuc)
        );
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(4000))]
        /// The quick look never misses a sign or an ISO motion word: on
        /// text made of the signs' own pieces, comments and `;`, whatever
        /// it passes over shows nothing.
        #[test]
        fn the_quick_look_misses_no_sign(
            parts in proptest::collection::vec(0usize..45, 0..8),
        ) {
            const PIECES: [&str; 45] = [
                "G", "O", "L", "T", "P", "W", "D", "C", "A", "S", "(", ")", ";", " ", "N10 ",
                "1", "3", "4", ".", "=", "<", "#", "$", "%", "_", "R", "E", "B", "M", "X1.5",
                "g43.4", "o<x>", "l ", "goto", "(log,", "trans", "=ac", "begin pgm", "while", "\u{e9}", "(x)", "g4(a)3.4", "go(c)to", "=(i)c", "#(a)<",
            ];
            let text: String = parts.iter().map(|&i| PIECES[i]).collect();
            let upper = text.to_ascii_uppercase();
            let (sign, g) = may_show(text.as_bytes());
            if !sign {
                proptest::prop_assert!(signs(&text).is_empty(), "{text:?}");
            }
            if !sign && !g {
                proptest::prop_assert!(iso_motion(&code(&upper)).is_none(), "{text:?}");
            }
        }
    }
}
