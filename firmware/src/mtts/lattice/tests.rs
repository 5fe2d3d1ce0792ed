//! Unit tests of the lattice fit's steps.

use super::*;

/// A base model's products' length, rounded up to an even count: the shorter loops the
/// candidates once used for it must agree with the full ones.
const BASE_PAIRS: usize = BASE_HARMONICS + BASE_HARMONICS % 2;

/// The axial profile of a core showing `length_px` of a lattice of period `period_px` whose
/// hot stripes are `h` of it (10 K over 300 K) from `phase_px`, each bin's value the square
/// wave averaged over a pixel's length around it; bins ¼ px apart, as a tilted axis fills
/// them, with the counts of a tilted core: fewer pixels near its ends, where the image's
/// top and bottom clip it.
fn stripes(period_px: f32, h: f32, phase_px: f32, length_px: f32) -> Profile {
    let mut p = Profile {
        bins: [Bin::default(); FINE_BINS],
        used: 0,
        t0: 0.0,
        reference: 300.0,
        total: 0.0,
        mean_dev: 0.0,
        sq: 0.0,
        lo: 300.0,
        hi: 310.0,
    };
    let wave = |t: f32| {
        let x = (t - phase_px) / period_px;
        if x - floor(x) < h { 10.0 } else { 0.0 }
    };
    let bins = (length_px * FINE as f32) as usize;
    for b in 0..bins {
        let t = (b as f32 + 0.5) / FINE as f32;
        let y = (0..64)
            .map(|i| wave(t - 0.5 + (i as f32 + 0.5) / 64.0))
            .sum::<f32>()
            / 64.0;
        let w = (1 + b.min(bins - 1 - b) / 6).min(4) as f32;
        p.bins[b].sum = w * y;
        p.bins[b].cnt = w;
        p.bins[b].tsum = w * t;
        p.total += w;
        p.sq += w * y * y;
    }
    p.used = bins;
    p.mean_dev = p.bins.iter().map(|b| b.sum).sum::<f32>() / p.total;
    p
}

#[test]
fn the_frequency_is_refined_on_three_harmonics_not_the_fundamental_alone() {
    // Under two periods of stripes 0.15 of the period wide (a design exposed 85 %, 12–16 px
    // units over a core 24 px long), at eight phases each, where the periodogram found the
    // lattice's own peak (not its second harmonic's): a step of the fit of the fundamental
    // alone leaves the period as far off as the peak had it (measured: 1.7 and 1.8 %
    // mean); a step with three harmonics takes it within a few tenths of a percent (0.4 %).
    let (mut pgram, mut one, mut three, mut n) = (0f32, 0f32, 0f32, 0f32);
    for (period, h) in [(12.0f32, 0.15f32), (14.0, 0.85), (16.0, 0.15)] {
        for i in 0..8 {
            let p = stripes(period, h, i as f32 * period / 8.0, 24.0);
            let coarse = Coarse::of(&p);
            let (nu0, _) =
                find_frequency(&coarse, 1.0 / PERIOD_MAX_PX, 1.0 / PERIOD_MIN_PX, FREQ_STEP)
                    .expect("a lattice");
            let err = |nu: f32| (1.0 / nu / period - 1.0).abs();
            if err(nu0) > 0.06 {
                continue;
            }
            pgram += err(nu0);
            let mut angles = [(0f32, 0f32); FINE_BINS];
            one += err(nu0 + gn_step(&p, nu0, 1, &mut angles).unwrap_or(0.0));
            three += err(nu0 + gn_step(&p, nu0, 3, &mut angles).unwrap_or(0.0));
            n += 1.0;
        }
    }
    let (pgram, one, three) = (pgram / n, one / n, three / n);
    assert!(
        n >= 16.0 && one > 0.012 && three < 0.006,
        "{n} profiles, mean relative error of the period: periodogram {pgram:.4}, \
         fundamental {one:.4}, three harmonics {three:.4}"
    );
}

/// A tilted column (several places per ¼ px bin) and its coordinates, with a lattice
/// frequency, cycles per pixel, for smooth test profiles.
fn tilted_core() -> (Geometry, Coords, f32) {
    let g = Geometry {
        axis_col0: 15.3,
        axis_slope: 0.23,
        half_width_px: 9.0,
        ..Geometry::DEFAULT
    };
    let xy = g.coords_all();
    (g, xy, 1.0 / 6.1)
}

#[test]
fn the_bins_slopes_make_the_gram_matrix_the_pixels_own() {
    // A tilted core (several places per ¼ px bin) of a smooth profile: the candidates'
    // Gram matrix and right-hand side with the bins' slopes against the products of the
    // basis linearised about each bin's mean place, summed pixel by pixel in f64 —
    // x_k = cos(k(θ̄ − ψ)) − δ·2πν·k·sin(k(θ̄ − ψ)), δ the pixel's offset from the mean.
    // Without the slopes, the bins' means alone, the entries of the higher harmonics miss
    // by far more than the tolerance.
    let (g, xy, nu) = tilted_core();
    let img: [f32; IMG_PIXELS] = core::array::from_fn(|p| {
        let th = core::f32::consts::TAU * nu * xy.t[p];
        320.0
            + 3.0 * libm::cosf(th + 0.4)
            + 1.2 * libm::cosf(2.0 * th - 0.3)
            + 0.5 * libm::sinf(3.0 * th)
    });
    let u_core = lattice_core_u(g.half_width_px);
    let p = Profile::of(&img, &xy, &g, u_core, f32::INFINITY, &[0; IMG_ROWS]).expect("a core");
    let model = 5;
    let fit = harmonic_fit(&p, nu, 3, model).expect("a fit");
    let psi = sin_cos_turns(0.137);
    let (mut m, mut ur) = ([[0f32; U]; U], [0f32; U]);
    gram(&fit, model, nu, (psi.1, psi.0), &mut m, &mut ur);
    let (mut want, mut want_r) = ([[0f64; U]; U], [0f64; U]);
    let (mut bins_only, mut spread) = ([[0f64; U]; U], 0f64);
    let w = core::f64::consts::TAU * nu as f64;
    for q in 0..IMG_PIXELS {
        if xy.u[q] >= u_core {
            continue;
        }
        let b = (fine_place(xy.t[q], p.t0) as usize).min(FINE_BINS - 1);
        let mean_t = (p.bins[b].tsum / p.bins[b].cnt) as f64;
        let delta = xy.t[q] as f64 - mean_t;
        spread += delta * delta;
        let phase = w * mean_t - core::f64::consts::TAU * 0.137;
        let x: [f64; U] = core::array::from_fn(|k| {
            let k = k as f64;
            (k * phase).cos() - delta * w * k * (k * phase).sin()
        });
        let x0: [f64; U] = core::array::from_fn(|k| (k as f64 * phase).cos());
        let y = (img[q] - p.reference) as f64;
        for i in 0..=model {
            for j in 0..=model {
                want[i][j] += x[i] * x[j];
                bins_only[i][j] += x0[i] * x0[j];
            }
            want_r[i] += y * x[i];
        }
    }
    // The core's pixels do spread within their bins (else the test shows nothing).
    assert!(spread > 0.1, "{spread}");
    let scale: f64 = (0..p.used).map(|b| p.bins[b].sum.abs() as f64).sum();
    let mut missed = 0f64;
    for i in 0..=model {
        for j in 0..=model {
            assert!(
                (m[i][j] as f64 - want[i][j]).abs() < 1e-4 * want[0][0],
                "m[{i}][{j}] {} against {}",
                m[i][j],
                want[i][j]
            );
            missed = missed.max((bins_only[i][j] - want[i][j]).abs());
        }
        assert!(
            (ur[i] as f64 - want_r[i]).abs() < 1e-4 * scale,
            "ur[{i}] {} against {}",
            ur[i],
            want_r[i]
        );
    }
    assert!(missed > 1e-2 * want[0][0], "{missed}");
}

/// The tilted core's image of a smooth lattice (a fundamental of 3 K about 320 K), its
/// core's distance ratio and the bad-pixel threshold of a frame 6 K in range: what the
/// bad-pixel tests spoil.
fn smooth_core() -> (Geometry, Coords, [f32; IMG_PIXELS], f32, f32) {
    let (g, xy, nu) = tilted_core();
    let clean: [f32; IMG_PIXELS] = core::array::from_fn(|p| {
        320.0 + 3.0 * libm::cosf(core::f32::consts::TAU * nu * xy.t[p] + 0.4)
    });
    let u_core = lattice_core_u(g.half_width_px);
    let bad_k = max(BAD_RANGE_FRACTION * 6.0, LONE_PIXEL_K);
    (g, xy, clean, u_core, bad_k)
}

#[test]
fn a_few_pixels_beyond_both_their_row_neighbours_are_left_out_of_the_profile() {
    // Hot or dead pixels of one value (so the lone-pixel rule, which drops only an extreme
    // beyond every other, keeps all but a single one) on a smooth tilted core: up to
    // ODD_MAX of them the row rule leaves exactly those out and the rest of the profile as
    // the clean image has it; one more, and they are taken for the lattice's own and kept.
    let (g, xy, clean, u_core, bad_k) = smooth_core();
    let base = Profile::of(&clean, &xy, &g, u_core, bad_k, &[0; IMG_ROWS]).expect("a core");
    let all = Profile::of(&clean, &xy, &g, u_core, f32::INFINITY, &[0; IMG_ROWS]).expect("a core");
    // A smooth core loses nothing to the rule.
    assert_eq!(base.total, all.total);
    for (n, dead) in [
        (1, false),
        (ODD_MAX, false),
        (ODD_MAX, true),
        (ODD_MAX + 1, false),
    ] {
        let mut img = clean;
        let mut at = [usize::MAX; ODD_MAX + 1];
        for (k, a) in at.iter_mut().enumerate().take(n) {
            let r = 3 + 4 * k;
            let dc = if k % 2 == 0 { 3 } else { -4 };
            let c = (g.axis_col0 + g.axis_slope * r as f32) as i32 + dc;
            let q = r * IMG_COLS + c as usize;
            assert!(xy.u[q] < u_core, "pixel {q} in the core");
            img[q] = if dead { 310.0 } else { 330.0 };
            *a = (fine_place(xy.t[q], base.t0) as usize).min(FINE_BINS - 1);
        }
        // Without the row rule they stay, but for one alone, the lone pixel's.
        let kept =
            Profile::of(&img, &xy, &g, u_core, f32::INFINITY, &[0; IMG_ROWS]).expect("a core");
        let lone = if n == 1 { 1.0 } else { 0.0 };
        assert_eq!(kept.total, base.total - lone, "{n} without the rule");
        let p = Profile::of(&img, &xy, &g, u_core, bad_k, &[0; IMG_ROWS]).expect("a core");
        if n > ODD_MAX {
            assert_eq!(p.total, base.total, "{n} are the lattice's");
            continue;
        }
        // Each left out once, whichever rules take it.
        assert_eq!(p.total, base.total - n as f32);
        for b in 0..FINE_BINS {
            let left_out = at.iter().filter(|&&a| a == b).count() as f32;
            assert_eq!(p.bins[b].cnt, base.bins[b].cnt - left_out, "bin {b}");
            if left_out == 0.0 {
                assert_eq!(p.bins[b].sum, base.bins[b].sum, "bin {b}");
            }
        }
    }
}

#[test]
fn pixels_filled_in_are_left_out_of_the_profile_once() {
    // Broken pixels the pipeline filled in from their neighbours, on a smooth tilted core:
    // each is left out, whatever value it was filled with — one beyond its row neighbours
    // (which the row rule takes too: left out once, not twice), the core's hottest (the
    // lone-pixel rule's) — and the rest of the profile is the clean image's. A filled
    // pixel off the core changes nothing.
    let (g, xy, clean, u_core, bad_k) = smooth_core();
    let none = [0u32; IMG_ROWS];
    let base = Profile::of(&clean, &xy, &g, u_core, bad_k, &none).expect("a core");
    let at = |r: usize, dc: i32| {
        let c = (g.axis_col0 + g.axis_slope * r as f32) as i32 + dc;
        r * IMG_COLS + c as usize
    };
    // In the core: near its mid-line, near its side, beyond its row neighbours, its hottest.
    let inside = [at(4, 0), at(9, 4), at(14, -3), at(19, 1)];
    let outside = at(11, 10);
    assert!(xy.u[outside] >= u_core, "pixel {outside} off the core");
    let mut img = clean;
    let mut filled = [0u32; IMG_ROWS];
    for (k, &q) in inside.iter().chain([&outside]).enumerate() {
        assert!(q == outside || xy.u[q] < u_core, "pixel {q} in the core");
        filled[q / IMG_COLS] |= 1 << (q % IMG_COLS);
        img[q] = [321.0, 318.5, 335.0, 360.0, 400.0][k];
    }
    let p = Profile::of(&img, &xy, &g, u_core, bad_k, &filled).expect("a core");
    assert_eq!(p.total, base.total - inside.len() as f32);
    // Per bin, the clean pixels left out: how many, and their values less the reference.
    let mut out = [(0f32, 0f32); FINE_BINS];
    for &q in &inside {
        let b = (fine_place(xy.t[q], base.t0) as usize).min(FINE_BINS - 1);
        out[b].0 += 1.0;
        out[b].1 += clean[q] - base.reference;
    }
    assert_eq!(p.reference, base.reference);
    for (b, &(n, y)) in out.iter().enumerate() {
        assert_eq!(p.bins[b].cnt, base.bins[b].cnt - n, "bin {b}");
        let want = base.bins[b].sum - y;
        assert!(
            (p.bins[b].sum - want).abs() < 1e-3,
            "bin {b}: {} against {want}",
            p.bins[b].sum
        );
    }
    // The core's range is no longer the filled hottest's (it may keep the next one left
    // out: the fallback's bound, which it widens).
    assert!(p.hi < 360.0, "the core's hottest {}", p.hi);
    // Not marked, the same values stay (but for the row rule's and the lone one's).
    let kept = Profile::of(&img, &xy, &g, u_core, bad_k, &none).expect("a core");
    assert_eq!(kept.total, base.total - 2.0);
}

#[test]
fn the_gram_matrix_from_the_turned_sums_is_the_basis_products() {
    // The candidates' Gram matrix by the Toeplitz-plus-Hankel sums against uᵀ·N·u and
    // uᵀ·rhs summed bin by bin, with N and rhs of the basis (1, cos kθ, sin kθ) to the
    // model's harmonics: a thin stripe's profile, a tilted core's bins.
    let p = stripes(5.2, 0.29, 1.3, 30.0);
    let nu = 1.0 / 5.2;
    let model = HARMONICS;
    let fit = harmonic_fit(&p, nu, 3, model).expect("a fit");
    let psi = sin_cos_turns(0.137);
    let (mut m, mut ur) = ([[0f32; U]; U], [0f32; U]);
    gram(&fit, model, nu, (psi.1, psi.0), &mut m, &mut ur);
    // Per bin, the model's basis at the bin: u_k·x = cos(k(θ − ψ)).
    let mut want = [[0f64; U]; U];
    let mut want_r = [0f64; U];
    for b in 0..p.used {
        let w = p.bins[b].cnt as f64;
        if w == 0.0 {
            continue;
        }
        let t = (p.bins[b].tsum / p.bins[b].cnt) as f64;
        let y = (p.bins[b].sum / p.bins[b].cnt) as f64;
        let phase = core::f64::consts::TAU * (nu as f64 * t - 0.137);
        let x: [f64; U] = core::array::from_fn(|k| (k as f64 * phase).cos());
        for i in 0..U {
            for j in 0..U {
                want[i][j] += w * x[i] * x[j];
            }
            want_r[i] += w * y * x[i];
        }
    }
    for i in 0..U {
        for j in 0..U {
            // Σ w bounds every entry of uᵀ·N·u.
            assert!(
                (m[i][j] as f64 - want[i][j]).abs() < 2e-4 * want[0][0],
                "m[{i}][{j}] {} against {}",
                m[i][j],
                want[i][j]
            );
        }
        // Σ w·|y| bounds every entry of uᵀ·rhs.
        let scale: f64 = (0..p.used).map(|b| p.bins[b].sum.abs() as f64).sum();
        assert!(
            (ur[i] as f64 - want_r[i]).abs() < 2e-4 * scale,
            "ur[{i}] {} against {}",
            ur[i],
            want_r[i]
        );
    }
}

#[test]
fn thin_stripes_take_a_sixth_harmonic_and_a_tenth_in_the_model() {
    // The thesis's block (71 % exposed: surface stripes 0.29 of the period) keeps five,
    // fitted and modelled; stripes under a quarter of the period, hot or cold, take six in
    // the fit and ten in the candidates' model.
    for design in [0.71, 0.5, 0.74, 0.26] {
        assert_eq!(harmonics_for(design), BASE_HARMONICS, "{design}");
        assert_eq!(model_for(design), BASE_HARMONICS, "{design}");
    }
    for design in [0.76, 0.24, 0.15, EXPOSED_MAX] {
        assert_eq!(harmonics_for(design), FIT_HARMONICS, "{design}");
        assert_eq!(model_for(design), HARMONICS, "{design}");
    }
    assert_eq!((FIT_HARMONICS, HARMONICS), (6, 10));
}

/// The quadratic form the candidates' products stand for: c = (h, τ_k·sin πkh), τ_k =
/// 2·H_k/(πk), k = 1…model; (g01, g11, rv) = ((m·c)₀, cᵀ·m·c, c·ur), in f64.
fn direct(
    m: &[[f32; U]; U],
    ur: &[f32; U],
    mtf: &[f32; HARMONICS],
    model: usize,
    h: f32,
) -> (f64, f64, f64) {
    let mut c = [0f64; U];
    c[0] = h as f64;
    for k in 1..=model {
        c[k] = 2.0 * mtf[k - 1] as f64 / (core::f64::consts::PI * k as f64)
            * (core::f64::consts::PI * k as f64 * h as f64).sin();
    }
    let (mut g01, mut g11, mut rv) = (0f64, 0f64, 0f64);
    for i in 0..U {
        rv += c[i] * ur[i] as f64;
        g01 += m[0][i] as f64 * c[i];
        for j in 0..U {
            g11 += c[i] * m[i][j] as f64 * c[j];
        }
    }
    (g01, g11, rv)
}

#[test]
fn the_surface_hot_window_is_the_heater_hot_one_s_mirror() {
    // The grid is symmetric about ½ (h_at(i) + h_at(H_COUNT − 1 − i) = 1), so the
    // surface-hot window, taken as the mirror of the heater-hot one, is the grid's points
    // within [1 − hi, 1 − lo] for every design the configuration accepts (15–90 %), and every
    // exposed fraction the frames may adopt: the candidates' mirror products are its own.
    for i in 0..H_COUNT {
        assert!((h_at(i) + h_at(H_COUNT - 1 - i) - 1.0).abs() < 1e-6);
    }
    for pct in 15..=90 {
        let (lo, hi) = window(pct as f32 / 100.0);
        let b = h_range(Hyp::SurfaceHot, (lo, hi));
        let inside: std::vec::Vec<usize> = (0..H_COUNT)
            .filter(|&i| (1.0 - hi..=1.0 - lo).contains(&h_at(i)))
            .collect();
        assert_eq!(b.clone().collect::<std::vec::Vec<_>>(), inside, "{pct} %");
        assert!(!b.is_empty() && b.len() <= SLOTS, "{pct} %");
    }
}

#[test]
fn the_candidates_trigonometric_sums_are_their_quadratic_form_and_their_mirror_s() {
    // A symmetric positive Gram matrix of the full model, its right-hand side and a
    // spread's transfers: for every model length and h of the grid, the sums per spread
    // and the parity split give the heater-hot candidate h and its mirror 1 − h.
    let m: [[f32; U]; U] = core::array::from_fn(|i| {
        core::array::from_fn(|j| {
            let d = i.abs_diff(j) as f32;
            (if i == j { 2.0 } else { 0.0 }) + 1.0 / (1.0 + d * d) + 0.1 / (1.0 + (i + j) as f32)
        })
    });
    let ur: [f32; U] = core::array::from_fn(|i| 0.3 - 0.07 * i as f32);
    let mtf: [f32; HARMONICS] = core::array::from_fn(|k| 0.97f32.powi((k * k) as i32 / 4));
    for model in 1..=HARMONICS {
        let spread = if model <= BASE_PAIRS {
            Spread::of::<BASE_PAIRS>(&m, &ur, &mtf, model)
        } else {
            Spread::of::<HARMONICS>(&m, &ur, &mtf, model)
        };
        for i in 0..H_COUNT {
            let h = h_at(i);
            let got = if model <= BASE_PAIRS {
                spread.products::<BASE_PAIRS>(h, &Trig::of(h))
            } else {
                spread.products::<HARMONICS>(h, &Trig::of(h))
            };
            for ((g01, g11, rv), h) in got.into_iter().zip([h, 1.0 - h]) {
                let want = direct(&m, &ur, &mtf, model, h);
                for (x, w) in [(g01, want.0), (g11, want.1), (rv, want.2)] {
                    assert!(
                        (x as f64 - w).abs() < 2e-5 * (1.0 + w.abs()),
                        "model {model} h {h}: {x} against {w}"
                    );
                }
            }
        }
    }
}

#[test]
fn cholesky_solves() {
    let mut a = [[0f32; NP]; NP];
    let mut b = [0f32; NP];
    b[..3].copy_from_slice(&[1.0, 2.0, 3.0]);
    a[0][..3].copy_from_slice(&[4.0, 1.0, 0.5]);
    a[1][..3].copy_from_slice(&[1.0, 3.0, 0.2]);
    a[2][..3].copy_from_slice(&[0.5, 0.2, 2.0]);
    let x = solve(&a, &b, 3).unwrap();
    for i in 0..3 {
        let r: f32 = (0..3).map(|j| a[i][j] * x[j]).sum();
        assert!((r - b[i]).abs() < 1e-5);
    }
    let mut singular = a;
    singular[2] = singular[1];
    for r in singular.iter_mut() {
        r[2] = r[1];
    }
    assert!(solve(&singular, &b, 3).is_none());
}

#[test]
fn midpoint_is_exact_for_cubics_inside_and_quadratics_at_the_ends() {
    let cubic = |x: f32| 2.0 - 0.5 * x + 0.25 * x * x - 0.03 * x * x * x;
    let quad = |x: f32| 1.0 + 0.7 * x - 0.2 * x * x;
    for n in [3, 4, 5, 6] {
        for i in 0..n - 1 {
            let want = if i >= 1 && i + 2 < n {
                cubic(i as f32 + 0.5)
            } else {
                quad(i as f32 + 0.5)
            };
            let got = if i >= 1 && i + 2 < n {
                midpoint(|k| cubic(k as f32), i, n)
            } else {
                midpoint(|k| quad(k as f32), i, n)
            };
            assert!(
                (got - want).abs() < 1e-5,
                "n {n} i {i}: {got} against {want}"
            );
        }
    }
    assert_eq!(midpoint(|k| [1.0, 3.0][k], 0, 2), 2.0);
}

/// Candidates on the (spread, h) grid from `chi2(psf, k)`, with a = psf and b = k (so the
/// posterior means of a and b are those of the spread's and h's places).
fn grid(nh: usize, chi2: impl Fn(usize, usize) -> f32) -> [[Candidate; SLOTS]; PSFS] {
    core::array::from_fn(|psf| {
        core::array::from_fn(|k| Candidate {
            a: psf as f32,
            b: k as f32,
            var: 0.0,
            chi2: if k < nh { chi2(psf, k) } else { f32::NAN },
        })
    })
}

#[test]
fn a_flat_valley_s_posterior_is_its_middle_not_its_noisy_minimum() {
    // χ² equal along the diagonal valley psf = k (a thin stripe's width against the
    // spread), one point a little lower at its end (the noise): the best point is that
    // end, the posterior mean the valley's middle.
    let nh = 5;
    let g = grid(nh, |psf, k| {
        let off = psf as f32 - k as f32;
        let end = if psf == 4 && k == 4 { -1.0 } else { 0.0 };
        3.0 + 4.0 * off * off + end
    });
    let p = posterior(|psf| &g[psf][..], nh, 1.0);
    // The valley runs over spreads 0–4 (5 and 6 lie off it): its middle is 2, and the
    // lower end pulls a little.
    assert!((p.a - 2.0).abs() < 0.6 && p.a > 2.0, "spread place {}", p.a);
    assert!((p.b - p.a).abs() < 0.3, "h place {} against {}", p.b, p.a);
    assert!(
        (p.h_steps - p.b).abs() < 1e-3 * nh as f32,
        "{} {}",
        p.h_steps,
        p.b
    );
}

#[test]
fn a_sharp_row_s_posterior_is_its_parabola_s_vertex() {
    // Every spread but one far off; that one's χ² a steep parabola in h with its vertex
    // 0.3 steps past place 2: the mean is the vertex, between the candidates.
    let nh = 5;
    // Spread 3's row a parabola of curvature `c` in h, every other row far off.
    let of_row = |c: f32| {
        let g = grid(nh, |psf, k| {
            let x = k as f32 - 2.3;
            if psf == 3 { 1.0 + c * x * x } else { 500.0 }
        });
        posterior(|psf| &g[psf][..], nh, 1.0)
    };
    let p = of_row(40.0);
    assert!((p.h_steps - 2.3).abs() < 1e-3, "h {}", p.h_steps);
    assert!((p.b - 2.3).abs() < 1e-3, "b {}", p.b);
    assert!((p.a - 3.0).abs() < 1e-3, "a {}", p.a);
    // The same row, gentle (no vertex): the half steps' weighted mean lies near it too.
    let p = of_row(2.0);
    assert!((p.h_steps - 2.3).abs() < 0.1, "h {}", p.h_steps);
}

#[test]
fn the_stepped_transfers_are_the_transfer_function() {
    // The table the candidates use, built by angle-sum and product steps, against
    // `transfer` evaluated at each harmonic and spread: upright and tilted axes, short and
    // long periods.
    for (nu, slope) in [(0.2f32, 0.0f32), (0.19, 0.36), (0.125, -0.7), (0.07, 0.2)] {
        let mut mtf = [[0f32; HARMONICS]; PSFS];
        transfers(nu, slope, HARMONICS, &mut mtf);
        for (i, row) in mtf.iter().enumerate() {
            for (k, &x) in row.iter().enumerate() {
                let want = transfer((k + 1) as f32 * nu, slope, PSF_SIGMAS_PX[i]);
                assert!(
                    (x - want).abs() < 2e-5,
                    "nu {nu} slope {slope} spread {i} harmonic {}: {x} against {want}",
                    k + 1
                );
            }
        }
    }
}

#[test]
fn transfer_is_one_at_zero_and_falls() {
    let sigma = 0.35;
    assert!((transfer(0.0, 0.3, sigma) - 1.0).abs() < 1e-6);
    assert!(transfer(0.25, 0.0, sigma) < transfer(0.1, 0.0, sigma));
    // A box of one pixel: sinc(0.5) · Gaussian.
    let want = (2.0 / core::f32::consts::PI)
        * libm::expf(-2.0 * (core::f32::consts::PI * sigma * 0.5).powi(2));
    assert!((transfer(0.5, 0.0, sigma) - want).abs() < 1e-5);
}
