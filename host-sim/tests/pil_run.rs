//! The default cycle played by the board's own ELF on the emulated STM32F446 and by the
//! library's controller (`--features pil`; run in release: `cargo test --release -p host-sim
//! --features pil --test pil_run`): the same reply to every console line, no fault in either,
//! the bend within 2° of the library's at every row, and the cycle's figures alike.
#![cfg(feature = "pil")]

mod pil_common;

use host_sim::runs::elf_run::run_elf;
use host_sim::runs::run::run;
use host_sim::runs::scenario;
use pil_common::elf;

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

/// Bad input to `host-sim run --board` is one clear line on standard error and a non-zero
/// exit: a missing ELF, an ELF for another machine, a scene the board cannot play.
#[test]
fn bad_input_to_the_board_run_is_one_clear_error() {
    let exe = env!("CARGO_BIN_EXE_host-sim");
    let board = elf();
    let cases: [(&[&str], &str); 3] = [
        (
            &["run", "cycle", "--board", "/nonexistent/thermorph-board"],
            "cannot read",
        ),
        (&["run", "cycle", "--board", exe], "not the STM32F446"),
        (
            &["run", "open-loop", "--board", board.to_str().unwrap()],
            "closed-loop scenes only",
        ),
    ];
    let out_dir = std::env::temp_dir().join("thermorph-pil-bad-input");
    for (args, want) in cases {
        let out = std::process::Command::new(exe)
            .args(args)
            .arg("--out")
            .arg(&out_dir)
            .arg("--quiet")
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?}: {err}");
        let lines: Vec<&str> = err.lines().collect();
        assert_eq!(lines.len(), 1, "{args:?}: {err}");
        assert!(
            lines[0].starts_with("error: ") && lines[0].contains(want),
            "{args:?}: {err}"
        );
    }
}
