//! The supervisor: modes, the heater/fan loop, the spring timing and the fault latch, as one
//! pure state machine.
//!
//! [`Supervisor::step`]`(now, measurement, command)` is the only place a decision about an
//! output is made. The board calls it on every measurement, every console line and every tick
//! of its control loop, and applies the returned [`Decision`] to its pins; host-sim does the same
//! with its plant. Nothing else drives an output.
//!
//! ```text
//!                     power-up
//!                        |
//!                        v          mode standby / end of any mode
//!   +------------> [ Standby ] <-----------------------------------+
//!   |             hold standby_k (the idle state: no timeout)       |
//!   |    mode step-small|step-large [SPRINGS]                       |
//!   |                    v                                          |
//!   |            [ Stepping: Soak ]  heat until the observer's wall |
//!   |                    |           is soft (soft_frozen_max_pct)  |
//!   |                    |           (and every spring it drives    |
//!   |                    |           has a cleared on-time); warns  |
//!   |                    |           at soft_warn_s; soak_timeout_s>+
//!   |                    v                                          |
//!   |            [ Stepping: Rest ]  (only if a spring is still     |
//!   |                    |           austenite by the estimate)     |
//!   |                    |           hold hot_k until martensite    |
//!   |                    v                                          |
//!   |            [ Stepping: Prewarm ] springs to spring_prewarm_k  |
//!   |                    |   in pulses ≤ prewarm_s, off prewarm_gap_s|
//!   |                    v                                          |
//!   |   +--> [ Stepping: Spring i ] springs on for step_s           |
//!   |   |                |  (pause: springs off, timer held, until  |
//!   |   |                v   resume or hold_timeout_s ------------->+
//!   |   +--- [ Stepping: Pulse i ]  springs off for pulse_s         |
//!   |                    | after the last spring phase              |
//!   |                    v                                          |
//!   |            [ Stepping: Hold ]  hold hot_k; hold_timeout_s --->+
//!   |                                                               |
//!   |  mode form --> [ Forming ] heater off, fan form_fan, until the |
//!   |                hotter target ≤ form_end_k; form_timeout_s --->+
//!   |  mode recover -> [ Recovery: Heat ] to hot_k (as Soak), springs |
//!   |                   driven to their band (throughout); once the |
//!   |                   wall is soft and they are austenite (as     |
//!   |                   Soak, warns); soak_timeout_s --------------->+
//!   |                   -> [ Pulse ] all springs, recover_pulse_s,  |
//!   |                        inside an on window                    |
//!   |                   -> [ Hold ] recover_hold_s at hot_k          |
//!   |                   -> [ Cool ] as forming, until form_end_k;   |
//!   |                        form_timeout_s ----------------------->+
//!   |  autotune -> [ Autotune ] relay around tune_k; done, aborted  |
//!   |               (overshoot, not-following, tune_timeout_s) ---->+
//!   |                                                               |
//!   +-- mode ------- [ Stopped ] <-- stop: everything off until a `mode` command
//!                         ^
//!                         | reset (cause gone; never with the e-stop button pressed)
//!                    [ Faulted ] <-- any fault, from any mode: heater and springs
//!                                    off, fan on where cooling helps (off after
//!                                    `stop`); latched; an e-stop overrides any
//!                                    other fault
//! ```
//!
//! The loop: one PID on Tc with a split-range output, heater for u > 0 and fan for u < 0 with a
//! dead band between ([`SplitRange`]), so the two never run against
//! each other; forming runs the fan open loop with the heater off (a mode rule). The PID is fed
//! only by new measurements, with Δt from their timestamps; a change of mode, target or gains
//! is bumpless (the next output continues from the last), and outside ±`functional_band_k` the
//! loop drives bang-bang with its integrator reset (Marlin's functional range), so a 35 K
//! target step heats at full power instead of waiting for the integrator.
//!
//! Tc is [`crate::measurement::controlled_temperature`] of the mode's
//! [`SensingHint`]: the heating modes control the colder of T1/T2, forming the hotter one. The
//! supervisor is the one place Tc is computed — once per new valid measurement, with the hint
//! of the mode at that step; a [`Measurement`] carries no Tc.
//!
//! The springs and the wall's inside: nothing senses them, so the supervisor keeps an
//! [`Observer`] (the wall through its thickness, each spring's temperature and phase, the
//! ambient), predicted every step from the outputs that ran and corrected by every new frame.
//! Every spring phase drives a spring by its estimate (`spring_hot_k`, `spring_band_k`);
//! a spring estimated past `spring_max_k` latches `spring-over-temperature` (the estimate of a
//! driven spring is raised to the temperature its resistance shows); the heater is cut
//! as the estimated inner layer nears `t_max_k` ([`INNER_MARGIN_K`]). Recovery uses the
//! estimate to bring all three springs to austenite together — three equal pulls hold the
//! softened column straight while it cools and locks,
//! where a spring still austenite from the stepping would otherwise hold the bend for minutes —
//! and a new stepping waits (phase `rest`) until every spring is martensite again.
//!
//! Files: this one steps the whole (measurement, command, faults, the loop, outputs);
//! [`mode`] holds the one table of mode names ([`ModeId`]), [`Mode`] and what a mode's step
//! decides; each mode is one file with its state and its `advance` (`standby`,
//! [`stepping`], [`forming`], [`recovery`], [`autotune`]); [`safety`] the fault checks,
//! [`memory`] the springs' memory across resets, [`store`] `save`/`load`, [`report`] the
//! replies and telemetry, [`events`] the log. Every `match` on modes is exhaustive, so a new
//! mode is one file, one [`ModeId`] row and one [`Mode`] variant, and the compiler lists the
//! rest.

pub mod autotune;
pub mod boot;
mod channels;
pub mod events;
pub mod forming;
pub mod memory;
pub mod mode;
pub mod pose;
pub mod recovery;
pub mod report;
pub mod safety;
mod standby;
pub mod stepping;
pub mod store;

use crate::channels::{Channels, SpringSense};
use crate::command::Command;
use crate::control::{Pid, PidConfig, SplitRange};
use crate::measurement::{Measurement, Quality, SensingHint, controlled_temperature};
use crate::observer::{Estimate, Observer, SpringState};
use crate::outputs::{Duty, Outputs, SpringMask};
use crate::posture::{Bend, Posture};
use crate::settings::{PARAMS, SetError, Settings};
use crate::units::{Kelvin, Millis, Seconds};
use events::{EventKind, EventLog};
use report::Reply;
use safety::{Fault, FaultKind, LoopState, Safety};

pub use autotune::Tuning;
pub use boot::ResetCause;
pub use events::{Notice, ShortBy, Warning};
pub use forming::Forming;
pub use memory::{SpringMemory, SpringRecord};
pub use mode::{Mode, ModeId, PauseError};
pub use pose::{PosePhase, Posing};
pub use recovery::{RecoverPhase, Recovering};
pub use stepping::{StepKind, StepPhase, Stepping};

use mode::{Ctx, Drive, Next};

/// Region temperatures the block can really show, for a measurement to count as valid, K (a
/// finite frame above it is an over-temperature at once). Not [`crate::mtts::PLAUSIBLE_K`],
/// the wider range of values a working sensor's pixel can report (outside it: a broken pixel).
pub const VALID_K: (f32, f32) = (200.0, 500.0);

/// Within this of its ceiling (`heater_cap_k − heater_cap_band_k`, where the cascade holds the
/// film at most) a film counts as held at the ceiling: the no-response check rests, K.
pub const CEILING_MARGIN_K: f32 = 1.0;

/// The warning when the loop falls back to the film region.
pub const WARN_UNRESOLVED: Warning = Warning::Unresolved;
/// The warning when frames resolve again after a fallback.
pub const WARN_RESOLVED: Warning = Warning::Resolved;

/// Least time between two warnings about the lattice's exposed fraction, s: a view that
/// flickers between readings must not flood the console. A warning held back is said once
/// the time is up, with the frames' latest finding.
pub const EXPOSURE_WARN_INTERVAL_S: f32 = 60.0;

/// The heater is cut in proportion as the estimated inner wall layer comes within
/// `heater_cap_band_k` of `t_max_k` − this, K: the estimate's error allowance (its mean error
/// over the cycle is ≈ 0.1 K, docs/observer.md).
pub const INNER_MARGIN_K: f32 = 1.0;

/// Telemetry: on, and when the next line is due.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Stream {
    period_ms: u32,
    next_at: Millis,
}

/// Fastest telemetry rate, Hz: a line with the observer's fields is ≈ 560 bytes, so 10 Hz
/// takes half of the console's 115 200 baud.
pub const STREAM_MAX_HZ: f32 = 10.0;
/// Telemetry rate when `stream on` names none, Hz.
pub const STREAM_DEFAULT_HZ: f32 = 4.0;

/// What one step decided.
#[derive(Clone, Debug, PartialEq)]
pub struct Decision {
    /// The outputs to apply now.
    pub outputs: Outputs,
    /// What the sensing pipeline should assume and weigh for the next frames.
    pub sensing: SensingHint,
    /// The reply to the command of this step (exactly one per command).
    pub reply: Option<Reply>,
    /// A telemetry line is due: the board writes [`Supervisor::write_telemetry`].
    pub telemetry: bool,
    /// The step used a measurement at most `sensor_timeout_s` old, or a fault (sensor loss, or
    /// one latched before it) holds the outputs safe: the control loop is alive, so the board
    /// may feed its watchdog. A loop that stops stepping feeds nothing.
    pub alive: bool,
    /// A `save` or `load` to carry out: then `reply` is `None`, `outputs` have the heater and
    /// the springs off (the fan as the mode wants) and the caller applies them *before* the
    /// flash operation, holds them through it, and gives the outcome to
    /// [`Supervisor::finish_store`] for the command's reply ([`store`]).
    pub store: Option<store::StoreRequest>,
    /// A line to print on the console as `# {notice}` after the reply: a warning (also in the
    /// `log`) or an announcement (`# autotune done: …`).
    pub notice: Option<Notice>,
    /// `reset` asks for the spring channels to be probed: then `reply` is `None`, `outputs`
    /// have the spring power on with every gate and the heater off; the caller applies them,
    /// reads one [`SpringSense`] once the channels have settled, and gives it to
    /// [`Supervisor::finish_probe`] for the command's reply.
    pub probe: bool,
}

/// The supervisor.
#[derive(Clone, Debug)]
pub struct Supervisor {
    settings: Settings,
    mode: Mode,
    mode_since: Millis,
    pid: Pid,
    outer: Pid,
    split: SplitRange,
    target_k: f32,
    outputs: Outputs,
    fault: Option<Fault>,
    safety: Safety,
    events: EventLog,
    last: Option<Measurement>,
    tc_k: f32,
    last_step: Millis,
    started: Millis,
    springs: SpringMask,
    /// The estimate of what the camera cannot see: the wall through its thickness, the
    /// springs, the ambient.
    observer: Observer,
    /// The column's bend: the camera's axis tilt fused with the model of the springs.
    posture: Posture,
    stream: Option<Stream>,
    button_pressed: bool,
    store: Option<store::StoreRequest>,
    /// The sensor-loss window counts from here if it is later than the last measurement: the
    /// end of a flash operation, which stalls the sensor with the core.
    sensor_grace: Millis,
    /// Since when the frames have not separated T1 and T2 for sure (ambiguous, merged or
    /// fallback), if they have not.
    unresolved_since: Option<Millis>,
    /// The loop holds the film region (too long unresolved while heating on the colder one).
    film_fallback: bool,
    /// When the last warning about the lattice's exposed fraction was said.
    exposure_warned_at: Option<Millis>,
    /// One held back by [`EXPOSURE_WARN_INTERVAL_S`].
    exposure_pending: Option<Warning>,
    /// `stop` was asked with a fault latched: the fan is off too, until `reset`.
    quiet: bool,
    /// A warning for this step's decision.
    notice: Option<Notice>,
    /// The last decision's heater duty was cut by a cap (the film's or the estimated inner
    /// layer's), below what the loop or the relay asked.
    heater_capped: bool,
    /// The spring channels as measured, and their checks' state.
    channels: Channels,
    /// The spring channels' readings of this period, for the next step.
    sense: Option<SpringSense>,
    /// `reset` asked for a probe of the spring channels: the next decision carries it.
    probe: bool,
    /// The last decision asked for a probe ([`Decision::probe`]) and it is not finished.
    probe_pending: bool,
    /// A notice for the next decision (the boot's warning).
    carried: Option<Notice>,
    /// When a sagging supply was last reported.
    sag_warned: Option<Millis>,
}

/// The observer for `settings`, with the springs of `memory` (or at the first measured
/// ambient, rested, where the memory says so).
fn observer_with(settings: &Settings, memory: &SpringMemory) -> Observer {
    let params = settings.observer_params();
    let mut o = Observer::new(&params, f32::NAN);
    match memory.springs {
        Some(records) => o.set_springs(&records.map(|r| {
            SpringState::from_parts(r.temp_k, r.austenite, crate::settings::SPRING_HOT_K)
        })),
        None => o.rest_springs_at_ambient(),
    }
    o
}

fn pid_config(s: &Settings) -> PidConfig {
    PidConfig {
        derivative_tau_s: s.d_filter_s,
        functional_band_k: s.functional_band_k,
        ..PidConfig::split_range(s.gains)
    }
}

/// The cascade's outer loop: Tc's error → how far above the target the film runs, K.
fn outer_config(s: &Settings, target_k: f32) -> PidConfig {
    PidConfig {
        gains: s.outer_gains,
        output_min: 0.0,
        output_max: (s.heater_cap_k - s.heater_cap_band_k - target_k).max(0.0),
        derivative_tau_s: 0.0,
        max_dt_s: 1.0,
        functional_band_k: f32::INFINITY,
    }
}

impl Supervisor {
    /// Start in standby at `now` after a power-up with `settings` (checked; invalid ones give
    /// the defaults): nothing is known of the springs, so they are assumed hot
    /// ([`SpringMemory::POWER_UP`]) and a first stepping rests them.
    pub fn new(now: Millis, settings: Settings) -> Self {
        Self::with_memory(now, settings, SpringMemory::POWER_UP)
    }

    /// Start as [`Supervisor::new`] with the springs' memory kept across a reset (or, on a test
    /// bench or in a simulator whose springs start at ambient, [`SpringMemory::RESTED`]).
    pub fn with_memory(now: Millis, settings: Settings, springs: SpringMemory) -> Self {
        let settings = if settings.check().is_ok() {
            settings
        } else {
            Settings::DEFAULT
        };
        Supervisor {
            pid: Pid::new(pid_config(&settings), settings.standby_k),
            outer: Pid::new(
                outer_config(&settings, settings.standby_k),
                settings.standby_k,
            ),
            split: SplitRange::new(settings.fan_deadband),
            target_k: settings.standby_k,
            settings,
            mode: Mode::Standby,
            mode_since: now,
            outputs: Outputs::OFF,
            fault: None,
            safety: Safety::with_springs(springs.duty, springs.on_time),
            events: EventLog::new(),
            last: None,
            tc_k: f32::NAN,
            last_step: now,
            started: now,
            springs: SpringMask::from_bits(1),
            observer: observer_with(&settings, &springs),
            posture: Posture::new(),
            stream: None,
            button_pressed: false,
            store: None,
            sensor_grace: now,
            unresolved_since: None,
            film_fallback: false,
            exposure_warned_at: None,
            exposure_pending: None,
            quiet: false,
            notice: None,
            heater_capped: false,
            channels: Channels::default(),
            sense: None,
            probe: false,
            probe_pending: false,
            carried: None,
            sag_warned: None,
        }
    }

    /// Return the springs' memory (heat estimate, duty history, on-time counts) for the board
    /// to keep across a reset.
    pub fn spring_memory(&self) -> SpringMemory {
        let (duty, on_time) = self.safety.springs();
        SpringMemory {
            springs: Some(self.observer.springs().map(|s| SpringRecord::of(&s))),
            duty,
            on_time,
        }
    }

    /// Return the heater loop's and the cascade's outer loop's configurations (as the settings
    /// last rebuilt them).
    pub fn loop_configs(&self) -> (&PidConfig, &PidConfig) {
        (self.pid.config(), self.outer.config())
    }

    /// Return the fault checks' state (spring on-time counts and duties).
    pub fn safety(&self) -> &Safety {
        &self.safety
    }

    /// Return whether the loop holds the film region because the frames have been unresolved
    /// for `unresolved_s` while heating.
    pub fn film_fallback(&self) -> bool {
        self.film_fallback
    }

    /// The emergency-stop button's level, read by the board every control period: pressed
    /// latches the e-stop (over any other fault), and `reset` is refused while it reads
    /// pressed.
    pub fn button(&mut self, now: Millis, pressed: bool) {
        self.button_pressed = pressed;
        if pressed {
            self.latch(now, Fault::EStop);
        }
    }

    /// Return the mode.
    pub fn mode(&self) -> &Mode {
        &self.mode
    }

    /// Return the latched fault.
    pub fn fault(&self) -> Option<Fault> {
        self.fault
    }

    /// Return the settings.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// Return the event log.
    pub fn events(&self) -> &EventLog {
        &self.events
    }

    /// Return the loop's target, K (NaN when no loop runs).
    pub fn target_k(&self) -> f32 {
        if let Mode::Autotune(t) = &self.mode {
            t.target_k()
        } else if self.loop_active() {
            self.target_k
        } else {
            f32::NAN
        }
    }

    /// Return Tc of the last valid measurement, K (NaN before the first).
    pub fn tc_k(&self) -> f32 {
        self.tc_k
    }

    /// Return the last valid measurement.
    pub fn last_measurement(&self) -> Option<&Measurement> {
        self.last.as_ref()
    }

    /// Return the outputs of the last decision.
    pub fn outputs(&self) -> Outputs {
        self.outputs
    }

    /// Return the observer's estimate (the wall, the springs, the ambient), up to this
    /// step's start and its measurement.
    pub fn estimate(&self) -> Estimate {
        self.observer.estimate()
    }

    /// Return the observer.
    pub fn observer(&self) -> &Observer {
        &self.observer
    }

    /// Return the column's bend as estimated (camera and model, up to this step).
    pub fn bend(&self) -> Bend {
        self.posture.bend()
    }

    /// Return the posture estimate.
    pub fn posture(&self) -> &Posture {
        &self.posture
    }

    /// Return the sensing hint of the mode.
    pub fn sensing_hint(&self) -> SensingHint {
        self.mode.sensing(&self.settings, self.film_fallback)
    }

    /// One step: take the measurement (if a new one came) and the command (if a line came),
    /// check every fault, run the mode, and decide the outputs.
    pub fn step(
        &mut self,
        now: Millis,
        measurement: Option<&Measurement>,
        command: Option<Command>,
    ) -> Decision {
        let now = now.max(self.last_step);
        let elapsed_ms = now.0.saturating_sub(self.last_step.0).min(u32::MAX as u64) as u32;
        self.last_step = now;
        self.notice = self.carried.take();
        // A probe the caller did not carry out before this step is void.
        self.probe_pending = false;
        // The interval since the last step ran with the last decision's outputs: the
        // observer predicts over it, and the springs that were on are credited (on-time, duty).
        let ran = self.outputs;
        // The spring channels, read while `ran` was applied: their checks, then each driven
        // spring's measured power for the observer (before it predicts over the same interval).
        if let Some(sense) = self.sense.take() {
            self.check_channels(now, &sense, ran);
            let st = self.channels.state();
            let readings = core::array::from_fn(|i| crate::observer::SpringReading {
                on: ran.spring_power && ran.springs.contains(i),
                power_w: st[i].power_w,
                wire_ohm: st[i].wire_ohm,
            });
            self.observer.measure_springs(&readings);
        }
        // A spring heats only with the spring power on (its gate alone does nothing).
        let heated = if ran.spring_power {
            ran.springs
        } else {
            SpringMask::NONE
        };
        self.observer.predict(
            ran.heater.fraction(),
            ran.fan.fraction(),
            heated,
            Seconds::from_ms(elapsed_ms),
        );
        if let Some(f) = self
            .safety
            .credit_springs(ran.springs, elapsed_ms, &self.settings)
            .or_else(|| Safety::spring_temperature_fault(self.observer.springs(), &self.settings))
        {
            self.latch(now, f);
        }

        // 1. The measurement: only a valid, newer one is used. A newer, finite frame above the
        //    plausible range is still judged for over-temperature (a real 550 K is a fire, not
        //    a sensor fault).
        if let Some(m) = measurement.filter(|m| self.newer(m) && self.hot_or_plausible(m))
            && let Some(f) = Safety::over_temperature(m, &self.settings)
        {
            self.latch(now, f);
        }
        let fresh = measurement.filter(|m| self.valid(m)).copied();
        let mut dt = Seconds::ZERO;
        if let Some(m) = fresh {
            dt = self
                .last
                .map_or(Seconds::ZERO, |l| m.at.seconds_since(l.at));
            self.track_resolution(now, &m);
            self.track_exposure(now, &m);
            // The one place Tc is computed: under the hint of the mode as it stands now (after
            // a mode change or a film fallback it may differ from the hint the pipeline read
            // the frame with).
            self.tc_k =
                controlled_temperature(&m, &self.sensing_hint()).map_or(f32::NAN, Kelvin::k);
            self.correct_observer(&m);
            self.last = Some(m);
        }
        // The bend: the model follows the observer's springs and wall; a frame's tilt corrects.
        self.posture
            .predict(&self.observer.estimate(), Seconds::from_ms(elapsed_ms));
        if let Some(t) = fresh.and_then(|m| m.tilt) {
            self.posture.correct(t, self.settings.cam_azimuth_deg);
        }

        // 2. The command.
        let reply = command.map(|c| self.command(now, c));

        // 3. Faults that depend on the sensor.
        let since = self
            .last
            .map_or(self.started, |m| m.at)
            .max(self.sensor_grace);
        let age_s = now.seconds_since(since).s();
        if age_s > self.settings.sensor_timeout_s {
            self.latch(now, Fault::SensorLoss { for_s: age_s });
        }
        if let Some(m) = fresh {
            let heater = ran.heater.fraction();
            let film_k = m.hotter().map_or(f32::NAN, Kelvin::k);
            // A film held at its ceiling (the heater cap, or the cascade's film limit below it)
            // is visibly heated: the steady state of a long soak on a cold day. So is a heater
            // whose duty a cap cut (the film's, or the estimated inner layer's): it runs as hard
            // as the block allows, not as hard as the loop asks.
            let s = &self.settings;
            let at_ceiling = film_k >= s.heater_cap_k - s.heater_cap_band_k - CEILING_MARGIN_K;
            let demand = if at_ceiling || self.heater_capped {
                0.0
            } else {
                heater
            };
            if let Some(f) = self.safety.no_response(now, film_k, demand, &self.settings) {
                self.latch(now, f);
            }
            let l = LoopState {
                target_k: self.target_k(),
                tc_k: self.tc_k,
                film_k,
                heater_duty: heater,
                active: self.loop_active(),
            };
            if let Some(f) = self.safety.runaway(now, dt, l, &self.settings) {
                self.latch(now, f);
            }
        }

        // 4. The mode.
        let mut outputs = self.run_mode(now, elapsed_ms, fresh.as_ref(), dt);
        outputs.spring_power = self.mode.id().uses_springs();

        // 5. Spring limits on what would be applied: a spring past its limit is never on.
        if let Some(f) = self.safety.spring_fault(outputs.springs, &self.settings) {
            self.latch(now, f);
        }
        if self.fault.is_some() {
            outputs = self.safe_outputs();
        }
        // A flash operation follows this decision: heater and springs off through it. A probe
        // of the spring channels: their power on, every gate and the heater off.
        let probe = core::mem::take(&mut self.probe);
        self.probe_pending = probe;
        if self.store.is_some() || probe {
            outputs.heater = Duty::OFF;
            outputs.springs = SpringMask::NONE;
            outputs.spring_power = probe;
        }
        self.outputs = outputs;

        // 6. Telemetry.
        let mut telemetry = false;
        if let Some(s) = &mut self.stream
            && now >= s.next_at
        {
            telemetry = true;
            s.next_at = Millis(s.next_at.0 + s.period_ms as u64).max(now);
        }

        let store = self.store.take();
        Decision {
            outputs,
            sensing: self.sensing_hint(),
            reply: if store.is_some() || probe {
                None
            } else {
                reply
            },
            store,
            probe,
            telemetry,
            // A stale measurement always latches sensor loss in this same step unless another
            // fault already holds the outputs safe: either way the loop is alive.
            alive: age_s <= self.settings.sensor_timeout_s || self.fault.is_some(),
            notice: self.notice,
        }
    }

    /// Follow how long the frames have not separated T1 and T2; past `unresolved_s` while the
    /// loop heats on the colder region, fall back to the film region with a warning.
    fn track_resolution(&mut self, now: Millis, m: &Measurement) {
        if m.quality == Quality::Resolved {
            self.unresolved_since = None;
            if self.film_fallback {
                self.film_fallback = false;
                self.events.push(now, EventKind::Warning(WARN_RESOLVED));
                self.notice = Some(Notice::Warning(WARN_RESOLVED));
            }
            return;
        }
        let since = *self.unresolved_since.get_or_insert(m.at);
        let on_colder = self.loop_active() && self.sensing_hint().weights.w1 < 1.0;
        if on_colder
            && !self.film_fallback
            && m.at.seconds_since(since).s() >= self.settings.unresolved_s
        {
            self.film_fallback = true;
            self.events.push(now, EventKind::Warning(WARN_UNRESOLVED));
            self.notice = Some(Notice::Warning(WARN_UNRESOLVED));
        }
    }

    /// Warn when the frames adopt an exposed fraction unlike the configured design (a block
    /// printed or viewed unlike its design: MTTS fits with what the image shows), or come back
    /// to the design; at most one such warning per [`EXPOSURE_WARN_INTERVAL_S`].
    fn track_exposure(&mut self, now: Millis, m: &Measurement) {
        if let Some(e) = m.exposure.filter(|e| e.adopted) {
            self.exposure_pending = Some(if libm::fabsf(e.design_pct - e.configured_pct) >= 0.5 {
                Warning::ExposureUnlikeDesign {
                    shows_pct: e.design_pct,
                    design_pct: e.configured_pct,
                }
            } else {
                Warning::ExposureAsDesigned {
                    design_pct: e.configured_pct,
                }
            });
        }
        let due = self
            .exposure_warned_at
            .is_none_or(|t| now.seconds_since(t).s() >= EXPOSURE_WARN_INTERVAL_S);
        if due && let Some(w) = self.exposure_pending.take() {
            self.exposure_warned_at = Some(now);
            self.events.push(now, EventKind::Warning(w));
            self.notice = Some(Notice::Warning(w));
        }
    }

    fn newer(&self, m: &Measurement) -> bool {
        self.last.is_none_or(|l| m.at > l.at)
    }

    /// Finite and not implausibly cold (a frame above the plausible range is judged for
    /// over-temperature, not dropped).
    fn hot_or_plausible(&self, m: &Measurement) -> bool {
        [m.t1(), m.t2()]
            .iter()
            .all(|t| t.is_some_and(|t| t.k().is_finite() && t.k() >= VALID_K.0))
    }

    fn valid(&self, m: &Measurement) -> bool {
        let ok = |t: Option<Kelvin>| {
            t.is_some_and(|t| t.k().is_finite() && (VALID_K.0..=VALID_K.1).contains(&t.k()))
        };
        self.newer(m) && ok(m.t1()) && ok(m.t2())
    }

    fn loop_active(&self) -> bool {
        self.mode.cooling_since().is_none() && !matches!(self.mode, Mode::Stopped | Mode::Faulted)
    }

    fn safe_outputs(&self) -> Outputs {
        let fan = match self.fault {
            Some(f) if f.fan_helps() && !self.quiet => Duty::from_fraction(self.settings.form_fan),
            _ => Duty::OFF,
        };
        Outputs {
            heater: Duty::OFF,
            fan,
            springs: SpringMask::NONE,
            spring_power: false,
        }
    }

    /// Latch `f`. The first fault stays latched, except that an e-stop overrides any other
    /// (a press while another fault is latched is never lost: `reset` then needs the button
    /// released).
    fn latch(&mut self, now: Millis, f: Fault) {
        match self.fault {
            Some(Fault::EStop) => return,
            Some(_) if f != Fault::EStop => return,
            _ => {}
        }
        self.fault = Some(f);
        self.events.push(now, EventKind::Fault(f));
        self.enter(now, Mode::Faulted);
    }

    fn enter(&mut self, now: Millis, mode: Mode) {
        let from = self.mode.name();
        let to = mode.name();
        // Bumpless: the loop continues from the output it had (forming hands over its fan).
        let u = self.outputs.heater.fraction() - self.outputs.fan.fraction();
        self.mode = mode;
        self.mode_since = now;
        self.pid.reset_to(u);
        if from != to {
            self.events.push(now, EventKind::Mode { from, to });
        }
    }

    fn set_target(&mut self, target_k: f32) {
        if target_k != self.target_k {
            self.target_k = target_k;
            // Only a non-finite target is refused, and settings keep targets finite.
            let _ = self.pid.set_target(target_k);
            self.rebuild_outer();
        }
    }

    /// The outer loop's range depends on the target: rebuild it, continuing from its output.
    fn rebuild_outer(&mut self) {
        let o = self.outer.output();
        self.outer = Pid::new(outer_config(&self.settings, self.target_k), self.target_k);
        self.outer.reset_to(o);
    }

    /// Put checked settings in use and rebuild everything derived from them — the split range,
    /// the PID and the cascade's outer loop — each continuing from its last output (bumpless).
    /// The one place settings take effect: `set`, `load`, `defaults` and autotune's gains.
    fn configure(&mut self, s: Settings) {
        if s.check().is_err() {
            return;
        }
        self.settings = s;
        self.observer.set_params(&s.observer_params());
        self.split = SplitRange::new(s.fan_deadband);
        let u = self.pid.output();
        self.pid = Pid::new(pid_config(&s), self.target_k);
        self.pid.reset_to(u);
        self.rebuild_outer();
    }

    /// Run the mode; return the outputs it wants.
    fn run_mode(
        &mut self,
        now: Millis,
        elapsed_ms: u32,
        fresh: Option<&Measurement>,
        dt: Seconds,
    ) -> Outputs {
        let s = self.settings;
        self.heater_capped = false;
        let hotter = self.last.map(|m| m.hotter().map_or(f32::NAN, Kelvin::k));
        let estimate = self.observer.estimate();
        let mut c = Ctx {
            now,
            elapsed_ms,
            s,
            tc_k: self.tc_k,
            hotter_k: hotter,
            mode_since: self.mode_since,
            fresh,
            last_heater: self.outputs.heater,
            last_springs: self.outputs.springs,
            estimate: &estimate,
            bend: self.posture.bend(),
            observer: &self.observer,
            safety: &self.safety,
            events: &mut self.events,
            notice: &mut self.notice,
        };
        let Some(step) = self.mode.advance(&mut c) else {
            return self.safe_outputs();
        };
        if let Some(next) = step.next {
            let mode = match next {
                Next::Enter(m) => m,
                Next::GiveUp(what) => {
                    let tc_k = self.tc_k;
                    self.events.push(now, EventKind::TimedOut { what, tc_k });
                    Mode::Standby
                }
                Next::Tuned(tuned) => {
                    self.configure(tuned);
                    Mode::Standby
                }
            };
            self.enter(now, mode);
            return self.run_mode(now, 0, None, Seconds::ZERO);
        }
        // The heater cap, an override on the hotter region: whatever the loop or the relay
        // wants, the film is not driven past heater_cap_k. And the same on the observer's
        // inner wall layer, which the camera cannot see: it is not driven past t_max_k −
        // INNER_MARGIN_K.
        let cap = hotter
            .map_or(1.0, |h| (s.heater_cap_k - h) / s.heater_cap_band_k)
            .clamp(0.0, 1.0);
        let inner = estimate.layers_k[0];
        let inner_cap = if inner.is_finite() {
            ((s.t_max_k - INNER_MARGIN_K - inner) / s.heater_cap_band_k).clamp(0.0, 1.0)
        } else {
            1.0
        };
        let cap = cap.min(inner_cap);
        let capped = |d: Duty| Duty::from_fraction(d.fraction().min(cap));
        let target = match step.drive {
            Drive::Cool => {
                return Outputs {
                    heater: Duty::OFF,
                    fan: Duty::from_fraction(s.form_fan),
                    springs: step.springs,
                    spring_power: false,
                };
            }
            Drive::Relay(d) => {
                self.heater_capped = d.fraction() > cap;
                return Outputs {
                    heater: capped(d),
                    fan: Duty::OFF,
                    springs: step.springs,
                    spring_power: false,
                };
            }
            Drive::Hold(target_k) => target_k,
        };
        self.set_target(target);
        let cascade = self.sensing_hint().weights.w1 < 1.0;
        let u = match (fresh, hotter) {
            (Some(_), Some(h)) if cascade => {
                // Cascade: the slow outer loop turns Tc's error into how far above the target
                // the hotter region (the film) should run; the fast inner loop holds the film
                // there. The outer output is clamped so the film stays below heater_cap_k.
                let offset = self.outer.update(self.tc_k, dt);
                self.pid.update(h - offset, dt)
            }
            (Some(_), _) => self.pid.update(self.tc_k, dt),
            _ => self.pid.output(),
        };
        let hc = self.split.apply(u);
        self.heater_capped = hc.heater.fraction() > cap;
        Outputs {
            heater: capped(hc.heater),
            fan: hc.fan,
            springs: step.springs,
            spring_power: false,
        }
    }

    /// Carry out a command; return its reply.
    fn command(&mut self, now: Millis, c: Command) -> Reply {
        match c {
            Command::Help(topic) => Reply::help(topic),
            Command::Version => Reply::version(),
            Command::Status { short } => Reply::status(self, now, short),
            Command::Log => Reply::log(&self.events),
            Command::Get(None) => Reply::get_all(&self.settings),
            Command::Get(Some(i)) => Reply::get(&self.settings, i as usize),
            Command::Settings => Reply::settings(&self.settings),
            Command::Set(i, v) => {
                let Some(p) = PARAMS.get(i as usize) else {
                    return Reply::err("unknown-name", "no such parameter");
                };
                if self.fault.is_some() && p.relaxes((p.get)(&self.settings), v) {
                    return Reply::relaxed(p.name);
                }
                let mut next = self.settings;
                match next.set(p.name, v) {
                    Ok(()) => {
                        self.configure(next);
                        Reply::get(&self.settings, i as usize)
                    }
                    Err(SetError::OutOfRange { min, max }) => Reply::out_of_range(p, min, max),
                    Err(SetError::Conflict(why)) => Reply::err("conflict", why.message()),
                    Err(SetError::NotANumber) => Reply::err("bad-arguments", "not a number"),
                    Err(SetError::UnknownName) => Reply::err("unknown-name", "no such parameter"),
                }
            }
            Command::Stream(false, _) => {
                self.stream = None;
                Reply::ok("stream off")
            }
            Command::Stream(true, hz) => {
                let hz = hz.unwrap_or(STREAM_DEFAULT_HZ);
                if !(hz > 0.0 && hz <= STREAM_MAX_HZ) {
                    return Reply::err("out-of-range", "stream rate must be in (0, 10] Hz");
                }
                self.stream = Some(Stream {
                    period_ms: mode::ms(1.0 / hz).max(1),
                    next_at: now,
                });
                Reply::stream_on(hz)
            }
            Command::EStop => {
                self.latch(now, Fault::EStop);
                Reply::ok("emergency stop latched")
            }
            Command::Reset => self.reset(now),
            Command::Save => self.save(),
            Command::Load => self.load(),
            Command::Defaults => self.defaults(),
            // Accepted in every state: with a fault latched it turns the fan off too.
            Command::Stop if self.fault.is_some() => {
                self.quiet = true;
                Reply::ok("every output off; the fault stays latched (`reset` clears it)")
            }
            _ if self.fault.is_some() => Reply::fault_latched(self.fault),
            Command::Stop => {
                self.enter(now, Mode::Stopped);
                Reply::ok("stopped, every output off")
            }
            Command::Pause | Command::Resume => {
                let pause = c == Command::Pause;
                match self.mode.pause(pause) {
                    Ok(()) => Reply::ok(if pause { "paused" } else { "resumed" }),
                    Err(why) => Reply::err("bad-state", why.message()),
                }
            }
            Command::Autotune => {
                self.enter(now, Mode::Autotune(Tuning::start(&self.settings)));
                Reply::ok("autotune started")
            }
            Command::Pose {
                target_deg,
                springs,
                form,
            } => {
                let springs = springs.unwrap_or(self.springs);
                // What the springs reach against the soft wall at the power their channels
                // measured, less the tolerance: a target beyond is refused now, not found out
                // after a soak.
                let soft_reach_deg = pose::reach_at_power_deg(
                    springs,
                    &self.settings,
                    &self.observer.estimate(),
                    &self.observer.params().springs,
                    self.settings.soft_frozen_max,
                ) - self.settings.pose_tol_deg;
                // Formed, the column rests short of the bend it froze at once the springs have
                // cooled (the outer springs' pull on the glassy wall): it is bent past the
                // target by that spring-back, at most to the soft reach, and a target is taken
                // while that rest is within the tolerance of it.
                let (aim_deg, reach_deg, limit_deg) = if form {
                    let rest = Posture::rest_deg(springs, soft_reach_deg);
                    (
                        Posture::form_aim_deg(springs, target_deg).min(soft_reach_deg),
                        rest,
                        rest + self.settings.pose_tol_deg,
                    )
                } else {
                    (target_deg, soft_reach_deg, soft_reach_deg)
                };
                let reply = Reply::pose(target_deg, springs, reach_deg, limit_deg, form);
                if target_deg <= limit_deg && aim_deg.is_finite() {
                    self.springs = springs;
                    let posing = Posing::new(target_deg, aim_deg, springs, form);
                    self.enter(now, Mode::Posing(posing));
                }
                reply
            }
            Command::Mode(id, springs) => {
                if let Some(sp) = springs.filter(|_| id.takes_springs()) {
                    self.springs = sp;
                }
                let Some(mode) = Mode::start(id, now, &self.settings, self.springs) else {
                    return Reply::err("bad-state", "not a mode to ask for");
                };
                self.enter(now, mode);
                Reply::mode(&self.mode, self.springs)
            }
        }
    }

    /// `reset`: clear the latched fault once its cause is gone (never while the e-stop button
    /// reads pressed) and go to `stopped` — every output off until a `mode` command.
    fn reset(&mut self, now: Millis) -> Reply {
        let Some(f) = self.fault else {
            return Reply::ok("no fault latched");
        };
        if self.button_pressed {
            return Reply::cause_present(Fault::EStop);
        }
        let s = &self.settings;
        let fresh = self
            .last
            .is_some_and(|m| now.seconds_since(m.at).s() <= s.sensor_timeout_s);
        let gone = match f.kind() {
            FaultKind::SensorLoss => fresh,
            FaultKind::OverTemperature => {
                fresh
                    && self.last.is_some_and(|m| {
                        let mut cooler = m;
                        let warmer = |t: Kelvin| Kelvin::new(t.k() + 5.0);
                        for t in cooler.regions.iter_mut() {
                            *t = t.and_then(warmer);
                        }
                        cooler.hottest = cooler.hottest.and_then(warmer);
                        Safety::over_temperature(&cooler, s).is_none()
                    })
            }
            FaultKind::SpringOnTime(_)
            | FaultKind::SpringDuty(_)
            | FaultKind::SpringOverTemperature(_) => {
                let springs = self.observer.springs();
                (0..crate::outputs::SPRINGS).all(|i| {
                    self.safety.spring_duty(i) < 0.5 * s.spring_duty_max
                        && springs[i].temp_k < s.spring_hot_k - s.spring_band_k
                })
            }
            FaultKind::RunawayHeating | FaultKind::RunawayHolding | FaultKind::NoResponse => fresh,
            FaultKind::EStop => !self.button_pressed,
            // The probe decides whether a channel still conducts; an open spring is named again
            // the next time a mode drives it.
            FaultKind::SpringStuckOn(_)
            | FaultKind::SpringOpen(_)
            | FaultKind::SpringShort(_)
            | FaultKind::SpringSensing(_) => true,
        };
        if !gone {
            return Reply::cause_present(f);
        }
        // A board that senses its springs probes them first.
        if self.channels.present() {
            // The reply comes from the probe ([`Supervisor::finish_probe`]).
            self.probe = true;
            return Reply::ok("probing the spring channels");
        }
        self.clear_fault(now)
    }

    /// Clear the latched fault and go to `stopped`.
    fn clear_fault(&mut self, now: Millis) -> Reply {
        let Some(f) = self.fault else {
            return Reply::ok("no fault latched");
        };
        self.fault = None;
        self.quiet = false;
        self.events.push(now, EventKind::Cleared(f));
        self.outputs = Outputs::OFF;
        self.enter(now, Mode::Stopped);
        Reply::ok("fault cleared, stopped: every output off until a `mode` command")
    }

    /// Fuse a new valid measurement into the observer: T1 the film, T2 the outer surface, T5
    /// the background (≈ the ambient). A frame that did not separate T1 and T2 for sure
    /// (ambiguous: assigned by the prior; merged or fallback: both the same mean) counts with
    /// its bound added to their noise.
    fn correct_observer(&mut self, m: &Measurement) {
        let region = |i: usize| m.regions.get(i).copied().flatten();
        let extra = if m.quality == Quality::Resolved {
            0.0
        } else {
            let b = m.bound.k();
            if b.is_finite() { b * b } else { 100.0 }
        };
        self.observer.correct_with(m.t1(), m.t2(), region(4), extra);
    }

    /// Write the telemetry line (with its `#` and CR LF).
    pub fn write_telemetry(
        &self,
        now: Millis,
        out: &mut impl core::fmt::Write,
    ) -> core::fmt::Result {
        report::telemetry(self, now, out)
    }
}
#[cfg(test)]
mod tests;
