//! `host-sim mtts` and `host-sim scene` as a user runs them.

use std::process::{Command, Output};

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(args)
        .output()
        .expect("run host-sim")
}

fn tmp(name: &str, bytes: &[u8]) -> String {
    let dir = std::env::temp_dir().join(format!("thermorph-mtts-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p.to_str().unwrap().to_string()
}

#[test]
fn scene_then_mtts_finds_the_truth() {
    let scene = run(&["scene", "heating-358", "--seed", "2"]);
    assert!(scene.status.success());
    let text = String::from_utf8(scene.stdout.clone()).unwrap();
    let truth: Vec<f64> = text
        .lines()
        .filter(|l| l.starts_with("# truth"))
        .map(|l| {
            l.split(": ")
                .nth(1)
                .unwrap()
                .trim_end_matches(" K")
                .parse()
                .unwrap()
        })
        .collect();
    let path = tmp("heating.csv", &scene.stdout);
    for method in ["exact", "lloyd", "kmeanspp"] {
        // The heating mode's prior: the heater area is the hotter target.
        let out = run(&[
            "mtts",
            "--image",
            &path,
            "--method",
            method,
            "--seed",
            "3",
            "--prior",
            "heater-hotter",
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let csv = String::from_utf8(out.stdout).unwrap();
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines[0], "region,name,temp_k,pixels");
        assert_eq!(lines.len(), 8, "{csv}");
        assert!(
            lines[6].starts_with("# quality resolved, bound "),
            "{}",
            lines[6]
        );
        // The thesis's lattice as designed: its exposure, and no warning.
        assert!(
            lines[7].starts_with("# exposure fitted 7") && lines[7].ends_with(", design 71.0 %"),
            "{}",
            lines[7]
        );
        let names: Vec<&str> = lines[1..6]
            .iter()
            .map(|l| l.split(',').nth(1).unwrap())
            .collect();
        assert_eq!(
            names,
            ["heater", "surface", "edge", "radiation", "background"]
        );
        if method == "exact" {
            for (i, l) in lines[1..3].iter().enumerate() {
                let t: f64 = l.split(',').nth(2).unwrap().parse().unwrap();
                assert!(
                    (t - truth[i]).abs() < 2.0,
                    "region {}: {t} vs {}",
                    i + 1,
                    truth[i]
                );
            }
        }
    }
    // Other settings run too.
    let out = run(&["mtts", "--image", &path, "--scale", "1", "--k", "3"]);
    assert!(out.status.success());
}

#[test]
fn scene_lists_and_mtts_reads_decoded_csv_and_hints_at_celsius() {
    let list = run(&["scene"]);
    assert!(list.status.success());
    let list = String::from_utf8(list.stdout).unwrap();
    assert_eq!(list.lines().count(), 12, "{list}");
    assert!(
        list.contains("heating-358 ") && list.contains("ambient-318 "),
        "{list}"
    );

    let scene = run(&["scene", "heating-358"]);
    let text = String::from_utf8(scene.stdout).unwrap();
    let grid: Vec<Vec<f64>> = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    // The same image as `host-sim decode` writes it (°C), and as a °C grid.
    let mut decoded = String::from("pixel,row,col,value\n");
    let mut celsius = String::new();
    for (r, row) in grid.iter().enumerate() {
        for (c, k) in row.iter().enumerate() {
            decoded += &format!("{},{r},{c},{:.6}\n", r * 32 + c, k - 273.15);
        }
        let cells: Vec<String> = row.iter().map(|k| format!("{:.3}", k - 273.15)).collect();
        celsius += &(cells.join(",") + "\n");
    }
    let kelvin = run(&["mtts", "--image", &tmp("k.csv", text.as_bytes())]);
    let from_dump = run(&["mtts", "--image", &tmp("decoded.csv", decoded.as_bytes())]);
    assert!(
        from_dump.status.success(),
        "{}",
        String::from_utf8_lossy(&from_dump.stderr)
    );
    assert!(from_dump.stderr.is_empty());
    let temps = |o: &Output| -> Vec<f64> {
        String::from_utf8_lossy(&o.stdout)
            .lines()
            .skip(1)
            .take(5)
            .map(|l| l.split(',').nth(2).unwrap().parse().unwrap())
            .collect()
    };
    for (a, b) in temps(&kelvin).iter().zip(temps(&from_dump)) {
        assert!((a - b).abs() < 0.01, "{a} vs {b}");
    }
    let c = run(&["mtts", "--image", &tmp("celsius.csv", celsius.as_bytes())]);
    let hint = String::from_utf8_lossy(&c.stderr);
    assert!(hint.contains("looks like °C; MTTS reads kelvin"), "{hint}");
    assert!(kelvin.stderr.is_empty());
    // A decoded CSV with a line out of place is refused, naming it.
    let bad = decoded.replacen("\n40,1,8,", "\n40,2,8,", 1);
    let out = run(&["mtts", "--image", &tmp("bad-decoded.csv", bad.as_bytes())]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("line 42: `40,2,8,") && err.contains("host-sim decode"),
        "{err}"
    );
}

#[test]
fn bad_input_gets_one_clear_error() {
    let bad_rows = tmp("short.csv", b"300,301\n");
    for (args, what) in [
        (vec!["mtts", "--image", bad_rows.as_str()], "2 values"),
        (vec!["mtts", "--image", "/nonexistent/x.csv"], "cannot read"),
        (
            vec!["mtts", "--image", bad_rows.as_str(), "--method", "kmeans"],
            "method",
        ),
        (vec!["scene", "nope"], "no scene"),
    ] {
        let out = run(&args);
        assert!(!out.status.success(), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(what), "{args:?}: {err}");
        assert!(out.stdout.is_empty());
    }
    let all_nan = tmp(
        "nan.csv",
        format!("{}nan\n", "nan,".repeat(31)).repeat(24).as_bytes(),
    );
    let out = run(&["mtts", "--image", &all_nan]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("no valid pixel"));
    let bad_k = run(&["mtts", "--image", &all_nan, "--k", "9"]);
    assert!(String::from_utf8_lossy(&bad_k.stderr).contains("cluster count 9"));
}

/// Issue 43: an image whose lattice shows the heater through a fraction unlike the design (the
/// forming scene's inverted hot zone read under the heating prior: hot stripes 0.29 of the
/// period, the heater's under that prior) is ambiguous — one frame cannot tell it from its
/// design under a lagging prior — with a bound spanning both answers, and a `# warning` line
/// names both fractions; under the prior that fits the design there is none.
#[test]
fn an_image_unlike_its_design_is_ambiguous_and_says_so() {
    let scene = run(&["scene", "forming-inversion", "--seed", "1"]);
    assert!(scene.status.success());
    let path = tmp("forming.csv", &scene.stdout);
    let mtts = |prior: &str| {
        let out = run(&["mtts", "--image", &path, "--prior", prior]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8(out.stdout).unwrap()
    };
    let unlike = mtts("heater-hotter");
    assert!(unlike.contains("# quality ambiguous, bound "), "{unlike}");
    let bound: f64 = unlike
        .lines()
        .find_map(|l| l.strip_prefix("# quality ambiguous, bound "))
        .and_then(|b| b.trim_end_matches(" K").parse().ok())
        .expect("a bound");
    // T1 318 K, T2 336 K: either answer lies within the bound.
    assert!(bound >= 18.0, "{unlike}");
    let warning = unlike
        .lines()
        .find(|l| l.starts_with("# warning: "))
        .unwrap_or_else(|| panic!("no warning: {unlike}"));
    assert!(
        warning.contains("lattice 29 % exposed") || warning.contains("lattice 30 % exposed"),
        "{warning}"
    );
    assert!(warning.contains("its design 71 %"), "{warning}");
    let designed = mtts("surface-hotter");
    assert!(designed.contains("# quality resolved"), "{designed}");
    assert!(!designed.contains("# warning"), "{designed}");
}
