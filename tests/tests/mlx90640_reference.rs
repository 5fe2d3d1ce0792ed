//! The MLX90640 chain against the Melexis references in `../shared/data/mlx90640/`:
//! the example sheet's parameters and both expected images, the datasheet worked example, the
//! other public dumps, and a refused EEPROM.

use std::collections::HashMap;
use std::path::Path;

use host_sim::imaging::data::require_mlx90640_dir;
use host_sim::imaging::dump::{read_eeprom, read_frame};
use thermorph::mlx90640::calc::{self, IDX_GAIN};
use thermorph::mlx90640::{Calibration, CalibrationError, DecodeParams, Image, PIXELS};

fn expected_params(dir: &Path) -> HashMap<String, f64> {
    let text = std::fs::read_to_string(dir.join("melexis_example_expected_params.csv")).unwrap();
    text.lines()
        .skip(1)
        .map(|l| {
            let (k, v) = l.split_once(',').unwrap();
            (k.to_string(), v.trim().parse::<f64>().unwrap())
        })
        .collect()
}

fn expected_to(dir: &Path, name: &str) -> Vec<f64> {
    let text = std::fs::read_to_string(dir.join(name)).unwrap();
    let v: Vec<f64> = text
        .lines()
        .skip(1)
        .map(|l| l.rsplit(',').next().unwrap().parse::<f64>().unwrap())
        .collect();
    assert_eq!(v.len(), PIXELS);
    v
}

fn close(name: &str, got: f64, want: f64, tol: f64) {
    assert!(
        (got - want).abs() <= tol,
        "{name}: got {got}, expected {want} (tolerance {tol})"
    );
}

#[test]
fn melexis_example_parameters() {
    let Some(dir) = require_mlx90640_dir("melexis_example_parameters") else {
        return;
    };
    let cal =
        Calibration::from_eeprom(&read_eeprom(&dir.join("melexis_example_eeprom.hex")).unwrap())
            .unwrap();
    let e = expected_params(&dir);
    let f = |k: &str| e[k];
    // Scalars are printed with six decimals in the sheet.
    close("kVdd", cal.k_vdd as f64, f("kVdd"), 0.0);
    close("vdd25", cal.vdd25 as f64, f("vdd25"), 0.0);
    close("KvPTAT", cal.kv_ptat as f64, f("KvPTAT"), 5e-7);
    close("KtPTAT", cal.kt_ptat as f64, f("KtPTAT"), 5e-7);
    close("vPTAT25", cal.v_ptat25 as f64, f("vPTAT25"), 0.0);
    close("alphaPTAT", cal.alpha_ptat as f64, f("alphaPTAT"), 5e-7);
    close("gainEE", cal.gain_ee as f64, f("gainEE"), 0.0);
    close("tgc", cal.tgc as f64, f("tgc"), 5e-7);
    close("cpKv", cal.cp_kv as f64, f("cpKv"), 5e-7);
    close("cpKta", cal.cp_kta as f64, f("cpKta"), 5e-7);
    close(
        "resolutionEE",
        cal.resolution_ee as f64,
        f("resolutionEE"),
        0.0,
    );
    close(
        "calibrationModeEE",
        cal.calibration_mode_ee as f64,
        f("calibrationModeEE"),
        0.0,
    );
    close("KsTa", cal.ks_ta as f64, f("KsTa"), 5e-7);
    for i in 0..4 {
        close(
            &format!("ksTo[{i}]"),
            cal.ks_to[i] as f64,
            f(&format!("ksTo[{i}]")),
            5e-7,
        );
        close(
            &format!("ct[{i}]"),
            cal.ct[i] as f64,
            f(&format!("ct[{i}]")),
            0.0,
        );
    }
    for i in 0..2 {
        let want = f(&format!("cpAlpha[{i}]"));
        close(
            &format!("cpAlpha[{i}]"),
            cal.cp_alpha[i] as f64,
            want,
            want.abs() * 1e-6,
        );
        close(
            &format!("cpOffset[{i}]"),
            cal.cp_offset[i] as f64,
            f(&format!("cpOffset[{i}]")),
            0.0,
        );
    }
    for i in 0..3 {
        close(
            &format!("ilChessC[{i}]"),
            cal.il_chess_c[i] as f64,
            f(&format!("ilChessC[{i}]")),
            5e-5,
        );
    }
    for i in 0..5 {
        // 65535 = no entry, as the library's 0xFFFF terminator.
        let b = cal
            .broken_pixels
            .as_slice()
            .get(i)
            .map_or(65535.0, |&p| p as f64);
        let o = cal
            .outlier_pixels
            .as_slice()
            .get(i)
            .map_or(65535.0, |&p| p as f64);
        close(
            &format!("brokenPixels[{i}]"),
            b,
            f(&format!("brokenPixels[{i}]")),
            0.0,
        );
        close(
            &format!("outlierPixels[{i}]"),
            o,
            f(&format!("outlierPixels[{i}]")),
            0.0,
        );
    }
    let mut worst_alpha_rel = 0.0f64;
    for p in 0..PIXELS {
        // The library stores 1e-6/alpha rounded to a 16-bit integer, so alpha carries a relative
        // quantisation of at most half a unit of that integer against the sheet's exact value.
        let want = f(&format!("alpha[{p}]"));
        let rel = ((cal.alpha_of(p) as f64 - want) / want).abs();
        let bound = 0.5 / cal.alpha[p] as f64 + 1e-6;
        assert!(
            rel <= bound,
            "alpha[{p}]: relative error {rel:.3e} above {bound:.3e}"
        );
        worst_alpha_rel = worst_alpha_rel.max(rel);
        close(
            &format!("offset[{p}]"),
            cal.offset[p] as f64,
            f(&format!("offset[{p}]")),
            0.0,
        );
        close(
            &format!("kta[{p}]"),
            cal.kta_of(p) as f64,
            f(&format!("kta[{p}]")),
            5e-9,
        );
        close(
            &format!("kv[{p}]"),
            cal.kv_of(p) as f64,
            f(&format!("kv[{p}]")),
            5e-9,
        );
    }
    eprintln!("melexis example: worst alpha relative quantisation {worst_alpha_rel:.3e}");
}

/// Decode frames in order into one image, as `host-sim decode` does.
fn decode(
    dir: &Path,
    eeprom: &str,
    frames: &[&str],
    params: &DecodeParams,
) -> (Calibration, Image) {
    let cal = Calibration::from_eeprom(&read_eeprom(&dir.join(eeprom)).unwrap()).unwrap();
    let mut img = Image::new();
    for f in frames {
        let frame = read_frame(&dir.join(f)).unwrap();
        img.update(&frame, &cal, params).unwrap();
    }
    (cal, img)
}

#[test]
fn melexis_example_images_match_to_1e_3() {
    let Some(dir) = require_mlx90640_dir("melexis_example_images_match_to_1e_3") else {
        return;
    };
    let params = DecodeParams::default();
    let mut worst = 0.0f64;
    for (frames, expected, subpages) in [
        (
            &["melexis_example_frame0.hex"][..],
            "melexis_example_expected_To_frame0.csv",
            1,
        ),
        (
            &["melexis_example_frame0.hex", "melexis_example_frame1.hex"][..],
            "melexis_example_expected_To_frame1.csv",
            2,
        ),
    ] {
        let (_, img) = decode(&dir, "melexis_example_eeprom.hex", frames, &params);
        let want = expected_to(&dir, expected);
        let mut compared = 0;
        for p in 0..PIXELS {
            let got = img.to_k[p];
            if subpages == 1
                && !calc::pixel_in_subpage(p, thermorph::mlx90640::ReadingPattern::Chess, 0)
            {
                assert!(
                    got.is_nan(),
                    "pixel {p} of the other subpage must be uncovered"
                );
                continue;
            }
            let got_c = got as f64 - 273.15;
            let d = (got_c - want[p]).abs();
            assert!(
                d <= 1e-3,
                "{expected} pixel {p}: got {got_c:.6} °C, expected {}",
                want[p]
            );
            worst = worst.max(d);
            compared += 1;
        }
        assert_eq!(compared, 384 * subpages);
    }
    // The sheet prints three decimals, so up to 5e-4 of this is its rounding.
    eprintln!("melexis example: max |dTo| = {worst:.6} °C over 1152 pixel values");
}

#[test]
fn datasheet_worked_example() {
    let Some(dir) = require_mlx90640_dir("datasheet_worked_example") else {
        return;
    };
    let params = DecodeParams::default();
    let (cal, img) = decode(
        &dir,
        "datasheet_example_eeprom.hex",
        &["datasheet_example_frame_il_sp1.hex"],
        &params,
    );
    close("kVdd", cal.k_vdd as f64, -3168.0, 0.0);
    close("Vdd25", cal.vdd25 as f64, -13056.0, 0.0);
    close("KvPTAT", cal.kv_ptat as f64, 0.005371094, 1e-9);
    close("KtPTAT", cal.kt_ptat as f64, 42.25, 0.0);
    close("VPTAT25", cal.v_ptat25 as f64, 12273.0, 0.0);
    close("alphaPTAT", cal.alpha_ptat as f64, 9.0, 0.0);
    let p = 11 * 32 + 15; // pixel (12,16) in the datasheet's 1-based numbering
    close("offset", cal.offset[p] as f64, -75.0, 0.0);
    close("Kta", cal.kta_of(p) as f64, 0.005126953125, 0.0);
    close("Kv", cal.kv_of(p) as f64, 0.5, 0.0);
    close("KsTa", cal.ks_ta as f64, -0.001953125, 0.0);
    close("KsTo", cal.ks_to[1] as f64, -0.00080108642578125, 0.0);
    let frame = read_frame(&dir.join("datasheet_example_frame_il_sp1.hex")).unwrap();
    let kgain = cal.gain_ee as f64 / frame.words[IDX_GAIN] as i16 as f64;
    close("Kgain", kgain, 1.01753547, 1e-8);
    let vdd = calc::vdd_v(&frame, &cal);
    close("Vdd", vdd as f64, 3.319, 5e-4);
    let ta = calc::ta_c(&frame, &cal, vdd);
    close("Ta", ta as f64, 39.18442, 2e-4);
    // The reference library's value (it averages the CP alphas for TGC and applies the range
    // correction); the datasheet's literal formula gives 80.363.
    let to_c = img.to_k[p] as f64 - 273.15;
    close("To(12,16)", to_c, 80.414, 1e-3);

    // The same RAM read in chess mode: the calibration pattern, so no IL/chess correction and
    // subpage 0's compensation pixel. The pixel is in subpage 0 of the chess board.
    let (_, chess) = decode(
        &dir,
        "datasheet_example_eeprom.hex",
        &["datasheet_example_frame_chess_sp0.hex"],
        &params,
    );
    assert!(chess.to_k[p].is_finite());
    assert!(chess.to_k[p + 1].is_nan());
}

#[test]
fn other_public_dumps_decode_to_room_temperatures() {
    let Some(dir) = require_mlx90640_dir("other_public_dumps_decode_to_room_temperatures") else {
        return;
    };
    let params = DecodeParams::default();
    for (eeprom, frames) in [
        (
            "signaloid_eeprom.hex",
            &["signaloid_frame0.hex", "signaloid_frame1.hex"][..],
        ),
        (
            "ceri_eeprom.hex",
            &["ceri_ram0_frame00.hex", "ceri_ram1_frame01.hex"][..],
        ),
    ] {
        let (_, img) = decode(&dir, eeprom, frames, &params);
        assert!(img.complete(), "{eeprom}: both subpages");
        let s = img.stats().unwrap();
        assert_eq!(s.valid as usize, PIXELS, "{eeprom}");
        // Indoor scenes: every pixel between −10 °C and 60 °C.
        assert!(s.min.k() > 263.0 && s.max.k() < 333.0, "{eeprom}: {s:?}");
    }
    let jd = Calibration::from_eeprom(&read_eeprom(&dir.join("jamesdanielv_eeprom.hex")).unwrap());
    assert!(jd.is_ok(), "jamesdanielv EEPROM: {jd:?}");
}

#[test]
fn refused_eeprom_gives_a_clear_error() {
    let Some(dir) = require_mlx90640_dir("refused_eeprom_gives_a_clear_error") else {
        return;
    };
    let ee = read_eeprom(&dir.join("kedziorno_eeprom1.hex")).unwrap();
    let err = Calibration::from_eeprom(&ee).unwrap_err();
    assert_eq!(err, CalibrationError::TooManyBrokenPixels);
    assert!(err.to_string().contains("broken pixels"));
}

#[test]
fn broken_and_outlier_pixels_are_corrected_from_neighbours() {
    let Some(dir) = require_mlx90640_dir("broken_and_outlier_pixels_are_corrected_from_neighbours")
    else {
        return;
    };
    let mut ee = read_eeprom(&dir.join("melexis_example_eeprom.hex")).unwrap();
    // Pixel 300 (row 9, col 12) broken, pixel 500 (row 15, col 20) an outlier; 0 (a corner) broken.
    ee[64 + 300] = 0;
    ee[64 + 500] |= 1;
    ee[64] = 0;
    let cal = Calibration::from_eeprom(&ee).unwrap();
    assert_eq!(cal.broken_pixels.as_slice(), &[0, 300]);
    assert_eq!(cal.outlier_pixels.as_slice(), &[500]);
    let mut img = Image::new();
    for f in ["melexis_example_frame0.hex", "melexis_example_frame1.hex"] {
        img.update(
            &read_frame(&dir.join(f)).unwrap(),
            &cal,
            &DecodeParams::default(),
        )
        .unwrap();
    }
    let t = &img.to_k;
    let median = |p: usize| {
        let mut v = [t[p - 33], t[p - 31], t[p + 31], t[p + 33]];
        v.sort_by(f32::total_cmp);
        (v[1] + v[2]) / 2.0
    };
    assert_eq!(t[300], median(300));
    assert_eq!(t[500], median(500));
    assert_eq!(t[0], t[33], "corner pixel takes its one diagonal neighbour");
    // Adjacent bad pixels are refused.
    ee[64 + 301 + 32] = 0;
    assert_eq!(
        Calibration::from_eeprom(&ee).unwrap_err(),
        CalibrationError::AdjacentBadPixels {
            first: 300,
            second: 333
        }
    );
}
