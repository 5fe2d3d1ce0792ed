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
