//! The serial console protocol: line assembly, command parsing and one-line replies.
//!
//! Line-based ASCII, 115200 8N1 on the board and byte for byte the same in the simulator
//! (SPEC section 6). One command per line, ended by CR, LF or CR LF; every command gets exactly
//! one reply line, `ok …` or `err <code>: <message>`, ended by CR LF. An empty (or blank) line
//! gets no reply. A line longer than [`MAX_LINE`] bytes is discarded up to its end and answered
//! with one `err line-too-long`; a line holding bytes other than printable ASCII and TAB is
//! answered `err binary-input`; neither loses the command on the following line. Asynchronous lines
//! (telemetry, events) will start with `#`, so a program can tell them from replies.
//!
//! Commands so far: `help`, `version`, `status`. Words are case-insensitive and separated by
//! spaces or tabs.

use core::fmt::{self, Write};

use crate::mlx90640::{self, ImageStats};
use crate::mtts::{MttsError, REGIONS};
use crate::units::Kelvin;

/// Longest accepted line, bytes (without its end).
pub const MAX_LINE: usize = 96;

/// Why a line got `err`; each has a stable short code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum ConsoleError {
    /// The line exceeded [`MAX_LINE`] bytes.
    LineTooLong,
    /// The line held a byte that is not printable ASCII or TAB.
    BinaryInput,
    /// Bytes of the line were lost on the way in (receive overrun or a full buffer).
    LostBytes,
    /// Too many commands were waiting for their replies: the line was not run.
    Busy,
    /// The first word is not a command.
    UnknownCommand,
    /// The command's arguments are wrong.
    BadArguments,
}

impl ConsoleError {
    /// Return the stable code written after `err `.
    pub fn code(self) -> &'static str {
        match self {
            Self::LineTooLong => "line-too-long",
            Self::BinaryInput => "binary-input",
            Self::LostBytes => "lost-bytes",
            Self::Busy => "busy",
            Self::UnknownCommand => "unknown-command",
            Self::BadArguments => "bad-arguments",
        }
    }

    /// Return the human message.
    pub fn message(self) -> &'static str {
        match self {
            Self::LineTooLong => "line longer than 96 bytes discarded",
            Self::BinaryInput => "line holds non-printable bytes",
            Self::LostBytes => "bytes of this line were lost on input, line discarded",
            Self::Busy => "too many commands waiting for replies, line discarded",
            Self::UnknownCommand => "unknown command, try `help`",
            Self::BadArguments => "wrong arguments, try `help`",
        }
    }
}

/// Assembles bytes into lines.
///
/// Backspace (0x08) and DEL (0x7F) erase the last byte stored, so a person typing at a
/// terminal can correct a line; on an empty line they do nothing. They cannot undo a byte
/// that made the line binary or overlong. [`LineReader::mark_lost`] tells the reader that
/// input bytes were lost (a receive overrun or a full buffer): the line they belonged to is
/// answered `err lost-bytes` instead of being run with bytes missing. If the lost bytes held a
/// line end, the two lines merge into that one `err`.
#[derive(Debug)]
pub struct LineReader<const N: usize = MAX_LINE> {
    buf: [u8; N],
    len: usize,
    overflow: bool,
    binary: bool,
    lost: bool,
    after_cr: bool,
    done: bool,
}

impl<const N: usize> Default for LineReader<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> LineReader<N> {
    /// Make an empty reader.
    pub const fn new() -> Self {
        LineReader {
            buf: [0; N],
            len: 0,
            overflow: false,
            binary: false,
            lost: false,
            after_cr: false,
            done: false,
        }
    }

    fn clear(&mut self) {
        self.len = 0;
        self.overflow = false;
        self.binary = false;
        self.lost = false;
        self.done = false;
    }

    /// Record that input bytes were lost before the next byte pushed: the line being
    /// assembled (or, between lines, the next one) ends in `err lost-bytes`.
    pub fn mark_lost(&mut self) {
        if self.done {
            self.clear();
        }
        self.lost = true;
        self.after_cr = false;
    }

    /// Feed one byte; return a complete line (or why it is refused) when `byte` ends one.
    /// Empty and blank lines return `None` (unless bytes of them were lost).
    pub fn push(&mut self, byte: u8) -> Option<Result<&str, ConsoleError>> {
        if self.done {
            self.clear();
        }
        let after_cr = core::mem::replace(&mut self.after_cr, byte == b'\r');
        match byte {
            b'\n' if after_cr => None,
            b'\r' | b'\n' => {
                self.done = true;
                if self.lost {
                    Some(Err(ConsoleError::LostBytes))
                } else if self.overflow {
                    Some(Err(ConsoleError::LineTooLong))
                } else if self.binary {
                    Some(Err(ConsoleError::BinaryInput))
                } else if self.buf[..self.len]
                    .iter()
                    .all(|&b| b == b' ' || b == b'\t')
                {
                    None
                } else {
                    // Only printable ASCII and TAB were stored, so this is valid UTF-8.
                    Some(
                        core::str::from_utf8(&self.buf[..self.len])
                            .map_err(|_| ConsoleError::BinaryInput),
                    )
                }
            }
            0x08 | 0x7F => {
                if !self.overflow {
                    self.len = self.len.saturating_sub(1);
                }
                None
            }
            _ => {
                if !(byte == b'\t' || (0x20..0x7F).contains(&byte)) {
                    self.binary = true;
                } else if self.len < N {
                    self.buf[self.len] = byte;
                    self.len += 1;
                } else {
                    self.overflow = true;
                }
                None
            }
        }
    }
}

/// A parsed command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum Command {
    /// List the commands.
    Help,
    /// Show the firmware version.
    Version,
    /// Show the sensor status.
    Status,
}

/// Parse one line (without its end).
pub fn parse(line: &str) -> Result<Command, ConsoleError> {
    let mut words = line.split([' ', '\t']).filter(|w| !w.is_empty());
    let Some(verb) = words.next() else {
        return Err(ConsoleError::UnknownCommand);
    };
    let cmd = if verb.eq_ignore_ascii_case("help") {
        Command::Help
    } else if verb.eq_ignore_ascii_case("version") {
        Command::Version
    } else if verb.eq_ignore_ascii_case("status") {
        Command::Status
    } else {
        return Err(ConsoleError::UnknownCommand);
    };
    if words.next().is_some() {
        return Err(ConsoleError::BadArguments);
    }
    Ok(cmd)
}

/// The sensor chain's latest error.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum SensorError {
    /// From the MLX90640 driver or calculation.
    Driver(mlx90640::Error),
    /// From MTTS.
    Mtts(MttsError),
    /// From the sensing pipeline.
    Sensing(crate::sensing::SensingError),
}

impl fmt::Display for SensorError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Driver(e) => write!(f, "{e}"),
            Self::Mtts(e) => write!(f, "{e}"),
            Self::Sensing(e) => write!(f, "{e}"),
        }
    }
}

/// What `status` reports: plain data the board (or the simulator) fills.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Status {
    /// Sensor temperature of the last subpage.
    pub ta: Option<Kelvin>,
    /// Sensor supply of the last subpage, V.
    pub vdd_v: Option<f32>,
    /// Subpages decoded since boot.
    pub frames: u32,
    /// Min/mean/max of the last image.
    pub image: Option<ImageStats>,
    /// The five region temperatures of the last frame.
    pub regions: Option<[Kelvin; REGIONS]>,
    /// The latest sensor error, if the last attempt failed.
    pub sensor_error: Option<SensorError>,
    /// Sensor errors since boot.
    pub sensor_errors: u32,
    /// The emergency stop is latched.
    pub estop: bool,
}

/// Write the reply to a command: exactly one line ending in CR LF.
pub fn respond(cmd: Command, status: &Status, out: &mut impl Write) -> fmt::Result {
    match cmd {
        Command::Help => out.write_str("ok commands: help, version, status")?,
        Command::Version => write!(out, "ok thermorph {}", crate::VERSION)?,
        Command::Status => write_status(status, out)?,
    }
    out.write_str("\r\n")
}

/// Write the `err` reply for a refused line: one line ending in CR LF.
pub fn respond_error(e: ConsoleError, out: &mut impl Write) -> fmt::Result {
    write!(out, "err {}: {}\r\n", e.code(), e.message())
}

fn write_opt_k(out: &mut impl Write, name: &str, v: Option<Kelvin>) -> fmt::Result {
    match v {
        Some(t) if t.k().is_finite() => write!(out, " {name}={:.2}", t.k()),
        _ => write!(out, " {name}=-"),
    }
}

fn write_status(s: &Status, out: &mut impl Write) -> fmt::Result {
    out.write_str("ok")?;
    write_opt_k(out, "ta_k", s.ta)?;
    match s.vdd_v {
        Some(v) => write!(out, " vdd_v={v:.3}")?,
        None => out.write_str(" vdd_v=-")?,
    }
    write!(out, " frames={}", s.frames)?;
    write_opt_k(out, "min_k", s.image.map(|i| i.min))?;
    write_opt_k(out, "mean_k", s.image.map(|i| i.mean))?;
    write_opt_k(out, "max_k", s.image.map(|i| i.max))?;
    for r in 0..REGIONS {
        let mut name = [b't', b'0' + r as u8 + 1, b'_', b'k'];
        let name = core::str::from_utf8_mut(&mut name).map_err(|_| fmt::Error)?;
        write_opt_k(out, name, s.regions.map(|t| t[r]))?;
    }
    write!(out, " errors={} estop={}", s.sensor_errors, s.estop as u8)?;
    match s.sensor_error {
        Some(e) => write!(out, " sensor_error=\"{e}\""),
        None => out.write_str(" sensor_error=none"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::string::String;
    use std::vec::Vec;

    /// Feed bytes, collect the reply of every line as a console would.
    fn session(input: &[u8], status: &Status) -> Vec<String> {
        let mut r: LineReader = LineReader::new();
        let mut replies = Vec::new();
        for &b in input {
            if let Some(line) = r.push(b) {
                let mut out = String::new();
                match line.and_then(parse) {
                    Ok(cmd) => respond(cmd, status, &mut out).unwrap(),
                    Err(e) => respond_error(e, &mut out).unwrap(),
                }
                assert!(out.ends_with("\r\n") && out.matches("\r\n").count() == 1);
                replies.push(out.trim_end().into());
            }
        }
        replies
    }

    #[test]
    fn commands_and_line_ends() {
        let s = Status::default();
        let r = session(b"help\r\nversion\nSTATUS\r\r\n\n", &s);
        assert_eq!(r.len(), 3, "{r:?}");
        assert!(r[0].starts_with("ok commands"));
        assert_eq!(r[1], std::format!("ok thermorph {}", crate::VERSION));
        assert!(r[2].starts_with("ok ta_k=- vdd_v=- frames=0"));
    }

    #[test]
    fn errors_do_not_lose_the_next_command() {
        let s = Status::default();
        let mut input = Vec::new();
        input.extend_from_slice(b"frobnicate\n");
        input.extend_from_slice(b"help me\n");
        input.extend(core::iter::repeat_n(b'x', 300));
        input.extend_from_slice(b"\nver\x00sion\n\xff\xfe\nversion\n   \n\t\n");
        let r = session(&input, &s);
        assert_eq!(
            r.iter()
                .map(|l| l.split(':').next().unwrap())
                .collect::<Vec<_>>(),
            [
                "err unknown-command",
                "err bad-arguments",
                "err line-too-long",
                "err binary-input",
                "err binary-input",
                "ok thermorph 0.1.0",
            ]
        );
    }

    #[test]
    fn exactly_max_line_is_accepted() {
        let s = Status::default();
        let mut line = Vec::from(&b"status"[..]);
        line.resize(MAX_LINE, b' ');
        line.push(b'\n');
        assert!(session(&line, &s)[0].starts_with("ok ta_k"));
        let mut longer = Vec::from(&b"status"[..]);
        longer.resize(MAX_LINE + 1, b' ');
        longer.push(b'\n');
        assert!(session(&longer, &s)[0].starts_with("err line-too-long"));
    }

    #[test]
    fn status_shows_everything() {
        let s = Status {
            ta: Some(Kelvin(303.15)),
            vdd_v: Some(3.3),
            frames: 42,
            image: Some(ImageStats {
                min: Kelvin(297.5),
                mean: Kelvin(310.0),
                max: Kelvin(338.25),
                valid: 768,
            }),
            regions: Some([
                Kelvin(340.0),
                Kelvin(330.0),
                Kelvin(320.0),
                Kelvin(305.0),
                Kelvin(298.0),
            ]),
            sensor_error: Some(SensorError::Driver(mlx90640::Error::Stale {
                waited_ms: 250,
            })),
            sensor_errors: 3,
            estop: true,
        };
        let r = session(b"status\n", &s);
        assert_eq!(
            r[0],
            "ok ta_k=303.15 vdd_v=3.300 frames=42 min_k=297.50 mean_k=310.00 max_k=338.25 \
             t1_k=340.00 t2_k=330.00 t3_k=320.00 t4_k=305.00 t5_k=298.00 errors=3 estop=1 \
             sensor_error=\"no new frame for 250 ms\""
        );
    }

    #[test]
    fn lone_cr_ends_lines_and_crlf_gives_one_reply() {
        let s = Status::default();
        let r = session(b"help\rversion\rhelp\r\nversion\r\n\r\n\r\r", &s);
        assert_eq!(r.len(), 4, "{r:?}");
        assert!(r[0].starts_with("ok commands") && r[2].starts_with("ok commands"));
        assert!(r[1].starts_with("ok thermorph") && r[3].starts_with("ok thermorph"));
    }

    #[test]
    fn a_line_split_across_pushes_is_one_line() {
        let mut r: LineReader = LineReader::new();
        for &b in b"vers" {
            assert!(r.push(b).is_none());
        }
        assert!(r.push(b'i').is_none());
        for &b in b"on\r" {
            let got = r.push(b).map(|l| l.map(std::string::String::from));
            if b == b'\r' {
                assert_eq!(got, Some(Ok("version".into())));
            } else {
                assert!(got.is_none());
            }
        }
        // The LF of the CR LF arrives in the next read: no empty command.
        assert!(r.push(b'\n').is_none());
        assert!(r.push(b'\n').is_none(), "an empty line gets no reply");
    }

    #[test]
    fn overlong_line_gets_one_err_whatever_it_holds() {
        let s = Status::default();
        let mut input = Vec::new();
        input.extend(core::iter::repeat_n(b'a', MAX_LINE + 1));
        input.extend_from_slice(b"\x01\x02status\r\n");
        input.extend(core::iter::repeat_n(b'\xff', 3 * MAX_LINE));
        input.extend_from_slice(b"\r\nstatus\r\n");
        let r = session(&input, &s);
        assert_eq!(r.len(), 3, "{r:?}");
        assert!(r[0].starts_with("err line-too-long: "));
        assert!(r[1].starts_with("err binary-input: "));
        assert!(r[2].starts_with("ok ta_k="));
    }

    /// Feed bytes to a reader; return each line's outcome.
    fn lines(r: &mut LineReader, input: &[u8]) -> Vec<Result<String, ConsoleError>> {
        input
            .iter()
            .filter_map(|&b| r.push(b).map(|l| l.map(String::from)))
            .collect()
    }

    #[test]
    fn backspace_and_del_edit_the_line() {
        let mut r: LineReader = LineReader::new();
        assert_eq!(
            lines(&mut r, b"statsu\x08\x08us\r\n"),
            [Ok("status".into())]
        );
        assert_eq!(lines(&mut r, b"helo\x7fp\n"), [Ok("help".into())]);
        // More erasures than bytes: an empty line, no reply; the next line is whole.
        assert_eq!(lines(&mut r, b"ab\x08\x08\x08\x7f\n"), []);
        assert_eq!(lines(&mut r, b"\x08version\n"), [Ok("version".into())]);
        // Erasing does not undo a binary byte or an overlong line.
        assert_eq!(
            lines(&mut r, b"ver\x01\x08sion\n"),
            [Err(ConsoleError::BinaryInput)]
        );
        let mut long = std::vec![b'x'; MAX_LINE + 1];
        long.extend_from_slice(b"\x08\x08\n");
        assert_eq!(lines(&mut r, &long), [Err(ConsoleError::LineTooLong)]);
        // Editing a full line back below the cap is fine.
        let mut full = std::vec![b'x'; MAX_LINE];
        full.extend_from_slice(b"\x08\n");
        assert_eq!(lines(&mut r, &full), [Ok("x".repeat(MAX_LINE - 1))]);
    }

    #[test]
    fn lost_bytes_turn_the_affected_line_into_an_err() {
        let mut r: LineReader = LineReader::new();
        // `set target 358` with the `5` lost: refused, never run as `set target 38`.
        let mut got = lines(&mut r, b"set target 3");
        r.mark_lost();
        got.extend(lines(&mut r, b"8\r\nstatus\r\n"));
        assert_eq!(got, [Err(ConsoleError::LostBytes), Ok("status".into())]);
        // Lost between lines: the next line is the affected one, even if blank.
        r.mark_lost();
        assert_eq!(
            lines(&mut r, b"\nhelp\n"),
            [Err(ConsoleError::LostBytes), Ok("help".into())]
        );
        // After a CR, a loss then LF: the LF ends the damaged line, it is not swallowed.
        let mut got = lines(&mut r, b"help\r");
        r.mark_lost();
        got.extend(lines(&mut r, b"\nversion\n"));
        assert_eq!(
            got,
            [
                Ok("help".into()),
                Err(ConsoleError::LostBytes),
                Ok("version".into())
            ]
        );
        let mut out = String::new();
        respond_error(ConsoleError::LostBytes, &mut out).unwrap();
        assert_eq!(
            out,
            "err lost-bytes: bytes of this line were lost on input, line discarded\r\n"
        );
    }

    #[test]
    fn parse_words() {
        assert_eq!(parse("help"), Ok(Command::Help));
        assert_eq!(parse("  \tVeRsIoN \t"), Ok(Command::Version));
        assert_eq!(parse("status"), Ok(Command::Status));
        assert_eq!(parse(""), Err(ConsoleError::UnknownCommand));
        assert_eq!(parse("statusx"), Err(ConsoleError::UnknownCommand));
        assert_eq!(parse("mode standby"), Err(ConsoleError::UnknownCommand));
        assert_eq!(parse("status now"), Err(ConsoleError::BadArguments));
        assert_eq!(parse("help\tme"), Err(ConsoleError::BadArguments));
    }

    #[test]
    fn error_replies_use_stable_codes() {
        let all = [
            (ConsoleError::LineTooLong, "line-too-long"),
            (ConsoleError::BinaryInput, "binary-input"),
            (ConsoleError::LostBytes, "lost-bytes"),
            (ConsoleError::Busy, "busy"),
            (ConsoleError::UnknownCommand, "unknown-command"),
            (ConsoleError::BadArguments, "bad-arguments"),
        ];
        for (e, code) in all {
            assert_eq!(e.code(), code);
            if e == ConsoleError::LineTooLong {
                assert!(e.message().contains(&std::format!(" {MAX_LINE} ")));
            }
            let mut out = String::new();
            respond_error(e, &mut out).unwrap();
            assert_eq!(out, std::format!("err {code}: {}\r\n", e.message()));
            assert!(
                out.bytes()
                    .all(|b| b == b'\r' || b == b'\n' || (0x20..0x7F).contains(&b))
            );
        }
    }

    #[test]
    fn status_of_a_broken_image_prints_dashes() {
        let s = Status {
            ta: Some(Kelvin(f32::NAN)),
            image: Some(ImageStats {
                min: Kelvin(f32::NEG_INFINITY),
                mean: Kelvin(f32::NAN),
                max: Kelvin(f32::INFINITY),
                valid: 0,
            }),
            ..Status::default()
        };
        let r = session(b"status\n", &s);
        assert!(
            r[0].starts_with("ok ta_k=- vdd_v=- frames=0 min_k=- mean_k=- max_k=- t1_k=-"),
            "{}",
            r[0]
        );
    }

    #[test]
    fn arbitrary_bytes_never_panic() {
        let mut rng = crate::mtts::cluster::XorShift::new(5);
        let bytes: Vec<u8> = (0..20_000)
            .map(|_| (rng.next_f32() * 256.0) as u8)
            .collect();
        let r = session(&bytes, &Status::default());
        assert!(
            r.iter()
                .all(|l| l.starts_with("ok") || l.starts_with("err"))
        );
    }
}
