//! What a `Decision` drives: heater and fan duty, the spring gates and the spring power enable.
//!
//! This module owns the output types and the spring names. The board applies [`Outputs`] to its
//! pins and host-sim to its plant; nothing else drives an output.

/// A PWM duty cycle as a fraction of full power, always in [0, 1].
#[derive(Clone, Copy, Debug, PartialEq, PartialOrd, Default)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct Duty(f32);

impl Duty {
    /// Off.
    pub const OFF: Duty = Duty(0.0);
    /// Full power.
    pub const FULL: Duty = Duty(1.0);

    /// Make a duty from a fraction, clamped to [0, 1]; NaN gives 0 (off).
    pub fn from_fraction(f: f32) -> Duty {
        if f.is_nan() {
            Duty(0.0)
        } else {
            Duty(f.clamp(0.0, 1.0))
        }
    }

    /// Return the fraction, in [0, 1].
    pub fn fraction(self) -> f32 {
        self.0
    }

    /// Return the duty in percent, in [0, 100].
    pub fn pct(self) -> f32 {
        self.0 * 100.0
    }
}

/// Number of SMA springs.
pub const SPRINGS: usize = 3;
/// Spring names, in mask bit order.
pub const SPRING_NAMES: [char; SPRINGS] = ['A', 'B', 'C'];

/// A set of springs: bit 0 = A, bit 1 = B, bit 2 = C.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Hash)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct SpringMask(u8);

impl SpringMask {
    /// No spring.
    pub const NONE: SpringMask = SpringMask(0);
    /// All three springs.
    pub const ALL: SpringMask = SpringMask(0b111);

    /// Make a mask from its bits; bits above C are dropped.
    pub const fn from_bits(bits: u8) -> SpringMask {
        SpringMask(bits & 0b111)
    }

    /// Return the bits.
    pub const fn bits(self) -> u8 {
        self.0
    }

    /// Return whether spring `i` (0 = A) is in the set.
    pub const fn contains(self, i: usize) -> bool {
        i < SPRINGS && self.0 & (1 << i) != 0
    }

    /// Return whether the set is empty.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// Parse letters such as `A`, `ab`, `CBA` (each at most once, case-insensitive); `None`
    /// for an empty word, an unknown letter or a repeated one.
    pub fn parse(word: &str) -> Option<SpringMask> {
        let mut bits = 0u8;
        for c in word.chars() {
            let i = SPRING_NAMES
                .iter()
                .position(|n| n.eq_ignore_ascii_case(&c))?;
            if bits & (1 << i) != 0 {
                return None;
            }
            bits |= 1 << i;
        }
        (bits != 0).then_some(SpringMask(bits))
    }

    /// Write the set as letters (`-` when empty).
    pub fn write(self, out: &mut impl core::fmt::Write) -> core::fmt::Result {
        if self.is_empty() {
            return out.write_char('-');
        }
        for (i, n) in SPRING_NAMES.iter().enumerate() {
            if self.contains(i) {
                out.write_char(*n)?;
            }
        }
        Ok(())
    }
}

impl core::fmt::Display for SpringMask {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        self.write(f)
    }
}

/// The state of every output.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct Outputs {
    /// PI heater film duty.
    pub heater: Duty,
    /// Fan duty.
    pub fan: Duty,
    /// Springs switched on (their MOSFET gates).
    pub springs: SpringMask,
    /// The spring power enable: the high-side switch ahead of every spring channel, on only
    /// while a mode wants the springs available and no fault is latched, so a MOSFET failed
    /// short can still be cut.
    pub spring_power: bool,
}

impl Outputs {
    /// Everything off: the state from reset and after any fault that does not want the fan.
    pub const OFF: Outputs = Outputs {
        heater: Duty::OFF,
        fan: Duty::OFF,
        springs: SpringMask::NONE,
        spring_power: false,
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spring_masks_parse_and_print() {
        assert_eq!(SpringMask::parse("ab"), Some(SpringMask::from_bits(0b011)));
        assert_eq!(SpringMask::parse("CBA"), Some(SpringMask::ALL));
        assert_eq!(SpringMask::parse(""), None);
        assert_eq!(SpringMask::parse("AA"), None);
        assert_eq!(SpringMask::parse("AD"), None);
        assert_eq!(std::format!("{}", SpringMask::from_bits(0b101)), "AC");
        assert_eq!(std::format!("{}", SpringMask::NONE), "-");
    }

    #[test]
    fn duty_is_clamped_and_nan_is_off() {
        assert_eq!(Duty::from_fraction(1.5).fraction(), 1.0);
        assert_eq!(Duty::from_fraction(-0.1).fraction(), 0.0);
        assert_eq!(Duty::from_fraction(f32::NAN).fraction(), 0.0);
    }
}
