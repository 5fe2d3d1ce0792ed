//! The roots in the To calculation: the library alternatives to the firmware's `VSQRT`, an f64
//! reference of the calculation, and each alternative's To error against it.
//!
//! This module owns:
//! - the non-hardware [`Roots`] variants the work-precision table measures ([`LibmSqrtf`],
//!   [`LibmPowf`], [`MicromathSqrt`], [`MicromathPowf`]; the firmware keeps only
//!   [`HardwareRoots`]) and their list [`VARIANTS`], named as `bench-m4` prints them;
//! - [`to_f64`], the per-pixel object temperature of one subpage in `f64`, evaluated straight
//!   from the formulas of datasheet Rev. 12 §11.2.2.2–§11.2.2.9 with the reference library's
//!   conventions the firmware follows (alphas reduced by TGC × the mean CP alpha, the
//!   extended-range correction always applied). Its inputs are the [`Calibration`]'s fields,
//!   which are integers or dyadic fractions (exact in `f32` and `f64`), so nothing but the
//!   arithmetic differs from the firmware's `f32` path;
//! - the test set ([`cases`]: the shared real dumps and synthetic subpages of the virtual
//!   sensor) and [`max_error_k`], the largest |To_variant − To_f64| over it.

use std::path::Path;

use thermorph::mlx90640::calc::{
    IDX_CP_SP0, IDX_CP_SP1, IDX_GAIN, IDX_PTAT, IDX_VBE, IDX_VDD, conversion_pattern, il_pattern,
    pixel_in_subpage,
};
use thermorph::mlx90640::{
    Calibration, Control, DecodeParams, FrameError, HardwareRoots, PIXELS, ReadingPattern,
    RefreshRate, Resolution, Roots, SubpageFrame, SubpageInfo, calculate_to_with,
};

use crate::imaging::SensingError;
use crate::imaging::dump::{read_eeprom, read_frame};
use crate::sensor::SensorError;
use crate::sensor::sim_time::SimClock;
use crate::sensor::virtual_mlx::{Rng, VirtualMlx90640};

/// `libm::sqrtf` (software, correctly rounded: bit-identical to `VSQRT`), fourth root as two.
#[derive(Clone, Copy, Debug, Default)]
pub struct LibmSqrtf;

impl Roots for LibmSqrtf {
    fn sqrt(x: f32) -> f32 {
        libm::sqrtf(x)
    }
}

/// `libm::powf(x, 0.25)` for the fourth root (square root: `libm::sqrtf`).
#[derive(Clone, Copy, Debug, Default)]
pub struct LibmPowf;

impl Roots for LibmPowf {
    fn sqrt(x: f32) -> f32 {
        libm::sqrtf(x)
    }

    fn root4(x: f32) -> f32 {
        libm::powf(x, 0.25)
    }
}

/// micromath's approximate square root (an exponent-halving bit trick), fourth root as two.
#[derive(Clone, Copy, Debug, Default)]
pub struct MicromathSqrt;

impl Roots for MicromathSqrt {
    fn sqrt(x: f32) -> f32 {
        <f32 as micromath::F32Ext>::sqrt(x)
    }
}

/// micromath's approximate `powf(x, 0.25)` for the fourth root (square root: micromath's).
#[derive(Clone, Copy, Debug, Default)]
pub struct MicromathPowf;

impl Roots for MicromathPowf {
    fn sqrt(x: f32) -> f32 {
        <f32 as micromath::F32Ext>::sqrt(x)
    }

    fn root4(x: f32) -> f32 {
        <f32 as micromath::F32Ext>::powf(x, 0.25)
    }
}

/// The To calculation of one subpage with some roots (a [`calculate_to_with`] instance).
pub type CalcFn = fn(
    &SubpageFrame,
    &Calibration,
    &DecodeParams,
    &mut [f32; PIXELS],
) -> Result<SubpageInfo, FrameError>;

/// The measured variants, hardware (the firmware's default) first, with the names `bench-m4`
/// prints in its `wp_roots variant=<name>` lines.
pub const VARIANTS: [(&str, CalcFn); 5] = [
    ("vsqrt", calculate_to_with::<HardwareRoots>),
    ("libm_sqrtf", calculate_to_with::<LibmSqrtf>),
    ("libm_powf", calculate_to_with::<LibmPowf>),
    ("micromath_sqrt", calculate_to_with::<MicromathSqrt>),
    ("micromath_powf", calculate_to_with::<MicromathPowf>),
];

/// 0 °C in kelvin, exactly as the datasheet writes it.
const ZERO_C_K: f64 = 273.15;

/// Return 2^n in f64.
fn p2(n: i32) -> f64 {
    2f64.powi(n)
}

/// Vdd (V) and Ta (K) of a subpage in f64 (datasheet §11.2.2.2–§11.2.2.3).
pub fn vdd_ta_f64(frame: &SubpageFrame, cal: &Calibration) -> (f64, f64) {
    let res_ram = frame.control().resolution() as i32;
    let corr = p2(cal.resolution_ee as i32 - res_ram);
    let vdd =
        (corr * frame.words[IDX_VDD] as i16 as f64 - cal.vdd25 as f64) / cal.k_vdd as f64 + 3.3;
    let ptat = frame.words[IDX_PTAT] as i16 as f64;
    let vbe = frame.words[IDX_VBE] as i16 as f64;
    let ptat_art = ptat / (ptat * cal.alpha_ptat as f64 + vbe) * p2(18);
    let ta = (ptat_art / (1.0 + cal.kv_ptat as f64 * (vdd - 3.3)) - cal.v_ptat25 as f64)
        / cal.kt_ptat as f64
        + 25.0;
    (vdd, ta + ZERO_C_K)
}

/// Compute To (K) in f64 for the pixels of `frame`'s subpage into `out` (other pixels
/// untouched); returns (Vdd V, Ta K). No plausibility checks: callers compare only where the
/// firmware accepted the frame.
pub fn to_f64(
    frame: &SubpageFrame,
    cal: &Calibration,
    params: &DecodeParams,
    out: &mut [f64; PIXELS],
) -> (f64, f64) {
    let (vdd, ta_k) = vdd_ta_f64(frame, cal);
    let ta = ta_k - ZERO_C_K;
    let eps = params.emissivity as f64;
    let tr_k = match params.reflected {
        Some(t) => t.k() as f64,
        None => ta_k - params.ta_shift_k as f64,
    };
    let ta4 = ta_k.powi(4);
    let tr4 = tr_k.powi(4);
    let ta_tr = tr4 - (tr4 - ta4) / eps;
    let ks_to: [f64; 5] = cal.ks_to.map(|v| v as f64);
    let ct: [f64; 5] = cal.ct.map(|v| v as f64);
    let alpha_corr_r = {
        let r2 = 1.0 + ks_to[1] * ct[2];
        [
            1.0 / (1.0 + ks_to[0] * 40.0),
            1.0,
            r2,
            r2 * (1.0 + ks_to[2] * (ct[3] - ct[2])),
        ]
    };
    let gain = cal.gain_ee as f64 / frame.words[IDX_GAIN] as i16 as f64;
    let control = frame.control();
    let mode = control.mode_code();
    let pattern = control.pattern();
    let subpage = frame.subpage();
    let dta = ta - 25.0;
    let dvdd = vdd - 3.3;
    let cp_factor = (1.0 + cal.cp_kta as f64 * dta) * (1.0 + cal.cp_kv as f64 * dvdd);
    let ir_cp = if subpage == 0 {
        frame.words[IDX_CP_SP0] as i16 as f64 * gain - cal.cp_offset[0] as f64 * cp_factor
    } else {
        let off = cal.cp_offset[1] as f64
            + if mode == cal.calibration_mode_ee {
                0.0
            } else {
                cal.il_chess_c[0] as f64
            };
        frame.words[IDX_CP_SP1] as i16 as f64 * gain - off * cp_factor
    };
    let tgc_cp = cal.tgc as f64 * ir_cp;
    let ks_ta_factor = 1.0 + cal.ks_ta as f64 * dta;
    let alpha_scale = 1e-6 * p2(cal.alpha_scale as i32);
    for (p, dst) in out.iter_mut().enumerate() {
        if !pixel_in_subpage(p, pattern, subpage) {
            continue;
        }
        let kta = cal.kta[p] as f64 / p2(cal.kta_scale as i32);
        let kv = cal.kv[p] as f64 / p2(cal.kv_scale as i32);
        let mut ir = frame.words[p] as i16 as f64 * gain
            - cal.offset[p] as f64 * (1.0 + kta * dta) * (1.0 + kv * dvdd);
        if mode != cal.calibration_mode_ee {
            let (il, conv) = (il_pattern(p) as f64, conversion_pattern(p) as f64);
            ir += cal.il_chess_c[2] as f64 * (2.0 * il - 1.0) - cal.il_chess_c[1] as f64 * conv;
        }
        ir = (ir - tgc_cp) / eps;
        let alpha = alpha_scale / cal.alpha[p] as f64 * ks_ta_factor;
        let sx = (alpha.powi(3) * (ir + alpha * ta_tr)).powf(0.25) * ks_to[1];
        let to_k = (ir / (alpha * (1.0 - ks_to[1] * ZERO_C_K) + sx) + ta_tr).powf(0.25);
        let to_c = to_k - ZERO_C_K;
        let r = if to_c < ct[1] {
            0
        } else if to_c < ct[2] {
            1
        } else if to_c < ct[3] {
            2
        } else {
            3
        };
        *dst =
            (ir / (alpha * alpha_corr_r[r] * (1.0 + ks_to[r] * (to_c - ct[r]))) + ta_tr).powf(0.25);
    }
    (vdd, ta_k)
}

/// A calibration with the subpages to decode with it.
pub struct Case {
    /// Where it comes from.
    pub name: String,
    /// The sensor's calibration.
    pub cal: Box<Calibration>,
    /// Subpages.
    pub frames: Vec<SubpageFrame>,
}

/// The shared real dumps that carry frames (EEPROM file, frame files), in `dir`.
const REAL_DUMPS: [(&str, &[&str]); 4] = [
    (
        "melexis_example_eeprom.hex",
        &["melexis_example_frame0.hex", "melexis_example_frame1.hex"],
    ),
    (
        "datasheet_example_eeprom.hex",
        &[
            "datasheet_example_frame_chess_sp0.hex",
            "datasheet_example_frame_il_sp1.hex",
        ],
    ),
    (
        "signaloid_eeprom.hex",
        &["signaloid_frame0.hex", "signaloid_frame1.hex"],
    ),
    (
        "ceri_eeprom.hex",
        &[
            "ceri_ram0_frame00.hex",
            "ceri_ram0_frame01.hex",
            "ceri_ram1_frame00.hex",
            "ceri_ram1_frame01.hex",
        ],
    ),
];

/// Read the real dumps in `dir` (errors name the file).
pub fn real_cases(dir: &Path) -> Result<Vec<Case>, SensingError> {
    let mut out = Vec::new();
    for (ee, frames) in REAL_DUMPS {
        let words = read_eeprom(&dir.join(ee))?;
        let cal = Box::new(Calibration::from_eeprom(&words).map_err(|err| {
            SensingError::Calibration {
                file: ee.to_string(),
                err,
            }
        })?);
        let frames = frames
            .iter()
            .map(|f| read_frame(&dir.join(f)))
            .collect::<Result<Vec<_>, _>>()?;
        out.push(Case {
            name: ee.trim_end_matches("_eeprom.hex").to_string(),
            cal,
            frames,
        });
    }
    Ok(out)
}

/// Synthetic subpages from the virtual sensor: realistic EEPROMs of seeds 1…`sensors`, each
/// looking at the twelve standard scenes and at `random_fields` uniform random fields of
/// 263–573 K (through every extended range), both subpages, 18-bit chess plus one 16-bit and
/// one 19-bit interleaved pair of the first scene.
pub fn synthetic_cases(sensors: u64, random_fields: usize) -> Result<Vec<Case>, SensingError> {
    let scenes = crate::imaging::view::standard_scenes();
    let mut out = Vec::new();
    for seed in 1..=sensors {
        let eeprom = crate::sensor::eeprom::realistic(seed)
            .encode()
            .map_err(SensorError::from)?;
        let mut dev = VirtualMlx90640::new(eeprom, SimClock::new(), seed)
            .map_err(SensorError::VirtualSensor)?;
        let cal = Box::new(dev.calibration().clone());
        let mut frames = Vec::new();
        let mut shoot = |dev: &mut VirtualMlx90640, res, pattern, field: [f32; PIXELS]| {
            dev.set_control(Control(0).with(RefreshRate::Hz8, res, pattern));
            dev.field_k = field;
            for sp in 0..2 {
                frames.push(dev.raw_subpage(sp));
            }
        };
        for s in &scenes {
            let field = s.render(seed).image_k;
            shoot(&mut dev, Resolution::Bits18, ReadingPattern::Chess, field);
        }
        let mut rng = Rng::new(seed ^ 0x0007_0075);
        for _ in 0..random_fields {
            let field = crate::sensor::demo::random_field(&mut rng, 263.0, 573.0);
            shoot(&mut dev, Resolution::Bits18, ReadingPattern::Chess, field);
        }
        let first = scenes[0].render(seed).image_k;
        shoot(
            &mut dev,
            Resolution::Bits16,
            ReadingPattern::Interleaved,
            first,
        );
        shoot(
            &mut dev,
            Resolution::Bits19,
            ReadingPattern::Interleaved,
            first,
        );
        out.push(Case {
            name: format!("virtual sensor seed {seed}"),
            cal,
            frames,
        });
    }
    Ok(out)
}

/// The measurement set: the real dumps in `dir` (if given) and the synthetic subpages.
pub fn cases(dir: Option<&Path>) -> Result<Vec<Case>, SensingError> {
    let mut c = match dir {
        Some(d) => real_cases(d)?,
        None => Vec::new(),
    };
    c.extend(synthetic_cases(3, 4)?);
    Ok(c)
}

/// Error of one variant over a set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToError {
    /// Largest |To − To_f64|, K.
    pub max_abs_k: f64,
    /// Largest |To − To_f64| / (To_f64 − 0 K), relative.
    pub max_rel: f64,
    /// Pixels compared.
    pub pixels: usize,
}

/// Largest |To − To_f64| of `calc` over the subpages of `cases` the firmware accepts (its own
/// checks of Vdd, Ta and markers; a refused subpage is skipped by every variant alike).
pub fn max_error_k(calc: CalcFn, cases: &[Case]) -> ToError {
    let params = DecodeParams::default();
    let mut err = ToError {
        max_abs_k: 0.0,
        max_rel: 0.0,
        pixels: 0,
    };
    for case in cases {
        for f in &case.frames {
            let mut got = [f32::NAN; PIXELS];
            let Ok(info) = calc(f, &case.cal, &params, &mut got) else {
                continue;
            };
            let mut want = [f64::NAN; PIXELS];
            to_f64(f, &case.cal, &params, &mut want);
            let pattern = f.control().pattern();
            for p in (0..PIXELS).filter(|&p| pixel_in_subpage(p, pattern, info.subpage)) {
                let d = (got[p] as f64 - want[p]).abs();
                // A NaN (negative root argument) is the worst error there is.
                let d = if d.is_nan() { f64::INFINITY } else { d };
                err.max_abs_k = err.max_abs_k.max(d);
                err.max_rel = err.max_rel.max(d / want[p].abs());
                err.pixels += 1;
            }
        }
    }
    err
}
