//! Injected faults: what a scene can break on the simulated board (the heater, a spring's
//! MOSFET, the sensor, what the camera sees) and when, and the camera's settings. Scene files
//! name them ([`crate::runs::scenario`]); the board ([`crate::rig::SimBoard`]) applies them.

use crate::sensor::virtual_mlx::SensorFault;

/// Camera settings of a scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraSettings {
    /// Render the camera's view and read it through the virtual sensor and MTTS.
    pub enabled: bool,
    /// Sensor noise, K rms.
    pub noise_k: f64,
    /// Seed of the sensor's noise and calibration.
    pub seed: u64,
    /// Where the camera looks from: its image's rows at this angle from spring A (towards B),
    /// degrees; 0 is the product's mount, 90 sees spring A's plane along the line of sight.
    /// The firmware is told by its `cam_azimuth_deg` setting (a scene sends `set`).
    pub azimuth_deg: f64,
}

/// What an injected fault does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Injection {
    /// The heater is open-circuit: no power whatever the duty.
    HeaterOpen,
    /// A spring's MOSFET is stuck on (failed short: it conducts whatever its gate, until the
    /// spring power enable cuts it) or off (failed open).
    StuckSpring {
        /// Spring index, 0 = A.
        spring: usize,
        /// Stuck on (true) or off.
        on: bool,
    },
    /// A spring's wire is open (broken, a connector off): its channel carries nothing.
    OpenWire {
        /// Spring index, 0 = A.
        spring: usize,
    },
    /// A spring's wire is bypassed (its leads touching, the wire against the frame): its
    /// channel draws the supply's limit through almost nothing.
    WireShort {
        /// Spring index, 0 = A.
        spring: usize,
    },
    /// The sensor misbehaves (with the camera off: no measurement at all).
    Sensor(SensorFault),
    /// The camera sees something other than the block as the plant has it (camera on only).
    Camera(CameraFault),
}

/// What a `camera` fault shows the sensor instead of the plant's block (the sensor still adds
/// its own noise, and everything after it — driver, pairing, MTTS — is the firmware's).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraFault {
    /// The camera looks elsewhere (knocked aside, or a wrong sensor on the bus): a steady,
    /// plausible, uniform surface at [`ELSEWHERE_K`], whatever the block does.
    Elsewhere,
    /// The heater film burns through where the lattice shows it: the block as the plant has it,
    /// but region 1 at [`BURNING_FILM_K`], above the measurement's 500 K plausibility cap (the
    /// plant does not model the fire).
    BurningFilm,
}

/// The surface a camera that looks elsewhere sees, K.
pub const ELSEWHERE_K: f64 = 320.0;
/// The heater film of a [`CameraFault::BurningFilm`], K.
pub const BURNING_FILM_K: f64 = 550.0;

/// An injected fault and when it is active.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaultSpec {
    /// Start, s.
    pub at_s: f64,
    /// End, s (`None`: to the end of the run).
    pub until_s: Option<f64>,
    /// What it does.
    pub kind: Injection,
}

impl FaultSpec {
    /// Return whether the fault is active at `t_s`.
    pub fn active(&self, t_s: f64) -> bool {
        t_s >= self.at_s && self.until_s.is_none_or(|u| t_s < u)
    }
}
