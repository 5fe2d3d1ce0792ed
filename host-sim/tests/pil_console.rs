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
