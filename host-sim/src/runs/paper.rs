//! `host-sim paper`: the thesis's experiments (SPEC section 8) run against the simulated block
//! with the camera on and the firmware's own supervisor, each figure beside the thesis's.
//!
//! This module owns the experiment scripts and the figure definitions of SPEC section 8. Two
//! runs at 298.15 K ambient, camera on: power-up in standby; at 120 s `mode step-large AB` (or
//! `A`); once the stepping holds, `mode form`; once forming has handed back to standby,
//! `mode recover` — modes entered back to back, as the console would be driven. Times come
//! from the supervisor's mode and phase in each scene period, temperatures from its Tc,
//! angles and k_b from the plant's truth.

use thermorph::supervisor::Supervisor;
use thermorph::supervisor::events::EventKind;

use crate::plant::PlantScale;
use crate::runs::cycle_figures;
pub use crate::runs::cycle_figures::{CycleFigures, Figure, KEYS, judge, measure};
use crate::runs::run::{RunError, RunResult, run_with};
use crate::runs::scenario;
use crate::runs::series::Row;

/// When the stepping command is sent, s (after the standby figures' window).
pub const STEP_AT_S: f64 = 120.0;

/// The experiments' scene: `duration_s` at `ambient_k`, the camera on or off, power-up in
/// standby (a closed-loop scene whose only line is `mode standby` at 0 s).
pub fn scene(
    duration_s: f64,
    ambient_k: f64,
    camera: bool,
) -> Result<scenario::Scenario, scenario::ScenarioError> {
    scene_with(duration_s, ambient_k, camera, &PlantScale::UNIT)
}

/// [`scene`] on a block whose heater power, wall capacity, spring cooling and spring supply are
/// `scale` times the fitted block's (the scene's `[plant]` table, written as percentages; the
/// firmware keeps its own parameters). Factors outside 0.5–2.0 are refused as a scene file's
/// would be.
pub fn scene_with(
    duration_s: f64,
    ambient_k: f64,
    camera: bool,
    scale: &PlantScale,
) -> Result<scenario::Scenario, scenario::ScenarioError> {
    let mut text = format!(
        "name = \"paper\"\n\
         description = \"the thesis's experiments, real supervisor\"\n\
         duration = \"{duration_s} s\"\n\
         ambient = \"{ambient_k} K\"\n\
         initial = \"{ambient_k} K\"\n\
         period = \"0.25 s\"\n\
         [fidelity]\ncamera = {camera}\n\
         [camera]\nnoise = \"0.1 K\"\nseed = 1\n"
    );
    if *scale != PlantScale::UNIT {
        text.push_str("[plant]\n");
        for (key, factor) in scale.named() {
            text.push_str(&format!("{key} = \"{} %\"\n", 100.0 * factor));
        }
    }
    text.push_str("[[command]]\nat = \"0 s\"\nline = \"mode standby\"\n");
    scenario::parse(&text, "<paper>", "paper")
}

/// The two experiments, in the order the table is built from them: springs, duration (s).
pub const EXPERIMENTS: [(&str, f64); 2] = [("AB", 700.0), ("A", 400.0)];

/// Run the full cycle with `springs` at 298.15 K, the camera on or off; returns the rows.
pub fn cycle(springs: &str, duration_s: f64, camera: bool) -> Result<Vec<Row>, RunError> {
    cycle_in(&scene(duration_s, 298.15, camera)?, springs)
}

/// The experiments' script, as someone at the console would drive it, one decision a scene
/// period from the board's state: power-up in standby, `mode step-large SPRINGS` at
/// [`STEP_AT_S`], `mode form` once the stepping holds, `mode recover` once forming has handed
/// back to standby. A mode that ends otherwise (a timeout, a fault) ends the script there.
#[derive(Debug, Clone)]
pub struct Script {
    springs: String,
    stage: u8,
}

impl Script {
    /// The script with `springs` (`AB`, `A`).
    pub fn new(springs: &str) -> Script {
        Script {
            springs: springs.to_string(),
            stage: 0,
        }
    }

    /// The line to send after seeing, at `t_s`, the board in `mode` and `phase`; `formed`: the
    /// board's last mode change was `form` → `standby`.
    pub fn next(&mut self, t_s: f64, mode: &str, phase: &str, formed: bool) -> Option<String> {
        let line = match self.stage {
            0 if t_s >= STEP_AT_S => format!("mode step-large {}", self.springs),
            1 if mode == "step-large" && phase == "hold" => "mode form".into(),
            2 if mode == "standby" && formed => "mode recover".into(),
            _ => return None,
        };
        self.stage += 1;
        Some(line)
    }
}

/// Run the full cycle with `springs` in `sc` (from [`scene`]) by the [`Script`]; returns the
/// rows ([`play`]'s).
pub fn cycle_in(sc: &scenario::Scenario, springs: &str) -> Result<Vec<Row>, RunError> {
    Ok(play(sc, springs)?.rows)
}

/// Run the full cycle with `springs` in `sc` (from [`scene`]) by the [`Script`], the
/// supervisor's state read every scene period (`formed`: its last event is the mode change
/// `form` → `standby`); returns the run (its replies hold the script's lines and when they
/// were sent).
pub fn play(sc: &scenario::Scenario, springs: &str) -> Result<RunResult, RunError> {
    let mut script = Script::new(springs);
    let mut react = |t: f64, s: &Supervisor| -> Option<String> {
        let formed = s.events().iter().last().is_some_and(|e| {
            matches!(
                e.kind,
                EventKind::Mode {
                    from: "form",
                    to: "standby"
                }
            )
        });
        script.next(t, s.mode().name(), s.mode().phase_name(), formed)
    };
    run_with(sc, &mut |_| {}, &mut react)
}

/// Run both [`EXPERIMENTS`] (camera on, or off for a quick look with true temperatures) and
/// build the table (keys in [`KEYS`] order).
pub fn figures(camera: bool, out: Option<&std::path::Path>) -> Result<Vec<Figure>, RunError> {
    let [(two, two_s), (one, one_s)] = EXPERIMENTS;
    let two_rows = cycle(two, two_s, camera)?;
    let one_rows = cycle(one, one_s, camera)?;
    table(&two_rows, &one_rows, out)
}

/// The table (keys in [`KEYS`] order) from the [`EXPERIMENTS`]' rows (two springs, then one);
/// with `out`, both time series written into that folder first (`two-springs.csv`,
/// `one-spring.csv`).
pub fn table(
    two_rows: &[Row],
    one_rows: &[Row],
    out: Option<&std::path::Path>,
) -> Result<Vec<Figure>, RunError> {
    if let Some(dir) = out {
        std::fs::create_dir_all(dir).map_err(|err| RunError::Write {
            path: dir.to_path_buf(),
            err,
        })?;
        for (name, rows) in [("two-springs.csv", two_rows), ("one-spring.csv", one_rows)] {
            let path = dir.join(name);
            let mut buf = Vec::new();
            crate::runs::series::write_csv(rows, &mut buf).map_err(RunError::Csv)?;
            std::fs::write(&path, buf).map_err(|err| RunError::Write { path, err })?;
        }
    }
    let two = measure(two_rows);
    let one = measure(one_rows);
    Ok(judge(&two, Some(&one)))
}

/// `host-sim paper [--json] [--no-camera] [--out DIR]`: print the table (or the JSON object),
/// and with `--out` write both experiments' time series (`two-springs.csv`, `one-spring.csv`);
/// an error (exit status 1) when a figure fails ([`Figure::fails`]: a known shortfall of the
/// simulated block does not).
pub fn cli(json: bool, camera: bool, out: Option<&std::path::Path>) -> anyhow::Result<()> {
    let table = figures(camera, out)?;
    print(&table, json, None)?;
    failures(&table)
}

/// An error naming the figures that fail ([`Figure::fails`]), if any.
pub fn failures(table: &[Figure]) -> anyhow::Result<()> {
    let failed: Vec<&str> = table
        .iter()
        .filter(|f| f.fails())
        .map(|f| f.key.as_str())
        .collect();
    if failed.is_empty() {
        Ok(())
    } else {
        anyhow::bail!(
            "{} outside its tolerance: {}",
            failed.len(),
            failed.join(", ")
        )
    }
}

/// Print `table` as `host-sim paper` does: a table, or with `json` one JSON object keyed by
/// figure (`{thesis, sim, pass}`). `source`, when the figures are not the library's: a line
/// saying whose they are, first in the table (on standard error with `json`, which keeps the
/// object alone on standard output).
pub fn print(table: &[Figure], json: bool, source: Option<&str>) -> anyhow::Result<()> {
    if json {
        if let Some(s) = source {
            eprintln!("{s}");
        }
        let map: serde_json::Map<String, serde_json::Value> = table
            .iter()
            .map(|f| {
                (
                    f.key.clone(),
                    serde_json::json!({"thesis": f.thesis, "sim": f.simulated, "pass": f.passes()}),
                )
            })
            .collect();
        println!("{}", serde_json::to_string_pretty(&map)?);
        return Ok(());
    }
    let mut out = std::io::stdout().lock();
    write_text(&mut out, table, source)?;
    Ok(())
}

/// `host-sim paper`'s table: `source`'s line, if any, then the figures as `host-sim run`
/// prints its own ([`cycle_figures::write_table`], the values to 0.001 as in the JSON).
pub fn write_text(
    out: &mut impl std::io::Write,
    table: &[Figure],
    source: Option<&str>,
) -> std::io::Result<()> {
    if let Some(s) = source {
        writeln!(out, "{s}")?;
    }
    cycle_figures::write_table(out, table, cycle_figures::Digits::Exact)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A judged figure of `key` that passes or not.
    fn judged_figure(key: &str, pass: bool) -> Figure {
        Figure {
            pass: Some(pass),
            tolerance: Some("±1".into()),
            ..Figure::reported(key, key, "s", Some(1.0), 1.0, "how")
        }
    }

    #[test]
    fn a_failing_figure_fails_the_table_and_a_known_shortfall_does_not() {
        let ok = [judged_figure("forming_time_s", true)];
        assert!(failures(&ok).is_ok());
        let known = [judged_figure("pulse_drop_deg", false)];
        assert_eq!(known[0].verdict(), "fail, known");
        assert!(failures(&known).is_ok());
        let bad = [
            judged_figure("pulse_drop_deg", false),
            judged_figure("cycle_time_s", false),
        ];
        assert_eq!(bad[1].verdict(), "FAIL");
        let e = failures(&bad).unwrap_err().to_string();
        assert!(e.contains("cycle_time_s") && !e.contains("pulse"), "{e}");
    }

    #[test]
    fn the_table_keeps_every_verdict_in_one_column_and_names_the_figures() {
        // A list of pulse drops once pushed its row's columns out, and the rows named the
        // figures by their JSON keys where `host-sim run` names them for a person (issue 44).
        let drops = Figure {
            simulated: serde_json::json!([-0.024, -0.119, -0.196]),
            thesis: serde_json::json!([2.0, 4.0]),
            ..judged_figure("pulse_drop_deg", false)
        };
        let table = [
            Figure {
                name: "standby preheat".into(),
                ..judged_figure("preheat_time_s", true)
            },
            drops,
            Figure::reported(
                "hold_angle_loss_deg",
                "hold angle loss",
                "deg",
                None,
                0.0,
                "h",
            ),
        ];
        let mut out = Vec::new();
        write_text(&mut out, &table, Some("board: x.elf")).unwrap();
        let text = String::from_utf8(out).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "board: x.elf");
        let head = lines[1];
        assert!(
            head.starts_with("figure ") && head.ends_with("tolerance"),
            "{text}"
        );
        let head_w = head.chars().count();
        for (row, verdict) in lines[2..5].iter().zip(["pass", "fail, known", "—"]) {
            assert!(row.ends_with(&format!(" {verdict}")), "{text}");
            let cells: String = row
                .chars()
                .take(row.chars().count() - verdict.chars().count() - 1)
                .collect();
            assert_eq!(cells.chars().count(), head_w, "{text}");
        }
        assert!(lines[2].starts_with("standby preheat "), "{text}");
        assert!(
            lines[3].contains(" -0.024, -0.119, -0.196  ") && lines[3].contains(" 2.0–4.0  s "),
            "{text}"
        );
        assert!(
            lines[5].starts_with("known: pulse_drop_deg: a spring"),
            "{text}"
        );
    }

    #[test]
    fn the_scene_carries_a_plant_scale() {
        let plain = scene(900.0, 298.15, true).unwrap();
        assert_eq!(plain.plant_scale, PlantScale::UNIT);
        assert_eq!(
            scene_with(900.0, 298.15, true, &PlantScale::UNIT).unwrap(),
            plain
        );
        for scale in [
            PlantScale {
                heater_power: 1.2,
                wall_capacity: 0.8,
                spring_cooling: 0.8,
                spring_supply: 1.2,
            },
            PlantScale {
                heater_power: 0.8,
                wall_capacity: 1.2,
                spring_cooling: 1.2,
                spring_supply: 0.8,
            },
        ] {
            let sc = scene_with(900.0, 298.15, true, &scale).unwrap();
            assert_eq!(sc.plant_scale, scale);
            assert_eq!(sc.block().options.scale, scale);
            assert_eq!(
                scenario::Scenario {
                    plant_scale: PlantScale::UNIT,
                    ..sc
                },
                plain
            );
        }
        let e = scene_with(
            900.0,
            298.15,
            true,
            &PlantScale {
                wall_capacity: 2.5,
                ..PlantScale::UNIT
            },
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("`plant.wall_capacity`: 250 % is out of range"),
            "{e}"
        );
    }
}
