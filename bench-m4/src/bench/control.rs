//! The control step's cost: `Supervisor::step` with a new measurement and the spring channels'
//! readings (PID, cascade, safety checks, the channels' checks and their fusion into the
//! springs' estimates, spring timing, the state observer's prediction, correction and
//! estimates), the
//! dearest path — large stepping with two springs, the cascade on the colder region — measured
//! over a simulated run and reported as its worst step (`control insns=N`; `scripts/bench-m4`
//! holds it to 20 000). The worst is a step after the split-range output moved the fan duty:
//! the observer then recomputes its discretisation (`observer_predict_new_fan`).

use core::hint::black_box;

use cortex_m_semihosting::hprintln;
use thermorph::channels::{Channels, Counts, SpringSense};
use thermorph::command::Command;
use thermorph::measurement::{Measurement, Quality, Tilt};
use thermorph::outputs::{Outputs, SPRINGS, SpringMask};
use thermorph::settings::Settings;
use thermorph::supervisor::ModeId;
use thermorph::supervisor::{SpringMemory, Supervisor};
use thermorph::units::{Kelvin, Millis};

/// A frame with the colder region at `t2` and the film 25 K above it.
fn frame(at_ms: u64, seq: u32, t2: f32) -> Measurement {
    let t1 = t2 + 25.0;
    Measurement {
        at: Millis(at_ms),
        seq,
        regions: [t1, t2, t2 - 3.0, 305.0, 298.0].map(Kelvin::new),
        hottest: Kelvin::new(t1 + 1.0),
        filled_pixels: 0,
        quality: Quality::Resolved,
        bound: Kelvin::lit(0.5),
        // A bending column's tilt: every frame corrects the bend estimate.
        tilt: Some(Tilt {
            deg: 0.02 * (at_ms % 1000) as f32,
            sd_deg: 0.3,
        }),
        // The lattice as designed: the exposure warnings' check runs, and says nothing.
        exposure: Some(thermorph::measurement::LatticeExposure {
            fitted_pct: 71.3,
            design_pct: 71.0,
            configured_pct: 71.0,
            adopted: false,
            shows_pct: None,
        }),
    }
}

/// The channels as `o` drives them: 15 A through a wire whose resistance climbs with `k` (the
/// phase the fusion reads) where a gate and the power are on, a 5 V supply at rest.
fn sense(o: &Outputs, k: u32) -> SpringSense {
    let ohm = 0.272 * (1.0 + 0.125 * (k as f32 / 240.0));
    let one = |i: usize| {
        if o.spring_power && o.springs.contains(i) {
            Channels::ideal_counts(15.0, 15.0 * (0.02 + ohm))
        } else {
            Channels::ideal_counts(0.0, 5.0)
        }
    };
    let c: [(u16, u16); SPRINGS] = core::array::from_fn(one);
    let counts = Counts {
        current: c.map(|x| x.0),
        supply: c.map(|x| x.1),
    };
    SpringSense {
        samples: [counts; 2],
    }
}

/// Measure and print the worst and the mean control step.
pub fn bench(overhead: u64) {
    // Rested springs: the stepping runs its spring phases at once.
    let mut sup = Supervisor::with_memory(Millis(0), Settings::DEFAULT, SpringMemory::RESTED);
    sup.set_channels(Channels::default());
    sup.step(
        Millis(0),
        None,
        Some(Command::Mode(ModeId::StepLarge, SpringMask::parse("AB"))),
    );
    let (mut worst, mut sum, mut n) = (0u64, 0u64, 0u64);
    // 60 s at 4 frames a second: the soak, the stepping phases and the hold.
    for k in 1..=240u32 {
        let at = k as u64 * 250;
        let t2 = (340.0 + 0.2 * k as f32).min(358.2);
        let m = frame(at, k, t2);
        sup.sense_springs(&sense(&sup.outputs(), k));
        let (d, insns) = super::measure(|| sup.step(Millis(at), Some(black_box(&m)), None));
        black_box(&d);
        let insns = insns.saturating_sub(overhead);
        worst = worst.max(insns);
        sum += insns;
        n += 1;
    }
    hprintln!(
        "control insns={} mean={} steps={} mode={}",
        worst,
        sum / n,
        n,
        sup.mode().phase_name()
    );
}
