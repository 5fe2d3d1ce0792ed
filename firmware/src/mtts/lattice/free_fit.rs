//! The free fit: the mean and the first harmonics of the period fitted to the profile by
//! least squares, free of any stripe shape. Takes a [`Profile`] and a frequency; gives
//! [`HarmonicFit`] (coefficients, normal matrix, the sums the candidates reuse).

use super::*;

/// Per-pixel least squares at frequency `nu`: the normal matrix, its right-hand side, the
/// solution and the residual variance per pixel; with the bins' slopes (see [`FINE`]) for the
/// candidates' model.
pub(super) struct HarmonicFit {
    pub(super) n: usize,
    pub(super) normal: [[f32; NP]; NP],
    /// Σ w·y·(1, cos kθ, sin kθ…) up to the candidates' model's harmonics.
    pub(super) rhs: [f32; RHS],
    pub(super) theta: [f32; NP],
    /// Σ w·cos mθ and Σ w·sin mθ, m = 0…2·(the model's harmonics): every entry of the normal
    /// matrix, the fit's and the model's (each half a sum or difference of two; [`gram`]).
    pub(super) cs: [f32; 2 * HARMONICS + 1],
    pub(super) sn: [f32; 2 * HARMONICS + 1],
    /// Σ w·y², K², and the bins in use.
    pub(super) yy: f32,
    pub(super) bins: f32,
    /// The bins' slopes (with `slopes`, else zero): Σ S·cos mθ and Σ S·sin mθ, S a bin's
    /// Σ (t − t̄)² (px²), m = 0…2·(the model's harmonics); Σ Y·(cos kθ, sin kθ), Y its
    /// Σ (t − t̄)·y (K·px), k = 1…(the model's harmonics), in the slots of [`Self::rhs`].
    pub(super) ds_c: [f32; 2 * HARMONICS + 1],
    pub(super) ds_s: [f32; 2 * HARMONICS + 1],
    pub(super) dy: [f32; RHS],
    /// Σ Y²/S over the bins of more than one axial position, K², and how many: what their
    /// slopes add to Σ w·y² and to the bins.
    pub(super) slope_yy: f32,
    pub(super) slope_bins: f32,
    pub(super) sigma2: f32,
    /// Pixel noise variance: the scatter of the pixels within a fine bin (same lattice
    /// phase), K².
    pub(super) noise2: f32,
    /// Weighted residual sum of squares, K².
    pub(super) rss: f32,
}

/// [`harmonic_fit_by`] at frequency `nu`, with the sums of the candidates' model up to `model`
/// harmonics and the bins' slopes.
pub(super) fn harmonic_fit(
    p: &Profile,
    nu: f32,
    harmonics: usize,
    model: usize,
) -> Option<HarmonicFit> {
    harmonic_fit_by::<true>(p, harmonics, model, |_, t| sin_cos_turns(nu * t))
}

/// [`harmonic_fit`] with the fundamental's (sin, cos) at bin b, axial position t from
/// `angle(b, t)` (which may keep them for a second pass); the bins' slopes' sums only with
/// `SLOPES` (the frequency's refinement, [`gn_step`], does without).
pub(super) fn harmonic_fit_by<const SLOPES: bool>(
    p: &Profile,
    harmonics: usize,
    model: usize,
    mut angle: impl FnMut(usize, f32) -> (f32, f32),
) -> Option<HarmonicFit> {
    let harmonics = harmonics.clamp(1, FIT_HARMONICS);
    let model = model.clamp(harmonics, HARMONICS);
    let n = 1 + 2 * harmonics;
    let mut f = HarmonicFit {
        n,
        normal: [[0.0; NP]; NP],
        rhs: [0.0; RHS],
        theta: [0.0; NP],
        cs: [0.0; 2 * HARMONICS + 1],
        sn: [0.0; 2 * HARMONICS + 1],
        yy: 0.0,
        bins: 0.0,
        ds_c: [0.0; 2 * HARMONICS + 1],
        ds_s: [0.0; 2 * HARMONICS + 1],
        dy: [0.0; RHS],
        slope_yy: 0.0,
        slope_bins: 0.0,
        sigma2: 0.0,
        noise2: 0.0,
        rss: 0.0,
    };
    // The pixels of a fine bin (¼ px) share nearly one axial position: their mean is the
    // sample at their mean position, their count its weight (and, with `SLOPES`, their slope
    // over the bin a sample of the derivative there: see [`FINE`]). The normal matrix's
    // entries are products of cos and sin of jθ and kθ (j, k ≤ H), each half a sum or
    // difference of the cos or sin of mθ (m ≤ 2H): the bins accumulate those 4H + 1 sums, not
    // the (2H + 1)(2H + 2)/2 products.
    let (mut yy, mut bins) = (0f32, 0f32);
    let mut cs = [0f32; 2 * HARMONICS + 1];
    let mut sn = [0f32; 2 * HARMONICS + 1];
    for b in 0..p.used {
        let bin = &p.bins[b];
        let w = bin.cnt;
        if w == 0.0 {
            continue;
        }
        let inv = 1.0 / w;
        let tm = bin.tsum * inv;
        let (s1, c1) = angle(b, tm);
        let y = bin.sum * inv;
        let wy = w * y;
        cs[0] += w;
        f.rhs[0] += wy;
        // The sums to 2·model, no further (one loop for any count: the flash holds one
        // copy); the first `model` feed the right-hand side too. Zipped slices: no bounds
        // checks.
        let (mut c, mut s) = (c1, s1);
        let (cs_lo, cs_hi) = cs[1..=2 * model].split_at_mut(model);
        let (sn_lo, sn_hi) = sn[1..=2 * model].split_at_mut(model);
        let rhs = f.rhs[1..=2 * model].chunks_exact_mut(2);
        // The bin's spread S and slope Y about its mean place (τ̄ in bin widths); a bin of
        // one place has none.
        let tau = fine_place(tm, p.t0) - b as f32;
        let sb = (bin.tt - w * tau * tau) * (1.0 / (FINE * FINE) as f32);
        if SLOPES && sb > SLOPE_MIN_PX2 {
            let yb = (bin.ty - tau * bin.sum) * (1.0 / FINE as f32);
            f.slope_yy += yb * yb / sb;
            f.slope_bins += 1.0;
            f.ds_c[0] += sb;
            let (dc_lo, dc_hi) = f.ds_c[1..=2 * model].split_at_mut(model);
            let (ds_lo, ds_hi) = f.ds_s[1..=2 * model].split_at_mut(model);
            let dy = f.dy[1..=2 * model].chunks_exact_mut(2);
            for (((cm, sm), (dcm, dsm)), (r, d)) in cs_lo
                .iter_mut()
                .zip(sn_lo.iter_mut())
                .zip(dc_lo.iter_mut().zip(ds_lo.iter_mut()))
                .zip(rhs.zip(dy))
            {
                *cm += w * c;
                *sm += w * s;
                *dcm += sb * c;
                *dsm += sb * s;
                r[0] += wy * c;
                r[1] += wy * s;
                d[0] += yb * c;
                d[1] += yb * s;
                (c, s) = turn((c, s), (c1, s1));
            }
            for ((cm, sm), (dcm, dsm)) in cs_hi
                .iter_mut()
                .zip(sn_hi.iter_mut())
                .zip(dc_hi.iter_mut().zip(ds_hi.iter_mut()))
            {
                *cm += w * c;
                *sm += w * s;
                *dcm += sb * c;
                *dsm += sb * s;
                (c, s) = turn((c, s), (c1, s1));
            }
        } else {
            for ((cm, sm), r) in cs_lo.iter_mut().zip(sn_lo.iter_mut()).zip(rhs) {
                *cm += w * c;
                *sm += w * s;
                r[0] += wy * c;
                r[1] += wy * s;
                (c, s) = turn((c, s), (c1, s1));
            }
            for (cm, sm) in cs_hi.iter_mut().zip(sn_hi.iter_mut()) {
                *cm += w * c;
                *sm += w * s;
                (c, s) = turn((c, s), (c1, s1));
            }
        }
        yy += wy * y;
        bins += 1.0;
    }
    if bins < n as f32 + 4.0 {
        return None;
    }
    f.normal[0][0] = cs[0];
    for k in 1..harmonics + 1 {
        f.normal[0][2 * k - 1] = cs[k];
        f.normal[0][2 * k] = sn[k];
        for j in 1..k + 1 {
            let (d, a) = (k - j, k + j);
            // cos jθ·cos kθ, sin jθ·sin kθ, cos jθ·sin kθ, sin jθ·cos kθ.
            f.normal[2 * j - 1][2 * k - 1] = 0.5 * (cs[d] + cs[a]);
            f.normal[2 * j][2 * k] = 0.5 * (cs[d] - cs[a]);
            f.normal[2 * j - 1][2 * k] = 0.5 * (sn[a] + sn[d]);
            f.normal[2 * j][2 * k - 1] = 0.5 * (sn[a] - sn[d]);
        }
    }
    for i in 0..n {
        for j in 0..i {
            f.normal[i][j] = f.normal[j][i];
        }
    }
    f.theta = solve(&f.normal, &f.rhs, n)?;
    (f.cs, f.sn, f.yy, f.bins) = (cs, sn, yy, bins);
    let fit: f32 = (0..n).map(|i| f.theta[i] * f.rhs[i]).sum();
    // Σ w·r² over the bins is (bins − n)·σ² for a pixel noise σ.
    let floor_k = NOISE_FLOOR_K;
    f.rss = yy - fit;
    f.sigma2 = max(floor_k * floor_k, f.rss / (bins - n as f32));
    f.noise2 = if p.total > bins {
        clamp((p.sq - yy) / (p.total - bins), floor_k * floor_k, f.sigma2)
    } else {
        f.sigma2
    };
    Some(f)
}

/// Harmonics fitted at most for a block whose design exposes `design_exposed` of each unit:
/// the thinner stripe's (a fraction h of the period) spectrum 2·sin(πkh)/(πk) first falls to
/// zero at k = 1/h; the fit reaches one harmonic past that, and never fewer than
/// [`BASE_HARMONICS`] nor more than [`HARMONICS`]. The thesis's block (71 % exposed, surface
/// stripes 0.29 of the period) keeps five; a block exposed beyond 75 % (or under 25 %) takes
/// six, which its thin stripes need (the first 1 000 unseen family members exposed 0.75–0.85
/// at 10–16 px: mean |T2| 0.38 K with five, 0.24 K with six). More than the stripes need is no
/// better: a sixth harmonic cost the thesis's block accuracy in the camera-on cycle (mean |T2|
/// 0.064 → 0.112 K) and the standard scenes' T1 (mean 0.010 → 0.028 K).
pub(super) fn harmonics_for(design_exposed: f32) -> usize {
    let thin = max(min(design_exposed, 1.0 - design_exposed), 0.05);
    // 1 + ⌈1/h⌉.
    ((1.0 - floor(-1.0 / thin)) as usize).clamp(BASE_HARMONICS, FIT_HARMONICS)
}

/// Harmonics of the candidates' model at most for a block whose design exposes
/// `design_exposed` of each unit: [`BASE_HARMONICS`] where the fit keeps them (the thesis's
/// block, whose camera-on cycle and standard scenes lost with more: [`MODEL_BAND_CPP`]), else
/// [`HARMONICS`], ten (the module docs). The fit keeps its six: the model's harmonics are fixed
/// by each candidate's stripe and spread, not unknowns.
pub(super) fn model_for(design_exposed: f32) -> usize {
    if harmonics_for(design_exposed) > BASE_HARMONICS {
        HARMONICS
    } else {
        BASE_HARMONICS
    }
}

/// Solve the symmetric positive definite system `a·x = b` (size n) by Cholesky; `None` when a
/// pivot is not clearly positive (an ill-conditioned fit).
pub(super) fn solve(a: &[[f32; NP]; NP], b: &[f32], n: usize) -> Option<[f32; NP]> {
    let mut l = [[0f32; NP]; NP];
    for i in 0..n {
        for j in 0..i + 1 {
            let mut s = a[i][j];
            for k in 0..j {
                s -= l[i][k] * l[j][k];
            }
            if i == j {
                if s <= 1e-4 * max(1e-12, a[i][i]) {
                    return None;
                }
                l[i][i] = crate::fmath::sqrt(s);
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    let mut y = [0f32; NP];
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i][k] * y[k];
        }
        y[i] = s / l[i][i];
    }
    let mut x = [0f32; NP];
    for i in (0..n).rev() {
        let mut s = y[i];
        for k in i + 1..n {
            s -= l[k][i] * x[k];
        }
        x[i] = s / l[i][i];
    }
    Some(x)
}
