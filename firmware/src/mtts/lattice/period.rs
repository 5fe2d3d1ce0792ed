//! The lattice's period: the periodogram's peak of the profile ([`find_frequency`]), refined by
//! Gauss–Newton steps of the least-squares fit ([`gn_step`]). Takes a [`Profile`]; gives a
//! frequency, cycles per pixel.

use super::*;

/// The profile on 1 px bins, mean removed (bin b centred at t0 + b + ½), for the periodogram.
pub(super) struct Coarse {
    pub(super) y: [f32; BINS],
    pub(super) used: usize,
    pub(super) t0: f32,
    pub(super) total: f32,
}

impl Coarse {
    pub(super) fn of(p: &Profile) -> Coarse {
        let mut c = Coarse {
            y: [0.0; BINS],
            used: p.length().min(BINS),
            t0: p.t0,
            total: max(p.total, 1.0),
        };
        for (b, four) in p.bins[..p.used].chunks(FINE).enumerate().take(BINS) {
            let (mut y, mut n) = (0f32, 0f32);
            for bin in four {
                y += bin.sum;
                n += bin.cnt;
            }
            c.y[b] = y - n * p.mean_dev;
        }
        c
    }
}

/// |fundamental| of the profile at `nu` cycles per pixel, K.
pub(super) fn amplitude(p: &Coarse, nu: f32) -> f32 {
    // z = e^{-i2πνt} at the bin centres, stepped by w = e^{-i2πν}.
    let (mut zs, mut zc) = sin_cos_turns(-nu * (p.t0 + 0.5));
    let (wr_s, wr_c) = sin_cos_turns(-nu);
    let (mut re, mut im) = (0f32, 0f32);
    for &y in &p.y[..p.used] {
        re += y * zc;
        im += y * zs;
        let nc = zc * wr_c - zs * wr_s;
        zs = zs * wr_c + zc * wr_s;
        zc = nc;
    }
    2.0 * crate::fmath::sqrt(re * re + im * im) / p.total
}

/// Find the lattice frequency: the periodogram's peak (parabola through the best grid point
/// and its neighbours) in [lo, hi] cycles per pixel, with its fundamental amplitude.
pub(super) fn find_frequency(p: &Coarse, lo: f32, hi: f32, step: f32) -> Option<(f32, f32)> {
    if hi <= lo {
        return None;
    }
    let n = ((hi - lo) / step) as usize + 1;
    let (mut best_i, mut best_a) = (0usize, -1f32);
    let (mut prev, mut at_best_prev, mut at_best_next) = (0f32, 0f32, 0f32);
    let mut after_best = false;
    for i in 0..n + 1 {
        let a = amplitude(p, lo + i as f32 * step);
        if after_best {
            at_best_next = a;
            after_best = false;
        }
        if a > best_a {
            best_a = a;
            best_i = i;
            at_best_prev = if i > 0 { prev } else { a };
            at_best_next = a;
            after_best = true;
        }
        prev = a;
    }
    // Half a step either side of the best grid point: the grid is coarse against the peak of
    // a lattice whose core shows under two periods (a peak between the first two points, at the
    // longest periods, would otherwise stay at the first). The parabola is then drawn through
    // the best of the three and its neighbours half a step away.
    let (left, right) = (best_i > 0, best_i < n);
    let nu_b = lo + best_i as f32 * step;
    let half = 0.5 * step;
    let ml = if left {
        amplitude(p, nu_b - half)
    } else {
        -1.0
    };
    let mr = if right {
        amplitude(p, nu_b + half)
    } else {
        -1.0
    };
    let (centre, y_l, y_c, y_r, ok) = if ml > best_a && ml >= mr {
        (nu_b - half, at_best_prev, ml, best_a, true)
    } else if mr > best_a {
        (nu_b + half, best_a, mr, at_best_next, right)
    } else {
        (nu_b, ml, best_a, mr, left && right)
    };
    let den = y_l - 2.0 * y_c + y_r;
    let off = if ok && den < -1e-9 {
        (0.5 * (y_l - y_r) / den).clamp(-0.5, 0.5)
    } else {
        0.0
    };
    let nu = centre + off * half;
    Some((nu, amplitude(p, nu)))
}

/// One Gauss–Newton step of the frequency ν of the least-squares fit of the mean and the first
/// `k` harmonics (at most [`REFINE_HARMONICS`]) to the fine bins, cycles per pixel; `None` where
/// the fit is ill-conditioned or the residual is flat in ν.
///
/// The model is linear in its coefficients θ (columns X) and not in ν; at the coefficients'
/// least squares the residual r is orthogonal to X, so the step in ν with θ re-fitted is
/// `Jᵀr / (JᵀJ − (XᵀJ)ᵀ·N⁻¹·XᵀJ)`, J = ∂model/∂ν = Σ_j 2πj·t·(b_j·cos jθ − a_j·sin jθ), N the
/// fit's normal matrix (all sums weighted by the bins' counts). A thin stripe's harmonics pull
/// the fundamental's own minimum off (family members whose core shows under two periods of
/// stripes 0.15–0.2 of the period wide: the periodogram's peak and a fit of the fundamental
/// alone left them 6–8 % off); three harmonics hold them.
///
/// `angles` is working memory (each bin's angle, kept by the fit's pass for the second).
#[inline(never)] // called twice: one copy in the flash
pub(super) fn gn_step(
    p: &Profile,
    nu: f32,
    k: usize,
    angles: &mut [(f32, f32); FINE_BINS],
) -> Option<f32> {
    let k = k.clamp(1, REFINE_HARMONICS);
    let f = harmonic_fit_by::<false>(p, k, k, |b, t| {
        let a = sin_cos_turns(nu * t);
        angles[b] = a;
        a
    })?;
    let n = f.n;
    let (mut jr, mut jj) = (0f32, 0f32);
    let mut xj = [0f32; NP];
    for b in 0..p.used {
        let bin = &p.bins[b];
        let w = bin.cnt;
        if w == 0.0 {
            continue;
        }
        let inv = 1.0 / w;
        let t = bin.tsum * inv;
        let y = bin.sum * inv;
        let (s1, c1) = angles[b];
        let (mut c, mut s) = (c1, s1);
        // cos jθ, sin jθ of this bin, j = 1…k.
        let mut rot = [(0f32, 0f32); REFINE_HARMONICS];
        let (mut model, mut slope) = (f.theta[0], 0f32);
        for (j, x) in rot.iter_mut().enumerate().take(k) {
            *x = (c, s);
            let (a, bj) = (f.theta[2 * j + 1], f.theta[2 * j + 2]);
            model += a * c + bj * s;
            slope += (j + 1) as f32 * (bj * c - a * s);
            (c, s) = turn((c, s), (c1, s1));
        }
        let wj = w * core::f32::consts::TAU * t * slope;
        jr += wj * (y - model);
        jj += wj * core::f32::consts::TAU * t * slope;
        xj[0] += wj;
        for (j, &(c, s)) in rot.iter().enumerate().take(k) {
            xj[2 * j + 1] += wj * c;
            xj[2 * j + 2] += wj * s;
        }
    }
    let u = solve(&f.normal, &xj, n)?;
    let curvature = jj - (0..n).map(|i| xj[i] * u[i]).sum::<f32>();
    (curvature > 0.0).then(|| jr / curvature)
}
