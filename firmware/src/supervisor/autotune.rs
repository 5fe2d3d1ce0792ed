//! Autotune: a relay test around `tune_k` ([`RelayAutotune`]) under every safety check, whose
//! gains (Ziegler–Nichols' classic rule) replace the loop's if they pass the ranges `set`
//! checks; then standby.

use super::events::{EventKind, Notice};
use super::mode::{Ctx, Drive, Mode, ModeStep, Next};
use crate::control::{AutotuneConfig, AutotuneStep, RelayAutotune, TuneRule};
use crate::outputs::{Duty, SpringMask};
use crate::settings::Settings;

/// Autotune's state: the relay test.
#[derive(Clone, Debug)]
pub struct Tuning {
    relay: RelayAutotune,
}

impl Tuning {
    /// A relay test with `s`: base ± amplitude around `tune_k`, at most `tune_timeout_s`. The
    /// reading must follow the relay: rise as the runaway check asks while heating up to the
    /// band, and switch within two expected periods once cycling.
    pub fn start(s: &Settings) -> Tuning {
        // Ziegler–Nichols' classic rule: on the simulated block it gives 0.6 K of overshoot and
        // a ±0.2 K hold (docs/control-and-safety.md); the no-overshoot rule holds the standby target
        // ±0.3 K but takes 30 s to preheat.
        Tuning {
            relay: RelayAutotune::new(AutotuneConfig {
                rule: TuneRule::ZieglerNichols,
                timeout_s: s.tune_timeout_s,
                max_overshoot_k: (s.t_max_k - s.tune_k - 1.0).min(8.0),
                follow_s: 2.0 * s.tune_expected_period_s(),
                rise_k: s.runaway_gain_k,
                rise_window_s: s.runaway_window_s,
                ..AutotuneConfig::around(
                    s.tune_k,
                    Duty::from_fraction(s.tune_base),
                    s.tune_amplitude,
                )
            }),
        }
    }

    /// The relay's target, K.
    pub fn target_k(&self) -> f32 {
        self.relay.config().target_k
    }

    /// The relay test.
    pub fn relay(&self) -> &RelayAutotune {
        &self.relay
    }

    /// One step of autotune: the relay moves on every new measurement and holds its duty
    /// between them.
    pub(super) fn advance(&mut self, c: &mut Ctx) -> ModeStep {
        let relay = |d: Duty| ModeStep {
            drive: Drive::Relay(d),
            springs: SpringMask::NONE,
            next: None,
        };
        let Some(m) = c.fresh else {
            return relay(c.last_heater);
        };
        // Seconds since the run started: f32 keeps its resolution however long the board has
        // been up.
        let next = match self.relay.step(m.at.seconds_since(c.mode_since), c.tc_k) {
            AutotuneStep::Running { heater_duty } => return relay(heater_duty),
            // The tuned gains must pass the ranges `set` would check.
            AutotuneStep::Done(r) => match c.s.with_gains(r.gains) {
                Ok(tuned) => {
                    c.event(EventKind::Tuned {
                        ku_per_k: r.ku_per_k,
                        tu_s: r.tu_s,
                    });
                    c.announce(Notice::Tuned {
                        ku_per_k: r.ku_per_k,
                        tu_s: r.tu_s,
                        kp: tuned.gains.kp_per_k,
                        ki: tuned.gains.ki_per_k_s,
                        kd: tuned.gains.kd_s_per_k,
                    });
                    Next::Tuned(tuned)
                }
                Err(_) => abort(c, "gains out of range"),
            },
            AutotuneStep::Aborted(why) => abort(c, why.name()),
        };
        ModeStep {
            drive: Drive::Relay(Duty::OFF),
            springs: SpringMask::NONE,
            next: Some(next),
        }
    }
}

/// Give up the autotune for `why`: log it, say it on the console, back to standby (the gains
/// unchanged).
fn abort(c: &mut Ctx, why: &'static str) -> Next {
    c.event(EventKind::TuneAborted(why));
    c.announce(Notice::TuneAborted(why));
    Next::Enter(Mode::Standby)
}
