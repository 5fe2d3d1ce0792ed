//! `host-sim paper`: the thesis's experiments (SPEC section 8) run against the simulated block
//! with the camera on and the firmware's own supervisor, each figure beside the thesis's.
//!
//! This module owns the experiment scripts and the figure definitions of SPEC section 8. Two
//! runs at 298.15 K ambient, camera on: power-up in standby; at 120 s `mode step-large AB` (or
//! `A`); once the stepping holds, `mode form`; once forming has handed back to standby,
//! `mode recover` — modes entered back to back, as the console would be driven. Times come
//! from the supervisor's mode and phase in each scene period, temperatures from its Tc,
//! angles and k_b from the plant's truth.

use serde::Serialize;
use thermorph::supervisor::Supervisor;
use thermorph::supervisor::events::EventKind;

pub use crate::runs::cycle_figures::{CycleFigures, measure};
use crate::runs::run::{RunError, run_with};
use crate::runs::scenario;
use crate::runs::series::Row;

/// One figure: the thesis's value, the simulated one and whether it passes.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Figure {
    /// The thesis's (or SPEC's) value.
    pub thesis: serde_json::Value,
    /// The simulated value (`null` if the run never showed it).
    pub sim: serde_json::Value,
    /// Within tolerance.
    pub pass: bool,
    /// The tolerance, as printed.
    #[serde(skip)]
    pub tolerance: String,
    /// Why it failed, when it did and the reason is known.
    #[serde(skip)]
    pub note: String,
}

/// The figures, keyed as `host-sim paper --json` prints them, in SPEC order.
pub const KEYS: [&str; 13] = [
    "preheat_time_s",
    "standby_overshoot_k",
    "standby_hold_band_k",
    "large_stepping_time_s",
    "pulse_drop_deg",
    "full_loading_one_spring_deg",
    "full_loading_two_springs_deg",
    "forming_time_s",
    "forming_angle_loss_deg",
    "formed_k_b",
    "stiffness_ratio",
    "recovery_time_s",
    "cycle_time_s",
];

/// When the stepping command is sent, s (after the standby figures' window).
pub const STEP_AT_S: f64 = 120.0;

/// The experiments' scene: `duration_s` at `ambient_k`, the camera on or off, power-up in
/// standby (a closed-loop scene whose only line is `mode standby` at 0 s).
pub fn scene(
    duration_s: f64,
    ambient_k: f64,
    camera: bool,
) -> Result<scenario::Scenario, scenario::ScenarioError> {
    let text = format!(
        "name = \"paper\"\n\
         description = \"the thesis's experiments, real supervisor\"\n\
         duration = \"{duration_s} s\"\n\
         ambient = \"{ambient_k} K\"\n\
         initial = \"{ambient_k} K\"\n\
         period = \"0.25 s\"\n\
         [fidelity]\ncamera = {camera}\n\
         [camera]\nnoise = \"0.1 K\"\nseed = 1\n\
         [[command]]\nat = \"0 s\"\nline = \"mode standby\"\n"
    );
    scenario::parse(&text, "<paper>", "paper")
}

/// Run the full cycle with `springs` at 298.15 K, the camera on or off; returns the rows.
pub fn cycle(springs: &str, duration_s: f64, camera: bool) -> Result<Vec<Row>, RunError> {
    cycle_in(&scene(duration_s, 298.15, camera)?, springs)
}

/// Run the full cycle with `springs` in `sc` (from [`scene`]): power-up in standby,
/// `mode step-large SPRINGS` at [`STEP_AT_S`], `mode form` once the stepping holds, `mode
/// recover` once forming has handed back to standby. A mode that ends otherwise (a timeout, a
/// fault) ends the script there.
pub fn cycle_in(sc: &scenario::Scenario, springs: &str) -> Result<Vec<Row>, RunError> {
    let mut stage = 0;
    let mut react = |t: f64, s: &Supervisor| -> Option<String> {
        let (mode, phase) = (s.mode().name(), s.mode().phase_name());
        let line = match stage {
            0 if t >= STEP_AT_S => format!("mode step-large {springs}"),
            1 if mode == "step-large" && phase == "hold" => "mode form".into(),
            2 if mode == "standby"
                && s.events().iter().last().is_some_and(|e| {
                    matches!(
                        e.kind,
                        EventKind::Mode {
                            from: "form",
                            to: "standby"
                        }
                    )
                }) =>
            {
                "mode recover".into()
            }
            _ => return None,
        };
        stage += 1;
        Some(line)
    };
    Ok(run_with(sc, &mut |_| {}, &mut react)?.rows)
}

fn num(v: Option<f64>) -> serde_json::Value {
    v.filter(|x| x.is_finite())
        .map_or(serde_json::Value::Null, |x| {
            serde_json::json!((x * 1000.0).round() / 1000.0)
        })
}

fn within(v: Option<f64>, lo: f64, hi: f64) -> bool {
    v.is_some_and(|x| (lo..=hi).contains(&x))
}

/// Run both cycles (camera on, or off for a quick look with true temperatures) and build the
/// table (keys in [`KEYS`] order).
pub fn figures(
    camera: bool,
    out: Option<&std::path::Path>,
) -> Result<Vec<(&'static str, Figure)>, RunError> {
    let two_rows = cycle("AB", 700.0, camera)?;
    let one_rows = cycle("A", 400.0, camera)?;
    if let Some(dir) = out {
        std::fs::create_dir_all(dir).map_err(|err| RunError::Write {
            path: dir.to_path_buf(),
            err,
        })?;
        for (name, rows) in [
            ("two-springs.csv", &two_rows),
            ("one-spring.csv", &one_rows),
        ] {
            let path = dir.join(name);
            let mut buf = Vec::new();
            crate::runs::series::write_csv(rows, &mut buf).map_err(RunError::Csv)?;
            std::fs::write(&path, buf).map_err(|err| RunError::Write { path, err })?;
        }
    }
    let two = measure(&two_rows);
    let one = measure(&one_rows);
    let fig = |thesis: serde_json::Value, sim: Option<f64>, lo: f64, hi: f64, tol: &str| Figure {
        thesis,
        sim: num(sim),
        pass: within(sim, lo, hi),
        tolerance: tol.into(),
        note: String::new(),
    };
    let j = |x: f64| serde_json::json!(x);
    let drops = &two.pulse_drop_deg;
    let drops_ok = drops.len() == 3 && drops.iter().all(|d| (1.0..=5.0).contains(d));
    Ok(vec![
        (
            "preheat_time_s",
            fig(j(10.0), two.preheat_time_s, 7.0, 13.0, "±3 s"),
        ),
        (
            "standby_overshoot_k",
            fig(j(1.0), two.standby_overshoot_k, f64::MIN, 1.0, "< 1 K"),
        ),
        (
            "standby_hold_band_k",
            fig(j(0.5), two.standby_hold_band_k, 0.0, 0.5, "≤ 0.5 K"),
        ),
        (
            "large_stepping_time_s",
            fig(j(30.0), two.large_stepping_time_s, 29.5, 30.5, "±0.5 s"),
        ),
        (
            "pulse_drop_deg",
            Figure {
                thesis: serde_json::json!([2.0, 4.0]),
                sim: serde_json::json!(
                    drops
                        .iter()
                        .map(|d| (d * 1000.0).round() / 1000.0)
                        .collect::<Vec<_>>()
                ),
                pass: drops_ok,
                tolerance: "each 2–4° ±1°".into(),
                note: String::new(),
            },
        ),
        (
            "full_loading_one_spring_deg",
            fig(j(42.0), one.full_loading_deg, 38.0, 46.0, "±4°"),
        ),
        (
            "full_loading_two_springs_deg",
            fig(j(65.0), two.full_loading_deg, 61.0, 69.0, "±4°"),
        ),
        (
            "forming_time_s",
            fig(j(50.0), two.forming_time_s, 40.0, 60.0, "±10 s"),
        ),
        (
            "forming_angle_loss_deg",
            fig(j(5.0), two.forming_angle_loss_deg, 2.0, 8.0, "±3°"),
        ),
        (
            "formed_k_b",
            fig(j(1400.0), two.formed_k_b, 1190.0, 1610.0, "±15 %"),
        ),
        (
            "stiffness_ratio",
            fig(j(4.5), two.stiffness_ratio, 3.8, 5.2, "±0.7"),
        ),
        (
            "recovery_time_s",
            fig(j(40.0), two.recovery_time_s, 30.0, 50.0, "±10 s"),
        ),
        (
            "cycle_time_s",
            fig(j(120.0), two.cycle_time_s, 100.0, 140.0, "±20 s"),
        ),
    ])
}

/// `host-sim paper [--json] [--no-camera] [--out DIR]`: print the table (or the JSON object),
/// and with `--out` write both experiments' time series (`two-springs.csv`, `one-spring.csv`);
/// exit status 0 either way (the tests assert the passes).
pub fn cli(json: bool, camera: bool, out: Option<&std::path::Path>) -> anyhow::Result<()> {
    let table = figures(camera, out)?;
    if json {
        let map: serde_json::Map<String, serde_json::Value> = table
            .iter()
            .map(|(k, f)| {
                (
                    (*k).to_string(),
                    serde_json::to_value(f).unwrap_or_default(),
                )
            })
            .collect();
        println!("{}", serde_json::to_string_pretty(&map)?);
        return Ok(());
    }
    println!(
        "{:<30} {:>12} {:>22} {:>14}",
        "figure", "thesis", "simulated", "tolerance"
    );
    for (k, f) in &table {
        println!(
            "{:<30} {:>12} {:>22} {:>14} {}",
            k,
            f.thesis.to_string(),
            f.sim.to_string(),
            f.tolerance,
            if f.pass { "pass" } else { "FAIL" }
        );
    }
    Ok(())
}
