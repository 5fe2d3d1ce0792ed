//! The virtual sensor: what stands in for the MLX90640 on the board's I2C bus.
//!
//! - [`virtual_mlx`]: the virtual MLX90640 on a simulated I2C bus (faults, a bus stuck low,
//!   power cycles), read by the firmware's own driver.
//! - [`eeprom`]: MLX90640 EEPROM fields, their exact encoding, a realistic sensor.
//! - [`sim_time`]: the simulated clock and delay the driver waits on.
//! - [`demo`]: `host-sim sensor`, the sensor chain alone against a fixed scene.

pub mod demo;
pub mod eeprom;
pub mod sim_time;
pub mod virtual_mlx;
