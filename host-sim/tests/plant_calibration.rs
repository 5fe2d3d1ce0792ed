//! Open-loop calibration of the plant against the thesis's figures (6.4.1–6.4.3): heat-up,
//! forming and reheating times, bending angles with one and two springs, the stiffness contrast
//! and the recovery. `cargo test -p host-sim --test plant_calibration -- --nocapture` prints the
//! measured figures (they are quoted in docs/PLANT-API.md).

use host_sim::plant::{Inputs, Observation, Plant, PlantConfig};

const DT_S: f64 = 0.1;

fn plant_at(initial_k: f64) -> Plant {
    Plant::new(&PlantConfig {
        initial_k,
        ..PlantConfig::default()
    })
    .expect("valid config")
}

/// Run until `done` holds (linear interpolation of the crossing time on `value`), at most
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

/// A PI controller on the SMP outer surface (region 2), as the firmware's would be.
struct Hold {
    target_k: f64,
    integral: f64,
}

impl Hold {
    fn new(target_k: f64) -> Self {
        Hold {
            target_k,
            integral: 0.3,
        }
    }
    fn duty(&mut self, obs: &Observation) -> f64 {
        let e = self.target_k - obs.smp_outer_k;
        self.integral = (self.integral + 0.002 * e * DT_S).clamp(0.0, 1.0);
        (0.15 * e + self.integral).clamp(0.0, 1.0)
    }
}

/// Run `secs` holding the SMP at `hold` with springs `on` and fan `fan`.
fn hold_for(plant: &mut Plant, hold: &mut Hold, on: [bool; 3], fan: f64, secs: f64) {
    let t0 = plant.time_s();
    while plant.time_s() - t0 < secs {
        let d = hold.duty(&plant.observe());
        let inputs = Inputs {
            heater_duty: d,
            fan_duty: fan,
            springs_on: on,
            ..Inputs::default()
        };
        plant.step(&inputs, DT_S);
    }
}

/// Bend at 358 K with springs `on` until the active springs are fully austenite and the column
/// has settled. Returns the plant and (loading, bend) samples, where loading is the thesis's
/// (6.4.1): the active springs' contraction relative to their contraction at full loading.
fn bend_at_358(on: [bool; 3]) -> (Plant, Vec<(f64, f64)>) {
    // Springs cold: heat the column from room temperature and soak it at 358 K.
    let mut plant = plant_at(298.15);
    let mut hold = Hold::new(358.0);
    hold_for(&mut plant, &mut hold, [false; 3], 0.0, 300.0);
    let active: Vec<usize> = (0..3).filter(|&i| on[i]).collect();
    let contraction = |plant: &Plant| {
        let l = plant.spring_lengths_mm();
        active.iter().map(|&i| 200.0 - l[i]).sum::<f64>() / active.len() as f64
    };
    let mut raw = vec![];
    let t0 = plant.time_s();
    let mut full_at = None;
    loop {
        raw.push((contraction(&plant), plant.observe().bend_deg));
        let obs = plant.observe();
        if full_at.is_none() && active.iter().all(|&i| obs.austenite[i] >= 1.0) {
            full_at = Some(plant.time_s());
        }
        if full_at.is_some_and(|t| plant.time_s() - t > 30.0) || plant.time_s() - t0 > 900.0 {
            break;
        }
        hold_for(&mut plant, &mut hold, on, 0.0, DT_S);
    }
    let full = raw.last().expect("samples").0;
    let samples = raw.iter().map(|&(c, b)| (c / full, b)).collect();
    (plant, samples)
}

fn bend_at_loading(samples: &[(f64, f64)], loading: f64) -> f64 {
    samples
        .iter()
        .find(|(l, _)| *l >= loading)
        .map(|s| s.1)
        .expect("loading reached")
}

#[test]
fn heater_full_on_reaches_323_k_in_about_10_s() {
    let mut plant = plant_at(298.15);
    let full = Inputs {
        heater_duty: 1.0,
        ..Inputs::default()
    };
    let t = time_until(&mut plant, &full, |o| o.heater_k, 323.0, 60.0).expect("reaches 323 K");
    println!(
        "heater 298 → 323 K: {t:.1} s (thesis ≈10 s); power {:.1} W",
        plant.observe().heater_power_w
    );
    assert!((8.5..=11.5).contains(&t), "{t}");
}

/// Forming from a soaked 358 K wall, then reheating: (forming time, reheat time, plant).
fn form_and_reheat() -> (f64, f64, f64, f64) {
    let mut plant = plant_at(358.0);
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

#[test]
fn forming_takes_about_50_s_and_reheating_about_25_s() {
    let (forming, reheat, _, _) = form_and_reheat();
    println!("forming 358 → 323 K (fan full, soaked wall): {forming:.1} s (thesis ≈50 s)");
    println!("reheating 323 → 358 K (heater full): {reheat:.1} s (thesis ≈25 s)");
    assert!((45.0..=55.0).contains(&forming), "{forming}");
    assert!((22.0..=28.0).contains(&reheat), "{reheat}");
}

#[test]
fn stiffness_rises_about_4_5_times_to_1400_on_forming() {
    let (_, _, k_hot, k_cold) = form_and_reheat();
    let ratio = k_cold / k_hot;
    println!("k_b 358 K {k_hot:.0} → 323 K {k_cold:.0} N·mm/rad (×{ratio:.2}; thesis 1400, ×4.5)");
    assert!((1190.0..=1610.0).contains(&k_cold), "{k_cold}");
    assert!((4.5 * 0.85..=4.5 * 1.15).contains(&ratio), "{ratio}");
}

#[test]
fn one_spring_bends_about_42_degrees() {
    let (plant, samples) = bend_at_358([true, false, false]);
    let full = samples.last().expect("samples").1;
    println!(
        "one spring, full loading: {full:.1}° (thesis ≈42°), plane {:.1}°, after {:.0} s",
        plant.observe().bend_plane_deg,
        plant.time_s() - 300.0
    );
    assert!((38.0..=46.0).contains(&full), "{full}");
    assert!(plant.observe().bend_plane_deg.abs() < 0.5);
}

#[test]
fn two_springs_bend_about_65_degrees_slowing_above_70_percent() {
    let (plant, samples) = bend_at_358([true, true, false]);
    let full = samples.last().expect("samples").1;
    let at70 = bend_at_loading(&samples, 0.7);
    let slope_low = at70 / 0.7;
    let slope_high = (full - at70) / 0.3;
    println!(
        "two springs, full loading: {full:.1}° (thesis ≈65°), at 70 %: {at70:.1}°, \
         slope 0–70 % {slope_low:.1} °/loading, 70–100 % {slope_high:.1}; plane {:.1}°",
        plant.observe().bend_plane_deg
    );
    assert!((61.0..=69.0).contains(&full), "{full}");
    assert!(slope_high < 0.9 * slope_low, "{slope_low} {slope_high}");
    assert!((plant.observe().bend_plane_deg - 60.0).abs() < 0.5);
}

#[test]
fn reheated_with_cold_springs_the_column_recovers_slowly_at_first() {
    let (mut plant, _) = bend_at_358([true, true, false]);
    let bent = plant.observe().bend_deg;
    // Forming: springs off, fan full until the outer surface is at 323 K.
    let fan = Inputs {
        fan_duty: 1.0,
        ..Inputs::default()
    };
    time_until(&mut plant, &fan, |o| o.smp_outer_k, 323.0, 300.0).expect("forms");
    let formed = plant.observe().bend_deg;
    // Hold at 323 K until the springs are cold (martensite).
    let mut hold = Hold::new(323.0);
    while plant.observe().austenite.iter().any(|&a| a > 0.0) && plant.time_s() < 3000.0 {
        hold_for(&mut plant, &mut hold, [false; 3], 0.0, 1.0);
    }
    let locked = plant.observe().bend_deg;
    assert!(plant.observe().austenite.iter().all(|&a| a == 0.0));
    // Reheat to 358 K (heater full until the heater surface is there, then hold).
    let t0 = plant.time_s();
    let heat = Inputs {
        heater_duty: 1.0,
        ..Inputs::default()
    };
    let mut trace = vec![(0.0, locked)];
    while plant.observe().heater_k < 358.0 {
        plant.step(&heat, DT_S);
        trace.push((plant.time_s() - t0, plant.observe().bend_deg));
    }
    let mut hold = Hold::new(358.0);
    while plant.time_s() - t0 < 200.0 {
        hold_for(&mut plant, &mut hold, [false; 3], 0.0, DT_S);
        trace.push((plant.time_s() - t0, plant.observe().bend_deg));
    }
    let at = |t: f64| trace.iter().find(|s| s.0 >= t).expect("sampled").1;
    let within_2 = trace
        .iter()
        .find(|s| s.1 <= 2.0)
        .map(|s| s.0)
        .expect("recovers within 2°");
    println!(
        "recovery: bent {bent:.1}°, formed {formed:.1}°, locked (springs cold) {locked:.1}°; \
         after reheat 10 s {:.1}°, 20 s {:.1}°, 30 s {:.1}°, 40 s {:.1}°; within 2° at {within_2:.0} s",
        at(10.0),
        at(20.0),
        at(30.0),
        at(40.0)
    );
    // Locked: the shape holds a substantial part of the bend.
    assert!(locked > 0.5 * bent, "{locked} {bent}");
    // Slowly at first: the first 10 s release less than the next 10 s.
    assert!(locked - at(10.0) < at(10.0) - at(20.0), "{trace:?}");
    assert!(within_2 <= 70.0, "{within_2}");
    assert!(plant.observe().bend_deg < 2.0);
}
