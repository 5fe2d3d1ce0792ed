//! The core's axial profile: its pixels binned along the axis (¼ px bins with each bin's
//! slope), bad pixels left out. Takes the image, the geometry and the filled pixels; gives
//! [`Profile`].

use super::*;
use core::ops::Range;

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
    /// The core's profile of image `img`: its pixels (`u` under `u_core`) binned along the
    /// axis, but for the few more than `bad_k` beyond both row neighbours, the `filled` ones
    /// and a lone extreme. In steps: a profile of no pixels ([`Profile::empty`]), one pass over
    /// the rows ([`Pass::row`]), then the pixels left out ([`Pass::leave_out_odd`],
    /// [`Pass::leave_out_filled`], [`Pass::leave_out_lone`]). None without a core pixel.
    pub(super) fn of(
        img: &[f32; IMG_PIXELS],
        xy: &Coords,
        g: &Geometry,
        u_core: f32,
        bad_k: f32,
        filled: &FilledRows,
    ) -> Option<Profile> {
        let mut p = Profile::empty(img, xy, g);
        let mut pass = Pass::new(u_core, bad_k);
        let mut odd = Odd::new();
        let columns = Columns::of(g, u_core);
        for r in 0..IMG_ROWS {
            pass.row(&mut p, &mut odd, img, xy, r, columns.of_row(r));
        }
        pass.leave_out_odd(&mut p, &odd, filled);
        pass.leave_out_filled(&mut p, img, xy, &columns, filled);
        pass.leave_out_lone(&mut p);
        p.lo = pass.lo;
        p.hi = pass.hi;
        (p.total > 0.0).then(|| {
            p.mean_dev = pass.s / p.total;
            p
        })
    }

    /// A profile of no pixels for image `img` and the axis of `g`: its bins from the floor of
    /// the image's smallest axial coordinate (at a corner), and its values to be kept less a
    /// reference near the core's, for the sums' precision: the pixel on the axis in the middle
    /// row (the nearest column in the image).
    #[inline(always)]
    fn empty(img: &[f32; IMG_PIXELS], xy: &Coords, g: &Geometry) -> Profile {
        let corners = [0, IMG_COLS - 1, (IMG_ROWS - 1) * IMG_COLS, IMG_PIXELS - 1];
        let mut tmin = f32::INFINITY;
        for p in corners {
            if xy.t[p] < tmin {
                tmin = xy.t[p];
            }
        }
        let mid = IMG_ROWS / 2;
        let axis_col = floor(g.axis_col0 + g.axis_slope * mid as f32 + 0.5);
        let axis = mid * IMG_COLS + min(max(0.0, axis_col), (IMG_COLS - 1) as f32) as usize;
        Profile {
            bins: [Bin::default(); FINE_BINS],
            used: 0,
            t0: floor(tmin),
            reference: img[axis],
            total: 0.0,
            mean_dev: 0.0,
            sq: 0.0,
            lo: f32::INFINITY,
            hi: f32::NEG_INFINITY,
        }
    }

    /// Put the pixel of value `v` at axial position `t` into its bin and the core's sums, and
    /// into the running sum `s` of values less the reference; gives its bin.
    #[inline(always)]
    fn add(&mut self, v: f32, t: f32, s: &mut f32) -> usize {
        let q = fine_place(t, self.t0);
        let b = (q as usize).min(FINE_BINS - 1);
        let y = v - self.reference;
        let tau = q - b as f32;
        let bin = &mut self.bins[b];
        bin.sum += y;
        bin.cnt += 1.0;
        bin.tsum += t;
        bin.tt += tau * tau;
        bin.ty += tau * y;
        self.total += 1.0;
        self.sq += y * y;
        *s += y;
        if b >= self.used {
            self.used = b + 1;
        }
        b
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

/// The columns of each row that the core can reach: it lies within u_core·w·√(1 + slope²)
/// columns of the axis, and only those columns (and one more either side, for rounding) are
/// looked at, in the same order.
struct Columns {
    /// The axis's column in row 0.
    col0: f32,
    /// The axis's slope, columns per row.
    slope: f32,
    /// How far the core reaches either side of the axis, columns.
    reach: f32,
}

impl Columns {
    /// The columns of a core of distance ratio `u_core` about the axis of `g`.
    #[inline(always)]
    fn of(g: &Geometry, u_core: f32) -> Columns {
        let reach =
            u_core * g.half_width_px * crate::fmath::sqrt(1.0 + g.axis_slope * g.axis_slope);
        Columns {
            col0: g.axis_col0,
            slope: g.axis_slope,
            reach,
        }
    }

    /// The columns of row `r` looked at: first..end, within the image.
    #[inline(always)]
    fn of_row(&self, r: usize) -> Range<usize> {
        let centre = self.col0 + self.slope * r as f32;
        let first = (floor(centre - self.reach) as i32).clamp(0, IMG_COLS as i32) as usize;
        let end = (floor(centre + self.reach) as i32 + 2).clamp(0, IMG_COLS as i32) as usize;
        first.min(end)..end
    }
}

/// Whether pixel `q` is one of the `filled` (broken and filled in from its neighbours).
#[inline(always)]
fn is_filled(filled: &FilledRows, q: usize) -> bool {
    (filled[q / IMG_COLS] >> (q % IMG_COLS)) & 1 != 0
}

/// The core's pixels beyond both row neighbours, as the pass notes them: the first
/// [`ODD_MAX`], and how many there are. Kept apart from [`Pass`]: the pixels, indexed by their
/// count, stay in memory, and the pass's other state in registers.
struct Odd {
    /// The first [`ODD_MAX`] (value, axial position, index).
    pixels: [(f32, f32, usize); ODD_MAX],
    /// How many pixels lie beyond both row neighbours (past [`ODD_MAX`] too).
    n: usize,
}

impl Odd {
    /// None noted yet.
    #[inline(always)]
    fn new() -> Odd {
        Odd {
            pixels: [(0.0, 0.0, 0); ODD_MAX],
            n: 0,
        }
    }

    /// Note the pixel `(value, axial position, index)` of column `c` of its row `line` if it
    /// lies more than `bad_k` beyond both its row neighbours: the left one first, the right
    /// one only past it — most pixels are not (the pixel itself at the image's sides).
    #[inline(always)]
    fn note(&mut self, line: &[f32; IMG_COLS], c: usize, pixel: (f32, f32, usize), bad_k: f32) {
        let m = IMG_COLS - 1;
        let v = pixel.0;
        let dl = v - line[c.wrapping_sub(1) & m];
        if c > 0 && dl.abs() > bad_k {
            let dr = v - line[(c + 1).min(m)];
            if dl * dr > 0.0 && dr.abs() > bad_k {
                if let Some(o) = self.pixels.get_mut(self.n) {
                    *o = pixel;
                }
                self.n += 1;
            }
        }
    }
}

/// The state of [`Profile::of`]'s pass besides the profile's own sums and the [`Odd`] pixels:
/// the running sum, the core's extremes and second extremes and where they are; and the
/// pass's two thresholds.
struct Pass {
    /// The core's edge: a pixel whose distance ratio `u` is under it is the core's.
    u_core: f32,
    /// How far beyond both row neighbours a pixel must lie to be noted, K.
    bad_k: f32,
    /// Σ of values less the reference, K.
    s: f32,
    /// The highest value, K.
    hi: f32,
    /// The second highest value, K.
    hi2: f32,
    /// (bin, axial position) of the highest.
    hi_at: (usize, f32),
    /// The lowest value, K.
    lo: f32,
    /// The second lowest value, K.
    lo2: f32,
    /// (bin, axial position) of the lowest.
    lo_at: (usize, f32),
    /// Whether the highest is still in the profile (not left out as odd or filled).
    hi_kept: bool,
    /// Whether the lowest is still in the profile.
    lo_kept: bool,
}

impl Pass {
    /// The state before the first pixel, for a core of edge `u_core` and pixels noted `bad_k`
    /// beyond both row neighbours.
    #[inline(always)]
    fn new(u_core: f32, bad_k: f32) -> Pass {
        Pass {
            u_core,
            bad_k,
            s: 0.0,
            hi: f32::NEG_INFINITY,
            hi2: f32::NEG_INFINITY,
            hi_at: (0, 0.0),
            lo: f32::INFINITY,
            lo2: f32::INFINITY,
            lo_at: (0, 0.0),
            hi_kept: true,
            lo_kept: true,
        }
    }

    /// Take the core's pixels of row `r` among `columns` into the profile `p`, noting the
    /// extremes, and those beyond both row neighbours in `odd`.
    #[inline(always)]
    fn row(
        &mut self,
        p: &mut Profile,
        odd: &mut Odd,
        img: &[f32; IMG_PIXELS],
        xy: &Coords,
        r: usize,
        columns: Range<usize>,
    ) {
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
        for c in columns {
            if us[c & m] < self.u_core {
                let (t, v) = (ts[c & m], line[c & m]);
                odd.note(line, c, (v, t, row + c), self.bad_k);
                let b = p.add(v, t, &mut self.s);
                self.extremes(v, (b, t));
            }
        }
    }

    /// Note the value `v` at (bin, axial position) `at` among the extremes and second
    /// extremes. Most pixels pass neither second extreme: one comparison each.
    #[inline(always)]
    fn extremes(&mut self, v: f32, at: (usize, f32)) {
        if v < self.lo2 {
            if v < self.lo {
                self.lo2 = self.lo;
                self.lo = v;
                self.lo_at = at;
            } else {
                self.lo2 = v;
            }
        }
        if v > self.hi2 {
            if v > self.hi {
                self.hi2 = self.hi;
                self.hi = v;
                self.hi_at = at;
            } else {
                self.hi2 = v;
            }
        }
    }

    /// Leave the pixel of value `v` at axial position `t` out of the profile `p` and the
    /// running sum. If it is the highest (or lowest), the second takes its place, which may
    /// be another pixel left out: the core's range serves only the fallback's bound, which it
    /// widens.
    #[inline(always)]
    fn leave_out(&mut self, p: &mut Profile, v: f32, t: f32) {
        let b = (fine_place(t, p.t0) as usize).min(FINE_BINS - 1);
        p.drop(v, (b, t), &mut self.s);
        if (v, t) == (self.hi, self.hi_at.1) {
            self.hi = self.hi2;
            self.hi_kept = false;
        }
        if (v, t) == (self.lo, self.lo_at.1) {
            self.lo = self.lo2;
            self.lo_kept = false;
        }
    }

    /// Leave the `odd` pixels, beyond both row neighbours, out of the profile `p` if there are
    /// at most [`ODD_MAX`]: hot or dead pixels the EEPROM does not flag. More are the
    /// lattice's own, thin stripes crossing the rows at a slant, and stay. Those `filled` are
    /// left to [`Pass::leave_out_filled`]: each is left out once.
    #[inline(always)]
    fn leave_out_odd(&mut self, p: &mut Profile, odd: &Odd, filled: &FilledRows) {
        if odd.n <= ODD_MAX {
            for &(v, t, q) in &odd.pixels[..odd.n] {
                if !is_filled(filled, q) {
                    self.leave_out(p, v, t);
                }
            }
        }
    }

    /// Leave every core pixel among `columns` that was broken and filled in from its
    /// neighbours (`filled`) out of the profile `p`: it is no measurement of its place (across
    /// a thin stripe, the mean of both targets). Rows without any are skipped.
    #[inline(always)]
    fn leave_out_filled(
        &mut self,
        p: &mut Profile,
        img: &[f32; IMG_PIXELS],
        xy: &Coords,
        columns: &Columns,
        filled: &FilledRows,
    ) {
        for (r, &fill) in filled.iter().enumerate() {
            if fill == 0 {
                continue;
            }
            for c in columns.of_row(r) {
                let q = r * IMG_COLS + c;
                if (fill >> c) & 1 != 0 && xy.u[q] < self.u_core {
                    self.leave_out(p, img[q], xy.t[q]);
                }
            }
        }
    }

    /// Leave a lone extreme out of the profile `p`: a pixel more than [`LONE_PIXEL_K`] beyond
    /// every other in a core of more than [`LONE_MIN_PIXELS`] (a hot or dead pixel the EEPROM
    /// does not flag; one such pixel shifts its bin by its whole excess), unless it is already
    /// left out. The second extreme takes its place.
    #[inline(always)]
    fn leave_out_lone(&mut self, p: &mut Profile) {
        if self.hi_kept && p.total > LONE_MIN_PIXELS && self.hi - self.hi2 > LONE_PIXEL_K {
            p.drop(self.hi, self.hi_at, &mut self.s);
            self.hi = self.hi2;
        }
        if self.lo_kept && p.total > LONE_MIN_PIXELS && self.lo2 - self.lo > LONE_PIXEL_K {
            p.drop(self.lo, self.lo_at, &mut self.s);
            self.lo = self.lo2;
        }
    }
}
