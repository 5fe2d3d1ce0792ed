//! The console session recorded in `docs/console.md` replayed against the board's own ELF on
//! the emulated STM32F446 (`--features pil`; release: `cargo test --release -p host-sim
//! --features pil --test pil_console`), reply for reply, by the rules `tests/docs.rs` checks the
//! library's `host-sim console` with (`tests/transcripts`): the board powered up on the
//! default scene's block as `host-sim console` boots its own, the session's lines typed into
//! USART2 once its console is up, each once the one before is answered.
#![cfg(feature = "pil")]

mod pil_common;
mod transcripts;

use host_sim::runs::elf_run::{Start, replay_lines};
use host_sim::runs::scenario;
use pil_common::elf;

#[test]
fn the_elf_answers_the_recorded_session_as_the_library_does() {
    let block = transcripts::console_session();
    let session = transcripts::transcript(&block);
    assert!(session.len() >= 15, "{} lines", session.len());
    let sent: Vec<Vec<u8>> = session.iter().map(|e| e.sent.clone()).collect();
    let cycle = scenario::load("cycle").unwrap();
    let started = std::time::Instant::now();
    let written = replay_lines(&cycle, &elf(), Start::PowerUp, &sent).unwrap();
    println!(
        "{} lines answered by the ELF in {:.1} s",
        sent.len(),
        started.elapsed().as_secs_f64()
    );
    let wrong = transcripts::differences("session", "the ELF", &session, &written);
    assert!(
        wrong.is_empty(),
        "the ELF answers docs/console.md's session otherwise than the library did:\n{}",
        wrong.join("\n")
    );
}

/// The replay tells boots apart: after a reset by its pin (the start of every `run --board`)
/// the board's log holds the reset's warning, so the session's `log` differs, and only it.
#[test]
fn after_a_pin_reset_the_sessions_log_differs() {
    let block = transcripts::console_session();
    let session = transcripts::transcript(&block);
    let sent: Vec<Vec<u8>> = session.iter().map(|e| e.sent.clone()).collect();
    let cycle = scenario::load("cycle").unwrap();
    let written = replay_lines(&cycle, &elf(), Start::PinRested, &sent).unwrap();
    assert!(
        written.iter().any(|l| l.starts_with("# warning: reset by")),
        "{written:#?}"
    );
    let wrong = transcripts::differences("session", "the ELF", &session, &written);
    assert_eq!(wrong.len(), 1, "{wrong:#?}");
    assert!(
        wrong[0].starts_with("> log\n") && wrong[0].contains("ok events=3 |"),
        "{}",
        wrong[0]
    );
}

/// Issue 44 on the board's own ELF: `settings`' listing is written by the board's transmitter
/// (its own path: one `#` line a parameter from the settings of the period, then the reply),
/// line for line what `host-sim console` writes; `get` after it is still one line.
#[test]
fn the_elf_lists_the_settings_as_the_library_does() {
    let sent: Vec<Vec<u8>> = ["set hot_k 360", "settings", "get hot_k"]
        .iter()
        .map(|l| l.as_bytes().to_vec())
        .collect();
    let cycle = scenario::load("cycle").unwrap();
    let written = replay_lines(&cycle, &elf(), Start::PowerUp, &sent).unwrap();
    let listed: Vec<&String> = written
        .iter()
        .filter(|l| l.starts_with("#   ") || l.starts_with("# * "))
        .collect();
    let mut want = Vec::new();
    let mut settings = thermorph::settings::Settings::DEFAULT;
    settings.set("hot_k", 360.0).unwrap();
    for i in 0..thermorph::supervisor::report::SETTING_LINES {
        let mut line = String::new();
        thermorph::supervisor::report::write_setting(&mut line, &settings, i).unwrap();
        want.push(line.trim_end().to_string());
    }
    assert_eq!(listed, want.iter().collect::<Vec<_>>(), "{written:#?}");
    let replies: Vec<&String> = written.iter().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(
        replies,
        [
            "ok hot_k=360 K",
            "ok 81 parameters, 1 not the default (*)",
            "ok hot_k=360 K"
        ]
    );
    // The listing comes between `set`'s reply and its own.
    let at = |l: &str| written.iter().position(|w| w == l).unwrap();
    assert!(at(&want[0]) > at("ok hot_k=360 K"));
    assert!(at(&want[want.len() - 1]) < at("ok 81 parameters, 1 not the default (*)"));
}

/// Replies longer than the board's transmit ring (`get`'s 1.4 KB, `help set`'s 1.2 KB; the
/// board once wrote them as empty lines) come whole, also among 10 Hz telemetry, where a reply
/// the ring had no room for once stalled the transmitter for good.
#[test]
fn the_elf_writes_replies_longer_than_its_ring_among_telemetry() {
    let sent: Vec<Vec<u8>> = [
        "get",
        "help set",
        "stream on 10",
        "get",
        "status",
        "get",
        "stream off",
        "version",
    ]
    .iter()
    .map(|l| l.as_bytes().to_vec())
    .collect();
    let cycle = scenario::load("cycle").unwrap();
    let written = replay_lines(&cycle, &elf(), Start::PowerUp, &sent).unwrap();
    let replies: Vec<&String> = written.iter().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(replies.len(), sent.len(), "{written:#?}");
    for i in [0, 3, 5] {
        assert!(
            replies[i].starts_with("ok standby_k=") && replies[i].ends_with(" trim_vc_pct=100"),
            "{}",
            replies[i]
        );
        assert!(replies[i].len() > 1024);
    }
    assert!(replies[1].starts_with("ok set NAME VALUE") && replies[1].ends_with(" trim_vc_pct"));
    assert!(replies[4].starts_with("ok mode=") && replies[4].ends_with("fault=none"));
    pil_common::assert_names_its_build(replies[7]);
    let telemetry = written.iter().filter(|l| l.starts_with("# t_s=")).count();
    assert!(telemetry >= 1, "{written:#?}");
}
