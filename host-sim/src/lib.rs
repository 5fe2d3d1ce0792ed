//! Thermorph's simulator library: models that stand in for the board's peripherals.
//!
//! - [`desk`]: the researcher's desk, `thermorph-desk`: console, recorder, scripts, plots.
//! - [`dump`]: reading MLX90640 EEPROM and frame dumps (the shared test-data format).
//! - [`console`]: `host-sim console`, the block behind the board's console (stdin or a pty).
//! - [`data`]: where the shared sensor dumps live.
//! - [`eeprom`]: MLX90640 EEPROM fields, their exact encoding, a realistic sensor.
//! - [`mtts_cli`]: MTTS on image files, scenes as image files.
//! - [`mtts_wp`]: the MTTS work-precision table (`host-sim mtts-wp`).
//! - [`paper`]: `host-sim paper`, the thesis's experiments against the real supervisor.
//! - [`plant`]: the simulated block: thermal network, SMA springs, SMP lattice, bending.
//! - [`plot`]: the PNG plot of a run.
//! - [`run`]: `host-sim run`, a scene played against the plant, and its outputs.
//! - [`scenario`]: scene files (TOML) and the bundled scenes.
//! - [`scene`]: the camera's view of the block, with ground truth.
//! - [`scene_family`]: randomized views of the block through the MLX90640 optics (MTTS robustness).
//! - [`sim_time`]: the simulated clock and delay.
//! - [`to_roots`]: root variants of the To calculation and its f64 reference.
//! - [`virtual_mlx`]: the virtual MLX90640 on a simulated I2C bus.

pub mod console;
pub mod data;
pub mod decode;
pub mod desk;
pub mod dump;
pub mod eeprom;
pub mod mtts_cli;
pub mod mtts_wp;
pub mod paper;
pub mod plant;
pub mod plot;
pub mod run;
pub mod scenario;
pub mod scene;
pub mod scene_family;
pub mod sensor_demo;
pub mod sim_time;
pub mod to_roots;
pub mod virtual_mlx;
