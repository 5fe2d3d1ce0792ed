//! The firmware's observer (`thermorph::observer`) against the plant, open loop: heater 100 %
//! for 60 s, 35 % for 120 s, then heater off and fan 100 % for 120 s, in steps of 0.25 s. The
//! observer is fed the plant's true heater film (T1) and outer surface (T2) and the ambient
//! (T5), each with ≈0.1 K of Gaussian-ish noise, every step; its inner layer (never measured)
//! is compared with the plant's. At 298 K, 263 K and 323 K ambient, on the fitted plant, with
//! its PMMA plates and on plants 20 % off the observer's parameters (`PlantScale`). The same
//! run measures the observer's order (its wall in 1…6 layers) for `docs/observer.md`'s
//! work-precision table, at 273, 298 and 323 K. Then the closed-loop error table of
//! `docs/observer.md`.
//! `cargo test -p host-sim --test observer -- --nocapture` prints the errors.

mod doc_table;
use doc_table::write_or_check;

use std::collections::BTreeMap;

use host_sim::plant::{Inputs, ModelOptions, Observation, Plant, PlantConfig, PlantScale};
use host_sim::sensor::virtual_mlx::Rng;
use thermorph::observer::{AUG, EstimateN, LAYERS, ObserverN, ObserverParams, STATES, Wall};
use thermorph::outputs::SpringMask;
use thermorph::units::{Kelvin, Seconds};

const DT_S: f64 = 0.25;
const NOISE_K: f32 = 0.1;
/// The errors are counted from this time on, s (the filter's start-up).
const SETTLE_S: f64 = 10.0;

/// The corner of a ±20 % block where everything heats faster than the observer believes:
/// heater power +20 %, wall capacity −20 %, spring cooling −20 %, spring supply +20 %.
const PLUS_20: PlantScale = PlantScale {
    heater_power: 1.2,
    wall_capacity: 0.8,
    spring_cooling: 0.8,
    spring_supply: 1.2,
};

/// The opposite corner: everything heats slower than the observer believes.
const MINUS_20: PlantScale = PlantScale {
    heater_power: 0.8,
    wall_capacity: 1.2,
    spring_cooling: 1.2,
    spring_supply: 0.8,
};

/// The open-loop run with an observer of `L` wall layers ([`ObserverN`]) against the plant,
/// with `options` (its PMMA end plates, which the observer does not model; a scale): `visit`
/// sees each step's estimate, the observer's wall and the plant, from `SETTLE_S` on.
fn open_loop<const L: usize, const S: usize, const A: usize>(
    ambient_k: f64,
    options: ModelOptions,
    mut visit: impl FnMut(&EstimateN<L>, &Wall<L>, &Observation),
) {
    let config = PlantConfig {
        ambient_k,
        initial_k: ambient_k,
        ..PlantConfig::default()
    };
    let mut plant = Plant::with_options(&config, options).expect("valid config");
    // The observer starts from a guess 5 K off (it does not know the ambient yet).
    let mut obs = ObserverN::<L, S, A>::new(&ObserverParams::DEFAULT, ambient_k as f32 + 5.0);
    let mut noise = Rng::new(0x2545_f491_4f6c_dd1d);
    let dt = Seconds::new(DT_S as f32).expect("finite");
    let steps = (300.0 / DT_S) as u32;
    for i in 0..steps {
        let t = f64::from(i) * DT_S;
        let (heater_duty, fan_duty) = if t < 60.0 {
            (1.0, 0.0)
        } else if t < 180.0 {
            (0.35, 0.0)
        } else {
            (0.0, 1.0)
        };
        let inputs = Inputs {
            heater_duty,
            fan_duty,
            ..Inputs::default()
        };
        plant.step(&inputs, DT_S);
        obs.predict(heater_duty as f32, fan_duty as f32, SpringMask::NONE, dt);
        let o = plant.observe();
        let mut measure = |k: f64| Kelvin::new(k as f32 + (noise.gauss() * NOISE_K as f64) as f32);
        let (t1, t2, t5) = (
            measure(o.heater_k),
            measure(o.smp_outer_k),
            measure(o.ambient_k),
        );
        obs.correct(t1, t2, t5);
        if t + DT_S >= SETTLE_S {
            visit(&obs.estimate(), obs.wall(), &o);
        }
    }
}

/// Mean and max |inner layer error| after `SETTLE_S`, K, with the plant's PMMA end plates on
/// or off (the observer does not model them).
fn run(ambient_k: f64, pmma_plates: bool) -> (f64, f64) {
    run_with(
        ambient_k,
        ModelOptions {
            pmma_plates,
            ..ModelOptions::default()
        },
    )
}

/// [`run`] on a plant with `options` (the observer keeps its default parameters).
fn run_with(ambient_k: f64, options: ModelOptions) -> (f64, f64) {
    let (mut sum, mut max, mut n) = (0.0f64, 0.0f64, 0u32);
    open_loop::<LAYERS, STATES, AUG>(ambient_k, options, |e, _, o| {
        let e = (f64::from(e.layers_k[0]) - o.smp_inner_k).abs();
        sum += e;
        max = max.max(e);
        n += 1;
    });
    (sum / f64::from(n), max)
}

/// The default plant (no plates: the observer's network without the duct air node). Measured
/// (2026-11): mean 0.091 K, max 0.171 K at each ambient; asserted with a margin of ≈3.
#[test]
fn observer_tracks_the_inner_layer() {
    for ambient_k in [298.15, 263.15, 323.15] {
        let (mean, max) = run(ambient_k, false);
        println!(
            "ambient {ambient_k:.2} K: inner layer |error| after {SETTLE_S} s: mean {mean:.3} K, max {max:.3} K"
        );
        assert!(max <= 0.5, "ambient {ambient_k}: max error {max} K");
        assert!(mean <= 0.25, "ambient {ambient_k}: mean error {mean} K");
    }
}

/// The plant with its PMMA end plates, a heat path the observer does not model. Measured
/// (2026-11): mean 0.062 K, max 0.124 K at each ambient (the plates' 0.015 W/K is small).
#[test]
fn observer_with_unmodelled_plates() {
    for ambient_k in [298.15, 263.15, 323.15] {
        let (mean, max) = run(ambient_k, true);
        println!(
            "plates, ambient {ambient_k:.2} K: inner layer |error| after {SETTLE_S} s: mean {mean:.3} K, max {max:.3} K"
        );
        assert!(max <= 0.5, "ambient {ambient_k}: max error {max} K");
    }
}

/// A plant whose heater power, wall capacity and spring factors are 20 % off the observer's
/// (its parameters stay the defaults): the open-loop inner-layer error grows with the mismatch.
#[test]
fn observer_with_a_plant_20_percent_off() {
    for (label, scale) in [("+20 %", PLUS_20), ("−20 %", MINUS_20)] {
        for ambient_k in [298.15, 263.15, 323.15] {
            let options = ModelOptions {
                scale,
                ..ModelOptions::default()
            };
            let (mean, max) = run_with(ambient_k, options);
            println!(
                "plant {label}, ambient {ambient_k:.2} K: inner layer |error| after {SETTLE_S} s: mean {mean:.3} K, max {max:.3} K"
            );
            // Measured (2026-11): +20 % mean 0.298 K, max 1.196 K; −20 % mean 0.438 K, max
            // 1.260 K at each ambient (the network is linear); asserted with a margin of ≈2.
            assert!(
                max <= 2.5,
                "{label}, ambient {ambient_k}: max error {max} K"
            );
            assert!(
                mean <= 0.8,
                "{label}, ambient {ambient_k}: mean error {mean} K"
            );
        }
    }
}

/// Mean and max |error| (and the signed mean, estimate − plant) of one estimate over a run.
#[derive(Default)]
struct Err {
    sum: f64,
    signed: f64,
    max: f64,
    n: u32,
}

impl Err {
    fn add(&mut self, e: f64) {
        if e.is_finite() {
            self.sum += e.abs();
            self.signed += e;
            self.max = self.max.max(e.abs());
            self.n += 1;
        }
    }
    fn signed_mean(&self) -> f64 {
        self.signed / f64::from(self.n.max(1))
    }
    fn mean(&self) -> f64 {
        self.sum / f64::from(self.n.max(1))
    }
    fn cell(&self, digits: usize) -> String {
        format!(
            "{:.d$} / {:.d$}",
            self.sum / f64::from(self.n.max(1)),
            self.max,
            d = digits
        )
    }
}

/// The observer error table of `docs/observer.md`: the supervisor's own observer, in the loop
/// with the camera on, over the paper's cycle (`paper::cycle_in`, springs A+B) at 273, 298 and
/// 323 K, against the plant's truth, counted after the first 10 s. The table in the docs must
/// be this test's output (a stale table fails); `THERMORPH_WRITE_DOCS=1` rewrites it.
#[test]
fn observer_error_table_over_the_cycle() {
    use host_sim::runs::paper;
    let mut table = String::from(
        "| ambient | inner layer K | outer layer K | frozen fraction | springs K (A, B, C) | austenite fraction (A, B, C) |\n\
         |---|---|---|---|---|---|\n",
    );
    let cases = [
        ("273.15 K", 273.15, PlantScale::UNIT),
        ("298.15 K", 298.15, PlantScale::UNIT),
        ("323.15 K", 323.15, PlantScale::UNIT),
        ("298.15 K, plant +20 %", 298.15, PLUS_20),
        ("298.15 K, plant −20 %", 298.15, MINUS_20),
    ];
    for (label, ambient_k, scale) in cases {
        let sc = paper::scene_with(900.0, ambient_k, true, &scale).unwrap();
        let rows = paper::cycle_in(&sc, "AB").unwrap();
        let mut modes: Vec<&str> = Vec::new();
        for r in &rows {
            let c = r.control.expect("closed loop");
            if modes.last() != Some(&c.mode) {
                modes.push(c.mode);
            }
        }
        let faults: Vec<_> = rows.iter().filter_map(|r| r.control?.fault).collect();
        let max_bend_deg = rows.iter().map(|r| r.obs.bend_deg).fold(0.0, f64::max);
        println!(
            "{label}: modes {modes:?}, first fault {:?}, largest bend {max_bend_deg:.1}°",
            faults.first()
        );
        // The whole cycle runs, on the mismatched plants too: no fault, every mode entered.
        assert!(faults.is_empty(), "{label}: fault {:?}", faults.first());
        assert_eq!(
            modes,
            [
                "standby",
                "step-large",
                "form",
                "standby",
                "recover",
                "standby"
            ],
            "{label}"
        );
        let (mut inner, mut outer, mut frozen, mut spring, mut aus) = (
            Err::default(),
            Err::default(),
            Err::default(),
            Err::default(),
            Err::default(),
        );
        // The estimate is the one of the period's start; the plant's of its end: compare each
        // estimate with the plant at the end of the period before.
        for w in rows.windows(2) {
            let (before, r) = (&w[0], &w[1]);
            if r.obs.time_s < 10.0 {
                continue;
            }
            let e = r.control.expect("closed loop").estimate;
            let o = &before.obs;
            inner.add(f64::from(e.layers_k[0]) - o.smp_inner_k);
            outer.add(f64::from(e.layers_k[1]) - o.smp_outer_k);
            frozen.add(f64::from(e.frozen) - o.frozen_fraction);
            for i in 0..3 {
                spring.add(f64::from(e.springs_k[i]) - o.springs_k[i]);
                aus.add(f64::from(e.austenite[i]) - o.austenite[i]);
            }
        }
        println!(
            "{label}: inner {} outer {} frozen {} springs {} austenite {}",
            inner.cell(3),
            outer.cell(3),
            frozen.cell(4),
            spring.cell(2),
            aus.cell(3)
        );
        println!(
            "{label}: signed mean (estimate − plant): inner {:+.3} K, frozen {:+.4}, springs {:+.2} K, austenite {:+.3}",
            inner.signed_mean(),
            frozen.signed_mean(),
            spring.signed_mean(),
            aus.signed_mean()
        );
        table.push_str(&format!(
            "| {label} | {} | {} | {} | {} | {} |\n",
            inner.cell(2),
            outer.cell(2),
            frozen.cell(3),
            spring.cell(1),
            aus.cell(2)
        ));
        let mean = |e: &Err| e.sum / f64::from(e.n);
        if scale == PlantScale::UNIT {
            // The wall is what readiness reads: within 1 K and 0.05 of frozen fraction on
            // average.
            assert!(mean(&inner) < 1.0, "{label}: inner");
            assert!(mean(&frozen) < 0.05, "{label}: frozen");
            // The springs are model states nothing corrects (measured 2026-11-25: max 14 K at
            // 273 K, where the plant's loaded springs transform higher than the model's).
            assert!(mean(&spring) < 6.0, "{label}: springs mean");
            assert!(spring.max < 20.0, "{label}: springs max {}", spring.max);
        } else {
            // A ±20 % plant with the observer's default parameters. Measured (2026-11-25, the
            // wall's refit, recovery on the colder region), mean / max: +20 % inner 0.27 /
            // 1.39 K, frozen 0.004 / 0.079, springs 7.2 / 22.2 K, austenite 0.05 / 0.27; −20 %
            // inner 0.15 / 3.06 K (recovery's reheat drives the film to its cap, which the
            // slower wall follows late), frozen 0.002 / 0.032, springs 8.8 / 24.0 K, austenite
            // 0.33 / 0.77 (the springs get 0.78× the heat the model gives them and lose 1.2× as
            // much: the model's are ahead). Asserted with ≈1.5–2×.
            assert!(mean(&inner) < 0.8, "{label}: inner mean {}", mean(&inner));
            assert!(inner.max < 4.5, "{label}: inner max {}", inner.max);
            assert!(
                mean(&frozen) < 0.01,
                "{label}: frozen mean {}",
                mean(&frozen)
            );
            assert!(
                mean(&spring) < 16.0,
                "{label}: springs mean {}",
                mean(&spring)
            );
            assert!(spring.max < 40.0, "{label}: springs max {}", spring.max);
            assert!(mean(&aus) < 0.6, "{label}: austenite mean {}", mean(&aus));
        }
    }
    print!("{table}");
    write_or_check(
        "observer.md",
        "observer-errors",
        &table,
        "THERMORPH_WRITE_DOCS=1 cargo test -p host-sim --test observer",
    );
}

/// The ambients of the order table, K.
const ORDER_AMBIENTS_K: [f64; 3] = [273.15, 298.15, 323.15];
/// Control periods per second on the board (`thermorph::app::CONTROL_PERIOD_MS`): cached
/// predictions per second.
const PREDICTS_PER_S: u64 = 1000 / thermorph::app::CONTROL_PERIOD_MS;
/// Camera frames per second (the MLX90640's default 8 Hz subpages: a whole frame at 4 Hz):
/// corrections per second.
const CORRECTS_PER_S: u64 = 4;

/// One order's errors over the open-loop run at each of `ORDER_AMBIENTS_K`, pooled (every
/// step after `SETTLE_S` of the three runs): the inner lattice layer (the capacity-weighted
/// mean of the observer's layers lying in the plant's inner 4 mm, `Wall::inner_layer_k`,
/// against the plant's inner node), the wall's frozen fraction (the observer's, weighted by
/// its layers' capacities, against the plant's `frozen_fraction`) and the outer surface (the
/// outermost layer, what T2 measures, against the plant's outer node).
fn order_errors<const L: usize, const S: usize, const A: usize>() -> [Err; 3] {
    let mut all = [Err::default(), Err::default(), Err::default()];
    for ambient_k in ORDER_AMBIENTS_K {
        let mut one = [Err::default(), Err::default(), Err::default()];
        open_loop::<L, S, A>(ambient_k, ModelOptions::default(), |e, wall, o| {
            let errors = [
                f64::from(wall.inner_layer_k(&e.layers_k)) - o.smp_inner_k,
                f64::from(e.frozen) - o.frozen_fraction,
                f64::from(e.layers_k[L - 1]) - o.smp_outer_k,
            ];
            for (k, &x) in errors.iter().enumerate() {
                all[k].add(x);
                one[k].add(x);
            }
        });
        println!(
            "{L} layers, {ambient_k} K: inner {} K, frozen {}, outer {} K",
            one[0].cell(3),
            one[1].cell(4),
            one[2].cell(3)
        );
    }
    all
}

/// The Cortex-M4 counts of each order: `docs/observer-order-m4.txt`, the `observer_order`
/// lines of `scripts/bench-m4` (which checks them against the bench), by layers:
/// (correct, predict, predict with a new fan duty).
fn order_counts() -> BTreeMap<usize, [u64; 3]> {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/observer-order-m4.txt");
    let text = std::fs::read_to_string(&path).expect("docs/observer-order-m4.txt");
    let mut counts = BTreeMap::new();
    for line in text.lines().filter(|l| l.starts_with("observer_order ")) {
        let field = |key: &str| -> u64 {
            line.split_whitespace()
                .find_map(|w| w.strip_prefix(key)?.strip_prefix('='))
                .and_then(|v| v.parse().ok())
                .unwrap_or_else(|| panic!("docs/observer-order-m4.txt: no {key} in `{line}`"))
        };
        counts.insert(
            field("layers") as usize,
            [
                field("correct_insns"),
                field("predict_insns"),
                field("predict_new_fan_insns"),
            ],
        );
    }
    counts
}

/// The model alone (no correction) of `L` layers at the end of the open loop's 60 s at full
/// heater from a wall at 298.15 K: the inner lattice layer's temperature, K, and the wall's
/// frozen fraction. The wall's own gradient, which the plant's two nodes cannot show.
fn model_after_full_heat<const L: usize, const S: usize, const A: usize>() -> (f32, f32) {
    let mut obs = ObserverN::<L, S, A>::new(&ObserverParams::DEFAULT, 298.15);
    let dt = Seconds::new(DT_S as f32).expect("finite");
    for _ in 0..(60.0 / DT_S) as u32 {
        obs.predict(1.0, 0.0, SpringMask::NONE, dt);
    }
    let e = obs.estimate();
    (obs.wall().inner_layer_k(&e.layers_k), e.frozen)
}

/// The work-precision table of the observer's order in `docs/observer.md`: each order's
/// errors against the plant over the open-loop run (`order_errors`) beside its Cortex-M4
/// instructions (`order_counts`), and the orders on the front. The table in the docs must be
/// this test's output (a stale table fails); `bash scripts/observer-order` rewrites the counts
/// and then it (`THERMORPH_WRITE_DOCS=1`).
#[test]
fn observer_order_table() {
    let errors = [
        (1, order_errors::<1, 3, 4>()),
        (2, order_errors::<2, 4, 5>()),
        (3, order_errors::<3, 5, 6>()),
        (4, order_errors::<4, 6, 7>()),
        (6, order_errors::<6, 8, 9>()),
    ];
    let counts = order_counts();
    let mut table = String::from(
        "| layers | inner layer K | frozen fraction | outer surface K | correct insns | predict insns | predict new-fan insns | insns/s |\n\
         |---|---|---|---|---|---|---|---|\n",
    );
    let mut points = Vec::new();
    for (layers, [inner, frozen, outer]) in &errors {
        let Some(&[correct, predict, new_fan]) = counts.get(layers) else {
            panic!(
                "docs/observer-order-m4.txt has no {layers}-layer line: bash scripts/observer-order"
            );
        };
        let per_s = PREDICTS_PER_S * predict + CORRECTS_PER_S * correct;
        let name = if *layers == LAYERS {
            format!("{layers} (default)")
        } else {
            layers.to_string()
        };
        table.push_str(&format!(
            "| {name} | {} | {} | {} | {correct} | {predict} | {new_fan} | {per_s} |\n",
            inner.cell(3),
            frozen.cell(4),
            outer.cell(3),
        ));
        points.push((*layers, inner.mean(), per_s));
    }
    // The front: no other order has a mean inner-layer error and a load at least as small,
    // one of them smaller.
    let front: Vec<String> = points
        .iter()
        .filter(|&&(_, e, c)| {
            !points
                .iter()
                .any(|&(_, e2, c2)| e2 <= e && c2 <= c && (e2 < e || c2 < c))
        })
        .map(|p| p.0.to_string())
        .collect();
    table.push_str(&format!(
        "\nOn the front (mean inner-layer error against instructions per second): {} layers.\n",
        front.join(", ")
    ));
    let models = [
        (2, model_after_full_heat::<2, 4, 5>()),
        (6, model_after_full_heat::<6, 8, 9>()),
        (24, model_after_full_heat::<24, 26, 27>()),
    ];
    let cells: Vec<String> = models
        .iter()
        .map(|(l, (t, f))| format!("{t:.2} K and {f:.3} ({l} layers)"))
        .collect();
    table.push_str(&format!(
        "The model alone after the 60 s at full heater from 298.15 K (no correction): inner \
         4 mm and frozen fraction {}.\n",
        cells.join(", ")
    ));
    print!("{table}");
    // Against this plant (two nodes, the default's) the default is the most accurate order on
    // the inner layer and the frozen fraction; the cost grows with the order.
    let default = errors
        .iter()
        .find(|e| e.0 == LAYERS)
        .expect("the default order");
    for (layers, [inner, frozen, _]) in &errors {
        if *layers != LAYERS {
            assert!(inner.mean() > default.1[0].mean(), "{layers} layers: inner");
            assert!(
                frozen.mean() > default.1[1].mean(),
                "{layers} layers: frozen"
            );
        }
    }
    assert!(points.windows(2).all(|w| w[0].2 < w[1].2), "{points:?}");
    // The finer models converge: 6 layers are nearer 24 than the default is.
    let (t2, t6, t24) = (models[0].1.0, models[1].1.0, models[2].1.0);
    assert!((t6 - t24).abs() < 0.25 * (t2 - t24).abs(), "{models:?}");
    write_or_check(
        "observer.md",
        "observer-order",
        &table,
        "bash scripts/observer-order",
    );
}
