//! `host-sim paper --board ELF` (`--features pil`): the thesis's experiments played by the
//! board's own ELF on the emulated STM32F446 instead of the library's supervisor, and the same
//! table built from its runs.
//!
//! Both experiments of [`crate::runs::paper`] are closed loop (power-up in standby, then the
//! console lines of [`Script`]), so every figure comes from the ELF's runs; none is the
//! library's. The script decides from the board's own telemetry (its mode and phase, 4 Hz)
//! at each scene period's start, where the library's reads the supervisor: `mode recover` goes
//! once the telemetry's mode has gone from `form` to `standby`. The camera must be on: the ELF
//! measures through it and has no way to be shown the true temperatures (`--no-camera`).
//! The two experiments run at once, one on each of two threads, each with its own emulated
//! chip (the library's run one after the other).

use std::path::Path;
use std::sync::Mutex;

use crate::runs::elf_run::{ElfRunError, run_elf_with};
use crate::runs::paper::{EXPERIMENTS, Figure, Script, scene, table};
use crate::runs::run::{Progress, RunResult};
use crate::runs::scenario::Scenario;
use crate::runs::series::{ControlRow, Row};

/// Why `paper --board` cannot build its table.
#[derive(Debug, thiserror::Error)]
pub enum ElfPaperError {
    /// `--no-camera` with `--board`.
    #[error(
        "--no-camera: the board's ELF measures through its camera and cannot be shown the true \
         temperatures; leave --no-camera off with --board"
    )]
    NoCamera,
    /// An experiment could not be played.
    #[error(transparent)]
    Run(#[from] ElfRunError),
    /// The scene, or writing the time series.
    #[error(transparent)]
    Table(#[from] crate::runs::run::RunError),
}

/// The full cycle with `springs` in `sc` (from [`scene`]) played by the ELF at `elf` by the
/// [`Script`], the board's state from its telemetry at each scene period's start (`formed`:
/// the last change of the telemetry's mode was `form` → `standby`), as
/// [`crate::runs::paper::play`] plays the library's; returns the run. `progress` gets the
/// fraction done.
pub fn play(
    sc: &Scenario,
    springs: &str,
    elf: &Path,
    progress: &mut dyn FnMut(f64),
) -> Result<RunResult, ElfRunError> {
    let mut script = Script::new(springs);
    let mut mode: Option<&'static str> = None;
    let mut formed = false;
    let mut react = |t: f64, c: &ControlRow| -> Option<String> {
        if let Some(before) = mode.filter(|&m| m != c.mode) {
            formed = before == "form" && c.mode == "standby";
        }
        mode = Some(c.mode);
        script.next(t, c.mode, c.phase, formed)
    };
    run_elf_with(sc, elf, progress, &mut react)
}

/// Both [`EXPERIMENTS`] played by the ELF at `elf` (camera on), one thread each, and the table
/// built from them as [`crate::runs::paper::figures`] builds the library's (with `out`, both
/// time series written there). `progress` gets the fraction done over both.
pub fn figures(
    camera: bool,
    out: Option<&Path>,
    elf: &Path,
    progress: &mut (dyn FnMut(f64) + Send),
) -> Result<Vec<Figure>, ElfPaperError> {
    if !camera {
        return Err(ElfPaperError::NoCamera);
    }
    // A bad ELF is one error, before any thread starts.
    crate::f446::elf::load(elf).map_err(ElfRunError::from)?;
    let scenes = EXPERIMENTS
        .map(|(springs, duration_s)| scene(duration_s, 298.15, true).map(|sc| (springs, sc)));
    let [two, one] = scenes;
    let (two, one) = (
        two.map_err(crate::runs::run::RunError::from)?,
        one.map_err(crate::runs::run::RunError::from)?,
    );
    let total_s: f64 = EXPERIMENTS.iter().map(|e| e.1).sum();
    let done = Mutex::new(([0.0f64; 2], progress));
    let run_one = |i: usize, (springs, sc): &(&str, Scenario)| -> Result<Vec<Row>, ElfRunError> {
        let share = sc.duration_s / total_s;
        let run = play(sc, springs, elf, &mut |f| {
            let mut d = done.lock().unwrap_or_else(|e| e.into_inner());
            d.0[i] = f * share;
            let sum = d.0[0] + d.0[1];
            (d.1)(sum);
        })?;
        Ok(run.rows)
    };
    let (two_rows, one_rows) = std::thread::scope(|s| {
        let a = s.spawn(|| run_one(0, &two));
        let b = s.spawn(|| run_one(1, &one));
        // A panic in an experiment is the run's panic.
        let join = |h: std::thread::ScopedJoinHandle<'_, Result<Vec<Row>, ElfRunError>>| {
            h.join().unwrap_or_else(|p| std::panic::resume_unwind(p))
        };
        (join(a), join(b))
    });
    Ok(table(&two_rows?, &one_rows?, out)?)
}

/// `host-sim paper --board ELF [--json] [--out DIR]`: the table (or the JSON object) from the
/// ELF's runs, as `host-sim paper` prints the library's, under a line saying whose the figures
/// are; a progress bar on a terminal.
pub fn cli(json: bool, camera: bool, out: Option<&Path>, elf: &Path) -> anyhow::Result<()> {
    let mut bar = Progress::new(true);
    let result = figures(camera, out, elf, &mut |f| bar.update(f));
    bar.finish();
    let source = format!(
        "# every figure from the board's ELF {} on the emulated STM32F446 (both experiments \
         are closed loop: none is the library's)",
        elf.display()
    );
    let table = result?;
    crate::runs::paper::print(&table, json, Some(&source))?;
    crate::runs::paper::failures(&table)
}
