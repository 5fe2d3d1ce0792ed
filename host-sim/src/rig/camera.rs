//! The simulated board's camera chain: the plant's surfaces rendered into the camera's view,
//! encoded by the virtual MLX90640, read over the simulated I2C bus by the firmware's own
//! sensing pipeline (driver, subpage pairing, error policy, MTTS) — the board's sensor task with
//! models in place of the peripherals. With the camera off, [`truth_measurement`] hands the
//! controller the true region temperatures instead.
//!
//! The column's tilt in the image is half its bending angle (the chord of a constant-curvature
//! arc) projected on the image plane.

use embassy_futures::block_on;
use thermorph::measurement::{Measurement, Quality, SensingHint, Tilt};
use thermorph::mlx90640::{Config as SensorConfig, Mlx90640};
use thermorph::mtts::{IMG_PIXELS, REGIONS};
use thermorph::sensing::{Outcome, Pipeline, PipelineConfig, Sensor};
use thermorph::units::{Kelvin, Millis, k_or_nan};

use crate::imaging::view::{Geometry, Layout, Temps};
use crate::plant::Observation;
use crate::rig::RigError;
use crate::rig::faults::{BURNING_FILM_K, CameraFault, ELSEWHERE_K};
use crate::sensor::sim_time::{SimClock, SimDelay};
use crate::sensor::virtual_mlx::{HeapBuffers, SensorFault, VirtualBus, VirtualMlx90640};
use crate::sensor::{SensorError, eeprom};

/// Samples per pixel side of the camera's view.
const CAMERA_SUBGRID: usize = 4;

/// What the active injected faults do to the camera chain.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CameraFaults {
    /// The sensor's own fault (with the camera off: no measurement at all).
    pub sensor: Option<SensorFault>,
    /// What the camera sees instead of the block.
    pub view: Option<CameraFault>,
}

/// Render the block as `obs` has it, seen by a camera mounted at `azimuth_deg` (or what a
/// camera fault shows instead), into a sensor's `field` (K): the view as `scene::render`
/// draws it, without noise (the sensor adds its own). `layout` and `view_k` are the caller's
/// cache and scratch (the layout is kept while the column's tilt stays).
pub fn render_field(
    obs: &Observation,
    faults: CameraFaults,
    azimuth_deg: f64,
    layout: &mut Option<Layout>,
    view_k: &mut [f64; IMG_PIXELS],
    field: &mut [f32; IMG_PIXELS],
) {
    if faults.view == Some(CameraFault::Elsewhere) {
        *field = [ELSEWHERE_K as f32; IMG_PIXELS];
        return;
    }
    let mut temps = camera_temps(obs);
    if faults.view == Some(CameraFault::BurningFilm) {
        temps.heater_k = BURNING_FILM_K;
    }
    let geometry = Geometry {
        tilt_deg: true_tilt_deg(obs, azimuth_deg),
        springs: true,
        ..Geometry::default()
    };
    let layout = match layout {
        Some(l) if *l.geometry() == geometry => l,
        slot => slot.insert(Layout::new(&geometry, CAMERA_SUBGRID)),
    };
    layout.image(&temps, view_k);
    for (dst, &k) in field.iter_mut().zip(view_k.iter()) {
        *dst = k as f32;
    }
}

/// The camera chain: renderer → virtual MLX90640 → the firmware's sensing pipeline.
pub struct Camera {
    clock: SimClock,
    bus: VirtualBus,
    sensor: Sensor<VirtualBus, SimDelay, SimClock, HeapBuffers>,
    /// Whole frames published.
    pub frames: u64,
    /// Sensor or pipeline errors.
    pub errors: u64,
    /// The latest measurement; `None` after an error until the next frame.
    last: Option<Measurement>,
    /// Which region each sample of the view shows, for the last geometry (the column's tilt
    /// changes only while it bends).
    layout: Option<Layout>,
    /// The rendered view, K.
    view_k: Box<[f64; IMG_PIXELS]>,
    /// The mount ([`crate::rig::faults::CameraSettings::azimuth_deg`]), degrees.
    azimuth_deg: f64,
}

impl Camera {
    /// A camera whose sensor's calibration and noise come from `seed`, with `noise_k` rms.
    pub fn new(seed: u64, noise_k: f64, azimuth_deg: f64) -> Result<Self, RigError> {
        let clock = SimClock::new();
        let words = eeprom::realistic(seed)
            .encode()
            .map_err(SensorError::from)?;
        let mut device =
            VirtualMlx90640::new(words, clock.clone(), seed).map_err(SensorError::VirtualSensor)?;
        device.noise_k = noise_k;
        let bus = VirtualBus::new(device);
        // The sensor has been read and set to the pipeline's rate once before the sensing
        // task's own setup (≈ 44 ms of bus time): the timing every camera run has had.
        let mut probe = Mlx90640::new(
            bus.clone(),
            SimDelay::new(clock.clone()),
            thermorph::mlx90640::ADDRESS,
        );
        let mut words = [0u16; thermorph::mlx90640::EEPROM_WORDS];
        block_on(probe.read_eeprom(&mut words)).map_err(SensorError::Driver)?;
        block_on(probe.configure(SensorConfig::default())).map_err(SensorError::Driver)?;
        let pipeline = Pipeline::new(PipelineConfig::default()).map_err(RigError::Pipeline)?;
        let sensor = Sensor::new(
            bus.clone(),
            SimDelay::new(clock.clone()),
            clock.clone(),
            thermorph::mlx90640::ADDRESS,
            pipeline,
            HeapBuffers::new(),
        );
        Ok(Camera {
            clock,
            bus,
            sensor,
            frames: 0,
            errors: 0,
            last: None,
            layout: None,
            view_k: Box::new([0.0; IMG_PIXELS]),
            azimuth_deg,
        })
    }

    /// The sensor's clock, µs (it runs ahead of the board's by at most one bus action).
    pub fn clock_us(&self) -> u64 {
        self.clock.now_us()
    }

    /// The latest frame's region temperatures, K (`None` after an error until the next frame).
    pub fn last_regions_k(&self) -> Option<[f64; REGIONS]> {
        self.last
            .map(|m| core::array::from_fn(|i| k_or_nan(m.regions[i]) as f64))
    }

    /// The latest frame's MTTS quality (`None` after an error until the next frame).
    pub fn last_quality(&self) -> Option<Quality> {
        self.last.map(|m| m.quality)
    }

    /// Whether the sensor may measure a subpage before `until_us` (or within one bus action
    /// after it): only then must it be shown the block anew.
    pub fn measures_before(&self, until_us: u64) -> bool {
        const MARGIN_US: u64 = 50_000;
        self.bus.0.borrow().next_measurement_us() < until_us + MARGIN_US
    }

    /// Give the sensor its injected fault (or none).
    pub fn set_fault(&mut self, faults: CameraFaults) {
        self.bus.0.borrow_mut().set_fault(faults.sensor);
    }

    /// Show the sensor the block as `obs` has it (or what a camera fault shows instead; the
    /// sensor's own fault is [`Camera::set_fault`]'s).
    pub fn show(&mut self, obs: &Observation, faults: CameraFaults) {
        let mut dev = self.bus.0.borrow_mut();
        render_field(
            obs,
            faults,
            self.azimuth_deg,
            &mut self.layout,
            &mut self.view_k,
            &mut dev.field_k,
        );
    }

    /// Run the sensing pipeline, with `hint`, until the sensor's clock reaches `until_us` or a
    /// whole frame is published; return that frame with the clock's time then, µs.
    pub fn run_until(&mut self, until_us: u64, hint: SensingHint) -> Option<(u64, Measurement)> {
        self.sensor.set_hint(hint);
        // Every action advances the simulated clock (bus time, a pause or a timeout).
        while self.clock.now_us() < until_us {
            match block_on(self.sensor.step()) {
                Outcome::Frame(m) => {
                    self.frames += 1;
                    self.last = Some(m);
                    return Some((self.clock.now_us(), m));
                }
                Outcome::Error(_) => {
                    // The supervisor sees no measurement until a good frame comes.
                    self.errors += 1;
                    self.last = None;
                }
                _ => {}
            }
        }
        None
    }
}

/// What an open-loop scene (no supervisor to give the mode's prior) tells the camera: the
/// heating modes' prior, the heater area the hotter — a clear spatial verdict still wins over
/// it (MTTS) — and Tc on the SMP surface.
pub fn open_loop_hint() -> SensingHint {
    SensingHint {
        prior: thermorph::mtts::Prior::HeaterHotter,
        ..SensingHint::default()
    }
}

/// The camera's tilt for the column of `obs`, degrees: half the bend's component along the
/// image's rows (the chord of a constant-curvature arc), the rows at `azimuth_deg` from spring
/// A ([`CameraSettings::azimuth_deg`](crate::rig::faults::CameraSettings)) and the bend's plane
/// measured from spring A.
pub fn true_tilt_deg(obs: &Observation, azimuth_deg: f64) -> f64 {
    0.5 * obs.bend_deg * (obs.bend_plane_deg - azimuth_deg).to_radians().cos()
}

/// The standard error a camera-off measurement gives its (true) tilt, degrees.
pub const TRUTH_TILT_SD_DEG: f32 = 0.1;

/// The camera-off measurement: the true region temperatures of `obs` at `at` (frame number
/// `seq`), resolved (the supervisor computes Tc from them, as from a camera frame), and the
/// true tilt ([`true_tilt_deg`]) as a camera mounted at `azimuth_deg` sees it.
pub fn truth_measurement(obs: &Observation, azimuth_deg: f64, at: Millis, seq: u32) -> Measurement {
    Measurement {
        at,
        seq,
        regions: camera_temps(obs).regions().map(|t| Kelvin::new(t as f32)),
        hottest: Kelvin::new(obs.heater_k.max(obs.smp_outer_k) as f32),
        filled_pixels: 0,
        quality: Quality::Resolved,
        bound: Kelvin::lit(0.0),
        tilt: Some(Tilt {
            deg: true_tilt_deg(obs, azimuth_deg) as f32,
            sd_deg: TRUTH_TILT_SD_DEG,
        }),
        exposure: None,
    }
}

/// The five region temperatures the camera sees, from the plant ([`Temps::from_surfaces`]):
/// the heater film through the lattice gaps, the SMP outer surface, edges and radiation zone
/// between it and the background (the ambient), and the springs at the hottest one's
/// temperature (the renderer draws one spring temperature; a spring heating out of turn is
/// what the camera must not miss).
pub fn camera_temps(obs: &Observation) -> Temps {
    Temps::from_surfaces(
        obs.ambient_k,
        obs.heater_k,
        obs.smp_outer_k,
        obs.springs_k.iter().copied().fold(f64::MIN, f64::max),
    )
}
