//! Host timings of the sensing pipeline's stages (the Cortex-M4 counts are `scripts/bench-m4`):
//! `cargo bench -p host-sim --bench mtts`.
//!
//! Input: the realistic virtual sensor's EEPROM and two raw subpages of the rendered
//! `heating-358` scene — the same input as the QEMU bench.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use host_sim::scene::standard_scenes;
use host_sim::sim_time::SimClock;
use host_sim::virtual_mlx::VirtualMlx90640;
use thermorph::mlx90640::{
    Calibration, Control, DecodeParams, Image, ReadingPattern, RefreshRate, Resolution,
};
use thermorph::mtts::{Config, Method, Mtts, Scratch};

fn stages(c: &mut Criterion) {
    let eeprom = host_sim::eeprom::realistic(1).encode().unwrap();
    let cal = Calibration::from_eeprom(&eeprom).unwrap();
    let mut dev = VirtualMlx90640::new(eeprom, SimClock::new(), 7).unwrap();
    dev.set_control(Control(0).with(RefreshRate::Hz8, Resolution::Bits18, ReadingPattern::Chess));
    let scene = standard_scenes()
        .into_iter()
        .find(|s| s.name == "heating-358")
        .unwrap();
    dev.field_k = scene.render(1).image_k;
    let frames = [dev.raw_subpage(0), dev.raw_subpage(1)];
    let params = DecodeParams::default();
    let mut image = Image::new();

    c.bench_function("to_768", |b| {
        b.iter(|| {
            image.update(black_box(&frames[0]), &cal, &params).unwrap();
            image.update(black_box(&frames[1]), &cal, &params).unwrap();
        })
    });
    let mut scratch = Box::new(Scratch::new());
    for method in [Method::Exact, Method::Lloyd, Method::KMeansPlusPlus] {
        let mut m = Mtts::new(Config {
            method,
            ..Config::default()
        })
        .unwrap();
        let tag = format!("{method:?}").to_lowercase();
        let (work, filled) = m.stage_upsample(&image.to_k, &mut scratch).unwrap();
        let clusters = m.stage_cluster(&mut scratch).unwrap();
        if method == Method::Exact {
            c.bench_function("upsample", |b| {
                b.iter(|| {
                    m.stage_upsample(black_box(&image.to_k), &mut scratch)
                        .unwrap()
                })
            });
            c.bench_function("regions", |b| {
                b.iter(|| m.stage_regions(black_box(&work), &clusters, filled))
            });
        }
        c.bench_function(&format!("cluster_{tag}"), |b| {
            b.iter(|| m.stage_cluster(black_box(&mut scratch)).unwrap())
        });
        c.bench_function(&format!("total_{tag}"), |b| {
            b.iter(|| m.process(black_box(&image.to_k), &mut scratch).unwrap())
        });
    }
}

criterion_group!(benches, stages);
criterion_main!(benches);
