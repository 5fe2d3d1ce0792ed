//! The modes: one name table ([`ModeId`]), the [`Mode`] each variant of which carries its own
//! state, and what a mode's step decides (`ModeStep`).
//!
//! A mode is one file beside this one (`standby.rs`, `stepping.rs`, `forming.rs`,
//! `recovery.rs`, `autotune.rs`): its state and its `advance(&mut state, &mut Ctx) -> ModeStep`.
//! The supervisor owns everything around it — the loop, the faults, the outputs — and turns a
//! `ModeStep` into outputs. Every `match` on modes is exhaustive, so a new mode is one file,
//! one [`ModeId`] row and one [`Mode`] variant, and the compiler lists what else it needs.

use super::autotune::Tuning;
use super::events::{EventKind, EventLog, Notice, Warning};
use super::forming::Forming;
use super::pose::{PosePhase, Posing};
use super::recovery::{RecoverPhase, Recovering};
use super::safety::Safety;
use super::stepping::{StepKind, StepPhase, Stepping};
use crate::measurement::{Measurement, SensingHint};
use crate::mtts::Prior;
use crate::observer::{Estimate, Observer};
use crate::outputs::{Duty, SPRINGS, SpringMask};
use crate::posture::Bend;
use crate::settings::Settings;
use crate::units::Millis;

/// Every mode as a plain, copyable id: the one table of mode names (`status`, telemetry, the
/// `mode` command, `log`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModeId {
    /// Mode 0: hold `standby_k`.
    Standby,
    /// Mode 1: one stepping phase.
    StepSmall,
    /// Mode 2: `large_steps` stepping phases with pulses between.
    StepLarge,
    /// Mode 3: cool with the fan until the hotter target is at `form_end_k`.
    Form,
    /// Mode 4: reheat, straighten with the springs, cool straight.
    Recover,
    /// Bend to an angle by the bend estimate (`mode pose ANGLE [SPRINGS] [form]`).
    Pose,
    /// A relay autotune.
    Autotune,
    /// Everything off until a `mode` command.
    Stopped,
    /// A fault is latched.
    Faulted,
}

impl ModeId {
    /// Every mode, the ones a `mode` command asks for first, in the thesis's order.
    pub const ALL: [ModeId; 9] = [
        ModeId::Standby,
        ModeId::StepSmall,
        ModeId::StepLarge,
        ModeId::Form,
        ModeId::Recover,
        ModeId::Pose,
        ModeId::Autotune,
        ModeId::Stopped,
        ModeId::Faulted,
    ];

    /// The mode's name as the console shows it.
    pub const fn name(self) -> &'static str {
        match self {
            ModeId::Standby => "standby",
            ModeId::StepSmall => "step-small",
            ModeId::StepLarge => "step-large",
            ModeId::Form => "form",
            ModeId::Recover => "recover",
            ModeId::Pose => "pose",
            ModeId::Autotune => "autotune",
            ModeId::Stopped => "stopped",
            ModeId::Faulted => "fault",
        }
    }

    /// Whether `mode NAME` enters it (autotune has its own command; stopped and fault are
    /// reached by `stop` and by a fault).
    pub const fn requestable(self) -> bool {
        match self {
            ModeId::Standby
            | ModeId::StepSmall
            | ModeId::StepLarge
            | ModeId::Form
            | ModeId::Recover
            | ModeId::Pose => true,
            ModeId::Autotune | ModeId::Stopped | ModeId::Faulted => false,
        }
    }

    /// Whether the mode drives the springs (a `mode` command may name them).
    pub const fn takes_springs(self) -> bool {
        match self {
            ModeId::StepSmall | ModeId::StepLarge | ModeId::Pose => true,
            ModeId::Standby
            | ModeId::Form
            | ModeId::Recover
            | ModeId::Autotune
            | ModeId::Stopped
            | ModeId::Faulted => false,
        }
    }

    /// Whether the mode wants the springs available: the spring power enable is on only then
    /// (and with no fault latched), so a MOSFET failed short cannot heat a spring in any
    /// other mode, and is caught with its gate off as soon as a mode turns the power on.
    pub const fn uses_springs(self) -> bool {
        match self {
            ModeId::StepSmall | ModeId::StepLarge | ModeId::Recover | ModeId::Pose => true,
            ModeId::Standby
            | ModeId::Form
            | ModeId::Autotune
            | ModeId::Stopped
            | ModeId::Faulted => false,
        }
    }

    /// Whether the mode drives the block (heater loop, springs or fan on purpose): no flash
    /// operation then, since it stalls the core.
    pub const fn drives_block(self) -> bool {
        match self {
            ModeId::StepSmall
            | ModeId::StepLarge
            | ModeId::Form
            | ModeId::Recover
            | ModeId::Pose
            | ModeId::Autotune => true,
            ModeId::Standby | ModeId::Stopped | ModeId::Faulted => false,
        }
    }
}

/// The supervisor's mode; each variant carries its own state.
#[derive(Clone, Debug)]
pub enum Mode {
    /// Mode 0: hold `standby_k`.
    Standby,
    /// Modes 1 and 2.
    Stepping(Stepping),
    /// Mode 3: fan on, heater off, until the hotter target is at `form_end_k`.
    Forming(Forming),
    /// Mode 4.
    Recovery(Recovering),
    /// Bending to an angle by the bend estimate.
    Posing(Posing),
    /// A relay autotune.
    Autotune(Tuning),
    /// Everything off until a `mode` command.
    Stopped,
    /// A fault is latched: heater and springs off.
    Faulted,
}

/// Why `pause` or `resume` was refused ([`Mode::pause`]). [`fmt::Display`](core::fmt::Display)
/// gives the console's message (`err bad-state: …`); it is written by hand, as `thiserror` is
/// not used in this `no_std` crate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum PauseError {
    /// The mode is not a stepping.
    NotStepping,
    /// `pause` while paused.
    AlreadyPaused,
    /// `resume` while not paused.
    NotPaused,
    /// `pause` in a stepping phase without a spring timer (soak, rest, hold).
    NotInSpringPhase,
}

impl PauseError {
    /// Return the message (what [`fmt::Display`](core::fmt::Display) writes).
    pub fn message(self) -> &'static str {
        match self {
            Self::NotStepping => "only stepping pauses",
            Self::AlreadyPaused => "already paused",
            Self::NotPaused => "not paused",
            Self::NotInSpringPhase => "pause only in a spring phase (prewarm, spring, pulse)",
        }
    }
}

impl core::fmt::Display for PauseError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.message())
    }
}

impl Mode {
    /// The mode `id` entered at `now` with `s`, stepping with `springs`; `None` for a mode no
    /// command enters (a fault is latched, never asked for).
    pub fn start(id: ModeId, now: Millis, s: &Settings, springs: SpringMask) -> Option<Mode> {
        Some(match id {
            ModeId::Standby => Mode::Standby,
            ModeId::StepSmall => Mode::Stepping(Stepping::new(StepKind::Small, springs)),
            ModeId::StepLarge => Mode::Stepping(Stepping::new(StepKind::Large, springs)),
            ModeId::Form => Mode::Forming(Forming::new(now)),
            ModeId::Recover => Mode::Recovery(Recovering::new(s)),
            ModeId::Autotune => Mode::Autotune(Tuning::start(s)),
            ModeId::Stopped => Mode::Stopped,
            // A pose needs its angle (`Command::Pose`); a fault is latched, never asked for.
            ModeId::Pose | ModeId::Faulted => return None,
        })
    }

    /// One step of the mode; `None` where no mode runs (stopped, faulted: outputs safe).
    pub(super) fn advance(&mut self, c: &mut Ctx) -> Option<ModeStep> {
        Some(match self {
            Mode::Standby => super::standby::advance(c),
            Mode::Stepping(st) => st.advance(c),
            Mode::Forming(f) => f.advance(c),
            Mode::Recovery(r) => r.advance(c),
            Mode::Posing(p) => p.advance(c),
            Mode::Autotune(t) => t.advance(c),
            Mode::Stopped | Mode::Faulted => return None,
        })
    }

    /// `pause` (`true`) or `resume`: `Err` with the reason where it means nothing.
    pub fn pause(&mut self, pause: bool) -> Result<(), PauseError> {
        match self {
            Mode::Stepping(st) => st.pause(pause),
            Mode::Standby
            | Mode::Forming(_)
            | Mode::Recovery(_)
            | Mode::Posing(_)
            | Mode::Autotune(_)
            | Mode::Stopped
            | Mode::Faulted => Err(PauseError::NotStepping),
        }
    }

    /// What the sensing should assume and weigh in this mode ([`SensingHint`]); with
    /// `film_fallback` every heating mode weighs the film region alone.
    pub fn sensing(&self, s: &Settings, film_fallback: bool) -> SensingHint {
        let hint = |prior, w1| SensingHint {
            prior,
            weights: Settings::weights(w1),
        };
        let heating = |w1| hint(Prior::HeaterHotter, if film_fallback { 1.0 } else { w1 });
        match self {
            Mode::Forming(_) => hint(Prior::SurfaceHotter, s.w1_form),
            Mode::Recovery(r) if matches!(r.phase, RecoverPhase::Cool { .. }) => {
                hint(Prior::SurfaceHotter, s.w1_form)
            }
            Mode::Posing(p) if matches!(p.phase, PosePhase::Form { .. }) => {
                hint(Prior::SurfaceHotter, s.w1_form)
            }
            Mode::Stopped | Mode::Faulted => hint(Prior::Unknown, s.w1_standby),
            Mode::Stepping(_) | Mode::Posing(_) => heating(s.w1_step),
            Mode::Recovery(_) => heating(s.w1_recover),
            Mode::Standby | Mode::Autotune(_) => heating(s.w1_standby),
        }
    }

    /// Return the mode's id.
    pub fn id(&self) -> ModeId {
        match self {
            Mode::Standby => ModeId::Standby,
            Mode::Stepping(s) => match s.kind {
                StepKind::Small => ModeId::StepSmall,
                StepKind::Large => ModeId::StepLarge,
            },
            Mode::Forming(_) => ModeId::Form,
            Mode::Recovery(_) => ModeId::Recover,
            Mode::Posing(_) => ModeId::Pose,
            Mode::Autotune(_) => ModeId::Autotune,
            Mode::Stopped => ModeId::Stopped,
            Mode::Faulted => ModeId::Faulted,
        }
    }

    /// Return the mode's name as `status` and telemetry show it.
    pub fn name(&self) -> &'static str {
        self.id().name()
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
                StepPhase::Hold { .. } => "hold",
            },
            Mode::Recovery(r) => match r.phase {
                RecoverPhase::Heat { .. } => "heat",
                RecoverPhase::Pulse { .. } => "pulse",
                RecoverPhase::Hold { .. } => "hold",
                RecoverPhase::Cool { .. } => "cool",
            },
            Mode::Posing(p) => match p.phase {
                PosePhase::Soak { .. } => "soak",
                PosePhase::Step { .. } => "spring",
                PosePhase::Settle { .. } => "settle",
                PosePhase::Hold => "hold",
                PosePhase::Form { .. } => "cool",
            },
            Mode::Standby
            | Mode::Forming(_)
            | Mode::Autotune(_)
            | Mode::Stopped
            | Mode::Faulted => "-",
        }
    }

    /// Cooling with the heater off and the fan on (forming, and recovery's last phase): no
    /// loop runs, and the sensing expects the surface hotter. Since when, if so.
    pub fn cooling_since(&self) -> Option<Millis> {
        match self {
            Mode::Forming(f) => Some(f.since),
            Mode::Recovery(r) => match r.phase {
                RecoverPhase::Cool { since } => Some(since),
                RecoverPhase::Heat { .. }
                | RecoverPhase::Pulse { .. }
                | RecoverPhase::Hold { .. } => None,
            },
            Mode::Posing(p) => match p.phase {
                PosePhase::Form { since, .. } => Some(since),
                PosePhase::Soak { .. }
                | PosePhase::Step { .. }
                | PosePhase::Settle { .. }
                | PosePhase::Hold => None,
            },
            Mode::Standby
            | Mode::Stepping(_)
            | Mode::Autotune(_)
            | Mode::Stopped
            | Mode::Faulted => None,
        }
    }
}

/// What a mode's step sees: the time, the settings and the measurements, the springs' state,
/// and the event log to write to.
pub(super) struct Ctx<'a> {
    /// This step's time.
    pub now: Millis,
    /// Time since the last step, ms.
    pub elapsed_ms: u32,
    /// The settings in force.
    pub s: Settings,
    /// Tc of the last valid measurement, K (NaN before the first).
    pub tc_k: f32,
    /// The hotter target of the last valid measurement, K.
    pub hotter_k: Option<f32>,
    /// When the mode was entered.
    pub mode_since: Millis,
    /// A new valid measurement came this step.
    pub fresh: Option<&'a Measurement>,
    /// The heater duty of the last decision.
    pub last_heater: Duty,
    /// The springs switched on by the last decision (the temperature band's memory).
    pub last_springs: SpringMask,
    /// The observer's estimate at this step (the wall's softness, the springs).
    pub estimate: &'a Estimate,
    /// The bend estimate at this step.
    pub bend: Bend,
    /// The observer (for what the heater can make of the wall, [`Observer::softest`]).
    pub observer: &'a Observer,
    /// The fault checks (spring on-time and duty).
    pub safety: &'a Safety,
    /// The event log.
    pub events: &'a mut EventLog,
    /// This step's notice (a warning, an announcement), if any.
    pub notice: &'a mut Option<Notice>,
}

/// What the mode wants of the heater and the fan.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Drive {
    /// The loop holds this target, K.
    Hold(f32),
    /// Heater off, fan at `form_fan` (forming, recovery's cooling).
    Cool,
    /// The autotune relay's heater duty (fan off), capped like the loop.
    Relay(Duty),
}

/// Where the mode goes next.
#[derive(Clone, Debug)]
pub(super) enum Next {
    /// Enter this mode.
    Enter(Mode),
    /// A wait gave up (`soak`, `reheat`, `form`, `recover`, `hold`): standby, with an event.
    GiveUp(&'static str),
    /// Autotune finished: these settings (with the tuned gains) and standby.
    Tuned(Settings),
}

/// What one step of a mode decided.
#[derive(Clone, Debug)]
pub(super) struct ModeStep {
    /// Heater and fan.
    pub drive: Drive,
    /// The springs to drive.
    pub springs: SpringMask,
    /// Where to go next, if anywhere.
    pub next: Option<Next>,
}

impl ModeStep {
    /// Hold `target_k` with the springs off and stay.
    pub fn hold(target_k: f32) -> ModeStep {
        ModeStep {
            drive: Drive::Hold(target_k),
            springs: SpringMask::NONE,
            next: None,
        }
    }
}

/// What a wait for a temperature (the ready one, or forming's end) decided this step.
pub(super) enum Soak {
    /// Keep heating.
    Wait,
    /// Ready: go on to the next phase.
    Go,
    /// Not there within its timeout: give up, back to standby.
    GiveUp,
}

impl Ctx<'_> {
    /// The mode has lasted past `soak_timeout_s`.
    pub fn soak_timed_out(&self) -> bool {
        self.now.seconds_since(self.mode_since).s() > self.s.soak_timeout_s
    }

    /// Forming's end, and recovery's cooling's: the hotter target at `form_end_k` is done
    /// (Go), past `form_timeout_s` from `since` it gives up.
    pub fn cooled(&self, since: Millis) -> Soak {
        if self.hotter_k.is_some_and(|h| h <= self.s.form_end_k) {
            Soak::Go
        } else if self.now.seconds_since(since).s() > self.s.form_timeout_s {
            Soak::GiveUp
        } else {
            Soak::Wait
        }
    }

    /// Log `kind` now.
    pub fn event(&mut self, kind: EventKind) {
        self.events.push(self.now, kind);
    }

    /// Say `w` on the console (`# warning: …`) and log it.
    pub fn warn(&mut self, w: Warning) {
        self.events.push(self.now, EventKind::Warning(w));
        *self.notice = Some(Notice::Warning(w));
    }

    /// Say `n` on the console (`# {n}`), unlogged (the caller logs what the `log` keeps).
    pub fn announce(&mut self, n: Notice) {
        *self.notice = Some(n);
    }

    /// The estimated wall is soft: its frozen fraction at most `soft_frozen_max`.
    pub fn soft(&self) -> bool {
        self.estimate.frozen <= self.s.soft_frozen_max
    }

    /// Readiness by softness: Go once the wall is soft. `soft_warn_s` into the mode with the
    /// wall not soft yet, the model's best steady state (the film at the cascade's ceiling,
    /// `heater_cap_k − heater_cap_band_k`) decides: above `soft_frozen_max` the soak ends now
    /// with a warning ([`Warning::CannotSoften`]); otherwise a warning says how far it is
    /// ([`Warning::SoakSlow`], once: `warned`) and the soak goes on to `soak_timeout_s`.
    pub fn softened(&mut self, warned: &mut bool) -> Soak {
        if self.soft() {
            return Soak::Go;
        }
        let s = self.s;
        if !*warned && self.now.seconds_since(self.mode_since).s() >= s.soft_warn_s {
            *warned = true;
            let best = self.observer.softest(s.heater_cap_k - s.heater_cap_band_k);
            let e = *self.estimate;
            if best.frozen > s.soft_frozen_max {
                self.warn(Warning::CannotSoften {
                    frozen: e.frozen,
                    best: best.frozen,
                    film_k: best.film_k,
                    ambient_k: e.ambient_k,
                });
                return Soak::GiveUp;
            }
            self.warn(Warning::SoakSlow {
                frozen: e.frozen,
                inner_k: e.layers_k[0],
                best: best.frozen,
                ambient_k: e.ambient_k,
            });
        }
        if self.soak_timed_out() {
            Soak::GiveUp
        } else {
            Soak::Wait
        }
    }

    /// Of `springs`, the ones the temperature band drives now: a spring is on while its
    /// estimate is below `top_k`; once off it comes on again below `top_k − spring_band_k`.
    pub fn band(&self, springs: SpringMask, top_k: f32) -> SpringMask {
        let bits = (0..SPRINGS)
            .filter(|&i| springs.contains(i))
            .filter(|&i| {
                let t = self.estimate.springs_k[i];
                let limit = if self.last_springs.contains(i) {
                    top_k
                } else {
                    top_k - self.s.spring_band_k
                };
                t < limit
            })
            .fold(0u8, |b, i| b | 1 << i);
        SpringMask::from_bits(bits)
    }

    /// Spring `i` has rested: its estimated austenite fraction is at most `spring_rest`, or
    /// it has cooled to within 3 K of the estimated ambient (on a day too warm for martensite
    /// it can do no more).
    pub fn rested(&self, i: usize) -> bool {
        let e = self.estimate;
        e.austenite[i] <= self.s.spring_rest || e.springs_k[i] <= e.ambient_k + 3.0
    }

    /// Every spring has rested ([`Ctx::rested`]).
    pub fn all_rested(&self) -> bool {
        (0..SPRINGS).all(|i| self.rested(i))
    }
}

/// Seconds to whole milliseconds (rounded).
pub(super) fn ms(seconds: f32) -> u32 {
    (seconds * 1000.0 + 0.5) as u32
}
