//! Physical quantities as newtypes: temperatures are Kelvin everywhere inside the firmware.
//!
//! Celsius appears only at the edges where a datasheet or a user speaks it (the Melexis
//! formulas, CSV output), always through [`Kelvin::from_celsius`] and [`Kelvin::to_celsius`].
//!
//! [`Kelvin`] and [`Seconds`] never hold NaN: their field is private and every constructor
//! refuses it ([`Kelvin::new`] returns `None`, [`Kelvin::lit`] fails to compile in a const
//! context). A value that may be missing — a region no cluster was given, a frame not yet
//! measured — is an `Option<Kelvin>`, never a NaN Kelvin. Infinities are accepted: they are
//! ordered above and below every finite value, and the plausibility ranges that already guard
//! every reading (`mtts::PLAUSIBLE_K`, the supervisor's `VALID_K`) reject them.
//!
//! Both are ordered by [`f32::total_cmp`], so `Eq`, `Ord`, `PartialEq` and `PartialOrd` agree
//! with one another (the one place total order differs from `f32`'s `==`: −0 sorts below +0 and
//! the two are not equal).

use core::cmp::Ordering;

/// Offset between the Celsius and Kelvin scales, K.
pub const ZERO_CELSIUS_K: f32 = 273.15;

/// An absolute temperature (or a temperature difference) in Kelvin; never NaN (see the
/// module docs).
#[derive(Clone, Copy, Debug, Default)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct Kelvin(f32);

impl Kelvin {
    /// Make a temperature in Kelvin; `None` for NaN (infinities are accepted).
    pub const fn new(k: f32) -> Option<Kelvin> {
        if k.is_nan() { None } else { Some(Kelvin(k)) }
    }

    /// Make a temperature from a literal in Kelvin, for consts and tests: `Kelvin::lit(298.15)`.
    ///
    /// # Panics
    ///
    /// On NaN — a compile error where it is evaluated in a const context (`const T: Kelvin =
    /// Kelvin::lit(..)`, `const { Kelvin::lit(..) }`). For a computed value use
    /// [`Kelvin::new`].
    ///
    /// ```compile_fail
    /// const T: thermorph::units::Kelvin = thermorph::units::Kelvin::lit(f32::NAN);
    /// ```
    pub const fn lit(k: f32) -> Kelvin {
        match Kelvin::new(k) {
            Some(t) => t,
            None => panic!("Kelvin::lit(NaN)"),
        }
    }

    /// Make a temperature from degrees Celsius; `None` for NaN.
    pub fn from_celsius(celsius: f32) -> Option<Kelvin> {
        Kelvin::new(celsius + ZERO_CELSIUS_K)
    }

    /// Return the temperature in degrees Celsius.
    pub fn to_celsius(self) -> f32 {
        self.0 - ZERO_CELSIUS_K
    }

    /// Return the raw value in Kelvin (never NaN).
    pub const fn k(self) -> f32 {
        self.0
    }
}

impl PartialEq for Kelvin {
    /// Equal under [`f32::total_cmp`].
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Kelvin {}

impl PartialOrd for Kelvin {
    /// [`Ord::cmp`], always `Some`.
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Kelvin {
    /// [`f32::total_cmp`] of the values.
    fn cmp(&self, other: &Self) -> Ordering {
        self.0.total_cmp(&other.0)
    }
}

/// Return the value in Kelvin, NaN for a missing one: for the output edges only (CSV,
/// telemetry, plots), where a missing value is written as NaN.
pub fn k_or_nan(t: Option<Kelvin>) -> f32 {
    t.map_or(f32::NAN, Kelvin::k)
}

/// A span of time in seconds; never NaN (see the module docs). It is what crosses a module
/// boundary where a span in seconds is an argument (`Pid::update`, the autotune's clock,
/// [`Millis::seconds_since`]); settings and internal state keep plain `f32` fields named `_s`.
#[derive(Clone, Copy, Debug, Default)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct Seconds(f32);

impl Seconds {
    /// No time at all.
    pub const ZERO: Seconds = Seconds(0.0);

    /// Make a span in seconds; `None` for NaN (infinities are accepted).
    pub const fn new(s: f32) -> Option<Seconds> {
        if s.is_nan() { None } else { Some(Seconds(s)) }
    }

    /// Make a span from a literal in seconds, for consts and tests: `Seconds::lit(0.125)`.
    ///
    /// # Panics
    ///
    /// On NaN — a compile error where it is evaluated in a const context. For a computed value
    /// use [`Seconds::new`].
    ///
    /// ```compile_fail
    /// const T: thermorph::units::Seconds = thermorph::units::Seconds::lit(f32::NAN);
    /// ```
    pub const fn lit(s: f32) -> Seconds {
        match Seconds::new(s) {
            Some(t) => t,
            None => panic!("Seconds::lit(NaN)"),
        }
    }

    /// Make a span from whole milliseconds (`ms · 10⁻³` in `f32`, as [`Millis::seconds_since`]
    /// computes it).
    pub const fn from_ms(ms: u32) -> Seconds {
        Seconds(ms as f32 * 1e-3)
    }

    /// Return the raw value in seconds (never NaN).
    pub const fn s(self) -> f32 {
        self.0
    }
}

impl PartialEq for Seconds {
    /// Equal under [`f32::total_cmp`].
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Seconds {}

impl PartialOrd for Seconds {
    /// [`Ord::cmp`], always `Some`.
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Seconds {
    /// [`f32::total_cmp`] of the values.
    fn cmp(&self, other: &Self) -> Ordering {
        self.0.total_cmp(&other.0)
    }
}

/// A monotonic instant or a span in milliseconds (time since boot on the board, simulated
/// time in host-sim).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Default, Hash)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct Millis(pub u64);

impl Millis {
    /// Return the span from `earlier` to `self` (0 if `earlier` is later).
    pub fn seconds_since(self, earlier: Millis) -> Seconds {
        // A u64 converted to f32 is finite, never NaN.
        Seconds(self.0.saturating_sub(earlier.0) as f32 * 1e-3)
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
        let t = Kelvin::from_celsius(25.0).unwrap();
        assert!((t.k() - 298.15).abs() < 1e-4);
        assert!((t.to_celsius() - 25.0).abs() < 1e-4);
    }

    #[test]
    fn nan_is_refused() {
        assert_eq!(Kelvin::new(f32::NAN), None);
        assert_eq!(Kelvin::from_celsius(f32::NAN), None);
        assert_eq!(Seconds::new(f32::NAN), None);
        assert_eq!(
            Kelvin::new(f32::INFINITY).map(Kelvin::k),
            Some(f32::INFINITY)
        );
        const T: Kelvin = Kelvin::lit(298.15);
        assert_eq!(Kelvin::new(298.15), Some(T));
    }

    #[test]
    fn order_is_total() {
        let (a, b) = (Kelvin::lit(300.0), Kelvin::lit(310.0));
        assert!(a < b && a.max(b) == b && b.min(a) == a);
        assert!(Kelvin::lit(-0.0) < Kelvin::lit(0.0));
        assert!(Seconds::lit(1.0) > Seconds::ZERO);
        assert_eq!(Millis(1500).seconds_since(Millis(1000)), Seconds::lit(0.5));
        assert_eq!(Millis(1000).seconds_since(Millis(1500)), Seconds::ZERO);
    }
}
