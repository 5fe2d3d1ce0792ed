//! The sensor chain end to end in simulation: a virtual MLX90640 read by the firmware's driver.
//!
//! [`Rig`] wires a [`VirtualMlx90640`] to a [`Mlx90640`] driver on the simulated bus and clock;
//! [`round_trip`] measures decode(encode(T)) against T; [`run`] is `host-sim sensor`, the
//! sensor chain alone: it shows a fixed scene (a warm cylinder with hotter heater stripes on a
//! room background; `host-sim run` with the camera on drives the sensor from the plant), prints each whole frame's statistics against the truth, and the round-trip
//! error per ADC resolution.

use clap::Args;
use embassy_futures::block_on;
use thermorph::mlx90640::{
    Calibration, Config, DecodeParams, Error, Image, Mlx90640, PIXELS, ReadingPattern, RefreshRate,
    Resolution, SubpageFrame,
};

use anyhow::{Context as _, anyhow, bail};

use crate::sensor::sim_time::{SimClock, SimDelay};
use crate::sensor::virtual_mlx::{Rng, VirtualBus, VirtualMlx90640};
use crate::sensor::{SensorError, eeprom};

/// A virtual sensor and the firmware driver reading it.
pub struct Rig {
    /// The simulated clock shared by device and driver.
    pub clock: SimClock,
    /// The bus (a handle on the device).
    pub bus: VirtualBus,
    /// The firmware's driver.
    pub driver: Mlx90640<VirtualBus, SimDelay>,
    /// The calibration the driver read.
    pub cal: Box<Calibration>,
    /// The merged image.
    pub image: Image,
    frame: Box<SubpageFrame>,
}

impl Rig {
    /// Build a rig around EEPROM words, calibrate and configure the driver.
    pub fn new(eeprom: [u16; 832], seed: u64, config: Config) -> Result<Self, SensorError> {
        let clock = SimClock::new();
        let device = VirtualMlx90640::new(eeprom, clock.clone(), seed)
            .map_err(SensorError::VirtualSensor)?;
        let bus = VirtualBus::new(device);
        let mut driver = Mlx90640::new(
            bus.clone(),
            SimDelay::new(clock.clone()),
            thermorph::mlx90640::ADDRESS,
        );
        let mut cal = Box::new(Calibration::new());
        block_on(driver.calibrate(&mut cal)).map_err(SensorError::Driver)?;
        block_on(driver.configure(config)).map_err(SensorError::Driver)?;
        Ok(Rig {
            clock,
            bus,
            driver,
            cal,
            image: Image::new(),
            frame: Box::new(SubpageFrame::new()),
        })
    }

    /// Build a rig on the default realistic EEPROM of `seed`.
    pub fn realistic(seed: u64, config: Config) -> Result<Self, SensorError> {
        Self::new(eeprom::realistic(seed).encode()?, seed, config)
    }

    /// Set the true temperature field, K.
    pub fn set_field(&self, field_k: &[f32; PIXELS]) {
        self.bus.0.borrow_mut().field_k = *field_k;
    }

    /// Set the sensor noise, K rms.
    pub fn set_noise(&self, noise_k: f64) {
        self.bus.0.borrow_mut().noise_k = noise_k;
    }

    /// Read the next subpage and decode it into the image; return its number.
    pub fn step(&mut self, params: &DecodeParams) -> Result<u8, Error> {
        block_on(self.driver.read_subpage(&mut self.frame))?;
        let info = self.image.update(&self.frame, &self.cal, params)?;
        Ok(info.subpage)
    }
}

/// The benches' input: the realistic sensor of seed 1 (its EEPROM words) and two raw
/// subpages (8 Hz, 18 bit, chess) of the rendered standard scene `scene` — what the driver
/// would read from a sensor looking at it.
pub fn bench_input(scene: &str) -> Result<([u16; 832], [SubpageFrame; 2]), SensorError> {
    let eeprom = eeprom::realistic(1).encode()?;
    let mut dev =
        VirtualMlx90640::new(eeprom, SimClock::new(), 7).map_err(SensorError::VirtualSensor)?;
    dev.set_control(thermorph::mlx90640::Control(0).with(
        RefreshRate::Hz8,
        Resolution::Bits18,
        ReadingPattern::Chess,
    ));
    let s = crate::imaging::view::standard_scenes()
        .into_iter()
        .find(|s| s.name == scene)
        .ok_or_else(|| SensorError::UnknownScene(scene.to_string()))?;
    dev.field_k = s.render(1).image_k;
    Ok((eeprom, [dev.raw_subpage(0), dev.raw_subpage(1)]))
}

/// Return a random field, each pixel uniform in [`lo_k`, `hi_k`].
pub fn random_field(rng: &mut Rng, lo_k: f64, hi_k: f64) -> [f32; PIXELS] {
    let mut f = [0f32; PIXELS];
    for t in f.iter_mut() {
        *t = (lo_k + (hi_k - lo_k) * rng.uniform()) as f32;
    }
    f
}

/// Largest |decoded − true| over `fields` random fields of `lo_k`–`hi_k` at `resolution` and
/// `pattern`, with the sensor noise off: what is left is the encoding's rounding to ADC counts.
pub fn round_trip(
    seed: u64,
    resolution: Resolution,
    pattern: ReadingPattern,
    fields: usize,
    lo_k: f64,
    hi_k: f64,
) -> Result<f64, SensorError> {
    // 8 Hz: the bus keeps pace (a subpage read takes ≈ 40 ms), so every read is a new subpage.
    let config = Config {
        refresh: RefreshRate::Hz8,
        resolution,
        pattern,
    };
    let mut rig = Rig::realistic(seed, config)?;
    rig.set_noise(0.0);
    let mut rng = Rng::new(seed ^ 0x5EED);
    let params = DecodeParams::default();
    let mut worst = 0f64;
    for _ in 0..fields {
        let field = random_field(&mut rng, lo_k, hi_k);
        rig.set_field(&field);
        // Two subpages measured after the change make one whole image of this field; a
        // subpage measured before the change may still be waiting, so read until both
        // subpages of the new field are in.
        rig.image = Image::new();
        let start = rig.bus.0.borrow().measurements();
        let mut seen = [false; 2];
        while !(seen[0] && seen[1]) {
            let sp = rig.step(&params).map_err(SensorError::Driver)?;
            if rig.bus.0.borrow().measurements() > start + 1 {
                seen[sp as usize] = true;
            } else {
                rig.image = Image::new();
            }
        }
        for (got, want) in rig.image.to_k.iter().zip(field.iter()) {
            worst = worst.max((*got as f64 - *want as f64).abs());
        }
    }
    Ok(worst)
}

/// Options of `host-sim sensor`.
#[derive(Args, Clone, Debug)]
pub struct SensorArgs {
    /// Simulated seconds to run.
    #[arg(long, default_value_t = 4.0)]
    pub seconds: f64,
    /// Subpage refresh rate, Hz (0.5–64).
    #[arg(long, default_value_t = 8.0)]
    pub refresh_hz: f32,
    /// ADC resolution, bits (16–19).
    #[arg(long, default_value_t = 18)]
    pub resolution: u8,
    /// Sensor noise, K rms.
    #[arg(long, default_value_t = 0.1)]
    pub noise_k: f64,
    /// Seed of the virtual sensor's calibration spread and noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

impl Default for SensorArgs {
    fn default() -> Self {
        SensorArgs {
            seconds: 4.0,
            refresh_hz: 8.0,
            resolution: 18,
            noise_k: 0.1,
            seed: 1,
        }
    }
}

/// The fixed scene: room background, a warm cylinder across the middle columns with hotter
/// stripes where the heater shows through the lattice's gaps — 4 rows of each 6, near the
/// block's design of 71 % (`thermorph::mtts::Config::exposed_pct`), so MTTS tells the heater
/// from the surface by the stripes' width — K.
pub fn demo_scene() -> [f32; PIXELS] {
    let mut f = [298.0f32; PIXELS];
    for (p, t) in f.iter_mut().enumerate() {
        let (row, col) = (p / 32, p % 32);
        if (10..22).contains(&col) {
            *t = if row % 6 < 4 { 338.0 } else { 323.0 };
        } else if col == 9 || col == 22 {
            *t = 310.0;
        }
    }
    f
}

/// Run `host-sim sensor`.
pub fn run(args: &SensorArgs) -> anyhow::Result<()> {
    let refresh = RefreshRate::from_hz(args.refresh_hz).ok_or_else(|| {
        anyhow!(
            "refresh rate {} Hz is not one of 0.5, 1, 2, …, 64",
            args.refresh_hz
        )
    })?;
    let resolution = Resolution::from_bits(args.resolution)
        .ok_or_else(|| anyhow!("resolution {} is not 16–19 bits", args.resolution))?;
    if !(args.noise_k >= 0.0 && args.noise_k.is_finite()) {
        bail!("noise must be ≥ 0 K");
    }
    if !(args.seconds > 0.0 && args.seconds <= 86_400.0) {
        bail!("seconds must be in (0, 86400]");
    }
    let config = Config {
        refresh,
        resolution,
        pattern: ReadingPattern::Chess,
    };
    let mut rig = Rig::realistic(args.seed, config)?;
    rig.set_noise(args.noise_k);
    let scene = demo_scene();
    rig.set_field(&scene);
    let params = DecodeParams::default();
    println!(
        "virtual MLX90640 (seed {}): {} Hz subpages, {} bit, chess, noise {} K rms",
        args.seed,
        refresh.hz(),
        resolution.bits(),
        args.noise_k
    );
    println!("time_s,subpage,ta_k,min_k,mean_k,max_k,rms_err_k,max_err_k");
    let end_us = (args.seconds * 1e6) as u64;
    let (mut frames, mut errors) = (0u32, 0u32);
    let mut worst = 0f64;
    while rig.clock.now_us() < end_us {
        match rig.step(&params) {
            Ok(sp) => {
                frames += 1;
                if sp == 1 && rig.image.complete() {
                    let s = rig.image.stats().context("empty image")?;
                    let (mut se, mut me) = (0f64, 0f64);
                    for (got, want) in rig.image.to_k.iter().zip(scene.iter()) {
                        let d = (got - want) as f64;
                        se += d * d;
                        me = me.max(d.abs());
                    }
                    worst = worst.max(me);
                    let ta = rig.bus.0.borrow().ta_k;
                    println!(
                        "{:.3},{sp},{ta:.2},{:.3},{:.3},{:.3},{:.4},{:.4}",
                        rig.clock.now_us() as f64 / 1e6,
                        s.min.k(),
                        s.mean.k(),
                        s.max.k(),
                        (se / PIXELS as f64).sqrt(),
                        me
                    );
                }
            }
            Err(e) => {
                errors += 1;
                println!("# sensor error: {e}");
            }
        }
    }
    println!(
        "summary: {frames} subpages decoded, {errors} errors, max |decoded - true| {worst:.3} K \
         (noise {} K rms)",
        args.noise_k
    );
    println!("round trip without noise, 20 random fields of 263–573 K:");
    for res in Resolution::ALL {
        let e = round_trip(args.seed, res, ReadingPattern::Chess, 20, 263.0, 573.0)?;
        println!(
            "  {} bit: max |decode(encode(T)) - T| = {e:.4} K",
            res.bits()
        );
    }
    Ok(())
}
