//! Unit tests of [`super`]: reals, times and Ids in every notation, the
//! fast paths against core's parser.
#![allow(clippy::excessive_precision)] // the robot writes such texts

use super::*;
use crate::value::Time;
extern crate std;
use std::format;
use std::string::String;

#[test]
fn m5_reals_parse_in_any_decimal_notation() {
    assert_eq!(parse_f32(b"1620.0"), Ok(1620.0));
    assert_eq!(parse_f32(b" -12345.678901\n"), Ok(-12345.678901));
    assert_eq!(parse_f32(b"1.21592e-06"), Ok(1.21592e-06));
    assert_eq!(parse_f32(b"+.5E+1"), Ok(5.0));
    assert_eq!(parse_f32(b"7."), Ok(7.0));
    assert_eq!(parse_f32(b"1e39"), Err(NumberError::OutOfRange));
    for bad in [
        &b""[..],
        b" ",
        b"abc",
        b"1.2.3",
        b"inf",
        b"NaN",
        b"0x10",
        b"1e",
        b"--1",
        b"1 2",
        b".",
    ] {
        assert_eq!(
            parse_f32(bad),
            Err(NumberError::Syntax),
            "{:?}",
            core::str::from_utf8(bad)
        );
    }
}

#[test]
fn m5_fast_paths_round_exactly_like_core() {
    // core's parser is the oracle: correctly rounded. Texts of every
    // shape the fast paths take or refuse.
    let mut next = crate::codec::xorshift64(0x9E37_79B9_7F4A_7C15);
    for _ in 0..300_000 {
        let r = next();
        let digits = 1 + (r % 20) as usize;
        let mut text = String::new();
        if r & 1 << 20 != 0 {
            text.push('-');
        }
        let mut m = next();
        for i in 0..digits {
            if i == (r >> 24) as usize % (digits + 1) {
                text.push('.');
            }
            text.push((b'0' + (m % 10) as u8) as char);
            m /= 10;
        }
        if r & 1 << 21 != 0 {
            let e = (r >> 32) as i32 % 45;
            text.push_str(&format!("e{e}"));
        }
        let want = text.parse::<f32>().ok().filter(|v| v.is_finite());
        let got = parse_f32(text.as_bytes()).ok();
        assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits), "{text}");
    }
    // Values printed by core (shortest round-trip) read back exactly.
    let mut next = crate::codec::xorshift32(1);
    for _ in 0..200_000 {
        let v = f32::from_bits(next());
        if v.is_finite() {
            for text in [format!("{v}"), format!("{v:e}"), format!("{v:.6}")] {
                let want: f32 = text.parse().unwrap();
                assert_eq!(
                    parse_f32(text.as_bytes()).map(f32::to_bits),
                    Ok(want.to_bits()),
                    "{text}"
                );
            }
        }
    }
}

#[test]
fn m5_times_parse_exactly_in_any_notation() {
    let t = |s: &[u8]| parse_time(s).map(Time::as_micros);
    assert_eq!(t(b"86400.123"), Ok(86_400_123_000));
    assert_eq!(t(b"765.315969"), Ok(765_315_969));
    assert_eq!(t(b" 1.200 "), Ok(1_200_000));
    assert_eq!(t(b"-0.5"), Ok(-500_000));
    assert_eq!(t(b"1.5e-3"), Ok(1_500));
    assert_eq!(t(b"2E3"), Ok(2_000_000_000));
    assert_eq!(t(b"0.0000005"), Ok(1), "half a µs rounds away from zero");
    assert_eq!(t(b"0.00000049"), Ok(0));
    assert_eq!(t(b"-0.0000005"), Ok(-1));
    assert_eq!(t(b"12345678901234567890123"), Err(NumberError::OutOfRange));
    assert_eq!(t(b"1e300"), Err(NumberError::OutOfRange));
    assert_eq!(t(b"1e-300"), Ok(0));
    assert_eq!(t(b"9223372036854.775807"), Ok(i64::MAX));
    assert_eq!(t(b"9223372036854.775808"), Err(NumberError::OutOfRange));
    // The least time fits (its magnitude does not, as a positive i64):
    // exactness list of issue 36.
    assert_eq!(t(b"-9223372036854.775808"), Ok(i64::MIN));
    assert_eq!(t(b"-9223372036854.775807"), Ok(i64::MIN + 1));
    assert_eq!(t(b"-9223372036854.775809"), Err(NumberError::OutOfRange));
    assert_eq!(
        t(b"-9223372036854.7758075"),
        Ok(i64::MIN),
        "rounds half away from zero"
    );
    assert_eq!(t(b"-9223372036854.7758085"), Err(NumberError::OutOfRange));
    assert_eq!(t(b"x"), Err(NumberError::Syntax));
    assert_eq!(t(b"inf"), Err(NumberError::Syntax));
}

#[test]
fn number_errors_display_a_lowercase_message_citing_m5() {
    assert_eq!(NumberError::Syntax.to_string(), "not a decimal number (M5)");
    assert_eq!(
        NumberError::OutOfRange.to_string(),
        "number beyond the range of its type (M5)"
    );
    assert_eq!(
        NumberError::TooLong.to_string(),
        "number text too long to read (M5)"
    );
    let e: &dyn core::error::Error = &NumberError::Syntax;
    assert!(e.source().is_none());
}

#[test]
fn s3_ids_are_u32() {
    assert_eq!(parse_u32(b"111"), Ok(111));
    assert_eq!(parse_u32(b" 4294967295 "), Ok(u32::MAX));
    assert_eq!(parse_u32(b"4294967296"), Err(NumberError::OutOfRange));
    assert_eq!(parse_u32(b"-1"), Err(NumberError::Syntax));
    assert_eq!(parse_u32(b"1.0"), Err(NumberError::Syntax));
    assert_eq!(parse_u32(b""), Err(NumberError::Syntax));
}

#[test]
fn m5_the_plain_path_agrees_with_the_whole_scanner() {
    // Texts the plain path takes (sign, up to 19 digits, a point) and
    // some it hands on (whitespace, exponent, 20 digits): both paths
    // give the same bits, or the same error.
    let mut next = crate::codec::xorshift64(0x2545_F491_4F6C_DD1D);
    for _ in 0..100_000 {
        let x = next();
        let digits = 1 + (x % 20) as usize;
        let mut text = String::new();
        match (x >> 8) % 4 {
            0 => text.push('-'),
            1 => text.push('+'),
            _ => {}
        }
        let point = (x >> 16) as usize % (digits + 1);
        let mut m = x >> 24;
        for i in 0..digits {
            if i == point {
                text.push('.');
            }
            text.push((b'0' + (m % 10) as u8) as char);
            m /= 10;
        }
        let plain = parse_f32(text.as_bytes()).map(f32::to_bits);
        let general = parse_f32_general(text.as_bytes()).map(f32::to_bits);
        assert_eq!(plain, general, "{text}");
    }
    for text in [
        &b"1620.000"[..],
        b" 1620.000",
        b"1.62e3",
        b"-0",
        b"+.5",
        b"7.",
        b".",
        b"-",
        b"",
        b"-.",
        b"1.2.3",
        b"--1",
        b"1-",
        b"1.-2",
        b"12345678901234567890",
        b"1234567890.1234567890",
    ] {
        assert_eq!(parse_f32(text), parse_f32_general(text));
    }
}

/// The four-at-a-time digit count agrees with a byte-at-a-time one for
/// every byte in every place of a word, after digits and before them (a
/// byte that carries when 6 is added, `0xfa`..`0xff`, among them).
#[test]
fn m5_digit_count_four_at_a_time_is_exact() {
    let bytewise = |s: &[u8]| s.iter().take_while(|b| b.is_ascii_digit()).count();
    for b in 0..=255u8 {
        for at in 0..9 {
            let mut text = *b"123456789";
            text[at] = b;
            assert_eq!(digit_count(&text), bytewise(&text), "{b:#x} at {at}");
            assert_eq!(digit_count(&text[..at + 1]), bytewise(&text[..at + 1]));
        }
    }
    assert_eq!(digit_count(b""), 0);
    assert_eq!(
        digit_count(b"0123456789012345678901234567890123456789.5"),
        40
    );
}
