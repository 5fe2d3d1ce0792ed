//! `thermorph-desk` end to end, through the real serial stack on pseudo-terminals.
//!
//! Each test opens a pty pair and plays a fake board on the master side: host-sim's simulated
//! board (`rig::SimBoard`: the library's `Controller` around the plant, true region
//! temperatures, no camera), its control loop run faster than real time. The desk binary is started as a process on the
//! slave side, exactly as it opens the NUCLEO's ST-LINK port. Other boards spew garbage or never
//! answer, one is reset, one vanishes. Every process is waited for with a limit: a desk that
//! hangs fails the test instead of hanging it.

use std::fs::File;
use std::io::{ErrorKind, Read, Write};
use std::os::fd::{AsRawFd, OwnedFd};
use std::path::PathBuf;
use std::sync::{Arc, Mutex, mpsc};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use host_sim::console::desk::telemetry::csv_header;
use host_sim::rig::store::SimFlash;
use host_sim::rig::{Said, SimBoard};
use host_sim::runs::plot::Table;
use thermorph::app::Line;
use thermorph::console::LineReader;
use thermorph::settings::Settings;

mod common;

use common::{desk, png_size, scratch};

/// How the fake board behaves.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Behaviour {
    /// The supervisor behind the console, with the plant.
    Board,
    /// Random bytes, never a reply.
    Garbage,
    /// Reads everything, answers nothing.
    Silent,
}

enum Ctl {
    /// A board reset: a new supervisor (clock from 0, stream off); the block keeps its heat.
    Reset,
    /// Close the master side: the port vanishes.
    Vanish,
}

/// What the board side saw and is doing, for the tests to assert on.
#[derive(Clone, Debug, Default)]
struct View {
    /// Every line the board received, in order.
    lines: Vec<String>,
    /// The supervisor's mode now.
    mode: String,
    /// The heater's duty now, %.
    heater_pct: f32,
    /// Telemetry lines the board has written.
    telemetry: u64,
}

struct FakeBoard {
    path: PathBuf,
    ctl: mpsc::Sender<Ctl>,
    view: Arc<Mutex<View>>,
    thread: Option<JoinHandle<()>>,
}

fn write_all(master: &mut File, bytes: &[u8]) {
    let mut rest = bytes;
    let until = Instant::now() + Duration::from_secs(1);
    while !rest.is_empty() && Instant::now() < until {
        match master.write(rest) {
            Ok(n) => rest = &rest[n..],
            Err(e) if e.kind() == ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(2))
            }
            // EIO: nobody has the slave side open; like a board talking to no one.
            Err(_) => return,
        }
    }
}

/// Write what the board said besides its replies (warnings, telemetry), and forget it; count
/// the telemetry lines in `view`.
fn write_said(master: &mut File, said: &mut Vec<Said>, view: &Mutex<View>) {
    for s in said.drain(..) {
        match s {
            Said::Notice(n) => write_all(master, format!("# {n}\r\n").as_bytes()),
            Said::Telemetry(t) => {
                write_all(master, t.as_bytes());
                view.lock().unwrap().telemetry += 1;
            }
        }
    }
}

impl FakeBoard {
    fn start(behaviour: Behaviour, speed: f64) -> FakeBoard {
        let pty = nix::pty::openpty(None, None).expect("openpty");
        let path = std::fs::read_link(format!("/proc/self/fd/{}", pty.slave.as_raw_fd()))
            .expect("slave path");
        // A board's USB serial port does not echo: raw mode before anyone opens the slave, or
        // the line discipline would echo the board's own telemetry back to it.
        let mut raw = nix::sys::termios::tcgetattr(&pty.slave).expect("tcgetattr");
        nix::sys::termios::cfmakeraw(&mut raw);
        nix::sys::termios::tcsetattr(&pty.slave, nix::sys::termios::SetArg::TCSANOW, &raw)
            .expect("tcsetattr");
        // The desk opens the slave by its path; the test keeps no handle on it.
        drop(pty.slave);
        let master: OwnedFd = pty.master;
        // openpty(3) does not set close-on-exec: without it every desk process started later
        // would inherit this master and keep the pseudo-terminal alive after `vanish`.
        nix::fcntl::fcntl(
            &master,
            nix::fcntl::FcntlArg::F_SETFD(nix::fcntl::FdFlag::FD_CLOEXEC),
        )
        .expect("close-on-exec master");
        nix::fcntl::fcntl(
            &master,
            nix::fcntl::FcntlArg::F_SETFL(nix::fcntl::OFlag::O_NONBLOCK),
        )
        .expect("non-blocking master");
        let mut master = File::from(master);
        let (tx, rx) = mpsc::channel();
        let view = Arc::new(Mutex::new(View::default()));
        let seen = view.clone();
        let thread = std::thread::spawn(move || {
            // The simulated board (host-sim's rig, the library's Controller inside), camera
            // off: true region temperatures four times a second.
            let scene = host_sim::runs::scenario::parse(
                "name = \"desk\"\nduration = \"1 s\"\nambient = \"298.15 K\"\nperiod = \"0.25 s\"\n\
                 [fidelity]\ncamera = false\n[[command]]\nat = \"0 s\"\nline = \"status\"\n",
                "<desk_e2e>",
                "desk",
            )
            .expect("scene");
            let mut board = SimBoard::new(
                &scene.block(),
                true,
                Settings::DEFAULT,
                SimFlash::Memory(None),
            )
            .expect("board");
            let mut reader: LineReader = LineReader::new();
            let started = Instant::now();
            let mut said = Vec::new();
            let mut rng = 0x9E37_79B9_7F4A_7C15u64;
            loop {
                match rx.try_recv() {
                    Ok(Ctl::Vanish) | Err(mpsc::TryRecvError::Disconnected) => return,
                    Ok(Ctl::Reset) => {
                        // A reset keeps RAM: the springs' memory survives it.
                        board.reset(Settings::DEFAULT);
                        reader = LineReader::new();
                    }
                    Err(mpsc::TryRecvError::Empty) => {}
                }
                let mut buf = [0u8; 256];
                if let Ok(n) = master.read(&mut buf) {
                    for &b in &buf[..n] {
                        if behaviour != Behaviour::Board {
                            continue;
                        }
                        let line = match reader.push(b) {
                            None => continue,
                            Some(Ok(text)) => {
                                seen.lock().unwrap().lines.push(text.to_string());
                                Line::Text(text)
                            }
                            Some(Err(e)) => Line::Refused(e),
                        };
                        if let Some(r) = board.line(line, &mut said) {
                            write_all(&mut master, format!("{}\r\n", r.as_str()).as_bytes());
                        }
                        write_said(&mut master, &mut said, &seen);
                    }
                }
                if behaviour == Behaviour::Garbage {
                    let junk: Vec<u8> = (0..96)
                        .map(|_| {
                            rng ^= rng << 13;
                            rng ^= rng >> 7;
                            rng ^= rng << 17;
                            (rng >> 24) as u8
                        })
                        .collect();
                    write_all(&mut master, &junk);
                }
                // The board's control loop, catching up with the clock (at most 2 s of
                // simulated time at once).
                let target_us = (started.elapsed().as_secs_f64() * speed * 1e6) as u64;
                let target_us = target_us.min(board.time_us() + 2_000_000);
                board.advance_to(target_us, &mut said);
                if behaviour == Behaviour::Board {
                    write_said(&mut master, &mut said, &seen);
                }
                said.clear();
                if let Some(s) = board.supervisor() {
                    let mut v = seen.lock().unwrap();
                    v.mode = s.mode().name().to_string();
                    v.heater_pct = s.outputs().heater.pct();
                }
                std::thread::sleep(Duration::from_millis(4));
            }
        });
        FakeBoard {
            path,
            ctl: tx,
            view,
            thread: Some(thread),
        }
    }

    fn path(&self) -> &str {
        self.path.to_str().unwrap()
    }

    /// What the board saw and is doing now.
    fn view(&self) -> View {
        self.view.lock().unwrap().clone()
    }

    /// Wait until `f` holds for the board's view (at most `limit`); return that view.
    fn until(&self, limit: Duration, what: &str, f: impl Fn(&View) -> bool) -> View {
        let end = Instant::now() + limit;
        loop {
            let v = self.view();
            if f(&v) {
                return v;
            }
            assert!(
                Instant::now() < end,
                "board: {what} not within {limit:?}: {v:?}"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Assert that the board writes no telemetry over `for_` (the stream is off).
    fn assert_silent(&self, for_: Duration) {
        let before = self.view().telemetry;
        std::thread::sleep(for_);
        let after = self.view().telemetry;
        assert_eq!(before, after, "the board still streams telemetry");
    }

    fn reset(&self) {
        self.ctl.send(Ctl::Reset).unwrap();
    }

    fn vanish(mut self) {
        let _ = self.ctl.send(Ctl::Vanish);
        if let Some(t) = self.thread.take() {
            t.join().unwrap();
        }
    }
}

impl Drop for FakeBoard {
    fn drop(&mut self) {
        let _ = self.ctl.send(Ctl::Vanish);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Connect, then a script that preheats, steps with two springs, forms and recovers while it
/// records the telemetry; then plot the recording.
#[test]
fn connect_run_a_full_cycle_record_and_plot() {
    // 10× real time: a 6 s spring phase lasts 600 ms, so the script's `status` polls (every
    // 200 ms plus the round trip) cannot alias with the 8 s stepping period and miss it.
    let board = FakeBoard::start(Behaviour::Board, 10.0);
    let dir = scratch("cycle");

    let hist = dir.join("history");
    let c = desk(
        &[
            "connect",
            board.path(),
            "--status-every",
            "0",
            "--history",
            hist.to_str().unwrap(),
        ],
        "version\nget hot_k\nmode fly\n.foo\n.quit\n",
        Duration::from_secs(20),
    );
    assert!(c.ok, "{}\n{}", c.stdout, c.stderr);
    assert!(c.stdout.contains("< ok thermorph "), "{}", c.stdout);
    assert!(c.stdout.contains("< ok hot_k=358"), "{}", c.stdout);
    assert!(c.stdout.contains("< err bad-arguments"), "{}", c.stdout);
    // Leaving says what the block is doing, as `run` does (issue 44).
    assert!(
        c.stdout.contains("left as it is, mode standby (phase ")
            && c.stdout.contains("%, springs ")
            && c.stdout.contains(", fault none (only `stop` turns it off)"),
        "{}",
        c.stdout
    );
    // `.foo` is refused by the desk, with the desk's own commands; the board never sees it.
    assert!(
        c.stdout
            .contains("`.foo` is not a desk command (the desk's: .quit .t .help)"),
        "{}",
        c.stdout
    );
    let seen = board.view().lines;
    assert_eq!(
        seen,
        ["version", "get hot_k", "mode fly", "status"],
        "the board got {seen:?} (the last, the desk's own as it leaves)"
    );
    assert!(!c.stdout.contains("no reply"), "{}", c.stdout);

    let script = dir.join("cycle.txt");
    std::fs::write(
        &script,
        "# preheat in standby (323 K)\n\
         mode standby\n\
         wait tc_k >= 318 within 60\n\
         expect fault == none\n\
         # large stepping with springs A and B at 358 K\n\
         mode step-large AB\n\
         wait phase == spring within 60\n\
         wait springs == AB within 10\n\
         wait phase == hold within 60\n\
         # lock the shape, then recover it\n\
         mode form\n\
         wait mode == standby within 60\n\
         mode recover\n\
         wait mode == standby within 60\n\
         expect fault == none\n",
    )
    .unwrap();
    let csv = dir.join("cycle.csv");
    let r = desk(
        &[
            "run",
            board.path(),
            script.to_str().unwrap(),
            "--record",
            csv.to_str().unwrap(),
        ],
        "",
        Duration::from_secs(150),
    );
    assert!(r.ok, "{}\n{}", r.stdout, r.stderr);
    assert!(r.stdout.contains("script passed"), "{}", r.stdout);

    // The CSV: the library's fields, every mode of the cycle, springs A+B, a steady clock.
    let text = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(text.lines().next().unwrap(), csv_header());
    let t = Table::parse(&text).unwrap();
    assert!(t.len() > 200, "{} rows", t.len());
    let modes = t.text("mode").unwrap();
    for m in ["standby", "step-large", "form", "recover"] {
        assert!(modes.contains(&m), "no {m} in the recording");
    }
    let springs = t.text("springs").unwrap();
    assert!(springs.contains(&"AB"));
    // Recovery's pulse drives every spring.
    assert!(
        modes
            .iter()
            .zip(&springs)
            .any(|(m, s)| *m == "recover" && *s == "ABC"),
        "no recovery pulse recorded"
    );
    let board_t = t.num("t_s").unwrap();
    assert!(
        board_t.windows(2).all(|w| w[1] > w[0]),
        "board clock not increasing"
    );
    let t1 = t.num("t1_k").unwrap();
    let hot = t1.iter().cloned().fold(f64::MIN, f64::max);
    assert!(
        hot > 355.0,
        "the film never reached the stepping temperature: {hot}"
    );
    assert!(t.text("gap").unwrap().iter().all(|g| *g == "-"));

    let png = dir.join("cycle.png");
    let p = desk(
        &[
            "plot",
            csv.to_str().unwrap(),
            "--out",
            png.to_str().unwrap(),
        ],
        "",
        Duration::from_secs(30),
    );
    assert!(p.ok, "{}", p.stderr);
    assert!(
        p.stdout.contains("temperatures, duties, springs"),
        "{}",
        p.stdout
    );
    let (w, h) = png_size(&png);
    assert_eq!(w, host_sim::runs::plot::WIDTH_PX);
    assert!(h > 600, "{h}");
    if let Some(keep) = std::env::var_os("DESK_E2E_KEEP") {
        std::fs::copy(&png, PathBuf::from(&keep).join("desk-cycle.png")).unwrap();
        std::fs::copy(&csv, PathBuf::from(keep).join("desk-cycle.csv")).unwrap();
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A board reset (clock back to 0, stream off) and an unplug/replug (the port's name moves to a
/// new pseudo-terminal, as a udev by-id link does) during a recording: it carries on and marks
/// both gaps.
#[test]
fn record_survives_a_reset_and_a_replug() {
    let dir = scratch("replug");
    let link = dir.join("board");
    let board = FakeBoard::start(Behaviour::Board, 5.0);
    std::os::unix::fs::symlink(board.path(), &link).unwrap();
    let csv = dir.join("rec.csv");
    let (l, c) = (link.clone(), csv.clone());
    let rec = std::thread::spawn(move || {
        desk(
            &[
                "record",
                l.to_str().unwrap(),
                "--out",
                c.to_str().unwrap(),
                "--duration",
                "7",
                "--hz",
                "10",
                "--silence",
                "0.8",
                "--reconnect",
                "5",
            ],
            "",
            Duration::from_secs(40),
        )
    });
    std::thread::sleep(Duration::from_millis(1500));
    board.reset();
    std::thread::sleep(Duration::from_millis(2000));
    board.vanish();
    std::thread::sleep(Duration::from_millis(600));
    let board2 = FakeBoard::start(Behaviour::Board, 5.0);
    std::fs::remove_file(&link).unwrap();
    std::os::unix::fs::symlink(board2.path(), &link).unwrap();
    let r = rec.join().unwrap();
    assert!(r.ok, "{}", r.stderr);
    assert!(r.took < Duration::from_secs(20), "{:?}", r.took);
    let t = Table::read(&csv).unwrap();
    let gaps: Vec<&str> = t
        .text("gap")
        .unwrap()
        .into_iter()
        .filter(|g| *g != "-")
        .collect();
    assert!(
        gaps.iter().any(|g| *g == "reset" || *g == "silence"),
        "{gaps:?}"
    );
    assert!(gaps.contains(&"reconnect"), "{gaps:?}\n{}", r.stderr);
    // Host time runs on across the gaps; rows came before and after each.
    let host = t.num("time_s").unwrap();
    assert!(host.windows(2).all(|w| w[1] >= w[0]));
    let gap_col = t.text("gap").unwrap();
    let last_gap = gap_col.iter().rposition(|g| *g == "reconnect").unwrap();
    assert!(
        last_gap > 10 && last_gap + 10 < t.len(),
        "{last_gap} of {}",
        t.len()
    );
    drop(board2);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A port that vanishes for good: the recording ends with a clear error once the reconnect
/// time is over, and keeps every row it had.
#[test]
fn a_vanished_port_ends_the_recording_with_an_error() {
    let dir = scratch("vanish");
    let board = FakeBoard::start(Behaviour::Board, 5.0);
    let csv = dir.join("rec.csv");
    let (p, c) = (board.path().to_string(), csv.clone());
    let rec = std::thread::spawn(move || {
        desk(
            &[
                "record",
                &p,
                "--out",
                c.to_str().unwrap(),
                "--hz",
                "10",
                "--reconnect",
                "1.5",
            ],
            "",
            Duration::from_secs(30),
        )
    });
    std::thread::sleep(Duration::from_millis(1500));
    board.vanish();
    let r = rec.join().unwrap();
    assert!(!r.ok);
    assert!(r.stderr.contains("not back within 1.5 s"), "{}", r.stderr);
    assert!(r.took < Duration::from_secs(10), "{:?}", r.took);
    let t = Table::read(&csv).unwrap();
    assert!(t.len() >= 5, "{} rows kept", t.len());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A port that spews garbage and one that never answers: clear errors within the reply
/// timeout, never a hang.
#[test]
fn garbage_and_silence_give_clear_errors_in_time() {
    let dir = scratch("bad");
    let script = dir.join("s.txt");
    std::fs::write(&script, "status\n").unwrap();
    for (behaviour, want) in [
        (Behaviour::Garbage, "garbage lines instead"),
        (Behaviour::Silent, "no reply to `status`"),
    ] {
        let board = FakeBoard::start(behaviour, 1.0);
        let r = desk(
            &[
                "run",
                board.path(),
                script.to_str().unwrap(),
                "--reply-timeout",
                "1",
            ],
            "",
            Duration::from_secs(15),
        );
        assert!(!r.ok, "{behaviour:?}: {}", r.stdout);
        assert!(r.stderr.contains(want), "{behaviour:?}: {}", r.stderr);
        assert!(
            r.stderr.contains(&format!("{}:1: ", script.display())),
            "{}",
            r.stderr
        );
        let csv = dir.join("r.csv");
        let r = desk(
            &["record", board.path(), "--out", csv.to_str().unwrap()],
            "",
            Duration::from_secs(15),
        );
        assert!(!r.ok, "{behaviour:?}");
        assert!(r.stderr.contains("Thermorph console?"), "{}", r.stderr);
        // Connect says no reply came, as `run` does, and leaves after the reply timeout.
        let c = desk(
            &[
                "connect",
                board.path(),
                "--status-every",
                "0",
                "--reply-timeout",
                "1",
            ],
            "status\n",
            Duration::from_secs(15),
        );
        assert!(c.ok, "{behaviour:?}: {}", c.stderr);
        assert!(!c.stdout.contains("< ok"), "{}", c.stdout);
        assert!(
            c.stdout.contains(&format!(
                "! no reply to `status` from {} within 1.0 s: is this a Thermorph console?",
                board.path()
            )),
            "{behaviour:?}: {}",
            c.stdout
        );
        assert!(c.took < Duration::from_secs(5), "{:?}", c.took);
    }
    let r = desk(
        &[
            "run",
            "/dev/nonexistent-thermorph",
            script.to_str().unwrap(),
        ],
        "",
        Duration::from_secs(10),
    );
    assert!(
        !r.ok && r.stderr.contains("cannot open port"),
        "{}",
        r.stderr
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A script that fails mid-way (a `wait` that times out) with the heater on: the desk sends
/// `stop` and says what it left; with `--leave-running` it sends nothing and says so.
#[test]
fn a_failed_run_stops_the_block_and_says_what_it_left() {
    let dir = scratch("failed");
    let board = FakeBoard::start(Behaviour::Board, 10.0);
    // A run that fails before any of its commands went out sends nothing: the block is as the
    // desk found it.
    let early = dir.join("early.txt");
    std::fs::write(&early, "wait mode == form within 0.5\nmode step-large AB\n").unwrap();
    let r = desk(
        &["run", board.path(), early.to_str().unwrap()],
        "",
        Duration::from_secs(10),
    );
    assert!(!r.ok, "{}", r.stdout);
    assert!(
        r.stdout
            .contains("the run failed before any of its commands was sent"),
        "{}",
        r.stdout
    );
    let v = board.view();
    assert!(v.lines.iter().all(|l| l == "status"), "{v:?}");
    assert_eq!(v.mode, "standby");

    let script = dir.join("fail.txt");
    std::fs::write(&script, "mode step-large AB\nwait mode == form within 1\n").unwrap();
    let args = ["run", board.path(), script.to_str().unwrap()];
    let r = desk(&args, "", Duration::from_secs(15));
    assert!(!r.ok, "{}", r.stdout);
    assert!(
        r.stderr.contains(&format!(
            "{}:2: timeout: mode == form did not hold",
            script.display()
        )),
        "{}",
        r.stderr
    );
    assert!(
        r.stdout.contains(
            "the run failed: sent `stop` -> ok stopped, every output off; the block is left in \
             mode stopped (phase -), heater 0.0 %"
        ),
        "{}",
        r.stdout
    );
    let v = board.view();
    assert_eq!(v.lines.last().map(String::as_str), Some("status"), "{v:?}");
    assert!(v.lines.iter().any(|l| l == "stop"), "{v:?}");
    assert_eq!((v.mode.as_str(), v.heater_pct), ("stopped", 0.0), "{v:?}");

    let before = v.lines.len();
    let mut leave = args.to_vec();
    leave.push("--leave-running");
    let r = desk(&leave, "", Duration::from_secs(15));
    assert!(!r.ok, "{}", r.stdout);
    assert!(
        r.stdout.contains(
            "--leave-running: nothing sent, the block is left in mode step-large (phase soak), \
             heater 100.0 %"
        ),
        "{}",
        r.stdout
    );
    let v = board.view();
    assert!(!v.lines[before..].iter().any(|l| l == "stop"), "{v:?}");
    assert_eq!(
        (v.mode.as_str(), v.heater_pct),
        ("step-large", 100.0),
        "{v:?}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Ctrl-C during `run --record`: `stop`, `stream off`, the rows counted, the line named.
#[test]
fn ctrl_c_on_a_recorded_run_stops_the_block_and_the_stream() {
    let dir = scratch("run-int");
    let board = FakeBoard::start(Behaviour::Board, 10.0);
    let script = dir.join("long.txt");
    std::fs::write(&script, "mode step-large AB\nsleep 60\n").unwrap();
    let csv = dir.join("long.csv");
    let run = common::start(
        &[
            "run",
            board.path(),
            script.to_str().unwrap(),
            "--record",
            csv.to_str().unwrap(),
        ],
        "",
    );
    board.until(Duration::from_secs(10), "step-large", |v| {
        v.mode == "step-large" && v.telemetry > 5
    });
    std::thread::sleep(Duration::from_millis(300));
    run.interrupt();
    let r = run.finish(Duration::from_secs(15));
    // Interrupted: 130, after the same tidying up.
    assert_eq!(r.code, Some(130), "{}\n{}", r.stdout, r.stderr);
    assert!(
        r.stderr
            .contains(&format!("{}:2: interrupted (Ctrl-C)", script.display())),
        "{}",
        r.stderr
    );
    assert!(
        r.stdout.contains("the run failed: sent `stop`"),
        "{}",
        r.stdout
    );
    let rows = std::fs::read_to_string(&csv).unwrap().lines().count() - 1;
    assert!(rows > 0);
    assert!(
        r.stdout.contains(&format!(
            "recorded {rows} telemetry rows (0 gaps) to {}",
            csv.display()
        )),
        "{rows} rows: {}",
        r.stdout
    );
    let v = board.view();
    assert_eq!(
        v.lines.last().map(String::as_str),
        Some("stream off"),
        "{v:?}"
    );
    assert_eq!((v.mode.as_str(), v.heater_pct), ("stopped", 0.0), "{v:?}");
    board.assert_silent(Duration::from_millis(400));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Ctrl-C on `record`, its documented way to stop: `stream off` and the rows counted, exit
/// status 130.
#[test]
fn ctrl_c_on_record_turns_the_stream_off_and_counts_the_rows() {
    let dir = scratch("rec-int");
    let board = FakeBoard::start(Behaviour::Board, 5.0);
    let csv = dir.join("rec.csv");
    let rec = common::start(
        &[
            "record",
            board.path(),
            "--out",
            csv.to_str().unwrap(),
            "--hz",
            "10",
        ],
        "",
    );
    board.until(Duration::from_secs(10), "telemetry", |v| v.telemetry > 8);
    rec.interrupt();
    let r = rec.finish(Duration::from_secs(10));
    assert_eq!(r.code, Some(130), "{}", r.stderr);
    let rows = std::fs::read_to_string(&csv).unwrap().lines().count() - 1;
    assert!(rows > 5, "{rows}");
    assert!(
        r.stderr.contains(&format!(
            "wrote {rows} rows to {} (0 gaps, 0 garbage lines); stopped by Ctrl-C, \
             `stream off` sent",
            csv.display()
        )),
        "{rows} rows: {}",
        r.stderr
    );
    let v = board.view();
    assert_eq!(v.lines, ["stream on 10", "stream off"], "{v:?}");
    board.assert_silent(Duration::from_millis(400));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A recording never overwrites a file without `--force`, and creates nothing before the port
/// answers: an existing file loses nothing, whatever goes wrong.
#[test]
fn a_recording_opens_the_port_first_and_overwrites_only_with_force() {
    let dir = scratch("keep");
    let keep = dir.join("keep.csv");
    let precious = "time_s,t_s\n1,2\n";
    std::fs::write(&keep, precious).unwrap();
    let board = FakeBoard::start(Behaviour::Board, 5.0);
    let silent = FakeBoard::start(Behaviour::Silent, 1.0);
    let k = keep.to_str().unwrap();
    let script = dir.join("s.txt");
    std::fs::write(&script, "status\n").unwrap();
    let s = script.to_str().unwrap();
    for (args, want) in [
        (
            vec!["record", board.path(), "--out", k],
            "the file exists; pass --force",
        ),
        (
            vec!["run", board.path(), s, "--record", k],
            "the file exists; pass --force",
        ),
        (
            vec![
                "record",
                "/dev/nonexistent-thermorph",
                "--out",
                k,
                "--force",
            ],
            "cannot open port",
        ),
        (
            vec!["record", silent.path(), "--out", k, "--force"],
            "Thermorph console?",
        ),
    ] {
        let r = desk(&args, "", Duration::from_secs(15));
        assert!(!r.ok, "{args:?}");
        assert!(r.stderr.contains(want), "{args:?}: {}", r.stderr);
        assert_eq!(
            std::fs::read_to_string(&keep).unwrap(),
            precious,
            "{args:?}"
        );
    }
    assert!(board.view().lines.is_empty(), "{:?}", board.view());
    // A new file is not created for a port that cannot be opened.
    let fresh = dir.join("fresh.csv");
    let r = desk(
        &[
            "record",
            "/dev/nonexistent-thermorph",
            "--out",
            fresh.to_str().unwrap(),
        ],
        "",
        Duration::from_secs(10),
    );
    assert!(!r.ok && !fresh.exists(), "{}", r.stderr);
    // Nor for a port where nothing answers `stream on`, by `record` or by `run --record`.
    let f = fresh.to_str().unwrap();
    for args in [
        vec!["record", silent.path(), "--out", f],
        vec![
            "run",
            silent.path(),
            s,
            "--record",
            f,
            "--reply-timeout",
            "0.5",
        ],
    ] {
        let r = desk(&args, "", Duration::from_secs(10));
        assert!(!r.ok, "{args:?}");
        assert!(r.stderr.contains("no reply to `stream on`"), "{}", r.stderr);
        assert!(!fresh.exists(), "{args:?} created {f}");
    }
    // With --force, once the board answers.
    let r = desk(
        &[
            "record",
            board.path(),
            "--out",
            k,
            "--force",
            "--duration",
            "1",
        ],
        "",
        Duration::from_secs(15),
    );
    assert!(r.ok, "{}", r.stderr);
    let text = std::fs::read_to_string(&keep).unwrap();
    assert_eq!(text.lines().next().unwrap(), csv_header());
    assert!(text.lines().count() > 2, "{text}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `run` checks its arguments and every line of the script before anything is sent: swapped
/// PORT and SCRIPT are named as such (a pseudo-terminal given as SCRIPT is never read), and
/// every bad line is reported as `FILE:LINE: reason`.
#[test]
fn run_checks_its_arguments_and_every_line_before_sending() {
    let dir = scratch("check");
    let board = FakeBoard::start(Behaviour::Board, 5.0);
    let script = dir.join("s.txt");
    std::fs::write(
        &script,
        "mode step-large AB\nwait phase == hold within 60\nwait tck >= 300\nmode fly\n\
         expect fault = none\n",
    )
    .unwrap();
    let s = script.to_str().unwrap();
    let r = desk(&["run", s, board.path()], "", Duration::from_secs(10));
    assert!(!r.ok);
    assert!(
        r.stderr.contains(&format!(
            "{s}: a file, not a serial port; the port comes first: `thermorph-desk run PORT \
             SCRIPT`"
        )),
        "{}",
        r.stderr
    );
    // `record` and `connect` name a file given as PORT too, and create nothing.
    let out = dir.join("out.csv");
    for args in [
        vec!["record", s, "--out", out.to_str().unwrap()],
        vec!["connect", s],
    ] {
        let r = desk(&args, "", Duration::from_secs(10));
        assert!(!r.ok, "{args:?}");
        assert!(
            r.stderr
                .contains(&format!("{s}: a file, not a serial port")),
            "{}",
            r.stderr
        );
    }
    assert!(!out.exists());
    let r = desk(
        &["run", board.path(), board.path()],
        "",
        Duration::from_secs(10),
    );
    assert!(!r.ok);
    assert!(
        r.stderr.contains(&format!(
            "{}: a device (a serial port?), not a script file; the port comes first",
            board.path()
        )),
        "{}",
        r.stderr
    );
    let r = desk(&["run", board.path(), s], "", Duration::from_secs(10));
    assert!(!r.ok);
    for want in [
        format!("{s}:3: `status` has no field `tck` (did you mean `tc_k`?)"),
        format!("{s}:4: `mode fly`"),
        format!("{s}:5: `=` is not one of"),
    ] {
        assert!(r.stderr.contains(&want), "{want}: {}", r.stderr);
    }
    assert!(!r.stderr.contains(&format!("{s}:1:")), "{}", r.stderr);
    let v = board.view();
    assert!(v.lines.is_empty(), "sent before the check: {v:?}");
    assert_eq!(v.mode, "standby");
    std::fs::remove_dir_all(&dir).unwrap();
}
