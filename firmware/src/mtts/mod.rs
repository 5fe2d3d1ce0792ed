//! Multi-target thermal sensing (MTTS): five region temperatures from a 32×24 frame.
//!
//! The thesis pipeline (6.3.3.1) — cubic interpolation, k-means on temperature, regions by
//! temperature rank — made deterministic, optimal and spatially aware:
//! 1. broken pixels (NaN) are filled from their valid neighbours ([`inpaint`]), and marked
//!    ([`Scratch::filled`]: the lattice fit leaves them out);
//! 2. [`upsample`]: bicubic by s = 1…8 (default 4), streamed into a histogram;
//! 3. [`cluster`]: exact 1-D k-means of the binned values (K = 2…8, default 5) by dynamic
//!    programming — or Lloyd with random / k-means++ seeding for comparison;
//! 4. [`regions`]: clusters mapped to regions by where their pixels lie (cylinder axis, lattice
//!    phase, continuity with the previous frame);
//! 5. [`lattice`]: T1 and T2 by least squares on the per-pixel region-mix forward model of the
//!    cylinder's core (the refinement of SPEC section 3), with the supervisor's [`Prior`], a
//!    bound and a per-frame [`Quality`] (resolved, ambiguous, merged, fallback) — never NaN, never a
//!    guess presented as a measurement.
//!
//! [`Mtts`] owns the settings and the state that persists between frames (the last geometry);
//! [`Scratch`] is the working memory (≈ 43 KB, all zero at start so a `static` of it costs no
//! flash); [`Mtts::process`] runs one frame. No heap.

pub mod cluster;
pub mod lattice;
pub mod regions;
pub mod upsample;

use cluster::{Clusters, DEFAULT_BINS, DpScratch, Histogram, XorShift};
use regions::{Coords, Fresh, Geometry};

use upsample::{UpsampleScratch, Upsampler};

use crate::units::Kelvin;

/// How well a frame separated the two control targets (T1, the heater area seen through the
/// lattice, and T2, the SMP outer surface).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum Quality {
    /// T1 and T2 were measured as two separate targets.
    Resolved,
    /// T1 and T2 were separated, not for sure: which is which only the supervisor's prior (or
    /// the previous frame) says (heater and surface stripes of one width, a faint lattice), or
    /// their levels are uncertain (stripes thinner than about 1.5 px, whose level trades
    /// against their width). T1 and T2 are the fit's best values and the bound holds them
    /// whichever assignment is right. Not a resolved frame: the supervisor judges it by the
    /// worst its bound allows.
    Ambiguous,
    /// The image cannot separate them at this lattice period and optics; both carry the best
    /// estimate of their area-weighted mean.
    Merged,
    /// No lattice or cylinder fit yet (a cold, uniform block at power-up): T2 is the cylinder
    /// core's temperature and T1 the same.
    Fallback,
}

impl Quality {
    /// Return the stable lower-case name used on the console and in files.
    pub fn name(self) -> &'static str {
        match self {
            Self::Resolved => "resolved",
            Self::Ambiguous => "ambiguous",
            Self::Merged => "merged",
            Self::Fallback => "fallback",
        }
    }
}

/// Image rows.
pub const IMG_ROWS: usize = 24;
/// Image columns.
pub const IMG_COLS: usize = 32;
/// Image pixels.
pub const IMG_PIXELS: usize = IMG_ROWS * IMG_COLS;
/// Number of regions.
pub const REGIONS: usize = 5;
/// Region names, in order (region 1 first).
pub const REGION_NAMES: [&str; REGIONS] = ["heater", "surface", "edge", "radiation", "background"];
/// Values outside this range are not temperatures a working sensor reports here, K; they are
/// treated as broken pixels (the sensor's saturation shows as values pinned at its extremes,
/// which stay inside).
pub const PLAUSIBLE_K: (f32, f32) = (150.0, 1000.0);

/// MTTS errors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum MttsError {
    /// Upsampling factor outside 1…8.
    BadScale {
        /// The factor asked for.
        scale: u8,
    },
    /// Cluster count outside 2…8.
    BadK {
        /// The count asked for.
        k: u8,
    },
    /// Histogram bins outside 2…512.
    BadBins {
        /// The count asked for.
        bins: u16,
    },
    /// Design exposed fraction outside 15…90 %.
    BadExposed {
        /// The percentage asked for.
        exposed_pct: u8,
    },
    /// No pixel holds a plausible temperature.
    NoValidPixels,
    /// More pixels were broken than [`Config::max_filled`] allows to fill in (the sensor-loss
    /// fault).
    TooManyBroken {
        /// Broken pixels in the frame.
        broken: u16,
        /// The limit.
        limit: u16,
    },
}

impl core::fmt::Display for MttsError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Self::BadScale { scale } => write!(f, "upsampling factor {scale} is not 1-8"),
            Self::BadK { k } => write!(f, "cluster count {k} is not 2-8"),
            Self::BadBins { bins } => write!(f, "histogram bins {bins} is not 2-512"),
            Self::BadExposed { exposed_pct } => {
                write!(f, "exposed fraction {exposed_pct} % is not 15-90")
            }
            Self::NoValidPixels => write!(f, "no valid pixel in the frame"),
            Self::TooManyBroken { broken, limit } => {
                write!(f, "{broken} broken pixels, more than the {limit} allowed")
            }
        }
    }
}

/// Clustering method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum Method {
    /// Exact 1-D k-means by dynamic programming (the default).
    Exact,
    /// Lloyd's algorithm from random initial centroids (the thesis; feature
    /// `comparison-methods`).
    #[cfg(feature = "comparison-methods")]
    Lloyd,
    /// Lloyd's algorithm from k-means++ seeding (feature `comparison-methods`).
    #[cfg(feature = "comparison-methods")]
    KMeansPlusPlus,
}

/// What the supervisor's mode says about the two control targets: a prior the region finder
/// combines with the spatial fit (it never decides alone).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum Prior {
    /// Nothing known (power-up, a fault).
    #[default]
    Unknown,
    /// The heater area is expected hotter than the SMP surface (the heating modes).
    HeaterHotter,
    /// The SMP surface is expected hotter than the heater area (forming's hot-zone inversion).
    SurfaceHotter,
}

/// MTTS settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct Config {
    /// Upsampling factor, 1…8.
    pub scale: u8,
    /// Number of clusters, 2…8.
    pub k: u8,
    /// Histogram bins, 2…512.
    pub bins: u16,
    /// Clustering method.
    pub method: Method,
    /// Seed of the Lloyd methods' generator.
    pub seed: u64,
    /// Most broken pixels a frame may have filled in; above it the frame is refused
    /// ([`MttsError::TooManyBroken`]).
    pub max_filled: u16,
    /// The block's design: the share of each lattice unit through which the heater shows,
    /// percent (the thesis's block: 21.35 mm of 30 mm, 71 %). A frame's own fraction is fitted
    /// within [`lattice::EXPOSED_TOLERANCE`] of it; it tells the heater's stripes from the
    /// surface's wherever the two differ in width (away from 50 %).
    pub exposed_pct: u8,
}

/// Default [`Config::max_filled`]: 32 pixels (4 % of the frame). The MLX90640 datasheet allows
/// at most 4 defective pixels per device; 32 leaves room for those plus transient outliers,
/// while filled pixels stay isolated enough to be interpolated and cannot cover more than a
/// quarter of the smallest cylinder core (≈ 6 × 24 px at 100 mm).
pub const DEFAULT_MAX_FILLED: u16 = 32;

/// Default [`Config::exposed_pct`]: the thesis's lattice, rounded to a percent.
pub const DEFAULT_EXPOSED_PCT: u8 =
    (crate::block::LATTICE_GAP_MM * 100.0 / crate::block::LATTICE_UNIT_MM + 0.5) as u8;

impl Default for Config {
    /// s = 4, K = 5, 128 bins, exact: SPEC section 3 (bins: the Cortex-M4 budget).
    fn default() -> Self {
        Config {
            scale: 4,
            k: 5,
            bins: DEFAULT_BINS as u16,
            method: Method::Exact,
            seed: 1,
            max_filled: DEFAULT_MAX_FILLED,
            exposed_pct: DEFAULT_EXPOSED_PCT,
        }
    }
}

/// One region's result.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct Region {
    /// The region's temperature (its cluster's mean); `None` only if that mean is NaN, which a
    /// processed frame (every pixel filled and finite) never gives.
    pub temp: Option<Kelvin>,
    /// Upsampled pixels in its cluster.
    pub pixels: u32,
    /// Sensor pixels in its zone.
    pub zone_pixels: u16,
}

/// The lattice's exposed fraction as one frame saw it, against the design (the heater's share
/// of a lattice unit): what `status` reports, and what the supervisor warns about when the
/// frames adopt a fraction unlike the configured design ([`lattice::Exposure`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LatticeExposure {
    /// The exposed fraction this frame's fit shows, %.
    pub fitted_pct: f32,
    /// The design the next frame fits with: the configured one, or the fraction the frames
    /// adopted in its place, %.
    pub design_pct: f32,
    /// The configured design ([`Config::exposed_pct`]), %.
    pub configured_pct: f32,
    /// This frame's run of readings adopted `design_pct` in place of the design in use before.
    pub adopted: bool,
    /// The exposed fraction this frame's image shows where it is unlike the design in use,
    /// read as the supervisor's prior orders the targets (`None` without a prior, or where
    /// the image agrees with the design), %.
    pub shows_pct: Option<f32>,
}

/// One frame's MTTS result (every temperature finite).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Output {
    /// Regions 1…5 (heater, surface, edge, radiation, background). T1 and T2 are the
    /// [`lattice`] fit's; regions 3–5 their clusters' means.
    pub regions: [Region; REGIONS],
    /// How well T1 and T2 were separated this frame.
    pub quality: Quality,
    /// Bound on |T1 − truth| and |T2 − truth|, K (for a merged frame: how far either may lie
    /// from the area-weighted mean both carry).
    pub bound: Kelvin,
    /// T1 and T2 as the clustering alone assigns them (the thesis method, for comparison).
    pub clustered: [Option<Kelvin>; 2],
    /// Lowest sensor pixel over the cylinder (core and edges), if any pixel lies on it.
    pub cylinder_min: Option<Kelvin>,
    /// Hottest sensor pixel of the frame (wherever it lies: a spring burning beside the
    /// cylinder shows there), if any pixel lies on the cylinder
    /// ([`Scratch::hottest_k`]).
    pub hottest: Option<Kelvin>,
    /// The clusters.
    pub clusters: Clusters,
    /// The geometry used.
    pub geometry: Geometry,
    /// What was re-estimated this frame.
    pub fresh: Fresh,
    /// Pixels that were broken and filled in.
    pub filled_pixels: u16,
    /// The lattice's exposed fraction this frame, against the design: `None` unless the frame
    /// fitted a lattice and decided which target is hotter (resolved or ambiguous).
    pub exposure: Option<LatticeExposure>,
}

impl Output {
    /// Return T1 (heater area).
    pub fn t1(&self) -> Option<Kelvin> {
        self.regions[0].temp
    }

    /// Return T2 (SMP outer surface).
    pub fn t2(&self) -> Option<Kelvin> {
        self.regions[1].temp
    }

    /// Return the controlled temperature Tc = w1·T1 + w2·T2 (`None` without T1 or T2).
    pub fn controlled(&self, w: Weights) -> Option<Kelvin> {
        w.apply(self.t1()?, self.t2()?)
    }
}

/// Weights of the controlled temperature Tc = w1·T1 + w2·T2 (w1 + w2 = 1).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct Weights {
    /// Weight of T1.
    pub w1: f32,
    /// Weight of T2.
    pub w2: f32,
}

impl Weights {
    /// Make weights; `None` unless both are in [0, 1] and sum to 1 (±1e-4).
    pub fn new(w1: f32, w2: f32) -> Option<Self> {
        let ok = (0.0..=1.0).contains(&w1) && (0.0..=1.0).contains(&w2);
        (ok && libm::fabsf(w1 + w2 - 1.0) < 1e-4).then_some(Weights { w1, w2 })
    }

    /// Return w1·t1 + w2·t2 (`None` if that is NaN: NaN weights, or 0 · ∞).
    pub fn apply(self, t1: Kelvin, t2: Kelvin) -> Option<Kelvin> {
        Kelvin::new(self.w1 * t1.k() + self.w2 * t2.k())
    }
}

/// Fill non-finite or implausible pixels with the mean of their valid 8-neighbours, repeating
/// until all are filled; returns how many were broken, or `NoValidPixels`.
pub fn inpaint(img: &mut [f32; IMG_PIXELS]) -> Result<u16, MttsError> {
    inpaint_range(img, &mut [0; IMG_ROWS]).map(|(bad, _, _)| bad)
}

/// [`inpaint`], also returning the image's range (lowest, highest value), K, and marking the
/// filled pixels in `filled`. Filled pixels are means of valid ones, so the range is that of
/// the valid pixels.
fn inpaint_range(
    img: &mut [f32; IMG_PIXELS],
    filled: &mut FilledRows,
) -> Result<(u16, f32, f32), MttsError> {
    *filled = [0; IMG_ROWS];
    // The range by plain comparisons, which a NaN (a pixel the driver flags as broken) passes
    // neither, and the NaNs counted. Only a frame whose range is not all plausible (a glitch:
    // a value off the sensor's scale, an infinity) is looked at pixel by pixel: a flagged pixel
    // every frame costs no second pass.
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    let mut bad = 0u16;
    for &v in img.iter() {
        if v < lo {
            lo = v;
        }
        if v > hi {
            hi = v;
        }
        bad += u16::from(v.is_nan());
    }
    if !(lo >= PLAUSIBLE_K.0 && hi <= PLAUSIBLE_K.1) {
        bad = 0;
        (lo, hi) = (PLAUSIBLE_K.1, PLAUSIBLE_K.0);
        for v in img.iter_mut() {
            // NaN fails both comparisons.
            if *v >= PLAUSIBLE_K.0 && *v <= PLAUSIBLE_K.1 {
                if *v < lo {
                    lo = *v;
                }
                if *v > hi {
                    hi = *v;
                }
            } else {
                *v = f32::NAN;
                bad += 1;
            }
        }
    }
    if bad as usize == IMG_PIXELS {
        return Err(MttsError::NoValidPixels);
    }
    if bad == 0 {
        return Ok((0, lo, hi));
    }
    for (p, v) in img.iter().enumerate() {
        if v.is_nan() {
            filled[p / IMG_COLS] |= 1 << (p % IMG_COLS);
        }
    }
    // In rounds, each broken pixel with a valid neighbour takes their mean. A neighbour is
    // valid when it was not broken at the round's start (`todo`): a pixel filled in this round
    // feeds the next round, not this one. Only the broken pixels are visited, by their marks.
    let mut todo = *filled;
    let mut left = bad;
    while left > 0 {
        let mut next = todo;
        for r in 0..IMG_ROWS {
            let mut bits = todo[r];
            while bits != 0 {
                let c = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let (mut s, mut n) = (0f32, 0f32);
                for rr in r.saturating_sub(1)..(r + 2).min(IMG_ROWS) {
                    for cc in c.saturating_sub(1)..(c + 2).min(IMG_COLS) {
                        if (todo[rr] >> cc) & 1 == 0 {
                            s += img[rr * IMG_COLS + cc];
                            n += 1.0;
                        }
                    }
                }
                if n > 0.0 {
                    img[r * IMG_COLS + c] = s / n;
                    next[r] &= !(1 << c);
                    left -= 1;
                }
            }
        }
        todo = next;
    }
    Ok((bad, lo, hi))
}

/// Which pixels of a frame were broken and filled in ([`inpaint`]): bit c of word r is the
/// pixel in row r, column c.
pub type FilledRows = [u32; IMG_ROWS];

/// Working memory of the pipeline (keep it in a `static` on the target).
pub struct Scratch {
    up: UpsampleScratch,
    dp: DpScratch,
    xy: Coords,
    /// The last frame with its broken pixels filled, K.
    pub work: [f32; IMG_PIXELS],
    /// The last frame's histogram of upsampled values.
    pub hist: Histogram,
    /// The last frame's highest value, K (broken pixels filled): the range
    /// [`Mtts::stage_upsample`] finds for the histogram.
    pub hottest_k: f32,
    /// The last frame's lowest value, K (the other end of that range).
    pub coldest_k: f32,
    /// The last frame's pixels that were broken and filled in.
    pub filled: FilledRows,
}

impl Default for Scratch {
    fn default() -> Self {
        Self::new()
    }
}

impl Scratch {
    /// Return zeroed working memory.
    pub const fn new() -> Self {
        Scratch {
            up: UpsampleScratch::new(),
            dp: DpScratch::new(),
            xy: Coords::ZERO,
            work: [0.0; IMG_PIXELS],
            hist: Histogram::EMPTY,
            // Zero, as every field: an all-zero static lies in .bss, not in flash.
            hottest_k: 0.0,
            coldest_k: 0.0,
            filled: [0; IMG_ROWS],
        }
    }
}

/// The MTTS settings and the state kept between frames.
#[derive(Clone, Debug)]
pub struct Mtts {
    config: Config,
    upsampler: Upsampler,
    geometry: Geometry,
    rng: XorShift,
    prior: Prior,
}

impl Mtts {
    /// Make the pipeline for `config` (checked).
    pub fn new(config: Config) -> Result<Self, MttsError> {
        if !(2..=cluster::MAX_K as u8).contains(&config.k) {
            return Err(MttsError::BadK { k: config.k });
        }
        if !(2..=cluster::MAX_BINS as u16).contains(&config.bins) {
            return Err(MttsError::BadBins { bins: config.bins });
        }
        if !(15..=90).contains(&config.exposed_pct) {
            return Err(MttsError::BadExposed {
                exposed_pct: config.exposed_pct,
            });
        }
        Ok(Mtts {
            upsampler: Upsampler::new(config.scale)?,
            config,
            geometry: Geometry::DEFAULT,
            rng: XorShift::new(config.seed),
            prior: Prior::Unknown,
        })
    }

    /// Return the settings.
    pub fn config(&self) -> Config {
        self.config
    }

    /// Return the geometry the next frame starts from.
    pub fn geometry(&self) -> Geometry {
        self.geometry
    }

    /// Set the prior the next frames are read with (kept until changed).
    pub fn set_prior(&mut self, prior: Prior) {
        self.prior = prior;
    }

    /// Return the prior in force.
    pub fn prior(&self) -> Prior {
        self.prior
    }

    /// Forget the previous frames (geometry back to the default).
    pub fn reset(&mut self) {
        self.geometry = Geometry::DEFAULT;
        self.rng = XorShift::new(self.config.seed);
    }

    /// Stage 1–2: inpaint into `scratch.work`, upsample into `scratch.hist`. Returns how many
    /// pixels were broken and filled; refuses a frame with more than `max_filled` of them.
    pub fn stage_upsample(
        &mut self,
        image: &[f32; IMG_PIXELS],
        scratch: &mut Scratch,
    ) -> Result<u16, MttsError> {
        scratch.work = *image;
        let (filled, lo, hi) = inpaint_range(&mut scratch.work, &mut scratch.filled)?;
        if filled > self.config.max_filled {
            return Err(MttsError::TooManyBroken {
                broken: filled,
                limit: self.config.max_filled,
            });
        }
        scratch.hist.reset(lo, hi, self.config.bins as usize)?;
        scratch.hottest_k = hi;
        scratch.coldest_k = lo;
        let Scratch { up, hist, work, .. } = scratch;
        self.upsampler.histogram(work, hist, up);
        Ok(filled)
    }

    /// Stage 3: cluster the histogram of the last [`Mtts::stage_upsample`].
    pub fn stage_cluster(&mut self, scratch: &mut Scratch) -> Result<Clusters, MttsError> {
        let hist = &scratch.hist;
        let k = self.config.k as usize;
        match self.config.method {
            Method::Exact => cluster::exact_binned(hist, k, &mut scratch.dp),
            #[cfg(feature = "comparison-methods")]
            Method::Lloyd => cluster::lloyd(hist, k, cluster::Seeding::Random, &mut self.rng, 100),
            #[cfg(feature = "comparison-methods")]
            Method::KMeansPlusPlus => cluster::lloyd(
                hist,
                k,
                cluster::Seeding::KMeansPlusPlus,
                &mut self.rng,
                100,
            ),
        }
    }

    /// Stage 4: regions from the filled image and the clusters, T1 and T2 from the lattice
    /// fit; updates the geometry.
    pub fn stage_regions(
        &mut self,
        clusters: &Clusters,
        filled: u16,
        scratch: &mut Scratch,
    ) -> Output {
        let Scratch {
            work,
            xy,
            hottest_k,
            coldest_k,
            filled: filled_rows,
            ..
        } = scratch;
        let (mut g, fresh) =
            regions::update_geometry(work, (*coldest_k, *hottest_k), &self.geometry, xy);
        let configured = f32::from(self.config.exposed_pct) / 100.0;
        let sep = lattice::separate(
            work,
            xy,
            &mut g,
            self.prior,
            configured,
            *hottest_k - *coldest_k,
            filled_rows,
        );
        let decided = matches!(sep.quality, Quality::Resolved | Quality::Ambiguous);
        let exposure = (decided || sep.adopted.is_some()).then(|| LatticeExposure {
            fitted_pct: 100.0 * g.exposed,
            design_pct: 100.0 * g.exposure.design(configured),
            configured_pct: f32::from(self.config.exposed_pct),
            adopted: sep.adopted.is_some(),
            shows_pct: sep.shows.map(|f| 100.0 * f),
        });
        self.geometry = g;
        let (o, cylinder_min) = regions::overlap_and_min(work, &g, xy, clusters);
        let pick = regions::assign(&o, clusters.k);
        let mut regions: [Region; REGIONS] = core::array::from_fn(|z| {
            let zone_pixels = o[z].iter().sum();
            match pick[z] {
                Some(c) => Region {
                    temp: Kelvin::new(clusters.means[c]),
                    pixels: clusters.counts[c],
                    zone_pixels,
                },
                // A zone without pixels: the cylinder's mean stands in (never NaN).
                None => Region {
                    temp: Kelvin::new(sep.mean_k),
                    pixels: 0,
                    zone_pixels,
                },
            }
        });
        let clustered = [regions[0].temp, regions[1].temp];
        regions[0].temp = Kelvin::new(sep.t1_k);
        regions[1].temp = Kelvin::new(sep.t2_k);
        Output {
            regions,
            quality: sep.quality,
            // A spread of finite pixels, so never NaN. Were it NaN, 0 is what every use made of
            // it before `Kelvin` refused NaN (`Measurement::hotter`/`colder` take the bound's
            // `max(0.0)`), so nothing downstream changes.
            bound: Kelvin::new(sep.bound_k).unwrap_or(Kelvin::lit(0.0)),
            clustered,
            cylinder_min: cylinder_min.and_then(Kelvin::new),
            // As `cylinder_min`, given when a pixel lies on the cylinder.
            hottest: cylinder_min.and(Kelvin::new(*hottest_k)),
            clusters: *clusters,
            geometry: g,
            fresh,
            filled_pixels: filled,
            exposure,
        }
    }

    /// Run the whole pipeline on one frame (K, NaN for broken pixels).
    pub fn process(
        &mut self,
        image: &[f32; IMG_PIXELS],
        scratch: &mut Scratch,
    ) -> Result<Output, MttsError> {
        let filled = self.stage_upsample(image, scratch)?;
        let clusters = self.stage_cluster(scratch)?;
        Ok(self.stage_regions(&clusters, filled, scratch))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch() -> std::boxed::Box<Scratch> {
        std::boxed::Box::new(Scratch::new())
    }

    #[test]
    fn all_broken_is_an_error() {
        let mut m = Mtts::new(Config::default()).unwrap();
        assert_eq!(
            m.process(&[f32::NAN; IMG_PIXELS], &mut scratch())
                .unwrap_err(),
            MttsError::NoValidPixels
        );
    }

    /// Every region finite and in the image's range; returns the output.
    fn finite(out: Output, lo: f32, hi: f32) -> Output {
        for (z, r) in out.regions.iter().enumerate() {
            let t = r.temp.expect("a temperature").k();
            assert!(t.is_finite(), "region {} is {t}", z + 1);
            assert!(t >= lo - 1e-3 && t <= hi + 1e-3, "region {}: {t}", z + 1);
        }
        assert!(out.bound.k().is_finite() && out.bound.k() >= 0.0);
        out
    }

    #[test]
    fn uniform_scene_gives_one_temperature_and_falls_back() {
        let mut m = Mtts::new(Config::default()).unwrap();
        let out = finite(
            m.process(&[300.0; IMG_PIXELS], &mut scratch()).unwrap(),
            300.0,
            300.0,
        );
        assert_eq!(out.clusters.k, 1);
        assert_eq!(out.quality, Quality::Fallback);
        assert!((out.t1().unwrap().k() - 300.0).abs() < 1e-4);
        assert!((out.t2().unwrap().k() - 300.0).abs() < 1e-4);
        assert_eq!(out.hottest, Some(Kelvin::lit(300.0)));
    }

    #[test]
    fn cold_power_up_gives_the_core_as_t2() {
        // A cold block at 296 K on a 294 K background: no lattice visible, sensor noise.
        let mut rng = cluster::XorShift::new(3);
        let img: [f32; IMG_PIXELS] = core::array::from_fn(|p| {
            let c = (p % IMG_COLS) as f32;
            let noise = (rng.next_f32() - 0.5) * 0.2;
            (if (c - 15.5).abs() < 6.0 { 296.0 } else { 294.0 }) + noise
        });
        let mut m = Mtts::new(Config::default()).unwrap();
        let out = finite(m.process(&img, &mut scratch()).unwrap(), 293.8, 296.2);
        assert_eq!(out.quality, Quality::Fallback);
        assert!(
            (out.t2().unwrap().k() - 296.0).abs() < 0.1,
            "T2 {}",
            out.t2().unwrap().k()
        );
        assert!(
            (out.t1().unwrap().k() - 296.0).abs() < 0.1,
            "T1 {}",
            out.t1().unwrap().k()
        );
    }

    #[test]
    fn saturated_pixels_stay_finite() {
        // A cylinder pinned at the sensor's top (573 K) over a cold background.
        let img: [f32; IMG_PIXELS] = core::array::from_fn(|p| {
            if ((p % IMG_COLS) as f32 - 15.5).abs() < 7.0 {
                573.15
            } else {
                233.15
            }
        });
        let mut m = Mtts::new(Config::default()).unwrap();
        let out = finite(m.process(&img, &mut scratch()).unwrap(), 233.15, 573.15);
        assert!(
            (out.t2().unwrap().k() - 573.15).abs() < 1.0,
            "T2 {}",
            out.t2().unwrap().k()
        );
    }

    #[test]
    fn all_broken_but_one_region_is_refused_or_finite() {
        // Only the background (left columns) survives.
        let img: [f32; IMG_PIXELS] =
            core::array::from_fn(|p| if p % IMG_COLS < 4 { 298.0 } else { f32::NAN });
        let mut m = Mtts::new(Config::default()).unwrap();
        assert_eq!(
            m.process(&img, &mut scratch()).unwrap_err(),
            MttsError::TooManyBroken {
                broken: 672,
                limit: DEFAULT_MAX_FILLED
            }
        );
        let mut lax = Mtts::new(Config {
            max_filled: IMG_PIXELS as u16,
            ..Config::default()
        })
        .unwrap();
        let out = finite(lax.process(&img, &mut scratch()).unwrap(), 298.0, 298.0);
        assert_eq!(out.filled_pixels, 672);
    }

    #[test]
    fn single_hot_pixel_is_its_own_cluster() {
        let mut img = [300.0; IMG_PIXELS];
        img[100] = 400.0;
        let mut m = Mtts::new(Config {
            scale: 1,
            ..Config::default()
        })
        .unwrap();
        let out = finite(m.process(&img, &mut scratch()).unwrap(), 300.0, 400.0);
        assert_eq!(out.clusters.k, 2, "two distinct values");
        assert_eq!(out.clusters.counts[1], 1);
        // Values stand at their bin's centre: within half a bin of 400 K.
        let half_bin = 100.0 / cluster::DEFAULT_BINS as f32 / 2.0;
        assert!((out.clusters.means[1] - 400.0).abs() <= half_bin + 1e-3);
    }

    /// Fill broken pixels as the pipeline's first version did, pixel by pixel: non-finite or
    /// implausible values are NaN, then rounds over a copy of the frame, each NaN taking its
    /// valid 8-neighbours' mean. Returns how many were broken.
    fn inpaint_by_copies(img: &mut [f32; IMG_PIXELS]) -> u16 {
        let mut bad = 0;
        for v in img.iter_mut() {
            if !(*v >= PLAUSIBLE_K.0 && *v <= PLAUSIBLE_K.1) {
                *v = f32::NAN;
                bad += 1;
            }
        }
        let mut left = bad;
        while left > 0 {
            let prev = *img;
            for p in (0..IMG_PIXELS).filter(|&p| prev[p].is_nan()) {
                let (r, c) = ((p / IMG_COLS) as i32, (p % IMG_COLS) as i32);
                let (mut s, mut n) = (0f32, 0f32);
                for rr in r - 1..=r + 1 {
                    for cc in c - 1..=c + 1 {
                        if (0..IMG_ROWS as i32).contains(&rr) && (0..IMG_COLS as i32).contains(&cc)
                        {
                            let v = prev[rr as usize * IMG_COLS + cc as usize];
                            if !v.is_nan() {
                                s += v;
                                n += 1.0;
                            }
                        }
                    }
                }
                if n > 0.0 {
                    img[p] = s / n;
                    left -= 1;
                }
            }
        }
        bad
    }

    proptest::proptest! {
        #![proptest_config(proptest::test_runner::Config::with_cases(300))]

        /// Any frame with some valid pixel: the same filled frame, to the bit, as pixel-by-pixel
        /// rounds over copies; the marks are exactly the broken pixels; the range is the valid
        /// pixels'. Broken pixels come alone, in clusters and as whole rows, NaN, infinite or
        /// off the plausible scale.
        #[test]
        fn inpainting_is_the_rounds_over_copies(
            base in proptest::collection::vec(250.0f32..400.0, IMG_PIXELS),
            broken in proptest::collection::vec((0usize..IMG_PIXELS, 0u8..4, 0usize..3), 0..40),
        ) {
            let mut img: [f32; IMG_PIXELS] = core::array::from_fn(|p| base[p]);
            for &(q, kind, spread) in &broken {
                let v = [f32::NAN, f32::INFINITY, PLAUSIBLE_K.1 + 5.0, PLAUSIBLE_K.0 - 5.0][kind as usize];
                // One pixel, a 3-pixel run, or a whole row.
                let span = match spread { 0 => q..q + 1, 1 => q..(q + 3).min(IMG_PIXELS), _ => {
                    let r = q / IMG_COLS;
                    r * IMG_COLS..(r + 1) * IMG_COLS
                } };
                for p in span {
                    img[p] = v;
                }
            }
            let was_broken: Vec<bool> =
                img.iter().map(|v| !(*v >= PLAUSIBLE_K.0 && *v <= PLAUSIBLE_K.1)).collect();
            let mut want = img;
            let want_bad = inpaint_by_copies(&mut want);
            let valid: Vec<f32> = img.iter().copied().filter(|v| *v >= PLAUSIBLE_K.0 && *v <= PLAUSIBLE_K.1).collect();
            let mut filled = [0; IMG_ROWS];
            let got = inpaint_range(&mut img, &mut filled);
            if valid.is_empty() {
                proptest::prop_assert_eq!(got, Err(MttsError::NoValidPixels));
                return Ok(());
            }
            let lo = valid.iter().copied().fold(f32::INFINITY, f32::min);
            let hi = valid.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            proptest::prop_assert_eq!(got, Ok((want_bad, lo, hi)));
            for p in 0..IMG_PIXELS {
                proptest::prop_assert_eq!(img[p].to_bits(), want[p].to_bits(), "pixel {}", p);
                let marked = (filled[p / IMG_COLS] >> (p % IMG_COLS)) & 1 != 0;
                proptest::prop_assert_eq!(marked, was_broken[p], "pixel {}", p);
            }
        }
    }

    #[test]
    fn broken_pixels_are_filled() {
        let mut img = [300.0; IMG_PIXELS];
        img[5] = f32::NAN;
        img[6] = f32::INFINITY;
        img[7] = 5000.0;
        let mut m = Mtts::new(Config::default()).unwrap();
        let out = m.process(&img, &mut scratch()).unwrap();
        assert_eq!(out.filled_pixels, 3);
        assert!((out.t1().unwrap().k() - 300.0).abs() < 1e-3);
    }

    #[test]
    fn the_range_and_the_filled_pixels_are_the_valid_pixels_own() {
        // A clean frame (the path that only finds its range) and frames with one pixel broken
        // in each way (NaN first, where the range starts; beyond either plausible end; an
        // infinity): the range is the valid pixels', and exactly the broken pixels are marked.
        let clean: [f32; IMG_PIXELS] = core::array::from_fn(|p| 290.0 + (p % 97) as f32 * 0.5);
        let (lo, hi) = (290.0, 290.0 + 96.0 * 0.5);
        let mut filled = [u32::MAX; IMG_ROWS];
        let mut img = clean;
        assert_eq!(inpaint_range(&mut img, &mut filled), Ok((0, lo, hi)));
        assert_eq!(filled, [0; IMG_ROWS]);
        assert_eq!(img, clean);
        for (q, v) in [
            (0, f32::NAN),
            (40, PLAUSIBLE_K.0 - 1.0),
            (700, PLAUSIBLE_K.1 + 1.0),
            (767, f32::NEG_INFINITY),
        ] {
            let mut img = clean;
            img[q] = v;
            let (bad, l, h) = inpaint_range(&mut img, &mut filled).expect("a frame");
            assert_eq!(bad, 1, "pixel {q} at {v}");
            // The valid pixels' range (other pixels hold each extreme too).
            assert_eq!((l, h), (lo, hi), "pixel {q} at {v}");
            let mut want = [0u32; IMG_ROWS];
            want[q / IMG_COLS] = 1 << (q % IMG_COLS);
            assert_eq!(filled, want, "pixel {q} at {v}");
            assert!(img[q].is_finite() && img[q] >= lo && img[q] <= hi);
        }
    }

    #[test]
    fn config_is_checked() {
        assert!(
            Mtts::new(Config {
                k: 1,
                ..Config::default()
            })
            .is_err()
        );
        assert!(
            Mtts::new(Config {
                k: 9,
                ..Config::default()
            })
            .is_err()
        );
        assert!(
            Mtts::new(Config {
                scale: 0,
                ..Config::default()
            })
            .is_err()
        );
        assert!(
            Mtts::new(Config {
                bins: 1000,
                ..Config::default()
            })
            .is_err()
        );
    }

    #[test]
    fn weights() {
        assert!(Weights::new(0.5, 0.6).is_none());
        let w = Weights::new(0.25, 0.75).unwrap();
        assert_eq!(
            w.apply(Kelvin::lit(300.0), Kelvin::lit(340.0)).unwrap().k(),
            330.0
        );
    }
}
