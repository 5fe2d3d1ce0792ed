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
//!
//! This module owns the desk's error type, [`DeskError`] (script lines that cannot be read or
//! that fail, recordings that cannot be written, ports that are lost).

pub mod connect;
pub mod link;
pub mod ports;
pub mod record;
pub mod script;
pub mod telemetry;

use std::path::PathBuf;

pub use link::LinkError;

/// Why a desk command failed: a port, a CSV file, a script line.
#[derive(Debug, thiserror::Error)]
pub enum DeskError {
    /// The serial link failed (open, lost, timeout).
    #[error(transparent)]
    Link(#[from] LinkError),
    /// A file (a script, a CSV) cannot be read or written.
    #[error("{}: {err}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// Why.
        err: std::io::Error,
    },
    /// A script file has a line that cannot be read.
    #[error("{}: {err}", path.display())]
    Script {
        /// The script file.
        path: PathBuf,
        /// The line and what is wrong with it ([`DeskError::Line`]).
        err: Box<DeskError>,
    },
    /// A script line cannot be read, or failed when run.
    #[error("line {line}: {err}")]
    Line {
        /// The line, 1-based.
        line: usize,
        /// What is wrong with it.
        err: Box<DeskError>,
    },
    /// A command the library's parser refuses.
    #[error("`{command}`: {message}")]
    Command {
        /// The command.
        command: String,
        /// The parser's message.
        message: String,
    },
    /// Not a number of seconds.
    #[error("`{0}` is not a number of seconds")]
    Seconds(String),
    /// Not a comparison operator.
    #[error("`{0}` is not one of == != < <= > >=")]
    Op(String),
    /// A step with the wrong words; the message says what was expected.
    #[error("expected {0}")]
    Usage(&'static str),
    /// `status` got an error reply.
    #[error("`status` refused: {0}")]
    StatusRefused(String),
    /// `stream on` got an error reply.
    #[error("`stream on` refused: {0}")]
    StreamRefused(String),
    /// `status` lacks the field a condition names.
    #[error("`status` has no field `{field}` (it has: {fields})")]
    NoField {
        /// The field asked for.
        field: String,
        /// The fields it has, space separated.
        fields: String,
    },
    /// A command's reply is not `ok`.
    #[error("`{command}` got `{reply}`")]
    NotOk {
        /// The command.
        command: String,
        /// Its reply.
        reply: String,
    },
    /// An `expect-err` command's reply is not that error.
    #[error("`{command}` got `{reply}`, not `err {code}`")]
    NotErr {
        /// The command.
        command: String,
        /// Its reply.
        reply: String,
        /// The error code expected.
        code: String,
    },
    /// An `expect` condition does not hold.
    #[error("expected {cond}, but {field} = {value}")]
    Expected {
        /// The condition.
        cond: String,
        /// Its field.
        field: String,
        /// The field's value.
        value: String,
    },
    /// A `wait` condition did not hold in time.
    #[error(transparent)]
    WaitTimeout(Box<WaitTimeout>),
    /// Nothing answered the first command: not a Thermorph console.
    #[error("{0}: is this a Thermorph console?")]
    NoConsole(String),
    /// A lost port did not come back in time.
    #[error("{path}: port lost ({why}) and not back within {within_s:.1} s: {last}")]
    NotBack {
        /// The port.
        path: String,
        /// Why it was lost.
        why: LinkError,
        /// How long it was waited for, s.
        within_s: f64,
        /// The last attempt's error.
        last: LinkError,
    },
    /// A port of the lost one's name came back, but nothing answers on it.
    #[error(
        "{path}: port lost and not back within {within_s:.1} s: a port of that name came back, \
         but no Thermorph console answers on it ({detail})"
    )]
    NoAnswer {
        /// The port.
        path: String,
        /// How long it was waited for, s.
        within_s: f64,
        /// The last timeout.
        detail: String,
    },
    /// The interactive console's port was lost.
    #[error("{0}: port lost")]
    PortLost(String),
    /// The line editor failed.
    #[error("line editor: {0}")]
    LineEditor(rustyline::error::ReadlineError),
    /// The serial ports cannot be listed.
    #[error("listing ports: {0}")]
    Ports(serialport::Error),
}

/// A `wait` whose condition did not hold in time, with the last `status` seen.
#[derive(Debug, thiserror::Error)]
#[error(
    "timeout: {cond} did not hold within {within_s:.1} s (last {field} = {value}, mode = {mode}, \
     fault = {fault})"
)]
pub struct WaitTimeout {
    /// The condition.
    pub cond: String,
    /// How long it was waited for, s.
    pub within_s: f64,
    /// Its field.
    pub field: String,
    /// The field's last value.
    pub value: String,
    /// The last mode.
    pub mode: String,
    /// The last fault.
    pub fault: String,
}
