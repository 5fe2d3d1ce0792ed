//! The posterior: T1, T2 and h as the posterior mean over a hypothesis's window and the
//! spreads (a sharp row by its χ² parabola's vertex). Takes a hypothesis's candidates; gives
//! [`Posterior`].

use super::*;

/// χ² above the best point beyond which [`posterior()`] leaves a point out (its weight
/// e^(−Δ/2) < 3.4·10⁻⁴).
pub(super) const POSTERIOR_CHI2: f32 = 16.0;
/// The posterior means of a, b and h.
pub(super) struct Posterior {
    pub(super) a: f32,
    pub(super) b: f32,
    /// h less the window's first, in grid steps.
    pub(super) h_steps: f32,
}

/// The value midway between points `i` and `i + 1` of `n` (≥ 2) equally spaced values `f`:
/// the cubic through the four around it, the quadratic through three at an end, the line
/// between two.
pub(super) fn midpoint(f: impl Fn(usize) -> f32, i: usize, n: usize) -> f32 {
    if i >= 1 && i + 2 < n {
        0.5625 * (f(i) + f(i + 1)) - 0.0625 * (f(i - 1) + f(i + 2))
    } else if n >= 3 && i == 0 {
        0.375 * f(0) + 0.75 * f(1) - 0.125 * f(2)
    } else if n >= 3 {
        0.375 * f(i + 1) + 0.75 * f(i) - 0.125 * f(i - 1)
    } else {
        0.5 * (f(i) + f(i + 1))
    }
}

/// Most the posterior sharpens χ² by, when the best candidate's residual variance exceeds the
/// pixel noise (the model's mismatch: a period a little off, the footprint's approximation): the
/// likelihood then takes the noise as at least a quarter of the residual variance. Seen
/// family members: mean |T2| 0.151 → 0.147 K (1, 2, 8, 16 and no limit: 0.148–0.150).
pub(super) const POSTERIOR_SHARPEN: f32 = 4.0;

/// Second difference over one h step of the posterior's χ² (sharpened, see
/// [`POSTERIOR_SHARPEN`]) above which a spread's row is sharp: its posterior's width in h,
/// √(2/Δ²χ²) steps, is under half a step, finer than the half steps (see [`posterior()`]).
pub(super) const POSTERIOR_SHARP: f32 = 8.0;

/// A sharp row's χ² parabola through its best h and their neighbours, at its vertex: χ², a, b,
/// the place in half h steps, and the row's weight against one point of the half-step grid
/// (the Gaussian's integral, √(4π/Δ²χ²) steps, over half a step).
pub(super) struct Vertex {
    pub(super) chi2: f32,
    pub(super) a: f32,
    pub(super) b: f32,
    pub(super) half_steps: f32,
    pub(super) mass: f32,
}

/// [`Vertex`] of the row `r` whose best candidate is `k`, if the row is sharp (its second
/// difference of χ² times `sharpen` exceeds [`POSTERIOR_SHARP`]) and `k` is not at the
/// window's ends.
pub(super) fn sharp_vertex(r: &[Candidate], k: usize, sharpen: f32) -> Option<Vertex> {
    if k == 0 || k + 1 >= r.len() {
        return None;
    }
    let (lo, c, hi) = (&r[k - 1], &r[k], &r[k + 1]);
    let den = (lo.chi2 - 2.0 * c.chi2 + hi.chi2) * sharpen;
    if den.is_nan() || den <= POSTERIOR_SHARP {
        return None;
    }
    let x = (0.5 * (lo.chi2 - hi.chi2) * sharpen / den).clamp(-0.5, 0.5);
    let at =
        |y0: f32, y1: f32, y2: f32| y1 + 0.5 * x * (y2 - y0) + 0.5 * x * x * (y0 - 2.0 * y1 + y2);
    Some(Vertex {
        chi2: at(lo.chi2, c.chi2, hi.chi2),
        a: at(lo.a, c.a, hi.a),
        b: at(lo.b, c.b, hi.b),
        half_steps: 2.0 * (k as f32 + x),
        mass: 2.0 * crate::fmath::sqrt(4.0 * core::f32::consts::PI / den),
    })
}

/// The posterior means of a, b and h over one hypothesis's window (`row(psf)`: its `nh`
/// candidates at spread `psf`, in h order) and the spreads, with a flat prior on both (the
/// design's window, the spreads' range) and the likelihood e^(−s·χ²/2), s = `sharpen` (see
/// [`POSTERIOR_SHARPEN`]): on the candidates and, between neighbouring h, at the
/// [`midpoint`] of their χ², a and b; a sharp row (s·χ²'s second difference over an h step
/// above [`POSTERIOR_SHARP`], so its posterior is narrower than half a step) by its
/// parabola's vertex, weighted by the parabola's integral. Points whose s·χ² lies past
/// [`POSTERIOR_CHI2`] above the best are left out (a midpoint when both its neighbours are:
/// one can dip at most a little below them).
///
/// A thin stripe's level trades against its width and the optics' spread along a valley of
/// nearly equal χ², whose minimum the noise moves from end to end; the mean over it errs far
/// less than that minimum. Where χ² is sharp, the vertex places it between the candidates' h.
pub(super) fn posterior<'a>(
    row: impl Fn(usize) -> &'a [Candidate],
    nh: usize,
    sharpen: f32,
) -> Posterior {
    // Each row's vertex, if sharp; the best χ² of all (candidates and vertices).
    let mut vertex: [Option<Vertex>; PSFS] = core::array::from_fn(|_| None);
    let mut lo = f32::INFINITY;
    for (psf, v) in vertex.iter_mut().enumerate() {
        let r = &row(psf)[..nh];
        let mut k = 0;
        for (j, c) in r.iter().enumerate() {
            if c.chi2 < r[k].chi2 {
                k = j;
            }
        }
        if let Some(c) = r.get(k)
            && c.chi2 < lo
        {
            lo = c.chi2;
        }
        *v = sharp_vertex(r, k, sharpen);
        if let Some(v) = v
            && v.chi2 < lo
        {
            lo = v.chi2;
        }
    }
    // χ² above `lo` past which a point is left out.
    let reach = POSTERIOR_CHI2 / sharpen;
    let (mut sw, mut sa, mut sb, mut sh) = (0f32, 0f32, 0f32, 0f32);
    let mut add = |chi2: f32, a: f32, b: f32, half_steps: f32, mass: f32| {
        // A midpoint may dip below the best point; far below is the interpolation's.
        let d = max(-POSTERIOR_CHI2, (chi2 - lo) * sharpen);
        if d < POSTERIOR_CHI2 {
            // e^(−d/2) as 2^(−d·log₂e/2).
            let w = mass * crate::fmath::exp2(d * (-0.5 * core::f32::consts::LOG2_E));
            sw += w;
            sa += w * a;
            sb += w * b;
            sh += w * half_steps;
        }
    };
    for (psf, v) in vertex.iter().enumerate() {
        if let Some(v) = v {
            add(v.chi2, v.a, v.b, v.half_steps, v.mass);
            continue;
        }
        let r = &row(psf)[..nh];
        for (k, c) in r.iter().enumerate() {
            add(c.chi2, c.a, c.b, (2 * k) as f32, 1.0);
            if k + 1 < nh {
                let next = r[k + 1].chi2;
                let near = if c.chi2 < next { c.chi2 } else { next };
                if near - lo < reach {
                    add(
                        midpoint(|x| r[x].chi2, k, nh),
                        midpoint(|x| r[x].a, k, nh),
                        midpoint(|x| r[x].b, k, nh),
                        (2 * k + 1) as f32,
                        1.0,
                    );
                }
            }
        }
    }
    // The best point has weight at least its mass: sw > 0 whenever nh > 0.
    if sw > 0.0 {
        Posterior {
            a: sa / sw,
            b: sb / sw,
            h_steps: 0.5 * sh / sw,
        }
    } else {
        let c = row(0).first().copied().unwrap_or_default();
        Posterior {
            a: c.a,
            b: c.b,
            h_steps: 0.0,
        }
    }
}

/// The frame's estimate: the posterior mean over the chosen hypothesis's window (h) and the
/// spreads (σ), not the grid's best point. Along the valley where a thin stripe's level trades
/// against its width and the optics' spread, χ² is nearly flat, and its minimum wanders with
/// the noise to the window's or the spreads' ends; where it is sharp, the grid's steps are
/// coarse against it ([`posterior()`]).
pub(super) struct Estimate {
    /// The best candidate's key (of the hypothesis taken, or of either if that has no window).
    pub(super) best: usize,
    /// The hypothesis whose window the estimate is over.
    pub(super) hyp: Hyp,
    /// h, in grid steps from that window's start.
    pub(super) h_steps: f32,
    /// T1 under the verdict's hypothesis, K.
    pub(super) t1_k: f32,
    /// T2 under the verdict's hypothesis, K.
    pub(super) t2_k: f32,
}

impl Estimate {
    /// The estimate on `grid` under `verdict`, from the free fit `fit` (its pixels' noise) and
    /// the core's `reference`, K.
    pub(super) fn of(
        grid: &Grid,
        verdict: &Verdict,
        fit: &HarmonicFit,
        reference: f32,
    ) -> Estimate {
        // At least one hypothesis has a window (the design is within EXPOSED_MIN…EXPOSED_MAX).
        let chosen = if verdict.hyp == Hyp::HeaterHot {
            verdict.best_a
        } else {
            verdict.best_b
        };
        let ibest = chosen.or(verdict.best_a).or(verdict.best_b).unwrap_or(0);
        let hyp_best = Grid::hyp_of(ibest);
        // χ² is against the best candidate's residual variance, which holds the model's
        // mismatch as well as the pixels' noise (their scatter within a fine bin); the
        // posterior takes the noise, but no less than 1/POSTERIOR_SHARPEN of the residual
        // variance.
        let ratio = grid.sigma2 / fit.noise2;
        let (base, nh) = (Grid::base_of(hyp_best), grid.range_of(hyp_best).len());
        // A hypothesis's candidates at one spread lie side by side, in h order.
        let post = posterior(
            |psf| &grid.cand[psf * 2 * SLOTS + base..][..nh],
            nh,
            if ratio < POSTERIOR_SHARPEN {
                ratio
            } else {
                POSTERIOR_SHARPEN
            },
        );
        let best = Candidate {
            a: post.a,
            b: post.b,
            ..grid.cand[ibest]
        };
        let (t1_k, t2_k) = temps(reference, &best, verdict.hyp);
        Estimate {
            best: ibest,
            hyp: hyp_best,
            h_steps: post.h_steps,
            t1_k,
            t2_k,
        }
    }
}
