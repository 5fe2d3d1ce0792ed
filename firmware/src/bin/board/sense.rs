//! The spring channels' readings (SPEC section 2): ADC1 scans the three currents and the three
//! supplies continuously into a circular DMA buffer ([`pins::SpringInputs`], embassy's
//! `RingBufferedAdc`), and the control loop drains it once a period.
//!
//! Why a ring and not a read a period: embassy-stm32 0.6 has no DMA `Adc::read` for the F4's
//! ADC (adc v2); its `RingBufferedAdc` keeps converting without the CPU, and
//! `read_latest` copies out whatever whole scans came since the last call without waiting —
//! the control loop never blocks or spins on the ADC. It sees [`pins::RING_SCANS`] scans
//! (67 ms); a loop that drains later (a flash operation) loses the scans since, and its next
//! period has no reading.
//!
//! Each period ([`Springs::take`]) the scans since the last drain are split in a first and a
//! second half, each averaged: the library's `SpringSense`. When a spring gate or the spring
//! power switches ([`Springs::switched`], right after the pins change) the scans taken before
//! are discarded and the next [`SETTLE_SCANS`] dropped: those that began within
//! [`SETTLE_US`] of the switch, and the one under way at it. So a period's reading is taken
//! under the outputs that the previous period applied, as the library judges it.
//!
//! At boot ([`Springs::calibrate`]), with every gate and the spring power off, 32 scans give the
//! amplifiers' offsets. For `reset`'s probe ([`Springs::probe`]) the loop applies the probe's
//! outputs (spring power on, every gate off), waits until settled scans come (≈ 2 ms) and reads
//! them.
//!
//! An ADC that stops converting ([`pins::spring_inputs_running`]: an overrun, which stops its
//! DMA requests, or a DMA stream disabled by an error) reads as counts beyond 12 bits on every
//! input, which the library latches as a sensing fault of spring A: the spring power goes off,
//! and `reset` is refused until the chip is reset.

#[path = "scans.rs"]
mod scans;

use defmt::{error, warn};
use embassy_time::{Duration, Timer};
use static_cell::ConstStaticCell;
use thermorph::channels::{Calibration, Counts, SETTLE_US, SpringSense};
use thermorph::decimal::Fixed;
use thermorph::outputs::SPRING_NAMES;

use super::pins::{self, RING_SCANS, SCAN_NS, SENSE_INPUTS};

const _: () = assert!(scans::INPUTS == SENSE_INPUTS, "a scan is the six inputs");

/// Scans dropped after a spring gate or the spring power switched.
pub const SETTLE_SCANS: usize = scans::settle_scans(SETTLE_US, SCAN_NS);
/// Scans averaged for the amplifiers' offsets at boot (8.4 ms).
pub const CALIBRATION_SCANS: usize = 32;
/// Scans a probe reads after the settling (≈ 1 ms).
pub const PROBE_SCANS: usize = 4;

/// What a stopped ADC reads: beyond 12 bits, which the library refuses as a broken channel.
const BROKEN: SpringSense = SpringSense {
    samples: [Counts {
        current: [u16::MAX; 3],
        supply: [u16::MAX; 3],
    }; 2],
};

/// Where the scans are copied out of the ring: as large as the ring.
static DRAIN: ConstStaticCell<[u16; RING_SCANS * SENSE_INPUTS]> =
    ConstStaticCell::new([0; RING_SCANS * SENSE_INPUTS]);

/// The time `scans` scans take, with one more for the scan under way.
fn scans_time(scans: usize) -> Duration {
    Duration::from_micros((scans as u64 + 1) * u64::from(SCAN_NS) / 1_000 + 1)
}

/// The spring channels' ADC and what the control loop has read of it.
pub struct Springs {
    adc: pins::SpringInputs,
    buf: &'static mut [u16; RING_SCANS * SENSE_INPUTS],
    settle: scans::Settle,
    /// The ADC was found stopped (reported once).
    stopped: bool,
}

impl Springs {
    /// Take the ADC (not started yet: [`Springs::calibrate`] starts it).
    pub fn new(adc: pins::SpringInputs) -> Self {
        Springs {
            adc,
            buf: DRAIN.take(),
            settle: scans::Settle::new(),
            stopped: false,
        }
    }

    /// Copy out the whole scans since the last drain (oldest first); return how many counts.
    fn drain(&mut self) -> usize {
        self.adc.read_latest(&mut self.buf[..])
    }

    /// Whether the ADC has stopped converting (it does not start again).
    fn has_stopped(&mut self) -> bool {
        if !self.stopped && !pins::spring_inputs_running() {
            self.stopped = true;
            error!("spring channels: the ADC stopped converting; channels read as broken");
        }
        self.stopped
    }

    /// The reading of this control period: the settled scans since the last one, in two halves
    /// (`None`: fewer than two came).
    pub fn take(&mut self) -> Option<SpringSense> {
        let n = self.drain();
        if self.has_stopped() {
            return Some(BROKEN);
        }
        self.settle.sense(&self.buf[..n])
    }

    /// A spring gate or the spring power has just switched: the scans so far are discarded and
    /// the next [`SETTLE_SCANS`] will be.
    pub fn switched(&mut self) {
        self.drain();
        self.settle.switched(SETTLE_SCANS);
    }

    /// Start the ADC and measure the amplifiers' offsets; every gate and the spring power must
    /// be off. A refused calibration, or no scans, writes a `# warning` line (with its CR LF) to
    /// `warning` and gives [`Calibration::NOMINAL`].
    pub async fn calibrate(&mut self, warning: &mut impl core::fmt::Write) -> Calibration {
        self.adc.start();
        self.switched();
        Timer::after(scans_time(SETTLE_SCANS + CALIBRATION_SCANS)).await;
        let n = self.drain() / SENSE_INPUTS;
        let skip = SETTLE_SCANS.min(n);
        let mut scans = [Counts::default(); CALIBRATION_SCANS];
        let mut k = 0;
        for (c, s) in scans
            .iter_mut()
            .zip(self.buf[skip * SENSE_INPUTS..n * SENSE_INPUTS].chunks_exact(SENSE_INPUTS))
        {
            *c = scans::scan(s);
            k += 1;
        }
        self.settle = scans::Settle::new();
        if k == 0 {
            warn!("spring channels: no ADC scans at boot");
            let _ = write!(
                warning,
                "# warning: spring channels read nothing; channels uncalibrated\r\n"
            );
            return Calibration::NOMINAL;
        }
        match Calibration::from_scans(&scans[..k]) {
            Ok(c) => c,
            Err(e) => {
                let spring = SPRING_NAMES[usize::from(e.spring).min(SPRING_NAMES.len() - 1)];
                warn!(
                    "spring channel {}: amplifier offset {} counts",
                    spring, e.counts
                );
                let _ = write!(
                    warning,
                    "# warning: spring channel {spring} amplifier offset {} counts; channels \
                     uncalibrated\r\n",
                    Fixed::new(e.counts, 0)
                );
                Calibration::NOMINAL
            }
        }
    }

    /// `reset`'s probe: the probe's outputs were just applied and [`Springs::switched`] called;
    /// wait for settled scans and read them. An ADC that gives none reads as broken (the probe
    /// then refuses the reset).
    pub async fn probe(&mut self) -> SpringSense {
        for _ in 0..4 {
            Timer::after(scans_time(self.settle.left() + PROBE_SCANS)).await;
            if let Some(s) = self.take() {
                return s;
            }
        }
        error!("spring channels: no scans for the probe");
        BROKEN
    }
}
