//! Closed-loop tests of the control law against analytic results, on an exactly discretised
//! first-order-plus-dead-time plant.

use super::*;
use crate::outputs::Duty;
use crate::units::Seconds;
use std::collections::VecDeque;

/// A span in seconds from a test's `f32` (never NaN here).
fn sec(s: f32) -> Seconds {
    Seconds::new(s).expect("a test span is not NaN")
}

/// First-order plus dead time, exact for a zero-order-held input:
/// `τ·ẏ = −(y − T_amb) + K·u(t − L) − disturbance`.
struct Fopdt {
    amb_k: f64,
    gain_k: f64,
    tau_s: f64,
    dt_s: f64,
    y_k: f64,
    delay: VecDeque<f64>,
    /// Heat loss expressed as a temperature drop at steady state, K.
    disturbance_k: f64,
}

impl Fopdt {
    fn new(amb_k: f64, gain_k: f64, tau_s: f64, dead_s: f64, dt_s: f64) -> Fopdt {
        let n = (dead_s / dt_s).round() as usize;
        assert!(
            (n as f64 * dt_s - dead_s).abs() < 1e-9,
            "dead time not a whole number of steps"
        );
        Fopdt {
            amb_k,
            gain_k,
            tau_s,
            dt_s,
            y_k: amb_k,
            delay: core::iter::repeat_n(0.0, n).collect(),
            disturbance_k: 0.0,
        }
    }

    /// Put the plant at its steady state under a constant input `u`.
    fn settle_at(&mut self, u: f64) {
        self.delay.iter_mut().for_each(|d| *d = u);
        self.y_k = self.amb_k + self.gain_k * u - self.disturbance_k;
    }

    /// Apply `u` for one step and return the new temperature.
    fn step(&mut self, u: f64) -> f64 {
        self.delay.push_back(u);
        let u_now = self.delay.pop_front().unwrap_or(u);
        let y_inf = self.amb_k + self.gain_k * u_now - self.disturbance_k;
        let phi = (-self.dt_s / self.tau_s).exp();
        self.y_k = y_inf + (self.y_k - y_inf) * phi;
        self.y_k
    }
}

/// xorshift64* for deterministic measurement noise.
struct Rng(u64);
impl Rng {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn wide(gains: PidGains) -> PidConfig {
    PidConfig {
        output_min: -100.0,
        output_max: 100.0,
        derivative_tau_s: 0.0,
        ..PidConfig::heater(gains)
    }
}

// ---------------------------------------------------------------------------------------------
// PID against analytic results

#[test]
fn p_only_leaves_the_analytic_steady_state_error_and_i_removes_it() {
    // Plant: K = 2 K per unit output, τ = 20 s, no dead time. Under P control the loop settles
    // where y − T_amb = K·Kp·(r − y): e_ss = (r − T_amb)/(1 + K·Kp), for the sampled loop too
    // (the exact discretisation keeps the DC gain K).
    let (amb, r, k, kp) = (298.0, 358.0, 2.0, 1.5);
    let e_ss = (r - amb) / (1.0 + k * kp);
    let run = |ki: f32| {
        let mut plant = Fopdt::new(amb, k, 20.0, 0.0, 0.25);
        let gains = PidGains {
            kp_per_k: kp as f32,
            ki_per_k_s: ki,
            kd_s_per_k: 0.0,
        };
        let mut pid = Pid::new(wide(gains), r as f32);
        let mut y = plant.y_k;
        for _ in 0..4000 {
            let u = pid.update(y as f32, sec(0.25));
            y = plant.step(u as f64);
        }
        r - y
    };
    let e_p = run(0.0);
    assert!(e_p > 10.0, "{e_p}");
    assert!(
        (e_p - e_ss).abs() < 1e-3,
        "P error {e_p} vs analytic {e_ss}"
    );
    let e_pi = run(0.05);
    assert!(e_pi.abs() < 1e-3, "PI left {e_pi} K");
}

/// A loop whose proportional term alone sits near the output limit must still integrate up
/// to it: a plant that needs 95 % of full output at the target (K = 63 K per unit from 298 K
/// to 358 K), the firmware's default gains, frames every 0.5 s. Integration refused whenever
/// P + I + ΔI would pass the limit froze I at 0 from the first (saturated) step and settled
/// P-only ≈ 6 K short (the analytic 60/(1 + K·Kp)); integrating up to the limit removes it.
#[test]
fn an_integral_grows_up_to_the_limit_when_p_alone_is_near_it() {
    let (amb, r, k) = (298.0, 358.0, 63.0);
    let gains = PidGains {
        kp_per_k: 0.139,
        ki_per_k_s: 0.079,
        kd_s_per_k: 0.0,
    };
    let mut plant = Fopdt::new(amb, k, 20.0, 0.0, 0.5);
    let mut pid = Pid::new(PidConfig::heater(gains), r as f32);
    let mut y = plant.y_k;
    for _ in 0..2000 {
        let u = pid.update(y as f32, sec(0.5));
        assert!((0.0..=1.0).contains(&u), "{u}");
        y = plant.step(u as f64);
    }
    let p_only_error = (r - amb) / (1.0 + k * 0.139);
    assert!(p_only_error > 5.0, "{p_only_error}");
    assert!((r - y).abs() < 0.05, "settled {y} K, {} K short", r - y);
}

#[test]
fn derivative_filter_follows_the_first_order_step_response() {
    // A ramp of slope s from t = 0 is a step of s in the raw slope; the filtered slope is
    // s·(1 − e^(−t/τ)) and the D term −Kd times that, exactly at the samples.
    let (s, tau, dt, kd) = (0.8f32, 2.0f32, 0.25f32, 0.5f32);
    let gains = PidGains {
        kp_per_k: 0.0,
        ki_per_k_s: 0.0,
        kd_s_per_k: kd,
    };
    let mut pid = Pid::new(
        PidConfig {
            derivative_tau_s: tau,
            ..wide(gains)
        },
        400.0,
    );
    assert_eq!(pid.update(300.0, sec(dt)), 0.0);
    let mut worst = 0.0f32;
    for k in 1..=80 {
        let t = k as f32 * dt;
        let u = pid.update(300.0 + s * t, sec(dt));
        let want = -kd * s * (1.0 - (-t / tau).exp());
        worst = worst.max((u - want).abs());
    }
    assert!(worst < 1e-5, "worst deviation {worst}");
    // Unfiltered (τ = 0) the D term is the raw slope at once.
    let mut raw = Pid::new(wide(gains), 400.0);
    raw.update(300.0, sec(dt));
    let u = raw.update(300.0 + s * dt, sec(dt));
    // f32 resolves 300 K to 3e-5 K: the raw slope to 3e-5/Δt.
    assert!((u + kd * s).abs() < kd * 2e-4, "{u}");
}

#[test]
fn anti_windup_bounds_the_overshoot_after_a_long_saturation() {
    // A heat loss the heater cannot beat (at full power the plant sits at 248 K, the target is
    // 358 K) for `sat_s`, then the loss vanishes. Without anti-windup (eq. 6.16 as written,
    // output clamp only) the integral grows with the saturation and so does the overshoot; with
    // it, the overshoot after 300 s of saturation is the same as after 30 s, and small (what is
    // left is the loop's own response to a 110 K step taken at full power).
    let gains = PidGains {
        kp_per_k: 0.02,
        ki_per_k_s: 0.00025,
        kd_s_per_k: 0.1,
    };
    let (dt, r) = (0.25f32, 358.0f32);
    let run = |ours: bool, sat_s: f32| {
        let mut plant = Fopdt::new(298.0, 400.0, 120.0, 2.0, dt as f64);
        plant.disturbance_k = 450.0;
        plant.settle_at(1.0);
        let mut pid = Pid::new(PidConfig::heater(gains), r);
        let (mut integ, mut prev) = (0.0f32, None::<f32>);
        let mut y = plant.y_k as f32;
        let mut peak = f32::MIN;
        let release = (sat_s / dt) as usize;
        for k in 0..release + 8000 {
            if k == release {
                plant.disturbance_k = 0.0;
            }
            let u = if ours {
                pid.update(y, sec(dt))
            } else {
                let e = r - y;
                integ += e * dt;
                let de = prev.map_or(0.0, |p: f32| (e - p) / dt);
                prev = Some(e);
                (gains.kp_per_k * e + gains.ki_per_k_s * integ + gains.kd_s_per_k * de)
                    .clamp(0.0, 1.0)
            };
            y = plant.step(u as f64) as f32;
            peak = peak.max(y);
        }
        (peak - r, y)
    };
    let (short, _) = run(true, 30.0);
    let (long, long_end) = run(true, 300.0);
    let (textbook_short, _) = run(false, 30.0);
    let (textbook_long, _) = run(false, 300.0);
    std::println!(
        "overshoot after 30 s / 300 s saturation: ours {short:.2} / {long:.2} K, \
         textbook {textbook_short:.2} / {textbook_long:.2} K"
    );
    assert!(
        textbook_long > 20.0,
        "reference did not wind up: {textbook_long}"
    );
    assert!(textbook_long > textbook_short + 10.0);
    assert!((long - short).abs() < 0.01, "ours {short} → {long} K");
    assert!(
        long < 5.0 && long < textbook_long / 10.0,
        "overshoot {long} K"
    );
    assert!((long_end - r).abs() < 0.05, "did not settle: {long_end}");
}

/// Run a split-range PID on a first-order plant to steady state and return the pid and plant
/// (the plant takes u ∈ [−1, 1] as net heat, the fan's share negative).
fn settled_loop() -> (Pid, Fopdt, f32) {
    let gains = PidGains {
        kp_per_k: 0.02,
        ki_per_k_s: 0.001,
        kd_s_per_k: 0.05,
    };
    let mut plant = Fopdt::new(298.0, 400.0, 120.0, 0.0, 0.25);
    let mut pid = Pid::new(PidConfig::split_range(gains), 340.0);
    let mut y = plant.y_k as f32;
    for _ in 0..1000 {
        let u = pid.update(y, sec(0.25));
        y = plant.step(u as f64) as f32;
    }
    (pid, plant, y)
}

#[test]
fn gain_and_target_changes_are_bumpless() {
    let (mut pid, mut plant, mut y) = settled_loop();
    let before = pid.output();
    assert!(before > 0.05 && before < 0.9, "{before}");
    // Five times the gains with the temperature 1 K off target: the P term alone jumps by
    // 4·0.02·e. Bumpless, the output does not move at all.
    let new = PidGains {
        kp_per_k: 0.1,
        ki_per_k_s: 0.005,
        kd_s_per_k: 0.25,
    };
    let off = y - 1.0;
    let i_before = pid.terms().i;
    pid.set_gains(new).unwrap();
    let u = pid.update(off, sec(0.25));
    assert!(
        (u - before).abs() < 1e-5,
        "gain change stepped {before} → {u}"
    );
    // Without the realignment the output would have been the new P and D on the old I.
    let t = pid.terms();
    let naive = t.p + t.d + i_before;
    assert!(
        (naive - before).abs() > 0.05,
        "test too weak: naive {naive}"
    );
    // Target 340 → 345: P alone would jump by 0.1·5 = 0.5; bumpless it does not.
    let before = pid.update(y, sec(0.25));
    pid.set_target(345.0).unwrap();
    let u = pid.update(y, sec(0.25));
    assert!(
        (u - before).abs() < 1e-5,
        "target change stepped {before} → {u}"
    );
    // And the loop still reaches the new target.
    for _ in 0..4000 {
        let u = pid.update(y, sec(0.25));
        y = plant.step(u as f64) as f32;
    }
    assert!((y - 345.0).abs() < 0.01, "{y}");
    // reset_to: a mode hands over at 0.42; the first output is 0.42.
    pid.reset_to(0.42);
    assert!((pid.update(y + 3.0, sec(0.25)) - 0.42).abs() < 1e-6);
}

#[test]
fn bad_input_gives_the_safe_documented_result() {
    let (mut pid, _, y) = settled_loop();
    let i_before = pid.terms().i;
    // NaN or infinite measurement: safe output (0: heater and fan off), integrator kept.
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        assert_eq!(pid.update(bad, sec(0.25)), 0.0);
        assert_eq!(pid.output(), 0.0);
    }
    // Back to good data: the integrator is where it was and D restarts at 0.
    pid.update(y, sec(0.25));
    assert!((pid.terms().i - i_before).abs() < 1e-4);
    assert_eq!(pid.terms().d, 0.0);
    // Bad Δt: no integration, no derivative, finite output.
    // (A NaN Δt cannot be passed: `Seconds` refuses it.)
    assert_eq!(Seconds::new(f32::NAN), None);
    for dt in [0.0, -1.0, 5.0, f32::INFINITY, f32::MAX] {
        let i = pid.terms().i;
        let u = pid.update(y + 2.0, sec(dt));
        assert!((-1.0..=1.0).contains(&u));
        assert_eq!(pid.terms().i, i, "dt {dt} integrated");
        assert_eq!(pid.terms().d, 0.0, "dt {dt} differentiated");
    }
    // Bad gains are refused and the old ones kept; a bad target likewise.
    let g = pid.config().gains;
    let nan = PidGains {
        kp_per_k: f32::NAN,
        ..g
    };
    assert_eq!(pid.set_gains(nan), Err(PidError::InvalidGains));
    let neg = PidGains {
        ki_per_k_s: -1.0,
        ..g
    };
    assert_eq!(pid.set_gains(neg), Err(PidError::InvalidGains));
    assert_eq!(pid.config().gains, g);
    assert_eq!(pid.set_target(f32::NAN), Err(PidError::InvalidTarget));
    assert_eq!(pid.target_k(), 340.0);
    // Built from garbage: zero gains and a [0, 0] range — always off.
    let mut junk = Pid::new(
        PidConfig {
            gains: nan,
            output_min: f32::NAN,
            output_max: 1.0,
            derivative_tau_s: -1.0,
            max_dt_s: f32::NAN,
            functional_band_k: f32::NAN,
        },
        f32::NAN,
    );
    for t in [300.0, f32::NAN, 1e30, -1e30] {
        assert_eq!(junk.update(t, sec(0.25)), 0.0);
    }
    // Extreme but finite values stay in range.
    let mut big = Pid::new(
        PidConfig::split_range(PidGains {
            kp_per_k: f32::MAX,
            ki_per_k_s: f32::MAX,
            kd_s_per_k: f32::MAX,
        }),
        358.0,
    );
    for (t, dt) in [
        (1e38f32, 1e-30f32),
        (-1e38, 0.5),
        (358.0, 1e-38),
        (0.0, 1.0),
    ] {
        let u = big.update(t, sec(dt));
        assert!((-1.0..=1.0).contains(&u), "{t} {dt} → {u}");
    }
    big.reset_to(f32::NAN);
    assert_eq!(big.output(), 0.0);
}

#[test]
fn functional_range_is_bang_bang_outside_and_restarts_the_integrator() {
    let gains = PidGains {
        kp_per_k: 0.01,
        ki_per_k_s: 0.01,
        kd_s_per_k: 0.0,
    };
    let mut pid = Pid::new(
        PidConfig {
            functional_band_k: 10.0,
            ..PidConfig::heater(gains)
        },
        358.0,
    );
    for _ in 0..100 {
        assert_eq!(pid.update(340.0, sec(0.25)), 1.0);
    }
    assert_eq!(pid.terms().i, 0.0);
    assert_eq!(pid.update(370.0, sec(0.25)), 0.0);
    // Inside the band: plain PID with the integrator restarted from 0 (P = 0.05, each I step
    // 0.01·5·0.25 = 0.0125).
    let u = pid.update(353.0, sec(0.25));
    assert!((u - 0.0625).abs() < 1e-6, "{u}");
    let u = pid.update(353.0, sec(0.25));
    assert!((u - 0.075).abs() < 1e-6, "{u}");
}

// ---------------------------------------------------------------------------------------------
// Relay autotune on a first-order-plus-dead-time plant

/// The test plant: 400 K per unit duty above 298 K ambient, τ = 120 s, 6 s dead time, sampled
/// at 4 Hz (the camera's frame rate). Holding 358 K takes 0.15 duty.
const AMB_K: f64 = 298.0;
const GAIN_K: f64 = 400.0;
const TAU_S: f64 = 120.0;
const DEAD_S: f64 = 6.0;
const DT_S: f64 = 0.25;
const TARGET_K: f32 = 358.0;

fn plant() -> Fopdt {
    Fopdt::new(AMB_K, GAIN_K, TAU_S, DEAD_S, DT_S)
}

fn relay_config() -> AutotuneConfig {
    AutotuneConfig::around(TARGET_K, Duty::from_fraction(0.15), 0.15)
}

/// Run the relay on `plant` until it ends; return the end and the highest temperature seen.
fn run_relay(mut plant: Fopdt, config: AutotuneConfig) -> (AutotuneStep, f64, f64) {
    let mut tune = RelayAutotune::new(config);
    let mut y = plant.y_k;
    let mut peak = y;
    for k in 0..100_000 {
        let t = k as f64 * DT_S;
        match tune.step(sec(t as f32), y as f32) {
            AutotuneStep::Running { heater_duty } => {
                y = plant.step(heater_duty.fraction() as f64);
                peak = peak.max(y);
            }
            end => return (end, peak, t),
        }
    }
    panic!("relay never ended");
}

/// The exact limit cycle of a relay with hysteresis ±ε on the FOPDT plant with dead time `l`:
/// (amplitude a, period Tu). In deviation from ambient, with input levels giving steady states
/// y_h and y_l and switching points r ± ε, the output keeps moving for `l` after each switch:
/// y_max = y_h − (y_h − r − ε)·e^(−l/τ), y_min = y_l + (r − ε − y_l)·e^(−l/τ), and each half
/// period is the first-order travel time between them.
fn exact_cycle(c: &AutotuneConfig, l: f64) -> (f64, f64) {
    let (yh, yl) = (
        GAIN_K * c.high.fraction() as f64,
        GAIN_K * c.low.fraction() as f64,
    );
    let (r, eps) = (c.target_k as f64 - AMB_K, c.hysteresis_k as f64);
    let q = (-l / TAU_S).exp();
    let ymax = yh - (yh - r - eps) * q;
    let ymin = yl + (r - eps - yl) * q;
    let tu = TAU_S * ((yh - ymin) / (yh - ymax)).ln() + TAU_S * ((ymax - yl) / (ymin - yl)).ln();
    ((ymax - ymin) / 2.0, tu)
}

/// The describing-function prediction for a relay of half-swing d with hysteresis ε:
/// G(jω) = −1/N(a) with N(a) = 4d/(πa)·(√(1 − ε²/a²) − jε/a), i.e. the phase of G is
/// −π + asin(ε/a) and |G| = πa/(4d). Solved by fixed-point iteration on a.
fn describing_function(c: &AutotuneConfig, l: f64) -> (f64, f64) {
    let d = 0.5 * (c.high.fraction() - c.low.fraction()) as f64;
    let eps = c.hysteresis_k as f64;
    let mut a = 2.0 * eps;
    let mut w = 0.0;
    for _ in 0..200 {
        let phase = std::f64::consts::PI - (eps / a).min(1.0).asin();
        // ω·L + atan(ω·τ) = phase, increasing in ω: bisect.
        let (mut lo, mut hi) = (1e-9, std::f64::consts::PI / l);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if mid * l + (mid * TAU_S).atan() < phase {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        w = 0.5 * (lo + hi);
        let mag = GAIN_K / (1.0 + (w * TAU_S).powi(2)).sqrt();
        a = 4.0 * d * mag / std::f64::consts::PI;
    }
    (a, 2.0 * std::f64::consts::PI / w)
}

#[test]
fn relay_measures_the_analytic_limit_cycle() {
    let c = relay_config();
    let (end, peak, t_end) = run_relay(plant(), c);
    let AutotuneStep::Done(r) = end else {
        panic!("relay ended with {end:?}");
    };
    assert_eq!(r.cycles_used, 4);
    let (a, tu) = (r.amplitude_k as f64, r.tu_s as f64);
    let d = 0.5 * (c.high.fraction() - c.low.fraction());
    let ku = 4.0 * d / (core::f32::consts::PI * r.amplitude_k);
    assert!((r.ku_per_k - ku).abs() < 1e-6 * ku);
    assert_eq!(r.gains, TuneRule::TyreusLuyben.gains(r.ku_per_k, r.tu_s));

    // 1. Exact analysis. The relay acts on the first sample past a switching point, i.e.
    //    0…Δt late: an extra dead time in [0, Δt). The sampled peak lies below the true corner
    //    by at most slope·Δt, the slope there being at most (y_h − r)/τ.
    let (a_lo, tu_lo) = exact_cycle(&c, DEAD_S);
    let (a_hi, tu_hi) = exact_cycle(&c, DEAD_S + DT_S);
    let slope = GAIN_K * c.high.fraction() as f64 / TAU_S;
    assert!(
        a >= a_lo - slope * DT_S && a <= a_hi,
        "a {a} outside [{a_lo}, {a_hi}]"
    );
    assert!(
        tu >= tu_lo - DT_S && tu <= tu_hi + DT_S,
        "Tu {tu} outside [{tu_lo}, {tu_hi}]"
    );

    std::println!(
        "relay (±{} K): a {a:.3} K (exact {a_lo:.3}…{a_hi:.3}), Tu {tu:.2} s (exact \
         {tu_lo:.2}…{tu_hi:.2}), Ku {:.5}/K, peak {peak:.2} K, done at {t_end} s, gains {:?}",
        c.hysteresis_k,
        r.ku_per_k,
        r.gains
    );
    // The run never came near its overshoot limit.
    assert!(peak < (c.target_k + c.max_overshoot_k) as f64 - 2.0);
}

#[test]
fn relay_ku_and_tu_match_the_describing_function() {
    // The describing function predicts the fundamental of the plant output; the relay measures
    // its peak. For an ideal relay on a FOPDT plant the half-wave lies between a triangle
    // (lag-dominant limit, peak/fundamental = π²/8) and a square (dead-time limit, π/4), so
    // Ku = 4d/(πa) is 8/π² … 4/π times the DF's 1/|G(jω)| — the relay method's known −19 % …
    // +27 % bias. The DF's period is exact in both limits (integrator + dead time: 4L; pure
    // dead time: 2L), so 5 % is ample between them. Sampling delays each switch by 0…Δt: the
    // DF is evaluated at dead times L and L + Δt and the bounds taken over both. A small band
    // (ε/a ≈ 0.07) keeps the hysteresis's own DF error (its sinusoidal asin(ε/a) phase) out.
    let c = AutotuneConfig {
        hysteresis_k: 0.2,
        ..relay_config()
    };
    let (end, _, _) = run_relay(plant(), c);
    let AutotuneStep::Done(r) = end else {
        panic!("relay ended with {end:?}");
    };
    let pi = std::f64::consts::PI;
    let d = 0.5 * (c.high.fraction() - c.low.fraction()) as f64;
    let (a0, tu0) = describing_function(&c, DEAD_S);
    let (a1, tu1) = describing_function(&c, DEAD_S + DT_S);
    let (ku0, ku1) = (4.0 * d / (pi * a0), 4.0 * d / (pi * a1));
    let ku = r.ku_per_k as f64;
    let tu = r.tu_s as f64;
    std::println!(
        "relay (±0.2 K): Ku {ku:.5}/K vs DF {ku1:.5}…{ku0:.5} (ratio {:.3}…{:.3}), \
         Tu {tu:.2} s vs DF {tu0:.2}…{tu1:.2}",
        ku / ku0,
        ku / ku1
    );
    assert!(
        ku >= 8.0 / (pi * pi) * ku1 && ku <= 4.0 / pi * ku0,
        "Ku {ku} vs DF {ku1}…{ku0}"
    );
    assert!(
        tu >= 0.95 * tu0 && tu <= 1.05 * tu1,
        "Tu {tu} vs DF {tu0}…{tu1}"
    );
}

/// Step the tuned split-range loop from ambient to the target, ±0.2 K measurement noise, the
/// fan at full duty worth −0.3 heater duty. The loop starts with `reset_to(0)` (outputs were
/// off), so the step is taken bumplessly. Return the overshoot, the largest deviation over the
/// last 600 s of 1200 s and the time after which the temperature stays within 0.5 K.
fn tuned_step(gains: PidGains) -> (f64, f64, f64) {
    let mut plant = plant();
    let split = SplitRange::new(0.02);
    let mut noise = Rng(0x1234_5678_9ABC_DEF1);
    let mut pid = Pid::new(PidConfig::split_range(gains), TARGET_K);
    pid.reset_to(0.0);
    let n = (1200.0 / DT_S) as usize;
    let (mut overshoot, mut dev, mut settled_s) = (f64::MIN, 0.0f64, 0.0);
    for k in 0..n {
        let measured = plant.y_k + 0.4 * (noise.uniform() - 0.5);
        let hc = split.apply(pid.update(measured as f32, sec(DT_S as f32)));
        assert!(!(hc.heater.fraction() > 0.0 && hc.fan.fraction() > 0.0));
        let y = plant.step((hc.heater.fraction() - 0.3 * hc.fan.fraction()) as f64);
        let err = y - TARGET_K as f64;
        overshoot = overshoot.max(err);
        if k >= n / 2 {
            dev = dev.max(err.abs());
        }
        if err.abs() > 0.5 {
            settled_s = (k + 1) as f64 * DT_S;
        }
    }
    (overshoot, dev, settled_s)
}

#[test]
fn tuned_loop_holds_the_target_without_overshoot() {
    let (end, _, _) = run_relay(plant(), relay_config());
    let AutotuneStep::Done(r) = end else {
        panic!("relay ended with {end:?}");
    };
    assert_eq!(r.rule, TuneRule::TyreusLuyben);
    let (overshoot, dev, settled) = tuned_step(r.gains);
    std::println!(
        "Tyreus–Luyben: overshoot {overshoot:.3} K, within 0.5 K from {settled} s, \
         hold ±{dev:.3} K"
    );
    assert!(overshoot < 1.0, "overshoot {overshoot} K");
    assert!(dev <= 0.5, "hold ±{dev} K");
    assert!(settled < 600.0, "settled only at {settled} s");
    // The Ziegler–Nichols rows on the same Ku, Tu overshoot by kelvins: why they are not the
    // default.
    for rule in [
        TuneRule::ZieglerNichols,
        TuneRule::ZieglerNicholsNoOvershoot,
    ] {
        let (o, _, _) = tuned_step(rule.gains(r.ku_per_k, r.tu_s));
        std::println!("{rule:?}: overshoot {o:.3} K");
        assert!(o > 2.0, "{rule:?} overshoot {o}");
    }
}

#[test]
fn relay_aborts_on_overshoot_timeout_and_bad_input() {
    // A relay swinging 0…1 duty on this plant overshoots by far more than 8 K.
    let wild = AutotuneConfig::around(TARGET_K, Duty::from_fraction(0.5), 0.5);
    let (end, peak, _) = run_relay(plant(), wild);
    assert_eq!(end, AutotuneStep::Aborted(AbortReason::Overshoot));
    assert!(peak > (TARGET_K + wild.max_overshoot_k) as f64);
    // Too short a timeout.
    let short = AutotuneConfig {
        timeout_s: 100.0,
        ..relay_config()
    };
    let (end, _, t) = run_relay(plant(), short);
    assert_eq!(end, AutotuneStep::Aborted(AbortReason::Timeout));
    assert!(t > 100.0 && t <= 100.0 + DT_S, "{t}");
    // A NaN measurement, then the abort sticks.
    let mut tune = RelayAutotune::new(relay_config());
    assert!(
        matches!(tune.step(sec(0.0), 300.0), AutotuneStep::Running { heater_duty } if heater_duty.fraction() > 0.29)
    );
    assert_eq!(
        tune.step(sec(0.25), f32::NAN),
        AutotuneStep::Aborted(AbortReason::InvalidMeasurement)
    );
    assert_eq!(
        tune.step(sec(0.5), 300.0),
        AutotuneStep::Aborted(AbortReason::InvalidMeasurement)
    );
    // Time going backwards or NaN.
    let mut tune = RelayAutotune::new(relay_config());
    tune.step(sec(10.0), 300.0);
    assert_eq!(
        tune.step(sec(9.0), 300.0),
        AutotuneStep::Aborted(AbortReason::InvalidTime)
    );
    // (A NaN clock cannot be passed: `Seconds` refuses it. An infinite one aborts.)
    assert_eq!(Seconds::new(f32::NAN), None);
    let mut tune = RelayAutotune::new(relay_config());
    assert_eq!(
        tune.step(sec(f32::INFINITY), 300.0),
        AutotuneStep::Aborted(AbortReason::InvalidTime)
    );
    // Invalid settings never drive the heater.
    for bad in [
        AutotuneConfig {
            hysteresis_k: f32::NAN,
            ..relay_config()
        },
        AutotuneConfig {
            cycles: 1,
            ..relay_config()
        },
        AutotuneConfig::around(TARGET_K, Duty::from_fraction(0.15), f32::NAN),
        AutotuneConfig::around(f32::NAN, Duty::from_fraction(0.15), 0.1),
        AutotuneConfig {
            timeout_s: f32::INFINITY,
            ..relay_config()
        },
    ] {
        let mut tune = RelayAutotune::new(bad);
        assert_eq!(
            tune.step(sec(0.0), 300.0),
            AutotuneStep::Aborted(AbortReason::InvalidConfig)
        );
    }
    // Rules refuse nonsense.
    assert_eq!(TuneRule::TyreusLuyben.gains(f32::NAN, 30.0), PidGains::ZERO);
    assert_eq!(TuneRule::ZieglerNichols.gains(0.1, 0.0), PidGains::ZERO);
}

#[test]
fn tune_rules_follow_their_tables() {
    let (ku, tu) = (0.05f32, 40.0f32);
    let zn = TuneRule::ZieglerNichols.gains(ku, tu);
    let no = TuneRule::ZieglerNicholsNoOvershoot.gains(ku, tu);
    let close = |a: f32, b: f32| (a - b).abs() <= 1e-6 * b.abs();
    assert!(close(zn.kp_per_k, 0.03) && close(zn.ki_per_k_s, 0.03 / 20.0));
    assert!(close(zn.kd_s_per_k, 0.03 * 5.0));
    assert!(close(no.kp_per_k, 0.01) && close(no.ki_per_k_s, 0.01 / 20.0));
    assert!(close(no.kd_s_per_k, 0.01 * 40.0 / 3.0));
    let tl = TuneRule::TyreusLuyben.gains(ku, tu);
    assert!(close(tl.kp_per_k, 0.0225) && close(tl.ki_per_k_s, 0.0225 / 88.0));
    assert!(close(tl.kd_s_per_k, 0.0225 * 40.0 / 6.3));
    assert_eq!(TuneRule::default(), TuneRule::TyreusLuyben);
}
