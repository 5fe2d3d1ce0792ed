//! Host timings of the sensing pipeline's stages (the Cortex-M4 counts are `scripts/bench-m4`):
//! `cargo bench -p host-sim --bench mtts`.
//!
//! Input: the realistic virtual sensor's EEPROM and two raw subpages of the rendered
//! `heating-358` scene — the same input as the QEMU bench.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use thermorph::mlx90640::{Calibration, DecodeParams, Image};
use thermorph::mtts::{Config, Method, Mtts, Scratch};

fn stages(c: &mut Criterion) {
    let (eeprom, frames) = host_sim::sensor::demo::bench_input("heating-358").unwrap();
    let cal = Calibration::from_eeprom(&eeprom).unwrap();
    let params = DecodeParams::default();
    let mut image = Image::new();
    // The image every later bench reads, whether or not a filter runs `to_768`.
    image.update(&frames[0], &cal, &params).unwrap();
    image.update(&frames[1], &cal, &params).unwrap();

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
        let filled = m.stage_upsample(&image.to_k, &mut scratch).unwrap();
        let clusters = m.stage_cluster(&mut scratch).unwrap();
        if method == Method::Exact {
            c.bench_function("upsample", |b| {
                b.iter(|| {
                    m.stage_upsample(black_box(&image.to_k), &mut scratch)
                        .unwrap()
                })
            });
            c.bench_function("regions", |b| {
                b.iter(|| m.stage_regions(black_box(&clusters), filled, &mut scratch))
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
