//! The supervisor stepped against a two-node thermal model (heater film and SMP wall), with
//! console lines, sensor gaps and faults.

use super::*;
use crate::command::{ParseError, parse};
use crate::measurement::Quality;
use std::vec::Vec;

/// Heater film (T1) and SMP wall (T2): a crude stand-in for the plant, enough for timing and
/// latch logic (host-sim's tests run the real plant).
struct Block {
    t1: f32,
    t2: f32,
    ambient: f32,
    heater_ok: bool,
}

impl Block {
    fn new() -> Self {
        Block {
            t1: 298.0,
            t2: 298.0,
            ambient: 298.0,
            heater_ok: true,
        }
    }

    fn step(&mut self, o: &Outputs, dt: f32) {
        let p = if self.heater_ok {
            4.0 * o.heater.fraction()
        } else {
            0.0
        };
        let fan = 0.08 * o.fan.fraction();
        let d1 = p - 0.05 * (self.t1 - self.t2) - (0.01 + fan) * (self.t1 - self.ambient);
        let d2 = 0.02 * (self.t1 - self.t2) - 0.004 * (self.t2 - self.ambient);
        self.t1 += d1 * dt;
        self.t2 += d2 * dt;
    }

    fn measure(&self, at_ms: u64, seq: u32) -> Measurement {
        Measurement {
            at: Millis(at_ms),
            seq,
            regions: [self.t1, self.t2, self.t2, 300.0, 298.0].map(Kelvin::new),
            hottest: Kelvin::new(self.t1.max(self.t2)),
            filled_pixels: 0,
            quality: Quality::Resolved,
            bound: Kelvin::lit(0.5),
            tilt: None,
            exposure: None,
        }
    }
}

struct Rig {
    sup: Supervisor,
    block: Block,
    now_ms: u64,
    seq: u32,
    sensor: bool,
    log: Vec<(u64, Outputs)>,
}

impl Rig {
    fn new() -> Self {
        Rig {
            // The crude block's springs start at ambient (power-up is tested on its own).
            sup: Supervisor::with_memory(Millis(0), Settings::DEFAULT, SpringMemory::RESTED),
            block: Block::new(),
            now_ms: 0,
            seq: 0,
            sensor: true,
            log: Vec::new(),
        }
    }

    /// Run `secs` at 4 Hz frames with a 0.25 s control period.
    fn run(&mut self, secs: f32) {
        let n = (secs * 4.0).round() as u32;
        for _ in 0..n {
            self.now_ms += 250;
            self.seq += 1;
            let m = self.block.measure(self.now_ms, self.seq);
            let d = self
                .sup
                .step(Millis(self.now_ms), self.sensor.then_some(&m), None);
            self.block.step(&d.outputs, 0.25);
            self.log.push((self.now_ms, d.outputs));
        }
    }

    fn line(&mut self, line: &str) -> String {
        let c = parse(line).unwrap();
        let d = self.sup.step(Millis(self.now_ms), None, Some(c));
        let r = d.reply.expect("every command gets a reply");
        assert!(!r.as_str().contains(['\r', '\n']));
        std::string::String::from(r.as_str())
    }
}

#[test]
fn standby_heats_and_holds() {
    let mut r = Rig::new();
    r.run(300.0);
    assert_eq!(r.sup.mode().name(), "standby");
    assert!((r.sup.tc_k() - 323.0).abs() < 0.5, "tc {}", r.sup.tc_k());
    assert!(r.sup.fault().is_none());
}

#[test]
fn large_stepping_runs_four_steps_and_three_pulses_in_30_s() {
    let mut r = Rig::new();
    // One pre-warm pulse of the full 7 s (a target the crude block's springs reach in one).
    assert!(r.line("set spring_prewarm_k 323").starts_with("ok"));
    r.run(60.0);
    assert!(
        r.line("mode step-large AB")
            .starts_with("ok mode step-large springs=AB")
    );
    r.run(600.0);
    let on: Vec<u64> = r
        .log
        .windows(2)
        .filter(|w| w[0].1.springs.is_empty() != w[1].1.springs.is_empty())
        .map(|w| w[1].0)
        .collect();
    // The pre-warm, four steps and three pulses; after them the hold keeps the springs in
    // their band (switched on and off as their estimate crosses it), never past their limits.
    assert!(on.len() >= 10, "{on:?}");
    assert!(r.sup.fault().is_none(), "{:?}", r.sup.fault());
    assert!(
        r.log
            .iter()
            .all(|(_, o)| (o.springs.bits() & !SpringMask::from_bits(0b011).bits()) == 0),
        "only the selected springs"
    );
    let on = &on[..10];
    assert_eq!(on[1] - on[0], 7_000, "the pre-warm pulse");
    assert_eq!(on[2] - on[1], 1_000, "the gap after it");
    let on = &on[2..];
    assert_eq!(on[7] - on[0], 30_000, "first spring on to last off");
    for w in on.chunks(2) {
        assert_eq!(w[1] - w[0], 6_000);
    }
    // Springs only ever came on with the colder target within the ready band.
    assert!(r.sup.fault().is_none(), "{:?}", r.sup.fault());
    assert_eq!(r.sup.mode().phase_name(), "hold");
    let first_on = r.log.iter().find(|(_, o)| !o.springs.is_empty()).unwrap();
    assert_eq!(first_on.1.springs, SpringMask::parse("AB").unwrap());
}

#[test]
fn pause_holds_the_timer_and_resume_finishes_it() {
    let mut r = Rig::new();
    r.run(60.0);
    assert_eq!(r.line("set prewarm_s 0"), "ok prewarm_s=0 s");
    r.line("mode step-small C");
    while r.sup.mode().phase_name() != "spring" {
        r.run(0.25);
    }
    r.run(2.0);
    assert_eq!(r.line("pause"), "ok paused");
    assert!(r.line("pause").starts_with("err bad-state"));
    r.run(20.0);
    assert!(
        r.log
            .iter()
            .rev()
            .take(40)
            .all(|(_, o)| o.springs.is_empty())
    );
    assert_eq!(r.line("resume"), "ok resumed");
    r.run(10.0);
    let on = r.log.iter().filter(|(_, o)| !o.springs.is_empty()).count();
    assert_eq!(on, 24, "6 s of springs in all, the pause not counted");
    assert_eq!(r.sup.mode().phase_name(), "hold");
}

#[test]
fn forming_cools_with_the_fan_and_returns_to_standby() {
    let mut r = Rig::new();
    r.block.t1 = 360.0;
    r.block.t2 = 358.0;
    r.run(1.0);
    r.line("mode form");
    r.run(1.0);
    let o = r.sup.outputs();
    assert_eq!((o.heater, o.fan), (Duty::OFF, Duty::FULL));
    let mut t = 0.0;
    while r.sup.mode().name() == "form" && t < 2000.0 {
        r.run(0.25);
        t += 0.25;
    }
    assert_eq!(r.sup.mode().name(), "standby");
    assert!(r.block.t1.max(r.block.t2) <= 323.2);
    assert!(
        r.sup.fault().is_none(),
        "no runaway trip while the fan cools"
    );
}

#[test]
fn sensor_loss_latches_within_a_second_and_resets_once_frames_return() {
    let mut r = Rig::new();
    r.run(30.0);
    r.line("mode step-large A");
    r.sensor = false;
    r.run(1.0);
    assert!(r.sup.fault().is_none(), "a 1 s gap is within the window");
    r.run(0.25);
    assert_eq!(r.sup.fault().map(|f| f.code()), Some("sensor-loss"));
    let o = r.sup.outputs();
    assert!(o.heater == Duty::OFF && o.springs.is_empty() && o.fan > Duty::OFF);
    assert!(r.line("mode standby").starts_with("err fault-latched"));
    assert!(r.line("reset").starts_with("err cause-present"));
    r.sensor = true;
    r.run(0.5);
    assert_eq!(
        r.line("reset"),
        "ok fault cleared, stopped: every output off until a `mode` command"
    );
    assert_eq!(r.sup.mode().name(), "stopped");
}

#[test]
fn glitches_shorter_than_the_window_do_not_trip() {
    let mut r = Rig::new();
    for _ in 0..50 {
        r.sensor = false;
        r.run(0.75);
        r.sensor = true;
        r.run(0.5);
    }
    assert!(r.sup.fault().is_none());
}

#[test]
fn dead_heater_trips_runaway_and_estop_needs_the_button_released() {
    let mut r = Rig::new();
    r.block.heater_ok = false;
    r.run(30.0);
    let f = r.sup.fault().unwrap();
    assert_eq!(f.code(), "runaway-heating");
    let mut r = Rig::new();
    r.run(5.0);
    r.sup.button(Millis(r.now_ms), true);
    let d = r.sup.step(Millis(r.now_ms), None, None);
    assert_eq!(d.outputs, Outputs::OFF, "e-stop: everything off, fan too");
    assert!(r.line("reset").starts_with("err cause-present"));
    r.sup.button(Millis(r.now_ms), false);
    assert_eq!(
        r.line("reset"),
        "ok fault cleared, stopped: every output off until a `mode` command"
    );
}

#[test]
fn over_temperature_is_by_rank_not_label() {
    let mut r = Rig::new();
    r.run(1.0);
    let mut m = r.block.measure(r.now_ms + 250, 999);
    // The hotter is the film: 390 K is below its limit whichever label it has.
    m.regions[0] = Kelvin::new(330.0);
    m.regions[1] = Kelvin::new(390.0);
    r.sup.step(Millis(r.now_ms + 250), Some(&m), None);
    assert!(r.sup.fault().is_none());
    // The colder at 375 K is the SMP above 373 K.
    m.at = Millis(r.now_ms + 500);
    m.regions[0] = Kelvin::new(375.0);
    r.sup.step(Millis(r.now_ms + 500), Some(&m), None);
    assert_eq!(r.sup.fault().map(|f| f.code()), Some("over-temperature"));
}

/// Region 3 (the cylinder's edges) shows the film through the lattice's gaps at a grazing
/// angle, so it is judged against the film's limit, not the SMP's; regions 4–5 (beside the
/// cylinder, the background) stay against the SMP's.
#[test]
fn the_edges_are_judged_as_the_film_and_the_surroundings_as_the_smp() {
    use super::safety::Safety;
    let s = Settings::DEFAULT;
    let r = Rig::new();
    let mut m = r.block.measure(250, 1);
    m.quality = Quality::Resolved;
    m.regions[0] = Kelvin::new(385.0);
    m.regions[1] = Kelvin::new(350.0);
    m.hottest = Kelvin::new(386.0);
    m.regions[3] = Kelvin::new(330.0);
    m.regions[4] = Kelvin::new(298.0);
    // An edge cluster that caught the 385 K film: below the film's 403 K, no fault.
    m.regions[2] = Kelvin::new(384.0);
    assert_eq!(Safety::over_temperature(&m, &s), None);
    // Above the film's limit, a fault.
    m.regions[2] = Kelvin::new(s.t_heater_max_k + 2.0);
    assert!(matches!(
        Safety::over_temperature(&m, &s),
        Some(Fault::OverTemperature { .. })
    ));
    // Something beside the cylinder above the SMP's limit (a runaway spring): a fault.
    m.regions[2] = Kelvin::new(360.0);
    m.regions[3] = Kelvin::new(s.t_max_k + 2.0);
    assert!(matches!(
        Safety::over_temperature(&m, &s),
        Some(Fault::OverTemperature { .. })
    ));
}

#[test]
fn bad_measurements_are_ignored_and_time_never_runs_back() {
    let mut r = Rig::new();
    r.run(5.0);
    let mut m = r.block.measure(r.now_ms, 1);
    m.regions[1] = Kelvin::new(f32::NAN);
    for k in 1..3u64 {
        m.at = Millis(r.now_ms + 250 * k);
        r.sup.step(Millis(r.now_ms + 250 * k), Some(&m), None);
    }
    assert!(r.sup.fault().is_none());
    r.sup.step(Millis(r.now_ms + 1_600), Some(&m), None);
    assert_eq!(r.sup.fault().map(|f| f.code()), Some("sensor-loss"));
    // A step dated before the last one counts as no time passing.
    let d = r.sup.step(Millis(0), None, None);
    assert_eq!(d.outputs.heater, Duty::OFF);
}

#[test]
fn set_get_and_spring_limits() {
    let mut r = Rig::new();
    assert_eq!(r.line("set step_s 5"), "ok step_s=5 s");
    assert_eq!(r.line("get step_s"), "ok step_s=5 s");
    assert!(r.line("set step_s 9").starts_with("err conflict"));
    assert!(
        r.line("set hot_k 400")
            .starts_with("err out-of-range: hot_k must be in [338, 368] K")
    );
    assert!(r.line("help").starts_with("ok commands: help [COMMAND];"));
    assert_eq!(
        r.line("help mode"),
        "ok mode standby|step-small|step-large|form|recover [SPRINGS] | pose ANGLE [SPRINGS] \
         [form]: enter a mode; SPRINGS: letters of A, B, C for stepping and pose"
    );
    assert_eq!(
        r.line("HELP save"),
        "ok save: store every parameter (survives a reset)"
    );
    assert_eq!(parse("help fly"), Err(ParseError::UnknownCommand(None)));
    assert_eq!(
        parse("help mode set"),
        Err(ParseError::BadArguments(crate::command::ArgError::TooMany(
            0
        )))
    );
    assert!(r.line("log").starts_with("ok events=0"));
    assert!(r.line("status").starts_with("ok mode=standby"));
    assert!(r.line("stream on 50").starts_with("err out-of-range"));
    assert_eq!(r.line("stream on 2"), "ok stream on 2 Hz");
}

#[test]
fn telemetry_comes_at_its_rate() {
    let mut r = Rig::new();
    r.line("stream on 2");
    let mut lines = 0;
    for k in 1..=40u64 {
        let d = r.sup.step(Millis(250 * k), None, None);
        if d.telemetry {
            let mut s = std::string::String::new();
            r.sup.write_telemetry(Millis(250 * k), &mut s).unwrap();
            assert!(s.starts_with("# t_s=") && s.ends_with("\r\n"));
            lines += 1;
        }
    }
    assert_eq!(lines, 20);
}

#[test]
fn alive_while_measured_or_safe_even_with_the_sensor_gone_under_an_estop() {
    let mut r = Rig::new();
    r.run(5.0);
    let d = r.sup.step(Millis(r.now_ms), None, None);
    assert!(d.alive, "a fresh measurement");
    // The e-stop first, then the sensor goes: sensor loss cannot latch over the e-stop, but the
    // outputs are safe and the loop runs, so the watchdog is fed (no reset loop).
    r.sup.step(Millis(r.now_ms), None, Some(Command::EStop));
    r.sensor = false;
    r.run(3.0);
    let d = r.sup.step(Millis(r.now_ms), None, None);
    assert_eq!(r.sup.fault().map(|f| f.code()), Some("estop"));
    assert!(d.alive && d.outputs == Outputs::OFF);
    // Without a fault, a stale measurement latches sensor loss in the same step.
    let mut r = Rig::new();
    r.run(5.0);
    r.sensor = false;
    r.run(1.25);
    let d = r.sup.step(Millis(r.now_ms), None, None);
    assert_eq!(r.sup.fault().map(|f| f.code()), Some("sensor-loss"));
    assert!(d.alive);
}

#[test]
fn recovery_balances_the_springs_then_cools_and_a_new_stepping_waits_for_them_to_rest() {
    let mut r = Rig::new();
    r.run(60.0);
    r.line("mode step-large AB");
    while r.sup.mode().phase_name() != "hold" {
        r.run(0.25);
    }
    r.line("mode form");
    while r.sup.mode().name() == "form" {
        r.run(0.25);
    }
    let e = r.sup.estimate();
    let (a, c) = (e.springs_k[0], e.springs_k[2]);
    assert!(a > c + 20.0 && c < 305.0, "{a} {c}");
    let start = r.log.len();
    r.line("mode recover");
    let mut phases = Vec::new();
    let mut at_pulse = None;
    let mut hottest = 0.0f32;
    while r.sup.mode().name() == "recover" && r.log.len() - start < 4 * 600 {
        let p = r.sup.mode().phase_name();
        if phases.last() != Some(&p) {
            phases.push(p);
        }
        if p == "pulse" && at_pulse.is_none() {
            at_pulse = Some(r.sup.estimate());
        }
        hottest = r
            .sup
            .estimate()
            .springs_k
            .into_iter()
            .fold(hottest, f32::max);
        r.run(0.25);
    }
    assert_eq!(phases, ["heat", "pulse", "hold", "cool"]);
    assert_eq!(r.sup.mode().name(), "standby");
    assert!(r.sup.fault().is_none(), "{:?}", r.sup.fault());
    let s = Settings::DEFAULT;
    // The pulse came once the wall was soft and every spring austenite by the estimate; no
    // spring passed its band by more than one period's heating (≈ 0.9 K at 0.25 s).
    let e = at_pulse.unwrap();
    assert!(e.frozen <= s.soft_frozen_max, "{e:?}");
    assert!(e.austenite.iter().all(|&a| a >= s.spring_recover), "{e:?}");
    assert!(hottest < s.spring_hot_k + 1.0, "{hottest}");
    let rec = &r.log[start..];
    // The cold spring C is driven from the start.
    let first = rec.iter().find(|(_, o)| !o.springs.is_empty()).unwrap();
    assert!(first.1.springs.contains(2));
    // Never longer on than a window.
    for i in 0..3 {
        let mut run = 0;
        for (_, o) in rec {
            run = if o.springs.contains(i) { run + 1 } else { 0 };
            assert!(run <= 28, "spring {i} on for {run} frames");
        }
    }
    let s = Settings::DEFAULT;
    // Cooling: heater off and fan on, springs still topped up.
    let cool: Vec<_> = rec.iter().rev().take(20).collect();
    assert!(
        cool.iter()
            .all(|(_, o)| o.heater == Duty::OFF && o.fan != Duty::OFF)
    );
    assert!(r.sup.estimate().austenite.iter().all(|&a| a > 0.9));
    // A new stepping right away: soak, then rest until the estimate says martensite.
    r.line("mode step-large AB");
    let mut rested_after = None;
    let t0 = r.now_ms;
    while r.sup.mode().phase_name() != "prewarm" && r.now_ms - t0 < 2_000_000 {
        if r.sup.mode().phase_name() == "rest" && rested_after.is_none() {
            rested_after = Some(r.now_ms);
        }
        r.run(0.25);
    }
    let rest_from = rested_after.expect("it rests");
    assert!(
        r.sup
            .estimate()
            .austenite
            .iter()
            .all(|&a| a <= s.spring_rest)
    );
    assert!(
        r.now_ms - rest_from > 100_000,
        "{} ms",
        r.now_ms - rest_from
    );
    assert!(
        r.log[start..]
            .iter()
            .filter(|(t, _)| *t > rest_from && *t < r.now_ms - 250)
            .all(|(_, o)| o.springs.is_empty())
    );
    assert!(
        r.sup
            .events()
            .iter()
            .any(|e| e.kind == EventKind::SpringsResting)
    );
}

// ---------------------------------------------------------------------------------------------
// Issue 17: no setting, sequence or sensor state may defeat a limit. One test per finding.

impl Rig {
    /// One step with this frame (at the next 0.25 s), applying its outputs to the block.
    fn frame(&mut self, m: Measurement) -> Decision {
        self.now_ms += 250;
        let m = Measurement {
            at: Millis(self.now_ms),
            ..m
        };
        let d = self.sup.step(Millis(self.now_ms), Some(&m), None);
        self.block.step(&d.outputs, 0.25);
        self.log.push((self.now_ms, d.outputs));
        d
    }

    fn fault_code(&self) -> Option<&'static str> {
        self.sup.fault().map(|f| f.code())
    }
}

/// A frame reading `t1`/`t2` (resolved, unless `quality` says otherwise).
fn frame_of(t1: f32, t2: f32, quality: Quality, bound: f32) -> Measurement {
    Measurement {
        at: Millis(0),
        seq: 0,
        regions: [t1, t2, t2, 300.0, 298.0].map(Kelvin::new),
        hottest: Kelvin::new(t1.max(t2)),
        filled_pixels: 0,
        quality,
        bound: Kelvin::new(bound).unwrap(),
        tilt: None,
        exposure: None,
    }
}

#[test]
fn autotune_settings_past_a_safe_relay_are_refused() {
    let mut r = Rig::new();
    // base + amplitude may not pass 90 % (90 + 50 clamped to 100 % before).
    assert!(r.line("set tune_base_pct 90").starts_with("err conflict"));
    assert!(
        r.line("set tune_base_pct 60")
            .starts_with("ok tune_base_pct=60")
    );
    assert!(
        r.line("set tune_amplitude_pct 31")
            .starts_with("err conflict")
    );
    // A relay test needs minutes, not an hour.
    assert!(
        r.line("set tune_timeout_s 3600")
            .starts_with("err out-of-range")
    );
    assert_eq!(r.line("set tune_timeout_s 900"), "ok tune_timeout_s=900 s");
}

#[test]
fn autotune_obeys_the_heater_cap_and_both_over_temperature_limits() {
    let mut r = Rig::new();
    // Tc on the SMP, so the film can be near its cap while the relay runs.
    r.line("set w1_standby 0");
    r.run(2.0);
    r.line("autotune");
    // The film at 391 K: the cap allows (393 − 391)/4 = 50 % whatever the relay asks (70 %).
    let d = r.frame(frame_of(391.0, 300.0, Quality::Resolved, 0.3));
    assert_eq!(r.sup.mode().name(), "autotune");
    assert!(d.outputs.heater.fraction() <= 0.5 + 1e-6, "{d:?}");
    // The SMP past t_max_k latches over-temperature in autotune too.
    let d = r.frame(frame_of(380.0, 374.0, Quality::Resolved, 0.3));
    assert_eq!(r.fault_code(), Some("over-temperature"));
    assert_eq!(d.outputs.heater, Duty::OFF);
}

#[test]
fn autotune_keeps_the_heating_runaway_check() {
    let mut r = Rig::new();
    r.line("set tune_base_pct 60");
    r.line("set tune_amplitude_pct 30");
    r.line("set runaway_window_s 10");
    r.block.heater_ok = false;
    r.line("autotune");
    r.run(40.0);
    // The relay drives 90 % with no rise: a fault (runaway) or the tuner's own abort; either
    // way the heater is off within one window and a frame.
    let heating: Vec<_> = r
        .log
        .iter()
        .filter(|(_, o)| o.heater > Duty::OFF)
        .map(|(t, _)| *t)
        .collect();
    assert!(
        heating.last().is_some_and(|&t| t <= 10_500),
        "heater on until {:?} ms",
        heating.last()
    );
    assert_eq!(r.fault_code(), Some("runaway-heating"));
}

#[test]
fn autotune_aborts_when_the_reading_does_not_follow_the_relay() {
    // A camera that reads a steady 300 K however the relay drives: no rise in the heat-up.
    let mut r = Rig::new();
    r.line("autotune");
    for _ in 0..4 * 30 {
        r.frame(frame_of(300.0, 299.0, Quality::Resolved, 0.3));
    }
    assert_eq!(r.sup.mode().name(), "standby");
    assert!(
        r.sup
            .events()
            .iter()
            .any(|e| e.kind == EventKind::TuneAborted("not-following")),
        "{:?}",
        r.sup.events().iter().collect::<Vec<_>>()
    );
    // Once cycling: the reading crosses the band once, then freezes above it.
    let mut r = Rig::new();
    r.line("autotune");
    let limit_s = 2.0 * Settings::DEFAULT.tune_expected_period_s();
    let mut t = 0.0;
    let mut y = 330.0;
    while r.sup.mode().name() == "autotune" && t < 100.0 {
        y = (y + 1.0f32).min(342.0);
        r.frame(frame_of(y + 5.0, y, Quality::Resolved, 0.3));
        t += 0.25;
    }
    // The first switch comes at 341.5 K (2.75 s in); the abort two expected periods later.
    assert!(t < 2.75 + limit_s + 0.6, "aborted after {t} s");
    assert!(
        r.sup
            .events()
            .iter()
            .any(|e| e.kind == EventKind::TuneAborted("not-following"))
    );
}

#[test]
fn autotune_gains_out_of_range_are_refused() {
    let s = Settings::DEFAULT;
    let g = |kp, ki, kd| crate::control::PidGains {
        kp_per_k: kp,
        ki_per_k_s: ki,
        kd_s_per_k: kd,
    };
    assert!(s.with_gains(g(0.2, 0.1, 0.05)).is_ok());
    assert!(s.with_gains(g(20.0, 0.1, 0.05)).is_err(), "kp past 10 /K");
    assert!(s.with_gains(g(0.2, 5.0, 0.05)).is_err(), "ki past 1");
    assert!(s.with_gains(g(0.2, 0.1, f32::NAN)).is_err());
}

#[test]
fn autotune_at_a_hundred_days_of_uptime_measures_what_it_does_at_boot() {
    let tune = |start_ms: u64| {
        let mut r = Rig::new();
        r.now_ms = start_ms;
        r.sup = Supervisor::with_memory(Millis(start_ms), Settings::DEFAULT, SpringMemory::RESTED);
        r.run(2.0);
        r.line("autotune");
        while r.sup.mode().name() == "autotune" {
            r.run(0.25);
        }
        let tuned = r.sup.events().iter().find_map(|e| match e.kind {
            EventKind::Tuned { ku_per_k, tu_s } => Some((ku_per_k, tu_s)),
            _ => None,
        });
        tuned.expect("tuned")
    };
    let (ku0, tu0) = tune(0);
    let (ku1, tu1) = tune(100 * 86_400_000);
    assert!((tu1 - tu0).abs() < 0.01 * tu0, "Tu {tu0} vs {tu1}");
    assert!((ku1 - ku0).abs() < 0.01 * ku0, "Ku {ku0} vs {ku1}");
}

#[test]
fn a_short_gap_does_not_end_a_springs_on_time() {
    let mut r = Rig::new();
    // The safety review's sequence is refused as a setting…
    assert!(r.line("set pulse_s 0.5").starts_with("err conflict"));
    assert!(r.line("set prewarm_gap_s 0").starts_with("err conflict"));
    assert!(r.line("set recover_off_s 0.5").starts_with("err conflict"));
    // …and the duty check cannot be switched off.
    assert!(
        r.line("set spring_duty_max_pct 100")
            .starts_with("err out-of-range")
    );
    // With no pre-warm, a short gap is fine where the phases it joins fit the limit.
    assert_eq!(r.line("set prewarm_s 0"), "ok prewarm_s=0 s");
    assert_eq!(r.line("set step_s 3"), "ok step_s=3 s");
    assert_eq!(r.line("set large_steps 2"), "ok large_steps=2");
    assert!(r.line("set pulse_s 0.5").starts_with("ok pulse_s=0.5"));
    assert!(r.line("set large_steps 3").starts_with("err conflict"));
    // Ten 6 s phases with 2 s pulses keep on-time and duty; the springs' temperature band
    // keeps their heat (`back_to_back_steppings_keep_every_spring_in_its_band`).
    let mut r = Rig::new();
    assert!(r.line("set large_steps 10").starts_with("ok"));
    // At run time the count is the limit's: springs on 6 s, off 0.5 s, on again → past 8 s.
    let s = Settings::DEFAULT;
    let mut safety = Safety::new();
    let a = SpringMask::from_bits(1);
    for _ in 0..24 {
        assert_eq!(safety.credit_springs(a, 250, &s), None);
    }
    for _ in 0..2 {
        assert_eq!(safety.credit_springs(SpringMask::NONE, 250, &s), None);
    }
    let mut tripped = None;
    for k in 0..12 {
        if let Some(f) = safety.credit_springs(a, 250, &s) {
            tripped = Some((k, f));
            break;
        }
    }
    let (k, f) = tripped.expect("trips");
    assert_eq!(f.kind(), FaultKind::SpringOnTime(0));
    assert_eq!(k, 8, "6 s + 2.25 s of on-time");
}

#[test]
fn each_interval_is_credited_to_the_springs_that_were_on_during_it() {
    let mut r = Rig::new();
    r.run(60.0);
    r.line("mode step-small A");
    let mut on_at = None;
    while r.sup.mode().name() == "step-small" && r.now_ms < 200_000 {
        r.run(0.25);
        let on = r.sup.outputs().springs.contains(0);
        if on && on_at.is_none() {
            on_at = Some(r.now_ms);
            // Just switched on: nothing of the interval before (springs off) counts.
            assert_eq!(r.sup.safety().spring_on_s(0), 0.0);
        }
        // Through the first on-run (the pre-warm) the count is exactly the time on.
        if let Some(t0) = on_at {
            if !on {
                break;
            }
            let want = (r.now_ms - t0) as f32 * 1e-3;
            assert!((r.sup.safety().spring_on_s(0) - want).abs() < 1e-3);
        }
    }
    assert!(on_at.is_some());
    assert!(r.sup.fault().is_none(), "{:?}", r.sup.fault());
}

#[test]
fn the_estop_overrides_a_latched_fault_and_reset_waits_for_the_button() {
    let mut r = Rig::new();
    r.run(10.0);
    r.sensor = false;
    r.run(1.5);
    assert_eq!(r.fault_code(), Some("sensor-loss"));
    // The console's estop over another fault is recorded, not lost.
    assert_eq!(r.line("estop"), "ok emergency stop latched");
    assert_eq!(r.fault_code(), Some("estop"));
    r.sensor = true;
    r.run(1.0);
    // The button read pressed (its level, every period): reset is refused while it is.
    r.sup.button(Millis(r.now_ms), true);
    r.run(0.25);
    assert!(r.line("reset").starts_with("err cause-present"));
    r.sup.button(Millis(r.now_ms), false);
    let reply = r.line("reset");
    assert!(reply.starts_with("ok fault cleared, stopped"), "{reply}");
    // After an e-stop the heater does not come back by itself.
    r.run(30.0);
    assert!(
        r.log
            .iter()
            .rev()
            .take(100)
            .all(|(_, o)| *o == Outputs::OFF)
    );
    assert_eq!(r.sup.mode().name(), "stopped");
    assert!(r.line("mode standby").starts_with("ok"));
    r.run(1.0);
    assert!(r.sup.outputs().heater > Duty::OFF);
}

#[test]
fn the_button_pressed_during_another_fault_still_latches_the_estop() {
    let mut r = Rig::new();
    r.block.heater_ok = false;
    r.run(30.0);
    assert_eq!(r.fault_code(), Some("runaway-heating"));
    r.sup.button(Millis(r.now_ms), true);
    assert_eq!(r.fault_code(), Some("estop"));
    r.run(1.0);
    assert_eq!(r.sup.outputs(), Outputs::OFF, "e-stop: the fan off too");
    assert!(r.line("reset").starts_with("err cause-present"));
}

#[test]
fn stop_is_accepted_with_a_fault_latched_and_turns_the_fan_off() {
    let mut r = Rig::new();
    r.run(5.0);
    r.sensor = false;
    r.run(1.5);
    assert_eq!(r.fault_code(), Some("sensor-loss"));
    assert!(
        r.sup.outputs().fan > Duty::OFF,
        "the fan cools under a fault"
    );
    let reply = r.line("stop");
    assert!(reply.starts_with("ok every output off"), "{reply}");
    r.run(1.0);
    assert_eq!(r.sup.outputs(), Outputs::OFF);
    assert_eq!(r.fault_code(), Some("sensor-loss"), "still latched");
}

#[test]
fn unresolved_frames_are_judged_by_the_worst_they_may_hide() {
    // Merged: mean 370 K, bound 4 K. The SMP may be at 374 K > t_max_k (373 K).
    let mut r = Rig::new();
    r.run(1.0);
    r.frame(frame_of(370.0, 370.0, Quality::Merged, 4.0));
    assert_eq!(r.fault_code(), Some("over-temperature"));
    // The same frame resolved is two regions at 370 K: fine.
    let mut r = Rig::new();
    r.run(1.0);
    r.frame(frame_of(370.0, 370.0, Quality::Resolved, 4.0));
    assert_eq!(r.fault_code(), None);
}

#[test]
fn a_frame_above_the_plausible_range_is_an_over_temperature_at_once() {
    let mut r = Rig::new();
    r.run(1.0);
    let d = r.frame(frame_of(560.0, 380.0, Quality::Resolved, 0.3));
    assert_eq!(r.fault_code(), Some("over-temperature"));
    assert_eq!(d.outputs.heater, Duty::OFF);
    // Implausibly cold (or NaN) is still no measurement: sensor loss after the window.
    let mut r = Rig::new();
    r.run(1.0);
    for _ in 0..5 {
        r.frame(frame_of(150.0, 150.0, Quality::Resolved, 0.3));
    }
    assert_eq!(r.fault_code(), Some("sensor-loss"));
}

#[test]
fn a_plausible_but_wrong_camera_trips_no_response_however_the_modes_change() {
    // The camera reads 320 K whatever the heater does: inside standby's hold band, below
    // its target, so the loop drives the heater flat out.
    let mut r = Rig::new();
    let mut tripped = None;
    for k in 0..4 * 120 {
        // Toggling the mode every 10 s re-armed every check before.
        if k % 40 == 0 {
            r.line(if k % 80 == 0 {
                "mode standby"
            } else {
                "mode step-large AB"
            });
        }
        r.frame(frame_of(320.0, 319.0, Quality::Resolved, 0.3));
        if r.sup.fault().is_some() {
            tripped = Some(k as f32 * 0.25);
            break;
        }
    }
    assert_eq!(r.fault_code(), Some("no-response"));
    let t = tripped.unwrap();
    assert!((59.0..65.0).contains(&t), "after {t} s");
}

#[test]
fn a_long_run_of_unresolved_frames_while_heating_falls_back_to_the_film() {
    let mut r = Rig::new();
    r.run(40.0);
    r.line("mode step-large AB");
    let mut warned = None;
    for k in 0..4 * 40 {
        let t1 = r.block.t1;
        let d = r.frame(frame_of(t1, t1, Quality::Merged, 2.0));
        if let Some(events::Notice::Warning(w)) = d.notice {
            warned = Some((k, w));
            break;
        }
    }
    let (k, w) = warned.expect("a warning");
    assert_eq!(w, WARN_UNRESOLVED);
    assert!((4 * 30 - 1..=4 * 30 + 1).contains(&k), "after {k} frames");
    assert!(r.sup.film_fallback());
    assert_eq!(r.sup.sensing_hint().weights.w1, 1.0);
    // Resolved frames give the mode its region back.
    let d = r.frame(r.block.measure(0, 0));
    assert_eq!(d.notice, Some(events::Notice::Warning(WARN_RESOLVED)));
    assert!(!r.sup.film_fallback());
}

#[test]
fn flash_operations_run_with_heater_and_springs_off_and_no_nuisance_sensor_loss() {
    let mut r = Rig::new();
    r.run(5.0);
    assert!(r.sup.outputs().heater > Duty::OFF, "standby heating");
    let d = r
        .sup
        .step(Millis(r.now_ms), None, Some(parse("save").unwrap()));
    assert!(d.store.is_some());
    assert_eq!(d.outputs.heater, Duty::OFF);
    assert!(d.outputs.springs.is_empty());
    // A 2.5 s erase: the sensor stalls with the core; the window restarts at its end.
    r.now_ms += 2500;
    r.sup
        .finish_store(Millis(r.now_ms), store::StoreOutcome::Saved);
    r.run(5.0);
    assert_eq!(r.fault_code(), None);
    // `load` is refused where `save` is (while a mode drives the block).
    r.line("mode step-large AB");
    assert!(r.line("load").starts_with("err bad-state"));
    assert!(r.line("save").starts_with("err bad-state"));
}

#[test]
fn a_stepping_hold_and_a_pause_end_by_their_idle_timeout() {
    let mut r = Rig::new();
    r.line("set hold_timeout_s 30");
    r.run(60.0);
    r.line("mode step-small A");
    while r.sup.mode().phase_name() != "hold" && r.now_ms < 400_000 {
        r.run(0.25);
    }
    assert_eq!(
        r.sup.mode().phase_name(),
        "hold",
        "{:?}",
        r.sup.events().iter().collect::<Vec<_>>()
    );
    r.run(29.0);
    assert_eq!(r.sup.mode().phase_name(), "hold");
    r.run(1.5);
    assert_eq!(r.sup.mode().name(), "standby");
    assert!(
        r.sup
            .events()
            .iter()
            .any(|e| matches!(e.kind, EventKind::TimedOut { what: "hold", .. }))
    );
    // Pause means something only in a spring phase; paused, the idle timeout runs.
    let mut r = Rig::new();
    r.line("set hold_timeout_s 30");
    r.run(60.0);
    r.line("mode step-small A");
    assert!(r.line("pause").starts_with("err bad-state"), "soak");
    while r.sup.mode().phase_name() != "prewarm" {
        r.run(0.25);
    }
    assert_eq!(r.line("pause"), "ok paused");
    r.run(31.0);
    assert_eq!(r.sup.mode().name(), "standby");
}

#[test]
fn recovery_heat_ends_by_its_timeout_even_when_ready() {
    let mut r = Rig::new();
    r.line("set soak_timeout_s 60");
    // 5 W springs never reach A_s (their still-air balance is ≈ 36 K above the ambient): the
    // wall softens but the springs never turn austenite.
    assert!(r.line("set obs_spring_w 5").starts_with("ok"));
    r.run(60.0);
    r.line("mode recover");
    r.run(61.0);
    assert_eq!(r.sup.mode().name(), "standby");
    assert!(
        r.sup
            .events()
            .iter()
            .any(|e| matches!(e.kind, EventKind::TimedOut { what: "reheat", .. }))
    );
}

#[test]
fn load_and_defaults_rebuild_the_cascade_outer_loop() {
    let mut r = Rig::new();
    r.line("set heater_cap_k 380");
    let max = |r: &Rig| r.sup.loop_configs().1.output_max;
    assert_eq!(max(&r), 380.0 - 4.0 - 323.0);
    r.line("defaults");
    assert_eq!(max(&r), 393.0 - 4.0 - 323.0);
    r.line("set heater_cap_k 380");
    let mut saved = Settings::DEFAULT;
    saved.heater_cap_k = 385.0;
    r.sup.step(Millis(r.now_ms), None, Some(Command::Load));
    r.sup.finish_store(
        Millis(r.now_ms),
        store::StoreOutcome::Loaded(Some(&saved.encode())),
    );
    assert_eq!(max(&r), 385.0 - 4.0 - 323.0);
}

#[test]
fn after_a_power_up_the_springs_are_assumed_hot_and_a_reset_keeps_them() {
    // Power-up: a stepping rests the springs first.
    let mut r = Rig::new();
    r.sup = Supervisor::new(Millis(0), Settings::DEFAULT);
    r.run(60.0);
    r.line("mode step-small A");
    let mut phases = Vec::new();
    while r.sup.mode().phase_name() != "spring" && r.now_ms < 1_000_000 {
        let p = r.sup.mode().phase_name();
        if phases.last() != Some(&p) {
            phases.push(p);
        }
        r.run(0.25);
    }
    assert_eq!(phases, ["soak", "rest", "prewarm"]);
    // The memory of a hot spring survives a reset of the chip (and the console's reset).
    let mut hot = Rig::new();
    hot.run(60.0);
    hot.line("mode step-large AB");
    while hot.sup.mode().phase_name() != "hold" {
        hot.run(0.25);
    }
    let memory = hot.sup.spring_memory();
    let back = SpringMemory::from_words(&memory.to_words()).unwrap();
    let again = Supervisor::with_memory(Millis(0), Settings::DEFAULT, back);
    let (e, h) = (again.estimate(), hot.sup.estimate());
    assert_eq!((e.springs_k, e.austenite), (h.springs_k, h.austenite));
    assert_eq!(
        again.safety().spring_duty(0),
        hot.sup.safety().spring_duty(0)
    );
    assert!(e.springs_k[0] > 340.0, "{e:?}");
}

#[test]
fn a_spring_estimated_past_its_limit_latches_and_is_never_driven() {
    // A reset that kept a spring's memory at 390 K (past spring_max_k, 383 K).
    let mut memory = SpringMemory::RESTED;
    memory.springs = Some(
        [SpringRecord {
            temp_k: 390.0,
            austenite: 1.0,
        }; 3],
    );
    let mut r = Rig::new();
    r.sup = Supervisor::with_memory(Millis(0), Settings::DEFAULT, memory);
    r.run(1.0);
    assert_eq!(r.fault_code(), Some("spring-over-temperature"));
    assert!(r.log.iter().all(|(_, o)| o.springs.is_empty()));
    // The cause stays until the estimate has cooled below the band.
    assert!(r.line("reset").starts_with("err cause-present"));
    r.run(300.0);
    assert!(r.sup.estimate().springs_k[0] < 361.0);
    assert!(r.line("reset").starts_with("ok"), "{}", r.line("status"));
}

#[test]
fn back_to_back_steppings_keep_every_spring_in_its_band() {
    let mut r = Rig::new();
    for l in ["set prewarm_s 0", "set large_steps 10", "set pulse_s 1"] {
        assert!(r.line(l).starts_with("ok"), "{l}: {}", r.line(l));
    }
    r.run(60.0);
    let mut hottest = 0.0f32;
    let mut steppings = 0;
    for _ in 0..900 {
        if matches!(r.sup.mode().phase_name(), "hold" | "-") {
            r.line("mode step-large A");
            steppings += 1;
        }
        r.run(1.0);
        hottest = hottest.max(r.sup.estimate().springs_k[0]);
    }
    // Each stepping waits for spring A to rest (≈ 4 min) before its ten phases.
    assert!(steppings >= 3, "{steppings}");
    assert!(r.sup.fault().is_none(), "{:?}", r.sup.fault());
    let s = Settings::DEFAULT;
    assert!(hottest > s.spring_hot_k - s.spring_band_k, "{hottest}");
    assert!(hottest < s.spring_hot_k + 1.0, "{hottest}");
}

// ---------------------------------------------------------------------------------------------
// Issue 22: the console's answers.

/// `get` writes a count whole and any other value in the fewest decimals that read back as
/// the value stored (issue 44: `set ki 0.0004` answered `ki=0.000`), and lists every parameter
/// in one uncut reply.
#[test]
fn get_writes_what_reads_back_and_lists_every_one() {
    let mut r = Rig::new();
    assert_eq!(r.line("set hot_k 358"), "ok hot_k=358 K");
    assert_eq!(r.line("set hot_k 357.5"), "ok hot_k=357.5 K");
    assert_eq!(r.line("get hot_k"), "ok hot_k=357.5 K");
    assert_eq!(r.line("set ki 0.0004"), "ok ki=0.0004 1/(K*s)");
    assert_eq!(r.line("set kp 0.1234567"), "ok kp=0.1234567 1/K");
    assert_eq!(r.line("get kp"), "ok kp=0.1234567 1/K");
    assert_eq!(r.line("set kd 1e-20"), "ok kd=1e-20 s/K");
    assert_eq!(
        r.line("set cam_azimuth_deg -12.25"),
        "ok cam_azimuth_deg=-12.25 deg"
    );
    assert_eq!(
        r.line("set spring_duty_max_pct 60"),
        "ok spring_duty_max_pct=60 %"
    );
    assert_eq!(r.line("get large_steps"), "ok large_steps=4");
    assert_eq!(
        r.line("set kp 12.5"),
        "err out-of-range: kp must be in [0, 10] 1/K"
    );
    // A percentage's range as the table has it (120, not the 120.00001 that 1.2 × 100 is).
    assert_eq!(
        r.line("set trim_ia_pct 130"),
        "err out-of-range: trim_ia_pct must be in [80, 120] %"
    );
    let all = r.line("get");
    assert!(!all.ends_with(" ..."), "cut: {all}");
    for p in PARAMS {
        assert!(
            all.contains(&std::format!(" {}=", p.name)),
            "{} missing",
            p.name
        );
    }
}

proptest::proptest! {
    /// What `set` stored is what `set`'s reply and `get` show, to the bit: for every
    /// parameter, values typed in the shortest form and with 0 to 9 decimals,
    /// parse(get(set(x))) == x as f32 (a percentage: the same percentage once kept as a
    /// fraction), and setting what `get` showed changes nothing.
    #[test]
    fn a_value_reads_back_as_set(
        i in 0..PARAMS.len(),
        at in 0.0f64..=1.0,
        decimals in proptest::option::of(0usize..=9),
    ) {
        let p = &PARAMS[i];
        let v = f64::from(p.min) + at * f64::from(p.max - p.min);
        let typed = match decimals {
            _ if p.integer => std::format!("{}", v.round()),
            Some(d) => std::format!("{v:.d$}"),
            None => std::format!("{}", v as f32),
        };
        let x: f32 = typed.parse().unwrap();
        proptest::prop_assume!((p.min..=p.max).contains(&x));
        let mut r = Rig::new();
        let reply = r.line(&std::format!("set {} {typed}", p.name));
        // Another parameter's relation may refuse it (`err conflict`).
        proptest::prop_assume!(!reply.starts_with("err conflict"), "{}", reply);
        let prefix = std::format!("ok {}=", p.name);
        let shown = reply
            .strip_prefix(&prefix)
            .and_then(|rest| rest.split(' ').next())
            .unwrap_or_else(|| panic!("set {} {typed}: {reply}", p.name));
        let read = crate::decimal::parse(shown).unwrap();
        proptest::prop_assert_eq!(shown.parse::<f32>().ok(), Some(read), "{}", reply);
        if p.percent {
            // Kept as a fraction: the text's fraction gives the same percentage as x's.
            proptest::prop_assert_eq!(read / 100.0 * 100.0, x / 100.0 * 100.0, "{}", reply);
        } else {
            proptest::prop_assert_eq!(read, x, "{}", reply);
        }
        proptest::prop_assert_eq!(r.line(&std::format!("get {}", p.name)), reply.clone());
        let before = r.sup.settings().encode();
        proptest::prop_assert_eq!(r.line(&std::format!("set {} {shown}", p.name)), reply);
        proptest::prop_assert_eq!(r.sup.settings().encode(), before);
    }
}

/// Issue 44: `help` says what a person needs first: the parameters' names (`help set`,
/// `help get`), the stream's range and default (the constants'), how an e-stop is cleared.
#[test]
fn help_names_the_parameters_the_stream_range_and_how_to_clear_an_estop() {
    let mut r = Rig::new();
    for line in ["help set", "help get"] {
        let reply = r.line(line);
        let names = reply
            .split("; NAME: ")
            .nth(1)
            .unwrap_or_else(|| panic!("{reply}"));
        let want: Vec<&str> = PARAMS.iter().map(|p| p.name).collect();
        assert_eq!(names.split(' ').collect::<Vec<_>>(), want, "{line}");
        assert!(!reply.ends_with(" ..."), "cut: {reply}");
    }
    let stream = r.line("help stream");
    let (max, default) = (
        std::format!("up to {STREAM_MAX_HZ}"),
        std::format!("default {STREAM_DEFAULT_HZ})"),
    );
    assert!(
        stream.contains(&max) && stream.contains(&default),
        "{stream}"
    );
    assert!(
        r.line(&std::format!("stream on {STREAM_MAX_HZ}"))
            .starts_with("ok")
    );
    let above = r.line(&std::format!("stream on {}", STREAM_MAX_HZ + 0.5));
    assert_eq!(
        above,
        std::format!("err out-of-range: stream rate must be in (0, {STREAM_MAX_HZ}] Hz")
    );
    assert_eq!(
        r.line("help estop"),
        "ok estop: emergency stop, every output off; latched until `reset` with the button \
         released"
    );
    // What the help says clears it does.
    r.run(1.0);
    assert!(r.line("estop").starts_with("ok"));
    assert_eq!(r.sup.fault().map(|f| f.code()), Some("estop"));
    assert!(r.line("reset").starts_with("ok"));
    assert!(r.sup.fault().is_none());
}

/// Issue 44: `status short` is `status`' fields a person watches, in the same order and format.
#[test]
fn status_short_is_the_watched_fields_of_status() {
    let mut r = Rig::new();
    r.run(5.0);
    let full = r.line("status");
    let short = r.line("status short");
    let names = |reply: &str| -> Vec<std::string::String> {
        reply
            .split(' ')
            .skip(1)
            .map(|f| f.split('=').next().unwrap().into())
            .collect()
    };
    assert_eq!(
        names(&short),
        [
            "mode",
            "phase",
            "target_k",
            "tc_k",
            "heater_pct",
            "fan_pct",
            "springs",
            "bend_deg",
            "bend_sd_deg",
            "fault"
        ]
    );
    for field in short.split(' ').skip(1) {
        assert!(
            full.contains(&std::format!(" {field}")),
            "{field} in {full}"
        );
    }
    assert!(short.len() < 200 && full.len() > 600, "{short}");
}

/// Issue 44: `settings`, the listing a person reads (Marlin's M503): one `#` line a parameter
/// with value, unit, default and range, `*` where not the default; `get` stays one line.
#[test]
fn settings_lists_every_parameter_for_a_person() {
    use crate::supervisor::report::{SETTING_LINES, write_setting};
    let mut r = Rig::new();
    assert_eq!(r.line("set hot_k 360"), "ok hot_k=360 K");
    assert_eq!(r.line("set large_steps 3"), "ok large_steps=3");
    let c = parse("settings").unwrap();
    let reply = r.sup.step(Millis(r.now_ms), None, Some(c)).reply.unwrap();
    assert!(reply.lists_settings());
    assert_eq!(reply.as_str(), "ok 81 parameters, 2 not the default (*)");
    assert!(
        !r.sup
            .step(Millis(r.now_ms), None, parse("get").ok())
            .reply
            .unwrap()
            .lists_settings()
    );
    let mut text = std::string::String::new();
    for i in 0..SETTING_LINES {
        write_setting(&mut text, r.sup.settings(), i).unwrap();
    }
    let lines: Vec<&str> = text.split_terminator("\r\n").collect();
    assert_eq!(lines.len(), PARAMS.len());
    assert_eq!(
        lines[1],
        "# * hot_k                       360         K        default 358, 338 to 368"
    );
    assert_eq!(
        lines[3],
        "#   kp                          0.139       1/K      default 0.139, 0 to 10"
    );
    let steps = PARAMS.iter().position(|p| p.name == "large_steps").unwrap();
    assert_eq!(
        lines[steps],
        "# * large_steps                 3                    default 4, 1 to 10"
    );
    for (line, p) in lines.iter().zip(PARAMS) {
        assert!(line.starts_with("# ") && line.len() <= 96, "{line}");
        // The columns: mark, name, value, unit.
        assert_eq!(line.get(4..32).map(str::trim_end), Some(p.name), "{line}");
        assert_eq!(line.get(44..53).map(str::trim_end), Some(p.unit), "{line}");
        let value = line.get(32..44).unwrap().trim_end();
        let get = r.sup.step(
            Millis(r.now_ms),
            None,
            Some(Command::Get(Some(
                PARAMS.iter().position(|q| q.name == p.name).unwrap() as u8,
            ))),
        );
        let get = get.reply.unwrap();
        assert!(
            get.as_str()
                .starts_with(&std::format!("ok {}={value}", p.name)),
            "{line}"
        );
        assert_eq!(
            line.starts_with("# *"),
            p.name == "hot_k" || p.name == "large_steps"
        );
    }
}

/// An autotune says when it is done, with what it measured and the gains it put in use (which
/// are the settings' now, in RAM: `save` keeps them); one that gives up says so.
#[test]
fn autotune_announces_its_result_and_that_save_keeps_it() {
    let mut r = Rig::new();
    r.run(2.0);
    assert_eq!(r.line("autotune"), "ok autotune started");
    let mut said = None;
    for _ in 0..4 * 600 {
        r.now_ms += 250;
        r.seq += 1;
        let m = r.block.measure(r.now_ms, r.seq);
        let d = r.sup.step(Millis(r.now_ms), Some(&m), None);
        r.block.step(&d.outputs, 0.25);
        if let Some(n) = d.notice {
            said = Some(n);
            break;
        }
    }
    let Some(events::Notice::Tuned { kp, ki, kd, .. }) = said else {
        panic!("no autotune notice: {said:?}");
    };
    let g = r.sup.settings().gains;
    assert_eq!((kp, ki, kd), (g.kp_per_k, g.ki_per_k_s, g.kd_s_per_k));
    assert_ne!(g, Settings::DEFAULT.gains, "the gains changed");
    let line = std::format!("# {}", said.unwrap());
    assert!(line.starts_with("# autotune done: ku="), "{line}");
    assert!(
        line.ends_with("the gains are in use (in RAM): `save` keeps them"),
        "{line}"
    );
    assert_eq!(r.sup.mode().name(), "standby");

    // A relay that never sees the block move gives up with its reason.
    let mut r = Rig::new();
    r.run(2.0);
    assert!(r.line("set tune_timeout_s 60").starts_with("ok"));
    r.line("autotune");
    r.block.heater_ok = false;
    let mut said = None;
    for _ in 0..4 * 120 {
        let d = r.frame(r.block.measure(0, 0));
        if d.notice.is_some() {
            said = d.notice;
            break;
        }
    }
    let said = std::format!("# {}", said.expect("an abort notice"));
    assert!(said.starts_with("# autotune aborted: "), "{said}");
    assert!(said.ends_with("; the gains are unchanged"), "{said}");
    assert_eq!(r.sup.settings().gains, Settings::DEFAULT.gains);
}

#[test]
fn a_pose_beyond_its_springs_reach_is_refused_and_one_within_reach_steps_by_the_estimate() {
    let mut r = Rig::new();
    r.run(5.0);
    // One spring against the soft wall reaches ≈ 42°: 60° is refused, nothing changes.
    let reply = r.line("mode pose 60 A");
    assert!(reply.starts_with("err out-of-reach"), "{reply}");
    assert_eq!(r.sup.mode().name(), "standby");
    let reply = r.line("mode pose 20 BC form");
    assert!(
        reply.starts_with("ok mode pose 20.0 springs=BC reach_deg="),
        "{reply}"
    );
    assert!(reply.ends_with(" form"), "{reply}");
    assert_eq!(
        (r.sup.mode().name(), r.sup.mode().phase_name()),
        ("pose", "soak")
    );
    // It soaks as stepping does, with the springs off.
    r.run(1.0);
    assert_eq!(r.sup.outputs().springs, SpringMask::NONE);
    assert!(r.line("status").contains(" bend_deg="));
    // Formed, the column rests short of where it froze: the pose aims past its target by the
    // spring-back, and the reach it gives is the formed column's, less than the soft one's.
    let Mode::Posing(p) = r.sup.mode() else {
        panic!("{:?}", r.sup.mode())
    };
    assert!(p.aim_deg > 21.0 && p.aim_deg < 30.0, "{p:?}");
    let reach = |reply: &str| -> f32 {
        let at = reply.find("reach_deg=").unwrap() + "reach_deg=".len();
        reply[at..].split(' ').next().unwrap().parse().unwrap()
    };
    let formed = reach(&r.line("mode pose 20 BC form"));
    let soft = reach(&r.line("mode pose 20 BC"));
    assert!(formed < soft - 3.0, "{formed} {soft}");
    let Mode::Posing(p) = r.sup.mode() else {
        panic!("{:?}", r.sup.mode())
    };
    assert_eq!(
        p.aim_deg, 20.0,
        "held soft, no spring-back to make up: {p:?}"
    );
    // A formed target beyond the formed reach (plus the tolerance) is refused.
    let reply = r.line(&format!("mode pose {} BC form", formed + 2.5));
    assert!(reply.starts_with("err out-of-reach"), "{reply}");
}

/// A frame of the lattice as MTTS saw it: `fitted_pct` exposed, fitted with `design_pct`
/// (adopted this frame when `adopted`), the configured design 71 %.
fn exposure_frame(design_pct: f32, adopted: bool) -> Measurement {
    Measurement {
        exposure: Some(crate::measurement::LatticeExposure {
            fitted_pct: design_pct + 1.0,
            design_pct,
            configured_pct: 71.0,
            adopted,
            shows_pct: None,
        }),
        ..frame_of(300.0, 299.0, Quality::Resolved, 0.3)
    }
}

#[test]
fn a_lattice_unlike_its_design_is_named_once_a_minute_and_status_carries_its_exposure() {
    let mut r = Rig::new();
    assert!(r.line("status").contains(" exposed_pct=- design_pct=-"));
    // Frames that agree with the design: no warning.
    for _ in 0..8 {
        assert_eq!(r.frame(exposure_frame(71.0, false)).notice, None);
    }
    // The frames adopt 33 %: one warning naming both fractions.
    let d = r.frame(exposure_frame(33.0, true));
    let Some(events::Notice::Warning(w)) = d.notice else {
        panic!("no warning: {:?}", d.notice);
    };
    assert_eq!(
        w,
        Warning::ExposureUnlikeDesign {
            shows_pct: 33.0,
            design_pct: 71.0
        }
    );
    let text = std::format!("{w}");
    assert!(
        text.contains("33 % exposed") && text.contains("design 71 %"),
        "{text}"
    );
    assert!(
        r.line("status")
            .contains(" exposed_pct=34.0 design_pct=33.0"),
        "{}",
        r.line("status")
    );
    // Back to the design 10 s later, then unlike again: held back until a minute has passed,
    // then said once with the latest finding.
    let mut said = Vec::new();
    for k in 0..4 * 70 {
        let m = match k {
            40 => exposure_frame(71.0, true),
            80 => exposure_frame(40.0, true),
            _ if k > 80 => exposure_frame(40.0, false),
            _ => exposure_frame(71.0, false),
        };
        if let Some(events::Notice::Warning(w)) = r.frame(m).notice {
            said.push((k, w));
        }
    }
    assert_eq!(said.len(), 1, "{said:?}");
    let (k, w) = said[0];
    assert_eq!(
        w,
        Warning::ExposureUnlikeDesign {
            shows_pct: 40.0,
            design_pct: 71.0
        }
    );
    // The first warning came one step before this loop: the next is due a minute after it.
    assert!((4 * 60 - 2..=4 * 60).contains(&k), "said at frame {k}");
    assert!(r.line("log").contains("lattice shows 40 % exposed"));
}
