//! The roots of the To calculation: the f64 reference against the firmware's f32 path and the
//! datasheet, the software square root bit-identical to the default, micromath's far off.

use host_sim::imaging::data::require_mlx90640_dir;
use host_sim::imaging::dump::{read_eeprom, read_frame};
use host_sim::imaging::to_roots::{self, Case, LibmSqrtf, VARIANTS, max_error_k, to_f64};
use thermorph::mlx90640::calc::{calculate_to, pixel_in_subpage};
use thermorph::mlx90640::{Calibration, DecodeParams, PIXELS, calculate_to_with};

fn all_cases() -> Vec<Case> {
    let dir = require_mlx90640_dir("to_roots");
    to_roots::cases(dir.as_deref()).unwrap()
}

fn variant(name: &str) -> to_roots::CalcFn {
    VARIANTS.iter().find(|(n, _)| *n == name).unwrap().1
}

#[test]
fn f64_reference_agrees_with_the_firmware_within_f32_rounding() {
    let cases = all_cases();
    let e = max_error_k(variant("vsqrt"), &cases);
    assert!(e.pixels > 20_000, "{} pixels compared", e.pixels);
    // f32 carries 24 bits: 300 K has an ulp of 3e-5 K; the calculation's cancellations cost a
    // few ulps more, nothing like a formula difference (0.05 K between the datasheet's and the
    // library's TGC convention).
    assert!(
        e.max_abs_k < 5e-4,
        "max |To_f32 - To_f64| = {} K",
        e.max_abs_k
    );
}

#[test]
fn f64_reference_gives_the_datasheet_worked_example() {
    let Some(dir) = require_mlx90640_dir("f64_reference_gives_the_datasheet_worked_example") else {
        return;
    };
    let cal =
        Calibration::from_eeprom(&read_eeprom(&dir.join("datasheet_example_eeprom.hex")).unwrap())
            .unwrap();
    let frame = read_frame(&dir.join("datasheet_example_frame_il_sp1.hex")).unwrap();
    let mut to = [f64::NAN; PIXELS];
    let (vdd, ta_k) = to_f64(&frame, &cal, &DecodeParams::default(), &mut to);
    assert!((vdd - 3.319).abs() < 1e-3, "Vdd {vdd}");
    assert!((ta_k - 273.15 - 39.184).abs() < 1e-3, "Ta {ta_k}");
    // Pixel (12,16), 1-based: the library's convention gives 80.414 °C (SOURCES.md).
    let p = 11 * 32 + 15;
    assert!(
        (to[p] - 273.15 - 80.414).abs() < 1e-3,
        "To {}",
        to[p] - 273.15
    );
}

#[test]
fn software_sqrt_is_bit_identical_to_the_default() {
    let params = DecodeParams::default();
    let mut compared = 0;
    for case in all_cases() {
        for f in &case.frames {
            let (mut a, mut b) = ([f32::NAN; PIXELS], [f32::NAN; PIXELS]);
            let (ra, rb) = (
                calculate_to(f, &case.cal, &params, &mut a),
                calculate_to_with::<LibmSqrtf>(f, &case.cal, &params, &mut b),
            );
            assert_eq!(ra, rb, "{}", case.name);
            let Ok(info) = ra else { continue };
            let pattern = f.control().pattern();
            for p in (0..PIXELS).filter(|&p| pixel_in_subpage(p, pattern, info.subpage)) {
                assert_eq!(a[p].to_bits(), b[p].to_bits(), "{} pixel {p}", case.name);
                compared += 1;
            }
        }
    }
    assert!(compared > 20_000);
}

#[test]
fn micromath_sqrt_is_far_off_and_libm_is_not() {
    let cases = all_cases();
    let mm = max_error_k(variant("micromath_sqrt"), &cases);
    // An exponent-halving approximation: percent-level errors per root, tens of kelvin in To.
    assert!(mm.max_abs_k > 5.0, "micromath_sqrt: {} K", mm.max_abs_k);
    assert!(mm.max_rel > 0.01, "micromath_sqrt: {}", mm.max_rel);
    let pow = max_error_k(variant("libm_powf"), &cases);
    assert!(pow.max_abs_k < 5e-4, "libm_powf: {} K", pow.max_abs_k);
    let mmp = max_error_k(variant("micromath_powf"), &cases);
    assert!(
        mmp.max_abs_k > pow.max_abs_k * 10.0,
        "micromath_powf: {} K",
        mmp.max_abs_k
    );
}
