//! Decimal text of fractional numbers: the firmware's one number-with-decimals formatter, for
//! every console reply, notice, fault reason and telemetry line.
//!
//! `core::fmt` on a float (`{:.1}` on an `f32`) links core's float-to-decimal code — Grisu and
//! Dragon with their tables of powers and big-number helpers, about 22 KB of the board's flash.
//! [`Fixed`] writes the text `format!("{:.N}", x)` writes for an `f32` with integer arithmetic on
//! its bits: the exact binary value rounded to `N` decimals, an exact tie to the even last digit,
//! `-0.0` for a negative value that rounds to zero, `NaN`, `inf` and `-inf`, and the `+` flag,
//! width, fill, alignment and `0` flag as core applies them to a float. [`Shortest`] writes an
//! `f32` in the fewest decimals that [`parse`] reads back as the same `f32` (a parameter's value,
//! so that what `set` stored is what `get` shows). [`Thousandths`] writes a whole count of
//! thousandths (milliseconds as seconds) with three decimals. [`parse`] reads a console number.

use core::fmt::{self, Alignment, Formatter, Write};

/// Most decimals [`Fixed`] writes: the fraction's 24 bits times 10^9 fit a `u64`.
pub const MAX_DECIMALS: u8 = 9;

/// Most digits of a scaled value: `f32::MAX` (39 digits) times 10^[`MAX_DECIMALS`].
const DIGITS: usize = 39 + MAX_DECIMALS as usize;

/// An `f32` written with a fixed number of decimals, as `format!("{:.N}", value)` writes it.
///
/// `write!(r, "{}", Fixed::new(reached_k, 1))` writes `{reached_k:.1}`'s text, byte for byte,
/// for every `f32`; the format's precision, if any, is ignored (the decimals are the value's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fixed {
    value: f32,
    decimals: u8,
}

impl Fixed {
    /// Write `value` with `decimals` decimals (at most [`MAX_DECIMALS`]; more are taken as that).
    pub const fn new(value: f32, decimals: u8) -> Fixed {
        Fixed {
            value,
            decimals: min_u8(decimals, MAX_DECIMALS),
        }
    }
}

const fn min_u8(a: u8, b: u8) -> u8 {
    if a < b { a } else { b }
}

impl fmt::Display for Fixed {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        let v = self.value;
        if v.is_nan() {
            return pad(f, "", b"NaN");
        }
        let sign = if v.is_sign_negative() {
            "-"
        } else if f.sign_plus() {
            "+"
        } else {
            ""
        };
        if v.is_infinite() {
            return pad(f, sign, b"inf");
        }
        let mut text = Text::new();
        text.point(&scaled(v, self.decimals), self.decimals, false);
        pad(f, sign, text.as_bytes())
    }
}

/// A whole count of thousandths written with three decimals, `12.345` for 12 345: milliseconds
/// as seconds (the telemetry's `t_s`).
///
/// The text of `format!("{:.3}", n as f64 * 1e-3)` for every `n` below 2^50 (the product is
/// then within 2.5·10⁻⁴ of `n`/1000, so it rounds to it); beyond, the exact `n`/1000 where the
/// `f64` no longer holds three decimals.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Thousandths(pub u64);

impl fmt::Display for Thousandths {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        let mut text = Text::new();
        text.point(&Digits::of(self.0), 3, false);
        pad(f, if f.sign_plus() { "+" } else { "" }, text.as_bytes())
    }
}

/// An `f32` in the fewest decimals that [`parse`] reads back as the same `f32`: `358`, `0.139`,
/// `0.0004`, `0.1234567` — a parameter as `get` shows it, so the text `set` took reads back as
/// the value it stored.
///
/// The digits are the value rounded to that many decimals (at most [`PLAIN_DECIMALS`]), so the
/// text is `{}`'s (the shortest round-trip digits) for every `f32` from 0.001 to 2^24 (checked
/// on random ones; above, where every `f32` is whole, the whole number); below 0.001 a value
/// that needs more decimals is written with an exponent and the fewest significant digits (at
/// most nine) that read back, `{:e}`'s digits (`1e-20`, `1.2345679e-30`). Zero is `0` (also
/// `-0.0`); a value of 10^9 or more, infinite or NaN is written as [`Fixed::new`]`(value, 0)`
/// writes it (no parameter's range reaches 10^9).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shortest {
    value: f32,
    per: f32,
}

impl Shortest {
    /// Write `value` in the fewest decimals that read back as it.
    pub const fn new(value: f32) -> Shortest {
        Shortest { value, per: 1.0 }
    }

    /// A percentage kept as a fraction (`value` is the fraction × 100): the fewest decimals
    /// whose hundredth, times 100, is `value` again — what `set` stores for the text gives the
    /// same percentage (`60` for 0.6 × 100 = 60.000004). A value no fraction × 100 gives is
    /// written with ten significant digits.
    pub const fn percent(value: f32) -> Shortest {
        Shortest { value, per: 100.0 }
    }
}

/// Most decimals [`Shortest`] writes without an exponent.
pub const PLAIN_DECIMALS: usize = 12;

impl fmt::Display for Shortest {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        let v = self.value;
        let a = v.abs();
        if a.is_nan() || a >= 1e9 {
            return Fixed::new(v, 0).fmt(f);
        }
        let mut text = Text::new();
        text.shortest(a, self.per);
        pad(f, if v < 0.0 { "-" } else { "" }, text.as_bytes())
    }
}

/// Exact powers of ten in f64 (10^22 is the last).
const POW10_F64: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// `v` × 10^`exp10`, by exact powers of ten in f64 ([`parse`]'s arithmetic). Not inlined:
/// [`parse`] and [`Shortest`] share it.
#[inline(never)]
fn scale(mut v: f64, mut exp10: i32) -> f64 {
    while exp10 > 22 {
        v *= POW10_F64[22];
        exp10 -= 22;
    }
    while exp10 < -22 {
        v /= POW10_F64[22];
        exp10 += 22;
    }
    if exp10 >= 0 {
        v * POW10_F64[exp10 as usize]
    } else {
        v / POW10_F64[(-exp10) as usize]
    }
}

/// A console number, `[+|-]digits[.digits][(e|E)[+|-]digits]` (`.5` and `5.` too), finite.
///
/// By hand rather than `str::parse::<f32>`: core's parser, correctly rounded for any input,
/// links a 10 KiB table of powers of five and about 6 KiB of code — 6 % of the board's flash —
/// for inputs no console line carries. Here the first 18 significant digits make an exact
/// integer, scaled once by an exact power of ten in f64 and rounded to f32: the same value as
/// core's for every input of up to 15 significant digits with a decimal exponent within ±22
/// (f64's one rounding then f32's; a test compares the two on the shortest, three-decimal and
/// exponent forms of 200 000 random f32s), within an ulp beyond. Not inlined: three commands
/// parse numbers, and one copy is what the board's flash has room for.
pub fn parse(word: &str) -> Option<f32> {
    parse_bytes(word.as_bytes())
}

/// [`parse`] of a word's bytes.
#[inline(never)]
pub fn parse_bytes(b: &[u8]) -> Option<f32> {
    let (neg, mut i) = match b.first()? {
        b'-' => (true, 1),
        b'+' => (false, 1),
        _ => (false, 0),
    };
    let (mut m, mut exp10, mut any) = (0u64, 0i32, false);
    let mut digits = |i: &mut usize, fraction: bool, m: &mut u64, exp10: &mut i32| {
        while let Some(d) = b.get(*i).filter(|c| c.is_ascii_digit()) {
            if *m < 100_000_000_000_000_000 {
                *m = *m * 10 + u64::from(d - b'0');
                *exp10 -= i32::from(fraction);
            } else {
                *exp10 += i32::from(!fraction);
            }
            any = true;
            *i += 1;
        }
    };
    digits(&mut i, false, &mut m, &mut exp10);
    if b.get(i) == Some(&b'.') {
        i += 1;
        digits(&mut i, true, &mut m, &mut exp10);
    }
    if !any {
        return None;
    }
    if matches!(b.get(i), Some(b'e' | b'E')) {
        i += 1;
        let sign = match b.get(i) {
            Some(b'-') => {
                i += 1;
                -1
            }
            Some(b'+') => {
                i += 1;
                1
            }
            _ => 1,
        };
        let (mut e, start) = (0i32, i);
        while let Some(d) = b.get(i).filter(|c| c.is_ascii_digit()) {
            e = (e * 10 + i32::from(d - b'0')).min(100_000);
            i += 1;
        }
        if i == start {
            return None;
        }
        exp10 += sign * e;
    }
    if i != b.len() {
        return None;
    }
    let v = scale(m as f64, exp10);
    let v = (if neg { -v } else { v }) as f32;
    v.is_finite().then_some(v)
}

/// A whole number's decimal digits, least significant first.
struct Digits {
    digit: [u8; DIGITS],
    len: usize,
}

impl Digits {
    /// The digits of `n` (one, `0`, for zero). One copy for both formatters (flash).
    #[inline(never)]
    fn of(mut n: u64) -> Digits {
        let mut d = Digits {
            digit: [0; DIGITS],
            len: 0,
        };
        loop {
            // A u64 has 20 digits: always a slot.
            if let Some(slot) = d.digit.get_mut(d.len) {
                *slot = (n % 10) as u8;
                d.len += 1;
            }
            n /= 10;
            if n == 0 {
                return d;
            }
        }
    }

    /// Return the digit of 10^`i` (0 past the most significant).
    fn at(&self, i: usize) -> u8 {
        if i < self.len {
            self.digit.get(i).copied().unwrap_or(0)
        } else {
            0
        }
    }

    /// Double the number (a carry past [`DIGITS`] digits is dropped: no scaled `f32` has one).
    fn double(&mut self) {
        let mut carry = 0;
        for d in self.digit.iter_mut().take(self.len) {
            let x = *d * 2 + carry;
            carry = u8::from(x >= 10);
            *d = x - 10 * carry;
        }
        if let Some(top) = self.digit.get_mut(self.len).filter(|_| carry > 0) {
            *top = carry;
            self.len += 1;
        }
    }
}

/// 10^`i` for every `i` up to [`MAX_DECIMALS`].
const POW10: [u64; MAX_DECIMALS as usize + 1] = {
    let mut p = [1; MAX_DECIMALS as usize + 1];
    let mut i = 1;
    while i < p.len() {
        p[i] = p[i - 1] * 10;
        i += 1;
    }
    p
};

/// The digits of |`value`| × 10^`decimals` rounded to a whole number, an exact tie to the even
/// one: `{:.decimals}`'s digits without the point. `value` is finite, `decimals` at most
/// [`MAX_DECIMALS`].
#[inline(never)]
fn scaled(value: f32, decimals: u8) -> Digits {
    let bits = value.to_bits();
    let biased = (bits >> 23) & 0xFF;
    let fraction = bits & 0x7F_FFFF;
    // |value| = mantissa · 2^exponent exactly.
    let (mantissa, exponent) = if biased == 0 {
        (fraction, -149)
    } else {
        (fraction | 1 << 23, biased as i32 - 150)
    };
    // < 2^24 · 10^9 < 2^54.
    let m = u64::from(mantissa) * POW10[usize::from(min_u8(decimals, MAX_DECIMALS))];
    if exponent < 0 {
        return Digits::of(round_shift(m, exponent.unsigned_abs()));
    }
    // A whole number: shifted in a u64 as far as it fits, doubled digit by digit past that.
    let exponent = exponent.unsigned_abs();
    let shift = exponent.min(m.leading_zeros());
    let mut d = Digits::of(m << shift);
    for _ in shift..exponent {
        d.double();
    }
    d
}

/// Return `n` / 2^`k` rounded to the nearest whole number, a tie to the even one (`k` ≥ 1,
/// `n` < 2^63).
fn round_shift(n: u64, k: u32) -> u64 {
    if k >= 64 {
        // n / 2^k < 1/2.
        return 0;
    }
    let q = n >> k;
    let rest = n & ((1 << k) - 1);
    let half = 1 << (k - 1);
    if rest > half || (rest == half && q % 2 == 1) {
        q + 1
    } else {
        q
    }
}

/// Room for the longest body: [`DIGITS`] digits and the point.
const TEXT_CAP: usize = DIGITS + 1;

/// A number's text without its sign: ASCII digits and the point.
struct Text {
    buf: [u8; TEXT_CAP],
    len: usize,
}

impl Text {
    fn new() -> Text {
        Text {
            buf: [0; TEXT_CAP],
            len: 0,
        }
    }

    /// Append `b` (nothing past [`TEXT_CAP`] bytes, which no number reaches).
    fn push(&mut self, b: u8) {
        if let Some(slot) = self.buf.get_mut(self.len) {
            *slot = b;
            self.len += 1;
        }
    }

    /// Write `digits` with a point before the last `decimals` of them (at least one digit before
    /// it); `trim` drops the decimals' trailing zeros, and the point with the last of them.
    #[inline(never)]
    fn point(&mut self, digits: &Digits, decimals: u8, trim: bool) {
        let decimals = usize::from(decimals);
        let len = digits.len.max(decimals + 1);
        let mut kept = decimals;
        while trim && kept > 0 && digits.at(decimals - kept) == 0 {
            kept -= 1;
        }
        for i in (decimals..len).rev() {
            self.push(b'0' + digits.at(i));
        }
        if kept > 0 {
            self.push(b'.');
        }
        for i in (decimals - kept..decimals).rev() {
            self.push(b'0' + digits.at(i));
        }
    }

    /// Write `a` (finite, at least 0, below 10^9) as [`Shortest`] does: the text of the first
    /// candidate `c` with `c` / `per` × `per` = `a`.
    #[inline(never)]
    fn shortest(&mut self, a: f32, per: f32) {
        let x = f64::from(a);
        // The value rounded to a last digit of 10^q, for q = 0, −1, …: the first that reads
        // back as `a`. Nine significant digits always do for `per` 1, so the digits fit a u32
        // (`a` below 10^9 has them at q = 0); ten end the search for any `per` (a percentage no
        // fraction gives, such as 120: 1.2 × 100 is 120.00001).
        let mut q = 0i32;
        let d = loop {
            let d = (scale(x, -q) + 0.5) as u32;
            if scale(f64::from(d), q) as f32 / per * per == a || d >= 1_000_000_000 {
                break d;
            }
            q -= 1;
        };
        let digits = Digits::of(u64::from(d));
        if q >= -(PLAIN_DECIMALS as i32) {
            return self.point(&digits, (-q) as u8, false);
        }
        // d.ddd × 10^e: the point after the first digit, trailing zeros dropped.
        let last = digits.len - 1;
        self.point(&digits, last as u8, true);
        self.push(b'e');
        self.push(b'-');
        let e = Digits::of(u64::from((q + last as i32).unsigned_abs()));
        for i in (0..e.len).rev() {
            self.push(b'0' + e.at(i));
        }
    }

    fn as_bytes(&self) -> &[u8] {
        self.buf.get(..self.len).unwrap_or_default()
    }
}

/// Write `sign` and `body` (ASCII) padded as core pads a float: to the width with the fill,
/// right-aligned unless told otherwise, or with the `0` flag zeros between the sign and the body.
fn pad(f: &mut Formatter<'_>, sign: &str, body: &[u8]) -> fmt::Result {
    let room = f
        .width()
        .unwrap_or(0)
        .saturating_sub(sign.len() + body.len());
    let zeros = f.sign_aware_zero_pad();
    let (fill, before, after) = match f.align() {
        _ if zeros => ('0', room, 0),
        Some(Alignment::Left) => (f.fill(), 0, room),
        Some(Alignment::Center) => (f.fill(), room / 2, room - room / 2),
        _ => (f.fill(), room, 0),
    };
    if zeros {
        f.write_str(sign)?;
    }
    for _ in 0..before {
        f.write_char(fill)?;
    }
    if !zeros {
        f.write_str(sign)?;
    }
    for &b in body {
        f.write_char(char::from(b))?;
    }
    for _ in 0..after {
        f.write_char(fill)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::format;
    use std::string::String;

    /// `Fixed::new(v, d)`'s text against std's `{:.d}`, for `d` in `decimals`.
    fn check(v: f32, decimals: core::ops::RangeInclusive<u8>) {
        for d in decimals {
            let want = format!("{:.*}", usize::from(d), v);
            assert_eq!(
                format!("{}", Fixed::new(v, d)),
                want,
                "{v:e} ({:#010x}) .{d}",
                v.to_bits()
            );
        }
    }

    /// xorshift64: the test's random bits.
    fn xorshift(x: &mut u64) -> u64 {
        *x ^= *x << 13;
        *x ^= *x >> 7;
        *x ^= *x << 17;
        *x
    }

    #[test]
    fn special_values_and_ties_are_what_std_writes() {
        let subnormals = [1, 2, 3, 0x40_0000, 0x7F_FFFF].map(f32::from_bits);
        let specials = [
            0.0,
            -0.0,
            f32::NAN,
            -f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MAX,
            f32::MIN,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            f32::EPSILON,
            16_777_216.0,
            16_777_215.0,
            4_294_967_296.0,
            1.8446744e19,
            1e30,
        ];
        let ties = [
            0.5,
            1.5,
            2.5,
            -2.5,
            3.5,
            0.25,
            0.75,
            0.125,
            0.375,
            0.0625,
            1.005,
            2.675,
            0.05,
            0.15,
            -0.04,
            -0.4,
            -0.5,
            -0.05,
            9.995,
            99.95,
            0.45,
            1e-5,
            5e-5,
            1023.5,
            8_388_607.5,
        ];
        for v in subnormals.iter().chain(&specials).chain(&ties) {
            check(*v, 0..=MAX_DECIMALS);
            check(-*v, 0..=MAX_DECIMALS);
        }
        assert_eq!(format!("{}", Fixed::new(-0.04, 1)), "-0.0");
        assert_eq!(format!("{}", Fixed::new(0.125, 2)), "0.12");
        assert_eq!(format!("{}", Fixed::new(0.375, 2)), "0.38");
        assert_eq!(format!("{}", Fixed::new(2.5, 0)), "2");
        assert_eq!(format!("{}", Fixed::new(f32::NEG_INFINITY, 1)), "-inf");
        assert_eq!(format!("{}", Fixed::new(1.0, 200)), format!("{:.9}", 1.0));
    }

    #[test]
    fn every_binary_fraction_on_a_grid_is_what_std_writes() {
        // k / 1024 for |k| < 2^16: each an exact tie at some precision below 10.
        for k in -65_536..65_536 {
            check(k as f32 / 1024.0, 0..=4);
        }
    }

    #[test]
    fn random_bit_patterns_are_what_std_writes() {
        let mut x = 0x2545_F491_4F6C_DD1D;
        for i in 0..150_000 {
            let bits = xorshift(&mut x);
            check(f32::from_bits(bits as u32), 0..=4);
            // Values of everyday size: exponents from 2^-14 to 2^17.
            let everyday =
                f32::from_bits((bits >> 32) as u32 & 0x807F_FFFF | (113 + (i % 32)) << 23);
            check(everyday, 0..=4);
            if i % 8 == 0 {
                check(f32::from_bits((bits >> 32) as u32), 5..=MAX_DECIMALS);
            }
        }
    }

    proptest::proptest! {
        #[test]
        fn any_f32_is_what_std_writes(bits in proptest::prelude::any::<u32>(), d in 0..=MAX_DECIMALS) {
            let v = f32::from_bits(bits);
            proptest::prop_assert_eq!(format!("{}", Fixed::new(v, d)), format!("{:.*}", usize::from(d), v));
        }
    }

    #[test]
    fn flags_are_what_std_applies() {
        let mut x = 7u64;
        let mut values: std::vec::Vec<f32> = std::vec![
            0.0,
            -0.0,
            -0.04,
            1.25,
            -1.25,
            123.456,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MAX,
        ];
        values.extend((0..200).map(|_| f32::from_bits(xorshift(&mut x) as u32) / 1e30));
        for v in values {
            let fx = Fixed::new(v, 2);
            let pairs: [(String, String); 10] = [
                (format!("{fx:+}"), format!("{v:+.2}")),
                (format!("{fx:8}"), format!("{v:8.2}")),
                (format!("{fx:+8}"), format!("{v:+8.2}")),
                (format!("{fx:08}"), format!("{v:08.2}")),
                (format!("{fx:+09}"), format!("{v:+09.2}")),
                (format!("{fx:<8}"), format!("{v:<8.2}")),
                (format!("{fx:^9}"), format!("{v:^9.2}")),
                (format!("{fx:*>10}"), format!("{v:*>10.2}")),
                (format!("{fx:_^+11}"), format!("{v:_^+11.2}")),
                (format!("{fx:<06}"), format!("{v:<06.2}")),
            ];
            for (got, want) in pairs {
                assert_eq!(got, want, "{v:e}");
            }
        }
    }

    /// `Shortest(v)` reads back as `v` through [`parse`] and through std's parser.
    fn reads_back(v: f32) -> String {
        let text = format!("{}", Shortest::new(v));
        assert_eq!(
            parse(&text),
            Some(v),
            "{v:e} ({:#010x}): {text}",
            v.to_bits()
        );
        assert_eq!(text.parse::<f32>().ok(), Some(v), "{v:e}: {text}");
        text
    }

    #[test]
    fn shortest_is_what_display_writes_and_reads_back() {
        // Every value of at most four places in (0, 10], and random six-place ones: what a
        // person types (a rate, a gain).
        for k in 1..=100_000u32 {
            let typed = format!("{}.{:04}", k / 10_000, k % 10_000);
            let v: f32 = typed.parse().unwrap();
            assert_eq!(reads_back(v), format!("{v}"), "{typed}");
        }
        let mut x = 11u64;
        for i in 0..200_000 {
            let k = xorshift(&mut x) % 10_000_000 + 1;
            let typed = format!("{}.{:06}", k / 1_000_000, k % 1_000_000);
            let v: f32 = typed.parse().unwrap();
            assert_eq!(reads_back(v), format!("{v}"), "{typed}");
            // Random bit patterns of every size from 10^-3 to 10^9: std's shortest digits
            // below 2^24 (above, every f32 is whole: written whole, where std rounds to its
            // shortest digits and pads with zeros).
            let bits = xorshift(&mut x) as u32;
            let v = f32::from_bits(bits & 0x807F_FFFF | (117 + (i % 41)) << 23);
            let text = reads_back(v);
            if v.abs() >= 1e-3 && v.abs() < 16_777_216.0 {
                assert_eq!(text, format!("{v}"));
            }
            // Below 10^-3 with an exponent: std's shortest digits too.
            let v = f32::from_bits(bits & 0x807F_FFFF | (i % 117) << 23);
            let text = reads_back(v);
            if text.contains('e') {
                assert_eq!(text, format!("{v:e}"));
            }
        }
        for (v, want) in [
            (0.0, "0"),
            (-0.0, "0"),
            (358.0, "358"),
            (0.139, "0.139"),
            (0.0004, "0.0004"),
            (0.1234567, "0.1234567"),
            (-180.0, "-180"),
            (58.90909, "58.90909"),
            (1.5e-7, "0.00000015"),
            (1e-20, "1e-20"),
            (1.234_567_9e-30, "1.2345679e-30"),
            (f32::MIN_POSITIVE, "1.1754944e-38"),
            (f32::from_bits(1), "1e-45"),
            (1e9, "1000000000"),
            (f32::INFINITY, "inf"),
            (f32::NAN, "NaN"),
        ] {
            assert_eq!(format!("{}", Shortest::new(v)), want, "{v:e}");
        }
    }

    #[test]
    fn a_percentage_reads_back_as_its_fraction() {
        let mut x = 5u64;
        for i in 0..300_000 {
            // Fractions of every size up to 2, and those of typed percentages.
            let f = match i % 2 {
                0 => (xorshift(&mut x) >> 40) as f32 / (1u64 << 23) as f32,
                _ => {
                    format!("{}", (xorshift(&mut x) % 200_000) as f32 / 1000.0)
                        .parse::<f32>()
                        .unwrap()
                        / 100.0
                }
            };
            let v = f * 100.0;
            let text = format!("{}", Shortest::percent(v));
            let c = parse(&text).unwrap();
            assert_eq!(c / 100.0 * 100.0, v, "{f:e}: {text}");
            assert!(text.len() <= 12, "{f:e}: {text}");
        }
        assert_eq!(format!("{}", Shortest::percent(0.6 * 100.0)), "60");
        // Not a fraction × 100: ten digits, and the search ends.
        assert_eq!(format!("{}", Shortest::percent(120.0)), "120.0000000");
    }

    proptest::proptest! {
        #[test]
        fn any_f32_below_1e9_reads_back(bits in proptest::prelude::any::<u32>()) {
            let v = f32::from_bits(bits);
            if v.is_finite() && v.abs() < 1e9 && v != 0.0 {
                let text = reads_back(v);
                proptest::prop_assert!(text.len() <= 16, "{}", text);
            }
        }
    }

    #[test]
    fn thousandths_are_what_std_writes_of_the_f64_seconds() {
        let mut x = 3u64;
        let edges = [
            0,
            1,
            9,
            10,
            999,
            1_000,
            1_001,
            59_999,
            1 << 32,
            (1 << 50) - 1,
        ];
        for ms in edges.into_iter().chain((0..100_000).map(|i| {
            let r = xorshift(&mut x);
            // Every size below 2^50.
            (r >> 14) >> (i % 50)
        })) {
            let want = format!("{:.3}", ms as f64 * 1e-3);
            assert_eq!(format!("{}", Thousandths(ms)), want, "{ms}");
        }
        assert_eq!(
            format!("{}", Thousandths(u64::MAX)),
            "18446744073709551.615"
        );
        assert_eq!(format!("{:+}", Thousandths(1_234)), "+1.234");
    }
}
