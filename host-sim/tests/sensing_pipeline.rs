//! The library's sensing state machine stepped by hand with real subpages from the virtual
//! sensor: which subpages form a frame (pairing, gaps, repeated parity, errors between),
//! frozen data, the supervisor's hint, too many broken pixels and implausible frames.

use host_sim::sensor::demo::demo_scene;
use host_sim::sensor::eeprom;
use host_sim::sensor::sim_time::SimClock;
use host_sim::sensor::virtual_mlx::VirtualMlx90640;
use thermorph::measurement::{Measurement, Quality, SensingHint, controlled_temperature};
use thermorph::mlx90640::{
    Control, Error as DriverError, PIXELS, ReadingPattern, RefreshRate, Resolution, SubpageFrame,
};
use thermorph::mtts::{Prior, Weights};
use thermorph::sensing::{
    Buffers, Discard, Implausible, Outcome, Pipeline, PipelineConfig, SensingError,
};
use thermorph::units::{Millis, k_or_nan};

/// A virtual sensor at 8 Hz, 18 bit, chess looking at the demo scene, and a set-up pipeline
/// with the sensor's calibration.
struct Bench {
    dev: VirtualMlx90640,
    p: Pipeline,
    bufs: Box<Buffers>,
}

impl Bench {
    fn new() -> Self {
        let words = eeprom::realistic(3).encode().unwrap();
        let mut dev = VirtualMlx90640::new(words, SimClock::new(), 9).unwrap();
        dev.set_control(Control(0).with(
            RefreshRate::Hz8,
            Resolution::Bits18,
            ReadingPattern::Chess,
        ));
        dev.field_k = demo_scene();
        let mut bufs = Box::new(Buffers::new());
        bufs.cal = dev.calibration().clone();
        let mut p = Pipeline::new(PipelineConfig::default()).unwrap();
        assert_eq!(p.on_setup(Ok(())), Outcome::Ready);
        Bench { dev, p, bufs }
    }

    /// A fresh measurement of subpage `sp` (new noise each time).
    fn frame(&mut self, sp: u8) -> SubpageFrame {
        self.dev.raw_subpage(sp)
    }

    /// Feed `frame` as read at `at_ms`.
    fn feed(&mut self, at_ms: u64, frame: &SubpageFrame) -> Outcome {
        let Buffers {
            cal,
            image,
            scratch,
            ..
        } = &mut *self.bufs;
        self.p.on_subpage(Millis(at_ms), frame, cal, image, scratch)
    }

    /// Feed a fresh subpage `sp` at `at_ms`.
    fn sub(&mut self, at_ms: u64, sp: u8) -> Outcome {
        let f = self.frame(sp);
        self.feed(at_ms, &f)
    }
}

fn frame_of(o: Outcome) -> Measurement {
    match o {
        Outcome::Frame(m) => m,
        other => panic!("expected a frame, got {other:?}"),
    }
}

#[test]
fn a_subpage_0_then_1_within_one_and_a_half_periods_is_a_frame() {
    let mut b = Bench::new();
    assert_eq!(b.sub(1000, 0), Outcome::Half);
    let m = frame_of(b.sub(1125, 1));
    assert_eq!((m.at, m.seq), (Millis(1125), 0));
    // The demo scene: a 323 K cylinder with 338 K stripes on 298 K. Resolved, T1 is the
    // stripes; merged, the bound covers both targets around the mean both carry.
    match m.quality {
        Quality::Resolved => assert!((k_or_nan(m.t1()) - 338.0).abs() < 2.0, "{m:?}"),
        _ => assert!(
            k_or_nan(m.hotter()) >= 336.0 && k_or_nan(m.colder()) <= 325.0,
            "{m:?}"
        ),
    }
    assert!(k_or_nan(m.regions[4]) < 305.0, "{m:?}");
    // 188 ms apart is still on time (1.5 periods of 125 ms, rounded up), 189 is not.
    assert_eq!(b.sub(1250, 0), Outcome::Half);
    assert_eq!(frame_of(b.sub(1438, 1)).seq, 1);
    assert_eq!(b.sub(1500, 0), Outcome::Half);
    assert_eq!(b.sub(1689, 1), Outcome::Discarded(Discard::Unpaired));
    assert_eq!(b.p.frames(), 2);
}

#[test]
fn a_frame_never_spans_a_gap_an_error_or_a_repeated_parity() {
    let mut b = Bench::new();
    // Starting on subpage 1: nothing to pair with.
    assert_eq!(b.sub(0, 1), Outcome::Discarded(Discard::Unpaired));
    // 0, 0, 1: the second 0 replaces the first (a 1 was missed between them).
    assert_eq!(b.sub(125, 0), Outcome::Half);
    assert_eq!(b.sub(250, 0), Outcome::Half);
    assert_eq!(frame_of(b.sub(375, 1)).at, Millis(375));
    // 0, 1, 1: the second 1 has no 0 just before it.
    assert_eq!(b.sub(500, 0), Outcome::Half);
    frame_of(b.sub(625, 1));
    assert_eq!(b.sub(750, 1), Outcome::Discarded(Discard::Unpaired));
    // An error between 0 and 1.
    assert_eq!(b.sub(875, 0), Outcome::Half);
    assert!(matches!(
        b.p.on_read_error(DriverError::Stale { waited_ms: 250 }),
        Outcome::Error(SensingError::Stale { .. })
    ));
    b.p.on_setup(Ok(()));
    assert_eq!(b.sub(1000, 1), Outcome::Discarded(Discard::Unpaired));
    // An overwritten subpage between 0 and 1.
    assert_eq!(b.sub(1125, 0), Outcome::Half);
    assert_eq!(
        b.p.on_read_error(DriverError::Overwritten { subpage: 1 }),
        Outcome::Discarded(Discard::Overwritten)
    );
    assert_eq!(b.sub(1375, 1), Outcome::Discarded(Discard::Unpaired));
    // A setup between 0 and 1 (the sensor was configured again).
    assert_eq!(b.sub(1500, 0), Outcome::Half);
    b.p.on_setup(Ok(()));
    assert_eq!(b.sub(1625, 1), Outcome::Discarded(Discard::Unpaired));
    // And frames come again.
    assert_eq!(b.sub(1750, 0), Outcome::Half);
    let m = frame_of(b.sub(1875, 1));
    assert_eq!(m.seq, 2, "seq counts published frames only");
}

#[test]
fn a_repeated_subpage_is_frozen_data() {
    let mut b = Bench::new();
    let f0 = b.frame(0);
    assert_eq!(b.feed(0, &f0), Outcome::Half);
    frame_of(b.sub(125, 1));
    assert_eq!(
        b.feed(250, &f0),
        Outcome::Error(SensingError::Frozen { subpage: 0 })
    );
    assert!(!b.p.is_ready(), "a frozen sensor is set up again");
    b.p.on_setup(Ok(()));
    // One changed word is a live sensor.
    let mut g0 = f0.clone();
    g0.words[100] ^= 1;
    assert_eq!(b.feed(375, &g0), Outcome::Half);
    frame_of(b.sub(500, 1));
}

#[test]
fn the_hint_sets_the_weights_of_tc() {
    let mut b = Bench::new();
    for (w1, w2) in [(1.0, 0.0), (0.0, 1.0), (0.3, 0.7)] {
        b.p.set_hint(SensingHint {
            prior: Prior::HeaterHotter,
            weights: Weights::new(w1, w2).unwrap(),
        });
        assert_eq!(b.sub(0, 0), Outcome::Half);
        let m = frame_of(b.sub(125, 1));
        // Tc weighs the pair ranked as the prior expects (T1* the hotter, with a merged
        // frame's bound counted against the loop). The measurement carries no Tc: it is
        // computed from the frame under the hint in force.
        let want = w1 * k_or_nan(m.hotter()) + w2 * k_or_nan(m.colder());
        assert_eq!(b.p.hint().weights, Weights::new(w1, w2).unwrap());
        let tc = k_or_nan(controlled_temperature(&m, &b.p.hint()));
        assert!((tc - want).abs() < 1e-3, "{m:?}");
    }
    assert_eq!(b.p.hint().prior, Prior::HeaterHotter);
}

#[test]
fn too_many_broken_pixels_and_implausible_frames_are_errors() {
    let mut b = Bench::new();
    // 40 pixels far below anything plausible (the encoder saturates them).
    let mut field = demo_scene();
    for t in field.iter_mut().step_by(PIXELS / 40).take(40) {
        *t = 20.0;
    }
    b.dev.field_k = field;
    assert_eq!(b.sub(0, 0), Outcome::Half);
    let o = b.sub(125, 1);
    assert!(
        matches!(o, Outcome::Error(SensingError::TooManyFilled { filled, limit })
            if limit == thermorph::mtts::DEFAULT_MAX_FILLED && filled >= 39),
        "{o:?}"
    );
    assert!(b.p.is_ready(), "the sensor works: no new setup");
    // Every pixel implausible.
    b.dev.field_k = [20.0; PIXELS];
    assert_eq!(b.sub(250, 0), Outcome::Half);
    let o = b.sub(375, 1);
    assert!(
        matches!(
            o,
            Outcome::Error(SensingError::Implausible(Implausible::Mtts(_)))
        ),
        "{o:?}"
    );
    // A subpage whose Ta decodes out of range.
    b.dev.field_k = demo_scene();
    let mut f = b.frame(0);
    f.words[thermorph::mlx90640::calc::IDX_VDD] = 0x7000;
    assert!(
        matches!(
            b.feed(500, &f),
            Outcome::Error(SensingError::Implausible(Implausible::Frame(_)))
        ),
        "{f:?}"
    );
    assert_eq!(b.sub(625, 0), Outcome::Half);
    frame_of(b.sub(750, 1));
}
