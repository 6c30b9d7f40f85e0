//! Numeric lexemes as controllers write them, read exactly and rewritten in
//! the same style.
//!
//! A rewritten coordinate must look like its neighbours: `X.5` stays without
//! a leading zero, HEIDENHAIN keeps its explicit `+`, a fixed-width post
//! (`X10.000`) keeps its trailing zeros, and on FANUC a value always keeps
//! its decimal point, since `X1` may mean 1 um there (decimal point input
//! type I) while `X1.` always means 1 mm. Formatting goes through an integer
//! at the output resolution, so it is exact and allocation-free.

/// How a numeric lexeme was written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct NumStyle {
    /// Written with an explicit `+` for positive values.
    pub plus: bool,
    /// Written with a decimal point (`1.`, `1.5`, `.5`).
    pub point: bool,
    /// Digits after the decimal point.
    pub decimals: u8,
    /// Written without the leading zero (`.5`, `-.5`).
    pub no_leading_zero: bool,
    /// Ends in a zero after the decimal point (`1.500`): a fixed-width post.
    pub trailing_zeros: bool,
    /// Written with a decimal comma (`+32,000`, older HEIDENHAIN controls).
    pub comma: bool,
}

/// A lexed number: its value and style.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Lexeme {
    /// The value.
    pub value: f64,
    /// The style.
    pub style: NumStyle,
}

const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// "00" to "99".
const PAIRS: &[u8; 200] = b"0001020304050607080910111213141516171819\
2021222324252627282930313233343536373839\
4041424344454647484950515253545556575859\
6061626364656667686970717273747576777879\
8081828384858687888990919293949596979899";

/// `10^d` for `d` up to 22 (exact), else `powi`.
pub(crate) fn pow10(d: u8) -> f64 {
    POW10
        .get(d as usize)
        .copied()
        .unwrap_or_else(|| 10f64.powi(d as i32))
}

/// Half a unit of the last of `d` decimals.
pub(crate) fn half_unit(d: u8) -> f64 {
    0.5 / pow10(d)
}

/// `v` rounded to `d` decimals.
pub(crate) fn round_to(v: f64, d: u8) -> f64 {
    let k = pow10(d);
    let x = v * k;
    // A cast rounds without a libm call on baseline x86-64.
    if x.abs() < 4.0e15 {
        let r = (x + 0.5f64.copysign(x)) as i64 as f64;
        r / k
    } else {
        x.round() / k
    }
}

/// Length of the numeric lexeme at the start of `s` (`[+-]? (d+ (. d*)? | . d+)`),
/// or 0 when there is none. Spaces are not allowed inside.
pub(crate) fn lex_len(s: &[u8]) -> usize {
    let mut i = 0;
    if i < s.len() && (s[i] == b'+' || s[i] == b'-') {
        i += 1;
    }
    let d0 = i;
    while i < s.len() && s[i].is_ascii_digit() {
        i += 1;
    }
    let int_digits = i - d0;
    if i < s.len() && s[i] == b'.' {
        let f0 = i + 1;
        let mut j = f0;
        while j < s.len() && s[j].is_ascii_digit() {
            j += 1;
        }
        if int_digits == 0 && j == f0 {
            return 0;
        }
        return j;
    }
    if int_digits == 0 { 0 } else { i }
}

/// Lexes and reads the number at the start of `s` in one pass: the lexeme
/// and its length, or `None` (the same acceptance as `lex_len`).
pub(crate) fn scan(s: &[u8]) -> Option<(Lexeme, usize)> {
    scan_with(s, b'.')
}

/// As [`scan`], with `sep` as the decimal separator (`.` or `,`).
pub(crate) fn scan_with(s: &[u8], sep: u8) -> Option<(Lexeme, usize)> {
    let mut style = NumStyle::default();
    let mut i = 0;
    let mut neg = false;
    match s.first() {
        Some(b'+') => {
            style.plus = true;
            i = 1;
        }
        Some(b'-') => {
            neg = true;
            i = 1;
        }
        _ => {}
    }
    let sign = i;
    let mut mant: u64 = 0;
    let d0 = i;
    while i < s.len() && s[i].is_ascii_digit() {
        mant = mant.wrapping_mul(10).wrapping_add((s[i] - b'0') as u64);
        i += 1;
    }
    let int_digits = i - d0;
    let mut dec = 0usize;
    if i < s.len() && s[i] == sep {
        let f0 = i + 1;
        let mut j = f0;
        while j < s.len() && s[j].is_ascii_digit() {
            mant = mant.wrapping_mul(10).wrapping_add((s[j] - b'0') as u64);
            j += 1;
        }
        dec = j - f0;
        if int_digits == 0 && dec == 0 {
            return None;
        }
        style.point = true;
        style.comma = sep == b',';
        style.trailing_zeros = dec > 0 && s[j - 1] == b'0';
        i = j;
    } else if int_digits == 0 {
        return None;
    }
    style.no_leading_zero = int_digits == 0;
    style.decimals = dec.min(255) as u8;
    let value = if int_digits + dec <= 15 && dec < POW10.len() {
        mant as f64 / POW10[dec]
    } else {
        // Long lexemes (rare): the standard library's correctly rounded
        // parser; a value beyond f64 reads as infinite and is refused by
        // the tokenizers.
        String::from_utf8_lossy(&s[sign..i])
            .replace(',', ".")
            .parse::<f64>()
            .unwrap_or(f64::NAN)
    };
    Some((
        Lexeme {
            value: if neg { -value } else { value },
            style,
        },
        i,
    ))
}

/// Reads a numeric lexeme that `lex_len` accepted in full.
pub(crate) fn read(s: &[u8]) -> Lexeme {
    let mut style = NumStyle::default();
    let mut i = 0;
    let mut neg = false;
    if let Some(&c) = s.first() {
        if c == b'+' {
            style.plus = true;
            i = 1;
        } else if c == b'-' {
            neg = true;
            i = 1;
        }
    }
    let mut mant: u64 = 0;
    let mut digits = 0usize;
    let mut int_digits = 0;
    while i < s.len() && s[i].is_ascii_digit() {
        mant = mant.wrapping_mul(10).wrapping_add((s[i] - b'0') as u64);
        digits += 1;
        int_digits += 1;
        i += 1;
    }
    let mut dec = 0usize;
    if i < s.len() && s[i] == b'.' {
        style.point = true;
        i += 1;
        while i < s.len() && s[i].is_ascii_digit() {
            mant = mant.wrapping_mul(10).wrapping_add((s[i] - b'0') as u64);
            digits += 1;
            dec += 1;
            i += 1;
        }
        style.trailing_zeros = dec > 0 && s[i - 1] == b'0';
    }
    style.no_leading_zero = int_digits == 0;
    style.decimals = dec.min(255) as u8;
    // An integer below 2^53 divided by an exact power of ten is correctly
    // rounded (one IEEE operation on exact operands); otherwise use the
    // standard library's parser.
    let value = if digits <= 15 && dec < POW10.len() {
        mant as f64 / POW10[dec]
    } else {
        std::str::from_utf8(&s[usize::from(style.plus || neg)..])
            .ok()
            .and_then(|t| t.parse::<f64>().ok())
            .unwrap_or(f64::NAN)
    };
    Lexeme {
        value: if neg { -value } else { value },
        style,
    }
}

/// Dialect rules for writing a rewritten value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct WriteRules {
    /// Always write a decimal point (FANUC: an integer may be read in
    /// least-input increments).
    pub force_point: bool,
    /// Always write an explicit sign (HEIDENHAIN).
    pub force_plus: bool,
}

/// Writes `value` rounded to `decimals` digits in the style of `like`,
/// appending to `out`. Trailing zeros are kept only when `like` had them.
pub(crate) fn write(
    out: &mut Vec<u8>,
    value: f64,
    decimals: u8,
    like: &NumStyle,
    rules: WriteRules,
) {
    let d = decimals.min(15) as usize;
    let x = value.abs() * POW10[d];
    if x.is_nan() || x >= 4.0e15 {
        // Out of any controller's range: plain formatting.
        out.extend_from_slice(format!("{value:.d$}").as_bytes());
        return;
    }
    // Round by a cast (no libm call), through i64 (native conversion).
    let n = (x + 0.5) as i64 as u64;
    let negative = value < 0.0 && n != 0;
    if negative {
        out.push(b'-');
    } else if like.plus || rules.force_plus {
        out.push(b'+');
    }
    // All digits at once, at least d + 1 of them (`0.0012`), then split:
    // two digits per division by the constant 100.
    let mut buf = [b'0'; 24];
    let mut i = buf.len();
    let mut m = n;
    while m >= 100 {
        let k = (m % 100) as usize * 2;
        m /= 100;
        i -= 2;
        buf[i..i + 2].copy_from_slice(&PAIRS[k..k + 2]);
    }
    if m >= 10 {
        let k = m as usize * 2;
        i -= 2;
        buf[i..i + 2].copy_from_slice(&PAIRS[k..k + 2]);
    } else {
        i -= 1;
        buf[i] = b'0' + m as u8;
    }
    // Leading zeros up to d + 1 digits (the buffer is zero-filled).
    i = i.min(buf.len() - (d + 1));
    let digits = &buf[i..];
    let (int, frac) = digits.split_at(digits.len() - d);
    let mut keep = d;
    if !like.trailing_zeros {
        while keep > 0 && frac[keep - 1] == b'0' {
            keep -= 1;
        }
    }
    let int_zero = int == b"0";
    if !int_zero || !like.no_leading_zero || keep == 0 {
        out.extend_from_slice(int);
    }
    let point = if like.comma { b',' } else { b'.' };
    if keep > 0 {
        out.push(point);
        out.extend_from_slice(&frac[..keep]);
    } else if rules.force_point || (like.point && like.decimals == 0) {
        // `X1.` stays `X2.`; `X1.5` becoming whole is written `X2`.
        out.push(point);
    }
}

/// Appends the decimal digits of `n`.
pub(crate) fn push_u64(out: &mut Vec<u8>, mut n: u64) {
    let mut buf = [0u8; 20];
    let mut i = buf.len();
    loop {
        i -= 1;
        buf[i] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    out.extend_from_slice(&buf[i..]);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lex(s: &str) -> Lexeme {
        assert_eq!(lex_len(s.as_bytes()), s.len(), "{s}");
        read(s.as_bytes())
    }

    fn fmt(v: f64, d: u8, like: &str, rules: WriteRules) -> String {
        let mut out = Vec::new();
        write(&mut out, v, d, &lex(like).style, rules);
        String::from_utf8(out).unwrap()
    }

    const ISO: WriteRules = WriteRules {
        force_point: false,
        force_plus: false,
    };
    const FANUC: WriteRules = WriteRules {
        force_point: true,
        force_plus: false,
    };
    const HH: WriteRules = WriteRules {
        force_point: false,
        force_plus: true,
    };

    #[test]
    fn reads_every_form_controllers_write() {
        assert_eq!(lex("1.").value, 1.0);
        assert!(lex("1.").style.point);
        assert_eq!(lex(".5").value, 0.5);
        assert!(lex(".5").style.no_leading_zero);
        assert_eq!(lex("-.5").value, -0.5);
        assert_eq!(lex("+10.250").value, 10.25);
        assert!(lex("+10.250").style.trailing_zeros && lex("+10.250").style.plus);
        assert_eq!(lex("123").value, 123.0);
        assert!(!lex("123").style.point);
        assert_eq!(lex("0.1").value, 0.1);
        assert_eq!(lex("-12.3456789012345678").value, -12.345_678_901_234_568);
        assert_eq!(lex_len(b"."), 0);
        assert_eq!(lex_len(b"-"), 0);
        assert_eq!(lex_len(b"1.2.3"), 3);
        assert_eq!(lex_len(b"12X"), 2);
    }

    #[test]
    fn one_pass_scan_agrees_with_lex_and_read() {
        for s in [
            "1.",
            ".5",
            "-.5",
            "+10.250",
            "123",
            "0.1",
            "-12.3456789012345678",
            ".",
            "-",
            "1.2.3",
            "12X",
            "+Q1",
        ] {
            let b = s.as_bytes();
            let n = lex_len(b);
            match scan(b) {
                Some((lx, len)) => {
                    assert_eq!(len, n, "{s}");
                    assert_eq!(lx, read(&b[..n]), "{s}");
                }
                None => assert_eq!(n, 0, "{s}"),
            }
        }
    }

    #[test]
    fn written_values_read_back_within_half_a_unit() {
        let fixed = lex("1.000").style;
        let mut x = 0.123_456_789f64;
        for k in 0..20_000 {
            // A deterministic spread of magnitudes and signs.
            x = (x * 7919.0 + 0.618_033_988_7).fract();
            let v = (x - 0.5) * 10f64.powi(k % 7 - 1);
            for d in [0u8, 1, 3, 4, 6, 9] {
                let mut out = Vec::new();
                write(&mut out, v, d, &fixed, ISO);
                let s = String::from_utf8(out).unwrap();
                let back: f64 = s.parse().unwrap_or_else(|_| panic!("{s}"));
                assert!(
                    (back - v).abs() <= 0.5 / pow10(d) + v.abs() * 2e-15 + 1e-15,
                    "{v} with {d}: {s}"
                );
                let frac = s.split('.').nth(1).unwrap_or("");
                assert_eq!(frac.len(), d as usize, "{v} with {d}: {s}");
            }
        }
    }

    #[test]
    fn exact_decimal_reading_matches_the_standard_parser() {
        for s in ["0.3", "-123.4567", "99999.99999", "0.0001", "7.", "250.125"] {
            assert_eq!(lex(s).value, s.parse::<f64>().unwrap(), "{s}");
        }
    }

    #[test]
    fn writes_in_the_style_of_the_original() {
        assert_eq!(fmt(10.00234, 4, "10.", FANUC), "10.0023");
        assert_eq!(fmt(10.0, 4, "10.", FANUC), "10.");
        assert_eq!(fmt(10.0, 4, "10", FANUC), "10.");
        assert_eq!(fmt(10.0, 4, "10", ISO), "10");
        assert_eq!(fmt(0.25, 4, ".5", ISO), ".25");
        assert_eq!(fmt(-0.25, 4, "-.5", ISO), "-.25");
        assert_eq!(fmt(-0.25, 4, "0.5", ISO), "-0.25");
        assert_eq!(fmt(10.5, 4, "10.000", ISO), "10.5000");
        assert_eq!(fmt(3.0, 3, "+1", HH), "+3");
        assert_eq!(fmt(-0.00001, 3, "+1.5", HH), "+0");
        assert_eq!(fmt(-2.5, 3, "+1.5", HH), "-2.5");
        assert_eq!(fmt(0.0, 4, ".5", ISO), "0");
        assert_eq!(fmt(2.0, 4, "1.", ISO), "2.");
        assert_eq!(fmt(0.0, 4, "5", ISO), "0");
        assert_eq!(fmt(0.0, 4, ".5", FANUC), "0.");
    }
}
