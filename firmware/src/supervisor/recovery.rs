//! Mode 4, recovery: reheat to `hot_k` while every spring is driven to its temperature band
//! (so all three reach austenite together), pulse them all once the wall is soft, hold, then
//! cool as forming does with the springs still held in their band, so the column locks
//! straight.

use super::events::EventKind;
use super::mode::{Ctx, Drive, ModeStep, Next, Soak, ms};
use super::safety::Safety;
use crate::outputs::{SPRINGS, SpringMask};
use crate::settings::Settings;
use crate::units::Millis;

/// Where recovery is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RecoverPhase {
    /// Heating to `hot_k` (as stepping's soak) while the springs are driven to their band.
    /// Ends once the estimated wall is soft and every spring's estimated austenite fraction
    /// has reached `spring_recover`.
    Heat {
        /// The `soft_warn_s` warning has been given.
        warned: bool,
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
/// Throughout recovery the springs are driven in windows of `recover_on_s` on and
/// `recover_off_s` off (within the on-time limit), each by its estimated temperature to the
/// band (`spring_hot_k`): the colder ones run longer, so all three reach austenite together,
/// and none passes the band. Three austenite springs pull the soft column straight together;
/// a spring that stayed austenite from the stepping would otherwise hold the bend (in still
/// air it takes minutes to turn martensite again), and the stored strain's release alone
/// cannot undo that.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Recovering {
    /// Where recovery is.
    pub phase: RecoverPhase,
    /// In a window where springs may be on.
    pub window_on: bool,
    /// Time left in the window, ms.
    pub window_left_ms: u32,
}

impl Recovering {
    /// Recovery from its start: heating, in an on window.
    pub fn new(s: &Settings) -> Recovering {
        Recovering {
            phase: RecoverPhase::Heat { warned: false },
            window_on: true,
            window_left_ms: ms(s.recover_on_s).max(1),
        }
    }

    /// One step of recovery.
    pub(super) fn advance(&mut self, c: &mut Ctx) -> ModeStep {
        let s = c.s;
        let now = c.now;
        // A spring near its duty limit, or whose on-time what is left of the window would
        // take past the limit, sits the window out.
        let may_run = |safety: &Safety, left_ms: u32| -> SpringMask {
            let room = safety.duty_room(&s);
            let bits = (0..SPRINGS)
                .filter(|&i| {
                    room.contains(i) && safety.spring_may_run(i, left_ms as f32 * 1e-3, &s)
                })
                .fold(0u8, |b, i| b | 1 << i);
            SpringMask::from_bits(bits)
        };
        self.window_left_ms = self.window_left_ms.saturating_sub(c.elapsed_ms);
        if self.window_left_ms == 0 {
            self.window_on = !self.window_on;
            self.window_left_ms = ms(if self.window_on {
                s.recover_on_s
            } else {
                s.recover_off_s
            })
            .max(1);
        }
        let balanced = (0..SPRINGS).all(|i| c.estimate.austenite[i] >= s.spring_recover);
        let mut next = None;
        match &mut self.phase {
            RecoverPhase::Heat { warned } => {
                let go = c.softened(warned);
                // The pulse runs inside an on window (it fits in what is left of it), so a
                // spring's continuous on-time stays within the window's.
                let pulse_fits = self.window_on
                    && self.window_left_ms >= ms(s.recover_pulse_s)
                    && may_run(c.safety, self.window_left_ms) == SpringMask::ALL;
                match go {
                    Soak::Go if balanced && pulse_fits => {
                        self.phase = RecoverPhase::Pulse {
                            left_ms: ms(s.recover_pulse_s),
                        }
                    }
                    Soak::GiveUp => next = Some(Next::GiveUp("reheat")),
                    // Soft but the springs not yet austenite: the heat phase still ends by
                    // soak_timeout_s.
                    Soak::Go | Soak::Wait if c.soak_timed_out() => {
                        next = Some(Next::GiveUp("reheat"))
                    }
                    Soak::Go | Soak::Wait => {}
                }
            }
            RecoverPhase::Pulse { left_ms } => {
                *left_ms = left_ms.saturating_sub(c.elapsed_ms);
                if *left_ms == 0 {
                    self.phase = RecoverPhase::Hold {
                        left_ms: ms(s.recover_hold_s),
                    };
                }
            }
            RecoverPhase::Hold { left_ms } => {
                *left_ms = left_ms.saturating_sub(c.elapsed_ms);
                if *left_ms == 0 {
                    self.phase = RecoverPhase::Cool { since: now };
                    c.event(EventKind::RecoveryCooling);
                }
            }
            RecoverPhase::Cool { since } => match c.cooled(*since) {
                Soak::Go => next = Some(Next::Enter(super::mode::Mode::Standby)),
                Soak::GiveUp => next = Some(Next::GiveUp("recover")),
                Soak::Wait => {}
            },
        }
        let allowed = may_run(c.safety, self.window_left_ms);
        let in_band = c.band(SpringMask::ALL, s.spring_hot_k);
        let springs = match self.phase {
            RecoverPhase::Pulse { .. } => SpringMask::from_bits(in_band.bits() & allowed.bits()),
            RecoverPhase::Heat { .. } | RecoverPhase::Hold { .. } | RecoverPhase::Cool { .. }
                if self.window_on =>
            {
                SpringMask::from_bits(in_band.bits() & allowed.bits())
            }
            RecoverPhase::Heat { .. } | RecoverPhase::Hold { .. } | RecoverPhase::Cool { .. } => {
                SpringMask::NONE
            }
        };
        let drive = match self.phase {
            RecoverPhase::Cool { .. } => Drive::Cool,
            RecoverPhase::Heat { .. } | RecoverPhase::Pulse { .. } | RecoverPhase::Hold { .. } => {
                Drive::Hold(s.hot_k)
            }
        };
        ModeStep {
            drive,
            springs,
            next,
        }
    }
}
