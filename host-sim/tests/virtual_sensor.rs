//! The firmware's MLX90640 driver and sensing pipeline against the virtual sensor: round trips,
//! configuration, timing, every injectable fault, bus recovery and a power-cycled sensor.

use embassy_futures::block_on;
use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource};
use host_sim::sensor::demo::{Rig, round_trip};
use host_sim::sensor::sim_time::{SimClock, SimDelay};
use host_sim::sensor::virtual_mlx::{HeapBuffers, SensorFault, VirtualBus};
use thermorph::measurement::Measurement;
use thermorph::mlx90640::calc::FrameError;
use thermorph::mlx90640::{
    Config, DecodeParams, Error, ReadingPattern, RefreshRate, Resolution, SubpageFrame,
};
use thermorph::sensing::{Outcome, Pipeline, PipelineConfig, SensingError, Sensor};

fn rig(config: Config) -> Rig {
    Rig::realistic(7, config).unwrap()
}

type TestSensor = Sensor<VirtualBus, SimDelay, SimClock, HeapBuffers>;

/// The library's sensing pipeline on the rig's bus (it sets the sensor up itself).
fn sensor(r: &Rig) -> TestSensor {
    r.bus.0.borrow_mut().field_k = host_sim::sensor::demo::demo_scene();
    Sensor::new(
        r.bus.clone(),
        SimDelay::new(r.clock.clone()),
        r.clock.clone(),
        thermorph::mlx90640::ADDRESS,
        Pipeline::new(PipelineConfig::default()).unwrap(),
        HeapBuffers::new(),
    )
}

/// Step the sensor for `us` of simulated time; return the frames and the errors (with the
/// time they came, µs).
fn run_for(s: &mut TestSensor, r: &Rig, us: u64) -> (Vec<Measurement>, Vec<(u64, SensingError)>) {
    let end = r.clock.now_us() + us;
    let (mut frames, mut errors) = (Vec::new(), Vec::new());
    while r.clock.now_us() < end {
        match block_on(s.step()) {
            Outcome::Frame(m) => frames.push(m),
            Outcome::Error(e) => errors.push((r.clock.now_us(), e)),
            _ => {}
        }
    }
    (frames, errors)
}

/// Step the sensor until `n` frames came or `us` of simulated time passed.
fn run_until_frames(s: &mut TestSensor, r: &Rig, n: usize, us: u64) -> Vec<Measurement> {
    let end = r.clock.now_us() + us;
    let mut frames = Vec::new();
    while frames.len() < n && r.clock.now_us() < end {
        if let Outcome::Frame(m) = block_on(s.step()) {
            frames.push(m);
        }
    }
    frames
}

#[test]
fn round_trip_within_0_1_k_at_18_bit() {
    let e = round_trip(
        3,
        Resolution::Bits18,
        ReadingPattern::Chess,
        10,
        263.0,
        573.0,
    )
    .unwrap();
    eprintln!("18 bit round trip max error {e:.4} K");
    assert!(e <= 0.1, "18-bit round trip error {e} K");
    // Finer ADC, smaller steps.
    let e19 = round_trip(
        3,
        Resolution::Bits19,
        ReadingPattern::Chess,
        10,
        263.0,
        573.0,
    )
    .unwrap();
    assert!(e19 < e, "19 bit ({e19}) must beat 18 bit ({e})");
    assert!(e19 <= 0.05, "19-bit round trip error {e19} K");
}

#[test]
fn round_trip_interleaved_and_other_seeds() {
    for seed in [11, 12] {
        let e = round_trip(
            seed,
            Resolution::Bits18,
            ReadingPattern::Chess,
            4,
            263.0,
            573.0,
        )
        .unwrap();
        assert!(e <= 0.1, "seed {seed}: {e} K");
    }
    let e = round_trip(
        5,
        Resolution::Bits18,
        ReadingPattern::Interleaved,
        4,
        263.0,
        573.0,
    )
    .unwrap();
    assert!(e <= 0.1, "interleaved: {e} K");
}

#[test]
fn configure_sets_the_device_and_timing_follows_the_rate() {
    for (rate, res) in [
        (RefreshRate::Hz0_5, Resolution::Bits16),
        (RefreshRate::Hz8, Resolution::Bits18),
        (RefreshRate::Hz16, Resolution::Bits19),
    ] {
        let config = Config {
            refresh: rate,
            resolution: res,
            pattern: ReadingPattern::Chess,
        };
        let mut r = rig(config);
        let ctrl = r.bus.0.borrow().control();
        assert_eq!(
            (ctrl.refresh_rate(), ctrl.resolution(), ctrl.pattern()),
            (rate, res, ReadingPattern::Chess)
        );
        let params = DecodeParams::default();
        r.step(&params).unwrap();
        let t0 = r.clock.now_us();
        let mut subpages = Vec::new();
        for _ in 0..4 {
            subpages.push(r.step(&params).unwrap());
        }
        let per = (r.clock.now_us() - t0) as f64 / 4.0;
        let period = rate.period_us() as f64;
        assert!(
            (per - period).abs() < 0.1 * period,
            "{rate:?}: {per} µs per subpage, expected {period}"
        );
        assert!(
            subpages.windows(2).all(|w| w[0] != w[1]),
            "subpages alternate"
        );
    }
    // Above 16 Hz a 400 kHz bus cannot keep pace (SPEC section 2): the sensor overwrites each
    // subpage while the driver reads it (≈ 40 ms against 15.6 ms), and the driver refuses it.
    let mut r = rig(Config {
        refresh: RefreshRate::Hz64,
        ..Config::default()
    });
    assert_eq!(r.bus.0.borrow().control().refresh_rate(), RefreshRate::Hz64);
    for _ in 0..6 {
        assert!(matches!(
            r.step(&DecodeParams::default()),
            Err(Error::Overwritten { .. })
        ));
    }
}

#[test]
fn a_subpage_overwritten_during_its_read_is_refused() {
    // 32 Hz: a subpage every 31.25 ms, a read takes ≈ 40 ms — always torn.
    let mut r = rig(Config {
        refresh: RefreshRate::Hz32,
        ..Config::default()
    });
    let e = r.step(&DecodeParams::default()).unwrap_err();
    assert!(matches!(e, Error::Overwritten { .. }), "{e:?}");
    // At 16 Hz (62.5 ms) the read fits between two measurements: never refused.
    let mut r = rig(Config {
        refresh: RefreshRate::Hz16,
        ..Config::default()
    });
    for _ in 0..8 {
        r.step(&DecodeParams::default()).unwrap();
    }
}

#[test]
fn a_power_cycled_sensor_is_reported_and_configured_again() {
    let mut r = rig(Config::default());
    let params = DecodeParams::default();
    r.step(&params).unwrap();
    r.bus.0.borrow_mut().power_cycle();
    assert_eq!(r.bus.0.borrow().control().refresh_rate(), RefreshRate::Hz2);
    // Waiting for 8 Hz data from a 2 Hz sensor times out, and the control register shows why;
    // a 2 Hz subpage that does come carries the wrong control register.
    let e = r.step(&params).unwrap_err();
    assert!(
        matches!(e, Error::ControlReset { read } if read == 0x1901),
        "{e:?}"
    );
    // The pipeline sets it up again and frames follow.
    let mut s = sensor(&r);
    r.bus.0.borrow_mut().power_cycle();
    let frames = run_until_frames(&mut s, &r, 2, 5_000_000);
    assert_eq!(frames.len(), 2);
    assert_eq!(r.bus.0.borrow().control().refresh_rate(), RefreshRate::Hz8);
}

#[test]
fn nack_is_a_typed_error_and_recovers() {
    let mut r = rig(Config::default());
    let params = DecodeParams::default();
    r.step(&params).unwrap();
    r.bus.0.borrow_mut().set_fault(Some(SensorFault::Nack));
    let e = r.step(&params).unwrap_err();
    assert_eq!(
        e,
        Error::Bus {
            register: 0x8000,
            kind: ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address)
        }
    );
    let mut cal = thermorph::mlx90640::Calibration::new();
    assert!(matches!(
        block_on(r.driver.calibrate(&mut cal)),
        Err(Error::Bus { .. })
    ));
    r.bus.0.borrow_mut().set_fault(None);
    r.step(&params).unwrap();
}

#[test]
fn bus_timeout_is_a_typed_error() {
    let mut r = rig(Config::default());
    let params = DecodeParams::default();
    r.bus
        .0
        .borrow_mut()
        .set_fault(Some(SensorFault::BusTimeout));
    let t0 = r.clock.now_us();
    assert_eq!(
        r.step(&params).unwrap_err(),
        Error::Timeout { register: 0x8000 }
    );
    let waited = r.clock.now_us() - t0;
    assert_eq!(waited, thermorph::mlx90640::driver::BUS_TIMEOUT_US as u64);
    r.bus.0.borrow_mut().set_fault(None);
    r.step(&params).unwrap();
}

#[test]
fn stuck_sensor_is_stale_after_two_periods() {
    let mut r = rig(Config::default());
    let params = DecodeParams::default();
    r.step(&params).unwrap();
    r.bus.0.borrow_mut().set_fault(Some(SensorFault::Stuck));
    let t0 = r.clock.now_us();
    // The subpage measured just before the fault may still be pending; after it, stale.
    let e = match r.step(&params) {
        Ok(_) => r.step(&params).unwrap_err(),
        Err(e) => e,
    };
    assert!(
        matches!(e, Error::Stale { waited_ms } if waited_ms >= 250),
        "{e:?}"
    );
    let elapsed = r.clock.now_us() - t0;
    assert!(
        elapsed < 4 * RefreshRate::Hz8.period_us() as u64,
        "gave up in bounded time"
    );
    r.bus.0.borrow_mut().set_fault(None);
    r.step(&params).unwrap();
}

#[test]
fn corrupt_words_are_rejected() {
    let mut r = rig(Config::default());
    let params = DecodeParams::default();
    r.step(&params).unwrap();
    r.bus.0.borrow_mut().set_fault(Some(SensorFault::Corrupt));
    let mut got = None;
    for _ in 0..3 {
        if let Err(e) = r.step(&params) {
            got = Some(e);
            break;
        }
    }
    assert!(
        matches!(got, Some(Error::Frame(FrameError::InvalidMarker { .. }))),
        "{got:?}"
    );
}

#[test]
fn frozen_frame_is_rejected() {
    let r = rig(Config::default());
    let mut s = sensor(&r);
    assert_eq!(run_until_frames(&mut s, &r, 2, 2_000_000).len(), 2);
    r.bus.0.borrow_mut().set_fault(Some(SensorFault::Frozen));
    let t0 = r.clock.now_us();
    let (frames, errors) = run_for(&mut s, &r, 1_000_000);
    // At most the frame whose subpages were measured before the fault.
    assert!(frames.len() <= 1, "{frames:?}");
    let first = errors.first().map(|(t, e)| (*t - t0, *e));
    assert!(
        matches!(first, Some((dt, SensingError::Frozen { .. })) if dt < 500_000),
        "{first:?}"
    );
    r.bus.0.borrow_mut().set_fault(None);
    assert_eq!(run_until_frames(&mut s, &r, 1, 2_000_000).len(), 1);
}

#[test]
fn a_bus_stuck_low_is_recovered_and_frames_come_again() {
    let r = rig(Config::default());
    let mut s = sensor(&r);
    assert_eq!(run_until_frames(&mut s, &r, 2, 2_000_000).len(), 2);
    r.bus
        .0
        .borrow_mut()
        .set_fault(Some(SensorFault::BusStuckLow));
    let t0 = r.clock.now_us();
    // One timeout, then the recovery frees the bus: a pause, a setup, and frames again.
    let got = run_until_frames(&mut s, &r, 2, 2_000_000);
    assert_eq!(got.len(), 2, "frames again after the recovery");
    assert_eq!(r.bus.0.borrow().recoveries(), 1);
    assert_eq!(r.bus.0.borrow().fault(), None);
    let back_us = got[0].at.ms() * 1000 - t0;
    eprintln!("bus stuck low: first frame again {back_us} µs later");
    assert!(
        back_us < 1_000_000,
        "first frame {back_us} µs after the bus stuck (inside the 1 s loss window)"
    );
    // Without the recovery the bus stays stuck: every transfer times out.
    r.bus
        .0
        .borrow_mut()
        .set_fault(Some(SensorFault::BusStuckLow));
    let mut frame = SubpageFrame::new();
    assert!(matches!(
        block_on(s.driver().read_subpage(&mut frame)),
        Err(Error::Timeout { .. })
    ));
    assert!(matches!(
        block_on(s.driver().read_subpage(&mut frame)),
        Err(Error::Timeout { .. })
    ));
}

#[test]
fn nack_and_timeout_recover_the_bus_then_set_up_again() {
    for fault in [SensorFault::Nack, SensorFault::BusTimeout] {
        let r = rig(Config::default());
        let mut s = sensor(&r);
        assert_eq!(run_until_frames(&mut s, &r, 1, 2_000_000).len(), 1);
        r.bus.0.borrow_mut().set_fault(Some(fault));
        let (frames, errors) = run_for(&mut s, &r, 1_000_000);
        assert!(frames.len() <= 1);
        assert!(!errors.is_empty());
        assert!(
            errors
                .iter()
                .all(|(_, e)| matches!(e, SensingError::I2c(_))),
            "{errors:?}"
        );
        // A recovery after every I2C error (the last may still be in its pause), a pause
        // between attempts: a bounded rate.
        let recoveries = r.bus.0.borrow().recoveries();
        let n = errors.len() as u64;
        assert!(
            recoveries == n || recoveries + 1 == n,
            "{fault:?}: {recoveries} for {n}"
        );
        assert!(recoveries <= 6, "{fault:?}: {recoveries} recoveries in 1 s");
        r.bus.0.borrow_mut().set_fault(None);
        assert_eq!(run_until_frames(&mut s, &r, 1, 2_000_000).len(), 1);
    }
}

#[test]
fn image_errors_leave_the_image_unchanged() {
    let mut r = rig(Config::default());
    let params = DecodeParams::default();
    r.step(&params).unwrap();
    r.step(&params).unwrap();
    let before = r.image.to_k;
    let mut frame = SubpageFrame::new();
    block_on(r.driver.read_subpage(&mut frame)).unwrap();
    let bad = DecodeParams {
        emissivity: 0.0,
        ..params
    };
    assert_eq!(
        r.image.update(&frame, &r.cal, &bad).unwrap_err(),
        FrameError::BadEmissivity
    );
    frame.words[thermorph::mlx90640::calc::IDX_GAIN] = 0;
    assert_eq!(
        r.image.update(&frame, &r.cal, &params).unwrap_err(),
        FrameError::ZeroGain
    );
    assert_eq!(r.image.to_k.map(f32::to_bits), before.map(f32::to_bits));
}

#[test]
fn driver_reads_a_real_eeprom_over_the_bus() {
    let Some(dir) =
        host_sim::imaging::data::require_mlx90640_dir("driver_reads_a_real_eeprom_over_the_bus")
    else {
        return;
    };
    let words =
        host_sim::imaging::dump::read_eeprom(&dir.join("melexis_example_eeprom.hex")).unwrap();
    let r = Rig::new(words, 1, Config::default()).unwrap();
    let direct = thermorph::mlx90640::Calibration::from_eeprom(&words).unwrap();
    assert_eq!(*r.cal, direct);
}

/// The camera chain's round trip: the view `host-sim run` renders (springs, a 4×4 subgrid,
/// the tilts of a bending column, standby to a burning film), encoded by the virtual sensor's
/// fast encoder and decoded by the firmware's calculation, is within 0.1 K of the rendered
/// truth at every pixel (noise off: what is left is the ADC's rounding).
#[test]
fn camera_view_round_trip_within_0_1_k() {
    use host_sim::imaging::view::{Geometry, Layout, Temps};
    use host_sim::sensor::virtual_mlx::VirtualMlx90640;
    use thermorph::mlx90640::{Calibration, Control, Image, PIXELS};

    let eeprom = host_sim::sensor::eeprom::realistic(1).encode().unwrap();
    let cal = Calibration::from_eeprom(&eeprom).unwrap();
    let mut dev = VirtualMlx90640::new(eeprom, SimClock::new(), 1).unwrap();
    dev.set_control(Control(0).with(RefreshRate::Hz8, Resolution::Bits18, ReadingPattern::Chess));
    dev.noise_k = 0.0;
    let params = DecodeParams::default();
    let mut worst = 0f64;
    for (tilt_deg, heater_k, surface_k) in [
        (0.0, 328.0, 323.0),
        (7.5, 372.0, 358.0),
        (-16.0, 318.0, 336.0),
        (31.0, 550.0, 352.0),
    ] {
        let geometry = Geometry {
            tilt_deg,
            springs: true,
            ..Geometry::default()
        };
        let temps = Temps {
            spring_k: 341.0,
            ..Temps::from_surfaces(298.15, heater_k, surface_k, 0.0)
        };
        let mut view = [0f64; PIXELS];
        Layout::new(&geometry, 4).image(&temps, &mut view);
        dev.field_k = view.map(|k| k as f32);
        let mut image = Image::new();
        for sp in [0, 1] {
            image.update(&dev.raw_subpage(sp), &cal, &params).unwrap();
        }
        for (got, want) in image.to_k.iter().zip(dev.field_k.iter()) {
            worst = worst.max((*got as f64 - *want as f64).abs());
        }
    }
    eprintln!("camera view round trip max error {worst:.4} K");
    assert!(worst <= 0.1, "round trip error {worst} K");
}
