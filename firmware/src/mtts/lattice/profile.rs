//! The core's axial profile: its pixels binned along the axis (¼ px bins with each bin's
//! slope), bad pixels left out. Takes the image, the geometry and the filled pixels; gives
//! [`Profile`].

use super::*;

/// How far a core pixel must lie beyond every other (above the second highest, or below the
/// second lowest) to be left out as a lone bad pixel, K: pixel noise (≤ 0.5 K rms) leaves the
/// extremes of a lattice's stripes within a kelvin or so of each other. Seen family members,
/// |gap| ≥ 3 K: mean |T1|, |T2| 0.106, 0.147 → 0.093, 0.133 K (1.5, 2 and 3 K alike).
pub const LONE_PIXEL_K: f32 = 2.0;
/// Fewest core pixels for [`LONE_PIXEL_K`]'s test (a core of a few pixels has no "every other").
pub(super) const LONE_MIN_PIXELS: f32 = 8.0;
/// A core pixel more than this share of the frame's range (and at least [`LONE_PIXEL_K`])
/// beyond both its row neighbours is a hot or dead pixel (if there are at most [`ODD_MAX`]).
/// Without that limit a fixed 2 K took the 273 K camera-on cycle's mean |T2| from 0.077 to
/// 0.113 K: gaps of tens of kelvin put a slanted stripe's single pixels that far beyond their
/// neighbours. With it, a fixed 2 K and this share tie on the seen family members (mean |T1|,
/// |T2| 0.0766, 0.1060 against 0.0771, 0.1055 K), whose gaps stop at 15 K; the share keeps the
/// few such pixels of a larger gap.
pub(super) const BAD_RANGE_FRACTION: f32 = 0.05;
/// Most core pixels beyond both row neighbours that the profile leaves out as bad: more are
/// the lattice's own stripes, and all stay. Seen family members, |gap| ≥ 3 K, mean |T1|, |T2|:
/// no rule 0.0772, 0.1084 K; at most 3 0.0781, 0.1055; 4 or 6 0.0771, 0.1055; no limit 0.0769,
/// 0.1055. Without a limit a thin stripe at a slant lost its pixels (unseen member 1000543,
/// tilt −30°, exposed 0.83: |T2| 0.27 → 0.70 K, past its bound).
pub(super) const ODD_MAX: usize = 4;

/// Least spread Σ (t − t̄)² of a bin's pixels along the axis for its slope to count, px²
/// (pixels at one place, within rounding, tell no slope).
pub(super) const SLOPE_MIN_PX2: f32 = 1e-6;
/// Fine bins per pixel of axial length.
///
/// A tilted axis puts a bin's pixels at several places within it, and across a sharp stripe's
/// edge their values differ by a kelvin or more: that slope is what tells a stripe's width from
/// the optics' spread, which a bin's mean alone throws away. So the candidates' misfit takes
/// each bin to first order — its pixels at t̄ + δ see the model plus δ times its derivative —
/// which adds the bins' slopes Y/S (S = Σ δ², Y = Σ δ·y, from [`Bin`]'s sums) weighed by S,
/// exact up to the profile's curvature within ¼ px (`gram`; the free fit and the frequency's
/// refinement keep the means alone). Unseen family members, |gap| ≥ 3 K: mean |T2| 0.114 →
/// 0.110 K, exposed 0.75–0.85 at 6–10 px 0.48 → 0.46 K, the thesis's lattice 0.18 → 0.17 K;
/// seen members 0.113 → 0.111 K (their thin-stripe cells at 10–16 px 0.26 → 0.24 K, at 4–6 px
/// 0.64 → 0.67 K). Finer bins instead (16 per px, the means alone) bought less (0.112
/// K unseen) for 28 700 more Cortex-M4 instructions; the slopes, with the profile's pass
/// made cheaper (one array of bins, only the columns each row's core can reach), cost 3 470
/// (`bash scripts/bench-m4`, first frame).
pub(super) const FINE: usize = 4;
/// Fine bins of the core's axial profile.
pub(super) const FINE_BINS: usize = FINE * BINS;

/// Axial position `t` (pixels) in fine-bin widths from the profile's start `t0` (pixels): its
/// integer part is the pixel's bin, the rest its place τ within that bin (0…1), as [`Bin`]
/// keeps it.
#[inline(always)]
pub(super) fn fine_place(t: f32, t0: f32) -> f32 {
    (t - t0) * FINE as f32
}

/// One fine bin of the core's axial profile: its pixels' sum of values less the reference,
/// count and sum of axial positions; Σ τ² and Σ τ·y, τ a pixel's place within the bin (bin
/// widths, 0…1): how far its pixels spread along the axis and how their values slope over it.
#[derive(Clone, Copy, Default)]
pub(super) struct Bin {
    pub(super) sum: f32,
    pub(super) cnt: f32,
    pub(super) tsum: f32,
    pub(super) tt: f32,
    pub(super) ty: f32,
}

/// The core's pixels binned along the axis (one pass over the columns each row's core can
/// reach): a [`Bin`] per ¼ px; with the core's count, mean and range. Bad pixels are left out
/// (the module docs): a few beyond both row neighbours, a lone extreme, and every pixel filled
/// in.
pub(super) struct Profile {
    pub(super) bins: [Bin; FINE_BINS],
    /// Fine bins in use (the last non-empty one + 1).
    pub(super) used: usize,
    /// Axial position of bin 0's start, pixels.
    pub(super) t0: f32,
    pub(super) reference: f32,
    pub(super) total: f32,
    pub(super) mean_dev: f32,
    /// Σ of squared values less the reference, K².
    pub(super) sq: f32,
    pub(super) lo: f32,
    pub(super) hi: f32,
}

impl Profile {
    pub(super) fn of(
        img: &[f32; IMG_PIXELS],
        xy: &Coords,
        g: &Geometry,
        u_core: f32,
        bad_k: f32,
        filled: &FilledRows,
    ) -> Option<Profile> {
        // The smallest axial coordinate in the image is at a corner.
        let corners = [0, IMG_COLS - 1, (IMG_ROWS - 1) * IMG_COLS, IMG_PIXELS - 1];
        let mut tmin = f32::INFINITY;
        for p in corners {
            if xy.t[p] < tmin {
                tmin = xy.t[p];
            }
        }
        let t0 = floor(tmin);
        let mut p = Profile {
            bins: [Bin::default(); FINE_BINS],
            used: 0,
            t0,
            reference: 0.0,
            total: 0.0,
            mean_dev: 0.0,
            sq: 0.0,
            lo: f32::INFINITY,
            hi: f32::NEG_INFINITY,
        };
        let mut s = 0f32;
        // The second highest and lowest values, and the (bin, axial position) of the extremes.
        let (mut hi2, mut lo2) = (f32::NEG_INFINITY, f32::INFINITY);
        let (mut hi_at, mut lo_at) = ((0usize, 0f32), (0usize, 0f32));
        // Pixels beyond both row neighbours (value, axial position, index): the first ODD_MAX.
        let mut odd = [(0f32, 0f32, 0usize); ODD_MAX];
        let mut n_odd = 0usize;
        // Each row's core lies within u_core·w·√(1 + slope²) columns of the axis: only those
        // columns (and one more either side, for rounding) are looked at, in the same order.
        let reach =
            u_core * g.half_width_px * crate::fmath::sqrt(1.0 + g.axis_slope * g.axis_slope);
        // The values are kept less a reference near the core's, for the sums' precision: the
        // pixel on the axis in the middle row (the nearest column in the image).
        let mid = IMG_ROWS / 2;
        let axis_col = floor(g.axis_col0 + g.axis_slope * mid as f32 + 0.5);
        p.reference = img[mid * IMG_COLS + min(max(0.0, axis_col), (IMG_COLS - 1) as f32) as usize];
        // The columns of row r looked at: first..end.
        let columns = |r: usize| {
            let centre = g.axis_col0 + g.axis_slope * r as f32;
            let first = (floor(centre - reach) as i32).clamp(0, IMG_COLS as i32) as usize;
            let end = (floor(centre + reach) as i32 + 2).clamp(0, IMG_COLS as i32) as usize;
            (first.min(end), end)
        };
        for r in 0..IMG_ROWS {
            let (first, end) = columns(r);
            let row = r * IMG_COLS;
            // Whole rows of 32, indexed under a mask: no range checks in the loop (a row always
            // fits, so the fallbacks are never taken).
            let m = IMG_COLS - 1;
            let line: &[f32; IMG_COLS] = img[row..row + IMG_COLS]
                .try_into()
                .unwrap_or(&[0.0; IMG_COLS]);
            let us: &[f32; IMG_COLS] = xy.u[row..row + IMG_COLS]
                .try_into()
                .unwrap_or(&[0.0; IMG_COLS]);
            let ts: &[f32; IMG_COLS] = xy.t[row..row + IMG_COLS]
                .try_into()
                .unwrap_or(&[0.0; IMG_COLS]);
            for c in first..end {
                if us[c & m] < u_core {
                    let (t, v) = (ts[c & m], line[c & m]);
                    // Beyond both row neighbours: the left one first, the right one only past
                    // it — most pixels are not (the pixel itself at the image's sides).
                    let dl = v - line[c.wrapping_sub(1) & m];
                    if c > 0 && dl.abs() > bad_k {
                        let dr = v - line[(c + 1).min(m)];
                        if dl * dr > 0.0 && dr.abs() > bad_k {
                            if let Some(o) = odd.get_mut(n_odd) {
                                *o = (v, t, row + c);
                            }
                            n_odd += 1;
                        }
                    }
                    let q = fine_place(t, t0);
                    let b = (q as usize).min(FINE_BINS - 1);
                    let y = v - p.reference;
                    let tau = q - b as f32;
                    let bin = &mut p.bins[b];
                    bin.sum += y;
                    bin.cnt += 1.0;
                    bin.tsum += t;
                    bin.tt += tau * tau;
                    bin.ty += tau * y;
                    p.total += 1.0;
                    p.sq += y * y;
                    s += y;
                    if b >= p.used {
                        p.used = b + 1;
                    }
                    // Most pixels pass neither second extreme: one comparison each.
                    if v < lo2 {
                        if v < p.lo {
                            lo2 = p.lo;
                            p.lo = v;
                            lo_at = (b, t);
                        } else {
                            lo2 = v;
                        }
                    }
                    if v > hi2 {
                        if v > p.hi {
                            hi2 = p.hi;
                            p.hi = v;
                            hi_at = (b, t);
                        } else {
                            hi2 = v;
                        }
                    }
                }
            }
        }
        // Left out: a few pixels beyond both row neighbours, hot or dead pixels the EEPROM does
        // not flag (many are the lattice's own, thin stripes crossing the rows at a slant, and
        // stay), and every pixel that was broken and filled in from its neighbours (no
        // measurement of its place: across a thin stripe, the mean of both targets). The
        // core's range may keep another of them: it serves only the fallback's bound, which it
        // widens.
        let (mut hi_kept, mut lo_kept) = (true, true);
        let is_filled = |q: usize| (filled[q / IMG_COLS] >> (q % IMG_COLS)) & 1 != 0;
        let mut leave_out = |p: &mut Profile, v: f32, t: f32| {
            let b = (fine_place(t, t0) as usize).min(FINE_BINS - 1);
            p.drop(v, (b, t), &mut s);
            if (v, t) == (p.hi, hi_at.1) {
                p.hi = hi2;
                hi_kept = false;
            }
            if (v, t) == (p.lo, lo_at.1) {
                p.lo = lo2;
                lo_kept = false;
            }
        };
        if n_odd <= ODD_MAX {
            for &(v, t, q) in &odd[..n_odd] {
                if !is_filled(q) {
                    leave_out(&mut p, v, t);
                }
            }
        }
        for (r, &fill) in filled.iter().enumerate() {
            if fill == 0 {
                continue;
            }
            let (first, end) = columns(r);
            for c in first..end {
                let q = r * IMG_COLS + c;
                if (fill >> c) & 1 != 0 && xy.u[q] < u_core {
                    leave_out(&mut p, img[q], xy.t[q]);
                }
            }
        }
        // A lone pixel far beyond every other in the core (a hot or dead pixel the EEPROM does
        // not flag) is left out: one such pixel shifts its bin by its whole excess.
        if hi_kept && p.total > LONE_MIN_PIXELS && p.hi - hi2 > LONE_PIXEL_K {
            p.drop(p.hi, hi_at, &mut s);
            p.hi = hi2;
        }
        if lo_kept && p.total > LONE_MIN_PIXELS && lo2 - p.lo > LONE_PIXEL_K {
            p.drop(p.lo, lo_at, &mut s);
            p.lo = lo2;
        }
        (p.total > 0.0).then(|| {
            p.mean_dev = s / p.total;
            p
        })
    }

    /// Take the pixel of value `v` at (bin, axial position) `at` back out of the profile, and
    /// out of the running sum `s` of values less the reference.
    pub(super) fn drop(&mut self, v: f32, (b, t): (usize, f32), s: &mut f32) {
        let y = v - self.reference;
        let tau = fine_place(t, self.t0) - b as f32;
        let bin = &mut self.bins[b];
        bin.sum -= y;
        bin.cnt -= 1.0;
        bin.tsum -= t;
        bin.tt -= tau * tau;
        bin.ty -= tau * y;
        self.total -= 1.0;
        self.sq -= y * y;
        *s -= y;
    }

    /// Pixels of axial length covered (1 px bins).
    pub(super) fn length(&self) -> usize {
        self.used.div_ceil(FINE)
    }
}
