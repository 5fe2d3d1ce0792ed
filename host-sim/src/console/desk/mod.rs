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
    /// Script lines that cannot be read (every one of them, found before anything is sent), or
    /// the line that failed when run: `FILE:LINE: reason` (`line LINE: reason` without a
    /// file), one a line.
    #[error("{}", script_lines(file.as_deref(), lines))]
    Script {
        /// The script file, once known.
        file: Option<PathBuf>,
        /// Each line (1-based) and what is wrong with it.
        lines: Vec<(usize, DeskError)>,
    },
    /// `run`'s SCRIPT is not a file one can read a script from (a device: the arguments are
    /// probably swapped).
    #[error(
        "{}: {what}, not a script file; the port comes first: `thermorph-desk run PORT SCRIPT`",
        path.display()
    )]
    NotAScript {
        /// The path given as SCRIPT.
        path: PathBuf,
        /// What it is instead.
        what: &'static str,
    },
    /// The run was interrupted (Ctrl-C, or the process was asked to end).
    #[error("interrupted (Ctrl-C)")]
    Interrupted,
    /// A recording would overwrite an existing file.
    #[error(
        "{}: the file exists; pass --force to overwrite it (nothing was sent to the board)",
        path.display()
    )]
    Exists {
        /// The file.
        path: PathBuf,
    },
    /// A recording that had begun ended with an error; what it kept is said with it.
    #[error(
        "{err} (kept {rows} rows, {gaps} gaps in {}; {})",
        path.display(),
        if *stream_off { "`stream off` sent" } else { "could not send `stream off`" }
    )]
    RecordingEnded {
        /// Why it ended.
        err: Box<DeskError>,
        /// The CSV.
        path: PathBuf,
        /// Rows written.
        rows: u64,
        /// Gaps marked.
        gaps: u64,
        /// Whether the board acknowledged `stream off`.
        stream_off: bool,
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
    /// `stream off` got no `ok`: the telemetry stream may still be on.
    #[error("`stream off` was not acknowledged: the board may still be streaming telemetry")]
    StreamOffRefused,
    /// `status` lacks the field a condition names.
    #[error(
        "`status` has no field `{field}`{} (it has: {fields})",
        did_you_mean(field, fields)
    )]
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

/// ` (did you mean `x`?)` for the field of `fields` (space separated) closest to `field`, if
/// one is at most two edits away.
fn did_you_mean(field: &str, fields: &str) -> String {
    fields
        .split_whitespace()
        .map(|f| (edits(field, f), f))
        .filter(|(d, _)| *d <= 2)
        .min()
        .map_or(String::new(), |(_, f)| format!(" (did you mean `{f}`?)"))
}

/// The edit distance between `a` and `b` (insertions, deletions, substitutions).
fn edits(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let keep = prev + usize::from(ca != *cb);
            prev = row[j + 1];
            row[j + 1] = keep.min(prev + 1).min(row[j] + 1);
        }
    }
    row[b.len()]
}

/// `FILE:LINE: reason` (or `line LINE: reason`), one a line.
fn script_lines(file: Option<&std::path::Path>, lines: &[(usize, DeskError)]) -> String {
    lines
        .iter()
        .map(|(n, e)| match file {
            Some(f) => format!("{}:{n}: {e}", f.display()),
            None => format!("line {n}: {e}"),
        })
        .collect::<Vec<_>>()
        .join("\n")
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
