//! The camera chain per 8 Hz subpage, as `host-sim run` drives it: render the view of the
//! block, encode it by the virtual MLX90640 (noise on), decode it by the firmware's
//! calculation — `cargo bench -p host-sim --bench camera`.
//!
//! - `subpage`: one subpage with the column's geometry unchanged since the last view (the
//!   renderer keeps which region each sample shows; only the temperatures are applied).
//! - `subpage_new_geometry`: the same with the column's tilt changed (the regions worked out
//!   again), as every period of a bending column.
//! - `layout`: working out the regions alone.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use host_sim::imaging::view::{Geometry, Layout, Temps};
use host_sim::sensor::sim_time::SimClock;
use host_sim::sensor::virtual_mlx::VirtualMlx90640;
use thermorph::mlx90640::{
    Calibration, Control, DecodeParams, Image, PIXELS, ReadingPattern, RefreshRate, Resolution,
};

fn bench(c: &mut Criterion) {
    let eeprom = host_sim::sensor::eeprom::realistic(1).encode().unwrap();
    let cal = Calibration::from_eeprom(&eeprom).unwrap();
    let mut dev = VirtualMlx90640::new(eeprom, SimClock::new(), 1).unwrap();
    dev.set_control(Control(0).with(RefreshRate::Hz8, Resolution::Bits18, ReadingPattern::Chess));
    dev.noise_k = 0.1;
    let params = DecodeParams::default();
    let mut image = Image::new();
    let geometry = |tilt_deg: f64| Geometry {
        tilt_deg,
        springs: true,
        ..Geometry::default()
    };
    let temps = Temps {
        spring_k: 341.0,
        ..Temps::from_surfaces(298.15, 361.0, 358.0, 0.0)
    };
    let mut view = [0f64; PIXELS];
    let mut sp = 0u8;
    let mut subpage = |layout: &Layout, dev: &mut VirtualMlx90640, image: &mut Image| {
        layout.image(black_box(&temps), &mut view);
        for (dst, &k) in dev.field_k.iter_mut().zip(view.iter()) {
            *dst = k as f32;
        }
        sp ^= 1;
        let frame = dev.raw_subpage(sp);
        image.update(black_box(&frame), &cal, &params).unwrap();
    };

    let mut g = c.benchmark_group("camera");
    let layout = Layout::new(&geometry(8.0), 4);
    g.bench_function("subpage", |b| {
        b.iter(|| subpage(&layout, &mut dev, &mut image))
    });
    let mut tilt = 8.0;
    g.bench_function("subpage_new_geometry", |b| {
        b.iter(|| {
            tilt += 0.01;
            let layout = Layout::new(&geometry(tilt), 4);
            subpage(&layout, &mut dev, &mut image)
        })
    });
    g.bench_function("layout", |b| {
        b.iter(|| Layout::new(black_box(&geometry(8.0)), 4))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
