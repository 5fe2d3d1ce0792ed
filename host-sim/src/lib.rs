//! Thermorph's simulator library: models that stand in for the board's peripherals, laid out by
//! what they are (as `firmware/src/` is by what the firmware does).
//!
//! - [`sensor`]: the virtual sensor — the MLX90640 on a simulated I2C bus, its EEPROM, the
//!   simulated clock.
//! - [`imaging`]: the camera's images on the host — the camera's view (standard scenes and the
//!   randomized family), MTTS on images, work-precision tables, the shared dumps.
//! - [`plant`]: the simulated block: thermal network, SMA springs, SMP lattice, bending.
//! - [`rig`]: the simulated board — plant, camera chain, injected faults and the firmware's
//!   controller, stepped at the board's tick and on every frame and line.
//! - [`runs`]: runs and scenes — scene files, the run loop with the supervisor in it, the
//!   thesis's experiments, plots.
//! - [`console`]: the console — the block behind the board's console, and the researcher's
//!   desk that drives it (or the board).
//! - [`f446`]: the emulated STM32F446's peripherals, register-level models the board's own ELF
//!   runs against (the CPU core, unicorn, only with `--features pil`).
//! - [`cli`]: what the two binaries share: the build's identity (`--version`), shell
//!   completions, Ctrl-C and the exit status (0 done, 1 failure, 2 usage error, 130 Ctrl-C).
//!
//! Errors are typed, one `thiserror` enum per layer, each in the module that owns it:
//! [`runs::scenario::ScenarioError`], [`plant::PlantError`], [`sensor::eeprom::EepromError`]
//! and [`sensor::SensorError`], [`rig::RigError`] (wrapping the plant's and the sensor's),
//! [`runs::plot::PlotError`], [`runs::run::RunError`] (runs and `paper`),
//! [`imaging::SensingError`] (with [`imaging::dump::DumpError`]) and
//! [`console::desk::DeskError`]. Each error's `Display` is the whole message a person reads, its
//! causes' text included; a wrapper adds no text of its own (`#[error(transparent)]`). Only the
//! command entries (`cli`, the `run` of `sensor`, `plant-wp` and `mtts-wp`, `mtts_cli::run` and
//! `scene`) and the binaries' `main`s use `anyhow`, adding a file name or step as context; the
//! binaries print `error: {:#}` ([`cli::exit`]).

pub mod cli;
pub mod console;
pub mod f446;
pub mod imaging;
pub mod plant;
pub mod rig;
pub mod runs;
pub mod sensor;
