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
//!   |            [ Stepping: Soak ]  heat until the colder target   |
//!   |                    |           reaches hot_k and holds it     |
//!   |                    |           ready_dwell_s (and every spring |
//!   |                    |           it drives has a cleared        |
//!   |                    |           on-time); soak_timeout_s ----->+
//!   |                    v                                          |
//!   |            [ Stepping: Rest ]  (only if a spring is still warm|
//!   |                    |           by its heat estimate) hold     |
//!   |                    |           hot_k until spring_rest: ends  |
//!   |                    |           within cool_s·ln(h/spring_rest)|
//!   |                    v                                          |
//!   |            [ Stepping: Prewarm ] springs on prewarm_s, then   |
//!   |                    |             off prewarm_gap_s            |
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
//!   |                   balanced to spring_recover_pct (throughout); |
//!   |                   soak_timeout_s, ready or not --------------->+
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
//! Tc is [`controlled_temperature`](crate::measurement::controlled_temperature) of the mode's
//! [`SensingHint`]: the heating modes control the colder of T1/T2, forming the hotter one.
//!
//! The springs: nothing senses them, so the supervisor keeps a heat estimate of each from its
//! own switching ([`SpringHeat`]). Recovery uses it to bring all three springs to austenite
//! together — three equal pulls hold the softened column straight while it cools and locks,
//! where a spring still austenite from the stepping would otherwise hold the bend for minutes —
//! and a new stepping waits (phase `rest`) until every spring is martensite again.

pub mod events;
pub mod memory;
pub mod report;
pub mod safety;
pub mod store;

use crate::command::{Command, ModeRequest};
use crate::control::{
    AutotuneConfig, AutotuneStep, Pid, PidConfig, RelayAutotune, SplitRange, SpringHeat, TuneRule,
};
use crate::measurement::{Measurement, Quality, SensingHint, controlled_temperature};
use crate::mtts::Prior;
use crate::outputs::{Duty, Outputs, SpringMask};
use crate::settings::{PARAMS, SetError, Settings};
use crate::units::{Kelvin, Millis};
use events::{EventKind, EventLog};
use report::Reply;
use safety::{Fault, FaultKind, LoopState, Safety};

pub use memory::SpringMemory;

/// Plausible region temperatures for a measurement to count as valid, K.
pub const VALID_K: (f32, f32) = (200.0, 500.0);

/// Within this of its ceiling (`heater_cap_k − heater_cap_band_k`, where the cascade holds the
/// film at most) a film counts as held at the ceiling: the no-response check rests, K.
pub const CEILING_MARGIN_K: f32 = 1.0;

/// The warning when the loop falls back to the film region.
pub const WARN_UNRESOLVED: &str =
    "frames unresolved for unresolved_s while heating: the loop holds the film region";
/// The warning when frames resolve again after a fallback.
pub const WARN_RESOLVED: &str = "frames resolved again: the loop holds the mode's region";

/// Which stepping mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepKind {
    /// One stepping phase.
    Small,
    /// `large_steps` stepping phases with pulses between.
    Large,
}

/// Where a stepping mode is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StepPhase {
    /// Heating until the colder target is ready; since when it has been ready.
    Soak {
        /// The first time the colder target was within the ready band, if it still is.
        ready_since: Option<Millis>,
    },
    /// The soak is done but a spring is still warm from an earlier cycle: holding `hot_k` with
    /// the springs off until every spring's heat estimate is at most `spring_rest` (a passive
    /// spring that is still austenite would hold the column against the stepping).
    Rest,
    /// The springs' pre-warm: on for `prewarm_s` (from room temperature to just below their
    /// transformation, so the first stepping phase loads at once), then off for
    /// `prewarm_gap_s` (which also ends the continuous on-time).
    Prewarm {
        /// Springs on (the pulse) or off (the gap).
        on: bool,
        /// Time left, ms.
        left_ms: u32,
    },
    /// Springs on: phase `index` (0-based), `left_ms` to go.
    Spring {
        /// Which stepping phase.
        index: u8,
        /// Time left, ms.
        left_ms: u32,
    },
    /// Springs off between stepping phases.
    Pulse {
        /// The stepping phase that follows.
        index: u8,
        /// Time left, ms.
        left_ms: u32,
    },
    /// Done: holding `hot_k` with the springs off.
    Hold,
}

/// A stepping mode's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stepping {
    /// Small or large.
    pub kind: StepKind,
    /// The springs it drives.
    pub springs: SpringMask,
    /// Where it is.
    pub phase: StepPhase,
    /// Paused: springs off and timers held.
    pub paused: bool,
    /// Since when the stepping has been holding `hot_k` without a spring phase to run (hold or
    /// paused): past `hold_timeout_s` it returns to standby.
    pub idle_since: Option<Millis>,
}

/// Where recovery is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RecoverPhase {
    /// Heating to `hot_k` (as stepping's soak) while the springs are balanced. Ends once Tc is
    /// ready and every spring's heat estimate has reached `spring_recover_heat`.
    Heat {
        /// The first time Tc was within the ready band, if it still is.
        ready_since: Option<Millis>,
    },
    /// All springs on to clear stress-induced martensite (the thesis's pulse); time left, ms.
    Pulse {
        /// Time left, ms.
        left_ms: u32,
    },
    /// Holding `hot_k` while the stored strain releases and the springs hold the column
    /// straight; time left, ms.
    Hold {
        /// Time left, ms.
        left_ms: u32,
    },
    /// Cooling as forming does (heater off, fan `form_fan`) with the springs still balanced, so
    /// the column locks straight; ends when the hotter target is at `form_end_k`.
    Cool {
        /// When the cooling started (its `form_timeout_s` counts from here).
        since: Millis,
    },
}

/// Recovery's state: its phase and the springs' drive windows.
///
/// Throughout recovery the springs are balanced ([`SpringHeat::balance`]) in windows of
/// `recover_on_s` on and `recover_off_s` off (within the on-time limit): the coldest springs by
/// their heat estimate are driven first, until all three have reached `spring_recover_heat`,
/// and topped up after. Three austenite springs pull the soft column straight together; a spring that stayed
/// austenite from the stepping would otherwise hold the bend (in still air it takes minutes to
/// turn martensite again), and the stored strain's release alone cannot undo that.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Recovering {
    /// Where recovery is.
    pub phase: RecoverPhase,
    /// In a window where springs may be on.
    pub window_on: bool,
    /// Time left in the window, ms.
    pub window_left_ms: u32,
}

/// The supervisor's mode; each variant carries its own state.
#[derive(Clone, Debug)]
pub enum Mode {
    /// Mode 0: hold `standby_k`.
    Standby,
    /// Modes 1 and 2.
    Stepping(Stepping),
    /// Mode 3: fan on, heater off, until the hotter target is at `form_end_k`.
    Forming {
        /// When forming started.
        since: Millis,
    },
    /// Mode 4.
    Recovery(Recovering),
    /// A relay autotune.
    Autotune(RelayAutotune),
    /// Everything off until a `mode` command.
    Stopped,
    /// A fault is latched: heater and springs off.
    Faulted,
}

impl Mode {
    /// Return the mode's name as `status` and telemetry show it.
    pub fn name(&self) -> &'static str {
        match self {
            Mode::Standby => "standby",
            Mode::Stepping(s) if s.kind == StepKind::Small => "step-small",
            Mode::Stepping(_) => "step-large",
            Mode::Forming { .. } => "form",
            Mode::Recovery(_) => "recover",
            Mode::Autotune(_) => "autotune",
            Mode::Stopped => "stopped",
            Mode::Faulted => "fault",
        }
    }

    /// Return the stepping/recovery phase's name (`-` where a mode has none).
    pub fn phase_name(&self) -> &'static str {
        match self {
            Mode::Stepping(s) if s.paused => "paused",
            Mode::Stepping(s) => match s.phase {
                StepPhase::Soak { .. } => "soak",
                StepPhase::Rest => "rest",
                StepPhase::Prewarm { .. } => "prewarm",
                StepPhase::Spring { .. } => "spring",
                StepPhase::Pulse { .. } => "pulse",
                StepPhase::Hold => "hold",
            },
            Mode::Recovery(r) => match r.phase {
                RecoverPhase::Heat { .. } => "heat",
                RecoverPhase::Pulse { .. } => "pulse",
                RecoverPhase::Hold { .. } => "hold",
                RecoverPhase::Cool { .. } => "cool",
            },
            _ => "-",
        }
    }

    /// Cooling with the heater off and the fan on (forming, and recovery's last phase): no
    /// loop runs, and the sensing expects the surface hotter. Since when, if so.
    pub fn cooling_since(&self) -> Option<Millis> {
        match *self {
            Mode::Forming { since }
            | Mode::Recovery(Recovering {
                phase: RecoverPhase::Cool { since },
                ..
            }) => Some(since),
            _ => None,
        }
    }
}

/// What a wait for a temperature (the ready one, or forming's end) decided this step.
enum Soak {
    /// Keep heating.
    Wait,
    /// Ready: go on to the next phase.
    Go,
    /// Not there within its timeout: give up, back to standby.
    GiveUp,
}

/// Telemetry: on, and when the next line is due.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Stream {
    period_ms: u32,
    next_at: Millis,
}

/// Fastest telemetry rate, Hz.
pub const STREAM_MAX_HZ: f32 = 20.0;
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
    /// A warning to print on the console as `# warning: …` (it is also in the `log`).
    pub warning: Option<&'static str>,
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
    spring_heat: SpringHeat,
    stream: Option<Stream>,
    button_pressed: bool,
    store: Option<store::StoreRequest>,
    /// The sensor-loss window counts from here if it is later than the last measurement: the
    /// end of a flash operation, which stalls the sensor with the core.
    sensor_grace: Millis,
    /// Since when the frames have not separated T1 and T2 (merged or fallback), if they have not.
    unresolved_since: Option<Millis>,
    /// The loop holds the film region (too long unresolved while heating on the colder one).
    film_fallback: bool,
    /// `stop` was asked with a fault latched: the fan is off too, until `reset`.
    quiet: bool,
    /// A warning for this step's decision.
    warning: Option<&'static str>,
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

fn ms(seconds: f32) -> u32 {
    (seconds * 1000.0 + 0.5) as u32
}

/// Recovery's balancing drives the springs whose heat estimate is within this of the
/// coldest's ([`SpringHeat::balance`]): one 0.25 s frame at full current adds ≈0.01.
const BALANCE_BAND: f32 = 0.05;

/// The first springs-on phase of a stepping: the pre-warm, or the first stepping phase.
fn first_spring_phase(s: &Settings) -> StepPhase {
    if s.prewarm_s > 0.0 {
        StepPhase::Prewarm {
            on: true,
            left_ms: ms(s.prewarm_s),
        }
    } else {
        StepPhase::Spring {
            index: 0,
            left_ms: ms(s.step_s),
        }
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
            spring_heat: springs.heat,
            stream: None,
            button_pressed: false,
            store: None,
            sensor_grace: now,
            unresolved_since: None,
            film_fallback: false,
            quiet: false,
            warning: None,
        }
    }

    /// Return the springs' memory (heat estimate, duty history, on-time counts) for the board
    /// to keep across a reset.
    pub fn spring_memory(&self) -> SpringMemory {
        let (duty, on_time) = self.safety.springs();
        SpringMemory {
            heat: self.spring_heat,
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
            self.latch(
                now,
                Fault {
                    kind: FaultKind::EStop,
                    value: 1.0,
                },
            );
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
            t.config().target_k
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

    /// Return the springs' heat estimate ([`SpringHeat`]), up to this step's start.
    pub fn spring_heat(&self) -> &SpringHeat {
        &self.spring_heat
    }

    /// Return the sensing hint of the mode.
    pub fn sensing_hint(&self) -> SensingHint {
        match self.mode {
            Mode::Forming { .. }
            | Mode::Recovery(Recovering {
                phase: RecoverPhase::Cool { .. },
                ..
            }) => SensingHint {
                prior: Prior::SurfaceHotter,
                weights: Settings::weights(self.settings.w1_form),
            },
            Mode::Stopped | Mode::Faulted => SensingHint {
                prior: Prior::Unknown,
                weights: Settings::weights(self.settings.w1_standby),
            },
            Mode::Stepping(_) | Mode::Recovery(_) | Mode::Standby | Mode::Autotune(_)
                if self.film_fallback =>
            {
                SensingHint {
                    prior: Prior::HeaterHotter,
                    weights: Settings::weights(1.0),
                }
            }
            Mode::Stepping(_) => SensingHint {
                prior: Prior::HeaterHotter,
                weights: Settings::weights(self.settings.w1_step),
            },
            Mode::Recovery(_) => SensingHint {
                prior: Prior::HeaterHotter,
                weights: Settings::weights(self.settings.w1_recover),
            },
            Mode::Standby | Mode::Autotune(_) => SensingHint {
                prior: Prior::HeaterHotter,
                weights: Settings::weights(self.settings.w1_standby),
            },
        }
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
        self.warning = None;
        // The interval since the last step ran with the last decision's outputs: credit it to
        // the springs that were on during it (heat estimate, on-time, duty).
        let ran = self.outputs;
        self.spring_heat.update(
            ran.springs,
            elapsed_ms as f32 * 1e-3,
            self.settings.spring_heat_s,
            self.settings.spring_cool_s,
        );
        if let Some(f) = self
            .safety
            .credit_springs(ran.springs, elapsed_ms, &self.settings)
            .or_else(|| self.spring_heat_fault(ran.springs))
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
        let mut dt_s = 0.0;
        if let Some(m) = fresh {
            dt_s = self.last.map_or(0.0, |l| m.at.seconds_since(l.at));
            self.track_resolution(now, &m);
            self.tc_k = controlled_temperature(&m, &self.sensing_hint()).k();
            self.last = Some(m);
        }

        // 2. The command.
        let reply = command.map(|c| self.command(now, c));

        // 3. Faults that depend on the sensor.
        let since = self
            .last
            .map_or(self.started, |m| m.at)
            .max(self.sensor_grace);
        let age_s = now.seconds_since(since);
        if age_s > self.settings.sensor_timeout_s {
            self.latch(
                now,
                Fault {
                    kind: FaultKind::SensorLoss,
                    value: age_s,
                },
            );
        }
        if let Some(m) = fresh {
            let heater = ran.heater.fraction();
            let film_k = m.hotter().k();
            // A film held at its ceiling (the heater cap, or the cascade's film limit below it)
            // is visibly heated: the steady state of a long soak on a cold day.
            let s = &self.settings;
            let at_ceiling = film_k >= s.heater_cap_k - s.heater_cap_band_k - CEILING_MARGIN_K;
            let demand = if at_ceiling { 0.0 } else { heater };
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
            if let Some(f) = self.safety.runaway(now, dt_s, l, &self.settings) {
                self.latch(now, f);
            }
        }

        // 4. The mode.
        let mut outputs = self.run_mode(now, elapsed_ms, fresh.as_ref(), dt_s);

        // 5. Spring limits on what would be applied: a spring past its limit is never on.
        if let Some(f) = self
            .safety
            .spring_fault(outputs.springs, &self.settings)
            .or_else(|| self.spring_heat_fault(outputs.springs))
        {
            self.latch(now, f);
        }
        if self.fault.is_some() {
            outputs = self.safe_outputs();
        }
        // A flash operation follows this decision: heater and springs off through it.
        if self.store.is_some() {
            outputs.heater = Duty::OFF;
            outputs.springs = SpringMask::NONE;
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
            reply: if store.is_some() { None } else { reply },
            store,
            telemetry,
            // A stale measurement always latches sensor loss in this same step unless another
            // fault already holds the outputs safe: either way the loop is alive.
            alive: age_s <= self.settings.sensor_timeout_s || self.fault.is_some(),
            warning: self.warning,
        }
    }

    /// A spring of `springs` whose heat estimate is past `spring_heat_max`.
    fn spring_heat_fault(&self, springs: SpringMask) -> Option<Fault> {
        (0..crate::outputs::SPRINGS)
            .filter(|&i| springs.contains(i))
            .find(|&i| self.spring_heat.heat(i) > self.settings.spring_heat_max)
            .map(|i| Fault {
                kind: FaultKind::SpringHeat(i as u8),
                value: self.spring_heat.heat(i),
            })
    }

    /// Follow how long the frames have not separated T1 and T2; past `unresolved_s` while the
    /// loop heats on the colder region, fall back to the film region with a warning.
    fn track_resolution(&mut self, now: Millis, m: &Measurement) {
        if m.quality == Quality::Resolved {
            self.unresolved_since = None;
            if self.film_fallback {
                self.film_fallback = false;
                self.events.push(now, EventKind::Warning(WARN_RESOLVED));
                self.warning = Some(WARN_RESOLVED);
            }
            return;
        }
        let since = *self.unresolved_since.get_or_insert(m.at);
        let on_colder = self.loop_active() && self.sensing_hint().weights.w1 < 1.0;
        if on_colder
            && !self.film_fallback
            && m.at.seconds_since(since) >= self.settings.unresolved_s
        {
            self.film_fallback = true;
            self.events.push(now, EventKind::Warning(WARN_UNRESOLVED));
            self.warning = Some(WARN_UNRESOLVED);
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
            .all(|t| t.k().is_finite() && t.k() >= VALID_K.0)
    }

    fn valid(&self, m: &Measurement) -> bool {
        let ok = |t: Kelvin| t.k().is_finite() && (VALID_K.0..=VALID_K.1).contains(&t.k());
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
        }
    }

    /// Latch `f`. The first fault stays latched, except that an e-stop overrides any other
    /// (a press while another fault is latched is never lost: `reset` then needs the button
    /// released).
    fn latch(&mut self, now: Millis, f: Fault) {
        match self.fault {
            Some(cur) if cur.kind == FaultKind::EStop => return,
            Some(_) if f.kind != FaultKind::EStop => return,
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
        dt_s: f32,
    ) -> Outputs {
        let s = self.settings;
        let hotter = self.last.map(|m| m.hotter().k());
        let tc = self.tc_k;
        // Ready: Tc has reached hot_k (with the stepping weights, the colder region: the
        // whole cross-section) and has not fallen more than ready_band_k below it since, for
        // ready_dwell_s.
        // A wait that lasts past soak_timeout_s gives up.
        let timed_out = now.seconds_since(self.mode_since) > s.soak_timeout_s;
        let ready = |since: Option<Millis>| -> (Option<Millis>, Soak) {
            let (since, go) = match since {
                Some(t0) if tc >= s.hot_k - s.ready_band_k => {
                    (Some(t0), now.seconds_since(t0) >= s.ready_dwell_s)
                }
                None if tc >= s.hot_k => (Some(now), s.ready_dwell_s <= 0.0),
                _ => (None, false),
            };
            let outcome = match (go, timed_out) {
                (true, _) => Soak::Go,
                (false, true) => Soak::GiveUp,
                (false, false) => Soak::Wait,
            };
            (since, outcome)
        };
        let mut gave_up: Option<&'static str> = None;
        // Forming's end, and recovery's cooling's: the hotter target at form_end_k is done
        // (Go), past form_timeout_s from `since` it gives up.
        let cooled = |since: Millis| -> Soak {
            if hotter.is_some_and(|h| h <= s.form_end_k) {
                Soak::Go
            } else if now.seconds_since(since) > s.form_timeout_s {
                Soak::GiveUp
            } else {
                Soak::Wait
            }
        };
        let mut springs = SpringMask::NONE;
        let mut next: Option<Mode> = None;
        let target = match &mut self.mode {
            Mode::Standby => s.standby_k,
            Mode::Stepping(st) => {
                let run_ms = if st.paused { 0 } else { elapsed_ms };
                match &mut st.phase {
                    StepPhase::Soak { ready_since } => {
                        let (since, mut go) = ready(*ready_since);
                        *ready_since = since;
                        // A spring whose on-time a gap has not yet cleared (a mode changed
                        // straight from its phase) waits: it would trip the on-time limit.
                        let cleared = (0..crate::outputs::SPRINGS)
                            .all(|i| !st.springs.contains(i) || self.safety.spring_on_s(i) == 0.0);
                        if matches!(go, Soak::Go) && !cleared {
                            go = Soak::Wait;
                        }
                        match go {
                            Soak::Go if !self.spring_heat.rested(s.spring_rest) => {
                                self.events.push(now, EventKind::SpringsResting);
                                st.phase = StepPhase::Rest;
                            }
                            Soak::Go => st.phase = first_spring_phase(&s),
                            Soak::GiveUp => gave_up = Some("soak"),
                            Soak::Wait => {}
                        }
                    }
                    StepPhase::Rest => {
                        if self.spring_heat.rested(s.spring_rest) {
                            st.phase = first_spring_phase(&s);
                        }
                    }
                    StepPhase::Prewarm { on, left_ms } => {
                        *left_ms = left_ms.saturating_sub(run_ms);
                        if *left_ms == 0 {
                            st.phase = if *on {
                                StepPhase::Prewarm {
                                    on: false,
                                    left_ms: ms(s.prewarm_gap_s).max(1),
                                }
                            } else {
                                StepPhase::Spring {
                                    index: 0,
                                    left_ms: ms(s.step_s),
                                }
                            };
                        }
                    }
                    StepPhase::Spring { index, left_ms } => {
                        *left_ms = left_ms.saturating_sub(run_ms);
                        if *left_ms == 0 {
                            let steps = match st.kind {
                                StepKind::Small => 1,
                                StepKind::Large => s.large_steps as u8,
                            };
                            st.phase = if *index + 1 >= steps {
                                self.events.push(now, EventKind::SteppingDone);
                                StepPhase::Hold
                            } else {
                                StepPhase::Pulse {
                                    index: *index + 1,
                                    left_ms: ms(s.pulse_s),
                                }
                            };
                        }
                    }
                    StepPhase::Pulse { index, left_ms } => {
                        *left_ms = left_ms.saturating_sub(run_ms);
                        if *left_ms == 0 {
                            st.phase = StepPhase::Spring {
                                index: *index,
                                left_ms: ms(s.step_s),
                            };
                        }
                    }
                    StepPhase::Hold => {}
                }
                // Hold and pause hold hot_k with nothing to run: an idle timeout ends them in
                // standby. (Rest ends by the springs' model, within cool_s·ln(h/spring_rest).)
                let idle = st.paused || matches!(st.phase, StepPhase::Hold);
                if !idle {
                    st.idle_since = None;
                } else if now.seconds_since(*st.idle_since.get_or_insert(now)) > s.hold_timeout_s {
                    gave_up = Some("hold");
                }
                let on = matches!(
                    st.phase,
                    StepPhase::Spring { .. } | StepPhase::Prewarm { on: true, .. }
                );
                if on && !st.paused {
                    springs = st.springs;
                }
                s.hot_k
            }
            Mode::Forming { since } => {
                match cooled(*since) {
                    Soak::Go => next = Some(Mode::Standby),
                    Soak::GiveUp => gave_up = Some("form"),
                    Soak::Wait => {}
                }
                s.standby_k
            }
            Mode::Recovery(rec) => {
                let heat = self.spring_heat;
                let may_run = |safety: &Safety, left_ms: u32| -> SpringMask {
                    let bits = (0..crate::outputs::SPRINGS)
                        .filter(|&i| {
                            safety.spring_duty(i) < 0.9 * s.spring_duty_max
                                && safety.spring_may_run(i, left_ms as f32 * 1e-3, &s)
                                && heat.heat(i) < s.spring_heat_max - BALANCE_BAND
                        })
                        .fold(0u8, |b, i| b | 1 << i);
                    SpringMask::from_bits(bits)
                };
                rec.window_left_ms = rec.window_left_ms.saturating_sub(elapsed_ms);
                if rec.window_left_ms == 0 {
                    rec.window_on = !rec.window_on;
                    rec.window_left_ms = ms(if rec.window_on {
                        s.recover_on_s
                    } else {
                        s.recover_off_s
                    })
                    .max(1);
                }
                let balanced = self.spring_heat.all_at(s.spring_recover_heat);
                match &mut rec.phase {
                    RecoverPhase::Heat { ready_since } => {
                        let (since, go) = ready(*ready_since);
                        *ready_since = since;
                        // The pulse runs inside an on window (it fits in what is left of
                        // it), so a spring's continuous on-time stays within the window's.
                        let pulse_fits = rec.window_on
                            && rec.window_left_ms >= ms(s.recover_pulse_s)
                            && may_run(&self.safety, rec.window_left_ms) == SpringMask::ALL;
                        match go {
                            Soak::Go if balanced && pulse_fits => {
                                rec.phase = RecoverPhase::Pulse {
                                    left_ms: ms(s.recover_pulse_s),
                                }
                            }
                            Soak::GiveUp => gave_up = Some("reheat"),
                            // Ready but the springs not yet balanced: the heat phase still
                            // ends by soak_timeout_s.
                            Soak::Go | Soak::Wait if timed_out => gave_up = Some("reheat"),
                            Soak::Go | Soak::Wait => {}
                        }
                    }
                    RecoverPhase::Pulse { left_ms } => {
                        *left_ms = left_ms.saturating_sub(elapsed_ms);
                        if *left_ms == 0 {
                            rec.phase = RecoverPhase::Hold {
                                left_ms: ms(s.recover_hold_s),
                            };
                        }
                    }
                    RecoverPhase::Hold { left_ms } => {
                        *left_ms = left_ms.saturating_sub(elapsed_ms);
                        if *left_ms == 0 {
                            rec.phase = RecoverPhase::Cool { since: now };
                            self.events.push(now, EventKind::RecoveryCooling);
                        }
                    }
                    RecoverPhase::Cool { since } => match cooled(*since) {
                        Soak::Go => next = Some(Mode::Standby),
                        Soak::GiveUp => gave_up = Some("recover"),
                        Soak::Wait => {}
                    },
                }
                let allowed = may_run(&self.safety, rec.window_left_ms);
                if matches!(rec.phase, RecoverPhase::Pulse { .. }) {
                    springs = SpringMask::from_bits(SpringMask::ALL.bits() & allowed.bits());
                } else if rec.window_on {
                    // A spring near its duty or heat limit, or whose on-time the rest of the
                    // window would take past the limit, sits the window out.
                    springs = SpringMask::from_bits(
                        self.spring_heat
                            .balance(s.spring_recover_heat, BALANCE_BAND)
                            .bits()
                            & allowed.bits(),
                    );
                }
                s.hot_k
            }
            Mode::Autotune(tuner) => {
                // The relay obeys the heater cap like the loop does.
                let cap = hotter.map_or(1.0, |h| (s.heater_cap_k - h) / s.heater_cap_band_k);
                let capped = |d: Duty| Duty::from_fraction(d.fraction().min(cap.clamp(0.0, 1.0)));
                if let Some(m) = fresh {
                    // Seconds since the run started: f32 keeps its resolution however long
                    // the board has been up.
                    match tuner.step(m.at.seconds_since(self.mode_since), self.tc_k) {
                        AutotuneStep::Running { heater_duty } => {
                            return Outputs {
                                heater: capped(heater_duty),
                                fan: Duty::OFF,
                                springs: SpringMask::NONE,
                            };
                        }
                        AutotuneStep::Done(r) => {
                            // The tuned gains must pass the ranges `set` would check.
                            if let Ok(tuned) = s.with_gains(r.gains) {
                                self.configure(tuned);
                                self.events.push(
                                    now,
                                    EventKind::Tuned {
                                        ku_per_k: r.ku_per_k,
                                        tu_s: r.tu_s,
                                    },
                                );
                            } else {
                                self.events
                                    .push(now, EventKind::TuneAborted("gains out of range"));
                            }
                            next = Some(Mode::Standby);
                        }
                        AutotuneStep::Aborted(why) => {
                            self.events.push(now, EventKind::TuneAborted(why.name()));
                            next = Some(Mode::Standby);
                        }
                    }
                } else {
                    // Between frames the relay's output holds (capped by the last frame).
                    return Outputs {
                        heater: capped(self.outputs.heater),
                        fan: Duty::OFF,
                        springs: SpringMask::NONE,
                    };
                }
                s.tune_k
            }
            Mode::Stopped | Mode::Faulted => return self.safe_outputs(),
        };
        if let Some(what) = gave_up {
            self.events
                .push(now, EventKind::TimedOut { what, tc_k: tc });
            next = Some(Mode::Standby);
        }
        if let Some(m) = next {
            self.enter(now, m);
            return self.run_mode(now, 0, None, 0.0);
        }
        if self.mode.cooling_since().is_some() {
            return Outputs {
                heater: Duty::OFF,
                fan: Duty::from_fraction(s.form_fan),
                springs,
            };
        }
        self.set_target(target);
        let cascade = self.sensing_hint().weights.w1 < 1.0;
        let u = match (fresh, hotter) {
            (Some(_), Some(h)) if cascade => {
                // Cascade: the slow outer loop turns Tc's error into how far above the target
                // the hotter region (the film) should run; the fast inner loop holds the film
                // there. The outer output is clamped so the film stays below heater_cap_k.
                let offset = self.outer.update(self.tc_k, dt_s);
                self.pid.update(h - offset, dt_s)
            }
            (Some(_), _) => self.pid.update(self.tc_k, dt_s),
            _ => self.pid.output(),
        };
        let hc = self.split.apply(u);
        // The heater cap, an override on the hotter region: whatever the loop wants, the film
        // is not driven past heater_cap_k.
        let cap = hotter.map_or(1.0, |h| (s.heater_cap_k - h) / s.heater_cap_band_k);
        Outputs {
            heater: Duty::from_fraction(hc.heater.fraction().min(cap.clamp(0.0, 1.0))),
            fan: hc.fan,
            springs,
        }
    }

    /// Carry out a command; return its reply.
    fn command(&mut self, now: Millis, c: Command) -> Reply {
        match c {
            Command::Help => Reply::help(),
            Command::Version => Reply::version(),
            Command::Status => Reply::status(self, now),
            Command::Log => Reply::log(&self.events),
            Command::Get(None) => Reply::get_all(&self.settings),
            Command::Get(Some(i)) => Reply::get(&self.settings, i as usize),
            Command::Set(i, v) => {
                let Some(p) = PARAMS.get(i as usize) else {
                    return Reply::err("unknown-name", "no such parameter");
                };
                let mut next = self.settings;
                match next.set(p.name, v) {
                    Ok(()) => {
                        self.configure(next);
                        Reply::get(&self.settings, i as usize)
                    }
                    Err(SetError::OutOfRange { min, max }) => Reply::out_of_range(p, min, max),
                    Err(SetError::Conflict(why)) => Reply::err("conflict", why),
                    Err(SetError::NotANumber) => Reply::err("bad-arguments", "not a valid number"),
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
                    return Reply::err("out-of-range", "stream rate must be in (0, 20] Hz");
                }
                self.stream = Some(Stream {
                    period_ms: ms(1.0 / hz).max(1),
                    next_at: now,
                });
                Reply::stream_on(hz)
            }
            Command::EStop => {
                self.latch(
                    now,
                    Fault {
                        kind: FaultKind::EStop,
                        value: 0.0,
                    },
                );
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
                match &mut self.mode {
                    // Pause holds a spring phase's timer; soak, rest and hold have none.
                    Mode::Stepping(st)
                        if pause
                            && !st.paused
                            && matches!(
                                st.phase,
                                StepPhase::Soak { .. } | StepPhase::Rest | StepPhase::Hold
                            ) =>
                    {
                        Reply::err(
                            "bad-state",
                            "pause only in a spring phase (prewarm, spring, pulse)",
                        )
                    }
                    Mode::Stepping(st) if st.paused != pause => {
                        st.paused = pause;
                        Reply::ok(if pause { "paused" } else { "resumed" })
                    }
                    Mode::Stepping(_) => Reply::err(
                        "bad-state",
                        if pause {
                            "already paused"
                        } else {
                            "not paused"
                        },
                    ),
                    _ => Reply::err("bad-state", "only stepping pauses"),
                }
            }
            Command::Autotune => {
                let s = &self.settings;
                // Ziegler–Nichols' classic rule: on the simulated block it gives 0.6 K of
                // overshoot and a ±0.2 K hold (README, control section); the no-overshoot rule
                // holds the standby target ±0.3 K but takes 30 s to preheat.
                // The reading must follow the relay: rise while heating up to the band as the
                // runaway check asks, and switch within two expected periods once cycling.
                let tuner = RelayAutotune::new(AutotuneConfig {
                    rule: TuneRule::ZieglerNichols,
                    timeout_s: s.tune_timeout_s,
                    max_overshoot_k: (s.t_max_k - s.tune_k - 1.0).min(8.0),
                    follow_s: 2.0 * s.tune_expected_period_s(),
                    rise_k: s.runaway_gain_k,
                    rise_window_s: s.runaway_window_s,
                    ..AutotuneConfig::around(
                        s.tune_k,
                        Duty::from_fraction(s.tune_base),
                        s.tune_amplitude,
                    )
                });
                self.enter(now, Mode::Autotune(tuner));
                Reply::ok("autotune started")
            }
            Command::Mode(req, springs) => {
                let mode = match req {
                    ModeRequest::Standby => Mode::Standby,
                    ModeRequest::StepSmall | ModeRequest::StepLarge => {
                        if let Some(sp) = springs {
                            self.springs = sp;
                        }
                        // From a hold at hot_k, a new step still waits the dwell (a fresh check).
                        Mode::Stepping(Stepping {
                            kind: if req == ModeRequest::StepSmall {
                                StepKind::Small
                            } else {
                                StepKind::Large
                            },
                            springs: self.springs,
                            phase: StepPhase::Soak { ready_since: None },
                            paused: false,
                            idle_since: None,
                        })
                    }
                    ModeRequest::Form => Mode::Forming { since: now },
                    ModeRequest::Recover => Mode::Recovery(Recovering {
                        phase: RecoverPhase::Heat { ready_since: None },
                        window_on: true,
                        window_left_ms: ms(self.settings.recover_on_s).max(1),
                    }),
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
            return Reply::cause_present(Fault {
                kind: FaultKind::EStop,
                value: 1.0,
            });
        }
        let s = &self.settings;
        let fresh = self
            .last
            .is_some_and(|m| now.seconds_since(m.at) <= s.sensor_timeout_s);
        let gone = match f.kind {
            FaultKind::SensorLoss => fresh,
            FaultKind::OverTemperature => {
                fresh
                    && self.last.is_some_and(|m| {
                        let mut cooler = m;
                        for t in cooler.regions.iter_mut() {
                            t.0 += 5.0;
                        }
                        cooler.cylinder_max = cooler.cylinder_max.map(|t| Kelvin(t.0 + 5.0));
                        Safety::over_temperature(&cooler, s).is_none()
                    })
            }
            FaultKind::SpringOnTime(_) | FaultKind::SpringDuty(_) | FaultKind::SpringHeat(_) => {
                (0..crate::outputs::SPRINGS).all(|i| {
                    self.safety.spring_duty(i) < 0.5 * s.spring_duty_max
                        && self.spring_heat.heat(i) < 1.0
                })
            }
            FaultKind::RunawayHeating | FaultKind::RunawayHolding | FaultKind::NoResponse => fresh,
            FaultKind::EStop => !self.button_pressed,
        };
        if !gone {
            return Reply::cause_present(f);
        }
        self.fault = None;
        self.quiet = false;
        self.events.push(now, EventKind::Cleared(f));
        self.outputs = Outputs::OFF;
        self.enter(now, Mode::Stopped);
        Reply::ok("fault cleared, stopped: every output off until a `mode` command")
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
