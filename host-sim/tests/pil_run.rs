//! The default cycle played by the board's own ELF on the emulated STM32F446 and by the
//! library's controller (`--features pil`; run in release: `cargo test --release -p host-sim
//! --features pil --test pil_run`): the same reply to every console line, no fault in either,
//! the bend within 2° of the library's at every row, and the cycle's figures alike.
#![cfg(feature = "pil")]

use std::path::PathBuf;

use host_sim::runs::elf_run::run_elf;
use host_sim::runs::run::run;
use host_sim::runs::scenario;

fn elf() -> PathBuf {
    let target = std::env::var_os("CARGO_TARGET_DIR").map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target"),
        PathBuf::from,
    );
    let p = target.join("thumbv7em-none-eabihf/release/thermorph-board");
    assert!(
        p.exists(),
        "{} is missing: build it with `cargo build --release -p thermorph-firmware --target \
         thumbv7em-none-eabihf --bin thermorph-board`",
        p.display()
    );
    p
}

#[test]
fn the_elf_plays_the_default_cycle_as_the_library_does() {
    let sc = scenario::load("cycle").unwrap();
    let lib = run(&sc, &mut |_| {}).unwrap();
    let board = run_elf(&sc, &elf(), &mut |_| {}).unwrap();
    let replies = |r: &host_sim::runs::run::RunResult| -> Vec<(String, String)> {
        r.summary
            .replies
            .iter()
            .map(|x| (x.line.clone(), x.reply.clone()))
            .collect()
    };
    assert_eq!(replies(&board), replies(&lib));
    assert!(lib.summary.faults.is_empty(), "{:?}", lib.summary.faults);
    assert!(
        board.summary.faults.is_empty(),
        "{:?}",
        board.summary.faults
    );
    let worst = lib
        .rows
        .iter()
        .zip(&board.rows)
        .map(|(a, b)| (a.obs.bend_deg - b.obs.bend_deg).abs())
        .fold(0.0, f64::max);
    println!(
        "the ELF's bend within {worst:.2}° of the library's; {:.1}× real time",
        board.summary.real_time_factor
    );
    assert!(worst <= 2.0, "bend apart by {worst}°");
    for (a, b) in lib.summary.figures.iter().zip(&board.summary.figures) {
        assert_eq!(a.key, b.key);
        assert_eq!(
            a.pass, b.pass,
            "{}: {:?} vs {:?}",
            a.key, a.simulated, b.simulated
        );
    }
}
