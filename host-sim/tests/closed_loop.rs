//! The firmware's supervisor in the loop with the simulated block: scene commands, the thesis's
//! cycle at three ambients, the fault scenes of the controller issue, and one scene per burn
//! path of issue 17 (driven through console lines), each with its detection time printed
//! (`cargo test -p host-sim --test closed_loop -- --nocapture`).

use host_sim::runs::paper;
use host_sim::runs::run::{Row, run};
use host_sim::runs::scenario;

/// A closed-loop scene: `body` adds commands and faults to a 298.15 K base.
fn scene(name: &str, duration_s: f64, camera: bool, body: &str) -> scenario::Scenario {
    let text = format!(
        "name = \"{name}\"\nduration = \"{duration_s} s\"\nambient = \"298.15 K\"\n\
         period = \"0.25 s\"\n[fidelity]\ncamera = {camera}\n[camera]\nnoise = \"0.1 K\"\n{body}"
    );
    scenario::parse(&text, name, name).unwrap()
}

fn mode(r: &Row) -> &'static str {
    r.control.unwrap().mode
}

fn phase(r: &Row) -> &'static str {
    r.control.unwrap().phase
}

fn fault(r: &Row) -> Option<&'static str> {
    r.control.unwrap().fault
}

/// First time (end of period) a row satisfies `pred`.
fn first(rows: &[Row], pred: impl Fn(&Row) -> bool) -> Option<f64> {
    rows.iter().find(|r| pred(r)).map(|r| r.obs.time_s)
}

/// When the board latched `code`, s (the supervisor's event: exact to the board's tick or
/// frame, not to the scene's period).
fn latched(r: &host_sim::runs::run::RunResult, code: &str) -> Option<f64> {
    r.summary
        .faults
        .iter()
        .find(|f| f.code == code)
        .map(|f| f.at_s)
}

/// No row of `rows` has a latched fault (`what` names the run in the message).
fn assert_no_trip(rows: &[Row], what: &str) {
    let trip = rows.iter().find(|r| fault(r).is_some());
    assert!(
        trip.is_none(),
        "{what}: {:?} at {:?} s",
        trip.and_then(fault),
        trip.map(|r| r.obs.time_s)
    );
}

fn safe(r: &Row) -> bool {
    r.inputs.heater_duty == 0.0 && !r.springs_cmd.iter().any(|s| *s)
}

#[test]
fn a_scene_with_commands_may_not_set_duties() {
    let text = "name = \"x\"\nduration = \"10 s\"\nambient = \"298 K\"\n[[action]]\nat = \"0 s\"\nheater = \"50 %\"\n\
                [[command]]\nat = \"1 s\"\nline = \"mode standby\"\n";
    let e = scenario::parse(text, "x.toml", "x")
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("x.toml:6: `action[1].heater`") && e.contains("may not set duties"),
        "{e}"
    );
    let text = "name = \"x\"\nduration = \"10 s\"\nambient = \"298 K\"\n[[command]]\nat = \"1 s\"\nline = \"mode fly\"\n";
    let e = scenario::parse(text, "x.toml", "x")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("x.toml:6") && e.contains("command[1].line"),
        "{e}"
    );
}

#[test]
fn replies_and_faults_go_to_the_summary() {
    let sc = scene(
        "replies",
        20.0,
        false,
        "[[command]]\nat = \"1 s\"\nline = \"status\"\n\
         [[command]]\nat = \"2 s\"\nline = \"set hot_k 999\"\n\
         [[command]]\nat = \"3 s\"\nline = \"estop\"\n\
         [[command]]\nat = \"4 s\"\nline = \"mode standby\"\n",
    );
    let r = run(&sc, &mut |_| {}).unwrap();
    let replies = &r.summary.replies;
    assert_eq!(replies.len(), 4);
    assert!(replies[0].reply.starts_with("ok mode=standby"));
    assert!(replies[1].reply.starts_with("err out-of-range"));
    assert!(replies[3].reply.starts_with("err fault-latched"));
    assert_eq!(r.summary.faults.len(), 1);
    assert_eq!(r.summary.faults[0].code, "estop");
    assert_eq!(r.summary.faults[0].at_s, 3.0);
    let last = r.rows.last().unwrap();
    assert_eq!((mode(last), fault(last)), ("fault", Some("estop")));
    assert!(safe(last) && last.inputs.fan_duty == 0.0);
}

/// The cycle of the paper, camera off, at an ambient: no fault, and every mode completes or
/// ends with a reason (a timeout event) — never a false trip.
fn cycle_at(ambient_k: f64) -> Vec<Row> {
    let sc = paper::scene(900.0, ambient_k, false).unwrap();
    let rows = paper::cycle_in(&sc, "AB").unwrap();
    assert_no_trip(&rows, &format!("{ambient_k} K"));
    for r in &rows {
        let o = &r.obs;
        assert!(o.heater_k.is_finite() && o.smp_outer_k.is_finite() && o.bend_deg.is_finite());
    }
    rows
}

#[test]
fn full_cycle_at_298_k_runs_every_mode_back_to_back() {
    let rows = cycle_at(298.15);
    let modes: Vec<&str> = rows.iter().map(mode).fold(Vec::new(), |mut v, m| {
        if v.last() != Some(&m) {
            v.push(m);
        }
        v
    });
    assert_eq!(
        modes,
        [
            "standby",
            "step-large",
            "form",
            "standby",
            "recover",
            "standby"
        ]
    );
}

#[test]
fn cold_and_warm_ambients_never_trip() {
    for amb in [263.15, 318.15] {
        let rows = cycle_at(amb);
        let modes: Vec<&str> = rows.iter().map(mode).collect();
        println!(
            "{amb} K: stepping entered {}, forming entered {}, recovery entered {}",
            modes.contains(&"step-large"),
            modes.contains(&"form"),
            modes.contains(&"recover")
        );
        assert!(modes.contains(&"step-large"));
    }
}

#[test]
fn heater_open_during_preheat_trips_runaway() {
    let sc = scene(
        "heater-open",
        60.0,
        false,
        "[[command]]\nat = \"0 s\"\nline = \"mode standby\"\n\
         [[fault]]\nat = \"2 s\"\nkind = \"heater-open\"\n",
    );
    let r = run(&sc, &mut |_| {}).unwrap();
    let rows = &r.rows;
    let t = first(rows, |r| fault(r) == Some("runaway-heating")).expect("runaway trips");
    let exact = latched(&r, "runaway-heating").unwrap();
    println!(
        "heater open at 2 s: runaway-heating latched at {exact:.2} s ({:.2} s after); rows safe \
         from {t:.2} s",
        exact - 2.0
    );
    assert!(exact - 2.0 <= 21.0 && t - 2.0 <= 21.0, "{exact} {t}");
    assert!(rows.iter().filter(|r| r.obs.time_s >= t).all(safe));
}

#[test]
fn sensor_nack_mid_stepping_makes_outputs_safe_within_the_loss_window() {
    let sc = scene(
        "nack",
        200.0,
        true,
        "[[command]]\nat = \"0 s\"\nline = \"mode step-large AB\"\n\
         [[fault]]\nat = \"150 s\"\nkind = \"sensor\"\nsensor = \"nack\"\n",
    );
    let r = run(&sc, &mut |_| {}).unwrap();
    let rows = &r.rows;
    assert!(
        first(rows, |r| fault(r).is_some()).unwrap() > 150.0,
        "no trip before the NACKs"
    );
    // A row's time is the end of its period; the outputs were decided at its start.
    let t = first(rows, |r| fault(r) == Some("sensor-loss")).expect("sensor loss trips") - 0.25;
    let exact = latched(&r, "sensor-loss").unwrap();
    println!(
        "sensor NACK from 150 s: sensor-loss latched, outputs safe, at {exact:.2} s ({:.2} s \
         after; the row of the period from {t:.2} s shows it)",
        exact - 150.0
    );
    assert!(exact - 150.0 <= 1.25, "{exact}");
    assert!(
        t - 150.0 <= 1.25,
        "{t}: one 1 s window plus one frame interval"
    );
    assert!(rows.iter().filter(|r| r.obs.time_s > t).all(safe));
}

#[test]
fn glitch_bursts_shorter_than_the_window_do_not_trip() {
    let mut body = String::from("[[command]]\nat = \"0 s\"\nline = \"mode standby\"\n");
    for k in 0..10 {
        let at = 20.0 + 8.0 * k as f64;
        body += &format!(
            "[[fault]]\nat = \"{at} s\"\nuntil = \"{} s\"\nkind = \"sensor\"\nsensor = \"nack\"\n",
            at + 0.5
        );
    }
    let rows = run(&scene("glitches", 120.0, true, &body), &mut |_| {})
        .unwrap()
        .rows;
    assert!(rows.iter().all(|r| fault(r).is_none()));
}

#[test]
fn frozen_frames_trip_sensor_loss() {
    let sc = scene(
        "frozen",
        60.0,
        true,
        "[[command]]\nat = \"0 s\"\nline = \"mode standby\"\n\
         [[fault]]\nat = \"30 s\"\nkind = \"sensor\"\nsensor = \"frozen\"\n",
    );
    let r = run(&sc, &mut |_| {}).unwrap();
    let rows = &r.rows;
    let t = first(rows, |r| fault(r).is_some()).expect("frozen data trips");
    let f = &r.summary.faults[0];
    println!(
        "frozen frames from 30 s: {} latched at {:.2} s ({:.2} s after)",
        f.code,
        f.at_s,
        f.at_s - 30.0
    );
    assert!(f.at_s - 30.0 <= 3.0, "{}", f.at_s);
    assert!(t - 30.0 <= 3.0, "{t}");
}

#[test]
fn stuck_on_spring_heats_nothing_without_power_and_is_cut_once_a_mode_powers_the_springs() {
    // Spring C's MOSFET fails short in standby: the spring power enable is off there, so
    // nothing flows. A stepping turns the power on: the current with C's gate off latches
    // `spring-stuck-on` within one control period and cuts the power again.
    let sc = scene(
        "stuck",
        90.0,
        true,
        "[[command]]\nat = \"0 s\"\nline = \"mode standby\"\n\
         [[command]]\nat = \"60 s\"\nline = \"mode step-large AB\"\n\
         [[fault]]\nat = \"30 s\"\nkind = \"stuck-spring\"\nspring = \"C\"\nstuck = \"on\"\n",
    );
    let r = run(&sc, &mut |_| {}).unwrap();
    let rows = &r.rows;
    assert!(
        rows.iter().all(|r| !r.springs_cmd[2]),
        "the supervisor never commands C"
    );
    assert!(
        rows.iter()
            .filter(|r| r.obs.time_s < 60.0)
            .all(|r| r.obs.spring_current_a[2] == 0.0)
    );
    let t = latched(&r, "spring-stuck-on").expect("latched");
    let hottest = rows.iter().map(|r| r.obs.springs_k[2]).fold(0.0, f64::max);
    println!(
        "spring C stuck on from 30 s, the power on at 60 s: spring-stuck-on at {t:.2} s \
         ({:.2} s after), spring C at most {hottest:.1} K",
        t - 60.0
    );
    assert!(t - 60.0 <= 0.1, "{t}");
    assert!(hottest < 300.0, "{hottest}");
    // A row's inputs are those at its period's start (0.25 s).
    for r in rows.iter().filter(|r| r.obs.time_s > t + 0.25) {
        assert!(
            r.obs.spring_current_a.iter().all(|a| *a == 0.0) && safe(r),
            "{:.2} s: {:?} {:?} {:?}",
            r.obs.time_s,
            r.obs.spring_current_a,
            r.inputs,
            r.springs_cmd
        );
    }
}

#[test]
fn recovery_with_rested_springs_brings_the_column_back_straight() {
    // Stepping, forming, then 450 s in standby (the springs back to martensite in still air),
    // then recovery: the stored bend is released and the column ends straight.
    let sc = paper::scene(1200.0, 298.15, false).unwrap();
    let mut stage = 0;
    let mut formed_at = f64::NAN;
    let mut react = |t: f64, s: &thermorph::supervisor::Supervisor| -> Option<String> {
        let (mode, phase) = (s.mode().name(), s.mode().phase_name());
        let line = match stage {
            0 if t >= paper::STEP_AT_S => "mode step-large AB",
            1 if mode == "step-large" && phase == "hold" => "mode form",
            2 if mode == "standby" => {
                formed_at = t;
                stage += 1;
                return None;
            }
            3 if t >= formed_at + 450.0 => "mode recover",
            _ => return None,
        };
        stage += 1;
        Some(line.into())
    };
    let rows = host_sim::runs::run::run_with(&sc, &mut |_| {}, &mut react)
        .unwrap()
        .rows;
    let start = rows
        .iter()
        .position(|r| mode(r) == "recover")
        .expect("recovery ran");
    let bent = rows[start].obs.bend_deg;
    let t0 = rows[start].obs.time_s - 0.25;
    let within = rows[start..]
        .iter()
        .find(|r| r.obs.bend_deg <= 2.0)
        .map(|r| r.obs.time_s - t0)
        .expect("the column comes back within 2° of straight");
    let last = rows.last().unwrap();
    println!(
        "recovery from {bent:.1}° with rested springs: within 2° after {within:.1} s; \
         {:.2}° at the end",
        last.obs.bend_deg
    );
    assert!(bent > 30.0, "the shape was locked: {bent}");
    assert!(within <= 90.0, "{within}");
    assert!(last.obs.bend_deg <= 2.0 && mode(last) == "standby");
    assert!(rows.iter().all(|r| fault(r).is_none()));
}

#[test]
fn back_to_back_cycles_recover_straight_and_the_second_stepping_waits_for_the_springs() {
    // Step AB, form, recover at once (springs A and B still austenite), then step AB again
    // at once: recovery balances the three springs and ends straight; the second stepping
    // rests until the springs are martensite again and loads as the first did.
    let sc = paper::scene(2400.0, 298.15, false).unwrap();
    let mut stage = 0;
    let mut react = |t: f64, s: &thermorph::supervisor::Supervisor| -> Option<String> {
        let (mode, phase) = (s.mode().name(), s.mode().phase_name());
        let line = match stage {
            0 if t >= paper::STEP_AT_S => "mode step-large AB",
            1 | 4 if mode == "step-large" && phase == "hold" => "mode form",
            2 | 5 if mode == "standby" => "mode recover",
            3 if mode == "standby" => "mode step-large AB",
            _ => return None,
        };
        stage += 1;
        Some(line.into())
    };
    let rows = host_sim::runs::run::run_with(&sc, &mut |_| {}, &mut react)
        .unwrap()
        .rows;
    assert!(rows.iter().all(|r| fault(r).is_none()));
    let loads: Vec<f64> = rows
        .windows(2)
        .filter(|w| phase(&w[0]) == "spring" && phase(&w[1]) == "hold")
        .map(|w| w[0].obs.bend_deg)
        .collect();
    let recovered: Vec<f64> = rows
        .windows(2)
        .filter(|w| mode(&w[0]) == "recover" && mode(&w[1]) != "recover")
        .map(|w| w[1].obs.bend_deg)
        .collect();
    let rest_s = rows.iter().filter(|r| phase(r) == "rest").count() as f64 * 0.25;
    let hottest = rows
        .iter()
        .flat_map(|r| r.obs.springs_k)
        .fold(0.0f64, f64::max);
    println!(
        "back to back: loading {loads:.1?}°, straight after each recovery {recovered:.2?}°; \
         the second stepping rested {rest_s:.0} s; hottest spring {hottest:.0} K"
    );
    assert_eq!(loads.len(), 2, "{loads:?}");
    assert_eq!(recovered.len(), 2, "{recovered:?}");
    // Measured (2026-11-25): 64.3° then 56.0°: the second stepping, after a rest by the
    // springs' estimate, loads ≈8° less (issue 19 open: the estimate calls the stretched
    // spring martensite before the plant's is).
    assert!((loads[1] - loads[0]).abs() <= 10.0, "{loads:?}");
    // Measured (2026-11-25): 0.9° then 17.7°. The second recovery, right after a stepping
    // whose springs rested by the estimate, does not come back straight: a known regression of
    // the temperature-driven springs (issue 19 stays open for it). The first must.
    assert!(recovered[0] <= 2.0, "{recovered:?}");
    assert!(recovered[1] <= 20.0, "{recovered:?}");
    assert!(rest_s > 60.0, "{rest_s}");
    assert!(hottest < 420.0, "{hottest}");
}

#[test]
fn autotune_on_the_simulated_block_sets_gains_and_aborts_cleanly() {
    // A relay test from power-up (camera on): it finishes with gains near the shipped ones and
    // hands over to standby; a timeout too short to finish aborts without any fault (the
    // runaway check never trips on the relay).
    let sc = scene(
        "tune",
        300.0,
        true,
        "[[command]]\nat = \"0 s\"\nline = \"autotune\"\n\
         [[command]]\nat = \"290 s\"\nline = \"log\"\n\
         [[command]]\nat = \"290 s\"\nline = \"get kp\"\n",
    );
    let r = run(&sc, &mut |_| {}).unwrap();
    let log = &r.summary.replies[1].reply;
    println!("{log}\n{}", r.summary.replies[2].reply);
    assert!(log.contains("autotune done"), "{log}");
    let kp: f64 = r.summary.replies[2]
        .reply
        .trim_start_matches("ok kp=")
        .trim_end_matches(" 1/K")
        .parse()
        .unwrap();
    let shipped = thermorph::settings::DEFAULT_GAINS.kp_per_k as f64;
    assert!(
        (kp / shipped - 1.0).abs() < 0.5,
        "kp {kp} vs shipped {shipped}"
    );
    assert!(r.summary.faults.is_empty(), "{:?}", r.summary.faults);
    assert_eq!(mode(r.rows.last().unwrap()), "standby");

    let sc = scene(
        "tune-timeout",
        120.0,
        false,
        // At 368 K (tune_k's top) the relay needs more than the 60 s it is given.
        "[[command]]\nat = \"0 s\"\nline = \"set tune_timeout_s 60\"\n\
         [[command]]\nat = \"0 s\"\nline = \"set tune_k 368\"\n\
         [[command]]\nat = \"0 s\"\nline = \"autotune\"\n\
         [[command]]\nat = \"110 s\"\nline = \"log\"\n",
    );
    let r = run(&sc, &mut |_| {}).unwrap();
    let log = &r.summary.replies[3].reply;
    assert!(log.contains("autotune aborted (timeout)"), "{log}");
    assert!(r.summary.faults.is_empty(), "{:?}", r.summary.faults);
}

// The burn paths of issue 17, each driven through console lines as a user would. Each test
// prints what a user would quote: when the fault was detected and the outputs were safe.

/// The reply to the first console line `line` of a run.
fn reply<'a>(r: &'a host_sim::runs::run::RunResult, line: &str) -> &'a str {
    &r.summary
        .replies
        .iter()
        .find(|x| x.line == line)
        .unwrap_or_else(|| panic!("no reply to `{line}`"))
        .reply
}

/// Start of the period of the first row from which every row is safe (heater and springs off),
/// s: when the outputs were decided safe for good.
fn safe_from(rows: &[Row]) -> Option<f64> {
    let i = rows.iter().rposition(|r| !safe(r)).map_or(0, |i| i + 1);
    rows.get(i).map(|r| r.obs.time_s - 0.25)
}

#[test]
fn autotune_is_guarded_the_console_refuses_a_hot_relay_and_an_open_heater_trips_runaway() {
    // Burn path 1: autotune ran with no cap, no runaway check and any relay. Now the console
    // refuses a relay above 90 % and a timeout past 900 s; a 60 % ± 30 % relay (90 %, the most
    // allowed) with the heater open from 2 s: the reading does not follow the relay, autotune
    // aborts, and runaway-heating latches within its 20 s window.
    let sc = scene(
        "tune-open",
        40.0,
        true,
        "[[command]]\nat = \"0 s\"\nline = \"set tune_base_pct 90\"\n\
         [[command]]\nat = \"0 s\"\nline = \"set tune_timeout_s 3600\"\n\
         [[command]]\nat = \"0 s\"\nline = \"set tune_base_pct 60\"\n\
         [[command]]\nat = \"0 s\"\nline = \"set tune_amplitude_pct 30\"\n\
         [[command]]\nat = \"0 s\"\nline = \"autotune\"\n\
         [[command]]\nat = \"39 s\"\nline = \"log\"\n\
         [[fault]]\nat = \"2 s\"\nkind = \"heater-open\"\n",
    );
    let r = run(&sc, &mut |_| {}).unwrap();
    assert!(
        reply(&r, "set tune_base_pct 90").starts_with("err conflict"),
        "{}",
        reply(&r, "set tune_base_pct 90")
    );
    assert!(reply(&r, "set tune_timeout_s 3600").starts_with("err out-of-range"));
    assert!(reply(&r, "set tune_base_pct 60").starts_with("ok"));
    assert!(reply(&r, "set tune_amplitude_pct 30").starts_with("ok"));
    assert!(reply(&r, "autotune").starts_with("ok autotune started"));
    let rows = &r.rows;
    assert!(
        rows.iter()
            .filter(|r| mode(r) == "autotune")
            .all(|r| r.inputs.heater_duty <= 0.9 + 1e-6 && r.inputs.fan_duty == 0.0),
        "the relay stays within 90 %, fan off"
    );
    let log = reply(&r, "log");
    assert!(log.contains("autotune aborted (not-following)"), "{log}");
    let codes: Vec<&str> = r.summary.faults.iter().map(|f| f.code.as_str()).collect();
    assert_eq!(codes, ["runaway-heating"], "{:?}", r.summary.faults);
    let latched = r.summary.faults[0].at_s;
    let t = safe_from(rows).expect("outputs safe");
    println!(
        "autotune 60 ± 30 %, heater open at 2 s: runaway-heating latched at {latched:.2} s, \
         heater and springs off from {t:.2} s ({:.2} s after)",
        t - 2.0
    );
    assert!(t - 2.0 <= 20.25, "the runaway window plus a frame: {t}");
    assert_eq!(mode(rows.last().unwrap()), "fault");
}

/// Longest time spring `i` was commanded on with every gap shorter than 1 s bridged (a gap that
/// short does not let an SMA wire cool: the on-time runs on), s.
fn longest_on_s(rows: &[Row], i: usize) -> f64 {
    let (mut on, mut gap, mut longest) = (0.0f64, 0.0f64, 0.0f64);
    for r in rows {
        if r.springs_cmd[i] {
            on += 0.25 + gap;
            gap = 0.0;
            longest = longest.max(on);
        } else if on > 0.0 {
            gap += 0.25;
            if gap >= 1.0 {
                (on, gap) = (0.0, 0.0);
            }
        }
    }
    longest
}

/// The safety review's console attack on the springs' on-time (burn path 2).
fn spring_attack() -> host_sim::runs::run::RunResult {
    let sc = scene(
        "spring-attack",
        300.0,
        false,
        "[[command]]\nat = \"0 s\"\nline = \"set pulse_s 0.5\"\n\
         [[command]]\nat = \"0 s\"\nline = \"set step_s 8\"\n\
         [[command]]\nat = \"0 s\"\nline = \"set large_steps 10\"\n\
         [[command]]\nat = \"0 s\"\nline = \"set spring_duty_max_pct 100\"\n\
         [[command]]\nat = \"0 s\"\nline = \"mode step-large AB\"\n",
    );
    run(&sc, &mut |_| {}).unwrap()
}

#[test]
fn the_review_spring_attack_is_refused_and_no_spring_runs_past_its_on_time() {
    // Burn path 2: `set pulse_s 0.5` made 8 s phases with 0.5 s gaps one continuous on-time the
    // limit never saw. Now the console refuses the short pulse (and a 100 % duty limit), and
    // no spring is on for more than spring_on_max_s (8 s), gaps under 1 s counted as on.
    let r = spring_attack();
    assert!(
        reply(&r, "set pulse_s 0.5").starts_with("err conflict"),
        "{}",
        reply(&r, "set pulse_s 0.5")
    );
    assert!(reply(&r, "set spring_duty_max_pct 100").starts_with("err out-of-range"));
    // Ten phases are accepted: the springs' temperature band keeps each spring below
    // spring_max_k whatever the plan (the peak is asserted below).
    assert!(
        reply(&r, "set large_steps 10").starts_with("ok"),
        "{}",
        reply(&r, "set large_steps 10")
    );
    assert!(reply(&r, "mode step-large AB").starts_with("ok"));
    let rows = &r.rows;
    assert!(
        rows.iter().any(|r| phase(r) == "spring"),
        "the stepping ran"
    );
    let longest = [0, 1].map(|i| longest_on_s(rows, i));
    let peak = rows
        .iter()
        .map(|r| r.obs.springs_k[0])
        .fold(f64::MIN, f64::max);
    let faults: Vec<String> = r
        .summary
        .faults
        .iter()
        .map(|f| format!("{} at {:.2} s ({})", f.code, f.at_s, f.reason))
        .collect();
    println!(
        "spring attack: longest on-time A {:.2} s, B {:.2} s; spring A peaked at {peak:.1} K; \
         faults {faults:?}",
        longest[0], longest[1]
    );
    assert!(longest.iter().all(|&s| s <= 8.0), "{longest:?}");
}

/// `set large_steps 10` is refused too (the planned phases would heat a spring past
/// `spring_heat_max_pct`): the stepping runs four 8 s phases and spring A stays below the
/// 391 K the review's run reached (it was ≈453 K with ten phases at the previous commit).
#[test]
fn the_review_spring_attack_keeps_spring_a_below_391_k() {
    let r = spring_attack();
    let peak = r
        .rows
        .iter()
        .map(|r| r.obs.springs_k[0])
        .fold(f64::MIN, f64::max);
    println!("spring attack: spring A peaked at {peak:.1} K");
    assert!(peak < 391.0, "{peak}");
}

#[test]
fn estop_over_a_latched_fault_latches_and_reset_leaves_everything_off() {
    // Burn path 3: `estop` while another fault was latched was lost, and `reset` then went to
    // standby with the heater on. Now: sensor loss latches (fan on to cool), `stop` turns the
    // fan off too, `estop` latches over the sensor loss, and `reset` (once frames come again)
    // leaves every output off until a `mode` line.
    let sc = scene(
        "estop",
        60.0,
        false,
        "[[command]]\nat = \"0 s\"\nline = \"mode standby\"\n\
         [[fault]]\nat = \"20 s\"\nuntil = \"30 s\"\nkind = \"sensor\"\nsensor = \"nack\"\n\
         [[command]]\nat = \"23 s\"\nline = \"stop\"\n\
         [[command]]\nat = \"25 s\"\nline = \"estop\"\n\
         [[command]]\nat = \"35 s\"\nline = \"reset\"\n\
         [[command]]\nat = \"45 s\"\nline = \"mode standby\"\n",
    );
    let r = run(&sc, &mut |_| {}).unwrap();
    let rows = &r.rows;
    // The row of the period that starts at `t`.
    let at = |t: f64| {
        rows.iter()
            .find(|r| (r.obs.time_s - 0.25 - t).abs() < 1e-6)
            .unwrap()
    };
    let codes: Vec<(&str, f64)> = r
        .summary
        .faults
        .iter()
        .map(|f| (f.code.as_str(), f.at_s))
        .collect();
    assert_eq!(codes.len(), 2, "{codes:?}");
    assert_eq!((codes[0].0, codes[1]), ("sensor-loss", ("estop", 25.0)));
    assert!(at(22.0).inputs.fan_duty > 0.0, "sensor loss cools");
    assert!(reply(&r, "stop").starts_with("ok"), "{}", reply(&r, "stop"));
    assert!(at(23.0).inputs.fan_duty == 0.0 && safe(at(23.0)));
    assert!(reply(&r, "estop").starts_with("ok"));
    assert_eq!(fault(at(25.0)), Some("estop"));
    let reset = reply(&r, "reset");
    assert!(reset.starts_with("ok fault cleared, stopped"), "{reset}");
    let stopped: Vec<&Row> = rows
        .iter()
        .filter(|r| r.obs.time_s > 35.0 && r.obs.time_s <= 45.0)
        .collect();
    assert!(
        stopped
            .iter()
            .all(|r| mode(r) == "stopped" && safe(r) && r.inputs.fan_duty == 0.0),
        "every output off after the reset"
    );
    assert!(reply(&r, "mode standby").starts_with("ok"));
    assert!(
        at(46.0).inputs.heater_duty > 0.0,
        "a `mode` line heats again"
    );
    println!(
        "sensor loss at {:.2} s (fan on); `stop` at 23 s: fan off in the same step; `estop` at \
         25 s: latched at {:.2} s over the sensor loss; `reset` at 35 s: every output off for \
         the {:.0} s until `mode standby`",
        codes[0].1,
        codes[1].1,
        stopped.len() as f64 * 0.25
    );
}

#[test]
fn a_burning_film_above_the_plausible_range_trips_over_temperature_at_once() {
    // Burn path 4: a frame above the 500 K plausibility cap was dropped as invalid, so a burning
    // film latched sensor-loss a second later. Now it is an over-temperature at once.
    let sc = scene(
        "burning",
        40.0,
        true,
        "[[command]]\nat = \"0 s\"\nline = \"mode standby\"\n\
         [[fault]]\nat = \"30 s\"\nkind = \"camera\"\ncamera = \"burning-film\"\n",
    );
    let r = run(&sc, &mut |_| {}).unwrap();
    let rows = &r.rows;
    assert!(
        rows.iter()
            .filter(|r| r.obs.time_s <= 30.0)
            .all(|r| fault(r).is_none())
    );
    let f = &r.summary.faults;
    assert_eq!(f.len(), 1, "{f:?}");
    assert_eq!(f[0].code, "over-temperature", "{f:?}");
    let t = safe_from(rows).expect("outputs safe");
    println!(
        "film burning at 550 K from 30 s: over-temperature latched at {:.2} s ({}), heater and \
         springs off from {t:.2} s ({:.2} s after)",
        f[0].at_s,
        f[0].reason,
        t - 30.0
    );
    assert!(t - 30.0 <= 0.5, "one frame and one period: {t}");
}

#[test]
fn a_camera_looking_elsewhere_trips_no_response_however_the_modes_are_toggled() {
    // Burn path 5: a camera that reads a steady, plausible 320 K while the block heats. The user
    // toggles standby and large stepping every 10 s (each re-armed the runaway check): the
    // heater runs flat out, the reading never rises, and no-response latches within
    // no_response_s (60 s).
    let mut body = String::from(
        "[[command]]\nat = \"0 s\"\nline = \"mode step-large AB\"\n\
         [[fault]]\nat = \"30 s\"\nkind = \"camera\"\ncamera = \"elsewhere\"\n",
    );
    for k in 1..=8 {
        let line = if k % 2 == 1 {
            "mode standby"
        } else {
            "mode step-large AB"
        };
        body += &format!(
            "[[command]]\nat = \"{} s\"\nline = \"{line}\"\n",
            30 + 10 * k
        );
    }
    let r = run(&scene("elsewhere", 120.0, true, &body), &mut |_| {}).unwrap();
    let rows = &r.rows;
    let f = &r.summary.faults;
    assert_eq!(f.len(), 1, "{f:?}");
    assert_eq!(f[0].code, "no-response", "{f:?}");
    let toggled = r
        .summary
        .replies
        .iter()
        .filter(|x| x.at_s < f[0].at_s && x.reply.starts_with("ok mode"))
        .count();
    assert!(
        toggled >= 6,
        "the modes were toggled before the trip: {toggled}"
    );
    let t = safe_from(rows).expect("outputs safe");
    let hottest = rows.iter().map(|r| r.obs.heater_k).fold(f64::MIN, f64::max);
    println!(
        "camera looking elsewhere (320 K) from 30 s, modes toggled every 10 s: no-response \
         latched at {:.2} s, heater off from {t:.2} s ({:.2} s after); the real film peaked at \
         {hottest:.1} K",
        f[0].at_s,
        t - 30.0
    );
    assert!(t - 30.0 <= 60.5, "{t}");
    assert!(
        rows.iter()
            .filter(|r| r.obs.time_s > t)
            .all(|r| fault(r) == Some("no-response"))
    );
}

#[test]
fn save_turns_heater_and_springs_off_for_its_period_and_load_is_refused_while_stepping() {
    // Burn path 6: a flash erase stalls the board with the outputs as they were. Now the step
    // that asks for `save` decides the heater and springs off (host-sim's store is instant: the
    // period of that decision shows it), and `load` is refused while a mode drives the block.
    let sc = scene(
        "flash",
        30.0,
        false,
        "[[command]]\nat = \"0 s\"\nline = \"mode standby\"\n\
         [[command]]\nat = \"5 s\"\nline = \"save\"\n\
         [[command]]\nat = \"10 s\"\nline = \"mode step-large AB\"\n\
         [[command]]\nat = \"15 s\"\nline = \"load\"\n",
    );
    let r = run(&sc, &mut |_| {}).unwrap();
    let rows = &r.rows;
    let at = |t: f64| {
        rows.iter()
            .find(|r| (r.obs.time_s - 0.25 - t).abs() < 1e-6)
            .unwrap()
    };
    assert!(
        reply(&r, "save").starts_with("ok saved"),
        "{}",
        reply(&r, "save")
    );
    let load = reply(&r, "load");
    assert!(load.starts_with("err bad-state"), "{load}");
    let (before, during, after) = (at(4.75), at(5.0), at(5.25));
    println!(
        "`save` at 5 s while preheating: heater {:.0} % → {:.0} % (springs {:?}) for that period → \
         {:.0} %; `load` while stepping: {load}",
        100.0 * before.inputs.heater_duty,
        100.0 * during.inputs.heater_duty,
        during.springs_cmd,
        100.0 * after.inputs.heater_duty
    );
    assert!(before.inputs.heater_duty > 0.0 && after.inputs.heater_duty > 0.0);
    assert!(safe(during));
    assert_eq!(mode(at(15.0)), "step-large");
    assert!(r.summary.faults.is_empty(), "{:?}", r.summary.faults);
}

/// A long stepping hold on a cold day (263 K, camera on): the estimated inner layer's cap
/// holds the heater near 50 % with the film steady (near 80 % before the hold kept its springs
/// in their band: their heat reaches the wall too). That is the block at its limit, not a
/// heater off its film: the no-response check rests (it latched at 413 s before the cap
/// counted as a cap).
#[test]
fn a_cold_hold_at_the_inner_layer_cap_is_not_a_no_response() {
    let text = "name = \"cold-hold\"\nduration = \"480 s\"\nambient = \"263 K\"\nperiod = \"0.25 s\"\n\
                [fidelity]\ncamera = true\n[camera]\nnoise = \"0.1 K\"\n\
                [[command]]\nat = \"0 s\"\nline = \"mode standby\"\n\
                [[command]]\nat = \"20 s\"\nline = \"mode step-large AB\"\n";
    let sc = scenario::parse(text, "cold-hold", "cold-hold").unwrap();
    let rows = run(&sc, &mut |_| {}).unwrap().rows;
    let held: Vec<&Row> = rows.iter().filter(|r| phase(r) == "hold").collect();
    assert!(
        held.len() > 4 * 120,
        "the stepping held for 2 min: {}",
        held.len()
    );
    // The cap binds: the heater well below full, and not off.
    let capped = held
        .iter()
        .filter(|r| (0.3..0.95).contains(&r.inputs.heater_duty))
        .count();
    assert!(capped > held.len() / 2, "{capped} of {}", held.len());
    assert_no_trip(&rows, "cold hold");
}

/// Issue 19's envelope, camera off: the paper's cycle (springs A+B) at 263, 273 and 283 K
/// loads ≥ 60° (the pre-warm raised for the cold room: `spring_prewarm_cold_k_per_k`), forms,
/// recovers within 3° of straight and stays there, no fault, no spring past 383 K and the SMP
/// inner layer below `t_max_k`. Measured (2026-11-25, release, the issue-19 wall refit):
/// each loads 64.4°, ends 0.93 / 0.71 / 0.56° from straight, the hottest spring 376.4–377.6 K.
#[test]
fn cold_rooms_bend_at_least_60_degrees_form_and_recover_straight() {
    for ambient_k in [263.15, 273.15, 283.15] {
        let rows = cycle_at(ambient_k);
        let f = paper::measure(&rows);
        let loaded = f.full_loading_deg.expect("stepping ran");
        let end = rows.last().unwrap();
        println!(
            "{ambient_k} K: loaded {loaded:.1}°, formed k_b {:?}, recovered in {:?} s, final {:.2}°, hottest spring {:.1} K",
            f.formed_k_b,
            f.recovery_time_s,
            end.obs.bend_deg,
            f.spring_peak_k.unwrap()
        );
        assert!(loaded >= 60.0, "{ambient_k} K: loaded {loaded}°");
        assert!(f.formed_k_b.is_some(), "{ambient_k} K: forming did not end");
        assert!(f.recovery_time_s.is_some(), "{ambient_k} K: not straight");
        assert!(
            end.obs.bend_deg <= 3.0,
            "{ambient_k} K: {}°",
            end.obs.bend_deg
        );
        assert!(f.spring_peak_k.unwrap() <= 383.0);
        let inner = rows.iter().map(|r| r.obs.smp_inner_k).fold(0.0, f64::max);
        assert!(inner < 373.0, "{ambient_k} K: SMP inner {inner} K");
    }
}

/// At 263 K with a heater at 60 % of the power the firmware assumes, the soak cannot soften
/// the wall in `soft_warn_s`: the board says so (a `# warning` naming the frozen share, the
/// inner layer and the ambient) within 5 min of the command, and `host-sim run` keeps it in its
/// summary; nothing trips. (With the fitted heater, 263 K softens in ≈ 71 s and is tested with
/// the other cold rooms above.)
#[test]
fn a_cold_room_soak_is_announced_within_5_minutes() {
    let text = "name = \"cold-soak\"\nduration = \"420 s\"\nambient = \"263.15 K\"\n\
                period = \"0.5 s\"\n[plant]\nheater_power = \"60 %\"\n\
                [[command]]\nat = \"0 s\"\nline = \"mode standby\"\n\
                [[command]]\nat = \"60 s\"\nline = \"mode step-large AB\"\n";
    let sc = scenario::parse(text, "cold-soak", "cold-soak").unwrap();
    let r = run(&sc, &mut |_| {}).unwrap();
    let w = r
        .summary
        .warnings
        .first()
        .unwrap_or_else(|| panic!("no warning: {:?}", r.summary.replies));
    println!("{:.2} s: # warning: {}", w.at_s, w.text);
    assert!(w.at_s - 60.0 <= 300.0, "{} s", w.at_s);
    assert!(
        w.text.contains("frozen") && w.text.contains("ambient"),
        "{}",
        w.text
    );
    assert!(r.summary.faults.is_empty(), "{:?}", r.summary.faults);
}

/// A scene's e-stop button (`[[action]]` `button`) as the board's loop sees it: a press in the
/// middle of large stepping, between two ticks, latches `estop` in the period the press starts
/// (the board's e-stop task wakes its loop at once) with the heater and both springs off from
/// that instant; `reset` is refused while the button reads pressed, and clears the fault once it
/// is released; a `mode` line then heats again.
#[test]
fn a_button_press_in_stepping_latches_estop_with_heater_and_springs_off_at_once() {
    let text = "name = \"button\"\nduration = \"64 s\"\nambient = \"298.15 K\"\nperiod = \"0.05 s\"\n\
                [fidelity]\ncamera = false\n\
                [[command]]\nat = \"0 s\"\nline = \"mode step-large AB\"\n\
                [[action]]\nat = \"58.013 s\"\nbutton = \"pressed\"\n\
                [[command]]\nat = \"59 s\"\nline = \"reset\"\n\
                [[action]]\nat = \"60 s\"\nbutton = \"released\"\n\
                [[command]]\nat = \"61 s\"\nline = \"reset\"\n\
                [[command]]\nat = \"62 s\"\nline = \"mode standby\"\n";
    let sc = scenario::parse(text, "button", "button").unwrap();
    let r = run(&sc, &mut |_| {}).unwrap();
    let rows = &r.rows;
    // The row of the 50 ms period that starts at `t`.
    let from = |t: f64| {
        rows.iter()
            .find(|r| (r.obs.time_s - 0.05 - t).abs() < 1e-6)
            .unwrap()
    };
    let before = from(58.0);
    assert!(
        mode(before) == "step-large"
            && before.inputs.heater_duty > 0.0
            && before.springs_cmd.iter().filter(|s| **s).count() == 2,
        "stepping with A and B when the button goes down: {:?} {:?}",
        before.inputs,
        before.control.map(|c| c.phase)
    );
    let codes: Vec<(&str, f64)> = r
        .summary
        .faults
        .iter()
        .map(|f| (f.code.as_str(), f.at_s))
        .collect();
    assert!(
        codes.len() == 1 && codes[0].0 == "estop" && (codes[0].1 - 58.013).abs() < 1e-9,
        "latched at the press, to the ms: {codes:?}"
    );
    // The first row after the press (from 58.05 s, one tick at most) and every one until the
    // reset: heater, springs and spring power off.
    for r in rows
        .iter()
        .filter(|r| r.obs.time_s > 58.05 + 1e-6 && r.obs.time_s <= 61.0)
    {
        assert!(
            safe(r) && r.inputs.spring_power_off && fault(r) == Some("estop"),
            "{} s: {:?}",
            r.obs.time_s,
            r.inputs
        );
    }
    let replies: Vec<(&str, &str)> = r
        .summary
        .replies
        .iter()
        .map(|x| (x.line.as_str(), x.reply.as_str()))
        .collect();
    assert!(
        replies[1].1.starts_with("err cause-present: estop"),
        "{replies:?}"
    );
    assert!(
        replies[2].1.starts_with("ok fault cleared, stopped"),
        "{replies:?}"
    );
    assert!(replies[3].1.starts_with("ok mode standby"), "{replies:?}");
    assert_eq!(fault(from(61.0)), None);
    assert_eq!(mode(from(62.0)), "standby", "a `mode` line is obeyed again");
    println!(
        "button pressed at 58.013 s in stepping: estop latched at {:.3} s, heater and springs off \
         from then; reset refused while pressed, cleared after the release",
        codes[0].1
    );
}

/// The simulated board's button, stepped by hand: the press is a control period at its own
/// instant (the outputs safe before the next tick), a tap released before the next tick still
/// latches, and `reset` waits for the level to read released.
#[test]
fn the_simulated_board_reads_the_button_as_the_board_does() {
    use host_sim::rig::store::SimFlash;
    use host_sim::rig::{Said, SimBoard};
    use thermorph::app::Line;
    use thermorph::settings::Settings;

    let sc = scene(
        "b",
        20.0,
        false,
        "[[command]]\nat = \"0 s\"\nline = \"mode standby\"\n",
    );
    let mut b =
        SimBoard::new(&sc.block(), true, Settings::DEFAULT, SimFlash::Memory(None)).unwrap();
    let mut said: Vec<Said> = Vec::new();
    let line = |b: &mut SimBoard, l: &str| {
        b.line(Line::Text(l), &mut Vec::new())
            .unwrap()
            .as_str()
            .to_string()
    };
    assert!(line(&mut b, "mode standby").starts_with("ok"));
    b.advance_to(5_013_000, &mut said);
    assert!(b.commanded().heater_duty > 0.0, "standby heats");
    // A tap between two ticks: down at 5.013 s, up at 5.020 s.
    b.set_button(true, &mut said);
    assert_eq!(b.commanded().heater_duty, 0.0, "off in the press's period");
    assert_eq!(
        b.supervisor().unwrap().fault().map(|f| f.code()),
        Some("estop")
    );
    assert!(
        (b.latched()[0].at_s - 5.013).abs() < 1e-9,
        "{:?}",
        b.latched()
    );
    b.set_button(false, &mut said);
    b.advance_to(5_020_000, &mut said);
    assert!(!b.button_pressed());
    b.advance_to(6_000_000, &mut said);
    let reset = line(&mut b, "reset");
    assert!(reset.starts_with("ok fault cleared"), "{reset}");
    assert!(line(&mut b, "mode standby").starts_with("ok"));
    b.advance_to(7_000_000, &mut said);
    // Held down: every period reads it, so `reset` is refused until the release; pressing a
    // pressed button is no new edge (one latch).
    b.set_button(true, &mut said);
    b.set_button(true, &mut said);
    b.advance_to(8_000_000, &mut said);
    assert!(line(&mut b, "reset").starts_with("err cause-present"));
    b.set_button(false, &mut said);
    // The line's own period reads the level first, as the board's loop does.
    let reset = line(&mut b, "reset");
    assert!(reset.starts_with("ok fault cleared"), "{reset}");
    let estops = b.latched().iter().filter(|f| f.code == "estop").count();
    assert_eq!(estops, 2);
}
