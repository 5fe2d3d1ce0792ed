//! The springs' continuous on-time, as the safety limit counts it.
//!
//! A spring's on-time does not restart after any gap: an SMA wire switched off for half a
//! second has not cooled, so a short gap only pauses the count. An off interval *clears* the
//! count only once it has lasted at least [`OFF_MIN_S`] and at least [`OFF_RATIO`] times the
//! on-time it follows; a shorter one leaves the count where it was, and the next on interval
//! adds to it. The supervisor trips `spring-on-time` when the count passes
//! `spring_on_max_s`, and [`Settings::check`](crate::settings::Settings::check) runs the same
//! counter over every planned sequence of phases (pre-warm + gap + stepping, stepping + pulse,
//! recovery's windows), so no setting can plan a sequence the limit would stop.

/// An off interval shorter than this never clears the on-time, s.
pub const OFF_MIN_S: f32 = 1.0;
/// An off interval clears the on-time only if it is at least this fraction of it: 8 s on (the
/// default `spring_on_max_s`) need 1 s off. The default pre-warm (7 s on, 1 s off) and recovery
/// windows (7 s on, 1 s off) clear; a 6 s stepping phase with a 0.5 s pulse does not.
pub const OFF_RATIO: f32 = 0.125;

/// One spring's on-time count (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OnTimer {
    /// On-time counted since the last clearing off interval, ms.
    on_ms: u32,
    /// Length of the current off interval, ms (0 while on).
    off_ms: u32,
}

impl OnTimer {
    /// A spring that has been off long enough to be cleared.
    pub const CLEAR: OnTimer = OnTimer {
        on_ms: 0,
        off_ms: 0,
    };

    /// Make a count from its parts (on-time and current off interval, ms), e.g. restored from
    /// memory kept across a reset.
    pub const fn from_parts(on_ms: u32, off_ms: u32) -> OnTimer {
        OnTimer { on_ms, off_ms }
    }

    /// Return the on-time and the current off interval, ms.
    pub const fn parts(self) -> (u32, u32) {
        (self.on_ms, self.off_ms)
    }

    /// Account `elapsed_ms` during which the spring was `on`.
    pub fn credit(&mut self, on: bool, elapsed_ms: u32) {
        if on {
            self.on_ms = self.on_ms.saturating_add(elapsed_ms);
            self.off_ms = 0;
        } else if self.on_ms > 0 {
            self.off_ms = self.off_ms.saturating_add(elapsed_ms);
            if self.off_ms as f32 >= Self::clearing_off_ms(self.on_ms) {
                self.on_ms = 0;
                self.off_ms = 0;
            }
        }
    }

    /// The off interval that clears `on_ms` of on-time, ms.
    pub fn clearing_off_ms(on_ms: u32) -> f32 {
        (OFF_MIN_S * 1000.0).max(OFF_RATIO * on_ms as f32)
    }

    /// Return the counted on-time, s.
    pub fn on_s(self) -> f32 {
        self.on_ms as f32 * 1e-3
    }

    /// Return the counted on-time, ms.
    pub fn on_ms(self) -> u32 {
        self.on_ms
    }

    /// Run the count over `phases` (each `(on, seconds)`, in order, from a cleared spring) and
    /// return the largest on-time it reaches, s: what the limit would see if a mode ran them.
    pub fn peak_s(phases: impl IntoIterator<Item = (bool, f32)>) -> f32 {
        let mut t = OnTimer::CLEAR;
        let mut peak = 0u32;
        for (on, s) in phases {
            // As the supervisor times its phases: in whole ms, at least 1 ms.
            let ms = ((s.max(0.0) * 1000.0 + 0.5) as u32).max(1);
            t.credit(on, ms);
            peak = peak.max(t.on_ms);
        }
        peak as f32 * 1e-3
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_short_gap_pauses_the_count_and_a_long_one_clears_it() {
        let mut t = OnTimer::CLEAR;
        t.credit(true, 6000);
        t.credit(false, 500);
        assert_eq!(t.on_ms(), 6000, "0.5 s off is shorter than the 1 s minimum");
        t.credit(true, 3000);
        assert_eq!(t.on_ms(), 9000);
        // 9 s on need max(1 s, 1.125 s) off.
        t.credit(false, 1100);
        assert_eq!(t.on_ms(), 9000);
        t.credit(false, 25);
        assert_eq!(t.on_ms(), 0);
        // Gaps add up only within one off interval.
        t.credit(true, 2000);
        t.credit(false, 900);
        t.credit(true, 50);
        t.credit(false, 900);
        assert_eq!(t.on_ms(), 2050);
    }

    #[test]
    fn the_console_attack_of_the_safety_review_is_counted_whole() {
        // step_s 8, pulse_s 0.5, ten steps: one continuous on-time of 80 s.
        let phases = (0..10).flat_map(|_| [(true, 8.0), (false, 0.5)]);
        assert_eq!(OnTimer::peak_s(phases), 80.0);
        // The defaults: pre-warm 7 s, gap 1 s, four 6 s phases with 2 s pulses.
        let mut p = vec![(true, 7.0), (false, 1.0)];
        for _ in 0..4 {
            p.extend([(true, 6.0), (false, 2.0)]);
        }
        assert!((OnTimer::peak_s(p) - 7.0).abs() < 1e-6);
    }
}
