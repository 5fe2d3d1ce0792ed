//! What the frames say about the lattice's exposed fraction against its design. A frame whose
//! targets the supervisor's prior orders (heating: the heater hotter; forming and recovery:
//! the surface) reads the fraction of each lattice unit where the heater shows: its hot
//! stripes' width, or the cold ones'. Readings that agree with the design in use confirm it;
//! a run of readings that disagree replaces it with their mean (a block printed or viewed
//! unlike its design), and the frame that does so says so. Takes each frame's reading; gives
//! the design the next frame fits with ([`Exposure::design`]) and whether it is confirmed.

use super::*;

/// Readings in a row that agree with the design in use before it counts as confirmed: a
/// frame whose image contradicts the supervisor's prior is then taken for a prior that lags
/// the block (forming's first seconds), not for a design that does not fit.
pub const CONFIRM_FRAMES: u8 = 4;
/// Readings in a row that disagree with an unconfirmed design before their mean replaces it
/// (2 s at the sensor's 4 Hz of frames).
pub const ADOPT_FRAMES: u8 = 8;
/// Readings in a row that disagree with a confirmed design before their mean replaces it:
/// longer than a lagging prior lasts.
pub const REVOKE_FRAMES: u8 = 120;
/// Least gap |T1 − T2| of a frame whose reading counts, K: below it the stripes' width is
/// poorly measured (and which target is hotter matters little).
pub const READING_GAP_K: f32 = 1.0;

/// The exposed fraction the frames show against the design (carried in
/// [`super::super::regions::Geometry`] from frame to frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Exposure {
    /// The exposed fraction adopted in place of the configured design (`None`: the design).
    pub adopted: Option<f32>,
    /// Readings in a row that agreed with the design in use (up to [`CONFIRM_FRAMES`]).
    pub agreeing: u8,
    /// Readings in a row that disagreed with it.
    pub disagreeing: u8,
    /// Their sum (their mean is what a run adopts).
    pub disagreeing_sum: f32,
}

impl Exposure {
    /// No reading yet: the configured design, unconfirmed.
    pub const NONE: Exposure = Exposure {
        adopted: None,
        agreeing: 0,
        disagreeing: 0,
        disagreeing_sum: 0.0,
    };

    /// The design the next frame fits with: the adopted fraction, or the `configured` one.
    pub fn design(&self, configured: f32) -> f32 {
        self.adopted.unwrap_or(configured)
    }

    /// The design in use has been confirmed by [`CONFIRM_FRAMES`] readings in a row.
    pub fn confirmed(&self) -> bool {
        self.agreeing >= CONFIRM_FRAMES
    }

    /// Take one frame's `reading` (`None`: the frame gave none) against the `configured`
    /// design; `Some(fraction)` when this frame adopts a new design in use (the configured
    /// one again when the run's mean lies within its tolerance).
    pub fn take(&mut self, reading: Option<f32>, configured: f32) -> Option<f32> {
        let reading = reading?;
        let design = self.design(configured);
        if libm::fabsf(reading - design) <= EXPOSED_TOLERANCE {
            self.agreeing = self.agreeing.saturating_add(1).min(CONFIRM_FRAMES);
            self.disagreeing = 0;
            self.disagreeing_sum = 0.0;
            return None;
        }
        self.disagreeing = self.disagreeing.saturating_add(1);
        self.disagreeing_sum += reading;
        let needed = if self.confirmed() {
            REVOKE_FRAMES
        } else {
            ADOPT_FRAMES
        };
        if self.disagreeing < needed {
            return None;
        }
        let mean = clamp(
            self.disagreeing_sum / f32::from(self.disagreeing),
            EXPOSED_MIN,
            EXPOSED_MAX,
        );
        self.adopted = (libm::fabsf(mean - configured) > EXPOSED_TOLERANCE).then_some(mean);
        *self = Exposure {
            adopted: self.adopted,
            ..Exposure::NONE
        };
        Some(self.design(configured))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DESIGN: f32 = 0.71;

    #[test]
    fn readings_that_agree_confirm_the_design_and_none_change_nothing() {
        let mut e = Exposure::NONE;
        for _ in 0..CONFIRM_FRAMES - 1 {
            assert_eq!(e.take(Some(0.73), DESIGN), None);
        }
        assert!(!e.confirmed());
        assert_eq!(e.take(None, DESIGN), None);
        assert_eq!(e.take(Some(0.69), DESIGN), None);
        assert!(e.confirmed());
        assert_eq!(e.design(DESIGN), DESIGN);
    }

    #[test]
    fn a_run_of_readings_unlike_an_unconfirmed_design_is_adopted() {
        let mut e = Exposure::NONE;
        for i in 0..ADOPT_FRAMES - 1 {
            let r = if i % 2 == 0 { 0.32 } else { 0.34 };
            assert_eq!(e.take(Some(r), DESIGN), None, "frame {i}");
            assert_eq!(e.design(DESIGN), DESIGN);
        }
        let adopted = e
            .take(Some(0.33), DESIGN)
            .expect("adopted at the run's end");
        assert!((adopted - 0.33).abs() < 0.01, "{adopted}");
        assert_eq!(e.adopted, Some(adopted));
        assert!(!e.confirmed());
        // The new design in use is confirmed by readings like it; the configured one is back
        // once a run of readings like it comes.
        for _ in 0..CONFIRM_FRAMES {
            assert_eq!(e.take(Some(0.35), DESIGN), None);
        }
        assert!(e.confirmed());
        let mut back = None;
        for _ in 0..REVOKE_FRAMES {
            back = back.or(e.take(Some(0.72), DESIGN));
        }
        assert_eq!(back, Some(DESIGN));
        assert_eq!(e.adopted, None);
    }

    #[test]
    fn a_confirmed_design_outlasts_a_lagging_prior() {
        let mut e = Exposure::NONE;
        for _ in 0..CONFIRM_FRAMES {
            e.take(Some(0.71), DESIGN);
        }
        // Forming's first seconds: the prior says the surface is hotter while the heater
        // still is; the frames read 1 − 0.71.
        for _ in 0..REVOKE_FRAMES - 1 {
            assert_eq!(e.take(Some(0.29), DESIGN), None);
        }
        assert_eq!(e.design(DESIGN), DESIGN);
        // One agreeing reading ends the run.
        e.take(Some(0.70), DESIGN);
        assert_eq!(e.disagreeing, 0);
    }

    #[test]
    fn an_adopted_fraction_stays_within_what_the_fit_considers() {
        let mut e = Exposure::NONE;
        let mut got = None;
        for _ in 0..ADOPT_FRAMES {
            got = got.or(e.take(Some(0.99), DESIGN));
        }
        assert_eq!(got, Some(EXPOSED_MAX));
    }
}
