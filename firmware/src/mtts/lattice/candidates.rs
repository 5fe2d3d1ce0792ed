//! The candidates: for each hot-stripe fraction h of the grid and each spread, the (a, b) of
//! the square wave that best matches the core's pixels and its misfit χ², through the free
//! fit's sums. Takes a [`HarmonicFit`]; gives [`Candidate`]s.

use super::*;

/// One h of the grid: the colder temperature a (less the reference), the gap b, their
/// standard errors on (a + b) and a, and the misfit χ².
#[derive(Clone, Copy, Default)]
pub(super) struct Candidate {
    pub(super) a: f32,
    pub(super) b: f32,
    /// Variance of the larger of T_hot, T_cold per unit pixel-noise variance.
    pub(super) var: f32,
    pub(super) chi2: f32,
}

/// 2/(πk), k = 1…[`HARMONICS`] (index k − 1): a stripe's k-th harmonic per unit gap and
/// unit transfer is 2·sin(πkh)/(πk).
pub(super) const TWO_OVER_PI_K: [f32; HARMONICS] = {
    let mut t = [0f32; HARMONICS];
    let mut k = 0;
    while k < HARMONICS {
        t[k] = 2.0 / (core::f32::consts::PI * (k + 1) as f32);
        k += 1;
    }
    t
};

/// The trigonometric values of one h of the grid: sin(πkh) at `sin[k − 1]`, k = 1…(the
/// model's harmonics), and cos(πnh) at `cos[n]`, n = 0…2·(the model's harmonics).
#[derive(Clone, Copy)]
pub(super) struct Trig {
    pub(super) sin: [f32; HARMONICS],
    pub(super) cos: [f32; 2 * HARMONICS + 1],
}

impl Default for Trig {
    fn default() -> Self {
        Trig {
            sin: [0.0; HARMONICS],
            cos: [0.0; 2 * HARMONICS + 1],
        }
    }
}

impl Trig {
    /// The sines and cosines of h's multiples (all of [`HARMONICS`]: a candidate's products run
    /// over the full length, the model's rest zero, in loops of fixed length), stepped by the
    /// angle sum from sin πh, cos πh.
    pub(super) fn of(h: f32) -> Trig {
        let (s1, c1) = sin_cos_turns(0.5 * h);
        let mut cos = [1f32; 2 * HARMONICS + 1];
        let mut sin = [0f32; HARMONICS];
        let (mut c, mut s) = (c1, s1);
        for n in 1..2 * HARMONICS + 1 {
            cos[n] = c;
            if n <= HARMONICS {
                sin[n - 1] = s;
            }
            (c, s) = turn((c, s), (c1, s1));
        }
        Trig { sin, cos }
    }
}

/// A spread's share of every candidate's products, once per spread: a candidate's
/// coefficients in the model's basis are c = (h, τ_1·sin πh, …, τ_K·sin πKh) with
/// τ_k = 2·H_k/(πk) (H_k the spread's transfer), so with the Gram matrix m and uᵀ·rhs (ur)
///
/// - g01 = (m·c)₀ = h·m₀₀ + Σ_k a_k·sin πkh, a_k = m₀ₖ·τ_k;
/// - rv = c·ur = h·ur₀ + Σ_k r_k·sin πkh, r_k = urₖ·τ_k;
/// - g11 = cᵀ·m·c = h²·m₀₀ + 2h·(g01 − h·m₀₀) + Σ_n q_n·cos πnh, n = 0…2K: the harmonics'
///   block Σ_kl M_kl·sin πkh·sin πlh (M_kl = m_kl·τ_k·τ_l), each product of sines half a
///   difference of cos π(k − l)h and cos π(k + l)h.
///
/// A candidate then costs 4K + 1 products, not the (K + 1)(K + 2)/2 + K + 1 of the quadratic
/// form: a model of ten harmonics 41 against 77, which is what lets a thin-stripe design
/// model ten within the Cortex-M4 budget.
#[derive(Clone, Copy, Default)]
pub(super) struct Spread {
    pub(super) m00: f32,
    pub(super) ur0: f32,
    pub(super) a: [f32; HARMONICS],
    pub(super) r: [f32; HARMONICS],
    pub(super) q: [f32; 2 * HARMONICS + 1],
}

impl Spread {
    /// The sums of one spread whose transfers (harmonic k at `mtf[k − 1]`) are `mtf`, for a
    /// model of `model` harmonics, in loops of the fixed length `K` (≥ `model`; the rest zero).
    #[inline(always)]
    pub(super) fn of<const K: usize>(
        m: &[[f32; U]; U],
        ur: &[f32; U],
        mtf: &[f32; HARMONICS],
        model: usize,
    ) -> Spread {
        const { assert!(K <= HARMONICS) };
        let mut tau = [0f32; HARMONICS];
        for (k, t) in tau.iter_mut().enumerate().take(model.min(K)) {
            *t = mtf[k] * TWO_OVER_PI_K[k];
        }
        let mut a = [0f32; HARMONICS];
        let mut r = [0f32; HARMONICS];
        for k in 1..K + 1 {
            a[k - 1] = m[0][k] * tau[k - 1];
            r[k - 1] = ur[k] * tau[k - 1];
        }
        // The differences' (Toeplitz) and the sums' (Hankel) shares, row by row of the
        // harmonics' block: each row's call has a constant k once inlined, so its loop over l
        // has constant bounds and every slot a constant index (the sums stay in registers).
        let mut toeplitz = [0f32; 2 * HARMONICS + 1];
        let mut hankel = [0f32; 2 * HARMONICS + 1];
        const { assert!(HARMONICS == 10) };
        let (t, hk) = (&mut toeplitz, &mut hankel);
        Self::row::<K>(1, m, &tau, t, hk);
        Self::row::<K>(2, m, &tau, t, hk);
        Self::row::<K>(3, m, &tau, t, hk);
        Self::row::<K>(4, m, &tau, t, hk);
        Self::row::<K>(5, m, &tau, t, hk);
        Self::row::<K>(6, m, &tau, t, hk);
        Self::row::<K>(7, m, &tau, t, hk);
        Self::row::<K>(8, m, &tau, t, hk);
        Self::row::<K>(9, m, &tau, t, hk);
        Self::row::<K>(10, m, &tau, t, hk);
        let mut q = [0f32; 2 * HARMONICS + 1];
        for ((q, t), h) in q.iter_mut().zip(&toeplitz).zip(&hankel) {
            *q = t - h;
        }
        Spread {
            m00: m[0][0],
            ur0: ur[0],
            a,
            r,
            q,
        }
    }

    /// Row `k` of the harmonics' block into the sums: the diagonal's half to slots 0 and 2k,
    /// each l = k + 1…K to slot l − k (`toeplitz`) and k + l (`hankel`); nothing past `K`.
    #[inline(always)]
    pub(super) fn row<const K: usize>(
        k: usize,
        m: &[[f32; U]; U],
        tau: &[f32; HARMONICS],
        toeplitz: &mut [f32; 2 * HARMONICS + 1],
        hankel: &mut [f32; 2 * HARMONICS + 1],
    ) {
        if k > K {
            return;
        }
        let tk = tau[k - 1];
        let d = 0.5 * m[k][k] * tk * tk;
        toeplitz[0] += d;
        hankel[2 * k] += d;
        for l in k + 1..K + 1 {
            let e = m[k][l] * tk * tau[l - 1];
            toeplitz[l - k] += e;
            hankel[k + l] += e;
        }
    }

    /// (g01, g11, rv) of the candidate of hot-stripe fraction `h`, whose sines and cosines are
    /// `t`, and of its mirror 1 − h: sin πk(1 − h) = (−1)^(k+1)·sin πkh and
    /// cos πn(1 − h) = (−1)^n·cos πnh, so the mirror's sums are the same terms, the odd
    /// and the even apart, added the other way. Loops of the fixed length `K` (even; past the
    /// model's harmonics this spread's sums are zero), which the compiler unrolls.
    #[inline(always)]
    pub(super) fn products<const K: usize>(&self, h: f32, t: &Trig) -> [(f32, f32, f32); 2] {
        const { assert!(K.is_multiple_of(2) && K <= HARMONICS) };
        // Odd and even k (index k − 1), odd and even n.
        let (mut po, mut pe, mut ro, mut re) = (0f32, 0f32, 0f32, 0f32);
        let (mut qo, mut qe) = (0f32, self.q[0]);
        for j in 0..K / 2 {
            let (o, e) = (2 * j, 2 * j + 1);
            po += self.a[o] * t.sin[o];
            pe += self.a[e] * t.sin[e];
            ro += self.r[o] * t.sin[o];
            re += self.r[e] * t.sin[e];
        }
        for j in 0..K {
            let (o, e) = (2 * j + 1, 2 * j + 2);
            qo += self.q[o] * t.cos[o];
            qe += self.q[e] * t.cos[e];
        }
        let one = |h: f32, p: f32, rv: f32, qq: f32| {
            let hm = h * self.m00;
            (hm + p, h * (hm + 2.0 * p) + qq, h * self.ur0 + rv)
        };
        [
            one(h, po + pe, ro + re, qe + qo),
            one(1.0 - h, po - pe, ro - re, qe - qo),
        ]
    }
}

impl Candidate {
    /// The least-squares a ≥ any, b ≥ 0 of a candidate whose products with the fit's sums are
    /// `(g01, g11, rv)` (g00 = Σ w, r0 = Σ w·y, `yy` = Σ w·y² with the slopes'), and its
    /// misfit Σ w·r² in `chi2` (a χ² once the noise is known).
    #[inline(always)]
    pub(super) fn of(g00: f32, r0: f32, yy: f32, (g01, g11, rv): (f32, f32, f32)) -> Candidate {
        let det = g00 * g11 - g01 * g01;
        let regular = det > 1e-6 * g00 * g11;
        let inv_det = if regular { 1.0 / det } else { 0.0 };
        let (mut a, mut b) = if regular {
            (
                (g11 * r0 - g01 * rv) * inv_det,
                (g00 * rv - g01 * r0) * inv_det,
            )
        } else {
            (r0 / g00, 0.0)
        };
        let explained = if b < 0.0 {
            a = r0 / g00;
            b = 0.0;
            a * r0
        } else {
            a * r0 + b * rv
        };
        let (va, vb, cab) = if regular {
            (g11 * inv_det, g00 * inv_det, -g01 * inv_det)
        } else {
            (1.0 / g00, 0.0, 0.0)
        };
        let var_hot = va + vb + 2.0 * cab;
        Candidate {
            a,
            b,
            var: if var_hot > va { var_hot } else { va },
            chi2: max(0.0, yy - explained),
        }
    }
}

/// Which hypothesis: the heater is the hot stripe (A) or the cold one (B).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum Hyp {
    HeaterHot,
    SurfaceHot,
}

/// Write [`transfer`] at the first `model` harmonics of `nu` (cycles per pixel, along an axis
/// of slope `slope`) and each spread of [`PSF_SIGMAS_PX`] into `mtf` (`mtf[spread][k]`): the
/// footprint's two boxes, cos α and sin α wide, their sines at k·ν by the angle-sum step from
/// ν's, times the Gaussian's: the spreads are multiples i·δ of one step, so
/// exp(−2(πσkν)²) = E_k^(i²) with E_k = E_1^(k²), both stepped by products (one `expf` in all).
pub(super) fn transfers(nu: f32, slope: f32, model: usize, mtf: &mut [[f32; HARMONICS]; PSFS]) {
    let inv_norm = 1.0 / crate::fmath::sqrt(1.0 + slope * slope);
    let widths = (inv_norm, libm::fabsf(slope) * inv_norm);
    let (sa1, ca1) = sin_cos_turns(0.5 * nu * widths.0);
    let (sb1, cb1) = sin_cos_turns(0.5 * nu * widths.1);
    let (mut box_a, mut box_b) = ((ca1, sa1), (cb1, sb1));
    let x1 = core::f32::consts::PI * PSF_STEP_PX * nu;
    let e1 = libm::expf(-2.0 * x1 * x1);
    // E_k, stepped by E_1^(2k + 1), itself stepped by E_1².
    let (mut ek, mut ek_step, e1_2) = (e1, e1 * e1 * e1, e1 * e1);
    for k in 0..model {
        let f = (k + 1) as f32 * nu;
        let boxes = sinc_of(box_a.1, f * widths.0) * sinc_of(box_b.1, f * widths.1);
        box_a = turn(box_a, (ca1, sa1));
        box_b = turn(box_b, (cb1, sb1));
        // E_k^(i²), stepped by E_k^((i+1)² − i²) = E_k^(2i + 1), itself stepped by E_k².
        let (mut gauss, mut step, e2) = (1.0, ek, ek * ek);
        for row in mtf.iter_mut() {
            row[k] = boxes * gauss;
            gauss *= step;
            step *= e2;
        }
        ek *= ek_step;
        ek_step *= e1_2;
    }
}

/// Write the candidates' Gram matrix m = uᵀ·N·u and uᵀ·rhs into `m` and `ur`, for the fit's
/// sums and `model` harmonics at the fundamental's phase ψ (cos ψ, sin ψ), where u_0 = e_0 and
/// u_k = (cos kψ, sin kψ) in harmonic k's slots of the basis (1, cos θ, sin θ, cos 2θ, …),
/// θ = 2πν·t at `nu` cycles per pixel; with the bins' slopes (the fit's `ds_c`, `ds_s`, `dy`)
/// added through the model's derivative along the axis.
pub(super) fn gram(
    fit: &HarmonicFit,
    model: usize,
    nu: f32,
    (cpsi, spsi): (f32, f32),
    m: &mut [[f32; U]; U],
    ur: &mut [f32; U],
) {
    // The bins' sums turned by the phase: R_j = Σ w·cos(j(θ − ψ)) = C_j·cos jψ + S_j·sin jψ,
    // j = 0…2·model. With u_0 = e_0 and u_k = (cos kψ, sin kψ) in harmonic k's slots, the
    // products of the normal matrix's 2 × 2 blocks (each entry half a sum or difference of
    // the C and S at |i − j| and i + j) reduce to m_00 = R_0, m_0j = R_j and
    // m_ij = (R_|i−j| + R_(i+j))/2: Toeplitz plus Hankel, one product each.
    //
    // The slopes: a pixel at t̄ + δ in a bin of mean place t̄ sees the model at t̄ plus δ times
    // its derivative, and a candidate's misfit over the bin's pixels is the bin mean's plus
    // its slope's: Σ S·(Y/S − v')² with S = Σ δ², Y = Σ δ·y (the cross terms vanish, Σ δ = 0).
    // The k-th unit's derivative is −2πν·k·sin(k(θ − ψ)), so the slopes add
    // (2πν)²·i·j·(RS_|i−j| − RS_(i+j))/2 to m_ij (RS the S-weighted R) and
    // −2πν·i·Σ Y·sin(i(θ − ψ)) to ur_i.
    let mut turned = [0f32; 2 * HARMONICS + 1];
    let mut turned_s = [0f32; 2 * HARMONICS + 1];
    let mut j_psi = (1f32, 0f32);
    for j in 0..2 * model + 1 {
        turned[j] = fit.cs[j] * j_psi.0 + fit.sn[j] * j_psi.1;
        turned_s[j] = fit.ds_c[j] * j_psi.0 + fit.ds_s[j] * j_psi.1;
        j_psi = turn(j_psi, (cpsi, spsi));
    }
    let w = core::f32::consts::TAU * nu;
    let w2 = 0.5 * w * w;
    m[0][0] = turned[0];
    ur[0] = fit.rhs[0];
    let mut k_psi = (cpsi, spsi);
    for i in 1..model + 1 {
        m[0][i] = turned[i];
        m[i][0] = turned[i];
        for j in 1..i + 1 {
            let x = 0.5 * (turned[i - j] + turned[i + j])
                + w2 * (i * j) as f32 * (turned_s[i - j] - turned_s[i + j]);
            m[i][j] = x;
            m[j][i] = x;
        }
        ur[i] = fit.rhs[2 * i - 1] * k_psi.0 + fit.rhs[2 * i] * k_psi.1
            - w * i as f32 * (fit.dy[2 * i] * k_psi.0 - fit.dy[2 * i - 1] * k_psi.1);
        k_psi = turn(k_psi, (cpsi, spsi));
    }
}

/// The hot-stripe fraction of candidate `j` (candidates run over h, then over the spreads).
pub(super) fn h_at(j: usize) -> f32 {
    H_FIRST + (j % H_COUNT) as f32 * H_STEP
}

/// The exposed fractions a frame of a block designed with `design` may show.
pub(super) fn window(design: f32) -> (f32, f32) {
    (
        max(design - EXPOSED_TOLERANCE, EXPOSED_MIN) - 1e-4,
        min(design + EXPOSED_TOLERANCE, EXPOSED_MAX) + 1e-4,
    )
}

/// The grid indices `i` (h = h_at(i)) a hypothesis allows in the window `(lo, hi)` of exposed
/// fractions: a range, empty when none. The surface-hot range is the heater-hot one's mirror
/// (h ↔ 1 − h, i ↔ `H_COUNT` − 1 − i; the grid is symmetric about ½), which lets a candidate's
/// products serve both ([`Spread::products`]).
pub(super) fn h_range(hyp: Hyp, (lo, hi): (f32, f32)) -> core::ops::Range<usize> {
    let first = max(0.0, (lo - H_FIRST) / H_STEP);
    let first = first as usize + usize::from(first > floor(first));
    let last = max(-1.0, (hi - H_FIRST) / H_STEP);
    let end = if last < 0.0 {
        0
    } else {
        (last as usize + 1).min(H_COUNT)
    };
    let first = first.min(end);
    let heater_hot = first..end.min(first + SLOTS);
    match hyp {
        Hyp::HeaterHot => heater_hot,
        Hyp::SurfaceHot => H_COUNT - heater_hot.end..H_COUNT - heater_hot.start,
    }
}

/// The free fit's sums per spread, from which every candidate's products are made: the
/// Gram matrix of the model's basis at the fundamental's phase, folded per spread
/// ([`Spread`]), and the fit's totals.
pub(super) struct Spreads {
    all: [Spread; PSFS],
    /// Σ w, Σ w·y and Σ w·y² (with the bins' slopes) of the fit.
    g00: f32,
    r0: f32,
    fit_yy: f32,
    /// The fundamental's phase: (cos ψ, sin ψ).
    pub(super) psi: (f32, f32),
    /// The misfit's degrees of freedom (at least 1).
    dof: f32,
}

impl Spreads {
    /// The sums of the free fit `fit` at frequency `nu` along an axis of slope `slope`, the
    /// model reaching `model` harmonics.
    pub(super) fn of(fit: &HarmonicFit, nu: f32, slope: f32, model: usize) -> Spreads {
        let (a1, b1) = (fit.theta[1], fit.theta[2]);
        let r1 = max(1e-12, crate::fmath::sqrt(a1 * a1 + b1 * b1));
        let (cpsi, spsi) = (a1 / r1, b1 / r1);
        let mut mtf = [[0f32; HARMONICS]; PSFS];
        transfers(nu, slope, model, &mut mtf);
        // The model's coefficients per unit gap are v = Σ_k c_k·u_k with u_0 = e_0 (weight h)
        // and u_k = (cos kψ, sin kψ) in harmonic k's slots (weight 2·S_k(h)·H_k), k up to the
        // model's harmonics: the Gram matrix m = uᵀ·N·u and uᵀ·rhs, computed once, make each
        // candidate a (1 + H) × (1 + H) product, and its misfit Σ w·y² less what it explains.
        let (mut m, mut ur) = ([[0f32; U]; U], [0f32; U]);
        gram(fit, model, nu, (cpsi, spsi), &mut m, &mut ur);
        // A loop, not `array::from_fn`, which the compiler unrolls into a copy per spread.
        let mut all = [Spread::default(); PSFS];
        for (spread, mtf) in all.iter_mut().zip(&mtf) {
            *spread = Spread::of::<HARMONICS>(&m, &ur, mtf, model);
        }
        Spreads {
            all,
            g00: fit.cs[0],
            r0: fit.rhs[0],
            fit_yy: fit.yy + fit.slope_yy,
            psi: (cpsi, spsi),
            dof: (fit.bins + fit.slope_bins - MODEL_PARAMETERS).max(1.0),
        }
    }

    /// The candidates of hot-stripe fraction `h` (sines and cosines `t`) and of its mirror
    /// 1 − h at spread `psf`, their misfits Σ w·r² in `chi2`. Not inlined: the grid and the
    /// free scan share one copy of the unrolled products (the board's flash is full).
    #[inline(never)]
    fn pair(&self, psf: usize, h: f32, t: &Trig) -> [Candidate; 2] {
        // The full model's length whatever the model: a base model's sums past its harmonics
        // are zero, which adds nothing (one copy of the unrolled loops in the flash).
        let [pa, pb] = self.all[psf].products::<HARMONICS>(h, t);
        [
            Candidate::of(self.g00, self.r0, self.fit_yy, pa),
            Candidate::of(self.g00, self.r0, self.fit_yy, pb),
        ]
    }
}

/// The spreads the free scan tries: every third of [`PSF_SIGMAS_PX`] (0, 0.3, 0.6 px).
const FREE_SPREADS: [usize; 3] = [0, 3, 6];
/// The free scan's step on the h grid, grid steps (0.05).
const FREE_STEP: usize = 2;
/// Hot-stripe fractions of the free scan up to ½ (each with its mirror): h_at(0), h_at(2), …,
/// h_at(16).
const FREE_H: usize = (H_COUNT / 2) / FREE_STEP + 1;

/// The free scan: the hot stripes' fraction the image shows, free of the design. Every other
/// h of the grid (0.1, 0.15, … 0.9) under every third spread, and the best of them within the
/// design's windows: when that is worse than the free best by [`DESIGN_CHI2`], the design
/// does not explain the image (a lattice unlike its design: another print, another view).
/// Takes the [`Spreads`] and the design; gives [`FreeScan`].
pub(super) struct FreeScan {
    /// The best candidate's hot-stripe fraction.
    pub(super) hot: f32,
    /// The best candidate (its levels: the image's own answer).
    pub(super) best: Candidate,
    /// The image allows the grid's thinnest stripes (hot stripes 0.1 or 0.9 of the period):
    /// their best misfit lies within [`CONFIDENCE_CHI2`] of the free best's. A stripe that
    /// thin trades its level against its width and the optics' spread along a valley the
    /// grid's end cuts: the image does not bound the thinner target's level.
    pub(super) thinnest_allowed: bool,
    /// The design windows' best misfit less the free best's, over the free best's noise
    /// variance: a χ² excess.
    pub(super) excess_chi2: f32,
}

impl FreeScan {
    /// The free scan of `sp` for a block designed with `design_exposed`.
    pub(super) fn of(sp: &Spreads, design_exposed: f32) -> FreeScan {
        let win = window(design_exposed);
        let (ra, rb) = (h_range(Hyp::HeaterHot, win), h_range(Hyp::SurfaceHot, win));
        let mut free = (f32::INFINITY, 0usize);
        let mut best = Candidate::default();
        let mut design = f32::INFINITY;
        let mut edge = f32::INFINITY;
        for j in 0..FREE_H {
            let i = j * FREE_STEP;
            let h = h_at(i);
            let t = Trig::of(h);
            for &psf in &FREE_SPREADS {
                let pair = sp.pair(psf, h, &t);
                for (c, i) in pair.iter().zip([i, H_COUNT - 1 - i]) {
                    if c.chi2 < free.0 {
                        free = (c.chi2, i);
                        best = *c;
                    }
                    if (i == 0 || i == H_COUNT - 1) && c.chi2 < edge {
                        edge = c.chi2;
                    }
                    if (ra.contains(&i) || rb.contains(&i)) && c.chi2 < design {
                        design = c.chi2;
                    }
                }
            }
        }
        let sigma2 = (free.0 / sp.dof).max(NOISE_FLOOR_K * NOISE_FLOOR_K);
        FreeScan {
            hot: h_at(free.1),
            best,
            thinnest_allowed: (edge - free.0) / sigma2 <= CONFIDENCE_CHI2,
            excess_chi2: (design - free.0) / sigma2,
        }
    }

    /// How far the image's own answer lies from `design`, read either way (the hot stripes
    /// the heater's, or the surface's).
    pub(super) fn off(&self, design: f32) -> f32 {
        min(
            libm::fabsf(self.hot - design),
            libm::fabsf(1.0 - self.hot - design),
        )
    }

    /// The design's windows explain the image about as well as any h does, or the best h
    /// lies near them: read either way (the heater's stripes or the surface's), it is within
    /// twice the tolerance of `design` (a thin stripe's χ² valley runs past the window's end
    /// on a block of its design).
    pub(super) fn design_fits(&self, design: f32) -> bool {
        self.excess_chi2 < DESIGN_CHI2 || self.off(design) <= 2.0 * EXPOSED_TOLERANCE
    }
}

/// The candidates of one frame: each hypothesis's window of h (about the design, heater hot,
/// and its mirror, surface hot) under every spread, with its χ² (the misfit over the noise,
/// plus the design's prior on the exposed fraction).
pub(super) struct Grid {
    /// Key = spread·2·[`SLOTS`] + the window's base (0 heater hot, [`SLOTS`] surface hot) + the
    /// h's place in the window; keys outside the windows keep an infinite χ².
    pub(super) cand: [Candidate; CANDIDATES],
    /// The heater-hot hypothesis's window on the h grid.
    range_a: core::ops::Range<usize>,
    /// The surface-hot hypothesis's.
    range_b: core::ops::Range<usize>,
    /// The pixels' noise variance the χ² are against (the best candidate's misfit per degree
    /// of freedom), K².
    pub(super) sigma2: f32,
}

impl Grid {
    /// The candidates from the sums `sp` for a block designed with `design_exposed`.
    pub(super) fn of(sp: &Spreads, design_exposed: f32, prior: bool) -> Grid {
        let win = window(design_exposed);
        let mut grid = Grid {
            cand: [Candidate {
                chi2: f32::INFINITY,
                ..Candidate::default()
            }; CANDIDATES],
            range_a: h_range(Hyp::HeaterHot, win),
            range_b: h_range(Hyp::SurfaceHot, win),
            sigma2: 0.0,
        };
        let range_a = grid.range_a.clone();
        // Per place of the heater-hot window, the stripe's harmonics' sines sin(πkh), k = 1…,
        // and the cosines cos(πnh), n = 0…, of its h: with each spread's sums, a candidate's
        // products are three dot products, and its mirror's (1 − h, the surface-hot window's)
        // the same sums split by parity ([`Spread`]). Windows that overlap (a design near
        // 50 %) compute their common h twice.
        let mut trig = [Trig::default(); SLOTS];
        for (t, i) in trig.iter_mut().zip(range_a.clone()) {
            *t = Trig::of(h_at(i));
        }
        // Each candidate's misfit Σ w·r² first, its χ² once the noise is known.
        let mut rss_min = f32::INFINITY;
        // The design's prior, z² per place of the two windows: the exposed fraction a
        // candidate says the frame shows, against the design.
        let inv_prior_sd = if prior { 1.0 / EXPOSED_PRIOR_SD } else { 0.0 };
        let mut prior_chi2 = [0f32; 2 * SLOTS];
        for hyp in [Hyp::HeaterHot, Hyp::SurfaceHot] {
            for (k, i) in grid.range_of(hyp).enumerate() {
                let exposed = if hyp == Hyp::HeaterHot {
                    h_at(i)
                } else {
                    1.0 - h_at(i)
                };
                let z = (exposed - design_exposed) * inv_prior_sd;
                prior_chi2[Grid::base_of(hyp) + k] = z * z;
            }
        }
        let na = range_a.len();
        for psf in 0..PSFS {
            let first = psf * 2 * SLOTS;
            for (slot, i) in range_a.clone().enumerate() {
                let [ca, cb] = sp.pair(psf, h_at(i), &trig[slot]);
                // The heater-hot candidate h, and its mirror 1 − h: the surface-hot window's
                // place na − 1 − slot.
                for (key, c) in [(first + slot, ca), (first + SLOTS + na - 1 - slot, cb)] {
                    if c.chi2 < rss_min {
                        rss_min = c.chi2;
                    }
                    grid.cand[key] = c;
                }
            }
        }
        // The noise: the best candidate's misfit per degree of freedom (the model holds the
        // stripes' harmonics to the model's band; what is left is the pixels' noise, and what
        // the model still misses), floored as the fit's.
        let sigma2 = (rss_min / sp.dof).max(NOISE_FLOOR_K * NOISE_FLOOR_K);
        let inv_sigma2 = 1.0 / sigma2;
        for row in grid.cand.chunks_exact_mut(2 * SLOTS) {
            for (c, z2) in row.iter_mut().zip(&prior_chi2) {
                c.chi2 = c.chi2 * inv_sigma2 + z2;
            }
        }
        grid.sigma2 = sigma2;
        grid
    }

    /// The place of a hypothesis's window in a spread's row of keys.
    pub(super) fn base_of(hyp: Hyp) -> usize {
        match hyp {
            Hyp::HeaterHot => 0,
            Hyp::SurfaceHot => SLOTS,
        }
    }

    /// A hypothesis's window on the h grid.
    pub(super) fn range_of(&self, hyp: Hyp) -> core::ops::Range<usize> {
        match hyp {
            Hyp::HeaterHot => self.range_a.clone(),
            Hyp::SurfaceHot => self.range_b.clone(),
        }
    }

    /// A key's hypothesis.
    pub(super) fn hyp_of(key: usize) -> Hyp {
        if key % (2 * SLOTS) < SLOTS {
            Hyp::HeaterHot
        } else {
            Hyp::SurfaceHot
        }
    }

    /// The best candidate (its key) of a hypothesis at the spreads `psfs`.
    pub(super) fn best_in(&self, hyp: Hyp, psfs: core::ops::Range<usize>) -> Option<usize> {
        let mut best: Option<usize> = None;
        let (base, nh) = (Grid::base_of(hyp), self.range_of(hyp).len());
        for psf in psfs {
            let first = psf * 2 * SLOTS + base;
            for j in first..first + nh {
                if best.is_none_or(|b| self.cand[j].chi2 < self.cand[b].chi2) {
                    best = Some(j);
                }
            }
        }
        best
    }
}
