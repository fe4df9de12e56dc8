//! One cell's number: the exact fast decimal parse, the general parse with worded errors, and
//! the shortest rendering that reads back to the same bits.

use std::fmt::Write as _;

/// Parses one cell as a finite decimal number (surrounding ASCII whitespace allowed).
pub(super) fn parse_cell(cell: &[u8]) -> Result<f64, String> {
    if let Some(v) = fast_f64(cell) {
        return Ok(v);
    }
    let s = cell.trim_ascii();
    if s.is_empty() {
        return Err("empty cell: expected a number".to_owned());
    }
    let v = std::str::from_utf8(s)
        .ok()
        .and_then(|s| s.parse::<f64>().ok())
        .ok_or_else(|| format!("not a number: {:?}", shorten(&String::from_utf8_lossy(s))))?;
    if v.is_nan() {
        Err(format!(
            "{:?} is not allowed: expected a finite number",
            String::from_utf8_lossy(s)
        ))
    } else if v.is_infinite() {
        Err(format!(
            "infinite value {:?}: expected a finite number",
            shorten(&String::from_utf8_lossy(s))
        ))
    } else {
        Ok(v)
    }
}

/// The exact fast path (Eisel-Lemire, Clinger for short decimals) for a cell that is a finite
/// decimal and nothing else: the correctly rounded value, so exactly what `str::parse` returns.
/// `None` for anything else (`inf`, `nan`, whitespace, junk); the caller then goes through
/// `str::parse`, which also words the errors.
#[inline]
fn fast_f64(s: &[u8]) -> Option<f64> {
    match fast_f64_prefix(s) {
        Some((v, len)) if len == s.len() => Some(v),
        _ => None,
    }
}

/// [`fast_f64`] on the longest prefix of `s` that is a decimal number; returns the value and
/// the prefix length, `None` when there is none or it is not finite.
#[inline(always)]
pub(super) fn fast_f64_prefix(s: &[u8]) -> Option<(f64, usize)> {
    if let Some(hit) = short_decimal_prefix(s) {
        return Some(hit);
    }
    match fast_float2::parse_partial::<f64, _>(s) {
        Ok((v, len)) if v.is_finite() => Some((v, len)),
        _ => None,
    }
}

/// Exact powers of ten up to `1e22` (the largest a double holds exactly).
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// The cells of a typical record, `-?digits(.digits)?` with at most 19 digits, a significand
/// of at most 2^53 and at most 22 decimals, parsed without the general machinery: the digits
/// as an integer `m`, the value `m / 10^d`, both exact doubles, so one correctly rounded
/// division gives the correctly rounded value (Clinger's fast path), the bits `str::parse`
/// gives. Anything else (an exponent, a leading `+` or `.`, a trailing `.`, more digits) is
/// `None` and goes to `fast-float2`, which takes every decimal.
#[inline(always)]
fn short_decimal_prefix(s: &[u8]) -> Option<(f64, usize)> {
    let neg = s.first() == Some(&b'-');
    let mut i = neg as usize;
    let mut m: u64 = 0;
    let int_start = i;
    i = push_digits(s, i, &mut m);
    let int_digits = i - int_start;
    let mut decimals = 0;
    if s.get(i) == Some(&b'.') {
        i += 1;
        let frac_start = i;
        i = push_digits(s, i, &mut m);
        decimals = i - frac_start;
        if decimals == 0 {
            return None;
        }
    }
    if int_digits == 0
        || int_digits + decimals > 19
        || decimals > 22
        || m > 1 << 53
        || matches!(s.get(i), Some(b'e' | b'E'))
    {
        return None;
    }
    let v = m as f64 / POW10[decimals];
    Some((if neg { -v } else { v }, i))
}

/// Appends the ASCII digits from `s[i]` on to `m` (wrapping: the caller bounds the count);
/// returns where they end.
#[inline(always)]
fn push_digits(s: &[u8], mut i: usize, m: &mut u64) -> usize {
    while let Some(&b) = s.get(i) {
        let d = b.wrapping_sub(b'0');
        if d > 9 {
            break;
        }
        *m = m.wrapping_mul(10).wrapping_add(d as u64);
        i += 1;
    }
    i
}

fn shorten(s: &str) -> String {
    if s.chars().count() > 40 {
        let cut: String = s.chars().take(37).collect();
        format!("{cut}...")
    } else {
        s.to_owned()
    }
}

/// Appends `v` in a shortest form that parses back to the same bits.
pub(crate) fn push_f64(buf: &mut String, v: f64) {
    let a = v.abs();
    if a == 0.0 || (1e-5..1e16).contains(&a) {
        let _ = write!(buf, "{v}");
    } else {
        let _ = write!(buf, "{v:e}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_path_agrees_with_std() {
        for s in [
            "0",
            "-0",
            "+0",
            "0.0",
            "-0.0",
            "1",
            "1.",
            ".5",
            "-.5",
            "+1.25",
            "0.003112",
            "12345678",
            "9007199254740992",
            "9007199254740993",
            "1e22",
            "1e23",
            "1e-22",
            "4e-3",
            "4E+3",
            "1e",
            "1e+",
            "-",
            ".",
            "",
            "e5",
            "1.2.3",
            "1,5",
            "inf",
            "NaN",
            " 1",
            "1 ",
            "0.1",
            "0.2",
            "0.30000000000000004",
            "123456789012345678901",
            "1e-0005",
            "00000000000000000001",
            "5.0200000000000005",
            "-0.000064421",
            "1e400",
            "1e-400",
            "infinity",
            "0x10",
        ] {
            // Taken exactly when std reads a finite number, and then the same bits.
            let std = s.parse::<f64>().ok().filter(|v| v.is_finite());
            let fast = fast_f64(s.as_bytes());
            assert_eq!(fast.map(f64::to_bits), std.map(f64::to_bits), "{s:?}");
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(4096))]

        #[test]
        fn fast_path_agrees_with_std_on_random_decimals(s in "[-+]?[0-9]{0,20}(\\.[0-9]{0,20})?([eE][-+]?[0-9]{0,4})?") {
            let std = s.parse::<f64>().ok().filter(|v| v.is_finite());
            let fast = fast_f64(s.as_bytes());
            proptest::prop_assert_eq!(fast.map(f64::to_bits), std.map(f64::to_bits), "{:?}", s);
        }

        /// The prefix parse as the record parser calls it, with the rest of the file after
        /// the number: the bits `std` reads from the number alone, and the number's length.
        #[test]
        fn prefix_parse_agrees_with_std_before_more_text(
            s in "-?[0-9]{1,20}(\\.[0-9]{1,20})?",
            rest in "[,\n0-9.e-]{0,12}",
        ) {
            let std = s.parse::<f64>().ok().filter(|v| v.is_finite());
            let mut text = s.clone();
            text.push(',');
            text.push_str(&rest);
            let got = fast_f64_prefix(text.as_bytes());
            proptest::prop_assert_eq!(got.map(|(v, len)| (v.to_bits(), len)), std.map(|v| (v.to_bits(), s.len())), "{:?}", text);
        }

        #[test]
        fn fast_path_agrees_with_std_on_written_values(bits in proptest::prelude::any::<u64>()) {
            let v = f64::from_bits(bits);
            if v.is_finite() {
                let mut s = String::new();
                push_f64(&mut s, v);
                let got = parse_cell(s.as_bytes()).unwrap();
                proptest::prop_assert_eq!(got.to_bits(), v.to_bits(), "{}", s);
            }
        }
    }

    #[test]
    fn floats_round_trip() {
        for v in [
            0.0,
            -0.0,
            1.0,
            0.1,
            1e-5,
            9.99e-6,
            1e16,
            1e300,
            -5e-324,
            f64::MAX,
            f64::MIN_POSITIVE,
            123456.789,
        ] {
            let mut s = String::new();
            push_f64(&mut s, v);
            assert_eq!(s.parse::<f64>().unwrap().to_bits(), v.to_bits(), "{s}");
        }
    }
}
