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
//!
//! FIELD is a field of the `status` reply (`mode`, `phase`, `tc_k`, `t1_k`, `fault`, …); OP is
//! one of `==`, `!=`, `<`, `<=`, `>`, `>=`; numbers compare as numbers, words as words. So
//! `wait mode == form`, `wait fault != none within 30` and `wait tc_k >= 355 within 120` wait for
//! a mode, a fault and a temperature. Commands are checked with the library's parser when the
//! script is read; the run stops at the first failure. With `--record FILE.csv` the run turns
//! the telemetry stream on and writes every telemetry line it receives, as `record` does (one
//! serial port has room for one program, so the script's run records its own experiment).

use std::time::{Duration, Instant};

use super::link::{Line, Link};
use super::record::CsvSink;
use super::telemetry::{Fields, fields, get};
use super::{DeskError, WaitTimeout};

/// Default `wait` timeout.
pub const DEFAULT_WAIT: Duration = Duration::from_secs(60);
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

/// A script line's error: `line N: …`.
fn at_line(line: usize) -> impl Fn(DeskError) -> DeskError + Copy {
    move |e| DeskError::Line {
        line,
        err: Box::new(e),
    }
}

/// Parse a script; the error ([`DeskError::Line`]) names the line.
pub fn parse(text: &str) -> Result<Script, DeskError> {
    let mut out = Vec::new();
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
                    Ok(Step::Wait { cond: c, within })
                }
                "expect" => Ok(Step::Expect(cond(&words[1..])?)),
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
        })()
        .map_err(at_line(n))?;
        out.push((n, step));
    }
    Ok(out)
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

/// Run `script` on `link`, logging each step to `log`; stop at the first failure with an error
/// naming the line.
pub fn run(
    link: &mut Link,
    script: &Script,
    reply_timeout: Duration,
    sink: &mut Option<CsvSink>,
    log: &mut dyn FnMut(&str),
) -> Result<(), DeskError> {
    let started = Instant::now();
    for (n, step) in script {
        let at = || format!("[{:7.2} s] line {n}:", started.elapsed().as_secs_f64());
        let fail = at_line(*n);
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
                    drain(link, next, sink).map_err(fail)?;
                }
            }
            Step::Sleep(d) => {
                drain(link, Instant::now() + *d, sink).map_err(fail)?;
                log(&format!("{} slept {:.1} s", at(), d.as_secs_f64()));
            }
        }
    }
    Ok(())
}

/// Read lines until `until`, writing telemetry to `sink` (so nothing piles up while waiting).
fn drain(link: &mut Link, until: Instant, sink: &mut Option<CsvSink>) -> Result<(), DeskError> {
    while let Some(l) = link.next_line(until)? {
        if let (Line::Async(a), Some(s)) = (l, sink.as_mut()) {
            s.line(&a)?;
        }
    }
    Ok(())
}

/// Open `path` and run the script file `script_path`; with `record`, write the telemetry
/// received meanwhile to that CSV (the stream is turned on first and off at the end).
pub fn run_file(
    path: &str,
    baud: u32,
    script_path: &std::path::Path,
    reply_timeout: Duration,
    record: Option<&std::path::Path>,
    log: &mut dyn FnMut(&str),
) -> Result<(), DeskError> {
    let text = std::fs::read_to_string(script_path).map_err(|err| DeskError::File {
        path: script_path.to_path_buf(),
        err,
    })?;
    let script = parse(&text).map_err(|e| DeskError::Script {
        path: script_path.to_path_buf(),
        err: Box::new(e),
    })?;
    let mut link = Link::open(path, baud)?;
    let mut sink = record.map(CsvSink::create).transpose()?;
    if sink.is_some() {
        let r = command(&mut link, "stream on", reply_timeout, &mut sink)?;
        if !r.starts_with("ok") {
            return Err(DeskError::StreamRefused(r));
        }
    }
    let result = run(&mut link, &script, reply_timeout, &mut sink, log);
    if sink.is_some() {
        // Best effort: the run's result matters more than the stream's state.
        let _ = command(&mut link, "stream off", reply_timeout, &mut sink);
    }
    if let Some(s) = &sink {
        log(&format!(
            "recorded {} telemetry rows ({} gaps)",
            s.rows, s.gaps
        ));
    }
    result
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
                .contains("no such parameter")
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
