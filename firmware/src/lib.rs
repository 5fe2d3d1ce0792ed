//! Thermorph firmware library: every piece of logic the board runs, free of hardware.
//!
//! The library is `no_std`, allocation-free and builds and tests on the host. The board binary
//! (`src/bin/board/`) wires embassy's peripherals to it; `host-sim` wires simulated ones.
//!
//! - [`units`]: physical quantities as newtypes (Kelvin inside, as the thesis).
//! - [`mlx90640`]: the MLX90640 thermal camera — typed registers, calibration extraction, the
//!   Melexis temperature calculation, and an async driver generic over the I2C trait.
//! - [`mtts`]: multi-target thermal sensing — five region temperatures from a frame.
//! - [`observer`]: a Kalman filter of the hidden wall temperatures from the camera's surfaces
//!   (not yet wired into the supervisor).
//! - [`sensing`]: the sensor policy (setup, bus recovery, subpage pairing, frozen and
//!   implausible data) from subpages to one [`measurement::Measurement`] a frame.
//! - [`measurement`]: what sensing hands control, one [`measurement::Measurement`] a frame.
//! - [`posture`]: the column's bend from the camera's axis tilt and a model of the springs.
//! - [`outputs`]: heater and fan duty and the spring gates, the only things a decision drives.
//! - [`block`]: the block's geometry.
//! - [`channels`]: the spring channels' currents and supplies as measured, and their checks.
//! - [`console`]: the line-based serial console protocol: assembling bytes into lines.
//! - [`command`]: the command table and the parser of console lines.
//! - [`settings`]: every tunable parameter (targets, gains, weights, durations, limits).
//! - [`control`]: the control laws: PID, split range, relay autotune.
//! - [`storage`]: the settings record in a NOR flash (sequential-storage), for `save`/`load`.
//! - [`supervisor`]: modes, safety and the fault latch; `Supervisor::step` → `Decision`.
//! - [`app`]: the one owner of a control period ([`app::Controller`]): button, frame, line.
//! - [`fmath`]: the few float functions the target lacks in `core` (square root).
//! - [`decimal`]: decimal text of fractional numbers (`{:.N}`'s text without core's float
//!   formatting).
#![cfg_attr(not(test), no_std)]

pub mod app;
pub mod block;
pub mod channels;
pub mod command;
pub mod console;
pub mod control;
pub mod decimal;
pub mod fmath;
pub mod measurement;
pub mod mlx90640;
pub mod mtts;
pub mod observer;
pub mod outputs;
pub mod posture;
pub mod sensing;
pub mod settings;
pub mod storage;
pub mod supervisor;
pub mod units;

/// Firmware version string shown by the console's `version` command.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// The commit the board's firmware was built from, `b98b8ce 2026-11-29` (short hash, `-dirty`
/// when tracked files differed from it, and its date; `unknown` outside a git checkout): set by
/// `firmware/build.rs` for the board's target only, so the console's `version` answers
/// `ok thermorph 0.1.0 (b98b8ce 2026-11-29)` on the board. `None` on the host: the library is
/// built into every host crate, and a commit would rebuild them all (host-sim's binaries carry
/// their own commit in `--version`).
pub const BUILD: Option<&str> = option_env!("THERMORPH_BUILD");
