//! The sensing pipeline: MLX90640 subpages → whole frames → MTTS → one [`Measurement`] a frame.
//!
//! This module owns the sensor policy both boards share: when to set the sensor up (calibrate
//! and configure), when to recover the bus, which subpages form a frame, what counts as frozen
//! or implausible data, and what is published. The board and host-sim only move data.
//!
//! Two layers:
//! - [`Pipeline`], a pure state machine (no I/O, no clock): it says what to do next
//!   ([`Pipeline::next_action`]) and is fed the result of each action ([`Pipeline::on_setup`],
//!   [`Pipeline::on_recovered`], [`Pipeline::on_subpage`], [`Pipeline::on_read_error`]),
//!   answering with an [`Outcome`]. Tests step it by hand.
//! - [`Sensor`], a thin async wrapper generic over the embedded-hal-async I2C trait (plus
//!   [`RecoverBus`]) that performs one action per [`Sensor::step`].
//!
//! Rules:
//! - A frame is a subpage 0 followed directly by a subpage 1, read at most 1.5 refresh periods
//!   apart. Anything in between — an error, a discarded subpage, a repeated parity (a subpage
//!   missed), a longer pause — drops the held half: a frame never merges subpages across a gap.
//! - A subpage identical word for word (pixels and aux) to the last one of its number is
//!   frozen data: real frames always carry noise.
//! - After an I2C error (NACK, timeout, …) the pipeline pauses [`PipelineConfig::retry_ms`],
//!   recovers the bus ([`RecoverBus`]) and sets the sensor up again (EEPROM and control
//!   register); a failed setup or recovery pauses and tries again, so a missing sensor costs
//!   a few bus transfers every 200 ms and never stops the loop. Stale data, frozen data and a control register that lost its settings (a
//!   power-cycled sensor) also set it up again. Implausible data only drops the frame.
//! - T1, T2 and Tc (under the hint in force; the frame does not carry it, the supervisor
//!   computes its own) must be within [`mtts::PLAUSIBLE_K`]; regions 3–5 may be missing
//!   (`None`). A uniform block has no lattice, so MTTS may give T1 or T2
//!   no cluster: the other stands for both, quality `Fallback` ([`to_measurement`]). More than
//!   [`mtts::Config::max_filled`] broken pixels in a frame is an error.
//! - Every error is a [`SensingError`] with a stable [`SensingError::code`], for the logs: an
//!   error publishes no [`Measurement`], and the supervisor's sensor-loss fault is the age of
//!   the last valid one (it does not read the errors).
//! - The [`SensingHint`] from the supervisor sets the MTTS prior and the weights of Tc for the
//!   frames that follow.

use embedded_hal_async::delay::DelayNs;
use embedded_hal_async::i2c::I2c;

use crate::measurement::{Measurement, SensingHint, controlled_temperature};
use crate::mlx90640::{
    self, Calibration, DecodeParams, FrameError, Image, Mlx90640, PIXELS, SubpageFrame, SubpageInfo,
};
use crate::mtts::{self, Mtts, MttsError, PLAUSIBLE_K};
use crate::units::{Kelvin, Millis};

/// Default pause after an error before the sensor is set up again, ms.
pub const DEFAULT_RETRY_MS: u32 = 200;

/// The pipeline's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PipelineConfig {
    /// Measurement settings written to the sensor.
    pub sensor: mlx90640::Config,
    /// MTTS settings.
    pub mtts: mtts::Config,
    /// Object parameters of the temperature calculation.
    pub decode: DecodeParams,
    /// Pause after an error before setting the sensor up again, ms.
    pub retry_ms: u32,
}

impl Default for PipelineConfig {
    /// 8 Hz subpages, 18 bit, chess; MTTS defaults (its `max_filled` is the broken-pixel
    /// limit); emissivity 1; 200 ms.
    fn default() -> Self {
        PipelineConfig {
            sensor: mlx90640::Config::default(),
            mtts: mtts::Config::default(),
            decode: DecodeParams::default(),
            retry_ms: DEFAULT_RETRY_MS,
        }
    }
}

/// The bus stayed held low after a recovery.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct BusStuck;

/// I2C bus recovery, implemented by the bus the sensor is on.
///
/// After a timeout the transfer was abandoned midway: the sensor may hold SDA low waiting for
/// clocks, and the peripheral may be left busy. `recover` frees both: it releases the pins
/// from the peripheral, clocks SCL up to nine times until SDA is high, sends a STOP, and
/// builds the peripheral again. It returns [`BusStuck`] if SDA is still low.
#[allow(async_fn_in_trait)]
pub trait RecoverBus {
    /// Recover the bus in place (see the trait docs).
    async fn recover(&mut self) -> Result<(), BusStuck>;
}

/// Monotonic time for the timestamps.
pub trait Clock {
    /// Return the time now.
    fn now(&self) -> Millis;
}

/// Why values were implausible.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum Implausible {
    /// The subpage was refused (0x7FFF marker, Vdd or Ta out of range, zero gain, …).
    Frame(FrameError),
    /// MTTS refused the frame (no valid pixel).
    Mtts(MttsError),
    /// T1, T2 or Tc was not finite or outside [`mtts::PLAUSIBLE_K`].
    Regions,
}

/// A sensing error (logged; the frame it spoiled publishes no measurement, which is what the
/// supervisor's sensor-loss fault sees).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum SensingError {
    /// A bus transfer failed or timed out (the bus is recovered and the sensor set up again).
    I2c(mlx90640::Error),
    /// The bus stayed held low after a recovery.
    BusStuck,
    /// No new subpage within two refresh periods.
    Stale {
        /// How long the driver waited, ms.
        waited_ms: u32,
    },
    /// A subpage repeated the last one of its number word for word.
    Frozen {
        /// Subpage number.
        subpage: u8,
    },
    /// The sensor lost its configuration (power-cycled); it is set up again.
    ControlReset {
        /// The control register as read.
        read: u16,
    },
    /// Setting the sensor up failed for a reason other than the bus (EEPROM refused, control
    /// register not taking the settings).
    Setup(mlx90640::Error),
    /// Values outside what a working sensor reports.
    Implausible(Implausible),
    /// More broken pixels than the limit were filled in a frame.
    TooManyFilled {
        /// Pixels filled.
        filled: u16,
        /// The limit.
        limit: u16,
    },
}

impl SensingError {
    /// Return a stable short code (for the console and files).
    pub fn code(&self) -> &'static str {
        match self {
            Self::I2c(_) => "i2c",
            Self::BusStuck => "bus-stuck",
            Self::Stale { .. } => "stale",
            Self::Frozen { .. } => "frozen",
            Self::ControlReset { .. } => "control-reset",
            Self::Setup(_) => "setup",
            Self::Implausible(_) => "implausible",
            Self::TooManyFilled { .. } => "too-many-filled",
        }
    }

    /// Classify a driver error met while reading a subpage (`None`: not an error, the
    /// subpage was only discarded).
    fn from_read(e: mlx90640::Error) -> Option<Self> {
        use mlx90640::Error as E;
        Some(match e {
            E::Bus { .. } | E::Timeout { .. } => Self::I2c(e),
            E::Stale { waited_ms } => Self::Stale { waited_ms },
            E::ControlReset { read } => Self::ControlReset { read },
            E::Frame(f) => Self::Implausible(Implausible::Frame(f)),
            E::Overwritten { .. } => return None,
            E::Calibration(_) | E::ConfigMismatch { .. } => Self::Setup(e),
        })
    }
}

impl core::fmt::Display for SensingError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::I2c(e) | Self::Setup(e) => write!(f, "{e}"),
            Self::BusStuck => write!(f, "I2C bus still held low after a recovery"),
            Self::Stale { waited_ms } => write!(f, "no new frame for {waited_ms} ms"),
            Self::Frozen { subpage } => {
                write!(f, "subpage {subpage} repeated unchanged (frozen sensor)")
            }
            Self::ControlReset { read } => write!(
                f,
                "control register 0x{read:04X} lost its settings (sensor power-cycled?)"
            ),
            Self::Implausible(Implausible::Frame(e)) => write!(f, "{e}"),
            Self::Implausible(Implausible::Mtts(e)) => write!(f, "{e}"),
            Self::Implausible(Implausible::Regions) => {
                write!(f, "T1, T2 or Tc not a plausible temperature")
            }
            Self::TooManyFilled { filled, limit } => {
                write!(f, "{filled} broken pixels filled (limit {limit})")
            }
        }
    }
}

/// Why a subpage was dropped without being an error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum Discard {
    /// The sensor overwrote it during the read.
    Overwritten,
    /// A subpage 1 with no subpage 0 just before it (after a gap, an error, a repeated
    /// parity or at start): it cannot complete a frame.
    Unpaired,
}

/// What the pipeline wants done next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum Action {
    /// Recover the bus ([`RecoverBus::recover`]), then report with [`Pipeline::on_recovered`].
    RecoverBus,
    /// Wait this long, then ask again.
    Pause {
        /// The pause, ms.
        ms: u32,
    },
    /// Calibrate and configure the sensor, then report with [`Pipeline::on_setup`].
    Setup,
    /// Read the next subpage, then report with [`Pipeline::on_subpage`] or
    /// [`Pipeline::on_read_error`].
    ReadSubpage,
}

/// The result of one action.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outcome {
    /// The bus was recovered.
    Recovered,
    /// A pause ended.
    Paused,
    /// The sensor was calibrated and configured.
    Ready,
    /// A subpage 0 was read and waits for its subpage 1.
    Half,
    /// A subpage was dropped without fault.
    Discarded(Discard),
    /// A whole frame: publish it.
    Frame(Measurement),
    /// An error: publish it (no measurement this time).
    Error(SensingError),
}

/// The half of a frame held: subpage 0, read at `at`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Half {
    at: Millis,
}

/// Working memory of the pipeline (≈ 60 KB: keep it in a `static` on the target).
pub struct Buffers {
    /// The sensor's calibration.
    pub cal: Calibration,
    /// The last subpage read.
    pub frame: SubpageFrame,
    /// The image merged from the last subpages.
    pub image: Image,
    /// MTTS working memory.
    pub scratch: mtts::Scratch,
}

impl Default for Buffers {
    fn default() -> Self {
        Self::new()
    }
}

impl Buffers {
    /// Return zeroed buffers.
    pub const fn new() -> Self {
        Buffers {
            cal: Calibration::new(),
            frame: SubpageFrame::new(),
            image: Image::new(),
            scratch: mtts::Scratch::new(),
        }
    }
}

/// The pipeline's working memory, borrowed part by part.
pub struct Parts<'a> {
    /// The sensor's calibration.
    pub cal: &'a mut Calibration,
    /// The last subpage read.
    pub frame: &'a mut SubpageFrame,
    /// The image merged from the last subpages.
    pub image: &'a mut Image,
    /// MTTS working memory.
    pub scratch: &'a mut mtts::Scratch,
}

/// Where the pipeline's working memory lives: [`Buffers`] in one piece (a `Box` on the host),
/// or four separate `static`s on the board, so the zero-initialised parts stay in `.bss`
/// instead of being copied from flash with the image's NaNs.
pub trait Storage {
    /// Return the parts, mutably.
    fn parts(&mut self) -> Parts<'_>;
    /// Return the image.
    fn image(&self) -> &Image;
}

impl Storage for Buffers {
    fn parts(&mut self) -> Parts<'_> {
        Parts {
            cal: &mut self.cal,
            frame: &mut self.frame,
            image: &mut self.image,
            scratch: &mut self.scratch,
        }
    }

    fn image(&self) -> &Image {
        &self.image
    }
}

impl<S: Storage + ?Sized> Storage for &mut S {
    fn parts(&mut self) -> Parts<'_> {
        (**self).parts()
    }

    fn image(&self) -> &Image {
        (**self).image()
    }
}

/// FNV-1a digest of words, to spot repeated subpages without keeping a copy.
fn digest(words: &[u16]) -> u32 {
    words.iter().fold(0x811C_9DC5u32, |h, &w| {
        let h = (h ^ (w & 0xFF) as u32).wrapping_mul(0x0100_0193);
        (h ^ (w >> 8) as u32).wrapping_mul(0x0100_0193)
    })
}

/// Turn one frame's MTTS result into the supervisor's [`Measurement`], or `None` when T1, T2
/// or Tc under `hint` is not a temperature this sensor can report (the measurement carries no
/// Tc: the supervisor computes it, with the hint of its mode).
pub fn to_measurement(
    out: &mtts::Output,
    hint: &SensingHint,
    at: Millis,
    seq: u32,
) -> Option<Measurement> {
    let regions = out.regions.map(|r| r.temp);
    let plausible =
        |t: Option<Kelvin>| t.is_some_and(|t| t.k() >= PLAUSIBLE_K.0 && t.k() <= PLAUSIBLE_K.1);
    if !(plausible(regions[0]) && plausible(regions[1])) {
        return None;
    }
    let m = Measurement {
        at,
        seq,
        regions,
        hottest: out.hottest,
        filled_pixels: out.filled_pixels,
        quality: out.quality,
        bound: out.bound,
        tilt: if out.fresh.cylinder_fresh {
            crate::measurement::Tilt::from_slope(out.fresh.tilt_slope, out.fresh.tilt_slope_se)
        } else {
            None
        },
        exposure: out.exposure,
    };
    // Tc is the supervisor's to compute (it carries no field here); under the hint in force it
    // only decides whether the frame is plausible enough to publish.
    plausible(controlled_temperature(&m, hint)).then_some(m)
}

/// The sensing state machine (see the module docs).
#[derive(Clone, Debug)]
pub struct Pipeline {
    config: PipelineConfig,
    mtts: Mtts,
    hint: SensingHint,
    ready: bool,
    recover: bool,
    pause: bool,
    half: Option<Half>,
    digests: [Option<u32>; 2],
    seq: u32,
    last_subpage: Option<SubpageInfo>,
}

impl Pipeline {
    /// Make a pipeline (MTTS settings checked); the first action is [`Action::Setup`].
    pub fn new(config: PipelineConfig) -> Result<Self, MttsError> {
        Ok(Pipeline {
            mtts: Mtts::new(config.mtts)?,
            hint: SensingHint::default(),
            config,
            ready: false,
            recover: false,
            pause: false,
            half: None,
            digests: [None, None],
            seq: 0,
            last_subpage: None,
        })
    }

    /// Return the settings.
    pub fn config(&self) -> &PipelineConfig {
        &self.config
    }

    /// Apply the supervisor's hint to the frames that follow: MTTS prior and Tc weights.
    pub fn set_hint(&mut self, hint: SensingHint) {
        self.mtts.set_prior(hint.prior);
        self.hint = hint;
    }

    /// Return the hint in force.
    pub fn hint(&self) -> SensingHint {
        self.hint
    }

    /// Return the number of frames published so far (the next frame's `seq` is this).
    pub fn frames(&self) -> u32 {
        self.seq
    }

    /// Return the sensor temperature and supply of the last subpage decoded.
    pub fn last_subpage(&self) -> Option<SubpageInfo> {
        self.last_subpage
    }

    /// Return whether the sensor is set up.
    pub fn is_ready(&self) -> bool {
        self.ready
    }

    /// Return what to do next. A pause is asked for once after each error that needs it.
    pub fn next_action(&mut self) -> Action {
        if core::mem::take(&mut self.pause) {
            Action::Pause {
                ms: self.config.retry_ms,
            }
        } else if self.recover {
            Action::RecoverBus
        } else if !self.ready {
            Action::Setup
        } else {
            Action::ReadSubpage
        }
    }

    /// Record an error: drop the held half, plan the next actions, return the outcome.
    fn fail(&mut self, e: SensingError) -> Outcome {
        self.half = None;
        match e {
            SensingError::I2c(_) | SensingError::BusStuck => {
                self.recover = true;
                self.pause = true;
                self.ready = false;
            }
            SensingError::Setup(_) => {
                self.pause = true;
                self.ready = false;
            }
            SensingError::Stale { .. }
            | SensingError::Frozen { .. }
            | SensingError::ControlReset { .. } => self.ready = false,
            SensingError::Implausible(_) | SensingError::TooManyFilled { .. } => {}
        }
        Outcome::Error(e)
    }

    /// Report the end of a pause.
    pub fn on_paused(&mut self) -> Outcome {
        Outcome::Paused
    }

    /// Report a bus recovery.
    pub fn on_recovered(&mut self, result: Result<(), BusStuck>) -> Outcome {
        self.recover = false;
        match result {
            Ok(()) => Outcome::Recovered,
            // Recover again after the pause.
            Err(BusStuck) => self.fail(SensingError::BusStuck),
        }
    }

    /// Report a setup (calibration and configuration).
    pub fn on_setup(&mut self, result: Result<(), mlx90640::Error>) -> Outcome {
        self.half = None;
        match result {
            Ok(()) => {
                self.ready = true;
                Outcome::Ready
            }
            Err(e @ (mlx90640::Error::Bus { .. } | mlx90640::Error::Timeout { .. })) => {
                self.fail(SensingError::I2c(e))
            }
            Err(e) => self.fail(SensingError::Setup(e)),
        }
    }

    /// Report a failed subpage read.
    pub fn on_read_error(&mut self, e: mlx90640::Error) -> Outcome {
        match SensingError::from_read(e) {
            Some(e) => self.fail(e),
            None => {
                self.half = None;
                Outcome::Discarded(Discard::Overwritten)
            }
        }
    }

    /// Report a subpage read at `at` into `frame`: check it, decode it into `image` and, if it
    /// completes a frame, run MTTS and return the measurement.
    pub fn on_subpage(
        &mut self,
        at: Millis,
        frame: &SubpageFrame,
        cal: &Calibration,
        image: &mut Image,
        scratch: &mut mtts::Scratch,
    ) -> Outcome {
        let sp = frame.subpage();
        let d = digest(&frame.words[..PIXELS + mlx90640::AUX_WORDS]);
        let repeated = self.digests[sp as usize] == Some(d);
        self.digests[sp as usize] = Some(d);
        if repeated {
            return self.fail(SensingError::Frozen { subpage: sp });
        }
        match image.update(frame, cal, &self.config.decode) {
            Ok(info) => self.last_subpage = Some(info),
            Err(e) => return self.fail(SensingError::Implausible(Implausible::Frame(e))),
        }
        let held = self.half.take();
        if sp == 0 {
            self.half = Some(Half { at });
            return Outcome::Half;
        }
        // 1.5 periods: a subpage read on time is one period after its partner (± the poll
        // interval); two periods means one (or more) was missed in between.
        let limit_ms = (self.config.sensor.refresh.period_us() as u64 * 3 / 2).div_ceil(1000);
        match held {
            Some(h) if at.0.saturating_sub(h.at.0) <= limit_ms => {}
            _ => return Outcome::Discarded(Discard::Unpaired),
        }
        let out = match self.mtts.process(&image.to_k, scratch) {
            Ok(out) => out,
            Err(MttsError::TooManyBroken { broken, limit }) => {
                return self.fail(SensingError::TooManyFilled {
                    filled: broken,
                    limit,
                });
            }
            Err(e) => return self.fail(SensingError::Implausible(Implausible::Mtts(e))),
        };
        match to_measurement(&out, &self.hint, at, self.seq) {
            Some(m) => {
                self.seq = self.seq.wrapping_add(1);
                Outcome::Frame(m)
            }
            None => self.fail(SensingError::Implausible(Implausible::Regions)),
        }
    }
}

/// The sensor, its driver and the pipeline: one [`Sensor::step`] performs one action.
///
/// `B` holds the working memory ([`Storage`]).
pub struct Sensor<I2C, D, C, B> {
    driver: Mlx90640<I2C, D>,
    delay: D,
    clock: C,
    pipeline: Pipeline,
    bufs: B,
}

impl<I2C, D, C, B> Sensor<I2C, D, C, B>
where
    I2C: I2c + RecoverBus,
    D: DelayNs + Clone,
    C: Clock,
    B: Storage,
{
    /// Make the sensor at 7-bit `address` on `i2c`, with `pipeline` and its buffers.
    pub fn new(i2c: I2C, delay: D, clock: C, address: u8, pipeline: Pipeline, bufs: B) -> Self {
        Sensor {
            driver: Mlx90640::new(i2c, delay.clone(), address),
            delay,
            clock,
            pipeline,
            bufs,
        }
    }

    /// Return the pipeline.
    pub fn pipeline(&self) -> &Pipeline {
        &self.pipeline
    }

    /// Apply the supervisor's hint (see [`Pipeline::set_hint`]).
    pub fn set_hint(&mut self, hint: SensingHint) {
        self.pipeline.set_hint(hint);
    }

    /// Return the last image (for status and telemetry).
    pub fn image(&self) -> &Image {
        self.bufs.image()
    }

    /// Return the driver (for tests and diagnostics).
    pub fn driver(&mut self) -> &mut Mlx90640<I2C, D> {
        &mut self.driver
    }

    /// Perform the pipeline's next action and return its outcome.
    pub async fn step(&mut self) -> Outcome {
        match self.pipeline.next_action() {
            Action::RecoverBus => {
                let r = self.driver.bus_mut().recover().await;
                self.pipeline.on_recovered(r)
            }
            Action::Pause { ms } => {
                self.delay.delay_ms(ms).await;
                self.pipeline.on_paused()
            }
            Action::Setup => {
                let sensor = self.pipeline.config().sensor;
                let r = match self.driver.calibrate(self.bufs.parts().cal).await {
                    Ok(()) => self.driver.configure(sensor).await,
                    Err(e) => Err(e),
                };
                self.pipeline.on_setup(r)
            }
            Action::ReadSubpage => match self.driver.read_subpage(self.bufs.parts().frame).await {
                Ok(()) => {
                    let at = self.clock.now();
                    let Parts {
                        cal,
                        frame,
                        image,
                        scratch,
                    } = self.bufs.parts();
                    self.pipeline.on_subpage(at, frame, cal, image, scratch)
                }
                Err(e) => self.pipeline.on_read_error(e),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mlx90640::Error as E;
    use crate::mtts::Weights;
    use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource};

    fn pipeline() -> Pipeline {
        Pipeline::new(PipelineConfig::default()).unwrap()
    }

    fn nack() -> E {
        E::Bus {
            register: 0x8000,
            kind: ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address),
        }
    }

    #[test]
    fn starts_with_setup_then_reads() {
        let mut p = pipeline();
        assert_eq!(p.next_action(), Action::Setup);
        assert_eq!(p.next_action(), Action::Setup, "until a setup succeeds");
        assert_eq!(p.on_setup(Ok(())), Outcome::Ready);
        assert!(p.is_ready());
        assert_eq!(p.next_action(), Action::ReadSubpage);
    }

    #[test]
    fn i2c_errors_pause_recover_and_set_up_again() {
        let mut p = pipeline();
        p.on_setup(Ok(()));
        for e in [nack(), E::Timeout { register: 0x0400 }] {
            assert_eq!(p.on_read_error(e), Outcome::Error(SensingError::I2c(e)));
            assert_eq!(
                p.next_action(),
                Action::Pause {
                    ms: DEFAULT_RETRY_MS
                }
            );
            assert_eq!(p.next_action(), Action::RecoverBus);
            assert_eq!(p.on_recovered(Ok(())), Outcome::Recovered);
            assert_eq!(p.next_action(), Action::Setup);
            // A setup that fails on the bus goes round again.
            assert_eq!(
                p.on_setup(Err(nack())),
                Outcome::Error(SensingError::I2c(nack()))
            );
            assert_eq!(
                p.next_action(),
                Action::Pause {
                    ms: DEFAULT_RETRY_MS
                }
            );
            assert_eq!(p.next_action(), Action::RecoverBus);
            assert_eq!(
                p.on_recovered(Err(BusStuck)),
                Outcome::Error(SensingError::BusStuck)
            );
            assert_eq!(
                p.next_action(),
                Action::Pause {
                    ms: DEFAULT_RETRY_MS
                }
            );
            assert_eq!(p.next_action(), Action::RecoverBus);
            p.on_recovered(Ok(()));
            assert_eq!(p.next_action(), Action::Setup);
            assert_eq!(p.on_setup(Ok(())), Outcome::Ready);
            assert_eq!(p.next_action(), Action::ReadSubpage);
        }
    }

    #[test]
    fn stale_frozen_and_control_reset_set_up_again_without_a_pause() {
        let mut p = pipeline();
        p.on_setup(Ok(()));
        let cases = [
            (
                E::Stale { waited_ms: 250 },
                SensingError::Stale { waited_ms: 250 },
            ),
            (
                E::ControlReset { read: 0x1901 },
                SensingError::ControlReset { read: 0x1901 },
            ),
        ];
        for (e, want) in cases {
            assert_eq!(p.on_read_error(e), Outcome::Error(want));
            assert_eq!(p.next_action(), Action::Setup);
            p.on_setup(Ok(()));
        }
        // A refused setup that is not the bus: pause, then set up again (no recovery).
        let cal = E::ConfigMismatch {
            wrote: 0x1A01,
            read: 0x1901,
        };
        assert_eq!(
            p.on_setup(Err(cal)),
            Outcome::Error(SensingError::Setup(cal))
        );
        assert_eq!(
            p.next_action(),
            Action::Pause {
                ms: DEFAULT_RETRY_MS
            }
        );
        assert_eq!(p.next_action(), Action::Setup);
    }

    #[test]
    fn overwritten_and_corrupt_subpages_only_drop_the_frame() {
        let mut p = pipeline();
        p.on_setup(Ok(()));
        assert_eq!(
            p.on_read_error(E::Overwritten { subpage: 1 }),
            Outcome::Discarded(Discard::Overwritten)
        );
        assert_eq!(p.next_action(), Action::ReadSubpage);
        let f = FrameError::InvalidMarker { index: 768 };
        assert_eq!(
            p.on_read_error(E::Frame(f)),
            Outcome::Error(SensingError::Implausible(Implausible::Frame(f)))
        );
        assert_eq!(p.next_action(), Action::ReadSubpage);
    }

    #[test]
    fn hint_sets_prior_and_weights() {
        let mut p = pipeline();
        assert_eq!(p.hint(), SensingHint::default());
        let hint = SensingHint {
            prior: mtts::Prior::SurfaceHotter,
            weights: Weights { w1: 0.25, w2: 0.75 },
        };
        p.set_hint(hint);
        assert_eq!(p.hint(), hint);
        assert_eq!(p.mtts.prior(), mtts::Prior::SurfaceHotter);
    }

    #[test]
    fn measurement_from_mtts_output() {
        let mut m = Mtts::new(mtts::Config::default()).unwrap();
        let mut scratch = std::boxed::Box::new(mtts::Scratch::new());
        // A uniform block: no geometry can be fitted.
        let mut img = [300.0f32; mtts::IMG_PIXELS];
        img[5] = f32::NAN;
        let out = m.process(&img, &mut scratch).unwrap();
        let hint = SensingHint {
            prior: mtts::Prior::Unknown,
            weights: Weights { w1: 0.5, w2: 0.5 },
        };
        let got = to_measurement(&out, &hint, Millis(1234), 7).unwrap();
        assert_eq!((got.at, got.seq), (Millis(1234), 7));
        assert_eq!(got.quality, crate::measurement::Quality::Fallback);
        assert!(got.t1().unwrap().k().is_finite() && got.t2().unwrap().k().is_finite());
        assert_eq!(got.bound, out.bound);
        assert_eq!(got.filled_pixels, 1);
        assert!(
            (controlled_temperature(&got, &hint).unwrap().k() - 300.0).abs()
                < 1e-3 + 0.5 * got.bound.k(),
            "{got:?}"
        );
        assert_eq!(got.hottest, out.hottest);
        // Tc out of the plausible range (weights that do not sum to 1) is refused.
        let bad = SensingHint {
            weights: Weights { w1: 3.0, w2: 3.0 },
            ..hint
        };
        assert_eq!(to_measurement(&out, &bad, Millis(0), 0), None);
    }

    #[test]
    fn error_codes_are_distinct() {
        let all = [
            SensingError::I2c(nack()),
            SensingError::BusStuck,
            SensingError::Stale { waited_ms: 1 },
            SensingError::Frozen { subpage: 0 },
            SensingError::ControlReset { read: 0 },
            SensingError::Setup(E::ConfigMismatch { wrote: 0, read: 0 }),
            SensingError::Implausible(Implausible::Regions),
            SensingError::TooManyFilled {
                filled: 40,
                limit: 38,
            },
        ];
        for (i, a) in all.iter().enumerate() {
            for b in &all[i + 1..] {
                assert_ne!(a.code(), b.code());
            }
            assert!(!std::format!("{a}").is_empty());
        }
    }
}
