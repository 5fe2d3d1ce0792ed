//! `host-sim console [--speed X] [--pty] [--settings FILE] [SCENE]`: the simulated block behind
//! the board's console, on standard input/output or on a pseudo-terminal.
//!
//! This module owns the interactive console: the real-time loop, the byte path and the
//! settings file's place. The byte path is the board's: bytes → [`LineReader`] → a
//! [`Line`] → the simulated board ([`SimBoard`], which drives the library's
//! `thermorph::app::Controller` as the board does), one reply per complete non-blank line
//! (`err …` for a refused one), every line ended by CR LF, and `# warning` and `#` telemetry
//! lines written after whole replies by the same loop, so neither breaks the other.
//!
//! The block is the scene's plant, camera and injected faults (its timed duties and console
//! lines are not played: the person at the console drives the block), advanced tick by tick at
//! the board's control period, with a control period on every frame too. `save` writes the
//! settings record ([`thermorph::settings::Record`]) to the settings file, `load` reads it
//! ([`SimFlash::File`]), and the console starts with the file's settings (a bad or old file:
//! the defaults and a `# warning` line).
//!
//! Time runs at `speed` × real time; Ctrl-C (SIGINT or SIGTERM) or the end of standard input
//! ends the session cleanly.

use std::io::{Read, Write};
use std::os::fd::{AsFd, OwnedFd};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use thermorph::app::Line;
use thermorph::console::{LineReader, MAX_LINE};
use thermorph::settings::Settings;
use thermorph::supervisor::Supervisor;
use thermorph::supervisor::report::{SETTING_LINES, write_setting};
use thermorph::supervisor::store::settings_at_boot;
use thermorph::units::Millis;

use anyhow::{Context as _, bail};

use crate::rig::store::{SettingsFile, SimFlash};
use crate::rig::{RigError, Said, SimBoard};
use crate::runs::scenario::Scenario;

/// Arguments of `host-sim console`.
#[derive(clap::Args, Debug, Clone)]
pub struct ConsoleArgs {
    /// Scene giving the block, the camera and injected faults: a bundled name or a TOML file.
    #[arg(default_value = "cycle")]
    pub scene: String,
    /// Simulated seconds per real second.
    #[arg(long, default_value_t = 1.0)]
    pub speed: f64,
    /// Serve the console on a new pseudo-terminal (its path is printed) instead of stdin/stdout.
    #[arg(long)]
    pub pty: bool,
    /// Settings file for `save` and `load` (default `runs/console-settings.bin`).
    #[arg(long)]
    pub settings: Option<PathBuf>,
}

/// The simulated block behind the console: a [`SimBoard`] of the scene (its plant, camera and
/// injected faults; the scene's timed actions and lines are not played) with its controller.
pub struct Block {
    board: SimBoard,
}

impl Block {
    /// The block of `scenario` at time 0, its controller started as after a power-up with
    /// `settings` (`stopped`, unless `boot_mode` is 1), `save` and `load` on `store`.
    pub fn new(
        scenario: Scenario,
        settings: Settings,
        store: SettingsFile,
    ) -> Result<Self, RigError> {
        let mut board = SimBoard::new(&scenario.block(), true, settings, SimFlash::File(store))?;
        // As a board after a power-up: stopped unless the settings' `boot_mode` says standby.
        board.boot(thermorph::supervisor::ResetCause::PowerUp);
        Ok(Block { board })
    }

    /// The supervisor.
    pub fn supervisor(&self) -> &Supervisor {
        self.board
            .supervisor()
            .expect("a console board is closed loop")
    }

    /// Simulated time, s.
    pub fn time_s(&self) -> f64 {
        self.board.time_s()
    }

    /// Simulated time of the next tick's end, s.
    pub fn next_tick_s(&self) -> f64 {
        self.board.next_tick_us() as f64 * 1e-6
    }

    /// The board's clock now.
    pub fn now(&self) -> Millis {
        self.board.now()
    }

    /// One tick of the board: the block runs to the next tick, with a control period at each
    /// frame and at the tick; due warnings and telemetry lines go to `out`.
    pub fn tick(&mut self, out: &mut impl Write) -> std::io::Result<()> {
        let mut said = Vec::new();
        self.board.advance_to(self.board.next_tick_us(), &mut said);
        write_said(&said, out)
    }

    /// A console line now: its reply, then the period's warnings and telemetry, on `out`.
    pub fn line(&mut self, line: Line<'_>, out: &mut impl Write) -> std::io::Result<()> {
        let mut said = Vec::new();
        if let Some(reply) = self.board.line(line, &mut said) {
            if reply.lists_settings() {
                let settings = *self.supervisor().settings();
                for i in 0..SETTING_LINES {
                    let mut text = String::new();
                    // Writing into a String cannot fail.
                    let _ = write_setting(&mut text, &settings, i);
                    out.write_all(text.as_bytes())?;
                }
            }
            out.write_all(reply.as_str().as_bytes())?;
            out.write_all(b"\r\n")?;
        }
        write_said(&said, out)
    }
}

fn write_said(said: &[Said], out: &mut impl Write) -> std::io::Result<()> {
    for s in said {
        match s {
            Said::Notice(n) => write!(out, "# {n}\r\n")?,
            Said::Telemetry(t) => out.write_all(t.as_bytes())?,
        }
    }
    Ok(())
}

/// A console session: the board's line reader in front of the block.
pub struct Session {
    reader: LineReader<MAX_LINE>,
    /// The block.
    pub block: Block,
    /// Complete non-blank lines received.
    pub lines: u64,
}

impl Session {
    /// A session on `block`.
    pub fn new(block: Block) -> Self {
        Session {
            reader: LineReader::new(),
            block,
            lines: 0,
        }
    }

    /// Feed received bytes; every complete non-blank line is answered on `out` at once (a
    /// reply, then warnings and a telemetry line if that period made them due).
    pub fn feed(&mut self, bytes: &[u8], out: &mut impl Write) -> std::io::Result<()> {
        for &b in bytes {
            let Some(read) = self.reader.push(b) else {
                continue;
            };
            self.lines += 1;
            let line = match read {
                Ok(text) => Line::Text(text),
                Err(e) => Line::Refused(e),
            };
            self.block.line(line, out)?;
        }
        Ok(())
    }
}

/// Input to the console loop.
enum Input {
    Bytes(Vec<u8>),
    End,
}

/// Where the console's bytes go: standard output, or the pseudo-terminal's master side, which
/// never blocks the simulation (output nobody reads for 200 ms is dropped, as a UART with
/// nothing attached sends into the void).
enum Sink {
    Stdout(std::io::Stdout),
    Pty(std::fs::File),
}

impl Write for Sink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self {
            Sink::Stdout(s) => s.write(buf),
            Sink::Pty(f) => {
                let deadline = Instant::now() + Duration::from_millis(200);
                loop {
                    match f.write(buf) {
                        Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                            if Instant::now() >= deadline {
                                return Ok(buf.len());
                            }
                            std::thread::sleep(Duration::from_millis(2));
                        }
                        r => return r,
                    }
                }
            }
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        match self {
            Sink::Stdout(s) => s.flush(),
            Sink::Pty(f) => f.flush(),
        }
    }
}

/// A pseudo-terminal in raw mode (no echo, no line editing, CR and LF passed as they are, as a
/// UART): the master for the console, the slave kept open so that clients may come and go.
struct Pty {
    master: OwnedFd,
    _slave: OwnedFd,
    path: PathBuf,
}

fn open_pty() -> anyhow::Result<Pty> {
    use nix::sys::termios;
    let p = nix::pty::openpty(None, None).context("openpty")?;
    let mut t = termios::tcgetattr(p.slave.as_fd()).context("tcgetattr")?;
    termios::cfmakeraw(&mut t);
    termios::tcsetattr(p.slave.as_fd(), termios::SetArg::TCSANOW, &t).context("tcsetattr")?;
    let path = nix::unistd::ttyname(p.slave.as_fd()).context("ttyname")?;
    let flags =
        nix::fcntl::fcntl(p.master.as_fd(), nix::fcntl::FcntlArg::F_GETFL).context("fcntl")?;
    let flags = nix::fcntl::OFlag::from_bits_truncate(flags) | nix::fcntl::OFlag::O_NONBLOCK;
    nix::fcntl::fcntl(p.master.as_fd(), nix::fcntl::FcntlArg::F_SETFL(flags)).context("fcntl")?;
    Ok(Pty {
        master: p.master,
        _slave: p.slave,
        path,
    })
}

/// Read the pty's master (non-blocking) into `tx`, waiting with `poll`.
fn read_pty(master: std::fs::File, tx: mpsc::Sender<Input>) {
    use nix::poll::{PollFd, PollFlags, PollTimeout, poll};
    let mut master = master;
    let mut buf = [0u8; 4096];
    loop {
        let mut fds = [PollFd::new(master.as_fd(), PollFlags::POLLIN)];
        if poll(&mut fds, PollTimeout::from(200u16)).is_err() {
            std::thread::sleep(Duration::from_millis(10));
        }
        match master.read(&mut buf) {
            Ok(0) => std::thread::sleep(Duration::from_millis(10)),
            Ok(n) => {
                if tx.send(Input::Bytes(buf[..n].to_vec())).is_err() {
                    return;
                }
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {}
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            // EIO: no client has the slave open (ours keeps it, so only briefly).
            Err(_) => std::thread::sleep(Duration::from_millis(10)),
        }
    }
}

fn read_stdin(tx: mpsc::Sender<Input>) {
    let mut stdin = std::io::stdin().lock();
    let mut buf = [0u8; 4096];
    loop {
        match stdin.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => {
                if tx.send(Input::Bytes(buf[..n].to_vec())).is_err() {
                    return;
                }
            }
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(_) => break,
        }
    }
    let _ = tx.send(Input::End);
}

/// The settings file of a session (`--settings`, default `runs/console-settings.bin`).
pub fn settings_path(args: &ConsoleArgs) -> PathBuf {
    args.settings
        .clone()
        .unwrap_or_else(|| Path::new("runs").join("console-settings.bin"))
}

/// `host-sim console`: run the block behind the console until Ctrl-C or the end of input.
pub fn cli(args: &ConsoleArgs) -> anyhow::Result<()> {
    if !(args.speed.is_finite() && args.speed > 0.0) {
        bail!("--speed {}: must be a positive number", args.speed);
    }
    let scenario = crate::runs::scenario::load(&args.scene)?;
    let store = SettingsFile::new(settings_path(args));
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        ctrlc::set_handler(move || stop.store(true, Ordering::SeqCst))
            .context("cannot catch Ctrl-C")?;
    }
    let (tx, rx) = mpsc::channel();
    let mut out = if args.pty {
        let pty = open_pty()?;
        let master = std::fs::File::from(pty.master.try_clone()?);
        let reader = std::fs::File::from(pty.master.try_clone()?);
        std::thread::spawn(move || read_pty(reader, tx));
        println!("{}", pty.path.display());
        let _ = std::io::stdout().flush();
        // Keep the slave open for the whole session.
        std::mem::forget(pty);
        Sink::Pty(master)
    } else {
        std::thread::spawn(move || read_stdin(tx));
        Sink::Stdout(std::io::stdout())
    };
    let ignored = scenario.actions.len() + scenario.commands.len();
    eprintln!(
        "host-sim console: scene {} at {}× real time, settings file {}{}; Ctrl-C ends",
        scenario.name,
        args.speed,
        store.path().display(),
        if ignored > 0 {
            format!(" (the scene's {ignored} timed actions and lines are not played)")
        } else {
            String::new()
        }
    );
    let mut boot = String::new();
    let stored = store.read().unwrap_or_else(|e| {
        eprintln!("host-sim console: {e}");
        None
    });
    let settings = settings_at_boot(stored.as_deref(), &mut boot);
    out.write_all(boot.as_bytes())?;
    let mut session = Session::new(Block::new(scenario, settings, store)?);

    let started = Instant::now();
    let mut ended = false;
    while !ended && !stop.load(Ordering::SeqCst) {
        // Ticks due by now (at most 200 at a time, so input is never starved).
        let due_s = started.elapsed().as_secs_f64() * args.speed;
        let mut n = 0;
        while session.block.next_tick_s() <= due_s && n < 200 {
            session.block.tick(&mut out)?;
            n += 1;
        }
        out.flush()?;
        let next_wall_s = session.block.next_tick_s() / args.speed;
        let wait = (next_wall_s - started.elapsed().as_secs_f64()).clamp(0.0, 0.1);
        let mut msg = rx.recv_timeout(Duration::from_secs_f64(wait)).ok();
        while let Some(m) = msg {
            match m {
                Input::Bytes(b) => session.feed(&b, &mut out)?,
                Input::End => ended = true,
            }
            msg = rx.try_recv().ok();
        }
        out.flush()?;
    }
    eprintln!(
        "host-sim console: ended at t = {:.1} s after {} lines",
        session.block.time_s(),
        session.lines
    );
    Ok(())
}
