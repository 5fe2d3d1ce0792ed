//! The supervisor stepped against a two-node thermal model (heater film and SMP wall), with
//! console lines, sensor gaps and faults.

use super::*;
use crate::command::parse;
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
            regions: [
                Kelvin(self.t1),
                Kelvin(self.t2),
                Kelvin(self.t2),
                Kelvin(300.0),
                Kelvin(298.0),
            ],
            tc: Kelvin(self.t2),
            cylinder_max: Some(Kelvin(self.t1.max(self.t2))),
            filled_pixels: 0,
            quality: Quality::Resolved,
            bound: Kelvin(0.5),
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
            sup: Supervisor::new(Millis(0), Settings::DEFAULT),
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
    assert_eq!(on.len(), 10, "{on:?}");
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
    assert_eq!(r.line("reset"), "ok fault cleared, standby");
    assert_eq!(r.sup.mode().name(), "standby");
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
    let d = r.sup.step(
        Millis(r.now_ms),
        None,
        Some(Command::Button { pressed: true }),
    );
    assert_eq!(d.outputs, Outputs::OFF, "e-stop: everything off, fan too");
    assert!(r.line("reset").starts_with("err cause-present"));
    r.sup.step(
        Millis(r.now_ms),
        None,
        Some(Command::Button { pressed: false }),
    );
    assert_eq!(r.line("reset"), "ok fault cleared, standby");
}

#[test]
fn over_temperature_is_by_rank_not_label() {
    let mut r = Rig::new();
    r.run(1.0);
    let mut m = r.block.measure(r.now_ms + 250, 999);
    // The hotter is the film: 390 K is below its limit whichever label it has.
    m.regions[0] = Kelvin(330.0);
    m.regions[1] = Kelvin(390.0);
    r.sup.step(Millis(r.now_ms + 250), Some(&m), None);
    assert!(r.sup.fault().is_none());
    // The colder at 375 K is the SMP above 373 K.
    m.at = Millis(r.now_ms + 500);
    m.regions[0] = Kelvin(375.0);
    r.sup.step(Millis(r.now_ms + 500), Some(&m), None);
    assert_eq!(r.sup.fault().map(|f| f.code()), Some("over-temperature"));
}

#[test]
fn bad_measurements_are_ignored_and_time_never_runs_back() {
    let mut r = Rig::new();
    r.run(5.0);
    let mut m = r.block.measure(r.now_ms, 1);
    m.regions[1] = Kelvin(f32::NAN);
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
    assert!(r.line("help").starts_with("ok commands: help;"));
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
    let (a, c) = (r.sup.spring_heat().heat(0), r.sup.spring_heat().heat(2));
    assert!(a > 0.6 && c == 0.0, "{a} {c}");
    let start = r.log.len();
    r.line("mode recover");
    let mut phases = Vec::new();
    while r.sup.mode().name() == "recover" && r.log.len() - start < 4 * 600 {
        let p = r.sup.mode().phase_name();
        if phases.last() != Some(&p) {
            phases.push(p);
        }
        r.run(0.25);
    }
    assert_eq!(phases, ["heat", "pulse", "hold", "cool"]);
    assert_eq!(r.sup.mode().name(), "standby");
    assert!(r.sup.fault().is_none(), "{:?}", r.sup.fault());
    let rec = &r.log[start..];
    // C, the cold spring, is driven alone first; A and B join once it has caught up.
    let first = rec.iter().find(|(_, o)| !o.springs.is_empty()).unwrap();
    assert_eq!(first.1.springs, SpringMask::from_bits(0b100));
    let joined = rec.iter().position(|(_, o)| o.springs.contains(0)).unwrap();
    assert!(joined > 4 * 10, "A joined after {joined} frames");
    // Never longer on than a window, and every spring reached the recovery heat.
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
    assert!((0..3).all(|i| r.sup.spring_heat().heat(i) > 0.9 * s.spring_recover_heat));
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
    assert!(r.sup.spring_heat().rested(s.spring_rest));
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
