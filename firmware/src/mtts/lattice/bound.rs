//! The bound: how far T1 and T2 may lie from the truth. The spread of T1 and T2 over the
//! confidence set (the candidates within [`CONFIDENCE_CHI2`] of each hypothesis's best; both
//! hypotheses' where the image allowed both) and over the best candidates of the neighbouring
//! spreads, plus two standard errors from the pixels' noise, scaled by [`BOUND_SCALE`] and
//! floored by [`BOUND_FLOOR_K`]. Takes the [`Grid`], the [`Verdict`] and the [`Estimate`];
//! gives [`Bounds`].

use super::*;

/// The frame's bounds, K.
pub(super) struct Bounds {
    /// On |T1 − truth| and |T2 − truth| of the estimate.
    pub(super) estimate_k: f32,
    /// On how far either target may lie from the core's mean (a merged frame's).
    pub(super) merged_k: f32,
}

impl Bounds {
    /// The bounds of the estimate `est` on `grid` under `verdict`; `fit` gives the pixels'
    /// noise, `reference` and `mean` the core's values, K.
    pub(super) fn of(
        grid: &Grid,
        verdict: &Verdict,
        est: &Estimate,
        fit: &HarmonicFit,
        reference: f32,
        mean: f32,
    ) -> Bounds {
        let (t1, t2) = (est.t1_k, est.t2_k);
        // Envelopes over the confidence sets: around the estimate, and around the mean.
        let mut spread = 0f32;
        let mut merged_spread = 0f32;
        for hy in [Hyp::HeaterHot, Hyp::SurfaceHot] {
            let cmin = verdict.chi2(hy);
            let (base, nh) = (Grid::base_of(hy), grid.range_of(hy).len());
            for j in (0..PSFS).flat_map(|psf| psf * 2 * SLOTS + base..psf * 2 * SLOTS + base + nh) {
                let c = &grid.cand[j];
                if c.chi2 > cmin + CONFIDENCE_CHI2 {
                    continue;
                }
                let (x1, x2) = temps(reference, c, hy);
                let sd = crate::fmath::sqrt(fit.noise2 * c.var);
                let m = max(libm::fabsf(x1 - mean), libm::fabsf(x2 - mean)) + 2.0 * sd;
                if m > merged_spread {
                    merged_spread = m;
                }
                // The chosen hypothesis's set, and, when the image allows the other one too
                // (no clear verdict: the prior or the previous frame picked), the other's: a
                // wrong pick lies within that.
                if hy == verdict.hyp || !verdict.clear {
                    let e = max(libm::fabsf(x1 - t1), libm::fabsf(x2 - t2)) + 2.0 * sd;
                    spread = max(spread, e);
                }
            }
        }
        // The spread is a grid: the truth lies between two of its values. What the best
        // candidate would be at the neighbouring spreads (each one's best h in the hypothesis)
        // is within the bound too.
        let psf_best = est.best / (2 * SLOTS);
        for psf in [psf_best.wrapping_sub(1), psf_best + 1] {
            if psf >= PSFS {
                continue;
            }
            if let Some(j) = grid.best_in(verdict.hyp, psf..psf + 1) {
                let (x1, x2) = temps(reference, &grid.cand[j], verdict.hyp);
                let e = max(libm::fabsf(x1 - t1), libm::fabsf(x2 - t2));
                if e > spread {
                    spread = e;
                }
            }
        }
        // Calibrated on the seen seeds: what the grids and the model's approximations (the
        // core's straight edges, the footprint's two boxes) add.
        Bounds {
            estimate_k: BOUND_SCALE * spread + BOUND_FLOOR_K,
            merged_k: BOUND_SCALE * merged_spread + BOUND_FLOOR_K,
        }
    }
}
