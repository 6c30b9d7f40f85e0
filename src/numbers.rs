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

/// `n` and the word that counts it: `1 move`, `3 moves` (`plural` for
/// the few words that do not take an `s`).
pub fn count(n: usize, singular: &str, plural: &str) -> String {
    if n == 1 {
        format!("1 {singular}")
    } else {
        format!("{n} {plural}")
    }
}

/// A p-value as a verdict prints it: two significant figures, and below
/// what a double holds (an underflow to 0) `< 1e-300` rather than
/// `0.0e0`, which would claim an impossible certainty.
pub fn p_value(p: f64) -> String {
    if !p.is_finite() {
        "not computable".to_string()
    } else if p < 1e-300 {
        "< 1e-300".to_string()
    } else {
        format!("= {p:.1e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_p_values_read_as_words() {
        assert_eq!(count(1, "move", "moves"), "1 move");
        assert_eq!(count(0, "move", "moves"), "0 moves");
        assert_eq!(count(12, "record", "records"), "12 records");
        assert_eq!(p_value(0.0), "< 1e-300");
        assert_eq!(p_value(3.2e-25), "= 3.2e-25");
        assert_eq!(p_value(0.5), "= 5.0e-1");
        assert_eq!(p_value(f64::NAN), "not computable");
    }
}
