//! Console transcripts (the README's example, the session `scripts/record-session` recorded in
//! `docs/console.md`) and the rules a replay's replies are checked by, shared by the replay
//! through the library's `host-sim console` (`tests/docs.rs`) and the one against the board's
//! ELF on the emulated STM32F446 (`tests/pil_console.rs`).
//!
//! Every reply that does not depend on the simulated temperatures or the time must be the
//! transcript's: `status` is compared by its states (mode, phase, springs, selection, fault),
//! `log` with its numbers masked, every other reply word for word; `#` lines (warnings,
//! telemetry) are not replies.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use thermorph::supervisor::report::TELEMETRY_FIELDS;

/// The workspace's root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The text of `path`.
pub fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A transcript: each line sent (`> `, `\xHH` unescaped) with the lines that came back.
pub struct Exchange {
    pub sent: Vec<u8>,
    pub got: Vec<String>,
}

/// A transcript's line as bytes (`\xHH` a byte, `\\` a backslash).
pub fn unescape(s: &str) -> Vec<u8> {
    let b = s.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'\\' && b.get(i + 1) == Some(&b'x') {
            out.push(u8::from_str_radix(&s[i + 2..i + 4], 16).unwrap());
            i += 4;
        } else if b[i] == b'\\' && b.get(i + 1) == Some(&b'\\') {
            out.push(b'\\');
            i += 2;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    out
}

/// The exchanges of a transcript block.
pub fn transcript(block: &str) -> Vec<Exchange> {
    let mut out: Vec<Exchange> = Vec::new();
    for line in block.lines() {
        if let Some(sent) = line.strip_prefix("> ") {
            out.push(Exchange {
                sent: unescape(sent),
                got: Vec::new(),
            });
        } else {
            out.last_mut()
                .expect("a transcript starts with a line sent")
                .got
                .push(line.to_string());
        }
    }
    out
}

/// The first fenced block after `marker` in `text` (and, with `end`, before it).
pub fn block_after<'a>(text: &'a str, marker: &str, end: Option<&str>) -> &'a str {
    let at = text.find(marker).unwrap_or_else(|| panic!("no {marker:?}"));
    let rest = &text[at..];
    let limit = end.map_or(rest.len(), |e| rest.find(e).expect(e));
    let rest = &rest[..limit];
    let open = rest.find("```text\n").expect("a ```text block") + 8;
    let close = rest[open..].find("\n```").expect("the block's end");
    &rest[open..open + close]
}

/// The session recorded in `docs/console.md` (between its markers).
pub fn console_session() -> String {
    let console = read(&root().join("docs/console.md"));
    block_after(
        &console,
        "<!-- session: begin",
        Some("<!-- session: end -->"),
    )
    .to_string()
}

/// Every number in `s` as `N`.
pub fn mask_numbers(s: &str) -> String {
    let mut out = String::new();
    let mut in_number = false;
    for c in s.chars() {
        let digit = c.is_ascii_digit() || (in_number && c == '.');
        if digit && !in_number {
            out.push('N');
        } else if !digit {
            out.push(c);
        }
        in_number = digit;
    }
    out
}

/// A `status` reply's states (mode, phase, springs, selection, fault): what a replay at
/// another time must still answer (the measured fields differ, and before the first frame
/// some are missing).
pub fn status_shape(reply: &str) -> Vec<String> {
    const STATES: [&str; 5] = ["mode", "phase", "springs", "select", "fault"];
    reply
        .split_whitespace()
        .filter(|w| !w.contains('=') || STATES.contains(&w.split('=').next().unwrap()))
        .map(String::from)
        .collect()
}

/// A `version` reply without the build the board's ELF adds (`ok thermorph 0.1.0 (b98b8ce
/// 2026-11-29)`: its commit, which the library built for the host does not know).
pub fn version_base(reply: &str) -> &str {
    match reply.rfind(" (") {
        Some(i) if reply.ends_with(')') => &reply[..i],
        _ => reply,
    }
}

/// The transcript `session` against `written`, every line a replay of its lines wrote (`#`
/// lines are left out): one reply per line, and each reply the transcript's under the rules
/// above (and `version` without the ELF's build). Returns the replies that differ (`> line`, the transcript's, `who`'s), none if all
/// agree; panics if the replay has another number of replies or the transcript is malformed
/// (not one reply per line, a telemetry line without today's fields).
pub fn differences(name: &str, who: &str, session: &[Exchange], written: &[String]) -> Vec<String> {
    assert!(!session.is_empty(), "{name}: an empty transcript");
    let replayed: Vec<&String> = written.iter().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(
        replayed.len(),
        session.len(),
        "{name}: one reply per line from {who}: {written:#?}"
    );
    let mut wrong = Vec::new();
    for (e, now) in session.iter().zip(replayed) {
        let line = String::from_utf8_lossy(&e.sent);
        let replies: Vec<&String> = e.got.iter().filter(|l| !l.starts_with('#')).collect();
        let [then] = replies[..] else {
            panic!("{name}: `{line}` got {:?}, not one reply", e.got);
        };
        for t in e.got.iter().filter(|l| l.starts_with("# t_s=")) {
            let fields: Vec<&str> = t[2..]
                .split_whitespace()
                .map(|f| f.split('=').next().unwrap())
                .collect();
            assert_eq!(fields, TELEMETRY_FIELDS, "{name}: {t}");
        }
        let (a, b) = match line.split_whitespace().next() {
            Some("status") => (status_shape(then).join(" "), status_shape(now).join(" ")),
            Some("log") => (mask_numbers(then), mask_numbers(now)),
            Some("version") => (version_base(then).into(), version_base(now).into()),
            _ => (then.clone(), now.clone()),
        };
        if a != b {
            wrong.push(format!("> {line}\n  page: {then}\n  {who}: {now}"));
        }
    }
    wrong
}
