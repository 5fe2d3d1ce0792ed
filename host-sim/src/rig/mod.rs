//! The simulated board: the plant, the camera chain, injected faults and the library's
//! [`Controller`], stepped as the board steps it.
//!
//! This module owns the order of simulated time. The board's control loop steps the
//! controller every [`TICK_MS`] (the library's [`CONTROL_PERIOD_MS`]), on every frame the
//! sensing task publishes, on every console line and on every press of the e-stop button; so
//! does [`SimBoard`]:
//! [`SimBoard::advance_to`] runs the plant between those instants with the outputs of the last
//! decision (and the active injected faults), runs the camera chain at the sensor's own 8 Hz
//! subpage rate and steps the controller at each tick and at each frame's time;
//! [`SimBoard::line`] is a console line at the board's present time, [`SimBoard::set_button`]
//! the e-stop button pressed or released then (every period reports the button as the board's
//! loop does: its level, or a press since the last period). A fault is therefore made
//! safe at the same simulated time as on the board. Every simulator command — `host-sim run`,
//! `paper`, `host-sim console` and the desk's end-to-end board — drives one `SimBoard`, and
//! `save`/`load` are carried out here ([`store::SimFlash`]) and nowhere else.
//!
//! With the camera off the controller gets the true region temperatures once per scene period
//! ([`camera::truth_measurement`]); an open-loop scene has no controller, and its timed duties
//! are set with [`SimBoard::set_inputs`].
//!
//! This module owns the simulated board's error type, [`RigError`] (a plant, sensor or
//! pipeline that cannot be built, a settings file that cannot be read or written).

pub mod camera;
pub mod channels;
pub mod faults;
pub mod store;

use std::path::PathBuf;

use thermorph::mtts::MttsError;

use crate::plant::PlantError;
use crate::sensor::SensorError;

/// Why the simulated board could not be built, or its settings file not be used.
#[derive(Debug, thiserror::Error)]
pub enum RigError {
    /// The plant's configuration is refused.
    #[error(transparent)]
    Plant(#[from] PlantError),
    /// The camera's virtual sensor or its driver failed.
    #[error(transparent)]
    Sensor(#[from] SensorError),
    /// The firmware's sensing pipeline refuses its configuration.
    #[error("{0}")]
    Pipeline(MttsError),
    /// The settings file (or its folder) cannot be read or written.
    #[error("{}: {err}", path.display())]
    SettingsFile {
        /// The file or folder.
        path: PathBuf,
        /// Why.
        err: std::io::Error,
    },
}

use thermorph::app::{CONTROL_PERIOD_MS, Controller, Line};
use thermorph::measurement::{Measurement, SensingHint};
use thermorph::mtts::{Quality, REGIONS};
use thermorph::outputs::Outputs;
use thermorph::settings::Settings;
use thermorph::supervisor::events::EventKind;
use thermorph::supervisor::report::Reply;
use thermorph::supervisor::{SpringMemory, Supervisor};
use thermorph::units::Millis;

use crate::plant::{Inputs, ModelOptions, Observation, Plant, PlantConfig};

/// What a simulated board is built from: the block's plant, its camera, the faults to inject
/// and the sample period of camera-off measurements.
#[derive(Clone, Debug, PartialEq)]
pub struct BlockSpec {
    /// The plant.
    pub plant: PlantConfig,
    /// The plant's model options (its [`PlantScale`](crate::plant::PlantScale) among them).
    pub options: ModelOptions,
    /// The camera (off: true temperatures every `sample_period_s`).
    pub camera: CameraSettings,
    /// Injected faults.
    pub faults: Vec<FaultSpec>,
    /// The period of the camera-off measurements, s.
    pub sample_period_s: f64,
}
use camera::{Camera, CameraFaults, open_loop_hint, truth_measurement};
use faults::{CameraSettings, FaultSpec, Injection};
use store::SimFlash;

/// The board's control tick, ms.
pub const TICK_MS: u64 = CONTROL_PERIOD_MS;
const TICK_US: u64 = TICK_MS * 1000;

/// What the board wrote on its console besides a reply.
#[derive(Clone, Debug, PartialEq)]
pub enum Said {
    /// A `# {notice}` line: a warning (`# warning: …`) or an announcement (`# autotune done:
    /// …`).
    Notice(thermorph::supervisor::Notice),
    /// A telemetry line (with its `#` and CR LF).
    Telemetry(String),
}

/// A fault the controller latched.
#[derive(Clone, Debug, serde::Serialize, PartialEq)]
pub struct FaultRecord {
    /// When, s of simulated time.
    pub at_s: f64,
    /// Its code.
    pub code: String,
    /// Its reason.
    pub reason: String,
}

/// The plant's inputs for a decision's outputs.
pub fn inputs_of(o: &Outputs) -> Inputs {
    Inputs {
        heater_duty: o.heater.fraction() as f64,
        fan_duty: o.fan.fraction() as f64,
        springs_on: core::array::from_fn(|i| o.springs.contains(i)),
        spring_power_off: !o.spring_power,
        ..Inputs::default()
    }
}

/// Apply the faults of `faults` active at `t_s` to `inputs`; return their bit mask (bit i =
/// fault i) and what they do to the camera chain.
pub fn apply_faults(faults: &[FaultSpec], t_s: f64, inputs: &mut Inputs) -> (u32, CameraFaults) {
    let mut mask = 0u32;
    let mut camera = CameraFaults::default();
    for (i, f) in faults.iter().enumerate().filter(|(_, f)| f.active(t_s)) {
        mask |= 1 << i.min(31);
        match f.kind {
            Injection::HeaterOpen => inputs.heater_open = true,
            Injection::StuckSpring { spring, on } => {
                inputs.springs_on[spring] = on;
                inputs.channel_faults[spring].mosfet_stuck = Some(on);
            }
            Injection::OpenWire { spring } => inputs.channel_faults[spring].open_wire = true,
            Injection::WireShort { spring } => inputs.channel_faults[spring].wire_short = true,
            Injection::Sensor(s) => camera.sensor = Some(s),
            Injection::Camera(v) => camera.view = Some(v),
        }
    }
    (mask, camera)
}

/// The simulated board and the block it drives.
pub struct SimBoard {
    plant: Plant,
    camera: Option<Camera>,
    faults: Vec<FaultSpec>,
    control: Option<Controller>,
    flash: SimFlash,
    /// Simulated time, µs.
    time_us: u64,
    /// The plant has been run to this time, µs, and runs on with `held` from there.
    plant_us: u64,
    /// The plant's inputs since `plant_us` (the commanded actuators with the active faults).
    held: Inputs,
    /// When the board last booted, µs (its clock counts from there).
    boot_us: u64,
    /// A frame the camera chain published ahead of the board's time, with its time, µs.
    pending: Option<(u64, Measurement)>,
    /// The faults the view shown to the sensor was drawn with, while that view is the plant's
    /// present state (`None`: the plant has run since, or nothing was shown yet).
    shown: Option<CameraFaults>,
    /// Camera off: the period of the true measurements, µs, and the next one's time.
    truth_period_us: u64,
    /// The camera's mount ([`CameraSettings::azimuth_deg`]), degrees: also the camera-off
    /// measurement's view.
    azimuth_deg: f64,
    next_truth_us: u64,
    truth_frames: u32,
    /// The actuators as the last decision (or the open-loop scene) set them, before faults.
    commanded: Inputs,
    latched: Vec<FaultRecord>,
    seen_events: u32,
    /// The spring channels' sensing front end.
    sensing: channels::Sensing,
    /// The e-stop button reads pressed (its level: every period reports it, as the board's
    /// control loop reads PC13).
    button_pressed: bool,
    /// The button went down since the last period (the board's `ESTOP_TAPPED`): that period
    /// reports it pressed even if it was released meanwhile.
    button_tapped: bool,
}

impl SimBoard {
    /// The block of `block` at time 0 with its camera (if on) and injected faults. A
    /// closed-loop board gets a controller that starts with `settings` and keeps its record
    /// in `flash`; an open-loop one gets none ([`SimBoard::set_inputs`] drives it).
    /// The simulated springs start at ambient, and the board knows it: its supervisor starts
    /// with [`SpringMemory::RESTED`], as a board would whose RAM kept the springs' memory
    /// across a reset long after they were last driven (a real power-up assumes them hot).
    pub fn new(
        block: &BlockSpec,
        closed_loop: bool,
        settings: Settings,
        flash: SimFlash,
    ) -> Result<Self, RigError> {
        let plant = Plant::with_options(&block.plant, block.options)?;
        let camera = if block.camera.enabled {
            Some(Camera::new(
                block.camera.seed,
                block.camera.noise_k,
                block.camera.azimuth_deg,
            )?)
        } else {
            None
        };
        let truth_period_us = ((block.sample_period_s * 1e6).round() as u64).max(1);
        let seed = block.camera.seed;
        let mut sensing = channels::Sensing::new(channels::SenseErrors::drawn(seed), seed);
        let mut control = closed_loop.then(|| {
            Controller::new(Supervisor::with_memory(
                Millis(0),
                settings,
                SpringMemory::RESTED,
            ))
        });
        if let Some(c) = &mut control {
            boot_calibration(c, &mut sensing, &plant);
        }
        Ok(SimBoard {
            plant,
            camera,
            faults: block.faults.clone(),
            control,
            flash,
            time_us: 0,
            plant_us: 0,
            held: Inputs::default(),
            boot_us: 0,
            pending: None,
            shown: None,
            truth_period_us,
            azimuth_deg: block.camera.azimuth_deg,
            next_truth_us: truth_period_us,
            truth_frames: 0,
            commanded: Inputs::default(),
            latched: Vec::new(),
            seen_events: 0,
            sensing,
            button_pressed: false,
            button_tapped: false,
        })
    }

    /// Simulated time, s.
    pub fn time_s(&self) -> f64 {
        self.time_us as f64 * 1e-6
    }

    /// Simulated time, µs.
    pub fn time_us(&self) -> u64 {
        self.time_us
    }

    /// When the board's next tick falls, µs of simulated time (every [`TICK_MS`] of its clock).
    pub fn next_tick_us(&self) -> u64 {
        let since_boot = self.time_us - self.boot_us;
        self.boot_us + (since_boot / TICK_US + 1) * TICK_US
    }

    /// The board's clock now (from its last boot).
    pub fn now(&self) -> Millis {
        Millis((self.time_us - self.boot_us) / 1000)
    }

    /// The supervisor (closed loop only).
    pub fn supervisor(&self) -> Option<&Supervisor> {
        self.control.as_ref().map(Controller::supervisor)
    }

    /// The plant as it is now, at the board's time (the plant's own clock sums its steps and
    /// may differ from it by round-off).
    pub fn observe(&mut self) -> Observation {
        self.sync();
        Observation {
            time_s: self.time_s(),
            ..self.plant.observe()
        }
    }

    /// The camera chain (camera on only).
    pub fn camera(&self) -> Option<&Camera> {
        self.camera.as_ref()
    }

    /// Every fault the controller latched so far.
    pub fn latched(&self) -> &[FaultRecord] {
        &self.latched
    }

    /// Set the actuators of an open-loop scene (a closed-loop board's next decision overrides
    /// them).
    pub fn set_inputs(&mut self, inputs: Inputs) {
        self.commanded = inputs;
        self.hold_inputs();
    }

    /// The actuators as commanded (before injected faults).
    pub fn commanded(&self) -> Inputs {
        self.commanded
    }

    /// The plant's inputs from now: the commanded actuators with the faults active now, and
    /// those faults' bit mask.
    pub fn inputs(&self) -> (Inputs, u32, CameraFaults) {
        let mut inputs = self.commanded;
        let (mask, camera) = apply_faults(&self.faults, self.time_s(), &mut inputs);
        (inputs, mask, camera)
    }

    /// The region temperatures the controller was last given, K: the latest frame's (camera
    /// on), the truth (camera off), `None` while the sensor has no good frame.
    pub fn measured_k(&mut self) -> Option<[f64; REGIONS]> {
        match &self.camera {
            Some(c) => c.last_regions_k(),
            None if self.inputs().2.sensor.is_some() => None,
            None => Some(camera::camera_temps(&self.observe()).regions()),
        }
    }

    /// The quality of the frame behind [`SimBoard::measured_k`]: the latest frame's (camera
    /// on), `Resolved` for the truth (camera off), `None` while the sensor has no good frame.
    pub fn measured_quality(&mut self) -> Option<Quality> {
        match &self.camera {
            Some(c) => c.last_quality(),
            None if self.inputs().2.sensor.is_some() => None,
            None => Some(Quality::Resolved),
        }
    }

    /// A board reset by its reset pin (its RAM kept): a new controller with the springs'
    /// memory and the settings `settings`, `stopped` with a `# warning` saying why, the clock
    /// from 0; the block keeps its heat.
    pub fn reset(&mut self, settings: Settings) {
        if let Some(c) = &mut self.control {
            let memory = c.supervisor().spring_memory();
            *c = Controller::new(Supervisor::boot(
                Millis(0),
                settings,
                Some(memory),
                thermorph::supervisor::ResetCause::Pin,
            ));
            boot_calibration(c, &mut self.sensing, &self.plant);
            self.boot_us = self.time_us - self.time_us % 1000;
            self.commanded = Inputs::default();
            self.hold_inputs();
        }
    }

    /// Start the controller as the board does after a reset of `cause` at time 0 (its settings
    /// kept; the springs rested, as the simulated ones are): after a power-up `stopped` unless
    /// `boot_mode` asks for standby, after any other reset `stopped` with a warning. Scenes
    /// and `paper` skip this: they start as a power-up followed by `mode standby`.
    pub fn boot(&mut self, cause: thermorph::supervisor::ResetCause) {
        let now = self.now();
        if let Some(c) = &mut self.control {
            let settings = *c.supervisor().settings();
            *c = Controller::new(Supervisor::boot(
                now,
                settings,
                Some(SpringMemory::RESTED),
                cause,
            ));
            boot_calibration(c, &mut self.sensing, &self.plant);
        }
    }

    /// The e-stop button pressed (`true`) or released at the board's present time, as the
    /// board sees it: a press is a falling edge on PC13, which its e-stop task turns into a
    /// control period at once with the button reported pressed (the supervisor latches
    /// `estop`, every output off in that period); after it, every period reports the button's
    /// level, so `reset` is refused until a release. A press of a pressed button, or a release
    /// of a released one, is no edge and changes nothing. Warnings and telemetry of the
    /// period go to `said`. An open-loop board has no controller to read it: nothing happens.
    pub fn set_button(&mut self, pressed: bool, said: &mut Vec<Said>) {
        let edge = pressed && !self.button_pressed;
        self.button_pressed = pressed;
        if edge && self.control.is_some() {
            self.button_tapped = true;
            self.period(None, None, false, said);
            self.hold_inputs();
        }
    }

    /// Whether the e-stop button reads pressed now.
    pub fn button_pressed(&self) -> bool {
        self.button_pressed
    }

    fn hint(&self) -> SensingHint {
        self.supervisor()
            .map_or_else(open_loop_hint, Supervisor::sensing_hint)
    }

    /// A console line at the board's present time: one control period with it, as the board
    /// runs one when a line arrives; returns the reply (a `save` or `load` carried out first),
    /// and puts the period's warnings and telemetry in `said`. `None` for an open-loop board.
    pub fn line(&mut self, line: Line<'_>, said: &mut Vec<Said>) -> Option<Reply> {
        self.control.as_ref()?;
        let reply = self.period(None, Some(line), false, said);
        self.hold_inputs();
        // Every line gets a reply (a `store`'s comes from the flash).
        Some(reply.unwrap_or_else(|| Reply::err("internal", "no reply")))
    }

    /// One control period at the board's present time, with the spring channels' readings
    /// (at a tick); returns the line's reply, if a line came and got one.
    fn period(
        &mut self,
        frame: Option<&Measurement>,
        line: Option<Line<'_>>,
        tick: bool,
        said: &mut Vec<Said>,
    ) -> Option<Reply> {
        let now = self.now();
        let t_s = self.time_s();
        let sense = if tick && self.control.is_some() {
            let o = self.observe();
            Some(self.sensing.sense(o.spring_current_a, o.spring_supply_v))
        } else {
            None
        };
        let c = self.control.as_mut()?;
        // The button as the board's loop reports it: its level, or a press since the last
        // period (a tap shorter than a period is not lost).
        let tapped = std::mem::take(&mut self.button_tapped);
        let button = self.button_pressed || tapped;
        let mut p = c.period(now, Some(button), sense.as_ref(), frame, line);
        if let Some(req) = p.store.take() {
            // The heater and the springs are off through the flash operation (instant here).
            p.reply = Some(self.flash.carry_out(&req, c, now));
        }
        if p.probe {
            // The spring power on with every gate off, read at once (the circuit has no
            // dynamics here), then the probe's reply.
            let mut inputs = Inputs {
                springs_on: [false; 3],
                ..inputs_of(&p.outputs)
            };
            apply_faults(&self.faults, t_s, &mut inputs);
            let flows = self.plant.channel_flows(&inputs);
            let sense = self
                .sensing
                .sense(flows.map(|f| f.current_a), flows.map(|f| f.supply_v));
            let (reply, outputs) = c.finish_probe(now, &sense);
            p.reply = Some(reply);
            p.outputs = outputs;
        }
        for n in p.notices.into_iter().flatten() {
            said.push(Said::Notice(n));
        }
        if p.telemetry {
            let mut t = String::new();
            // Writing into a String cannot fail.
            let _ = c.write_telemetry(now, &mut t);
            said.push(Said::Telemetry(t));
        }
        self.commanded = inputs_of(&p.outputs);
        let events = c.supervisor().events();
        for e in events.since(self.seen_events) {
            if let EventKind::Fault(f) = e.kind {
                self.latched.push(FaultRecord {
                    at_s: (self.boot_us + e.at.ms() * 1000) as f64 * 1e-6,
                    code: f.code().into(),
                    reason: f.reason().to_string(),
                });
            }
        }
        self.seen_events = events.total();
        p.reply
    }

    /// Run the plant to the board's time with the inputs held since it last ran.
    fn sync(&mut self) {
        if self.time_us > self.plant_us {
            self.plant
                .step(&self.held, (self.time_us - self.plant_us) as f64 * 1e-6);
            self.plant_us = self.time_us;
            self.shown = None;
        }
    }

    /// The plant's inputs from now on are the commanded actuators with the faults active now:
    /// where they change, the plant runs to now with the old ones first.
    fn hold_inputs(&mut self) {
        let (inputs, _, _) = self.inputs();
        if inputs != self.held {
            self.sync();
            self.held = inputs;
        }
    }

    /// Advance simulated time to `t_us`: the plant between the board's instants, the camera
    /// chain at its own rate, and a control period at each tick (every [`TICK_MS`] of the
    /// board's clock) and at each frame's time. Warnings and telemetry go to `said`.
    ///
    /// The plant runs to every tick and to every instant its inputs change (a decision, a
    /// scene's duty, an injected fault coming or going, seen at the board's instants); a frame
    /// that changes nothing does not split its step, so an open-loop block runs the same with
    /// the camera on or off. The sensor is shown the plant as of its last step.
    pub fn advance_to(&mut self, t_us: u64, said: &mut Vec<Said>) {
        self.hold_inputs();
        while self.time_us < t_us {
            let next_tick = self.next_tick_us();
            let mut target = next_tick.min(t_us);
            let faults = self.inputs().2;
            let hint = self.hint();
            if let Some(cam) = &mut self.camera {
                if self.pending.is_none() && cam.clock_us() < target {
                    cam.set_fault(faults);
                    if self.shown != Some(faults) && cam.measures_before(target) {
                        cam.show(&self.plant.observe(), faults);
                        self.shown = Some(faults);
                    }
                    self.pending = cam.run_until(target, hint);
                }
            } else {
                target = target.min(self.next_truth_us);
            }
            if let Some((at_us, _)) = self.pending {
                target = target.min(at_us.max(self.time_us));
            }
            self.time_us = self.time_us.max(target);
            if self.time_us == next_tick {
                self.sync();
            }
            let mut frame = None;
            if self.pending.is_some_and(|(at_us, _)| at_us <= self.time_us) {
                frame = self.pending.take().map(|(_, m)| m);
            }
            if self.camera.is_none() && self.time_us >= self.next_truth_us {
                self.next_truth_us += self.truth_period_us;
                if faults.sensor.is_none() {
                    self.truth_frames += 1;
                    let (now, seq) = (self.now(), self.truth_frames);
                    let m = truth_measurement(&self.observe(), self.azimuth_deg, now, seq);
                    frame = Some(m);
                }
            }
            if frame.is_some() || self.time_us == next_tick {
                let tick = self.time_us == next_tick;
                self.period(frame.as_ref(), None, tick, said);
            }
            self.hold_inputs();
        }
    }
}

/// The board's boot calibration of the spring channels: scans with every gate and the spring
/// power off (the supplies at their EMF), the amplifiers' offsets from them; a refused
/// calibration leaves the nominal one (the board warns; the simulated parts never exceed it).
fn boot_calibration(c: &mut Controller, sensing: &mut channels::Sensing, plant: &Plant) {
    let off = Inputs {
        spring_power_off: true,
        ..Inputs::default()
    };
    let idle = plant.channel_flows(&off).map(|f| f.supply_v);
    let cal = thermorph::channels::Calibration::from_scans(&sensing.idle_scans(32, idle))
        .unwrap_or(thermorph::channels::Calibration::NOMINAL);
    c.supervisor_mut()
        .set_channels(thermorph::channels::Channels::new(cal));
}
