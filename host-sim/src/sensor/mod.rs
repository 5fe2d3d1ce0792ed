//! The virtual sensor: what stands in for the MLX90640 on the board's I2C bus.
//!
//! - [`virtual_mlx`]: the virtual MLX90640 on a simulated I2C bus (faults, a bus stuck low,
//!   power cycles), read by the firmware's own driver.
//! - [`eeprom`]: MLX90640 EEPROM fields, their exact encoding, a realistic sensor.
//! - [`sim_time`]: the simulated clock and delay the driver waits on.
//! - [`demo`]: `host-sim sensor`, the sensor chain alone against a fixed scene.
//!
//! This module owns the virtual sensor's error type, [`SensorError`] (EEPROM images that do not
//! encode, a calibration the virtual sensor refuses, the firmware driver's errors).

pub mod demo;
pub mod eeprom;
pub mod sim_time;
pub mod virtual_mlx;

use thermorph::mlx90640::{CalibrationError, Error as DriverError};

/// Why a virtual sensor (or the firmware's driver reading it) could not be set up or read.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SensorError {
    /// The EEPROM fields do not encode.
    #[error(transparent)]
    Eeprom(#[from] eeprom::EepromError),
    /// The virtual sensor refuses the EEPROM's calibration.
    #[error("virtual sensor: {0}")]
    VirtualSensor(CalibrationError),
    /// The firmware's driver failed (calibrate, configure, read).
    #[error("{0}")]
    Driver(DriverError),
    /// No standard scene of that name.
    #[error("no scene `{0}`")]
    UnknownScene(String),
}
