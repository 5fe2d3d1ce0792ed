//! Fault detection (SPEC section 5): over-temperature, spring on-time and duty, sensor loss,
//! thermal runaway while heating and while holding, emergency stop.
//!
//! This module owns the fault types and the checks' state; the supervisor calls the checks and
//! owns the latch. Runaway is checked the Marlin/Klipper way, and only where the heater is
//! supposed to raise or hold the temperature (never in forming, where the fan pulls it down on
//! purpose, nor while stopped or faulted):
//! - heating: while the heater runs at ≥ `runaway_duty` and the film (the hotter of T1/T2,
//!   which the heater warms directly) is below `target − hold_band_k`, the film must rise by
//!   `runaway_gain_k` within every `runaway_window_s` (Klipper's heating_gain /
//!   check_gain_time, Marlin's WATCH_TEMP);
//! - holding: once Tc has reached the target band, the error beyond `±hold_band_k` is
//!   integrated (K·s) and the fault trips above `hold_max_error_ks` (Klipper's max_error);
//!   it decays back while Tc is inside the band. A change of target re-arms both checks.

use core::fmt;

use crate::channels::{ChannelFault, SenseFault};
use crate::control::OnTimer;
use crate::decimal::Fixed;
use crate::measurement::{Measurement, Quality};
use crate::observer::Springs;
use crate::outputs::{SPRING_NAMES, SPRINGS, SpringMask};
use crate::settings::Settings;
use crate::units::{Kelvin, Millis, Seconds};

/// How far a spring's on-time may pass `spring_on_max_s` before it trips, ms: one tick of the
/// board's control loop (a phase ends on the first step after its time is up).
pub const ON_TIME_SLACK_MS: u32 = 50;

/// The share of `spring_duty_max` up to which the optional spring drives (recovery's
/// windows, stepping's pre-warm) still use a spring ([`Safety::duty_room`]).
pub const DUTY_ROOM: f32 = 0.9;

/// Which check latched a fault (with the spring, where one did), without what tripped it: for
/// matching and comparing ([`Fault::kind`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FaultKind {
    /// A region (or the frame's hottest pixel) is above `t_max_k`.
    OverTemperature,
    /// A spring was on longer than `spring_on_max_s` (index 0 = A).
    SpringOnTime(u8),
    /// A spring's duty over the window exceeded `spring_duty_max_pct` (index 0 = A).
    SpringDuty(u8),
    /// A spring's estimated temperature exceeded `spring_max_k` (index 0 = A).
    SpringOverTemperature(u8),
    /// No valid measurement within `sensor_timeout_s`.
    SensorLoss,
    /// The heater ran hard with too little rise.
    RunawayHeating,
    /// The held temperature drifted from its target for too long.
    RunawayHolding,
    /// The heater ran at high duty for `no_response_s` and the film did not rise, whatever the
    /// mode and target (a camera that reads plausible but wrong values, a heater off its film).
    NoResponse,
    /// The emergency stop (button or console).
    EStop,
    /// A spring channel conducted with its gate off: its MOSFET failed short (index 0 = A).
    SpringStuckOn(u8),
    /// A spring channel carried no current with its gate on (index 0 = A).
    SpringOpen(u8),
    /// A spring channel carried too much current, or its wire reads bypassed (index 0 = A).
    SpringShort(u8),
    /// A spring channel's sensing reads garbage (index 0 = A).
    SpringSensing(u8),
}

/// A latched fault, with what tripped it in that check's own unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fault {
    /// A region (or the frame's hottest pixel) reached `reached_k` above its limit.
    OverTemperature {
        /// The temperature that tripped it, K.
        reached_k: f32,
    },
    /// A spring was on for `on_s` past `spring_on_max_s`.
    SpringOnTime {
        /// Spring index, 0 = A.
        spring: u8,
        /// Its on-time, s.
        on_s: f32,
    },
    /// A spring's duty over the window passed `spring_duty_max_pct`.
    SpringDuty {
        /// Spring index, 0 = A.
        spring: u8,
        /// Its duty, a fraction.
        duty: f32,
    },
    /// A spring's estimated temperature passed `spring_max_k`.
    SpringOverTemperature {
        /// Spring index, 0 = A.
        spring: u8,
        /// Its estimated temperature, K.
        estimate_k: f32,
    },
    /// No valid measurement for `for_s`.
    SensorLoss {
        /// Since the last valid measurement, s.
        for_s: f32,
    },
    /// The heater ran hard and the film rose only `rise_k` in the window.
    RunawayHeating {
        /// The film's rise over the window, K.
        rise_k: f32,
    },
    /// Tc stayed away from its target: `error_k_s` accumulated beyond the band.
    RunawayHolding {
        /// The accumulated error, K·s.
        error_k_s: f32,
    },
    /// The heater ran hard for `no_response_s` and the film changed by `change_k`.
    NoResponse {
        /// The film's change over the window, K.
        change_k: f32,
    },
    /// The emergency stop (button or console).
    EStop,
    /// A spring channel's measurement tripped a check ([`crate::channels`]).
    Channel(ChannelFault),
}

impl FaultKind {
    /// Return the stable code shown on the console and in files.
    pub fn code(self) -> &'static str {
        match self {
            FaultKind::OverTemperature => "over-temperature",
            FaultKind::SpringOnTime(_) => "spring-on-time",
            FaultKind::SpringDuty(_) => "spring-duty",
            FaultKind::SpringOverTemperature(_) => "spring-over-temperature",
            FaultKind::SensorLoss => "sensor-loss",
            FaultKind::RunawayHeating => "runaway-heating",
            FaultKind::RunawayHolding => "runaway-holding",
            FaultKind::NoResponse => "no-response",
            FaultKind::EStop => "estop",
            FaultKind::SpringStuckOn(_) => "spring-stuck-on",
            FaultKind::SpringOpen(_) => "spring-open",
            FaultKind::SpringShort(_) => "spring-short",
            FaultKind::SpringSensing(_) => "spring-sensing",
        }
    }
}

impl Fault {
    /// Return which check tripped (with the spring, where one did).
    pub fn kind(&self) -> FaultKind {
        match *self {
            Fault::OverTemperature { .. } => FaultKind::OverTemperature,
            Fault::SpringOnTime { spring, .. } => FaultKind::SpringOnTime(spring),
            Fault::SpringDuty { spring, .. } => FaultKind::SpringDuty(spring),
            Fault::SpringOverTemperature { spring, .. } => FaultKind::SpringOverTemperature(spring),
            Fault::SensorLoss { .. } => FaultKind::SensorLoss,
            Fault::RunawayHeating { .. } => FaultKind::RunawayHeating,
            Fault::RunawayHolding { .. } => FaultKind::RunawayHolding,
            Fault::NoResponse { .. } => FaultKind::NoResponse,
            Fault::EStop => FaultKind::EStop,
            Fault::Channel(c) => match c {
                ChannelFault::StuckOn { spring, .. } => FaultKind::SpringStuckOn(spring),
                ChannelFault::Open { spring, .. } => FaultKind::SpringOpen(spring),
                ChannelFault::Short { spring, .. } => FaultKind::SpringShort(spring),
                ChannelFault::Sensing { spring, .. } => FaultKind::SpringSensing(spring),
            },
        }
    }

    /// Return the stable code shown on the console and in files.
    pub fn code(&self) -> &'static str {
        self.kind().code()
    }

    /// Return whether the fan should run while this fault is latched (cooling helps unless a
    /// person stopped everything).
    pub fn fan_helps(&self) -> bool {
        !matches!(self, Fault::EStop)
    }

    /// Return a one-line human reason (no line breaks).
    pub fn reason(&self) -> Reason {
        Reason(*self)
    }
}

/// The human reason of a fault, as `Display`.
pub struct Reason(Fault);

impl fmt::Display for Reason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = |i: u8| SPRING_NAMES[i as usize % SPRINGS];
        match self.0 {
            Fault::OverTemperature { reached_k } => {
                write!(f, "a region reached {} K", Fixed::new(reached_k, 1))
            }
            Fault::SpringOnTime { spring, on_s } => {
                write!(
                    f,
                    "spring {} on for {} s",
                    name(spring),
                    Fixed::new(on_s, 1)
                )
            }
            Fault::SpringDuty { spring, duty } => write!(
                f,
                "spring {} duty {} % over its window",
                name(spring),
                Fixed::new(duty * 100.0, 0)
            ),
            Fault::SpringOverTemperature { spring, estimate_k } => write!(
                f,
                "spring {} estimated at {} K",
                name(spring),
                Fixed::new(estimate_k, 1)
            ),
            Fault::SensorLoss { for_s } => {
                write!(f, "no valid measurement for {} s", Fixed::new(for_s, 2))
            }
            Fault::RunawayHeating { rise_k } => write!(
                f,
                "heater at high duty but the film rose only {} K in the window",
                Fixed::new(rise_k, 2)
            ),
            Fault::RunawayHolding { error_k_s } => {
                write!(
                    f,
                    "Tc away from target for {} K*s",
                    Fixed::new(error_k_s, 0)
                )
            }
            Fault::NoResponse { change_k } => write!(
                f,
                "heater at high duty for no_response_s but the film changed by {:+} K",
                Fixed::new(change_k, 2)
            ),
            Fault::EStop => f.write_str("emergency stop"),
            Fault::Channel(c) => channel_reason(f, c),
        }
    }
}

/// The reason of a spring channel's fault, naming the spring.
fn channel_reason(f: &mut fmt::Formatter<'_>, c: ChannelFault) -> fmt::Result {
    let name = SPRING_NAMES[c.spring() as usize % SPRINGS];
    let a = |x: f32| Fixed::new(x, 1);
    match c {
        ChannelFault::StuckOn { current_a, .. } => write!(
            f,
            "spring {name} stuck on: {} A with its gate off; spring power cut",
            a(current_a)
        ),
        ChannelFault::Open {
            current_a,
            supply_v,
            ..
        } => write!(
            f,
            "spring {name} open: {} A with its gate on (supply {} V)",
            a(current_a),
            a(supply_v)
        ),
        ChannelFault::Short {
            current_a,
            wire_ohm,
            ..
        } if wire_ohm.is_finite() => write!(
            f,
            "spring {name} short: its wire reads {} ohm at {} A; spring power cut",
            Fixed::new(wire_ohm, 3),
            a(current_a)
        ),
        ChannelFault::Short { current_a, .. } => write!(
            f,
            "spring {name} short: {} A; spring power cut",
            a(current_a)
        ),
        ChannelFault::Sensing { what, .. } => {
            let why = match what {
                SenseFault::OutOfRange => "a reading beyond the ADC's 12 bits",
                SenseFault::DividerRail => "its supply divider at its rail",
                SenseFault::NoSupplyReading => "current with no supply reading (a broken divider)",
            };
            write!(f, "spring {name} sensing: {why}")
        }
    }
}

/// The state of the checks that need memory.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Safety {
    /// Continuous on-time of each spring ([`OnTimer`]: short gaps pause it, a rest clears it).
    spring_on: [OnTimer; SPRINGS],
    /// Each spring's duty, averaged over the window (exponential), fraction.
    spring_duty: [f32; SPRINGS],
    /// Heating check: when the window started and Tc then.
    heat_window: Option<(Millis, f32)>,
    /// Holding check: the target it watches.
    hold_target_k: f32,
    /// Holding check: Tc has been inside the band since the target was set.
    hold_met: bool,
    /// Holding check: error accumulated beyond the band, K·s.
    hold_error_ks: f32,
    /// No-response check: since when the heater has run at high duty, and the film then. Kept
    /// across mode changes and targets: only a lower duty or a rise restarts it.
    response_window: Option<(Millis, f32)>,
}

/// What the runaway check is told about the loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopState {
    /// The loop's target, K.
    pub target_k: f32,
    /// The controlled temperature of this measurement, K.
    pub tc_k: f32,
    /// The hotter of T1/T2 — the film the heater warms directly, whose rise the heating check
    /// watches (Tc may weigh the colder region, which lags by tens of seconds), K.
    pub film_k: f32,
    /// The heater duty applied since the last measurement, fraction.
    pub heater_duty: f32,
    /// The mode wants the heater to raise or hold Tc (false in forming, stopped, faulted).
    pub active: bool,
}

impl Safety {
    /// Make the checks' state.
    pub const fn new() -> Self {
        Safety {
            spring_on: [OnTimer::CLEAR; SPRINGS],
            spring_duty: [0.0; SPRINGS],
            heat_window: None,
            hold_target_k: 0.0,
            hold_met: false,
            hold_error_ks: 0.0,
            response_window: None,
        }
    }

    /// Make the checks' state with the springs' memory (duty history and on-time counts) kept
    /// across a reset, or assumed at power-up.
    pub fn with_springs(duty: [f32; SPRINGS], on_time: [OnTimer; SPRINGS]) -> Self {
        Safety {
            spring_on: on_time,
            spring_duty: duty.map(|d| {
                if d.is_finite() {
                    d.clamp(0.0, 1.0)
                } else {
                    1.0
                }
            }),
            ..Safety::new()
        }
    }

    /// Return the springs' duty history and on-time counts (for [`super::SpringMemory`]).
    pub fn springs(&self) -> ([f32; SPRINGS], [OnTimer; SPRINGS]) {
        (self.spring_duty, self.spring_on)
    }

    /// Return the over-temperature fault of a measurement, if any. By rank, so a swapped
    /// T1/T2 changes nothing: the colder of T1/T2 (the SMP) and regions 4–5 (beside the
    /// cylinder and the background: a spring or anything else hot in view) against `t_max_k`;
    /// the hotter of T1/T2, region 3 and the frame's hottest pixel (the PI heater film seen
    /// through the lattice, or a spring burning beside the cylinder) against `t_heater_max_k`.
    /// Region 3, the cylinder's edges, mixes the lattice with the film seen through its gaps at a grazing angle: as the column bends, a
    /// frame's edge cluster can read the film's ≈ 385 K, which is not the SMP's (judged against
    /// `t_max_k` it tripped full cycles whose SMP never passed 371 K: the ±20 % sweep's block
    /// with 80 % heater power and 120 % wall capacity, at 193 s). A frame that could not
    /// separate T1 and T2 for sure (ambiguous, merged or fallback) is judged by the worst it may hide: the SMP may
    /// be as hot as the mean plus the bound ([`Measurement::hotter`]), never the mean less it.
    pub fn over_temperature(m: &Measurement, s: &Settings) -> Option<Fault> {
        let smp_k = match m.quality {
            Quality::Resolved => m.colder(),
            Quality::Ambiguous | Quality::Merged | Quality::Fallback => m.hotter(),
        }
        .map_or(f32::NAN, Kelvin::k);
        let smp = m.regions[3..]
            .iter()
            .map(|t| t.map_or(f32::NAN, Kelvin::k))
            .chain([smp_k])
            .filter(|t| t.is_finite())
            .fold(f32::MIN, f32::max);
        let film = [m.hotter().map_or(f32::NAN, Kelvin::k)]
            .into_iter()
            .chain(m.regions[2].map(Kelvin::k))
            .chain(m.hottest.map(|t| t.k()))
            .filter(|t| t.is_finite())
            .fold(f32::MIN, f32::max);
        if smp > s.t_max_k {
            Some(Fault::OverTemperature { reached_k: smp })
        } else if film > s.t_heater_max_k {
            Some(Fault::OverTemperature { reached_k: film })
        } else {
            None
        }
    }

    /// Credit `elapsed_ms` to the springs that were on during it (`springs`: the outputs applied
    /// over that interval, not the ones about to be); return a fault if a spring is past its
    /// on-time or duty limit. The on-time may pass `spring_on_max_s` by less than
    /// [`ON_TIME_SLACK_MS`] (a phase ends on the first step after its time is up) before it
    /// trips.
    pub fn credit_springs(
        &mut self,
        springs: SpringMask,
        elapsed_ms: u32,
        s: &Settings,
    ) -> Option<Fault> {
        let a = (elapsed_ms as f32 * 1e-3 / s.spring_window_s).min(1.0);
        for i in 0..SPRINGS {
            let on = springs.contains(i);
            self.spring_on[i].credit(on, elapsed_ms);
            self.spring_duty[i] += ((on as u8 as f32) - self.spring_duty[i]) * a;
        }
        self.spring_fault(SpringMask::ALL, s)
    }

    /// Return a fault if one of `springs` is past its on-time or duty limit now (checked again
    /// on the outputs about to be applied: a spring past its limit is never switched on).
    pub fn spring_fault(&self, springs: SpringMask, s: &Settings) -> Option<Fault> {
        let on_max_ms = s.spring_on_max_s * 1000.0 + ON_TIME_SLACK_MS as f32;
        (0..SPRINGS).filter(|&i| springs.contains(i)).find_map(|i| {
            let on_ms = self.spring_on[i].on_ms();
            if on_ms as f32 > on_max_ms {
                Some(Fault::SpringOnTime {
                    spring: i as u8,
                    on_s: on_ms as f32 * 1e-3,
                })
            } else if self.spring_duty[i] > s.spring_duty_max {
                Some(Fault::SpringDuty {
                    spring: i as u8,
                    duty: self.spring_duty[i],
                })
            } else {
                None
            }
        })
    }

    /// Return a fault if a spring's estimated temperature is past `spring_max_k` (the
    /// observer's [`Springs`]: whether the spring is on or not, a spring that hot got there by
    /// being driven).
    pub fn spring_temperature_fault(springs: &Springs, s: &Settings) -> Option<Fault> {
        springs
            .iter()
            .position(|sp| sp.temp_k > s.spring_max_k)
            .map(|i| Fault::SpringOverTemperature {
                spring: i as u8,
                estimate_k: springs[i].temp_k,
            })
    }

    /// The springs whose duty over the window is below `DUTY_ROOM` of `spring_duty_max`: the
    /// ones recovery's windows and stepping's pre-warm may still drive (a spring nearer its
    /// limit sits out rather than trip it).
    pub fn duty_room(&self, s: &Settings) -> SpringMask {
        let bits = (0..SPRINGS)
            .filter(|&i| self.spring_duty(i) < DUTY_ROOM * s.spring_duty_max)
            .fold(0u8, |b, i| b | 1 << i);
        SpringMask::from_bits(bits)
    }

    /// Return spring `i`'s counted on-time, s.
    pub fn spring_on_s(&self, i: usize) -> f32 {
        self.spring_on.get(i).map_or(0.0, |t| t.on_s())
    }

    /// Return whether spring `i` may be switched on without running its on-time count past
    /// `spring_on_max_s` within `for_s`.
    pub fn spring_may_run(&self, i: usize, for_s: f32, s: &Settings) -> bool {
        self.spring_on_s(i) + for_s <= s.spring_on_max_s
    }

    /// Return spring `i`'s duty over the window, fraction.
    pub fn spring_duty(&self, i: usize) -> f32 {
        self.spring_duty.get(i).copied().unwrap_or(0.0)
    }

    /// Run the runaway checks on a new measurement taken `dt` after the previous one.
    pub fn runaway(
        &mut self,
        now: Millis,
        dt: Seconds,
        l: LoopState,
        s: &Settings,
    ) -> Option<Fault> {
        let dt_s = dt.s();
        if !l.active || !l.tc_k.is_finite() || !l.film_k.is_finite() {
            self.heat_window = None;
            self.rearm(l.target_k);
            self.hold_target_k = f32::NAN;
            return None;
        }
        if l.target_k != self.hold_target_k {
            self.rearm(l.target_k);
        }
        // Heating: a hard-driven heater whose film is still below the target band must show a
        // rise within every window (a film already above the target is visibly being heated,
        // even when the colder region lags).
        let below = l.film_k < l.target_k - s.hold_band_k;
        if below && l.heater_duty >= s.runaway_duty && !self.hold_met {
            match self.heat_window {
                None => self.heat_window = Some((now, l.film_k)),
                Some((t0, film0)) if now.seconds_since(t0).s() >= s.runaway_window_s => {
                    let rise = l.film_k - film0;
                    if rise < s.runaway_gain_k {
                        return Some(Fault::RunawayHeating { rise_k: rise });
                    }
                    self.heat_window = Some((now, l.film_k));
                }
                Some(_) => {}
            }
        } else {
            self.heat_window = None;
        }
        // Holding: once the band was reached, integrate the error beyond it.
        let excess = libm::fabsf(l.tc_k - l.target_k) - s.hold_band_k;
        if excess <= 0.0 {
            self.hold_met = true;
            self.hold_error_ks = (self.hold_error_ks + excess * dt_s).max(0.0);
        } else if self.hold_met {
            self.hold_error_ks += excess * dt_s;
            if self.hold_error_ks > s.hold_max_error_ks {
                return Some(Fault::RunawayHolding {
                    error_k_s: self.hold_error_ks,
                });
            }
        }
        None
    }

    /// The no-response check, on every new measurement: while the heater has run at
    /// `runaway_duty` or more since the last one, the film (the hotter of T1/T2) must rise by
    /// `runaway_gain_k` within every `no_response_s`. Unlike the runaway checks it knows no
    /// target, band or mode, and nothing re-arms it but a lower duty or the rise itself: a
    /// camera that reads a steady, plausible temperature while the heater runs flat out trips
    /// it, however often the mode is changed. The supervisor passes a duty of 0 while the film
    /// reads at its ceiling (within [`super::CEILING_MARGIN_K`] of `heater_cap_k −
    /// heater_cap_band_k`, where the cascade holds it at most): visibly heated — the steady
    /// state of a long soak on a cold day. (A camera stuck at exactly that reading is not
    /// caught here.)
    pub fn no_response(
        &mut self,
        now: Millis,
        film_k: f32,
        heater_duty: f32,
        s: &Settings,
    ) -> Option<Fault> {
        if heater_duty < s.runaway_duty || !film_k.is_finite() {
            self.response_window = None;
            return None;
        }
        match self.response_window {
            None => self.response_window = Some((now, film_k)),
            Some((t0, film0)) => {
                let rise = film_k - film0;
                if rise >= s.runaway_gain_k {
                    self.response_window = Some((now, film_k));
                } else if now.seconds_since(t0).s() >= s.no_response_s {
                    return Some(Fault::NoResponse { change_k: rise });
                }
            }
        }
        None
    }

    /// Start the holding check afresh for a new target. The heating check's window runs on: it
    /// watches the film's rise under a hard-driven heater, which a new target does not change
    /// (toggling modes must not re-arm it); a lower duty or a film in the band ends it.
    fn rearm(&mut self, target_k: f32) {
        self.hold_target_k = target_k;
        self.hold_met = false;
        self.hold_error_ks = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(
        safety: &mut Safety,
        s: &Settings,
        secs: f32,
        mut tc: impl FnMut(f32) -> f32,
        duty: f32,
        target: f32,
    ) -> Option<(f32, Fault)> {
        let dt = 0.25;
        let mut t = 0.0;
        while t <= secs {
            let l = LoopState {
                target_k: target,
                tc_k: tc(t),
                film_k: tc(t),
                heater_duty: duty,
                active: true,
            };
            if let Some(f) =
                safety.runaway(Millis((t * 1000.0) as u64), Seconds::new(dt).unwrap(), l, s)
            {
                return Some((t, f));
            }
            t += dt;
        }
        None
    }

    #[test]
    fn dead_heater_trips_after_one_window() {
        let s = Settings::DEFAULT;
        let mut safety = Safety::new();
        let (t, f) = run(&mut safety, &s, 60.0, |_| 298.0, 1.0, 323.0).unwrap();
        assert_eq!(f.kind(), FaultKind::RunawayHeating);
        assert!((t - s.runaway_window_s).abs() < 0.3, "tripped at {t}");
    }

    #[test]
    fn a_heater_that_heats_does_not_trip() {
        let s = Settings::DEFAULT;
        let mut safety = Safety::new();
        // 0.3 K/s: 6 K per 20 s window, well above 2 K.
        let tc = |t: f32| (298.0 + 0.3 * t).min(323.0);
        assert_eq!(run(&mut safety, &s, 300.0, tc, 1.0, 323.0), None);
    }

    #[test]
    fn drift_after_reaching_target_trips_by_accumulated_error() {
        let s = Settings::DEFAULT;
        let mut safety = Safety::new();
        // At target for 10 s, then 10 K below: 5 K beyond the band → 120 K·s after 24 s.
        let tc = |t: f32| if t < 10.0 { 323.0 } else { 313.0 };
        let (t, f) = run(&mut safety, &s, 100.0, tc, 0.5, 323.0).unwrap();
        assert_eq!(f.kind(), FaultKind::RunawayHolding);
        assert!((t - 34.0).abs() < 0.6, "tripped at {t}");
    }

    #[test]
    fn inactive_loops_never_trip() {
        let s = Settings::DEFAULT;
        let mut safety = Safety::new();
        for i in 0..1000 {
            let l = LoopState {
                target_k: 323.0,
                tc_k: 250.0,
                film_k: 250.0,
                heater_duty: 1.0,
                active: false,
            };
            assert_eq!(
                safety.runaway(Millis(i * 250), Seconds::lit(0.25), l, &s),
                None
            );
        }
    }

    #[test]
    fn spring_limits() {
        let s = Settings::DEFAULT;
        let mut safety = Safety::new();
        let a = SpringMask::from_bits(1);
        for _ in 0..32 {
            assert_eq!(safety.credit_springs(a, 250, &s), None);
        }
        let f = safety.credit_springs(a, 250, &s).unwrap();
        assert_eq!(f.kind(), FaultKind::SpringOnTime(0));
        // Duty: 6 s on, 1 s off, repeated, is 86 % — above the 60 % limit eventually.
        let mut safety = Safety::new();
        let mut tripped = None;
        for k in 0..400 {
            let on = k % 28 < 24;
            let m = if on { a } else { SpringMask::NONE };
            if let Some(f) = safety.credit_springs(m, 250, &s) {
                tripped = Some(f);
                break;
            }
        }
        assert_eq!(tripped.map(|f| f.kind()), Some(FaultKind::SpringDuty(0)));
    }
}
