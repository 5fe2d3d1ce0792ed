//! `host-sim console` end to end: on stdin/stdout (settings surviving a restart, a bad
//! settings file) and on a real pseudo-terminal (a burst of garbage, then `status`,
//! `mode standby`, `stream on 10`: one reply per line and whole telemetry lines), ended by
//! SIGINT.

use std::io::{Read, Write};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use thermorph::console::{LineReader, MAX_LINE};
use thermorph::supervisor::report::TELEMETRY_FIELDS;

fn host_sim() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
}

fn temp_dir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("thermorph-console-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Run the console with `input` on stdin (it ends at EOF); return stdout's lines (CR LF ends
/// checked) and stderr.
fn session(settings: &std::path::Path, input: &str) -> (Vec<String>, String) {
    let mut child = host_sim()
        .args(["console", "--speed", "10", "--settings"])
        .arg(settings)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(input.as_bytes())
        .unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{out:?}");
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.is_empty() || text.ends_with("\r\n"), "{text:?}");
    let lines = text
        .split_terminator("\r\n")
        .map(|l| {
            assert!(!l.contains(['\r', '\n']), "{l:?}");
            l.to_string()
        })
        .collect();
    (lines, String::from_utf8(out.stderr).unwrap())
}

#[test]
fn settings_survive_a_restart_and_a_bad_file_falls_back_to_defaults() {
    let dir = temp_dir("stdin");
    let file = dir.join("settings.bin");
    let (lines, err) = session(&file, "set hot_k 360\r\nsave\r\n\r\nfrobnicate\n");
    assert_eq!(lines[0], "ok hot_k=360 K");
    assert!(lines[1].starts_with("ok saved "), "{lines:?}");
    assert_eq!(lines[2], "err unknown-command: unknown command, try `help`");
    assert_eq!(lines.len(), 3, "a blank line gets no reply");
    assert!(err.contains("ended"), "{err}");

    // "Reset": a new process starts with the saved settings; `defaults` and `load` round-trip.
    let (lines, _) = session(
        &file,
        "get hot_k\rdefaults\r\nget hot_k\nload\r\nget hot_k\r\n",
    );
    assert_eq!(
        lines,
        [
            "ok hot_k=360 K",
            "ok defaults in use (`save` keeps them)",
            "ok hot_k=358 K",
            &lines[3],
            "ok hot_k=360 K"
        ]
    );
    assert!(lines[3].starts_with("ok loaded "));

    // A damaged record: the defaults and one warning line before anything else.
    let mut bytes = std::fs::read(&file).unwrap();
    bytes[20] ^= 0x10;
    std::fs::write(&file, &bytes).unwrap();
    let (lines, _) = session(&file, "get hot_k\r\nload\r\n");
    assert_eq!(
        lines,
        [
            "# warning: stored settings not used (CRC mismatch); defaults in use",
            "ok hot_k=358 K",
            "err bad-record: CRC mismatch; defaults in use"
        ]
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Collects what the pty's client side reads.
struct Client {
    tty: std::fs::File,
    rx: mpsc::Receiver<Vec<u8>>,
    got: Vec<u8>,
}

impl Client {
    /// Read until `done` holds for the lines so far or `timeout` passes; return the lines.
    fn lines_until(&mut self, timeout: Duration, done: impl Fn(&[String]) -> bool) -> Vec<String> {
        let end = Instant::now() + timeout;
        loop {
            let text = String::from_utf8_lossy(&self.got).to_string();
            let lines: Vec<String> = text.split_terminator("\r\n").map(String::from).collect();
            let whole = text.ends_with("\r\n");
            if whole && done(&lines) {
                return lines;
            }
            let left = end.saturating_duration_since(Instant::now());
            assert!(!left.is_zero(), "timed out; got {lines:?}");
            if let Ok(b) = self.rx.recv_timeout(left.min(Duration::from_millis(100))) {
                self.got.extend_from_slice(&b);
            }
        }
    }
}

#[test]
fn garbage_then_commands_and_telemetry_over_a_pty() {
    let dir = temp_dir("pty");
    let mut child = host_sim()
        .args(["console", "--pty", "--speed", "2", "--settings"])
        .arg(dir.join("s.bin"))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdout = child.stdout.take().unwrap();
    let mut path = Vec::new();
    let mut b = [0u8; 1];
    while stdout.read(&mut b).unwrap() == 1 && b[0] != b'\n' {
        path.push(b[0]);
    }
    let path = String::from_utf8(path).unwrap();
    assert!(path.starts_with("/dev/"), "{path}");
    let tty = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(&path)
        .unwrap();
    let (tx, rx) = mpsc::channel();
    let mut reader = tty.try_clone().unwrap();
    std::thread::spawn(move || {
        let mut buf = [0u8; 4096];
        while let Ok(n) = reader.read(&mut buf) {
            if n == 0 || tx.send(buf[..n].to_vec()).is_err() {
                break;
            }
        }
    });
    let mut client = Client {
        tty,
        rx,
        got: Vec::new(),
    };

    // A burst of garbage: binary, overlong, partial UTF-8, bad arguments, a CR LF split.
    let mut burst: Vec<u8> = Vec::new();
    let mut x = 0x1234_5678u32;
    for i in 0..300 {
        match i % 6 {
            0 => burst.extend((0..40).map(|_| {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                (x as u8) | 0x80
            })),
            1 => burst.extend(std::iter::repeat_n(b'y', 300)),
            2 => burst.extend_from_slice(b"status \xE2\x82"),
            3 => burst.extend_from_slice(b"set hot_k 1e40"),
            4 => burst.extend_from_slice(b"mode fly ABD"),
            _ => burst.extend_from_slice(b"   \t"),
        }
        burst.extend_from_slice(if i % 2 == 0 { b"\r\n" } else { b"\n" });
    }
    burst.extend_from_slice(b"status\r");
    // How many replies the board's reader makes of it.
    let mut r: LineReader<MAX_LINE> = LineReader::new();
    let garbage_replies = burst.iter().filter(|&&b| r.push(b).is_some()).count();
    assert_eq!(garbage_replies, 250 + 1);
    client.tty.write_all(&burst).unwrap();
    client.tty.write_all(b"\nmode standby\r\n").unwrap();
    client.tty.write_all(b"stream on 10\r\n").unwrap();

    let replies = |ls: &[String]| ls.iter().filter(|l| !l.starts_with('#')).count();
    let telemetry = |ls: &[String]| ls.iter().filter(|l| l.starts_with("# ")).count();
    let lines = client.lines_until(Duration::from_secs(60), |ls| {
        replies(ls) >= garbage_replies + 2 && telemetry(ls) >= 6
    });
    let replies: Vec<&String> = lines.iter().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(replies.len(), garbage_replies + 2, "{lines:?}");
    for r in &replies[..garbage_replies - 1] {
        assert!(r.starts_with("err "), "{r}");
    }
    // `host-sim console` starts as a power-up: stopped until a `mode` command.
    assert!(replies[garbage_replies - 1].starts_with("ok mode=stopped"));
    assert_eq!(replies[garbage_replies], "ok mode standby");
    assert_eq!(replies[garbage_replies + 1], "ok stream on 10 Hz");

    // Whole telemetry lines, every field in order, 0.1 s apart in simulated time.
    let tele: Vec<&String> = lines.iter().filter(|l| l.starts_with('#')).collect();
    let mut times = Vec::new();
    for l in &tele {
        let names: Vec<&str> = l[2..]
            .split(' ')
            .map(|kv| kv.split_once('=').unwrap().0)
            .collect();
        assert_eq!(names, TELEMETRY_FIELDS, "{l}");
        assert!(l.contains(" mode=standby "), "{l}");
        let t: f64 = l[2..].split(' ').next().unwrap()[4..].parse().unwrap();
        times.push(t);
    }
    for w in times.windows(2) {
        assert!((w[1] - w[0] - 0.1).abs() < 0.051, "{times:?}");
    }

    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(child.id() as i32),
        nix::sys::signal::Signal::SIGINT,
    )
    .unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{out:?}");
    assert!(String::from_utf8_lossy(&out.stderr).contains("ended at t ="));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Random and mutated lines through `host-sim console` on stdin: exactly one reply per complete
/// non-blank line, and each burst's closing `version` answered properly.
/// `THERMORPH_FUZZ_LINES` sets the number of lines (default 1 000 000).
#[test]
fn random_lines_through_the_console_binary() {
    let total: usize = std::env::var("THERMORPH_FUZZ_LINES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1_000_000);
    let mut x = 0x9E37_79B9_7F4A_7C15u64;
    let mut rnd = move |n: usize| {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x % n as u64) as usize
    };
    let words = [
        "help",
        "status",
        "mode",
        "set",
        "get",
        "stream",
        "save",
        "load",
        "defaults",
        "hot_k",
        "standby",
        "step-large",
        "AB",
        "on",
        "off",
        "1e40",
        "nan",
        "-3",
        "360",
        "x",
    ];
    let mut input = Vec::new();
    let mut expected = 0usize;
    let mut sentinels = Vec::new();
    let mut sent = 0;
    let dir = temp_dir("fuzz");
    while sent < total {
        for _ in 0..1 + rnd(40) {
            let mut line: Vec<u8> = match rnd(5) {
                0 => (0..rnd(150)).map(|_| rnd(256) as u8).collect(),
                1 => vec![b'z'; 90 + rnd(20)],
                2 => b" \t ".to_vec(),
                3 => (0..1 + rnd(4))
                    .map(|_| words[rnd(words.len())])
                    .collect::<Vec<_>>()
                    .join(" ")
                    .into_bytes(),
                _ => {
                    let mut v = format!("set hot_k {}", 330 + rnd(40)).into_bytes();
                    let at = rnd(v.len());
                    v[at] ^= 1 << rnd(8);
                    v
                }
            };
            line.retain(|&b| b != b'\r' && b != b'\n');
            // `stream on` would interleave telemetry: replies are counted without `#` lines.
            expected += usize::from(answered(&line, MAX_LINE));
            input.extend_from_slice(&line);
            input.extend_from_slice([&b"\r\n"[..], b"\n", b"\r"][rnd(3)]);
            sent += 1;
        }
        input.extend_from_slice(b"version\r\n");
        sentinels.push(expected);
        expected += 1;
        sent += 1;
    }
    let mut child = host_sim()
        .args(["console", "--speed", "1000", "--settings"])
        .arg(dir.join("s.bin"))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let writer = std::thread::spawn(move || stdin.write_all(&input).unwrap());
    let out = child.wait_with_output().unwrap();
    writer.join().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.ends_with("\r\n"));
    let replies: Vec<&str> = text
        .split_terminator("\r\n")
        .filter(|l| !l.starts_with('#'))
        .collect();
    assert_eq!(replies.len(), expected, "{sent} lines sent");
    println!(
        "{sent} lines sent, {expected} replies, {} bursts",
        sentinels.len()
    );
    for r in &replies {
        assert!(!r.contains(['\r', '\n']));
        assert!(r.starts_with("ok") || r.starts_with("err "), "{r:?}");
    }
    for &i in &sentinels {
        assert!(replies[i].starts_with("ok thermorph "), "{}", replies[i]);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Whether the console answers a complete line (its bytes without the end): a model of the
/// reader's rules written apart from it — Backspace and DEL erase the last byte kept (not a
/// binary byte or an overflow), a line with a byte outside printable ASCII, TAB, BS and DEL or
/// one that grew past the cap is refused with a reply, and what is left blank gets none.
fn answered(line: &[u8], cap: usize) -> bool {
    let (mut len, mut kept_blank, mut overflow, mut binary) = (0usize, Vec::new(), false, false);
    for &b in line {
        match b {
            0x08 | 0x7f => {
                if !overflow && len > 0 {
                    len -= 1;
                    kept_blank.pop();
                }
            }
            b'\t' | 0x20..=0x7e => {
                if len < cap {
                    len += 1;
                    kept_blank.push(b == b' ' || b == b'\t');
                } else {
                    overflow = true;
                }
            }
            _ => binary = true,
        }
    }
    overflow || binary || kept_blank.iter().any(|blank| !blank)
}

/// Issue 44, a researcher's first hour, through `host-sim console`: a value reads back as set,
/// a refused value says what to write instead, a mistyped name is named.
#[test]
fn first_hour_replies() {
    let dir = temp_dir("first-hour");
    let input = [
        "set ki 0.0004",
        "set kp 0.1234567",
        "get kp",
        "set spring_duty_max_pct 60",
        "set large_steps 2.5",
        "set hot_k 360 extra",
        "set hot_k 360K",
        "set hot_k 360 K",
        "stauts",
        "set hotk 360",
        "get temperature",
        "status short",
    ]
    .join("\r\n")
        + "\r\n";
    let (lines, _) = session(&dir.join("settings.bin"), &input);
    assert_eq!(
        lines,
        [
            "ok ki=0.0004 1/(K*s)",
            "ok kp=0.1234567 1/K",
            "ok kp=0.1234567 1/K",
            "ok spring_duty_max_pct=60 %",
            "err bad-arguments: large_steps takes a whole number, 1 to 10",
            "err bad-arguments: one value expected, extra `extra`",
            "err bad-arguments: `360K`: write the number without its unit, the unit is K",
            "err bad-arguments: `360 K`: write the number without its unit, the unit is K",
            "err unknown-command: unknown command; did you mean status?",
            "err unknown-name: unknown parameter hotk; did you mean hot_k?",
            "err unknown-name: unknown parameter temperature; `help set` lists them",
            "ok mode=stopped phase=- target_k=- tc_k=- heater_pct=0.0 fan_pct=0.0 springs=- \
             bend_deg=0.00 bend_sd_deg=1.50 fault=none",
        ]
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Issue 44 through `host-sim console`: `help` names the parameters, the stream's range and how
/// to clear an e-stop; `settings` lists every parameter for a person (`#` lines, then `ok`),
/// while `get` stays one line.
#[test]
fn first_hour_help_and_settings() {
    let dir = temp_dir("first-hour-settings");
    let input = "set hot_k 360\r\nhelp set\r\nhelp stream\r\nhelp estop\r\nsettings\r\nget\r\n";
    let (lines, _) = session(&dir.join("settings.bin"), input);
    assert_eq!(lines[0], "ok hot_k=360 K");
    let names: Vec<&str> = thermorph::settings::PARAMS.iter().map(|p| p.name).collect();
    assert_eq!(
        lines[1],
        format!(
            "ok set NAME VALUE: write a parameter, the number alone in its unit (settings shows \
             them); NAME: {}",
            names.join(" ")
        )
    );
    assert_eq!(
        lines[2],
        "ok stream on|off [HZ]: telemetry lines starting with #, HZ up to 10 (default 4)"
    );
    assert_eq!(
        lines[3],
        "ok estop: emergency stop, every output off; latched until `reset` with the button \
         released"
    );
    let listing = &lines[4..4 + names.len()];
    for (line, name) in listing.iter().zip(&names) {
        assert!(
            line.starts_with("# ") && line[4..].starts_with(name),
            "{line}"
        );
    }
    assert_eq!(
        listing[1],
        "# * hot_k                       360         K        default 358, 338 to 368"
    );
    assert_eq!(listing.iter().filter(|l| l.starts_with("# *")).count(), 1);
    assert_eq!(
        lines[4 + names.len()],
        "ok 81 parameters, 1 not the default (*)"
    );
    let get = &lines[5 + names.len()];
    assert!(
        get.starts_with("ok standby_k=323 hot_k=360 form_end_k=323 kp=0.139 "),
        "{get}"
    );
    assert_eq!(lines.len(), 6 + names.len());
    // docs/console.md's example listing (after the same `set hot_k 360`) is this one.
    let doc = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/console.md"),
    )
    .unwrap();
    let example = doc
        .split("> settings\n")
        .nth(1)
        .expect("the settings example");
    let example = &example[..example.find("```").unwrap()];
    let mut shown = 0;
    for l in example.lines() {
        if l.starts_with('#') {
            assert!(listing.iter().any(|x| x == l), "docs/console.md: {l}");
            shown += 1;
        } else if l.starts_with("ok") {
            assert_eq!(l, lines[4 + names.len()]);
        }
    }
    assert!(shown >= 4, "{example}");
    std::fs::remove_dir_all(&dir).unwrap();
}
