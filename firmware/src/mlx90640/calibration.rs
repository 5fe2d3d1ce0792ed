//! Calibration parameters extracted from the MLX90640's 832 EEPROM words.
//!
//! [`Calibration::from_eeprom`] is a faithful port of the Melexis reference library's
//! `MLX90640_ExtractParameters` (mlx90640-library, commit f6be7ca; datasheet Rev. 12 §11.1):
//! the same fields, the same integer and float steps (the few steps the library does in
//! `double` are done in `f64` here too, so the quantised per-pixel `alpha`, `kta` and `kv`
//! come out bit for bit the same), and the same refusals (too many broken or outlier pixels,
//! adjacent bad pixels). Two departures, both on EEPROMs the library would hang or divide by
//! zero on: all-zero `kta`/`kv` tables give scale 0 instead of an endless loop, and a
//! non-positive alpha, a zero `kVdd`, `KtPTAT` or `gainEE` are refused as
//! [`CalibrationError::BadEepromData`].
//!
//! RAM: `size_of::<Calibration>()` is 4 724 bytes (768 × (2 + 2 + 1 + 1) bytes of per-pixel
//! data plus 116 bytes of scalars) — checked by a test.

use super::{COLS, EEPROM_WORDS, PIXELS, ROWS};
use crate::fmath::pow2_f64;

/// Most broken or outlier pixels the reference library accepts (together).
pub const MAX_BAD_PIXELS: usize = 4;

/// Why an EEPROM was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum CalibrationError {
    /// More than four broken pixels (pixel word zero); library error −3.
    TooManyBrokenPixels,
    /// More than four outlier pixels (pixel word bit 0 set); library error −4.
    TooManyOutlierPixels,
    /// More than four broken and outlier pixels together; library error −5.
    TooManyBadPixels,
    /// Two bad pixels touch (including diagonally); library error −6.
    AdjacentBadPixels {
        /// First pixel index (row × 32 + column).
        first: u16,
        /// Second pixel index.
        second: u16,
    },
    /// A field would make the calculation divide by zero or never terminate.
    BadEepromData {
        /// EEPROM word offset (0 = address 0x2400) holding the bad field.
        word: u16,
    },
}

impl core::fmt::Display for CalibrationError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Self::TooManyBrokenPixels => write!(f, "EEPROM refused: more than 4 broken pixels"),
            Self::TooManyOutlierPixels => write!(f, "EEPROM refused: more than 4 outlier pixels"),
            Self::TooManyBadPixels => {
                write!(f, "EEPROM refused: more than 4 broken and outlier pixels")
            }
            Self::AdjacentBadPixels { first, second } => write!(
                f,
                "EEPROM refused: bad pixels {first} and {second} are adjacent"
            ),
            Self::BadEepromData { word } => write!(
                f,
                "EEPROM refused: unusable calibration field at 0x{:04X}",
                0x2400 + word as u32
            ),
        }
    }
}

/// A short list of pixel indices (broken or outlier pixels), at most [`MAX_BAD_PIXELS`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct PixelList {
    idx: [u16; MAX_BAD_PIXELS],
    len: u8,
}

impl PixelList {
    /// Return the pixel indices.
    pub fn as_slice(&self) -> &[u16] {
        &self.idx[..self.len as usize]
    }

    /// Return whether `pixel` is in the list.
    pub fn contains(&self, pixel: u16) -> bool {
        self.as_slice().contains(&pixel)
    }

    fn push(&mut self, pixel: u16) {
        if (self.len as usize) < MAX_BAD_PIXELS {
            self.idx[self.len as usize] = pixel;
            self.len += 1;
        }
    }
}

/// Every parameter the reference library extracts, with its names (datasheet symbols).
#[derive(Clone, Debug, PartialEq)]
pub struct Calibration {
    /// Vdd sensitivity, LSB/V (datasheet K_Vdd).
    pub k_vdd: i16,
    /// Vdd ADC value at 25 °C and 3.3 V (datasheet VDD_25).
    pub vdd25: i16,
    /// PTAT supply sensitivity, 1/V (K_V_PTAT).
    pub kv_ptat: f32,
    /// PTAT temperature sensitivity, LSB/°C (K_T_PTAT).
    pub kt_ptat: f32,
    /// PTAT at 25 °C (V_PTAT25).
    pub v_ptat25: u16,
    /// PTAT scaling (Alpha_PTAT).
    pub alpha_ptat: f32,
    /// Gain reference (GAIN).
    pub gain_ee: i16,
    /// Thermal gradient coefficient (TGC).
    pub tgc: f32,
    /// Compensation pixel supply coefficient (K_V_CP).
    pub cp_kv: f32,
    /// Compensation pixel temperature coefficient (K_Ta_CP).
    pub cp_kta: f32,
    /// ADC resolution at calibration (0–3 for 16–19 bit).
    pub resolution_ee: u8,
    /// Calibration reading pattern in the library's coding (0x80 chess, 0 interleaved).
    pub calibration_mode_ee: u8,
    /// Ambient sensitivity of alpha (KsTa), 1/°C.
    pub ks_ta: f32,
    /// Object sensitivity of alpha per temperature range (KsTo), 1/°C.
    pub ks_to: [f32; 5],
    /// Corner temperatures of the ranges (CT), °C.
    pub ct: [i16; 5],
    /// Per-pixel `1e-6 / alpha`, scaled by 2^`alpha_scale` and rounded (library coding).
    pub alpha: [u16; PIXELS],
    /// Scale of `alpha`.
    pub alpha_scale: u8,
    /// Per-pixel offset (pix_OS_ref), LSB.
    pub offset: [i16; PIXELS],
    /// Per-pixel Kta scaled by 2^`kta_scale`.
    pub kta: [i8; PIXELS],
    /// Scale of `kta`.
    pub kta_scale: u8,
    /// Per-pixel Kv scaled by 2^`kv_scale`.
    pub kv: [i8; PIXELS],
    /// Scale of `kv`.
    pub kv_scale: u8,
    /// Compensation pixel sensitivities, subpages 0 and 1.
    pub cp_alpha: [f32; 2],
    /// Compensation pixel offsets, subpages 0 and 1.
    pub cp_offset: [i16; 2],
    /// Interleaved/chess corrections (IL_CHESS_C1..3).
    pub il_chess_c: [f32; 3],
    /// Broken pixels (pixel word 0).
    pub broken_pixels: PixelList,
    /// Outlier pixels (pixel word bit 0).
    pub outlier_pixels: PixelList,
}

impl Default for Calibration {
    fn default() -> Self {
        Self::new()
    }
}

fn nib1(w: u16) -> i32 {
    (w & 0x000F) as i32
}
fn nib2(w: u16) -> i32 {
    ((w & 0x00F0) >> 4) as i32
}
fn nib3(w: u16) -> i32 {
    ((w & 0x0F00) >> 8) as i32
}
fn nib4(w: u16) -> i32 {
    ((w & 0xF000) >> 12) as i32
}
fn ms_byte(w: u16) -> u8 {
    (w >> 8) as u8
}
fn ls_byte(w: u16) -> u8 {
    (w & 0xFF) as u8
}
/// Two's complement of an `n`-bit field.
fn signed(v: i32, bits: u32) -> i32 {
    let half = 1 << (bits - 1);
    if v >= half { v - (1 << bits) } else { v }
}
/// Signed 4-bit nibbles `[n1, n2, n3, n4]` of `count` consecutive words, as the library's
/// accRow/accColumn/occRow/occColumn tables.
fn nibble_table<const N: usize>(ee: &[u16; EEPROM_WORDS], first: usize) -> [i32; N] {
    let mut t = [0i32; N];
    for (i, v) in t.iter_mut().enumerate() {
        let w = ee[first + i / 4];
        let n = match i % 4 {
            0 => nib1(w),
            1 => nib2(w),
            2 => nib3(w),
            _ => nib4(w),
        };
        *v = signed(n, 4);
    }
    t
}
/// Index into the 4-entry row/column-parity tables (KtaRC, KvT) as the library computes it.
fn split(p: usize) -> usize {
    2 * (p / 32 - (p / 64) * 2) + p % 2
}

impl Calibration {
    /// Return an all-zero calibration (storage to fill with [`Calibration::extract`]).
    pub const fn new() -> Self {
        Calibration {
            k_vdd: 0,
            vdd25: 0,
            kv_ptat: 0.0,
            kt_ptat: 0.0,
            v_ptat25: 0,
            alpha_ptat: 0.0,
            gain_ee: 0,
            tgc: 0.0,
            cp_kv: 0.0,
            cp_kta: 0.0,
            resolution_ee: 0,
            calibration_mode_ee: 0,
            ks_ta: 0.0,
            ks_to: [0.0; 5],
            ct: [0; 5],
            alpha: [0; PIXELS],
            alpha_scale: 0,
            offset: [0; PIXELS],
            kta: [0; PIXELS],
            kta_scale: 0,
            kv: [0; PIXELS],
            kv_scale: 0,
            cp_alpha: [0.0; 2],
            cp_offset: [0; 2],
            il_chess_c: [0.0; 3],
            broken_pixels: PixelList {
                idx: [0; MAX_BAD_PIXELS],
                len: 0,
            },
            outlier_pixels: PixelList {
                idx: [0; MAX_BAD_PIXELS],
                len: 0,
            },
        }
    }

    /// Extract a calibration from the EEPROM words (0x2400–0x273F), or refuse the EEPROM.
    ///
    /// Builds on the stack (≈ 5 KB plus 3 KB scratch); on the target prefer
    /// [`Calibration::extract`] into static storage.
    pub fn from_eeprom(ee: &[u16; EEPROM_WORDS]) -> Result<Self, CalibrationError> {
        let mut cal = Self::new();
        cal.extract(ee)?;
        Ok(cal)
    }

    /// Fill `self` from the EEPROM words, in place; on error `self` holds a partial extraction
    /// and must not be used.
    pub fn extract(&mut self, ee: &[u16; EEPROM_WORDS]) -> Result<(), CalibrationError> {
        self.extract_vdd(ee);
        self.extract_ptat(ee);
        self.gain_ee = ee[48] as i16;
        self.tgc = (ls_byte(ee[60]) as i8) as f32 / 32.0;
        self.resolution_ee = ((ee[56] & 0x3000) >> 12) as u8;
        self.ks_ta = (ms_byte(ee[60]) as i8) as f32 / 8192.0;
        self.extract_ks_to(ee);
        self.extract_cp(ee);
        self.extract_alpha(ee)?;
        self.extract_offset(ee);
        self.extract_kta(ee);
        self.extract_kv(ee);
        self.extract_cilc(ee);
        if self.k_vdd == 0 {
            return Err(CalibrationError::BadEepromData { word: 51 });
        }
        if self.kt_ptat == 0.0 {
            return Err(CalibrationError::BadEepromData { word: 50 });
        }
        if self.gain_ee == 0 {
            return Err(CalibrationError::BadEepromData { word: 48 });
        }
        self.extract_deviating_pixels(ee)
    }

    fn extract_vdd(&mut self, ee: &[u16; EEPROM_WORDS]) {
        let k_vdd = ms_byte(ee[51]) as i8;
        let vdd25 = ls_byte(ee[51]) as i32;
        self.k_vdd = 32 * k_vdd as i16;
        self.vdd25 = (((vdd25 - 256) << 5) - 8192) as i16;
    }

    fn extract_ptat(&mut self, ee: &[u16; EEPROM_WORDS]) {
        let kv = signed(((ee[50] & 0xFC00) >> 10) as i32, 6);
        self.kv_ptat = kv as f32 / 4096.0;
        let kt = signed((ee[50] & 0x03FF) as i32, 10);
        self.kt_ptat = kt as f32 / 8.0;
        self.v_ptat25 = ee[49];
        self.alpha_ptat = (((ee[16] & 0xF000) as f64) / pow2_f64(14) + 8.0) as f32;
    }

    fn extract_ks_to(&mut self, ee: &[u16; EEPROM_WORDS]) {
        let step = (((ee[63] & 0x3000) >> 12) * 10) as i16;
        self.ct[0] = -40;
        self.ct[1] = 0;
        self.ct[2] = nib2(ee[63]) as i16 * step;
        self.ct[3] = self.ct[2] + nib3(ee[63]) as i16 * step;
        self.ct[4] = 400;
        let scale = (1u32 << (nib1(ee[63]) + 8)) as f32;
        self.ks_to[0] = (ls_byte(ee[61]) as i8) as f32 / scale;
        self.ks_to[1] = (ms_byte(ee[61]) as i8) as f32 / scale;
        self.ks_to[2] = (ls_byte(ee[62]) as i8) as f32 / scale;
        self.ks_to[3] = (ms_byte(ee[62]) as i8) as f32 / scale;
        self.ks_to[4] = -0.0002;
    }

    fn extract_cp(&mut self, ee: &[u16; EEPROM_WORDS]) {
        let alpha_scale = nib4(ee[32]) + 27;
        let off0 = signed((ee[58] & 0x03FF) as i32, 10);
        let off1 = signed(((ee[58] & 0xFC00) >> 10) as i32, 6) + off0;
        let a0 = signed((ee[57] & 0x03FF) as i32, 10) as f64 / pow2_f64(alpha_scale);
        let a0 = a0 as f32;
        let a1 = signed(((ee[57] & 0xFC00) >> 10) as i32, 6) as f32;
        let a1 = (1.0 + a1 / 128.0) * a0;
        let kta_scale1 = nib2(ee[56]) + 8;
        self.cp_kta = ((ls_byte(ee[59]) as i8) as f64 / pow2_f64(kta_scale1)) as f32;
        let kv_scale = nib3(ee[56]);
        self.cp_kv = ((ms_byte(ee[59]) as i8) as f64 / pow2_f64(kv_scale)) as f32;
        self.cp_alpha = [a0, a1];
        self.cp_offset = [off0 as i16, off1 as i16];
    }

    fn extract_alpha(&mut self, ee: &[u16; EEPROM_WORDS]) -> Result<(), CalibrationError> {
        let acc_rem_scale = nib1(ee[32]);
        let acc_column_scale = nib2(ee[32]);
        let acc_row_scale = nib3(ee[32]);
        let alpha_scale = nib4(ee[32]) + 30;
        let alpha_ref = ee[33] as i32;
        let acc_row: [i32; ROWS] = nibble_table(ee, 34);
        let acc_col: [i32; COLS] = nibble_table(ee, 40);
        let cp_mean = self.tgc * (self.cp_alpha[0] + self.cp_alpha[1]) / 2.0;
        // The library keeps this scratch table in f32 (`float alphaTemp[768]`).
        let mut tmp = [0f32; PIXELS];
        for (p, t) in tmp.iter_mut().enumerate() {
            let (i, j) = (p / COLS, p % COLS);
            let a = signed(((ee[64 + p] & 0x03F0) >> 4) as i32, 6) * (1 << acc_rem_scale);
            let a = (alpha_ref
                + acc_row[i] * (1 << acc_row_scale)
                + acc_col[j] * (1 << acc_column_scale)
                + a) as f32;
            let a = ((a as f64) / pow2_f64(alpha_scale)) as f32;
            let a = a - cp_mean;
            if a.is_nan() || a <= 0.0 {
                return Err(CalibrationError::BadEepromData {
                    word: (64 + p) as u16,
                });
            }
            *t = (1e-6f64 / a as f64) as f32;
        }
        let mut temp = tmp.iter().copied().fold(tmp[0], f32::max);
        let mut scale = 0u8;
        while (temp as f64) < 32767.4 {
            temp *= 2.0;
            scale += 1;
        }
        for (dst, &t) in self.alpha.iter_mut().zip(tmp.iter()) {
            let v = ((t as f64) * pow2_f64(scale as i32)) as f32;
            *dst = (v as f64 + 0.5) as u16;
        }
        self.alpha_scale = scale;
        Ok(())
    }

    fn extract_offset(&mut self, ee: &[u16; EEPROM_WORDS]) {
        let occ_rem_scale = nib1(ee[16]);
        let occ_column_scale = nib2(ee[16]);
        let occ_row_scale = nib3(ee[16]);
        let offset_ref = ee[17] as i16 as i32;
        let occ_row: [i32; ROWS] = nibble_table(ee, 18);
        let occ_col: [i32; COLS] = nibble_table(ee, 24);
        for (p, dst) in self.offset.iter_mut().enumerate() {
            let (i, j) = (p / COLS, p % COLS);
            let o = signed(((ee[64 + p] & 0xFC00) >> 10) as i32, 6) * (1 << occ_rem_scale);
            let o = offset_ref
                + occ_row[i] * (1 << occ_row_scale)
                + occ_col[j] * (1 << occ_column_scale)
                + o;
            *dst = o as i16;
        }
    }

    fn extract_kta(&mut self, ee: &[u16; EEPROM_WORDS]) {
        let kta_rc = [
            ms_byte(ee[54]) as i8 as i32,
            ms_byte(ee[55]) as i8 as i32,
            ls_byte(ee[54]) as i8 as i32,
            ls_byte(ee[55]) as i8 as i32,
        ];
        let scale1 = nib2(ee[56]) + 8;
        let scale2 = nib1(ee[56]);
        let mut tmp = [0f32; PIXELS];
        for (p, t) in tmp.iter_mut().enumerate() {
            let k = signed(((ee[64 + p] & 0x000E) >> 1) as i32, 3) * (1 << scale2);
            let k = (kta_rc[split(p)] + k) as f32;
            *t = ((k as f64) / pow2_f64(scale1)) as f32;
        }
        self.kta_scale = requantise_i8(&tmp, &mut self.kta);
    }

    fn extract_kv(&mut self, ee: &[u16; EEPROM_WORDS]) {
        let kv_t = [
            signed(nib4(ee[52]), 4),
            signed(nib2(ee[52]), 4),
            signed(nib3(ee[52]), 4),
            signed(nib1(ee[52]), 4),
        ];
        let scale = nib3(ee[56]);
        let mut tmp = [0f32; PIXELS];
        for (p, t) in tmp.iter_mut().enumerate() {
            *t = ((kv_t[split(p)] as f32 as f64) / pow2_f64(scale)) as f32;
        }
        self.kv_scale = requantise_i8(&tmp, &mut self.kv);
    }

    fn extract_cilc(&mut self, ee: &[u16; EEPROM_WORDS]) {
        self.calibration_mode_ee = (((ee[10] & 0x0800) >> 4) as u8) ^ 0x80;
        let c0 = signed((ee[53] & 0x003F) as i32, 6) as f32 / 16.0;
        let c1 = signed(((ee[53] & 0x07C0) >> 6) as i32, 5) as f32 / 2.0;
        let c2 = signed(((ee[53] & 0xF800) >> 11) as i32, 5) as f32 / 8.0;
        self.il_chess_c = [c0, c1, c2];
    }

    fn extract_deviating_pixels(
        &mut self,
        ee: &[u16; EEPROM_WORDS],
    ) -> Result<(), CalibrationError> {
        let mut broken = PixelList::default();
        let mut outliers = PixelList::default();
        let (mut n_broken, mut n_outliers) = (0usize, 0usize);
        let mut p = 0;
        while p < PIXELS && n_broken < 5 && n_outliers < 5 {
            let w = ee[64 + p];
            if w == 0 {
                broken.push(p as u16);
                n_broken += 1;
            } else if w & 1 != 0 {
                outliers.push(p as u16);
                n_outliers += 1;
            }
            p += 1;
        }
        self.broken_pixels = broken;
        self.outlier_pixels = outliers;
        if n_broken > MAX_BAD_PIXELS {
            return Err(CalibrationError::TooManyBrokenPixels);
        }
        if n_outliers > MAX_BAD_PIXELS {
            return Err(CalibrationError::TooManyOutlierPixels);
        }
        if n_broken + n_outliers > MAX_BAD_PIXELS {
            return Err(CalibrationError::TooManyBadPixels);
        }
        let b = broken.as_slice();
        let o = outliers.as_slice();
        for (i, &x) in b.iter().enumerate() {
            for &y in &b[i + 1..] {
                check_adjacent(x, y)?;
            }
        }
        for (i, &x) in o.iter().enumerate() {
            for &y in &o[i + 1..] {
                check_adjacent(x, y)?;
            }
        }
        for &x in b {
            for &y in o {
                check_adjacent(x, y)?;
            }
        }
        Ok(())
    }

    /// Return whether pixel `p` is broken or an outlier.
    pub fn is_bad_pixel(&self, p: u16) -> bool {
        self.broken_pixels.contains(p) || self.outlier_pixels.contains(p)
    }

    /// Return pixel `p`'s sensitivity alpha (1/LSB·K⁻⁴ scaled as the datasheet), as the
    /// temperature calculation uses it (before the KsTa correction).
    pub fn alpha_of(&self, p: usize) -> f32 {
        crate::fmath::pow2(self.alpha_scale as i32) * 1e-6 / self.alpha[p] as f32
    }

    /// Return pixel `p`'s Kta, 1/°C.
    pub fn kta_of(&self, p: usize) -> f32 {
        self.kta[p] as f32 / crate::fmath::pow2(self.kta_scale as i32)
    }

    /// Return pixel `p`'s Kv, 1/V.
    pub fn kv_of(&self, p: usize) -> f32 {
        self.kv[p] as f32 / crate::fmath::pow2(self.kv_scale as i32)
    }
}

/// Requantise a table to `i8` with the largest power-of-two scale that keeps |value| below
/// 63.4 · 2 (the library's `ktaScale`/`kvScale` step); return the scale.
fn requantise_i8(tmp: &[f32; PIXELS], out: &mut [i8; PIXELS]) -> u8 {
    let mut temp = tmp
        .iter()
        .fold(libm::fabsf(tmp[0]), |m, v| m.max(libm::fabsf(*v)));
    let mut scale = 0u8;
    // The library loops forever on an all-zero table; stop at scale 0 instead.
    if temp > 0.0 {
        while (temp as f64) < 63.4 {
            temp *= 2.0;
            scale += 1;
        }
    }
    for (dst, &t) in out.iter_mut().zip(tmp.iter()) {
        let v = ((t as f64) * pow2_f64(scale as i32)) as f32;
        *dst = if v < 0.0 {
            (v as f64 - 0.5) as i8
        } else {
            (v as f64 + 0.5) as i8
        };
    }
    scale
}

fn check_adjacent(a: u16, b: u16) -> Result<(), CalibrationError> {
    let (la, lb) = ((a >> 5) as i32, (b >> 5) as i32);
    let (ca, cb) = ((a & 31) as i32, (b & 31) as i32);
    if (la - lb).abs() < 2 && (ca - cb).abs() < 2 {
        return Err(CalibrationError::AdjacentBadPixels {
            first: a,
            second: b,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ram_size_is_documented() {
        assert_eq!(core::mem::size_of::<Calibration>(), 4724);
    }

    #[test]
    fn adjacency() {
        assert!(check_adjacent(0, 1).is_err());
        assert!(check_adjacent(0, 33).is_err());
        assert!(check_adjacent(0, 2).is_ok());
        assert!(check_adjacent(31, 32).is_ok(), "row wrap is not adjacency");
        assert!(check_adjacent(100, 164).is_ok());
    }

    #[test]
    fn split_matches_library() {
        // Row parity × 2 + column parity.
        assert_eq!(split(0), 0);
        assert_eq!(split(1), 1);
        assert_eq!(split(32), 2);
        assert_eq!(split(33), 3);
        assert_eq!(split(64), 0);
    }
}
