//! Float functions `core` does not provide: square root, fourth root, floor, exact powers of
//! two and 2^x, sine and cosine in `f32` (libm's `sinf`/`cosf` work in `f64`, which the Cortex-M4's FPU lacks:
//! linking them costs ≈ 10 KiB of soft-float code and far more time), and a clamp without
//! core's panic (whose message links core's float formatting).
//!
//! On the Cortex-M4F the square root is the FPU's `VSQRT.F32` (exact, correctly rounded, a
//! handful of cycles); elsewhere it is `libm::sqrtf`, which is also correctly rounded, so both
//! give bit-identical results.

#[cfg(all(target_arch = "arm", target_os = "none", target_abi = "eabihf"))]
core::arch::global_asm!(
    ".section .text.thermorph_vsqrt_f32,\"ax\",%progbits",
    ".global thermorph_vsqrt_f32",
    ".type thermorph_vsqrt_f32,%function",
    ".syntax unified",
    ".fpu fpv4-sp-d16",
    ".thumb",
    ".thumb_func",
    "thermorph_vsqrt_f32:",
    "vsqrt.f32 s0, s0",
    "bx lr",
    ".size thermorph_vsqrt_f32, . - thermorph_vsqrt_f32",
);

#[cfg(all(target_arch = "arm", target_os = "none", target_abi = "eabihf"))]
unsafe extern "C" {
    fn thermorph_vsqrt_f32(x: f32) -> f32;
}

/// Return the correctly rounded square root of `x` (NaN for negative input).
#[inline]
pub fn sqrt(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_os = "none", target_abi = "eabihf"))]
    {
        // SAFETY: the function is two instructions that only touch s0 and return; it follows
        // the AAPCS-VFP calling convention (argument and result in s0).
        unsafe { thermorph_vsqrt_f32(x) }
    }
    #[cfg(not(all(target_arch = "arm", target_os = "none", target_abi = "eabihf")))]
    {
        libm::sqrtf(x)
    }
}

/// Return the fourth root of `x` as two square roots, as the Melexis library computes it.
#[inline]
pub fn root4(x: f32) -> f32 {
    sqrt(sqrt(x))
}

/// Return 2^`n` exactly, for `n` in −126..=127 (clamped outside that range).
#[inline]
pub fn pow2(n: i32) -> f32 {
    let n = n.clamp(-126, 127);
    f32::from_bits(((n + 127) as u32) << 23)
}

/// Return the larger of `a` and `b`, or `a` when `b` is NaN, as `f32::max` does: without its
/// library call on the Cortex-M4 (`fmaxf`: a call, eleven instructions and a return, where this
/// is a comparison and a conditional move). Unlike `f32::max`, NaN `a` gives NaN: a value that
/// may be NaN goes second (a bound first: `max(0.0, x)`).
#[inline(always)]
pub fn max(a: f32, b: f32) -> f32 {
    if b > a { b } else { a }
}

/// Return the smaller of `a` and `b`, or `a` when `b` is NaN ([`max`]'s twin, for `f32::min`).
#[inline(always)]
pub fn min(a: f32, b: f32) -> f32 {
    if b < a { b } else { a }
}

/// Return `x` limited to [`lo`, `hi`] as `f32::clamp` does (NaN `x` stays NaN), without its
/// panic: core's `clamp` asserts `lo <= hi` and formats both bounds with `Debug` in its panic
/// message, which links core's float-to-decimal code (about 22 KB) into the board wherever a
/// bound is not a constant. Bounds out of order (or NaN) give what the two comparisons give:
/// `hi` for `x > hi`, else `lo` for `x < lo`, else `x`.
#[inline(always)]
pub fn clamp(x: f32, lo: f32, hi: f32) -> f32 {
    let x = if x < lo { lo } else { x };
    if x > hi { hi } else { x }
}

/// Return ⌊`x`⌋ without a library call (`f32::floor` is one on the Cortex-M4), for |x| < 2^31.
#[inline]
pub fn floor(x: f32) -> f32 {
    let i = x as i32 as f32;
    if i > x { i - 1.0 } else { i }
}

/// Return 2^`y` without a library call: 2^⌊y⌋ from the exponent's bits times a cubic of the
/// fraction (the cubic of least relative error on [0, 1), 7.5·10⁻⁵), so within 10⁻⁴ relative
/// for −126 < y < 128; 0 at or below −126, +∞ at or above 128, NaN for NaN.
pub fn exp2(y: f32) -> f32 {
    if y.is_nan() {
        return y;
    }
    if y <= -126.0 {
        return 0.0;
    }
    if y >= 128.0 {
        return f32::INFINITY;
    }
    let n = floor(y);
    let f = y - n;
    let p = 0.999_925_3 + f * (0.695_832_8 + f * (0.226_068 + f * 0.078_024_45));
    p * pow2(n as i32)
}

/// Return 2^`n` exactly as `f64`, for `n` in −1022..=1023 (clamped outside that range).
#[inline]
pub fn pow2_f64(n: i32) -> f64 {
    let n = n.clamp(-1022, 1023);
    f64::from_bits(((n + 1023) as u64) << 52)
}

/// Sine and cosine of 2π·x (x in turns, |x| < 2^31), without a library call: reduction to an
/// eighth of a turn and Taylor polynomials (error < 1e-6); exactly (0, 1) at x = 0.
pub fn sin_cos_turns(x: f32) -> (f32, f32) {
    let r = x - floor(x + 0.5);
    let q = floor(r * 4.0 + 0.5);
    let p = core::f32::consts::TAU * (r - 0.25 * q);
    let p2 = p * p;
    let s = p * (1.0 - p2 / 6.0 * (1.0 - p2 / 20.0 * (1.0 - p2 / 42.0)));
    let c = 1.0 - p2 / 2.0 * (1.0 - p2 / 12.0 * (1.0 - p2 / 30.0 * (1.0 - p2 / 56.0)));
    match q as i32 {
        0 => (s, c),
        1 => (c, -s),
        -1 => (-c, s),
        _ => (-s, -c),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pow2_is_exact() {
        assert_eq!(pow2(0), 1.0);
        assert_eq!(pow2(10), 1024.0);
        assert_eq!(pow2(-3), 0.125);
        assert_eq!(pow2_f64(45), 35_184_372_088_832.0);
    }

    #[test]
    fn clamp_matches_std_for_ordered_bounds() {
        let values = [
            -2.0f32,
            -1.0,
            -0.0,
            0.0,
            0.5,
            1.0,
            3.0,
            f32::NAN,
            f32::INFINITY,
        ];
        for x in values {
            for (lo, hi) in [(-1.0, 1.0), (0.0, 0.0), (-0.0, 0.0), (0.5, f32::INFINITY)] {
                let (got, want) = (clamp(x, lo, hi), x.clamp(lo, hi));
                assert_eq!(got.to_bits(), want.to_bits(), "{x} in [{lo}, {hi}]");
            }
        }
        assert_eq!(clamp(0.0, 2.0, 1.0), 1.0);
        assert_eq!(clamp(3.0, f32::NAN, 1.0), 1.0);
        assert_eq!(clamp(-3.0, -1.0, f32::NAN), -1.0);
    }

    #[test]
    fn floor_matches_std() {
        for &x in &[
            0.0f32,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.999,
            -2.999,
            1e6 + 0.5,
            -7.25,
        ] {
            assert_eq!(floor(x), x.floor(), "{x}");
        }
    }

    #[test]
    fn exp2_is_within_1e_4_relative() {
        for i in -1250..=1270 {
            let y = i as f32 * 0.1;
            let want = libm::exp2(y as f64);
            let got = exp2(y) as f64;
            assert!(
                (got / want - 1.0).abs() < 1e-4,
                "2^{y}: {got} against {want}"
            );
        }
        assert_eq!(exp2(-126.0), 0.0);
        assert_eq!(exp2(-1000.0), 0.0);
        assert_eq!(exp2(128.0), f32::INFINITY);
        assert!(exp2(f32::NAN).is_nan());
    }

    #[test]
    fn sqrt_matches_std() {
        for &x in &[0.0f32, 1.0, 2.0, 1e-30, 8.1e9, 123.456] {
            assert_eq!(sqrt(x), x.sqrt());
        }
        assert!(sqrt(-1.0).is_nan());
        assert!((root4(8.1e9) - 300.0).abs() < 1e-3);
    }

    #[test]
    fn sin_cos_matches_libm() {
        for i in -400..400 {
            let x = i as f32 * 0.01237;
            let (s, c) = sin_cos_turns(x);
            let a = core::f32::consts::TAU * x;
            assert!((s - libm::sinf(a)).abs() < 2e-6, "{x}");
            assert!((c - libm::cosf(a)).abs() < 2e-6, "{x}");
        }
        assert_eq!(sin_cos_turns(0.0), (0.0, 1.0));
    }
}
