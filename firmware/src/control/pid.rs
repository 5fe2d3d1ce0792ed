//! The PID law of thesis eq. 6.14–6.16, built as production heater firmwares build it.
//!
//! `u = Kp·e + Ki·Σ e·Δt − Kd·dT/dt` with `e = T_target − T_measured` (eq. 6.15). Against the
//! textbook form of eq. 6.16 it differs as Klipper's `ControlPID` and Marlin's `PID_temp` do:
//!
//! - **Derivative on measurement**, not on error (a target change gives no derivative kick),
//!   low-pass filtered with time constant [`PidConfig::derivative_tau_s`]. The filter is the
//!   exact discretisation of `τ·ḋ + d = dT/dt` for a piecewise-constant raw slope
//!   (`d += (1 − e^(−Δt/τ))·(raw − d)`), so it is independent of the sample rate.
//! - **Anti-windup** twice over: the I term (kept in output units, `Ki·Σ e·Δt`) is clamped to the
//!   output range, so it alone never exceeds it; and it stops integrating while the output is
//!   saturated in the direction the error pushes (conditional integration).
//! - **Output clamped** to `[output_min, output_max]`.
//! - **Δt from the caller's measurement timestamps.** A Δt that is NaN, ≤ 0 or above
//!   [`PidConfig::max_dt_s`] (a missed or repeated frame) does not integrate and restarts the
//!   derivative (D = 0 for that sample) — the Klipper/Marlin answer to a gap.
//! - **Bumpless transfer.** [`Pid::set_gains`], [`Pid::set_target`] and [`Pid::reset_to`] make
//!   the next output equal the last one (or the given one): at the next sample the integrator is
//!   recomputed as `I = u_last − P − D` (clamped to its range; only that clamp can leave a step).
//!   A bumpless target step takes the proportional kick into the integrator, so the approach is
//!   driven by the integral (I-PD-like) and does not overshoot; that needs room below zero for
//!   the I term, which the split range ([`PidConfig::split_range`], [−1, 1]) has and a
//!   heater-only loop ([0, 1], I ≥ 0) has not. A loop starting from rest takes the same path
//!   with `reset_to(0.0)` (the outputs were off).
//! - **Functional range** (Marlin's `PID_FUNCTIONAL_RANGE`, optional): with
//!   `|e| >` [`PidConfig::functional_band_k`] the output is bang-bang (`output_max` below the
//!   band, `output_min` above it) and the integrator is reset to 0, so a long heat-up cannot
//!   wind it; a pending bumpless realignment is dropped. Back inside, the integrator starts
//!   from 0.
//!
//! Bad input never panics: a non-finite measurement or target gives [`Pid::safe_output`] (0
//! clamped into the range: heater off, and with [`super::SplitRange`] heater and fan off) and
//! restarts the derivative; invalid gains are refused by the setters and replaced by zeros in
//! [`Pid::new`].

use crate::fmath::clamp;
use crate::units::Seconds;

/// PID gains with their units. The output is a fraction of full actuator power (1.0 = 100 %).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct PidGains {
    /// Proportional gain: output fraction per kelvin of error.
    pub kp_per_k: f32,
    /// Integral gain: output fraction per kelvin-second of accumulated error.
    pub ki_per_k_s: f32,
    /// Derivative gain: output fraction per (kelvin per second) of measured rise.
    pub kd_s_per_k: f32,
}

impl PidGains {
    /// All gains zero: the output is always 0 (clamped into the range).
    pub const ZERO: PidGains = PidGains {
        kp_per_k: 0.0,
        ki_per_k_s: 0.0,
        kd_s_per_k: 0.0,
    };

    /// Return whether every gain is finite and ≥ 0.
    pub fn is_valid(&self) -> bool {
        [self.kp_per_k, self.ki_per_k_s, self.kd_s_per_k]
            .iter()
            .all(|g| g.is_finite() && *g >= 0.0)
    }
}

/// Everything a [`Pid`] is built from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PidConfig {
    /// The gains.
    pub gains: PidGains,
    /// Lowest output (0 for a heater alone, −1 for a heater/fan split range).
    pub output_min: f32,
    /// Highest output (1 = full power).
    pub output_max: f32,
    /// Time constant of the derivative's first-order low-pass filter, s (0 = unfiltered;
    /// Klipper's `smooth_time` default is 1 s).
    pub derivative_tau_s: f32,
    /// Largest Δt between two measurements that still counts as consecutive, s.
    pub max_dt_s: f32,
    /// Half-width of the functional range, K: outside `target ± band` the output is bang-bang
    /// and the integrator is reset. `f32::INFINITY` turns it off.
    pub functional_band_k: f32,
}

impl PidConfig {
    /// A heater-only loop: output in [0, 1], derivative filtered over 1 s, Δt up to 1 s
    /// (four frames at the default 4 Hz), no functional range.
    pub const fn heater(gains: PidGains) -> PidConfig {
        PidConfig {
            gains,
            output_min: 0.0,
            output_max: 1.0,
            derivative_tau_s: 1.0,
            max_dt_s: 1.0,
            functional_band_k: f32::INFINITY,
        }
    }

    /// A heater/fan split-range loop: as [`PidConfig::heater`] with output in [−1, 1].
    pub const fn split_range(gains: PidGains) -> PidConfig {
        PidConfig {
            output_min: -1.0,
            ..PidConfig::heater(gains)
        }
    }

    /// Return whether the configuration is usable as it is: valid gains, a finite range with
    /// `output_min ≤ output_max`, a finite `derivative_tau_s ≥ 0`, a finite `max_dt_s > 0` and a
    /// `functional_band_k > 0` (may be infinite).
    pub fn is_valid(&self) -> bool {
        self.gains.is_valid()
            && self.output_min.is_finite()
            && self.output_max.is_finite()
            && self.output_min <= self.output_max
            && self.derivative_tau_s.is_finite()
            && self.derivative_tau_s >= 0.0
            && self.max_dt_s.is_finite()
            && self.max_dt_s > 0.0
            && self.functional_band_k > 0.0
    }

    /// Return the configuration with every invalid field replaced by a safe value: invalid
    /// gains → [`PidGains::ZERO`]; an invalid range → [0, 0] (always off); an invalid filter
    /// time → 0 (unfiltered); an invalid `max_dt_s` → 1 s; an invalid band → off.
    pub fn sanitized(self) -> PidConfig {
        let mut c = self;
        if !c.gains.is_valid() {
            c.gains = PidGains::ZERO;
        }
        if !(c.output_min.is_finite() && c.output_max.is_finite() && c.output_min <= c.output_max) {
            c.output_min = 0.0;
            c.output_max = 0.0;
        }
        if !(c.derivative_tau_s.is_finite() && c.derivative_tau_s >= 0.0) {
            c.derivative_tau_s = 0.0;
        }
        if !(c.max_dt_s.is_finite() && c.max_dt_s > 0.0) {
            c.max_dt_s = 1.0;
        }
        if c.functional_band_k.is_nan() || c.functional_band_k <= 0.0 {
            c.functional_band_k = f32::INFINITY;
        }
        c
    }
}

/// Why a setter refused its argument (the previous value stays).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PidError {
    /// A gain was NaN, infinite or negative.
    InvalidGains,
    /// The target was NaN or infinite.
    InvalidTarget,
}

/// The three terms of the last output, in output units (for logs and the console).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct PidTerms {
    /// Proportional term.
    pub p: f32,
    /// Integral term.
    pub i: f32,
    /// Derivative term (negative while the temperature rises).
    pub d: f32,
}

/// A PID controller (see the module docs for how it is built).
#[derive(Clone, Debug)]
pub struct Pid {
    config: PidConfig,
    target_k: f32,
    /// I term in output units, within [output_min, output_max].
    integral: f32,
    /// Filtered measured slope, K/s.
    slope_k_per_s: f32,
    /// Previous valid measurement (None after a reset, a gap or a bad sample).
    prev_measured_k: Option<f32>,
    /// Last output returned (or set by `reset_to`), if any since the last `reset`.
    last_output: Option<f32>,
    /// Recompute the integrator at the next sample so the output equals this.
    align_to: Option<f32>,
    terms: PidTerms,
    /// Whether the last sample was outside the functional range.
    outside_band: bool,
}

impl Pid {
    /// Make a controller holding `target_k`. An invalid `config` is
    /// [sanitized](PidConfig::sanitized); a non-finite target gives the safe output until
    /// [`Pid::set_target`] sets a valid one.
    pub fn new(config: PidConfig, target_k: f32) -> Pid {
        Pid {
            config: config.sanitized(),
            target_k,
            integral: 0.0,
            slope_k_per_s: 0.0,
            prev_measured_k: None,
            last_output: None,
            align_to: None,
            terms: PidTerms::default(),
            outside_band: false,
        }
    }

    /// Return the configuration in use.
    pub fn config(&self) -> &PidConfig {
        &self.config
    }

    /// Return the target, K.
    pub fn target_k(&self) -> f32 {
        self.target_k
    }

    /// Return the last output (the safe output before the first sample).
    pub fn output(&self) -> f32 {
        self.last_output.unwrap_or_else(|| self.safe_output())
    }

    /// Return the terms of the last output.
    pub fn terms(&self) -> PidTerms {
        self.terms
    }

    /// Return the output given for bad input: 0 clamped into the output range.
    pub fn safe_output(&self) -> f32 {
        clamp(0.0, self.config.output_min, self.config.output_max)
    }

    /// Change the gains, bumplessly: the next output equals the last one (if there was one since
    /// the last [`Pid::reset`]) and moves on from there with the new gains. Invalid gains are
    /// refused and the old ones kept.
    pub fn set_gains(&mut self, gains: PidGains) -> Result<(), PidError> {
        if !gains.is_valid() {
            return Err(PidError::InvalidGains);
        }
        self.config.gains = gains;
        self.align_to = self.last_output;
        Ok(())
    }

    /// Change the target, bumplessly: the next output equals the last one, if there was one
    /// since the last [`Pid::reset`] (the proportional step is taken into the integrator,
    /// within its clamp). To answer a new target with a step instead, call [`Pid::reset`]
    /// first. A non-finite target is refused and the old one kept.
    pub fn set_target(&mut self, target_k: f32) -> Result<(), PidError> {
        if !target_k.is_finite() {
            return Err(PidError::InvalidTarget);
        }
        if target_k != self.target_k {
            self.target_k = target_k;
            self.align_to = self.last_output;
        }
        Ok(())
    }

    /// Forget all state: integrator 0, derivative restarted, no last output.
    pub fn reset(&mut self) {
        self.integral = 0.0;
        self.slope_k_per_s = 0.0;
        self.prev_measured_k = None;
        self.last_output = None;
        self.align_to = None;
        self.terms = PidTerms::default();
        self.outside_band = false;
    }

    /// Take over from whatever drove the actuator at `output` (clamped to the range; NaN gives
    /// the safe output): the derivative restarts and the next sample's output is `output`.
    pub fn reset_to(&mut self, output: f32) {
        self.reset();
        let u = if output.is_nan() {
            self.safe_output()
        } else {
            clamp(output, self.config.output_min, self.config.output_max)
        };
        self.last_output = Some(u);
        self.align_to = Some(u);
    }

    /// Feed one measurement taken `dt` after the previous one and return the output, in
    /// `[output_min, output_max]`.
    ///
    /// A non-finite `measured_k` (or target) returns [`Pid::safe_output`], keeps the integrator
    /// and restarts the derivative. A `dt` that is ≤ 0 or above `max_dt_s` neither integrates
    /// nor differentiates (D = 0) this sample ([`Seconds`] is never NaN).
    pub fn update(&mut self, measured_k: f32, dt: Seconds) -> f32 {
        let dt_s = dt.s();
        let c = self.config;
        if !measured_k.is_finite() || !self.target_k.is_finite() {
            self.prev_measured_k = None;
            self.slope_k_per_s = 0.0;
            let u = self.safe_output();
            self.terms = PidTerms::default();
            self.last_output = Some(u);
            return u;
        }
        let dt_ok = dt_s > 0.0 && dt_s <= c.max_dt_s;
        // Filtered slope of the measurement.
        match self.prev_measured_k {
            Some(prev) if dt_ok => {
                let raw = (measured_k - prev) / dt_s;
                let alpha = if c.derivative_tau_s > 0.0 {
                    1.0 - libm::expf(-dt_s / c.derivative_tau_s)
                } else {
                    1.0
                };
                self.slope_k_per_s += alpha * (raw - self.slope_k_per_s);
                if !self.slope_k_per_s.is_finite() {
                    self.slope_k_per_s = 0.0;
                }
            }
            _ => self.slope_k_per_s = 0.0,
        }
        let integrate = dt_ok && self.prev_measured_k.is_some();
        self.prev_measured_k = Some(measured_k);

        let e = self.target_k - measured_k;
        if e.abs() > c.functional_band_k {
            // Marlin's functional range: bang-bang, integrator reset.
            self.outside_band = true;
            self.integral = 0.0;
            self.align_to = None;
            let u = if e > 0.0 { c.output_max } else { c.output_min };
            self.terms = PidTerms::default();
            self.last_output = Some(u);
            return u;
        }
        if self.outside_band {
            // Back inside: start the integrator from 0 as Marlin does.
            self.outside_band = false;
            self.integral = 0.0;
        }

        let g = c.gains;
        let p = g.kp_per_k * e;
        let d = -g.kd_s_per_k * self.slope_k_per_s;
        if let Some(u) = self.align_to.take() {
            self.integral = u - p - d;
        } else if integrate {
            let tentative = clamp(
                self.integral + g.ki_per_k_s * e * dt_s,
                c.output_min,
                c.output_max,
            );
            let raw = p + tentative + d;
            // Conditional integration: the integral grows up to where the output meets its
            // limit, never past it (and the limit never unwinds it). Refusing the whole step
            // instead left a large proportional term short of the limit for good: a cold day's
            // inner loop held the film 6 K under its setpoint at 80 % duty with I = 0.
            self.integral = if raw > c.output_max && e > 0.0 {
                tentative.min((c.output_max - p - d).max(self.integral))
            } else if raw < c.output_min && e < 0.0 {
                tentative.max((c.output_min - p - d).min(self.integral))
            } else {
                tentative
            };
        }
        if !self.integral.is_finite() {
            self.integral = 0.0;
        }
        self.integral = clamp(self.integral, c.output_min, c.output_max);
        let raw = p + self.integral + d;
        let u = if raw.is_nan() {
            self.safe_output()
        } else {
            clamp(raw, c.output_min, c.output_max)
        };
        self.terms = PidTerms {
            p,
            i: self.integral,
            d,
        };
        self.last_output = Some(u);
        u
    }
}
