//! The console's command set: one table ([`COMMANDS`]) drives parsing, `help` and docs/console.md's
//! list, and [`parse`] turns a line into a typed [`Command`] for `Supervisor::step`.
//!
//! Words are separated by spaces or tabs and are case-insensitive. Parsing checks the shape of
//! each argument (mode names, spring letters, parameter names, numbers, a whole number for a
//! count); the supervisor checks what depends on its state (ranges that involve other
//! settings, a latched fault). A refused argument says what was wrong ([`ArgError`]):
//! `err bad-arguments: unknown mode; one of …` keeps its stable code and names the reason, and
//! an unknown command or parameter name near a known one is answered with it
//! (`did you mean status?`, [`lookup`]).

use core::fmt;

use crate::console::ConsoleError;
use crate::decimal::parse as number;
use crate::outputs::SpringMask;
use crate::settings::PARAMS;
use crate::supervisor::mode::ModeId;

/// Why a line was refused before it reached the supervisor; each has a stable code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum ParseError {
    /// The line exceeded the console's line length.
    LineTooLong,
    /// The line held a byte that is not printable ASCII or TAB.
    BinaryInput,
    /// Bytes of the line were lost on the way in (receive overrun).
    LostBytes,
    /// The first word is not a command (the one it is near enough to suggest, an index into
    /// [`COMMANDS`]).
    UnknownCommand(Option<u8>),
    /// The command's arguments are wrong; the reason says how.
    BadArguments(ArgError),
    /// `get` or `set` named no parameter: the word, and the parameter it is near enough to
    /// suggest (an index into [`PARAMS`]).
    UnknownName(Word, Option<u8>),
    /// Too many commands were waiting for their replies (the board's bound).
    Busy,
}

impl ParseError {
    /// Return the stable code written after `err `.
    pub fn code(self) -> &'static str {
        match self {
            Self::LineTooLong => "line-too-long",
            Self::BinaryInput => "binary-input",
            Self::LostBytes => "lost-bytes",
            Self::UnknownCommand(_) => "unknown-command",
            Self::BadArguments(_) => "bad-arguments",
            Self::UnknownName(..) => "unknown-name",
            Self::Busy => "busy",
        }
    }
}

/// The human message written after `err <code>: ` (the 96 is [`crate::console::MAX_LINE`],
/// checked by a test).
impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::LineTooLong => f.write_str("line longer than 96 bytes, discarded"),
            Self::BinaryInput => f.write_str("line holds non-printable bytes"),
            Self::LostBytes => f.write_str("bytes of this line were lost, line discarded"),
            Self::UnknownCommand(None) => f.write_str("unknown command, try `help`"),
            Self::UnknownCommand(Some(i)) => {
                write!(f, "unknown command; did you mean {}?", command_name(*i))
            }
            Self::BadArguments(why) => write!(f, "{why}"),
            Self::UnknownName(w, near) => {
                write!(f, "unknown parameter {w}")?;
                match near {
                    Some(i) => write!(f, "; did you mean {}?", param_name(*i)),
                    None => f.write_str("; `help set` lists them"),
                }
            }
            Self::Busy => f.write_str("too many commands waiting for replies, line discarded"),
        }
    }
}

/// A word of a refused line, kept for its message: its first [`Word::CAP`] bytes (a longer one
/// is written cut, with `...`), each byte that is not ASCII as `?` (the console's lines are
/// printable ASCII; `parse` may be given any text).
#[derive(Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct Word {
    bytes: [u8; Word::CAP],
    len: u8,
    cut: bool,
}

impl Word {
    /// Most bytes kept.
    pub const CAP: usize = 24;

    /// Keep `w`.
    #[inline(never)]
    pub fn new(w: &str) -> Word {
        let n = w.len().min(Word::CAP);
        let mut bytes = [0; Word::CAP];
        bytes[..n].copy_from_slice(&w.as_bytes()[..n]);
        Word {
            bytes,
            len: n as u8,
            cut: n < w.len(),
        }
    }
}

impl fmt::Display for Word {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for &b in self.bytes.iter().take(usize::from(self.len)) {
            fmt::Write::write_char(f, if b.is_ascii() { char::from(b) } else { '?' })?;
        }
        f.write_str(if self.cut { "..." } else { "" })
    }
}

impl fmt::Debug for Word {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "`{self}`")
    }
}

/// Command `i`'s name (`?` past the table's end).
fn command_name(i: u8) -> &'static str {
    COMMANDS.get(usize::from(i)).map_or("?", |c| c.name)
}

/// Parameter `i`'s name (`?` past the table's end).
fn param_name(i: u8) -> &'static str {
    PARAMS.get(usize::from(i)).map_or("?", |p| p.name)
}

/// What was wrong with a command's arguments (the message of `err bad-arguments`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum ArgError {
    /// The command takes no arguments (its index into [`COMMANDS`]).
    NoneTaken(u8),
    /// More words than the command takes (its index into [`COMMANDS`]).
    TooMany(u8),
    /// `mode` without a mode name.
    NoMode,
    /// `mode` with a word that names no mode.
    UnknownMode,
    /// The springs are not letters of A, B, C.
    UnknownSprings,
    /// Springs given to a mode that does not step.
    SpringsNotTaken,
    /// `set` without a parameter name.
    NoName,
    /// `set NAME` without a value.
    NoValue,
    /// A value that is not a finite number.
    NotANumber,
    /// `set`'s value written with its unit (`360K`, or `358 K` as two words): the text and
    /// the parameter (an index into [`PARAMS`]).
    WithUnit(Word, u8),
    /// A word after `set`'s value that is not its unit.
    Extra(Word),
    /// A count (an index into [`PARAMS`]) set to a value with a fraction.
    NotWhole(u8),
    /// `stream` without `on` or `off`.
    OnOrOff,
    /// `stream off` with a rate.
    RateWithOff,
    /// `mode pose` without an angle in 0–65°, or with a word after it that is neither
    /// springs nor `form`.
    PoseUsage,
}

impl fmt::Display for ArgError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let usage = |f: &mut fmt::Formatter<'_>, i: u8| match COMMANDS.get(i as usize) {
            Some(c) if c.args.is_empty() => write!(f, "`{}` takes no arguments", c.name),
            Some(c) => write!(f, "usage: {} {}", c.name, c.args),
            None => f.write_str("wrong arguments, try `help`"),
        };
        match *self {
            Self::NoneTaken(i) | Self::TooMany(i) => usage(f, i),
            Self::NoMode | Self::UnknownMode => {
                f.write_str(if *self == Self::NoMode {
                    "which mode? one of"
                } else {
                    "unknown mode; one of"
                })?;
                for (i, (name, _)) in mode_names().enumerate() {
                    write!(f, "{}{name}", if i == 0 { " " } else { ", " })?;
                }
                Ok(())
            }
            Self::UnknownSprings => {
                f.write_str("unknown spring; springs are distinct letters of A, B, C (e.g. AB)")
            }
            Self::SpringsNotTaken => {
                f.write_str("springs are for")?;
                let stepping = mode_names().filter(|(_, m)| m.takes_springs());
                for (i, (name, _)) in stepping.enumerate() {
                    write!(f, "{}{name}", if i == 0 { " " } else { " and " })?;
                }
                f.write_str(" only")
            }
            Self::NoName => f.write_str("usage: set NAME VALUE (names: `get`)"),
            Self::NoValue => f.write_str("no value; usage: set NAME VALUE"),
            Self::NotANumber => f.write_str("not a number"),
            Self::WithUnit(w, i) => match PARAMS.get(usize::from(i)) {
                Some(p) if !p.unit.is_empty() => write!(
                    f,
                    "`{w}`: write the number without its unit, the unit is {}",
                    p.unit
                ),
                _ => write!(
                    f,
                    "`{w}`: write the number alone, {} has no unit",
                    param_name(i)
                ),
            },
            Self::Extra(w) => write!(f, "one value expected, extra `{w}`"),
            Self::NotWhole(i) => match PARAMS.get(usize::from(i)) {
                Some(p) => write!(
                    f,
                    "{} takes a whole number, {} to {}",
                    p.name,
                    crate::decimal::Shortest::new(p.min),
                    crate::decimal::Shortest::new(p.max)
                ),
                None => f.write_str("a whole number expected"),
            },
            Self::OnOrOff => f.write_str("usage: stream on|off [HZ]"),
            Self::RateWithOff => f.write_str("`stream off` takes no rate"),
            Self::PoseUsage => {
                f.write_str("usage: mode pose ANGLE [SPRINGS] [form] (ANGLE 0 to 65 degrees)")
            }
        }
    }
}

impl From<ConsoleError> for ParseError {
    fn from(e: ConsoleError) -> Self {
        match e {
            ConsoleError::LineTooLong => ParseError::LineTooLong,
            ConsoleError::BinaryInput => ParseError::BinaryInput,
            ConsoleError::LostBytes => ParseError::LostBytes,
            ConsoleError::Busy => ParseError::Busy,
        }
    }
}

/// Parse what [`LineReader::push`](crate::console::LineReader::push) returned for a complete
/// line: a line the reader refused keeps its reason, a line it accepted is [`parse`]d. This is
/// the one path from bytes to commands, on the board and in the simulator.
pub fn parse_read(line: Result<&str, ConsoleError>) -> Result<Command, ParseError> {
    parse(line?)
}

/// The modes a `mode` command asks for ([`ModeId::requestable`]), with their console names
/// ([`ModeId`]'s one name table), in the order of the thesis's mode numbers.
pub fn mode_names() -> impl Iterator<Item = (&'static str, ModeId)> {
    ModeId::ALL
        .into_iter()
        .filter(|m| m.requestable())
        .map(|m| (m.name(), m))
}

/// A parsed command.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command {
    /// List the commands, or (with an index into [`COMMANDS`]) say what one does.
    Help(Option<u8>),
    /// Show the firmware version.
    Version,
    /// Show mode, temperatures, outputs and faults; `short`: only what a person watches
    /// (mode, phase, target, Tc, outputs, bend, fault).
    Status {
        /// `status short`.
        short: bool,
    },
    /// Enter a mode; the springs for the stepping modes (default: the last used, at first A).
    Mode(ModeId, Option<SpringMask>),
    /// `mode pose ANGLE [SPRINGS] [form]`: bend to `target_deg` with the springs (default: the
    /// last used), forming once reached with `form`.
    Pose {
        /// The target bend, degrees (0–65).
        target_deg: f32,
        /// The springs to bend with.
        springs: Option<SpringMask>,
        /// Form once reached.
        form: bool,
    },
    /// Pause stepping (springs off, timers held).
    Pause,
    /// Resume paused stepping.
    Resume,
    /// Every output off, no mode running, until a `mode` command.
    Stop,
    /// Clear a latched fault whose cause is gone.
    Reset,
    /// Read a parameter (index into [`PARAMS`]), or list them all with `None`.
    Get(Option<u8>),
    /// Write a parameter (index into [`PARAMS`]) in its console unit.
    Set(u8, f32),
    /// Every parameter for a person: one `#` line each with value, unit, default and range.
    Settings,
    /// Tune the PID gains with a relay test.
    Autotune,
    /// Print the event log.
    Log,
    /// Telemetry lines on or off, at a rate in Hz.
    Stream(bool, Option<f32>),
    /// An emergency stop from the console.
    EStop,
    /// Store every parameter (the board in flash, the simulator in a file).
    Save,
    /// Replace every parameter by the stored ones (the defaults if none or a bad record).
    Load,
    /// Every parameter back to its default (in RAM; `save` keeps them).
    Defaults,
}

/// One line of the command table.
pub struct CommandSpec {
    /// The command word.
    pub name: &'static str,
    /// Its arguments, as `help` shows them.
    pub args: &'static str,
    /// What it does.
    pub help: &'static str,
}

/// Every console command, in `help` order.
pub const COMMANDS: &[CommandSpec] = &[
    CommandSpec {
        name: "help",
        args: "[COMMAND]",
        help: "list the commands, or show one's arguments and what it does",
    },
    CommandSpec {
        name: "version",
        args: "",
        help: "firmware version",
    },
    CommandSpec {
        name: "status",
        args: "[short]",
        help: "mode, temperatures, outputs, fault; short: mode, Tc, outputs, bend, fault",
    },
    CommandSpec {
        name: "mode",
        args: "standby|step-small|step-large|form|recover [SPRINGS] | pose ANGLE [SPRINGS] [form]",
        help: "enter a mode; SPRINGS: letters of A, B, C for stepping and pose",
    },
    CommandSpec {
        name: "pause",
        args: "",
        help: "pause a spring phase of stepping (springs off, timer held)",
    },
    CommandSpec {
        name: "resume",
        args: "",
        help: "resume paused stepping",
    },
    CommandSpec {
        name: "stop",
        args: "",
        help: "every output off until the next mode (any state)",
    },
    CommandSpec {
        name: "reset",
        args: "",
        help: "clear a fault whose cause is gone; then stopped",
    },
    CommandSpec {
        name: "get",
        args: "[NAME]",
        help: "read one parameter, or all",
    },
    CommandSpec {
        name: "set",
        args: "NAME VALUE",
        help: "write a parameter, the number alone in its unit (settings shows them)",
    },
    CommandSpec {
        name: "settings",
        args: "",
        help: "one # line a parameter: value, unit, default, range; * where not the default",
    },
    CommandSpec {
        name: "autotune",
        args: "",
        help: "relay autotune of the PID gains",
    },
    CommandSpec {
        name: "log",
        args: "",
        help: "recent mode changes and faults",
    },
    CommandSpec {
        name: "stream",
        args: "on|off [HZ]",
        help: "telemetry lines starting with #, HZ up to 10 (default 4)",
    },
    CommandSpec {
        name: "estop",
        args: "",
        help: "emergency stop, every output off; latched until `reset` with the button released",
    },
    CommandSpec {
        name: "save",
        args: "",
        help: "store every parameter (survives a reset)",
    },
    CommandSpec {
        name: "load",
        args: "",
        help: "read the stored parameters (defaults if none)",
    },
    CommandSpec {
        name: "defaults",
        args: "",
        help: "every parameter to its default (save to keep)",
    },
];

/// `mode pose`'s arguments after `pose`: ANGLE [SPRINGS] [form].
fn parse_pose<'a>(mut words: impl Iterator<Item = &'a str>) -> Result<Command, ParseError> {
    let bad = ParseError::BadArguments(ArgError::PoseUsage);
    let target_deg = words
        .next()
        .and_then(number)
        .filter(|v| (0.0..=crate::supervisor::pose::MAX_TARGET_DEG).contains(v))
        .ok_or(bad)?;
    let (mut springs, mut form) = (None, false);
    for w in words {
        if !form && w.eq_ignore_ascii_case("form") {
            form = true;
        } else if springs.is_none() && !form {
            springs = Some(SpringMask::parse(w).ok_or(bad)?);
        } else {
            return Err(bad);
        }
    }
    Ok(Command::Pose {
        target_deg,
        springs,
        form,
    })
}

/// Whether `a` becomes `b` (case-insensitive) in at most `k` edits: a letter inserted,
/// deleted or replaced, or two neighbours swapped (the optimal string alignment distance).
/// Recursive, at most `k` deep (the console asks for 2 at most): no allocation, no table.
#[inline(never)]
fn within(a: &[u8], b: &[u8], k: u8) -> bool {
    let same = |i: usize, j: usize| match (a.get(i), b.get(j)) {
        (Some(x), Some(y)) => x.eq_ignore_ascii_case(y),
        _ => false,
    };
    let mut i = 0;
    while same(i, i) {
        i += 1;
    }
    let (left_a, left_b) = (a.len().saturating_sub(i), b.len().saturating_sub(i));
    if left_a == 0 || left_b == 0 {
        return left_a.max(left_b) <= usize::from(k);
    }
    if k == 0 {
        return false;
    }
    let (a0, b0) = (
        a.get(i..).unwrap_or_default(),
        b.get(i..).unwrap_or_default(),
    );
    let (a1, b1) = (
        a0.get(1..).unwrap_or_default(),
        b0.get(1..).unwrap_or_default(),
    );
    let (a2, b2) = (
        a1.get(1..).unwrap_or_default(),
        b1.get(1..).unwrap_or_default(),
    );
    // a[i] deleted, b[i] inserted, a[i] replaced, or a[i] and a[i + 1] swapped.
    within(a1, b0, k - 1)
        || within(a0, b1, k - 1)
        || within(a1, b1, k - 1)
        || (same(i, i + 1) && same(i + 1, i) && within(a2, b2, k - 1))
}

/// Where `word` is among the names `name(0)`, `name(1)`, … (case-insensitive): `Ok` with its
/// index, or `Err` with the index of the closest name if one is near enough to suggest — one
/// edit away (a letter wrong, missing, extra, or two neighbours swapped) for a word of up to
/// four letters, two for a longer one; the first in table order among equals. (The desk's own
/// did-you-mean allows two edits for any word; the console's commands are short.)
#[inline(never)]
pub fn lookup(word: &str, name: &dyn Fn(usize) -> Option<&'static str>) -> Result<u8, Option<u8>> {
    let limit = if word.len() <= 4 { 1 } else { 2 };
    for k in 0..=limit {
        let mut i = 0;
        while let Some(n) = name(i) {
            if within(word.as_bytes(), n.as_bytes(), k) {
                return if k == 0 {
                    Ok(i as u8)
                } else {
                    Err(Some(i as u8))
                };
            }
            i += 1;
        }
    }
    Err(None)
}

/// The command called `word`.
fn command_index(word: &str) -> Result<u8, ParseError> {
    lookup(word, &|i| COMMANDS.get(i).map(|c| c.name)).map_err(ParseError::UnknownCommand)
}

/// `set NAME WORD`'s refusal when WORD is not a number: a number with its unit stuck to it
/// (`360K`, `12.5%`) says so, anything else is not a number.
fn not_a_number(word: &str, param: u8) -> ArgError {
    let b = word.as_bytes();
    let n = b
        .iter()
        .rposition(|c| c.is_ascii_digit() || *c == b'.')
        .map_or(0, |i| i + 1);
    if n > 0 && n < b.len() && crate::decimal::parse_bytes(&b[..n]).is_some() {
        ArgError::WithUnit(Word::new(word), param)
    } else {
        ArgError::NotANumber
    }
}

/// Parse one line (without its end).
pub fn parse(line: &str) -> Result<Command, ParseError> {
    let mut words = line.split([' ', '\t']).filter(|w| !w.is_empty());
    let verb = words.next().ok_or(ParseError::UnknownCommand(None))?;
    let index = command_index(verb)?;
    let spec = &COMMANDS[usize::from(index)];
    let bad = ParseError::BadArguments;
    let a = words.next();
    if spec.name == "mode" && a.is_some_and(|w| w.eq_ignore_ascii_case("pose")) {
        return parse_pose(words);
    }
    let b = words.next();
    let c = words.next();
    if c.is_some() && spec.name != "set" {
        return Err(bad(ArgError::TooMany(index)));
    }
    let none = |cmd: Command| match (a, b) {
        (None, None) => Ok(cmd),
        _ => Err(bad(ArgError::NoneTaken(index))),
    };
    match spec.name {
        "help" => match (a, b) {
            (None, None) => Ok(Command::Help(None)),
            (Some(word), None) => Ok(Command::Help(Some(command_index(word)?))),
            _ => Err(bad(ArgError::TooMany(index))),
        },
        "version" => none(Command::Version),
        "status" => match (a, b) {
            (None, _) => Ok(Command::Status { short: false }),
            (Some(w), None) if w.eq_ignore_ascii_case("short") => {
                Ok(Command::Status { short: true })
            }
            _ => Err(bad(ArgError::TooMany(index))),
        },
        "pause" => none(Command::Pause),
        "resume" => none(Command::Resume),
        "stop" => none(Command::Stop),
        "reset" => none(Command::Reset),
        "autotune" => none(Command::Autotune),
        "log" => none(Command::Log),
        "estop" => none(Command::EStop),
        "save" => none(Command::Save),
        "load" => none(Command::Load),
        "defaults" => none(Command::Defaults),
        "settings" => none(Command::Settings),
        "mode" => {
            let name = a.ok_or(bad(ArgError::NoMode))?;
            let mode = lookup(name, &|i| mode_names().nth(i).map(|(n, _)| n))
                .ok()
                .and_then(|i| mode_names().nth(usize::from(i)))
                .ok_or(bad(ArgError::UnknownMode))?
                .1;
            let springs = match b {
                None => None,
                Some(w) => Some(SpringMask::parse(w).ok_or(bad(ArgError::UnknownSprings))?),
            };
            if springs.is_some() && !mode.takes_springs() {
                return Err(bad(ArgError::SpringsNotTaken));
            }
            Ok(Command::Mode(mode, springs))
        }
        "get" => match (a, b) {
            (None, None) => Ok(Command::Get(None)),
            (Some(n), None) => Ok(Command::Get(Some(param_index(n)?))),
            _ => Err(bad(ArgError::TooMany(index))),
        },
        "set" => {
            let i = param_index(a.ok_or(bad(ArgError::NoName))?)?;
            let p = &PARAMS[usize::from(i)];
            let w = b.ok_or(bad(ArgError::NoValue))?;
            let v = number(w);
            match c {
                // `358 K`: the value and its unit, as two words.
                Some(unit) if v.is_some() && unit.eq_ignore_ascii_case(p.unit) => {
                    let start = w.as_ptr() as usize - line.as_ptr() as usize;
                    let end = unit.as_ptr() as usize - line.as_ptr() as usize + unit.len();
                    let both = line.get(start..end).unwrap_or(w);
                    Err(bad(ArgError::WithUnit(Word::new(both), i)))
                }
                Some(extra) => Err(bad(ArgError::Extra(Word::new(extra)))),
                None => match v {
                    None => Err(bad(not_a_number(w, i))),
                    Some(v) if p.integer && v != libm::roundf(v) => Err(bad(ArgError::NotWhole(i))),
                    Some(v) => Ok(Command::Set(i, v)),
                },
            }
        }
        "stream" => {
            let on = match a {
                Some(w) if w.eq_ignore_ascii_case("on") => true,
                Some(w) if w.eq_ignore_ascii_case("off") => false,
                _ => return Err(bad(ArgError::OnOrOff)),
            };
            let hz = match b {
                None => None,
                Some(w) if on => Some(number(w).ok_or(bad(ArgError::NotANumber))?),
                Some(_) => return Err(bad(ArgError::RateWithOff)),
            };
            Ok(Command::Stream(on, hz))
        }
        _ => Err(ParseError::UnknownCommand(None)),
    }
}

/// The parameter called `name`.
fn param_index(name: &str) -> Result<u8, ParseError> {
    lookup(name, &|i| PARAMS.get(i).map(|p| p.name))
        .map_err(|near| ParseError::UnknownName(Word::new(name), near))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_what_core_parses() {
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        for _ in 0..200_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let v = f32::from_bits(x as u32);
            if !v.is_finite() {
                continue;
            }
            let small = (x >> 40) as f32 / 1000.0 - 5000.0;
            for text in [
                std::format!("{v}"),
                std::format!("{v:e}"),
                std::format!("{small:.3}"),
                std::format!("{small}"),
            ] {
                let want: f32 = text.parse().unwrap();
                assert_eq!(number(&text), Some(want), "{text}");
            }
        }
        for (text, want) in [
            ("357.5", Some(357.5)),
            ("+2", Some(2.0)),
            ("-0.25", Some(-0.25)),
            (".5", Some(0.5)),
            ("5.", Some(5.0)),
            ("1E3", Some(1000.0)),
            ("2.5e-3", Some(0.0025)),
            ("0.1399999999999999999999", Some(0.14)),
            ("1e39", None),
            ("-1e39", None),
            ("inf", None),
            ("nan", None),
            ("", None),
            ("-", None),
            (".", None),
            ("e5", None),
            ("1e", None),
            ("1e+", None),
            ("1.2.3", None),
            ("12K", None),
            ("1_000", None),
            ("0x10", None),
        ] {
            assert_eq!(number(text), want, "{text:?}");
        }
    }

    #[test]
    fn every_table_command_parses_with_its_arguments() {
        for c in COMMANDS {
            let line = match c.name {
                "mode" => "mode step-large AB",
                "get" => "get hot_k",
                "set" => "set hot_k 357.5",
                "stream" => "stream on 4",
                n => n,
            };
            assert!(parse(line).is_ok(), "{line}");
        }
    }

    #[test]
    fn modes_springs_and_numbers() {
        assert_eq!(
            parse("MODE Step-Large ba"),
            Ok(Command::Mode(ModeId::StepLarge, SpringMask::parse("AB")))
        );
        assert_eq!(
            parse("mode standby"),
            Ok(Command::Mode(ModeId::Standby, None))
        );
        let bad = |why| Err(ParseError::BadArguments(why));
        assert_eq!(parse("mode form A"), bad(ArgError::SpringsNotTaken));
        assert_eq!(parse("mode step-small ABD"), bad(ArgError::UnknownSprings));
        assert_eq!(parse("mode fly"), bad(ArgError::UnknownMode));
        assert_eq!(
            parse("mode pose 30 BC form"),
            Ok(Command::Pose {
                target_deg: 30.0,
                springs: SpringMask::parse("BC"),
                form: true
            })
        );
        assert_eq!(
            parse("MODE POSE 12.5"),
            Ok(Command::Pose {
                target_deg: 12.5,
                springs: None,
                form: false
            })
        );
        for line in [
            "mode pose",
            "mode pose 70",
            "mode pose -1",
            "mode pose x",
            "mode pose 30 AD",
            "mode pose 30 form A",
            "mode pose 30 A B",
        ] {
            assert_eq!(parse(line), bad(ArgError::PoseUsage), "{line}");
        }
        assert_eq!(parse("mode"), bad(ArgError::NoMode));
        assert_eq!(parse("set hot_k nan"), bad(ArgError::NotANumber));
        assert_eq!(parse("set hot_k inf"), bad(ArgError::NotANumber));
        assert_eq!(parse("set hot_k"), bad(ArgError::NoValue));
        assert_eq!(parse("set"), bad(ArgError::NoName));
        let hot_k = param_index("hot_k").unwrap();
        assert_eq!(
            parse("set hot_k 358 K"),
            bad(ArgError::WithUnit(Word::new("358 K"), hot_k))
        );
        assert_eq!(
            parse("set hot_k 360K"),
            bad(ArgError::WithUnit(Word::new("360K"), hot_k))
        );
        assert_eq!(
            parse("set hot_k 360 extra"),
            bad(ArgError::Extra(Word::new("extra")))
        );
        assert_eq!(
            parse("set nope 1"),
            Err(ParseError::UnknownName(Word::new("nope"), None))
        );
        assert_eq!(parse("get"), Ok(Command::Get(None)));
        assert_eq!(parse("stream off 3"), bad(ArgError::RateWithOff));
        assert_eq!(parse("stream"), bad(ArgError::OnOrOff));
        assert_eq!(parse("stream on"), Ok(Command::Stream(true, None)));
        let status = COMMANDS.iter().position(|c| c.name == "status").unwrap() as u8;
        assert_eq!(parse("status now"), bad(ArgError::TooMany(status)));
        assert_eq!(parse("frobnicate"), Err(ParseError::UnknownCommand(None)));
        assert_eq!(parse("SAVE"), Ok(Command::Save));
        assert_eq!(parse("defaults"), Ok(Command::Defaults));
    }

    /// Each refused argument's message, as `err bad-arguments: …` writes it.
    #[test]
    fn bad_arguments_say_what_was_wrong() {
        let said = |line: &str| std::format!("{}", parse(line).unwrap_err());
        assert_eq!(
            said("mode fly"),
            "unknown mode; one of standby, step-small, step-large, form, recover, pose"
        );
        assert_eq!(
            said("mode step-large D"),
            "unknown spring; springs are distinct letters of A, B, C (e.g. AB)"
        );
        assert_eq!(
            said("mode form AB"),
            "springs are for step-small and step-large and pose only"
        );
        assert_eq!(said("set hot_k abc"), "not a number");
        // Issue 44: what was wrong, with a hint.
        assert_eq!(
            said("set hot_k 358 K"),
            "`358 K`: write the number without its unit, the unit is K"
        );
        assert_eq!(
            said("set hot_k 360K"),
            "`360K`: write the number without its unit, the unit is K"
        );
        assert_eq!(
            said("set spring_duty_max_pct 50%"),
            "`50%`: write the number without its unit, the unit is %"
        );
        assert_eq!(
            said("set large_steps 4x"),
            "`4x`: write the number alone, large_steps has no unit"
        );
        assert_eq!(
            said("set hot_k 360 extra"),
            "one value expected, extra `extra`"
        );
        assert_eq!(
            said("set large_steps 2.5"),
            "large_steps takes a whole number, 1 to 10"
        );
        assert_eq!(
            said("set ki 1e-3 1/(k*s)"),
            "`1e-3 1/(k*s)`: write the number without its unit, the unit is 1/(K*s)"
        );
        assert_eq!(
            said("set hot_k 1e"),
            "`1e`: write the number without its unit, the unit is K"
        );
        assert_eq!(said("set hot_k 0x10"), "not a number");
        assert_eq!(said("set hot_k K"), "not a number");
        assert_eq!(
            said("set hot_k 360 an-extra-word-of-forty-bytes-or-so"),
            "one value expected, extra `an-extra-word-of-forty-b...`"
        );
        assert_eq!(said("status now"), "usage: status [short]");
        assert_eq!(said("version now"), "`version` takes no arguments");
        assert_eq!(said("get a b"), "usage: get [NAME]");
        assert_eq!(said("stream maybe"), "usage: stream on|off [HZ]");
        assert_eq!(said("load now"), "`load` takes no arguments");
        assert_eq!(said("set hot_k b c"), "one value expected, extra `c`");
        assert_eq!(
            said("set a b c"),
            "unknown parameter a; `help set` lists them"
        );
        // Every message fits a reply with room to spare.
        for line in [
            "mode",
            "mode fly",
            "set",
            "set hot_k",
            "stream off 2",
            "help a b",
        ] {
            let m = said(line);
            assert!(!m.is_empty() && m.len() < 120, "{line}: {m}");
        }
    }

    /// Issue 44: an unknown command or parameter near a known one names it.
    #[test]
    fn did_you_mean() {
        let said = |line: &str| std::format!("{}", parse(line).unwrap_err());
        assert_eq!(said("stauts"), "unknown command; did you mean status?");
        assert_eq!(said("STAUTS"), "unknown command; did you mean status?");
        assert_eq!(said("hlep"), "unknown command; did you mean help?");
        assert_eq!(said("stpo"), "unknown command; did you mean stop?");
        assert_eq!(said("defualts"), "unknown command; did you mean defaults?");
        assert_eq!(said("autotun"), "unknown command; did you mean autotune?");
        assert_eq!(said("help stram"), "unknown command; did you mean stream?");
        assert_eq!(
            said("set hotk 360"),
            "unknown parameter hotk; did you mean hot_k?"
        );
        assert_eq!(
            said("get Hot-K"),
            "unknown parameter Hot-K; did you mean hot_k?"
        );
        assert_eq!(
            said("set stepp_s 3"),
            "unknown parameter stepp_s; did you mean step_s?"
        );
        assert_eq!(
            said("get sma_as"),
            "unknown parameter sma_as; did you mean sma_as_k?"
        );
        // Too far from every name: no guess.
        for (line, want) in [
            ("frobnicate", "unknown command, try `help`"),
            ("fly", "unknown command, try `help`"),
            ("xy", "unknown command, try `help`"),
            (
                "get temperature",
                "unknown parameter temperature; `help set` lists them",
            ),
        ] {
            assert_eq!(said(line), want, "{line}");
        }
        // The rule: one edit for a word of up to four letters, two beyond; a swap is one.
        let distance = |a: &str, b: &str| (0..9).find(|&k| within(a.as_bytes(), b.as_bytes(), k));
        assert_eq!(distance("stauts", "status"), Some(1));
        assert_eq!(distance("status", "STATUS"), Some(0));
        assert_eq!(distance("sttus", "status"), Some(1));
        assert_eq!(distance("kitten", "sitting"), Some(3));
        assert_eq!(distance("ab", "abcdef"), Some(4));
        assert_eq!(distance("ca", "abc"), Some(3));
        assert_eq!(distance("", ""), Some(0));
        let two = |i: usize| ["log", "load"].get(i).copied();
        assert_eq!(lookup("lgo", &two), Err(Some(0)));
        assert_eq!(lookup("lod", &two), Err(Some(0)));
        assert_eq!(lookup("LOAD", &two), Ok(1));
        assert_eq!(lookup("lo", &two), Err(Some(0)));
        assert_eq!(lookup("x", &two), Err(None));
        // Every name is found as itself, whatever its case.
        for (i, c) in COMMANDS.iter().enumerate() {
            assert_eq!(command_index(&c.name.to_ascii_uppercase()), Ok(i as u8));
        }
        for (i, p) in PARAMS.iter().enumerate() {
            assert_eq!(param_index(p.name), Ok(i as u8));
        }
    }

    #[test]
    fn reader_refusals_keep_their_reason() {
        assert_eq!(
            parse_read(Err(ConsoleError::LineTooLong)),
            Err(ParseError::LineTooLong)
        );
        assert_eq!(
            parse_read(Err(ConsoleError::BinaryInput)),
            Err(ParseError::BinaryInput)
        );
        assert_eq!(
            parse_read(Ok("status")),
            Ok(Command::Status { short: false })
        );
        assert_eq!(
            parse_read(Ok("STATUS Short")),
            Ok(Command::Status { short: true })
        );
    }
}
