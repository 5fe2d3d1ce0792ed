//! `host-sim console [--speed X] [--pty] [--settings FILE] [SCENE]`: the simulated block behind
//! the board's console, on standard input/output or on a pseudo-terminal.
//!
//! This module owns the interactive console: the real-time loop, the byte path and the
//! settings file. The byte path is the board's: bytes → [`LineReader`] → [`parse_read`] →
//! [`Supervisor::step`] (the board orders these steps through `thermorph::app::Controller`;
//! this console does not drive it yet, and steps once per line where the board steps the
//! frame first), one reply per complete non-blank line
//! (`err …` from [`Reply::parse_error`] for a refused one), every line ended by CR LF, and `#`
//! telemetry lines from [`Supervisor::write_telemetry`] written between whole replies by the
//! same loop, so neither breaks the other.
//!
//! The block is the scene's plant, camera and injected faults (its timed duties and console
//! lines are not played: the person at the console drives the block), advanced in ticks of at
//! most [`TICK_S`] so that telemetry runs at up to 20 Hz; the supervisor gets a measurement once
//! per scene period, as in `host-sim run` ([`crate::runs::run`]'s `Control`, camera chain,
//! `measure` and [`inputs_of`](crate::runs::run::inputs_of)). `save` writes the settings record
//! ([`thermorph::settings::Record`]) to the settings file, `load` reads it, and the console
//! starts with the file's settings (a bad or old file: the defaults and a `# warning` line).
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

use thermorph::command::parse_read;
use thermorph::console::{LineReader, MAX_LINE};
use thermorph::measurement::Measurement;
use thermorph::settings::Settings;
use thermorph::supervisor::report::Reply;
use thermorph::supervisor::store::{StoreOutcome, StoreRequest, settings_at_boot};
use thermorph::supervisor::{SpringMemory, Supervisor};
use thermorph::units::Millis;

use crate::plant::Plant;
use crate::runs::run::{Camera, Control, apply_faults, block_of, inputs_of, measure};
use crate::runs::scenario::Scenario;

/// Longest tick of the simulated block, s: the supervisor steps at least this often (telemetry
/// runs at up to 20 Hz).
pub const TICK_S: f64 = thermorph::app::CONTROL_PERIOD_MS as f64 * 1e-3;

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

/// The settings file: the record's bytes, written whole (a temporary file renamed over it).
pub struct SettingsFile {
    path: PathBuf,
}

impl SettingsFile {
    /// The file at `path`.
    pub fn new(path: PathBuf) -> Self {
        SettingsFile { path }
    }

    /// Read the stored record: `Ok(None)` when there is no file.
    pub fn read(&self) -> Result<Option<Vec<u8>>, String> {
        match std::fs::read(&self.path) {
            Ok(b) => Ok(Some(b)),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(format!("{}: {e}", self.path.display())),
        }
    }

    /// Write a record.
    pub fn write(&self, record: &[u8]) -> Result<(), String> {
        if let Some(dir) = self.path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        }
        let tmp = self.path.with_extension("tmp");
        std::fs::write(&tmp, record)
            .and_then(|()| std::fs::rename(&tmp, &self.path))
            .map_err(|e| format!("{}: {e}", self.path.display()))
    }

    /// Carry out the supervisor's request at `now`; return its reply.
    pub fn carry_out(&self, req: &StoreRequest, supervisor: &mut Supervisor, now: Millis) -> Reply {
        match req {
            StoreRequest::Save(record) => match self.write(record) {
                Ok(()) => supervisor.finish_store(now, StoreOutcome::Saved),
                Err(e) => {
                    eprintln!("host-sim console: save: {e}");
                    supervisor
                        .finish_store(now, StoreOutcome::Failed("cannot write the settings file"))
                }
            },
            StoreRequest::Load => match self.read() {
                Ok(b) => supervisor.finish_store(now, StoreOutcome::Loaded(b.as_deref())),
                Err(e) => {
                    eprintln!("host-sim console: load: {e}");
                    supervisor
                        .finish_store(now, StoreOutcome::Failed("cannot read the settings file"))
                }
            },
        }
    }
}

/// The simulated block with its supervisor: plant, camera and faults of a scene.
pub struct Block {
    scenario: Scenario,
    plant: Plant,
    camera: Option<Camera>,
    control: Option<Control>,
    measurement: Option<Measurement>,
    tick_s: f64,
    ticks_per_period: u64,
    ticks: u64,
}

impl Block {
    /// The block of `scenario` at time 0, its supervisor started with `settings`.
    pub fn new(scenario: Scenario, settings: Settings) -> Result<Self, String> {
        let (plant, camera) = block_of(&scenario)?;
        let mut control = Control::new(Millis(0));
        control.supervisor = Supervisor::with_memory(Millis(0), settings, SpringMemory::RESTED);
        let ticks_per_period = (scenario.period_s / TICK_S).ceil().max(1.0) as u64;
        Ok(Block {
            tick_s: scenario.period_s / ticks_per_period as f64,
            ticks_per_period,
            scenario,
            plant,
            camera,
            control: Some(control),
            measurement: None,
            ticks: 0,
        })
    }

    /// The supervisor.
    pub fn supervisor(&mut self) -> &mut Supervisor {
        &mut self.control.as_mut().expect("always set").supervisor
    }

    /// Simulated time, s.
    pub fn time_s(&self) -> f64 {
        self.ticks as f64 * self.tick_s
    }

    /// Simulated time of the next tick's end, s.
    pub fn next_tick_s(&self) -> f64 {
        (self.ticks + 1) as f64 * self.tick_s
    }

    /// The supervisor's clock now.
    pub fn now(&self) -> Millis {
        Millis((self.time_s() * 1000.0).round() as u64)
    }

    /// One tick: the supervisor steps (with the measurement of the last period's end, if one
    /// came), a due telemetry line goes to `out`, and the plant advances with the decided
    /// outputs and the scene's active faults; at a period's end the block is measured.
    pub fn tick(&mut self, out: &mut impl Write) -> std::io::Result<()> {
        let now = self.now();
        let m = self.measurement.take();
        let sup = self.supervisor();
        let d = sup.step(now, m.as_ref(), None);
        if let Some(w) = d.warning {
            write!(out, "# warning: {w}\r\n")?;
        }
        if d.telemetry {
            write_telemetry(sup, now, out)?;
        }
        // A line between ticks is stepped at the tick's time, so this step's outputs already
        // include its effect.
        let t0_s = self.time_s();
        let mut inputs = inputs_of(&d.outputs);
        let (_, camera_faults) = apply_faults(&self.scenario.faults, t0_s, &mut inputs);
        self.plant.step(&inputs, self.tick_s);
        self.ticks += 1;
        if !self.ticks.is_multiple_of(self.ticks_per_period) {
            return Ok(());
        }
        let t1_s = self.time_s();
        let obs = self.plant.observe();
        let period = self.ticks / self.ticks_per_period;
        let hint = self
            .control
            .as_ref()
            .map_or_else(crate::runs::run::open_loop_hint, |c| {
                c.supervisor.sensing_hint()
            });
        self.measurement = measure(
            self.camera.as_mut(),
            &obs,
            camera_faults,
            t1_s,
            period,
            hint,
        )
        .1;
        Ok(())
    }
}

fn write_telemetry(sup: &Supervisor, now: Millis, out: &mut impl Write) -> std::io::Result<()> {
    let mut line = String::new();
    // Writing into a String cannot fail.
    let _ = sup.write_telemetry(now, &mut line);
    out.write_all(line.as_bytes())
}

/// A console session: the board's line reader in front of the block.
pub struct Session {
    reader: LineReader<MAX_LINE>,
    /// The block.
    pub block: Block,
    store: SettingsFile,
    /// Complete non-blank lines received.
    pub lines: u64,
}

impl Session {
    /// A session on `block`, storing settings in `store`.
    pub fn new(block: Block, store: SettingsFile) -> Self {
        Session {
            reader: LineReader::new(),
            block,
            store,
            lines: 0,
        }
    }

    /// Feed received bytes; every complete non-blank line is answered on `out` at once (a
    /// reply, then a telemetry line if that step made one due).
    pub fn feed(&mut self, bytes: &[u8], out: &mut impl Write) -> std::io::Result<()> {
        for &b in bytes {
            let Some(line) = self.reader.push(b) else {
                continue;
            };
            self.lines += 1;
            let now = self.block.now();
            let sup = self.block.supervisor();
            let (reply, telemetry) = match parse_read(line) {
                Ok(c) => {
                    let d = sup.step(now, None, Some(c));
                    let reply = match (&d.reply, &d.store) {
                        (Some(r), _) => r.clone(),
                        (None, Some(req)) => self.store.carry_out(req, sup, now),
                        (None, None) => Reply::err("internal", "no reply"),
                    };
                    (reply, d.telemetry)
                }
                Err(e) => (Reply::parse_error(e), false),
            };
            out.write_all(reply.as_str().as_bytes())?;
            out.write_all(b"\r\n")?;
            if telemetry {
                write_telemetry(sup, now, out)?;
            }
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

fn open_pty() -> Result<Pty, String> {
    use nix::sys::termios;
    let p = nix::pty::openpty(None, None).map_err(|e| format!("openpty: {e}"))?;
    let mut t = termios::tcgetattr(p.slave.as_fd()).map_err(|e| format!("tcgetattr: {e}"))?;
    termios::cfmakeraw(&mut t);
    termios::tcsetattr(p.slave.as_fd(), termios::SetArg::TCSANOW, &t)
        .map_err(|e| format!("tcsetattr: {e}"))?;
    let path = nix::unistd::ttyname(p.slave.as_fd()).map_err(|e| format!("ttyname: {e}"))?;
    let flags = nix::fcntl::fcntl(p.master.as_fd(), nix::fcntl::FcntlArg::F_GETFL)
        .map_err(|e| format!("fcntl: {e}"))?;
    let flags = nix::fcntl::OFlag::from_bits_truncate(flags) | nix::fcntl::OFlag::O_NONBLOCK;
    nix::fcntl::fcntl(p.master.as_fd(), nix::fcntl::FcntlArg::F_SETFL(flags))
        .map_err(|e| format!("fcntl: {e}"))?;
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
pub fn cli(args: &ConsoleArgs) -> Result<(), String> {
    if !(args.speed.is_finite() && args.speed > 0.0) {
        return Err(format!("--speed {}: must be a positive number", args.speed));
    }
    let scenario = crate::runs::scenario::load(&args.scene)?;
    let store = SettingsFile::new(settings_path(args));
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        ctrlc::set_handler(move || stop.store(true, Ordering::SeqCst))
            .map_err(|e| format!("cannot catch Ctrl-C: {e}"))?;
    }
    let (tx, rx) = mpsc::channel();
    let mut out = if args.pty {
        let pty = open_pty()?;
        let master = std::fs::File::from(pty.master.try_clone().map_err(|e| e.to_string())?);
        let reader = std::fs::File::from(pty.master.try_clone().map_err(|e| e.to_string())?);
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
        store.path.display(),
        if ignored > 0 {
            format!(" (the scene's {ignored} timed duties and lines are not played)")
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
    out.write_all(boot.as_bytes()).map_err(|e| e.to_string())?;
    let mut session = Session::new(Block::new(scenario, settings)?, store);

    let started = Instant::now();
    let mut ended = false;
    while !ended && !stop.load(Ordering::SeqCst) {
        // Ticks due by now (at most 200 at a time, so input is never starved).
        let due_s = started.elapsed().as_secs_f64() * args.speed;
        let mut n = 0;
        while session.block.next_tick_s() <= due_s && n < 200 {
            session.block.tick(&mut out).map_err(|e| e.to_string())?;
            n += 1;
        }
        out.flush().map_err(|e| e.to_string())?;
        let next_wall_s = session.block.next_tick_s() / args.speed;
        let wait = (next_wall_s - started.elapsed().as_secs_f64()).clamp(0.0, 0.1);
        let mut msg = rx.recv_timeout(Duration::from_secs_f64(wait)).ok();
        while let Some(m) = msg {
            match m {
                Input::Bytes(b) => session.feed(&b, &mut out).map_err(|e| e.to_string())?,
                Input::End => ended = true,
            }
            msg = rx.try_recv().ok();
        }
        out.flush().map_err(|e| e.to_string())?;
    }
    eprintln!(
        "host-sim console: ended at t = {:.1} s after {} lines",
        session.block.time_s(),
        session.lines
    );
    Ok(())
}
