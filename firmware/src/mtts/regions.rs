//! Region identification: which cluster is the heater area, the SMP surface, the edges, the
//! radiation zone and the background — by where its pixels lie, not by its temperature rank.
//!
//! Method (at the sensor's 32×24 resolution, on the inpainted image):
//! 1. Contrast: background level `bg` = 20th percentile, top = 95th percentile. Below
//!    [`MIN_CONTRAST_K`] of contrast the geometry is not re-estimated: the previous frame's is
//!    kept (or, on the first frame, a centred vertical cylinder of the default width).
//! 2. Cylinder: pixels above bg + ½·contrast form a mask; each row's mask centroid and width
//!    give, by weighted least squares, the axis `col = a + b·row` (shift and tilt) and the
//!    half-width `w` (median row width, perpendicular). Every pixel gets a perpendicular
//!    distance ratio u = |d|/w and an axial coordinate t along the axis.
//! 3. Zones: u < [`CORE_U`] core, < [`EDGE_U`] edge (region 3), < [`RADIATION_U`] radiation
//!    (region 4), else background (region 5).
//! 4. Lattice: the core's mean temperature along t is fitted with a square wave of the
//!    block's gap fraction (`block::LATTICE_GAP_FRACTION`, 71 %) over periods of
//!    [`PERIOD_MIN_PX`]–[`PERIOD_MAX_PX`] and all phases; the part of each period that is
//!    `gap fraction` long is the heater area (region 1), the rest SMP surface (region 2). The
//!    sign of the contrast is ignored: which part is hotter may flip (the hot-zone inversion
//!    of forming) without changing which part is the gap. A fit weaker than
//!    [`MIN_LATTICE_K`], or not clearly better than the previous frame's lattice, keeps the
//!    previous lattice (continuity).
//! 5. Assignment: each pixel's cluster is its temperature's cluster; the zone × cluster
//!    overlap, each row normalised by the zone's size, is assigned greedily one to one
//!    (largest share first); when there are fewer clusters than zones the remaining zones take
//!    their largest-share cluster. A region's temperature is its cluster's mean.

use super::cluster::{Clusters, MAX_K};
use super::{IMG_COLS, IMG_PIXELS, IMG_ROWS, REGIONS};
use crate::block::LATTICE_GAP_FRACTION;

/// Least contrast (95th − 20th percentile) to re-estimate the cylinder, K.
pub const MIN_CONTRAST_K: f32 = 1.0;
/// Least lattice square-wave amplitude to re-estimate the lattice, K.
pub const MIN_LATTICE_K: f32 = 0.3;
/// Core zone: distance ratio below this.
pub const CORE_U: f32 = 0.75;
/// Edge zone (region 3): distance ratio below this.
pub const EDGE_U: f32 = 1.15;
/// Radiation zone (region 4): distance ratio below this.
pub const RADIATION_U: f32 = 1.6;
/// Shortest lattice period searched, pixels (a 30 mm unit at 100 mm distance).
pub const PERIOD_MIN_PX: f32 = 8.0;
/// Longest lattice period searched, pixels (a 30 mm unit at 50 mm distance).
pub const PERIOD_MAX_PX: f32 = 24.0;
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
    /// Whether the lattice has ever been fitted (else every core pixel is heater area).
    pub lattice_known: bool,
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
        lattice_known: false,
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
            for c in 0..IMG_COLS {
                let p = r * IMG_COLS + c;
                out.u[p] = libm::fabsf(c as f32 + d0) * inv_half;
                out.t[p] = t0 + c as f32 * dt;
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
        ph < LATTICE_GAP_FRACTION * self.period_px
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

/// Floor without a library call (|x| < 2^31).
fn floor(x: f32) -> f32 {
    let i = x as i32 as f32;
    if i > x { i - 1.0 } else { i }
}

/// What the region finder could estimate this frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Quality {
    /// The cylinder was re-estimated (else the previous geometry was kept).
    pub cylinder_fresh: bool,
    /// The lattice was re-estimated (else the previous lattice was kept).
    pub lattice_fresh: bool,
}

/// Return the 20th and 95th percentiles of `v`, to 1/256 of its range: a counting pass over
/// 256 bins (a copy and a selection would cost ten times as much on the Cortex-M4).
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

/// Re-estimate the cylinder from an image (finite values); `None` when the contrast is too low
/// or too few rows show it.
pub fn fit_cylinder(img: &[f32; IMG_PIXELS]) -> Option<(f32, f32, f32)> {
    let (bg, top) = percentiles_20_95(img);
    if top - bg < MIN_CONTRAST_K {
        return None;
    }
    let thr = bg + 0.5 * (top - bg);
    let mut widths = [0f32; IMG_ROWS];
    let mut nrows = 0;
    let (mut sw, mut sx, mut sy, mut sxx, mut sxy) = (0f32, 0f32, 0f32, 0f32, 0f32);
    for r in 0..IMG_ROWS {
        let row = &img[r * IMG_COLS..(r + 1) * IMG_COLS];
        let (mut n, mut sc) = (0f32, 0f32);
        for (c, &v) in row.iter().enumerate() {
            if v > thr {
                n += 1.0;
                sc += c as f32;
            }
        }
        if n >= 3.0 {
            let x = r as f32;
            let y = sc / n;
            sw += n;
            sx += n * x;
            sy += n * y;
            sxx += n * x * x;
            sxy += n * x * y;
            widths[nrows] = n;
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
    let w = &mut widths[..nrows];
    w.sort_unstable_by(f32::total_cmp);
    let median = w[nrows / 2];
    let half = 0.5 * median / crate::fmath::sqrt(1.0 + slope * slope);
    Some((col0, slope, half.max(1.0)))
}

/// Square-wave amplitude of an axial profile (`prof[b]` at t = t0 + b + ½, NaN = no data)
/// for one period and phase: |mean over gaps − mean over rings|, or `None` if either part has
/// fewer than two samples.
fn square_wave(prof: &[f32], t0: f32, period: f32, phase: f32) -> Option<f32> {
    let (mut sg, mut ng, mut ss, mut ns) = (0f32, 0f32, 0f32, 0f32);
    let gap = LATTICE_GAP_FRACTION * period;
    let x = t0 + 0.5 - phase;
    let mut ph = x - floor(x / period) * period;
    for &p in prof {
        if !p.is_nan() {
            if ph < gap {
                sg += p;
                ng += 1.0;
            } else {
                ss += p;
                ns += 1.0;
            }
        }
        ph += 1.0;
        if ph >= period {
            ph -= period;
        }
    }
    (ng >= 2.0 && ns >= 2.0).then(|| libm::fabsf(sg / ng - ss / ns))
}

/// Bins of the axial profile (one per pixel of axial length).
const PROFILE_BINS: usize = 48;

/// The core's mean temperature along the axis: `v[b]` at t = t0 + b + ½ (NaN = no pixel).
#[derive(Clone, Debug)]
pub struct Profile {
    v: [f32; PROFILE_BINS],
    /// `v` less the first sample (precision of the folded sums), 0 where NaN.
    dev: [f32; PROFILE_BINS],
    /// 1 where `v` holds a sample, else 0.
    valid: [f32; PROFILE_BINS],
    used: usize,
    t0: f32,
}

impl Profile {
    /// Return the profile of the core pixels (u < [`CORE_U`]), or `None` if there are none.
    pub fn of(img: &[f32; IMG_PIXELS], xy: &Coords) -> Option<Profile> {
        let mut sum = [0f32; PROFILE_BINS];
        let mut cnt = [0u16; PROFILE_BINS];
        let mut tmin = f32::INFINITY;
        for p in 0..IMG_PIXELS {
            if xy.u[p] < CORE_U && xy.t[p] < tmin {
                tmin = xy.t[p];
            }
        }
        if !tmin.is_finite() {
            return None;
        }
        let t0 = floor(tmin);
        for p in 0..IMG_PIXELS {
            if xy.u[p] < CORE_U {
                let b = ((xy.t[p] - t0) as usize).min(PROFILE_BINS - 1);
                sum[b] += img[p];
                cnt[b] += 1;
            }
        }
        let used = cnt.iter().rposition(|&n| n > 0)? + 1;
        let mut v = [f32::NAN; PROFILE_BINS];
        let mut dev = [0f32; PROFILE_BINS];
        let mut valid = [0f32; PROFILE_BINS];
        let mut reference = None;
        for b in 0..used {
            if cnt[b] > 0 {
                v[b] = sum[b] / cnt[b] as f32;
                let r = *reference.get_or_insert(v[b]);
                dev[b] = v[b] - r;
                valid[b] = 1.0;
            }
        }
        Some(Profile {
            v,
            dev,
            valid,
            used,
            t0,
        })
    }

    /// Return the square-wave amplitude |mean over gaps − mean over rings| for a period and
    /// phase (pixels), or `None` if either part has fewer than two samples.
    pub fn amplitude(&self, period: f32, phase: f32) -> Option<f32> {
        square_wave(&self.v[..self.used], self.t0, period, phase)
    }

    /// Return the best (phase, amplitude) of an integer period over the even phases 0, 2, …
    /// (ties keep the lower phase), or `None` if no phase leaves two samples to each part.
    ///
    /// Equal to [`Profile::amplitude`] at those phases up to rounding, in O(bins + period)
    /// instead of O(bins · period): with t0 and the phase integers, sample b lies in a gap iff
    /// (t0 + b − phase) mod period < m, where m counts the j with j + ½ < gap fraction ·
    /// period; so the profile is folded modulo the period once, and each phase's gap is a
    /// circular window of m folded bins, summed from prefix sums.
    pub fn best_integer_phase(&self, period: usize) -> Option<(usize, f32)> {
        const W: usize = 32;
        let p = period.clamp(1, MAX_PERIOD);
        let mut f = [0f32; W];
        let mut c = [0f32; W];
        let mut i = (self.t0 as i32).rem_euclid(p as i32) as usize;
        for (&d, &n) in self.dev[..self.used].iter().zip(&self.valid[..self.used]) {
            // Masks and clamps (no-ops: i < p ≤ 24 < W) spare the bounds checks.
            f[i & (W - 1)] += d;
            c[i & (W - 1)] += n;
            i += 1;
            if i == p {
                i = 0;
            }
        }
        let gap = LATTICE_GAP_FRACTION * p as f32;
        let m = (0..p).filter(|&j| (j as f32 + 0.5) < gap).count();
        // Prefix sums over one period; a window phase..phase + m past the end wraps around.
        let mut sf = [0f32; W + 1];
        let mut sc = [0f32; W + 1];
        let (mut af, mut ac) = (0f32, 0f32);
        for j in 0..p {
            af += f[j & (W - 1)];
            ac += c[j & (W - 1)];
            sf[(j + 1).min(W)] = af;
            sc[(j + 1).min(W)] = ac;
        }
        let (tf, tc) = (af, ac);
        let mut best: Option<(usize, f32)> = None;
        for phase in (0..p).step_by(2) {
            let e = phase + m;
            let (sg, ng) = if e <= p {
                (
                    sf[e.min(W)] - sf[phase.min(W)],
                    sc[e.min(W)] - sc[phase.min(W)],
                )
            } else {
                let e = e - p;
                (
                    tf - sf[phase.min(W)] + sf[e.min(W)],
                    tc - sc[phase.min(W)] + sc[e.min(W)],
                )
            };
            let (ss, ns) = (tf - sg, tc - ng);
            if ng >= 2.0 && ns >= 2.0 {
                let amp = libm::fabsf(sg / ng - ss / ns);
                if best.is_none_or(|b| amp > b.1) {
                    best = Some((phase, amp));
                }
            }
        }
        best
    }
}

/// Longest period [`Profile::best_integer_phase`] folds.
const MAX_PERIOD: usize = PERIOD_MAX_PX as usize;

/// Fit the lattice square wave to the core's axial profile; return (period, phase,
/// amplitude in K). Coarse search (integer periods, even phases, by folding — see
/// [`Profile::best_integer_phase`]), then a fine one (0.5 px) around the best.
///
/// With `near` (the previous frame's period), only the integer periods within 2 px of it are
/// searched: the lattice's image period changes only as the camera distance does.
pub fn fit_lattice(prof: &Profile, near: Option<f32>) -> Option<(f32, f32, f32)> {
    let (pmin, pmax) = match near {
        Some(p) => {
            let r = libm::roundf(p.clamp(PERIOD_MIN_PX, PERIOD_MAX_PX)) as usize;
            (r.saturating_sub(2), r + 2)
        }
        None => (PERIOD_MIN_PX as usize, PERIOD_MAX_PX as usize),
    };
    let (pmin, pmax) = (
        pmin.max(PERIOD_MIN_PX as usize),
        pmax.min(PERIOD_MAX_PX as usize),
    );
    let mut best: Option<(f32, f32, f32)> = None;
    for period in pmin..=pmax {
        if let Some((phase, amp)) = prof.best_integer_phase(period) {
            if best.is_none_or(|b| amp > b.2) {
                best = Some((period as f32, phase as f32, amp));
            }
        }
    }
    let (p0, f0, _) = best?;
    for dp in [-0.5f32, 0.0, 0.5] {
        let period = (p0 + dp).clamp(PERIOD_MIN_PX, PERIOD_MAX_PX);
        for df in [-1.5f32, -1.0, -0.5, 0.0, 0.5, 1.0, 1.5] {
            let phase = f0 + df;
            let phase = phase - floor(phase / period) * period;
            if let Some(amp) = prof.amplitude(period, phase) {
                if best.is_none_or(|b| amp > b.2) {
                    best = Some((period, phase, amp));
                }
            }
        }
    }
    best
}

/// Update the geometry from a frame (keeping what cannot be re-estimated); `xy` receives every
/// pixel's coordinates under the new geometry.
pub fn update_geometry(
    img: &[f32; IMG_PIXELS],
    prev: &Geometry,
    xy: &mut Coords,
) -> (Geometry, Quality) {
    let mut g = *prev;
    let mut q = Quality::default();
    if let Some((col0, slope, half)) = fit_cylinder(img) {
        g.axis_col0 = col0;
        g.axis_slope = slope;
        g.half_width_px = half;
        q.cylinder_fresh = true;
    }
    g.coords_into(xy);
    let near = g.lattice_known.then_some(g.period_px);
    let prof = Profile::of(img, xy);
    let fit = prof.as_ref().and_then(|p| fit_lattice(p, near));
    if let (Some(prof), Some((period, phase, amp))) = (&prof, fit) {
        // Continuity: the previous lattice, measured on the same profile.
        let prev_amp = prof.amplitude(g.period_px, g.phase_px).unwrap_or(0.0);
        let keep = g.lattice_known && prev_amp >= 0.8 * amp;
        if amp >= MIN_LATTICE_K && !keep {
            g.period_px = period;
            g.phase_px = phase;
            g.lattice_known = true;
            q.lattice_fresh = true;
        }
    }
    (g, q)
}

/// Zone × cluster pixel counts.
pub type Overlap = [[u16; MAX_K]; REGIONS];

/// Count, for every pixel, its zone and its value's cluster.
pub fn overlap(img: &[f32; IMG_PIXELS], g: &Geometry, xy: &Coords, cl: &Clusters) -> Overlap {
    let mut o = [[0u16; MAX_K]; REGIONS];
    for p in 0..IMG_PIXELS {
        let z = g.zone_of(xy.u[p], xy.t[p]) as usize;
        o[z][cl.label(img[p])] += 1;
    }
    o
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
    fn finds_a_shifted_tilted_cylinder() {
        let img = cylinder_image(13.0, 0.15, 6.0, false);
        let (col0, slope, half) = fit_cylinder(&img).unwrap();
        assert!((col0 - 13.0).abs() < 1.0, "{col0}");
        assert!((slope - 0.15).abs() < 0.05, "{slope}");
        assert!((half - 6.0).abs() < 1.5, "{half}");
    }

    #[test]
    fn lattice_phase_survives_inversion() {
        for inverted in [false, true] {
            let img = cylinder_image(15.5, 0.0, 7.0, inverted);
            let (g, q) = update_geometry(
                &img,
                &Geometry::default(),
                &mut Geometry::DEFAULT.coords_all(),
            );
            assert!(q.cylinder_fresh && q.lattice_fresh);
            assert!((g.period_px - 14.0).abs() <= 0.5, "period {}", g.period_px);
            // Gap rows agree with the truth on most core pixels.
            let truth = Geometry {
                axis_col0: 15.5,
                axis_slope: 0.0,
                half_width_px: 7.0,
                period_px: 14.0,
                phase_px: 3.0,
                lattice_known: true,
            };
            let agree = (0..IMG_ROWS)
                .filter(|&r| g.in_gap(r as f32) == truth.in_gap(r as f32))
                .count();
            assert!(agree >= 20, "inverted={inverted}: {agree}/24 rows agree");
        }
    }

    #[test]
    fn uniform_scene_keeps_previous_geometry() {
        let img = [300.0f32; IMG_PIXELS];
        let prev = Geometry {
            axis_col0: 10.0,
            ..Geometry::default()
        };
        let (g, q) = update_geometry(&img, &prev, &mut prev.coords_all());
        assert_eq!(q, Quality::default());
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

    #[test]
    fn folded_phase_search_equals_the_direct_one() {
        for (t0, n) in [(-3.0f32, 40usize), (0.0, 24), (5.0, 33)] {
            let mut v = [f32::NAN; PROFILE_BINS];
            for (b, x) in v.iter_mut().enumerate().take(n) {
                if b % 7 != 3 {
                    *x = 330.0 + 8.0 * libm::sinf(b as f32 * 0.61) + (b % 5) as f32;
                }
            }
            let r = v[..n].iter().copied().find(|x| !x.is_nan()).unwrap();
            let prof = Profile {
                v,
                dev: core::array::from_fn(|b| if v[b].is_nan() { 0.0 } else { v[b] - r }),
                valid: core::array::from_fn(|b| if v[b].is_nan() { 0.0 } else { 1.0 }),
                used: n,
                t0,
            };
            for period in 8..=24usize {
                let mut want: Option<(usize, f32)> = None;
                for phase in (0..period).step_by(2) {
                    if let Some(a) = prof.amplitude(period as f32, phase as f32) {
                        if want.is_none_or(|w| a > w.1 + 1e-4) {
                            want = Some((phase, a));
                        }
                    }
                }
                let got = prof.best_integer_phase(period);
                match (got, want) {
                    (Some(g), Some(w)) => {
                        assert!((g.1 - w.1).abs() < 1e-3, "t0={t0} p={period}: {g:?} {w:?}");
                        let at = prof.amplitude(period as f32, g.0 as f32).unwrap();
                        assert!((at - g.1).abs() < 1e-3);
                    }
                    (g, w) => assert_eq!(g.is_some(), w.is_some(), "p={period}"),
                }
            }
        }
    }
}
