//! Unit tests of [`super`]: numbers and times written as the robot reads
//! them, exactly.
#![allow(clippy::excessive_precision)] // the robot writes such texts

use super::*;
extern crate std;
use std::format;
use std::string::String;

fn real(x: f32, d: u8) -> String {
    let mut buf = [0u8; 64];
    let mut w = Writer::new(&mut buf);
    w.real(x, d);
    String::from_utf8(w.written().to_vec()).unwrap()
}

#[test]
fn digit_count_is_exact_at_every_power_of_ten() {
    assert_eq!(digit_count(0), 1);
    assert_eq!(digit_count(u64::MAX), 20);
    let mut p = 1u64;
    for n in 1..=19 {
        assert_eq!(digit_count(p), n, "10^{}", n - 1);
        assert_eq!(
            digit_count(p - 1).max(1),
            (n - 1).max(1),
            "10^{} - 1",
            n - 1
        );
        assert_eq!(digit_count(p * 10 - 1), n, "10^{n} - 1");
        p *= 10;
    }
}

fn time(micros: i64, d: u8) -> String {
    let mut buf = [0u8; 64];
    let mut w = Writer::new(&mut buf);
    w.time(Time::from_micros(micros), d);
    String::from_utf8(w.written().to_vec()).unwrap()
}

#[test]
fn m5_reals_have_fixed_decimals_and_no_exponent() {
    assert_eq!(real(232.661, 3), "232.661");
    assert_eq!(real(1620.293, 3), "1620.293");
    assert_eq!(real(0.0, 3), "0.000");
    assert_eq!(real(1.21592e-06, 3), "0.000");
    assert_eq!(real(-12345.678901, 3), "-12345.679");
    assert_eq!(real(1.5, 0), "2");
    assert_eq!(real(2.5, 0), "2");
    assert_eq!(real(1e20, 3), "100000002004087734272.000");
    assert_eq!(real(f32::MAX, 3).len(), 39 + 4);
    assert_eq!(real(f32::MIN, 3).len(), 1 + 39 + 4);
    assert_eq!(real(-0.0, 3), "0.000");
    assert_eq!(real(-0.0001, 3), "0.000");
    assert_eq!(real(f32::from_bits(1), 6), "0.000000");
}

#[test]
fn m5_non_finite_is_written_as_zero_and_reported() {
    let mut buf = [0u8; 16];
    let mut w = Writer::new(&mut buf);
    assert!(!w.real(f32::NAN, 3));
    assert!(!w.real(f32::INFINITY, 2));
    assert_eq!(w.written(), b"0.0000.00");
}

#[test]
fn m5_reals_match_core_fmt_on_many_values() {
    // core::fmt is the oracle here (host test only): same digits,
    // except that we never write "-0.000".
    let mut next = crate::codec::xorshift32(0x1234_5678);
    for _ in 0..200_000 {
        let v = f32::from_bits(next());
        if !v.is_finite() {
            continue;
        }
        for d in 0..=MAX_DECIMALS {
            let mut want = format!("{:.*}", usize::from(d), v);
            if want.starts_with('-') && want.bytes().all(|b| matches!(b, b'-' | b'0' | b'.')) {
                want.remove(0);
            }
            assert_eq!(real(v, d), want, "{v:e} with {d} decimals");
        }
    }
}

#[test]
fn m5_times_are_exact() {
    assert_eq!(time(1_234_000, 3), "1.234");
    assert_eq!(time(765_315_969, 3), "765.316");
    assert_eq!(time(765_315_969, 6), "765.315969");
    assert_eq!(time(86_400_123_000, 3), "86400.123");
    assert_eq!(time(-1_500, 3), "-0.002");
    assert_eq!(time(-499, 3), "0.000");
    assert_eq!(time(7, 0), "0");
}

/// What we send, we accept: at the ends of the range, rounding half
/// away from zero would write a time no `Time` holds (the decoder,
/// exact, refuses `-9223372036854.776`), so there it rounds towards
/// zero. Found by the `decode_manual` fuzz corpus once the least time
/// was accepted (issue 36).
#[test]
fn the_ends_of_the_range_round_to_a_time_that_is_accepted() {
    for (micros, d, want) in [
        (i64::MIN, 3, "-9223372036854.775"),
        (i64::MAX, 3, "9223372036854.775"),
        (i64::MIN, 6, "-9223372036854.775808"),
        (i64::MAX, 0, "9223372036854"),
        (i64::MIN + 500, 3, "-9223372036854.775"),
        (i64::MAX - 1_000, 3, "9223372036854.775"),
    ] {
        let text = time(micros, d);
        assert_eq!(text, want);
        assert!(
            crate::codec::number::parse_time(text.as_bytes()).is_ok(),
            "{text} is refused"
        );
    }
    // Short of the ends, half away from zero as before.
    assert_eq!(time(-9_223_372_036_854_774_500, 3), "-9223372036854.775");
    assert_eq!(time(9_223_372_036_854_774_500, 3), "9223372036854.775");
    assert_eq!(time(9_223_372_036_854_774_499, 3), "9223372036854.774");
}

/// Times of ±(10^k − 1) and ±10^k µs with 6 decimals, 8 to 21
/// characters: every length, below 2^32 µs through `fixed_u32`, above
/// it through `long`.
#[test]
fn m5_times_of_every_length_through_both_paths() {
    for k in 0..=18 {
        let p = 10i64.pow(k);
        for micros in [p - 1, p, 1 - p, -p] {
            let m = micros.unsigned_abs();
            let sign = if micros < 0 { "-" } else { "" };
            let want = format!("{sign}{}.{:06}", m / 1_000_000, m % 1_000_000);
            assert_eq!(time(micros, 6), want);
        }
    }
}

/// A real needs its own length of room, not `fixed`'s whole window:
/// with less than the window left it is written by the long path,
/// the same text; with less than its length, nothing, and flagged.
/// The window's bytes past the text are left as they were.
#[test]
fn a_real_fits_exactly_at_the_end_of_the_buffer() {
    let text = b"-1234.567";
    for room in 0..=WINDOW + 2 {
        let mut buf = [b'#'; 32];
        let mut w = Writer::new(&mut buf[..room]);
        w.real(-1234.567, 3);
        let fits = room >= text.len();
        let want: &[u8] = if fits { text } else { b"" };
        assert_eq!((w.written(), w.overflowed()), (want, !fits), "room {room}");
        let end = want.len();
        assert!(buf[end..].iter().all(|&b| b == b'#'), "room {room}");
    }
}

#[test]
fn writer_never_overruns() {
    let mut buf = [0u8; 4];
    let mut w = Writer::new(&mut buf);
    w.real(1234.5, 3);
    assert!(w.overflowed());
    assert!(w.len() <= 4);
}
