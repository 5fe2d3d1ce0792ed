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

use std::io::Write;
use std::path::Path;
use std::time::{Duration, Instant};

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
        }
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

fn reopen(path: &str, o: &RecordOptions, why: &str) -> Result<Link, String> {
    let until = Instant::now() + o.reconnect;
    loop {
        let last = match Link::open(path, o.baud) {
            Ok(l) => return Ok(l),
            Err(e) => e.to_string(),
        };
        if Instant::now() + o.retry > until {
            return Err(format!(
                "{path}: port lost ({why}) and not back within {:.1} s: {last}",
                o.reconnect.as_secs_f64()
            ));
        }
        std::thread::sleep(o.retry);
    }
}

/// Record `path`'s telemetry into `out` (CSV); `progress` gets each written row's telemetry.
pub fn record(
    path: &str,
    out: &Path,
    o: &RecordOptions,
    progress: &mut dyn FnMut(&Telemetry, &RecordStats),
) -> Result<RecordStats, String> {
    let file = std::fs::File::create(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let mut csv = std::io::BufWriter::new(file);
    let started = Instant::now();
    let end = o.duration.map(|d| started + d);
    let mut stats = RecordStats::default();
    let mut gap: Option<&'static str> = None;
    let mut last_t_s = f64::NEG_INFINITY;
    let mut last_row = Instant::now();
    writeln!(csv, "{}", csv_header()).map_err(|e| e.to_string())?;
    csv.flush().map_err(|e| e.to_string())?;

    let mut write = |line: &str,
                     gap: &mut Option<&'static str>,
                     last_t_s: &mut f64,
                     stats: &mut RecordStats|
     -> Result<(), String> {
        let Some(t) = Telemetry::parse(line) else {
            return Ok(());
        };
        if let Some(ts) = t.t_s() {
            if ts < *last_t_s && gap.is_none() {
                *gap = Some("reset");
            }
            *last_t_s = ts;
        }
        let row = csv_row(started.elapsed().as_secs_f64(), &t, *gap);
        if gap.take().is_some() {
            stats.gaps += 1;
        }
        writeln!(csv, "{row}")
            .and_then(|_| csv.flush())
            .map_err(|e| format!("{}: {e}", out.display()))?;
        stats.rows += 1;
        progress(&t, stats);
        Ok(())
    };

    // Rows that arrive while a command waits for its reply are written too.
    let mut held: Vec<String> = Vec::new();
    let mut link = Link::open(path, o.baud).map_err(|e| e.to_string())?;
    let mut need_stream = true;
    loop {
        if end.is_some_and(|e| Instant::now() >= e) {
            break;
        }
        let result: Result<(), LinkError> = (|| {
            if need_stream {
                stream_on(&mut link, o, &mut |l| held.push(l.to_string()))?;
                need_stream = false;
                last_row = Instant::now();
            }
            let deadline = (Instant::now() + Duration::from_millis(200))
                .min(end.unwrap_or(Instant::now() + Duration::from_secs(1)));
            while let Some(line) = link.next_line(deadline)? {
                if let Line::Async(a) = line {
                    held.push(a);
                }
            }
            Ok(())
        })();
        for l in held.drain(..) {
            let before = stats.rows;
            write(&l, &mut gap, &mut last_t_s, &mut stats)?;
            if stats.rows > before {
                last_row = Instant::now();
            }
        }
        stats.garbage = stats.garbage.max(link.garbage);
        match result {
            Ok(()) => {
                if last_row.elapsed() >= o.silence {
                    // A reset board starts with the stream off: ask again.
                    eprintln!(
                        "record: no telemetry for {:.1} s, asking for the stream again",
                        o.silence.as_secs_f64()
                    );
                    gap.get_or_insert("silence");
                    need_stream = true;
                    last_row = Instant::now();
                }
            }
            Err(LinkError::Timeout(e)) => {
                eprintln!("record: {e}");
                gap.get_or_insert("silence");
                need_stream = true;
                last_row = Instant::now();
            }
            Err(e) => {
                eprintln!("record: {e}; reopening {path}");
                let garbage = stats.garbage;
                drop(link);
                link = reopen(path, o, &e.to_string())?;
                link.garbage = garbage;
                eprintln!("record: {path} is back");
                gap = Some("reconnect");
                need_stream = true;
            }
        }
    }
    // Leave the block as it was before, apart from the stream: turn it off again.
    let _ = link.command("stream off", o.reply_timeout, &mut |l| {
        held.push(l.to_string())
    });
    for l in held.drain(..) {
        write(&l, &mut gap, &mut last_t_s, &mut stats)?;
    }
    Ok(stats)
}
