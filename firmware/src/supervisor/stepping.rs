//! Modes 1 and 2, small and large stepping: soak until the estimated wall is soft, rest the
//! springs if they are still austenite, pre-warm them (`spring_prewarm_k`, raised on a cold
//! day: `Settings::prewarm_k`), then the stepping phases with pulses between, then hold. Every
//! spring phase drives each selected spring by its estimated temperature: full current below
//! the band, switched at the control period's rate to hold it (`spring_hot_k`,
//! `spring_band_k`).

use super::events::EventKind;
use super::mode::{Ctx, Drive, ModeStep, Next, PauseError, Soak, ms};
use crate::outputs::{SPRINGS, SpringMask};
use crate::settings::Settings;
use crate::units::Millis;

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
    /// Heating until the estimated wall is soft (frozen fraction ≤ `soft_frozen_max`).
    Soak {
        /// The `soft_warn_s` warning has been given.
        warned: bool,
    },
    /// The soak is done but a spring is still austenite from an earlier cycle: holding
    /// `hot_k` with the springs off until every spring has rested by its estimate (a passive
    /// spring that is still austenite would hold the column against the stepping).
    Rest,
    /// The springs' pre-warm: each selected spring driven to `spring_prewarm_k` (below its
    /// transformation, so the first stepping phase loads as the thesis's did), in pulses of at most
    /// `prewarm_s` with `prewarm_gap_s` off after each (which also ends the continuous
    /// on-time), until every selected spring is warm.
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
    /// Done: holding `hot_k` and the bend the stepping reached, each selected spring held in
    /// its band below `spring_k`.
    Hold {
        /// The springs' band top, K: the hottest selected spring's estimate when the last
        /// stepping phase ended (at most `spring_hot_k`), so the hold keeps the springs as the
        /// stepping left them — no hotter, which would change how forming's cooling locks the
        /// bend.
        spring_k: f32,
    },
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

impl Stepping {
    /// A new stepping of `kind` driving `springs`: it starts with a fresh soak (from a hold at
    /// hot_k a new step still waits the dwell).
    pub fn new(kind: StepKind, springs: SpringMask) -> Stepping {
        Stepping {
            kind,
            springs,
            phase: StepPhase::Soak { warned: false },
            paused: false,
            idle_since: None,
        }
    }

    /// Pause (springs off, timer held) or resume; `Err` with the reason where it means nothing.
    pub fn pause(&mut self, pause: bool) -> Result<(), PauseError> {
        let in_spring_phase = match self.phase {
            StepPhase::Prewarm { .. } | StepPhase::Spring { .. } | StepPhase::Pulse { .. } => true,
            StepPhase::Soak { .. } | StepPhase::Rest | StepPhase::Hold { .. } => false,
        };
        match (pause, self.paused) {
            (true, true) => Err(PauseError::AlreadyPaused),
            (false, false) => Err(PauseError::NotPaused),
            // Pause holds a spring phase's timer; soak, rest and hold have none.
            (true, false) if !in_spring_phase => Err(PauseError::NotInSpringPhase),
            (p, _) => {
                self.paused = p;
                Ok(())
            }
        }
    }

    /// One step of the stepping.
    pub(super) fn advance(&mut self, c: &mut Ctx) -> ModeStep {
        let s = c.s;
        let now = c.now;
        let run_ms = if self.paused { 0 } else { c.elapsed_ms };
        let mut next = None;
        match &mut self.phase {
            StepPhase::Soak { warned } => {
                let mut go = c.softened(warned);
                // A spring whose on-time a gap has not yet cleared (a mode changed straight
                // from its phase) waits: it would trip the on-time limit.
                let cleared = (0..SPRINGS)
                    .all(|i| !self.springs.contains(i) || c.safety.spring_on_s(i) == 0.0);
                if matches!(go, Soak::Go) && !cleared {
                    go = Soak::Wait;
                }
                match go {
                    Soak::Go if !c.all_rested() => {
                        c.event(EventKind::SpringsResting);
                        self.phase = StepPhase::Rest;
                    }
                    Soak::Go => self.phase = first_spring_phase(&s),
                    Soak::GiveUp => next = Some(Next::GiveUp("soak")),
                    Soak::Wait => {}
                }
            }
            StepPhase::Rest => {
                if c.all_rested() {
                    self.phase = first_spring_phase(&s);
                }
            }
            StepPhase::Prewarm { on, left_ms } => {
                *left_ms = left_ms.saturating_sub(run_ms);
                // A pulse ends once every selected spring has reached its pre-warm
                // temperature; after the gap the stepping goes on if every one is still in
                // the band below it.
                let at = |floor_k: f32| {
                    (0..SPRINGS)
                        .all(|i| !self.springs.contains(i) || c.estimate.springs_k[i] >= floor_k)
                };
                let prewarm_k = s.prewarm_k(c.estimate.ambient_k);
                if *on && at(prewarm_k) && !self.paused {
                    *left_ms = 0;
                }
                let warm = at(prewarm_k - s.spring_band_k);
                if *left_ms == 0 {
                    // After a gap, another pulse if a spring is not yet warm (a cold day: one
                    // `prewarm_s` pulse, bounded by the on-time limit, is not enough).
                    self.phase = if *on {
                        StepPhase::Prewarm {
                            on: false,
                            left_ms: ms(s.prewarm_gap_s).max(1),
                        }
                    } else if !warm {
                        StepPhase::Prewarm {
                            on: true,
                            left_ms: ms(s.prewarm_s).max(1),
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
                    let steps = match self.kind {
                        StepKind::Small => 1,
                        StepKind::Large => s.large_steps,
                    };
                    self.phase = if *index + 1 >= steps {
                        c.event(EventKind::SteppingDone);
                        let reached = (0..SPRINGS)
                            .filter(|&i| self.springs.contains(i))
                            .map(|i| c.estimate.springs_k[i])
                            .fold(f32::MIN, f32::max);
                        StepPhase::Hold {
                            spring_k: reached.min(s.spring_hot_k),
                        }
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
                    self.phase = StepPhase::Spring {
                        index: *index,
                        left_ms: ms(s.step_s),
                    };
                }
            }
            StepPhase::Hold { .. } => {}
        }
        // Hold and pause hold hot_k with nothing to run: an idle timeout ends them in standby.
        // (Rest ends by the springs' estimate: martensite, or as cool as the ambient allows.)
        let idle = self.paused || matches!(self.phase, StepPhase::Hold { .. });
        if !idle {
            self.idle_since = None;
        } else if now.seconds_since(*self.idle_since.get_or_insert(now)).s() > s.hold_timeout_s {
            next = Some(Next::GiveUp("hold"));
        }
        let springs = if self.paused {
            SpringMask::NONE
        } else {
            match self.phase {
                StepPhase::Spring { .. } => c.band(self.springs, s.spring_hot_k),
                StepPhase::Prewarm { on: true, .. } => {
                    // A spring near its duty limit sits a pre-warm pulse out (the duty check would
                    // otherwise latch on a long cold-day pre-warm).
                    let band = c.band(self.springs, s.prewarm_k(c.estimate.ambient_k));
                    SpringMask::from_bits(band.bits() & c.safety.duty_room(&s).bits())
                }
                // The hold keeps the bend the stepping reached: the springs held in their band
                // (a spring left to cool reverts and the soft wall lets the column relax: 64 →
                // 37° over a 2.5-minute hold), any near its duty limit, or whose continuous
                // on-time another period would take past its limit, sitting out.
                StepPhase::Hold { spring_k } => {
                    let band = c.band(self.springs, spring_k);
                    let room = c.safety.duty_room(&s);
                    let period_s = c.elapsed_ms.max(1) as f32 * 1e-3;
                    let bits = (0..SPRINGS)
                        .filter(|&i| band.contains(i) && room.contains(i))
                        .filter(|&i| c.safety.spring_may_run(i, period_s, &s))
                        .fold(0u8, |b, i| b | 1 << i);
                    SpringMask::from_bits(bits)
                }
                StepPhase::Soak { .. }
                | StepPhase::Rest
                | StepPhase::Prewarm { on: false, .. }
                | StepPhase::Pulse { .. } => SpringMask::NONE,
            }
        };
        ModeStep {
            drive: Drive::Hold(s.hot_k),
            springs,
            next,
        }
    }
}
