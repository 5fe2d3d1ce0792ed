//! `host-sim paper --board ELF` (`--features pil`; release: `cargo test --release -p host-sim
//! --features pil --test pil_paper`): the thesis's experiments played by the board's own ELF
//! on the emulated STM32F446.
//!
//! In CI: the experiments' script played by the ELF on a shortened one-spring experiment
//! (every stage: standby, stepping, forming, recovery) sends the library's lines, answered
//! alike, at the library's times within a second, no fault and the bend within 2° of the
//! library's; and bad input is one error line. The whole table from the ELF (1100 s of
//! emulation, ≈ 1–4 min) against the library's is `#[ignore]`d: `cargo test --release -p
//! host-sim --features pil --test pil_paper -- --ignored --nocapture`.
#![cfg(feature = "pil")]

mod pil_common;

use std::process::Command;
use std::time::Instant;

use host_sim::runs::run::RunResult;
use host_sim::runs::{elf_paper, paper};
use pil_common::elf;

/// The one-spring experiment cut at this, s: recovery starts at ≈ 200 s.
const SHORT_S: f64 = 250.0;

fn lines(r: &RunResult) -> Vec<(f64, String, String)> {
    r.summary
        .replies
        .iter()
        .map(|x| (x.at_s, x.line.clone(), x.reply.clone()))
        .collect()
}

#[test]
fn the_elf_follows_the_experiments_script_as_the_library_does() {
    let sc = paper::scene(SHORT_S, 298.15, true).unwrap();
    let lib = paper::play(&sc, "A").unwrap();
    let started = Instant::now();
    let board = elf_paper::play(&sc, "A", &elf(), &mut |_| {}).unwrap();
    let wall_s = started.elapsed().as_secs_f64();
    let (l, b) = (lines(&lib), lines(&board));
    for ((lt, line, lr), (bt, _, br)) in l.iter().zip(&b) {
        println!("{line:<20} library {lt:7.2} s, ELF {bt:7.2} s | {lr} | {br}");
    }
    println!(
        "{SHORT_S} s played by the ELF in {wall_s:.1} s ({:.1}× real time)",
        SHORT_S / wall_s
    );
    let said = |v: &[(f64, String, String)]| -> Vec<(String, String)> {
        v.iter().map(|x| (x.1.clone(), x.2.clone())).collect()
    };
    assert_eq!(said(&b), said(&l), "the lines sent and their replies");
    let sent: Vec<&str> = l.iter().map(|x| x.1.as_str()).collect();
    assert_eq!(
        sent,
        [
            "mode standby",
            "mode step-large A",
            "mode form",
            "mode recover"
        ],
        "every stage of the script within {SHORT_S} s"
    );
    for ((lt, line, _), (bt, _, _)) in l.iter().zip(&b) {
        assert!(
            (lt - bt).abs() <= 1.0,
            "`{line}`: the library at {lt} s, the ELF at {bt} s"
        );
    }
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
    println!("the ELF's bend within {worst:.2}° of the library's");
    assert!(worst <= 2.0, "bend apart by {worst}°");
}

/// `host-sim paper --json` with `args`: figure → (sim, pass), and its standard error.
fn paper_json(args: &[&str]) -> (Vec<(String, serde_json::Value, bool)>, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(["paper", "--json"])
        .args(args)
        .output()
        .unwrap();
    assert!(out.status.success(), "paper {args:?}: {out:?}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let table = v
        .as_object()
        .unwrap()
        .iter()
        .map(|(k, f)| (k.clone(), f["sim"].clone(), f["pass"].as_bool().unwrap()))
        .collect();
    (table, String::from_utf8_lossy(&out.stderr).into_owned())
}

/// The whole table from the ELF's runs: every figure the library's has, and the same pass or
/// fail for each (1100 s of emulation: not in CI).
#[test]
#[ignore = "1100 s of emulation, 1-4 min: cargo test --release -p host-sim --features pil --test pil_paper -- --ignored"]
fn paper_on_the_board_gives_the_librarys_table() {
    let (lib, _) = paper_json(&[]);
    let board_elf = elf();
    let started = Instant::now();
    let (board, said) = paper_json(&["--board", board_elf.to_str().unwrap()]);
    println!(
        "paper --board: {:.1} s wall",
        started.elapsed().as_secs_f64()
    );
    assert!(said.contains("every figure from the board's ELF"), "{said}");
    let keys = |t: &[(String, serde_json::Value, bool)]| -> Vec<String> {
        t.iter().map(|x| x.0.clone()).collect()
    };
    assert_eq!(keys(&board), keys(&lib));
    for (l, b) in lib.iter().zip(&board) {
        println!("{:<30} library {:<28} ELF {}", l.0, l.1.to_string(), b.1);
        assert_eq!(l.2, b.2, "{}: library {} ELF {}", l.0, l.1, b.1);
    }
}

/// Bad input to `host-sim paper --board` is one clear line on standard error and a non-zero
/// exit: a missing ELF, an ELF for another machine, `--no-camera`.
#[test]
fn bad_input_to_the_board_paper_is_one_clear_error() {
    let exe = env!("CARGO_BIN_EXE_host-sim");
    let board = elf();
    let board = board.to_str().unwrap();
    let cases: [(&[&str], &str); 3] = [
        (
            &["paper", "--board", "/nonexistent/thermorph-board"],
            "cannot read",
        ),
        (&["paper", "--json", "--board", exe], "not the STM32F446"),
        (&["paper", "--no-camera", "--board", board], "--no-camera"),
    ];
    for (args, want) in cases {
        let out = Command::new(exe).args(args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?}: {err}");
        assert!(out.stdout.is_empty(), "{args:?}: {out:?}");
        let lines: Vec<&str> = err.lines().collect();
        assert_eq!(lines.len(), 1, "{args:?}: {err}");
        assert!(
            lines[0].starts_with("error: ") && lines[0].contains(want),
            "{args:?}: {err}"
        );
    }
}
