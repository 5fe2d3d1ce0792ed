//! `host-sim decode` as a user runs it: CSV on success, one clear error naming the file.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use host_sim::imaging::data::require_mlx90640_dir;

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(args)
        .output()
        .expect("run host-sim")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn tmp(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("thermorph-decode-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn decodes_the_melexis_example() {
    let Some(dir) = require_mlx90640_dir("decodes_the_melexis_example") else {
        return;
    };
    let ee = dir.join("melexis_example_eeprom.hex");
    let f0 = dir.join("melexis_example_frame0.hex");
    let f1 = dir.join("melexis_example_frame1.hex");
    let out = run(&["decode", "--eeprom", s(&ee), "--frame", s(&f0)]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "pixel,row,col,value");
    assert_eq!(lines.len(), 769);
    assert_eq!(lines[2], "1,0,1,nan", "subpage 1 pixels uncovered");
    let v: f64 = lines[1].rsplit(',').next().unwrap().parse().unwrap();
    assert!((v - 28.711).abs() < 1e-3, "pixel 0: {v}");
    let decimals = lines[1]
        .rsplit(',')
        .next()
        .unwrap()
        .split('.')
        .nth(1)
        .unwrap();
    assert!(decimals.len() >= 6);

    let out = run(&[
        "decode",
        "--eeprom",
        s(&ee),
        "--frame",
        s(&f0),
        "--frame",
        s(&f1),
    ]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(!text.contains("nan"), "both subpages cover every pixel");

    // Emissivity and the Ta shift change the result: with the reflected temperature below the
    // object, a lower emissivity reads warmer; a different reflected temperature reads
    // differently.
    let first = |args: &[&str]| -> f64 {
        let out = run(args);
        assert!(out.status.success());
        String::from_utf8(out.stdout)
            .unwrap()
            .lines()
            .nth(1)
            .unwrap()
            .rsplit(',')
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    let v_eps = first(&[
        "decode",
        "--eeprom",
        s(&ee),
        "--frame",
        s(&f0),
        "--emissivity",
        "0.9",
    ]);
    assert!(v_eps > v + 0.1, "ε = 0.9 reads warmer: {v_eps} vs {v}");
    let v_shift = first(&[
        "decode",
        "--eeprom",
        s(&ee),
        "--frame",
        s(&f0),
        "--emissivity",
        "0.9",
        "--ta-shift",
        "-20",
    ]);
    assert!(
        (v_shift - v_eps).abs() > 0.1,
        "the Ta shift matters: {v_shift} vs {v_eps}"
    );
}

fn assert_one_error_naming(out: &Output, file: &Path, what: &str) {
    assert!(!out.status.success(), "must fail");
    assert!(out.stdout.is_empty(), "no partial CSV");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim_end().lines().count(), 1, "one error line: {err}");
    assert!(err.contains(s(file)), "names the file: {err}");
    assert!(err.contains(what), "says what is wrong ({what}): {err}");
}

#[test]
fn bad_files_get_one_clear_error() {
    let Some(dir) = require_mlx90640_dir("bad_files_get_one_clear_error") else {
        return;
    };
    let ee = dir.join("melexis_example_eeprom.hex");
    let f0 = dir.join("melexis_example_frame0.hex");
    let short = tmp("short.hex", "00AE 499A\n");
    let out = run(&["decode", "--eeprom", s(&short), "--frame", s(&f0)]);
    assert_one_error_naming(&out, &short, "832 words");
    let out = run(&["decode", "--eeprom", s(&ee), "--frame", s(&short)]);
    assert_one_error_naming(&out, &short, "834 words");
    let nonhex = tmp(
        "nonhex.hex",
        &"00AE\n"
            .repeat(400)
            .replace("00AE\n00AE\n00AE", "00AE\nXYZ\n00AE"),
    );
    let out = run(&["decode", "--eeprom", s(&nonhex), "--frame", s(&f0)]);
    assert_one_error_naming(&out, &nonhex, "`XYZ`");
    let refused = dir.join("kedziorno_eeprom1.hex");
    let out = run(&["decode", "--eeprom", s(&refused), "--frame", s(&f0)]);
    assert_one_error_naming(&out, &refused, "broken pixels");
    let missing = dir.join("no_such_file.hex");
    let out = run(&["decode", "--eeprom", s(&missing), "--frame", s(&f0)]);
    assert_one_error_naming(&out, &missing, "cannot read");
    let out = run(&[
        "decode",
        "--eeprom",
        s(&ee),
        "--frame",
        s(&f0),
        "--emissivity",
        "1.5",
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("emissivity"));
}
