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
        assert_eq!(lines.len(), 7);
        assert!(
            lines[6].starts_with("# quality resolved, bound "),
            "{}",
            lines[6]
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
