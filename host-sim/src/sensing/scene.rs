//! The camera's view of the block: a 32×24 image with ground truth, for MTTS tests, benches
//! and (later) the plant model.
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
//! per region.

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
}

/// Render the view.
pub fn render(g: &Geometry, temps: &Temps, opts: &Options) -> Rendered {
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
                    match sample(g, row, col) {
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
