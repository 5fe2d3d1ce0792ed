//! Every tunable number of the controller in one table: targets, gains, weights, durations and
//! limits, with units and ranges.
//!
//! This module owns the parameter list. [`PARAMS`] drives the console's `get`, `set` and
//! `settings`, docs/console.md's list and the stored settings record, so a parameter exists in
//! exactly one place. Values are `f32` in the unit the name ends with (`_k` Kelvin, `_s`
//! seconds, `_pct` percent, gains per Kelvin of error on a duty fraction).

use crate::control::{OnTimer, PidGains};
use crate::mtts::Weights;
use crate::observer::ObserverParams;

/// The PID gains the block ships with: what `autotune` (relay around 340 K, Ziegler–Nichols'
/// classic rule) measured on the simulated block at 298 K ambient — Ku = 0.231 /K, Tu = 3.5 s.
pub const DEFAULT_GAINS: PidGains = PidGains {
    kp_per_k: 0.139,
    ki_per_k_s: 0.079,
    kd_s_per_k: 0.061,
};

/// The springs' temperature band's top, K: the thesis's A_f (351 K) plus the Clausius–Clapeyron
/// shift of a spring stretched by the bend (a spring pulling ≈ 35 N carries ≈ 280 MPa:
/// +20 K at Brinson's 13.8 MPa/K), so a loaded spring still finishes its transformation; 10 K
/// below [`SPRING_MAX_K`], the margin the observer's spring error needs (docs/observer.md).
pub const SPRING_HOT_K: f32 = 373.0;
/// The springs' over-temperature limit by the estimate, K (issue 19's default).
pub const SPRING_MAX_K: f32 = 383.0;
/// The ambient at which the springs' pre-warm is `spring_prewarm_k` as set, K: the thesis's
/// lab (298.15 K), where its 7 s pre-warm gives ≈ 322 K.
pub const PREWARM_REFERENCE_K: f32 = 298.15;

/// The controller's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Standby target, K (SPEC 4: 323 K, never above).
    pub standby_k: f32,
    /// Stepping and recovery target, K (358 K: the whole cross-section above the transition).
    pub hot_k: f32,
    /// Forming ends once the hotter target is at or below this, K.
    pub form_end_k: f32,
    /// PID gains of the heater/fan loop.
    pub gains: PidGains,
    /// Gains of the cascade's outer loop (where Tc weighs the colder region): K of film
    /// offset per K of Tc error.
    pub outer_gains: PidGains,
    /// Time constant of the derivative's low-pass filter, s.
    pub d_filter_s: f32,
    /// Outside ±this of the target the loop drives bang-bang and resets its integrator, K.
    pub functional_band_k: f32,
    /// Weight of T1 in Tc in standby (T2 gets 1 − w1). With the heating modes' ordering (T1 =
    /// the hotter of the pair) 1 holds the hottest region at `standby_k`: "never above".
    pub w1_standby: f32,
    /// Weight of T1 in Tc in stepping: 0 brings the colder region (the whole cross-section) to
    /// `hot_k`.
    pub w1_step: f32,
    /// Weight of T1 in Tc in recovery: 0, as in stepping — the reheat drives the film to its
    /// ceiling until the colder region is at `hot_k`, the fastest the heater can soften the
    /// wall (and what the soak's "can it soften" projection assumes); the observer's inner-layer
    /// cap keeps the unseen inner layer below `t_max_k`. (With readiness by Tc, 0.5 was faster;
    /// readiness is now by softness. 0.5 stayed the default until the wall's refit, where a
    /// loop on half the film drove the heater and the fan in turn at ≈ 2 Hz through recovery's
    /// hold — 25 fan switches in the default cycle, one with 0 — and ended 1.5° bent, 0.1°
    /// with 0.)
    pub w1_recover: f32,
    /// Weight of T1 in Tc in forming (ordering: T1 = the colder, heater side): 0 cools until the
    /// hotter region is at `form_end_k`.
    pub w1_form: f32,
    /// While heating, the heater duty is cut in proportion as the hotter region comes within
    /// `heater_cap_band_k` of this, K (an override that keeps the film below its limit while
    /// the loop brings the colder region up).
    pub heater_cap_k: f32,
    /// Width of the heater cap's proportional band, K.
    pub heater_cap_band_k: f32,
    /// Over-temperature limit of the hotter region and the frame's hottest pixel (the PI
    /// heater film seen through the lattice, or a burning spring beside the cylinder), K.
    pub t_heater_max_k: f32,
    /// Stepping and recovery give up (to standby, with an event) if Tc is not ready by then, s.
    pub soak_timeout_s: f32,
    /// Forming gives up (to standby, with an event) if not cool by then, s.
    pub form_timeout_s: f32,
    /// Stepping: the springs' pre-warm pulse once the soak is done (0: none), s.
    pub prewarm_s: f32,
    /// Stepping: springs off after the pre-warm, before the first stepping phase, s.
    pub prewarm_gap_s: f32,
    /// Length of one stepping phase (springs on), s.
    pub step_s: f32,
    /// Length of one pulsing phase (springs off between steps), s.
    pub pulse_s: f32,
    /// Stepping phases in large stepping.
    pub large_steps: u8,
    /// Recovery: length of the pulse on all springs, s.
    pub recover_pulse_s: f32,
    /// Recovery: time held at `hot_k` after the pulse before standby, s.
    pub recover_hold_s: f32,
    /// A new stepping waits (holding `hot_k`, phase `rest`) until every spring's estimated
    /// austenite fraction is at most this (martensite again), fraction — or, on a day too warm
    /// for martensite, until the spring has cooled to within 3 K of the estimated ambient.
    pub spring_rest: f32,
    /// Recovery's pulse waits until every spring's estimated austenite fraction is at least
    /// this, fraction.
    pub spring_recover: f32,
    /// Recovery drives the springs in windows of this on, s (at most `spring_on_max_s`).
    pub recover_on_s: f32,
    /// ... and this off, which ends each continuous on-time, s.
    pub recover_off_s: f32,
    /// Fan duty in forming, fraction.
    pub form_fan: f32,
    /// Split range: loop outputs within ±this drive neither heater nor fan, fraction.
    pub fan_deadband: f32,
    /// Over-temperature limit of the SMP: the colder of T1/T2 and regions 4–5, K.
    pub t_max_k: f32,
    /// Longest a spring may stay on continuously, s.
    pub spring_on_max_s: f32,
    /// Highest spring duty over the duty window, fraction.
    pub spring_duty_max: f32,
    /// Window of the spring duty limit, s.
    pub spring_window_s: f32,
    /// Sensor loss: longest time without a valid measurement, s.
    pub sensor_timeout_s: f32,
    /// Runaway while heating: the least rise expected within `runaway_window_s`, K.
    pub runaway_gain_k: f32,
    /// Runaway while heating: the window, s.
    pub runaway_window_s: f32,
    /// Runaway while heating: the check runs while the heater's duty is at least this, fraction.
    pub runaway_duty: f32,
    /// Runaway while holding: errors within ±this count as held, K.
    pub hold_band_k: f32,
    /// Runaway while holding: the largest accumulated error beyond the band, K·s.
    pub hold_max_error_ks: f32,
    /// Autotune: relay target, K.
    pub tune_k: f32,
    /// Autotune: the relay's middle duty (it swings base ± amplitude), fraction.
    pub tune_base: f32,
    /// Autotune: relay amplitude (heater duty swings base ± this), fraction.
    pub tune_amplitude: f32,
    /// Autotune: longest run before it gives up, s (at most 900 s: a relay test needs minutes).
    pub tune_timeout_s: f32,
    /// No-response check: the heater at `runaway_duty` or more this long without the film
    /// rising `runaway_gain_k` is a fault, whatever the mode, s.
    pub no_response_s: f32,
    /// While heating on the colder region, this long a run of frames that could not separate
    /// T1 and T2 for sure (ambiguous, merged or fallback) makes the loop fall back to the film region, with a
    /// `# warning`, s.
    pub unresolved_s: f32,
    /// Idle timeout of the holding phases (stepping's hold and pause): after this the block
    /// returns to standby with a `log` event, s.
    pub hold_timeout_s: f32,
    /// Readiness by softness: stepping and recovery start the springs once the estimated
    /// wall's frozen fraction is at most this, fraction.
    pub soft_frozen_max: f32,
    /// A soak whose wall is not soft this long after the mode began says so (`# warning`
    /// with the estimate), and ends at once if the model says the heater cannot soften it, s.
    pub soft_warn_s: f32,
    /// The springs' temperature band: a driven spring is on while its estimate is below this,
    /// K.
    pub spring_hot_k: f32,
    /// ... and, once off, on again below `spring_hot_k` − this (the band), K.
    pub spring_band_k: f32,
    /// The springs' pre-warm drives each spring to this, K: 322 K is what the thesis's 7 s
    /// pre-warm gives at 298 K, so the first step loads as it did there, on any day (on a cold
    /// one in several `prewarm_s` pulses, on a warm one with none).
    pub spring_prewarm_k: f32,
    /// ... raised by this much per kelvin the estimated ambient is below
    /// [`PREWARM_REFERENCE_K`] (never past `sma_as_k` − 1 K: the pre-warm must not start the
    /// stroke), K/K. A cold room takes more of the four steps' heat and leaves the springs short
    /// of austenite: at 273 K the default's 0.32 (334 K) loads 63.6° where 326 K loaded 49.7°.
    pub spring_prewarm_cold_k_per_k: f32,
    /// A spring whose estimate passes this is a fault (`spring-over-temperature`), K.
    pub spring_max_k: f32,
    /// Observer: heater power at full duty, W.
    pub obs_heater_w: f32,
    /// Observer: the SMP wall's heat capacity (both layers), J/K.
    pub obs_wall_j_per_k: f32,
    /// Observer: one spring's Joule power at full current (martensite), W.
    pub obs_spring_w: f32,
    /// Observer: one spring's heat capacity, J/K.
    pub obs_spring_j_per_k: f32,
    /// Observer: one spring's latent heat of transformation, J.
    pub obs_spring_latent_j: f32,
    /// Observer: one spring's loss to still air, W/K.
    pub obs_spring_loss_w_per_k: f32,
    /// Observer: the springs' austenite start, K (thesis 6.3.1).
    pub sma_as_k: f32,
    /// Observer: the springs' austenite finish, K.
    pub sma_af_k: f32,
    /// Observer: the springs' martensite start, K.
    pub sma_ms_k: f32,
    /// Observer: the springs' martensite finish, K.
    pub sma_mf_k: f32,
    /// Observer: centre of the wall's frozen fraction, K (PLA's transition).
    pub smp_frozen_centre_k: f32,
    /// Observer: width of the frozen fraction's logistic, K.
    pub smp_frozen_width_k: f32,
    /// A pose (`mode pose ANGLE`) has reached its target once the bend estimate is within
    /// this of it after a settle, degrees.
    pub pose_tol_deg: f32,
    /// Where the camera looks from: the direction of its image's rows (left to right) in the
    /// block's cross-section, measured from spring A towards spring B, degrees. 0 (the
    /// product's mount) sees spring A's plane across the view; 90 sees it along the line of
    /// sight (docs/posture.md).
    pub cam_azimuth_deg: f32,
    /// What a power-up starts in: 0 `stopped` (every output off until a `mode` command, as
    /// Marlin and Klipper never heat at boot), 1 `standby`. Any other reset starts stopped.
    pub boot_mode: u8,
    /// A spring channel conducting at least this with its gate off, two samples running, has a
    /// MOSFET failed short (`spring-stuck-on`), A.
    pub spring_leak_a: f32,
    /// A spring channel carrying less than this with its gate on, two samples running, is open
    /// (`spring-open`), A.
    pub spring_open_a: f32,
    /// A spring channel carrying more than this in any sample is shorted (`spring-short`), A.
    pub spring_short_a: f32,
    /// A spring supply reading below this under load, short of its current limit, sags (a `#
    /// warning`), V.
    pub spring_supply_min_v: f32,
    /// Gain trims of the spring current channels A, B, C (a fraction, 1 = nominal).
    pub i_trim: [f32; 3],
    /// Gain trims of the spring supply channels A, B, C (a fraction, 1 = nominal).
    pub v_trim: [f32; 3],
}

impl Settings {
    /// The defaults: SPEC sections 4 and 5 and the tuned gains.
    pub const DEFAULT: Settings = Settings {
        standby_k: 323.0,
        hot_k: 358.0,
        form_end_k: 323.0,
        gains: DEFAULT_GAINS,
        outer_gains: PidGains {
            kp_per_k: 8.0,
            ki_per_k_s: 1.0,
            kd_s_per_k: 0.0,
        },
        d_filter_s: 1.0,
        functional_band_k: 50.0,
        w1_standby: 1.0,
        w1_step: 0.0,
        w1_recover: 0.0,
        w1_form: 0.0,
        heater_cap_k: 393.0,
        heater_cap_band_k: 4.0,
        t_heater_max_k: 403.0,
        soak_timeout_s: 300.0,
        form_timeout_s: 300.0,
        prewarm_s: 7.0,
        prewarm_gap_s: 1.0,
        step_s: 6.0,
        pulse_s: 2.0,
        large_steps: 4,
        recover_pulse_s: 1.0,
        recover_hold_s: 15.0,
        spring_rest: 0.1,
        spring_recover: 0.95,
        recover_on_s: 7.0,
        recover_off_s: 1.0,
        form_fan: 1.0,
        fan_deadband: 0.02,
        t_max_k: 373.0,
        spring_on_max_s: 8.0,
        spring_duty_max: 0.6,
        spring_window_s: 60.0,
        sensor_timeout_s: 1.0,
        runaway_gain_k: 2.0,
        runaway_window_s: 20.0,
        runaway_duty: 0.8,
        hold_band_k: 5.0,
        hold_max_error_ks: 120.0,
        tune_k: 340.0,
        tune_base: 0.4,
        tune_amplitude: 0.3,
        tune_timeout_s: 600.0,
        no_response_s: 60.0,
        unresolved_s: 30.0,
        hold_timeout_s: 600.0,
        soft_frozen_max: 0.05,
        soft_warn_s: 120.0,
        spring_hot_k: SPRING_HOT_K,
        spring_band_k: 2.0,
        spring_prewarm_k: 326.0,
        spring_prewarm_cold_k_per_k: 0.32,
        spring_max_k: SPRING_MAX_K,
        obs_heater_w: ObserverParams::DEFAULT.heater_full_power_w,
        obs_wall_j_per_k: ObserverParams::DEFAULT.layer_capacity_j_per_k[0]
            + ObserverParams::DEFAULT.layer_capacity_j_per_k[1],
        obs_spring_w: ObserverParams::DEFAULT.springs.power_w,
        obs_spring_j_per_k: ObserverParams::DEFAULT.springs.capacity_j_per_k,
        obs_spring_latent_j: ObserverParams::DEFAULT.springs.latent_j,
        obs_spring_loss_w_per_k: ObserverParams::DEFAULT.springs.ambient_w_per_k,
        sma_as_k: ObserverParams::DEFAULT.springs.as_k,
        sma_af_k: ObserverParams::DEFAULT.springs.af_k,
        sma_ms_k: ObserverParams::DEFAULT.springs.ms_k,
        sma_mf_k: ObserverParams::DEFAULT.springs.mf_k,
        smp_frozen_centre_k: ObserverParams::DEFAULT.frozen_centre_k,
        smp_frozen_width_k: ObserverParams::DEFAULT.frozen_width_k,
        pose_tol_deg: 2.0,
        cam_azimuth_deg: 0.0,
        boot_mode: 0,
        spring_leak_a: 0.5,
        spring_open_a: 2.0,
        spring_short_a: 20.0,
        spring_supply_min_v: 4.5,
        i_trim: [1.0; 3],
        v_trim: [1.0; 3],
    };

    /// The springs' pre-warm target at an estimated ambient, K: `spring_prewarm_k`, raised by
    /// `spring_prewarm_cold_k_per_k` per kelvin below [`PREWARM_REFERENCE_K`] (not lowered on a
    /// warm day), never past `sma_as_k` − 1 K unless `spring_prewarm_k` itself is; a
    /// non-finite ambient gets the plain `spring_prewarm_k`.
    pub fn prewarm_k(&self, ambient_k: f32) -> f32 {
        let cold_k = if ambient_k.is_finite() {
            (PREWARM_REFERENCE_K - ambient_k).max(0.0)
        } else {
            0.0
        };
        let raised = self.spring_prewarm_k + self.spring_prewarm_cold_k_per_k * cold_k;
        raised.min((self.sma_as_k - 1.0).max(self.spring_prewarm_k))
    }

    /// The observer's parameters: its defaults ([`ObserverParams::DEFAULT`]) with the ones
    /// this table holds (`obs_…`, `sma_…`, `smp_…`). The wall's capacity keeps the default
    /// split between its layers.
    pub fn observer_params(&self) -> ObserverParams {
        let mut p = ObserverParams::DEFAULT;
        p.heater_full_power_w = self.obs_heater_w;
        let default_wall: f32 = p.layer_capacity_j_per_k.iter().sum();
        let scale = self.obs_wall_j_per_k / default_wall;
        for c in p.layer_capacity_j_per_k.iter_mut() {
            *c *= scale;
        }
        p.springs.power_w = self.obs_spring_w;
        p.springs.capacity_j_per_k = self.obs_spring_j_per_k;
        p.springs.latent_j = self.obs_spring_latent_j;
        p.springs.ambient_w_per_k = self.obs_spring_loss_w_per_k;
        p.springs.as_k = self.sma_as_k;
        p.springs.af_k = self.sma_af_k;
        p.springs.ms_k = self.sma_ms_k;
        p.springs.mf_k = self.sma_mf_k;
        p.frozen_centre_k = self.smp_frozen_centre_k;
        p.frozen_width_k = self.smp_frozen_width_k;
        p
    }

    /// Return Tc weights with `w1` for T1.
    pub fn weights(w1: f32) -> Weights {
        Weights { w1, w2: 1.0 - w1 }
    }

    /// Check the relations between parameters that one range cannot express; the first rule
    /// broken is the error.
    pub fn check(&self) -> Result<(), ConflictError> {
        if self.standby_k >= self.hot_k {
            return Err(ConflictError::StandbyNotBelowHot);
        }
        if self.hot_k + 5.0 > self.t_max_k || self.standby_k + 5.0 > self.t_max_k {
            return Err(ConflictError::TargetsNearTMax);
        }
        if self.tune_k + 5.0 > self.t_max_k {
            return Err(ConflictError::TuneNearTMax);
        }
        if self.step_s > self.spring_on_max_s
            || self.recover_pulse_s > self.spring_on_max_s
            || self.prewarm_s > self.spring_on_max_s
            || self.recover_on_s > self.spring_on_max_s
        {
            return Err(ConflictError::SpringOnTooLong);
        }
        if self.heater_cap_k + 2.0 > self.t_heater_max_k {
            return Err(ConflictError::HeaterCapNearFilmLimit);
        }
        if self.hot_k > self.heater_cap_k {
            return Err(ConflictError::HotAboveHeaterCap);
        }
        if self.form_end_k > self.hot_k {
            return Err(ConflictError::FormEndAboveHot);
        }
        if self.tune_base + self.tune_amplitude > TUNE_DUTY_MAX + 1e-6 {
            return Err(ConflictError::TuneRelayTooStrong);
        }
        if self.recover_pulse_s > self.recover_on_s {
            return Err(ConflictError::RecoverPulseOutsideWindow);
        }
        if self.spring_hot_k + 10.0 > self.spring_max_k {
            return Err(ConflictError::SpringBandNearMax);
        }
        if self.spring_prewarm_k > self.spring_hot_k - self.spring_band_k {
            return Err(ConflictError::PrewarmAboveBand);
        }
        if !(self.sma_mf_k < self.sma_ms_k
            && self.sma_ms_k < self.sma_as_k
            && self.sma_as_k < self.sma_af_k
            && self.sma_af_k < self.spring_hot_k - self.spring_band_k)
        {
            return Err(ConflictError::TransformationOrder);
        }
        if self.spring_plan_peak_s() > self.spring_on_max_s {
            return Err(ConflictError::SteppingOnTimePastMax);
        }
        Ok(())
    }

    /// A large stepping's spring phases as planned, `(on, seconds)` in order: the pre-warm and
    /// its gap (if any), then every stepping phase with the pulses between (large stepping,
    /// which includes small).
    fn stepping_plan(&self) -> impl Iterator<Item = (bool, f32)> + use<> {
        let steps = self.large_steps.max(1) as usize;
        let (step_s, pulse_s) = (self.step_s, self.pulse_s);
        let prewarm = (self.prewarm_s > 0.0)
            .then_some([(true, self.prewarm_s), (false, self.prewarm_gap_s)])
            .into_iter()
            .flatten();
        let stepping = (0..steps).flat_map(move |i| {
            [
                (true, step_s),
                (false, if i + 1 < steps { pulse_s } else { 0.0 }),
            ]
        });
        prewarm.chain(stepping)
    }

    /// The longest continuous on-time any planned sequence of spring phases reaches, as the
    /// on-time limit counts it ([`OnTimer`]: a short gap does not end an on-time): the
    /// stepping's plan, and recovery's windows (on, off, repeated; the pulse runs inside an on
    /// window), s.
    pub fn spring_plan_peak_s(&self) -> f32 {
        let windows =
            (0..16).flat_map(|_| [(true, self.recover_on_s), (false, self.recover_off_s)]);
        OnTimer::peak_s(self.stepping_plan()).max(OnTimer::peak_s(windows))
    }
}

impl Settings {
    /// Return the first safety limit (its name) that `next` relaxes against these settings
    /// ([`Param::relax`]), if any.
    pub fn relaxed_by(&self, next: &Settings) -> Option<&'static str> {
        PARAMS
            .iter()
            .find(|p| p.relaxes((p.get)(self), (p.get)(next)))
            .map(|p| p.name)
    }
}

/// The highest relay duty autotune may ask for, fraction (`tune_base + tune_amplitude`).
pub const TUNE_DUTY_MAX: f32 = 0.9;

impl Settings {
    /// Return the autotune relay's expected period, s: what the current gains were tuned for
    /// (Ziegler–Nichols' `Ti = Tu/2`, the rule autotune applies), at least 5 s. The relay
    /// must switch at least every two of these once cycling.
    pub fn tune_expected_period_s(&self) -> f32 {
        let g = self.gains;
        let tu = if g.ki_per_k_s > 0.0 {
            2.0 * g.kp_per_k / g.ki_per_k_s
        } else {
            f32::INFINITY
        };
        tu.max(5.0)
    }
}

impl Default for Settings {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// One settable parameter.
pub struct Param {
    /// Name on the console.
    pub name: &'static str,
    /// Unit shown after the value (empty for a plain number).
    pub unit: &'static str,
    /// Smallest accepted value.
    pub min: f32,
    /// Largest accepted value.
    pub max: f32,
    /// One-line description (docs/console.md's table, the desk's completion). Not on the
    /// board, whose flash cannot spare the 2.5 KB of text: its console's `settings` shows each
    /// parameter's value, unit, default and range, and docs/console.md what each is.
    #[cfg(not(target_os = "none"))]
    pub help: &'static str,
    /// Read the value.
    pub get: fn(&Settings) -> f32,
    /// Write the value (already range-checked).
    pub set: fn(&mut Settings, f32),
    /// The value is a whole number.
    pub integer: bool,
    /// The value is shown in percent and kept as a fraction (`set` stores it / 100).
    pub percent: bool,
    /// Whether the parameter is a safety limit, and which way relaxes it: while a fault is
    /// latched `set` and `load` may tighten a limit but never relax one (SPEC section 5).
    pub relax: Relax,
}

/// Which way a safety limit is relaxed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Relax {
    /// Not a limit.
    No,
    /// A higher value relaxes it (a ceiling, a window, a timeout).
    Up,
    /// A lower value relaxes it (a floor: a rise required, a current required).
    Down,
}

impl Param {
    /// Return whether going from `old` to `new` relaxes this limit.
    pub fn relaxes(&self, old: f32, new: f32) -> bool {
        match self.relax {
            Relax::No => false,
            Relax::Up => new > old,
            Relax::Down => new < old,
        }
    }
}

macro_rules! param {
    ($name:literal, $unit:literal, $min:expr, $max:expr, $help:literal, |$s:ident| $field:expr) => {
        Param {
            name: $name,
            unit: $unit,
            min: $min,
            max: $max,
            #[cfg(not(target_os = "none"))]
            help: $help,
            get: |$s: &Settings| $field,
            set: |$s: &mut Settings, v: f32| $field = v,
            integer: false,
            percent: false,
            relax: Relax::No,
        }
    };
}

/// A whole-number parameter, kept as an integer (the record stores it as `f32`, whole; the
/// range check happens before `set`, so the cast is exact).
macro_rules! count {
    ($name:literal, $min:expr, $max:expr, $help:literal, |$s:ident| $field:expr) => {
        Param {
            name: $name,
            unit: "",
            min: $min,
            max: $max,
            #[cfg(not(target_os = "none"))]
            help: $help,
            get: |$s: &Settings| $field as f32,
            set: |$s: &mut Settings, v: f32| $field = v as _,
            integer: true,
            percent: false,
            relax: Relax::No,
        }
    };
}

/// A parameter shown in percent and kept as a fraction.
macro_rules! pct {
    ($name:literal, $min:expr, $max:expr, $help:literal, |$s:ident| $field:expr) => {
        Param {
            name: $name,
            unit: "%",
            min: $min,
            max: $max,
            #[cfg(not(target_os = "none"))]
            help: $help,
            get: |$s: &Settings| $field * 100.0,
            set: |$s: &mut Settings, v: f32| $field = v / 100.0,
            integer: false,
            percent: true,
            relax: Relax::No,
        }
    };
}

/// Every parameter, in the order of the stored record. Percent parameters are stored as
/// fractions inside and shown in percent; see [`Param::get`] of each.
pub const PARAMS: &[Param] = &[
    param!("standby_k", "K", 293.0, 343.0, "standby target", |s| s
        .standby_k),
    param!(
        "hot_k",
        "K",
        338.0,
        368.0,
        "stepping and recovery target",
        |s| s.hot_k
    ),
    param!(
        "form_end_k",
        "K",
        293.0,
        343.0,
        "forming ends at or below this",
        |s| s.form_end_k
    ),
    param!(
        "kp",
        "1/K",
        0.0,
        10.0,
        "proportional gain (duty per K)",
        |s| s.gains.kp_per_k
    ),
    param!("ki", "1/(K*s)", 0.0, 1.0, "integral gain", |s| s
        .gains
        .ki_per_k_s),
    param!("kd", "s/K", 0.0, 100.0, "derivative gain", |s| s
        .gains
        .kd_s_per_k),
    param!(
        "outer_kp",
        "K/K",
        0.0,
        20.0,
        "cascade outer loop: film offset per K",
        |s| s.outer_gains.kp_per_k
    ),
    param!(
        "outer_ki",
        "1/s",
        0.0,
        2.0,
        "cascade outer loop: integral gain",
        |s| s.outer_gains.ki_per_k_s
    ),
    param!(
        "d_filter_s",
        "s",
        0.0,
        10.0,
        "derivative low-pass time constant",
        |s| s.d_filter_s
    ),
    param!(
        "functional_band_k",
        "K",
        1.0,
        50.0,
        "bang-bang outside this of target",
        |s| s.functional_band_k
    ),
    param!(
        "w1_standby",
        "",
        0.0,
        1.0,
        "weight of T1 (the hotter) in Tc in standby",
        |s| s.w1_standby
    ),
    param!(
        "w1_step",
        "",
        0.0,
        1.0,
        "weight of T1 (the hotter) in Tc in stepping",
        |s| s.w1_step
    ),
    param!(
        "w1_recover",
        "",
        0.0,
        1.0,
        "weight of T1 (the hotter) in Tc in recovery",
        |s| s.w1_recover
    ),
    param!(
        "w1_form",
        "",
        0.0,
        1.0,
        "weight of T1 (the colder) in Tc in forming",
        |s| s.w1_form
    ),
    Param {
        relax: Relax::Up,
        ..param!(
            "heater_cap_k",
            "K",
            343.0,
            400.0,
            "heater duty cut as the hotter region nears this",
            |s| s.heater_cap_k
        )
    },
    Param {
        relax: Relax::Down,
        ..param!(
            "heater_cap_band_k",
            "K",
            0.5,
            20.0,
            "width of the heater cap",
            |s| s.heater_cap_band_k
        )
    },
    param!(
        "soak_timeout_s",
        "s",
        30.0,
        1800.0,
        "stepping/recovery give up heating after",
        |s| s.soak_timeout_s
    ),
    param!(
        "form_timeout_s",
        "s",
        30.0,
        1800.0,
        "forming gives up cooling after",
        |s| s.form_timeout_s
    ),
    param!(
        "prewarm_s",
        "s",
        0.0,
        15.0,
        "springs' pre-warm before stepping",
        |s| s.prewarm_s
    ),
    param!(
        "prewarm_gap_s",
        "s",
        0.0,
        10.0,
        "off after the pre-warm",
        |s| s.prewarm_gap_s
    ),
    param!("step_s", "s", 0.5, 15.0, "stepping phase", |s| s.step_s),
    param!("pulse_s", "s", 0.5, 30.0, "pulsing phase", |s| s.pulse_s),
    count!(
        "large_steps",
        1.0,
        10.0,
        "stepping phases in large stepping",
        |s| s.large_steps
    ),
    param!(
        "recover_pulse_s",
        "s",
        0.2,
        5.0,
        "recovery pulse on all springs",
        |s| s.recover_pulse_s
    ),
    param!(
        "recover_hold_s",
        "s",
        0.0,
        120.0,
        "recovery hold after the pulse",
        |s| s.recover_hold_s
    ),
    pct!(
        "spring_rest_pct",
        1.0,
        50.0,
        "stepping rests springs to this austenite",
        |s| s.spring_rest
    ),
    pct!(
        "spring_recover_pct",
        50.0,
        100.0,
        "recovery pulses once springs are this austenite",
        |s| s.spring_recover
    ),
    param!(
        "recover_on_s",
        "s",
        0.5,
        15.0,
        "recovery: spring window on",
        |s| s.recover_on_s
    ),
    param!(
        "recover_off_s",
        "s",
        0.5,
        30.0,
        "recovery: spring window off",
        |s| s.recover_off_s
    ),
    pct!("form_fan_pct", 10.0, 100.0, "fan duty in forming", |s| s
        .form_fan),
    pct!(
        "fan_deadband_pct",
        0.0,
        20.0,
        "split-range dead band",
        |s| s.fan_deadband
    ),
    Param {
        relax: Relax::Up,
        ..param!(
            "t_max_k",
            "K",
            330.0,
            383.0,
            "SMP over-temperature limit",
            |s| s.t_max_k
        )
    },
    Param {
        relax: Relax::Up,
        ..param!(
            "t_heater_max_k",
            "K",
            340.0,
            413.0,
            "heater-film over-temperature limit",
            |s| s.t_heater_max_k
        )
    },
    Param {
        relax: Relax::Up,
        ..param!(
            "spring_on_max_s",
            "s",
            1.0,
            15.0,
            "longest continuous spring on-time",
            |s| s.spring_on_max_s
        )
    },
    Param {
        relax: Relax::Up,
        ..pct!(
            "spring_duty_max_pct",
            10.0,
            80.0,
            "spring duty limit",
            |s| s.spring_duty_max
        )
    },
    Param {
        relax: Relax::Up,
        ..param!(
            "spring_window_s",
            "s",
            10.0,
            600.0,
            "spring duty window",
            |s| s.spring_window_s
        )
    },
    Param {
        relax: Relax::Up,
        ..param!(
            "sensor_timeout_s",
            "s",
            0.5,
            2.0,
            "sensor loss after this without a frame",
            |s| s.sensor_timeout_s
        )
    },
    Param {
        relax: Relax::Down,
        ..param!(
            "runaway_gain_k",
            "K",
            0.5,
            20.0,
            "least rise while heating hard",
            |s| s.runaway_gain_k
        )
    },
    Param {
        relax: Relax::Up,
        ..param!(
            "runaway_window_s",
            "s",
            5.0,
            120.0,
            "...within this window",
            |s| s.runaway_window_s
        )
    },
    Param {
        relax: Relax::Up,
        ..pct!(
            "runaway_duty_pct",
            30.0,
            100.0,
            "...while the heater is at least this",
            |s| s.runaway_duty
        )
    },
    Param {
        relax: Relax::Up,
        ..param!(
            "hold_band_k",
            "K",
            1.0,
            20.0,
            "holding: errors within this are fine",
            |s| s.hold_band_k
        )
    },
    Param {
        relax: Relax::Up,
        ..param!(
            "hold_max_error_ks",
            "K*s",
            10.0,
            2000.0,
            "holding: largest error beyond the band",
            |s| s.hold_max_error_ks
        )
    },
    param!("tune_k", "K", 303.0, 368.0, "autotune target", |s| s.tune_k),
    pct!(
        "tune_base_pct",
        10.0,
        90.0,
        "autotune relay middle duty",
        |s| s.tune_base
    ),
    pct!(
        "tune_amplitude_pct",
        5.0,
        50.0,
        "autotune relay amplitude",
        |s| s.tune_amplitude
    ),
    param!(
        "tune_timeout_s",
        "s",
        60.0,
        900.0,
        "autotune time limit",
        |s| s.tune_timeout_s
    ),
    Param {
        relax: Relax::Up,
        ..param!(
            "no_response_s",
            "s",
            20.0,
            600.0,
            "fault if the heater runs hard this long and the film does not rise",
            |s| s.no_response_s
        )
    },
    param!(
        "unresolved_s",
        "s",
        5.0,
        300.0,
        "loop falls back to the film after this long unresolved",
        |s| s.unresolved_s
    ),
    param!(
        "hold_timeout_s",
        "s",
        10.0,
        7200.0,
        "holding phases return to standby after",
        |s| s.hold_timeout_s
    ),
    pct!(
        "soft_frozen_max_pct",
        0.5,
        50.0,
        "springs start once the wall is this frozen at most",
        |s| s.soft_frozen_max
    ),
    param!(
        "soft_warn_s",
        "s",
        10.0,
        900.0,
        "warn if the wall is not soft after",
        |s| s.soft_warn_s
    ),
    Param {
        relax: Relax::Up,
        ..param!(
            "spring_hot_k",
            "K",
            345.0,
            393.0,
            "springs driven up to this estimate",
            |s| s.spring_hot_k
        )
    },
    param!(
        "spring_band_k",
        "K",
        0.5,
        10.0,
        "...and on again this far below it",
        |s| s.spring_band_k
    ),
    param!(
        "spring_prewarm_k",
        "K",
        300.0,
        360.0,
        "springs' pre-warm target",
        |s| s.spring_prewarm_k
    ),
    param!(
        "spring_prewarm_cold_k_per_k",
        "K/K",
        0.0,
        1.0,
        "pre-warm raised per K of ambient below 298.15 K",
        |s| s.spring_prewarm_cold_k_per_k
    ),
    Param {
        relax: Relax::Up,
        ..param!(
            "spring_max_k",
            "K",
            360.0,
            403.0,
            "spring over-temperature limit (estimate)",
            |s| s.spring_max_k
        )
    },
    param!(
        "obs_heater_w",
        "W",
        5.0,
        100.0,
        "observer: heater power at full duty",
        |s| s.obs_heater_w
    ),
    param!(
        "obs_wall_j_per_k",
        "J/K",
        5.0,
        200.0,
        "observer: wall heat capacity",
        |s| s.obs_wall_j_per_k
    ),
    Param {
        relax: Relax::Down,
        ..param!(
            "obs_spring_w",
            "W",
            5.0,
            150.0,
            "observer: spring power at full current",
            |s| s.obs_spring_w
        )
    },
    param!(
        "obs_spring_j_per_k",
        "J/K",
        2.0,
        100.0,
        "observer: spring heat capacity",
        |s| s.obs_spring_j_per_k
    ),
    param!(
        "obs_spring_latent_j",
        "J",
        0.0,
        5000.0,
        "observer: spring latent heat",
        |s| s.obs_spring_latent_j
    ),
    Param {
        relax: Relax::Up,
        ..param!(
            "obs_spring_loss_w_per_k",
            "W/K",
            0.01,
            2.0,
            "observer: spring loss to still air",
            |s| s.obs_spring_loss_w_per_k
        )
    },
    param!(
        "sma_as_k",
        "K",
        300.0,
        380.0,
        "springs' austenite start",
        |s| s.sma_as_k
    ),
    param!(
        "sma_af_k",
        "K",
        300.0,
        380.0,
        "springs' austenite finish",
        |s| s.sma_af_k
    ),
    param!(
        "sma_ms_k",
        "K",
        280.0,
        370.0,
        "springs' martensite start",
        |s| s.sma_ms_k
    ),
    param!(
        "sma_mf_k",
        "K",
        280.0,
        370.0,
        "springs' martensite finish",
        |s| s.sma_mf_k
    ),
    param!(
        "smp_frozen_centre_k",
        "K",
        300.0,
        370.0,
        "wall's frozen fraction: centre",
        |s| s.smp_frozen_centre_k
    ),
    param!(
        "smp_frozen_width_k",
        "K",
        0.5,
        10.0,
        "wall's frozen fraction: width",
        |s| s.smp_frozen_width_k
    ),
    param!(
        "pose_tol_deg",
        "deg",
        0.5,
        10.0,
        "a pose is reached within this of its angle",
        |s| s.pose_tol_deg
    ),
    param!(
        "cam_azimuth_deg",
        "deg",
        -180.0,
        180.0,
        "camera's image rows from spring A, towards B",
        |s| s.cam_azimuth_deg
    ),
    count!(
        "boot_mode",
        0.0,
        1.0,
        "what a power-up starts in: 0 stopped, 1 standby",
        |s| s.boot_mode
    ),
    Param {
        relax: Relax::Up,
        ..param!(
            "spring_leak_a",
            "A",
            0.1,
            2.0,
            "a spring conducting this with its gate off is stuck on",
            |s| s.spring_leak_a
        )
    },
    Param {
        relax: Relax::Down,
        ..param!(
            "spring_open_a",
            "A",
            0.5,
            8.0,
            "a spring carrying less with its gate on is open",
            |s| s.spring_open_a
        )
    },
    Param {
        relax: Relax::Up,
        ..param!(
            "spring_short_a",
            "A",
            16.0,
            30.0,
            "a spring carrying more is shorted",
            |s| s.spring_short_a
        )
    },
    param!(
        "spring_supply_min_v",
        "V",
        3.0,
        5.0,
        "a spring supply under this under load sags (warning)",
        |s| s.spring_supply_min_v
    ),
    pct!(
        "trim_ia_pct",
        80.0,
        120.0,
        "gain trim of spring A's current",
        |s| s.i_trim[0]
    ),
    pct!(
        "trim_ib_pct",
        80.0,
        120.0,
        "gain trim of spring B's current",
        |s| s.i_trim[1]
    ),
    pct!(
        "trim_ic_pct",
        80.0,
        120.0,
        "gain trim of spring C's current",
        |s| s.i_trim[2]
    ),
    pct!(
        "trim_va_pct",
        80.0,
        120.0,
        "gain trim of spring A's supply",
        |s| s.v_trim[0]
    ),
    pct!(
        "trim_vb_pct",
        80.0,
        120.0,
        "gain trim of spring B's supply",
        |s| s.v_trim[1]
    ),
    pct!(
        "trim_vc_pct",
        80.0,
        120.0,
        "gain trim of spring C's supply",
        |s| s.v_trim[2]
    ),
];

/// A relation between parameters that [`Settings::check`] refuses: one variant per rule, in the
/// order they are checked. [`fmt::Display`](core::fmt::Display) gives the console's message
/// (`err conflict: …`); it is written by hand, as `thiserror` is not used in this `no_std`
/// crate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum ConflictError {
    /// `standby_k` ≥ `hot_k`.
    StandbyNotBelowHot,
    /// `hot_k` or `standby_k` less than 5 K below `t_max_k`.
    TargetsNearTMax,
    /// `tune_k` less than 5 K below `t_max_k`.
    TuneNearTMax,
    /// A single spring on-time (`step_s`, `prewarm_s`, `recover_pulse_s`, `recover_on_s`) past `spring_on_max_s`.
    SpringOnTooLong,
    /// `heater_cap_k` less than 2 K below `t_heater_max_k`.
    HeaterCapNearFilmLimit,
    /// `hot_k` above `heater_cap_k`.
    HotAboveHeaterCap,
    /// `form_end_k` above `hot_k`.
    FormEndAboveHot,
    /// `tune_base_pct` + `tune_amplitude_pct` above 90 %.
    TuneRelayTooStrong,
    /// `recover_pulse_s` longer than `recover_on_s`.
    RecoverPulseOutsideWindow,
    /// `spring_hot_k` less than 10 K below `spring_max_k`.
    SpringBandNearMax,
    /// `spring_prewarm_k` above the band's bottom (`spring_hot_k` − `spring_band_k`).
    PrewarmAboveBand,
    /// The transformation temperatures out of order: Mf < Ms < As < Af < the band's bottom.
    TransformationOrder,
    /// The springs' phases add up past `spring_on_max_s`.
    SteppingOnTimePastMax,
}

impl ConflictError {
    /// Return the message (what [`fmt::Display`](core::fmt::Display) writes).
    pub fn message(self) -> &'static str {
        match self {
            Self::StandbyNotBelowHot => "standby_k must be below hot_k",
            Self::TargetsNearTMax => "targets must be at least 5 K below t_max_k",
            Self::TuneNearTMax => "tune_k must be at least 5 K below t_max_k",
            Self::SpringOnTooLong => {
                "step_s, prewarm_s, recover_pulse_s and recover_on_s must not exceed spring_on_max_s"
            }
            Self::HeaterCapNearFilmLimit => {
                "heater_cap_k must be at least 2 K below t_heater_max_k"
            }
            Self::HotAboveHeaterCap => "hot_k must not exceed heater_cap_k",
            Self::FormEndAboveHot => "form_end_k must not exceed hot_k",
            Self::TuneRelayTooStrong => "tune_base_pct + tune_amplitude_pct must not exceed 90 %",
            Self::RecoverPulseOutsideWindow => {
                "recover_pulse_s must not exceed recover_on_s (the pulse runs inside a window)"
            }
            Self::SpringBandNearMax => "spring_hot_k must be at least 10 K below spring_max_k",
            Self::PrewarmAboveBand => {
                "spring_prewarm_k must not exceed spring_hot_k - spring_band_k"
            }
            Self::TransformationOrder => {
                "need sma_mf_k < sma_ms_k < sma_as_k < sma_af_k < spring_hot_k - spring_band_k"
            }
            Self::SteppingOnTimePastMax => {
                "the springs' phases add up past spring_on_max_s: a gap shorter than 1 s (or 1/8 of the on-time before it) does not end an on-time"
            }
        }
    }
}

impl core::fmt::Display for ConflictError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.message())
    }
}

/// Why `set` refused a value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SetError {
    /// No parameter has that name.
    UnknownName,
    /// The value is not a finite number (or not whole where it must be).
    NotANumber,
    /// The value is outside the parameter's range.
    OutOfRange {
        /// Smallest accepted value.
        min: f32,
        /// Largest accepted value.
        max: f32,
    },
    /// The value contradicts another parameter.
    Conflict(ConflictError),
}

/// Return the parameter called `name` (case-insensitive).
pub fn find(name: &str) -> Option<&'static Param> {
    PARAMS.iter().find(|p| p.name.eq_ignore_ascii_case(name))
}

impl Settings {
    /// Return the value of the parameter called `name`.
    pub fn get(&self, name: &str) -> Option<f32> {
        find(name).map(|p| (p.get)(self))
    }

    /// Return these settings with `gains` (autotune's result), checked as `set kp`, `set ki`
    /// and `set kd` would check them: a gain out of its range, or not finite, is refused.
    pub fn with_gains(&self, gains: PidGains) -> Result<Settings, SetError> {
        let mut next = *self;
        next.set("kp", gains.kp_per_k)?;
        next.set("ki", gains.ki_per_k_s)?;
        next.set("kd", gains.kd_s_per_k)?;
        Ok(next)
    }

    /// Set the parameter called `name` to `value` (in its console unit); on any error nothing
    /// changes.
    pub fn set(&mut self, name: &str, value: f32) -> Result<(), SetError> {
        let p = find(name).ok_or(SetError::UnknownName)?;
        if !value.is_finite() || (p.integer && value != libm::roundf(value)) {
            return Err(SetError::NotANumber);
        }
        if !(p.min..=p.max).contains(&value) {
            return Err(SetError::OutOfRange {
                min: p.min,
                max: p.max,
            });
        }
        let mut next = *self;
        (p.set)(&mut next, value);
        next.check().map_err(SetError::Conflict)?;
        *self = next;
        Ok(())
    }
}

/// The stored settings record: every [`PARAMS`] value, versioned and CRC-checked.
///
/// Layout (little-endian, [`RECORD_LEN`] bytes):
///
/// | offset | bytes | field |
/// |---|---|---|
/// | 0 | 4 | magic `TMRS` |
/// | 4 | 2 | record version, [`RECORD_VERSION`] |
/// | 6 | 2 | number of values, `PARAMS.len()` |
/// | 8 | 4 | layout id: CRC-32 of the parameter names in [`PARAMS`] order, each ended by NUL |
/// | 12 | 4 × n | the values as `f32`, in [`PARAMS`] order and console units (`get` shows them) |
/// | 12 + 4n | 4 | CRC-32 (IEEE) of every byte before it |
///
/// The [`PARAMS`] table defines the record: adding, removing, renaming or reordering a
/// parameter changes the count or the layout id, so a record written by another firmware is
/// recognised as old and refused ([`RecordError::OtherLayout`]) instead of being read into the
/// wrong fields.
pub type Record = [u8; RECORD_LEN];

/// Version of the record format (the header and the encoding of values).
pub const RECORD_VERSION: u16 = 1;
/// The record's first four bytes.
pub const RECORD_MAGIC: [u8; 4] = *b"TMRS";
const HEADER_LEN: usize = 12;
/// Length of the stored record, bytes.
pub const RECORD_LEN: usize = HEADER_LEN + 4 * PARAMS.len() + 4;

/// Why a stored record was not used.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RecordError {
    /// Too short, or no record magic: nothing (or something else) is stored.
    NotARecord,
    /// The record's CRC does not match its bytes.
    BadCrc,
    /// Written by another record version.
    OtherVersion(u16),
    /// Written for another parameter table (count or names differ).
    OtherLayout,
    /// A value is not finite, not whole where it must be, or outside its range.
    BadValue(&'static str),
    /// The values contradict each other ([`Settings::check`]).
    Conflict(ConflictError),
}

impl RecordError {
    /// Return a short stable code.
    pub fn code(self) -> &'static str {
        match self {
            Self::NotARecord => "not-a-record",
            Self::BadCrc => "bad-crc",
            Self::OtherVersion(_) => "other-version",
            Self::OtherLayout => "other-layout",
            Self::BadValue(_) => "bad-value",
            Self::Conflict(_) => "conflict",
        }
    }
}

impl core::fmt::Display for RecordError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NotARecord => f.write_str("no settings record"),
            Self::BadCrc => f.write_str("CRC mismatch"),
            Self::OtherVersion(v) => write!(f, "record version {v}, expected {RECORD_VERSION}"),
            Self::OtherLayout => f.write_str("written for another parameter table"),
            Self::BadValue(name) => write!(f, "{name} invalid or out of range"),
            Self::Conflict(why) => write!(f, "values conflict: {why}"),
        }
    }
}

/// CRC-32 (IEEE 802.3, reflected, as zlib's `crc32`) of `bytes`, continuing from `crc` (start
/// with 0).
pub fn crc32(crc: u32, bytes: &[u8]) -> u32 {
    let mut c = !crc;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = (c >> 1) ^ (0xEDB8_8320 & (c & 1).wrapping_neg());
        }
    }
    !c
}

/// The record's layout id: CRC-32 of the names of [`PARAMS`], in order, each ended by NUL.
pub fn layout_id() -> u32 {
    PARAMS
        .iter()
        .fold(0, |c, p| crc32(crc32(c, p.name.as_bytes()), &[0]))
}

impl Settings {
    /// Encode every [`PARAMS`] value into a [`Record`].
    pub fn encode(&self) -> Record {
        let mut r = [0u8; RECORD_LEN];
        r[0..4].copy_from_slice(&RECORD_MAGIC);
        r[4..6].copy_from_slice(&RECORD_VERSION.to_le_bytes());
        r[6..8].copy_from_slice(&(PARAMS.len() as u16).to_le_bytes());
        r[8..12].copy_from_slice(&layout_id().to_le_bytes());
        for (i, p) in PARAMS.iter().enumerate() {
            let at = HEADER_LEN + 4 * i;
            // Percent values are fractions inside: ×100 may land one ulp past a bound.
            let v = crate::fmath::clamp((p.get)(self), p.min, p.max);
            r[at..at + 4].copy_from_slice(&v.to_le_bytes());
        }
        let crc = crc32(0, &r[..RECORD_LEN - 4]);
        r[RECORD_LEN - 4..].copy_from_slice(&crc.to_le_bytes());
        r
    }

    /// Decode a stored record (exactly [`RECORD_LEN`] bytes; longer input is refused too, as
    /// another layout). Every value is checked as `set` checks it, and the whole with
    /// [`Settings::check`]; on any error nothing is returned and the caller keeps or falls back
    /// to the defaults.
    pub fn decode(bytes: &[u8]) -> Result<Settings, RecordError> {
        if bytes.len() < HEADER_LEN || bytes[0..4] != RECORD_MAGIC {
            return Err(RecordError::NotARecord);
        }
        let u16_at = |i: usize| u16::from_le_bytes([bytes[i], bytes[i + 1]]);
        let u32_at =
            |i: usize| u32::from_le_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
        let version = u16_at(4);
        if version != RECORD_VERSION {
            return Err(RecordError::OtherVersion(version));
        }
        if bytes.len() != RECORD_LEN
            || u16_at(6) as usize != PARAMS.len()
            || u32_at(8) != layout_id()
        {
            // The CRC decides between a damaged record and another table's record.
            let n = bytes.len();
            if n >= HEADER_LEN + 4 && crc32(0, &bytes[..n - 4]) != u32_at(n - 4) {
                return Err(RecordError::BadCrc);
            }
            return Err(RecordError::OtherLayout);
        }
        if crc32(0, &bytes[..RECORD_LEN - 4]) != u32_at(RECORD_LEN - 4) {
            return Err(RecordError::BadCrc);
        }
        let mut s = Settings::DEFAULT;
        for (i, p) in PARAMS.iter().enumerate() {
            let v = f32::from_bits(u32_at(HEADER_LEN + 4 * i));
            let whole = !p.integer || v == libm::roundf(v);
            if !v.is_finite() || !whole || !(p.min..=p.max).contains(&v) {
                return Err(RecordError::BadValue(p.name));
            }
            (p.set)(&mut s, v);
        }
        s.check().map_err(RecordError::Conflict)?;
        Ok(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pre-warm rises 0.32 K per K below 298.15 K, never falls on a warm day, stops at
    /// A_s − 1 K (a colder room does not start the stroke), and a non-finite ambient gets
    /// `spring_prewarm_k`.
    #[test]
    fn the_prewarm_rises_on_a_cold_day_up_to_just_below_a_s() {
        let s = Settings::DEFAULT;
        assert_eq!(s.prewarm_k(PREWARM_REFERENCE_K), s.spring_prewarm_k);
        assert_eq!(s.prewarm_k(323.15), s.spring_prewarm_k);
        assert!((s.prewarm_k(273.15) - (s.spring_prewarm_k + 0.32 * 25.0)).abs() < 1e-3);
        assert_eq!(s.prewarm_k(200.0), s.sma_as_k - 1.0);
        assert_eq!(s.prewarm_k(f32::NAN), s.spring_prewarm_k);
        // A pre-warm set above A_s − 1 K by hand is kept, not lowered.
        let mut hot = s;
        hot.spring_prewarm_k = 345.0;
        assert_eq!(hot.prewarm_k(263.15), 345.0);
    }

    #[test]
    fn defaults_are_in_range_and_consistent() {
        let s = Settings::DEFAULT;
        s.check().unwrap();
        for p in PARAMS {
            let v = (p.get)(&s);
            assert!((p.min..=p.max).contains(&v), "{} = {v}", p.name);
            let mut t = s;
            t.set(p.name, v).unwrap();
            assert_eq!(t, s, "{} does not round-trip", p.name);
        }
    }

    #[test]
    fn names_are_unique_and_lower_case() {
        for (i, p) in PARAMS.iter().enumerate() {
            assert!(
                p.name
                    .bytes()
                    .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_')
            );
            assert!(
                PARAMS[i + 1..].iter().all(|q| q.name != p.name),
                "{}",
                p.name
            );
        }
    }

    #[test]
    fn set_checks_units_ranges_and_relations() {
        let mut s = Settings::DEFAULT;
        assert_eq!(s.set("HOT_K", 360.0), Ok(()));
        assert_eq!(s.hot_k, 360.0);
        assert_eq!(s.set("nope", 1.0), Err(SetError::UnknownName));
        assert_eq!(s.set("hot_k", f32::NAN), Err(SetError::NotANumber));
        assert_eq!(
            s.set("hot_k", 400.0),
            Err(SetError::OutOfRange {
                min: 338.0,
                max: 368.0
            })
        );
        assert!(matches!(s.set("step_s", 9.0), Err(SetError::Conflict(_))));
        assert!(matches!(
            s.set("large_steps", 2.5),
            Err(SetError::NotANumber)
        ));
        assert_eq!(s.set("form_fan_pct", 50.0), Ok(()));
        assert!((s.form_fan - 0.5).abs() < 1e-6);
        assert_eq!(s.hot_k, 360.0, "a refused set changes nothing");
    }
    #[test]
    fn crc32_matches_the_standard_check_value() {
        // The CRC catalogue's check value of CRC-32/ISO-HDLC ("123456789").
        assert_eq!(crc32(0, b"123456789"), 0xCBF4_3926);
        assert_eq!(crc32(crc32(0, b"1234"), b"56789"), 0xCBF4_3926);
        assert_eq!(crc32(0, b""), 0);
    }

    #[test]
    fn record_round_trips_every_parameter() {
        assert_eq!(RECORD_LEN, 12 + 4 * PARAMS.len() + 4);
        let d = Settings::DEFAULT;
        assert_eq!(Settings::decode(&d.encode()), Ok(d));
        // Every parameter moved to the other end of its range (where the relations allow).
        let mut s = d;
        for p in PARAMS {
            for v in [p.max, p.min, 0.5 * (p.min + p.max)] {
                let v = if p.integer { libm::roundf(v) } else { v };
                if s.set(p.name, v).is_ok() {
                    break;
                }
            }
        }
        assert_ne!(s, d);
        let back = Settings::decode(&s.encode()).unwrap();
        for p in PARAMS {
            let (a, b) = ((p.get)(&s), (p.get)(&back));
            assert!(
                (a - b).abs() <= 1e-6 * a.abs().max(1.0),
                "{}: {a} vs {b}",
                p.name
            );
        }
        // Stored once more it is the same record.
        assert_eq!(
            back.encode(),
            Settings::decode(&back.encode()).unwrap().encode()
        );
    }

    #[test]
    fn damaged_old_and_foreign_records_are_refused() {
        let good = Settings::DEFAULT.encode();
        assert_eq!(Settings::decode(&[]), Err(RecordError::NotARecord));
        assert_eq!(
            Settings::decode(&[0xFF; RECORD_LEN]),
            Err(RecordError::NotARecord)
        );
        // Every single-bit flip after the magic is caught.
        for byte in 4..RECORD_LEN {
            for bit in 0..8 {
                let mut r = good;
                r[byte] ^= 1 << bit;
                let e = Settings::decode(&r).unwrap_err();
                assert!(
                    matches!(e, RecordError::BadCrc | RecordError::OtherVersion(_)),
                    "byte {byte} bit {bit}: {e:?}"
                );
            }
        }
        // A truncated record.
        assert_eq!(
            Settings::decode(&good[..RECORD_LEN - 1]),
            Err(RecordError::BadCrc)
        );
        // Version 0 with a valid CRC.
        let mut old = good;
        old[4..6].copy_from_slice(&0u16.to_le_bytes());
        assert_eq!(Settings::decode(&old), Err(RecordError::OtherVersion(0)));
        // A table with one parameter more, correctly CRC'd: another layout.
        let mut longer = [0u8; RECORD_LEN + 4];
        longer[..RECORD_LEN - 4].copy_from_slice(&good[..RECORD_LEN - 4]);
        longer[6..8].copy_from_slice(&(PARAMS.len() as u16 + 1).to_le_bytes());
        let crc = crc32(0, &longer[..RECORD_LEN]);
        longer[RECORD_LEN..].copy_from_slice(&crc.to_le_bytes());
        assert_eq!(Settings::decode(&longer), Err(RecordError::OtherLayout));
        // Same length, names renamed: the layout id differs.
        let mut renamed = good;
        renamed[8..12].copy_from_slice(&(layout_id() ^ 1).to_le_bytes());
        let crc = crc32(0, &renamed[..RECORD_LEN - 4]);
        renamed[RECORD_LEN - 4..].copy_from_slice(&crc.to_le_bytes());
        assert_eq!(Settings::decode(&renamed), Err(RecordError::OtherLayout));
    }

    #[test]
    fn out_of_range_and_conflicting_values_are_refused_with_a_valid_crc() {
        let with = |name: &str, v: f32| {
            let i = PARAMS.iter().position(|p| p.name == name).unwrap();
            let mut r = Settings::DEFAULT.encode();
            r[12 + 4 * i..16 + 4 * i].copy_from_slice(&v.to_le_bytes());
            let crc = crc32(0, &r[..RECORD_LEN - 4]);
            r[RECORD_LEN - 4..].copy_from_slice(&crc.to_le_bytes());
            Settings::decode(&r)
        };
        assert_eq!(with("hot_k", 400.0), Err(RecordError::BadValue("hot_k")));
        assert_eq!(with("hot_k", f32::NAN), Err(RecordError::BadValue("hot_k")));
        assert_eq!(
            with("large_steps", 2.5),
            Err(RecordError::BadValue("large_steps"))
        );
        assert!(matches!(with("step_s", 9.0), Err(RecordError::Conflict(_))));
        assert_eq!(with("hot_k", 360.0).map(|s| s.hot_k), Ok(360.0));
    }

    #[test]
    fn records_that_would_defeat_a_limit_are_not_loaded() {
        let with = |pairs: &[(&str, f32)]| {
            let mut r = Settings::DEFAULT.encode();
            for &(name, v) in pairs {
                let i = PARAMS.iter().position(|p| p.name == name).unwrap();
                r[12 + 4 * i..16 + 4 * i].copy_from_slice(&v.to_le_bytes());
            }
            let crc = crc32(0, &r[..RECORD_LEN - 4]);
            r[RECORD_LEN - 4..].copy_from_slice(&crc.to_le_bytes());
            Settings::decode(&r)
        };
        // Past a range: the duty check off, an hour-long relay test.
        assert_eq!(
            with(&[("spring_duty_max_pct", 100.0)]),
            Err(RecordError::BadValue("spring_duty_max_pct"))
        );
        assert_eq!(
            with(&[("tune_timeout_s", 3600.0)]),
            Err(RecordError::BadValue("tune_timeout_s"))
        );
        // Combinations: a relay past 90 %, short gaps joining spring phases past the limit.
        for bad in [
            &[("tune_base_pct", 90.0), ("tune_amplitude_pct", 50.0)][..],
            &[("pulse_s", 0.5)],
            &[("prewarm_gap_s", 0.0)],
            &[("recover_off_s", 0.5)],
            &[("recover_pulse_s", 3.0), ("recover_on_s", 2.0)],
        ] {
            assert!(
                matches!(with(bad), Err(RecordError::Conflict(_))),
                "{bad:?}: {:?}",
                with(bad)
            );
        }
        // The same limits hold for `set`.
        let mut s = Settings::DEFAULT;
        assert!(matches!(s.set("pulse_s", 0.5), Err(SetError::Conflict(_))));
        assert_eq!(s, Settings::DEFAULT);
    }

    #[test]
    fn the_spring_plan_counts_gaps_as_the_limit_does() {
        let d = Settings::DEFAULT;
        // Pre-warm 7 s, then a 1 s gap clears it; each 6 s phase after a 2 s pulse.
        assert!((d.spring_plan_peak_s() - 7.0).abs() < 1e-4);
        let mut s = d;
        s.recover_on_s = 2.0;
        s.prewarm_s = 0.0;
        s.step_s = 3.0;
        s.pulse_s = 0.5;
        s.large_steps = 2;
        assert!((s.spring_plan_peak_s() - 6.0).abs() < 1e-4);
        s.large_steps = 3;
        assert!((s.spring_plan_peak_s() - 9.0).abs() < 1e-4);
    }
}
