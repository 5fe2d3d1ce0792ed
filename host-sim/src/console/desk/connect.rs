//! `connect`: the interactive console.
//!
//! Line editing and history by rustyline; Tab completes command words from the library's
//! [`COMMANDS`], mode names from [`mode_names`], parameter names from [`PARAMS`] and spring
//! letters. Replies print as `< …` as they come. Telemetry is kept apart from them: it never
//! prints line by line; a status line `| t=… mode … T1 … T2 …` of the latest telemetry is printed
//! at most every `--status-every` seconds, and `.t` prints the latest telemetry line in full.
//!
//! A command that gets no reply within `--reply-timeout` is said so (``! no reply to `status`
//! … within 2.0 s …``), as `run` says it. A line starting with a dot is the desk's own: one it does
//! not know is refused here, never sent to the board.
//!
//! Leaving (`.quit`, Ctrl-D or Ctrl-C) sends nothing: the block stays in whatever mode it is in.
//! Only a typed `stop` turns its outputs off. Ctrl-C — typed at the prompt, or SIGINT between
//! prompts — leaves as `.quit` does and sets the caller's `interrupt` flag (the desk's exit
//! status 130). Lines typed on a terminal go through the line editor; from a pipe or a file
//! they are read by a thread of their own, so that Ctrl-C and a lost port end the session
//! while no line comes.

use std::collections::VecDeque;
use std::io::{BufRead, IsTerminal};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use rustyline::completion::{Completer, Pair};
use rustyline::error::ReadlineError;
use rustyline::highlight::Highlighter;
use rustyline::hint::Hinter;
use rustyline::history::FileHistory;
use rustyline::validate::Validator;
use rustyline::{Context, Editor, ExternalPrinter, Helper};
use thermorph::command::{COMMANDS, mode_names};
use thermorph::settings::PARAMS;

use super::DeskError;
use super::link::{Line, Link};
use super::telemetry::Telemetry;

/// The desk's own commands (they start with a dot, so they never collide with the console's).
pub const LOCAL: [(&str, &str); 3] = [
    (
        ".quit",
        "leave; the block stays as it is (type `stop` first to turn it off)",
    ),
    (".t", "print the latest telemetry line in full"),
    (".help", "this list (the board's commands: `help`)"),
];

/// What the desk does with a line starting with a dot: `Ok` with the [`LOCAL`] command it is
/// (`.q` and `.exit` are `.quit`), or the message refusing it (it is never sent to the board).
pub fn local(line: &str) -> Result<&'static str, String> {
    let word = line.split_whitespace().next().unwrap_or(line);
    let word = match word {
        ".q" | ".exit" => ".quit",
        w => w,
    };
    LOCAL.iter().find(|l| l.0 == word).map(|l| l.0).ok_or_else(|| {
        let names: Vec<&str> = LOCAL.iter().map(|l| l.0).collect();
        format!(
            "`{word}` is not a desk command (the desk's: {}); nothing sent. The board's commands \
             have no dot: `help` lists them",
            names.join(" ")
        )
    })
}

/// Completion candidates for the text before the cursor: where the word being completed starts
/// and the words that fit.
pub fn complete(before: &str) -> (usize, Vec<String>) {
    let start = before
        .rfind(|c: char| c.is_whitespace())
        .map_or(0, |i| i + 1);
    let prefix = &before[start..];
    let words: Vec<&str> = before[..start].split_whitespace().collect();
    let verb = words.first().map(|w| w.to_ascii_lowercase());
    let options: Vec<String> = match (words.len(), verb.as_deref()) {
        (0, _) => COMMANDS
            .iter()
            .map(|c| c.name.to_string())
            .chain(LOCAL.iter().map(|l| l.0.to_string()))
            .collect(),
        (1, Some("mode")) => mode_names().map(|m| m.0.to_string()).collect(),
        (1, Some("get" | "set")) => PARAMS.iter().map(|p| p.name.to_string()).collect(),
        (1, Some("stream")) => vec!["on".into(), "off".into()],
        (2, Some("mode")) if words[1].to_ascii_lowercase().starts_with("step-") => {
            let n = thermorph::outputs::SPRING_NAMES;
            (1u8..8)
                .map(|bits| {
                    (0..n.len())
                        .filter(|i| bits & (1 << i) != 0)
                        .map(|i| n[i])
                        .collect::<String>()
                })
                .collect()
        }
        _ => Vec::new(),
    };
    let p = prefix.to_ascii_lowercase();
    let mut fit: Vec<String> = options
        .into_iter()
        .filter(|o| o.to_ascii_lowercase().starts_with(&p))
        .collect();
    fit.sort();
    (start, fit)
}

struct DeskHelper;

impl Completer for DeskHelper {
    type Candidate = Pair;
    fn complete(
        &self,
        line: &str,
        pos: usize,
        _ctx: &Context<'_>,
    ) -> rustyline::Result<(usize, Vec<Pair>)> {
        let (start, fit) = complete(&line[..pos]);
        Ok((
            start,
            fit.into_iter()
                .map(|w| Pair {
                    display: w.clone(),
                    replacement: w,
                })
                .collect(),
        ))
    }
}

impl Hinter for DeskHelper {
    type Hint = String;
}
impl Highlighter for DeskHelper {}
impl Validator for DeskHelper {}
impl Helper for DeskHelper {}

/// How `connect` runs.
#[derive(Clone, Debug)]
pub struct ConnectOptions {
    /// Baud rate.
    pub baud: u32,
    /// Print the telemetry status line at most this often (`None`: never).
    pub status_every: Option<Duration>,
    /// History file.
    pub history: Option<std::path::PathBuf>,
    /// How long a command may wait for its reply before the desk says none came (and, on
    /// leaving, how long it waits for replies still due).
    pub reply_timeout: Duration,
}

/// The note for a command that got no reply in time.
fn no_reply(line: &str, path: &str, timeout: Duration) -> String {
    format!(
        "! no reply to `{line}` from {path} within {:.1} s: is this a Thermorph console?",
        timeout.as_secs_f64()
    )
}

/// Standard input's lines, read by a thread of their own (standard input not a terminal): the
/// channel closes at its end.
fn piped_lines() -> Receiver<String> {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in std::io::stdin().lock().lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    rx
}

/// Run the interactive console on `path` until the user leaves, the port is lost or
/// `interrupt` is set (Ctrl-C typed at the prompt sets it too).
pub fn connect(path: &str, o: &ConnectOptions, interrupt: &AtomicBool) -> Result<(), DeskError> {
    let mut link = Link::open(path, o.baud)?;
    let mut reader = link.try_clone()?;
    // Bash-like completion: Tab completes the common part, a second Tab lists the choices.
    let config = rustyline::Config::builder()
        .completion_type(rustyline::CompletionType::List)
        .auto_add_history(false)
        .build();
    let mut rl: Editor<DeskHelper, FileHistory> =
        Editor::with_config(config).map_err(DeskError::LineEditor)?;
    rl.set_helper(Some(DeskHelper));
    if let Some(h) = &o.history {
        let _ = rl.load_history(h);
    }
    // The reader thread's lines go through an unbounded channel to a printer thread: rustyline's
    // printer may block until the editor next reads a key, and the reader must never wait on it
    // (nor the main thread, which prints its own lines directly between prompts).
    let direct = Arc::new(AtomicBool::new(false));
    let (tx, rx) = std::sync::mpsc::channel::<String>();
    // Said by the printer thread once every line sent to it is out.
    let (printed_tx, printed) = std::sync::mpsc::channel::<()>();
    {
        let direct = direct.clone();
        let mut external = rl.create_external_printer().ok();
        std::thread::spawn(move || {
            for msg in rx {
                match external.as_mut() {
                    Some(p) if !direct.load(Ordering::SeqCst) => {
                        let _ = p.print(msg + "\n");
                    }
                    _ => println!("{msg}"),
                }
            }
            let _ = printed_tx.send(());
        });
    }
    let print = move |s: String| {
        let _ = tx.send(s);
    };
    println!(
        "connected to {path} at {} baud; Tab completes, `help` lists the board's commands, .help the desk's, .quit leaves",
        o.baud
    );
    let stop = Arc::new(AtomicBool::new(false));
    let lost = Arc::new(AtomicBool::new(false));
    // The commands sent and not answered yet, oldest first, with when they were sent.
    let pending: Arc<Mutex<VecDeque<(Instant, String)>>> = Arc::default();
    let latest: Arc<Mutex<Option<String>>> = Arc::new(Mutex::new(None));
    let thread = {
        let (stop, lost, pending, latest, print) = (
            stop.clone(),
            lost.clone(),
            pending.clone(),
            latest.clone(),
            print.clone(),
        );
        let every = o.status_every;
        let timeout = o.reply_timeout;
        let path = path.to_string();
        std::thread::spawn(move || {
            let mut last_status: Option<Instant> = None;
            let mut last_garbage: Option<Instant> = None;
            let mut unreadable = 0u64;
            while !stop.load(Ordering::Relaxed) {
                // Commands whose reply is overdue: said once, then forgotten.
                if let Ok(mut p) = pending.lock() {
                    while p.front().is_some_and(|(at, _)| at.elapsed() >= timeout) {
                        if let Some((_, line)) = p.pop_front() {
                            print(no_reply(&line, &path, timeout));
                        }
                    }
                }
                match reader.next_line(Instant::now() + Duration::from_millis(100)) {
                    Ok(Some(Line::Reply(r))) => {
                        print(format!("< {r}"));
                        if let Ok(mut p) = pending.lock() {
                            p.pop_front();
                        }
                    }
                    Ok(Some(Line::Async(a))) => {
                        if let Some(t) = Telemetry::parse(&a) {
                            let due = every.is_some_and(|e| {
                                last_status.is_none_or(|l: Instant| l.elapsed() >= e)
                            });
                            if due {
                                print(format!("  | {}", t.summary()));
                                last_status = Some(Instant::now());
                            }
                        } else {
                            print(format!("  {a}"));
                        }
                        if let Ok(mut l) = latest.lock() {
                            *l = Some(a);
                        }
                    }
                    Ok(Some(Line::Garbage(_))) => {
                        // At most one note a second, however fast a port spews.
                        unreadable += 1;
                        if last_garbage
                            .is_none_or(|l: Instant| l.elapsed() >= Duration::from_secs(1))
                        {
                            print(format!("  ! {unreadable} unreadable lines so far"));
                            last_garbage = Some(Instant::now());
                        }
                    }
                    Ok(None) => {}
                    Err(e) => {
                        print(format!("! {e}"));
                        lost.store(true, Ordering::SeqCst);
                        break;
                    }
                }
            }
        })
    };
    let piped = (!std::io::stdin().is_terminal()).then(piped_lines);
    let mut result = Ok(());
    loop {
        if lost.load(Ordering::SeqCst) {
            result = Err(DeskError::PortLost(path.to_string()));
            break;
        }
        if interrupt.load(Ordering::SeqCst) {
            break;
        }
        let typed = match &piped {
            None => rl.readline("desk> "),
            Some(lines) => match lines.recv_timeout(Duration::from_millis(100)) {
                Ok(l) => Ok(l),
                Err(RecvTimeoutError::Timeout) => continue,
                Err(RecvTimeoutError::Disconnected) => Err(ReadlineError::Eof),
            },
        };
        match typed {
            Ok(line) => {
                let line = line.trim();
                if line.is_empty() {
                    continue;
                }
                let _ = rl.add_history_entry(line);
                let desk = line.starts_with('.').then(|| local(line));
                match desk {
                    Some(Err(why)) => println!("! {why}"),
                    Some(Ok(".quit")) => break,
                    Some(Ok(".t")) => {
                        let l = latest.lock().ok().and_then(|l| l.clone());
                        println!(
                            "{}",
                            l.unwrap_or_else(|| "no telemetry yet (`stream on`)".into())
                        );
                    }
                    Some(Ok(_)) => {
                        for (n, h) in LOCAL {
                            println!("{n:8} {h}");
                        }
                    }
                    None => {
                        if let Ok(mut p) = pending.lock() {
                            p.push_back((Instant::now(), line.to_string()));
                        }
                        if let Err(e) = link.send(line) {
                            result = Err(e.into());
                            break;
                        }
                    }
                }
            }
            Err(ReadlineError::Interrupted) => {
                interrupt.store(true, Ordering::SeqCst);
                break;
            }
            Err(ReadlineError::Eof) => break,
            Err(e) => {
                result = Err(DeskError::LineEditor(e));
                break;
            }
        }
    }
    // Let the replies still due arrive before leaving; the editor is done, so print directly.
    direct.store(true, Ordering::SeqCst);
    // (The reader thread says which of them timed out.)
    let until = Instant::now() + o.reply_timeout + Duration::from_millis(300);
    while pending.lock().is_ok_and(|p| !p.is_empty())
        && Instant::now() < until
        && !lost.load(Ordering::SeqCst)
    {
        std::thread::sleep(Duration::from_millis(20));
    }
    stop.store(true, Ordering::SeqCst);
    let _ = thread.join();
    // Every line the reader passed on is printed before leaving (the channel closes with the
    // last sender; bounded, in case the editor's printer is stuck).
    drop(print);
    let _ = printed.recv_timeout(Duration::from_millis(500));
    if let Ok(mut p) = pending.lock() {
        for (_, line) in p.drain(..) {
            println!("{}", no_reply(&line, path, o.reply_timeout));
        }
    }
    if let Some(h) = &o.history {
        let _ = rl.save_history(h);
    }
    // What the block is doing as the desk leaves it (as `run` says when it stops): asked once
    // more, unless the port is gone.
    let state = if lost.load(Ordering::SeqCst) {
        "in a state unknown (the port was lost)".to_string()
    } else {
        super::script::state_of(&mut link, o.reply_timeout, &mut None)
    };
    println!("left {path}; the block was left as it is, {state} (only `stop` turns it off)");
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn completion_follows_the_library_tables() {
        let (s, c) = complete("mo");
        assert_eq!((s, c), (0, vec!["mode".to_string()]));
        let (s, c) = complete("mode step");
        assert_eq!(s, 5);
        assert_eq!(c, ["step-large", "step-small"]);
        let (_, c) = complete("mode step-large ");
        assert_eq!(c.len(), 7);
        assert!(c.contains(&"AB".to_string()));
        let (_, c) = complete("mode form ");
        assert!(c.is_empty());
        let (s, c) = complete("set ho");
        assert_eq!(s, 4);
        assert!(c.iter().all(|n| n.starts_with("ho")) && c.contains(&"hot_k".to_string()));
        assert_eq!(complete("stream o").1, ["off", "on"]);
        let (_, all) = complete("");
        assert_eq!(all.len(), COMMANDS.len() + LOCAL.len());
        assert!(complete(".q").1.contains(&".quit".to_string()));
    }

    #[test]
    fn dot_lines_are_the_desks_own() {
        assert_eq!(local(".quit"), Ok(".quit"));
        assert_eq!(local(".q"), Ok(".quit"));
        assert_eq!(local(".t"), Ok(".t"));
        let e = local(".foo bar").unwrap_err();
        assert!(e.contains("`.foo` is not a desk command"), "{e}");
        assert!(
            e.contains(".quit .t .help") && e.contains("nothing sent"),
            "{e}"
        );
    }
}
