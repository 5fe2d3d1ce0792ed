//! Region identification: which cluster is the heater area, the SMP surface, the edges, the
//! radiation zone and the background — by where its pixels lie, not by its temperature rank.
//!
//! Method (at the sensor's 32×24 resolution, on the inpainted image):
//! 1. Contrast: background level `bg` = the median of the outer columns, contrast = the 95th
//!    percentile of |value − bg| (the cylinder may be warmer or colder than the background).
//!    Below [`MIN_CONTRAST_K`] of contrast the geometry is not re-estimated: the previous
//!    frame's is kept (or, on the first frame, a centred vertical cylinder of the default
//!    width).
//! 2. Cylinder: pixels farther than ½·contrast from bg form a mask; in each row that holds a
//!    run of 3 px, an outermost run of at most 2 px within [`SPRING_GAP_PX`] of the next (a
//!    hot spring, a hot pixel) is dropped; each row's mask centroid and width give, by
//!    weighted least squares, the axis `col = a + b·row` (shift and tilt) and the half-width
//!    `w` (median row width, perpendicular). Every pixel gets a perpendicular
//!    distance ratio u = |d|/w and an axial coordinate t along the axis.
//! 3. Zones: u < [`CORE_U`] core, < [`EDGE_U`] edge (region 3), < [`RADIATION_U`] radiation
//!    (region 4), else background (region 5).
//! 4. Lattice: fitted by [`super::lattice`] (period, phase, exposed fraction and which target
//!    is hotter); a core pixel whose axial coordinate falls in a gap is heater area (region 1),
//!    else SMP surface (region 2).
//! 5. Assignment: each pixel's cluster is its temperature's cluster; the zone × cluster
//!    overlap, each row normalised by the zone's size, is assigned greedily one to one
//!    (largest share first); when there are fewer clusters than zones the remaining zones take
//!    their largest-share cluster. A region's temperature is its cluster's mean.

use super::cluster::{Clusters, MAX_K};
use super::{IMG_COLS, IMG_PIXELS, IMG_ROWS, REGIONS};
use crate::block::LATTICE_GAP_FRACTION;
use crate::fmath::floor;

/// Least contrast (95th − 20th percentile) to re-estimate the cylinder, K.
pub const MIN_CONTRAST_K: f32 = 1.0;
/// Core zone: distance ratio below this.
pub const CORE_U: f32 = 0.75;
/// Edge zone (region 3): distance ratio below this.
pub const EDGE_U: f32 = 1.15;
/// Radiation zone (region 4): distance ratio below this.
pub const RADIATION_U: f32 = 1.6;
/// Default half-width when nothing was ever detected, pixels.
pub const DEFAULT_HALF_WIDTH_PX: f32 = 8.0;

/// Zone of a pixel, in region order (index = region − 1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Zone {
    /// Region 1: lattice gaps, PI heater visible.
    Heater = 0,
    /// Region 2: SMP outer surface (lattice rings).
    Surface = 1,
    /// Region 3: cylinder edges.
    Edge = 2,
    /// Region 4: radiation zone beside the cylinder.
    Radiation = 3,
    /// Region 5: background.
    Background = 4,
}

/// The cylinder's position in the image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geometry {
    /// Axis column at row 0, pixels.
    pub axis_col0: f32,
    /// Axis slope, columns per row (tilt = atan of it).
    pub axis_slope: f32,
    /// Half-width perpendicular to the axis, pixels.
    pub half_width_px: f32,
    /// Lattice period along the axis, pixels.
    pub period_px: f32,
    /// Axial position where a gap starts, pixels (0 ≤ phase < period).
    pub phase_px: f32,
    /// Fraction of each lattice unit where the heater shows (from `phase_px`).
    pub exposed: f32,
    /// Whether the lattice has ever been fitted (else every core pixel is heater area).
    pub lattice_known: bool,
    /// The last decided answer to "is the heater area the hotter target?" (continuity).
    pub heater_hotter: Option<bool>,
    /// What the frames said about the lattice's exposed fraction against its design.
    pub exposure: super::lattice::Exposure,
}

impl Default for Geometry {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl Geometry {
    /// A centred vertical cylinder of the default width, lattice unknown.
    pub const DEFAULT: Geometry = Geometry {
        axis_col0: (IMG_COLS as f32 - 1.0) / 2.0,
        axis_slope: 0.0,
        half_width_px: DEFAULT_HALF_WIDTH_PX,
        period_px: 16.0,
        phase_px: 0.0,
        exposed: LATTICE_GAP_FRACTION,
        lattice_known: false,
        heater_hotter: None,
        exposure: super::lattice::Exposure::NONE,
    };

    /// Return (distance ratio u, axial coordinate t) of a pixel.
    pub fn coords(&self, row: usize, col: usize) -> (f32, f32) {
        let norm = crate::fmath::sqrt(1.0 + self.axis_slope * self.axis_slope);
        let d = (col as f32 - (self.axis_col0 + self.axis_slope * row as f32)) / norm;
        let t = (row as f32 + self.axis_slope * (col as f32 - self.axis_col0)) / norm;
        (libm::fabsf(d) / self.half_width_px, t)
    }

    /// Return every pixel's (u, t), as [`Geometry::coords`], computed incrementally.
    pub fn coords_all(&self) -> Coords {
        let mut out = Coords::ZERO;
        self.coords_into(&mut out);
        out
    }

    /// Write every pixel's (u, t) into `out` (no 6 KB copy, for the Cortex-M4).
    pub fn coords_into(&self, out: &mut Coords) {
        let inv_norm = 1.0 / crate::fmath::sqrt(1.0 + self.axis_slope * self.axis_slope);
        let inv_half = inv_norm / self.half_width_px;
        for r in 0..IMG_ROWS {
            let d0 = -(self.axis_col0 + self.axis_slope * r as f32);
            let t0 = (r as f32 - self.axis_slope * self.axis_col0) * inv_norm;
            let dt = self.axis_slope * inv_norm;
            // The column as a float, counted (exact: small integers), not converted per pixel.
            let mut col = 0f32;
            let row_u = &mut out.u[r * IMG_COLS..(r + 1) * IMG_COLS];
            let row_t = &mut out.t[r * IMG_COLS..(r + 1) * IMG_COLS];
            for (u, t) in row_u.iter_mut().zip(row_t.iter_mut()) {
                *u = libm::fabsf(col + d0) * inv_half;
                *t = t0 + col * dt;
                col += 1.0;
            }
        }
    }

    /// Return whether axial coordinate `t` falls in a gap.
    pub fn in_gap(&self, t: f32) -> bool {
        if !self.lattice_known {
            return true;
        }
        let x = t - self.phase_px;
        let ph = x - floor(x / self.period_px) * self.period_px;
        ph < self.exposed * self.period_px
    }

    /// Return the zone of a pixel.
    pub fn zone(&self, row: usize, col: usize) -> Zone {
        let (u, t) = self.coords(row, col);
        self.zone_of(u, t)
    }

    /// Return the zone of a pixel at distance ratio `u`, axial coordinate `t`.
    pub fn zone_of(&self, u: f32, t: f32) -> Zone {
        if u < CORE_U {
            if self.in_gap(t) {
                Zone::Heater
            } else {
                Zone::Surface
            }
        } else if u < EDGE_U {
            Zone::Edge
        } else if u < RADIATION_U {
            Zone::Radiation
        } else {
            Zone::Background
        }
    }
}

/// Every pixel's distance ratio and axial coordinate under a geometry.
pub struct Coords {
    /// Perpendicular distance from the axis over the half-width.
    pub u: [f32; IMG_PIXELS],
    /// Position along the axis, pixels.
    pub t: [f32; IMG_PIXELS],
}

impl Coords {
    /// All zero (storage for [`Geometry::coords_into`]).
    pub const ZERO: Coords = Coords {
        u: [0.0; IMG_PIXELS],
        t: [0.0; IMG_PIXELS],
    };
}

/// What the region finder could estimate this frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Fresh {
    /// The cylinder was re-estimated (else the previous geometry was kept).
    pub cylinder_fresh: bool,
    /// The re-estimated axis slope from the rows the image's sides do not clip
    /// ([`CylinderFit::tilt_slope`]), columns per row; 0 when the cylinder was not
    /// re-estimated.
    pub tilt_slope: f32,
    /// Its standard error, columns per row ([`CylinderFit::slope_se`]).
    pub tilt_slope_se: f32,
}

/// A cylinder fitted to one image ([`fit_cylinder`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CylinderFit {
    /// Axis column at row 0, pixels: of the line through the unclipped rows when there are
    /// four (`tilt_slope` finite), else of the line through every row.
    pub col0: f32,
    /// Axis slope, columns per row: `tilt_slope` when finite, else the line through every row
    /// (whose clipped rows pull a steep tilt short: 32° read as 22°, and the lattice's axial
    /// coordinate then smears its stripes — T2 2.4 K off on a thin-stripe member).
    pub slope: f32,
    /// The axis slope fitted to the rows the image's side columns do not clip (a row whose
    /// mask reaches the first or last column has its centroid pulled inwards: a steep tilt
    /// would read short), columns per row; NaN with fewer than four such rows. The posture
    /// estimate's tilt, and the zones' when it exists.
    pub tilt_slope: f32,
    /// Standard error of `tilt_slope`, columns per row: the rows' centroid scatter about that
    /// axis (each row weighted by its pixel count) through the least-squares design.
    pub slope_se: f32,
    /// Half-width perpendicular to the axis, pixels.
    pub half_width_px: f32,
}

/// Return the 95th percentile of |v − bg|, to 1/256 of its range, for an image whose values
/// span `range_k` (lowest, highest): a counting pass over 256 bins (a copy and a selection
/// would cost ten times as much on the Cortex-M4). The largest |v − bg| is that of an end of
/// the range (float subtraction is monotonic), so it is not searched for.
fn deviation_95(v: &[f32; IMG_PIXELS], bg: f32, range_k: (f32, f32)) -> f32 {
    let hi = (range_k.1 - bg).max(bg - range_k.0).max(0.0);
    if hi <= 0.0 {
        return 0.0;
    }
    let scale = 255.0 / hi;
    let mut count = [0u16; 256];
    for &x in v.iter() {
        count[(libm::fabsf(x - bg) * scale) as usize & 255] += 1;
    }
    // The percentile is the lowest bin whose count with every bin below it exceeds `target`:
    // the lowest above which fewer than `IMG_PIXELS − target` values lie. Counted down from
    // the top, the scan passes only the highest 5 % of the values' bins, not the other 95 %.
    let target = (0.95 * (IMG_PIXELS - 1) as f32) as u32;
    let above = IMG_PIXELS as u32 - target;
    let mut acc = 0u32;
    for (b, &c) in count.iter().enumerate().rev() {
        acc += c as u32;
        if acc >= above {
            return (b as f32 + 0.5) / scale;
        }
    }
    hi
}

/// Return the median of the outer columns (finite values): the mean of the 24th and 25th of
/// their 48 values in order, by [`select`].
fn border_median(img: &[f32; IMG_PIXELS]) -> f32 {
    let mut b = [0f32; 2 * IMG_ROWS];
    for (r, pair) in b.chunks_exact_mut(2).enumerate() {
        pair[0] = img[r * IMG_COLS];
        pair[1] = img[r * IMG_COLS + IMG_COLS - 1];
    }
    let k = IMG_ROWS;
    let above = select(&mut b, k);
    let mut below = b[0];
    for &v in &b[1..k] {
        if v > below {
            below = v;
        }
    }
    0.5 * (below + above)
}

/// Return the `k`th smallest of `b` (0-based; finite values, `k < b.len()`), leaving every
/// value before it no higher. A selection, not a sort: Hoare's partition about the middle
/// element narrows the range holding the `k`th until it is one value. By hand: `core`'s
/// `select_nth_unstable_by` takes 3.8 KB of flash the board does not have, and its sort 4.9 KB;
/// the insertion sort before took 3 200 more Cortex-M4 instructions for the border's median.
fn select(b: &mut [f32], k: usize) -> f32 {
    let (mut lo, mut hi) = (0, b.len() - 1);
    while lo < hi {
        let pivot = b[(lo + hi) / 2];
        let (mut i, mut j) = (lo, hi);
        // Hoare: afterwards b[lo..=j] ≤ pivot ≤ b[j + 1..=hi], lo ≤ j < hi (the pivot stops
        // both scans, so neither runs off the range).
        loop {
            while b[i] < pivot {
                i += 1;
            }
            while b[j] > pivot {
                j -= 1;
            }
            if i >= j {
                break;
            }
            b.swap(i, j);
            i += 1;
            j -= 1;
        }
        if k <= j {
            hi = j;
        } else {
            lo = j + 1;
        }
    }
    b[k]
}

/// Return the 20th and 95th percentiles of `v`, to 1/256 of its range.
#[cfg(test)]
fn percentiles_20_95(v: &[f32; IMG_PIXELS]) -> (f32, f32) {
    let (mut lo, mut hi) = (v[0], v[0]);
    for &x in v.iter() {
        if x < lo {
            lo = x;
        }
        if x > hi {
            hi = x;
        }
    }
    let span = hi - lo;
    if span <= 0.0 {
        return (lo, hi);
    }
    let scale = 255.0 / span;
    let mut count = [0u16; 256];
    for &x in v.iter() {
        count[((x - lo) * scale) as usize & 255] += 1;
    }
    let at = |q: f32| {
        let target = (q * (IMG_PIXELS - 1) as f32) as u32;
        let mut acc = 0u32;
        for (b, &c) in count.iter().enumerate() {
            acc += c as u32;
            if acc > target {
                return lo + (b as f32 + 0.5) / scale;
            }
        }
        hi
    };
    (at(0.20), at(0.95))
}

/// Re-estimate the cylinder from an image (finite values) whose values span `range_k` (lowest,
/// highest, K: [`range_k`], or what inpainting found); `None` when the contrast is too low or
/// too few rows show it.
pub fn fit_cylinder(img: &[f32; IMG_PIXELS], range_k: (f32, f32)) -> Option<CylinderFit> {
    // The background: the median of the outer columns (the cylinder is near the middle). The
    // cylinder may be warmer or colder than it (a cold block in a warm room, or a heater
    // colder than the background in forming), so the mask is on the distance from it.
    let bg = border_median(img);
    let top = deviation_95(img, bg, range_k);
    if top < MIN_CONTRAST_K {
        return None;
    }
    let thr = 0.5 * top;
    let mut widths = [0f32; IMG_ROWS];
    let mut centroids = [(0f32, 0f32, 0f32); IMG_ROWS];
    let mut unclipped = 0;
    let mut nrows = 0;
    let (mut sw, mut sx, mut sy, mut sxx, mut sxy) = (0f32, 0f32, 0f32, 0f32, 0f32);
    for r in 0..IMG_ROWS {
        let row = &img[r * IMG_COLS..(r + 1) * IMG_COLS];
        let mut mask = 0u32;
        for (c, &v) in row.iter().enumerate() {
            mask |= u32::from(libm::fabsf(v - bg) > thr) << c;
        }
        let body = row_body(mask);
        if body.n >= 3 {
            let n = body.n as f32;
            let x = r as f32;
            let y = body.sum_col as f32 / n;
            sw += n;
            sx += n * x;
            sy += n * y;
            sxx += n * x * x;
            sxy += n * x * y;
            widths[nrows] = n;
            if !body.clipped {
                centroids[unclipped] = (x, y, n);
                unclipped += 1;
            }
            nrows += 1;
        }
    }
    if nrows < 4 {
        return None;
    }
    let det = sw * sxx - sx * sx;
    let slope = if det.abs() > 1e-3 {
        (sw * sxy - sx * sy) / det
    } else {
        0.0
    };
    let col0 = (sy - slope * sx) / sw;
    let (tilt_slope, slope_se, tilt_col0) = line_fit(&centroids[..unclipped]);
    let (col0, slope) = if tilt_slope.is_finite() {
        (tilt_col0, tilt_slope)
    } else {
        (col0, slope)
    };
    let median = select(&mut widths[..nrows], nrows / 2);
    let half = 0.5 * median / crate::fmath::sqrt(1.0 + slope * slope);
    Some(CylinderFit {
        col0,
        slope,
        tilt_slope,
        slope_se,
        half_width_px: half.max(1.0),
    })
}

/// The cylinder's pixels in one row ([`row_body`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct RowBody {
    /// Pixels.
    n: u32,
    /// Sum of their column indices.
    sum_col: u32,
    /// They reach the first or the last column.
    clipped: bool,
}

/// Widest gap between an outermost narrow run and the next run for the narrow one to be
/// dropped as a spring's, pixels (the rows of [`fit_cylinder`]). A spring 1.5 px off the
/// column's side leaves at most 2 px between; the rings' edge across a gap row whose heater is
/// near the room's temperature lies a column's width from the other edge. Tuned on the seen
/// family members (`host_sim::imaging::view_family`, |gap| ≥ 3 K, mean |T1|, |T2|, a throwaway
/// host experiment): no limit 0.078, 0.111 K; 1 px 0.078, 0.110; 2 px 0.077, 0.109; 3 px
/// 0.077, 0.108; 4 px 0.078, 0.109; 6 px 0.078, 0.110 K. Unseen members with 3 px: 0.073,
/// 0.110 → 0.073, 0.108 K; exposed 0.75–0.85 at 6–10 px 0.46 → 0.44 K
/// (`bash scripts/work-precision`).
pub const SPRING_GAP_PX: u32 = 3;

/// The cylinder's own pixels in one row's mask (bit c: column c lies beyond the threshold):
/// the outermost run of set bits on either side is dropped when it is at most 2 px wide, at
/// most [`SPRING_GAP_PX`] from the next run, and the row also holds a run at least 3 px wide.
/// A hot spring beside the column (0.5 px wide, 1.5 px off its side) lights one or two pixels
/// apart from it, and where the other spring lies off the image its row's centroid would be
/// pulled towards the one in view: at a 25° lean the fitted tilt read ≈ 2.8° short (a 5.6°
/// bend). A broken or hot pixel just off the column goes the same way. A narrow run farther
/// out is the column's own: the rings' edge of a gap row whose heater is near the room's
/// temperature, whose other edge is a 3 px run (dropping it put the row's centroid on that
/// edge: unseen member 1000842's tilt −0.087 read −0.013, now −0.052). A row of narrow runs
/// only is left whole for the same reason. Such a row's width is its pixel count, narrower
/// than the column (its span would be the column's, but measuring every row's width by its
/// span took the seen members' mean |T2| from 0.108 to 0.113 K: a core that reaches the edges
/// costs more than a narrow one). Works run by run, not pixel by pixel (a row holds a handful
/// of runs), keeping only the runs the rule looks at (the bench's `fit_cylinder`: an array of
/// every run, zeroed per row, took 24 400 instructions, this 23 200).
fn row_body(mask: u32) -> RowBody {
    // Runs as (first column, end column exclusive). The rule looks only at the first two, the
    // last two and the widest, so those and the totals are kept, not every run (an array of
    // the 16 a row can hold, zeroed per row, cost more than the rule).
    let (mut first, mut second, mut before, mut last) = ((0u32, 0u32), (0, 0), (0, 0), (0, 0));
    let (mut k, mut widest, mut n, mut sum_col) = (0u32, 0, 0, 0);
    let mut x = mask;
    while x != 0 {
        let a = x.trailing_zeros();
        // The run's length: the trailing ones of x >> a (32 when the whole row is set).
        let e = a + (!(x >> a)).trailing_zeros();
        if k == 0 {
            first = (a, e);
        } else if k == 1 {
            second = (a, e);
        }
        before = last;
        last = (a, e);
        k += 1;
        widest = widest.max(e - a);
        n += e - a;
        sum_col += (a + e - 1) * (e - a) / 2;
        x &= (u64::from(u32::MAX) << e) as u32;
    }
    // A single run is the body whatever its width; the widest run stays, so with two runs at
    // most one goes.
    let spring = |run: (u32, u32), gap_px: u32| run.1 - run.0 <= 2 && gap_px <= SPRING_GAP_PX;
    let drop_first = widest >= 3 && k >= 2 && spring(first, second.0 - first.1);
    let drop_last = widest >= 3 && k >= 2 && spring(last, last.0 - before.1);
    let mut body = RowBody {
        n,
        sum_col,
        clipped: false,
    };
    let (mut kept_first, mut kept_last) = (first, last);
    if drop_first {
        body.n -= first.1 - first.0;
        body.sum_col -= (first.0 + first.1 - 1) * (first.1 - first.0) / 2;
        kept_first = second;
    }
    if drop_last {
        body.n -= last.1 - last.0;
        body.sum_col -= (last.0 + last.1 - 1) * (last.1 - last.0) / 2;
        kept_last = before;
    }
    body.clipped = k > 0 && (kept_first.0 == 0 || kept_last.1 == IMG_COLS as u32);
    body
}

/// Return the lowest and highest value of an image (finite values), K.
pub fn range_k(img: &[f32; IMG_PIXELS]) -> (f32, f32) {
    img.iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        })
}

/// The weighted least-squares slope of `col = a + slope·row` through rows' (row, centroid,
/// pixel count), its standard error (the residual variance per unit weight, rows − 2 degrees
/// of freedom, times sw/det, the slope's entry of the inverse normal matrix) and `a`. NaN,
/// infinity and NaN with fewer than four rows.
fn line_fit(rows: &[(f32, f32, f32)]) -> (f32, f32, f32) {
    if rows.len() < 4 {
        return (f32::NAN, f32::INFINITY, f32::NAN);
    }
    let (mut sw, mut sx, mut sy, mut sxx, mut sxy) = (0f32, 0f32, 0f32, 0f32, 0f32);
    for &(x, y, n) in rows {
        sw += n;
        sx += n * x;
        sy += n * y;
        sxx += n * x * x;
        sxy += n * x * y;
    }
    let det = sw * sxx - sx * sx;
    if det <= 1e-3 {
        return (f32::NAN, f32::INFINITY, f32::NAN);
    }
    let slope = (sw * sxy - sx * sy) / det;
    let col0 = (sy - slope * sx) / sw;
    let ss: f32 = rows
        .iter()
        .map(|&(x, y, n)| n * (y - col0 - slope * x) * (y - col0 - slope * x))
        .sum();
    (
        slope,
        crate::fmath::sqrt(ss / (rows.len() as f32 - 2.0) * sw / det),
        col0,
    )
}

/// Update the cylinder from a frame whose values span `range_k` (keeping the previous one when it cannot be
/// re-estimated); `xy` receives every pixel's coordinates under the new geometry. The lattice
/// is left to [`super::lattice::separate`].
pub fn update_geometry(
    img: &[f32; IMG_PIXELS],
    range_k: (f32, f32),
    prev: &Geometry,
    xy: &mut Coords,
) -> (Geometry, Fresh) {
    let mut g = *prev;
    let mut q = Fresh::default();
    if let Some(fit) = fit_cylinder(img, range_k) {
        g.axis_col0 = fit.col0;
        g.axis_slope = fit.slope;
        g.half_width_px = fit.half_width_px;
        q.cylinder_fresh = true;
        q.tilt_slope = fit.tilt_slope;
        q.tilt_slope_se = fit.slope_se;
    }
    g.coords_into(xy);
    (g, q)
}

/// Zone × cluster pixel counts.
pub type Overlap = [[u16; MAX_K]; REGIONS];

/// Count, for every pixel, its zone and its value's cluster.
pub fn overlap(img: &[f32; IMG_PIXELS], g: &Geometry, xy: &Coords, cl: &Clusters) -> Overlap {
    overlap_and_min(img, g, xy, cl).0
}

/// [`overlap`], with the lowest value over the cylinder (core and edges, zones 1–3), `None`
/// when no pixel lies on it — one pass instead of two. (The hottest pixel MTTS reports is the
/// whole frame's, [`super::Scratch::hottest_k`]: a spring switched on by a shorted MOSFET runs
/// beside the cylinder, and a wire hundreds of kelvin above the block pulls the geometry fit
/// off it — a 550 K spring on a tilted column: a fitted half-width of 1.4 px instead of 8.)
///
/// Each pixel's zone and cluster are [`Geometry::zone_of`]'s and [`Clusters::label`]'s, to the
/// bit for any input, at 36 Cortex-M4 instructions a pixel instead of 54 (the bench's frame:
/// 41 200 → 27 500): a value between the boundaries of the last value's cluster takes that
/// cluster without the search (neighbouring pixels mostly share one: on the bench's frame 23 %
/// of the values search); a core pixel whose t has the last core pixel's bits takes its zone without
/// `in_gap` (along an upright axis a row's core is one t; a tilted axis pays `in_gap` per core
/// pixel); `label`'s `min(k − 1)` is applied to the counts at the end; and only the cylinder's
/// values are compared with the lowest.
pub fn overlap_and_min(
    img: &[f32; IMG_PIXELS],
    g: &Geometry,
    xy: &Coords,
    cl: &Clusters,
) -> (Overlap, Option<f32>) {
    let mut o = [[0u16; MAX_K]; REGIONS];
    let mut lo = f32::INFINITY;
    let upper = &cl.upper;
    // The boundaries around the search's answer c are bounds[c] and bounds[c + 1] when the
    // seven it reads ascend without NaN (the answer is then the count of boundaries at or below
    // the value), else NaN: no value lies between.
    let mut bounds = [f32::NAN; MAX_K + 1];
    if upper[..MAX_K - 1].windows(2).all(|w| w[0] <= w[1]) {
        bounds[0] = f32::NEG_INFINITY;
        bounds[1..MAX_K].copy_from_slice(&upper[..MAX_K - 1]);
        bounds[MAX_K] = f32::INFINITY;
    }
    // The last value's cluster and the boundaries around it (NaN before the first value).
    let (mut c, mut below, mut above) = (0, f32::NAN, f32::NAN);
    // The last core pixel's t, by its bits, and its zone (`in_gap` is a function of t).
    let mut t_last = f32::NAN.to_bits();
    let mut core = usize::from(!g.in_gap(f32::from_bits(t_last)));
    for (p, (&x, &u)) in img.iter().zip(&xy.u).enumerate() {
        if !(x >= below && x < above) {
            c = search(upper, x);
            (below, above) = (bounds[c], bounds[c + 1]);
        }
        // `zone_of`'s comparisons, in its order.
        if u < CORE_U {
            let t = xy.t[p].to_bits();
            if t != t_last {
                t_last = t;
                core = usize::from(!g.in_gap(f32::from_bits(t)));
            }
            o[core][c] += 1;
            // Plain comparisons: `f32::min` is a library call on the Cortex-M4.
            if x < lo {
                lo = x;
            }
        } else if u < EDGE_U {
            o[Zone::Edge as usize][c] += 1;
            if x < lo {
                lo = x;
            }
        } else if u < RADIATION_U {
            o[Zone::Radiation as usize][c] += 1;
        } else {
            o[Zone::Background as usize][c] += 1;
        }
    }
    // `label`'s min(k − 1), on the counts: the searches past k − 1 go to k − 1 (a value of +∞
    // with fewer than eight clusters, the boundaries from k − 1 on being +∞).
    let last = cl.k.saturating_sub(1);
    let flat = o.as_flattened_mut();
    for i in last + 1..flat.len() {
        let c = i % MAX_K;
        if c > last {
            flat[i - c + last] += flat[i];
            flat[i] = 0;
        }
    }
    (o, lo.is_finite().then_some(lo))
}

/// [`Clusters::label`]'s three-step search over the boundaries `upper`, without its
/// `min(k − 1)`: the count of boundaries at or below `v` when they ascend.
#[inline(always)]
fn search(upper: &[f32; MAX_K], v: f32) -> usize {
    let mut c = if v >= upper[3] { 4 } else { 0 };
    if v >= upper[(c + 1) & (MAX_K - 1)] {
        c += 2;
    }
    if v >= upper[c & (MAX_K - 1)] {
        c += 1;
    }
    c & (MAX_K - 1)
}

/// Assign a cluster to every region (see the module doc); `None` for a zone with no pixels
/// when no cluster is left to give it.
pub fn assign(o: &Overlap, k: usize) -> [Option<usize>; REGIONS] {
    let size: [u32; REGIONS] = core::array::from_fn(|z| o[z].iter().map(|&n| n as u32).sum());
    let share = |z: usize, c: usize| {
        if size[z] == 0 {
            0.0
        } else {
            o[z][c] as f32 / size[z] as f32
        }
    };
    let mut out = [None; REGIONS];
    let mut used = [false; MAX_K];
    loop {
        let mut best: Option<(usize, usize, f32)> = None;
        for z in 0..REGIONS {
            if out[z].is_some() || size[z] == 0 {
                continue;
            }
            for (c, &u) in used.iter().enumerate().take(k) {
                let s = share(z, c);
                if !u && s > 0.0 && best.is_none_or(|b| s > b.2) {
                    best = Some((z, c, s));
                }
            }
        }
        match best {
            Some((z, c, _)) => {
                out[z] = Some(c);
                used[c] = true;
            }
            None => break,
        }
    }
    // Zones left over (more zones than clusters, or no free cluster present): their largest
    // share, reused.
    for z in 0..REGIONS {
        if out[z].is_none() && size[z] > 0 {
            out[z] = (0..k).max_by(|&a, &b| share(z, a).total_cmp(&share(z, b)));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cylinder_image(col0: f32, slope: f32, half: f32, inverted: bool) -> [f32; IMG_PIXELS] {
        let g = Geometry {
            axis_col0: col0,
            axis_slope: slope,
            half_width_px: half,
            period_px: 14.0,
            phase_px: 3.0,
            lattice_known: true,
            ..Geometry::DEFAULT
        };
        core::array::from_fn(|p| {
            let (r, c) = (p / IMG_COLS, p % IMG_COLS);
            let (u, t) = g.coords(r, c);
            let (heater, surface) = if inverted {
                (330.0, 345.0)
            } else {
                (360.0, 340.0)
            };
            if u < 1.0 {
                if g.in_gap(t) { heater } else { surface }
            } else if u < 1.6 {
                300.0
            } else {
                298.0
            }
        })
    }

    #[test]
    fn a_heater_at_the_room_s_temperature_leaves_the_column_its_lean() {
        // Thin rings (exposed 0.8 of a 6 px period) 12 K over a heater at the room's
        // temperature: most rows show only the column's two edges, 1 to 3 px wide each.
        for (slope, phase) in [(-0.087, 1.0), (0.2, 0.0), (-0.3, 2.5), (0.1, 4.0)] {
            let g = Geometry {
                axis_col0: 16.9,
                axis_slope: slope,
                half_width_px: 9.6,
                period_px: 6.0,
                phase_px: phase,
                exposed: 0.8,
                lattice_known: true,
                ..Geometry::DEFAULT
            };
            let img: [f32; IMG_PIXELS] = core::array::from_fn(|p| {
                let (u, t) = g.coords(p / IMG_COLS, p % IMG_COLS);
                if u < 0.78 {
                    if g.in_gap(t) { 298.5 } else { 310.0 }
                } else if u < 1.0 {
                    309.0
                } else {
                    298.0
                }
            });
            // The rows' own scatter is small, and the line through them the column's (its
            // width reads narrow, the rows' pixel counts: the lattice's core stays inside it).
            // Dropping the far edge as a spring read −0.3 as −0.18, the slope's error 0.15.
            let fit = fit_cylinder(&img, range_k(&img)).unwrap();
            assert!((fit.slope - slope).abs() < 0.04, "{slope}: {fit:?}");
            assert!(fit.slope_se < 0.08, "{slope}: {fit:?}");
            assert!((fit.col0 - 16.9).abs() < 0.5, "{slope}: {fit:?}");
        }
    }

    #[test]
    fn finds_a_shifted_tilted_cylinder() {
        let img = cylinder_image(13.0, 0.15, 6.0, false);
        let fit = fit_cylinder(&img, range_k(&img)).unwrap();
        let (col0, slope, half) = (fit.col0, fit.slope, fit.half_width_px);
        assert!((col0 - 13.0).abs() < 1.0, "{col0}");
        assert!((slope - 0.15).abs() < 0.05, "{slope}");
        assert!((half - 6.0).abs() < 1.5, "{half}");
        // The slope's standard error covers its error and is finite.
        assert!(fit.slope_se.is_finite() && fit.slope_se >= 0.0, "{fit:?}");
        assert!(
            (fit.tilt_slope - 0.15).abs() < 4.0 * fit.slope_se + 0.01,
            "{fit:?}"
        );
    }

    #[test]
    fn a_steep_tilt_reads_true_from_the_rows_the_sides_do_not_clip() {
        // 32°: below row ≈ 12 the cylinder runs off the image's right side.
        let img = cylinder_image(15.5, 0.62, 8.0, false);
        let fit = fit_cylinder(&img, range_k(&img)).unwrap();
        assert!((fit.tilt_slope - 0.62).abs() < 0.03, "{fit:?}");
        // The zones take the same axis (every row's line read 0.41 here).
        assert_eq!(fit.slope, fit.tilt_slope, "{fit:?}");
        assert!((fit.col0 - 15.5).abs() < 0.5, "{fit:?}");
    }

    #[test]
    fn a_row_sheds_its_narrow_outer_runs_beside_a_wide_one() {
        let body = |cols: &[u32]| row_body(cols.iter().fold(0, |m, &c| m | 1 << c));
        // A spring each side (1 and 2 px) of a 10 px body: the body alone.
        let b = body(&[2, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 17, 18]);
        assert_eq!((b.n, b.sum_col, b.clipped), (10, (5..15).sum(), false));
        // One spring in view at column 0: not a clipped row.
        let b = body(&[0, 3, 4, 5, 6, 7]);
        assert_eq!((b.n, b.sum_col, b.clipped), (5, 25, false));
        // Only narrow runs (a gap row's edges): every run is the column's.
        let b = body(&[4, 5, 12, 13, 20]);
        assert_eq!((b.n, b.sum_col), (5, 54));
        // Only the outermost run goes; a narrow run inside stays; the body at the side clips.
        let b = body(&[0, 1, 2, 3, 6, 20, 21, 22, 23, 27, 28]);
        assert_eq!(
            (b.n, b.sum_col, b.clipped),
            (9, 6 + 6 + 20 + 21 + 22 + 23, true)
        );
        // A narrow run farther out than a spring (the rings' edge of a gap row whose other
        // edge is 3 px wide) is the column's: it stays. Three columns between: still a spring.
        let b = body(&[7, 8, 24, 25, 26]);
        assert_eq!((b.n, b.sum_col), (5, 7 + 8 + 24 + 25 + 26));
        let b = body(&[7, 8, 12, 13, 14]);
        assert_eq!((b.n, b.sum_col), (3, 12 + 13 + 14));
        let full = row_body(u32::MAX);
        assert_eq!((full.n, full.sum_col, full.clipped), (32, 496, true));
        assert_eq!(row_body(0).n, 0);
    }

    #[test]
    fn hot_springs_do_not_pull_the_tilt_where_one_leaves_the_view() {
        // 25° leaning left: the left spring runs off the image in the lower rows while the
        // column stays in view. Springs 1 px wide, 1.5 px off each side, at 360 K.
        let slope = -0.466;
        let mut img = cylinder_image(15.5, slope, 8.0, false);
        let norm = (1.0 + slope * slope).sqrt();
        for (p, v) in img.iter_mut().enumerate() {
            let (r, c) = ((p / IMG_COLS) as f32, (p % IMG_COLS) as f32);
            let d = (c - 15.5 - slope * r) / norm;
            if (9.0..10.0).contains(&d.abs()) {
                *v = 360.0;
            }
        }
        let fit = fit_cylinder(&img, range_k(&img)).unwrap();
        assert!((fit.tilt_slope - slope).abs() < 0.03, "{fit:?}");
    }

    proptest::proptest! {
        #![proptest_config(proptest::test_runner::Config::with_cases(300))]

        /// Images of a few values repeated (ties, equal bins) against a sort: the outer
        /// columns' median, and the 95th percentile of |v − bg| by an upward count.
        #[test]
        fn the_background_and_the_contrast_are_the_sorted_values_own(
            codes in proptest::collection::vec((0u32..40, 0u32..3), IMG_PIXELS),
            levels in 2u32..42,
        ) {
            let img: [f32; IMG_PIXELS] = core::array::from_fn(|p| {
                let (fine, coarse) = codes[p];
                280.0 + (fine % levels) as f32 * 0.37 + coarse as f32 * 11.0
            });
            let mut border: std::vec::Vec<f32> = (0..IMG_ROWS)
                .flat_map(|r| [img[r * IMG_COLS], img[r * IMG_COLS + IMG_COLS - 1]])
                .collect();
            border.sort_by(f32::total_cmp);
            let bg = border_median(&img);
            proptest::prop_assert_eq!(bg, 0.5 * (border[IMG_ROWS - 1] + border[IMG_ROWS]));
            let range = range_k(&img);
            let hi = (range.1 - bg).max(bg - range.0);
            let scale = 255.0 / hi;
            let mut count = [0u32; 256];
            for &x in &img {
                count[(libm::fabsf(x - bg) * scale) as usize & 255] += 1;
            }
            let target = (0.95 * (IMG_PIXELS - 1) as f32) as u32;
            let mut acc = 0;
            let bin = count
                .iter()
                .position(|&c| {
                    acc += c;
                    acc > target
                })
                .unwrap();
            proptest::prop_assert_eq!(deviation_95(&img, bg, range), (bin as f32 + 0.5) / scale);
        }

        /// Any length and rank, ties included (the rows' widths take their median this way):
        /// the sorted values' own, with none higher before it.
        #[test]
        fn a_selection_is_the_sorted_values_own(
            codes in proptest::collection::vec(0u32..12, 1..60),
            rank in 0usize..60,
        ) {
            let mut b: std::vec::Vec<f32> = codes.iter().map(|&c| 3.0 + c as f32 * 0.5).collect();
            let k = rank % b.len();
            let mut sorted = b.clone();
            sorted.sort_by(f32::total_cmp);
            let v = select(&mut b, k);
            proptest::prop_assert_eq!(v, sorted[k]);
            proptest::prop_assert!(b[..k].iter().all(|&x| x <= v));
            b.sort_by(f32::total_cmp);
            proptest::prop_assert_eq!(b, sorted);
        }
    }

    #[test]
    fn finds_a_cylinder_colder_than_the_background() {
        // A cold block (heater 290 K, rings 295 K) in a 305 K room: the 20th percentile is
        // inside the cylinder, the outer columns' median is the room.
        let img: [f32; IMG_PIXELS] = core::array::from_fn(|p| {
            let (r, c) = (p / IMG_COLS, p % IMG_COLS);
            if (c as f32 - 14.0).abs() < 6.0 {
                if r % 5 < 3 { 290.0 } else { 295.0 }
            } else {
                305.0
            }
        });
        assert_eq!(border_median(&img), 305.0);
        let fit = fit_cylinder(&img, range_k(&img)).unwrap();
        let (col0, slope, half) = (fit.col0, fit.slope, fit.half_width_px);
        assert!((col0 - 14.0).abs() < 0.6, "{col0}");
        assert!(slope.abs() < 0.05, "{slope}");
        assert!((half - 6.0).abs() < 1.0, "{half}");
    }

    #[test]
    fn uniform_scene_keeps_previous_geometry() {
        let img = [300.0f32; IMG_PIXELS];
        let prev = Geometry {
            axis_col0: 10.0,
            ..Geometry::default()
        };
        let (g, q) = update_geometry(&img, range_k(&img), &prev, &mut prev.coords_all());
        assert_eq!(q, Fresh::default());
        assert_eq!(g, prev);
    }

    #[test]
    fn coords_all_matches_coords_and_floor_is_floor() {
        let g = Geometry {
            axis_col0: 13.2,
            axis_slope: -0.2,
            half_width_px: 6.5,
            ..Geometry::DEFAULT
        };
        let xy = g.coords_all();
        for p in [0, 17, 300, 767] {
            let (u, t) = g.coords(p / 32, p % 32);
            assert!((u - xy.u[p]).abs() < 1e-4 && (t - xy.t[p]).abs() < 1e-4);
        }
        for x in [-2.5f32, -2.0, -0.1, 0.0, 0.3, 7.0, 7.9] {
            assert_eq!(floor(x), libm::floorf(x));
        }
    }

    #[test]
    fn percentiles_are_within_a_bin() {
        let v: [f32; IMG_PIXELS] = core::array::from_fn(|i| 300.0 + (i as f32 * 7.0) % 100.0);
        let mut sorted = v;
        sorted.sort_by(f32::total_cmp);
        let (p20, p95) = percentiles_20_95(&v);
        let bin = 100.0 / 255.0;
        assert!((p20 - sorted[(0.2 * 767.0) as usize]).abs() <= bin, "{p20}");
        assert!(
            (p95 - sorted[(0.95 * 767.0) as usize]).abs() <= bin,
            "{p95}"
        );
        assert_eq!(percentiles_20_95(&[3.0; IMG_PIXELS]), (3.0, 3.0));
    }

    #[test]
    fn greedy_assignment_is_one_to_one() {
        let mut o: Overlap = [[0; MAX_K]; REGIONS];
        o[0][4] = 100;
        o[0][3] = 20;
        o[1][3] = 40;
        o[1][4] = 30;
        o[2][2] = 50;
        o[3][1] = 60;
        o[4][0] = 300;
        let a = assign(&o, 5);
        assert_eq!(a, [Some(4), Some(3), Some(2), Some(1), Some(0)]);
        // Fewer clusters than zones: reuse the largest share.
        let a = assign(&o, 3);
        assert_eq!(a[4], Some(0));
        assert!(a.iter().all(|x| x.is_some()));
    }

    /// [`row_body`] as it was (the reference): every run into an array, then the rule.
    fn row_body_by_runs(mask: u32) -> RowBody {
        let mut runs = [(0u32, 0u32); IMG_COLS / 2];
        let mut k = 0;
        let mut widest = 0;
        let mut x = mask;
        while x != 0 && k < runs.len() {
            let a = x.trailing_zeros();
            let e = a + (!(x >> a)).trailing_zeros();
            runs[k] = (a, e);
            k += 1;
            widest = widest.max(e - a);
            x &= (u64::from(u32::MAX) << e) as u32;
        }
        let (mut lo, mut hi) = (0, k);
        if widest >= 3 && k >= 2 {
            let (first, next) = (runs[0], runs[1]);
            if first.1 - first.0 <= 2 && next.0 - first.1 <= SPRING_GAP_PX {
                lo = 1;
            }
            let (before, last) = (runs[k - 2], runs[k - 1]);
            if last.1 - last.0 <= 2 && last.0 - before.1 <= SPRING_GAP_PX {
                hi = k - 1;
            }
        }
        let mut body = RowBody {
            n: 0,
            sum_col: 0,
            clipped: false,
        };
        if lo < hi {
            for &(a, e) in &runs[lo..hi] {
                body.n += e - a;
                body.sum_col += (a + e - 1) * (e - a) / 2;
            }
            body.clipped = runs[lo].0 == 0 || runs[hi - 1].1 == IMG_COLS as u32;
        }
        body
    }

    #[test]
    fn a_row_body_is_the_run_array_s() {
        let check = |mask: u32| assert_eq!(row_body(mask), row_body_by_runs(mask), "{mask:#034b}");
        for m in 0..1u32 << 16 {
            check(m);
            check(m << 16);
            check(m << 8 | 0x8000_0001);
        }
        let mut rng = crate::mtts::cluster::XorShift::new(7);
        for _ in 0..1 << 17 {
            let (hi, lo) = (rng.next_f32(), rng.next_f32());
            let m = ((hi * 65536.0) as u32) << 16 | (lo * 65536.0) as u32;
            check(m);
            // Sparser and denser rows: more and fewer runs.
            check(m & (m >> 1) & (m >> 3));
            check(m | m << 1 | m >> 2);
        }
        for m in [
            0,
            u32::MAX,
            0x5555_5555,
            0xAAAA_AAAA,
            0x3333_3333,
            0x8000_0000,
            1,
            0x7FFF_FFFE,
        ] {
            check(m);
        }
    }

    /// [`overlap_and_min`] as it was (the reference): every pixel classified in turn.
    fn overlap_by_pixel(
        img: &[f32; IMG_PIXELS],
        g: &Geometry,
        xy: &Coords,
        cl: &Clusters,
    ) -> (Overlap, Option<f32>) {
        let mut o = [[0u16; MAX_K]; REGIONS];
        let mut lo = f32::INFINITY;
        for p in 0..IMG_PIXELS {
            let v = img[p];
            let z = g.zone_of(xy.u[p], xy.t[p]) as usize;
            o[z][cl.label(v)] += 1;
            // Plain comparisons: `f32::min` is a library call on the Cortex-M4.
            if z <= Zone::Edge as usize && v < lo {
                lo = v;
            }
        }
        (o, lo.is_finite().then_some(lo))
    }

    /// Proptest cases: `THERMORPH_PROPTEST_CASES`, else 256.
    fn cases() -> u32 {
        std::env::var("THERMORPH_PROPTEST_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(256)
    }

    /// A value from `rng` in [lo, hi).
    fn draw(rng: &mut crate::mtts::cluster::XorShift, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * rng.next_f32()
    }

    proptest::proptest! {
        #![proptest_config(proptest::test_runner::Config::with_cases(cases()))]

        /// Random frames (smooth stretches and noise; NaN, ±∞, ±0 and values on the clusters'
        /// boundaries among them), geometries (tilted, upright, any width, lattice known or
        /// not), coordinates (the geometry's own, another geometry's, degenerate widths and
        /// axes, or any values at all: u on the limits, NaN, negative; t repeated) and clusters
        /// (as `exact_binned` and `lloyd` make them, boundaries with ties, and clusters that
        /// break `label`'s invariants): the one pass counts exactly what every pixel classified
        /// in turn counts, and the lowest value is the same to the bit.
        #[test]
        fn one_pass_counts_what_every_pixel_counts(
            seed in proptest::prelude::any::<u64>(),
            col0 in -5.0f32..37.0,
            slope in -1.5f32..1.5,
            half in 0.5f32..20.0,
            period in 2.9f32..24.0,
            phase_frac in 0.0f32..1.0,
            exposed in 0.15f32..0.9,
            known in proptest::prelude::any::<bool>(),
            shape in 0u8..7,
            kind in 0u8..4,
            k in 0usize..=MAX_K + 1,
            specials in 0usize..80,
        ) {
            let mut rng = crate::mtts::cluster::XorShift::new(seed);
            let g = Geometry {
                axis_col0: col0,
                axis_slope: if shape == 1 { 0.0 } else { slope },
                half_width_px: half,
                period_px: period,
                phase_px: phase_frac * period,
                exposed,
                lattice_known: known,
                heater_hotter: None,
                exposure: crate::mtts::lattice::Exposure::NONE,
            };
            // The coordinates: the geometry's own; upright (t constant along a row) on a
            // whole column (a pixel on the axis); another geometry's (as the bench passes
            // the default's); a degenerate width or axis; any u and t (shape 6, below).
            let gx = match shape {
                0 | 1 => g,
                2 => Geometry { axis_col0: col0.round(), axis_slope: 0.0, ..g },
                3 => Geometry {
                    axis_col0: draw(&mut rng, -5.0, 37.0),
                    axis_slope: draw(&mut rng, -1.5, 1.5),
                    half_width_px: draw(&mut rng, 0.5, 20.0),
                    ..g
                },
                4 => {
                    let odd = [0.0, -0.0, -3.0, -1e-30, 1e-30, f32::INFINITY, f32::NAN];
                    let pick = (rng.next_f32() * odd.len() as f32) as usize;
                    Geometry { axis_col0: col0.round(), half_width_px: odd[pick], ..g }
                }
                _ => {
                    let odd = [f32::NAN, f32::INFINITY, -f32::INFINITY, 1e30];
                    let pick = (rng.next_f32() * odd.len() as f32) as usize;
                    if rng.next_f32() < 0.5 {
                        Geometry { axis_col0: odd[pick], ..g }
                    } else {
                        Geometry { axis_slope: odd[pick], ..g }
                    }
                }
            };
            let mut xy = gx.coords_all();
            if shape == 6 {
                let t_values = [1.5, -2.25, 0.0, -0.0, f32::NAN, f32::INFINITY, 7.0 + phase_frac];
                for p in 0..IMG_PIXELS {
                    let r = rng.next_f32();
                    xy.u[p] = if r < 0.5 {
                        draw(&mut rng, 0.0, 2.0)
                    } else {
                        [CORE_U, EDGE_U, RADIATION_U, f32::NAN, f32::INFINITY, -1.0, -0.0, 0.0]
                            [(r * 16.0) as usize - 8]
                    };
                    // Runs of one t, and t anywhere.
                    if p > 0 && rng.next_f32() < 0.5 {
                        xy.t[p] = xy.t[p - 1];
                    } else if rng.next_f32() < 0.5 {
                        xy.t[p] = t_values[(rng.next_f32() * t_values.len() as f32) as usize];
                    } else {
                        xy.t[p] = draw(&mut rng, -40.0, 40.0);
                    }
                }
            }
            // Smooth stretches (neighbours mostly in one cluster) and noise.
            let mut img = [0f32; IMG_PIXELS];
            let mut level = draw(&mut rng, 290.0, 370.0);
            for v in img.iter_mut() {
                let r = rng.next_f32();
                if r < 0.1 {
                    level = draw(&mut rng, 290.0, 370.0);
                } else if r < 0.6 {
                    level += draw(&mut rng, -0.5, 0.5);
                }
                *v = level;
            }
            let (lo_k, hi_k) = range_k(&img);
            let mut h = crate::mtts::cluster::Histogram::new(lo_k, hi_k, 64).unwrap();
            h.add_slice(&img);
            let kk = k.clamp(1, MAX_K);
            let cl = match kind {
                0 => crate::mtts::cluster::exact_binned(
                    &h,
                    kk,
                    &mut crate::mtts::cluster::DpScratch::new(),
                )
                .unwrap(),
                1 => crate::mtts::cluster::lloyd(
                    &h,
                    kk,
                    crate::mtts::cluster::Seeding::Random,
                    &mut crate::mtts::cluster::XorShift::new(seed ^ 1),
                    20,
                )
                .unwrap(),
                _ => {
                    let mut c = crate::mtts::cluster::exact_binned(
                        &h,
                        kk,
                        &mut crate::mtts::cluster::DpScratch::new(),
                    )
                    .unwrap();
                    c.k = kk;
                    // Ascending boundaries with ties, on the frame's own values.
                    let mut up: std::vec::Vec<f32> =
                        (0..kk - 1).map(|_| img[(rng.next_f32() * IMG_PIXELS as f32) as usize]).collect();
                    up.sort_by(f32::total_cmp);
                    if kk > 2 && rng.next_f32() < 0.5 {
                        up[1] = up[0];
                    }
                    c.upper = [f32::INFINITY; MAX_K];
                    c.upper[..kk - 1].copy_from_slice(&up);
                    if kind == 3 {
                        // Beyond the invariants: any k, NaN, unsorted, a finite tail.
                        c.k = k;
                        for b in c.upper.iter_mut() {
                            let r = rng.next_f32();
                            if r < 0.1 {
                                *b = f32::NAN;
                            } else if r < 0.3 {
                                *b = draw(&mut rng, 280.0, 380.0);
                            } else if r < 0.35 {
                                *b = -f32::INFINITY;
                            }
                        }
                    }
                    c
                }
            };
            // Special values, and values on the boundaries (the label's ties); ±0 together
            // in the cylinder make the lowest value's sign its first's.
            for _ in 0..specials {
                let p = (rng.next_f32() * IMG_PIXELS as f32) as usize;
                let r = rng.next_f32();
                img[p] = if r < 0.15 {
                    f32::NAN
                } else if r < 0.25 {
                    f32::INFINITY
                } else if r < 0.28 {
                    -f32::INFINITY
                } else if r < 0.45 {
                    0.0
                } else if r < 0.6 {
                    -0.0
                } else {
                    cl.upper[(rng.next_f32() * MAX_K as f32) as usize]
                };
            }
            let want = overlap_by_pixel(&img, &g, &xy, &cl);
            let got = overlap_and_min(&img, &g, &xy, &cl);
            proptest::prop_assert_eq!(got.0, want.0);
            proptest::prop_assert_eq!(got.1.map(f32::to_bits), want.1.map(f32::to_bits));
            proptest::prop_assert_eq!(overlap(&img, &g, &xy, &cl), want.0);
        }
    }
}
