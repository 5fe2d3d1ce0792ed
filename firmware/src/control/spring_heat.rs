//! The springs' heat estimate: the controller's model of how warm each SMA spring is, built from
//! its own switching history alone (nothing on the board senses a spring's temperature or
//! current, and the camera does not resolve the 2.3 mm wire).
//!
//! Each spring carries a normalised heat `h`: 0 is a spring at room temperature, 1 the heat a
//! spring takes at full current to go from room temperature through its transformation to
//! austenite (`spring_heat_s` of on-time). Switched on, `dh/dt = 1/heat_s`; always, still air
//! takes `dh/dt = −h/cool_s`. For an input held over a step the update is exact:
//! `h ← h·e^(−Δt/τ) + (τ/heat_s)·(1 − e^(−Δt/τ))` while on, `h·e^(−Δt/τ)` while off.
//!
//! Two constants make the model, like a heater's PID gains: the defaults are fitted to the
//! simulated block (`host-sim`'s `closed_loop` test checks the estimate against the plant's
//! phase fractions) and belong re-measured on a new spring. The supervisor uses it to:
//! - balance the springs in recovery: drive the coldest first so that all three reach
//!   austenite together ([`SpringHeat::balance`]), which pulls the soft column straight;
//! - let the springs rest before a new stepping, so a passive spring is martensite again
//!   ([`SpringHeat::rested`]).
//!
//! After a power-up nothing is known of the springs, so the estimate starts hot
//! ([`SpringHeat::POWER_UP`]: every spring just austenite) and a first stepping waits in `rest`
//! until the model has cooled them; across a reset that keeps RAM the board restores the
//! estimate it had ([`crate::supervisor::SpringMemory`]).

use crate::outputs::{SPRINGS, SpringMask};
use crate::units::Seconds;

/// Heat estimates of springs A, B and C (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpringHeat {
    h: [f32; SPRINGS],
    /// Reached austenite (h ≥ 1) and not yet cooled back below [`MARTENSITE_AGAIN`].
    austenite: [bool; SPRINGS],
}

/// The heat estimate below which a spring that was austenite counts as martensite again: the
/// transformation back is hysteretic (it starts only below Ms, and its latent heat holds the
/// wire there), so a spring cooling from austenite stays austenite down to h ≈ 0.7 (still
/// holding its latent heat at Ms) and is martensite by h ≈ 0.2 (Mf); 0.45 is the middle.
pub const MARTENSITE_AGAIN: f32 = 0.45;

/// The level ([`SpringHeat::level`]) a spring still austenite from earlier counts as, whatever
/// its estimate: cooling from austenite it gives back only its narrow (R-phase-like) share of
/// the stroke before Ms, about a quarter, so it pulls as a spring heated to ≈3/4 of the way.
pub const AUSTENITE_KEPT: f32 = 0.9;

impl Default for SpringHeat {
    fn default() -> Self {
        SpringHeat::COLD
    }
}

impl SpringHeat {
    /// Every spring at room temperature.
    pub const COLD: SpringHeat = SpringHeat {
        h: [0.0; SPRINGS],
        austenite: [false; SPRINGS],
    };

    /// Every spring just austenite: what a power-up assumes (a spring may have been driven
    /// until the moment the power went).
    pub const POWER_UP: SpringHeat = SpringHeat {
        h: [1.0; SPRINGS],
        austenite: [true; SPRINGS],
    };

    /// Make an estimate from its parts (heats and austenite latches), e.g. restored from memory
    /// kept across a reset. Non-finite heats become 1 (hot), negative ones 0.
    pub fn from_parts(h: [f32; SPRINGS], austenite: [bool; SPRINGS]) -> SpringHeat {
        SpringHeat {
            h: h.map(|x| if x.is_finite() { x.max(0.0) } else { 1.0 }),
            austenite,
        }
    }

    /// Return the heats and austenite latches (see [`SpringHeat::from_parts`]).
    pub fn parts(&self) -> ([f32; SPRINGS], [bool; SPRINGS]) {
        (self.h, self.austenite)
    }

    /// Account `dt` with `on` switched on. `heat_s` and `cool_s` are the model's constants,
    /// s; a non-finite or non-positive time or constant leaves the estimate as it was.
    pub fn update(&mut self, on: SpringMask, dt: Seconds, heat_s: f32, cool_s: f32) {
        let dt_s = dt.s();
        let valid = |x: f32| x > 0.0 && x.is_finite();
        if !(valid(dt_s) && valid(heat_s) && valid(cool_s)) {
            return;
        }
        let decay = libm::expf(-dt_s / cool_s);
        let gain = cool_s / heat_s * (1.0 - decay);
        for (i, h) in self.h.iter_mut().enumerate() {
            *h *= decay;
            if on.contains(i) {
                *h += gain;
            }
            if *h >= 1.0 {
                self.austenite[i] = true;
            } else if *h <= MARTENSITE_AGAIN {
                self.austenite[i] = false;
            }
        }
    }

    /// Spring `i`'s heat estimate (1: austenite reached); 0 for an index past the springs.
    pub fn heat(&self, i: usize) -> f32 {
        self.h.get(i).copied().unwrap_or(0.0)
    }

    /// Spring `i` reached austenite and has not cooled back to martensite since.
    pub fn is_austenite(&self, i: usize) -> bool {
        self.austenite.get(i).copied().unwrap_or(false)
    }

    /// Spring `i`'s level for balancing: its heat estimate, but at least `AUSTENITE_KEPT`
    /// while it is still austenite.
    pub fn level(&self, i: usize) -> f32 {
        let h = self.heat(i);
        if self.is_austenite(i) {
            h.max(AUSTENITE_KEPT)
        } else {
            h
        }
    }

    /// Every spring's estimate is at least `target`.
    pub fn all_at(&self, target: f32) -> bool {
        self.h.iter().all(|&h| h >= target)
    }

    /// Every spring's estimate is at most `rest` (a fraction of the heat to austenite).
    pub fn rested(&self, rest: f32) -> bool {
        self.h.iter().all(|&h| h <= rest)
    }

    /// The springs to drive so that all reach `target` together. While some spring's
    /// [`level`](Self::level) is below `AUSTENITE_KEPT`: those within `band` of the lowest
    /// level — the coldest spring starts alone and the others join as it catches up
    /// (water-filling), a spring still austenite from earlier waits. Then all three together
    /// while any estimate is below `target`: equal heat from there on, so no spring stops while
    /// the others still pull harder.
    pub fn balance(&self, target: f32, band: f32) -> SpringMask {
        if self.h.iter().all(|&h| h >= target) {
            return SpringMask::NONE;
        }
        let lowest = (0..SPRINGS)
            .map(|i| self.level(i))
            .fold(f32::INFINITY, f32::min);
        if lowest >= AUSTENITE_KEPT {
            return SpringMask::ALL;
        }
        let mut bits = 0u8;
        for i in 0..SPRINGS {
            if self.level(i) <= lowest + band {
                bits |= 1 << i;
            }
        }
        SpringMask::from_bits(bits)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEAT_S: f32 = 27.0;
    const COOL_S: f32 = 240.0;

    fn run(est: &mut SpringHeat, on: SpringMask, seconds: f32, dt_s: f32) {
        let n = (seconds / dt_s).round() as u32;
        for _ in 0..n {
            est.update(on, Seconds::new(dt_s).unwrap(), HEAT_S, COOL_S);
        }
    }

    #[test]
    fn matches_the_closed_form_whatever_the_step() {
        // On for 30 s from cold: h = τ/heat_s·(1 − e^(−30/τ)).
        let want = COOL_S / HEAT_S * (1.0 - libm::expf(-30.0 / COOL_S));
        for dt in [0.01, 0.25, 1.0, 30.0] {
            let mut e = SpringHeat::COLD;
            run(&mut e, SpringMask::from_bits(1), 30.0, dt);
            assert!((e.heat(0) - want).abs() < 1e-4, "{dt}: {}", e.heat(0));
            assert_eq!(e.heat(1), 0.0);
        }
        // Then off for one time constant: e^-1 of it.
        let mut e = SpringHeat::COLD;
        run(&mut e, SpringMask::ALL, 30.0, 0.25);
        run(&mut e, SpringMask::NONE, COOL_S, 0.25);
        assert!((e.heat(2) - want / core::f32::consts::E).abs() < 1e-4);
    }

    #[test]
    fn bad_times_change_nothing() {
        let mut e = SpringHeat::COLD;
        run(&mut e, SpringMask::ALL, 10.0, 0.5);
        let before = e;
        // (A NaN time cannot be passed: `Seconds` refuses it.)
        assert_eq!(Seconds::new(f32::NAN), None);
        for dt in [0.0, -1.0, f32::INFINITY] {
            e.update(SpringMask::ALL, Seconds::new(dt).unwrap(), HEAT_S, COOL_S);
        }
        e.update(SpringMask::ALL, Seconds::lit(1.0), 0.0, COOL_S);
        e.update(SpringMask::ALL, Seconds::lit(1.0), HEAT_S, f32::NAN);
        assert_eq!(e, before);
        assert_eq!(e.heat(7), 0.0);
    }

    #[test]
    fn balancing_brings_every_spring_to_austenite_together() {
        // A and B warm from a stepping, C cold.
        let mut e = SpringHeat::COLD;
        run(&mut e, SpringMask::from_bits(0b011), 20.0, 0.25);
        assert_eq!(e.balance(1.0, 0.05), SpringMask::from_bits(0b100));
        let mut t = 0.0;
        let mut joined = None;
        while !e.all_at(1.0) && t < 120.0 {
            let on = e.balance(1.0, 0.05);
            if joined.is_none() && on.contains(0) {
                joined = Some(t);
            }
            e.update(on, Seconds::lit(0.25), HEAT_S, COOL_S);
            t += 0.25;
        }
        assert!(e.all_at(1.0), "{e:?}");
        assert!(joined.is_some_and(|j| j > 5.0), "{joined:?}");
        // They arrive within one step's gain of each other.
        let spread = (0..SPRINGS).map(|i| e.heat(i)).fold(0.0f32, f32::max)
            - (0..SPRINGS)
                .map(|i| e.heat(i))
                .fold(f32::INFINITY, f32::min);
        assert!(spread < 0.06, "{e:?}");
        assert!(e.balance(1.0, 0.05).is_empty());
    }

    #[test]
    fn springs_rest_after_cool_s_times_the_log_of_the_ratio() {
        let mut e = SpringHeat::COLD;
        run(&mut e, SpringMask::ALL, HEAT_S, 0.25);
        assert!(!e.rested(0.15));
        let h0 = e.heat(0);
        let t_rest = COOL_S * libm::logf(h0 / 0.15);
        run(&mut e, SpringMask::NONE, t_rest - 1.0, 0.25);
        assert!(!e.rested(0.15));
        run(&mut e, SpringMask::NONE, 2.0, 0.25);
        assert!(e.rested(0.15));
    }
}
