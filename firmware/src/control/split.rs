//! Heater and fan on one temperature: a split range of one loop output.
//!
//! One PID (output in [−1, 1]) owns the temperature; its output is split so the heater takes the
//! positive side and the fan the negative side, with a dead band around 0 where both are off:
//!
//! ```text
//!  duty
//!   1 ┤ fan                                   heater
//!     │   ╲                                     ╱
//!     │     ╲                                 ╱
//!     │       ╲                             ╱
//!   0 ┼─────────╲───────────┬─────────────╱──────────
//!    −1         −b          0             +b        +1   u
//! ```
//!
//! `heater = (u − b)/(1 − b)` for `u > b`, `fan = (−u − b)/(1 − b)` for `u < −b`, both 0 in
//! between. Both are never on at once because a single `u` can only be on one side; the dead
//! band keeps noise around a held target from toggling the fan against the heater. Two loops
//! would need a gap between their targets and could still both act during a transient; the
//! split range cannot. (Forming runs the fan with the heater off by a mode rule, outside this
//! mapping.)

use crate::outputs::Duty;

/// Heater and fan duty from one loop output.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct HeatCool {
    /// Heater duty.
    pub heater: Duty,
    /// Fan duty.
    pub fan: Duty,
}

/// The split-range mapping with its dead band.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitRange {
    dead_band: f32,
}

impl SplitRange {
    /// Largest dead band accepted (a band of 1 would leave nothing to drive).
    pub const MAX_DEAD_BAND: f32 = 0.5;

    /// Make a split range with half-width `dead_band` of loop output in which both are off,
    /// clamped to [0, [`SplitRange::MAX_DEAD_BAND`]]; NaN gives 0.
    pub fn new(dead_band: f32) -> SplitRange {
        let dead_band = if dead_band.is_nan() {
            0.0
        } else {
            dead_band.clamp(0.0, Self::MAX_DEAD_BAND)
        };
        SplitRange { dead_band }
    }

    /// Return the dead band's half-width.
    pub fn dead_band(&self) -> f32 {
        self.dead_band
    }

    /// Map a loop output `u` (clamped to [−1, 1]; NaN gives both off) to the two duties.
    pub fn apply(&self, u: f32) -> HeatCool {
        if u.is_nan() {
            return HeatCool::default();
        }
        let u = u.clamp(-1.0, 1.0);
        let b = self.dead_band;
        let scale = 1.0 / (1.0 - b);
        if u > b {
            HeatCool {
                heater: Duty::from_fraction((u - b) * scale),
                fan: Duty::OFF,
            }
        } else if u < -b {
            HeatCool {
                heater: Duty::OFF,
                fan: Duty::from_fraction((-u - b) * scale),
            }
        } else {
            HeatCool::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// xorshift64*: a small deterministic generator for the property tests.
    struct Rng(u64);
    impl Rng {
        fn next_u64(&mut self) -> u64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
        }
        /// Any f32 bit pattern half the time (NaN, ±inf, subnormals, huge), else in [−2, 2].
        fn any_f32(&mut self) -> f32 {
            let r = self.next_u64();
            if r & 1 == 0 {
                f32::from_bits((r >> 32) as u32)
            } else {
                ((r >> 40) as f32 / (1u64 << 24) as f32) * 4.0 - 2.0
            }
        }
    }

    #[test]
    fn heater_and_fan_never_fight() {
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        let mut seen = [0usize; 3]; // heater on, fan on, both off
        for _ in 0..200_000 {
            let s = SplitRange::new(rng.any_f32());
            let u = rng.any_f32();
            let hc = s.apply(u);
            let (h, f) = (hc.heater.fraction(), hc.fan.fraction());
            assert!(
                !(h > 0.0 && f > 0.0),
                "both on for u={u} band={}",
                s.dead_band()
            );
            assert!((0.0..=1.0).contains(&h) && (0.0..=1.0).contains(&f));
            seen[if h > 0.0 {
                0
            } else if f > 0.0 {
                1
            } else {
                2
            }] += 1;
        }
        // The generator reached all three regions, so the property was exercised.
        assert!(seen.iter().all(|&n| n > 1000), "{seen:?}");
    }

    #[test]
    fn mapping_is_continuous_and_reaches_full_scale() {
        let s = SplitRange::new(0.05);
        assert_eq!(s.apply(1.0).heater, Duty::FULL);
        assert_eq!(s.apply(-1.0).fan, Duty::FULL);
        assert_eq!(s.apply(0.05), HeatCool::default());
        assert_eq!(s.apply(-0.05), HeatCool::default());
        assert_eq!(s.apply(f32::NAN), HeatCool::default());
        let h = s.apply(0.525).heater.fraction();
        assert!((h - 0.5).abs() < 1e-6, "{h}");
        let f = s.apply(-0.525).fan.fraction();
        assert!((f - 0.5).abs() < 1e-6, "{f}");
        // Continuity at the band edges: a small step in u gives a small step in duty.
        for edge in [0.05f32, -0.05] {
            let a = s.apply(edge * 1.001);
            let b = s.apply(edge * 0.999);
            assert!((a.heater.fraction() - b.heater.fraction()).abs() < 1e-3);
            assert!((a.fan.fraction() - b.fan.fraction()).abs() < 1e-3);
        }
    }
}
