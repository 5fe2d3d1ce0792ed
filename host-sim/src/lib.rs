//! Thermorph's simulator library: models that stand in for the board's peripherals.
//!
//! - [`dump`]: reading MLX90640 EEPROM and frame dumps (the shared test-data format).
//! - [`data`]: where the shared sensor dumps live.

pub mod data;
pub mod dump;
