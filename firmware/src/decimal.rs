//! Decimal text of fractional numbers: the firmware's one number-with-decimals formatter, for
//! every console reply, notice, fault reason and telemetry line.
//!
//! `core::fmt` on a float (`{:.1}` on an `f32`) links core's float-to-decimal code — Grisu and
//! Dragon with their tables of powers and big-number helpers, about 22 KB of the board's flash.
//! [`Fixed`] writes the text `format!("{:.N}", x)` writes for an `f32` with integer arithmetic on
//! its bits: the exact binary value rounded to `N` decimals, an exact tie to the even last digit,
//! `-0.0` for a negative value that rounds to zero, `NaN`, `inf` and `-inf`, and the `+` flag,
//! width, fill, alignment and `0` flag as core applies them to a float. [`Thousandths`] writes a
//! whole count of thousandths (milliseconds as seconds) with three decimals.

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
    trim: bool,
}

impl Fixed {
    /// Write `value` with `decimals` decimals (at most [`MAX_DECIMALS`]; more are taken as that).
    pub const fn new(value: f32, decimals: u8) -> Fixed {
        Fixed {
            value,
            decimals: min_u8(decimals, MAX_DECIMALS),
            trim: false,
        }
    }

    /// Write `value` with at most `max_decimals` decimals: [`Fixed::new`]'s text without its
    /// trailing zeros, and without the point when no decimal is left (`2`, `0.5`, `2.25`).
    ///
    /// That is the text `{}` writes for a value typed as a decimal of at most `max_decimals`
    /// places whose digits the `f32` keeps: any of at most 6 significant digits, and every one of
    /// the 10^7 six-place values in (0, 10] (`stream on`'s rates; each checked against std). Any
    /// other value is rounded to `max_decimals` places where `{}` writes its shortest round-trip
    /// digits (`0.0000001` as `0`, `1/3` as `0.333333` for `0.33333334`).
    pub const fn trimmed(value: f32, max_decimals: u8) -> Fixed {
        Fixed {
            trim: true,
            ..Fixed::new(value, max_decimals)
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
        text.point(&scaled(v, self.decimals), self.decimals, self.trim);
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

    #[test]
    fn trimmed_is_what_display_writes_for_typed_values() {
        // Every value of at most four places in (0, 10], and random six-place ones: a rate as
        // `stream on` takes it.
        for k in 1..=100_000u32 {
            let typed = format!("{}.{:04}", k / 10_000, k % 10_000);
            let v: f32 = typed.parse().unwrap();
            assert_eq!(
                format!("{}", Fixed::trimmed(v, 6)),
                format!("{v}"),
                "{typed}"
            );
        }
        let mut x = 11u64;
        for _ in 0..100_000 {
            let k = xorshift(&mut x) % 10_000_000 + 1;
            let typed = format!("{}.{:06}", k / 1_000_000, k % 1_000_000);
            let v: f32 = typed.parse().unwrap();
            assert_eq!(
                format!("{}", Fixed::trimmed(v, 6)),
                format!("{v}"),
                "{typed}"
            );
        }
        for v in [
            0.0,
            -0.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            4.0,
            -2.5,
            0.5,
        ] {
            assert_eq!(format!("{}", Fixed::trimmed(v, 6)), format!("{v}"));
        }
        assert_eq!(format!("{}", Fixed::trimmed(1.0 / 3.0, 6)), "0.333333");
        assert_eq!(format!("{}", Fixed::trimmed(2.5, 0)), "2");
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
