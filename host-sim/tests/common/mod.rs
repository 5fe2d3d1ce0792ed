//! Helpers the desk's end-to-end tests share: running `thermorph-desk` with a deadline, a
//! scratch folder, a PNG's size; a desk started in the background and interrupted (Ctrl-C).
#![allow(dead_code)]

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The desk binary.
pub const DESK: &str = env!("CARGO_BIN_EXE_thermorph-desk");

/// How a desk run ended.
pub struct Outcome {
    pub ok: bool,
    /// The exit status (`None`: ended by a signal).
    pub code: Option<i32>,
    pub stdout: String,
    pub stderr: String,
    pub took: Duration,
}

/// A desk process started by [`start`].
pub struct Running {
    child: Child,
    args: Vec<String>,
    started: Instant,
    feeder: std::thread::JoinHandle<()>,
    out_t: std::thread::JoinHandle<String>,
    err_t: std::thread::JoinHandle<String>,
}

/// The desk with `args` spawned, its standard streams piped (its history file under the
/// temporary folder, not the user's).
pub fn spawn_desk(args: &[&str]) -> Child {
    Command::new(DESK)
        .args(args)
        .env("HOME", std::env::temp_dir())
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start thermorph-desk")
}

/// Start the desk with `args`, `stdin` fed to it.
pub fn start(args: &[&str], stdin: &str) -> Running {
    let mut child = spawn_desk(args);
    let mut input = child.stdin.take().unwrap();
    let text = stdin.to_string();
    let feeder = std::thread::spawn(move || {
        let _ = input.write_all(text.as_bytes());
    });
    let mut out = child.stdout.take().unwrap();
    let mut err = child.stderr.take().unwrap();
    let out_t = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = out.read_to_string(&mut s);
        s
    });
    let err_t = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = err.read_to_string(&mut s);
        s
    });
    Running {
        child,
        args: args.iter().map(|a| a.to_string()).collect(),
        started: Instant::now(),
        feeder,
        out_t,
        err_t,
    }
}

impl Running {
    /// Send SIGINT, as Ctrl-C on its terminal does.
    pub fn interrupt(&self) {
        nix::sys::signal::kill(
            nix::unistd::Pid::from_raw(self.child.id() as i32),
            nix::sys::signal::Signal::SIGINT,
        )
        .expect("SIGINT to the desk");
    }

    /// Wait for the end, killing it and failing if it outlives `limit` (from its start).
    pub fn finish(mut self, limit: Duration) -> Outcome {
        let status = loop {
            if let Some(s) = self.child.try_wait().unwrap() {
                break s;
            }
            if self.started.elapsed() > limit {
                let _ = self.child.kill();
                let _ = self.child.wait();
                panic!(
                    "thermorph-desk {:?} still running after {limit:?}; stderr: {}",
                    self.args,
                    self.err_t.join().unwrap()
                );
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        self.feeder.join().unwrap();
        Outcome {
            ok: status.success(),
            code: status.code(),
            stdout: self.out_t.join().unwrap(),
            stderr: self.err_t.join().unwrap(),
            took: self.started.elapsed(),
        }
    }
}

/// Run the desk with `args` (and `stdin`), killing it and failing if it outlives `limit`.
pub fn desk(args: &[&str], stdin: &str, limit: Duration) -> Outcome {
    start(args, stdin).finish(limit)
}

pub fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("desk-e2e-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

pub fn png_size(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).unwrap();
    let reader = png::Decoder::new(std::io::Cursor::new(bytes))
        .read_info()
        .unwrap();
    (reader.info().width, reader.info().height)
}
