//! Open-loop calibration of the plant against the thesis's figures (6.4.1–6.4.3) at 298 K with
//! timed duties: heat-up, forming and reheating times, the stiffness contrast, stepping one and
//! two springs with the thesis's 4 × 6 s on + 3 × 2 s off (the angle in every phase), the
//! angle lost in the first 20 s of forming, the angle kept once the springs are cold, and the
//! recovery. `cargo test -p host-sim --test plant_calibration -- --nocapture --test-threads 1`
//! prints each figure beside the thesis's (they are quoted in docs/PLANT-API.md).

use host_sim::plant::{
    Inputs, ModelOptions, Observation, Plant, PlantConfig, circuit, params, sma,
};

const DT_S: f64 = 0.1;
const AMBIENT_K: f64 = 298.15;

fn plant_at(initial_k: f64) -> Plant {
    Plant::new(&PlantConfig {
        initial_k,
        ..PlantConfig::default()
    })
    .expect("valid config")
}

/// Run until `value` crosses `target` (linear interpolation of the crossing time), at most
/// `limit_s`. Returns the crossing time since the call, s.
fn time_until(
    plant: &mut Plant,
    inputs: &Inputs,
    value: impl Fn(&Observation) -> f64,
    target: f64,
    limit_s: f64,
) -> Option<f64> {
    let t0 = plant.time_s();
    let mut prev = value(&plant.observe());
    let rising = prev < target;
    while plant.time_s() - t0 < limit_s {
        plant.step(inputs, DT_S);
        let now = value(&plant.observe());
        let crossed = if rising { now >= target } else { now <= target };
        if crossed {
            let frac = (target - prev) / (now - prev);
            return Some(plant.time_s() - t0 - DT_S + frac * DT_S);
        }
        prev = now;
    }
    None
}

/// A PI controller on the coldest SMP layer (stepping's soak), or on the heater surface
/// (standby's 323 K), as the supervisor holds them.
struct Hold {
    target_k: f64,
    integral: f64,
    on_heater: bool,
}

impl Hold {
    fn new(target_k: f64) -> Self {
        Hold {
            target_k,
            integral: 0.3,
            on_heater: false,
        }
    }
    fn heater(target_k: f64) -> Self {
        Hold {
            on_heater: true,
            ..Hold::new(target_k)
        }
    }
    fn duty(&mut self, obs: &Observation) -> f64 {
        let t = if self.on_heater {
            obs.heater_k
        } else {
            obs.smp_coldest_k
        };
        let e = self.target_k - t;
        self.integral = (self.integral + 0.002 * e * DT_S).clamp(0.0, 1.0);
        (0.15 * e + self.integral).clamp(0.0, 1.0)
    }
}

/// Run `secs` holding the SMP at `hold` with springs `on`.
fn hold_for(plant: &mut Plant, hold: &mut Hold, on: [bool; 3], secs: f64) {
    let t0 = plant.time_s();
    while plant.time_s() - t0 < secs - 1e-9 {
        let d = hold.duty(&plant.observe());
        let inputs = Inputs {
            heater_duty: d,
            springs_on: on,
            ..Inputs::default()
        };
        plant.step(&inputs, DT_S);
    }
}

/// The thesis's ≈10 s to 323 K is the standby preheat with its PID (`host-sim paper`'s
/// `preheat_time_s`, 8.5 s), which backs off as the film nears 323 K; at full duty all the way
/// the refitted heater (58.9 W, issue 19) is there sooner, and never later than the thesis.
#[test]
fn heater_full_on_reaches_323_k_in_about_10_s() {
    let mut plant = plant_at(AMBIENT_K);
    let full = Inputs {
        heater_duty: 1.0,
        ..Inputs::default()
    };
    let t = time_until(&mut plant, &full, |o| o.heater_k, 323.0, 60.0).expect("reaches 323 K");
    println!(
        "heat-up 298 → 323 K (heater surface, full duty): {t:.1} s (thesis ≈10 s); {:.1} W",
        plant.observe().heater_power_w
    );
    assert!((6.0..=10.0).contains(&t), "{t}");
}

/// Forming from the stepping state (from 298 K, the coldest layer brought to and held at
/// 358 K for 240 s, as the supervisor holds it: the film ≈385 K, the inner layer ≈375 K), then
/// reheating: (forming time, reheat time, k_b hot, k_b formed).
fn form_and_reheat() -> (f64, f64, f64, f64) {
    let mut plant = plant_at(AMBIENT_K);
    hold_for(&mut plant, &mut Hold::new(358.0), [false; 3], 240.0);
    assert!(plant.observe().smp_coldest_k > 357.0);
    let k_hot = plant.observe().k_b_nmm_per_rad;
    let fan = Inputs {
        fan_duty: 1.0,
        ..Inputs::default()
    };
    let forming = time_until(&mut plant, &fan, |o| o.smp_outer_k, 323.0, 300.0).expect("forms");
    let k_cold = plant.observe().k_b_nmm_per_rad;
    let heat = Inputs {
        heater_duty: 1.0,
        ..Inputs::default()
    };
    let reheat = time_until(&mut plant, &heat, |o| o.heater_k, 358.0, 300.0).expect("reheats");
    (forming, reheat, k_hot, k_cold)
}

/// Forming from the stepping state ≈ 50 s; the film back at 358 K at full duty. The thesis's
/// ≈25 s reheat is read in the closed loop as the wall's: `host-sim paper`'s
/// `recovery_k_b_25s_ratio` (k_b 25 s into recovery over the heated k_b: 1.05, fig. 6.10(d)) —
/// the film alone, at full duty, leads the wall and is at 358 K in ≈ 14 s.
#[test]
fn forming_takes_about_50_s_and_reheating_about_25_s() {
    let (forming, reheat, _, _) = form_and_reheat();
    println!(
        "forming 358 → 323 K (SMP outer, fan full, from stepping): {forming:.1} s (thesis ≈50 s)"
    );
    println!("reheat 323 → 358 K (heater surface, full duty): {reheat:.1} s (thesis ≈25 s)");
    assert!((45.0..=55.0).contains(&forming), "{forming}");
    assert!((10.0..=25.0).contains(&reheat), "{reheat}");
}

#[test]
fn stiffness_rises_about_4_5_times_to_1400_on_forming() {
    let (_, _, k_hot, k_cold) = form_and_reheat();
    let ratio = k_cold / k_hot;
    println!("k_b 358 K {k_hot:.0} → formed {k_cold:.0} N·mm/rad (×{ratio:.2}; thesis 1400, ×4.5)");
    assert!((1190.0..=1610.0).contains(&k_cold), "{k_cold}");
    assert!((4.5 * 0.85..=4.5 * 1.15).contains(&ratio), "{ratio}");
}

/// Wire temperature a spring is pre-warmed to before stepping, K: 6 K under As, so the first
/// step bends at once and nothing bends before it.
const PREHEAT_TARGET_K: f64 = params::SMA_AS_K - 16.0;

/// Length of the full-current pre-warming pulse that takes a spring from `from_k` to the
/// preheat target (the channel's power into the wire's heat capacity, still-air loss neglected).
fn preheat_s(from_k: f64) -> f64 {
    let r = circuit::wire_ohm(1.0, params::WIRE_REFERENCE_K, 0.0);
    let p = circuit::channel(true, true, r, params::SPRING_SUPPLY_V, Default::default()).wire_w;
    sma::capacity_j_per_k() * (PREHEAT_TARGET_K - from_k) / p
}

/// The thesis's stepping (6.4.3): soak the column until its coldest layer holds 358 K, pre-warm
/// the springs with one timed full-current pulse at the end of the soak, then 4 × 6 s on with
/// 2 s off between. Returns the plant and the angle at the end of each of the 7 phases.
fn stepping(on: [bool; 3]) -> (Plant, [f64; 7]) {
    stepping_with(on, ModelOptions::default())
}

fn stepping_with(on: [bool; 3], options: ModelOptions) -> (Plant, [f64; 7]) {
    let config = PlantConfig {
        initial_k: AMBIENT_K,
        ..PlantConfig::default()
    };
    let mut plant = Plant::with_options(&config, options).expect("valid config");
    let mut hold = Hold::new(358.0);
    hold_for(&mut plant, &mut hold, [false; 3], 240.0);
    assert!(plant.observe().smp_coldest_k > 357.0);
    let spring = on.iter().position(|&s| s).expect("a spring");
    println!(
        "  after the 240 s soak at 358 K the springs are at {:.1} K (column heat path only)",
        plant.observe().springs_k[spring]
    );
    let pre = preheat_s(plant.observe().springs_k[spring]);
    hold_for(&mut plant, &mut hold, on, pre);
    let mut angles = [0.0; 7];
    for (k, angle) in angles.iter_mut().enumerate() {
        let (springs, secs) = if k % 2 == 0 {
            (on, 6.0)
        } else {
            ([false; 3], 2.0)
        };
        hold_for(&mut plant, &mut hold, springs, secs);
        *angle = plant.observe().bend_deg;
    }
    (plant, angles)
}

fn print_steps(name: &str, angles: &[f64; 7], thesis: f64) {
    let s: Vec<String> = angles.iter().map(|a| format!("{a:.1}")).collect();
    let drops: Vec<String> = [1, 3, 5]
        .iter()
        .map(|&k| format!("{:+.1}", angles[k] - angles[k - 1]))
        .collect();
    println!(
        "{name}: angle at the end of on/off/on/off/on/off/on = [{}]° (thesis ends ≈{thesis}°); \
         change in each 2 s pulse [{}]° (thesis −2…−4°)",
        s.join(", "),
        drops.join(", ")
    );
}

#[test]
fn one_spring_steps_to_about_42_degrees_in_30_s() {
    let (plant, angles) = stepping([true, false, false]);
    print_steps("one spring, 4 × 6 s + 3 × 2 s", &angles, 42.0);
    let o = plant.observe();
    println!(
        "  after 30 s: spring A {:.1} K, austenite {:.2}, {:.1} N, plane {:.1}°; preheat {:.1} s",
        o.springs_k[0],
        o.austenite[0],
        o.spring_force_n[0],
        o.bend_plane_deg,
        preheat_s(AMBIENT_K)
    );
    assert!((38.0..=46.0).contains(&angles[6]), "{angles:?}");
    assert!(o.bend_plane_deg.abs() < 0.5);
    // Every 6 s step bends further.
    for k in [2, 4, 6] {
        assert!(angles[k] > angles[k - 1] + 1.0, "{angles:?}");
    }
    assert!(angles[0] > 0.5, "{angles:?}");
}

#[test]
fn two_springs_step_to_about_65_degrees_on_the_same_timing() {
    let (plant, angles) = stepping([true, true, false]);
    print_steps("two springs, 4 × 6 s + 3 × 2 s", &angles, 65.0);
    let o = plant.observe();
    println!(
        "  after 30 s: springs {:.1}/{:.1} K, austenite {:.2}/{:.2}, plane {:.1}°",
        o.springs_k[0], o.springs_k[1], o.austenite[0], o.austenite[1], o.bend_plane_deg
    );
    assert!((61.0..=69.0).contains(&angles[6]), "{angles:?}");
    assert!((o.bend_plane_deg - 60.0).abs() < 0.5);
    for k in [2, 4, 6] {
        assert!(angles[k] > angles[k - 1] + 1.0, "{angles:?}");
    }
    // The pulses: no pulse adds more than a degree, none loses more than the thesis's 4°.
    for k in [1, 3, 5] {
        let change = angles[k] - angles[k - 1];
        assert!((-4.0..=1.0).contains(&change), "{angles:?}");
    }
}

/// Stepping with two springs, then forming and a back-to-back recovery, with every figure.
#[test]
fn formed_shape_locks_and_recovers_on_reheating() {
    let (mut plant, angles) = stepping([true, true, false]);
    let bent = angles[6];
    let off = plant.time_s();
    // Forming: springs off, fan full until the SMP outer surface is at 323 K.
    let fan = Inputs {
        fan_duty: 1.0,
        ..Inputs::default()
    };
    let mut at20 = None;
    while plant.observe().smp_outer_k > 323.0 {
        plant.step(&fan, DT_S);
        if at20.is_none() && plant.time_s() - off >= 20.0 - 1e-9 {
            at20 = Some(plant.observe().bend_deg);
        }
    }
    let at20 = at20.expect("forming lasts over 20 s");
    let formed = plant.observe().bend_deg;
    let forming_s = plant.time_s() - off;
    // Standby: hold the heater surface at 323 K until both springs are martensite again, then
    // 60 s more.
    let mut hold = Hold::heater(323.0);
    while plant.observe().austenite.iter().any(|&a| a > 0.0) && plant.time_s() - off < 3000.0 {
        hold_for(&mut plant, &mut hold, [false; 3], 1.0);
    }
    let cold_after_s = plant.time_s() - off;
    hold_for(&mut plant, &mut hold, [false; 3], 60.0);
    let o = plant.observe();
    let kept = o.bend_deg;
    println!(
        "forming ({forming_s:.0} s to 323 K): bent {bent:.1}°, after 20 s {at20:.1}° (lost {:.1}°, \
         thesis ≈5°), at 323 K {formed:.1}°",
        bent - at20
    );
    println!(
        "springs martensite again {cold_after_s:.0} s after switching off (still air); 60 s later \
         kept {kept:.1}° (stored {:.1}°, film set {:.1}°, passive spring C {:.1} N, k_b {:.0})",
        o.stored_bend_deg, o.film_set_deg, o.spring_force_n[2], o.k_b_nmm_per_rad
    );
    assert!((1.0..=9.0).contains(&(bent - at20)), "{bent} {at20}");
    assert!(kept > 0.5 * bent, "{kept} {bent}");
    // Recovery: reheat at full duty until the heater surface is at 358 K, then hold it.
    let t0 = plant.time_s();
    let heat = Inputs {
        heater_duty: 1.0,
        ..Inputs::default()
    };
    let mut trace = vec![(0.0, kept)];
    while plant.observe().heater_k < 358.0 {
        plant.step(&heat, DT_S);
        trace.push((plant.time_s() - t0, plant.observe().bend_deg));
    }
    let reheat_s = plant.time_s() - t0;
    let mut hold = Hold::new(358.0);
    while plant.time_s() - t0 < 200.0 {
        hold_for(&mut plant, &mut hold, [false; 3], DT_S);
        trace.push((plant.time_s() - t0, plant.observe().bend_deg));
    }
    let at = |t: f64| trace.iter().find(|s| s.0 >= t).expect("sampled").1;
    let within_2 = trace
        .iter()
        .find(|s| s.1 <= 2.0)
        .map(|s| s.0)
        .expect("recovers to within 2°");
    println!(
        "recovery from {kept:.1}° (reheat {reheat_s:.1} s): 5 s {:.1}°, 20 s {:.1}°, 30 s {:.1}°, \
         40 s {:.1}°; within 2° of straight at {within_2:.0} s (thesis ≈40 s, the sharp fall 5–20 s)",
        at(5.0),
        at(20.0),
        at(30.0),
        at(40.0)
    );
    // Fig. 6.10(d): the wall's stiffness falls "sharply from 5 to 20 seconds": the first 5 s
    // release less than a tenth of what the next 15 s do.
    assert!(kept - at(5.0) < 0.1 * (at(5.0) - at(20.0)), "{trace:?}");
    assert!((20.0..=80.0).contains(&within_2), "{within_2}");
    assert!(plant.observe().bend_deg < 2.0);
}

#[test]
fn a_shared_15_a_supply_cannot_step_two_springs_in_30_s() {
    let options = ModelOptions {
        shared_spring_supply: true,
        ..ModelOptions::default()
    };
    let (_, shared) = stepping_with([true, true, false], options);
    let (_, own) = stepping([true, true, false]);
    println!(
        "two springs, shared 15 A supply: {:.1}° after 30 s (own channels {:.1}°, thesis ≈65°)",
        shared[6], own[6]
    );
    assert!(shared[6] < 0.5 * own[6], "{shared:?}");
}

/// The observer's spring model (`thermorph::observer::SpringState`, the firmware's own
/// parameters) against the plant: a lone spring driven from room temperature reaches
/// austenite about when the plant's does, and after a stepping's worth of heating the
/// estimate calls it martensite (`spring_rest_pct`) no earlier than the plant's is.
#[test]
fn observer_spring_model_tracks_the_plant() {
    use thermorph::observer::{ObserverParams, SpringState};
    let p = ObserverParams::DEFAULT.springs;
    let rest = thermorph::settings::Settings::DEFAULT.spring_rest;
    let ambient = AMBIENT_K as f32;
    let config = PlantConfig {
        initial_k: AMBIENT_K,
        ..PlantConfig::default()
    };
    // A lone spring on a straight, cold column (no load beyond its own).
    let mut plant = Plant::new(&config).expect("valid config");
    let on = Inputs {
        springs_on: [true, false, false],
        ..Inputs::default()
    };
    let mut est = SpringState::at(&p, ambient, 0.0);
    let (mut t, mut est_s) = (0.0, None);
    while plant.observe().austenite[0] < 0.95 && t < 120.0 {
        plant.step(&on, DT_S);
        est.predict(&p, true, ambient, ambient, DT_S as f32);
        t += DT_S;
        if est_s.is_none() && est.austenite >= 0.95 {
            est_s = Some(t);
        }
    }
    let o = plant.observe();
    let est_s = est_s.unwrap_or(f64::INFINITY);
    println!(
        "spring A from {AMBIENT_K} K at 15 A: 95 % austenite after {t:.1} s at {:.1} K ({:.1} N); \
         the estimate after {est_s:.1} s at {:.1} K",
        o.springs_k[0], o.spring_force_n[0], est.temp_k
    );
    assert!((est_s - t).abs() <= 0.25 * t, "{t} {est_s}");
    // A stepping's heating (7 s pre-warm, 1 s off, 4 × 6 s with 2 s between), then still air.
    let mut plant = Plant::new(&config).expect("valid config");
    let mut est = SpringState::at(&p, ambient, 0.0);
    let schedule = [
        (true, 7.0),
        (false, 1.0),
        (true, 6.0),
        (false, 2.0),
        (true, 6.0),
        (false, 2.0),
        (true, 6.0),
        (false, 2.0),
        (true, 6.0),
    ];
    let mut peak = (0.0f64, 0.0f32);
    for (springs_on, secs) in schedule {
        let inputs = Inputs {
            springs_on: [springs_on, false, false],
            ..Inputs::default()
        };
        let n = (secs / DT_S).round() as usize;
        for _ in 0..n {
            plant.step(&inputs, DT_S);
            est.predict(&p, springs_on, ambient, ambient, DT_S as f32);
            peak = (
                peak.0.max(plant.observe().springs_k[0]),
                peak.1.max(est.temp_k),
            );
        }
    }
    let (mut t, mut martensite_s, mut rested_s) = (0.0, None, None);
    while (martensite_s.is_none() || rested_s.is_none()) && t < 3000.0 {
        plant.step(&Inputs::default(), DT_S);
        est.predict(&p, false, ambient, ambient, DT_S as f32);
        t += DT_S;
        if martensite_s.is_none() && plant.observe().austenite[0] < rest as f64 {
            martensite_s = Some(t);
        }
        if rested_s.is_none() && est.austenite <= rest {
            rested_s = Some(t);
        }
    }
    let (m, r) = (martensite_s.expect("cools"), rested_s.expect("rests"));
    println!(
        "after a stepping (peak {:.1} K, estimate {:.1} K): martensite again (austenite ≤ {:.0} %) \
         {m:.0} s after switching off, the estimate at {r:.0} s",
        peak.0,
        peak.1,
        100.0 * rest
    );
    // The wire's temperature coefficient raises the plant's power ≈ 2 % at the band, which
    // the model leaves out (`SpringState::model_power_w`): ≈ 0.5 K of this.
    assert!((f64::from(peak.1) - peak.0).abs() < 5.5, "{peak:?}");
    assert!(r >= 0.8 * m && r <= 1.6 * m, "{m} {r}");
}
