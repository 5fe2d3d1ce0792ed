//! Separable bicubic upsampling of the 32×24 image by an integer factor, streamed row by row.
//!
//! Kernel: Keys' cubic convolution with a = −0.5 (Catmull–Rom), the "cubic interpolation" of
//! thesis 6.3.3.1. Output pixel `u` of an axis of `n` input pixels sits at input coordinate
//! x = (u + ½)/s − ½ (pixel centres aligned), so its weights depend only on `u mod s`: they are
//! precomputed once per factor ("phases"). Edges replicate the border pixel (clamped taps).
//! For s = 1 the weights are (0, 1, 0, 0): the identity.
//!
//! Overshoot: the Catmull–Rom kernel rings at a step edge by up to 8/108 ≈ 7.4 % of the step
//! on each side (at phase 1/3). The upsampler leaves that to its caller: MTTS clamps every
//! value to the image's own range when it bins it, so no temperature beyond the hottest or
//! coldest pixel is invented; ringing inside the range is part of cubic interpolation, as in
//! the thesis.
//!
//! Memory: the output (up to 256×192 at s = 8) is never stored. [`Upsampler::run`] hands each
//! output row to a closure; it keeps only a ring of five horizontally interpolated input rows
//! (≈ 6 KB at s = 8).

use super::{IMG_COLS, IMG_ROWS, MttsError};

/// Largest upsampling factor.
pub const MAX_SCALE: usize = 8;
/// Longest output row.
pub const MAX_OUT_COLS: usize = IMG_COLS * MAX_SCALE;

/// Ring of horizontally interpolated rows (a vertical tap set spans at most five rows).
const RING: usize = 5;
/// Replicated pixels on each side of a padded row (taps reach two pixels out).
const PAD: usize = 2;

/// Scratch memory of the upsampler.
pub struct UpsampleScratch {
    ring: [[f32; MAX_OUT_COLS]; RING],
    ring_tag: [i32; RING],
    row: [f32; MAX_OUT_COLS],
}

impl Default for UpsampleScratch {
    fn default() -> Self {
        Self::new()
    }
}

impl UpsampleScratch {
    /// Return empty scratch (≈ 6 KB).
    pub const fn new() -> Self {
        UpsampleScratch {
            ring: [[0.0; MAX_OUT_COLS]; RING],
            ring_tag: [0; RING],
            row: [0.0; MAX_OUT_COLS],
        }
    }
}

/// Precomputed phase weights for one factor.
#[derive(Clone, Debug)]
pub struct Upsampler {
    scale: usize,
    /// Per phase: the offset of the first tap (−2 or −1) and the four weights.
    phases: [(i32, [f32; 4]); MAX_SCALE],
}

/// Keys' cubic kernel, a = −0.5.
fn keys(x: f32) -> f32 {
    let x = libm::fabsf(x);
    if x <= 1.0 {
        1.5 * x * x * x - 2.5 * x * x + 1.0
    } else if x < 2.0 {
        -0.5 * x * x * x + 2.5 * x * x - 4.0 * x + 2.0
    } else {
        0.0
    }
}

impl Upsampler {
    /// Make an upsampler for factor `scale` (1…8).
    pub fn new(scale: u8) -> Result<Self, MttsError> {
        let s = scale as usize;
        if !(1..=MAX_SCALE).contains(&s) {
            return Err(MttsError::BadScale { scale });
        }
        let mut phases = [(0i32, [0f32; 4]); MAX_SCALE];
        for (k, ph) in phases.iter_mut().enumerate().take(s) {
            // Output u = q·s + k sits at x = (u + ½)/s − ½ = q + ((k + ½)/s − ½).
            let off = (k as f32 + 0.5) / s as f32 - 0.5;
            let base = libm::floorf(off);
            let t = off - base;
            ph.0 = base as i32 - 1;
            ph.1 = [keys(t + 1.0), keys(t), keys(1.0 - t), keys(2.0 - t)];
        }
        Ok(Upsampler { scale: s, phases })
    }

    /// Return the factor.
    pub fn scale(&self) -> usize {
        self.scale
    }

    /// Return the output size (rows, columns).
    pub fn out_size(&self) -> (usize, usize) {
        (IMG_ROWS * self.scale, IMG_COLS * self.scale)
    }

    /// Interpolate input row `r` horizontally into its ring slot (once per row).
    fn horizontal(&self, image: &[f32; IMG_ROWS * IMG_COLS], r: usize, sc: &mut UpsampleScratch) {
        let slot = r % RING;
        if sc.ring_tag[slot] == r as i32 + 1 {
            return;
        }
        let src = &image[r * IMG_COLS..(r + 1) * IMG_COLS];
        let mut padded = [0f32; IMG_COLS + 2 * PAD];
        padded[PAD..PAD + IMG_COLS].copy_from_slice(src);
        padded[..PAD].fill(src[0]);
        padded[PAD + IMG_COLS..].fill(src[IMG_COLS - 1]);
        let s = self.scale;
        let out = &mut sc.ring[slot];
        for k in 0..s {
            let (first, w) = self.phases[k];
            let base = (first + PAD as i32) as usize;
            let taps = padded[base..].windows(4).take(IMG_COLS);
            for (o, t) in out.iter_mut().skip(k).step_by(s).zip(taps) {
                *o = w[0] * t[0] + w[1] * t[1] + w[2] * t[2] + w[3] * t[3];
            }
        }
        sc.ring_tag[slot] = r as i32 + 1;
    }

    /// Upsample `image` (24×32, row-major, finite values) and call `emit(row, values)` for
    /// every output row in order.
    pub fn run(
        &self,
        image: &[f32; IMG_ROWS * IMG_COLS],
        scratch: &mut UpsampleScratch,
        mut emit: impl FnMut(usize, &[f32]),
    ) {
        let s = self.scale;
        let oc = IMG_COLS * s;
        scratch.ring_tag = [0; RING];
        let last = IMG_ROWS as i32 - 1;
        for q in 0..IMG_ROWS {
            for k in 0..s {
                let (first, w) = self.phases[k];
                let rows = [0, 1, 2, 3].map(|j| (q as i32 + first + j).clamp(0, last) as usize);
                for &r in &rows {
                    self.horizontal(image, r, scratch);
                }
                let UpsampleScratch { ring, row, .. } = &mut *scratch;
                let [h0, h1, h2, h3] = rows.map(|r| &ring[r % RING][..oc]);
                for ((((o, a), b), c), d) in row[..oc].iter_mut().zip(h0).zip(h1).zip(h2).zip(h3) {
                    *o = w[0] * a + w[1] * b + w[2] * c + w[3] * d;
                }
                emit(q * s + k, &row[..oc]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    fn collect(up: &Upsampler, img: &[f32; 768]) -> Vec<f32> {
        let mut scratch = std::boxed::Box::new(UpsampleScratch::new());
        let mut out = Vec::new();
        let mut next = 0;
        up.run(img, &mut scratch, |r, v| {
            assert_eq!(r, next);
            next += 1;
            out.extend_from_slice(v);
        });
        out
    }

    #[test]
    fn scale_one_is_identity() {
        let img: [f32; 768] = core::array::from_fn(|i| (i as f32 * 0.37).sin() * 10.0 + 300.0);
        assert_eq!(collect(&Upsampler::new(1).unwrap(), &img), img.to_vec());
    }

    #[test]
    fn bad_scales_are_refused() {
        assert!(Upsampler::new(0).is_err());
        assert!(Upsampler::new(9).is_err());
    }

    #[test]
    fn reproduces_linear_ramps_inside() {
        // Cubic convolution reproduces linear functions exactly away from the clamped edges.
        for s in 2..=8u8 {
            let img: [f32; 768] = core::array::from_fn(|i| 300.0 + (i % 32) as f32 * 0.5);
            let up = Upsampler::new(s).unwrap();
            let out = collect(&up, &img);
            let (orows, oc) = up.out_size();
            let s = s as usize;
            for u in 2 * s..(32 - 2) * s {
                let x = (u as f32 + 0.5) / s as f32 - 0.5;
                let want = 300.0 + x * 0.5;
                for r in [0, orows / 2, orows - 1] {
                    let got = out[r * oc + u];
                    assert!((got - want).abs() < 1e-3, "s={s} u={u}: {got} vs {want}");
                }
            }
        }
    }

    #[test]
    fn step_edge_overshoot_is_bounded_as_documented() {
        let img: [f32; 768] = core::array::from_fn(|i| if i % 32 < 16 { 298.0 } else { 340.0 });
        for s in 1..=8u8 {
            let out = collect(&Upsampler::new(s).unwrap(), &img);
            let (mn, mx) = out
                .iter()
                .fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
            let bound = 42.0 * 8.0 / 108.0 + 1e-3;
            assert!(
                mx - 340.0 <= bound && 298.0 - mn <= bound,
                "s={s}: {mn}..{mx}"
            );
        }
        assert!((-keys(1.0 + 1.0 / 3.0) - 8.0 / 108.0).abs() < 1e-6);
    }

    #[test]
    fn weights_sum_to_one() {
        for s in 1..=8u8 {
            let up = Upsampler::new(s).unwrap();
            for k in 0..s as usize {
                let sum: f32 = up.phases[k].1.iter().sum();
                assert!((sum - 1.0).abs() < 1e-6);
            }
        }
    }
}
