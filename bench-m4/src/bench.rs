//! The bench itself (target only).

use core::hint::black_box;

use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};
use thermorph::mlx90640::{Calibration, DecodeParams, Image, SubpageFrame};
use thermorph::mtts::{Config, Method, Mtts, Scratch};
use thermorph::units::k_or_nan;

mod control;
mod observer;
mod posture;

mod data {
    include!(concat!(env!("OUT_DIR"), "/data.rs"));
}

/// FPGAIO free-running counter, 25 MHz of virtual time.
const COUNTER: *const u32 = 0x4002_8018 as *const u32;

fn ticks() -> u32 {
    // SAFETY: a read-only MMIO register of the mps2-an386 FPGAIO block.
    unsafe { core::ptr::read_volatile(COUNTER) }
}

/// Instructions in `ticks` of the 25 MHz counter at 1024 ns per instruction.
fn insns(t: u32) -> u64 {
    (t as u64 * 40 + 512) / 1024
}

fn measure<R>(f: impl FnOnce() -> R) -> (R, u64) {
    let t0 = ticks();
    let r = f();
    let t1 = ticks();
    (r, insns(t1.wrapping_sub(t0)))
}

/// A loop of exactly 2·n instructions (subs + bne per turn).
fn known_loop(n: u32) {
    // SAFETY: pure register arithmetic.
    unsafe {
        core::arch::asm!("1:", "subs {0}, {0}, #1", "bne 1b", inout(reg) n => _, options(nomem, nostack));
    }
}

/// Report a failure and stop QEMU with a failing status.
fn fail(what: &str) -> ! {
    hprintln!("error: {}", what);
    finish(debug::EXIT_FAILURE)
}

/// Stop QEMU.
fn finish(code: debug::ExitStatus) -> ! {
    debug::exit(code);
    loop {
        cortex_m::asm::wfi();
    }
}

static mut CAL: Calibration = Calibration::new();
static mut SCRATCH: Scratch = Scratch::new();
static mut FRAMES: [SubpageFrame; 2] = [SubpageFrame::new(), SubpageFrame::new()];

#[entry]
fn main() -> ! {
    // SAFETY: single-threaded bench, each static borrowed once here.
    let (cal, scratch, frames) = unsafe {
        (
            &mut *core::ptr::addr_of_mut!(CAL),
            &mut *core::ptr::addr_of_mut!(SCRATCH),
            &mut *core::ptr::addr_of_mut!(FRAMES),
        )
    };
    frames[0].words.copy_from_slice(&data::FRAME0);
    frames[1].words.copy_from_slice(&data::FRAME1);

    let (_, overhead) = measure(|| ());
    let (_, check) = measure(|| known_loop(black_box(50_000)));
    hprintln!(
        "selfcheck insns={} expected=100000 overhead={}",
        check,
        overhead
    );

    if cal.extract(&data::EEPROM).is_err() {
        fail("calibration refused");
    }
    let params = DecodeParams::default();
    let mut image = Image::new();
    let (ok, to_768) = measure(|| {
        image.update(&frames[0], cal, &params).is_ok()
            && image.update(&frames[1], cal, &params).is_ok()
    });
    if !ok {
        fail("frame refused");
    }
    let Ok(mut mtts) = Mtts::new(Config::default()) else {
        fail("config")
    };
    let (up, upsample) = measure(|| mtts.stage_upsample(&image.to_k, scratch));
    let Ok(filled) = up else { fail("upsample") };
    let (cl, cluster) = measure(|| mtts.stage_cluster(scratch));
    let Ok(clusters) = cl else { fail("cluster") };
    let (out, regions) = measure(|| mtts.stage_regions(&clusters, filled, scratch));
    let total = to_768 + upsample + cluster + regions;
    // The next frame starts from this one's geometry (the lattice search narrows to ±2 px).
    let (_, regions_next) = measure(|| black_box(mtts.stage_regions(&clusters, filled, scratch)));
    // A block of thin stripes (designed 85 % exposed): the lattice fits six harmonics, not five,
    // and models ten (`lattice::harmonics_for`, `model_for`); its first frame is held to the
    // same budget.
    let Ok(mut thin) = Mtts::new(Config {
        exposed_pct: 85,
        ..Config::default()
    }) else {
        fail("config")
    };
    let (_, regions_thin) = measure(|| black_box(thin.stage_regions(&clusters, filled, scratch)));
    // Parts of the upsample stage, for profiling.
    let mut w2 = image.to_k;
    let (_, t_inpaint) = measure(|| thermorph::mtts::inpaint(&mut w2));
    // The same frame with four pixels the driver flags as broken (NaN; the datasheet allows up
    // to four defective pixels): filled in, and no second pass over the frame.
    let mut w4 = image.to_k;
    for q in [37, 300, 301, 700] {
        w4[q] = f32::NAN;
    }
    let (_, t_inpaint4) = measure(|| thermorph::mtts::inpaint(&mut w4));
    if let Ok(up) = thermorph::mtts::upsample::Upsampler::new(4) {
        let mut us = thermorph::mtts::upsample::UpsampleScratch::new();
        let (_, t_interp) = measure(|| {
            let mut acc = 0.0f32;
            up.run(&w2, &mut us, |_, row| acc += row[0]);
            black_box(acc)
        });
        let mut h = thermorph::mtts::cluster::Histogram::EMPTY;
        let (_, t_reset) = measure(|| black_box(h.reset(300.0, 400.0, 128)));
        let (_, t_hist) = measure(|| up.histogram(&w2, &mut h, &mut us));
        let (_, t_minmax) = measure(|| {
            black_box(
                w2.iter()
                    .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| {
                        (a.min(v), b.max(v))
                    }),
            )
        });
        hprintln!(
            "part inpaint insns={} inpaint_four_broken insns={} interpolate_only insns={} fused_histogram insns={} reset insns={} minmax insns={}",
            t_inpaint,
            t_inpaint4,
            t_interp,
            t_hist,
            t_reset,
            t_minmax
        );
    }
    let g0 = thermorph::mtts::regions::Geometry::DEFAULT;
    let (_, t_cyl) = measure(|| {
        black_box(thermorph::mtts::regions::fit_cylinder(
            &scratch.work,
            (scratch.coldest_k, scratch.hottest_k),
        ))
    });
    let (xy, t_xy) = measure(|| g0.coords_all());
    let (_, t_lat) = measure(|| {
        let mut g = g0;
        black_box(thermorph::mtts::lattice::separate(
            &scratch.work,
            &xy,
            &mut g,
            thermorph::mtts::Prior::Unknown,
            f32::from(thermorph::mtts::DEFAULT_EXPOSED_PCT) / 100.0,
            scratch.hottest_k - scratch.coldest_k,
            &scratch.filled,
        ))
    });
    let (_, t_ov) = measure(|| {
        black_box(thermorph::mtts::regions::overlap(
            &scratch.work,
            &out.geometry,
            &xy,
            &clusters,
        ))
    });
    hprintln!(
        "part fit_cylinder insns={} coords_all insns={} fit_lattice insns={} overlap insns={}",
        t_cyl,
        t_xy,
        t_lat,
        t_ov
    );
    hprintln!("to_768 insns={}", to_768.saturating_sub(overhead));
    hprintln!("upsample insns={}", upsample.saturating_sub(overhead));
    hprintln!("cluster insns={}", cluster.saturating_sub(overhead));
    hprintln!("regions insns={}", regions.saturating_sub(overhead));
    hprintln!("total insns={}", total.saturating_sub(4 * overhead));
    hprintln!(
        "regions_next_frame insns={}",
        regions_next.saturating_sub(overhead)
    );
    hprintln!(
        "total_next_frame insns={}",
        (total - regions + regions_next).saturating_sub(4 * overhead)
    );
    hprintln!(
        "regions_thin_design insns={}",
        regions_thin.saturating_sub(overhead)
    );
    hprintln!(
        "total_thin_design insns={}",
        (total - regions + regions_thin).saturating_sub(4 * overhead)
    );
    // The result, to show the bench computed something real (truth: T1 372 K, T2 352 K).
    hprintln!(
        "result t1_k={} t2_k={} clusters={}",
        k_or_nan(out.t1()),
        k_or_nan(out.t2()),
        out.clusters.k
    );

    // Work-precision figures: MTTS instructions per frame (upsample + cluster + regions, a first
    // frame: fresh geometry) for each factor and method (`host-sim mtts-wp --m4` reads these).
    for scale in [1u8, 2, 4, 8] {
        for (method, name) in [
            (Method::Exact, "exact"),
            (Method::Lloyd, "lloyd"),
            (Method::KMeansPlusPlus, "kmeanspp"),
        ] {
            let config = Config {
                scale,
                method,
                ..Config::default()
            };
            let Ok(mut m) = Mtts::new(config) else {
                fail("wp config")
            };
            let (r, t) = measure(|| m.process(&image.to_k, scratch).is_ok());
            if !r {
                fail("wp frame");
            }
            hprintln!(
                "wp_mtts scale={} method={} insns={}",
                scale,
                name,
                t.saturating_sub(overhead)
            );
        }
    }

    // Work-precision figures: the to_768 stage (both subpages, a fresh image) with each roots
    // variant (`host-sim mtts-wp --m4` reads these). libm's sqrtf is correctly rounded, as
    // VSQRT is: the two images must agree to the bit, or the hardware path is broken.
    for (name, update) in crate::roots::VARIANTS {
        let mut img = Image::new();
        let (ok, t) = measure(|| {
            update(&mut img, &frames[0], cal, &params).is_ok()
                && update(&mut img, &frames[1], cal, &params).is_ok()
        });
        if !ok {
            fail("wp_roots frame refused");
        }
        let same_bits = img
            .to_k
            .iter()
            .zip(image.to_k.iter())
            .all(|(a, b)| a.to_bits() == b.to_bits());
        if (name == "vsqrt" || name == "libm_sqrtf") && !same_bits {
            fail("wp_roots: the image differs from the default path's");
        }
        hprintln!(
            "wp_roots variant={} to768_insns={}",
            name,
            t.saturating_sub(overhead)
        );
    }

    // Square and fourth roots: cost per call.
    let xs: [f32; 8] = [8.1e9, 1.2e10, 2.0e10, 4.4e9, 9.9e10, 6.5e9, 3.3e10, 7.7e9];
    let n = 64;
    let (_, t) = measure(|| {
        let mut a = 0.0;
        for i in 0..n {
            a += thermorph::fmath::sqrt(black_box(xs[i % 8]));
        }
        black_box(a)
    });
    hprintln!("sqrt_vsqrt insns_per_call={}", t / n as u64);
    let (_, t) = measure(|| {
        let mut a = 0.0;
        for i in 0..n {
            a += libm::sqrtf(black_box(xs[i % 8]));
        }
        black_box(a)
    });
    hprintln!("sqrt_libm insns_per_call={}", t / n as u64);
    let (_, t) = measure(|| {
        let mut a = 0.0;
        for i in 0..n {
            a += libm::powf(black_box(xs[i % 8]), black_box(0.25));
        }
        black_box(a)
    });
    hprintln!("root4_powf insns_per_call={}", t / n as u64);
    let (_, t) = measure(|| {
        let mut a = 0.0;
        for i in 0..n {
            a += thermorph::fmath::root4(black_box(xs[i % 8]));
        }
        black_box(a)
    });
    hprintln!("root4_vsqrt insns_per_call={}", t / n as u64);
    control::bench(overhead);
    observer::bench(overhead);
    posture::bench(overhead);
    finish(debug::EXIT_SUCCESS)
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    fail("panic")
}
