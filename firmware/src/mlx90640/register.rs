//! The MLX90640's status (0x8000) and control (0x800D) registers as typed values.
//!
//! Datasheet §8.2.2 (register map) and the reference library's `MLX90640_API.h` masks.

/// Status register 0x8000.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct Status(pub u16);

impl Status {
    /// Register address.
    pub const ADDRESS: u16 = 0x8000;
    /// Value written to clear the new-data bit (and keep data overwrite enabled).
    pub const CLEAR: u16 = 0x0030;
    /// Bit 3: a new subpage has been measured and not yet acknowledged.
    pub const NEW_DATA: u16 = 1 << 3;
    /// Bit 0: the subpage last measured.
    pub const SUBPAGE: u16 = 1 << 0;

    /// Return whether new data is ready.
    pub fn new_data(self) -> bool {
        self.0 & Self::NEW_DATA != 0
    }

    /// Return the subpage last measured (0 or 1).
    pub fn subpage(self) -> u8 {
        (self.0 & Self::SUBPAGE) as u8
    }
}

/// Subpage refresh rate (control register bits 7–9): each subpage is measured at this rate, so
/// a whole frame arrives at half of it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum RefreshRate {
    /// 0.5 Hz.
    Hz0_5 = 0,
    /// 1 Hz.
    Hz1 = 1,
    /// 2 Hz (the device's power-on default).
    Hz2 = 2,
    /// 4 Hz.
    Hz4 = 3,
    /// 8 Hz (Thermorph's default: a whole frame at 4 Hz).
    Hz8 = 4,
    /// 16 Hz.
    Hz16 = 5,
    /// 32 Hz.
    Hz32 = 6,
    /// 64 Hz.
    Hz64 = 7,
}

impl RefreshRate {
    /// All rates, slowest first.
    pub const ALL: [RefreshRate; 8] = [
        Self::Hz0_5,
        Self::Hz1,
        Self::Hz2,
        Self::Hz4,
        Self::Hz8,
        Self::Hz16,
        Self::Hz32,
        Self::Hz64,
    ];

    /// Return the rate for a 3-bit register code.
    pub fn from_code(code: u16) -> Self {
        Self::ALL[(code & 7) as usize]
    }

    /// Return the rate closest to `hz` that the device supports, or `None` outside 0.5–64 Hz.
    pub fn from_hz(hz: f32) -> Option<Self> {
        Self::ALL
            .into_iter()
            .find(|r| (r.hz() - hz).abs() < 1e-3 * r.hz())
    }

    /// Return the subpage rate in Hz.
    pub fn hz(self) -> f32 {
        0.5 * (1u32 << self as u32) as f32
    }

    /// Return the subpage period in microseconds.
    pub fn period_us(self) -> u32 {
        2_000_000 >> self as u32
    }
}

/// ADC resolution (control register bits 10–11).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum Resolution {
    /// 16 bit.
    Bits16 = 0,
    /// 17 bit.
    Bits17 = 1,
    /// 18 bit (the device's and Thermorph's default).
    Bits18 = 2,
    /// 19 bit.
    Bits19 = 3,
}

impl Resolution {
    /// All resolutions, coarsest first.
    pub const ALL: [Resolution; 4] = [Self::Bits16, Self::Bits17, Self::Bits18, Self::Bits19];

    /// Return the resolution for a 2-bit register code.
    pub fn from_code(code: u16) -> Self {
        Self::ALL[(code & 3) as usize]
    }

    /// Return the resolution for a bit count, or `None` outside 16–19.
    pub fn from_bits(bits: u8) -> Option<Self> {
        Self::ALL.into_iter().find(|r| r.bits() == bits)
    }

    /// Return the number of ADC bits.
    pub fn bits(self) -> u8 {
        16 + self as u8
    }
}

/// How the two subpages split the pixels (control register bit 12).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum ReadingPattern {
    /// Alternate rows belong to alternate subpages.
    Interleaved = 0,
    /// A chess board: subpage = (row + column) mod 2 (the factory calibration pattern).
    Chess = 1,
}

/// Control register 0x800D.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct Control(pub u16);

impl Control {
    /// Register address.
    pub const ADDRESS: u16 = 0x800D;
    const REFRESH_SHIFT: u16 = 7;
    const RESOLUTION_SHIFT: u16 = 10;
    const PATTERN_BIT: u16 = 1 << 12;

    /// Return the refresh rate field.
    pub fn refresh_rate(self) -> RefreshRate {
        RefreshRate::from_code(self.0 >> Self::REFRESH_SHIFT)
    }

    /// Return the ADC resolution field.
    pub fn resolution(self) -> Resolution {
        Resolution::from_code(self.0 >> Self::RESOLUTION_SHIFT)
    }

    /// Return the reading pattern field.
    pub fn pattern(self) -> ReadingPattern {
        if self.0 & Self::PATTERN_BIT != 0 {
            ReadingPattern::Chess
        } else {
            ReadingPattern::Interleaved
        }
    }

    /// Return this register with the three measurement fields replaced, other bits kept.
    pub fn with(self, rate: RefreshRate, resolution: Resolution, pattern: ReadingPattern) -> Self {
        let mask = (7 << Self::REFRESH_SHIFT) | (3 << Self::RESOLUTION_SHIFT) | Self::PATTERN_BIT;
        let mut v = self.0 & !mask;
        v |= (rate as u16) << Self::REFRESH_SHIFT;
        v |= (resolution as u16) << Self::RESOLUTION_SHIFT;
        if pattern == ReadingPattern::Chess {
            v |= Self::PATTERN_BIT;
        }
        Control(v)
    }

    /// Return the reference library's `mode` value: 0x80 for chess, 0 for interleaved, as it
    /// compares it with `calibrationModeEE`.
    pub fn mode_code(self) -> u8 {
        ((self.0 & Self::PATTERN_BIT) >> 5) as u8
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_fields() {
        // The Melexis example: chess, 18 bit, 2 Hz.
        let c = Control(0x1901);
        assert_eq!(c.refresh_rate(), RefreshRate::Hz2);
        assert_eq!(c.resolution(), Resolution::Bits18);
        assert_eq!(c.pattern(), ReadingPattern::Chess);
        assert_eq!(c.mode_code(), 0x80);
        let d = c.with(
            RefreshRate::Hz8,
            Resolution::Bits19,
            ReadingPattern::Interleaved,
        );
        assert_eq!(d.0 & 1, 1, "unrelated bits kept");
        assert_eq!(d.refresh_rate(), RefreshRate::Hz8);
        assert_eq!(d.resolution(), Resolution::Bits19);
        assert_eq!(d.pattern(), ReadingPattern::Interleaved);
        assert_eq!(d.mode_code(), 0);
    }

    #[test]
    fn rates() {
        assert_eq!(RefreshRate::Hz8.period_us(), 125_000);
        assert_eq!(RefreshRate::Hz0_5.period_us(), 2_000_000);
        assert_eq!(RefreshRate::from_hz(0.5), Some(RefreshRate::Hz0_5));
        assert_eq!(RefreshRate::from_hz(64.0), Some(RefreshRate::Hz64));
        assert_eq!(RefreshRate::from_hz(3.0), None);
        assert_eq!(Resolution::from_bits(19), Some(Resolution::Bits19));
        assert_eq!(Resolution::from_bits(20), None);
    }
}
