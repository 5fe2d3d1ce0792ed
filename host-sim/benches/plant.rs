//! The plant's 110 s reference scene (heat, bend with two springs, cool, recover) at full
//! fidelity and the 0.5 s control period; budget ≤ 11 ms.

use criterion::{Criterion, criterion_group, criterion_main};
use host_sim::plant::wp::{run_scene, scene_config};
use host_sim::plant::{Fidelity, Integrator};

fn plant_scene(c: &mut Criterion) {
    let config = scene_config(Integrator::default(), 0.5, Fidelity::default());
    c.bench_function("plant_110s_full_0p5s", |b| {
        b.iter(|| run_scene(std::hint::black_box(&config)).expect("valid config"))
    });
}

criterion_group!(benches, plant_scene);
criterion_main!(benches);
