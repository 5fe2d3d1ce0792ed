//! The spring channels' sensing as the board's ADC sees it: each channel's shunt and current
//! amplifier (gain and offset errors), each supply's divider (ratio error), the 12-bit ADC's
//! quantisation and noise, and the two samples a control period hands the firmware.
//!
//! The nominal front end is the firmware's ([`FRONT_END`]); the errors are drawn once per
//! board from a seed within the parts' datasheet classes ([`SenseErrors`]), so the firmware's
//! boot calibration (amplifier offsets) and its trims (gains) meet what a real board has.

use thermorph::channels::{ADC_MAX_COUNT, Counts, FRONT_END, SpringSense};

use crate::sensor::virtual_mlx::Rng;

/// A current amplifier's input offset, V rms [S INA181: ±150 µV max, ≈ 50 µV typical].
pub const AMP_OFFSET_SD_V: f64 = 50e-6;
/// A current channel's gain error (amplifier and shunt), fraction rms [S INA181 ±1 %, shunt
/// 1 %: ≈ 0.7 % rms together].
pub const CURRENT_GAIN_SD: f64 = 0.007;
/// A divider's ratio error, fraction rms [S: two 1 % resistors, ≈ 0.5 % rms].
pub const DIVIDER_SD: f64 = 0.005;
/// Noise of one sample (the mean of half a period's scans), counts rms [E: ≈ 1.5 counts per
/// conversion on the F446's ADC, averaged over ≈ 10 scans].
pub const SAMPLE_NOISE_COUNTS: f64 = 0.5;

/// One board's sensing errors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SenseErrors {
    /// Each current channel's offset at the ADC, counts.
    pub offset_counts: [f64; 3],
    /// Each current channel's gain, relative (1 = nominal).
    pub current_gain: [f64; 3],
    /// Each divider's ratio, relative (1 = nominal).
    pub supply_gain: [f64; 3],
}

impl SenseErrors {
    /// No errors.
    pub const NONE: SenseErrors = SenseErrors {
        offset_counts: [0.0; 3],
        current_gain: [1.0; 3],
        supply_gain: [1.0; 3],
    };

    /// Errors drawn from `seed` within the parts' classes.
    pub fn drawn(seed: u64) -> SenseErrors {
        let mut rng = Rng::new(seed ^ 0x5EA5_E000_C4A7_0000);
        let volts_per_count = FRONT_END.adc_ref_v as f64 / 4096.0;
        let amp = FRONT_END.amp_gain as f64;
        SenseErrors {
            // A negative offset reads as zero at the ADC: the amplifiers' outputs sit on a
            // small positive reference in practice, modelled as |offset|.
            offset_counts: core::array::from_fn(|_| {
                (rng.gauss() * AMP_OFFSET_SD_V * amp / volts_per_count).abs()
            }),
            current_gain: core::array::from_fn(|_| 1.0 + rng.gauss() * CURRENT_GAIN_SD),
            supply_gain: core::array::from_fn(|_| 1.0 + rng.gauss() * DIVIDER_SD),
        }
    }
}

/// The sensing front end of the simulated board.
pub struct Sensing {
    errors: SenseErrors,
    rng: Rng,
}

fn to_count(x: f64) -> u16 {
    x.round().clamp(0.0, ADC_MAX_COUNT as f64) as u16
}

impl Sensing {
    /// The front end with `errors`, its noise drawn from `seed`.
    pub fn new(errors: SenseErrors, seed: u64) -> Sensing {
        Sensing {
            errors,
            rng: Rng::new(seed ^ 0xADC0_0000_0000_0001),
        }
    }

    /// One scan of the six inputs for each channel's current and supply voltage.
    pub fn scan(&mut self, current_a: [f64; 3], supply_v: [f64; 3]) -> Counts {
        let e = self.errors;
        let amps_per_count = FRONT_END.amps_per_count() as f64;
        let volts_per_count = FRONT_END.volts_per_count() as f64;
        let mut c = Counts::default();
        for i in 0..3 {
            let ni = self.rng.gauss() * SAMPLE_NOISE_COUNTS;
            let nv = self.rng.gauss() * SAMPLE_NOISE_COUNTS;
            c.current[i] = to_count(
                current_a[i] * e.current_gain[i] / amps_per_count + e.offset_counts[i] + ni,
            );
            c.supply[i] = to_count(supply_v[i] * e.supply_gain[i] / volts_per_count + nv);
        }
        c
    }

    /// A control period's two samples of channels carrying `current_a` with their supplies at
    /// `supply_v`.
    pub fn sense(&mut self, current_a: [f64; 3], supply_v: [f64; 3]) -> SpringSense {
        SpringSense {
            samples: [
                self.scan(current_a, supply_v),
                self.scan(current_a, supply_v),
            ],
        }
    }

    /// `n` scans with everything off (the boot calibration's), with the supplies at `supply_v`.
    pub fn idle_scans(&mut self, n: usize, supply_v: [f64; 3]) -> Vec<Counts> {
        (0..n).map(|_| self.scan([0.0; 3], supply_v)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use thermorph::channels::{Calibration, Channels};
    use thermorph::outputs::SpringMask;
    use thermorph::settings::Settings;

    /// Through the firmware's calibration and conversion, a channel reads its current within
    /// its gain error and a count, and its supply within the divider's error.
    #[test]
    fn the_firmware_reads_what_the_front_end_was_given() {
        let errors = SenseErrors::drawn(7);
        let mut s = Sensing::new(errors, 7);
        let cal = Calibration::from_scans(&s.idle_scans(32, [5.0; 3])).unwrap();
        let mut ch = Channels::new(cal);
        let amps = [15.0, 7.5, 0.0];
        let volts = [4.35, 4.8, 5.0];
        let sense = SpringSense {
            samples: [s.scan(amps, volts), s.scan(amps, volts)],
        };
        let (fault, _) = ch.update(
            &sense,
            SpringMask::from_bits(0b011),
            true,
            &Settings::DEFAULT,
        );
        assert_eq!(fault, None);
        for i in 0..3 {
            let st = ch.state()[i];
            let tol_a = amps[i] * 3.0 * CURRENT_GAIN_SD + 0.03;
            assert!((st.current_a as f64 - amps[i]).abs() < tol_a, "{i}: {st:?}");
            let tol_v = volts[i] * 3.0 * DIVIDER_SD + 0.01;
            assert!((st.supply_v as f64 - volts[i]).abs() < tol_v, "{i}: {st:?}");
        }
    }
}
