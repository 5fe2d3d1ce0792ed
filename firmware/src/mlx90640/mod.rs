//! The MLX90640 32×24 thermal camera: everything from EEPROM words to a Kelvin image.
//!
//! Four parts, as the Melexis datasheet (Rev. 12) and reference library (`mlx90640-library`,
//! API at commit f6be7ca) describe the device:
//! - [`register`]: the status and control registers as types carrying their address and fields;
//! - [`calibration`]: [`Calibration::from_eeprom`], a pure function of the 832 EEPROM words;
//! - [`calc`]: the per-subpage temperature calculation (Vdd, Ta, To with emissivity, reflected
//!   temperature and the extended ranges), subpage merging and bad-pixel correction;
//! - [`driver`]: a thin async driver over `embedded_hal_async::i2c::I2c` with a timeout on every
//!   bus call and subpage checks (new data, stale, overwritten during the read, corrupt, lost
//!   configuration); the policy over subpages is [`crate::sensing`]'s.

pub mod calc;
pub mod calibration;
pub mod driver;
pub mod register;

pub use calc::{
    DecodeParams, FrameError, HardwareRoots, Image, ImageStats, Roots, SubpageFrame, SubpageInfo,
    calculate_to_with,
};
pub use calibration::{Calibration, CalibrationError};
pub use driver::{Config, Error, Mlx90640};
pub use register::{Control, ReadingPattern, RefreshRate, Resolution, Status};

/// Default 7-bit I2C address.
pub const ADDRESS: u8 = 0x33;
/// Number of pixel rows.
pub const ROWS: usize = 24;
/// Number of pixel columns.
pub const COLS: usize = 32;
/// Number of pixels.
pub const PIXELS: usize = ROWS * COLS;
/// First EEPROM address.
pub const EEPROM_START: u16 = 0x2400;
/// Number of EEPROM words.
pub const EEPROM_WORDS: usize = 832;
/// First RAM address (pixel data).
pub const RAM_START: u16 = 0x0400;
/// First auxiliary RAM address (Ta, Vdd, gain and compensation-pixel data).
pub const AUX_START: u16 = 0x0700;
/// Number of auxiliary RAM words.
pub const AUX_WORDS: usize = 64;
/// Words in one subpage frame: 768 pixels, 64 aux words, the control register, the subpage.
pub const FRAME_WORDS: usize = PIXELS + AUX_WORDS + 2;
