//! Whole-run speed: a 110 s scene (heat, bend with two springs, form, recover) at full
//! fidelity through `host_sim::runs::run::run`, with the camera off (true temperatures to the
//! controller; the issue's target is ≤ 11 ms, 10⁴× real time) and on (every 8 Hz subpage
//! rendered, encoded by the virtual MLX90640, read by the firmware's driver, and MTTS on
//! every whole frame).

use criterion::{Criterion, criterion_group, criterion_main};
use host_sim::runs::run::run;
use host_sim::runs::scenario::parse;

/// The thesis's step–form–recover cycle squeezed into 110 s, open loop.
const SCENE_110_S: &str = r#"
name = "bench-110"
duration = "110 s"
ambient = "298.15 K"
[[action]]
at = "0 s"
heater = "100 %"
[[action]]
at = "20 s"
heater = "35 %"
springs = "AB"
[[action]]
at = "60 s"
heater = "0 %"
fan = "100 %"
[[action]]
at = "90 s"
springs = "none"
fan = "0 %"
heater = "100 %"
"#;

fn bench(c: &mut Criterion) {
    let mut scene = parse(SCENE_110_S, "bench", "bench-110").expect("bench scene");
    let mut g = c.benchmark_group("run_110s");
    g.bench_function("camera_off", |b| {
        b.iter(|| run(&scene, &mut |_| ()).expect("run"))
    });
    scene.camera.enabled = true;
    g.sample_size(10);
    g.bench_function("camera_on", |b| {
        b.iter(|| run(&scene, &mut |_| ()).expect("run"))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
