//! Safety as invariants: random sequences of console lines (`set`, `mode`, `pause`, `resume`,
//! `autotune`, `estop`, `reset`, `stop`, `save`, `load`, `defaults`), e-stop button levels and
//! measurements (resolved, merged, fallback, stale, implausibly hot or cold, NaN) through
//! [`Supervisor::step`], against a two-node block warmed by the decided heater. After every
//! step:
//! - no spring is kept on past `spring_on_max_s` of continuous on-time (a run of on-intervals
//!   joined by gaps shorter than a clearing rest, counted here independently of the library),
//!   nor past its duty limit (the same exponential average, recomputed here): the interval
//!   that crosses a limit is the last one it runs;
//! - the heater is off whenever a fault is latched;
//! - the heater duty is never above the heater cap's for the last valid frame's film;
//! - a step that asks for a flash operation has heater and springs off;
//! - the e-stop always wins: once pressed (console or button) the fault is `estop` until a
//!   `reset` with the button released, and every output (the fan too) is off while it is;
//! - with random spring channel readings (healthy, a MOSFET conducting with its gate off, an
//!   open channel, noise, a saturated amplifier, counts beyond 12 bits, a broken divider): the
//!   spring power is never on with a fault latched (but for `reset`'s probe, with every gate
//!   and the heater off), a channel that conducts with its gate off and the power on in both
//!   samples of a period is latched in that period, and nothing panics;
//! - while a fault is latched no `set`, `load` or `defaults` relaxes a limit.
//!
//! `THERMORPH_PROPTEST_CASES` sets the number of sequences (default 256, of 600 steps each).

use proptest::prelude::*;
use thermorph::channels::{Channels, Counts, SpringSense};
use thermorph::command::parse;
use thermorph::measurement::{Measurement, Quality};
use thermorph::outputs::{Outputs, SPRINGS};
use thermorph::settings::{PARAMS, Settings};
use thermorph::supervisor::safety::ON_TIME_SLACK_MS;
use thermorph::supervisor::store::{StoreOutcome, StoreRequest};
use thermorph::supervisor::{Decision, SpringMemory, Supervisor, VALID_K};
use thermorph::units::{Kelvin, Millis};

/// One thing that happens between two steps.
#[derive(Clone, Debug)]
enum Event {
    /// A console line.
    Line(String),
    /// The e-stop button's level.
    Button(bool),
    /// A frame of this kind.
    Frame(FrameKind),
    /// No frame this period (the sensor is silent).
    Silent,
    /// The spring channels read this way this period (then a frame, as `Frame`).
    Channels(ChannelKind, FrameKind),
}

/// How the spring channels read in a period.
#[derive(Clone, Copy, Debug)]
enum ChannelKind {
    /// As the applied outputs drive them: 15 A where a gate and the power are on.
    Healthy,
    /// Channel i conducts whatever its gate (the power still gates it).
    Stuck(usize),
    /// Channel i carries nothing.
    Open(usize),
    /// Healthy with noise of this many counts on every input.
    Noisy(u16),
    /// Channel i's amplifier at full scale.
    Saturated(usize),
    /// Channel i reads beyond 12 bits.
    Garbage(usize, u16),
    /// Channel i's supply reads nothing.
    BrokenDivider(usize),
}

#[derive(Clone, Copy, Debug)]
enum FrameKind {
    Resolved,
    Merged(f32),
    Fallback(f32),
    Hot(f32),
    Cold,
    NaN,
    /// A plausible reading unrelated to the block (a camera looking elsewhere).
    Wrong(f32),
    /// The film near its cap, the SMP as the block has it.
    HotFilm(f32),
}

/// The parameters a user would play with around the limits, and some others.
const HOT_PARAMS: &[&str] = &[
    "step_s",
    "pulse_s",
    "prewarm_s",
    "prewarm_gap_s",
    "large_steps",
    "recover_on_s",
    "recover_off_s",
    "recover_pulse_s",
    "spring_on_max_s",
    "spring_duty_max_pct",
    "spring_window_s",
    "tune_base_pct",
    "tune_amplitude_pct",
    "tune_timeout_s",
    "heater_cap_k",
    "t_max_k",
    "t_heater_max_k",
    "hot_k",
    "spring_hot_k",
    "spring_max_k",
    "obs_spring_w",
    "soft_frozen_max_pct",
    "spring_rest_pct",
    "hold_timeout_s",
    "no_response_s",
    "w1_standby",
    "w1_standby",
    "w1_step",
];

fn line() -> impl Strategy<Value = String> {
    let set = (
        prop_oneof![
            prop::sample::select(HOT_PARAMS).prop_map(String::from),
            prop::sample::select(PARAMS.iter().map(|p| p.name).collect::<Vec<_>>())
                .prop_map(String::from),
        ],
        prop_oneof![0.0f32..1.2, -0.1f32..1.1],
    )
        .prop_map(|(name, f)| {
            let p = PARAMS.iter().find(|p| p.name == name).unwrap();
            // Across the range and a little past both ends.
            let v = p.min + (p.max - p.min) * f;
            let v = if p.integer { v.round() } else { v };
            format!("set {name} {v}")
        });
    let mode = prop_oneof![
        Just("mode standby".to_string()),
        Just("mode form".to_string()),
        Just("mode recover".to_string()),
        (
            prop::sample::select(vec!["step-small", "step-large"]),
            prop::sample::select(vec!["", " A", " B", " C", " AB", " ABC"])
        )
            .prop_map(|(m, s)| format!("mode {m}{s}")),
    ];
    prop_oneof![
        3 => set,
        4 => mode,
        1 => Just("pause".to_string()),
        1 => Just("resume".to_string()),
        1 => Just("autotune".to_string()),
        1 => Just("estop".to_string()),
        2 => Just("reset".to_string()),
        1 => Just("stop".to_string()),
        1 => Just("save".to_string()),
        1 => Just("load".to_string()),
        1 => Just("defaults".to_string()),
    ]
}

fn frame_kind() -> impl Strategy<Value = FrameKind> {
    prop_oneof![
        20 => Just(FrameKind::Resolved),
        2 => (0.0f32..8.0).prop_map(FrameKind::Merged),
        1 => (0.0f32..8.0).prop_map(FrameKind::Fallback),
        1 => (380.0f32..700.0).prop_map(FrameKind::Hot),
        1 => Just(FrameKind::Cold),
        1 => Just(FrameKind::NaN),
        2 => (300.0f32..360.0).prop_map(FrameKind::Wrong),
        2 => (380.0f32..402.0).prop_map(FrameKind::HotFilm),
    ]
}

fn channel_kind() -> impl Strategy<Value = ChannelKind> {
    prop_oneof![
        12 => Just(ChannelKind::Healthy),
        2 => (0usize..SPRINGS).prop_map(ChannelKind::Stuck),
        2 => (0usize..SPRINGS).prop_map(ChannelKind::Open),
        2 => (0u16..40).prop_map(ChannelKind::Noisy),
        1 => (0usize..SPRINGS).prop_map(ChannelKind::Saturated),
        1 => ((0usize..SPRINGS), 4096u16..=u16::MAX).prop_map(|(i, c)| ChannelKind::Garbage(i, c)),
        1 => (0usize..SPRINGS).prop_map(ChannelKind::BrokenDivider),
    ]
}

/// The readings of `kind` under the applied outputs `o`, with `seed` for the noise.
fn sense(kind: ChannelKind, o: &Outputs, seed: u32) -> SpringSense {
    let mut n = seed;
    let mut noise = |amp: u16| {
        n = n.wrapping_mul(1_103_515_245).wrapping_add(12_345);
        if amp == 0 {
            0i32
        } else {
            (n >> 16) as i32 % (2 * amp as i32 + 1) - amp as i32
        }
    };
    let mut sample = || {
        let mut c = Counts::default();
        for i in 0..SPRINGS {
            let gate = match kind {
                ChannelKind::Stuck(j) if j == i => true,
                ChannelKind::Open(j) if j == i => false,
                _ => o.springs.contains(i),
            };
            let on = o.spring_power && gate;
            let (a, v) = if on {
                Channels::ideal_counts(15.0, 4.35)
            } else {
                Channels::ideal_counts(0.0, 5.0)
            };
            let amp = if let ChannelKind::Noisy(x) = kind {
                x
            } else {
                0
            };
            c.current[i] = (a as i32 + noise(amp)).clamp(0, 4095) as u16;
            c.supply[i] = (v as i32 + noise(amp)).clamp(0, 4095) as u16;
            match kind {
                ChannelKind::Saturated(j) if j == i => c.current[i] = 4095,
                ChannelKind::Garbage(j, x) if j == i => c.current[i] = x,
                ChannelKind::BrokenDivider(j) if j == i => c.supply[i] = 0,
                _ => {}
            }
        }
        c
    };
    SpringSense {
        samples: [sample(), sample()],
    }
}

/// Whether `sense` shows a channel conducting clearly (≥ 2 A, four times `spring_leak_a`'s
/// default) in both samples with its gate off and the power on, under `o`.
fn conducts_with_gate_off(sense: &SpringSense, o: &Outputs) -> bool {
    let (two_a, _) = Channels::ideal_counts(2.0, 0.0);
    o.spring_power
        && (0..SPRINGS)
            .any(|i| !o.springs.contains(i) && sense.samples.iter().all(|c| c.current[i] >= two_a))
}

fn event() -> impl Strategy<Value = Event> {
    prop_oneof![
        30 => frame_kind().prop_map(Event::Frame),
        8 => (channel_kind(), frame_kind()).prop_map(|(c, f)| Event::Channels(c, f)),
        3 => Just(Event::Silent),
        4 => line().prop_map(Event::Line),
        1 => any::<bool>().prop_map(Event::Button),
    ]
}

/// Heater film and SMP wall: enough to close the loop (host-sim runs the real plant).
struct Block {
    film_k: f32,
    smp_k: f32,
}

impl Block {
    fn step(&mut self, o: &Outputs, dt: f32) {
        let p = 4.0 * o.heater.fraction();
        let fan = 0.08 * o.fan.fraction();
        let d1 = p - 0.05 * (self.film_k - self.smp_k) - (0.01 + fan) * (self.film_k - 298.0);
        let d2 = 0.02 * (self.film_k - self.smp_k) - 0.004 * (self.smp_k - 298.0);
        self.film_k += d1 * dt;
        self.smp_k += d2 * dt;
    }

    fn frame(&self, kind: FrameKind, at: Millis, seq: u32) -> Measurement {
        let (t1, t2, quality, bound) = match kind {
            FrameKind::Resolved => (self.film_k, self.smp_k, Quality::Resolved, 0.3),
            FrameKind::Merged(b) => {
                let m = 0.5 * (self.film_k + self.smp_k);
                (m, m, Quality::Merged, b)
            }
            FrameKind::Fallback(b) => (self.smp_k, self.smp_k, Quality::Fallback, b),
            FrameKind::Hot(t) => (t, self.smp_k, Quality::Resolved, 0.3),
            FrameKind::Cold => (150.0, 150.0, Quality::Resolved, 0.3),
            FrameKind::NaN => (f32::NAN, self.smp_k, Quality::Resolved, 0.3),
            FrameKind::Wrong(t) => (t + 2.0, t, Quality::Resolved, 0.3),
            FrameKind::HotFilm(t) => (t, self.smp_k, Quality::Resolved, 0.3),
        };
        Measurement {
            at,
            seq,
            regions: [t1, t2, t2, 300.0, 298.0].map(Kelvin::new),
            hottest: Kelvin::new(t1.max(t2)),
            filled_pixels: 0,
            quality,
            bound: Kelvin::new(bound).unwrap(),
            // Whatever the frame, a tilt (NaN with a NaN frame): the bend estimate takes it.
            tilt: Some(thermorph::measurement::Tilt {
                deg: 0.5 * (t1 - 300.0),
                sd_deg: 0.2,
            }),
            // Whatever the frame, a lattice exposure (NaN with a NaN frame), adopted now and
            // then: the exposure warnings and `status` take it.
            exposure: Some(thermorph::measurement::LatticeExposure {
                fitted_pct: t1 - 250.0,
                design_pct: t2 - 250.0,
                configured_pct: 71.0,
                adopted: seq.is_multiple_of(9),
                shows_pct: seq.is_multiple_of(5).then_some(t1 - 280.0),
            }),
        }
    }
}

/// The invariants' own bookkeeping, independent of the supervisor's.
struct Watch {
    /// Per spring: on-time since the last clearing rest (ms) and the current off interval (ms).
    on: [(u64, u64); SPRINGS],
    duty: [f32; SPRINGS],
    estop: bool,
    button: bool,
    /// The film of the last frame the supervisor takes as valid.
    last_valid: Option<(Millis, f32)>,
}

impl Watch {
    fn new() -> Watch {
        Watch {
            on: [(0, 0); SPRINGS],
            duty: [0.0; SPRINGS],
            estop: false,
            button: false,
            last_valid: None,
        }
    }

    /// Credit `dt_ms` of `o` (the outputs applied over that interval) with `s` in force.
    fn credit(&mut self, o: &Outputs, dt_ms: u64, s: &Settings) -> Result<(), String> {
        let a = (dt_ms as f32 * 1e-3 / s.spring_window_s).min(1.0);
        for i in 0..SPRINGS {
            let on = o.springs.contains(i);
            let (run, off) = &mut self.on[i];
            if on {
                *run += dt_ms;
                *off = 0;
            } else if *run > 0 {
                *off += dt_ms;
                // A rest clears the run only if it is ≥ 1 s and ≥ 1/8 of the run.
                if *off as f32 >= 1000f32.max(0.125 * *run as f32) {
                    *run = 0;
                    *off = 0;
                }
            }
            self.duty[i] += ((on as u8 as f32) - self.duty[i]) * a;
        }
        Ok(())
    }

    /// A spring whose on-time is past the limit is never decided on again (the interval that
    /// took it past is one control period: 50 ms on the board, up to 1.5 s here).
    fn check_springs(&self, o: &Outputs, s: &Settings) -> Result<(), String> {
        for i in 0..SPRINGS {
            let limit = (s.spring_on_max_s * 1000.0) as u64 + ON_TIME_SLACK_MS as u64;
            if o.springs.contains(i) && self.on[i].0 > limit {
                return Err(format!(
                    "spring {i} kept on at {} ms > {limit} ms",
                    self.on[i].0
                ));
            }
            // Allow the one interval that took it past the limit (it trips at the next step).
            if o.springs.contains(i) && self.duty[i] > s.spring_duty_max + 0.02 {
                return Err(format!("spring {i} on at duty {}", self.duty[i]));
            }
        }
        Ok(())
    }
}

fn check(
    sup: &Supervisor,
    d: &Decision,
    w: &Watch,
    s_before: &Settings,
    step: usize,
) -> Result<(), String> {
    let s = sup.settings();
    let o = d.outputs;
    let fault = sup.fault();
    let ctx = || format!("step {step}: {:?} {:?} {:?}", sup.mode(), fault, o);
    if fault.is_some() && o.heater.fraction() > 0.0 {
        return Err(format!("heater on with a fault latched: {}", ctx()));
    }
    if fault.is_some() && !o.springs.is_empty() {
        return Err(format!("springs on with a fault latched: {}", ctx()));
    }
    if fault.is_some() && o.spring_power && !(d.probe && o.springs.is_empty()) {
        return Err(format!("spring power on with a fault latched: {}", ctx()));
    }
    if d.store.is_some() && (o.heater.fraction() > 0.0 || !o.springs.is_empty()) {
        return Err(format!("outputs live through a flash operation: {}", ctx()));
    }
    if w.estop {
        if fault.map(|f| f.code()) != Some("estop") {
            return Err(format!("e-stop lost: {}", ctx()));
        }
        // `reset`'s probe of the spring channels (the button released) powers them with
        // every gate off for one reading.
        let probe = Outputs {
            spring_power: true,
            ..Outputs::OFF
        };
        if o != Outputs::OFF && !(d.probe && o == probe) {
            return Err(format!("an output on under the e-stop: {}", ctx()));
        }
    }
    if let Some((_, film)) = w.last_valid {
        // The cap of the settings in force before or after this step's `set`.
        let cap = |s: &Settings| ((s.heater_cap_k - film) / s.heater_cap_band_k).clamp(0.0, 1.0);
        let allowed = cap(s).max(cap(s_before)) + 1e-5;
        if o.heater.fraction() > allowed {
            return Err(format!(
                "heater {} above the cap's {allowed} (film {film}): {}",
                o.heater.fraction(),
                ctx()
            ));
        }
    }
    // The springs' temperature band: a spring is decided on only while its estimate is
    // below the band's top (of the settings before or after this step's `set`), so never
    // past `spring_max_k`.
    let e = sup.estimate();
    for i in 0..SPRINGS {
        let top = s.spring_hot_k.max(s_before.spring_hot_k);
        if o.springs.contains(i)
            && e.springs_k[i].partial_cmp(&top) != Some(core::cmp::Ordering::Less)
        {
            return Err(format!(
                "spring {i} on at an estimated {} K (band top {top} K): {}",
                e.springs_k[i],
                ctx()
            ));
        }
    }
    w.check_springs(&o, s)
        .map_err(|e| format!("{e}: {}", ctx()))
}

fn run(events: &[(Event, u16)]) -> Result<(), TestCaseError> {
    let mut sup = Supervisor::with_memory(Millis(0), Settings::DEFAULT, SpringMemory::RESTED);
    let mut block = Block {
        film_k: 298.0,
        smp_k: 298.0,
    };
    let mut w = Watch::new();
    let mut flash: Option<Vec<u8>> = None;
    let (mut now_ms, mut seq) = (0u64, 0u32);
    let mut applied = Outputs::OFF;
    for (k, (e, dt_ms)) in events.iter().enumerate() {
        let dt_ms = *dt_ms as u64;
        now_ms += dt_ms;
        let now = Millis(now_ms);
        // The interval just ended ran with the outputs applied at its start.
        block.step(&applied, dt_ms as f32 * 1e-3);
        let s_before = *sup.settings();
        w.credit(&applied, dt_ms, &s_before)
            .map_err(TestCaseError::fail)?;
        let latched_before = sup.fault().is_some();
        let mut leak = false;
        let (m, c) = match e {
            Event::Frame(kind) => {
                seq += 1;
                (Some(block.frame(*kind, now, seq)), None)
            }
            Event::Channels(kind, frame) => {
                let r = sense(*kind, &applied, seq.wrapping_add(k as u32));
                leak = conducts_with_gate_off(&r, &applied);
                sup.sense_springs(&r);
                seq += 1;
                (Some(block.frame(*frame, now, seq)), None)
            }
            Event::Silent => (None, None),
            Event::Line(l) => (None, parse(l).ok()),
            Event::Button(p) => {
                sup.button(now, *p);
                w.button = *p;
                if *p {
                    w.estop = true;
                }
                (None, None)
            }
        };
        let is_estop = matches!(e, Event::Line(l) if l == "estop");
        let is_reset = matches!(e, Event::Line(l) if l == "reset");
        let mut d = sup.step(now, m.as_ref(), c);
        if is_estop {
            w.estop = true;
        }
        let cleared = d
            .reply
            .as_ref()
            .is_some_and(|r| r.as_str().starts_with("ok fault cleared"));
        if is_reset && cleared {
            prop_assert!(
                !w.button,
                "reset cleared the e-stop with the button pressed"
            );
            w.estop = false;
        }
        if let Some(m) = m {
            let ok = |t: f32| t.is_finite() && (VALID_K.0..=VALID_K.1).contains(&t);
            let k = |t: Option<Kelvin>| t.map_or(f32::NAN, Kelvin::k);
            if ok(k(m.t1())) && ok(k(m.t2())) {
                w.last_valid = Some((m.at, k(m.hotter())));
            }
        }
        check(&sup, &d, &w, &s_before, k).map_err(TestCaseError::fail)?;
        if leak {
            prop_assert!(
                sup.fault().is_some(),
                "step {}: a channel conducted with its gate off and nothing latched",
                k
            );
        }
        let limits_kept = |after: &Settings| {
            PARAMS
                .iter()
                .find(|p| p.relaxes((p.get)(&s_before), (p.get)(after)))
                .map(|p| p.name)
        };
        if latched_before && let Some(name) = limits_kept(sup.settings()) {
            prop_assert!(false, "step {}: {} relaxed under a latched fault", k, name);
        }
        if let Some(req) = d.store.take() {
            let r = match req {
                StoreRequest::Save(rec) => {
                    flash = Some(rec.to_vec());
                    sup.finish_store(now, StoreOutcome::Saved)
                }
                StoreRequest::Load => sup.finish_store(now, StoreOutcome::Loaded(flash.as_deref())),
            };
            d.reply = Some(r);
        }
        if latched_before && let Some(name) = limits_kept(sup.settings()) {
            prop_assert!(false, "step {}: {} relaxed by a load", k, name);
        }
        if w.estop {
            prop_assert_eq!(sup.fault().map(|f| f.code()), Some("estop"));
        }
        applied = sup.outputs();
        prop_assert_eq!(applied, d.outputs);
        if d.probe {
            // `reset`'s probe: a healthy channel set, or the stuck one again.
            let kind = if k.is_multiple_of(2) {
                ChannelKind::Healthy
            } else {
                ChannelKind::Stuck(k % SPRINGS)
            };
            let r = sup.finish_probe(now, &sense(kind, &d.outputs, k as u32));
            let after = sup.outputs();
            prop_assert!(
                r.as_str().starts_with("ok") || r.as_str().starts_with("err cause-present")
            );
            prop_assert!(!after.spring_power && after.heater.fraction() == 0.0);
            if w.estop && r.as_str().starts_with("ok fault cleared") {
                prop_assert!(!w.button);
                w.estop = false;
            }
            applied = after;
        }
    }
    Ok(())
}

fn cases() -> u32 {
    std::env::var("THERMORPH_PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(256)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), ..ProptestConfig::default() })]

    #[test]
    fn no_sequence_defeats_a_limit(
        events in prop::collection::vec((event(), prop_oneof![8 => Just(250u16), 1 => 1u16..1500]), 600)
    ) {
        run(&events)?;
    }
}

/// The invariants' bookkeeping catches what it should: a spring driven 0.5 s off between 8 s
/// phases (the safety review's sequence, applied blind) fails the on-time check.
#[test]
fn the_watch_itself_catches_short_gaps() {
    let s = Settings::DEFAULT;
    let mut w = Watch::new();
    let on = Outputs {
        springs: thermorph::outputs::SpringMask::from_bits(1),
        ..Outputs::OFF
    };
    let mut failed = false;
    for _ in 0..3 {
        for _ in 0..32 {
            w.credit(&on, 250, &s).unwrap();
            failed |= w.check_springs(&on, &s).is_err();
        }
        for _ in 0..2 {
            w.credit(&Outputs::OFF, 250, &s).unwrap();
        }
    }
    assert!(failed);
}
