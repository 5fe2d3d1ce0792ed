//! What the sensing pipeline hands the supervisor: one [`Measurement`] per whole frame.
//!
//! This module owns the data contract between sensing and control. The pipeline (sensor frames
//! → MTTS) fills it; `Supervisor::step` reads it; nothing else flows from sensing to control.

use crate::mtts::REGIONS;
use crate::units::{Kelvin, Millis};

/// How well a frame separated the two control targets (T1, the heater area seen through the
/// lattice, and T2, the SMP outer surface).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum Quality {
    /// T1 and T2 were measured as two separate targets.
    Resolved,
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
            Self::Merged => "merged",
            Self::Fallback => "fallback",
        }
    }
}

/// One whole frame's result, as the supervisor sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measurement {
    /// When the frame's last subpage was read (monotonic time since boot).
    pub at: Millis,
    /// Frames published since boot (a gap in `seq` is a frame that failed).
    pub seq: u32,
    /// Region temperatures 1…5 (heater area, SMP surface, edge, radiation zone, background).
    pub regions: [Kelvin; REGIONS],
    /// Controlled temperature Tc = w1·T1 + w2·T2 with the weights the supervisor asked for.
    pub tc: Kelvin,
    /// Hottest sensor pixel over the cylinder, if any pixel lies on it.
    pub cylinder_max: Option<Kelvin>,
    /// Broken pixels filled from their neighbours in this frame.
    pub filled_pixels: u16,
    /// How well T1 and T2 were separated.
    pub quality: Quality,
}

impl Measurement {
    /// Return T1 (heater area).
    pub fn t1(&self) -> Kelvin {
        self.regions[0]
    }

    /// Return T2 (SMP outer surface).
    pub fn t2(&self) -> Kelvin {
        self.regions[1]
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

/// Return Tc for the pair (T1, T2) under `hint`: Tc = w1·T1* + w2·T2*, where (T1*, T2*) is the
/// pair ordered as the mode expects it — with [`Prior::HeaterHotter`](crate::mtts::Prior) T1* is
/// the hotter of the two, with `SurfaceHotter` the colder, with `Unknown` the pair as measured.
///
/// Ordering by rank makes Tc immune to a swapped (or merged) T1/T2: with the default weights
/// (0, 1) the heating modes control the colder of the two — the whole cross-section reaches the
/// target and a swap cannot make the controller chase the hotter one past it — and forming
/// controls the hotter one, so it ends only when everything it sees is cool.
pub fn controlled_temperature(t1: Kelvin, t2: Kelvin, hint: &SensingHint) -> Kelvin {
    use crate::mtts::Prior;
    let (hi, lo) = if t1.k() >= t2.k() { (t1, t2) } else { (t2, t1) };
    let (a, b) = match hint.prior {
        Prior::Unknown => (t1, t2),
        Prior::HeaterHotter => (hi, lo),
        Prior::SurfaceHotter => (lo, hi),
    };
    hint.weights.apply(a, b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mtts::{Prior, Weights};

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
        // Heating: the colder of the two, whichever label it carries.
        assert_eq!(
            controlled_temperature(Kelvin(360.0), Kelvin(350.0), &heat),
            Kelvin(350.0)
        );
        assert_eq!(
            controlled_temperature(Kelvin(350.0), Kelvin(360.0), &heat),
            Kelvin(350.0)
        );
        // Forming: the hotter.
        assert_eq!(
            controlled_temperature(Kelvin(320.0), Kelvin(330.0), &form),
            Kelvin(330.0)
        );
        assert_eq!(
            controlled_temperature(Kelvin(330.0), Kelvin(320.0), &form),
            Kelvin(330.0)
        );
        let blend = SensingHint {
            prior: Prior::Unknown,
            weights: Weights { w1: 0.25, w2: 0.75 },
        };
        assert_eq!(
            controlled_temperature(Kelvin(340.0), Kelvin(320.0), &blend),
            Kelvin(325.0)
        );
    }
}
