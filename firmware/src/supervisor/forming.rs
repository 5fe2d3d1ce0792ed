//! Mode 3, forming: heater off, fan at `form_fan`, until the hotter target is at `form_end_k`
//! (the lattice locks in the shape the springs gave it), then standby.

use super::mode::{Ctx, Drive, Mode, ModeStep, Next, Soak};
use crate::outputs::SpringMask;
use crate::units::Millis;

/// Forming's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Forming {
    /// When forming started (its `form_timeout_s` counts from here).
    pub since: Millis,
}

impl Forming {
    /// Forming from `now`.
    pub fn new(now: Millis) -> Forming {
        Forming { since: now }
    }

    /// One step of forming.
    pub(super) fn advance(&mut self, c: &mut Ctx) -> ModeStep {
        let next = match c.cooled(self.since) {
            Soak::Go => Some(Next::Enter(Mode::Standby)),
            Soak::GiveUp => Some(Next::GiveUp("form")),
            Soak::Wait => None,
        };
        ModeStep {
            drive: Drive::Cool,
            springs: SpringMask::NONE,
            next,
        }
    }
}
