//! `record`: turn the telemetry stream on and write every telemetry line as a CSV row.
//!
//! Each row is written and flushed as soon as its line has arrived, so a line received is never
//! lost, even if the recorder is killed. The recorder survives the block going away:
//! - a read or write error (port unplugged, pseudo-terminal closed) closes the port and reopens
//!   the same path every [`RecordOptions::retry`] until [`RecordOptions::reconnect`] has
//!   passed; then it stops with an error (the CSV keeps everything up to the loss);
//! - a board reset shows as the board's clock going backwards (or the stream going silent,
//!   since a reset board starts with the stream off): the stream is turned on again.
//!
//! The first row after either has its `gap` column set to why rows may be missing before it.
//!
//! The port is opened and must answer `stream on` before the CSV is created, and an existing
//! CSV is never overwritten unless asked to ([`check_out`]): a recording that cannot start
//! loses nothing. However it ends (its duration, `interrupt` set by Ctrl-C, a port lost for
//! good, a write error) it sends `stream off` and says how many rows it kept.

use std::io::Write;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use super::DeskError;
use super::link::{Line, Link, LinkError};
use super::telemetry::{Telemetry, csv_header, csv_row};

/// How `record` runs.
#[derive(Clone, Debug)]
pub struct RecordOptions {
    /// Baud rate.
    pub baud: u32,
    /// Telemetry rate asked for, Hz (`None`: the board's default).
    pub hz: Option<f32>,
    /// Stop after this long (`None`: until the port is lost for good or the process ends).
    pub duration: Option<Duration>,
    /// How long to keep trying to reopen a lost port.
    pub reconnect: Duration,
    /// Pause between reopening attempts.
    pub retry: Duration,
    /// No telemetry for this long: ask for the stream again (the board may have reset).
    pub silence: Duration,
    /// How long a command may wait for its reply.
    pub reply_timeout: Duration,
    /// Overwrite the output file if it exists.
    pub force: bool,
}

impl Default for RecordOptions {
    fn default() -> Self {
        RecordOptions {
            baud: super::link::DEFAULT_BAUD,
            hz: None,
            duration: None,
            reconnect: Duration::from_secs(30),
            retry: Duration::from_millis(250),
            silence: Duration::from_secs(3),
            reply_timeout: Duration::from_secs(2),
            force: false,
        }
    }
}

/// The recording's CSV file: the header at once, then each telemetry line as a row, flushed as
/// it is written.
pub struct CsvSink {
    out: std::io::BufWriter<std::fs::File>,
    path: std::path::PathBuf,
    started: Instant,
    last_t_s: f64,
    /// The mark for the next row (why rows may be missing before it).
    pub gap: Option<&'static str>,
    /// Rows written.
    pub rows: u64,
    /// Gaps marked.
    pub gaps: u64,
}

/// `Err` ([`DeskError::Exists`]) if `path` exists and `force` is not set: a recording is never
/// overwritten by mistake.
pub fn check_out(path: &Path, force: bool) -> Result<(), DeskError> {
    if !force && std::fs::symlink_metadata(path).is_ok() {
        return Err(DeskError::Exists {
            path: path.to_path_buf(),
        });
    }
    Ok(())
}

impl CsvSink {
    /// Create `path` (if it exists: only with `force`, else [`DeskError::Exists`]) and write
    /// the header.
    pub fn create(path: &Path, force: bool) -> Result<CsvSink, DeskError> {
        let file_err = |err| DeskError::File {
            path: path.to_path_buf(),
            err,
        };
        let mut open = std::fs::OpenOptions::new();
        open.write(true);
        if force {
            open.create(true).truncate(true);
        } else {
            open.create_new(true);
        }
        let file = open.open(path).map_err(|err| {
            if err.kind() == std::io::ErrorKind::AlreadyExists {
                DeskError::Exists {
                    path: path.to_path_buf(),
                }
            } else {
                file_err(err)
            }
        })?;
        let mut out = std::io::BufWriter::new(file);
        writeln!(out, "{}", csv_header())
            .and_then(|_| out.flush())
            .map_err(file_err)?;
        Ok(CsvSink {
            out,
            path: path.to_path_buf(),
            started: Instant::now(),
            last_t_s: f64::NEG_INFINITY,
            gap: None,
            rows: 0,
            gaps: 0,
        })
    }

    /// Return the CSV's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Write `line` if it is telemetry (a board clock that went backwards marks a `reset`);
    /// return the parsed telemetry.
    pub fn line(&mut self, line: &str) -> Result<Option<Telemetry>, DeskError> {
        let Some(t) = Telemetry::parse(line) else {
            return Ok(None);
        };
        if let Some(ts) = t.t_s() {
            if ts < self.last_t_s && self.gap.is_none() {
                self.gap = Some("reset");
            }
            self.last_t_s = ts;
        }
        let row = csv_row(self.started.elapsed().as_secs_f64(), &t, self.gap);
        if self.gap.take().is_some() {
            self.gaps += 1;
        }
        writeln!(self.out, "{row}")
            .and_then(|_| self.out.flush())
            .map_err(|err| DeskError::File {
                path: self.path.clone(),
                err,
            })?;
        self.rows += 1;
        Ok(Some(t))
    }
}

/// What a recording did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RecordStats {
    /// Telemetry rows written.
    pub rows: u64,
    /// Gaps marked (reconnects, resets, silences).
    pub gaps: u64,
    /// Garbage lines seen.
    pub garbage: u64,
    /// Ended by `interrupt` (Ctrl-C), not by its duration.
    pub interrupted: bool,
}

fn stream_on(
    link: &mut Link,
    o: &RecordOptions,
    rows: &mut dyn FnMut(&str),
) -> Result<(), LinkError> {
    let cmd = match o.hz {
        Some(hz) => format!("stream on {hz}"),
        None => "stream on".to_string(),
    };
    let r = link.command(&cmd, o.reply_timeout, rows)?;
    if r.starts_with("ok") {
        Ok(())
    } else {
        Err(LinkError::Open(format!("`{cmd}` refused: {r}")))
    }
}

/// Reopen the lost port `path`, trying until [`RecordOptions::reconnect`] has passed or
/// `interrupt` is set.
fn reopen(
    path: &str,
    o: &RecordOptions,
    why: LinkError,
    interrupt: &AtomicBool,
) -> Result<Link, DeskError> {
    let until = Instant::now() + o.reconnect;
    loop {
        if interrupt.load(Ordering::SeqCst) {
            return Err(DeskError::Interrupted);
        }
        let last = match Link::open(path, o.baud) {
            Ok(l) => return Ok(l),
            Err(e) => e,
        };
        if Instant::now() + o.retry > until {
            return Err(DeskError::NotBack {
                path: path.to_string(),
                why,
                within_s: o.reconnect.as_secs_f64(),
                last,
            });
        }
        std::thread::sleep(o.retry);
    }
}

/// Record `path`'s telemetry into `out` (CSV); `progress` gets each written row's telemetry.
/// Stops after [`RecordOptions::duration`] or once `interrupt` is set (both `Ok`). Nothing is
/// created before the port answers `stream on`; an error after that is
/// [`DeskError::RecordingEnded`], which says how many rows were kept.
pub fn record(
    path: &str,
    out: &Path,
    o: &RecordOptions,
    interrupt: &AtomicBool,
    progress: &mut dyn FnMut(&Telemetry, &RecordStats),
) -> Result<RecordStats, DeskError> {
    check_out(out, o.force)?;
    let mut link = Some(Link::open(path, o.baud)?);
    // Rows that arrive while a command waits for its reply are written too.
    let mut held: Vec<String> = Vec::new();
    if let Some(l) = link.as_mut() {
        match stream_on(l, o, &mut |t| held.push(t.to_string())) {
            Ok(()) => {}
            Err(LinkError::Timeout(e)) => return Err(DeskError::NoConsole(e)),
            Err(e) => return Err(e.into()),
        }
    }
    let mut sink = match CsvSink::create(out, o.force) {
        Ok(s) => s,
        Err(e) => {
            if let Some(l) = link.as_mut() {
                let _ = l.command("stream off", o.reply_timeout, &mut |_| {});
            }
            return Err(e);
        }
    };
    let started = Instant::now();
    let end = o.duration.map(|d| started + d);
    let mut garbage = 0;
    let mut interrupted = false;
    let mut write = |line: &str, sink: &mut CsvSink, garbage: u64| -> Result<bool, DeskError> {
        let t = sink.line(line)?;
        if let Some(t) = &t {
            progress(
                t,
                &RecordStats {
                    rows: sink.rows,
                    gaps: sink.gaps,
                    garbage,
                    interrupted: false,
                },
            );
        }
        Ok(t.is_some())
    };

    let result = (|| -> Result<(), DeskError> {
        let mut last_row = Instant::now();
        let mut need_stream = false;
        // Since when a reopened port has not answered: a port of the same name that comes back
        // but never answers (another device, a reused pseudo-terminal number) is not the board.
        let mut unanswered_since: Option<Instant> = None;
        loop {
            if interrupt.load(Ordering::SeqCst) {
                interrupted = true;
                break;
            }
            if end.is_some_and(|e| Instant::now() >= e) {
                break;
            }
            let Some(l) = link.as_mut() else { break };
            let result: Result<(), LinkError> = (|| {
                if need_stream {
                    stream_on(l, o, &mut |t| held.push(t.to_string()))?;
                    unanswered_since = None;
                    need_stream = false;
                    last_row = Instant::now();
                }
                let deadline = (Instant::now() + Duration::from_millis(200))
                    .min(end.unwrap_or(Instant::now() + Duration::from_secs(1)));
                while let Some(line) = l.next_line(deadline)? {
                    if let Line::Async(a) = line {
                        held.push(a);
                    }
                }
                Ok(())
            })();
            garbage = garbage.max(l.garbage);
            for t in held.drain(..) {
                if write(&t, &mut sink, garbage)? {
                    last_row = Instant::now();
                }
            }
            match result {
                Ok(()) => {
                    if last_row.elapsed() >= o.silence {
                        // A reset board starts with the stream off: ask again.
                        eprintln!(
                            "record: no telemetry for {:.1} s, asking for the stream again",
                            o.silence.as_secs_f64()
                        );
                        sink.gap.get_or_insert("silence");
                        need_stream = true;
                        last_row = Instant::now();
                    }
                }
                Err(LinkError::Timeout(e))
                    if unanswered_since.is_some_and(|t| t.elapsed() >= o.reconnect) =>
                {
                    return Err(DeskError::NoAnswer {
                        path: path.to_string(),
                        within_s: o.reconnect.as_secs_f64(),
                        detail: e,
                    });
                }
                Err(LinkError::Timeout(e)) => {
                    eprintln!("record: {e}");
                    sink.gap.get_or_insert("silence");
                    need_stream = true;
                    last_row = Instant::now();
                }
                Err(e) => {
                    eprintln!("record: {e}; reopening {path}");
                    link = None;
                    let mut l = reopen(path, o, e, interrupt)?;
                    l.garbage = garbage;
                    link = Some(l);
                    eprintln!("record: {path} is back");
                    unanswered_since = Some(Instant::now());
                    sink.gap = Some("reconnect");
                    need_stream = true;
                }
            }
        }
        Ok(())
    })();
    // Leave the block as it was before, apart from the stream: turn it off again, however the
    // recording ended (a lost port cannot be told).
    let stream_off = match link.as_mut() {
        Some(l) => {
            let r = l.command("stream off", o.reply_timeout, &mut |t| {
                held.push(t.to_string())
            });
            garbage = garbage.max(l.garbage);
            matches!(r, Ok(r) if r.starts_with("ok"))
        }
        None => false,
    };
    let mut written = Ok(());
    for t in held.drain(..) {
        if let Err(e) = write(&t, &mut sink, garbage) {
            written = Err(e);
            break;
        }
    }
    let ended = |err: DeskError| DeskError::RecordingEnded {
        err: Box::new(err),
        path: out.to_path_buf(),
        rows: sink.rows,
        gaps: sink.gaps,
        stream_off,
    };
    match (result, written) {
        (Err(e), _) | (Ok(()), Err(e)) => Err(ended(e)),
        (Ok(()), Ok(())) if !stream_off => Err(ended(DeskError::StreamOffRefused)),
        (Ok(()), Ok(())) => Ok(RecordStats {
            rows: sink.rows,
            gaps: sink.gaps,
            garbage,
            interrupted,
        }),
    }
}
