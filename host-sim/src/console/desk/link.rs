//! One serial line to the console: open a port, send command lines, and read reply and
//! telemetry lines, each read bounded by a deadline.
//!
//! Lines are assembled by the library's own [`LineReader`] (CR, LF or CR LF end a line); a
//! line holding non-printable bytes or longer than a reply can be is [`Line::Garbage`]. A reply
//! is a line starting with `ok` or `err`; a telemetry or event line starts with `#`.

use std::io::{ErrorKind, Read, Write};
use std::time::{Duration, Instant};

use thermorph::console::LineReader;
use thermorph::supervisor::report::REPLY_CAP;

/// Default baud rate of the board's ST-LINK virtual COM port.
pub const DEFAULT_BAUD: u32 = 115_200;
/// How long one blocking read may wait before the deadline is checked again.
const POLL: Duration = Duration::from_millis(50);

/// One line from the console.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Line {
    /// `ok …` or `err …`.
    Reply(String),
    /// A `#` line: telemetry (or another asynchronous line).
    Async(String),
    /// Anything else: binary bytes, an overlong line, or text that is neither.
    Garbage(String),
}

/// Why a read or write failed.
#[derive(Debug)]
pub enum LinkError {
    /// The port could not be opened.
    Open(String),
    /// The port went away (unplugged, board reset on USB, pseudo-terminal closed).
    Gone(String),
    /// Nothing arrived before the deadline.
    Timeout(String),
}

impl std::fmt::Display for LinkError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LinkError::Open(s) => write!(f, "cannot open port: {s}"),
            LinkError::Gone(s) => write!(f, "port lost: {s}"),
            LinkError::Timeout(s) => write!(f, "timeout: {s}"),
        }
    }
}

impl std::error::Error for LinkError {}

/// A serial port to the console.
pub struct Link {
    port: Box<dyn serialport::SerialPort>,
    path: String,
    reader: Box<LineReader<{ REPLY_CAP + 16 }>>,
    pending: std::collections::VecDeque<Line>,
    /// Lines that were neither replies nor `#` lines, since opening.
    pub garbage: u64,
}

impl Link {
    /// Open `path` at `baud`, 8N1, no flow control. A regular file or a directory is refused
    /// by name (never a serial port: most likely arguments given in the wrong order).
    pub fn open(path: &str, baud: u32) -> Result<Link, LinkError> {
        if let Ok(m) = std::fs::metadata(path)
            && (m.is_file() || m.is_dir())
        {
            let what = if m.is_dir() { "directory" } else { "file" };
            return Err(LinkError::Open(format!(
                "{path}: a {what}, not a serial port"
            )));
        }
        let port = serialport::new(path, baud)
            .timeout(POLL)
            .open()
            .map_err(|e| LinkError::Open(format!("{path}: {e}")))?;
        // Bytes that arrived before we opened belong to no command of ours.
        let _ = port.clear(serialport::ClearBuffer::Input);
        Ok(Link {
            port,
            path: path.to_string(),
            reader: Box::new(LineReader::new()),
            pending: Default::default(),
            garbage: 0,
        })
    }

    /// Return the port's path.
    pub fn path(&self) -> &str {
        &self.path
    }

    /// Return a second handle on the same port (for a reader thread).
    pub fn try_clone(&self) -> Result<Link, LinkError> {
        let port = self
            .port
            .try_clone()
            .map_err(|e| LinkError::Open(format!("{}: {e}", self.path)))?;
        Ok(Link {
            port,
            path: self.path.clone(),
            reader: Box::new(LineReader::new()),
            pending: Default::default(),
            garbage: 0,
        })
    }

    /// Send one command line (CR LF is added).
    pub fn send(&mut self, line: &str) -> Result<(), LinkError> {
        let mut bytes = line.trim_end().as_bytes().to_vec();
        bytes.extend_from_slice(b"\r\n");
        self.port
            .write_all(&bytes)
            .and_then(|_| self.port.flush())
            .map_err(|e| LinkError::Gone(format!("{}: write: {e}", self.path)))
    }

    /// Return the next line, or `None` once `deadline` has passed without one.
    pub fn next_line(&mut self, deadline: Instant) -> Result<Option<Line>, LinkError> {
        let mut buf = [0u8; 512];
        loop {
            if let Some(l) = self.pending.pop_front() {
                return Ok(Some(l));
            }
            if Instant::now() >= deadline {
                return Ok(None);
            }
            match self.port.read(&mut buf) {
                Ok(0) => {
                    // A pseudo-terminal whose other side closed reads 0 bytes (or EIO): gone.
                    return Err(LinkError::Gone(format!("{}: end of file", self.path)));
                }
                Ok(n) => {
                    for &b in &buf[..n] {
                        if let Some(r) = self.reader.push(b) {
                            let line = match r {
                                Ok(s) => classify(s),
                                Err(e) => Line::Garbage(format!(
                                    "<{}>",
                                    thermorph::command::ParseError::from(e).code()
                                )),
                            };
                            if matches!(line, Line::Garbage(_)) {
                                self.garbage += 1;
                            }
                            self.pending.push_back(line);
                        }
                    }
                }
                Err(e) if e.kind() == ErrorKind::TimedOut || e.kind() == ErrorKind::WouldBlock => {}
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => return Err(LinkError::Gone(format!("{}: read: {e}", self.path))),
            }
        }
    }

    /// Send `line` and return its reply, handing every `#` line that comes first to `on_async`.
    /// Fails after `timeout` without a reply (garbage lines do not count as one).
    pub fn command(
        &mut self,
        line: &str,
        timeout: Duration,
        on_async: &mut dyn FnMut(&str),
    ) -> Result<String, LinkError> {
        self.send(line)?;
        let deadline = Instant::now() + timeout;
        let garbage0 = self.garbage;
        loop {
            match self.next_line(deadline)? {
                Some(Line::Reply(r)) => return Ok(r),
                Some(Line::Async(a)) => on_async(&a),
                Some(Line::Garbage(_)) if Instant::now() < deadline => {}
                // A port that floods lines other than replies must not hold us past the deadline.
                Some(Line::Garbage(_)) | None => {
                    let g = self.garbage - garbage0;
                    let extra = if g > 0 {
                        format!(" ({g} garbage lines instead)")
                    } else {
                        String::new()
                    };
                    return Err(LinkError::Timeout(format!(
                        "no reply to `{line}` from {} within {:.1} s{extra}",
                        self.path,
                        timeout.as_secs_f64()
                    )));
                }
            }
        }
    }
}

/// Sort a complete line into reply, `#` line or garbage.
pub fn classify(s: &str) -> Line {
    let t = s.trim();
    if t.starts_with('#') {
        Line::Async(t.to_string())
    } else if t == "ok" || t.starts_with("ok ") || t.starts_with("err ") {
        Line::Reply(t.to_string())
    } else {
        Line::Garbage(t.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_are_sorted() {
        assert_eq!(classify("ok mode form"), Line::Reply("ok mode form".into()));
        assert_eq!(
            classify("err bad-arguments: x"),
            Line::Reply("err bad-arguments: x".into())
        );
        assert_eq!(classify("# t_s=1"), Line::Async("# t_s=1".into()));
        assert_eq!(classify("okay"), Line::Garbage("okay".into()));
        assert_eq!(classify("errr"), Line::Garbage("errr".into()));
    }
}
