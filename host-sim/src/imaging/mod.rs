//! Imaging: the camera's images on the host — what renders and judges the camera's view, real
//! dumps decoded, and the work-precision tables of the sensing math. (The firmware's sensing
//! pipeline is `thermorph::sensing`; this is the simulator's side of the camera.)
//!
//! - [`view`]: the camera's view of the block rendered, with ground truth (the twelve standard
//!   scenes: a *scene* here is one rendered image; a scene file, a whole run, is
//!   [`crate::runs::scenario`]).
//! - [`view_family`]: randomized views through the MLX90640 optics (MTTS robustness).
//! - [`view_limit`]: what a family member's view holds about T1 and T2 (the Cramér–Rao bound).
//! - [`mtts_cli`]: MTTS on image files, scenes as image files (`host-sim mtts`, `scene`).
//! - [`mtts_wp`]: the MTTS work-precision table (`host-sim mtts-wp`).
//! - [`to_roots`]: root variants of the To calculation and its f64 reference.
//! - [`dump`]: reading MLX90640 EEPROM and frame dumps (the shared test-data format).
//! - [`decode`]: `host-sim decode`, the dumps through the firmware's calculation.
//! - [`data`]: where the shared sensor dumps live.
//!
//! This module owns the sensing tools' error type, [`SensingError`] (image and dump files,
//! decoding, MTTS, bench-m4 counts); a dump file's own refusal is [`dump::DumpError`].

pub mod data;
pub mod decode;
pub mod dump;
pub mod mtts_cli;
pub mod mtts_wp;
pub mod to_roots;
pub mod view;
pub mod view_family;
pub mod view_limit;

use std::path::PathBuf;

use thermorph::mlx90640::{CalibrationError, FrameError};
use thermorph::mtts::{IMG_COLS, IMG_PIXELS, IMG_ROWS, MttsError};

use crate::sensor::SensorError;

/// Why a sensing tool could not read its input or compute its result.
#[derive(Debug, thiserror::Error)]
pub enum SensingError {
    /// An image CSV has a row too many.
    #[error("line {line}: more than {IMG_ROWS} rows")]
    TooManyRows {
        /// The line, 1-based.
        line: usize,
    },
    /// An image CSV row has the wrong number of values.
    #[error("line {line}: {values} values, a row needs {IMG_COLS}")]
    RowLength {
        /// The line, 1-based.
        line: usize,
        /// The values it has.
        values: usize,
    },
    /// An image CSV cell is not a number.
    #[error("line {line}, column {column}: `{cell}` is not a number")]
    NotANumber {
        /// The line, 1-based.
        line: usize,
        /// The column, 1-based.
        column: usize,
        /// The cell's text.
        cell: String,
    },
    /// An image CSV has too few rows.
    #[error("{rows} rows, an image needs {IMG_ROWS}")]
    RowCount {
        /// The rows it has.
        rows: usize,
    },
    /// A line of a `host-sim decode` CSV that is not `pixel,row,col,value` (or repeats a
    /// pixel, or puts it in the wrong row or column).
    #[error("line {line}: `{text}` is not a `pixel,row,col,value` line of `host-sim decode`")]
    DecodedLine {
        /// The line, 1-based.
        line: usize,
        /// Its text.
        text: String,
    },
    /// A `host-sim decode` CSV without every pixel.
    #[error("{pixels} pixels, an image needs {IMG_PIXELS}")]
    DecodedPixels {
        /// The pixels it has.
        pixels: usize,
    },
    /// An unknown clustering method name.
    #[error("method `{0}` is not exact, lloyd or kmeanspp")]
    UnknownMethod(String),
    /// An unknown prior name.
    #[error("prior `{0}` is not unknown, heater-hotter or surface-hotter")]
    UnknownPrior(String),
    /// An emissivity outside (0, 1].
    #[error("emissivity {0} is outside (0, 1]")]
    Emissivity(f32),
    /// A Ta shift that is not finite.
    #[error("the Ta shift must be a finite number of kelvin")]
    TaShift,
    /// A dump file is refused.
    #[error(transparent)]
    Dump(#[from] dump::DumpError),
    /// A file cannot be read.
    #[error("{}: cannot read: {err}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        err: std::io::Error,
    },
    /// A file's contents are refused.
    #[error("{}: {err}", path.display())]
    InFile {
        /// The file.
        path: PathBuf,
        /// What is wrong in it.
        err: Box<SensingError>,
    },
    /// An EEPROM dump's calibration is refused.
    #[error("{file}: {err}")]
    Calibration {
        /// The dump's name.
        file: String,
        /// Why.
        err: CalibrationError,
    },
    /// A frame dump does not decode.
    #[error("{file}: {err}")]
    Frame {
        /// The dump's name.
        file: String,
        /// Why.
        err: FrameError,
    },
    /// The virtual sensor could not be set up.
    #[error(transparent)]
    Sensor(#[from] SensorError),
    /// MTTS refused its configuration or an image.
    #[error("{0}")]
    Mtts(MttsError),
    /// Inpainting a scene's image failed.
    #[error("{scene}: {err}")]
    Inpaint {
        /// The scene's name.
        scene: &'static str,
        /// Why.
        err: MttsError,
    },
    /// A malformed `wp_` line of a bench-m4 output.
    #[error("line {line}: malformed `{text}`")]
    M4Line {
        /// The line, 1-based.
        line: usize,
        /// Its text.
        text: String,
    },
    /// A text without `wp_mtts` lines.
    #[error("no `wp_mtts` lines: not a scripts/bench-m4 output")]
    NotM4,
    /// No count for a work-precision row.
    #[error("no `wp_mtts scale={scale} method={method}` line")]
    NoMttsCount {
        /// The upsampling factor.
        scale: u8,
        /// The method's name.
        method: &'static str,
    },
    /// No count for a roots variant.
    #[error("no `wp_roots variant={0}` line")]
    NoRootsCount(String),
}
