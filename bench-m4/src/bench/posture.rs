//! The bend estimate's cost (`thermorph::posture::Posture`), each call on its own after a
//! warm-up (springs A and B heating towards austenite against a soft wall, a frame's tilt
//! every 5th step):
//!
//! - `posture_predict insns=N mean=M`: one control step's prediction (the stored bend, three
//!   Gauss–Newton iterations of the springs against the SMP, the covariance's relaxation);
//! - `posture_correct insns=N mean=M`: one frame's tilt fused (a scalar Kalman update along the
//!   camera's rows, `cam_azimuth_deg`);
//! - `posture_reach insns=N`: the reach of two springs (`mode pose`'s check, once a command).
//!
//! `N` is the worst of the measured calls, `M` their mean. `scripts/bench-m4` holds
//! `posture_predict` + `posture_correct` to 5 000 instructions.

use core::hint::black_box;

use cortex_m_semihosting::hprintln;
use thermorph::measurement::Tilt;
use thermorph::observer::{Estimate, Observer, ObserverParams};
use thermorph::outputs::SpringMask;
use thermorph::posture::Posture;
use thermorph::units::Seconds;

/// Calls measured per kind.
const CALLS: u32 = 16;

/// The observer's estimate at step `k`: a soft wall, springs A and B turning austenite.
fn estimate(base: &Estimate, k: u32) -> Estimate {
    let a = (0.02 * k as f32).min(1.0);
    Estimate {
        frozen: 0.01,
        austenite: [a, a, 0.0],
        ..*base
    }
}

/// Measure and print the lines.
pub fn bench(overhead: u64) {
    let base = Observer::new(&ObserverParams::DEFAULT, 298.15).estimate();
    let dt = Seconds::lit(0.05);
    let mut p = Posture::new();
    for k in 0..40u32 {
        p.predict(&estimate(&base, k), dt);
        if k % 5 == 0 {
            p.correct(
                Tilt {
                    deg: 0.3 * k as f32,
                    sd_deg: 0.3,
                },
                0.0,
            );
        }
    }
    let (mut worst_p, mut sum_p, mut worst_c, mut sum_c) = (0u64, 0u64, 0u64, 0u64);
    for i in 0..CALLS {
        let e = estimate(&base, 40 + i);
        let ((), t) = super::measure(|| p.predict(black_box(&e), black_box(dt)));
        let t = t.saturating_sub(overhead);
        worst_p = worst_p.max(t);
        sum_p += t;
        let tilt = Tilt {
            deg: 12.0 + 0.1 * i as f32,
            sd_deg: 0.3,
        };
        // The camera's mount as a setting (a black box: the general update, sine and cosine).
        let ((), t) = super::measure(|| p.correct(black_box(tilt), black_box(0.0)));
        let t = t.saturating_sub(overhead);
        worst_c = worst_c.max(t);
        sum_c += t;
    }
    let Some(ab) = SpringMask::parse("AB") else {
        super::fail("spring mask")
    };
    let (reach, t) = super::measure(|| Posture::reach_deg(black_box(ab), black_box(0.05)));
    let b = p.bend();
    if !(b.deg.is_finite() && reach.is_finite()) {
        super::fail("posture");
    }
    hprintln!(
        "posture_predict insns={} mean={}",
        worst_p,
        sum_p / CALLS as u64
    );
    hprintln!(
        "posture_correct insns={} mean={}",
        worst_c,
        sum_c / CALLS as u64
    );
    hprintln!(
        "posture_reach insns={} bend_deg={:.1} reach_deg={:.1}",
        t.saturating_sub(overhead),
        b.deg,
        reach
    );
}
