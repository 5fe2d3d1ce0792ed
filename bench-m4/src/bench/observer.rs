//! The state observer's cost (`thermorph::observer::Observer`), each call on its own after a
//! warm-up of predict/correct cycles (heater 0.8, fan off, springs A and B on, 50 ms — the
//! board's control period — and camera readings around 340 / 330 / 298 K), so the state, the
//! covariance and the springs' phases are realistic:
//!
//! - `observer_predict insns=N mean=M`: a prediction with the cached discretisation (same fan
//!   duty and period as the last one), springs A and B on;
//! - `observer_predict_new_fan insns=N mean=M`: the fan duty changed, so Φ and Γ are
//!   recomputed (the matrix exponential) at the same 50 ms period;
//! - `observer_predict_new_period insns=N dt_s=0.25`: the period changed to 250 ms (the
//!   exponential's norm is larger: scaling and squaring squares twice), for reference;
//! - `observer_predict_long_step insns=N dt_s=10`: a new period of `MAX_STEP_S` (a step after
//!   the loop stalled): the dearest recompute (eight squarings);
//! - `observer_correct insns=N mean=M`: one frame's correction with T1, T2 and T5 (not the
//!   first, which only initialises the state);
//! - `observer_estimate insns=N`, `observer_softest insns=N`.
//!
//! `N` is the worst of the measured calls, `M` their mean. `scripts/bench-m4` holds
//! `observer_correct` to 40 000 instructions per frame, and every recomputing prediction
//! (`observer_predict_new_fan`, `_new_period`, `_long_step`) to 40 000. A `part observer`
//! line splits the cached prediction for profiling (one spring's step, libm's `expf`).
//!
//! The observer's order (`thermorph::observer::ObserverN`, its wall in `L` layers): the same
//! measurement for each order, one line each,
//! `observer_order layers=L correct_insns=N predict_insns=N predict_new_fan_insns=N` (the
//! worst calls, as above; the default order's are the lines above). `scripts/bench-m4`
//! checks them against `docs/observer-order-m4.txt`, the work-precision table's cost columns
//! (`docs/observer.md`).

use core::hint::black_box;

use cortex_m_semihosting::hprintln;
use thermorph::observer::{
    AUG, EstimateN, LAYERS, MAX_STEP_S, ObserverN, ObserverParams, STATES, SoftestN,
};
use thermorph::outputs::SpringMask;
use thermorph::units::{Kelvin, Seconds};

/// Calls measured per kind (the worst and the mean are reported).
const CALLS: u32 = 16;

/// The camera's reading of frame `k`: the film rising from 340 K, the outer surface from
/// 330 K, the background at 298 K, each with a little deterministic jitter.
fn reading(k: u32) -> (Option<Kelvin>, Option<Kelvin>, Option<Kelvin>) {
    let jitter = ((k * 7) % 5) as f32 * 0.1 - 0.2;
    (
        Kelvin::new(340.0 + 0.05 * k as f32 + jitter),
        Kelvin::new(330.0 + 0.03 * k as f32 - jitter),
        Kelvin::new(298.0 + 0.5 * jitter),
    )
}

/// Worst and mean of `CALLS` measurements of `f(i)` (the overhead taken off).
fn worst_mean(overhead: u64, mut f: impl FnMut(u32) -> u64) -> (u64, u64) {
    let (mut worst, mut sum) = (0u64, 0u64);
    for i in 0..CALLS {
        let t = f(i).saturating_sub(overhead);
        worst = worst.max(t);
        sum += t;
    }
    (worst, sum / CALLS as u64)
}

/// One order's figures (instructions, overhead taken off; worst and mean of `CALLS`).
struct Figures<const L: usize, const S: usize, const A: usize> {
    predict: (u64, u64),
    new_fan: (u64, u64),
    new_period: u64,
    long_step: u64,
    correct: (u64, u64),
    estimate: u64,
    softest: u64,
    /// The estimate after the measurements (to show the bench computed something real).
    e: EstimateN<L>,
    /// The observer after the measurements.
    obs: ObserverN<L, S, A>,
}

/// Measure an observer of `L` wall layers: the warm-up, then each kind of call.
fn measure<const L: usize, const S: usize, const A: usize>(overhead: u64) -> Figures<L, S, A> {
    let Some(ab) = SpringMask::parse("AB") else {
        super::fail("spring mask")
    };
    let dt = Seconds::lit(0.05);
    let heater = 0.8f32;
    let mut obs = ObserverN::<L, S, A>::new(&ObserverParams::DEFAULT, 298.15);
    // Warm-up: 2 s of control periods, a frame every 5th (4 frames a second at 50 ms).
    let mut frame = 0u32;
    for k in 0..40u32 {
        obs.predict(black_box(heater), black_box(0.0), ab, black_box(dt));
        if k % 5 == 0 {
            let (t1, t2, t5) = reading(frame);
            obs.correct(t1, t2, t5);
            frame += 1;
        }
    }

    // The cached prediction (same fan duty, same period).
    let (predict, predict_mean) = worst_mean(overhead, |_| {
        let ((), t) = super::measure(|| {
            obs.predict(
                black_box(heater),
                black_box(0.0),
                black_box(ab),
                black_box(dt),
            )
        });
        t
    });

    // A new fan duty at every call: the discretisation is recomputed.
    let (new_fan, new_fan_mean) = worst_mean(overhead, |i| {
        let fan = 0.1 + 0.05 * i as f32;
        let ((), t) = super::measure(|| {
            obs.predict(
                black_box(heater),
                black_box(fan),
                black_box(ab),
                black_box(dt),
            )
        });
        t
    });
    // A new period (250 ms) at the fan duty last used: recomputed, with squarings.
    let fan = 0.1 + 0.05 * (CALLS - 1) as f32;
    // (On copies: the state the correction is measured on stays that of 50 ms periods.)
    let mut copy = obs.clone();
    let ((), new_period) = super::measure(|| {
        copy.predict(
            black_box(heater),
            black_box(fan),
            black_box(ab),
            black_box(Seconds::lit(0.25)),
        )
    });
    // The longest period one prediction covers (`MAX_STEP_S`, e.g. the step after a flash
    // operation stalled the loop): the dearest recompute, eight squarings.
    let mut copy = obs.clone();
    let ((), long_step) = super::measure(|| {
        copy.predict(
            black_box(heater),
            black_box(fan),
            black_box(ab),
            black_box(Seconds::lit(MAX_STEP_S)),
        )
    });
    // Back to the warm-up's inputs (recomputes once, unmeasured).
    obs.predict(black_box(heater), black_box(0.0), ab, black_box(dt));

    // One frame's correction with T1, T2, T5, a prediction between frames (unmeasured).
    let (correct, correct_mean) = worst_mean(overhead, |_| {
        obs.predict(black_box(heater), black_box(0.0), ab, black_box(dt));
        let (t1, t2, t5) = black_box(reading(frame));
        frame += 1;
        let ((), t) = super::measure(|| obs.correct(t1, t2, t5));
        t
    });

    let (e, estimate) = super::measure(|| obs.estimate());
    black_box(&e);
    let (s, softest) = super::measure(|| obs.softest(black_box(358.0)));
    black_box::<&SoftestN<L>>(&s);
    Figures {
        predict: (predict, predict_mean),
        new_fan: (new_fan, new_fan_mean),
        new_period: new_period.saturating_sub(overhead),
        long_step: long_step.saturating_sub(overhead),
        correct: (correct, correct_mean),
        estimate: estimate.saturating_sub(overhead),
        softest: softest.saturating_sub(overhead),
        e,
        obs,
    }
}

/// The order line of one order's figures.
fn order_line<const L: usize, const S: usize, const A: usize>(f: &Figures<L, S, A>) {
    hprintln!(
        "observer_order layers={} correct_insns={} predict_insns={} predict_new_fan_insns={}",
        L,
        f.correct.0,
        f.predict.0,
        f.new_fan.0
    );
}

/// Measure and print the observer's lines.
pub fn bench(overhead: u64) {
    let f = measure::<LAYERS, STATES, AUG>(overhead);
    let (obs, e) = (&f.obs, f.e);

    // Parts of the prediction, for profiling: one spring's enthalpy step (switched on), and
    // libm's expf (two per spring and step).
    let sp = ObserverParams::DEFAULT.springs;
    let mut spring = obs.springs()[0];
    let ((), t_spring) = super::measure(|| {
        spring.predict(
            black_box(&sp),
            black_box(true),
            black_box(298.0),
            black_box(330.0),
            black_box(0.05),
        )
    });
    black_box(&spring);
    let n = 64u32;
    let ((), t_expf) = super::measure(|| {
        let mut a = 0.0;
        for i in 0..n {
            a += libm::expf(black_box(-0.001 * i as f32));
        }
        black_box(a);
    });
    hprintln!(
        "part observer spring_predict insns={} expf insns_per_call={}",
        t_spring.saturating_sub(overhead),
        t_expf / n as u64
    );
    hprintln!(
        "observer_predict insns={} mean={}",
        f.predict.0,
        f.predict.1
    );
    hprintln!(
        "observer_predict_new_fan insns={} mean={}",
        f.new_fan.0,
        f.new_fan.1
    );
    hprintln!(
        "observer_predict_new_period insns={} dt_s=0.25",
        f.new_period
    );
    hprintln!(
        "observer_predict_long_step insns={} dt_s={}",
        f.long_step,
        MAX_STEP_S
    );
    hprintln!(
        "observer_correct insns={} mean={}",
        f.correct.0,
        f.correct.1
    );
    hprintln!("observer_estimate insns={}", f.estimate);
    hprintln!("observer_softest insns={}", f.softest);
    // The estimate, to show the bench computed something real.
    hprintln!(
        "observer_result film_k={} inner_k={} outer_k={} ambient_k={} frozen={} spring_a_k={} austenite_a={}",
        e.film_k,
        e.layers_k[0],
        e.layers_k[LAYERS - 1],
        e.ambient_k,
        e.frozen,
        e.springs_k[0],
        e.austenite[0]
    );

    // The wall's order: the same measurement in 1…6 layers (the default's is the one above).
    order_line(&measure::<1, 3, 4>(overhead));
    order_line(&f);
    order_line(&measure::<3, 5, 6>(overhead));
    order_line(&measure::<4, 6, 7>(overhead));
    order_line(&measure::<6, 8, 9>(overhead));
}
