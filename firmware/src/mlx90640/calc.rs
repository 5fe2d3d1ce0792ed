//! The per-subpage temperature calculation, subpage merging and bad-pixel correction.
//!
//! Free functions named after the datasheet's symbols (Rev. 12 §11.2), ported from the
//! reference library's `MLX90640_GetVdd`, `MLX90640_GetTa`, `MLX90640_CalculateTo` and
//! `MLX90640_BadPixelsCorrection` (commit f6be7ca) in `f32`. As the library does, the
//! thermal-gradient compensation uses the compensation pixel of the measured subpage with
//! alphas already reduced by TGC × the mean of the two CP alphas (see the calibration), and the
//! extended-range correction (ksTo, ct, alphaCorrR) is always applied. The result of the fourth
//! root is the object temperature in Kelvin; the library subtracts 273.15 from that same value.
//!
//! The roots the To formula takes are a type parameter ([`Roots`], [`calculate_to_with`],
//! [`Image::update_with`]): the firmware uses [`HardwareRoots`] (the FPU's `VSQRT.F32`); the
//! simulator and the QEMU bench plug in library alternatives to measure what each costs in
//! instructions and in To error (`host-sim mtts-wp`).

use super::calibration::Calibration;
use super::register::{Control, ReadingPattern};
use super::{COLS, FRAME_WORDS, PIXELS, ROWS};
use crate::fmath::pow2;
use crate::units::{Kelvin, ZERO_CELSIUS_K};

/// The square root and fourth root the To calculation takes (datasheet §11.2.2.9: To is the
/// fourth root of a fourth-power sum, and the extended-range Sx term too).
pub trait Roots {
    /// Return √x (NaN for negative x).
    fn sqrt(x: f32) -> f32;

    /// Return x^(1/4); by default two square roots, as the Melexis library computes it.
    #[inline]
    fn root4(x: f32) -> f32 {
        Self::sqrt(Self::sqrt(x))
    }
}

/// The firmware's roots: [`crate::fmath::sqrt`] — `VSQRT.F32` on the Cortex-M4F, the correctly
/// rounded `libm::sqrtf` elsewhere (bit-identical) — and the fourth root as two of them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HardwareRoots;

impl Roots for HardwareRoots {
    #[inline]
    fn sqrt(x: f32) -> f32 {
        crate::fmath::sqrt(x)
    }

    #[inline]
    fn root4(x: f32) -> f32 {
        crate::fmath::root4(x)
    }
}

/// Frame word index of the aux word Vbe (Ta_Vbe, RAM 0x0700).
pub const IDX_VBE: usize = 768;
/// Frame word index of compensation pixel, subpage 0 (RAM 0x0708).
pub const IDX_CP_SP0: usize = 776;
/// Frame word index of the gain word (RAM 0x070A).
pub const IDX_GAIN: usize = 778;
/// Frame word index of PTAT (RAM 0x0720).
pub const IDX_PTAT: usize = 800;
/// Frame word index of compensation pixel, subpage 1 (RAM 0x0728).
pub const IDX_CP_SP1: usize = 808;
/// Frame word index of Vdd (RAM 0x072A).
pub const IDX_VDD: usize = 810;
/// Frame word index of the control register copy.
pub const IDX_CONTROL: usize = 832;
/// Frame word index of the subpage number.
pub const IDX_SUBPAGE: usize = 833;

/// Plausible supply voltage range, V (datasheet absolute range 3.0–3.6 V with margin).
pub const VDD_RANGE_V: (f32, f32) = (2.8, 3.8);
/// Plausible sensor (ambient) temperature range, K (operating range −40…85 °C, with margin).
pub const TA_RANGE_K: (f32, f32) = (223.15, 398.15);

/// One subpage as the reference library's `frameData`: RAM 0x0400–0x073F, control, subpage.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SubpageFrame {
    /// The 834 words.
    pub words: [u16; FRAME_WORDS],
}

impl Default for SubpageFrame {
    fn default() -> Self {
        Self::new()
    }
}

impl SubpageFrame {
    /// Return an all-zero frame.
    pub const fn new() -> Self {
        SubpageFrame {
            words: [0; FRAME_WORDS],
        }
    }

    /// Return the subpage number (0 or 1).
    pub fn subpage(&self) -> u8 {
        (self.words[IDX_SUBPAGE] & 1) as u8
    }

    /// Return the control register copy.
    pub fn control(&self) -> Control {
        Control(self.words[IDX_CONTROL])
    }

    /// Return whether the frame's words carry the `0x7FFF` "not yet written" marker where the
    /// reference library looks for it (`ValidateAuxData`, `ValidateFrameData`): aux words 0,
    /// 8–18, 20–22, 24–32, 40–50, 52–54, 56–63, and the first pixel of each row of the subpage's
    /// parity. Returns the first offending word index.
    pub fn find_invalid_marker(&self) -> Option<usize> {
        const AUX_CHECKED: [(usize, usize); 7] = [
            (0, 1),
            (8, 19),
            (20, 23),
            (24, 33),
            (40, 51),
            (52, 55),
            (56, 64),
        ];
        for &(a, b) in &AUX_CHECKED {
            for i in a..b {
                if self.words[PIXELS + i] == 0x7FFF {
                    return Some(PIXELS + i);
                }
            }
        }
        let sp = self.words[IDX_SUBPAGE] as usize;
        (0..PIXELS / COLS)
            .filter(|line| line % 2 == sp)
            .map(|line| line * COLS)
            .find(|&i| self.words[i] == 0x7FFF)
    }
}

/// Object parameters for the To calculation.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct DecodeParams {
    /// Object emissivity, 0 < ε ≤ 1.
    pub emissivity: f32,
    /// Reflected (background) temperature; `None` means Ta − `ta_shift_k`, as the Melexis
    /// examples do.
    pub reflected: Option<Kelvin>,
    /// Ta minus the reflected temperature when `reflected` is `None`, K (Melexis: 8).
    pub ta_shift_k: f32,
}

impl Default for DecodeParams {
    fn default() -> Self {
        DecodeParams {
            emissivity: 1.0,
            reflected: None,
            ta_shift_k: 8.0,
        }
    }
}

/// Why a subpage could not be turned into temperatures.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum FrameError {
    /// A word carries the 0x7FFF marker (RAM not yet written).
    InvalidMarker {
        /// Frame word index.
        index: u16,
    },
    /// The gain word is zero: the calculation would divide by zero.
    ZeroGain,
    /// Vdd outside [`VDD_RANGE_V`].
    ImplausibleVdd {
        /// Computed Vdd, mV.
        millivolts: i32,
    },
    /// Ta outside [`TA_RANGE_K`] or not finite.
    ImplausibleTa {
        /// Computed Ta, centi-Kelvin (i32::MIN if not finite).
        centi_kelvin: i32,
    },
    /// Emissivity outside (0, 1].
    BadEmissivity,
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Self::InvalidMarker { index } => {
                write!(
                    f,
                    "frame word {index} carries the 0x7FFF not-written marker"
                )
            }
            Self::ZeroGain => write!(f, "gain word is zero"),
            Self::ImplausibleVdd { millivolts } => {
                write!(f, "implausible supply {millivolts} mV")
            }
            Self::ImplausibleTa { centi_kelvin } => write!(
                f,
                "implausible sensor temperature {}.{:02} K",
                centi_kelvin / 100,
                (centi_kelvin % 100).abs()
            ),
            Self::BadEmissivity => write!(f, "emissivity outside (0, 1]"),
        }
    }
}

/// Supply and sensor temperature of one decoded subpage.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct SubpageInfo {
    /// Subpage number.
    pub subpage: u8,
    /// Supply voltage, V.
    pub vdd_v: f32,
    /// Sensor (ambient) temperature.
    pub ta: Kelvin,
}

/// Minimum, mean and maximum over the valid pixels of an image.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct ImageStats {
    /// Lowest temperature.
    pub min: Kelvin,
    /// Mean temperature.
    pub mean: Kelvin,
    /// Highest temperature.
    pub max: Kelvin,
    /// Number of valid (finite) pixels.
    pub valid: u16,
}

/// Return the supply voltage Vdd, V (datasheet §11.2.2.2, library `MLX90640_GetVdd`).
pub fn vdd_v(frame: &SubpageFrame, cal: &Calibration) -> f32 {
    let resolution_ram = frame.control().resolution() as i32;
    let correction = pow2(cal.resolution_ee as i32 - resolution_ram);
    (correction * frame.words[IDX_VDD] as i16 as f32 - cal.vdd25 as f32) / cal.k_vdd as f32 + 3.3
}

/// Return the sensor temperature Ta, °C (datasheet §11.2.2.3, library `MLX90640_GetTa`).
pub fn ta_c(frame: &SubpageFrame, cal: &Calibration, vdd_v: f32) -> f32 {
    let ptat = frame.words[IDX_PTAT] as i16 as f32;
    let vbe = frame.words[IDX_VBE] as i16 as f32;
    let ptat_art = (ptat / (ptat * cal.alpha_ptat + vbe)) * pow2(18);
    let ta = ptat_art / (1.0 + cal.kv_ptat * (vdd_v - 3.3)) - cal.v_ptat25 as f32;
    ta / cal.kt_ptat + 25.0
}

/// The pixels of `row` that belong to `subpage` under `pattern`, as (first column, column
/// step), or `None` when the row has none: interleaved, every pixel of the rows of the
/// subpage's parity; chess, every other column, starting by the row's parity (library
/// `ilPattern` / `chessPattern`). The one rule of which pixel a subpage holds: the To
/// calculation walks it, [`pixel_in_subpage`] tests it.
#[inline(always)]
pub fn subpage_row(row: usize, pattern: ReadingPattern, subpage: u8) -> Option<(usize, usize)> {
    let parity = (row & 1) as u8;
    match pattern {
        ReadingPattern::Interleaved if parity == subpage => Some((0, 1)),
        ReadingPattern::Interleaved => None,
        ReadingPattern::Chess => Some(((parity ^ subpage) as usize, 2)),
    }
}

/// Return whether pixel `p` belongs to `subpage` under `pattern` ([`subpage_row`]).
pub fn pixel_in_subpage(p: usize, pattern: ReadingPattern, subpage: u8) -> bool {
    let column = p % COLS;
    subpage_row(p / COLS, pattern, subpage)
        .is_some_and(|(first, step)| column >= first && (column - first).is_multiple_of(step))
}

/// Return the library's `ilPattern` of pixel `p`: its row's parity (0 or 1).
pub fn il_pattern(p: usize) -> i32 {
    (p / 32 - (p / 64) * 2) as i32
}

/// Return the library's `conversionPattern` of pixel `p` (−1, 0 or 1): which pixels of a row
/// get the IL/chess correction IL_CHESS_C2, with the row's sign.
#[allow(clippy::manual_div_ceil)] // the library's integer formula, kept as written
pub fn conversion_pattern(p: usize) -> i32 {
    (((p + 2) / 4) as i32 - ((p + 3) / 4) as i32 + ((p + 1) / 4) as i32 - (p / 4) as i32)
        * (1 - 2 * il_pattern(p))
}

/// Compute To (Kelvin) for the pixels of one subpage into `out`, leaving the other pixels
/// untouched (datasheet §11.2.2.5–§11.2.2.9, library `MLX90640_CalculateTo`). Returns the
/// subpage's Vdd and Ta after checking them. The roots are [`HardwareRoots`].
pub fn calculate_to(
    frame: &SubpageFrame,
    cal: &Calibration,
    params: &DecodeParams,
    out: &mut [f32; PIXELS],
) -> Result<SubpageInfo, FrameError> {
    calculate_to_with::<HardwareRoots>(frame, cal, params, out)
}

/// [`calculate_to`] with the roots of `R`.
pub fn calculate_to_with<R: Roots>(
    frame: &SubpageFrame,
    cal: &Calibration,
    params: &DecodeParams,
    out: &mut [f32; PIXELS],
) -> Result<SubpageInfo, FrameError> {
    if !(params.emissivity > 0.0 && params.emissivity <= 1.0) {
        return Err(FrameError::BadEmissivity);
    }
    if let Some(index) = frame.find_invalid_marker() {
        return Err(FrameError::InvalidMarker {
            index: index as u16,
        });
    }
    let gain_ram = frame.words[IDX_GAIN] as i16;
    if gain_ram == 0 {
        return Err(FrameError::ZeroGain);
    }
    let subpage = frame.subpage();
    let vdd = vdd_v(frame, cal);
    if !(vdd >= VDD_RANGE_V.0 && vdd <= VDD_RANGE_V.1) {
        let millivolts = if vdd.is_finite() {
            (vdd * 1000.0) as i32
        } else {
            i32::MIN
        };
        return Err(FrameError::ImplausibleVdd { millivolts });
    }
    let ta = ta_c(frame, cal, vdd);
    let ta_k = ta + ZERO_CELSIUS_K;
    let in_range = ta_k >= TA_RANGE_K.0 && ta_k <= TA_RANGE_K.1;
    let Some(ta_kelvin) = Kelvin::new(ta_k).filter(|_| in_range) else {
        let centi_kelvin = if ta_k.is_finite() {
            (ta_k * 100.0) as i32
        } else {
            i32::MIN
        };
        return Err(FrameError::ImplausibleTa { centi_kelvin });
    };

    let tr_k = match params.reflected {
        Some(t) => t.k(),
        None => ta_k - params.ta_shift_k,
    };
    let ta4 = {
        let t2 = ta_k * ta_k;
        t2 * t2
    };
    let tr4 = {
        let t2 = tr_k * tr_k;
        t2 * t2
    };
    let ta_tr = tr4 - (tr4 - ta4) / params.emissivity;

    let kta_scale = pow2(cal.kta_scale as i32);
    let kv_scale = pow2(cal.kv_scale as i32);
    let alpha_scale = 1e-6 * pow2(cal.alpha_scale as i32);
    let ks_to = &cal.ks_to;
    let ct = [
        cal.ct[0] as f32,
        cal.ct[1] as f32,
        cal.ct[2] as f32,
        cal.ct[3] as f32,
    ];
    let alpha_corr_r = {
        let r2 = 1.0 + ks_to[1] * ct[2];
        [
            1.0 / (1.0 + ks_to[0] * 40.0),
            1.0,
            r2,
            r2 * (1.0 + ks_to[2] * (ct[3] - ct[2])),
        ]
    };

    let gain = cal.gain_ee as f32 / gain_ram as f32;
    let control = frame.control();
    let mode = control.mode_code();
    let pattern = control.pattern();
    let dta = ta - 25.0;
    let dvdd = vdd - 3.3;
    let cp_factor = (1.0 + cal.cp_kta * dta) * (1.0 + cal.cp_kv * dvdd);
    let ir_cp = if subpage == 0 {
        frame.words[IDX_CP_SP0] as i16 as f32 * gain - cal.cp_offset[0] as f32 * cp_factor
    } else {
        let off = if mode == cal.calibration_mode_ee {
            cal.cp_offset[1] as f32
        } else {
            cal.cp_offset[1] as f32 + cal.il_chess_c[0]
        };
        frame.words[IDX_CP_SP1] as i16 as f32 * gain - off * cp_factor
    };
    let tgc_cp = cal.tgc * ir_cp;
    let ks_ta_factor = 1.0 + cal.ks_ta * dta;
    let one_minus = 1.0 - ks_to[1] * ZERO_CELSIUS_K;

    let to_of = |p: usize| {
        let kta = cal.kta[p] as f32 / kta_scale;
        let kv = cal.kv[p] as f32 / kv_scale;
        let mut ir = frame.words[p] as i16 as f32 * gain;
        ir -= cal.offset[p] as f32 * (1.0 + kta * dta) * (1.0 + kv * dvdd);
        if mode != cal.calibration_mode_ee {
            let (il, conv) = (il_pattern(p), conversion_pattern(p));
            ir += cal.il_chess_c[2] * (2 * il - 1) as f32 - cal.il_chess_c[1] * conv as f32;
        }
        ir -= tgc_cp;
        ir /= params.emissivity;
        let alpha = alpha_scale / cal.alpha[p] as f32 * ks_ta_factor;
        let sx = R::root4(alpha * alpha * alpha * (ir + alpha * ta_tr)) * ks_to[1];
        let to_k = R::root4(ir / (alpha * one_minus + sx) + ta_tr);
        let to_c = to_k - ZERO_CELSIUS_K;
        let range = if to_c < ct[1] {
            0
        } else if to_c < ct[2] {
            1
        } else if to_c < ct[3] {
            2
        } else {
            3
        };
        R::root4(
            ir / (alpha * alpha_corr_r[range] * (1.0 + ks_to[range] * (to_c - ct[range]))) + ta_tr,
        )
    };
    // Only the subpage's pixels ([`subpage_row`]).
    for row in 0..ROWS {
        let Some((first, step)) = subpage_row(row, pattern, subpage) else {
            continue;
        };
        let mut p = row * COLS + first;
        while p < (row + 1) * COLS {
            out[p] = to_of(p);
            p += step;
        }
    }
    Ok(SubpageInfo {
        subpage,
        vdd_v: vdd,
        ta: ta_kelvin,
    })
}

/// Replace the listed bad pixels of `subpage` in `to` from their neighbours, exactly as the
/// library's `MLX90640_BadPixelsCorrection` (chess: the four diagonal neighbours' median or
/// the available pair; interleaved: left/right with gradient extrapolation). Pixels of the
/// other subpage are skipped, so this may run after each subpage: every neighbour it reads
/// lies in the same subpage.
pub fn correct_bad_pixels(
    pixels: &[u16],
    to: &mut [f32; PIXELS],
    pattern: ReadingPattern,
    subpage: u8,
    cal: &Calibration,
) {
    for &px in pixels {
        let p = px as usize;
        if p >= PIXELS || !pixel_in_subpage(p, pattern, subpage) {
            continue;
        }
        let line = p >> 5;
        let column = p & 31;
        to[p] = match pattern {
            ReadingPattern::Chess => {
                if line == 0 {
                    match column {
                        0 => to[33],
                        31 => to[62],
                        _ => (to[p + 31] + to[p + 33]) / 2.0,
                    }
                } else if line == 23 {
                    match column {
                        0 => to[705],
                        31 => to[734],
                        _ => (to[p - 33] + to[p - 31]) / 2.0,
                    }
                } else if column == 0 {
                    (to[p - 31] + to[p + 33]) / 2.0
                } else if column == 31 {
                    (to[p - 33] + to[p + 31]) / 2.0
                } else {
                    median4([to[p - 33], to[p - 31], to[p + 31], to[p + 33]])
                }
            }
            ReadingPattern::Interleaved => match column {
                0 => to[p + 1],
                1 | 30 => (to[p - 1] + to[p + 1]) / 2.0,
                31 => to[p - 1],
                _ => {
                    if !cal.is_bad_pixel(px - 2) && !cal.is_bad_pixel(px + 2) {
                        let a0 = to[p + 1] - to[p + 2];
                        let a1 = to[p - 1] - to[p - 2];
                        if libm::fabsf(a0) > libm::fabsf(a1) {
                            to[p - 1] + a1
                        } else {
                            to[p + 1] + a0
                        }
                    } else {
                        (to[p - 1] + to[p + 1]) / 2.0
                    }
                }
            },
        };
    }
}

fn median4(mut v: [f32; 4]) -> f32 {
    // The library's selection sort; NaN-free input assumed as there.
    for i in 0..3 {
        for j in i + 1..4 {
            if v[j] < v[i] {
                v.swap(i, j);
            }
        }
    }
    (v[1] + v[2]) / 2.0
}

/// A 32×24 image in Kelvin merged from subpages; pixels no subpage has covered yet are NaN.
#[derive(Clone, Debug)]
pub struct Image {
    /// Object temperatures, K, row-major.
    pub to_k: [f32; PIXELS],
    covered: [bool; 2],
    pattern: ReadingPattern,
}

impl Default for Image {
    fn default() -> Self {
        Self::new()
    }
}

impl Image {
    /// Return an empty image (every pixel NaN).
    pub const fn new() -> Self {
        Image {
            to_k: [f32::NAN; PIXELS],
            covered: [false; 2],
            pattern: ReadingPattern::Chess,
        }
    }

    /// Decode one subpage into the image: compute To for its pixels and correct its broken and
    /// outlier pixels. A change of reading pattern clears the other subpage's pixels. On error
    /// the image is unchanged. The roots are [`HardwareRoots`].
    pub fn update(
        &mut self,
        frame: &SubpageFrame,
        cal: &Calibration,
        params: &DecodeParams,
    ) -> Result<SubpageInfo, FrameError> {
        self.update_with::<HardwareRoots>(frame, cal, params)
    }

    /// [`Image::update`] with the roots of `R`.
    pub fn update_with<R: Roots>(
        &mut self,
        frame: &SubpageFrame,
        cal: &Calibration,
        params: &DecodeParams,
    ) -> Result<SubpageInfo, FrameError> {
        let pattern = frame.control().pattern();
        // `calculate_to_with` writes the subpage's pixels only, and only once every check has
        // passed (a refused frame leaves `out` as it was): with the pattern unchanged it
        // writes straight into the image.
        let info = if pattern == self.pattern {
            calculate_to_with::<R>(frame, cal, params, &mut self.to_k)?
        } else {
            // A new pattern: the other subpage's pixels are not covered yet.
            let mut fresh = [f32::NAN; PIXELS];
            let info = calculate_to_with::<R>(frame, cal, params, &mut fresh)?;
            self.to_k = fresh;
            self.covered = [false; 2];
            self.pattern = pattern;
            info
        };
        correct_bad_pixels(
            cal.broken_pixels.as_slice(),
            &mut self.to_k,
            pattern,
            info.subpage,
            cal,
        );
        correct_bad_pixels(
            cal.outlier_pixels.as_slice(),
            &mut self.to_k,
            pattern,
            info.subpage,
            cal,
        );
        self.covered[info.subpage as usize] = true;
        Ok(info)
    }

    /// Return whether both subpages have been decoded since the last pattern change.
    pub fn complete(&self) -> bool {
        self.covered[0] && self.covered[1]
    }

    /// Return the temperature at `row`, `col` (`None` if not covered).
    pub fn at(&self, row: usize, col: usize) -> Option<Kelvin> {
        Kelvin::new(self.to_k[row * COLS + col])
    }

    /// Return min, mean and max over the finite pixels, or `None` if there are none.
    pub fn stats(&self) -> Option<ImageStats> {
        let mut min = f32::INFINITY;
        let mut max = f32::NEG_INFINITY;
        let mut sum = 0.0f64;
        let mut n = 0u16;
        for &t in self.to_k.iter().filter(|t| t.is_finite()) {
            min = min.min(t);
            max = max.max(t);
            sum += t as f64;
            n += 1;
        }
        if n == 0 {
            return None;
        }
        // Over n > 0 finite pixels, none of the three is NaN.
        Some(ImageStats {
            min: Kelvin::new(min)?,
            mean: Kelvin::new((sum / n as f64) as f32)?,
            max: Kelvin::new(max)?,
            valid: n,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subpage_patterns_partition_pixels() {
        for pattern in [ReadingPattern::Chess, ReadingPattern::Interleaved] {
            let n0 = (0..PIXELS)
                .filter(|&p| pixel_in_subpage(p, pattern, 0))
                .count();
            let n1 = (0..PIXELS)
                .filter(|&p| pixel_in_subpage(p, pattern, 1))
                .count();
            assert_eq!((n0, n1), (384, 384));
        }
        // The library's own formulas (`ilPattern`, `chessPattern`) agree pixel by pixel.
        for p in 0..PIXELS {
            let il = il_pattern(p) as u8;
            for subpage in 0..2 {
                assert_eq!(
                    pixel_in_subpage(p, ReadingPattern::Interleaved, subpage),
                    il == subpage,
                    "interleaved {p}"
                );
                assert_eq!(
                    pixel_in_subpage(p, ReadingPattern::Chess, subpage),
                    (il ^ (p % 2) as u8) == subpage,
                    "chess {p}"
                );
            }
        }
        assert!(pixel_in_subpage(0, ReadingPattern::Chess, 0));
        assert!(pixel_in_subpage(1, ReadingPattern::Chess, 1));
        assert!(pixel_in_subpage(33, ReadingPattern::Chess, 0));
        assert!(pixel_in_subpage(32, ReadingPattern::Interleaved, 1));
    }

    #[test]
    fn median_of_four() {
        assert_eq!(median4([4.0, 1.0, 3.0, 2.0]), 2.5);
    }

    #[test]
    fn stats_skip_nan() {
        let mut img = Image::new();
        assert!(img.stats().is_none());
        img.to_k[0] = 300.0;
        img.to_k[5] = 310.0;
        let s = img.stats().unwrap();
        assert_eq!(
            (s.min.k(), s.max.k(), s.mean.k(), s.valid),
            (300.0, 310.0, 305.0, 2)
        );
    }

    #[test]
    fn invalid_marker_positions() {
        let mut f = SubpageFrame::new();
        f.words[IDX_SUBPAGE] = 1;
        f.words[0] = 0x7FFF; // line 0 belongs to subpage 0's parity: not checked
        assert_eq!(f.find_invalid_marker(), None);
        f.words[32] = 0x7FFF;
        assert_eq!(f.find_invalid_marker(), Some(32));
        f.words[32] = 0;
        f.words[PIXELS + 19] = 0x7FFF; // aux 19 is not checked by the library
        assert_eq!(f.find_invalid_marker(), None);
        f.words[PIXELS + 8] = 0x7FFF;
        assert_eq!(f.find_invalid_marker(), Some(PIXELS + 8));
    }
}
