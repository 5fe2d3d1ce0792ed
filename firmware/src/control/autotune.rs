//! Relay autotune (Åström & Hägglund 1984): a steppable state machine that finds the ultimate
//! gain and period of the loop and turns them into PID gains by a stated rule.
//!
//! The relay drives the heater at [`AutotuneConfig::high`] while the temperature is below
//! `target + hysteresis_k` and at [`AutotuneConfig::low`] once it has passed it, until it falls
//! below `target − hysteresis_k`, and so on. The loop settles into a limit cycle of amplitude
//! `a` (half of peak − trough) and period `Tu`; the relay's describing function gives the
//! ultimate gain `Ku = 4·d/(π·a)` with `d = (high − low)/2` (output fraction per kelvin).
//!
//! A cycle runs from one high→low switch to the next. The first cycle still carries the
//! heat-up transient and is discarded; `a` and `Tu` are the averages over the other
//! `cycles − 1`. An asymmetric relay (heating faster than cooling) gives unequal halves; the
//! peak-to-trough average over whole cycles is still the fundamental's amplitude to first order.
//!
//! The run aborts — with the reason, and every later step repeating it — when the temperature
//! passes `target + max_overshoot_k`, when it has run longer than `timeout_s`, or on a
//! non-finite measurement or time. The amplitude is bounded by choosing `high` and `low` close
//! to the holding duty (the supervisor holds a base duty ± an amplitude, see
//! [`AutotuneConfig::around`]), so the run never nears the over-temperature limit.
//!
//! ## The rule
//! Three rules are offered (`Ti = Kp/Ki`, `Td = Kd/Kp`):
//!
//! | rule | Kp | Ti | Td |
//! |---|---|---|---|
//! | [`TuneRule::ZieglerNichols`] (classic) | 0.6·Ku | Tu/2 | Tu/8 |
//! | [`TuneRule::ZieglerNicholsNoOvershoot`] | 0.2·Ku | Tu/2 | Tu/3 |
//! | [`TuneRule::TyreusLuyben`] (default) | 0.45·Ku | 2.2·Tu | Tu/6.3 |
//!
//! The SMP must not pass its target: standby holds 323 K "never above", and 358 K plus a few
//! kelvin heads for the 373 K over-temperature limit and softens the polymer beyond the state the
//! mode asks for. The default is therefore the rule that does not overshoot on this kind of
//! plant, and that is Tyreus–Luyben, not the table row named "no overshoot". The block is
//! lag-dominant (dead time a few seconds against a time constant of minutes); there, Ziegler–
//! Nichols' `Ti = Tu/2` makes the integral dominate, and cutting Kp to 0.2·Ku only makes that
//! worse. On the tests' plant (K = 400 K, τ = 120 s, L = 6 s, 4 Hz, ±0.2 K noise), stepping a
//! split-range loop from ambient to 358 K with a bumpless start ([`super::Pid::reset_to`]`(0)`),
//! the overshoot is 19.7 K (ZN no-overshoot), 9.2 K (classic ZN) and 0.08 K (Tyreus–Luyben).
//! Taken as a plain step (no room for a negative integral, as in a heater-only loop) even
//! Tyreus–Luyben overshoots by a few kelvin, so start the loop bumplessly. Tyreus–Luyben was
//! designed for exactly such slow, lag-dominant process loops, where overshoot costs more than
//! speed.

use super::pid::PidGains;
use crate::outputs::Duty;
use crate::units::Seconds;

/// How gains follow from the ultimate gain `Ku` and period `Tu` (table in the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum TuneRule {
    /// Classic Ziegler–Nichols: `Kp = 0.6·Ku`, `Ti = Tu/2`, `Td = Tu/8` (quarter-amplitude
    /// decay: overshoots a step by design).
    ZieglerNichols,
    /// Ziegler–Nichols "no overshoot": `Kp = 0.2·Ku`, `Ti = Tu/2`, `Td = Tu/3`. Despite its name
    /// it overshoots most on a lag-dominant heater (see the module docs).
    ZieglerNicholsNoOvershoot,
    /// Tyreus–Luyben: `Kp = 0.45·Ku`, `Ti = 2.2·Tu`, `Td = Tu/6.3` (the default: no overshoot on
    /// a lag-dominant plant).
    #[default]
    TyreusLuyben,
}

impl TuneRule {
    /// Return the gains for ultimate gain `ku_per_k` (output fraction per K) and period `tu_s`
    /// (`Ki = Kp/Ti`, `Kd = Kp·Td`). Non-finite or non-positive inputs give [`PidGains::ZERO`].
    pub fn gains(self, ku_per_k: f32, tu_s: f32) -> PidGains {
        if !(ku_per_k.is_finite() && tu_s.is_finite() && ku_per_k > 0.0 && tu_s > 0.0) {
            return PidGains::ZERO;
        }
        let (kp_frac, ti_frac, td_frac) = match self {
            TuneRule::ZieglerNichols => (0.6, 0.5, 0.125),
            TuneRule::ZieglerNicholsNoOvershoot => (0.2, 0.5, 1.0 / 3.0),
            TuneRule::TyreusLuyben => (0.45, 2.2, 1.0 / 6.3),
        };
        let kp = kp_frac * ku_per_k;
        let g = PidGains {
            kp_per_k: kp,
            ki_per_k_s: kp / (ti_frac * tu_s),
            kd_s_per_k: kp * td_frac * tu_s,
        };
        if g.is_valid() { g } else { PidGains::ZERO }
    }
}

/// The relay test's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AutotuneConfig {
    /// Temperature the relay cycles around, K.
    pub target_k: f32,
    /// Heater duty while below the upper switching point.
    pub high: Duty,
    /// Heater duty while above the lower switching point.
    pub low: Duty,
    /// Half-width of the relay's hysteresis band, K (switches at `target ± hysteresis_k`).
    pub hysteresis_k: f32,
    /// Whole cycles to run, the first of which is discarded (at least 2).
    pub cycles: u8,
    /// Abort once the temperature exceeds `target + max_overshoot_k`, K.
    pub max_overshoot_k: f32,
    /// Abort once the run has lasted longer than this, s.
    pub timeout_s: f32,
    /// Rule turning `Ku`, `Tu` into gains.
    pub rule: TuneRule,
    /// Once the relay has switched, the longest it may wait for the next switch, s (two
    /// expected periods; infinite: no limit). A reading that stops following the relay — a
    /// camera that looks elsewhere, a heater off its film — aborts with
    /// [`AbortReason::NotFollowing`] instead of cycling the heater until the timeout.
    pub follow_s: f32,
    /// Before the first switch (the heat-up to the band), the least rise of the reading within
    /// every [`AutotuneConfig::rise_window_s`] while the relay heats, K (0: no check).
    pub rise_k: f32,
    /// See [`AutotuneConfig::rise_k`], s.
    pub rise_window_s: f32,
}

impl AutotuneConfig {
    /// A relay of `base ± amplitude` duty (each clamped to [0, 1]) around `target_k`, with a
    /// ±1.5 K band, 5 cycles, an 8 K overshoot limit, a 20 min timeout and the default rule
    /// ([`TuneRule::TyreusLuyben`]).
    pub fn around(target_k: f32, base: Duty, amplitude: f32) -> AutotuneConfig {
        let amplitude = if amplitude.is_nan() { 0.0 } else { amplitude };
        AutotuneConfig {
            target_k,
            high: Duty::from_fraction(base.fraction() + amplitude),
            low: Duty::from_fraction(base.fraction() - amplitude),
            hysteresis_k: 1.5,
            cycles: 5,
            max_overshoot_k: 8.0,
            timeout_s: 1200.0,
            rule: TuneRule::TyreusLuyben,
            follow_s: f32::INFINITY,
            rise_k: 0.0,
            rise_window_s: f32::INFINITY,
        }
    }

    /// Return whether the settings can run: finite target, `high > low`, a finite
    /// `hysteresis_k > 0`, a finite `max_overshoot_k > hysteresis_k`, a finite `timeout_s > 0`,
    /// `cycles ≥ 2`.
    pub fn is_valid(&self) -> bool {
        self.target_k.is_finite()
            && self.high.fraction() > self.low.fraction()
            && self.hysteresis_k.is_finite()
            && self.hysteresis_k > 0.0
            && self.max_overshoot_k.is_finite()
            && self.max_overshoot_k > self.hysteresis_k
            && self.timeout_s.is_finite()
            && self.timeout_s > 0.0
            && self.cycles >= 2
            && self.follow_s > 0.0
            && self.rise_k.is_finite()
            && self.rise_k >= 0.0
            && self.rise_window_s > 0.0
    }
}

/// What a finished relay test measured and the gains it gives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AutotuneResult {
    /// Ultimate gain `4·d/(π·a)`, output fraction per K.
    pub ku_per_k: f32,
    /// Ultimate period (mean over the counted cycles), s.
    pub tu_s: f32,
    /// Limit-cycle amplitude `a` (mean half peak-to-trough), K.
    pub amplitude_k: f32,
    /// Cycles averaged (the configured number minus the discarded first).
    pub cycles_used: u8,
    /// The rule applied.
    pub rule: TuneRule,
    /// The resulting gains.
    pub gains: PidGains,
}

/// Why a relay test stopped without a result.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AbortReason {
    /// The temperature passed `target + max_overshoot_k`.
    Overshoot,
    /// The run lasted longer than `timeout_s`.
    Timeout,
    /// A measurement was NaN or infinite.
    InvalidMeasurement,
    /// A time was NaN or infinite, or went backwards.
    InvalidTime,
    /// The configuration is not valid (see [`AutotuneConfig::is_valid`]).
    InvalidConfig,
    /// The cycles measured no usable amplitude or period.
    NoOscillation,
    /// The reading did not follow the relay: no rise while heating up to the band, or no
    /// switch within [`AutotuneConfig::follow_s`] once cycling.
    NotFollowing,
}

impl AbortReason {
    /// Return the stable lower-case name used on the console and in files.
    pub fn name(self) -> &'static str {
        match self {
            Self::Overshoot => "overshoot",
            Self::Timeout => "timeout",
            Self::InvalidMeasurement => "invalid-measurement",
            Self::InvalidTime => "invalid-time",
            Self::InvalidConfig => "invalid-config",
            Self::NoOscillation => "no-oscillation",
            Self::NotFollowing => "not-following",
        }
    }
}

/// What one step of the relay test asks for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AutotuneStep {
    /// Still cycling: drive the heater at this duty until the next measurement.
    Running {
        /// Heater duty to apply.
        heater_duty: Duty,
    },
    /// Finished; the result (the caller hands over to the PID, e.g. with `Pid::reset_to`).
    Done(AutotuneResult),
    /// Stopped; the caller makes the outputs safe.
    Aborted(AbortReason),
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum State {
    Running,
    Done(AutotuneResult),
    Aborted(AbortReason),
}

/// The relay test as a state machine: feed it every measurement with [`RelayAutotune::step`].
#[derive(Clone, Debug)]
pub struct RelayAutotune {
    config: AutotuneConfig,
    state: State,
    start_s: Option<f32>,
    last_s: f32,
    heating: bool,
    /// Running minimum while heating, maximum while cooling, K.
    extreme_k: f32,
    /// Time of the last high→low switch (start of the current cycle), s.
    cycle_start_s: Option<f32>,
    /// Peak of the current cycle, once its low phase has ended, K.
    peak_k: Option<f32>,
    cycles_done: u8,
    amplitude_sum_k: f32,
    period_sum_s: f32,
    /// The last relay switch, s (None before the first).
    last_switch_s: Option<f32>,
    /// The heat-up's rise window: its start and the reading then.
    rise_window: Option<(f32, f32)>,
}

impl RelayAutotune {
    /// Make a relay test; it starts with the first [`RelayAutotune::step`].
    pub fn new(config: AutotuneConfig) -> RelayAutotune {
        RelayAutotune {
            config,
            state: State::Running,
            start_s: None,
            last_s: 0.0,
            heating: true,
            extreme_k: 0.0,
            cycle_start_s: None,
            peak_k: None,
            cycles_done: 0,
            amplitude_sum_k: 0.0,
            period_sum_s: 0.0,
            last_switch_s: None,
            rise_window: None,
        }
    }

    /// Return the settings.
    pub fn config(&self) -> &AutotuneConfig {
        &self.config
    }

    /// Feed the measurement `measured_k` taken at `now` (a monotonic clock; pass the time since
    /// the run started, so `f32` keeps sub-millisecond resolution however long the board has
    /// been up) and return what to do until the next one. An infinite `now` aborts
    /// ([`AbortReason::InvalidTime`]).
    /// After `Done` or `Aborted`, every call returns the same again.
    pub fn step(&mut self, now: Seconds, measured_k: f32) -> AutotuneStep {
        let now_s = now.s();
        match self.state {
            State::Done(r) => return AutotuneStep::Done(r),
            State::Aborted(r) => return AutotuneStep::Aborted(r),
            State::Running => {}
        }
        match self.advance(now_s, measured_k) {
            Ok(Some(result)) => {
                self.state = State::Done(result);
                AutotuneStep::Done(result)
            }
            Ok(None) => AutotuneStep::Running {
                heater_duty: if self.heating {
                    self.config.high
                } else {
                    self.config.low
                },
            },
            Err(reason) => {
                self.state = State::Aborted(reason);
                AutotuneStep::Aborted(reason)
            }
        }
    }

    fn advance(&mut self, now_s: f32, t_k: f32) -> Result<Option<AutotuneResult>, AbortReason> {
        let c = self.config;
        if !c.is_valid() {
            return Err(AbortReason::InvalidConfig);
        }
        if !now_s.is_finite() || (self.start_s.is_some() && now_s < self.last_s) {
            return Err(AbortReason::InvalidTime);
        }
        if !t_k.is_finite() {
            return Err(AbortReason::InvalidMeasurement);
        }
        let start_s = match self.start_s {
            Some(s) => s,
            None => {
                self.start_s = Some(now_s);
                self.heating = t_k < c.target_k;
                self.extreme_k = t_k;
                now_s
            }
        };
        self.last_s = now_s;
        if t_k > c.target_k + c.max_overshoot_k {
            return Err(AbortReason::Overshoot);
        }
        if now_s - start_s > c.timeout_s {
            return Err(AbortReason::Timeout);
        }
        match self.last_switch_s {
            Some(t) if now_s - t > c.follow_s => return Err(AbortReason::NotFollowing),
            Some(_) => {}
            None if self.heating && c.rise_k > 0.0 => match self.rise_window {
                None => self.rise_window = Some((now_s, t_k)),
                Some((t0, y0)) if now_s - t0 >= c.rise_window_s => {
                    if t_k - y0 < c.rise_k {
                        return Err(AbortReason::NotFollowing);
                    }
                    self.rise_window = Some((now_s, t_k));
                }
                Some(_) => {}
            },
            None => {}
        }
        if self.heating {
            self.extreme_k = self.extreme_k.min(t_k);
            if t_k > c.target_k + c.hysteresis_k {
                if let (Some(t0), Some(peak)) = (self.cycle_start_s, self.peak_k) {
                    // A whole cycle: high→low at t0, its peak, its trough, high→low now.
                    self.cycles_done = self.cycles_done.saturating_add(1);
                    if self.cycles_done > 1 {
                        self.amplitude_sum_k += 0.5 * (peak - self.extreme_k);
                        self.period_sum_s += now_s - t0;
                    }
                    if self.cycles_done >= c.cycles {
                        return self.result().map(Some);
                    }
                }
                self.cycle_start_s = Some(now_s);
                self.peak_k = None;
                self.heating = false;
                self.extreme_k = t_k;
                self.last_switch_s = Some(now_s);
            }
        } else {
            self.extreme_k = self.extreme_k.max(t_k);
            if t_k < c.target_k - c.hysteresis_k {
                if self.cycle_start_s.is_some() {
                    self.peak_k = Some(self.extreme_k);
                }
                self.heating = true;
                self.extreme_k = t_k;
                self.last_switch_s = Some(now_s);
            }
        }
        Ok(None)
    }

    fn result(&self) -> Result<AutotuneResult, AbortReason> {
        let c = self.config;
        let n = c.cycles - 1;
        let a_k = self.amplitude_sum_k / n as f32;
        let tu_s = self.period_sum_s / n as f32;
        let d = 0.5 * (c.high.fraction() - c.low.fraction());
        let ku = 4.0 * d / (core::f32::consts::PI * a_k);
        if !(a_k.is_finite() && a_k > 0.0 && tu_s.is_finite() && tu_s > 0.0 && ku.is_finite()) {
            return Err(AbortReason::NoOscillation);
        }
        Ok(AutotuneResult {
            ku_per_k: ku,
            tu_s,
            amplitude_k: a_k,
            cycles_used: n,
            rule: c.rule,
            gains: c.rule.gains(ku, tu_s),
        })
    }
}
