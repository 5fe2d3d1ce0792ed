//! The serial console's bytes-to-lines layer: [`LineReader`] assembles lines and refuses
//! overlong, binary or damaged ones; [`crate::command`] parses the lines and the supervisor
//! answers them ([`crate::supervisor::report`]).
//!
//! Line-based ASCII, 115200 8N1 on the board and byte for byte the same in the simulator
//! (SPEC section 6). One command per line, ended by CR, LF or CR LF; every command gets exactly
//! one reply line, `ok …` or `err <code>: <message>`, ended by CR LF. An empty (or blank) line
//! gets no reply. A line longer than [`MAX_LINE`] bytes is discarded up to its end and answered
//! with one `err line-too-long`; a line holding bytes other than printable ASCII and TAB is
//! answered `err binary-input`; neither loses the command on the following line. Asynchronous lines
//! (telemetry, events) will start with `#`, so a program can tell them from replies.
//!
//! Backspace and DEL edit the line for a person typing; a line some of whose bytes were lost
//! on input ([`LineReader::mark_lost`]) is refused `err lost-bytes`, never run damaged.

/// Longest accepted line, bytes (without its end).
pub const MAX_LINE: usize = 96;

/// Why the reader refused a line (its reply's code and message: [`crate::command::ParseError`]).
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::command::{ParseError, parse_read};
    use crate::settings::Settings;
    use crate::supervisor::Supervisor;
    use crate::supervisor::report::Reply;
    use crate::units::Millis;
    use std::string::String;
    use std::vec::Vec;

    /// The reply a refused line gets.
    fn refused(e: ConsoleError) -> String {
        Reply::parse_error(ParseError::from(e)).as_str().into()
    }

    /// Feed bytes, collect the reply of every line as the board does (reader → parser →
    /// supervisor).
    fn session(input: &[u8]) -> Vec<String> {
        let mut r: LineReader = LineReader::new();
        let mut sup = Supervisor::new(Millis(0), Settings::DEFAULT);
        let mut replies = Vec::new();
        for &b in input {
            if let Some(line) = r.push(b) {
                let reply = match parse_read(line) {
                    Ok(cmd) => sup.step(Millis(0), None, Some(cmd)).reply.unwrap(),
                    Err(e) => Reply::parse_error(e),
                };
                assert!(!reply.as_str().contains(['\r', '\n']));
                replies.push(reply.as_str().into());
            }
        }
        replies
    }

    #[test]
    fn commands_and_line_ends() {
        let r = session(b"help\r\nversion\nSTATUS\r\r\n\n");
        assert_eq!(r.len(), 3, "{r:?}");
        assert!(r[0].starts_with("ok commands"));
        assert_eq!(r[1], std::format!("ok thermorph {}", crate::VERSION));
        assert!(r[2].starts_with("ok mode=standby"));
    }

    #[test]
    fn errors_do_not_lose_the_next_command() {
        let mut input = Vec::new();
        input.extend_from_slice(b"frobnicate\n");
        input.extend_from_slice(b"version 2\n");
        input.extend(core::iter::repeat_n(b'x', 300));
        input.extend_from_slice(b"\nver\x00sion\n\xff\xfe\nversion\n   \n\t\n");
        let r = session(&input);
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
        let mut line = Vec::from(&b"status"[..]);
        line.resize(MAX_LINE, b' ');
        line.push(b'\n');
        assert!(session(&line)[0].starts_with("ok mode="));
        let mut longer = Vec::from(&b"status"[..]);
        longer.resize(MAX_LINE + 1, b' ');
        longer.push(b'\n');
        assert!(session(&longer)[0].starts_with("err line-too-long"));
    }

    #[test]
    fn lone_cr_ends_lines_and_crlf_gives_one_reply() {
        let r = session(b"help\rversion\rhelp\r\nversion\r\n\r\n\r\r");
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
        let mut input = Vec::new();
        input.extend(core::iter::repeat_n(b'a', MAX_LINE + 1));
        input.extend_from_slice(b"\x01\x02status\r\n");
        input.extend(core::iter::repeat_n(b'\xff', 3 * MAX_LINE));
        input.extend_from_slice(b"\r\nstatus\r\n");
        let r = session(&input);
        assert_eq!(r.len(), 3, "{r:?}");
        assert!(r[0].starts_with("err line-too-long: "));
        assert!(r[1].starts_with("err binary-input: "));
        assert!(r[2].starts_with("ok mode="));
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
        assert_eq!(
            refused(ConsoleError::LostBytes),
            "err lost-bytes: bytes of this line were lost, line discarded"
        );
    }

    #[test]
    fn error_replies_use_stable_codes() {
        let all = [
            (ConsoleError::LineTooLong, "line-too-long"),
            (ConsoleError::BinaryInput, "binary-input"),
            (ConsoleError::LostBytes, "lost-bytes"),
            (ConsoleError::Busy, "busy"),
        ];
        for (e, code) in all {
            let out = refused(e);
            if e == ConsoleError::LineTooLong {
                assert!(out.contains(&std::format!(" {MAX_LINE} ")), "{out}");
            }
            assert!(out.starts_with(&std::format!("err {code}: ")), "{out}");
            assert!(out.bytes().all(|b| (0x20..0x7F).contains(&b)));
        }
    }

    #[test]
    fn arbitrary_bytes_never_panic() {
        let mut rng = crate::mtts::cluster::XorShift::new(5);
        let bytes: Vec<u8> = (0..20_000)
            .map(|_| (rng.next_f32() * 256.0) as u8)
            .collect();
        let r = session(&bytes);
        assert!(
            r.iter()
                .all(|l| l.starts_with("ok") || l.starts_with("err"))
        );
    }
}
