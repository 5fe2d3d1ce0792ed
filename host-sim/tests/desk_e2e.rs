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
use std::sync::mpsc;
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

struct FakeBoard {
    path: PathBuf,
    ctl: mpsc::Sender<Ctl>,
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

/// Write what the board said besides its replies (warnings, telemetry), and forget it.
fn write_said(master: &mut File, said: &mut Vec<Said>) {
    for s in said.drain(..) {
        match s {
            Said::Notice(n) => write_all(master, format!("# {n}\r\n").as_bytes()),
            Said::Telemetry(t) => write_all(master, t.as_bytes()),
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
                            Some(Ok(text)) => Line::Text(text),
                            Some(Err(e)) => Line::Refused(e),
                        };
                        if let Some(r) = board.line(line, &mut said) {
                            write_all(&mut master, format!("{}\r\n", r.as_str()).as_bytes());
                        }
                        write_said(&mut master, &mut said);
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
                    write_said(&mut master, &mut said);
                }
                said.clear();
                std::thread::sleep(Duration::from_millis(4));
            }
        });
        FakeBoard {
            path,
            ctl: tx,
            thread: Some(thread),
        }
    }

    fn path(&self) -> &str {
        self.path.to_str().unwrap()
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
        "version\nget hot_k\nmode fly\n.quit\n",
        Duration::from_secs(20),
    );
    assert!(c.ok, "{}\n{}", c.stdout, c.stderr);
    assert!(c.stdout.contains("< ok thermorph "), "{}", c.stdout);
    assert!(c.stdout.contains("< ok hot_k=358"), "{}", c.stdout);
    assert!(c.stdout.contains("< err bad-arguments"), "{}", c.stdout);
    assert!(c.stdout.contains("left as it is"), "{}", c.stdout);

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
        assert!(r.stderr.contains("line 1:"), "{}", r.stderr);
        let csv = dir.join("r.csv");
        let r = desk(
            &["record", board.path(), "--out", csv.to_str().unwrap()],
            "",
            Duration::from_secs(15),
        );
        assert!(!r.ok, "{behaviour:?}");
        assert!(r.stderr.contains("Thermorph console?"), "{}", r.stderr);
        // Connect leaves after its drain time even though no reply ever comes.
        let c = desk(
            &["connect", board.path(), "--status-every", "0"],
            "status\n",
            Duration::from_secs(15),
        );
        assert!(c.ok, "{behaviour:?}: {}", c.stderr);
        assert!(!c.stdout.contains("< ok"), "{}", c.stdout);
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
