//! Numerics of the plant: the integrators against analytic solutions, stability over step
//! size and ambient, energy conservation, bounds of the internal fractions, a simulated day,
//! config validation and the fidelity levels.

use host_sim::plant::linalg::N;
use host_sim::plant::thermal::{self, Network, System};
use host_sim::plant::{
    Fidelity, Inputs, Integrator, ModelOptions, Plant, PlantConfig, SmaFidelity, SmpFidelity,
    ThermalFidelity,
};

const INTEGRATORS: [Integrator; 3] = [
    Integrator::ExponentialZoh,
    Integrator::BackwardEuler,
    Integrator::TrBdf2,
];

fn lumped(integrator: Integrator, max_step_s: f64) -> Plant {
    Plant::new(&PlantConfig {
        fidelity: Fidelity {
            thermal: ThermalFidelity::Lumped,
            ..Fidelity::default()
        },
        integrator,
        max_step_s,
        ..PlantConfig::default()
    })
    .expect("valid")
}

/// Largest error of the lumped node's heater step response against
/// T(t) = Ta + (P/G)(1 − e^{−G·t/C}) over 600 s.
fn rc_error(integrator: Integrator, h: f64) -> f64 {
    let mut plant = lumped(integrator, h);
    let net = Network::new(ThermalFidelity::Lumped, 0.0, false, false);
    let (c, g) = (net.c_j_per_k[0], net.g_amb_w_per_k[0]);
    let heat = Inputs {
        heater_duty: 1.0,
        ..Inputs::default()
    };
    plant.step(&heat, 1e-9);
    let p_w = plant.observe().heater_power_w;
    let mut worst: f64 = 0.0;
    for _ in 0..120 {
        plant.step(&heat, 5.0);
        let t = plant.time_s();
        let exact = 298.15 + p_w / g * (1.0 - (-g * t / c).exp());
        worst = worst.max((plant.observe().heater_k - exact).abs());
    }
    worst
}

#[test]
fn one_rc_node_step_response_matches_the_exponential() {
    assert!(rc_error(Integrator::ExponentialZoh, 0.5) < 1e-6);
    // First order: halving the step halves the error.
    let be1 = rc_error(Integrator::BackwardEuler, 0.5);
    let be2 = rc_error(Integrator::BackwardEuler, 0.25);
    assert!(be1 < 0.2 && (be1 / be2 - 2.0).abs() < 0.2, "{be1} {be2}");
    // Second order: halving the step quarters it.
    let tr1 = rc_error(Integrator::TrBdf2, 0.5);
    let tr2 = rc_error(Integrator::TrBdf2, 0.25);
    assert!(tr1 < 1e-3 && (tr1 / tr2 - 4.0).abs() < 0.5, "{tr1} {tr2}");
}

#[test]
fn two_node_exchange_relaxes_to_the_weighted_mean() {
    // Two nodes (C1 = 2, C2 = 8 J/K, G = 4 W/K), no ambient: the difference decays at
    // G(1/C1 + 1/C2) = 2.5 /s and the capacity-weighted mean is kept.
    let (c1, c2, g) = (2.0, 8.0, 4.0);
    let mut a = [[0.0; N]; N];
    a[0][0] = -g / c1;
    a[0][1] = g / c1;
    a[1][0] = g / c2;
    a[1][1] = -g / c2;
    let u = [0.0; N];
    let rate = g * (1.0 / c1 + 1.0 / c2);
    for integrator in INTEGRATORS {
        let h = 0.05;
        let mut x = [400.0, 300.0, 0.0, 0.0, 0.0];
        let mut cache = None;
        let sys = System {
            a: &a,
            n: 2,
            u: &u,
            key: 1,
        };
        for k in 1..=40 {
            thermal::advance(integrator, &sys, &mut x, h, &mut cache);
            let t = k as f64 * h;
            let mean = (c1 * 400.0 + c2 * 300.0) / (c1 + c2);
            let diff = 100.0 * (-rate * t).exp();
            let tol = match integrator {
                Integrator::ExponentialZoh => 1e-9,
                Integrator::TrBdf2 => 0.05,
                Integrator::BackwardEuler => 2.5,
            };
            assert!(((c1 * x[0] + c2 * x[1]) / (c1 + c2) - mean).abs() < 1e-9);
            assert!(
                ((x[0] - x[1]) - diff).abs() < tol,
                "{integrator:?} t {t}: {x:?}"
            );
        }
    }
}

/// A scene exercising every input: heat, bend with two springs, cool, recover.
fn program(t_s: f64) -> Inputs {
    let phase = t_s % 1200.0;
    Inputs {
        heater_duty: if phase < 400.0 || (700.0..900.0).contains(&phase) {
            0.6
        } else {
            0.0
        },
        fan_duty: if (400.0..700.0).contains(&phase) {
            1.0
        } else {
            0.0
        },
        // 30 s of full current (the thesis's stepping): a spring left on at 15 A in still air
        // would run past 800 K.
        springs_on: [
            (150.0..180.0).contains(&phase),
            (150.0..180.0).contains(&phase),
            false,
        ],
        ..Inputs::default()
    }
}

#[test]
fn every_step_up_to_the_control_period_is_stable_and_bounded() {
    for integrator in INTEGRATORS {
        for h in [0.01, 0.1, 0.25, 0.5] {
            for ambient_k in [263.15, 298.15, 318.15, 323.15] {
                let mut plant = Plant::new(&PlantConfig {
                    ambient_k,
                    initial_k: ambient_k,
                    integrator,
                    max_step_s: h,
                    ..PlantConfig::default()
                })
                .expect("valid");
                let mut prev_heater = ambient_k;
                while plant.time_s() < 1200.0 {
                    let inputs = program(plant.time_s());
                    plant.step(&inputs, 0.5);
                    let o = plant.observe();
                    let temps = [
                        o.heater_k,
                        o.smp_inner_k,
                        o.smp_outer_k,
                        o.duct_air_k,
                        o.springs_k[0],
                        o.springs_k[1],
                        o.springs_k[2],
                    ];
                    // TR-BDF2's trapezoidal stage is A- but not L-stable: at the fan's switch the
                    // duct air (a node of tiny capacity, the stiffest mode) rings below the
                    // ambient for one 0.5 s step (2.5 K at 263 K with the issue-19 refit's
                    // 30 W/(m²·K) duct). The exact default and backward Euler never undershoot.
                    let floor = if integrator == Integrator::TrBdf2 && h >= 0.5 {
                        ambient_k - 5.0
                    } else {
                        ambient_k - 1e-6
                    };
                    for t in temps {
                        assert!(
                            t.is_finite() && t > floor && t < 600.0,
                            "{integrator:?} h {h} {ambient_k} {o:?}"
                        );
                    }
                    for a in o.austenite {
                        assert!((0.0..=1.0).contains(&a));
                    }
                    assert!((0.0..=1.0).contains(&o.frozen_fraction));
                    assert!(o.bend_deg.is_finite() && o.bend_deg < 120.0);
                    // No ringing: with the heater on and the fan off, the heater only rises.
                    if inputs.heater_duty > 0.0 && inputs.fan_duty == 0.0 && o.time_s > 1.0 {
                        let phase = o.time_s % 1200.0;
                        if phase > 1.0 && phase < 400.0 {
                            assert!(o.heater_k >= prev_heater - 1e-9, "{integrator:?} {h}");
                        }
                    }
                    prev_heater = o.heater_k;
                }
            }
        }
    }
}

#[test]
fn an_adiabatic_run_conserves_energy() {
    for integrator in INTEGRATORS {
        for sma in [SmaFidelity::Hysteretic, SmaFidelity::Switch] {
            let config = PlantConfig {
                integrator,
                fidelity: Fidelity {
                    sma,
                    ..Fidelity::default()
                },
                ..PlantConfig::default()
            };
            let options = ModelOptions {
                adiabatic: true,
                pmma_plates: true,
                shared_spring_supply: false,
                ..ModelOptions::default()
            };
            let mut plant = Plant::with_options(&config, options).expect("valid");
            let e0 = plant.stored_energy_j();
            while plant.time_s() < 300.0 {
                let mut inputs = program(plant.time_s());
                inputs.springs_on = [true, plant.time_s() < 120.0, false];
                plant.step(&inputs, 0.5);
            }
            let gained = plant.stored_energy_j() - e0;
            let supplied = plant.electrical_energy_j();
            assert!(supplied > 1e4);
            assert!(
                (gained - supplied).abs() < 1e-9 * e0,
                "{integrator:?} {sma:?}: {gained} vs {supplied}"
            );
            // The springs went through the transformation (latent heat included).
            assert!(plant.observe().austenite[0] == 1.0);
        }
    }
}

/// Heat gained minus heat supplied plus the ambient loss (trapezoid-integrated at step `h`
/// over one cycle of `program` at 298 K), relative to the heat supplied.
fn closure_error_with_losses(h: f64) -> f64 {
    let mut plant = Plant::with_options(
        &PlantConfig::default(),
        ModelOptions {
            pmma_plates: true,
            ..ModelOptions::default()
        },
    )
    .expect("valid");
    let e0 = plant.stored_energy_j();
    let mut lost = 0.0;
    let steps = (1200.0 / h).round() as usize;
    for k in 0..steps {
        let inputs = program(k as f64 * h);
        let before = plant.ambient_loss_w(inputs.fan_duty);
        plant.step(&inputs, h);
        lost += 0.5 * h * (before + plant.ambient_loss_w(inputs.fan_duty));
    }
    let supplied = plant.electrical_energy_j();
    assert!(supplied > 1e4 && lost > 0.5 * supplied, "{supplied} {lost}");
    (plant.stored_energy_j() - e0 - supplied + lost) / supplied
}

#[test]
fn energy_closes_with_ambient_losses_over_a_cycle() {
    // Heating, two springs through their transformation, the fan, plates, losses to ambient:
    // stored + lost = supplied to 1e-6 once the loss integral is resolved, and the residual
    // is the trapezoid's (it falls 4× when the step halves), not a leak in the model.
    let coarse = closure_error_with_losses(0.005);
    let fine = closure_error_with_losses(0.0025);
    // Richardson: what is left once the trapezoid's h² term is removed is the model's own.
    let extrapolated = fine - (coarse - fine) / 3.0;
    println!(
        "energy closure with losses: {coarse:.2e} at 5 ms, {fine:.2e} at 2.5 ms, \
         {extrapolated:.1e} extrapolated"
    );
    assert!(fine.abs() < 1e-6, "{fine}");
    assert!(extrapolated.abs() < 1e-8, "{coarse} {fine} {extrapolated}");
}

#[test]
fn a_simulated_day_neither_drifts_nor_blows_up() {
    let mut plant = Plant::new(&PlantConfig::default()).expect("valid");
    let mut cycle_end = vec![];
    while plant.time_s() < 86_400.0 {
        let inputs = program(plant.time_s());
        plant.step(&inputs, 0.5);
        let o = plant.observe();
        assert!(o.heater_k.is_finite() && o.bend_deg.is_finite());
        if (plant.time_s() % 1200.0).abs() < 1e-6 {
            cycle_end.push(o);
        }
    }
    assert_eq!(cycle_end.len(), 72);
    // Periodic steady state: the last cycles end in the same state.
    let (a, b) = (cycle_end[70], cycle_end[71]);
    assert!((a.heater_k - b.heater_k).abs() < 1e-6);
    assert!((a.springs_k[0] - b.springs_k[0]).abs() < 1e-6);
    assert!(
        (a.bend_deg - b.bend_deg).abs() < 1e-6,
        "{} {}",
        a.bend_deg,
        b.bend_deg
    );
    assert!((plant.time_s() - 86_400.0).abs() < 1e-6);
}

#[test]
fn a_bad_config_names_its_field() {
    let bad = |c: PlantConfig| Plant::new(&c).err().expect("rejected").to_string();
    let d = PlantConfig::default();
    assert!(
        bad(PlantConfig {
            ambient_k: f64::NAN,
            ..d
        })
        .contains("ambient_k")
    );
    assert!(
        bad(PlantConfig {
            initial_k: -3.0,
            ..d
        })
        .contains("initial_k")
    );
    assert!(
        bad(PlantConfig {
            max_step_s: 0.0,
            ..d
        })
        .contains("max_step_s")
    );
    // Bad inputs are clamped or ignored, never a panic.
    let mut plant = Plant::new(&d).expect("valid");
    let weird = Inputs {
        heater_duty: f64::NAN,
        fan_duty: 7.0,
        ..Inputs::default()
    };
    plant.step(&weird, -1.0);
    plant.step(&weird, f64::INFINITY);
    plant.step(&weird, 1.0);
    let o = plant.observe();
    assert_eq!(o.heater_power_w, 0.0);
    assert!((o.time_s - 1.0).abs() < 1e-12);
}

#[test]
fn fidelity_levels_compute_only_what_they_need() {
    let run = |fidelity: Fidelity| {
        let mut plant = Plant::new(&PlantConfig {
            fidelity,
            ..PlantConfig::default()
        })
        .expect("valid");
        // Two springs pull while the heater warms the column, then the fan locks the shape
        // (to 550 s: the end of the fan phase, before the reheat releases it).
        while plant.time_s() < 550.0 {
            let inputs = program(plant.time_s() + 150.0);
            plant.step(&inputs, 0.5);
        }
        (plant.observe(), plant.stored_bend_deg())
    };
    let (full, stored_full) = run(Fidelity::default());
    assert!(
        full.bend_deg > 1.0 && stored_full > 1.0,
        "{} {stored_full}",
        full.bend_deg
    );
    let (still, _) = run(Fidelity {
        mechanics: false,
        ..Fidelity::default()
    });
    assert_eq!(still.bend_deg, 0.0);
    assert_eq!(
        still.k_b_nmm_per_rad,
        Plant::new(&PlantConfig::default())
            .expect("valid")
            .observe()
            .k_b_nmm_per_rad
    );
    let (_, stored_elastic) = run(Fidelity {
        smp: SmpFidelity::Elastic,
        ..Fidelity::default()
    });
    assert_eq!(stored_elastic, 0.0);
    let (lumped, _) = run(Fidelity {
        thermal: ThermalFidelity::Lumped,
        ..Fidelity::default()
    });
    assert_eq!(lumped.heater_k, lumped.smp_outer_k);
    let (switch, _) = run(Fidelity {
        sma: SmaFidelity::Switch,
        ..Fidelity::default()
    });
    assert!(switch.austenite.iter().all(|&a| a == 0.0 || a == 1.0));
}
