//! What the sensing pipeline hands the supervisor: one [`Measurement`] per whole frame.
//!
//! This module owns the data contract between sensing and control. The pipeline (sensor frames
//! → MTTS) fills it; `Supervisor::step` reads it; nothing else flows from sensing to control.
//!
//! The controlled temperature Tc is not part of a measurement: the supervisor alone computes
//! it ([`controlled_temperature`] under the hint of its mode at the step that uses the frame),
//! so the value the loop runs on never depends on which hint the pipeline held when the frame
//! was read. The pipeline evaluates the same formula under its hint only to drop an implausible
//! frame (see `crate::sensing`).

use crate::mtts::REGIONS;

pub use crate::mtts::LatticeExposure;
use crate::units::{Kelvin, Millis};

pub use crate::mtts::Quality;

/// One whole frame's result, as the supervisor sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measurement {
    /// When the frame's last subpage was read (monotonic time since boot).
    pub at: Millis,
    /// Frames published since boot (a gap in `seq` is a frame that failed).
    pub seq: u32,
    /// Region temperatures 1…5 (heater area, SMP surface, edge, radiation zone, background);
    /// `None` for a region the frame gave no temperature.
    pub regions: [Option<Kelvin>; REGIONS],
    /// Hottest sensor pixel of the frame (the film, or a spring burning beside the cylinder);
    /// judged against `t_heater_max_k`.
    pub hottest: Option<Kelvin>,
    /// Broken pixels filled from their neighbours in this frame.
    pub filled_pixels: u16,
    /// How well T1 and T2 were separated.
    pub quality: Quality,
    /// How far T1 and T2 may each lie from their values, K: for a merged or fallback frame from
    /// the area-weighted mean both carry, for an ambiguous one whichever assignment is right.
    pub bound: Kelvin,
    /// The cylinder's axis tilt in the image, if this frame re-estimated it.
    pub tilt: Option<Tilt>,
    /// The lattice's exposed fraction the frame's fit shows, against the design (`None`: no
    /// lattice fitted, or which target is hotter undecided).
    pub exposure: Option<LatticeExposure>,
}

/// The cylinder's axis tilt in the image as MTTS fitted it: for a constant-curvature column
/// fixed at its base the visible middle leans by half the bend's component in the image plane
/// (the posture estimate, [`crate::posture`], turns it into a bend).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tilt {
    /// The axis's angle from the image's vertical, degrees (positive: leaning towards higher
    /// columns down the image).
    pub deg: f32,
    /// The fit's standard error of that angle, degrees.
    pub sd_deg: f32,
}

impl Tilt {
    /// The tilt of an axis `col = a + slope·row` whose slope has the standard error
    /// `slope_se` (columns per row); `None` unless both are finite.
    pub fn from_slope(slope: f32, slope_se: f32) -> Option<Tilt> {
        if !(slope.is_finite() && slope_se.is_finite()) {
            return None;
        }
        Some(Tilt {
            deg: libm::atanf(slope).to_degrees(),
            sd_deg: (slope_se / (1.0 + slope * slope)).to_degrees(),
        })
    }
}

impl Measurement {
    /// Return T1 (heater area), `None` if the frame has none.
    pub fn t1(&self) -> Option<Kelvin> {
        self.regions[0]
    }

    /// Return T2 (SMP outer surface), `None` if the frame has none.
    pub fn t2(&self) -> Option<Kelvin> {
        self.regions[1]
    }

    /// Return the hotter of the two targets as far as this frame can tell: the higher of T1 and
    /// T2 when they were resolved; when ambiguous, the higher plus the bound (either may be
    /// that far off); when merged or fallback, the mean plus the bound (the hotter target may
    /// be that far above the mean both carry). `None` without T1 and T2 (or if infinite values
    /// make the sum undefined).
    pub fn hotter(&self) -> Option<Kelvin> {
        let (a, b) = (self.t1()?.k(), self.t2()?.k());
        let bound = self.bound.k().max(0.0);
        match self.quality {
            Quality::Resolved => Kelvin::new(if a >= b { a } else { b }),
            Quality::Ambiguous => Kelvin::new(if a >= b { a } else { b } + bound),
            Quality::Merged | Quality::Fallback => Kelvin::new(0.5 * (a + b) + bound),
        }
    }

    /// Return the colder of the two targets as far as this frame can tell (see
    /// [`Measurement::hotter`]).
    pub fn colder(&self) -> Option<Kelvin> {
        let (a, b) = (self.t1()?.k(), self.t2()?.k());
        let bound = self.bound.k().max(0.0);
        match self.quality {
            Quality::Resolved => Kelvin::new(if a >= b { b } else { a }),
            Quality::Ambiguous => Kelvin::new(if a >= b { b } else { a } - bound),
            Quality::Merged | Quality::Fallback => Kelvin::new(0.5 * (a + b) - bound),
        }
    }
}

/// What the supervisor tells the sensing pipeline for the next frames (carried in its
/// decision): the MTTS prior of the mode and the weights of Tc.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensingHint {
    /// What the mode expects of T1 against T2.
    pub prior: crate::mtts::Prior,
    /// Weights of the controlled temperature Tc.
    pub weights: crate::mtts::Weights,
}

impl Default for SensingHint {
    /// No prior; Tc = T2 (the SMP surface).
    fn default() -> Self {
        SensingHint {
            prior: crate::mtts::Prior::Unknown,
            weights: crate::mtts::Weights { w1: 0.0, w2: 1.0 },
        }
    }
}

/// Return Tc of a frame under `hint`: Tc = w1·T1* + w2·T2*, where (T1*, T2*) is the pair ordered
/// as the mode expects it — with [`Prior::HeaterHotter`](crate::mtts::Prior) T1* is the hotter of
/// the two ([`Measurement::hotter`]), with `SurfaceHotter` the colder, with `Unknown` the pair as
/// measured.
///
/// Ordering by rank makes Tc immune to a swapped T1/T2, and a merged frame counts its bound
/// against the loop: weighted to the colder region, Tc is the mean less the bound, so the whole
/// cross-section is at the target before a stepping starts; weighted to the hotter one, the mean
/// plus the bound, so standby never runs above it and forming ends only when everything the
/// frame can hide is cool.
///
/// `None` when the frame lacks T1 or T2 (or the weighted sum is undefined). The supervisor is
/// the one place whose Tc the loop uses; the pipeline calls this only to drop an implausible
/// frame.
pub fn controlled_temperature(m: &Measurement, hint: &SensingHint) -> Option<Kelvin> {
    use crate::mtts::Prior;
    let (a, b) = match hint.prior {
        Prior::Unknown => (m.t1()?, m.t2()?),
        Prior::HeaterHotter => (m.hotter()?, m.colder()?),
        Prior::SurfaceHotter => (m.colder()?, m.hotter()?),
    };
    hint.weights.apply(a, b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mtts::{Prior, Weights};

    fn frame(t1: f32, t2: f32, quality: Quality, bound: f32) -> Measurement {
        Measurement {
            at: Millis(0),
            seq: 0,
            regions: [t1, t2, 300.0, 299.0, 298.0].map(Kelvin::new),
            hottest: None,
            filled_pixels: 0,
            quality,
            bound: Kelvin::new(bound).unwrap(),
            tilt: None,
            exposure: None,
        }
    }

    #[test]
    fn a_tilt_is_the_slopes_angle_with_its_error_through_the_derivative() {
        let t = Tilt::from_slope(1.0, 0.02).unwrap();
        assert!((t.deg - 45.0).abs() < 1e-4, "{t:?}");
        assert!((t.sd_deg - 0.01f32.to_degrees()).abs() < 1e-4, "{t:?}");
        assert_eq!(Tilt::from_slope(f32::NAN, 0.1), None);
        assert_eq!(Tilt::from_slope(0.1, f32::INFINITY), None);
    }

    #[test]
    fn tc_ranks_the_pair_as_the_mode_expects() {
        let w = Weights { w1: 0.0, w2: 1.0 };
        let heat = SensingHint {
            prior: Prior::HeaterHotter,
            weights: w,
        };
        let form = SensingHint {
            prior: Prior::SurfaceHotter,
            weights: w,
        };
        let tc = |t1, t2, h: &SensingHint| {
            controlled_temperature(&frame(t1, t2, Quality::Resolved, 0.5), h)
        };
        // Heating: the colder of the two, whichever label it carries.
        assert_eq!(tc(360.0, 350.0, &heat), Some(Kelvin::lit(350.0)));
        assert_eq!(tc(350.0, 360.0, &heat), Some(Kelvin::lit(350.0)));
        // Forming: the hotter.
        assert_eq!(tc(320.0, 330.0, &form), Some(Kelvin::lit(330.0)));
        assert_eq!(tc(330.0, 320.0, &form), Some(Kelvin::lit(330.0)));
        let blend = SensingHint {
            prior: Prior::Unknown,
            weights: Weights { w1: 0.25, w2: 0.75 },
        };
        assert_eq!(tc(340.0, 320.0, &blend), Some(Kelvin::lit(325.0)));
    }

    #[test]
    fn an_ambiguous_frame_is_judged_by_its_targets_widened_by_its_bound() {
        // T1 and T2 the fit's, 20 K apart, a bound of 8 K: the hotter may be 368 K (the
        // midpoint plus the bound, 358 K, would hide the estimate itself).
        let m = frame(360.0, 340.0, Quality::Ambiguous, 8.0);
        assert_eq!(
            (m.hotter(), m.colder()),
            (Some(Kelvin::lit(368.0)), Some(Kelvin::lit(332.0)))
        );
    }

    #[test]
    fn a_merged_frame_counts_its_bound_against_the_loop() {
        let m = frame(350.0, 350.0, Quality::Merged, 6.0);
        assert_eq!(
            (m.hotter(), m.colder()),
            (Some(Kelvin::lit(356.0)), Some(Kelvin::lit(344.0)))
        );
        let heat = SensingHint {
            prior: Prior::HeaterHotter,
            weights: Weights { w1: 0.0, w2: 1.0 },
        };
        assert_eq!(controlled_temperature(&m, &heat), Some(Kelvin::lit(344.0)));
        let standby = SensingHint {
            prior: Prior::HeaterHotter,
            weights: Weights { w1: 1.0, w2: 0.0 },
        };
        assert_eq!(
            controlled_temperature(&m, &standby),
            Some(Kelvin::lit(356.0))
        );
    }
}
