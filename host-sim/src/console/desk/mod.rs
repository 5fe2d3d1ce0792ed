//! The researcher's desk: the host client (`thermorph-desk`) that drives the board's console (or
//! the simulator's, on a pseudo-terminal) over a serial port, records its telemetry, runs
//! experiment scripts and plots the recordings.
//!
//! - [`link`]: one serial line: open, send a command, read lines with a deadline.
//! - [`telemetry`]: telemetry and `status` lines parsed by the library's field names; the CSV.
//! - [`record`]: `record`: the telemetry stream to CSV, through disconnects and resets.
//! - [`script`]: `run`: experiment scripts (commands, waits, assertions).
//! - [`connect`]: `connect`: the interactive console with completion and history.
//! - [`ports`]: `ports`: serial ports with their USB identities.
//!
//! Every read has a deadline, so nothing waits forever on a silent or vanished port. The
//! protocol's names (commands, modes, parameters, telemetry fields) come from the firmware
//! library's tables, never from a copy here.

pub mod connect;
pub mod link;
pub mod ports;
pub mod record;
pub mod script;
pub mod telemetry;
