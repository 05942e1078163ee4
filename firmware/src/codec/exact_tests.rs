//! Unit tests of [`super`]: exact decimal-to-`f32` conversion against
//! core's parser, on the hard cases and on random texts.

use super::*;
use std::format;
use std::string::String;

fn oracle(text: &str) -> Option<u32> {
    text.parse::<f32>()
        .ok()
        .filter(|v| v.is_finite())
        .map(|v| v.abs().to_bits())
}

fn ours(text: &str) -> Option<u32> {
    parse_magnitude(text.as_bytes()).ok().map(f32::to_bits)
}

#[test]
fn m5_exact_on_hard_cases() {
    for text in [
        "0",
        "0.000",
        "1",
        "3.4028235e38",
        "3.4028235677973366e38",  // just below MAX + ulp/2
        "3.4028235677973367e38",  // just above: infinity
        "340282356779733661637539395458142568448", // MAX + ulp/2 exactly: ties to inf
        "1.4e-45",
        "7.006492321624085354618647916449580656401309709382578858785341419448955413429303e-46", // 2^-150: ties to 0
        "7.006492321624085354618647916449580656401309709382578858785341419448955413429304e-46",
        "1.17549435e-38",
        "16777217",               // 2^24 + 1: tie, to even
        "16777219",               // tie, to even (up)
        "16777217.000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000001",
        "9999999999999999999999999999999999999999",
        "0.1",
        "123456789012345678901234567890e-10",
        "1e-46",
        "9.99e-47",
        "1e38",
        "1e39",
    ] {
        assert_eq!(ours(text), oracle(text), "{text}");
    }
}

#[test]
fn m5_exact_on_random_long_texts() {
    let mut next = crate::codec::xorshift64(0x2545_f491_4f6c_dd1d);
    for _ in 0..100_000 {
        let r = next();
        let digits = 1 + (r % 200) as usize;
        let mut text = String::new();
        for i in 0..digits {
            if i == (r >> 16) as usize % (digits + 1) {
                text.push('.');
            }
            let d = next() % 10;
            text.push((b'0' + d as u8) as char);
        }
        let e = (r >> 32) as i32 % 120 - 60;
        text.push_str(&format!("e{e}"));
        assert_eq!(ours(&text), oracle(&text), "{text}");
    }
}

/// f32 midpoints written out exactly, and the texts a hair above
/// them, across the whole range.
#[test]
fn m5_exact_on_midpoints() {
    let mut next = crate::codec::xorshift32(7);
    // Random ones, then the subnormals' and the smallest normals'
    // edges, where the f32 spacing stops shrinking.
    let edges = (0..300).chain(0x007f_ff00..0x0080_0100);
    let random = (0..20_000).map(|_| next() & 0x7f7f_ffff);
    for bits in random.chain(edges) {
        let (m, q) = midpoint(bits, bits + 1);
        let (digits, e) = exact_decimal(m, q);
        // One less in the last place, then nines: a hair below it.
        let mut below = digits.clone().into_bytes();
        for b in below.iter_mut().rev() {
            if *b == b'0' {
                *b = b'9';
            } else {
                *b -= 1;
                break;
            }
        }
        let below = String::from_utf8(below).unwrap();
        for text in [
            format!("{digits}e{e}"),
            format!("{digits}1e{}", e - 1),
            format!("{digits}0000001e{}", e - 7),
            format!("{below}9999999e{}", e - 7),
            format!("{below}9e{}", e - 1),
        ] {
            assert_eq!(ours(&text), oracle(&text), "{text}");
        }
    }
}

/// `m × 2^q` as decimal digits and a power of ten (test only).
fn exact_decimal(m: u64, q: i32) -> (String, i32) {
    let mut digits: std::vec::Vec<u32> =
        m.to_string().bytes().map(|b| u32::from(b - b'0')).collect();
    let (factor, times) = if q >= 0 { (2, q) } else { (5, -q) };
    for _ in 0..times {
        let mut carry = 0;
        for d in digits.iter_mut().rev() {
            let v = *d * factor + carry;
            *d = v % 10;
            carry = v / 10;
        }
        while carry > 0 {
            digits.insert(0, carry % 10);
            carry /= 10;
        }
    }
    let text = digits.iter().map(|d| char::from(b'0' + *d as u8)).collect();
    (text, q.min(0))
}

#[test]
fn big_never_overflows_within_bounds() {
    // The largest operands: 120 nines at both magnitude bounds.
    for e in [MIN_MAGNITUDE - 1, MIN_MAGNITUDE, 0, MAX_MAGNITUDE] {
        let text = format!("0.{}e{}", "9".repeat(KEPT + 30), e + 1);
        let got = parse_magnitude(text.as_bytes());
        assert_eq!(got.ok().map(f32::to_bits), oracle(&text), "{text}");
    }
}

/// `parse_f32` hands the exact path the digits its own scanner found
/// ([`Parts`] from `Decimal::parts`): on every text it reads (at most
/// `MAX_NUMBER_LEN` characters: long mantissas, leading zeros, points
/// anywhere, exponents, midpoints written out) it rounds as core does.
#[test]
fn m5_parse_f32_reaches_the_exact_path_with_the_right_digits() {
    use crate::codec::number::{parse_f32, MAX_NUMBER_LEN};
    let check = |text: &str| {
        let core = text
            .parse::<f32>()
            .ok()
            .filter(|v| v.is_finite())
            .map(f32::to_bits);
        let ours = parse_f32(text.as_bytes()).ok().map(f32::to_bits);
        assert_eq!(ours, core, "{text}");
    };
    let mut next = crate::codec::xorshift64(0x9e37_79b9_7f4a_7c15);
    for _ in 0..100_000 {
        let r = next();
        let mut text = String::from(["", "-", "+"][(r % 3) as usize]);
        let zeros = (r >> 8) as usize % 4;
        let digits = 1 + (r >> 16) as usize % 40;
        let point = (r >> 24) as usize % (digits + 2);
        for i in 0..zeros + digits {
            if i == point {
                text.push('.');
            }
            let d = if i < zeros { 0 } else { next() % 10 };
            text.push((b'0' + d as u8) as char);
        }
        if r >> 40 & 1 == 1 {
            text.push_str(&format!("e{}", (r >> 48) as i32 % 50 - 25));
        }
        if text.len() <= MAX_NUMBER_LEN {
            check(&text);
        }
    }
    let mut next = crate::codec::xorshift32(11);
    for _ in 0..5_000 {
        let bits = next() & 0x7f7f_ffff;
        let (digits, e) = exact_decimal(midpoint(bits, bits + 1).0, midpoint(bits, bits + 1).1);
        // As long as a number may be, the point after the first digit.
        let (first, rest) = digits.split_at(1);
        let rest = &rest[..rest.len().min(MAX_NUMBER_LEN - 8)];
        let e = e + (digits.len() - 1) as i32;
        check(&format!("{first}.{rest}e{e}"));
        check(&format!("{first}.{rest}1e{e}"));
    }
}

/// Eight digits a word at a time give their value, for every digit in
/// every place (and the rest zeros or nines).
#[test]
fn m5_eight_digits_a_word_at_a_time() {
    for d in b'0'..=b'9' {
        for at in 0..8 {
            for fill in [b'0', b'9'] {
                let mut text = [fill; 8];
                text[at] = d;
                let want: u32 = std::str::from_utf8(&text).unwrap().parse().unwrap();
                assert_eq!(eight(&text), want, "{:?}", std::str::from_utf8(&text));
            }
        }
    }
    assert_eq!(eight(b"12345678"), 12_345_678);
    assert_eq!(eight(b"99999999"), 99_999_999);
}

/// The two-halves conversion rounds as `as` does, at the edges of the
/// halves and where the sum needs rounding (beyond 2^53).
#[test]
fn u64_to_f64_rounds_as_core() {
    let mut next = crate::codec::xorshift64(3);
    let edges = [
        0,
        1,
        u64::from(u32::MAX),
        1 << 32,
        (1 << 53) + 1,
        (1 << 54) + 3,
        u64::MAX,
        9_999_999_999_999_999_999,
    ];
    for v in edges.into_iter().chain((0..100_000).map(|_| next())) {
        assert_eq!(u64_to_f64(v).to_bits(), (v as f64).to_bits(), "{v}");
    }
}
