//! `host-sim run`: a scene played against the simulated board, with its time series, summary
//! and plot.
//!
//! This module owns the run loop and its outputs. The scene drives one [`SimBoard`] (the plant,
//! the camera chain, the injected faults and, closed loop, the firmware's controller stepped at
//! the board's tick and on every frame): its timed duties, e-stop button and console lines go
//! in at their times, and one [`Row`] is recorded per scene period (`period`, ≤ 0.5 s). With the camera on,
//! the controller sees the block through the virtual MLX90640 and the firmware's sensing
//! pipeline; camera off, the true region temperatures once per period; a sensor fault with the
//! camera off means no measurement at all (`nan` in the CSV). Outputs, written by
//! [`write_outputs`] into one folder: `timeseries.csv` (one row a period,
//! [`crate::runs::series`]), `summary.json` ([`Summary`]: run figures and the SPEC section 8
//! figures that an open-loop scene shows, beside the thesis's) and `plot.png`
//! ([`crate::runs::plot`]); a run of the board's ELF (`crate::runs::elf_run`, `--features pil`)
//! adds `defmt.log`, the board's defmt log ([`LogRecord`]).
//!
//! This module owns the error type of runs and of the experiments built on them
//! ([`crate::runs::paper`]), [`RunError`].

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use serde::Serialize;
use thermorph::app::Line;
use thermorph::posture::Posture;
use thermorph::settings::Settings;
use thermorph::supervisor::report::Reply;
use thermorph::supervisor::{Notice, Supervisor};
use thermorph::units::Seconds;

use crate::rig::RigError;
use crate::rig::camera::{Camera, camera_temps};
use crate::rig::store::SimFlash;
use crate::rig::{Said, SimBoard};
use crate::runs::plot::PlotError;
use crate::runs::scenario::{Scenario, ScenarioError};
pub use crate::runs::series::{CSV_HEADER, ControlRow, Row, write_csv};

/// A console line of the scene and the supervisor's reply.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ReplyRecord {
    /// When it was sent, s.
    pub at_s: f64,
    /// The line.
    pub line: String,
    /// The reply line.
    pub reply: String,
}

/// A `# warning: …` line the board wrote on its console (a soak that cannot soften the wall, a
/// spring held back), with when.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct WarningRecord {
    /// When the board wrote it, s.
    pub at_s: f64,
    /// The warning's text (after `# warning: `).
    pub text: String,
}

/// A line of the board's defmt log: a frame its ELF wrote to RTT, decoded with the ELF's
/// `.defmt` table, or a note on bytes that did not decode.
#[derive(Clone, Debug, PartialEq)]
pub struct LogRecord {
    /// When the harness read it off the chip, s of the run (within a millisecond of its
    /// writing).
    pub at_s: f64,
    /// The frame's own timestamp as defmt shows it (the board's: embassy's uptime in seconds,
    /// `12.345678`, which starts again at a chip reset); None without one (a note).
    pub timestamp: Option<String>,
    /// The frame's level (`TRACE` … `ERROR`); None for a `println!` frame or a note.
    pub level: Option<&'static str>,
    /// The message.
    pub text: String,
}

impl std::fmt::Display for LogRecord {
    /// `   12.345678 WARN  message`; a line without a timestamp shows the run's time in
    /// parentheses, one without a level `-`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let time = match &self.timestamp {
            Some(t) => t.clone(),
            None => format!("({:.3})", self.at_s),
        };
        write!(
            f,
            "{time:>11} {:<5} {}",
            self.level.unwrap_or("-"),
            self.text
        )
    }
}

/// Everything a run produced.
#[derive(Clone, Debug)]
pub struct RunResult {
    /// One row per scene period.
    pub rows: Vec<Row>,
    /// The summary.
    pub summary: Summary,
    /// The board's defmt log (a run of its ELF; empty for the library's board, which has none).
    pub log: Vec<LogRecord>,
}

pub use crate::runs::cycle_figures::Figure;

/// MTTS accuracy over a camera-on run.
#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
pub struct CameraStats {
    /// Whole frames turned into regions.
    pub frames: u64,
    /// Sensor or MTTS errors.
    pub errors: u64,
    /// Mean |T1 measured − true| over the periods with a measurement, K.
    pub mean_abs_t1_err_k: f64,
    /// Largest |T1 measured − true|, K.
    pub max_abs_t1_err_k: f64,
    /// Mean |T2 measured − true|, K.
    pub mean_abs_t2_err_k: f64,
    /// Largest |T2 measured − true|, K.
    pub max_abs_t2_err_k: f64,
}

/// A run's summary (written as `summary.json`).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Summary {
    /// Scene name.
    pub scene: String,
    /// Scene description.
    pub description: String,
    /// Simulated time, s.
    pub duration_s: f64,
    /// Control period, s.
    pub period_s: f64,
    /// Control periods simulated.
    pub steps: usize,
    /// Plant fidelity, as `thermal/sma/smp/mechanics`.
    pub fidelity: String,
    /// Whether the camera chain ran.
    pub camera: bool,
    /// Wall time of the simulation loop, s.
    pub wall_s: f64,
    /// Simulated seconds per wall second.
    pub real_time_factor: f64,
    /// Highest heater film temperature, K.
    pub max_heater_k: f64,
    /// Highest SMP outer-surface temperature, K.
    pub max_smp_outer_k: f64,
    /// Largest bending angle, degrees.
    pub max_bend_deg: f64,
    /// Bending angle at the end, degrees.
    pub final_bend_deg: f64,
    /// Lowest and highest bending stiffness, N·mm/rad.
    pub k_b_range_nmm_per_rad: [f64; 2],
    /// Periods without a measurement.
    pub periods_without_measurement: usize,
    /// MTTS accuracy (camera on only).
    pub camera_stats: Option<CameraStats>,
    /// The SPEC section 8 figures (open-loop scenes; `host-sim paper` measures them closed
    /// loop).
    pub figures: Vec<Figure>,
    /// Each console line of the scene with its reply (closed-loop scenes).
    pub replies: Vec<ReplyRecord>,
    /// Every fault the supervisor latched (closed-loop scenes).
    pub faults: Vec<crate::rig::FaultRecord>,
    /// Every warning the board wrote on its console (closed-loop scenes).
    pub warnings: Vec<WarningRecord>,
}

/// Why a run (or an experiment of runs) failed or could not write its outputs.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The scene is refused.
    #[error(transparent)]
    Scenario(#[from] ScenarioError),

    /// The simulated board could not be built.
    #[error(transparent)]
    Rig(#[from] RigError),
    /// The plot could not be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// An output folder cannot be created.
    #[error("{}: cannot create: {err}", path.display())]
    CreateDir {
        /// The folder.
        path: PathBuf,
        /// Why.
        err: std::io::Error,
    },
    /// A folder or file cannot be written.
    #[error("{}: {err}", path.display())]
    Write {
        /// The folder or file.
        path: PathBuf,
        /// Why.
        err: std::io::Error,
    },
    /// The rows could not be written as CSV.
    #[error("{0}")]
    Csv(std::io::Error),
    /// The summary could not be written as JSON.
    #[error("{0}")]
    Json(serde_json::Error),
    /// The run was stopped (Ctrl-C) before the scene's end.
    #[error("interrupted (Ctrl-C) at {at_s:.1} s of the scene's {duration_s} s")]
    Interrupted {
        /// Simulated time when it stopped, s.
        at_s: f64,
        /// The scene's duration, s.
        duration_s: f64,
    },
}

/// Play `scenario`; `progress` is called after each period with the fraction done.
pub fn run(scenario: &Scenario, progress: &mut dyn FnMut(f64)) -> Result<RunResult, RunError> {
    run_with(scenario, progress, &mut |_, _| None)
}

/// [`run`], stopped with [`RunError::Interrupted`] at the end of the first period after `stop`
/// is set (Ctrl-C: [`crate::cli::catch_interrupt`]).
pub fn run_until(
    scenario: &Scenario,
    progress: &mut dyn FnMut(f64),
    stop: &AtomicBool,
) -> Result<RunResult, RunError> {
    run_stoppable(scenario, progress, &mut |_, _| None, Some(stop))
}

/// Decides console lines from the supervisor's state (for experiments that enter modes back to
/// back): called at the start of each scene period with the time, s, and the supervisor, as a
/// person polling `status` would; a returned line is sent at the next period's start.
pub type Reactor<'a> = dyn FnMut(f64, &Supervisor) -> Option<String> + 'a;

/// [`run`], with `react` able to send console lines as the supervisor's state changes (the
/// scene must run closed loop: at least one `[[command]]`).
///
/// The scene drives one [`SimBoard`]: its timed duties (open loop) and console lines go in at
/// the first tick at or after their time (lines after that instant's control period, as the
/// board takes a line that arrives with a tick), the e-stop button (closed loop) at its own
/// time to the µs ([`SimBoard::set_button`]: a press is a control period at once, as on the
/// board), before that instant's lines, and one [`Row`] is recorded per scene period:
/// the plant at its end, the supervisor's state and the inputs it gave the plant at its start
/// (after that instant's lines).
pub fn run_with(
    scenario: &Scenario,
    progress: &mut dyn FnMut(f64),
    react: &mut Reactor<'_>,
) -> Result<RunResult, RunError> {
    run_stoppable(scenario, progress, react, None)
}

/// [`run_with`], checking `stop` (if any) after each period.
fn run_stoppable(
    scenario: &Scenario,
    progress: &mut dyn FnMut(f64),
    react: &mut Reactor<'_>,
    stop: Option<&AtomicBool>,
) -> Result<RunResult, RunError> {
    let closed_loop = !scenario.commands.is_empty();
    let mut board = SimBoard::new(
        &scenario.block(),
        closed_loop,
        Settings::DEFAULT,
        SimFlash::Memory(None),
    )?;
    let steps = (scenario.duration_s / scenario.period_s).round().max(1.0) as usize;
    let period_us = ((scenario.period_s * 1e6).round() as u64).max(1);
    let mut rows = Vec::with_capacity(steps);
    let mut next_action = 0;
    let mut next_command = 0;
    let mut replies = Vec::new();
    let mut said = Vec::new();
    let mut warnings = Vec::new();
    let started = Instant::now();
    let mut row_start = None;
    // A line `react` decided at a period's start, sent at the next one's: the reaction time of
    // someone polling `status`, one scene period.
    let mut reacted: Option<String> = None;
    let mut model_only = Posture::new();
    for k in 0..steps {
        let t1_us = (k as u64 + 1) * period_us;
        loop {
            let t_s = board.time_s();
            while let Some(a) = scenario
                .actions
                .get(next_action)
                .filter(|a| a.at_s <= t_s + 1e-9)
            {
                if a.sets_actuators() {
                    let mut cmd = board.commanded();
                    if let Some(d) = a.heater_duty {
                        cmd.heater_duty = d;
                    }
                    if let Some(d) = a.fan_duty {
                        cmd.fan_duty = d;
                    }
                    if let Some(s) = a.springs_on {
                        cmd.springs_on = s;
                    }
                    board.set_inputs(cmd);
                }
                if let Some(pressed) = a.button {
                    board.set_button(pressed, &mut said);
                }
                next_action += 1;
            }
            if closed_loop {
                while let Some(l) = scenario
                    .commands
                    .get(next_command)
                    .filter(|l| l.at_s <= t_s + 1e-9)
                {
                    let reply = board.line(Line::Text(&l.line), &mut said);
                    replies.push(record(l.at_s, &l.line, reply));
                    next_command += 1;
                }
                if row_start.is_none() {
                    if let Some(line) = reacted.take() {
                        let reply = board.line(Line::Text(&line), &mut said);
                        replies.push(record(t_s, &line, reply));
                    }
                    reacted = board.supervisor().and_then(|s| react(t_s, s));
                }
            }
            keep_warnings(&mut said, board.time_s(), &mut warnings);
            if row_start.is_none() {
                let mut control = board.supervisor().map(control_row);
                if let Some(c) = &mut control {
                    // The model alone, beside the supervisor's fused estimate.
                    model_only.predict(&c.estimate, Seconds::from_ms((period_us / 1000) as u32));
                    c.model_bend_deg = model_only.model_deg() as f64;
                }
                row_start = Some((board.inputs(), board.commanded().springs_on, control));
            }
            let now_us = board.time_us();
            if now_us >= t1_us {
                break;
            }
            let mut to_us = board.next_tick_us().min(t1_us);
            // The e-stop button at its own time (to the µs), not at the next tick: the board's
            // e-stop task wakes its control loop at the press.
            if let Some(a) = scenario
                .actions
                .get(next_action)
                .filter(|a| a.button.is_some())
            {
                let at_us = (a.at_s * 1e6).round() as u64;
                if at_us > now_us {
                    to_us = to_us.min(at_us);
                }
            }
            board.advance_to(to_us, &mut said);
        }
        let ((inputs, faults, _), springs_cmd, control) =
            row_start.take().expect("set at the period's start");
        let obs = board.observe();
        rows.push(Row {
            inputs,
            springs_cmd,
            obs,
            measured_k: board.measured_k(),
            quality: board.measured_quality(),
            truth_k: camera_temps(&obs).regions(),
            faults,
            control,
        });
        progress((k + 1) as f64 / steps as f64);
        if stop.is_some_and(|s| s.load(Ordering::SeqCst)) && k + 1 < steps {
            return Err(RunError::Interrupted {
                at_s: board.time_s(),
                duration_s: scenario.duration_s,
            });
        }
    }
    keep_warnings(&mut said, board.time_s(), &mut warnings);
    let wall_s = started.elapsed().as_secs_f64();
    let mut summary = summarise(scenario, &rows, wall_s, board.camera());
    summary.replies = replies;
    summary.faults = board.latched().to_vec();
    summary.warnings = warnings;
    Ok(RunResult {
        rows,
        summary,
        log: Vec::new(),
    })
}

/// Empty what the board said since the last call, keeping its warnings (timed `at_s`, the
/// board's time once they were drained: within one control tick of when they were written).
fn keep_warnings(said: &mut Vec<Said>, at_s: f64, warnings: &mut Vec<WarningRecord>) {
    for s in said.drain(..) {
        if let Said::Notice(Notice::Warning(w)) = s {
            warnings.push(WarningRecord {
                at_s,
                text: w.to_string(),
            });
        }
    }
}

fn record(at_s: f64, line: &str, reply: Option<Reply>) -> ReplyRecord {
    ReplyRecord {
        at_s,
        line: line.to_string(),
        reply: reply.map_or(String::new(), |r| r.as_str().to_string()),
    }
}

/// The supervisor's state for the time series (the model-only bend NaN: [`run`] fills it).
pub fn control_row(s: &Supervisor) -> ControlRow {
    ControlRow {
        estimate: s.estimate(),
        bend: s.bend(),
        model_bend_deg: f64::NAN,
        mode: s.mode().name(),
        phase: s.mode().phase_name(),
        target_k: s.target_k() as f64,
        tc_k: s.tc_k() as f64,
        fault: s.fault().map(|f| f.code()),
        spring_a: s.channels().state().map(|c| c.current_a as f64),
    }
}

/// The run's summary from its rows (the camera's statistics where it ran).
pub(crate) fn summarise(
    scenario: &Scenario,
    rows: &[Row],
    wall_s: f64,
    camera: Option<&Camera>,
) -> Summary {
    let f = scenario.fidelity;
    let fold = |get: &dyn Fn(&Row) -> f64, init: f64, op: fn(f64, f64) -> f64| {
        rows.iter().map(get).fold(init, op)
    };
    let camera_stats = camera.map(|c| {
        let errs: Vec<(f64, f64)> = rows
            .iter()
            .filter_map(|r| {
                r.measured_k
                    .map(|m| ((m[0] - r.truth_k[0]).abs(), (m[1] - r.truth_k[1]).abs()))
            })
            .collect();
        let n = errs.len().max(1) as f64;
        CameraStats {
            frames: c.frames,
            errors: c.errors,
            mean_abs_t1_err_k: errs.iter().map(|e| e.0).sum::<f64>() / n,
            max_abs_t1_err_k: errs.iter().map(|e| e.0).fold(0.0, f64::max),
            mean_abs_t2_err_k: errs.iter().map(|e| e.1).sum::<f64>() / n,
            max_abs_t2_err_k: errs.iter().map(|e| e.1).fold(0.0, f64::max),
        }
    });
    let duration_s = rows.last().map_or(0.0, |r| r.obs.time_s);
    Summary {
        scene: scenario.name.clone(),
        description: scenario.description.clone(),
        duration_s,
        period_s: scenario.period_s,
        steps: rows.len(),
        fidelity: format!(
            "{:?}/{:?}/{:?}/{}",
            f.thermal,
            f.sma,
            f.smp,
            if f.mechanics {
                "mechanics"
            } else {
                "no-mechanics"
            }
        )
        .to_lowercase(),
        camera: scenario.camera.enabled,
        wall_s,
        real_time_factor: if wall_s > 0.0 {
            duration_s / wall_s
        } else {
            f64::INFINITY
        },
        max_heater_k: fold(&|r| r.obs.heater_k, f64::MIN, f64::max),
        max_smp_outer_k: fold(&|r| r.obs.smp_outer_k, f64::MIN, f64::max),
        max_bend_deg: fold(&|r| r.obs.bend_deg, 0.0, f64::max),
        final_bend_deg: rows.last().map_or(0.0, |r| r.obs.bend_deg),
        k_b_range_nmm_per_rad: [
            fold(&|r| r.obs.k_b_nmm_per_rad, f64::MAX, f64::min),
            fold(&|r| r.obs.k_b_nmm_per_rad, f64::MIN, f64::max),
        ],
        periods_without_measurement: rows.iter().filter(|r| r.measured_k.is_none()).count(),
        camera_stats,
        figures: if scenario.commands.is_empty() {
            figures(rows)
        } else {
            closed_loop_figures(rows)
        },
        replies: Vec::new(),
        faults: Vec::new(),
        warnings: Vec::new(),
    }
}

/// First time in `rows[from..]` where `pred` holds, s.
fn first_time(rows: &[Row], from: usize, pred: impl Fn(&Row) -> bool) -> Option<(usize, f64)> {
    rows.iter()
        .enumerate()
        .skip(from)
        .find(|(_, r)| pred(r))
        .map(|(i, r)| (i, r.obs.time_s))
}

/// The SPEC section 8 figures that an open-loop run shows. Phases are found from the inputs:
/// *forming* starts at the first period with the heater off, the fan on and the column bent
/// by more than 5°; *recovery* at the first later period with the heater on and every spring
/// off. Start of period k is `time_s − period`.
pub fn figures(rows: &[Row]) -> Vec<Figure> {
    let period_s = match rows {
        [a, b, ..] => b.obs.time_s - a.obs.time_s,
        [a] => a.obs.time_s,
        [] => 0.0,
    };
    let start = |i: usize| rows[i].obs.time_s - period_s;
    let heat_323 = (rows.first().is_some_and(|r| r.obs.heater_k < 323.0))
        .then(|| first_time(rows, 0, |r| r.obs.heater_k >= 323.0).map(|(_, t)| t))
        .flatten();
    let loaded = |n: usize| {
        let v = rows
            .iter()
            .filter(|r| r.inputs.springs_on.iter().filter(|s| **s).count() == n)
            .map(|r| r.obs.bend_deg)
            .fold(f64::NAN, f64::max);
        (!v.is_nan()).then_some(v)
    };
    let forming = first_time(rows, 0, |r| {
        r.inputs.heater_duty == 0.0 && r.inputs.fan_duty > 0.0 && r.obs.bend_deg > 5.0
    });
    let formed = forming.and_then(|(i, _)| {
        first_time(rows, i, |r| r.obs.smp_outer_k <= 323.0).map(|(j, t)| (j, t - start(i)))
    });
    let k_b_hot = forming.map(|(i, _)| rows[i.saturating_sub(1)].obs.k_b_nmm_per_rad);
    let k_b_formed = formed.map(|(j, _)| rows[j].obs.k_b_nmm_per_rad);
    let recovery_start = forming.and_then(|(i, _)| {
        first_time(rows, i, |r| {
            r.inputs.heater_duty > 0.0 && !r.inputs.springs_on.iter().any(|s| *s)
        })
    });
    let reheat_358 = recovery_start.and_then(|(i, _)| {
        first_time(rows, i, |r| r.obs.heater_k >= 358.0).map(|(_, t)| t - start(i))
    });
    let recovered = recovery_start.and_then(|(i, _)| {
        first_time(rows, i, |r| r.obs.bend_deg <= 2.0).map(|(_, t)| t - start(i))
    });
    let fig = Figure::reported;
    vec![
        fig(
            "standby_heat_up_s",
            "standby heat-up",
            "s",
            heat_323,
            10.0,
            "heater film from the start to 323 K",
        ),
        fig(
            "full_loading_one_spring_deg",
            "full loading, one spring",
            "deg",
            loaded(1),
            42.0,
            "largest bend with one spring on",
        ),
        fig(
            "full_loading_two_springs_deg",
            "full loading, two springs",
            "deg",
            loaded(2),
            65.0,
            "largest bend with two springs on",
        ),
        fig(
            "forming_time_s",
            "forming",
            "s",
            formed.map(|f| f.1),
            50.0,
            "from heater off + fan on (bent) to the SMP outer surface at 323 K",
        ),
        fig(
            "formed_k_b",
            "formed stiffness",
            "N·mm/rad",
            k_b_formed,
            1400.0,
            "k_b when forming reaches 323 K",
        ),
        fig(
            "stiffness_ratio",
            "stiffness ratio formed/heated",
            "",
            k_b_formed.zip(k_b_hot).map(|(a, b)| a / b),
            4.5,
            "k_b at 323 K after forming over k_b just before forming",
        ),
        fig(
            "reheat_358_s",
            "reheat to 358 K",
            "s",
            reheat_358,
            25.0,
            "from recovery start (heater on, springs off) to the heater film at 358 K",
        ),
        fig(
            "recovery_time_s",
            "recovery",
            "s",
            recovered,
            40.0,
            "from recovery start to within 2° of straight",
        ),
    ]
}

/// The SPEC section 8 figures a closed-loop run shows, measured and judged as `host-sim paper`
/// measures and judges them ([`crate::runs::cycle_figures`]): a run that stepped with one spring
/// at most gives the one-spring loading, else the two-spring one. A scene whose own timing
/// differs from the thesis's experiment (the bundled `cycle` holds the bend for its own time
/// before forming) fails the figures that timing sets; `host-sim paper` runs the thesis's.
pub fn closed_loop_figures(rows: &[Row]) -> Vec<Figure> {
    use crate::runs::cycle_figures::{CycleFigures, judge, measure};
    let f = measure(rows);
    let springs = rows
        .iter()
        .map(|r| r.springs_cmd.iter().filter(|s| **s).count())
        .max()
        .unwrap_or(0);
    if springs == 1 {
        let two = CycleFigures {
            full_loading_deg: None,
            ..f.clone()
        };
        judge(&two, Some(&f))
    } else {
        judge(&f, None)
    }
}

/// Write `timeseries.csv`, `summary.json` and `plot.png` into `dir` (created if missing), and
/// `defmt.log` (one [`LogRecord`] a line) if the run has a log.
pub fn write_outputs(result: &RunResult, dir: &Path) -> Result<(), RunError> {
    std::fs::create_dir_all(dir).map_err(|err| RunError::CreateDir {
        path: dir.to_path_buf(),
        err,
    })?;
    // The CSV text is formatted once: written out on one thread while the plot is drawn from
    // it on this one.
    let text = crate::runs::series::csv_text(&result.rows);
    let files = || -> Result<(), RunError> {
        let csv = dir.join("timeseries.csv");
        std::fs::write(&csv, &text).map_err(|err| RunError::Write { path: csv, err })?;
        let json = dir.join("summary.json");
        let summary = serde_json::to_string_pretty(&result.summary).map_err(RunError::Json)?;
        std::fs::write(&json, summary + "\n").map_err(|err| RunError::Write { path: json, err })?;
        if !result.log.is_empty() {
            let log = dir.join("defmt.log");
            let text: String = result.log.iter().map(|r| format!("{r}\n")).collect();
            std::fs::write(&log, text).map_err(|err| RunError::Write { path: log, err })?;
        }
        Ok(())
    };
    let png = dir.join("plot.png");
    std::thread::scope(|s| {
        let written = s.spawn(files);
        let drawn = crate::runs::plot::write_png(&text, &result.summary.scene, &png);
        written.join().expect("the file writer does not panic")?;
        drawn.map_err(RunError::from)
    })
}

/// Print the summary for a person: the run, then the figures beside the thesis's.
pub fn print_summary(s: &Summary, out: &mut impl Write) -> std::io::Result<()> {
    writeln!(
        out,
        "scene {}: {} ({} periods of {} s, fidelity {}, camera {})",
        s.scene,
        s.description,
        s.steps,
        s.period_s,
        s.fidelity,
        if s.camera { "on" } else { "off" }
    )?;
    writeln!(
        out,
        "simulated {:.1} s in {:.3} s wall ({:.0}× real time)",
        s.duration_s, s.wall_s, s.real_time_factor
    )?;
    writeln!(
        out,
        "max heater {:.1} K, max SMP surface {:.1} K, max bend {:.1}°, final bend {:.1}°, k_b {:.0}–{:.0} N·mm/rad",
        s.max_heater_k,
        s.max_smp_outer_k,
        s.max_bend_deg,
        s.final_bend_deg,
        s.k_b_range_nmm_per_rad[0],
        s.k_b_range_nmm_per_rad[1]
    )?;
    if let Some(c) = &s.camera_stats {
        writeln!(
            out,
            "camera: {} frames, {} errors; |T1 − truth| mean {:.2} K max {:.2} K, |T2 − truth| mean {:.2} K max {:.2} K",
            c.frames,
            c.errors,
            c.mean_abs_t1_err_k,
            c.max_abs_t1_err_k,
            c.mean_abs_t2_err_k,
            c.max_abs_t2_err_k
        )?;
    }
    if s.periods_without_measurement > 0 {
        writeln!(
            out,
            "periods without a measurement: {}",
            s.periods_without_measurement
        )?;
    }
    crate::runs::cycle_figures::write_table(
        out,
        &s.figures,
        crate::runs::cycle_figures::Digits::Rounded,
    )?;
    if !s.replies.is_empty() {
        writeln!(
            out,
            "(the scene's own timing sets these; `host-sim paper` runs the thesis's experiments)"
        )?;
    } else if !s.figures.is_empty() {
        writeln!(
            out,
            "(reported, not judged: an open-loop scene is not the thesis's experiment; \
             `host-sim paper` runs and judges those)"
        )?;
    }
    // The console's lines, the board's warnings and the latched faults in time order (a
    // reply before a warning or fault of the same instant).
    let mut lines: Vec<(f64, String)> = Vec::new();
    for r in &s.replies {
        lines.push((r.at_s, format!("> {}  < {}", r.line, r.reply)));
    }
    for w in &s.warnings {
        lines.push((w.at_s, format!("# warning: {}", w.text)));
    }
    for f in &s.faults {
        lines.push((f.at_s, format!("fault {}: {}", f.code, f.reason)));
    }
    lines.sort_by(|a, b| a.0.total_cmp(&b.0));
    for (at_s, text) in lines {
        writeln!(out, "{at_s:>8.2} s  {text}")?;
    }
    Ok(())
}

/// Arguments of `host-sim run`.
#[derive(clap::Args, Debug, Default, Clone)]
pub struct RunArgs {
    /// Scene: a bundled name (cycle, open-loop, faults, two-cycles) or a TOML file.
    #[arg(default_value = "cycle")]
    pub scene: String,
    /// Output folder (default: `runs/<scene name>`).
    #[arg(long)]
    pub out: Option<std::path::PathBuf>,
    /// No progress bar and no summary on standard output.
    #[arg(long)]
    pub quiet: bool,
    /// Play the scene with the board's own ELF (`thermorph-board`, release, thumbv7em) on the
    /// emulated STM32F446 instead of the library's controller (needs a host-sim built with
    /// `--features pil`; docs/pil.md).
    #[arg(long, value_name = "ELF")]
    pub board: Option<std::path::PathBuf>,
}

/// A progress bar on standard error, drawn only on a terminal and only once a run has taken
/// more than a second.
pub struct Progress {
    started: Instant,
    enabled: bool,
    drawn: bool,
    last_pct: i64,
}

impl Progress {
    /// A bar, enabled if `enabled` and standard error is a terminal.
    pub fn new(enabled: bool) -> Self {
        use std::io::IsTerminal;
        Progress {
            started: Instant::now(),
            enabled: enabled && std::io::stderr().is_terminal(),
            drawn: false,
            last_pct: -1,
        }
    }

    /// The bar's text at `fraction` done after `elapsed_s` of wall time.
    pub fn line(fraction: f64, elapsed_s: f64) -> String {
        let f = fraction.clamp(0.0, 1.0);
        let filled = (f * 30.0).round() as usize;
        let eta_s = if f > 0.0 {
            elapsed_s * (1.0 - f) / f
        } else {
            0.0
        };
        format!(
            "[{}{}] {:3.0}%  {:.1} s, about {:.0} s left",
            "#".repeat(filled),
            "-".repeat(30 - filled),
            100.0 * f,
            elapsed_s,
            eta_s
        )
    }

    /// Report `fraction` done.
    pub fn update(&mut self, fraction: f64) {
        if !self.enabled {
            return;
        }
        let elapsed_s = self.started.elapsed().as_secs_f64();
        let pct = (fraction * 100.0) as i64;
        if elapsed_s < 1.0 || pct == self.last_pct {
            return;
        }
        self.last_pct = pct;
        self.drawn = true;
        eprint!("\r{}", Self::line(fraction, elapsed_s));
    }

    /// Finish the bar's line if one was drawn.
    pub fn finish(&mut self) {
        if self.drawn {
            eprintln!();
            self.drawn = false;
        }
    }
}

/// `host-sim run`: load the scene, run it with a progress bar, write the outputs, print the
/// summary. Once `stop` is set (Ctrl-C) the run ends at the end of its period, writing nothing,
/// with [`RunError::Interrupted`]. (`--board ELF` is `runs::elf_run::cli`'s, in a host-sim
/// built with `--features pil`; without it the binary refuses the option.)
pub fn cli(args: &RunArgs, stop: &AtomicBool) -> anyhow::Result<()> {
    let scenario = crate::runs::scenario::load(&args.scene)?;
    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("runs").join(&scenario.name));
    let mut bar = Progress::new(!args.quiet);
    let result = run_until(&scenario, &mut |f| bar.update(f), stop);
    bar.finish();
    let result = match result {
        Err(e @ RunError::Interrupted { .. }) => {
            anyhow::bail!("{e}; nothing written to {}", dir.display())
        }
        r => r?,
    };
    finish(&result, &dir, args.quiet)
}

/// Write a run's outputs into `dir` and, unless `quiet`, print its summary.
pub fn finish(result: &RunResult, dir: &Path, quiet: bool) -> anyhow::Result<()> {
    write_outputs(result, dir)?;
    if !quiet {
        let stdout = std::io::stdout();
        let mut out = stdout.lock();
        print_summary(&result.summary, &mut out)?;
        writeln!(
            out,
            "wrote {0}/timeseries.csv, {0}/summary.json, {0}/plot.png{1}",
            dir.display(),
            if result.log.is_empty() {
                String::new()
            } else {
                format!(", {}/defmt.log", dir.display())
            }
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plant::{Inputs, Observation};

    /// A synthetic run: heat 0–20 s, springs AB 10–40 s (bend rises 3°/s to 60°), form
    /// 40–70 s (the surface falls 1 K/s from 360 K), recover from 70 s (bend falls 2°/s).
    fn rows() -> Vec<Row> {
        (1..=100)
            .map(|k| {
                let t = k as f64;
                let mut inputs = Inputs::default();
                let (heater_k, outer_k) = if t <= 40.0 {
                    (298.0 + 2.5 * t.min(30.0), 298.0 + 2.0 * t.min(31.0))
                } else {
                    (350.0 - (t - 40.0).min(30.0), 360.0 - (t - 40.0).min(30.0))
                };
                inputs.heater_duty = if t <= 40.0 || t > 70.0 { 1.0 } else { 0.0 };
                inputs.fan_duty = if t > 40.0 && t <= 70.0 { 1.0 } else { 0.0 };
                inputs.springs_on = [t > 10.0 && t <= 70.0, t > 10.0 && t <= 70.0, false];
                let bend_deg = if t <= 70.0 {
                    (3.0 * (t - 10.0)).clamp(0.0, 60.0)
                } else {
                    (60.0 - 2.0 * (t - 70.0)).max(0.0)
                };
                let obs = Observation {
                    time_s: t,
                    heater_k,
                    smp_inner_k: outer_k,
                    smp_outer_k: outer_k,
                    duct_air_k: outer_k,
                    ambient_k: 298.0,
                    springs_k: [300.0; 3],
                    austenite: [0.0; 3],
                    frozen_fraction: 0.0,
                    bend_deg,
                    bend_plane_deg: 0.0,
                    k_b_nmm_per_rad: if t <= 40.0 {
                        300.0
                    } else {
                        300.0 + 40.0 * (t - 40.0)
                    },
                    heater_power_w: 0.0,
                    spring_power_w: [0.0; 3],
                    spring_current_a: [0.0; 3],
                    spring_supply_v: [5.0; 3],
                    spring_force_n: [0.0; 3],
                    smp_coldest_k: outer_k,
                    stored_bend_deg: 0.0,
                    film_set_deg: 0.0,
                };
                let truth_k = camera_temps(&obs).regions();
                Row {
                    inputs,
                    springs_cmd: inputs.springs_on,
                    obs,
                    measured_k: Some(truth_k),
                    quality: Some(thermorph::mtts::Quality::Resolved),
                    truth_k,
                    faults: 0,
                    control: None,
                }
            })
            .collect()
    }

    #[test]
    fn the_parallel_csv_text_is_what_write_csv_writes() {
        // 100 s of the default cycle with the camera off: 400 rows (two chunks and a part),
        // the supervisor's and the estimate's columns filled, a command at 60 s.
        let mut scenario = crate::runs::scenario::load("cycle").unwrap();
        scenario.camera.enabled = false;
        scenario.duration_s = 100.0;
        let rows = run(&scenario, &mut |_| {}).unwrap().rows;
        assert_eq!(rows.len(), 400);
        let mut buf = Vec::new();
        write_csv(&rows, &mut buf).unwrap();
        let text = crate::runs::series::csv_text(&rows);
        assert_eq!(text.lines().count(), 401);
        assert_eq!(text, String::from_utf8(buf).unwrap());
    }

    #[test]
    fn figures_find_the_phases() {
        let f = figures(&rows());
        let get = |name: &str| f.iter().find(|x| x.name == name).unwrap().simulated_f64();
        // 298 + 2.5 t ≥ 323 first at t = 10 s.
        assert_eq!(get("standby heat-up"), Some(10.0));
        assert_eq!(get("full loading, two springs"), Some(60.0));
        assert_eq!(get("full loading, one spring"), None);
        // Forming starts with period 41 (start 40 s), but the surface stops falling at 330 K.
        assert_eq!(get("forming"), None);
        assert_eq!(get("formed stiffness"), None);
        // Recovery starts with period 71 (start 70 s); 60 − 2 (t − 70) ≤ 2 first at t = 99 s.
        assert_eq!(get("recovery"), Some(29.0));
    }

    #[test]
    fn figures_of_a_formed_block() {
        let mut rows = rows();
        for r in rows
            .iter_mut()
            .filter(|r| r.obs.time_s > 40.0 && r.obs.time_s <= 70.0)
        {
            r.obs.smp_outer_k = 360.0 - 1.5 * (r.obs.time_s - 40.0);
        }
        let f = figures(&rows);
        let get = |name: &str| f.iter().find(|x| x.name == name).unwrap().simulated_f64();
        // 360 − 1.5 (t − 40) ≤ 323 first at t = 65 s: 25 s after forming started at 40 s.
        assert_eq!(get("forming"), Some(25.0));
        assert_eq!(get("formed stiffness"), Some(300.0 + 40.0 * 25.0));
        // Reported to 0.001.
        let ratio = get("stiffness ratio formed/heated").unwrap();
        assert!((ratio - 1300.0 / 300.0).abs() <= 5e-4, "{ratio}");
        // 60 − 2 (t − 70) ≤ 2 first at t = 99 s: 29 s after recovery started at 70 s.
        assert_eq!(get("recovery"), Some(29.0));
    }
}
