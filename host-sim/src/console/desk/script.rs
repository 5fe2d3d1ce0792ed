//! `run`: experiment scripts for repeatable runs, checked before anything is sent.
//!
//! One step a line; `#` starts a comment; blank lines are skipped.
//!
//! | line | does |
//! | --- | --- |
//! | a console command, e.g. `mode step-large AB` | sends it; the reply must be `ok …` |
//! | `try COMMAND` | sends it; any reply is accepted |
//! | `expect-err CODE COMMAND` | sends it; the reply must be `err CODE: …` |
//! | `wait FIELD OP VALUE [within S]` | polls `status` until the condition holds (default 60 s) |
//! | `expect FIELD OP VALUE` | one `status`; the condition must hold now |
//! | `sleep S` | waits S seconds |
//! | `pose ANGLE [SPRINGS] [form] [within S]` | sends `mode pose …` (the reply must be `ok …`), then waits until the pose holds its target (phase `hold`) or, with `form`, has formed and handed back to standby (default 600 s) |
//!
//! FIELD is a field of the `status` reply (`mode`, `phase`, `tc_k`, `t1_k`, `fault`, …); OP is
//! one of `==`, `!=`, `<`, `<=`, `>`, `>=`; numbers compare as numbers, words as words. So
//! `wait mode == form`, `wait fault != none within 30` and `wait tc_k >= 355 within 120` wait for
//! a mode, a fault and a temperature.
//!
//! Every line is checked when the script is read, before anything is sent: commands with the
//! library's parser, FIELD against the fields the library's `status` reply has
//! ([`status_fields`]); every bad line is reported as `FILE:LINE: reason`. The run stops at the
//! first failure. A run that fails or is interrupted (Ctrl-C) once its commands have gone out
//! sends `stop` (unless [`RunOptions::leave_running`]) and says in what state it left the
//! block; a run that passes leaves the block as its script left it. With `--record FILE.csv` the run turns the telemetry
//! stream on and writes every telemetry line it receives, as `record` does (one serial port has
//! room for one program, so the script's run records its own experiment), and turns it off
//! however the run ends.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use super::link::{Line, Link, LinkError};
use super::record::CsvSink;
use super::telemetry::{Fields, fields, get, status_fields};
use super::{DeskError, WaitTimeout};

/// Default `wait` timeout.
pub const DEFAULT_WAIT: Duration = Duration::from_secs(60);
/// Default `pose` timeout: a soak, the steps and (with `form`) the forming.
pub const DEFAULT_POSE_WAIT: Duration = Duration::from_secs(600);
/// How often `wait` asks for `status`.
pub const POLL: Duration = Duration::from_millis(200);

/// A comparison.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Op {
    /// `==`
    Eq,
    /// `!=`
    Ne,
    /// `<`
    Lt,
    /// `<=`
    Le,
    /// `>`
    Gt,
    /// `>=`
    Ge,
}

impl Op {
    fn parse(s: &str) -> Option<Op> {
        Some(match s {
            "==" => Op::Eq,
            "!=" => Op::Ne,
            "<" => Op::Lt,
            "<=" => Op::Le,
            ">" => Op::Gt,
            ">=" => Op::Ge,
            _ => return None,
        })
    }

    fn text(self) -> &'static str {
        match self {
            Op::Eq => "==",
            Op::Ne => "!=",
            Op::Lt => "<",
            Op::Le => "<=",
            Op::Gt => ">",
            Op::Ge => ">=",
        }
    }
}

/// A condition on one `status` field.
#[derive(Clone, Debug, PartialEq)]
pub struct Cond {
    /// The field.
    pub field: String,
    /// The comparison.
    pub op: Op,
    /// The value compared with.
    pub value: String,
}

impl Cond {
    /// Return whether the field's value `actual` satisfies the condition (numbers compare as
    /// numbers; otherwise only `==`/`!=` on the words, case-insensitive).
    pub fn holds(&self, actual: &str) -> bool {
        match (actual.parse::<f64>(), self.value.parse::<f64>()) {
            (Ok(a), Ok(b)) => match self.op {
                Op::Eq => a == b,
                Op::Ne => a != b,
                Op::Lt => a < b,
                Op::Le => a <= b,
                Op::Gt => a > b,
                Op::Ge => a >= b,
            },
            _ => match self.op {
                Op::Eq => actual.eq_ignore_ascii_case(&self.value),
                Op::Ne => !actual.eq_ignore_ascii_case(&self.value),
                _ => false,
            },
        }
    }
}

impl std::fmt::Display for Cond {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} {} {}", self.field, self.op.text(), self.value)
    }
}

/// One step of a script.
#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    /// Send a command; `ok` required unless `any`.
    Command {
        /// The line.
        line: String,
        /// Any reply is accepted.
        any: bool,
    },
    /// Send a command whose reply must be `err CODE`.
    ExpectErr {
        /// The error code.
        code: String,
        /// The line.
        line: String,
    },
    /// Poll `status` until the condition holds.
    Wait {
        /// The condition.
        cond: Cond,
        /// How long at most.
        within: Duration,
    },
    /// Check the condition on one `status`.
    Expect(Cond),
    /// Wait.
    Sleep(Duration),
}

/// A step and its line number (1-based).
pub type Script = Vec<(usize, Step)>;

fn check_command(line: &str) -> Result<(), DeskError> {
    thermorph::command::parse(line)
        .map(|_| ())
        .map_err(|e| DeskError::Command {
            command: line.to_string(),
            message: e.to_string(),
        })
}

/// Parse a number of seconds (`0.5`, `90`), as scripts and the desk's options write it.
pub fn seconds(word: &str) -> Result<Duration, DeskError> {
    word.parse::<f64>()
        .ok()
        .filter(|s| s.is_finite() && *s >= 0.0 && *s < 1e7)
        .map(Duration::from_secs_f64)
        .ok_or_else(|| DeskError::Seconds(word.to_string()))
}

fn cond(words: &[&str]) -> Result<Cond, DeskError> {
    match words {
        [field, op, value] => Ok(Cond {
            field: field.to_string(),
            op: Op::parse(op).ok_or_else(|| DeskError::Op(op.to_string()))?,
            value: value.to_string(),
        }),
        _ => Err(DeskError::Usage("FIELD OP VALUE")),
    }
}

/// A script line's error: `line N: …` ([`DeskError::Script`] without a file yet).
fn at_line(line: usize) -> impl Fn(DeskError) -> DeskError + Copy {
    move |e| DeskError::Script {
        file: None,
        lines: vec![(line, e)],
    }
}

/// `Err` unless `status` has the condition's field.
fn check_field(c: &Cond, known: &[String]) -> Result<(), DeskError> {
    if known.contains(&c.field) {
        Ok(())
    } else {
        Err(DeskError::NoField {
            field: c.field.clone(),
            fields: known.join(" "),
        })
    }
}

/// Parse a script, checking every line; the error ([`DeskError::Script`]) names every bad
/// line.
pub fn parse(text: &str) -> Result<Script, DeskError> {
    let known = status_fields();
    let mut out = Vec::new();
    let mut bad = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let n = i + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let words: Vec<&str> = line.split_whitespace().collect();
        let step = (|| -> Result<Step, DeskError> {
            match words[0] {
                "wait" => {
                    let (c, within) = match words[1..] {
                        [.., "within", s] => (cond(&words[1..words.len() - 2])?, seconds(s)?),
                        _ => (cond(&words[1..])?, DEFAULT_WAIT),
                    };
                    check_field(&c, &known)?;
                    Ok(Step::Wait { cond: c, within })
                }
                "pose" => {
                    let (args, within) = match words[1..] {
                        [.., "within", s] => (&words[1..words.len() - 2], seconds(s)?),
                        _ => (&words[1..], DEFAULT_POSE_WAIT),
                    };
                    let command = format!("mode pose {}", args.join(" "));
                    check_command(&command)?;
                    let form = args.iter().any(|w| w.eq_ignore_ascii_case("form"));
                    let done = if form {
                        cond(&["mode", "==", "standby"])?
                    } else {
                        cond(&["phase", "==", "hold"])?
                    };
                    out.push((
                        n,
                        Step::Command {
                            line: command,
                            any: false,
                        },
                    ));
                    Ok(Step::Wait { cond: done, within })
                }
                "expect" => {
                    let c = cond(&words[1..])?;
                    check_field(&c, &known)?;
                    Ok(Step::Expect(c))
                }
                "sleep" => match words[1..] {
                    [s] => Ok(Step::Sleep(seconds(s)?)),
                    _ => Err(DeskError::Usage("`sleep SECONDS`")),
                },
                "try" => {
                    let rest = line["try".len()..].trim();
                    check_command(rest)?;
                    Ok(Step::Command {
                        line: rest.into(),
                        any: true,
                    })
                }
                "expect-err" => {
                    let code = words
                        .get(1)
                        .ok_or(DeskError::Usage("`expect-err CODE COMMAND`"))?;
                    let rest = line["expect-err".len()..].trim()[code.len()..].trim();
                    if rest.is_empty() {
                        return Err(DeskError::Usage("`expect-err CODE COMMAND`"));
                    }
                    Ok(Step::ExpectErr {
                        code: code.to_string(),
                        line: rest.into(),
                    })
                }
                _ => {
                    check_command(line)?;
                    Ok(Step::Command {
                        line: line.into(),
                        any: false,
                    })
                }
            }
        })();
        match step {
            Ok(step) => out.push((n, step)),
            Err(e) => bad.push((n, e)),
        }
    }
    if bad.is_empty() {
        Ok(out)
    } else {
        Err(DeskError::Script {
            file: None,
            lines: bad,
        })
    }
}

/// Send `line` and return its reply; telemetry that comes first goes to `sink`.
fn command(
    link: &mut Link,
    line: &str,
    timeout: Duration,
    sink: &mut Option<CsvSink>,
) -> Result<String, DeskError> {
    let mut held = Vec::new();
    let r = link.command(line, timeout, &mut |l| held.push(l.to_string()));
    if let Some(s) = sink.as_mut() {
        for l in &held {
            s.line(l)?;
        }
    }
    Ok(r?)
}

/// Ask for `status` and return its fields.
pub fn status(
    link: &mut Link,
    timeout: Duration,
    sink: &mut Option<CsvSink>,
) -> Result<Fields, DeskError> {
    let r = command(link, "status", timeout, sink)?;
    match r.strip_prefix("ok") {
        Some(body) => Ok(fields(body)),
        None => Err(DeskError::StatusRefused(r)),
    }
}

fn check(f: &Fields, c: &Cond) -> Result<bool, DeskError> {
    match get(f, &c.field) {
        Some(v) => Ok(c.holds(v)),
        None => Err(DeskError::NoField {
            field: c.field.clone(),
            fields: f
                .iter()
                .map(|(n, _)| n.as_str())
                .collect::<Vec<_>>()
                .join(" "),
        }),
    }
}

/// Run `script` on `link`, logging each step to `log`; stop at the first failure, or once
/// `interrupt` is set, with an error naming the line. `sent` is set as soon as one of the
/// script's commands has gone out (the block may then be in a state the script brought it to).
pub fn run(
    link: &mut Link,
    script: &Script,
    reply_timeout: Duration,
    sink: &mut Option<CsvSink>,
    interrupt: &AtomicBool,
    sent: &mut bool,
    log: &mut dyn FnMut(&str),
) -> Result<(), DeskError> {
    let started = Instant::now();
    let stopped = || interrupt.load(Ordering::SeqCst);
    for (n, step) in script {
        let at = || format!("[{:7.2} s] line {n}:", started.elapsed().as_secs_f64());
        let fail = at_line(*n);
        if stopped() {
            return Err(fail(DeskError::Interrupted));
        }
        if matches!(step, Step::Command { .. } | Step::ExpectErr { .. }) {
            *sent = true;
        }
        match step {
            Step::Command { line, any } => {
                let r = command(link, line, reply_timeout, sink).map_err(fail)?;
                log(&format!("{} {line} -> {r}", at()));
                if !any && !r.starts_with("ok") {
                    return Err(fail(DeskError::NotOk {
                        command: line.clone(),
                        reply: r,
                    }));
                }
            }
            Step::ExpectErr { code, line } => {
                let r = command(link, line, reply_timeout, sink).map_err(fail)?;
                log(&format!("{} {line} -> {r}", at()));
                if !r.starts_with(&format!("err {code}:")) {
                    return Err(fail(DeskError::NotErr {
                        command: line.clone(),
                        reply: r,
                        code: code.clone(),
                    }));
                }
            }
            Step::Expect(c) => {
                let f = status(link, reply_timeout, sink).map_err(fail)?;
                if !check(&f, c).map_err(fail)? {
                    return Err(fail(DeskError::Expected {
                        cond: c.to_string(),
                        field: c.field.clone(),
                        value: get(&f, &c.field).unwrap_or("?").to_string(),
                    }));
                }
                log(&format!("{} expect {c}: holds", at()));
            }
            Step::Wait { cond, within } => {
                let until = Instant::now() + *within;
                loop {
                    let f = status(link, reply_timeout, sink).map_err(fail)?;
                    if check(&f, cond).map_err(fail)? {
                        log(&format!("{} wait {cond}: holds", at()));
                        break;
                    }
                    if Instant::now() >= until {
                        return Err(fail(DeskError::WaitTimeout(Box::new(WaitTimeout {
                            cond: cond.to_string(),
                            within_s: within.as_secs_f64(),
                            field: cond.field.clone(),
                            value: get(&f, &cond.field).unwrap_or("?").to_string(),
                            mode: get(&f, "mode").unwrap_or("?").to_string(),
                            fault: get(&f, "fault").unwrap_or("?").to_string(),
                        }))));
                    }
                    let next =
                        Instant::now() + POLL.min(until.saturating_duration_since(Instant::now()));
                    drain(link, next, sink, interrupt).map_err(fail)?;
                }
            }
            Step::Sleep(d) => {
                drain(link, Instant::now() + *d, sink, interrupt).map_err(fail)?;
                log(&format!("{} slept {:.1} s", at(), d.as_secs_f64()));
            }
        }
    }
    Ok(())
}

/// Read lines until `until`, writing telemetry to `sink` (so nothing piles up while waiting);
/// [`DeskError::Interrupted`] as soon as `interrupt` is set.
fn drain(
    link: &mut Link,
    until: Instant,
    sink: &mut Option<CsvSink>,
    interrupt: &AtomicBool,
) -> Result<(), DeskError> {
    loop {
        if interrupt.load(Ordering::SeqCst) {
            return Err(DeskError::Interrupted);
        }
        let now = Instant::now();
        if now >= until {
            return Ok(());
        }
        let step = until.min(now + Duration::from_millis(100));
        while let Some(l) = link.next_line(step)? {
            if let (Line::Async(a), Some(s)) = (l, sink.as_mut()) {
                s.line(&a)?;
            }
        }
    }
}

/// How `run` runs.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// Baud rate.
    pub baud: u32,
    /// How long a command may wait for its reply.
    pub reply_timeout: Duration,
    /// Also record the telemetry received during the run to this CSV.
    pub record: Option<PathBuf>,
    /// Overwrite the recording's file if it exists.
    pub force: bool,
    /// On a failure or an interruption, send nothing: leave the block in the state the script
    /// had brought it to (the desk still says what that state is).
    pub leave_running: bool,
}

impl Default for RunOptions {
    fn default() -> Self {
        RunOptions {
            baud: super::link::DEFAULT_BAUD,
            reply_timeout: Duration::from_secs(2),
            record: None,
            force: false,
            leave_running: false,
        }
    }
}

/// Read and check the script file `script_path` ([`parse`]); errors name the file.
pub fn read_file(script_path: &Path) -> Result<Script, DeskError> {
    // A device given as SCRIPT (the arguments swapped: `run SCRIPT PORT`) would block a read,
    // or read the board's own lines: refuse anything but a file.
    if let Ok(m) = std::fs::metadata(script_path)
        && !m.is_file()
    {
        use std::os::unix::fs::FileTypeExt;
        let t = m.file_type();
        let what = if t.is_char_device() {
            "a device (a serial port?)"
        } else if t.is_dir() {
            "a directory"
        } else {
            "not a regular file"
        };
        return Err(DeskError::NotAScript {
            path: script_path.to_path_buf(),
            what,
        });
    }
    let text = std::fs::read_to_string(script_path).map_err(|err| DeskError::File {
        path: script_path.to_path_buf(),
        err,
    })?;
    parse(&text).map_err(|e| in_file(e, script_path))
}

/// Name `file` in a script line's error.
fn in_file(e: DeskError, file: &Path) -> DeskError {
    match e {
        DeskError::Script { lines, .. } => DeskError::Script {
            file: Some(file.to_path_buf()),
            lines,
        },
        e => e,
    }
}

/// `Err` if `path` is a regular file or a directory: never a serial port (`run SCRIPT PORT`,
/// the arguments swapped).
fn check_port(path: &str) -> Result<(), DeskError> {
    match std::fs::metadata(path) {
        Ok(m) if m.is_file() || m.is_dir() => Err(LinkError::Open(format!(
            "{path}: a {}, not a serial port; the port comes first: `thermorph-desk run PORT SCRIPT`",
            if m.is_dir() { "directory" } else { "file" }
        ))
        .into()),
        _ => Ok(()),
    }
}

/// Open `path` and run the script file `script_path` (checked whole before anything is sent);
/// with [`RunOptions::record`], write the telemetry received meanwhile to that CSV (the stream
/// is turned on first and off however the run ends). A failure or `interrupt` sends `stop`
/// unless [`RunOptions::leave_running`] (or none of the script's commands had gone out yet);
/// either way `log` is told the state the block is left in.
pub fn run_file(
    path: &str,
    script_path: &Path,
    o: &RunOptions,
    interrupt: &AtomicBool,
    log: &mut dyn FnMut(&str),
) -> Result<(), DeskError> {
    check_port(path)?;
    let script = read_file(script_path)?;
    if let Some(r) = &o.record {
        super::record::check_out(r, o.force)?;
    }
    let mut link = Link::open(path, o.baud)?;
    // The recording's file is created only once the board has answered `stream on`.
    let mut sink = None;
    if let Some(r) = &o.record {
        let mut held = Vec::new();
        let reply = link.command("stream on", o.reply_timeout, &mut |l| {
            held.push(l.to_string())
        })?;
        if !reply.starts_with("ok") {
            return Err(DeskError::StreamRefused(reply));
        }
        let s = sink.insert(match CsvSink::create(r, o.force) {
            Ok(s) => s,
            Err(e) => {
                let _ = link.command("stream off", o.reply_timeout, &mut |_| {});
                return Err(e);
            }
        });
        for l in &held {
            s.line(l)?;
        }
    }
    let mut sent = false;
    let result = run(
        &mut link,
        &script,
        o.reply_timeout,
        &mut sink,
        interrupt,
        &mut sent,
        log,
    )
    .map_err(|e| in_file(e, script_path));
    if result.is_err() {
        if sent {
            leave(&mut link, o, &mut sink, log);
        } else {
            log("the run failed before any of its commands was sent: the block is left as it was");
        }
    }
    if sink.is_some() {
        // Best effort: the run's result matters more than the stream's state.
        match command(&mut link, "stream off", o.reply_timeout, &mut sink) {
            Ok(r) if r.starts_with("ok") => {}
            Ok(r) => log(&format!("`stream off` got `{r}`")),
            Err(e) => log(&format!("could not send `stream off`: {e}")),
        }
    }
    if let Some(s) = &sink {
        log(&format!(
            "recorded {} telemetry rows ({} gaps) to {}",
            s.rows,
            s.gaps,
            s.path().display()
        ));
    }
    result
}

/// What the block is doing, as its `status` says, for a person leaving it: `mode standby
/// (phase -), heater 12.5 %, fan 0.0 %, springs -, fault none` (or why it is unknown).
pub fn state_of(link: &mut Link, timeout: Duration, sink: &mut Option<CsvSink>) -> String {
    match status(link, timeout, sink) {
        Ok(f) => {
            let g = |n| get(&f, n).unwrap_or("?").to_string();
            format!(
                "mode {} (phase {}), heater {} %, fan {} %, springs {}, fault {}",
                g("mode"),
                g("phase"),
                g("heater_pct"),
                g("fan_pct"),
                g("springs"),
                g("fault")
            )
        }
        Err(e) => format!("in a state unknown ({e})"),
    }
}

/// After a failed or interrupted run: send `stop` (unless [`RunOptions::leave_running`]) and
/// say in what state the block is left.
fn leave(link: &mut Link, o: &RunOptions, sink: &mut Option<CsvSink>, log: &mut dyn FnMut(&str)) {
    let state = |link: &mut Link, sink: &mut Option<CsvSink>| state_of(link, o.reply_timeout, sink);
    if o.leave_running {
        let s = state(link, sink);
        log(&format!(
            "the run failed; --leave-running: nothing sent, the block is left in {s} (type `stop` \
             to end it)"
        ));
        return;
    }
    match command(link, "stop", o.reply_timeout, sink) {
        Ok(r) if r.starts_with("ok") => {
            let s = state(link, sink);
            log(&format!(
                "the run failed: sent `stop` -> {r}; the block is left in {s}"
            ));
        }
        Ok(r) => {
            let s = state(link, sink);
            log(&format!(
                "the run failed: sent `stop` but it got `{r}`; the block may still be running: {s}"
            ));
        }
        Err(e) => log(&format!(
            "the run failed: could not send `stop` ({e}); the block may still be running as the \
             script left it"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_parse_and_commands_are_checked_by_the_library() {
        let s = parse(
            "# preheat\nmode standby\nwait tc_k >= 320 within 90\n\nmode step-large AB  # two springs\n\
             try reset\nexpect-err fault-latched mode form\nexpect fault == none\nsleep 0.5\nwait mode == form\n",
        )
        .unwrap();
        assert_eq!(s.len(), 8);
        assert_eq!(
            s[0],
            (
                2,
                Step::Command {
                    line: "mode standby".into(),
                    any: false
                }
            )
        );
        assert_eq!(
            s[1],
            (
                3,
                Step::Wait {
                    cond: Cond {
                        field: "tc_k".into(),
                        op: Op::Ge,
                        value: "320".into()
                    },
                    within: Duration::from_secs(90)
                }
            )
        );
        assert_eq!(
            s[2].1,
            Step::Command {
                line: "mode step-large AB".into(),
                any: false
            }
        );
        assert_eq!(
            s[3].1,
            Step::Command {
                line: "reset".into(),
                any: true
            }
        );
        assert_eq!(
            s[4].1,
            Step::ExpectErr {
                code: "fault-latched".into(),
                line: "mode form".into()
            }
        );
        assert_eq!(s[6].1, Step::Sleep(Duration::from_millis(500)));
        assert!(matches!(&s[7].1, Step::Wait { within, .. } if *within == DEFAULT_WAIT));
    }

    #[test]
    fn pose_sends_the_mode_and_waits_for_its_end() {
        let s = parse("pose 30 AB form within 400\npose 12.5\n").unwrap();
        assert_eq!(s.len(), 4);
        assert_eq!(
            s[0],
            (
                1,
                Step::Command {
                    line: "mode pose 30 AB form".into(),
                    any: false
                }
            )
        );
        assert_eq!(
            s[1].1,
            Step::Wait {
                cond: Cond {
                    field: "mode".into(),
                    op: Op::Eq,
                    value: "standby".into()
                },
                within: Duration::from_secs(400)
            }
        );
        assert!(matches!(&s[3].1, Step::Wait { cond, within }
            if cond.field == "phase" && cond.value == "hold" && *within == DEFAULT_POSE_WAIT));
        // The pose's arguments are the library parser's to check.
        assert!(parse("pose 90 AB\n").is_err());
        assert!(parse("pose\n").is_err());
    }

    #[test]
    fn bad_lines_are_named() {
        assert_eq!(
            parse("status\nfrobnicate\n").unwrap_err().to_string(),
            "line 2: `frobnicate`: unknown command, try `help`"
        );
        assert!(
            parse("mode fly")
                .unwrap_err()
                .to_string()
                .starts_with("line 1: `mode fly`")
        );
        assert!(
            parse("set nope 1")
                .unwrap_err()
                .to_string()
                .contains("unknown parameter nope")
        );
        assert!(
            parse("wait tc_k ~ 3")
                .unwrap_err()
                .to_string()
                .contains("`~`")
        );
        assert!(
            parse("wait tc_k >= 3 within soon")
                .unwrap_err()
                .to_string()
                .contains("seconds")
        );
        assert!(parse("sleep -1").is_err());
        assert!(parse("expect mode").is_err());
    }

    #[test]
    fn every_bad_line_is_found_before_anything_runs() {
        let e =
            parse("mode standby\nwait tck >= 300\nexpect fault == none\nexpect faults == none\n")
                .unwrap_err()
                .to_string();
        let lines: Vec<&str> = e.lines().collect();
        assert_eq!(lines.len(), 2, "{e}");
        assert!(
            lines[0].starts_with("line 2: `status` has no field `tck` (did you mean `tc_k`?)"),
            "{e}"
        );
        assert!(
            lines[1].starts_with("line 4: `status` has no field `faults` (did you mean `fault`?)"),
            "{e}"
        );
        // No suggestion for a name nothing is close to; the fields are listed.
        let e = parse("wait colour == red").unwrap_err().to_string();
        assert!(!e.contains("did you mean") && e.contains("tc_k"), "{e}");
        // Named with the file once it is known.
        let e = in_file(parse("\nsleep x").unwrap_err(), Path::new("s.txt"));
        assert_eq!(e.to_string(), "s.txt:2: `x` is not a number of seconds");
    }

    #[test]
    fn conditions_compare_numbers_and_words() {
        let c = |f: &str, op, v: &str| Cond {
            field: f.into(),
            op,
            value: v.into(),
        };
        assert!(c("tc_k", Op::Ge, "355").holds("355.00"));
        assert!(!c("tc_k", Op::Ge, "355").holds("354.99"));
        assert!(c("tc_k", Op::Lt, "355").holds("300"));
        assert!(c("mode", Op::Eq, "form").holds("FORM"));
        assert!(c("fault", Op::Ne, "none").holds("heater-open"));
        assert!(!c("mode", Op::Lt, "form").holds("standby"));
        assert!(
            !c("tc_k", Op::Ge, "355").holds("-"),
            "a missing value never passes"
        );
        let f = fields("mode=form tc_k=330.5");
        assert!(check(&f, &c("tc_k", Op::Lt, "331")).unwrap());
        assert!(
            check(&f, &c("nope", Op::Eq, "1"))
                .unwrap_err()
                .to_string()
                .contains("mode tc_k")
        );
    }
}
