//! Sensing tools and tables: what renders and judges the camera's view, and the work-precision
//! tables of the sensing math.
//!
//! - [`scene`]: the camera's view of the block, with ground truth (the standard scenes).
//! - [`scene_family`]: randomized views through the MLX90640 optics (MTTS robustness).
//! - [`mtts_cli`]: MTTS on image files, scenes as image files (`host-sim mtts`, `scene`).
//! - [`mtts_wp`]: the MTTS work-precision table (`host-sim mtts-wp`).
//! - [`to_roots`]: root variants of the To calculation and its f64 reference.
//! - [`dump`]: reading MLX90640 EEPROM and frame dumps (the shared test-data format).
//! - [`decode`]: `host-sim decode`, the dumps through the firmware's calculation.
//! - [`data`]: where the shared sensor dumps live.

pub mod data;
pub mod decode;
pub mod dump;
pub mod mtts_cli;
pub mod mtts_wp;
pub mod scene;
pub mod scene_family;
pub mod to_roots;
