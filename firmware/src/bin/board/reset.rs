//! Why the chip started, from RCC_CSR's reset flags: the pure part of `retained`, so the host
//! tests can check it.
//!
//! Any internal reset also drives the NRST pin low, so PINRSTF comes with the watchdogs' and the
//! software reset's flags; it means the reset pin (the board's reset button, the probe) only
//! when no other flag is set. A power-up sets BORRSTF with PORRSTF, so PORRSTF is looked at
//! first.

use thermorph::supervisor::ResetCause;

/// RCC_CSR's reset flags (RM0390 6.3.21).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Flags {
    /// PORRSTF: power-on or power-down reset.
    pub power_on: bool,
    /// BORRSTF: brown-out (also set by a power-on).
    pub brown_out: bool,
    /// IWDGRSTF: the independent watchdog.
    pub independent_watchdog: bool,
    /// WWDGRSTF: the window watchdog.
    pub window_watchdog: bool,
    /// SFTRSTF: a software reset (SYSRESETREQ: the fault handlers, a debugger).
    pub software: bool,
    /// PINRSTF: NRST went low (with any internal reset too).
    pub pin: bool,
    /// LPWRRSTF: low-power management (entering Stop or Standby with the option bytes'
    /// reset).
    pub low_power: bool,
}

impl Flags {
    /// Return why the chip started.
    pub fn cause(self) -> ResetCause {
        if self.power_on {
            ResetCause::PowerUp
        } else if self.brown_out {
            ResetCause::BrownOut
        } else if self.independent_watchdog || self.window_watchdog {
            ResetCause::Watchdog
        } else if self.software {
            ResetCause::Software
        } else if self.pin && !self.low_power {
            ResetCause::Pin
        } else {
            ResetCause::Unknown
        }
    }

    /// Return whether RAM kept its contents: any reset but a power-up or a brown-out.
    pub fn ram_kept(self) -> bool {
        !(self.power_on || self.brown_out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PIN: Flags = Flags {
        power_on: false,
        brown_out: false,
        independent_watchdog: false,
        window_watchdog: false,
        software: false,
        pin: true,
        low_power: false,
    };

    #[test]
    fn each_reset_as_the_chip_flags_it() {
        let power_up = Flags {
            power_on: true,
            brown_out: true,
            ..PIN
        };
        assert_eq!(power_up.cause(), ResetCause::PowerUp);
        assert!(!power_up.ram_kept());
        let brown_out = Flags {
            brown_out: true,
            ..PIN
        };
        assert_eq!(brown_out.cause(), ResetCause::BrownOut);
        assert!(!brown_out.ram_kept());
        for watchdog in [
            Flags {
                independent_watchdog: true,
                ..PIN
            },
            Flags {
                window_watchdog: true,
                ..PIN
            },
        ] {
            assert_eq!(watchdog.cause(), ResetCause::Watchdog);
            assert!(watchdog.ram_kept());
        }
        let software = Flags {
            software: true,
            ..PIN
        };
        assert_eq!(software.cause(), ResetCause::Software);
        assert_eq!(PIN.cause(), ResetCause::Pin);
        assert!(PIN.ram_kept());
    }

    #[test]
    fn the_pin_means_the_pin_only_alone() {
        let low_power = Flags {
            low_power: true,
            ..PIN
        };
        assert_eq!(low_power.cause(), ResetCause::Unknown);
        assert_eq!(Flags::default().cause(), ResetCause::Unknown);
        assert!(Flags::default().ram_kept());
    }
}
