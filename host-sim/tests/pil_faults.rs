//! The fault scenes (`tests/scenes/pil-*.toml`) played by the board's own ELF on the emulated
//! STM32F446 and by the library's controller (`--features pil`; run in release: `cargo test
//! --release -p host-sim --features pil --test pil_faults -- --nocapture` prints the numbers):
//! a sensor that NACKs mid-stepping, a heater that goes open, the e-stop button over a latched
//! fault, the button pressed mid-stepping, and the rest a scene can inject (frozen, corrupt
//! and stopped frames, a spring's MOSFET failed short, a spring's wire open). Both give the same faults (code, and time within
//! 0.3 s), the same verdict to every console line, the bend within 2° at every row, and heater
//! and springs off within one control tick (50 ms) of every latch — for the ELF from its pins as
//! the harness read them every millisecond, for the library from its rows (every 50 ms).
#![cfg(feature = "pil")]

mod pil_common;

use host_sim::runs::elf_run::{ElfRun, OutputChange, run_elf_traced};
use host_sim::runs::run::{ReplyRecord, Row, RunResult, run};
use host_sim::runs::scenario::{self, Scenario};
use pil_common::elf;

/// The board's control tick, s: every latch must have the outputs off within it.
const TICK_S: f64 = 0.05;

/// How far apart the two runs' latches of one fault may be, s.
const LATCH_TOLERANCE_S: f64 = 0.3;

/// How far apart the two runs' bends may be at any row, degrees.
const BEND_TOLERANCE_DEG: f64 = 2.0;

fn scene(name: &str) -> Scenario {
    let path = format!("{}/tests/scenes/{name}.toml", env!("CARGO_MANIFEST_DIR"));
    scenario::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// A reply's verdict and what it is about: the text before its first `:` (`err
/// cause-present`, `ok fault cleared, stopped`, `ok mode standby`), without the numbers that
/// follow it.
fn head(reply: &str) -> &str {
    reply.split(':').next().unwrap_or(reply)
}

/// What the ELF drove at `t_s`: the last change the harness saw at or before it.
fn driven_at(outputs: &[OutputChange], t_s: f64) -> &OutputChange {
    outputs
        .iter()
        .take_while(|c| c.at_s <= t_s + 1e-9)
        .last()
        .expect("the trace starts at 0 s")
}

/// When the ELF's heater and springs went off for good before `until_s`: the first change of
/// the last run of changes up to `until_s` with every one of them off (None: on at `until_s`).
fn off_since(outputs: &[OutputChange], until_s: f64) -> Option<f64> {
    let upto: Vec<&OutputChange> = outputs
        .iter()
        .take_while(|c| c.at_s <= until_s + 1e-9)
        .collect();
    let on = upto.iter().rposition(|c| !c.heater_and_springs_off());
    match on {
        Some(i) if i + 1 == upto.len() => None,
        Some(i) => Some(upto[i + 1].at_s),
        None => Some(0.0),
    }
}

/// When the fault latched at `at_s` was cleared: the first `reset` after it that the board
/// answered `ok fault cleared` (the end of the run if none).
fn cleared_at(replies: &[ReplyRecord], at_s: f64, end_s: f64) -> f64 {
    replies
        .iter()
        .find(|r| r.at_s > at_s && r.reply.starts_with("ok fault cleared"))
        .map_or(end_s, |r| r.at_s)
}

/// The library's row of the period that starts at or after `t_s` (its inputs are the ones
/// applied from that period's start).
fn row_from(rows: &[Row], period_s: f64, t_s: f64) -> &Row {
    rows.iter()
        .find(|r| r.obs.time_s - period_s >= t_s - 1e-9)
        .expect("a row after the latch")
}

fn safe(r: &Row) -> bool {
    r.inputs.heater_duty == 0.0 && !r.springs_cmd.iter().any(|s| *s) && r.inputs.spring_power_off
}

/// Play `name` with the library and with the ELF; check what both must agree on; return both.
fn play(name: &str) -> (RunResult, ElfRun) {
    let sc = scene(name);
    assert!(
        (sc.period_s - TICK_S).abs() < 1e-12,
        "{name}: rows every tick, to see the library's outputs within one"
    );
    let lib = run(&sc, &mut |_| {}).unwrap();
    let board = run_elf_traced(&sc, &elf(), &mut |_| {}).unwrap();
    let b = &board.result;
    println!(
        "{name}: {:.0} s simulated, the ELF at {:.1}× real time",
        b.summary.duration_s, b.summary.real_time_factor
    );

    // The same faults, each within the tolerance.
    let codes = |r: &RunResult| -> Vec<String> {
        r.summary.faults.iter().map(|f| f.code.clone()).collect()
    };
    assert_eq!(codes(b), codes(&lib), "{name}: the latched faults");
    for (l, e) in lib.summary.faults.iter().zip(&b.summary.faults) {
        let apart = e.at_s - l.at_s;
        println!(
            "  {}: library {:.3} s, ELF {:.3} s ({apart:+.3} s)",
            l.code, l.at_s, e.at_s
        );
        assert!(
            apart.abs() <= LATCH_TOLERANCE_S,
            "{name}: {} latched at {:.3} s by the library, {:.3} s by the ELF",
            l.code,
            l.at_s,
            e.at_s
        );
    }

    // The same verdict to every line.
    let lines = |r: &RunResult| -> Vec<(String, String)> {
        r.summary
            .replies
            .iter()
            .map(|x| (x.line.clone(), head(&x.reply).to_string()))
            .collect()
    };
    assert_eq!(lines(b), lines(&lib), "{name}: the replies");
    for (l, e) in lib.summary.replies.iter().zip(&b.summary.replies) {
        if l.reply != e.reply {
            println!("  `{}`: library `{}`, ELF `{}`", l.line, l.reply, e.reply);
        }
    }

    // The bend at every row.
    assert_eq!(lib.rows.len(), b.rows.len());
    let worst = lib
        .rows
        .iter()
        .zip(&b.rows)
        .map(|(l, e)| (l.obs.bend_deg - e.obs.bend_deg).abs())
        .fold(0.0, f64::max);
    println!(
        "  bend within {worst:.2}° of the library's (up to {:.1}°)",
        lib.summary.max_bend_deg
    );
    assert!(worst <= BEND_TOLERANCE_DEG, "{name}: bends {worst}° apart");

    // Heater and springs off within a tick of every latch, and held off until the fault is
    // cleared: the ELF from its pins, the library from its rows.
    let end_s = b.summary.duration_s;
    for f in &b.summary.faults {
        let by_s = f.at_s + TICK_S;
        let at = driven_at(&board.outputs, by_s);
        assert!(
            at.heater_and_springs_off(),
            "{name}: the ELF drives {:?} at {by_s:.3} s, a tick after {} latched",
            at.outputs,
            f.code
        );
        let since = off_since(&board.outputs, by_s).expect("off");
        let until = cleared_at(&b.summary.replies, f.at_s, end_s);
        let back_on = board
            .outputs
            .iter()
            .find(|c| c.at_s > by_s && c.at_s < until && !c.heater_and_springs_off());
        assert!(
            back_on.is_none(),
            "{name}: the ELF drove {back_on:?} with {} latched (cleared at {until} s)",
            f.code
        );
        println!(
            "  ELF: {} at {:.3} s, heater and springs off from {since:.3} s ({:+.0} ms), fan {:.0} %",
            f.code,
            f.at_s,
            1e3 * (since - f.at_s),
            100.0 * at.outputs.fan_duty
        );
    }
    for (f, e) in lib.summary.faults.iter().zip(&b.summary.faults) {
        let r = row_from(&lib.rows, TICK_S, f.at_s);
        let from_s = r.obs.time_s - TICK_S;
        assert!(
            from_s - f.at_s <= TICK_S + 1e-9 && safe(r),
            "{name}: the library drives {:?} from {from_s:.3} s, after {} latched at {:.3} s",
            r.inputs,
            f.code,
            f.at_s
        );
        let until = cleared_at(&lib.summary.replies, f.at_s, end_s);
        assert!(
            lib.rows
                .iter()
                .filter(|r| r.obs.time_s - TICK_S >= from_s - 1e-9 && r.obs.time_s <= until)
                .all(safe),
            "{name}: the library's outputs came back on with {} latched",
            f.code
        );
        // The fan as the library's, each a tick after its own latch: on to cool under most
        // faults, off under an e-stop.
        let elf_fan = driven_at(&board.outputs, e.at_s + TICK_S).outputs.fan_duty;
        assert_eq!(
            elf_fan > 0.0,
            r.inputs.fan_duty > 0.0,
            "{name}: the fan after {}: library {}, ELF {elf_fan}",
            f.code,
            r.inputs.fan_duty
        );
    }
    (lib, board)
}

#[test]
fn a_sensor_nack_in_stepping_latches_sensor_loss_on_the_elf_as_in_the_library() {
    let (lib, board) = play("pil-nack-stepping");
    // Stepping with both springs when the sensor went quiet: the check above is not vacuous.
    let at_s = lib.summary.faults[0].at_s;
    let before = driven_at(&board.outputs, at_s - 0.3).outputs;
    assert!(
        before.springs_on == [true, true, false] && before.heater_duty > 0.0,
        "{before:?}"
    );
    assert_eq!(lib.summary.faults[0].code, "sensor-loss");
    // `reset` refused while no frame comes, accepted once they come again (the ELF's bus
    // recovery after the NACKs brings the sensor back).
    let replies: Vec<&str> = board
        .result
        .summary
        .replies
        .iter()
        .map(|r| head(&r.reply))
        .collect();
    assert_eq!(
        replies,
        [
            "ok mode step-large springs=AB",
            "err cause-present",
            "ok fault cleared, stopped",
            "ok mode standby"
        ]
    );
}

#[test]
fn an_open_heater_latches_runaway_heating_on_the_elf_as_in_the_library() {
    let (lib, board) = play("pil-heater-open");
    assert_eq!(lib.summary.faults[0].code, "runaway-heating");
    let at_s = board.result.summary.faults[0].at_s;
    assert!(
        driven_at(&board.outputs, at_s - 0.3).outputs.heater_duty > 0.5,
        "the ELF drove the open heater hard until the latch"
    );
    // Repaired, reset and standby again: the ELF heats.
    assert!(driven_at(&board.outputs, 29.0).outputs.heater_duty > 0.0);
}

#[test]
fn the_button_over_a_latched_fault_latches_estop_on_the_elf_as_in_the_library() {
    let (lib, board) = play("pil-estop-over-fault");
    let codes: Vec<&str> = lib.summary.faults.iter().map(|f| f.code.as_str()).collect();
    assert_eq!(codes, ["sensor-loss", "estop"]);
    // The e-stop at the press, to the board log's 10 ms.
    let estop_s = board.result.summary.faults[1].at_s;
    assert!((estop_s - 5.0).abs() <= 0.01, "{estop_s}");
    // The fan cooled under the sensor loss and is off under the e-stop.
    assert!(driven_at(&board.outputs, 4.9).outputs.fan_duty > 0.0);
    assert_eq!(driven_at(&board.outputs, 5.05).outputs.fan_duty, 0.0);
}

#[test]
fn the_button_in_stepping_latches_estop_on_the_elf_within_a_tick() {
    let (lib, board) = play("pil-button-stepping");
    let press_s = 74.013;
    assert!((lib.summary.faults[0].at_s - press_s).abs() < 1e-6);
    let before = driven_at(&board.outputs, press_s - 1e-3).outputs;
    assert!(
        before.springs_on == [true, true, false] && !before.spring_power_off,
        "stepping with A and B when the button goes down: {before:?}"
    );
    // Off at the press, long before the next tick: the press's edge wakes the control loop
    // (the harness sees the pins every millisecond; the loop runs once the executor's task
    // under way yields).
    let off = off_since(&board.outputs, press_s + TICK_S).unwrap();
    println!(
        "  the ELF's outputs off {:.0} ms after the press (seen at the harness's 1 ms looks)",
        1e3 * (off - press_s)
    );
    assert!(off - press_s < TICK_S, "off at {off} s");
    assert_eq!(driven_at(&board.outputs, off).outputs.fan_duty, 0.0);
}

#[test]
fn frozen_corrupt_and_stopped_frames_and_the_spring_faults_latch_on_the_elf_as_in_the_library() {
    let (lib, board) = play("pil-sensor-spring");
    let codes: Vec<&str> = lib.summary.faults.iter().map(|f| f.code.as_str()).collect();
    assert_eq!(
        codes,
        [
            "sensor-loss",
            "sensor-loss",
            "sensor-loss",
            "spring-stuck-on",
            "spring-open"
        ]
    );
    // Every reset accepted once its fault was gone, and each mode taken again.
    assert!(
        board
            .result
            .summary
            .replies
            .iter()
            .all(|r| r.reply.starts_with("ok")),
        "{:?}",
        board.result.summary.replies
    );
    // The ELF switched spring A on (its wire open since 65 s) shortly before the latch: the
    // check is not vacuous.
    let open_s = board.result.summary.faults[4].at_s;
    let on_s = board
        .outputs
        .iter()
        .find(|c| c.at_s > 65.0 && c.outputs.springs_on[0])
        .expect("spring A switched on")
        .at_s;
    println!("  the ELF switched spring A on at {on_s:.3} s");
    assert!(
        on_s < open_s && open_s - on_s <= 0.2,
        "on {on_s} s, latched {open_s} s"
    );
}
