//! The camera's view of the block: a 32×24 image with ground truth, for MTTS tests, benches
//! and the simulated board's camera ([`crate::rig::camera`]). A [`Scene`] here is one rendered
//! image (the twelve standard scenes); a scene *file*, a whole run, is
//! [`crate::runs::scenario`].
//!
//! Geometry (in sensor pixels; the block's sizes live in `thermorph::block`): the cylinder is a
//! band around an axis `col = axis_col0 + tan(tilt)·row` of half-width `half_width_px`. Along
//! the axis the lattice repeats every `period_px`: the first `exposed` fraction (default `LATTICE_GAP_FRACTION`) of each unit
//! (from `phase_px`) is a gap where the PI heater film shows (region 1), the rest is SMP ring
//! (region 2). The outer `edge_fraction` of the half-width, seen at grazing angles, is region 3.
//! Beside the cylinder a band `radiation_px` wide is the radiation zone (region 4); beyond it
//! the background (region 5). Optional springs are thin vertical lines outside the cylinder.
//!
//! Each sensor pixel integrates a `subgrid`×`subgrid` grid of samples (the optics' blur is a
//! box of one pixel), then Gaussian noise of `noise_k` rms (the MLX90640's NETD, ≈ 0.1 K) is
//! added. The result carries each region's true temperature and each pixel's area fraction
//! per region. [`Layout`] keeps which region each sample shows for one geometry, so a view of
//! the same geometry at other temperatures (the camera of `host-sim run`, each period) costs
//! only the temperatures — the same image, bit for bit, as [`render`] without noise.

use thermorph::block::LATTICE_GAP_FRACTION;
use thermorph::mtts::{IMG_COLS, IMG_PIXELS, IMG_ROWS, REGIONS};

use crate::sensor::virtual_mlx::Rng;

/// Where the block sits in the image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geometry {
    /// Axis column at row 0 (pixel centres are integers), pixels.
    pub axis_col0: f64,
    /// Tilt of the axis from vertical, degrees (positive: leaning right going down).
    pub tilt_deg: f64,
    /// Cylinder half-width perpendicular to the axis, pixels.
    pub half_width_px: f64,
    /// Lattice period along the axis, pixels.
    pub period_px: f64,
    /// Axial position where a gap starts, pixels.
    pub phase_px: f64,
    /// Fraction of each lattice unit where the heater shows (the gap as seen from the camera).
    pub exposed: f64,
    /// Outer fraction of the half-width that is edge (region 3).
    pub edge_fraction: f64,
    /// Width of the radiation zone beside the cylinder, pixels.
    pub radiation_px: f64,
    /// Draw the springs (at ±(half-width + 1.5 px) from the axis, 0.5 px wide).
    pub springs: bool,
}

impl Default for Geometry {
    /// The block 75 mm from a 55°×35° MLX90640BAB: 40 mm wide → 8 px half-width, a 30 mm
    /// lattice unit → 15 px, centred and upright.
    fn default() -> Self {
        Geometry {
            axis_col0: 15.5,
            tilt_deg: 0.0,
            half_width_px: 8.0,
            period_px: 15.0,
            phase_px: 2.0,
            exposed: LATTICE_GAP_FRACTION as f64,
            edge_fraction: 0.2,
            radiation_px: 3.0,
            springs: false,
        }
    }
}

/// True temperatures, K.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Temps {
    /// Region 1: heater film seen through the lattice gaps.
    pub heater_k: f64,
    /// Region 2: SMP outer surface.
    pub surface_k: f64,
    /// Region 3: cylinder edges.
    pub edge_k: f64,
    /// Region 4: radiation zone.
    pub radiation_k: f64,
    /// Region 5: background.
    pub background_k: f64,
    /// Springs (drawn only if the geometry asks).
    pub spring_k: f64,
}

impl Temps {
    /// The view of a block whose heater film is at `heater_k` and SMP outer surface at
    /// `surface_k` against a background at `background_k`: the edges, seen at grazing angles,
    /// 70 % of the way from the background to the surface; the radiation zone 25 %; the
    /// springs at `spring_k`.
    pub fn from_surfaces(background_k: f64, heater_k: f64, surface_k: f64, spring_k: f64) -> Self {
        Temps {
            heater_k,
            surface_k,
            edge_k: background_k + 0.7 * (surface_k - background_k),
            radiation_k: background_k + 0.25 * (surface_k - background_k),
            background_k,
            spring_k,
        }
    }

    /// Return the five region temperatures in region order.
    pub fn regions(&self) -> [f64; REGIONS] {
        [
            self.heater_k,
            self.surface_k,
            self.edge_k,
            self.radiation_k,
            self.background_k,
        ]
    }
}

/// Rendering options.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// Samples per pixel side.
    pub subgrid: usize,
    /// Sensor noise, K rms.
    pub noise_k: f64,
    /// Noise seed.
    pub seed: u64,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            subgrid: 8,
            noise_k: 0.1,
            seed: 1,
        }
    }
}

/// A rendered image with its ground truth.
#[derive(Clone, Debug)]
pub struct Rendered {
    /// The image, K, row-major 24×32.
    pub image_k: [f32; IMG_PIXELS],
    /// True region temperatures, K (region 1 first).
    pub truth_k: [f64; REGIONS],
    /// Per region, each pixel's area fraction (springs count as background).
    pub fraction: [[f32; IMG_PIXELS]; REGIONS],
}

/// What a sample point at (row, col) shows: region index (0…4) or `None` for a spring.
pub fn sample(g: &Geometry, row: f64, col: f64) -> Option<usize> {
    sampler(g)(row, col)
}

/// [`sample`] for many points of one geometry: the geometry's constants (the tilt's tangent,
/// the borders) worked out once.
pub fn sampler(g: &Geometry) -> impl Fn(f64, f64) -> Option<usize> + use<> {
    let s = Sampler::new(g);
    move |row, col| match s.region_at(row, col) {
        SPRING => None,
        z => Some(z as usize),
    }
}

/// `x.floor()` (up to the sign of a zero result), without a library call where the
/// target has no rounding instruction.
#[inline]
fn floor(x: f64) -> f64 {
    if x.abs() < 4.0e15 {
        let t = x as i64 as f64;
        if t > x { t - 1.0 } else { t }
    } else {
        x.floor()
    }
}

/// `floor` of each of `q` (up to the sign of a zero result): rounded to nearest by the
/// 1.5·2⁵² trick, less one where that rounded up — exact below 2⁵⁰, and done without branches
/// or library calls; larger values go through `f64::floor`.
#[inline]
fn floor16(q: &[f64; 16]) -> [f64; 16] {
    const MAGIC: f64 = 6_755_399_441_055_744.0;
    let mut out = [0.0; 16];
    let mut big = false;
    for k in 0..16 {
        let r = (q[k] + MAGIC) - MAGIC;
        out[k] = r - if r > q[k] { 1.0 } else { 0.0 };
        // NaN counts as large.
        big |= q[k].abs() >= 1.0e15 || q[k].is_nan();
    }
    if big {
        for k in 0..16 {
            out[k] = q[k].floor();
        }
    }
    out
}

/// A pixel the cheap proof of [`Sampler::settled`] leaves open.
const UNSETTLED: u8 = u8::MAX;

/// The region code of a spring sample (regions are 0…4).
const SPRING: u8 = 5;
/// Region codes: the five regions and the springs.
const CODES: usize = 6;

/// A geometry's constants, computed once: [`sample`] for many points. Every value is computed
/// with the same operations, in the same order, as the per-sample formulas, so a sample's
/// region is bit for bit what those formulas give.
#[derive(Clone, Copy, Debug)]
struct Sampler {
    slope: f64,
    norm: f64,
    axis: f64,
    half_width: f64,
    /// Where the edge starts: `(1 − edge_fraction)·half_width`.
    inner: f64,
    /// The springs' distance from the axis: `half_width + 1.5`.
    spring: f64,
    springs: bool,
    /// The radiation zone's outer border: `half_width + radiation`.
    outer: f64,
    phase: f64,
    period: f64,
    /// The gap's length along the axis: `exposed·period`.
    gap: f64,
}

/// What the distance from the axis decides for a sample (each a monotone test of |d|).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Across {
    cylinder: bool,
    edge: bool,
    spring_lo: bool,
    spring_hi: bool,
    radiation: bool,
}

impl Sampler {
    fn new(g: &Geometry) -> Self {
        let slope = g.tilt_deg.to_radians().tan();
        Sampler {
            slope,
            norm: (1.0 + slope * slope).sqrt(),
            axis: g.axis_col0,
            half_width: g.half_width_px,
            inner: (1.0 - g.edge_fraction) * g.half_width_px,
            spring: g.half_width_px + 1.5,
            springs: g.springs,
            outer: g.half_width_px + g.radiation_px,
            phase: g.phase_px,
            period: g.period_px,
            gap: g.exposed * g.period_px,
        }
    }

    /// Signed distance from the axis, perpendicular to it.
    #[inline]
    fn d(&self, row: f64, col: f64) -> f64 {
        (col - (self.axis + self.slope * row)) / self.norm
    }

    /// Position along the axis.
    #[inline]
    fn t(&self, row: f64, col: f64) -> f64 {
        (row + self.slope * (col - self.axis)) / self.norm
    }

    #[inline]
    fn across(&self, ad: f64) -> Across {
        let s = ad - self.spring;
        Across {
            cylinder: ad < self.half_width,
            edge: ad >= self.inner,
            spring_lo: s > -0.25,
            spring_hi: s < 0.25,
            radiation: ad < self.outer,
        }
    }

    /// The lattice unit (floor of the axial phase) and whether the heater shows.
    #[inline]
    fn along(&self, t: f64) -> (f64, bool) {
        let x = t - self.phase;
        let unit = floor(x / self.period);
        let ph = x - unit * self.period;
        (unit, ph < self.gap)
    }

    /// The region every sample of a pixel shows, or [`UNSETTLED`]: its samples' distances
    /// from the axis lie within `reach` of `d` and their axial positions within `reach` of `t`
    /// (`reach` covers the rounding of `d` and `t` and of the samples' own values), so if no
    /// test's border comes that close, they all show the region of (`d`, `t`). One branch:
    /// the lattice's position is worked out only off the edge, the one place it matters.
    #[inline]
    fn settled(&self, d: f64, t: f64, reach: f64) -> u8 {
        let ad = d.abs();
        let sp = ad - self.spring;
        let mut near = (ad - self.half_width).abs();
        near = near.min((ad - self.inner).abs());
        near = near.min((ad - self.outer).abs());
        if self.springs {
            near = near.min((sp + 0.25).abs()).min((sp - 0.25).abs());
        }
        // The lattice matters only off the edge (`ad < inner`): elsewhere neither `gap` nor
        // `along` is looked at, so they are not worked out.
        let (gap, along) = if ad < self.inner {
            let x = t - self.phase;
            let ph = x - floor(x / self.period) * self.period;
            (
                ph < self.gap,
                ph.min(self.period - ph).min((ph - self.gap).abs()),
            )
        } else {
            (false, f64::INFINITY)
        };
        let lattice = (ad < self.half_width) & (ad < self.inner);
        let sure = (near > reach) & (!lattice | (along > reach));
        let cylinder = if ad >= self.inner { 2 } else { 1 - gap as u8 };
        let spring = self.springs & (sp > -0.25) & (sp < 0.25);
        let outside = if spring {
            SPRING
        } else {
            4 - (ad < self.outer) as u8
        };
        let code = if ad < self.half_width {
            cylinder
        } else {
            outside
        };
        if sure { code } else { UNSETTLED }
    }

    /// The region codes of the 4×4 samples at `rows` × `cols`, row by row: [`Self::region_at`]
    /// of each, computed for all sixteen at once without branches (a pixel a border crosses
    /// has no likely region) but one: the lattice's position only when a sample lies off the
    /// edge.
    fn regions_4x4(&self, rows: [f64; 4], cols: [f64; 4]) -> [u8; 16] {
        let centre: [f64; 4] = core::array::from_fn(|i| self.axis + self.slope * rows[i]);
        let shift: [f64; 4] = core::array::from_fn(|j| self.slope * (cols[j] - self.axis));
        let mut ad = [0.0; 16];
        for k in 0..16 {
            ad[k] = ((cols[k % 4] - centre[k / 4]) / self.norm).abs();
        }
        // Where the lattice matters (a sample off the edge, `ad < inner`), whether it shows
        // the heater; elsewhere (most pixels a border crosses: the cylinder's sides, the
        // radiation zone, the springs) `gap` is never looked at, so it is not worked out.
        let mut gap = [0u8; 16];
        if ad.iter().any(|&a| a < self.inner) {
            let mut x = [0.0; 16];
            for k in 0..16 {
                x[k] = (rows[k / 4] + shift[k % 4]) / self.norm - self.phase;
            }
            let mut q = [0.0; 16];
            for k in 0..16 {
                q[k] = x[k] / self.period;
            }
            let unit = floor16(&q);
            for k in 0..16 {
                let ph = x[k] - unit[k] * self.period;
                gap[k] = (ph < self.gap) as u8;
            }
        }
        let mut out = [0u8; 16];
        for k in 0..16 {
            let ad = ad[k];
            let gap = gap[k];
            let sp = ad - self.spring;
            let cylinder = if ad >= self.inner { 2 } else { 1 - gap };
            let spring = self.springs & (sp > -0.25) & (sp < 0.25);
            let outside = if spring {
                SPRING
            } else {
                4 - (ad < self.outer) as u8
            };
            out[k] = if ad < self.half_width {
                cylinder
            } else {
                outside
            };
        }
        out
    }

    /// The region code of the sample at (`row`, `col`).
    #[inline]
    fn region_at(&self, row: f64, col: f64) -> u8 {
        self.region_of(self.across(self.d(row, col).abs()), || {
            self.along(self.t(row, col)).1
        })
    }

    /// The region code of a sample of tests `a`; `gap` says whether the lattice shows the
    /// heater there (asked only inside the cylinder, off its edge).
    #[inline]
    fn region_of(&self, a: Across, gap: impl FnOnce() -> bool) -> u8 {
        if a.cylinder {
            if a.edge {
                2
            } else if gap() {
                0
            } else {
                1
            }
        } else if self.springs && a.spring_lo && a.spring_hi {
            SPRING
        } else if a.radiation {
            3
        } else {
            4
        }
    }
}

/// Which region each sample of each pixel shows, for one geometry and subgrid: what a render
/// keeps between calls, so a view whose geometry did not change costs only its temperatures.
#[derive(Clone, Debug)]
pub struct Layout {
    geometry: Geometry,
    subgrid: usize,
    /// Per pixel: a region code (< [`CODES`]) when every sample shows it, else
    /// `CODES + k` for the `k`-th mixed pixel, whose samples' codes are
    /// `mixed[k·n²..(k+1)·n²]` in sample order.
    pixel: [u8; IMG_PIXELS],
    mixed_at: [u16; IMG_PIXELS],
    mixed: Vec<u8>,
}

impl Layout {
    /// Work out the regions of every sample of `g` on a `subgrid`×`subgrid` grid per pixel,
    /// each exactly as [`sample`] decides it.
    ///
    /// A pixel's samples lie within `reach` of its centre, both across the axis and along it
    /// (the grid is symmetric about the centre), and their computed values within rounding
    /// (≪ 1e-9 px) of the exact ones; so where no test's border comes within `reach` of the
    /// centre, every sample shows the centre's region. Only the pixels a border crosses (about
    /// a quarter) are sampled one by one.
    pub fn new(g: &Geometry, subgrid: usize) -> Self {
        let n = subgrid.max(1);
        let s = Sampler::new(g);
        let half = (n - 1) as f64 / (2 * n) as f64;
        let reach = half * (1.0 + s.slope.abs()) / s.norm + 1e-9;
        let inv_norm = 1.0 / s.norm;
        let mut out = Layout {
            geometry: *g,
            subgrid: n,
            pixel: [0; IMG_PIXELS],
            mixed_at: [0; IMG_PIXELS],
            mixed: Vec::new(),
        };
        // Sample coordinates, exactly as the per-sample formula writes them.
        let coord = |k: usize, i: usize| k as f64 - 0.5 + (i as f64 + 0.5) / n as f64;
        // Every pixel the cheap proof settles, in one pass without branches.
        for r in 0..IMG_ROWS {
            let row = r as f64;
            let centre = s.axis + s.slope * row;
            for c in 0..IMG_COLS {
                let col = c as f64;
                let d = (col - centre) * inv_norm;
                let t = (row + s.slope * (col - s.axis)) * inv_norm;
                out.pixel[r * IMG_COLS + c] = s.settled(d, t, reach);
            }
        }
        let mut n_mixed = 0usize;
        for p in 0..IMG_PIXELS {
            if out.pixel[p] != UNSETTLED {
                continue;
            }
            let (r, c) = (p / IMG_COLS, p % IMG_COLS);
            if n == 4 {
                let rows: [f64; 4] = core::array::from_fn(|i| coord(r, i));
                let cols: [f64; 4] = core::array::from_fn(|j| coord(c, j));
                out.mixed.extend_from_slice(&s.regions_4x4(rows, cols));
            } else {
                for i in 0..n {
                    let row = coord(r, i);
                    for j in 0..n {
                        out.mixed.push(s.region_at(row, coord(c, j)));
                    }
                }
            }
            out.mixed_at[p] = n_mixed as u16;
            n_mixed += 1;
            out.pixel[p] = CODES as u8;
        }
        out
    }

    /// Return the geometry.
    pub fn geometry(&self) -> &Geometry {
        &self.geometry
    }

    /// Return the samples per pixel side.
    pub fn subgrid(&self) -> usize {
        self.subgrid
    }

    /// Return how many pixels a border crosses (sampled in full).
    pub fn mixed_pixels(&self) -> usize {
        self.pixel.iter().filter(|&&z| z as usize >= CODES).count()
    }

    /// The noise-free image of `temps`, K: each pixel the mean of its samples' temperatures,
    /// summed in sample order as [`render`] does.
    pub fn image(&self, temps: &Temps, out: &mut [f64; IMG_PIXELS]) {
        let n2 = self.subgrid * self.subgrid;
        let w = 1.0 / n2 as f64;
        let truth = temps.regions();
        let value: [f64; CODES] = core::array::from_fn(|z| {
            if z == SPRING as usize {
                temps.spring_k * w
            } else {
                truth[z] * w
            }
        });
        let uniform: [f64; CODES] = core::array::from_fn(|z| {
            let mut acc = 0.0;
            for _ in 0..n2 {
                acc += value[z];
            }
            acc
        });
        for p in 0..IMG_PIXELS {
            let z = self.pixel[p] as usize;
            out[p] = if z < CODES {
                uniform[z]
            } else {
                let k = self.mixed_at[p] as usize * n2;
                let mut acc = 0.0;
                for &c in &self.mixed[k..k + n2] {
                    acc += value[c as usize];
                }
                acc
            };
        }
    }

    /// Each pixel's area fraction per region (springs count as background).
    fn fractions(&self, out: &mut [[f32; IMG_PIXELS]; REGIONS]) {
        let n2 = self.subgrid * self.subgrid;
        let w = (1.0 / n2 as f64) as f32;
        // The sum of k samples' weights, added one by one.
        let mut sums = vec![0f32; n2 + 1];
        for k in 1..=n2 {
            sums[k] = sums[k - 1] + w;
        }
        let region = |c: u8| (c as usize).min(REGIONS - 1);
        for p in 0..IMG_PIXELS {
            let z = self.pixel[p] as usize;
            if z < CODES {
                out[region(z as u8)][p] = sums[n2];
            } else {
                let k = self.mixed_at[p] as usize * n2;
                let mut count = [0usize; REGIONS];
                for &c in &self.mixed[k..k + n2] {
                    count[region(c)] += 1;
                }
                for (f, &m) in out.iter_mut().zip(count.iter()) {
                    if m > 0 {
                        f[p] = sums[m];
                    }
                }
            }
        }
    }
}

/// Render the view.
pub fn render(g: &Geometry, temps: &Temps, opts: &Options) -> Rendered {
    let layout = Layout::new(g, opts.subgrid);
    let mut out = Rendered {
        image_k: [0.0; IMG_PIXELS],
        truth_k: temps.regions(),
        fraction: [[0.0; IMG_PIXELS]; REGIONS],
    };
    let mut image = [0.0; IMG_PIXELS];
    layout.image(temps, &mut image);
    layout.fractions(&mut out.fraction);
    let mut rng = Rng::new(opts.seed);
    for (dst, &acc) in out.image_k.iter_mut().zip(image.iter()) {
        let mut acc = acc;
        if opts.noise_k > 0.0 {
            acc += opts.noise_k * rng.gauss();
        }
        *dst = acc as f32;
    }
    out
}

/// A named test scene.
#[derive(Clone, Copy, Debug)]
pub struct Scene {
    /// Short name.
    pub name: &'static str,
    /// Geometry.
    pub geometry: Geometry,
    /// Temperatures.
    pub temps: Temps,
    /// Noise, K rms.
    pub noise_k: f64,
}

/// The standard scenes of the MTTS tests and work-precision table: heating, holding, the
/// forming mode's hot-zone inversion, tilted and shifted cylinders, low contrast, springs,
/// strong noise, cold and hot ambients.
pub fn standard_scenes() -> [Scene; 12] {
    let g = Geometry::default();
    let heat = |bg: f64, t1: f64, t2: f64| Temps::from_surfaces(bg, t1, t2, bg + 5.0);
    let s = |name, geometry, temps, noise_k| Scene {
        name,
        geometry,
        temps,
        noise_k,
    };
    [
        s("standby-323", g, heat(298.0, 328.0, 323.0), 0.1),
        s("heating-358", g, heat(298.0, 372.0, 352.0), 0.1),
        s("holding-358", g, heat(298.0, 361.0, 358.0), 0.1),
        s("forming-inversion", g, heat(298.0, 318.0, 336.0), 0.1),
        s(
            "tilt-12deg",
            Geometry {
                tilt_deg: 12.0,
                ..g
            },
            heat(298.0, 365.0, 350.0),
            0.1,
        ),
        s(
            "shifted-left",
            Geometry {
                axis_col0: 11.0,
                half_width_px: 7.0,
                ..g
            },
            heat(298.0, 360.0, 345.0),
            0.1,
        ),
        s(
            "far-small",
            Geometry {
                half_width_px: 5.0,
                period_px: 10.0,
                ..g
            },
            heat(298.0, 360.0, 345.0),
            0.1,
        ),
        s("low-contrast", g, heat(298.0, 303.0, 301.5), 0.1),
        s(
            "springs-hot",
            Geometry { springs: true, ..g },
            Temps {
                spring_k: 355.0,
                ..heat(298.0, 360.0, 348.0)
            },
            0.1,
        ),
        s("noise-0.5K", g, heat(298.0, 360.0, 348.0), 0.5),
        s("ambient-268", g, heat(268.0, 330.0, 318.0), 0.1),
        s("ambient-318", g, heat(318.0, 365.0, 356.0), 0.1),
    ]
}

impl Scene {
    /// Render the scene with noise seed `seed`.
    pub fn render(&self, seed: u64) -> Rendered {
        render(
            &self.geometry,
            &self.temps,
            &Options {
                subgrid: 8,
                noise_k: self.noise_k,
                seed,
            },
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The renderer as first written: every sample through the per-sample formulas.
    fn render_reference(g: &Geometry, temps: &Temps, opts: &Options) -> Rendered {
        let sample = |row: f64, col: f64| -> Option<usize> {
            let slope = g.tilt_deg.to_radians().tan();
            let norm = (1.0 + slope * slope).sqrt();
            let d = (col - (g.axis_col0 + slope * row)) / norm;
            let t = (row + slope * (col - g.axis_col0)) / norm;
            let ad = d.abs();
            if ad < g.half_width_px {
                if ad >= (1.0 - g.edge_fraction) * g.half_width_px {
                    return Some(2);
                }
                let x = t - g.phase_px;
                let ph = x - (x / g.period_px).floor() * g.period_px;
                return Some(if ph < g.exposed * g.period_px { 0 } else { 1 });
            }
            if g.springs && (ad - (g.half_width_px + 1.5)).abs() < 0.25 {
                return None;
            }
            if ad < g.half_width_px + g.radiation_px {
                Some(3)
            } else {
                Some(4)
            }
        };
        let n = opts.subgrid.max(1);
        let truth = temps.regions();
        let mut rng = Rng::new(opts.seed);
        let mut out = Rendered {
            image_k: [0.0; IMG_PIXELS],
            truth_k: truth,
            fraction: [[0.0; IMG_PIXELS]; REGIONS],
        };
        let w = 1.0 / (n * n) as f64;
        for r in 0..IMG_ROWS {
            for c in 0..IMG_COLS {
                let p = r * IMG_COLS + c;
                let mut acc = 0.0;
                for i in 0..n {
                    for j in 0..n {
                        let row = r as f64 - 0.5 + (i as f64 + 0.5) / n as f64;
                        let col = c as f64 - 0.5 + (j as f64 + 0.5) / n as f64;
                        match sample(row, col) {
                            Some(z) => {
                                acc += truth[z] * w;
                                out.fraction[z][p] += w as f32;
                            }
                            None => {
                                acc += temps.spring_k * w;
                                out.fraction[4][p] += w as f32;
                            }
                        }
                    }
                }
                if opts.noise_k > 0.0 {
                    acc += opts.noise_k * rng.gauss();
                }
                out.image_k[p] = acc as f32;
            }
        }
        out
    }

    fn assert_same(a: &Rendered, b: &Rendered, what: &str) {
        assert_eq!(a.truth_k, b.truth_k, "{what}");
        for p in 0..IMG_PIXELS {
            assert_eq!(
                a.image_k[p].to_bits(),
                b.image_k[p].to_bits(),
                "{what}: pixel {p}: {} vs {}",
                a.image_k[p],
                b.image_k[p]
            );
            for z in 0..REGIONS {
                assert_eq!(
                    a.fraction[z][p].to_bits(),
                    b.fraction[z][p].to_bits(),
                    "{what}: fraction {z} of pixel {p}"
                );
            }
        }
    }

    #[test]
    fn render_matches_the_per_sample_formulas_bit_for_bit() {
        for s in standard_scenes() {
            for seed in [1, 2] {
                let opts = Options {
                    subgrid: 8,
                    noise_k: s.noise_k,
                    seed,
                };
                let want = render_reference(&s.geometry, &s.temps, &opts);
                assert_same(&render(&s.geometry, &s.temps, &opts), &want, s.name);
            }
        }
        // The camera's geometries: springs, a 4×4 subgrid, tilts of a bending column, shifts.
        let mut rng = Rng::new(42);
        let temps = Temps {
            spring_k: 340.0,
            ..Temps::from_surfaces(298.15, 352.0, 347.5, 0.0)
        };
        for k in 0..300 {
            let g = Geometry {
                tilt_deg: if k < 20 {
                    k as f64 * 0.5 - 5.0
                } else {
                    (rng.uniform() - 0.5) * 70.0
                },
                axis_col0: 15.5 + if k % 3 == 0 { rng.uniform() - 0.5 } else { 0.0 },
                phase_px: if k % 5 == 0 {
                    rng.uniform() * 15.0
                } else {
                    2.0
                },
                springs: k % 2 == 0,
                ..Geometry::default()
            };
            for subgrid in [1, 3, 4] {
                let opts = Options {
                    subgrid,
                    noise_k: 0.0,
                    seed: 0,
                };
                let want = render_reference(&g, &temps, &opts);
                assert_same(
                    &render(&g, &temps, &opts),
                    &want,
                    &format!("{g:?} n={subgrid}"),
                );
            }
        }
    }

    #[test]
    fn fractions_sum_to_one_and_noise_free_pixels_are_weighted_means() {
        let scene = &standard_scenes()[1];
        let r = render(
            &scene.geometry,
            &scene.temps,
            &Options {
                noise_k: 0.0,
                ..Options::default()
            },
        );
        for p in 0..IMG_PIXELS {
            let total: f32 = (0..REGIONS).map(|z| r.fraction[z][p]).sum();
            assert!((total - 1.0).abs() < 1e-5);
            let mean: f64 = (0..REGIONS)
                .map(|z| r.fraction[z][p] as f64 * r.truth_k[z])
                .sum();
            assert!((mean - r.image_k[p] as f64).abs() < 1e-3);
        }
    }

    #[test]
    fn lattice_gap_fraction_holds() {
        let g = Geometry::default();
        let (mut gap, mut ring) = (0, 0);
        for i in 0..1500 {
            match sample(&g, i as f64 * 0.01, g.axis_col0) {
                Some(0) => gap += 1,
                Some(1) => ring += 1,
                other => panic!("on the axis: {other:?}"),
            }
        }
        let f = gap as f64 / (gap + ring) as f64;
        assert!((f - LATTICE_GAP_FRACTION as f64).abs() < 0.01, "{f}");
    }

    #[test]
    fn noise_has_the_asked_rms() {
        let scene = &standard_scenes()[0];
        let clean = render(
            &scene.geometry,
            &scene.temps,
            &Options {
                noise_k: 0.0,
                ..Options::default()
            },
        );
        let noisy = render(
            &scene.geometry,
            &scene.temps,
            &Options {
                noise_k: 0.5,
                seed: 9,
                ..Options::default()
            },
        );
        let var: f64 = clean
            .image_k
            .iter()
            .zip(noisy.image_k.iter())
            .map(|(a, b)| ((b - a) as f64).powi(2))
            .sum::<f64>()
            / IMG_PIXELS as f64;
        assert!((var.sqrt() - 0.5).abs() < 0.05, "{}", var.sqrt());
    }
}
