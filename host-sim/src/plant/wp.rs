//! The work-precision table: every integrator × step × fidelity level on the 110 s reference
//! scene (heat, bend with two springs, cool, recover), its error in the region temperatures
//! (heater, SMP outer) and the bending angle against a fine-step full-fidelity reference, and its
//! wall time. `host-sim plant-wp` writes it to `docs/plant-work-precision.md`.

use std::fmt::Write as _;
use std::time::Instant;

use anyhow::Context as _;

use super::{
    Fidelity, Inputs, Integrator, Plant, PlantConfig, PlantError, SmaFidelity, SmpFidelity,
    ThermalFidelity,
};

/// Length of the reference scene, s.
pub const SCENE_S: f64 = 110.0;
/// Sampling (and control) period of the scene, s.
pub const SAMPLE_S: f64 = 0.5;
/// Internal step of the reference solution, s.
pub const REFERENCE_STEP_S: f64 = 0.002;

/// The reference scene's inputs at `t_s`: heat from a soaked 345 K (0–20 s), hold the heater
/// and bend with springs A and B (20–70 s), cool with the fan (70–95 s), reheat with cold
/// springs to recover (95–110 s).
pub fn scene_inputs(t_s: f64) -> Inputs {
    let (heater, fan, springs) = if t_s < 20.0 {
        (1.0, 0.0, false)
    } else if t_s < 70.0 {
        (0.45, 0.0, true)
    } else if t_s < 95.0 {
        (0.0, 1.0, false)
    } else {
        (1.0, 0.0, false)
    };
    Inputs {
        heater_duty: heater,
        fan_duty: fan,
        springs_on: [springs, springs, false],
        ..Inputs::default()
    }
}

/// Initial temperature of the reference scene (springs just below As), K.
pub const SCENE_INITIAL_K: f64 = 338.0;

/// Run the reference scene, returning (heater, SMP outer, bend) at every sample.
pub fn run_scene(config: &PlantConfig) -> Result<Vec<[f64; 3]>, PlantError> {
    let mut plant = Plant::new(config)?;
    let n = (SCENE_S / SAMPLE_S).round() as usize;
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        let inputs = scene_inputs(k as f64 * SAMPLE_S);
        plant.step(&inputs, SAMPLE_S);
        let o = plant.observe();
        out.push([o.heater_k, o.smp_outer_k, o.bend_deg]);
    }
    Ok(out)
}

/// The scene's configuration for an integrator, step and fidelity.
pub fn scene_config(integrator: Integrator, step_s: f64, fidelity: Fidelity) -> PlantConfig {
    PlantConfig {
        initial_k: SCENE_INITIAL_K,
        fidelity,
        integrator,
        max_step_s: step_s,
        ..PlantConfig::default()
    }
}

/// One row of the table.
#[derive(Clone, Debug)]
pub struct Row {
    /// Integrator.
    pub integrator: Integrator,
    /// Internal step, s.
    pub step_s: f64,
    /// Fidelity level's name.
    pub level: &'static str,
    /// Largest heater-surface error, K.
    pub heater_err_k: f64,
    /// Largest SMP outer error, K.
    pub outer_err_k: f64,
    /// Largest bending-angle error, degrees.
    pub bend_err_deg: f64,
    /// Wall time of one run, µs.
    pub wall_us: f64,
    /// On the (wall time, temperature error, bend error) Pareto front.
    pub on_front: bool,
}

/// The fidelity levels of the table.
pub fn levels() -> [(&'static str, Fidelity); 5] {
    let full = Fidelity::default();
    [
        ("full", full),
        (
            "lumped",
            Fidelity {
                thermal: ThermalFidelity::Lumped,
                ..full
            },
        ),
        (
            "sma-switch",
            Fidelity {
                sma: SmaFidelity::Switch,
                ..full
            },
        ),
        (
            "smp-elastic",
            Fidelity {
                smp: SmpFidelity::Elastic,
                ..full
            },
        ),
        (
            "no-mechanics",
            Fidelity {
                mechanics: false,
                ..full
            },
        ),
    ]
}

/// Steps of the table, s.
pub const STEPS_S: [f64; 4] = [0.05, 0.1, 0.25, 0.5];

/// Compute the table (`repeats` timed runs per row, the fastest kept).
pub fn table(repeats: usize) -> Result<Vec<Row>, PlantError> {
    let reference = run_scene(&scene_config(
        Integrator::ExponentialZoh,
        REFERENCE_STEP_S,
        Fidelity::default(),
    ))?;
    let mut rows = vec![];
    for (level, fidelity) in levels() {
        for integrator in [
            Integrator::ExponentialZoh,
            Integrator::TrBdf2,
            Integrator::BackwardEuler,
        ] {
            for step_s in STEPS_S {
                let config = scene_config(integrator, step_s, fidelity);
                let mut wall_us = f64::INFINITY;
                let mut trace = vec![];
                for _ in 0..repeats.max(1) {
                    let t0 = Instant::now();
                    trace = run_scene(&config)?;
                    wall_us = wall_us.min(t0.elapsed().as_secs_f64() * 1e6);
                }
                let err = |i: usize| {
                    trace
                        .iter()
                        .zip(&reference)
                        .map(|(a, b)| (a[i] - b[i]).abs())
                        .fold(0.0, f64::max)
                };
                rows.push(Row {
                    integrator,
                    step_s,
                    level,
                    heater_err_k: err(0),
                    outer_err_k: err(1),
                    bend_err_deg: err(2),
                    wall_us,
                    on_front: false,
                });
            }
        }
    }
    let key = |r: &Row| [r.wall_us, r.heater_err_k.max(r.outer_err_k), r.bend_err_deg];
    for i in 0..rows.len() {
        let a = key(&rows[i]);
        rows[i].on_front = !rows.iter().any(|r| {
            let b = key(r);
            b.iter().zip(&a).all(|(x, y)| x <= y) && b.iter().zip(&a).any(|(x, y)| x < y)
        });
    }
    Ok(rows)
}

fn name(i: Integrator) -> &'static str {
    match i {
        Integrator::ExponentialZoh => "zoh",
        Integrator::TrBdf2 => "tr-bdf2",
        Integrator::BackwardEuler => "backward-euler",
    }
}

/// The table as the Markdown page `docs/plant-work-precision.md`.
pub fn markdown(rows: &[Row]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Plant work-precision table\n");
    let _ = writeln!(
        s,
        "Generated by `host-sim plant-wp` (release build). Scene: {SCENE_S} s from a soaked \
         {SCENE_INITIAL_K} K block — heater full 0–20 s, heater 45 % with springs A and B 20–70 s, \
         fan full 70–95 s, heater full 95–110 s — observed every {SAMPLE_S} s. Error: largest \
         deviation over the samples from the full-fidelity exact-ZOH run at {REFERENCE_STEP_S} s \
         (so lower fidelity levels also show their model error). Wall time: fastest of the \
         repeated runs, this machine. Front: not dominated in (wall time, max region-temperature \
         error, bend error).\n"
    );
    let _ = writeln!(
        s,
        "| level | integrator | step s | heater err K | outer err K | bend err ° | wall µs | front |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|");
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.2e} | {:.2e} | {:.2e} | {:.0} | {} |",
            r.level,
            name(r.integrator),
            r.step_s,
            r.heater_err_k,
            r.outer_err_k,
            r.bend_err_deg,
            r.wall_us,
            if r.on_front { "yes" } else { "" }
        );
    }
    let default = rows.iter().find(|r| {
        r.level == "full"
            && r.integrator == Integrator::default()
            && r.step_s == super::params::DEFAULT_MAX_STEP_S
    });
    if let Some(d) = default {
        let _ = writeln!(
            s,
            "\nDefault (full, zoh, {} s): {} the front.",
            d.step_s,
            if d.on_front { "on" } else { "NOT on" }
        );
    }
    s
}

/// Compute the table and write it to `out`.
pub fn run(out: &std::path::Path, repeats: usize) -> anyhow::Result<()> {
    let rows = table(repeats)?;
    let md = markdown(&rows);
    if let Some(dir) = out.parent() {
        if !dir.as_os_str().is_empty() {
            std::fs::create_dir_all(dir).with_context(|| dir.display().to_string())?;
        }
    }
    std::fs::write(out, &md).with_context(|| out.display().to_string())?;
    print!("{md}");
    Ok(())
}
