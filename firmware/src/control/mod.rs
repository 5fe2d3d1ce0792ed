//! The control law: a PID as heater firmwares build it, the heater/fan split range and the relay
//! autotune. Pure arithmetic on `f32` — no time source, no outputs, no modes.
//!
//! This module owns how a temperature error becomes a duty. The supervisor owns everything
//! around it (which temperature, which target, which mode, safety) and calls in here once per
//! measurement with the time since the previous one.
//!
//! - [`Pid`] ([`PidConfig`], [`PidGains`]): thesis eq. 6.14–6.16 with derivative on measurement
//!   and its low-pass filter, anti-windup, clamped output, Δt from measurement timestamps,
//!   bumpless changes of gains and target and [`Pid::reset_to`] for a mode taking over.
//! - [`SplitRange`]: one loop output in [−1, 1] to heater and fan duty, never both on.
//! - [`RelayAutotune`]: the Åström–Hägglund relay test, giving `Ku`, `Tu` and gains by a
//!   [`TuneRule`].
//! - [`OnTimer`]: a spring's continuous on-time as the safety limit counts it (short gaps
//!   pause it, only a long enough rest clears it).
//!
//! Nothing here panics: bad input (NaN, infinities, Δt ≤ 0 or too long, invalid gains) gives a
//! documented safe result.
//!
//! ```
//! use thermorph::control::{Pid, PidConfig, PidGains, SplitRange};
//! use thermorph::units::Seconds;
//!
//! let gains = PidGains { kp_per_k: 0.05, ki_per_k_s: 0.002, kd_s_per_k: 0.3 };
//! let mut pid = Pid::new(PidConfig::split_range(gains), 358.0);
//! let split = SplitRange::new(0.02);
//! // One measurement (Tc = 340 K) 0.25 s after the previous one.
//! let u = pid.update(340.0, Seconds::lit(0.25));
//! let duties = split.apply(u);
//! assert!(duties.heater.fraction() > 0.0 && duties.fan.fraction() == 0.0);
//! // A new target keeps the output continuous.
//! pid.set_target(360.0).unwrap();
//! assert!((pid.update(340.0, Seconds::lit(0.25)) - u).abs() < 1e-6);
//! ```

mod autotune;
mod on_time;
mod pid;
mod split;

pub use autotune::{
    AbortReason, AutotuneConfig, AutotuneResult, AutotuneStep, RelayAutotune, TuneRule,
};
pub use on_time::{OFF_MIN_S, OFF_RATIO, OnTimer};
pub use pid::{Pid, PidConfig, PidError, PidGains, PidTerms};
pub use split::{HeatCool, SplitRange};

#[cfg(test)]
mod tests;
