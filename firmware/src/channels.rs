//! The spring channels as the board measures them (SPEC sections 2 and 5): each spring's current
//! through a low-side shunt under its MOSFET and its supply's voltage through a divider, read by
//! the ADC in counts; their calibration; what a control period derives from them (current,
//! supply voltage, power delivered to the wire, the wire's resistance while on); and the checks
//! on them.
//!
//! This module owns the sensing front end's facts ([`FrontEnd`]: shunt, amplifier gain,
//! divider, ADC scale), the conversion from counts to amps and volts, the boot calibration of
//! the amplifiers' offsets ([`Calibration`]) and the per-channel checks ([`Channels::update`]):
//!
//! | check | condition | what it means |
//! |---|---|---|
//! | stuck on | ≥ `spring_leak_a` with the gate off and spring power on, two samples running | a MOSFET failed short (or its gate is held): cut the spring power |
//! | open | < `spring_open_a` with the gate and spring power on, two samples running | an open wire, a MOSFET failed open, a blown fuse, a dead supply |
//! | short | > `spring_short_a` in one sample, or a wire under [`SHORT_WIRE_OHM`] while on | the wire bypassed (leads touching, wire to frame): cut at once |
//! | garbage | a count above the ADC's scale, the divider at its rail, or current with no supply | a broken sensing channel: nothing it says can be trusted |
//! | sag | on, below the supply's current limit and its voltage under `spring_supply_min_v` | a weak supply: reported (a `# warning`), the power measured |
//!
//! Samples are synchronised with the gates: a control period's readings are taken while the
//! outputs of the previous decision are applied (the board discards conversions of the first
//! [`SETTLE_US`] after it switches a gate), so each channel is judged with its gate as it was.
//! The board's ADC scans the six inputs into a DMA ring continuously; each control period it
//! hands the library two samples, the means of the first and second half of the scans since the
//! last period ([`SpringSense`]).
//!
//! What the resistance can tell: a NiTi wire's resistivity differs by ≈ 12 % between martensite
//! and austenite (80 against 90 µΩ·cm), so the resistance while on follows the phase; within a
//! phase it moves by ≈ 10⁻⁴–10⁻³ per K, which at one count in ≈ 1 800 (0.06 %) is a few K at
//! best and drowned by the strain and the leads' drift. [`ChannelState::wire_ohm`] is given to
//! the observer as a measure of the phase ([`crate::observer`]), not of the temperature.

use crate::fmath;
use crate::outputs::{SPRINGS, SpringMask};
use crate::settings::Settings;

/// The ADC's largest count (12 bits).
pub const ADC_MAX_COUNT: u16 = 4095;

/// How long after a gate or the spring power switches the board discards conversions, µs: the
/// amplifier's settling (INA240: ≈ 10 µs to 0.5 %) and the supply's step response, with margin.
pub const SETTLE_US: u32 = 200;

/// The sensing front end's hardware facts (SPEC section 2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrontEnd {
    /// Shunt resistance, Ω (≈ 2 mΩ, 1 %).
    pub shunt_ohm: f32,
    /// Current-sense amplifier gain, V/V (INA181A2/INA240A2: 50).
    pub amp_gain: f32,
    /// Supply divider: supply volts per ADC-input volt (20 kΩ over 10 kΩ: 3).
    pub divider_ratio: f32,
    /// ADC reference (full scale), V.
    pub adc_ref_v: f32,
    /// The supply's nominal voltage, V (5 V channels).
    pub supply_nominal_v: f32,
    /// The supply's current limit, A (15 A channels): at the limit a supply runs in constant
    /// current and its voltage falls to what the load needs, which is not a sag.
    pub supply_limit_a: f32,
    /// Resistance of a channel outside the wire between the supply's sense point and ground
    /// (leads, connectors, MOSFET, shunt), Ω: subtracted from V/I to give the wire's.
    pub series_ohm: f32,
}

/// The board's front end: 2 mΩ, gain 50 (15 A → 1.5 V), a 20 k/10 k divider (9.9 V full
/// scale), 3.3 V reference; 5 V / 15 A supplies; 20 mΩ of leads, MOSFET and shunt.
pub const FRONT_END: FrontEnd = FrontEnd {
    shunt_ohm: 0.002,
    amp_gain: 50.0,
    divider_ratio: 3.0,
    adc_ref_v: 3.3,
    supply_nominal_v: 5.0,
    supply_limit_a: 15.0,
    series_ohm: 0.020,
};

impl FrontEnd {
    /// Amps per ADC count of a current channel (≈ 8.06 mA).
    pub const fn amps_per_count(&self) -> f32 {
        self.adc_ref_v / 4096.0 / (self.shunt_ohm * self.amp_gain)
    }

    /// Supply volts per ADC count (≈ 2.42 mV).
    pub const fn volts_per_count(&self) -> f32 {
        self.adc_ref_v / 4096.0 * self.divider_ratio
    }
}

/// A healthy wire's resistance is above this while on, Ω: the 2.3 mm springs read 0.27 Ω
/// (martensite) to 0.31 Ω (austenite); under a third of that the wire is bypassed.
pub const SHORT_WIRE_OHM: f32 = 0.1;

/// Below this supply reading a channel that carries current has a broken divider, V: even a
/// wire bypassed at its terminals leaves the series resistance (20 mΩ × 15 A = 0.3 V).
pub const NO_SUPPLY_V: f32 = 0.1;

/// A divider count at or above this is at its rail (≈ 9.8 V: no 5 V supply reads it), counts.
pub const DIVIDER_RAIL_COUNT: u16 = 4050;

/// The offset a boot calibration may find on a current channel, counts (INA240: ±25 µV ×
/// 50 ≈ 2 counts, INA181: ±150 µV × 50 ≈ 9; 40 leaves room and flags a stuck amplifier).
pub const OFFSET_MAX_COUNTS: f32 = 40.0;

/// One scan of the six inputs, ADC counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct Counts {
    /// Current amplifier outputs of A, B, C.
    pub current: [u16; SPRINGS],
    /// Supply dividers of A, B, C.
    pub supply: [u16; SPRINGS],
}

/// What the board read of the spring channels over one control period: two samples (the means
/// of the first and of the second half of the period's scans).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct SpringSense {
    /// The two samples, in time order.
    pub samples: [Counts; 2],
}

/// The amplifiers' offsets measured at boot with every gate and the spring power off.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Calibration {
    /// Each current channel's zero, counts.
    pub offset_counts: [f32; SPRINGS],
}

/// Why a boot calibration was refused (the offsets stay nominal and the channel is reported).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CalibrationError {
    /// The channel, 0 = A.
    pub spring: u8,
    /// Its mean count with everything off.
    pub counts: f32,
}

impl Calibration {
    /// Zero offsets (an ideal amplifier).
    pub const NOMINAL: Calibration = Calibration {
        offset_counts: [0.0; SPRINGS],
    };

    /// The offsets from `scans` taken with every gate and the spring power off. A channel whose
    /// mean is beyond [`OFFSET_MAX_COUNTS`] (an amplifier stuck, a MOSFET conducting already
    /// with the power off is impossible, so current there is a fault of the sensing) is
    /// refused: the first such channel is returned as the error and no offset is changed.
    pub fn from_scans(scans: &[Counts]) -> Result<Calibration, CalibrationError> {
        if scans.is_empty() {
            return Ok(Calibration::NOMINAL);
        }
        let n = scans.len() as f32;
        let mut offset_counts = [0.0; SPRINGS];
        for (i, o) in offset_counts.iter_mut().enumerate() {
            let mean = scans.iter().map(|s| s.current[i] as f32).sum::<f32>() / n;
            if mean > OFFSET_MAX_COUNTS {
                return Err(CalibrationError {
                    spring: i as u8,
                    counts: mean,
                });
            }
            *o = mean;
        }
        Ok(Calibration { offset_counts })
    }
}

/// One channel in one period, in units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChannelState {
    /// Current through the wire, A (the mean of the period's two samples).
    pub current_a: f32,
    /// The supply's voltage at its sense point, V.
    pub supply_v: f32,
    /// Power delivered to the wire, W: I·V − I²·R_series (0 while off).
    pub power_w: f32,
    /// The wire's resistance while on, Ω (NaN while off or below `spring_open_a`).
    pub wire_ohm: f32,
}

impl ChannelState {
    /// Nothing measured yet.
    pub const UNKNOWN: ChannelState = ChannelState {
        current_a: f32::NAN,
        supply_v: f32::NAN,
        power_w: f32::NAN,
        wire_ohm: f32::NAN,
    };
}

/// What a channel check found, with the spring and what tripped it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ChannelFault {
    /// Current with the gate off (a MOSFET failed short).
    StuckOn {
        /// Spring index, 0 = A.
        spring: u8,
        /// The current, A.
        current_a: f32,
    },
    /// No current with the gate on.
    Open {
        /// Spring index, 0 = A.
        spring: u8,
        /// The current, A.
        current_a: f32,
        /// The supply's reading, V.
        supply_v: f32,
    },
    /// Over-current, or a wire that reads as bypassed.
    Short {
        /// Spring index, 0 = A.
        spring: u8,
        /// The current, A.
        current_a: f32,
        /// The wire's resistance, Ω (NaN where the current alone tripped it).
        wire_ohm: f32,
    },
    /// A sensing channel reads garbage.
    Sensing {
        /// Spring index, 0 = A.
        spring: u8,
        /// What is wrong.
        what: SenseFault,
    },
}

/// How a sensing channel reads garbage.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SenseFault {
    /// A count above the ADC's 12 bits.
    OutOfRange,
    /// The supply's divider at its rail.
    DividerRail,
    /// Current flows while the supply reads nothing (a broken divider).
    NoSupplyReading,
}

impl ChannelFault {
    /// The spring, 0 = A.
    pub fn spring(&self) -> u8 {
        match *self {
            ChannelFault::StuckOn { spring, .. }
            | ChannelFault::Open { spring, .. }
            | ChannelFault::Short { spring, .. }
            | ChannelFault::Sensing { spring, .. } => spring,
        }
    }
}

/// What a probe of the channels found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Probe {
    /// No channel conducts with its gate off.
    Clear,
    /// This channel (0 = A) conducts this current, A, with its gate off.
    Conducts(u8, f32),
    /// This channel's readings are garbage (beyond the ADC's 12 bits: an ADC that stopped).
    Garbage(u8),
}

/// A supply that sags under load: the channel and its reading.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sag {
    /// Spring index, 0 = A.
    pub spring: u8,
    /// The supply's voltage under load, V.
    pub supply_v: f32,
    /// The current it gave, A.
    pub current_a: f32,
}

/// The channels' state across control periods.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Channels {
    calibration: Calibration,
    /// Consecutive samples each channel conducted with its gate off.
    leaking: [u8; SPRINGS],
    /// Consecutive samples each channel carried no current with its gate on.
    dead: [u8; SPRINGS],
    state: [ChannelState; SPRINGS],
    /// At least one reading came: the board senses its springs.
    present: bool,
}

impl Default for Channels {
    fn default() -> Self {
        Channels::new(Calibration::NOMINAL)
    }
}

/// A sample's current and supply in units, with the calibration and trims.
fn convert(c: &Counts, i: usize, cal: &Calibration, s: &Settings) -> (f32, f32) {
    let fe = FRONT_END;
    let amps = (c.current[i] as f32 - cal.offset_counts[i]) * fe.amps_per_count() * s.i_trim[i];
    let volts = c.supply[i] as f32 * fe.volts_per_count() * s.v_trim[i];
    (amps.max(0.0), volts)
}

impl Channels {
    /// The channels with the boot calibration `calibration`, nothing measured yet.
    pub const fn new(calibration: Calibration) -> Channels {
        Channels {
            calibration,
            leaking: [0; SPRINGS],
            dead: [0; SPRINGS],
            state: [ChannelState::UNKNOWN; SPRINGS],
            present: false,
        }
    }

    /// Return whether any reading has come (a board or simulator that senses its springs).
    pub fn present(&self) -> bool {
        self.present
    }

    /// Return the channels as last measured.
    pub fn state(&self) -> &[ChannelState; SPRINGS] {
        &self.state
    }

    /// Take one period's readings, made while `gates` (and `power`: the spring power enable)
    /// were applied; return the first fault found (by spring, A first) and a sagging supply.
    pub fn update(
        &mut self,
        sense: &SpringSense,
        gates: SpringMask,
        power: bool,
        s: &Settings,
    ) -> (Option<ChannelFault>, Option<Sag>) {
        self.present = true;
        let mut fault = None;
        let mut sag = None;
        for i in 0..SPRINGS {
            let on = power && gates.contains(i);
            let (f, g) = self.update_channel(i, sense, on, power, s);
            fault = fault.or(f);
            sag = sag.or(g);
        }
        (fault, sag)
    }

    fn update_channel(
        &mut self,
        i: usize,
        sense: &SpringSense,
        on: bool,
        power: bool,
        s: &Settings,
    ) -> (Option<ChannelFault>, Option<Sag>) {
        let spring = i as u8;
        let sensing = |what| Some(ChannelFault::Sensing { spring, what });
        let mut sum = (0.0, 0.0);
        let mut fault = None;
        let (mut stuck, mut open) = (false, false);
        for c in &sense.samples {
            if c.current[i] > ADC_MAX_COUNT || c.supply[i] > ADC_MAX_COUNT {
                self.state[i] = ChannelState::UNKNOWN;
                return (sensing(SenseFault::OutOfRange), None);
            }
            if c.supply[i] >= DIVIDER_RAIL_COUNT {
                self.state[i] = ChannelState::UNKNOWN;
                return (sensing(SenseFault::DividerRail), None);
            }
            let (amps, volts) = convert(c, i, &self.calibration, s);
            sum = (sum.0 + amps, sum.1 + volts);
            if amps > s.spring_short_a {
                fault = fault.or(Some(ChannelFault::Short {
                    spring,
                    current_a: amps,
                    wire_ohm: f32::NAN,
                }));
            }
            if amps >= s.spring_open_a && volts < NO_SUPPLY_V {
                fault = fault.or(sensing(SenseFault::NoSupplyReading));
            }
            // Two samples running: a count across periods, so a fault that starts mid-period
            // is caught at the next period's first sample.
            let leak = power && !on && amps >= s.spring_leak_a;
            self.leaking[i] = if leak {
                self.leaking[i].saturating_add(1)
            } else {
                0
            };
            let dead = on && amps < s.spring_open_a;
            self.dead[i] = if dead {
                self.dead[i].saturating_add(1)
            } else {
                0
            };
            stuck |= self.leaking[i] >= 2;
            open |= self.dead[i] >= 2;
        }
        let n = sense.samples.len() as f32;
        let (current_a, supply_v) = (sum.0 / n, sum.1 / n);
        let flowing = on && current_a >= s.spring_open_a;
        let wire_ohm = if flowing {
            supply_v / current_a - FRONT_END.series_ohm
        } else {
            f32::NAN
        };
        let power_w = if flowing {
            fmath::max(
                current_a * supply_v - current_a * current_a * FRONT_END.series_ohm,
                0.0,
            )
        } else {
            0.0
        };
        self.state[i] = ChannelState {
            current_a,
            supply_v,
            power_w,
            wire_ohm,
        };
        if fault.is_none() && wire_ohm < SHORT_WIRE_OHM {
            fault = Some(ChannelFault::Short {
                spring,
                current_a,
                wire_ohm,
            });
        }
        if fault.is_none() && stuck {
            fault = Some(ChannelFault::StuckOn { spring, current_a });
        }
        if fault.is_none() && open {
            fault = Some(ChannelFault::Open {
                spring,
                current_a,
                supply_v,
            });
        }
        let below_limit = current_a < 0.95 * FRONT_END.supply_limit_a;
        let sag = (flowing && below_limit && supply_v < s.spring_supply_min_v).then_some(Sag {
            spring,
            supply_v,
            current_a,
        });
        (fault, sag)
    }

    /// Judge a probe's readings (spring power on, every gate off): the first channel that
    /// reads garbage, else the first that conducts (with its current), else none.
    pub fn probe(&self, sense: &SpringSense, s: &Settings) -> Probe {
        for i in 0..SPRINGS {
            let garbage = sense
                .samples
                .iter()
                .any(|c| c.current[i] > ADC_MAX_COUNT || c.supply[i] > ADC_MAX_COUNT);
            if garbage {
                return Probe::Garbage(i as u8);
            }
        }
        let (conducting, amps) = self.conducting(sense, s);
        match (0..SPRINGS).find(|&i| conducting.contains(i)) {
            Some(i) => Probe::Conducts(i as u8, amps),
            None => Probe::Clear,
        }
    }

    /// The channels that conduct with their gates off, as a mask, with the first one's current.
    fn conducting(&self, sense: &SpringSense, s: &Settings) -> (SpringMask, f32) {
        let mut bits = 0u8;
        let mut first_a = 0.0;
        for i in 0..SPRINGS {
            let amps = sense
                .samples
                .iter()
                .map(|c| convert(c, i, &self.calibration, s).0)
                .fold(0.0, fmath::max);
            if amps >= s.spring_leak_a {
                if bits == 0 {
                    first_a = amps;
                }
                bits |= 1 << i;
            }
        }
        (SpringMask::from_bits(bits), first_a)
    }

    /// Counts the front end reads for `current_a` and `supply_v` on an ideal channel (no
    /// offset, no trim), clamped to the ADC's scale: for tests and the simulator's nominal
    /// readings.
    pub fn ideal_counts(current_a: f32, supply_v: f32) -> (u16, u16) {
        let fe = FRONT_END;
        let to = |x: f32| fmath::clamp(libm::roundf(x), 0.0, ADC_MAX_COUNT as f32) as u16;
        (
            to(current_a / fe.amps_per_count()),
            to(supply_v / fe.volts_per_count()),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scan(current: u16, supply: u16) -> Counts {
        Counts {
            current: [current; SPRINGS],
            supply: [supply; SPRINGS],
        }
    }

    #[test]
    fn the_front_end_scales_are_the_hardware_s() {
        // 2 mΩ × 50 into 3.3 V / 4096: ≈ 8.06 mA a count; the divider ≈ 2.42 mV a count.
        assert!((FRONT_END.amps_per_count() - 0.008_057).abs() < 1e-6);
        assert!((FRONT_END.volts_per_count() - 0.002_417).abs() < 1e-6);
        assert_eq!(Channels::ideal_counts(15.0, 5.0), (1862, 2069));
        assert_eq!(Channels::ideal_counts(99.0, -1.0), (ADC_MAX_COUNT, 0));
    }

    #[test]
    fn calibration_takes_the_offsets_and_refuses_a_stuck_amplifier() {
        let scans = [scan(8, 2069), scan(10, 2069)];
        let cal = Calibration::from_scans(&scans).unwrap();
        assert_eq!(cal.offset_counts, [9.0; SPRINGS]);
        let mut stuck = scans;
        stuck[1].current[2] = 900;
        let e = Calibration::from_scans(&stuck).unwrap_err();
        assert_eq!(e.spring, 2);
        assert_eq!(Calibration::from_scans(&[]), Ok(Calibration::NOMINAL));
        // With the offset taken, a channel at rest reads 0 A, and 15 A reads 15 A.
        let mut ch = Channels::new(cal);
        let s = Settings::DEFAULT;
        let (i15, v) = Channels::ideal_counts(15.0, 4.35);
        let sense = SpringSense {
            samples: [Counts {
                current: [i15 + 9, 9, 9],
                supply: [v, 2069, 2069],
            }; 2],
        };
        assert_eq!(
            ch.update(&sense, SpringMask::from_bits(1), true, &s),
            (None, None)
        );
        let st = ch.state();
        assert!((st[0].current_a - 15.0).abs() < 0.01, "{st:?}");
        assert!((st[0].wire_ohm - 0.27).abs() < 0.002, "{st:?}");
        assert!((st[0].power_w - 15.0 * 15.0 * 0.27).abs() < 1.0, "{st:?}");
        assert_eq!(st[1].current_a, 0.0);
        assert!(st[1].wire_ohm.is_nan() && st[1].power_w == 0.0);
    }

    /// A reading the ADC cannot give, a divider at its rail or current with no supply reading
    /// is a sensing fault of that channel, never a value.
    #[test]
    fn garbage_readings_are_a_sensing_fault() {
        let s = Settings::DEFAULT;
        let cases = [
            (scan(5000, 2069), SpringMask::NONE, SenseFault::OutOfRange),
            (scan(0, 4095), SpringMask::NONE, SenseFault::DividerRail),
            (scan(1862, 0), SpringMask::ALL, SenseFault::NoSupplyReading),
        ];
        for (c, gates, what) in cases {
            let mut ch = Channels::default();
            let sense = SpringSense { samples: [c; 2] };
            let (f, _) = ch.update(&sense, gates, true, &s);
            assert_eq!(f, Some(ChannelFault::Sensing { spring: 0, what }));
        }
    }

    /// One sample over the leak threshold is not enough; two running (across periods) are.
    #[test]
    fn stuck_on_needs_two_samples_running() {
        let s = Settings::DEFAULT;
        let mut ch = Channels::default();
        let (leak, v) = Channels::ideal_counts(3.0, 5.0);
        let quiet = scan(0, v);
        let mut one = quiet;
        one.current[0] = leak;
        let period = |a: Counts, b: Counts| SpringSense { samples: [a, b] };
        assert_eq!(
            ch.update(&period(quiet, one), SpringMask::NONE, true, &s).0,
            None
        );
        let (f, _) = ch.update(&period(one, quiet), SpringMask::NONE, true, &s);
        assert!(
            matches!(f, Some(ChannelFault::StuckOn { spring: 0, .. })),
            "{f:?}"
        );
        // The spring power off: nothing can flow, nothing is judged stuck.
        let mut ch = Channels::default();
        assert_eq!(
            ch.update(&period(one, one), SpringMask::NONE, false, &s).0,
            None
        );
    }
}
