//! `host-sim decode`: decode MLX90640 dumps with the firmware's own calculation, print CSV.

use std::io::Write;
use std::path::{Path, PathBuf};

use thermorph::mlx90640::{Calibration, DecodeParams, Image, PIXELS};

use crate::imaging::SensingError;
use crate::imaging::dump::{read_eeprom, read_frame};

/// Decode `frames` (in order, merged into one image) with the calibration in `eeprom` and
/// return the image; errors name the file at fault.
pub fn decode_files(
    eeprom: &Path,
    frames: &[PathBuf],
    params: &DecodeParams,
) -> Result<Image, SensingError> {
    if !(params.emissivity > 0.0 && params.emissivity <= 1.0) {
        return Err(SensingError::Emissivity(params.emissivity));
    }
    if !params.ta_shift_k.is_finite() {
        return Err(SensingError::TaShift);
    }
    let words = read_eeprom(eeprom)?;
    let cal = Calibration::from_eeprom(&words).map_err(|err| SensingError::Calibration {
        file: eeprom.display().to_string(),
        err,
    })?;
    let mut image = Image::new();
    for f in frames {
        let frame = read_frame(f)?;
        image
            .update(&frame, &cal, params)
            .map_err(|err| SensingError::Frame {
                file: f.display().to_string(),
                err,
            })?;
    }
    Ok(image)
}

/// Write the image as CSV `pixel,row,col,value` (°C, 6 decimals, `nan` where uncovered).
pub fn write_csv(image: &Image, out: &mut impl Write) -> std::io::Result<()> {
    writeln!(out, "pixel,row,col,value")?;
    for p in 0..PIXELS {
        let t = image.to_k[p];
        if t.is_finite() {
            writeln!(out, "{p},{},{},{:.6}", p / 32, p % 32, t as f64 - 273.15)?;
        } else {
            writeln!(out, "{p},{},{},nan", p / 32, p % 32)?;
        }
    }
    Ok(())
}
