//! Runs and scenes: the block played through scenes, with the firmware's supervisor in the loop
//! or timed duties, and what a run writes.
//!
//! - [`scenario`]: scene files (TOML) and the bundled scenes (`host-sim/scenes/`).
//! - [`run`]: `host-sim run`: the run loop over the simulated board, JSON and PNG outputs.
//! - [`series`]: a run's time series (one row a period) and its CSV.
//! - [`cycle_figures`]: the thesis cycle's figures measured on a time series.
//! - [`paper`]: `host-sim paper`, the thesis's experiments against the real supervisor.
//! - `elf_run`, `elf_paper` (`--features pil`): `host-sim run --board ELF` and `host-sim paper
//!   --board ELF`, the board's own ELF on the emulated STM32F446 in the supervisor's place, and
//!   its console replayed line by line.
//! - [`pose`]: `host-sim pose-table`, posture control over targets, springs and ambients.
//! - [`sweep`]: `host-sim sweep`, a scene over a grid of overrides, in parallel.
//! - [`plot`]: the PNG plots (of a run and of a desk recording).
//! - `elf_run` and `defmt_log` (`--features pil`): a scene played by the board's own ELF on the
//!   emulated STM32F446, and its defmt log.

pub mod cycle_figures;
#[cfg(feature = "pil")]
pub mod defmt_log;
#[cfg(feature = "pil")]
pub mod elf_paper;
#[cfg(feature = "pil")]
pub mod elf_run;
pub mod paper;
pub mod plot;
pub mod pose;
pub mod run;
pub mod scenario;
pub mod series;
pub mod sweep;
