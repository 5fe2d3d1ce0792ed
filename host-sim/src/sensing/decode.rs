//! `host-sim decode`: decode MLX90640 dumps with the firmware's own calculation, print CSV.

use std::io::Write;
use std::path::{Path, PathBuf};

use thermorph::mlx90640::{Calibration, DecodeParams, Image, PIXELS};

use crate::sensing::dump::{read_eeprom, read_frame};

/// Decode `frames` (in order, merged into one image) with the calibration in `eeprom` and
/// return the image; errors name the file at fault.
pub fn decode_files(
    eeprom: &Path,
    frames: &[PathBuf],
    params: &DecodeParams,
) -> Result<Image, String> {
    if !(params.emissivity > 0.0 && params.emissivity <= 1.0) {
        return Err(format!(
            "emissivity {} is outside (0, 1]",
            params.emissivity
        ));
    }
    if !params.ta_shift_k.is_finite() {
        return Err("the Ta shift must be a finite number of kelvin".into());
    }
    let words = read_eeprom(eeprom).map_err(|e| e.to_string())?;
    let cal = Calibration::from_eeprom(&words).map_err(|e| format!("{}: {e}", eeprom.display()))?;
    let mut image = Image::new();
    for f in frames {
        let frame = read_frame(f).map_err(|e| e.to_string())?;
        image
            .update(&frame, &cal, params)
            .map_err(|e| format!("{}: {e}", f.display()))?;
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
