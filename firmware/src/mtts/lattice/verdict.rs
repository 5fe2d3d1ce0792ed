//! Which target is hotter: each hypothesis's best candidate (heater hot within the design's
//! window, or surface hot within its mirror), a clear spatial verdict where their χ² differ by
//! [`AMBIGUOUS_CHI2`], else the supervisor's prior or the previous frame's decision. Takes a
//! [`Grid`] and the prior; gives [`Verdict`].

use super::*;

/// What the frame says about which target is hotter.
pub(super) struct Verdict {
    /// The hypothesis taken.
    pub(super) hyp: Hyp,
    /// The image alone decided (its two hypotheses' χ² differ by [`AMBIGUOUS_CHI2`]).
    pub(super) clear: bool,
    /// Decided: by the image, the prior or the previous frame.
    pub(super) decided: bool,
    /// The heater-hot hypothesis's best candidate (key) and its χ².
    pub(super) best_a: Option<usize>,
    pub(super) chi2_a: f32,
    /// The surface-hot hypothesis's.
    pub(super) best_b: Option<usize>,
    pub(super) chi2_b: f32,
}

impl Verdict {
    /// The verdict on `grid` under the supervisor's `prior`, `heater_hotter` the previous
    /// frame's decision.
    pub(super) fn of(grid: &Grid, prior: Prior, heater_hotter: Option<bool>) -> Verdict {
        let (ia, ib) = (
            grid.best_in(Hyp::HeaterHot, 0..PSFS),
            grid.best_in(Hyp::SurfaceHot, 0..PSFS),
        );
        let chi2_of = |i: Option<usize>| i.map_or(f32::INFINITY, |i| grid.cand[i].chi2);
        let (ca, cb) = (chi2_of(ia), chi2_of(ib));
        let (bonus_a, bonus_b, informed) = match (prior, heater_hotter) {
            (Prior::HeaterHotter, _) => (PRIOR_CHI2, 0.0, true),
            (Prior::SurfaceHotter, _) => (0.0, PRIOR_CHI2, true),
            (Prior::Unknown, Some(true)) => (CONTINUITY_CHI2, 0.0, true),
            (Prior::Unknown, Some(false)) => (0.0, CONTINUITY_CHI2, true),
            (Prior::Unknown, None) => (0.0, 0.0, false),
        };
        // A clear spatial verdict stands whatever the prior says; between hypotheses the
        // image both allows, the prior (or the previous frame) picks.
        let clear = libm::fabsf(ca - cb) >= AMBIGUOUS_CHI2;
        let hyp = if clear {
            if ca <= cb {
                Hyp::HeaterHot
            } else {
                Hyp::SurfaceHot
            }
        } else if ca - bonus_a <= cb - bonus_b {
            Hyp::HeaterHot
        } else {
            Hyp::SurfaceHot
        };
        Verdict {
            hyp,
            clear,
            decided: informed || clear,
            best_a: ia,
            chi2_a: ca,
            best_b: ib,
            chi2_b: cb,
        }
    }

    /// The best χ² of hypothesis `hyp`.
    pub(super) fn chi2(&self, hyp: Hyp) -> f32 {
        match hyp {
            Hyp::HeaterHot => self.chi2_a,
            Hyp::SurfaceHot => self.chi2_b,
        }
    }
}
