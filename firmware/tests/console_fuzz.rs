//! Console robustness: random and mutated lines through the board's console path, bytes →
//! [`LineReader`] → [`Controller::period`] (which parses the line and steps the supervisor;
//! `save`/`load` carried out on an in-memory store), while the controller also steps on
//! measurements of a warming block.
//!
//! Lines: binary, overlong, partial UTF-8, valid commands with bad arguments, mutated valid
//! commands, blank lines, CR / LF / CR LF ends, fed in bursts split at random points (so a CR
//! and its LF often arrive apart). Checked: no panic; exactly one reply per complete non-blank
//! line, in order, each one line of printable ASCII starting `ok ` or `err <code>: `; after
//! every burst a known command gets its proper reply.
//!
//! `THERMORPH_FUZZ_LINES` sets the number of lines (default 1 000 000; the test prints the
//! count and the mix).

use thermorph::app::{Controller, Line};
use thermorph::command::{COMMANDS, mode_names};
use thermorph::console::{LineReader, MAX_LINE};
use thermorph::measurement::{Measurement, Quality};
use thermorph::settings::{PARAMS, Settings};
use thermorph::supervisor::Supervisor;
use thermorph::supervisor::store::{StoreOutcome, StoreRequest};
use thermorph::units::{Kelvin, Millis};

/// xorshift64*: deterministic, seedable.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    fn chance(&mut self, percent: u64) -> bool {
        self.next() % 100 < percent
    }
    fn pick<'a, T>(&mut self, xs: &'a [T]) -> &'a T {
        &xs[self.below(xs.len())]
    }
}

/// A valid line for every command shape (arguments as the table asks).
fn valid_line(r: &mut Rng) -> String {
    let c = r.pick(COMMANDS);
    let p = r.pick(PARAMS);
    match c.name {
        "mode" => {
            let names: Vec<_> = mode_names().collect();
            let (m, _) = *r.pick(&names);
            if m.starts_with("step") && r.chance(50) {
                format!("mode {m} {}", r.pick(&["A", "B", "C", "AB", "abc", "CA"]))
            } else {
                format!("mode {m}")
            }
        }
        "get" if r.chance(50) => "get".into(),
        "get" => format!("get {}", p.name),
        "set" => {
            let f = (r.next() % 1000) as f32 / 1000.0;
            format!("set {} {}", p.name, p.min + f * (p.max - p.min))
        }
        "stream" if r.chance(50) => "stream off".into(),
        "stream" => format!("stream on {}", 1 + r.below(20)),
        // `estop` latches a fault that only `reset` clears: keep it rare.
        "estop" if r.chance(90) => "reset".into(),
        n => n.into(),
    }
}

/// A valid command word with wrong arguments.
fn bad_arguments(r: &mut Rng) -> String {
    let c = r.pick(COMMANDS).name;
    let junk = [
        "x",
        "nan",
        "inf",
        "-inf",
        "1e40",
        "-0",
        "0x10",
        "ABD",
        "on on",
        "999999999999",
        "1.5.5",
        "",
    ];
    let p = r.pick(PARAMS).name;
    match r.below(4) {
        0 => format!("{c} {} {} {}", r.pick(&junk), r.pick(&junk), r.pick(&junk)),
        1 => format!("set {p} {}", r.pick(&junk)),
        2 => format!("set {p} {}", 1e6 * (r.next() % 7) as f32 - 3e6),
        _ => format!("{c}\t{}", r.pick(&junk)),
    }
}

/// A valid line with random byte edits (which may make it valid again).
fn mutated(r: &mut Rng) -> Vec<u8> {
    let mut b = valid_line(r).into_bytes();
    for _ in 0..1 + r.below(4) {
        let at = r.below(b.len() + 1);
        match r.below(5) {
            0 if at < b.len() => b[at] ^= 1 << r.below(8),
            1 => b.insert(at, r.next() as u8),
            2 if at < b.len() => {
                b.remove(at);
            }
            3 => b.truncate(at),
            _ => {
                let from = r.below(b.len() + 1);
                let tail = b[from..].to_vec();
                b.extend_from_slice(&tail);
            }
        }
    }
    b
}

/// Line content (never CR or LF) of one of the kinds.
fn garbage(r: &mut Rng, kind: usize) -> Vec<u8> {
    let mut b: Vec<u8> = match kind {
        0 => (0..r.below(200)).map(|_| r.next() as u8).collect(),
        1 => (0..MAX_LINE + 1 + r.below(400))
            .map(|_| b' ' + r.below(95) as u8)
            .collect(),
        2 => {
            let mut v = valid_line(r).into_bytes();
            let cut: &[&[u8]] = &[
                b"\xE2\x82",
                b"\xC3",
                b"\xF0\x9F\x98",
                b"\xED\xA0\x80",
                b"\xFF",
            ];
            let at = r.below(v.len() + 1);
            v.splice(at..at, r.pick(cut).iter().copied());
            v
        }
        3 => bad_arguments(r).into_bytes(),
        4 => mutated(r),
        5 => {
            let blanks: [&[u8]; 4] = [b"", b" ", b"\t \t", b"   "];
            r.pick(&blanks).to_vec()
        }
        // Exactly MAX_LINE and one more.
        6 => vec![b'x'; MAX_LINE + r.below(2)],
        _ => valid_line(r).into_bytes(),
    };
    b.retain(|&c| c != b'\r' && c != b'\n');
    b
}

const KINDS: [&str; 8] = [
    "binary",
    "overlong",
    "partial-utf8",
    "bad-arguments",
    "mutated",
    "blank",
    "boundary-length",
    "valid",
];

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

struct Console {
    reader: LineReader<MAX_LINE>,
    sup: Controller,
    flash: Option<Vec<u8>>,
    now_ms: u64,
    replies: Vec<String>,
}

impl Console {
    fn feed(&mut self, bytes: &[u8]) {
        for &b in bytes {
            let Some(line) = self.reader.push(b) else {
                continue;
            };
            let now = Millis(self.now_ms);
            // The board's path: the Controller orders the period and parses the line.
            let line = match line {
                Ok(text) => Line::Text(text),
                Err(e) => Line::Refused(e),
            };
            let p = self.sup.period(now, None, None, None, Some(line));
            let reply = match (p.reply, p.store) {
                (Some(r), None) => r,
                (None, Some(StoreRequest::Save(rec))) => {
                    self.flash = Some(rec.to_vec());
                    self.sup.finish_store(now, StoreOutcome::Saved)
                }
                (None, Some(StoreRequest::Load)) => {
                    let f = self.flash.clone();
                    self.sup
                        .finish_store(now, StoreOutcome::Loaded(f.as_deref()))
                }
                other => panic!("a period gave {other:?}"),
            };
            self.replies.push(reply.as_str().to_string());
        }
    }

    /// A control tick with a measurement of a block near `t_k`.
    fn tick(&mut self, seq: u32, t_k: f32) {
        self.now_ms += 125;
        let m = Measurement {
            at: Millis(self.now_ms),
            seq,
            regions: [t_k + 3.0, t_k, t_k - 1.0, t_k - 5.0, 298.0].map(Kelvin::new),
            hottest: Kelvin::new(t_k + 3.0),
            filled_pixels: 0,
            bound: Kelvin::lit(0.5),
            quality: Quality::Resolved,
            tilt: None,
            exposure: None,
        };
        self.sup
            .period(Millis(self.now_ms), None, None, Some(&m), None);
    }
}

fn check_reply(r: &str) {
    assert!(
        r.bytes().all(|b| (0x20..0x7F).contains(&b)),
        "not one printable line: {r:?}"
    );
    let ok = r.starts_with("ok ") || r == "ok";
    let err = r.starts_with("err ")
        && r[4..].split_once(": ").is_some_and(|(code, _)| {
            !code.is_empty() && code.bytes().all(|b| b.is_ascii_lowercase() || b == b'-')
        });
    assert!(ok || err, "malformed reply {r:?}");
}

#[test]
fn a_million_random_and_mutated_lines() {
    let total: usize = std::env::var("THERMORPH_FUZZ_LINES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1_000_000);
    let mut r = Rng(0x5EED_C0FF_EE12_3457);
    let mut c = Console {
        reader: LineReader::new(),
        sup: Controller::new(Supervisor::new(Millis(0), Settings::DEFAULT)),
        flash: None,
        now_ms: 0,
        replies: Vec::new(),
    };
    let mut sent = 0usize;
    let mut expected_total = 0usize;
    let mut kinds = [0usize; KINDS.len()];
    let mut bursts = 0usize;
    let mut seq = 0u32;
    let sentinels: [(&str, &str); 4] = [
        ("version", "ok thermorph "),
        ("get hot_k", "ok hot_k="),
        ("status", "ok mode="),
        ("help", "ok commands: help"),
    ];
    while sent < total {
        // One burst: up to 64 lines, as one byte stream.
        let n = 1 + r.below(64);
        let mut stream = Vec::new();
        let mut expected = 0usize;
        for _ in 0..n {
            let kind = r.below(KINDS.len());
            kinds[kind] += 1;
            let line = garbage(&mut r, kind);
            expected += usize::from(answered(&line, MAX_LINE));
            stream.extend_from_slice(&line);
            let ends: [&[u8]; 3] = [b"\r\n", b"\n", b"\r"];
            let end: &[u8] = ends[r.below(ends.len())];
            stream.extend_from_slice(end);
        }
        // The command after the garbage.
        let (cmd, want) = *r.pick(&sentinels);
        stream.extend_from_slice(cmd.as_bytes());
        stream.extend_from_slice(b"\r\n");
        expected += 1;
        sent += n + 1;

        // Fed in chunks split at random points, with control ticks between some of them.
        c.replies.clear();
        let mut at = 0;
        while at < stream.len() {
            let len = 1 + r.below(48).min(stream.len() - at - 1);
            c.feed(&stream[at..at + len]);
            at += len;
            if r.chance(10) {
                seq += 1;
                c.tick(seq, 300.0 + (seq % 700) as f32 * 0.1);
            }
        }
        assert_eq!(
            c.replies.len(),
            expected,
            "burst {bursts}: replies {:?}",
            c.replies
        );
        for reply in &c.replies {
            check_reply(reply);
        }
        let last = c.replies.last().unwrap();
        assert!(
            last.starts_with(want),
            "burst {bursts}: `{cmd}` after garbage got {last:?}"
        );
        expected_total += expected;
        bursts += 1;
    }
    println!(
        "{sent} lines in {bursts} bursts, {expected_total} replies; mix: {}",
        KINDS
            .iter()
            .zip(kinds)
            .map(|(k, n)| format!("{k} {n}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    assert!(sent >= total);
}
