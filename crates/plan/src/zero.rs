//! Negative zero in outputs: arithmetic can give -0 (an empty sum, a speed of 0 in the CC
//! direction, a tiny negative rounded to a few decimals), which every output writes as 0.

/// `x` with -0 turned into 0; every other value (NaN included) unchanged.
pub fn unsigned_zero(x: f64) -> f64 {
    x + 0.0
}

/// A formatted number without the sign of a zero: "-0", "-0.00", "-0e0" become "0", "0.00", "0e0";
/// any other text is returned as it is.
pub fn without_zero_sign(text: String) -> String {
    match text.strip_prefix('-') {
        Some(rest) if is_zero(rest) => rest.to_string(),
        _ => text,
    }
}

/// Whether `text` is a number that equals zero: digits all 0, an optional fraction, an optional
/// exponent.
fn is_zero(text: &str) -> bool {
    let mantissa = text.split(['e', 'E']).next().unwrap_or_default();
    let mut digits = 0;
    for c in mantissa.chars() {
        match c {
            '0' => digits += 1,
            '.' => {}
            _ => return false,
        }
    }
    digits > 0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn negative_zero_loses_its_sign() {
        assert!(unsigned_zero(-0.0).is_sign_positive());
        assert_eq!(unsigned_zero(-1.5), -1.5);
        assert!(unsigned_zero(f64::NAN).is_nan());
        for (text, expected) in [
            ("-0", "0"),
            ("-0.00", "0.00"),
            ("-0.0", "0.0"),
            ("-0e0", "0e0"),
            ("-0.001", "-0.001"),
            ("-1", "-1"),
            ("-", "-"),
            ("-inf", "-inf"),
            ("0", "0"),
        ] {
            assert_eq!(without_zero_sign(text.to_string()), expected, "{text}");
        }
        assert_eq!(without_zero_sign(format!("{:.2}", -1e-9)), "0.00");
    }
}
