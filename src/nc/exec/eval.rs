//! Evaluating the arithmetic of the four dialects' parameters: FANUC
//! Custom Macro B and LinuxCNC (`[ ]` brackets, `#` parameters, `SIN[..]`,
//! `ATAN[y]/[x]`, `EQ`/`GT`/`AND`/`MOD`/`**`), HEIDENHAIN Q formulas
//! (`( )`, `Q`/`QL`/`QR`, `SIN ( .. )`, `^`) and SINUMERIK (`( )`, `R1`,
//! `R[..]`, `DEF` names, `==`/`<>`, `DIV`, `ATAN2(a,b)`, `POT`).
//!
//! Angles are degrees in every dialect. A value the program does not fix
//! (a system variable, a parameter set outside it, an unknown function) is
//! [`Stop::Unknown`], never a guess; what a controller would stop on
//! (division by zero, the square root of a negative number) is
//! [`Stop::Alarm`]. Nesting is bounded by [`MAX_EXPR_DEPTH`] like the
//! lexers' validation.

use crate::limits::MAX_EXPR_DEPTH;
use crate::machine::Dialect;

/// A parameter: numbered (`#12`, `Q3`, `R7`) or named (`#<x>`, `QL2`,
/// a SINUMERIK `DEF` name), names in lower case.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Key {
    /// A numbered parameter.
    Num(i64),
    /// A named one.
    Name(String),
}

impl std::fmt::Display for Key {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Key::Num(n) => write!(f, "{n}"),
            Key::Name(s) => write!(f, "{s}"),
        }
    }
}

/// Why an expression has no value here.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Stop {
    /// Its value is not known from the program (with why).
    Unknown(String),
    /// The controller would raise an alarm (with why).
    Alarm(String),
}

impl std::fmt::Display for Stop {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Stop::Unknown(s) => write!(f, "{s}"),
            Stop::Alarm(s) => write!(f, "the controller stops here: {s}"),
        }
    }
}

/// Where parameter values come from.
pub(crate) trait Params {
    /// The value of a parameter, or why it has none.
    fn get(&self, key: &Key) -> Result<f64, Stop>;
}

/// No parameter has a value: for reading a parameter reference whose
/// index is a plain number (an assignment's target, a loop variable).
pub(crate) struct NoParams;

impl Params for NoParams {
    fn get(&self, _: &Key) -> Result<f64, Stop> {
        Err(Stop::Unknown("an indexed parameter".into()))
    }
}

/// Evaluates `text` (a whole expression) in `dialect`.
pub(crate) fn eval(dialect: Dialect, text: &[u8], params: &dyn Params) -> Result<f64, Stop> {
    let mut p = Parser {
        s: text,
        i: 0,
        dialect,
        params,
        depth: 0,
    };
    let v = p.expr(0)?;
    p.ws();
    if p.i < p.s.len() {
        return Err(Stop::Unknown(format!(
            "`{}` is not an expression fivecal evaluates",
            String::from_utf8_lossy(text).trim()
        )));
    }
    Ok(v)
}

/// Reads a parameter reference at the start of `text` (`#12`, `#<x>`,
/// `#[#1+2]`, `Q3`, `QL2`, `R[2]`, `_NAME`), evaluating any index; returns
/// the key and the bytes it took.
pub(crate) fn param_ref(
    dialect: Dialect,
    text: &[u8],
    params: &dyn Params,
) -> Result<(Key, usize), Stop> {
    let mut p = Parser {
        s: text,
        i: 0,
        dialect,
        params,
        depth: 0,
    };
    p.ws();
    match p.param()? {
        Some(k) => Ok((k, p.i)),
        None => Err(Stop::Unknown(format!(
            "`{}` is not a parameter fivecal knows",
            String::from_utf8_lossy(text).trim()
        ))),
    }
}

struct Parser<'a> {
    s: &'a [u8],
    i: usize,
    dialect: Dialect,
    params: &'a dyn Params,
    depth: usize,
}

/// Binary operators: spelling, binding power.
const ISO_OPS: [(&str, u8); 15] = [
    ("**", 6),
    ("*", 5),
    ("/", 5),
    ("MOD", 5),
    ("+", 4),
    ("-", 4),
    ("EQ", 3),
    ("NE", 3),
    ("GT", 3),
    ("GE", 3),
    ("LT", 3),
    ("LE", 3),
    ("AND", 2),
    ("OR", 1),
    ("XOR", 1),
];
const HH_OPS: [(&str, u8); 5] = [("^", 6), ("*", 5), ("/", 5), ("+", 4), ("-", 4)];
const SIN_OPS: [(&str, u8); 15] = [
    ("*", 5),
    ("/", 5),
    ("DIV", 5),
    ("MOD", 5),
    ("+", 4),
    ("-", 4),
    ("==", 3),
    ("<>", 3),
    ("<=", 3),
    (">=", 3),
    ("<", 3),
    (">", 3),
    ("AND", 2),
    ("OR", 1),
    ("XOR", 1),
];

fn truth(b: bool) -> f64 {
    if b { 1.0 } else { 0.0 }
}

impl Parser<'_> {
    fn iso(&self) -> bool {
        matches!(self.dialect, Dialect::Fanuc | Dialect::Linuxcnc)
    }

    fn open(&self) -> u8 {
        if self.iso() { b'[' } else { b'(' }
    }

    fn close(&self) -> u8 {
        if self.iso() { b']' } else { b')' }
    }

    fn ws(&mut self) {
        while self.i < self.s.len() && matches!(self.s[self.i], b' ' | b'\t') {
            self.i += 1;
        }
    }

    fn peek(&self) -> Option<u8> {
        self.s.get(self.i).copied()
    }

    fn starts(&self, kw: &str) -> bool {
        self.s[self.i..].len() >= kw.len()
            && self.s[self.i..self.i + kw.len()].eq_ignore_ascii_case(kw.as_bytes())
    }

    fn unknown<T>(&self, what: &str) -> Result<T, Stop> {
        Err(Stop::Unknown(format!(
            "{what} in `{}`",
            String::from_utf8_lossy(self.s).trim()
        )))
    }

    fn binop(&self) -> Option<(&'static str, u8)> {
        let ops: &[(&'static str, u8)] = match self.dialect {
            Dialect::Fanuc | Dialect::Linuxcnc => &ISO_OPS,
            Dialect::Heidenhain => &HH_OPS,
            Dialect::Sinumerik => &SIN_OPS,
        };
        ops.iter().copied().find(|(op, _)| {
            if !self.starts(op) {
                return false;
            }
            // A word operator is not the start of a longer name on
            // SINUMERIK (`ORIGIN`); macro code glues them (`#1GT2`).
            let alpha = op.as_bytes()[0].is_ascii_alphabetic();
            !(alpha
                && self.dialect == Dialect::Sinumerik
                && self
                    .s
                    .get(self.i + op.len())
                    .is_some_and(|c| c.is_ascii_alphanumeric() || *c == b'_'))
        })
    }

    fn expr(&mut self, min_bp: u8) -> Result<f64, Stop> {
        self.depth += 1;
        if self.depth > MAX_EXPR_DEPTH {
            return Err(Stop::Alarm(format!(
                "expression nested deeper than {MAX_EXPR_DEPTH} levels"
            )));
        }
        let mut lhs = self.unary()?;
        loop {
            self.ws();
            let Some((op, bp)) = self.binop() else { break };
            if bp < min_bp {
                break;
            }
            self.i += op.len();
            // `**` and `^` bind to the right.
            let next = if bp == 6 { bp } else { bp + 1 };
            let rhs = self.expr(next)?;
            lhs = apply(op, lhs, rhs)?;
        }
        self.depth -= 1;
        Ok(lhs)
    }

    /// Signs and NOT before an operand, read in a loop (a long run of
    /// them must not deepen the stack) and applied innermost first.
    fn unary(&mut self) -> Result<f64, Stop> {
        let mut ops = Vec::new();
        loop {
            self.ws();
            match self.peek() {
                Some(b'-') => {
                    ops.push(b'-');
                    self.i += 1;
                }
                Some(b'+') => self.i += 1,
                _ if self.dialect == Dialect::Sinumerik && self.starts("NOT") => {
                    ops.push(b'!');
                    self.i += 3;
                }
                _ => break,
            }
        }
        let mut v = self.atom()?;
        for op in ops.iter().rev() {
            v = if *op == b'-' { -v } else { truth(v == 0.0) };
        }
        Ok(v)
    }

    fn atom(&mut self) -> Result<f64, Stop> {
        self.ws();
        let Some(c) = self.peek() else {
            return self.unknown("an operand is missing");
        };
        if c == self.open() {
            return self.group();
        }
        if c.is_ascii_digit() || c == b'.' {
            let rest = &self.s[self.i..];
            let scanned = match super::super::lexeme::scan(rest) {
                // Older TNCs write a decimal comma (`Q1 = 2,5`); a HEIDENHAIN
                // formula has no other use for a comma.
                Some((_, n))
                    if self.dialect == Dialect::Heidenhain
                        && rest.get(n) == Some(&b',')
                        && rest.get(n + 1).is_some_and(u8::is_ascii_digit) =>
                {
                    super::super::lexeme::scan_with(rest, b',')
                }
                found => found,
            };
            let Some((lx, n)) = scanned else {
                return self.unknown("a malformed number");
            };
            self.i += n;
            return Ok(lx.value);
        }
        if let Some(key) = self.param()? {
            return self.params.get(&key);
        }
        if c.is_ascii_alphabetic() || c == b'$' || c == b'_' {
            return self.function();
        }
        self.unknown("an unexpected character")
    }

    fn group(&mut self) -> Result<f64, Stop> {
        self.i += 1;
        let v = self.expr(0)?;
        self.ws();
        if self.peek() != Some(self.close()) {
            return self.unknown("an unclosed bracket");
        }
        self.i += 1;
        Ok(v)
    }

    /// A parameter reference at the cursor, if there is one.
    fn param(&mut self) -> Result<Option<Key>, Stop> {
        let s = self.s;
        match self.dialect {
            Dialect::Fanuc | Dialect::Linuxcnc => {
                if self.peek() != Some(b'#') {
                    return Ok(None);
                }
                self.i += 1;
                self.ws();
                match self.peek() {
                    Some(b'<') => {
                        let Some(p) = s[self.i..].iter().position(|&c| c == b'>') else {
                            return self.unknown("an unclosed #<name>");
                        };
                        let name: String = String::from_utf8_lossy(&s[self.i + 1..self.i + p])
                            .chars()
                            .filter(|c| !c.is_whitespace())
                            .collect::<String>()
                            .to_lowercase();
                        self.i += p + 1;
                        Ok(Some(Key::Name(name)))
                    }
                    Some(d) if d.is_ascii_digit() => {
                        let n = self.integer();
                        Ok(Some(Key::Num(n)))
                    }
                    Some(b'[') => {
                        let v = self.group()?;
                        Ok(Some(Key::Num(index(v)?)))
                    }
                    Some(b'#') => {
                        self.depth += 1;
                        if self.depth > MAX_EXPR_DEPTH {
                            return Err(Stop::Alarm(format!(
                                "parameter references chained deeper than {MAX_EXPR_DEPTH} levels"
                            )));
                        }
                        let k = self.param()?.expect("a # follows");
                        let v = self.params.get(&k)?;
                        Ok(Some(Key::Num(index(v)?)))
                    }
                    _ => self.unknown("a # without a parameter"),
                }
            }
            Dialect::Heidenhain => {
                if !matches!(self.peek(), Some(b'Q' | b'q')) {
                    return Ok(None);
                }
                let mut j = self.i + 1;
                let kind = s.get(j).map(u8::to_ascii_uppercase);
                let prefix = match kind {
                    Some(b'L') => "ql",
                    Some(b'R') => "qr",
                    Some(b'S') => return self.unknown("a string parameter (QS)"),
                    _ => "",
                };
                if !prefix.is_empty() {
                    j += 1;
                }
                let d0 = j;
                while j < s.len() && s[j].is_ascii_digit() {
                    j += 1;
                }
                if j == d0 {
                    return Ok(None);
                }
                let n: i64 = std::str::from_utf8(&s[d0..j])
                    .ok()
                    .and_then(|t| t.parse().ok())
                    .unwrap_or(i64::MAX);
                self.i = j;
                Ok(Some(if prefix.is_empty() {
                    Key::Num(n)
                } else {
                    Key::Name(format!("{prefix}{n}"))
                }))
            }
            Dialect::Sinumerik => {
                let c = self.peek();
                if matches!(c, Some(b'R' | b'r')) {
                    let next = s.get(self.i + 1).copied();
                    if next.is_some_and(|d| d.is_ascii_digit()) {
                        let mut j = self.i + 1;
                        while j < s.len() && s[j].is_ascii_digit() {
                            j += 1;
                        }
                        if !s
                            .get(j)
                            .is_some_and(|c| c.is_ascii_alphabetic() || *c == b'_')
                        {
                            self.i += 1;
                            return Ok(Some(Key::Num(self.integer())));
                        }
                    } else if next == Some(b'[') {
                        self.i += 2;
                        let v = self.expr(0)?;
                        self.ws();
                        if self.peek() != Some(b']') {
                            return self.unknown("an unclosed R[");
                        }
                        self.i += 1;
                        return Ok(Some(Key::Num(index(v)?)));
                    }
                }
                if !c.is_some_and(|c| c.is_ascii_alphabetic() || c == b'_') {
                    return Ok(None);
                }
                let mut j = self.i;
                while j < s.len() && (s[j].is_ascii_alphanumeric() || s[j] == b'_') {
                    j += 1;
                }
                // A name followed by `(` is a function.
                let mut k = j;
                while k < s.len() && matches!(s[k], b' ' | b'\t') {
                    k += 1;
                }
                if s.get(k) == Some(&b'(') || s.get(j) == Some(&b'[') {
                    return Ok(None);
                }
                let name = String::from_utf8_lossy(&s[self.i..j]).to_lowercase();
                if matches!(name.as_str(), "and" | "or" | "xor" | "not" | "div" | "mod") {
                    return Ok(None);
                }
                self.i = j;
                Ok(Some(Key::Name(name)))
            }
        }
    }

    fn integer(&mut self) -> i64 {
        let s = self.s;
        let d0 = self.i;
        while self.i < s.len() && s[self.i].is_ascii_digit() {
            self.i += 1;
        }
        std::str::from_utf8(&s[d0..self.i])
            .ok()
            .and_then(|t| t.parse().ok())
            .unwrap_or(i64::MAX)
    }

    fn function(&mut self) -> Result<f64, Stop> {
        let s = self.s;
        let start = self.i;
        while self.i < s.len() && (s[self.i].is_ascii_alphanumeric() || s[self.i] == b'_') {
            self.i += 1;
        }
        let name = String::from_utf8_lossy(&s[start..self.i]).to_ascii_uppercase();
        if self.dialect == Dialect::Heidenhain && name == "PI" {
            return Ok(std::f64::consts::PI);
        }
        self.ws();
        if self.peek() != Some(self.open()) {
            if self.dialect == Dialect::Heidenhain && heidenhain_function(&name) {
                // `Q4 = ABS Q22`, `Q2 = SQ 10 - 3^3`: a function without
                // brackets takes the operand right after it (HEIDENHAIN's
                // formula rules: the function is evaluated first).
                let a = self.unary()?;
                return self.apply_function(&name, a, None);
            }
            return self.unknown(&format!("`{name}` is not a value fivecal knows"));
        }
        // Arguments: one, or two separated by `,` (SINUMERIK ATAN2, FANUC
        // ATAN[a,b]) or written `[y]/[x]` (ATAN).
        self.i += 1;
        let a = self.expr(0)?;
        self.ws();
        let mut b = None;
        if self.peek() == Some(b',') {
            self.i += 1;
            b = Some(self.expr(0)?);
            self.ws();
        }
        if self.peek() != Some(self.close()) {
            return self.unknown("an unclosed function argument");
        }
        self.i += 1;
        if self.iso() && b.is_none() && (name == "ATAN" || name == "ATN") {
            let save = self.i;
            self.ws();
            if self.peek() == Some(b'/') {
                self.i += 1;
                self.ws();
                if self.peek() == Some(b'[') {
                    b = Some(self.group()?);
                } else {
                    self.i = save;
                }
            } else {
                self.i = save;
            }
        }
        self.apply_function(&name, a, b)
    }

    /// The function `name` of `a` (and `b`, for two-argument arc tangents).
    fn apply_function(&self, name: &str, a: f64, b: Option<f64>) -> Result<f64, Stop> {
        let deg = f64::to_radians;
        let alarm = |what: &str| Err(Stop::Alarm(format!("{name} of {what}")));
        let v = match (name, b) {
            ("SIN", None) => deg(a).sin(),
            ("COS", None) => deg(a).cos(),
            ("TAN", None) => deg(a).tan(),
            ("ASIN", None) if (-1.0..=1.0).contains(&a) => a.asin().to_degrees(),
            ("ACOS", None) if (-1.0..=1.0).contains(&a) => a.acos().to_degrees(),
            ("ASIN" | "ACOS", None) => return alarm("a value beyond [-1, 1]"),
            ("ATAN" | "ATN", None) => a.atan().to_degrees(),
            ("ATAN" | "ATN" | "ATAN2", Some(x)) => {
                let t = a.atan2(x).to_degrees();
                // FANUC and LinuxCNC give 0..360, SINUMERIK -180..180.
                if self.iso() && t < 0.0 { t + 360.0 } else { t }
            }
            ("SQRT" | "SQR", None) if a >= 0.0 => a.sqrt(),
            ("SQRT" | "SQR", None) => return alarm("a negative number"),
            ("SQ" | "POT", None) => a * a,
            ("ABS", None) => a.abs(),
            ("ROUND" | "RND", None) => a.round(),
            ("FIX" | "TRUNC", None) if self.iso() => a.floor(),
            ("TRUNC" | "INT", None) => a.trunc(),
            ("FUP", None) => a.ceil(),
            ("NEG", None) => -a,
            ("FRAC", None) => a.fract(),
            ("SGN", None) => a.signum() * truth(a != 0.0),
            ("LN", None) if a > 0.0 => a.ln(),
            ("LOG", None) if a > 0.0 => a.log10(),
            ("LN" | "LOG", None) => return alarm("a number not above zero"),
            ("EXP", None) => a.exp(),
            _ => return self.unknown(&format!("the function `{name}`")),
        };
        Ok(v)
    }
}

/// The one-operand functions of HEIDENHAIN's Q-parameter formulas,
/// written without brackets as readily as with them (`ABS Q22`).
fn heidenhain_function(name: &str) -> bool {
    matches!(
        name,
        "SIN"
            | "COS"
            | "TAN"
            | "ASIN"
            | "ACOS"
            | "ATAN"
            | "SQRT"
            | "SQ"
            | "ABS"
            | "INT"
            | "NEG"
            | "FRAC"
            | "SGN"
            | "LN"
            | "LOG"
            | "EXP"
    )
}

/// A parameter number from a value (indirect addressing rounds).
fn index(v: f64) -> Result<i64, Stop> {
    if v.is_finite() && v.abs() < 1e9 {
        Ok(v.round() as i64)
    } else {
        Err(Stop::Alarm(format!("{v} is not a parameter number")))
    }
}

fn apply(op: &str, a: f64, b: f64) -> Result<f64, Stop> {
    let eps = 1e-9;
    let v = match op {
        "**" | "^" => a.powf(b),
        "*" => a * b,
        "/" if b == 0.0 => return Err(Stop::Alarm("division by zero".into())),
        "/" => a / b,
        "DIV" if b == 0.0 => return Err(Stop::Alarm("division by zero".into())),
        "DIV" => (a / b).trunc(),
        "MOD" if b == 0.0 => return Err(Stop::Alarm("MOD by zero".into())),
        "MOD" => a - (a / b).floor() * b,
        "+" => a + b,
        "-" => a - b,
        "EQ" | "==" => truth((a - b).abs() < eps),
        "NE" | "<>" => truth((a - b).abs() >= eps),
        "GT" | ">" => truth(a > b),
        "GE" | ">=" => truth(a >= b),
        "LT" | "<" => truth(a < b),
        "LE" | "<=" => truth(a <= b),
        "AND" => truth(a != 0.0 && b != 0.0),
        "OR" => truth(a != 0.0 || b != 0.0),
        "XOR" => truth((a != 0.0) != (b != 0.0)),
        _ => unreachable!("operator {op} is in the tables"),
    };
    if v.is_finite() {
        Ok(v)
    } else {
        Err(Stop::Alarm(format!("{a} {op} {b} is not a finite number")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    struct P(HashMap<Key, f64>);
    impl Params for P {
        fn get(&self, key: &Key) -> Result<f64, Stop> {
            self.0
                .get(key)
                .copied()
                .ok_or_else(|| Stop::Unknown(format!("{key} unset")))
        }
    }

    fn ev(d: Dialect, s: &str) -> Result<f64, Stop> {
        let mut m = HashMap::new();
        m.insert(Key::Num(1), 30.0);
        m.insert(Key::Num(2), 4.0);
        m.insert(Key::Name("x".into()), 2.5);
        m.insert(Key::Name("ql3".into()), -1.0);
        eval(d, s.as_bytes(), &P(m))
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-12
    }

    #[test]
    fn macro_b_and_rs274ngc_arithmetic() {
        let f = Dialect::Fanuc;
        assert!(close(ev(f, "[#1+2]*#2").unwrap(), 128.0));
        assert!(close(ev(f, "SIN[#1]").unwrap(), 0.5));
        assert!(close(ev(f, "ATAN[1]/[-1]").unwrap(), 135.0));
        assert!(close(ev(f, "ATAN[-1]/[-1]").unwrap(), 225.0));
        assert!(close(ev(f, "FIX[-2.5]+FUP[2.1]").unwrap(), 0.0));
        assert!(close(ev(f, "#1GT29").unwrap(), 1.0));
        assert!(close(ev(f, "#[#2-3]").unwrap(), 30.0));
        assert!(close(ev(f, "2**3**2").unwrap(), 512.0));
        assert!(close(ev(f, "7 MOD 3 + 1").unwrap(), 2.0));
        assert!(close(ev(Dialect::Linuxcnc, "#<x> * -2").unwrap(), -5.0));
        assert!(close(
            ev(Dialect::Linuxcnc, "[#< X > LT 3] AND [1 EQ 1]").unwrap(),
            1.0
        ));
        assert!(matches!(ev(f, "#5001+1"), Err(Stop::Unknown(_))));
        assert!(matches!(ev(f, "1/[#1-30]"), Err(Stop::Alarm(_))));
    }

    #[test]
    fn q_formulas_and_sinumerik_expressions() {
        let h = Dialect::Heidenhain;
        assert!(close(ev(h, "+Q1 / 3 * SIN ( 90 )").unwrap(), 10.0));
        assert!(close(
            ev(h, "SQRT ( ( Q2 ^ 2 ) + ( 3 ^ 2 ) )").unwrap(),
            5.0
        ));
        assert!(close(ev(h, "- QL3").unwrap(), 1.0));
        let s = Dialect::Sinumerik;
        assert!(close(ev(s, "R1+2*R[1+1]").unwrap(), 38.0));
        assert!(close(ev(s, "ATAN2(1,-1)").unwrap(), 135.0));
        assert!(close(ev(s, "X*POT(2)").unwrap(), 10.0));
        assert!(close(ev(s, "7 DIV 2").unwrap(), 3.0));
        assert!(close(ev(s, "(R1>=30) AND NOT (R2==5)").unwrap(), 1.0));
        assert!(matches!(ev(s, "$AA_IM[X]"), Err(Stop::Unknown(_))));
        let deep = format!("{}1{}", "(".repeat(100), ")".repeat(100));
        assert!(ev(s, &deep).is_err());
        // 200,000 signs in a row do not overflow the stack.
        let signs = format!("{}1", "- ".repeat(200_000));
        assert!(close(ev(Dialect::Heidenhain, &signs).unwrap(), 1.0));
        assert!(close(ev(s, "NOT NOT -2").unwrap(), 1.0));
    }
}
