//! Physical quantities as newtypes: temperatures are Kelvin everywhere inside the firmware.
//!
//! Celsius appears only at the edges where a datasheet or a user speaks it (the Melexis
//! formulas, CSV output), always through [`Kelvin::from_celsius`] and [`Kelvin::to_celsius`].

/// Offset between the Celsius and Kelvin scales, K.
pub const ZERO_CELSIUS_K: f32 = 273.15;

/// An absolute temperature in Kelvin.
#[derive(Clone, Copy, Debug, PartialEq, PartialOrd, Default)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct Kelvin(pub f32);

impl Kelvin {
    /// Make a temperature from degrees Celsius.
    pub fn from_celsius(celsius: f32) -> Self {
        Kelvin(celsius + ZERO_CELSIUS_K)
    }

    /// Return the temperature in degrees Celsius.
    pub fn to_celsius(self) -> f32 {
        self.0 - ZERO_CELSIUS_K
    }

    /// Return the raw value in Kelvin.
    pub fn k(self) -> f32 {
        self.0
    }
}

/// A monotonic instant or a span in milliseconds (time since boot on the board, simulated
/// time in host-sim).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Default, Hash)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct Millis(pub u64);

impl Millis {
    /// Return the span from `earlier` to `self` in seconds (0 if `earlier` is later).
    pub fn seconds_since(self, earlier: Millis) -> f32 {
        self.0.saturating_sub(earlier.0) as f32 * 1e-3
    }

    /// Return the raw value in milliseconds.
    pub fn ms(self) -> u64 {
        self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn celsius_round_trip() {
        let t = Kelvin::from_celsius(25.0);
        assert!((t.k() - 298.15).abs() < 1e-4);
        assert!((t.to_celsius() - 25.0).abs() < 1e-4);
    }
}
