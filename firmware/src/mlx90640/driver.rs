//! Thin async driver: bus transfers, the new-data handshake and frame checks.
//!
//! Generic over `embedded_hal_async::i2c::I2c` and `embedded_hal_async::delay::DelayNs`, so the
//! same code runs on embassy's I2C and on the simulator's virtual bus. Every bus call races a
//! timeout; waiting for a subpage polls the status register and gives up after two refresh
//! periods (stale data); after reading a subpage the status register is read again, and a
//! subpage the sensor overwrote during the read (new data flagged again) is refused; a control
//! register that no longer holds the configured settings (the sensor power-cycled to its 2 Hz
//! default) is reported so the caller configures it again. Which subpages form a frame, frozen
//! data and what to do after an error are the sensing pipeline's ([`crate::sensing`]). The
//! driver never panics and never loops without a bound.

use embassy_futures::select::{Either, select};
use embedded_hal::i2c::{Error as _, ErrorKind};
use embedded_hal_async::delay::DelayNs;
use embedded_hal_async::i2c::I2c;

use super::calc::{FrameError, IDX_CONTROL, IDX_SUBPAGE, SubpageFrame};
use super::calibration::{Calibration, CalibrationError};
use super::register::{Control, ReadingPattern, RefreshRate, Resolution, Status};
use super::{AUX_START, AUX_WORDS, EEPROM_START, EEPROM_WORDS, PIXELS, RAM_START};

/// Words per I2C read transaction (128 bytes on the wire).
pub const CHUNK_WORDS: usize = 64;
/// Timeout of one bus transaction, µs (a 64-word read takes ≈ 3.3 ms at 400 kHz).
pub const BUS_TIMEOUT_US: u32 = 20_000;

/// Measurement settings written to the control register.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct Config {
    /// Subpage refresh rate.
    pub refresh: RefreshRate,
    /// ADC resolution.
    pub resolution: Resolution,
    /// Reading pattern.
    pub pattern: ReadingPattern,
}

impl Default for Config {
    /// 8 Hz subpages (a whole frame at 4 Hz), 18 bit, chess: SPEC section 2.
    fn default() -> Self {
        Config {
            refresh: RefreshRate::Hz8,
            resolution: Resolution::Bits18,
            pattern: ReadingPattern::Chess,
        }
    }
}

/// Driver errors: one small `Copy` enum with context.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum Error {
    /// The bus reported an error (NACK, arbitration loss, …) at this register address.
    Bus {
        /// Register address of the transfer.
        register: u16,
        /// The bus error kind.
        #[cfg_attr(target_os = "none", defmt(Debug2Format))]
        kind: ErrorKind,
    },
    /// A transfer did not complete within [`BUS_TIMEOUT_US`].
    Timeout {
        /// Register address of the transfer.
        register: u16,
    },
    /// No new subpage within two refresh periods.
    Stale {
        /// How long the driver waited, ms.
        waited_ms: u32,
    },
    /// New data arrived while the subpage was being read: its words may mix two measurements,
    /// so it was discarded.
    Overwritten {
        /// Subpage number that was being read.
        subpage: u8,
    },
    /// The control register no longer holds the configured settings: the sensor lost them (a
    /// power cycle puts it back to chess, 18 bit, 2 Hz) and must be configured again.
    ControlReset {
        /// The control register as read.
        read: u16,
    },
    /// The control register did not read back what was written.
    ConfigMismatch {
        /// Value written.
        wrote: u16,
        /// Value read back.
        read: u16,
    },
    /// The EEPROM was refused.
    Calibration(CalibrationError),
    /// The subpage's data are unusable.
    Frame(FrameError),
}

impl From<CalibrationError> for Error {
    fn from(e: CalibrationError) -> Self {
        Error::Calibration(e)
    }
}

impl From<FrameError> for Error {
    fn from(e: FrameError) -> Self {
        Error::Frame(e)
    }
}

impl core::fmt::Display for Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Self::Bus { register, kind } => {
                write!(f, "I2C error at 0x{register:04X}: {kind}")
            }
            Self::Timeout { register } => write!(f, "I2C timeout at 0x{register:04X}"),
            Self::Stale { waited_ms } => write!(f, "no new frame for {waited_ms} ms"),
            Self::Overwritten { subpage } => {
                write!(
                    f,
                    "subpage {subpage} overwritten during its read (discarded)"
                )
            }
            Self::ControlReset { read } => write!(
                f,
                "control register 0x{read:04X} lost its settings (sensor power-cycled?)"
            ),
            Self::ConfigMismatch { wrote, read } => {
                write!(f, "control register wrote 0x{wrote:04X}, read 0x{read:04X}")
            }
            Self::Calibration(e) => write!(f, "{e}"),
            Self::Frame(e) => write!(f, "{e}"),
        }
    }
}

/// The MLX90640 on an async I2C bus.
pub struct Mlx90640<I2C, D> {
    i2c: I2C,
    delay: D,
    address: u8,
    config: Config,
    configured: bool,
}

impl<I2C: I2c, D: DelayNs> Mlx90640<I2C, D> {
    /// Make a driver for the device at 7-bit `address` (usually [`super::ADDRESS`]).
    pub fn new(i2c: I2C, delay: D, address: u8) -> Self {
        Mlx90640 {
            i2c,
            delay,
            address,
            config: Config::default(),
            configured: false,
        }
    }

    /// Give the bus and delay back.
    pub fn release(self) -> (I2C, D) {
        (self.i2c, self.delay)
    }

    /// Return the configuration last written.
    pub fn config(&self) -> Config {
        self.config
    }

    /// Return the bus, for a recovery in place (see [`crate::sensing::RecoverBus`]).
    pub fn bus_mut(&mut self) -> &mut I2C {
        &mut self.i2c
    }

    /// Return whether `control` holds the settings last written (always true before
    /// [`Mlx90640::configure`] succeeded: nothing to compare with).
    fn holds_config(&self, control: Control) -> bool {
        !self.configured
            || (
                control.refresh_rate(),
                control.resolution(),
                control.pattern(),
            ) == (
                self.config.refresh,
                self.config.resolution,
                self.config.pattern,
            )
    }

    /// Read `out.len()` words starting at `register`, in chunks, each under a timeout.
    pub async fn read_words(&mut self, register: u16, out: &mut [u16]) -> Result<(), Error> {
        let mut buf = [0u8; CHUNK_WORDS * 2];
        for (i, chunk) in out.chunks_mut(CHUNK_WORDS).enumerate() {
            let reg = register.wrapping_add((i * CHUNK_WORDS) as u16);
            let bytes = &mut buf[..chunk.len() * 2];
            let reg_bytes = reg.to_be_bytes();
            let fut = self.i2c.write_read(self.address, &reg_bytes, bytes);
            match select(fut, self.delay.delay_us(BUS_TIMEOUT_US)).await {
                Either::First(Ok(())) => {}
                Either::First(Err(e)) => {
                    return Err(Error::Bus {
                        register: reg,
                        kind: e.kind(),
                    });
                }
                Either::Second(()) => return Err(Error::Timeout { register: reg }),
            }
            for (w, b) in chunk.iter_mut().zip(bytes.chunks_exact(2)) {
                *w = u16::from_be_bytes([b[0], b[1]]);
            }
        }
        Ok(())
    }

    /// Write one word to `register` under a timeout.
    pub async fn write_word(&mut self, register: u16, value: u16) -> Result<(), Error> {
        let [a, b] = register.to_be_bytes();
        let [c, d] = value.to_be_bytes();
        let msg = [a, b, c, d];
        let fut = self.i2c.write(self.address, &msg);
        match select(fut, self.delay.delay_us(BUS_TIMEOUT_US)).await {
            Either::First(Ok(())) => Ok(()),
            Either::First(Err(e)) => Err(Error::Bus {
                register,
                kind: e.kind(),
            }),
            Either::Second(()) => Err(Error::Timeout { register }),
        }
    }

    async fn read_word(&mut self, register: u16) -> Result<u16, Error> {
        let mut w = [0u16; 1];
        self.read_words(register, &mut w).await?;
        Ok(w[0])
    }

    /// Read the 832 EEPROM words (call with the bus at ≤ 400 kHz).
    pub async fn read_eeprom(&mut self, words: &mut [u16; EEPROM_WORDS]) -> Result<(), Error> {
        self.read_words(EEPROM_START, words).await
    }

    /// Read the EEPROM and extract the calibration into `cal`, in place.
    pub async fn calibrate(&mut self, cal: &mut Calibration) -> Result<(), Error> {
        let mut words = [0u16; EEPROM_WORDS];
        self.read_eeprom(&mut words).await?;
        cal.extract(&words)?;
        Ok(())
    }

    /// Write the measurement settings (read-modify-write, verified by reading back).
    pub async fn configure(&mut self, config: Config) -> Result<(), Error> {
        self.configured = false;
        let old = Control(self.read_word(Control::ADDRESS).await?);
        let new = old.with(config.refresh, config.resolution, config.pattern);
        self.write_word(Control::ADDRESS, new.0).await?;
        let read = self.read_word(Control::ADDRESS).await?;
        if read != new.0 {
            return Err(Error::ConfigMismatch { wrote: new.0, read });
        }
        self.config = config;
        self.configured = true;
        Ok(())
    }

    /// Return the control register as the device has it.
    pub async fn read_control(&mut self) -> Result<Control, Error> {
        Ok(Control(self.read_word(Control::ADDRESS).await?))
    }

    /// Wait for the next subpage and read it into `frame` (the library's
    /// `MLX90640_GetFrameData`): poll the status register until new data (at most two refresh
    /// periods), acknowledge it, read the pixels, the aux words and the control register, read
    /// the status again (new data flagged again: the subpage was overwritten during the read,
    /// [`Error::Overwritten`]), then check the control register against the configuration
    /// ([`Error::ControlReset`]) and the frame for the 0x7FFF marker. On a timeout waiting for
    /// data the control register is read too: a sensor that power-cycled to 2 Hz shows as
    /// [`Error::ControlReset`], not as stale data.
    pub async fn read_subpage(&mut self, frame: &mut SubpageFrame) -> Result<(), Error> {
        let period_us = self.config.refresh.period_us();
        let limit_us = 2 * period_us;
        let poll_us = (period_us / 16).clamp(1_000, 20_000);
        let mut waited_us = 0u32;
        let status = loop {
            let status = Status(self.read_word(Status::ADDRESS).await?);
            if status.new_data() {
                break status;
            }
            if waited_us >= limit_us {
                let control = self.read_control().await?;
                if !self.holds_config(control) {
                    return Err(Error::ControlReset { read: control.0 });
                }
                return Err(Error::Stale {
                    waited_ms: waited_us / 1000,
                });
            }
            self.delay.delay_us(poll_us).await;
            waited_us += poll_us;
        };
        self.write_word(Status::ADDRESS, Status::CLEAR).await?;
        self.read_words(RAM_START, &mut frame.words[..PIXELS])
            .await?;
        self.read_words(AUX_START, &mut frame.words[PIXELS..PIXELS + AUX_WORDS])
            .await?;
        frame.words[IDX_CONTROL] = self.read_word(Control::ADDRESS).await?;
        let sp = status.subpage();
        frame.words[IDX_SUBPAGE] = sp as u16;
        if Status(self.read_word(Status::ADDRESS).await?).new_data() {
            return Err(Error::Overwritten { subpage: sp });
        }
        if !self.holds_config(frame.control()) {
            return Err(Error::ControlReset {
                read: frame.words[IDX_CONTROL],
            });
        }
        if let Some(index) = frame.find_invalid_marker() {
            return Err(FrameError::InvalidMarker {
                index: index as u16,
            }
            .into());
        }
        Ok(())
    }
}
