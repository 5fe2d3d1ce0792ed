//! The firmware's MLX90640 driver against the virtual sensor: round trips, configuration,
//! timing and every injectable fault.

use embassy_futures::block_on;
use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource};
use host_sim::sensor_demo::{Rig, round_trip};
use host_sim::virtual_mlx::Fault;
use thermorph::mlx90640::calc::FrameError;
use thermorph::mlx90640::{
    Config, DecodeParams, Error, ReadingPattern, RefreshRate, Resolution, SubpageFrame,
};

fn rig(config: Config) -> Rig {
    Rig::realistic(7, config).unwrap()
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
    // Above 16 Hz a 400 kHz bus cannot keep pace (SPEC section 2): subpages are still read,
    // just not every one.
    let mut r = rig(Config {
        refresh: RefreshRate::Hz64,
        ..Config::default()
    });
    assert_eq!(r.bus.0.borrow().control().refresh_rate(), RefreshRate::Hz64);
    for _ in 0..6 {
        r.step(&DecodeParams::default()).unwrap();
    }
}

#[test]
fn nack_is_a_typed_error_and_recovers() {
    let mut r = rig(Config::default());
    let params = DecodeParams::default();
    r.step(&params).unwrap();
    r.bus.0.borrow_mut().set_fault(Some(Fault::Nack));
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
    r.bus.0.borrow_mut().set_fault(Some(Fault::BusTimeout));
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
    r.bus.0.borrow_mut().set_fault(Some(Fault::Stuck));
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
    r.bus.0.borrow_mut().set_fault(Some(Fault::Corrupt));
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
    let mut r = rig(Config::default());
    let params = DecodeParams::default();
    r.step(&params).unwrap();
    r.step(&params).unwrap();
    r.bus.0.borrow_mut().set_fault(Some(Fault::Frozen));
    let mut got = None;
    for _ in 0..4 {
        if let Err(e) = r.step(&params) {
            got = Some(e);
            break;
        }
    }
    assert!(matches!(got, Some(Error::FrozenFrame { .. })), "{got:?}");
    r.bus.0.borrow_mut().set_fault(None);
    r.step(&params).unwrap();
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
    let Some(dir) = host_sim::data::require_mlx90640_dir("driver_reads_a_real_eeprom_over_the_bus")
    else {
        return;
    };
    let words = host_sim::dump::read_eeprom(&dir.join("melexis_example_eeprom.hex")).unwrap();
    let r = Rig::new(words, 1, Config::default()).unwrap();
    let direct = thermorph::mlx90640::Calibration::from_eeprom(&words).unwrap();
    assert_eq!(*r.cal, direct);
}
