//! `host-sim paper`: the thesis's experiments against the firmware's supervisor, camera on.
//! Every SPEC section 8 figure must pass, except those listed in [`PLANT_SHORTFALLS`] with the
//! reason the simulated block cannot show them yet (a row listed there that passes fails this
//! test, so the list cannot go stale).

use std::process::Command;

use host_sim::runs::cycle_figures::PLANT_SHORTFALLS;

#[test]
fn every_figure_passes_or_is_a_known_plant_shortfall() {
    let table = host_sim::runs::paper::figures(true, None).unwrap();
    let keys: Vec<&str> = table.iter().map(|f| f.key.as_str()).collect();
    assert_eq!(keys, host_sim::runs::paper::KEYS);
    let mut wrong = Vec::new();
    for f in &table {
        let k = &f.key;
        let known = PLANT_SHORTFALLS.iter().find(|(n, _)| n == k);
        println!(
            "{k:<30} thesis {:<12} sim {:<28} {}",
            f.thesis.to_string(),
            f.simulated.to_string(),
            if f.passes() { "pass" } else { "FAIL" }
        );
        match (f.passes(), known) {
            (true, None) => {}
            (false, None) => wrong.push(format!("{k} fails: sim {}", f.simulated)),
            (false, Some((_, why))) => println!("  known shortfall: {why}"),
            (true, Some(_)) => wrong.push(format!("{k} passes: take it off PLANT_SHORTFALLS")),
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}

#[test]
fn json_has_exactly_the_spec_keys() {
    let out = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(["paper", "--json", "--no-camera"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let obj = v.as_object().unwrap();
    let mut keys: Vec<&str> = obj.keys().map(|k| k.as_str()).collect();
    keys.sort();
    let mut want = host_sim::runs::paper::KEYS.to_vec();
    want.sort();
    assert_eq!(keys, want);
    for (k, f) in obj {
        let f = f.as_object().unwrap();
        let mut fk: Vec<&str> = f.keys().map(|k| k.as_str()).collect();
        fk.sort();
        assert_eq!(fk, ["pass", "sim", "thesis"], "{k}");
        assert!(f["pass"].is_boolean(), "{k}");
    }
    assert_eq!(obj["pulse_drop_deg"]["sim"].as_array().unwrap().len(), 3);
}
