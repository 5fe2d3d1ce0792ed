//! What the board comes up in after a reset (SPEC section 5): every output off unless a
//! power-up's saved `boot_mode` asks for standby.
//!
//! This module owns the reset causes and the rule. Marlin and Klipper never heat at boot; a
//! watchdog, a fault handler, a brown-out or the reset button restarting a board that was
//! heating must not resume heating unasked. So: after any reset that is not a power-up the
//! supervisor starts `stopped` and its first decision carries a `# warning: reset by …` line;
//! after a power-up it starts `stopped` too, unless `boot_mode` is 1 (standby).

use super::events::{EventKind, Notice, Warning};
use super::{Mode, SpringMemory, Supervisor};
use crate::settings::Settings;
use crate::units::Millis;

/// Why the chip started (the board reads RCC_CSR's flags; the simulator says which).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum ResetCause {
    /// Power applied (POR).
    PowerUp,
    /// The supply dipped below the brown-out level (BOR).
    BrownOut,
    /// The independent watchdog expired (the control loop stalled).
    Watchdog,
    /// A software reset: the panic or hard-fault handler (or a debugger) reset the chip.
    Software,
    /// The reset pin (the board's reset button, or the probe).
    Pin,
    /// No flag said why.
    Unknown,
}

impl ResetCause {
    /// Return its name on the console.
    pub const fn name(self) -> &'static str {
        match self {
            ResetCause::PowerUp => "power-up",
            ResetCause::BrownOut => "brown-out",
            ResetCause::Watchdog => "watchdog",
            ResetCause::Software => "a fault handler or software reset",
            ResetCause::Pin => "the reset pin",
            ResetCause::Unknown => "an unknown cause",
        }
    }
}

impl Supervisor {
    /// Start at `now` after a reset of `cause`, with `settings` (checked; invalid ones give the
    /// defaults) and the springs' memory (`None`: nothing kept, the springs assumed hot):
    /// `standby` after a power-up whose `boot_mode` is 1, `stopped` otherwise; after any reset
    /// but a power-up the first decision carries a `# warning` saying why.
    pub fn boot(
        now: Millis,
        settings: Settings,
        memory: Option<SpringMemory>,
        cause: ResetCause,
    ) -> Supervisor {
        let mut sup =
            Supervisor::with_memory(now, settings, memory.unwrap_or(SpringMemory::POWER_UP));
        let standby = cause == ResetCause::PowerUp && sup.settings.boot_mode == 1;
        if !standby {
            sup.mode = Mode::Stopped;
        }
        if cause != ResetCause::PowerUp {
            let w = Warning::Reset(cause);
            sup.events.push(now, EventKind::Warning(w));
            sup.carried = Some(Notice::Warning(w));
        }
        sup
    }
}

#[cfg(test)]
mod tests {
    use super::super::ModeId;
    use super::*;
    use crate::outputs::Outputs;

    #[test]
    fn a_power_up_stops_unless_boot_mode_asks_for_standby() {
        let mut s = Supervisor::boot(Millis(0), Settings::DEFAULT, None, ResetCause::PowerUp);
        assert_eq!(s.mode().id(), ModeId::Stopped);
        let d = s.step(Millis(50), None, None);
        assert_eq!(d.outputs, Outputs::OFF);
        assert!(d.notice.is_none());
        let standby = Settings {
            boot_mode: 1,
            ..Settings::DEFAULT
        };
        let s = Supervisor::boot(Millis(0), standby, None, ResetCause::PowerUp);
        assert_eq!(s.mode().id(), ModeId::Standby);
    }

    /// Any other reset comes up stopped whatever `boot_mode`, and says why once.
    #[test]
    fn any_other_reset_stops_and_says_why() {
        let standby = Settings {
            boot_mode: 1,
            ..Settings::DEFAULT
        };
        for cause in [
            ResetCause::Watchdog,
            ResetCause::BrownOut,
            ResetCause::Software,
            ResetCause::Pin,
            ResetCause::Unknown,
        ] {
            let mut s = Supervisor::boot(Millis(0), standby, Some(SpringMemory::RESTED), cause);
            assert_eq!(s.mode().id(), ModeId::Stopped, "{cause:?}");
            let d = s.step(Millis(50), None, None);
            assert_eq!(d.outputs, Outputs::OFF);
            let text = std::format!("{}", d.notice.expect("the reset's warning"));
            assert_eq!(
                text,
                std::format!(
                    "warning: reset by {}; every output off until a `mode` command",
                    cause.name()
                )
            );
            assert!(s.step(Millis(100), None, None).notice.is_none());
        }
    }
}
