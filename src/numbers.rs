//! Numbers as text: how a message echoes a value, and a fixed-decimals
//! writer that never prints a negative zero. Every layer writes numbers,
//! so these stand at the bottom with reading and writing.

/// A number as a message echoes it: `1e300` and `1e-9`, not three hundred
/// digits.
pub(crate) fn echo(v: f64) -> String {
    if v.is_finite() && v != 0.0 && !(1e-6..1e9).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// Writes a number without a negative zero, with `decimals` places.
pub(crate) fn fmt_num(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    if s.starts_with('-') && s[1..].bytes().all(|b| b == b'0' || b == b'.') {
        s[1..].to_string()
    } else {
        s
    }
}
