//! Mode 0, standby: hold `standby_k` (323 K, never above), springs off. The idle state: it has
//! no timeout.

use super::mode::{Ctx, ModeStep};

/// One step of standby.
pub(super) fn advance(c: &Ctx) -> ModeStep {
    ModeStep::hold(c.s.standby_k)
}
