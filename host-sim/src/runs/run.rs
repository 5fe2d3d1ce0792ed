//! `host-sim run`: a scene played against the plant, with its time series, summary and plot.
//!
//! This module owns the run loop and its outputs. Each control period (the scene's `period`,
//! ≤ 0.5 s) the runner applies the scene's due actions and active faults to the actuator
//! inputs, advances the [`Plant`], and measures the region temperatures the controller would
//! see:
//! - camera off: the true temperatures straight from the plant (region 1 = heater film,
//!   2 = SMP outer surface, 3–5 from them and the ambient as in [`camera_temps`]);
//! - camera on: the plant's surface temperatures are rendered into the camera's view
//!   ([`crate::sensing::scene::render`]; the column's tilt in the image is half its bending angle —
//!   the chord of a constant-curvature arc — projected on the image plane), encoded by the
//!   virtual MLX90640, read over the simulated I2C bus at 8 Hz subpages by the firmware's own
//!   sensing pipeline ([`thermorph::sensing`]: driver, subpage pairing, error policy, MTTS).
//!
//! A sensor fault with the camera off means no measurement at all (`nan` in the CSV). Outputs,
//! written by [`write_outputs`] into one folder: `timeseries.csv` (one row a period),
//! `summary.json` ([`Summary`]: run figures and the SPEC section 8 figures that an open-loop
//! scene shows, beside the thesis's) and `plot.png` ([`crate::runs::plot`]).

use std::io::Write;
use std::path::Path;
use std::time::Instant;

use embassy_futures::block_on;
use serde::Serialize;
use thermorph::mlx90640::{Config as SensorConfig, Mlx90640};
use thermorph::mtts::{IMG_PIXELS, REGIONS};
use thermorph::sensing::{Outcome, Pipeline, PipelineConfig, Sensor};

use thermorph::measurement::{Measurement, Quality, SensingHint};
use thermorph::outputs::Outputs;
use thermorph::settings::Settings;
use thermorph::supervisor::events::EventKind;
use thermorph::supervisor::report::Reply;
use thermorph::supervisor::store::{StoreOutcome, StoreRequest};
use thermorph::supervisor::{Decision, SpringMemory, Supervisor};
use thermorph::units::{Kelvin, Millis, k_or_nan};

use crate::plant::{Inputs, Observation, Plant, PlantConfig};
use crate::runs::scenario::{
    BURNING_FILM_K, CameraFault, ELSEWHERE_K, FaultSpec, Injection, Scenario,
};
use crate::sensing::scene::{Geometry, Layout, Temps};
use crate::sensor::eeprom;
use crate::sensor::sim_time::{SimClock, SimDelay};
use crate::sensor::virtual_mlx::{HeapBuffers, VirtualBus, VirtualMlx90640};

/// One control period of a run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Row {
    /// The inputs the plant was given (after faults).
    pub inputs: Inputs,
    /// Spring MOSFETs as commanded (before a stuck-MOSFET fault).
    pub springs_cmd: [bool; 3],
    /// The plant at the end of the period.
    pub obs: Observation,
    /// Region temperatures 1–5 as measured (camera on) or true (camera off), K; `None`
    /// while the sensor has no good frame.
    pub measured_k: Option<[f64; REGIONS]>,
    /// True region temperatures 1–5, K.
    pub truth_k: [f64; REGIONS],
    /// Bit mask of the scene's faults active in this period (bit i = fault i).
    pub faults: u32,
    /// The supervisor in this period (closed-loop scenes only).
    pub control: Option<ControlRow>,
}

/// What the supervisor did in one period of a closed-loop run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControlRow {
    /// Its mode (as `status` names it).
    pub mode: &'static str,
    /// Its phase within the mode (`-` where none).
    pub phase: &'static str,
    /// The loop's target, K (NaN when no loop runs).
    pub target_k: f64,
    /// Tc as the supervisor computed it, K (NaN before the first measurement).
    pub tc_k: f64,
    /// The latched fault's code, if any.
    pub fault: Option<&'static str>,
}

/// A console line of the scene and the supervisor's reply.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ReplyRecord {
    /// When it was sent, s.
    pub at_s: f64,
    /// The line.
    pub line: String,
    /// The reply line.
    pub reply: String,
}

/// A fault the supervisor latched.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct FaultRecord {
    /// When, s.
    pub at_s: f64,
    /// Its code.
    pub code: String,
    /// Its reason.
    pub reason: String,
}

/// The camera chain: renderer → virtual MLX90640 → the firmware's sensing pipeline (driver,
/// subpage pairing, MTTS) — the same policy as the board's sensor task.
pub(crate) struct Camera {
    clock: SimClock,
    bus: VirtualBus,
    pub(crate) sensor: Sensor<VirtualBus, SimDelay, SimClock, HeapBuffers>,
    pub(crate) frames: u64,
    errors: u64,
    /// The latest measurement; `None` after an error until the next frame.
    last: Option<Measurement>,
    /// Which region each sample of the view shows, for the last geometry (the column's tilt
    /// changes only while it bends).
    layout: Option<Layout>,
    /// The rendered view, K.
    view_k: Box<[f64; IMG_PIXELS]>,
}

/// Samples per pixel side of the camera's view.
const CAMERA_SUBGRID: usize = 4;

impl Camera {
    pub(crate) fn new(seed: u64, noise_k: f64) -> Result<Self, String> {
        let clock = SimClock::new();
        let mut device =
            VirtualMlx90640::new(eeprom::realistic(seed).encode()?, clock.clone(), seed)
                .map_err(|e| format!("virtual sensor: {e}"))?;
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
        block_on(probe.read_eeprom(&mut words)).map_err(|e| e.to_string())?;
        block_on(probe.configure(SensorConfig::default())).map_err(|e| e.to_string())?;
        let pipeline = Pipeline::new(PipelineConfig::default()).map_err(|e| e.to_string())?;
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
        })
    }

    /// Show the sensor the block as it is now (or what a camera fault shows instead), run the
    /// sensing pipeline until the sensor's clock reaches `t_s`, and return the latest region
    /// temperatures.
    pub(crate) fn update(
        &mut self,
        obs: &Observation,
        faults: CameraFaults,
        t_s: f64,
        hint: SensingHint,
    ) -> Option<Measurement> {
        self.sensor.set_hint(hint);
        let frames = self.frames;
        {
            let mut dev = self.bus.0.borrow_mut();
            if faults.view == Some(CameraFault::Elsewhere) {
                dev.field_k = [ELSEWHERE_K as f32; IMG_PIXELS];
            } else {
                let mut temps = camera_temps(obs);
                if faults.view == Some(CameraFault::BurningFilm) {
                    temps.heater_k = BURNING_FILM_K;
                }
                let plane = obs.bend_plane_deg.to_radians();
                let geometry = Geometry {
                    tilt_deg: 0.5 * obs.bend_deg * plane.cos(),
                    springs: true,
                    ..Geometry::default()
                };
                // The view as `scene::render` draws it (no noise: the sensor adds its own).
                let layout = match &mut self.layout {
                    Some(l) if *l.geometry() == geometry => l,
                    slot => slot.insert(Layout::new(&geometry, CAMERA_SUBGRID)),
                };
                layout.image(&temps, &mut self.view_k);
                for (dst, &k) in dev.field_k.iter_mut().zip(self.view_k.iter()) {
                    *dst = k as f32;
                }
            }
            dev.set_fault(faults.sensor);
        }
        let t_end_us = (t_s * 1e6) as u64;
        // Every action advances the simulated clock (bus time, a pause or a timeout).
        while self.clock.now_us() < t_end_us {
            match block_on(self.sensor.step()) {
                Outcome::Frame(m) => {
                    self.frames += 1;
                    self.last = Some(m);
                }
                Outcome::Error(_) => {
                    // The supervisor sees no measurement until a good frame comes.
                    self.errors += 1;
                    self.last = None;
                }
                _ => {}
            }
        }
        self.last.filter(|_| self.frames > frames)
    }
}

/// What the scene's active faults do to the camera chain in one period.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct CameraFaults {
    /// The sensor's own fault (with the camera off: no measurement at all).
    pub(crate) sensor: Option<crate::sensor::virtual_mlx::Fault>,
    /// What the camera sees instead of the block.
    pub(crate) view: Option<CameraFault>,
}

/// Apply the faults of `faults` active at `t_s` to `inputs`; return their bit mask (bit i =
/// fault i) and what they do to the camera chain.
pub(crate) fn apply_faults(
    faults: &[FaultSpec],
    t_s: f64,
    inputs: &mut Inputs,
) -> (u32, CameraFaults) {
    let mut mask = 0u32;
    let mut camera = CameraFaults::default();
    for (i, f) in faults.iter().enumerate().filter(|(_, f)| f.active(t_s)) {
        mask |= 1 << i.min(31);
        match f.kind {
            Injection::HeaterOpen => inputs.heater_open = true,
            Injection::StuckSpring { spring, on } => inputs.springs_on[spring] = on,
            Injection::Sensor(s) => camera.sensor = Some(s),
            Injection::Camera(v) => camera.view = Some(v),
        }
    }
    (mask, camera)
}

/// What an open-loop scene (no supervisor to give the mode's prior) tells the camera: the
/// heating modes' prior, the heater area the hotter — a clear spatial verdict still wins over
/// it (MTTS) — and Tc on the SMP surface.
pub(crate) fn open_loop_hint() -> SensingHint {
    SensingHint {
        prior: thermorph::mtts::Prior::HeaterHotter,
        ..SensingHint::default()
    }
}

/// Measure the block at the end of a period, as the supervisor will see it: through the camera
/// chain, or (camera off) the true temperatures — nothing while a sensor fault is injected.
/// Returns the region temperatures to record (the latest frame's) and the measurement for the
/// supervisor if a new frame came in this period.
pub(crate) fn measure(
    camera: Option<&mut Camera>,
    obs: &Observation,
    faults: CameraFaults,
    t_s: f64,
    period: u64,
    hint: SensingHint,
) -> (Option<[f64; REGIONS]>, Option<Measurement>) {
    match camera {
        Some(c) => {
            let new = c.update(obs, faults, t_s, hint);
            let regions = c
                .last
                .map(|m| core::array::from_fn(|i| k_or_nan(m.regions[i]) as f64));
            (regions, new)
        }
        None if faults.sensor.is_some() => (None, None),
        None => {
            let truth_k = camera_temps(obs).regions();
            let cyl = Kelvin::new(obs.heater_k.max(obs.smp_outer_k) as f32);
            let m = truth_measurement(&truth_k, cyl, t_s, period);
            (Some(truth_k), Some(m))
        }
    }
}

/// The firmware's supervisor in the loop: console lines in, plant inputs out.
pub struct Control {
    /// The supervisor, exactly as the board runs it.
    pub supervisor: Supervisor,
    /// Every fault it latched.
    pub faults: Vec<FaultRecord>,
    seen_events: u32,
    /// The settings record `save` wrote in this run.
    stored: Option<Vec<u8>>,
}

impl Control {
    /// Start the supervisor at `now` with the default settings. The simulated springs start at
    /// ambient, and the simulated board knows it: its supervisor starts with
    /// [`SpringMemory::RESTED`], as a board would whose RAM kept the springs' memory across a
    /// reset long after they were last driven (a real power-up assumes them hot).
    pub fn new(now: Millis) -> Self {
        Control {
            supervisor: Supervisor::with_memory(now, Settings::DEFAULT, SpringMemory::RESTED),
            faults: Vec::new(),
            seen_events: 0,
            stored: None,
        }
    }

    /// One control period: the new measurement (if a frame came) and the due console lines
    /// (each a step of its own, as the board does); returns the plant's inputs.
    pub fn step(
        &mut self,
        now: Millis,
        m: Option<&Measurement>,
        lines: &[crate::runs::scenario::CommandLine],
        replies: &mut Vec<ReplyRecord>,
    ) -> Inputs {
        let mut d = self.supervisor.step(now, m, None);
        for l in lines {
            let c = thermorph::command::parse(&l.line);
            d = match c {
                Ok(c) => self.supervisor.step(now, None, Some(c)),
                Err(e) => Decision {
                    reply: Some(Reply::parse_error(e)),
                    ..d
                },
            };
            // A scene's `save` and `load` use a record kept for the run (the board's flash,
            // the console's file).
            if let Some(req) = d.store.take() {
                let reply = match req {
                    StoreRequest::Save(record) => {
                        self.stored = Some(record.to_vec());
                        self.supervisor.finish_store(now, StoreOutcome::Saved)
                    }
                    StoreRequest::Load => {
                        let stored = self.stored.clone();
                        self.supervisor
                            .finish_store(now, StoreOutcome::Loaded(stored.as_deref()))
                    }
                };
                d.reply = Some(reply);
            }
            replies.push(ReplyRecord {
                at_s: l.at_s,
                line: l.line.clone(),
                reply: d
                    .reply
                    .as_ref()
                    .map_or(String::new(), |r| r.as_str().to_string()),
            });
        }
        for e in self.supervisor.events().since(self.seen_events) {
            if let EventKind::Fault(f) = e.kind {
                self.faults.push(FaultRecord {
                    at_s: e.at.ms() as f64 * 1e-3,
                    code: f.code().into(),
                    reason: f.reason().to_string(),
                });
            }
        }
        self.seen_events = self.supervisor.events().total();
        inputs_of(&d.outputs)
    }

    /// The supervisor's state for the time series.
    pub fn row(&self) -> ControlRow {
        let s = &self.supervisor;
        ControlRow {
            mode: s.mode().name(),
            phase: s.mode().phase_name(),
            target_k: s.target_k() as f64,
            tc_k: s.tc_k() as f64,
            fault: s.fault().map(|f| f.code()),
        }
    }
}

/// The plant's inputs for a decision's outputs.
pub fn inputs_of(o: &Outputs) -> Inputs {
    Inputs {
        heater_duty: o.heater.fraction() as f64,
        fan_duty: o.fan.fraction() as f64,
        springs_on: core::array::from_fn(|i| o.springs.contains(i)),
        ..Inputs::default()
    }
}

/// A measurement of region temperatures taken at `t_s` (frame number `seq`).
fn truth_measurement(
    regions_k: &[f64; REGIONS],
    cylinder_max: Option<Kelvin>,
    t_s: f64,
    seq: u64,
) -> Measurement {
    Measurement {
        at: Millis((t_s * 1000.0).round() as u64),
        seq: seq as u32,
        regions: regions_k.map(|t| Kelvin::new(t as f32)),
        cylinder_max,
        filled_pixels: 0,
        quality: Quality::Resolved,
        bound: Kelvin::lit(0.0),
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

/// Everything a run produced.
#[derive(Clone, Debug)]
pub struct RunResult {
    /// One row per control period.
    pub rows: Vec<Row>,
    /// The summary.
    pub summary: Summary,
}

/// One figure of SPEC section 8, as simulated, beside the thesis's value.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Figure {
    /// What it is.
    pub name: String,
    /// Unit of `simulated` and `thesis`.
    pub unit: String,
    /// Measured in this run (`None`: the scene does not show it).
    pub simulated: Option<f64>,
    /// The thesis's value.
    pub thesis: f64,
    /// How it is measured.
    pub how: String,
}

impl Figure {
    /// Make a figure.
    pub fn new(name: &str, unit: &str, simulated: Option<f64>, thesis: f64, how: &str) -> Figure {
        Figure {
            name: name.into(),
            unit: unit.into(),
            simulated,
            thesis,
            how: how.into(),
        }
    }
}

/// MTTS accuracy over a camera-on run.
#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
pub struct CameraStats {
    /// Whole frames turned into regions.
    pub frames: u64,
    /// Sensor or MTTS errors.
    pub errors: u64,
    /// Mean |T1 measured − true| over the periods with a measurement, K.
    pub mean_abs_t1_err_k: f64,
    /// Largest |T1 measured − true|, K.
    pub max_abs_t1_err_k: f64,
    /// Mean |T2 measured − true|, K.
    pub mean_abs_t2_err_k: f64,
    /// Largest |T2 measured − true|, K.
    pub max_abs_t2_err_k: f64,
}

/// A run's summary (written as `summary.json`).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Summary {
    /// Scene name.
    pub scene: String,
    /// Scene description.
    pub description: String,
    /// Simulated time, s.
    pub duration_s: f64,
    /// Control period, s.
    pub period_s: f64,
    /// Control periods simulated.
    pub steps: usize,
    /// Plant fidelity, as `thermal/sma/smp/mechanics`.
    pub fidelity: String,
    /// Whether the camera chain ran.
    pub camera: bool,
    /// Wall time of the simulation loop, s.
    pub wall_s: f64,
    /// Simulated seconds per wall second.
    pub real_time_factor: f64,
    /// Highest heater film temperature, K.
    pub max_heater_k: f64,
    /// Highest SMP outer-surface temperature, K.
    pub max_smp_outer_k: f64,
    /// Largest bending angle, degrees.
    pub max_bend_deg: f64,
    /// Bending angle at the end, degrees.
    pub final_bend_deg: f64,
    /// Lowest and highest bending stiffness, N·mm/rad.
    pub k_b_range_nmm_per_rad: [f64; 2],
    /// Periods without a measurement.
    pub periods_without_measurement: usize,
    /// MTTS accuracy (camera on only).
    pub camera_stats: Option<CameraStats>,
    /// The SPEC section 8 figures (open-loop scenes; `host-sim paper` measures them closed
    /// loop).
    pub figures: Vec<Figure>,
    /// Each console line of the scene with its reply (closed-loop scenes).
    pub replies: Vec<ReplyRecord>,
    /// Every fault the supervisor latched (closed-loop scenes).
    pub faults: Vec<FaultRecord>,
}

/// Play `scenario`; `progress` is called after each period with the fraction done.
pub fn run(scenario: &Scenario, progress: &mut dyn FnMut(f64)) -> Result<RunResult, String> {
    run_with(scenario, progress, &mut |_, _| None)
}

/// The plant and (if the scene has it on) the camera chain of `scenario`, at time 0.
pub(crate) fn block_of(scenario: &Scenario) -> Result<(Plant, Option<Camera>), String> {
    let plant = Plant::new(&PlantConfig {
        ambient_k: scenario.ambient_k,
        initial_k: scenario.initial_k,
        fidelity: scenario.fidelity,
        integrator: scenario.integrator,
        max_step_s: scenario.max_step_s,
    })?;
    let camera = if scenario.camera.enabled {
        Some(Camera::new(scenario.camera.seed, scenario.camera.noise_k)?)
    } else {
        None
    };
    Ok((plant, camera))
}

/// Decides console lines from the supervisor's state (for experiments that enter modes back to
/// back): called each period with the time and the supervisor; a returned line is sent then.
pub type Reactor<'a> = dyn FnMut(f64, &Supervisor) -> Option<String> + 'a;

/// [`run`], with `react` able to send console lines as the supervisor's state changes (the
/// scene must run closed loop: at least one `[[command]]`).
pub fn run_with(
    scenario: &Scenario,
    progress: &mut dyn FnMut(f64),
    react: &mut Reactor<'_>,
) -> Result<RunResult, String> {
    let (mut plant, mut camera) = block_of(scenario)?;
    let steps = (scenario.duration_s / scenario.period_s).round().max(1.0) as usize;
    let mut rows = Vec::with_capacity(steps);
    let mut cmd = Inputs::default();
    let mut next_action = 0;
    let mut next_command = 0;
    let closed_loop = !scenario.commands.is_empty();
    let mut control = closed_loop.then(|| Control::new(Millis(0)));
    let mut replies = Vec::new();
    let mut measurement: Option<Measurement> = None;
    let started = Instant::now();
    for k in 0..steps {
        let t0_s = k as f64 * scenario.period_s;
        let t1_s = (k + 1) as f64 * scenario.period_s;
        while let Some(a) = scenario
            .actions
            .get(next_action)
            .filter(|a| a.at_s <= t0_s + 1e-9)
        {
            if let Some(d) = a.heater_duty {
                cmd.heater_duty = d;
            }
            if let Some(d) = a.fan_duty {
                cmd.fan_duty = d;
            }
            if let Some(s) = a.springs_on {
                cmd.springs_on = s;
            }
            next_action += 1;
        }
        if let Some(c) = control.as_mut() {
            let now = Millis((t0_s * 1000.0).round() as u64);
            let mut lines = Vec::new();
            while let Some(l) = scenario
                .commands
                .get(next_command)
                .filter(|l| l.at_s <= t0_s + 1e-9)
            {
                lines.push(l.clone());
                next_command += 1;
            }
            if let Some(line) = react(t0_s, &c.supervisor) {
                lines.push(crate::runs::scenario::CommandLine { at_s: t0_s, line });
            }
            let d = c.step(now, measurement.take().as_ref(), &lines, &mut replies);
            cmd = d;
        }
        let mut inputs = cmd;
        let (faults, camera_faults) = apply_faults(&scenario.faults, t0_s, &mut inputs);
        plant.step(&inputs, t1_s - t0_s);
        let obs = plant.observe();
        let truth_k = camera_temps(&obs).regions();
        let hint = control
            .as_ref()
            .map_or_else(open_loop_hint, |c| c.supervisor.sensing_hint());
        let (measured_k, new) = measure(
            camera.as_mut(),
            &obs,
            camera_faults,
            t1_s,
            k as u64 + 1,
            hint,
        );
        measurement = new;
        rows.push(Row {
            inputs,
            springs_cmd: cmd.springs_on,
            obs,
            measured_k,
            truth_k,
            faults,
            control: control.as_ref().map(Control::row),
        });
        progress((k + 1) as f64 / steps as f64);
    }
    let wall_s = started.elapsed().as_secs_f64();
    let mut summary = summarise(scenario, &rows, wall_s, camera.as_ref());
    summary.replies = replies;
    summary.faults = control.map(|c| c.faults).unwrap_or_default();
    Ok(RunResult { rows, summary })
}

fn summarise(scenario: &Scenario, rows: &[Row], wall_s: f64, camera: Option<&Camera>) -> Summary {
    let f = scenario.fidelity;
    let fold = |get: &dyn Fn(&Row) -> f64, init: f64, op: fn(f64, f64) -> f64| {
        rows.iter().map(get).fold(init, op)
    };
    let camera_stats = camera.map(|c| {
        let errs: Vec<(f64, f64)> = rows
            .iter()
            .filter_map(|r| {
                r.measured_k
                    .map(|m| ((m[0] - r.truth_k[0]).abs(), (m[1] - r.truth_k[1]).abs()))
            })
            .collect();
        let n = errs.len().max(1) as f64;
        CameraStats {
            frames: c.frames,
            errors: c.errors,
            mean_abs_t1_err_k: errs.iter().map(|e| e.0).sum::<f64>() / n,
            max_abs_t1_err_k: errs.iter().map(|e| e.0).fold(0.0, f64::max),
            mean_abs_t2_err_k: errs.iter().map(|e| e.1).sum::<f64>() / n,
            max_abs_t2_err_k: errs.iter().map(|e| e.1).fold(0.0, f64::max),
        }
    });
    let duration_s = rows.last().map_or(0.0, |r| r.obs.time_s);
    Summary {
        scene: scenario.name.clone(),
        description: scenario.description.clone(),
        duration_s,
        period_s: scenario.period_s,
        steps: rows.len(),
        fidelity: format!(
            "{:?}/{:?}/{:?}/{}",
            f.thermal,
            f.sma,
            f.smp,
            if f.mechanics {
                "mechanics"
            } else {
                "no-mechanics"
            }
        )
        .to_lowercase(),
        camera: scenario.camera.enabled,
        wall_s,
        real_time_factor: if wall_s > 0.0 {
            duration_s / wall_s
        } else {
            f64::INFINITY
        },
        max_heater_k: fold(&|r| r.obs.heater_k, f64::MIN, f64::max),
        max_smp_outer_k: fold(&|r| r.obs.smp_outer_k, f64::MIN, f64::max),
        max_bend_deg: fold(&|r| r.obs.bend_deg, 0.0, f64::max),
        final_bend_deg: rows.last().map_or(0.0, |r| r.obs.bend_deg),
        k_b_range_nmm_per_rad: [
            fold(&|r| r.obs.k_b_nmm_per_rad, f64::MAX, f64::min),
            fold(&|r| r.obs.k_b_nmm_per_rad, f64::MIN, f64::max),
        ],
        periods_without_measurement: rows.iter().filter(|r| r.measured_k.is_none()).count(),
        camera_stats,
        figures: if scenario.commands.is_empty() {
            figures(rows)
        } else {
            closed_loop_figures(rows)
        },
        replies: Vec::new(),
        faults: Vec::new(),
    }
}

/// First time in `rows[from..]` where `pred` holds, s.
fn first_time(rows: &[Row], from: usize, pred: impl Fn(&Row) -> bool) -> Option<(usize, f64)> {
    rows.iter()
        .enumerate()
        .skip(from)
        .find(|(_, r)| pred(r))
        .map(|(i, r)| (i, r.obs.time_s))
}

/// The SPEC section 8 figures that an open-loop run shows. Phases are found from the inputs:
/// *forming* starts at the first period with the heater off, the fan on and the column bent
/// by more than 5°; *recovery* at the first later period with the heater on and every spring
/// off. Start of period k is `time_s − period`.
pub fn figures(rows: &[Row]) -> Vec<Figure> {
    let period_s = match rows {
        [a, b, ..] => b.obs.time_s - a.obs.time_s,
        [a] => a.obs.time_s,
        [] => 0.0,
    };
    let start = |i: usize| rows[i].obs.time_s - period_s;
    let heat_323 = (rows.first().is_some_and(|r| r.obs.heater_k < 323.0))
        .then(|| first_time(rows, 0, |r| r.obs.heater_k >= 323.0).map(|(_, t)| t))
        .flatten();
    let loaded = |n: usize| {
        let v = rows
            .iter()
            .filter(|r| r.inputs.springs_on.iter().filter(|s| **s).count() == n)
            .map(|r| r.obs.bend_deg)
            .fold(f64::NAN, f64::max);
        (!v.is_nan()).then_some(v)
    };
    let forming = first_time(rows, 0, |r| {
        r.inputs.heater_duty == 0.0 && r.inputs.fan_duty > 0.0 && r.obs.bend_deg > 5.0
    });
    let formed = forming.and_then(|(i, _)| {
        first_time(rows, i, |r| r.obs.smp_outer_k <= 323.0).map(|(j, t)| (j, t - start(i)))
    });
    let k_b_hot = forming.map(|(i, _)| rows[i.saturating_sub(1)].obs.k_b_nmm_per_rad);
    let k_b_formed = formed.map(|(j, _)| rows[j].obs.k_b_nmm_per_rad);
    let recovery_start = forming.and_then(|(i, _)| {
        first_time(rows, i, |r| {
            r.inputs.heater_duty > 0.0 && !r.inputs.springs_on.iter().any(|s| *s)
        })
    });
    let reheat_358 = recovery_start.and_then(|(i, _)| {
        first_time(rows, i, |r| r.obs.heater_k >= 358.0).map(|(_, t)| t - start(i))
    });
    let recovered = recovery_start.and_then(|(i, _)| {
        first_time(rows, i, |r| r.obs.bend_deg <= 2.0).map(|(_, t)| t - start(i))
    });
    let fig = Figure::new;
    vec![
        fig(
            "standby heat-up",
            "s",
            heat_323,
            10.0,
            "heater film from the start to 323 K",
        ),
        fig(
            "full loading, one spring",
            "deg",
            loaded(1),
            42.0,
            "largest bend with one spring on",
        ),
        fig(
            "full loading, two springs",
            "deg",
            loaded(2),
            65.0,
            "largest bend with two springs on",
        ),
        fig(
            "forming",
            "s",
            formed.map(|f| f.1),
            50.0,
            "from heater off + fan on (bent) to the SMP outer surface at 323 K",
        ),
        fig(
            "formed stiffness",
            "N·mm/rad",
            k_b_formed,
            1400.0,
            "k_b when forming reaches 323 K",
        ),
        fig(
            "stiffness ratio formed/heated",
            "",
            k_b_formed.zip(k_b_hot).map(|(a, b)| a / b),
            4.5,
            "k_b at 323 K after forming over k_b just before forming",
        ),
        fig(
            "reheat to 358 K",
            "s",
            reheat_358,
            25.0,
            "from recovery start (heater on, springs off) to the heater film at 358 K",
        ),
        fig(
            "recovery",
            "s",
            recovered,
            40.0,
            "from recovery start to within 2° of straight",
        ),
    ]
}

/// The SPEC section 8 figures a closed-loop run shows, measured as `host-sim paper` measures
/// them ([`crate::runs::paper::measure`]: from the supervisor's modes and phases, Tc, and the
/// plant's bend and k_b).
pub fn closed_loop_figures(rows: &[Row]) -> Vec<Figure> {
    let f = crate::runs::paper::measure(rows);
    let fig = Figure::new;
    let mean_drop = (!f.pulse_drop_deg.is_empty())
        .then(|| f.pulse_drop_deg.iter().sum::<f64>() / f.pulse_drop_deg.len() as f64);
    vec![
        fig(
            "standby preheat",
            "s",
            f.preheat_time_s,
            10.0,
            "power-up until Tc reaches 322.5 K",
        ),
        fig(
            "standby overshoot",
            "K",
            f.standby_overshoot_k,
            1.0,
            "largest Tc − 323 K (SPEC: < 1 K)",
        ),
        fig(
            "standby hold band",
            "K",
            f.standby_hold_band_k,
            0.5,
            "largest |Tc − 323 K| over 60 s from 20 s after reaching it",
        ),
        fig(
            "large stepping",
            "s",
            f.large_stepping_time_s,
            30.0,
            "first spring phase's start to the last one's end",
        ),
        fig(
            "pulse drop, mean",
            "deg",
            mean_drop,
            3.0,
            "bend at a pulse's start minus at its end (thesis 2–4°)",
        ),
        fig(
            "full loading",
            "deg",
            f.full_loading_deg,
            65.0,
            "bend at the end of stepping (thesis: 42° one spring, 65° two)",
        ),
        fig(
            "forming",
            "s",
            f.forming_time_s,
            50.0,
            "forming's start until the supervisor ends it",
        ),
        fig(
            "forming angle loss",
            "deg",
            f.forming_angle_loss_deg,
            5.0,
            "bend at forming's start minus 20 s later",
        ),
        fig(
            "formed stiffness",
            "N·mm/rad",
            f.formed_k_b,
            1400.0,
            "k_b when forming ends",
        ),
        fig(
            "stiffness ratio formed/heated",
            "",
            f.stiffness_ratio,
            4.5,
            "k_b formed over k_b at the end of stepping",
        ),
        fig(
            "recovery",
            "s",
            f.recovery_time_s,
            40.0,
            "recovery's start until within 2° of straight",
        ),
        fig(
            "cycle",
            "s",
            f.cycle_time_s,
            120.0,
            "first spring phase until recovery ends",
        ),
    ]
}

/// Write `timeseries.csv`, `summary.json` and `plot.png` into `dir` (created if missing).
pub fn write_outputs(result: &RunResult, dir: &Path) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: cannot create: {e}", dir.display()))?;
    let csv = dir.join("timeseries.csv");
    let mut buf = Vec::with_capacity(result.rows.len() * 300);
    write_csv(&result.rows, &mut buf).map_err(|e| e.to_string())?;
    std::fs::write(&csv, buf).map_err(|e| format!("{}: {e}", csv.display()))?;
    let json = dir.join("summary.json");
    let text = serde_json::to_string_pretty(&result.summary).map_err(|e| e.to_string())?;
    std::fs::write(&json, text + "\n").map_err(|e| format!("{}: {e}", json.display()))?;
    let png = dir.join("plot.png");
    crate::runs::plot::write_png(&result.rows, &result.summary.scene, &png)?;
    Ok(())
}

/// The CSV header.
pub const CSV_HEADER: &str = "time_s,heater_duty_pct,fan_duty_pct,spring_a,spring_b,spring_c,\
heater_k,smp_inner_k,smp_outer_k,duct_air_k,spring_a_k,spring_b_k,spring_c_k,\
austenite_a,austenite_b,austenite_c,frozen_fraction,bend_deg,bend_plane_deg,k_b_nmm_per_rad,\
heater_power_w,spring_power_w,t1_k,t2_k,t3_k,t4_k,t5_k,faults,mode,phase,target_k,tc_k,fault";

/// Write the time series as CSV (`nan` where there is no measurement).
pub fn write_csv(rows: &[Row], out: &mut impl Write) -> std::io::Result<()> {
    writeln!(out, "{CSV_HEADER}")?;
    for r in rows {
        let o = &r.obs;
        let s = |b: bool| u8::from(b);
        write!(
            out,
            "{:.3},{:.1},{:.1},{},{},{},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{:.4},{:.4},{:.4},{:.4},{:.3},{:.2},{:.1},{:.3},{:.3}",
            o.time_s,
            100.0 * r.inputs.heater_duty,
            100.0 * r.inputs.fan_duty,
            s(r.inputs.springs_on[0]),
            s(r.inputs.springs_on[1]),
            s(r.inputs.springs_on[2]),
            o.heater_k,
            o.smp_inner_k,
            o.smp_outer_k,
            o.duct_air_k,
            o.springs_k[0],
            o.springs_k[1],
            o.springs_k[2],
            o.austenite[0],
            o.austenite[1],
            o.austenite[2],
            o.frozen_fraction,
            o.bend_deg,
            o.bend_plane_deg,
            o.k_b_nmm_per_rad,
            o.heater_power_w,
            o.spring_power_w.iter().sum::<f64>(),
        )?;
        for i in 0..REGIONS {
            match r.measured_k {
                Some(m) => write!(out, ",{:.3}", m[i])?,
                None => write!(out, ",nan")?,
            }
        }
        write!(out, ",{}", r.faults)?;
        // The supervisor's columns: `-`/`nan` in open-loop scenes; `fault` is `none` unless
        // a fault is latched.
        match &r.control {
            Some(c) => {
                let k = |v: f64| {
                    if v.is_finite() {
                        format!("{v:.3}")
                    } else {
                        "nan".into()
                    }
                };
                writeln!(
                    out,
                    ",{},{},{},{},{}",
                    c.mode,
                    c.phase,
                    k(c.target_k),
                    k(c.tc_k),
                    c.fault.unwrap_or("none")
                )?
            }
            None => writeln!(out, ",-,-,nan,nan,none")?,
        }
    }
    Ok(())
}

/// Print the summary for a person: the run, then the figures beside the thesis's.
pub fn print_summary(s: &Summary, out: &mut impl Write) -> std::io::Result<()> {
    writeln!(
        out,
        "scene {}: {} ({} periods of {} s, fidelity {}, camera {})",
        s.scene,
        s.description,
        s.steps,
        s.period_s,
        s.fidelity,
        if s.camera { "on" } else { "off" }
    )?;
    writeln!(
        out,
        "simulated {:.1} s in {:.3} s wall ({:.0}× real time)",
        s.duration_s, s.wall_s, s.real_time_factor
    )?;
    writeln!(
        out,
        "max heater {:.1} K, max SMP surface {:.1} K, max bend {:.1}°, final bend {:.1}°, k_b {:.0}–{:.0} N·mm/rad",
        s.max_heater_k,
        s.max_smp_outer_k,
        s.max_bend_deg,
        s.final_bend_deg,
        s.k_b_range_nmm_per_rad[0],
        s.k_b_range_nmm_per_rad[1]
    )?;
    if let Some(c) = &s.camera_stats {
        writeln!(
            out,
            "camera: {} frames, {} errors; |T1 − truth| mean {:.2} K max {:.2} K, |T2 − truth| mean {:.2} K max {:.2} K",
            c.frames,
            c.errors,
            c.mean_abs_t1_err_k,
            c.max_abs_t1_err_k,
            c.mean_abs_t2_err_k,
            c.max_abs_t2_err_k
        )?;
    }
    if s.periods_without_measurement > 0 {
        writeln!(
            out,
            "periods without a measurement: {}",
            s.periods_without_measurement
        )?;
    }
    writeln!(
        out,
        "{:<32} {:>10} {:>10}  unit",
        "figure", "simulated", "thesis"
    )?;
    for f in &s.figures {
        let sim = f.simulated.map_or("—".to_string(), |v| format!("{v:.1}"));
        writeln!(
            out,
            "{:<32} {:>10} {:>10}  {}",
            f.name, sim, f.thesis, f.unit
        )?;
    }
    for r in &s.replies {
        writeln!(out, "{:>8.2} s  > {}  < {}", r.at_s, r.line, r.reply)?;
    }
    for f in &s.faults {
        writeln!(out, "{:>8.2} s  fault {}: {}", f.at_s, f.code, f.reason)?;
    }
    Ok(())
}

/// Arguments of `host-sim run`.
#[derive(clap::Args, Debug, Default, Clone)]
pub struct RunArgs {
    /// Scene: a bundled name (cycle, open-loop, faults) or a TOML file.
    #[arg(default_value = "cycle")]
    pub scene: String,
    /// Output folder (default: `runs/<scene name>`).
    #[arg(long)]
    pub out: Option<std::path::PathBuf>,
    /// No progress bar and no summary on standard output.
    #[arg(long)]
    pub quiet: bool,
}

/// A progress bar on standard error, drawn only on a terminal and only once a run has taken
/// more than a second.
pub struct Progress {
    started: Instant,
    enabled: bool,
    drawn: bool,
    last_pct: i64,
}

impl Progress {
    /// A bar, enabled if `enabled` and standard error is a terminal.
    pub fn new(enabled: bool) -> Self {
        use std::io::IsTerminal;
        Progress {
            started: Instant::now(),
            enabled: enabled && std::io::stderr().is_terminal(),
            drawn: false,
            last_pct: -1,
        }
    }

    /// The bar's text at `fraction` done after `elapsed_s` of wall time.
    pub fn line(fraction: f64, elapsed_s: f64) -> String {
        let f = fraction.clamp(0.0, 1.0);
        let filled = (f * 30.0).round() as usize;
        let eta_s = if f > 0.0 {
            elapsed_s * (1.0 - f) / f
        } else {
            0.0
        };
        format!(
            "[{}{}] {:3.0}%  {:.1} s, about {:.0} s left",
            "#".repeat(filled),
            "-".repeat(30 - filled),
            100.0 * f,
            elapsed_s,
            eta_s
        )
    }

    /// Report `fraction` done.
    pub fn update(&mut self, fraction: f64) {
        if !self.enabled {
            return;
        }
        let elapsed_s = self.started.elapsed().as_secs_f64();
        let pct = (fraction * 100.0) as i64;
        if elapsed_s < 1.0 || pct == self.last_pct {
            return;
        }
        self.last_pct = pct;
        self.drawn = true;
        eprint!("\r{}", Self::line(fraction, elapsed_s));
    }

    /// Finish the bar's line if one was drawn.
    pub fn finish(&mut self) {
        if self.drawn {
            eprintln!();
            self.drawn = false;
        }
    }
}

/// `host-sim run`: load the scene, run it with a progress bar, write the outputs, print the
/// summary.
pub fn cli(args: &RunArgs) -> Result<(), String> {
    let scenario = crate::runs::scenario::load(&args.scene)?;
    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("runs").join(&scenario.name));
    let mut bar = Progress::new(!args.quiet);
    let result = run(&scenario, &mut |f| bar.update(f));
    bar.finish();
    let result = result?;
    write_outputs(&result, &dir)?;
    if !args.quiet {
        let stdout = std::io::stdout();
        let mut out = stdout.lock();
        print_summary(&result.summary, &mut out).map_err(|e| e.to_string())?;
        writeln!(
            out,
            "wrote {0}/timeseries.csv, {0}/summary.json, {0}/plot.png",
            dir.display()
        )
        .map_err(|e| e.to_string())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A synthetic run: heat 0–20 s, springs AB 10–40 s (bend rises 3°/s to 60°), form
    /// 40–70 s (the surface falls 1 K/s from 360 K), recover from 70 s (bend falls 2°/s).
    fn rows() -> Vec<Row> {
        (1..=100)
            .map(|k| {
                let t = k as f64;
                let mut inputs = Inputs::default();
                let (heater_k, outer_k) = if t <= 40.0 {
                    (298.0 + 2.5 * t.min(30.0), 298.0 + 2.0 * t.min(31.0))
                } else {
                    (350.0 - (t - 40.0).min(30.0), 360.0 - (t - 40.0).min(30.0))
                };
                inputs.heater_duty = if t <= 40.0 || t > 70.0 { 1.0 } else { 0.0 };
                inputs.fan_duty = if t > 40.0 && t <= 70.0 { 1.0 } else { 0.0 };
                inputs.springs_on = [t > 10.0 && t <= 70.0, t > 10.0 && t <= 70.0, false];
                let bend_deg = if t <= 70.0 {
                    (3.0 * (t - 10.0)).clamp(0.0, 60.0)
                } else {
                    (60.0 - 2.0 * (t - 70.0)).max(0.0)
                };
                let obs = Observation {
                    time_s: t,
                    heater_k,
                    smp_inner_k: outer_k,
                    smp_outer_k: outer_k,
                    duct_air_k: outer_k,
                    ambient_k: 298.0,
                    springs_k: [300.0; 3],
                    austenite: [0.0; 3],
                    frozen_fraction: 0.0,
                    bend_deg,
                    bend_plane_deg: 0.0,
                    k_b_nmm_per_rad: if t <= 40.0 {
                        300.0
                    } else {
                        300.0 + 40.0 * (t - 40.0)
                    },
                    heater_power_w: 0.0,
                    spring_power_w: [0.0; 3],
                    spring_current_a: [0.0; 3],
                    spring_force_n: [0.0; 3],
                    smp_coldest_k: outer_k,
                    stored_bend_deg: 0.0,
                    film_set_deg: 0.0,
                };
                let truth_k = camera_temps(&obs).regions();
                Row {
                    inputs,
                    springs_cmd: inputs.springs_on,
                    obs,
                    measured_k: Some(truth_k),
                    truth_k,
                    faults: 0,
                    control: None,
                }
            })
            .collect()
    }

    #[test]
    fn figures_find_the_phases() {
        let f = figures(&rows());
        let get = |name: &str| f.iter().find(|x| x.name == name).unwrap().simulated;
        // 298 + 2.5 t ≥ 323 first at t = 10 s.
        assert_eq!(get("standby heat-up"), Some(10.0));
        assert_eq!(get("full loading, two springs"), Some(60.0));
        assert_eq!(get("full loading, one spring"), None);
        // Forming starts with period 41 (start 40 s), but the surface stops falling at 330 K.
        assert_eq!(get("forming"), None);
        assert_eq!(get("formed stiffness"), None);
        // Recovery starts with period 71 (start 70 s); 60 − 2 (t − 70) ≤ 2 first at t = 99 s.
        assert_eq!(get("recovery"), Some(29.0));
    }

    #[test]
    fn figures_of_a_formed_block() {
        let mut rows = rows();
        for r in rows
            .iter_mut()
            .filter(|r| r.obs.time_s > 40.0 && r.obs.time_s <= 70.0)
        {
            r.obs.smp_outer_k = 360.0 - 1.5 * (r.obs.time_s - 40.0);
        }
        let f = figures(&rows);
        let get = |name: &str| f.iter().find(|x| x.name == name).unwrap().simulated;
        // 360 − 1.5 (t − 40) ≤ 323 first at t = 65 s: 25 s after forming started at 40 s.
        assert_eq!(get("forming"), Some(25.0));
        assert_eq!(get("formed stiffness"), Some(300.0 + 40.0 * 25.0));
        assert_eq!(get("stiffness ratio formed/heated"), Some(1300.0 / 300.0));
        // 60 − 2 (t − 70) ≤ 2 first at t = 99 s: 29 s after recovery started at 70 s.
        assert_eq!(get("recovery"), Some(29.0));
    }
}
