//! A family of camera views, not a list: randomized geometry and optics of the block seen by
//! the MLX90640, for tuning MTTS on one seed range and reporting on another it never saw.
//!
//! Each seed draws, uniformly: lattice period 4–16 px; cylinder width 6–20 px; exposed (heater)
//! fraction 0.2–0.85; tilt ±35° (a bent column's middle leans by half its bend); axis shift
//! ±3 px and any lattice phase; camera distance 50–100 mm (SPEC section 1), which sets the
//! radiation halo (a 12 mm band, at the 110° × 75° sensor's 3.44° per pixel); noise
//! 0.05–0.5 K rms; SMP surface 300–365 K, the heater 1–15 K from it of either sign, background
//! 278–318 K (cold and warm rooms); up to 4 broken pixels (`NaN`, as the driver reports a pixel
//! the EEPROM flags) and up to 2 hot pixels (5–40 K above their neighbours, flagged by
//! nothing). The period and width are drawn in pixels directly: their ranges already span the
//! distance range and both fields of view.
//!
//! Optics: each pixel integrates its square footprint convolved with a Gaussian
//! point-spread function, evaluated on an 8 × 8 subgrid per pixel. The datasheet gives the
//! field of view (55° × 35° or 110° × 75° over 32 × 24 pixels) but no numeric sensitivity
//! profile, so the spread is drawn per seed: none at all (the footprint alone, the sharpest an
//! MLX90640 can be) for one member in five, else σ = 0–0.6 px. The firmware fits the spread
//! among its own grid (`thermorph::mtts::lattice::PSF_SIGMAS_PX`) and never gets the exact
//! optics it is tested on.
//!
//! The block's design: a member also carries the exposed fraction its builder would configure
//! (`thermorph::mtts::Config::exposed_pct`): the lattice's gap over its unit, which the view
//! shows within ±0.04 (the lattice's waviness and the view angle), so the firmware is never
//! told the exact fraction either.
//!
//! [`thesis`] draws the thesis's own corner: the 21.35 mm gap of each 30 mm unit (exposed
//! ≈ 0.71), about five units over the 24 rows (period 4.6–5.4 px), no spread beyond the
//! footprint, 0.1–0.5 K noise, gaps 1–12 K, tilted and shifted, broken and hot pixels.
//!
//! [`unlike_design`] draws blocks whose lattice shows the heater through a fraction far from
//! the design they are configured with (another print, another view angle: issue 43): the
//! product's default configuration (`thermorph::mtts::Config::default().exposed_pct`, the
//! thesis's 71 %), a view exposed 0.2–0.5 ([`UNLIKE_NARROW`], even seeds) or 0.85–0.95
//! ([`UNLIKE_WIDE`], odd seeds), everything else drawn as [`Member::draw`] does.
//!
//! Every member's sensor noise is seeded by its seed ([`Member::render`]); the frames a camera
//! takes of it later carry noise of their own ([`Member::noise_seed`],
//! [`Member::render_with_noise`]) over the same view and bad pixels.

use std::ops::Range;

use thermorph::mtts::{IMG_COLS, IMG_PIXELS, IMG_ROWS, REGIONS};

use crate::imaging::view::{Geometry, Rendered, Temps, sampler};
use crate::sensor::virtual_mlx::Rng;

/// Seeds the MTTS constants were tuned on.
pub const SEEN: Range<u64> = 0..1_000_000;
/// Seeds kept for reporting: never used while tuning.
pub const UNSEEN: Range<u64> = 1_000_000..2_000_000;

/// A pixel the image shows wrong: broken (`NaN`) or hot (an offset, K).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BadPixel {
    /// Pixel index, row-major.
    pub index: usize,
    /// `None`: broken (reported `NaN`); `Some(dt)`: reads `dt` kelvin too hot.
    pub offset_k: Option<f64>,
}

/// Most bad pixels a member carries.
pub const MAX_BAD: usize = 6;

/// One member of the family.
#[derive(Clone, Copy, Debug)]
pub struct Member {
    /// The seed it was drawn from.
    pub seed: u64,
    /// Geometry in sensor pixels.
    pub geometry: Geometry,
    /// True temperatures.
    pub temps: Temps,
    /// Sensor noise, K rms.
    pub noise_k: f64,
    /// Camera distance, mm.
    pub distance_mm: f64,
    /// Point-spread function: Gaussian standard deviation, pixels (0: the footprint alone).
    pub psf_sigma_px: f64,
    /// The exposed fraction the block's builder configures (the design), percent.
    pub design_exposed_pct: u8,
    /// Broken and hot pixels (the first `bad_count`).
    pub bad: [BadPixel; MAX_BAD],
    /// How many of `bad` are in use.
    pub bad_count: usize,
}

/// The ranges a family draws its members from (uniformly).
struct Ranges {
    period_px: (f64, f64),
    exposed: (f64, f64),
    tilt_deg: f64,
    gap_k: (f64, f64),
    psf_px: (f64, f64),
    noise_k: (f64, f64),
}

/// The ranges of [`Member::draw`].
const FAMILY: Ranges = Ranges {
    period_px: (4.0, 16.0),
    exposed: (0.2, 0.85),
    tilt_deg: 35.0,
    gap_k: (1.0, 15.0),
    // A draw below 0 is the footprint alone: one member in five.
    psf_px: (-0.15, 0.6),
    noise_k: (0.05, 0.5),
};

/// Exposed fractions of the even seeds of [`unlike_design`]: heater stripes narrower than the
/// surface's, where the default design (0.71) has them wider.
pub const UNLIKE_NARROW: (f64, f64) = (0.2, 0.5);
/// Exposed fractions of the odd seeds of [`unlike_design`]: surface stripes far thinner than
/// the default design's.
pub const UNLIKE_WIDE: (f64, f64) = (0.85, 0.95);

impl Member {
    /// Draw the member of `seed`.
    pub fn draw(seed: u64) -> Member {
        Self::draw_in(seed, 0x5CE7_E5EE_D000_0000, &FAMILY)
    }

    fn draw_in(seed: u64, salt: u64, r: &Ranges) -> Member {
        let mut rng = Rng::new(seed ^ salt);
        let mut u = |lo: f64, hi: f64| lo + (hi - lo) * rng.uniform();
        let period_px = u(r.period_px.0, r.period_px.1);
        let half_width_px = 0.5 * u(6.0, 20.0);
        let exposed = u(r.exposed.0, r.exposed.1);
        let tilt_deg = u(-r.tilt_deg, r.tilt_deg);
        let shift = u(-3.0, 3.0);
        let phase_px = u(0.0, period_px);
        let distance_mm = u(50.0, 100.0);
        let noise_k = u(r.noise_k.0, r.noise_k.1);
        let surface_k = u(300.0, 365.0);
        let gap_k = u(r.gap_k.0, r.gap_k.1) * if u(0.0, 1.0) < 0.5 { -1.0 } else { 1.0 };
        let background_k = u(278.0, 318.0);
        let psf_sigma_px = u(r.psf_px.0, r.psf_px.1).max(0.0);
        let design = (exposed + u(-0.04, 0.04)).clamp(0.0, 1.0);
        let bad_count = (u(0.0, MAX_BAD as f64 + 1.0) as usize).min(MAX_BAD);
        let mut bad = [BadPixel {
            index: 0,
            offset_k: None,
        }; MAX_BAD];
        for (i, b) in bad.iter_mut().enumerate().take(bad_count) {
            b.index = (u(0.0, IMG_PIXELS as f64) as usize).min(IMG_PIXELS - 1);
            // The first four broken, the rest hot.
            b.offset_k = (i >= 4).then(|| u(5.0, 40.0));
        }
        let mm_per_px = distance_mm * (110.0f64 / 32.0).to_radians();
        let geometry = Geometry {
            axis_col0: 15.5 + shift,
            tilt_deg,
            half_width_px,
            period_px,
            phase_px,
            exposed,
            edge_fraction: 0.2,
            radiation_px: 12.0 / mm_per_px,
            springs: false,
        };
        let temps = Temps::from_surfaces(background_k, surface_k + gap_k, surface_k, background_k);
        Member {
            seed,
            geometry,
            temps,
            noise_k,
            distance_mm,
            psf_sigma_px,
            design_exposed_pct: (100.0 * design).round() as u8,
            bad,
            bad_count,
        }
    }

    /// T1 − T2, K.
    pub fn gap_k(&self) -> f64 {
        self.temps.heater_k - self.temps.surface_k
    }

    /// The true area-weighted mean of the two targets, K.
    pub fn mean_k(&self) -> f64 {
        let d = self.geometry.exposed;
        d * self.temps.heater_k + (1.0 - d) * self.temps.surface_k
    }

    /// Render the member (noise seeded by its seed), with its broken and hot pixels.
    pub fn render(&self) -> Rendered {
        self.render_with_noise(self.seed)
    }

    /// The noise seed of the camera's `frame`-th frame of the member (0: the first, its own
    /// seed, which [`Member::render`] uses; later frames: seeds drawn from it, so no two frames'
    /// noise streams overlap).
    pub fn noise_seed(&self, frame: usize) -> u64 {
        if frame == 0 {
            return self.seed;
        }
        let mut rng = Rng::new(self.seed ^ 0xF4A3_E5EE_D000_0000);
        let mut s = 0;
        for _ in 0..frame {
            s = rng.next_u64();
        }
        s
    }

    /// Render the member with sensor noise seeded by `noise_seed`: the same view, optics and
    /// broken and hot pixels as [`Member::render`], whose frame is that of `self.seed`.
    pub fn render_with_noise(&self, noise_seed: u64) -> Rendered {
        self.frames().with_noise(noise_seed)
    }

    /// The member's view rendered once, for many frames of it ([`Frames`]).
    pub fn frames(&self) -> Frames<'_> {
        Frames {
            member: self,
            clean: render_clean(&self.geometry, &self.temps, self.psf_sigma_px),
        }
    }
}

/// A member's view rendered once through the optics, whose frames differ only by their sensor
/// noise (a camera watching a block that does not change).
#[derive(Clone, Debug)]
pub struct Frames<'a> {
    member: &'a Member,
    clean: CleanView,
}

impl Frames<'_> {
    /// The camera's `frame`-th frame of the member: [`Member::noise_seed`]'s noise, the
    /// member's broken and hot pixels (frame 0 is [`Member::render`]'s, bit for bit).
    pub fn frame(&self, frame: usize) -> Rendered {
        self.with_noise(self.member.noise_seed(frame))
    }

    /// The frame with sensor noise seeded by `noise_seed` and the member's bad pixels.
    pub fn with_noise(&self, noise_seed: u64) -> Rendered {
        let m = self.member;
        let mut r = self.clean.with_noise(m.noise_k, noise_seed);
        for b in &m.bad[..m.bad_count] {
            r.image_k[b.index] = match b.offset_k {
                None => f32::NAN,
                Some(dt) => r.image_k[b.index] + dt as f32,
            };
        }
        r
    }
}

/// The thesis's own corner of the family (module doc): the member of `seed`.
pub fn thesis(seed: u64) -> Member {
    let exposed = thermorph::block::LATTICE_GAP_FRACTION as f64;
    let mut m = Member::draw_in(
        seed,
        0x7E51_5000_0000_0000,
        &Ranges {
            period_px: (4.6, 5.4),
            exposed: (exposed - 0.02, exposed + 0.02),
            tilt_deg: 20.0,
            gap_k: (1.0, 12.0),
            psf_px: (0.0, 0.0),
            noise_k: (0.1, 0.5),
        },
    );
    m.design_exposed_pct = (100.0 * exposed).round() as u8;
    m
}

/// A block unlike its design (module doc): the member of `seed`, drawn as [`Member::draw`]
/// draws (its own salt) but exposed within [`UNLIKE_NARROW`] for an even seed and within
/// [`UNLIKE_WIDE`] for an odd one, and configured with the default design,
/// `thermorph::mtts::Config::default().exposed_pct`.
pub fn unlike_design(seed: u64) -> Member {
    let exposed = if seed.is_multiple_of(2) {
        UNLIKE_NARROW
    } else {
        UNLIKE_WIDE
    };
    let mut m = Member::draw_in(seed, 0x0DD5_DE51_6000_0000, &Ranges { exposed, ..FAMILY });
    m.design_exposed_pct = thermorph::mtts::Config::default().exposed_pct;
    m
}

/// Φ(x), the standard normal distribution function (erfc, to 1e-7).
fn phi(x: f64) -> f64 {
    0.5 * libm::erfc(-x / std::f64::consts::SQRT_2)
}

/// Render a view: pixel footprint ⊗ Gaussian PSF (σ pixels), 8 × 8 samples per pixel, then
/// Gaussian noise of `noise_k` rms. Fractions are the same weights applied to each region.
pub fn render_psf(g: &Geometry, temps: &Temps, sigma_px: f64, noise_k: f64, seed: u64) -> Rendered {
    render_clean(g, temps, sigma_px).with_noise(noise_k, seed)
}

/// A view through the optics before the sensor's noise ([`render_clean`]): the costly part
/// of [`render_psf`], computed once for any number of noisy frames.
#[derive(Clone, Debug)]
pub struct CleanView {
    /// Each pixel's value, K, in f64 (before noise and the sensor's f32).
    pub value_k: [f64; IMG_PIXELS],
    /// True region temperatures, K (region 1 first).
    pub truth_k: [f64; REGIONS],
    /// Per region, each pixel's area fraction (springs count as background).
    pub fraction: [[f32; IMG_PIXELS]; REGIONS],
}

impl CleanView {
    /// The frame with Gaussian noise of `noise_k` rms seeded by `seed`: bit for bit
    /// [`render_psf`]'s with the same view, noise and seed.
    pub fn with_noise(&self, noise_k: f64, seed: u64) -> Rendered {
        let mut rng = Rng::new(seed);
        let mut out = Rendered {
            image_k: [0.0; IMG_PIXELS],
            truth_k: self.truth_k,
            fraction: self.fraction,
        };
        for (o, &v) in out.image_k.iter_mut().zip(&self.value_k) {
            let mut v = v;
            if noise_k > 0.0 {
                v += noise_k * rng.gauss();
            }
            *o = v as f32;
        }
        out
    }
}

/// [`render_psf`] without the noise: the view through the footprint and the PSF.
pub fn render_clean(g: &Geometry, temps: &Temps, sigma_px: f64) -> CleanView {
    const N: usize = 8;
    let truth = temps.regions();
    let reach = 0.5 + 4.0 * sigma_px.max(0.0);
    let margin = reach.ceil() as i64 + 1;
    let (rows, cols) = (IMG_ROWS as i64 + 2 * margin, IMG_COLS as i64 + 2 * margin);
    let (fr, fc) = (rows as usize * N, cols as usize * N);
    // Fine grid: region index per sample (a spring counts as background).
    let pos = |i: usize, m: i64| (i as f64 + 0.5) / N as f64 - 0.5 - m as f64;
    let mut label = vec![0u8; fr * fc];
    let sample = sampler(g);
    for i in 0..fr {
        for j in 0..fc {
            label[i * fc + j] = sample(pos(i, margin), pos(j, margin)).unwrap_or(4) as u8;
        }
    }
    // Weight of a sample at offset x from a pixel centre: the footprint box ⊗ the Gaussian.
    let weight = |x: f64| {
        if sigma_px <= 0.0 {
            if x.abs() < 0.5 { 1.0 } else { 0.0 }
        } else {
            phi((x + 0.5) / sigma_px) - phi((x - 0.5) / sigma_px)
        }
    };
    let span = (reach * N as f64).ceil() as i64;
    // Sample centre + m sits at (m + ½)/N pixels from the pixel centre.
    let w1: Vec<f64> = (-span..span)
        .map(|m| weight((m as f64 + 0.5) / N as f64))
        .collect();
    let wsum: f64 = w1.iter().sum();
    let w1: Vec<f64> = w1.iter().map(|w| w / wsum).collect();
    // Horizontal pass: per fine row, per pixel column, the weight of each region.
    let mut horiz = vec![[0f64; REGIONS]; fr * IMG_COLS];
    for i in 0..fr {
        for c in 0..IMG_COLS {
            let centre = (c as i64 + margin) * N as i64 + (N as i64 / 2);
            let mut acc = [0f64; REGIONS];
            for (k, &w) in w1.iter().enumerate() {
                let j = centre + k as i64 - span;
                if (0..fc as i64).contains(&j) {
                    acc[label[i * fc + j as usize] as usize] += w;
                }
            }
            horiz[i * IMG_COLS + c] = acc;
        }
    }
    let mut out = CleanView {
        value_k: [0.0; IMG_PIXELS],
        truth_k: truth,
        fraction: [[0.0; IMG_PIXELS]; REGIONS],
    };
    for r in 0..IMG_ROWS {
        for c in 0..IMG_COLS {
            let centre = (r as i64 + margin) * N as i64 + (N as i64 / 2);
            let mut acc = [0f64; REGIONS];
            for (k, &w) in w1.iter().enumerate() {
                let i = centre + k as i64 - span;
                if (0..fr as i64).contains(&i) {
                    let a = &horiz[i as usize * IMG_COLS + c];
                    for z in 0..REGIONS {
                        acc[z] += w * a[z];
                    }
                }
            }
            let total: f64 = acc.iter().sum();
            let p = r * IMG_COLS + c;
            let mut v = 0.0;
            for z in 0..REGIONS {
                out.fraction[z][p] = (acc[z] / total) as f32;
                v += acc[z] / total * truth[z];
            }
            out.value_k[p] = v;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_stay_in_their_ranges_and_differ() {
        let a = Member::draw(1);
        let b = Member::draw(2);
        assert_ne!(a.geometry.period_px, b.geometry.period_px);
        for s in 0..200 {
            let m = Member::draw(s);
            let g = m.geometry;
            assert!((4.0..16.0).contains(&g.period_px));
            assert!((3.0..10.0).contains(&g.half_width_px));
            assert!((0.2..0.85).contains(&g.exposed));
            assert!(g.tilt_deg.abs() <= 35.0);
            assert!((1.0..=15.0).contains(&m.gap_k().abs()));
            assert!((0.05..0.5).contains(&m.noise_k));
            assert!((0.0..0.6).contains(&m.psf_sigma_px));
            assert!((f64::from(m.design_exposed_pct) / 100.0 - g.exposed).abs() <= 0.045);
            let r = m.render();
            let broken = r.image_k.iter().filter(|v| v.is_nan()).count();
            assert!(broken <= 4 && m.bad_count <= MAX_BAD);
        }
    }

    #[test]
    fn unlike_design_draws_both_bands_against_the_default_design() {
        let design = thermorph::mtts::Config::default().exposed_pct;
        let (mut narrow, mut wide) = (0, 0);
        for s in 0..200 {
            let m = unlike_design(s);
            let g = m.geometry;
            assert_eq!(m.design_exposed_pct, design);
            if (UNLIKE_NARROW.0..UNLIKE_NARROW.1).contains(&g.exposed) {
                assert_eq!(s % 2, 0, "{s}: {}", g.exposed);
                narrow += 1;
            } else {
                assert!(
                    (UNLIKE_WIDE.0..UNLIKE_WIDE.1).contains(&g.exposed),
                    "{s}: {}",
                    g.exposed
                );
                assert_eq!(s % 2, 1, "{s}: {}", g.exposed);
                wide += 1;
            }
            // The rest as the family draws it.
            assert!((4.0..16.0).contains(&g.period_px));
            assert!((3.0..10.0).contains(&g.half_width_px));
            assert!(g.tilt_deg.abs() <= 35.0);
            assert!((1.0..=15.0).contains(&m.gap_k().abs()));
            assert!((0.05..0.5).contains(&m.noise_k));
            assert!((0.0..0.6).contains(&m.psf_sigma_px));
            assert!(m.bad_count <= MAX_BAD);
        }
        assert_eq!((narrow, wide), (100, 100));
        // Its own draws, not the family's members with another exposure.
        assert_ne!(
            unlike_design(4).geometry.period_px,
            Member::draw(4).geometry.period_px
        );
    }

    #[test]
    fn later_frames_carry_their_own_noise_over_the_same_view() {
        let m = Member::draw(5);
        assert_eq!(m.noise_seed(0), m.seed);
        let first = m.render();
        let again = m.render_with_noise(m.noise_seed(0));
        assert_eq!(
            first.image_k.map(f32::to_bits),
            again.image_k.map(f32::to_bits)
        );
        let seeds: Vec<u64> = (0..12).map(|f| m.noise_seed(f)).collect();
        for (i, a) in seeds.iter().enumerate() {
            assert!(!seeds[i + 1..].contains(a), "frame {i}'s seed repeats");
        }
        let later = m.render_with_noise(m.noise_seed(1));
        let noiseless = render_psf(&m.geometry, &m.temps, m.psf_sigma_px, 0.0, 0);
        let mut differ = 0;
        for p in 0..IMG_PIXELS {
            // The same broken pixels; elsewhere the same view within the noise.
            assert_eq!(first.image_k[p].is_nan(), later.image_k[p].is_nan());
            if first.image_k[p].is_nan() {
                continue;
            }
            differ += usize::from(first.image_k[p] != later.image_k[p]);
            let hot = m.bad[..m.bad_count].iter().any(|b| b.index == p);
            if !hot {
                assert!((later.image_k[p] - noiseless.image_k[p]).abs() < 8.0 * m.noise_k as f32);
            }
        }
        assert!(differ > IMG_PIXELS / 2, "{differ} pixels differ");
    }

    #[test]
    fn without_spread_and_noise_it_is_the_area_integrating_renderer() {
        // σ = 0: the footprint box alone, which `scene::render` computes with its own grid.
        let m = Member::draw(7);
        let ours = render_psf(&m.geometry, &m.temps, 0.0, 0.0, 1);
        let theirs = crate::imaging::view::render(
            &m.geometry,
            &m.temps,
            &crate::imaging::view::Options {
                subgrid: 8,
                noise_k: 0.0,
                seed: 1,
            },
        );
        for p in 0..IMG_PIXELS {
            assert!(
                (ours.image_k[p] - theirs.image_k[p]).abs() < 1e-3,
                "pixel {p}: {} vs {}",
                ours.image_k[p],
                theirs.image_k[p]
            );
        }
    }

    #[test]
    fn spread_conserves_the_mean_and_fractions_sum_to_one() {
        let m = Member::draw(11);
        let r = m.render();
        for p in 0..IMG_PIXELS {
            let total: f32 = (0..REGIONS).map(|z| r.fraction[z][p]).sum();
            assert!((total - 1.0).abs() < 1e-4);
        }
        // A uniform scene stays uniform through the optics.
        let flat = Temps::from_surfaces(300.0, 300.0, 300.0, 300.0);
        let f = render_psf(&m.geometry, &flat, 0.4, 0.0, 1);
        assert!(f.image_k.iter().all(|&v| (v - 300.0).abs() < 1e-3));
    }
}
