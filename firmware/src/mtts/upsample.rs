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
//!
//! Speed: MTTS only needs the histogram of the output, so [`Upsampler::histogram`] fuses the
//! two. Output pixels are taken in *groups* that share their four input taps (at s = 4, four
//! consecutive output rows or columns between two input pixels): the vertical pass loads the
//! four tap values of a column once and produces every output of its group from registers, and
//! each value is counted into a padded histogram without a clamp — the values carry an offset
//! of [`GUARD_BINS`] bins, and the Catmull–Rom overshoot is bounded (the negative lobes of a
//! phase sum to at most 1/8, so two passes stay within −0.29…1.29 of the input range), so every
//! value lands inside the padded array; the guard bins are folded into the end bins afterwards,
//! which is exactly the clamp to the image's range. About 14 instructions per output pixel on
//! the Cortex-M4 (4 multiplies, 3 adds, a conversion and the count), against ≈ 28 for
//! [`Upsampler::run`] followed by a clamped count.
//!
//! On a desktop core (the simulator, where MTTS is most of a camera-on run) the same values are
//! counted another way (`Counting::Rows`): a group's output row at a time, its values computed
//! across the columns first (a loop the compiler turns into SIMD, each lane the same four
//! multiplies and three adds in the same order, so the same values bit for bit) and counted
//! after, into four arrays in turn — an increment of the bin the previous one touched would wait
//! for its store. The counts are the same (a test runs both); on the Cortex-M4, without SIMD or
//! store forwarding, the register path is the faster and keeps its RAM.

use super::cluster::{Histogram, MAX_BINS};
use super::{IMG_COLS, IMG_ROWS, MttsError};

/// Largest upsampling factor.
pub const MAX_SCALE: usize = 8;
/// Longest output row.
pub const MAX_OUT_COLS: usize = IMG_COLS * MAX_SCALE;

/// Ring of horizontally interpolated rows (a vertical tap set spans at most five rows).
const RING: usize = 5;
/// Replicated pixels on each side of a padded row (taps reach two pixels out).
const PAD: usize = 2;
/// Offset, in bins, of the values [`Upsampler::histogram`] counts (room for the overshoot).
pub const GUARD_BINS: usize = MAX_BINS / 2;
/// Bins of the padded histogram: [`GUARD_BINS`] below the range, room above it.
pub const PADDED_BINS: usize = 2 * MAX_BINS;
/// Output rows counted per pass over a group's columns: more would keep more weights live
/// than the FPU's 32 registers hold once the compiler unrolls the column loop.
const CHUNK: usize = 4;
/// Most groups of outputs sharing their taps along one axis (one per input pixel, plus one).
const MAX_GROUPS: usize = IMG_COLS + 1;

/// How the vertical pass computes and counts a group's outputs (the module docs): the same
/// counts either way.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Counting {
    /// Column by column, every output of the group from the four taps in registers: the
    /// Cortex-M4's way. Built on the host too (a test counts both ways), never taken there.
    #[cfg_attr(not(any(test, target_os = "none")), allow(dead_code))]
    Registers,
    /// Output row by output row, values first (SIMD), counts after into [`LANES`] arrays in
    /// turn. Built for the Cortex-M4 too, never taken there.
    #[cfg_attr(target_os = "none", allow(dead_code))]
    Rows,
}

/// The build's way of counting.
#[cfg(target_os = "none")]
const COUNTING: Counting = Counting::Registers;
/// The build's way of counting.
#[cfg(not(target_os = "none"))]
const COUNTING: Counting = Counting::Rows;

/// Count arrays: [`Counting::Rows`] counts into them in turn; the Cortex-M4 keeps its RAM.
#[cfg(target_os = "none")]
const LANES: usize = 1;
/// Count arrays: [`Counting::Rows`] counts into them in turn; the Cortex-M4 keeps its RAM.
#[cfg(not(target_os = "none"))]
const LANES: usize = 4;

/// Scratch memory of the upsampler.
pub struct UpsampleScratch {
    ring: [[f32; MAX_OUT_COLS]; RING],
    ring_tag: [i32; RING],
    row: [f32; MAX_OUT_COLS],
    /// Counts of [`Upsampler::histogram`], one array per lane (all zero between calls).
    padded: [[u32; PADDED_BINS]; LANES],
}

impl Default for UpsampleScratch {
    fn default() -> Self {
        Self::new()
    }
}

impl UpsampleScratch {
    /// Return empty scratch (≈ 10 KB).
    pub const fn new() -> Self {
        UpsampleScratch {
            ring: [[0.0; MAX_OUT_COLS]; RING],
            ring_tag: [0; RING],
            row: [0.0; MAX_OUT_COLS],
            padded: [[0; PADDED_BINS]; LANES],
        }
    }
}

/// Outputs along one axis that share their four input taps.
#[derive(Clone, Copy, Debug, Default)]
struct Group {
    /// Input index of the first tap (−2 … n − 2; clamped to the image when read).
    first: i8,
    /// Outputs in the group (1 … s).
    len: u8,
    /// Phase of the first output (its weights are `wrapped[phase..phase + len]`).
    phase: u8,
    /// Output j and output len − 1 − j have mirrored weights, for every j (len even).
    mirrored: bool,
}

/// The tap groups of the output rows.
#[derive(Clone, Debug)]
struct Groups {
    n: usize,
    g: [Group; MAX_GROUPS],
}

/// Precomputed phase weights for one factor.
#[derive(Clone, Debug)]
pub struct Upsampler {
    scale: usize,
    /// Per phase: the offset of the first tap (−2 or −1) and the four weights.
    phases: [(i32, [f32; 4]); MAX_SCALE],
    /// The phases' weights twice over, so a group's weights are one contiguous slice.
    wrapped: [[f32; 4]; 2 * MAX_SCALE],
    rows: Groups,
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
            // Output u = q·s + k sits at x = (u + ½)/s − ½ = q + (2k + 1 − s)/(2s): tap base
            // ⌊(2k + 1 − s)/(2s)⌋ and fraction t = m/(2s), in exact integers.
            let num = 2 * k as i32 + 1 - s as i32;
            let m = num.rem_euclid(2 * s as i32);
            ph.0 = num.div_euclid(2 * s as i32) - 1;
            // Phases t and 1 − t get exactly mirrored weights (the kernel is symmetric), which
            // `histogram` relies on: it computes a mirrored pair from one set of weights.
            let mirrored = 2 * m > 2 * s as i32;
            let m = if mirrored { 2 * s as i32 - m } else { m };
            let t = m as f32 / (2 * s) as f32;
            let w = [keys(t + 1.0), keys(t), keys(1.0 - t), keys(2.0 - t)];
            ph.1 = if mirrored {
                [w[3], w[2], w[1], w[0]]
            } else {
                w
            };
        }
        let wrapped: [[f32; 4]; 2 * MAX_SCALE] = core::array::from_fn(|i| phases[i % s].1);
        let groups = |n: usize| {
            let mut out = Groups {
                n: 0,
                g: [Group::default(); MAX_GROUPS],
            };
            for u in 0..n * s {
                let first = (u / s) as i32 + phases[u % s].0;
                if out.n > 0 && out.g[out.n - 1].first as i32 == first {
                    out.g[out.n - 1].len += 1;
                } else {
                    out.g[out.n] = Group {
                        first: first as i8,
                        len: 1,
                        phase: (u % s) as u8,
                        mirrored: false,
                    };
                    out.n += 1;
                }
            }
            for g in out.g[..out.n].iter_mut() {
                let w = &wrapped[g.phase as usize..][..g.len as usize];
                let l = w.len();
                g.mirrored = l.is_multiple_of(2)
                    && (0..l).all(|j| {
                        (0..4).all(|i| w[j][i].to_bits() == w[l - 1 - j][3 - i].to_bits())
                    });
            }
            out
        };
        Ok(Upsampler {
            scale: s,
            phases,
            wrapped,
            rows: groups(IMG_ROWS),
        })
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

    /// Upsample `image` (24×32, row-major, K, finite values in `hist`'s range) and count every
    /// output value into `hist` (emptied first with `reset`): values beyond the range — the
    /// kernel's overshoot — count in the end bins. Equal to [`Upsampler::run`] followed by
    /// counting each value, up to the rounding of values within ~1e-5 bin of a bin edge.
    pub fn histogram(
        &self,
        image: &[f32; IMG_ROWS * IMG_COLS],
        hist: &mut Histogram,
        scratch: &mut UpsampleScratch,
    ) {
        self.histogram_by(image, hist, scratch, COUNTING);
    }

    /// [`Upsampler::histogram`], counting by `counting`.
    fn histogram_by(
        &self,
        image: &[f32; IMG_ROWS * IMG_COLS],
        hist: &mut Histogram,
        scratch: &mut UpsampleScratch,
        counting: Counting,
    ) {
        let (lo, scale) = hist.units();
        let offset = GUARD_BINS as f32;
        let oc = IMG_COLS * self.scale;
        scratch.ring_tag = [0; RING];
        let last = IMG_ROWS as i32 - 1;
        for g in &self.rows.g[..self.rows.n] {
            let rows = [0, 1, 2, 3].map(|j| (g.first as i32 + j).clamp(0, last) as usize);
            for &r in &rows {
                self.horizontal_units(image, r, lo, scale, offset, scratch);
            }
            let UpsampleScratch { ring, padded, .. } = &mut *scratch;
            let taps = rows.map(|r| &ring[r % RING][..oc]);
            let w = &self.wrapped[g.phase as usize..][..g.len as usize];
            if counting == Counting::Rows {
                count_rows(w, g.mirrored, taps, padded);
                continue;
            }
            let padded = &mut padded[0];
            if g.mirrored {
                // Pairs (j, len − 1 − j) share their weights, reversed: half the registers.
                match g.len {
                    2 => vertical_count_mirrored::<1>(w, taps, padded),
                    4 => vertical_count_mirrored::<2>(w, taps, padded),
                    6 => vertical_count_mirrored::<3>(w, taps, padded),
                    _ => vertical_count_mirrored::<4>(w, taps, padded),
                }
                continue;
            }
            for w in w.chunks(CHUNK) {
                match w.len() {
                    1 => vertical_count::<1>(w, taps, padded),
                    2 => vertical_count::<2>(w, taps, padded),
                    3 => vertical_count::<3>(w, taps, padded),
                    _ => vertical_count::<4>(w, taps, padded),
                }
            }
        }
        // Fold the guard bins into the end bins (the clamp to the range) and leave the padded
        // counts zero for the next call. Values lie within GUARD ± 1.3 · bins (module docs).
        let bins = hist.bins();
        let from = GUARD_BINS - bins / 2;
        let to = (GUARD_BINS + bins + bins / 2).min(PADDED_BINS);
        let top = bins as i32 - 1;
        for lane in scratch.padded.iter_mut() {
            for (i, c) in lane[from..to].iter_mut().enumerate() {
                if *c != 0 {
                    let b = ((from + i) as i32 - GUARD_BINS as i32).clamp(0, top) as usize;
                    hist.count[b & (MAX_BINS - 1)] += *c;
                    *c = 0;
                }
            }
        }
    }

    /// Interpolate input row `r` horizontally, converted to offset bin units, into its ring
    /// slot (once per row), by groups of outputs sharing their taps.
    fn horizontal_units(
        &self,
        image: &[f32; IMG_ROWS * IMG_COLS],
        r: usize,
        lo: f32,
        scale: f32,
        offset: f32,
        sc: &mut UpsampleScratch,
    ) {
        let slot = r % RING;
        if sc.ring_tag[slot] == r as i32 + 1 {
            return;
        }
        let src = &image[r * IMG_COLS..(r + 1) * IMG_COLS];
        let mut padded = [0f32; IMG_COLS + 2 * PAD];
        for (p, &v) in padded[PAD..PAD + IMG_COLS].iter_mut().zip(src) {
            *p = (v - lo) * scale + offset;
        }
        let (first, last) = (padded[PAD], padded[PAD + IMG_COLS - 1]);
        padded[..PAD].fill(first);
        padded[PAD + IMG_COLS..].fill(last);
        let out = &mut sc.ring[slot];
        let s = self.scale;
        for (k, &(first, w)) in self.phases[..s].iter().enumerate() {
            // Phase k: outputs k, k + s, … from the windows starting at first + PAD ∈ {0, 1}.
            let base = ((first + PAD as i32) as usize).min(1);
            let src = &padded[base..base + IMG_COLS + 3];
            let mut o = k;
            for t in src.windows(4) {
                // The mask (a no-op: o < 32·s ≤ 256) spares the bounds check.
                out[o & (MAX_OUT_COLS - 1)] = w[0] * t[0] + w[1] * t[1] + w[2] * t[2] + w[3] * t[3];
                o += s;
            }
        }
        sc.ring_tag[slot] = r as i32 + 1;
    }
}

/// The padded bin of an offset value, `(v as i32 as usize) & (PADDED_BINS − 1)`, for every `v`
/// below 2²³ (the values counted lie within 0 … [`PADDED_BINS`], the module docs) and NaN,
/// in arithmetic a compiler vectorizes with baseline SSE2 (`v as i32` saturates, which it
/// does one lane at a time): adding 2²³ rounds `v` to the nearest integer r, exactly, in the
/// float's low bits; r − 1 where r > v is the truncation.
#[inline(always)]
#[cfg_attr(target_os = "none", allow(dead_code))]
fn bin_of(v: f32) -> u16 {
    const TWO_23: f32 = 8_388_608.0;
    let r = v + TWO_23;
    let k = r.to_bits().wrapping_sub(TWO_23.to_bits());
    let k = k.wrapping_sub((r - TWO_23 > v) as u32);
    (k as usize & (PADDED_BINS - 1)) as u16
}

/// Count every output row of a group ([`Counting::Rows`]): output j has weights `w[j]`, and in
/// a mirrored group output len − 1 − j has them reversed, computed as `vertical_count_mirrored`
/// computes it (the same products summed in the same order).
#[cfg_attr(target_os = "none", allow(dead_code))]
fn count_rows(
    w: &[[f32; 4]],
    mirrored: bool,
    taps: [&[f32]; 4],
    padded: &mut [[u32; PADDED_BINS]; LANES],
) {
    let [h0, h1, h2, h3] = taps;
    let n = h0.len();
    let mut at = [0u16; MAX_OUT_COLS];
    let mut count = |w: [f32; 4], padded: &mut [[u32; PADDED_BINS]; LANES]| {
        for ((((o, &a), &b), &c), &d) in at[..n].iter_mut().zip(h0).zip(h1).zip(h2).zip(h3) {
            *o = bin_of(w[0] * a + w[1] * b + w[2] * c + w[3] * d);
        }
        let mut chunks = at[..n].chunks_exact(LANES);
        for chunk in &mut chunks {
            for (lane, &i) in padded.iter_mut().zip(chunk) {
                lane[i as usize] += 1;
            }
        }
        for (lane, &i) in padded.iter_mut().zip(chunks.remainder()) {
            lane[i as usize] += 1;
        }
    };
    if mirrored {
        for &[a, b, c, d] in &w[..w.len() / 2] {
            count([a, b, c, d], padded);
            count([d, c, b, a], padded);
        }
    } else {
        for &wj in w {
            count(wj, padded);
        }
    }
}

/// Count the 2·H output rows of a mirrored group: output j has weights `w[j]`, output
/// 2H − 1 − j the same weights reversed, so only H sets stay in registers.
#[inline(always)]
fn vertical_count_mirrored<const H: usize>(
    w: &[[f32; 4]],
    taps: [&[f32]; 4],
    padded: &mut [u32; PADDED_BINS],
) {
    let mut wl = [[0f32; 4]; H];
    wl.copy_from_slice(&w[..H]);
    let [h0, h1, h2, h3] = taps;
    for (((&a, &b), &c), &d) in h0.iter().zip(h1).zip(h2).zip(h3) {
        for w in &wl {
            let v = w[0] * a + w[1] * b + w[2] * c + w[3] * d;
            padded[(v as i32 as usize) & (PADDED_BINS - 1)] += 1;
            // The mirrored output's weights are w reversed: w[3]·a + w[2]·b + w[1]·c + w[0]·d.
            let v = w[3] * a + w[2] * b + w[1] * c + w[0] * d;
            padded[(v as i32 as usize) & (PADDED_BINS - 1)] += 1;
        }
    }
}

/// Count the N output rows of one group: every column's four taps are loaded once.
#[inline(always)]
fn vertical_count<const N: usize>(
    w: &[[f32; 4]],
    taps: [&[f32]; 4],
    padded: &mut [u32; PADDED_BINS],
) {
    let mut wl = [[0f32; 4]; N];
    wl.copy_from_slice(&w[..N]);
    let [h0, h1, h2, h3] = taps;
    for (((&a, &b), &c), &d) in h0.iter().zip(h1).zip(h2).zip(h3) {
        for w in &wl {
            let v = w[0] * a + w[1] * b + w[2] * c + w[3] * d;
            // `as i32` saturates (VCVT); the mask spares the bounds check — the value is
            // inside the array anyway (module docs).
            padded[(v as i32 as usize) & (PADDED_BINS - 1)] += 1;
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

    fn test_image(seed: u32) -> [f32; 768] {
        // Smooth structure plus sharp steps (overshoot) and a hot spot.
        core::array::from_fn(|i| {
            let (r, c) = ((i / 32) as f32, (i % 32) as f32);
            let mut v = 300.0 + 10.0 * ((r * 0.3 + seed as f32).sin() + (c * 0.45).cos());
            if (i % 32) > 12 && (i % 32) < 20 {
                v += 45.0;
            }
            if i == 400 + seed as usize {
                v = 420.0;
            }
            v
        })
    }

    #[test]
    fn fused_histogram_equals_run_then_count() {
        for s in 1..=8u8 {
            for (seed, bins) in [(0u32, 128usize), (3, 2), (7, 512), (11, 37)] {
                let img = test_image(seed);
                let (lo, hi) = img
                    .iter()
                    .fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
                let up = Upsampler::new(s).unwrap();
                let mut sc = std::boxed::Box::new(UpsampleScratch::new());
                let mut fused = Histogram::new(lo, hi, bins).unwrap();
                up.histogram(&img, &mut fused, &mut sc);
                // Both ways of counting count the same.
                for counting in [Counting::Registers, Counting::Rows] {
                    let mut other = Histogram::new(lo, hi, bins).unwrap();
                    up.histogram_by(&img, &mut other, &mut sc, counting);
                    assert_eq!(other.count[..], fused.count[..], "s={s} {counting:?}");
                }
                // The same arithmetic through `run`: values in offset bin units, clamped.
                let (l, k) = fused.units();
                let units: [f32; 768] =
                    core::array::from_fn(|p| (img[p] - l) * k + GUARD_BINS as f32);
                let mut want = Histogram::new(lo, hi, bins).unwrap();
                up.run(&units, &mut sc, |_, row| {
                    for &v in row {
                        let b = (v as i32 - GUARD_BINS as i32).clamp(0, bins as i32 - 1);
                        want.count[b as usize] += 1;
                    }
                });
                assert_eq!(fused.count[..], want.count[..], "s={s} bins={bins}");
                let (rows, cols) = up.out_size();
                assert_eq!(fused.total() as usize, rows * cols);
                // The padded counts are left empty for the next call.
                assert!(sc.padded.iter().flatten().all(|&c| c == 0));
                // And against plain bin units (no offset), only values at bin edges may move.
                let mut plain = Histogram::new(lo, hi, bins).unwrap();
                up.run(&img, &mut sc, |_, row| plain.add_slice(row));
                let moved: u32 = (0..bins)
                    .map(|b| fused.count[b].abs_diff(plain.count[b]))
                    .sum();
                assert!(
                    moved <= 2 + fused.total() / 1000,
                    "s={s} bins={bins}: {moved}"
                );
            }
        }
    }

    #[test]
    fn bin_of_is_the_saturating_conversion_masked() {
        let want = |v: f32| ((v as i32 as usize) & (PADDED_BINS - 1)) as u16;
        let mut values = std::vec![
            0.0f32,
            f32::NAN,
            1_023.999_9,
            8_388_607.5,
            f32::MIN_POSITIVE
        ];
        for k in 0..=PADDED_BINS as u32 + 3 {
            let k = k as f32;
            values.extend([
                k,
                k + 0.5,
                k - 0.5,
                k.next_up(),
                k.next_down(),
                k + 0.25,
                k + 0.75,
            ]);
        }
        let mut x = 0x1234_5678u32;
        for _ in 0..100_000 {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            values.push((x >> 8) as f32 / (1u32 << 24) as f32 * 2048.0);
        }
        for v in values.into_iter().filter(|v| v.is_nan() || *v >= 0.0) {
            assert_eq!(bin_of(v), want(v), "{v}");
        }
    }

    #[test]
    fn groups_cover_every_output_once() {
        for s in 1..=8u8 {
            let up = Upsampler::new(s).unwrap();
            for (g, n) in [(&up.rows, IMG_ROWS)] {
                let mut next = 0usize;
                for grp in &g.g[..g.n] {
                    assert_eq!(grp.phase as usize, next % s as usize);
                    assert!((1..=s).contains(&grp.len));
                    next += grp.len as usize;
                }
                assert_eq!(next, n * s as usize);
            }
            // Even factors take the mirrored path for every full group.
            let mut full = up.rows.g[..up.rows.n].iter().filter(|g| g.len == s);
            assert!(full.clone().count() >= IMG_ROWS - 1);
            assert!(full.all(|g| g.mirrored == (s % 2 == 0 && s > 1)), "s={s}");
        }
    }
}
