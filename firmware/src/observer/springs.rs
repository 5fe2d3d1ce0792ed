//! The springs' part of the observer: each SMA spring's temperature and austenite fraction,
//! propagated from its known switching and supply, its loss to the estimated ambient and its
//! gain from the estimated outer wall. The camera does not resolve the 2.3 mm wire, so these
//! are model states with a variance that grows while nothing corrects them and shrinks as the
//! spring settles to the (estimated) ambient; where the board senses its spring channels, a
//! driven spring's wire resistance gives its temperature, which raises an estimate that runs
//! under it ([`SpringFusion`]).
//!
//! Each spring is an enthalpy node, `H = C·T + L·a` (a the austenite fraction: forming
//! austenite absorbs the latent heat `L`), with linear hysteretic branches:
//!
//! ```text
//! heating:  a_h(T) = clamp((T − As)/(Af − As), 0, 1)   (austenite forms between As and Af)
//! cooling:  a_c(T) = clamp((T − Mf)/(Ms − Mf), 0, 1)   (martensite forms between Ms and Mf)
//! a ← clamp(a_old, a_h(T), a_c(T))                      (inner loops are flat)
//! ```
//!
//! A step first moves the sensible temperature exactly for the held inputs (an exponential
//! towards the node's equilibrium), then settles `(T, a)` on the same enthalpy: the branches
//! are linear, so the settling is solved in closed form, and the latent heat is never skipped
//! however long the step. The Joule power follows the phase (NiTi's resistivity rises
//! ≈ 12.5 % from martensite to austenite, Dynalloy: 80 → 90 µΩ·cm) at the channel's current
//! limit, or is the spring channel's measured power where that differs by more than
//! [`MEASURED_POWER_SHARE`] ([`SpringFusion`]).

use crate::outputs::SPRINGS;

/// Austenite's resistance over martensite's (Dynalloy: 90 / 80 µΩ·cm): the Joule power at a
/// current-limited channel rises by this much as the spring transforms.
pub const AUSTENITE_RESISTANCE_RATIO: f32 = 90.0 / 80.0;

/// The springs' model parameters (every spring alike).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpringParams {
    /// Joule power in one martensite spring at full current, W (15 A through ≈0.27 Ω).
    pub power_w: f32,
    /// One spring's heat capacity, J/K.
    pub capacity_j_per_k: f32,
    /// One spring's latent heat of a full transformation, J.
    pub latent_j: f32,
    /// One spring's loss to the still ambient air, W/K.
    pub ambient_w_per_k: f32,
    /// Heat path from the column's outer surface to a spring, W/K.
    pub column_w_per_k: f32,
    /// Austenite start, K.
    pub as_k: f32,
    /// Austenite finish, K.
    pub af_k: f32,
    /// Martensite start, K.
    pub ms_k: f32,
    /// Martensite finish, K.
    pub mf_k: f32,
    /// The wire's temperature coefficient of resistance within a phase, 1/K (0: none).
    pub tempco_per_k: f32,
    /// Process noise of a switched-on spring's temperature, K²/s (the supply, the wire's
    /// resistance, the load's shift of the transformation).
    pub on_process_k2_per_s: f32,
    /// Process noise of a switched-off spring's temperature, K²/s (the air around it).
    pub off_process_k2_per_s: f32,
}

/// One spring's estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpringState {
    /// Temperature, K.
    pub temp_k: f32,
    /// Austenite fraction, 0…1.
    pub austenite: f32,
    /// Variance of the temperature, K².
    pub var_k2: f32,
}

impl SpringState {
    /// A spring at `temp_k` in the phase the branches give it coming from martensite (below
    /// As: martensite; above Af: austenite), with variance `var_k2`.
    pub fn at(p: &SpringParams, temp_k: f32, var_k2: f32) -> SpringState {
        let t = if temp_k.is_finite() { temp_k } else { 298.15 };
        SpringState {
            temp_k: t,
            austenite: heating_branch(p, t),
            var_k2: if var_k2.is_finite() {
                var_k2.max(0.0)
            } else {
                100.0
            },
        }
    }

    /// A spring's state from stored parts (temperature, austenite fraction): non-finite parts
    /// become a hot austenite spring at `hot_k` (the safe assumption: it rests before use).
    pub fn from_parts(temp_k: f32, austenite: f32, hot_k: f32) -> SpringState {
        let ok = temp_k.is_finite() && austenite.is_finite();
        SpringState {
            temp_k: if ok { temp_k } else { hot_k },
            austenite: if ok { austenite.clamp(0.0, 1.0) } else { 1.0 },
            var_k2: 25.0,
        }
    }

    /// Standard deviation of the austenite fraction: the temperature's, through the slope of
    /// the branch the spring is on or near (0 well outside both bands), at most 0.5.
    pub fn austenite_std(&self, p: &SpringParams) -> f32 {
        let std = libm::sqrtf(self.var_k2.max(0.0));
        let near = |lo: f32, hi: f32| self.temp_k > lo - 2.0 * std && self.temp_k < hi + 2.0 * std;
        let slope = if near(p.as_k, p.af_k) && self.austenite < 1.0 {
            1.0 / (p.af_k - p.as_k).max(0.1)
        } else if near(p.mf_k, p.ms_k) && self.austenite > 0.0 {
            1.0 / (p.ms_k - p.mf_k).max(0.1)
        } else {
            0.0
        };
        (std * slope).min(0.5)
    }

    /// Advance by `dt_s` with the spring switched `on`, the ambient at `ambient_k` and the
    /// column's outer surface at `outer_k`, the Joule power the model's.
    pub fn predict(&mut self, p: &SpringParams, on: bool, ambient_k: f32, outer_k: f32, dt_s: f32) {
        let power = if on { self.model_power_w(p) } else { 0.0 };
        self.predict_powered(p, power, ambient_k, outer_k, dt_s);
    }

    /// The Joule power the model assumes in this spring while it is on, W: the channel's
    /// current limit through the phase's resistance (the wire's temperature coefficient
    /// leaves out ≈ 2 % at the band: with it, the model's springs turned austenite early
    /// enough that a pose at the edge of its reach, AB from a formed 40° to 55° at 283 K,
    /// ended short in `host-sim pose-table`).
    pub fn model_power_w(&self, p: &SpringParams) -> f32 {
        p.power_w.max(0.0) * (1.0 + (AUSTENITE_RESISTANCE_RATIO - 1.0) * self.austenite)
    }

    /// Advance by `dt_s` with `power_w` of Joule heat in the wire (0: off), the ambient at
    /// `ambient_k` and the column's outer surface at `outer_k`.
    pub fn predict_powered(
        &mut self,
        p: &SpringParams,
        power_w: f32,
        ambient_k: f32,
        outer_k: f32,
        dt_s: f32,
    ) {
        let on = power_w > 0.0;
        let c = p.capacity_j_per_k.max(1e-3);
        let g = p.ambient_w_per_k.max(0.0) + p.column_w_per_k.max(0.0);
        let power = if power_w.is_finite() {
            power_w.max(0.0)
        } else {
            0.0
        };
        let drive =
            power + p.ambient_w_per_k.max(0.0) * ambient_k + p.column_w_per_k.max(0.0) * outer_k;
        // The sensible step: exact for the held inputs (dT/dt = (drive − g·T)/C).
        let decay = if g > 0.0 {
            libm::expf(-dt_s * g / c)
        } else {
            1.0
        };
        let sensible = if g > 0.0 {
            let eq = drive / g;
            eq + (self.temp_k - eq) * decay
        } else {
            self.temp_k + drive * dt_s / c
        };
        let h = c * sensible + p.latent_j.max(0.0) * self.austenite;
        let (t, a) = settle(p, h, self.austenite);
        if t.is_finite() && a.is_finite() {
            self.temp_k = t;
            self.austenite = a;
        }
        // The variance decays as the square of the temperature's deviation.
        let decay2 = decay * decay;
        let q = if on {
            p.on_process_k2_per_s
        } else {
            p.off_process_k2_per_s
        };
        self.var_k2 = self.var_k2 * decay2 + q.max(0.0) * dt_s;
    }
}

/// The austenite fraction the heating branch reaches at `t_k`.
pub fn heating_branch(p: &SpringParams, t_k: f32) -> f32 {
    ((t_k - p.as_k) / (p.af_k - p.as_k).max(0.1)).clamp(0.0, 1.0)
}

/// The austenite fraction the cooling branch keeps at `t_k`.
pub fn cooling_branch(p: &SpringParams, t_k: f32) -> f32 {
    ((t_k - p.mf_k) / (p.ms_k - p.mf_k).max(0.1)).clamp(0.0, 1.0)
}

/// The `(T, a)` with enthalpy `h_j` (`C·T + L·a`) reached from austenite fraction `old`, in
/// closed form on the linear branches.
pub fn settle(p: &SpringParams, h_j: f32, old: f32) -> (f32, f32) {
    let c = p.capacity_j_per_k.max(1e-3);
    let l = p.latent_j.max(0.0);
    let frozen_t = (h_j - l * old) / c;
    if heating_branch(p, frozen_t) > old {
        // Transforming to austenite: C·T + L·(T − As)/w = H.
        let w = (p.af_k - p.as_k).max(0.1);
        let t = (h_j + l * p.as_k / w) / (c + l / w);
        let a = (t - p.as_k) / w;
        if a >= 1.0 {
            return ((h_j - l) / c, 1.0);
        }
        return (t, a.max(old));
    }
    if cooling_branch(p, frozen_t) < old {
        // Transforming to martensite: C·T + L·(T − Mf)/w = H.
        let w = (p.ms_k - p.mf_k).max(0.1);
        let t = (h_j + l * p.mf_k / w) / (c + l / w);
        let a = (t - p.mf_k) / w;
        if a <= 0.0 {
            return (h_j / c, 0.0);
        }
        return (t, a.min(old));
    }
    (frozen_t, old)
}

/// Every spring's state.
pub type Springs = [SpringState; SPRINGS];

/// The measured power is used in place of the model's once they differ by more than this
/// share: the channel's sensing (gain and divider errors of ≈ 1 % each before trimming) is
/// less accurate than the model on the block it was fitted to, and far more so on a supply
/// that sags or a wire that differs.
pub const MEASURED_POWER_SHARE: f32 = 0.1;

/// What a spring channel measured over a control period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpringReading {
    /// The spring was driven (its gate and the spring power on).
    pub on: bool,
    /// The power delivered to the wire, W (NaN: not measured).
    pub power_w: f32,
    /// The wire's resistance, Ω (NaN: not measured).
    pub wire_ohm: f32,
}

/// What the spring channels measured of one spring while it is driven: its power and its
/// temperature.
///
/// The measured power (I·V less the leads' I²R) replaces the model's where they differ by more
/// than [`MEASURED_POWER_SHARE`]: a supply that sags or is strong, another wire. The wire's
/// resistance rises ≈ 12.5 % from martensite to austenite, and within a phase by its
/// temperature coefficient (10⁻⁴–10⁻³ per K): referenced at the first transformation's end
/// ([`SpringFusion::temperature`]), it reads a driven wire's temperature, which raises an
/// estimate that runs under it (a spring that cools slower than the model).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpringFusion {
    /// The measured power of the present drive, W (NaN: none yet, or off).
    pub power_w: f32,
    /// The lowest resistance read since the start (the wire's martensite), Ω (NaN: none yet) ...
    pub cold_ohm: f32,
    /// ... and the estimate's temperature then, K.
    pub cold_k: f32,
    /// The present reading's resistance, Ω (NaN: off).
    pub ohm: f32,
    /// The resistance at the start of the present energy window, Ω (NaN: off) ...
    pub window_ohm: f32,
    /// ... and the Joule energy delivered since, J.
    pub window_j: f32,
    /// The resistance has risen steeply per joule (a transformation under way), and the
    /// spring has not been off for long since.
    pub rising: bool,
    /// How long the spring has been off, s.
    pub off_s: f32,
    /// The wire's resistance at the end of its first transformation to austenite, Ω (NaN:
    /// none yet) ...
    pub reference_ohm: f32,
    /// ... and its temperature there, K ([`SpringFusion::temperature`]).
    pub reference_k: f32,
    /// The measured power's share of the model's over the recent drives (1: as the model
    /// assumes, before any drive; [`SpringFusion::track_share`]).
    pub share: f32,
    /// The wire's temperature by the present reading, K (NaN: not driven, or no reference
    /// yet): the reference plus the resistance's rise over it through the wire's temperature
    /// coefficient, as if it were all austenite (any martensite lowers the resistance, so the
    /// wire is at least this hot, to the reference's error).
    pub wire_k: f32,
}

/// A transformation's end is taken only where the wire's resistance is this much above its
/// martensite (martensite to austenite is 12.5 %).
pub const REFERENCE_RISE: f32 = 0.08;

/// The resistance's rise is judged per this much Joule energy, J (≈ 1 s at full power).
pub const KNEE_WINDOW_J: f32 = 100.0;

/// Transforming, the resistance rises ≈ 1.2 % per 100 J (12.5 % over the latent heat and the
/// 10 K band, ≈ 1 000 J); within austenite ≈ 0.17 % (3·10⁻⁴ per K over 5.5 K); the threshold
/// between them (the sensing's noise over a window: ≈ 0.04 %).
pub const KNEE_RISE_PER_WINDOW: f32 = 0.005;

/// A spring off for longer than this has cooled off its branch: a rise seen before it no
/// longer leads to an end, and the window starts afresh (a shorter pause keeps both: a band's
/// pulses are seconds apart), s.
pub const KNEE_OFF_S: f32 = 60.0;

/// An end whose temperature by the resistance is more than this under Af is a wire still
/// partly martensite (5 % martensite reads 18 K under), K: no reference is taken there.
pub const KNEE_BELOW_AF_K: f32 = 3.0;

/// How far above the model's Af the wire can be where its transformation's end is seen, K:
/// the load raises the transformation (Clausius–Clapeyron: up to 7 K on a spring pulling the
/// column, ≈ 15 K on one the bent column stretches) and the window lags (up to 5.5 K at full
/// power). An end whose temperature, read from the resistance's rise over the wire's
/// martensite at rest, is beyond this is not taken.
pub const KNEE_SHIFT_MAX_K: f32 = 30.0;

/// How far a reading moves [`SpringFusion::share`] towards its own (a few readings' memory:
/// the sensing's noise averages out within a step).
pub const SHARE_GAIN: f32 = 0.2;

/// The largest share taken (a supply at 150 % gives ≈ 1.6 where its current is not limited).
pub const SHARE_MAX: f32 = 3.0;

/// The austenite fraction a spring can reach at best when driven at `duty` (0…1, the duty
/// limit) of `share` times the model's power (its martensite's, the least), in still air at
/// `ambient_k` beside a column at `column_k`, and held at most at `ceiling_k` (the springs'
/// band): the heating branch at that steady temperature. At the model's power any duty
/// above ≈ 12 % reaches austenite, and at the 60 % duty limit any share above ≈ 20 %.
pub fn attainable_austenite(
    p: &SpringParams,
    share: f32,
    duty: f32,
    ambient_k: f32,
    column_k: f32,
    ceiling_k: f32,
) -> f32 {
    let (ga, gc) = (p.ambient_w_per_k.max(0.0), p.column_w_per_k.max(0.0));
    let g = (ga + gc).max(1e-6);
    let power = p.power_w.max(0.0) * share.max(0.0) * duty.clamp(0.0, 1.0);
    let steady = (ga * ambient_k + gc * column_k + power) / g;
    if !steady.is_finite() {
        return 0.0;
    }
    heating_branch(p, steady.min(ceiling_k))
}

/// The estimate of a driven spring is raised to its temperature by the resistance less this,
/// K: the reading's noise (≈ 1 K a reading).
pub const WIRE_MARGIN_K: f32 = 1.0;

impl SpringFusion {
    /// Nothing measured.
    pub const NEW: SpringFusion = SpringFusion {
        power_w: f32::NAN,
        cold_ohm: f32::NAN,
        cold_k: f32::NAN,
        ohm: f32::NAN,
        window_ohm: f32::NAN,
        window_j: 0.0,
        rising: false,
        off_s: 0.0,
        reference_ohm: f32::NAN,
        reference_k: f32::NAN,
        share: 1.0,
        wire_k: f32::NAN,
    };

    /// Follow the measured power's share of `model_w` (the model's power for the spring
    /// now) while the spring is driven, by [`SHARE_GAIN`] a reading; kept while it is off.
    pub fn track_share(&mut self, model_w: f32) {
        let m = self.power_w;
        if m.is_finite() && model_w > 0.0 {
            let r = (m / model_w).clamp(0.0, SHARE_MAX);
            self.share += SHARE_GAIN * (r - self.share);
        }
    }

    /// The power to predict with for a spring driven `on` in state `s`: the model's, or the
    /// measured one where they differ by more than [`MEASURED_POWER_SHARE`].
    pub fn power_w(&self, p: &SpringParams, s: &SpringState, on: bool) -> f32 {
        if !on {
            return 0.0;
        }
        let model = s.model_power_w(p);
        let m = self.power_w;
        if m.is_finite() && (m - model).abs() > MEASURED_POWER_SHARE * model {
            m.max(0.0)
        } else {
            model
        }
    }

    /// Take a channel's reading `r`: the power of a driven spring and the phase its resistance
    /// shows; nothing while it is off.
    pub fn fuse(&mut self, r: &SpringReading) {
        self.power_w = if r.on { r.power_w } else { f32::NAN };
        self.wire_k = f32::NAN;
        let ohm = r.wire_ohm;
        if !(r.on && ohm.is_finite() && ohm > 0.0) {
            self.ohm = f32::NAN;
            return;
        }
        self.ohm = ohm;
    }

    /// The reading over a period of `dt_s` with `power_w` in the wire, the estimate at
    /// `estimate_k`: the wire's martensite at rest, the reference at the first
    /// transformation's end, and the wire's temperature by the resistance.
    ///
    /// The martensite is the lowest resistance read, at the estimate's temperature then (a
    /// spring at rest after a power-up, where the estimate is the ambient's). A
    /// transformation's end is where the resistance, having risen steeply per joule
    /// ([`KNEE_RISE_PER_WINDOW`]), rises no faster than the temperature coefficient makes it,
    /// well above the wire's martensite ([`REFERENCE_RISE`]); the wire's temperature there is
    /// what its rise over the martensite gives through the phases' resistivities
    /// ([`AUSTENITE_RESISTANCE_RATIO`]) and the coefficient. An end that reads more than
    /// [`KNEE_BELOW_AF_K`] under Af (a wire still partly martensite) or more than
    /// [`KNEE_SHIFT_MAX_K`] over it (a ratio off by 1 % would be 33 K off) is not taken. It is
    /// taken once: the wire's resistance against its temperature does not change.
    pub fn temperature(&mut self, p: &SpringParams, power_w: f32, dt_s: f32, estimate_k: f32) {
        let ohm = self.ohm;
        if ohm.is_nan() {
            // A short pause (a band's or a window's) keeps the window: the wire stays on its
            // branch.
            self.off_s += dt_s;
            if self.off_s > KNEE_OFF_S {
                self.rising = false;
                self.window_ohm = f32::NAN;
                self.window_j = 0.0;
            }
            return;
        }
        self.off_s = 0.0;
        if self.cold_ohm.is_nan() || ohm < self.cold_ohm {
            self.cold_ohm = ohm;
            self.cold_k = estimate_k;
        }
        if self.reference_ohm.is_nan() {
            if self.window_ohm.is_nan() {
                self.window_ohm = ohm;
                self.window_j = 0.0;
            }
            self.window_j += power_w.max(0.0) * dt_s;
            if self.window_j >= KNEE_WINDOW_J {
                let rise = (ohm / self.window_ohm - 1.0) * KNEE_WINDOW_J / self.window_j;
                let risen = ohm >= self.cold_ohm * (1.0 + REFERENCE_RISE);
                if rise > KNEE_RISE_PER_WINDOW {
                    self.rising = true;
                } else if self.rising && risen && p.tempco_per_k > 0.0 {
                    let c = ohm / self.cold_ohm * coefficient(p, self.cold_k)
                        / AUSTENITE_RESISTANCE_RATIO;
                    let t = TEMPCO_BASE_K + (c - 1.0) / p.tempco_per_k;
                    // A wire still partly martensite reads far under Af: not its end yet.
                    if t >= p.af_k - KNEE_BELOW_AF_K && t <= p.af_k + KNEE_SHIFT_MAX_K {
                        self.reference_ohm = ohm;
                        self.reference_k = t.max(p.af_k);
                    }
                }
                self.window_ohm = ohm;
                self.window_j = 0.0;
            }
        }
        let r0 = self.reference_ohm;
        if r0.is_finite() && p.tempco_per_k > 0.0 {
            let at_reference = coefficient(p, self.reference_k);
            self.wire_k = TEMPCO_BASE_K + (ohm / r0 * at_reference - 1.0) / p.tempco_per_k;
        }
    }
}

/// The temperature the wire's coefficient is given at, K: R(T) = R(T₀)·(1 + α·(T − T₀)).
pub const TEMPCO_BASE_K: f32 = 298.15;

/// `1 + α·(T − T₀)`: the wire's resistance at `t_k` over its resistance at [`TEMPCO_BASE_K`].
fn coefficient(p: &SpringParams, t_k: f32) -> f32 {
    1.0 + p.tempco_per_k * (t_k - TEMPCO_BASE_K)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> SpringParams {
        crate::observer::ObserverParams::DEFAULT.springs
    }

    #[test]
    fn settling_keeps_the_enthalpy_and_the_hysteresis() {
        let p = params();
        for &(t, a) in &[
            (330.0, 0.0),
            (346.0, 0.0),
            (346.0, 1.0),
            (320.0, 1.0),
            (360.0, 0.3),
        ] {
            for dh in [-500.0, -50.0, 0.0, 50.0, 500.0, 2000.0] {
                let h = p.capacity_j_per_k * t + p.latent_j * a + dh;
                let (t2, a2) = settle(&p, h, a);
                let back = p.capacity_j_per_k * t2 + p.latent_j * a2;
                assert!((back - h).abs() < 1e-3 * h.abs(), "{t} {a} {dh}: {t2} {a2}");
                assert!((0.0..=1.0).contains(&a2));
                // The phase is on or between its branches.
                assert!(a2 >= heating_branch(&p, t2) - 1e-4, "{t2} {a2}");
                assert!(a2 <= cooling_branch(&p, t2) + 1e-4, "{t2} {a2}");
            }
        }
        // Between Ms and As nothing transforms: a half-austenite spring stays half.
        let h = p.capacity_j_per_k * 333.0 + p.latent_j * 0.5;
        assert_eq!(settle(&p, h, 0.5), (333.0, 0.5));
    }

    /// The measured power replaces the model's only where they differ by more than the
    /// sensing's allowance: a sagging supply, not the sensing's own error.
    #[test]
    fn the_measured_power_is_used_where_it_clearly_differs() {
        let p = params();
        let s = SpringState::at(&p, 300.0, 1.0);
        let mut f = SpringFusion::NEW;
        let model = s.model_power_w(&p);
        f.power_w = model * 0.95;
        assert_eq!(f.power_w(&p, &s, true), model);
        f.power_w = model * 0.5;
        assert_eq!(f.power_w(&p, &s, true), model * 0.5);
        assert_eq!(f.power_w(&p, &s, false), 0.0);
    }

    /// The share follows the measured power of driven readings only; a spring the supply
    /// gives a tenth of its power cannot reach austenite under the duty limit, one at half of
    /// it can.
    #[test]
    fn the_share_follows_the_drives_and_limits_the_austenite() {
        let p = params();
        let mut f = SpringFusion::NEW;
        assert_eq!(f.share, 1.0);
        for _ in 0..40 {
            f.fuse(&SpringReading {
                on: true,
                power_w: 30.0,
                wire_ohm: 0.27,
            });
            f.track_share(60.0);
        }
        assert!((f.share - 0.5).abs() < 1e-3, "{}", f.share);
        f.fuse(&SpringReading {
            on: false,
            power_w: f32::NAN,
            wire_ohm: f32::NAN,
        });
        f.track_share(60.0);
        assert!((f.share - 0.5).abs() < 1e-3, "kept while off: {}", f.share);
        let at = |share: f32| attainable_austenite(&p, share, 0.6, 298.15, 358.0, 373.0);
        assert_eq!(at(1.0), 1.0);
        assert_eq!(at(0.49), 1.0);
        assert_eq!(at(0.0), 0.0);
        // 17 % of 61 W at 60 % duty holds the wire ≈ 346 K, inside the transformation.
        let part = at(0.17);
        assert!(part > 0.2 && part < 0.8, "{part}");
        assert_eq!(at(0.1), 0.0);
    }

    fn reading(ohm: f32) -> SpringReading {
        SpringReading {
            on: true,
            power_w: 60.0,
            wire_ohm: ohm,
        }
    }

    /// A wire heated from martensite at 298 K at 100 W in 0.25 s readings: its resistance
    /// (the plant's law: 12.5 % over the transformation between As and Af, 3·10⁻⁴ per K) is
    /// read for the transformation's end, and from there the temperature the resistance gives
    /// is the wire's.
    #[test]
    fn the_resistance_reads_the_wire_hot_after_its_transformation() {
        let p = params();
        let mut f = SpringFusion::NEW;
        let (c, l) = (p.capacity_j_per_k, p.latent_j);
        let (mut t, mut a) = (298.0f32, 0.0f32);
        let ohm = |t: f32, a: f32| 0.272 * (1.0 + 0.125 * a) * (1.0 + 3e-4 * (t - 298.15));
        let mut low_err = f32::MIN;
        for _ in 0..200 {
            // 25 J a reading: sensible heat, or latent heat across the band.
            let mut e = 25.0;
            if t >= p.as_k && a < 1.0 {
                let w = p.af_k - p.as_k;
                let da = (e / (l + c * w)).min(1.0 - a);
                a += da;
                t += da * w;
                e -= da * (l + c * w);
            }
            t += e / c;
            f.fuse(&reading(ohm(t, a)));
            f.temperature(&p, 100.0, 0.25, t);
            if f.wire_k.is_finite() {
                low_err = low_err.max(f.wire_k - t);
                assert!((f.wire_k - t).abs() < 0.5, "{} vs {t}", f.wire_k);
            }
        }
        assert!(f.reference_ohm.is_finite(), "no end found");
        assert!(t > 420.0 && low_err <= 0.5, "{t} {low_err}");
        assert!(
            f.reference_k > p.af_k && f.reference_k < p.af_k + 6.0,
            "{}",
            f.reference_k
        );
    }

    /// A drive that stops mid-transformation and resumes after a pause warms back to its
    /// branch with a flat resistance first: that is no end, and no reference is taken.
    #[test]
    fn a_resumed_drive_is_no_transformation_end() {
        let p = params();
        let mut f = SpringFusion::NEW;
        let base = 0.272;
        f.fuse(&reading(base));
        f.temperature(&p, 100.0, 0.25, 300.0);
        // Rising steeply: 1.2 % per 100 J, to 6 % (half transformed).
        for k in 1..=20 {
            f.fuse(&reading(base * (1.0 + 0.003 * k as f32)));
            f.temperature(&p, 100.0, 0.25, 300.0);
        }
        assert!(f.rising);
        for _ in 0..40 {
            f.fuse(&SpringReading {
                on: false,
                power_w: 0.0,
                wire_ohm: f32::NAN,
            });
            f.temperature(&p, 0.0, 0.25, 300.0);
        }
        assert!(f.rising, "a 10 s pause keeps the rise");
        // Back on, flat at 9 % above martensite: by the phases' ratio it reads ≈ 100 K under
        // Af, a wire still partly martensite: no end.
        for _ in 0..20 {
            f.fuse(&reading(base * 1.09));
            f.temperature(&p, 100.0, 0.25, 300.0);
        }
        assert!(f.reference_ohm.is_nan() && f.wire_k.is_nan());
    }

    #[test]
    fn a_driven_spring_passes_its_transformation_and_cools_back() {
        let p = params();
        let mut s = SpringState::at(&p, 298.15, 1.0);
        let mut t_af = None;
        for i in 1..=1200 {
            s.predict(&p, true, 298.15, 298.15, 0.05);
            if t_af.is_none() && s.austenite >= 1.0 {
                t_af = Some(i as f32 * 0.05);
            }
        }
        let t_af = t_af.expect("austenite within 60 s");
        // Sensible heat to Af and the latent heat at ≈62–69 W: ≈26 s.
        let want = (p.capacity_j_per_k * (p.af_k - 298.15) + p.latent_j) / p.power_w;
        assert!(
            (t_af - want).abs() < 0.2 * want,
            "austenite after {t_af} s, want ≈{want}"
        );
        for _ in 0..20_000 {
            s.predict(&p, false, 298.15, 298.15, 0.1);
        }
        assert!(
            s.austenite == 0.0 && (s.temp_k - 298.15).abs() < 0.5,
            "{s:?}"
        );
    }
}
