//! MTTS on the scene family (unseen seeds): never a swap under the mode's prior, never NaN, a
//! merged or fallback frame says so, resolved frames are accurate and within their bound; a
//! wrong prior never overrides what the image shows, and where the image cannot decide its
//! pick stays within the frame's bound; the thesis's own lattice resolves. The harness of
//! lattices unlike their design (issue 43): the members are what they claim, and the settled
//! evaluation is the first frame's when it has one frame and follows its frames in order.

use host_sim::imaging::mtts_wp::{
    CellStats, FamilyOutcome, PriorCase, family_outcomes, members_outcomes,
    members_outcomes_lagging_prior,
};
use host_sim::imaging::view_family::{UNSEEN, thesis};
use thermorph::mtts::Quality;
use thermorph::mtts::lattice::{CONFIRM_FRAMES, EXPOSED_TOLERANCE};

/// Members per run: the fast default; `THERMORPH_FAMILY_MEMBERS` for a long run.
fn members() -> u64 {
    std::env::var("THERMORPH_FAMILY_MEMBERS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(300)
}

/// Mean |error| of T1 and T2 over `v`, K.
fn mean_err(v: &[&FamilyOutcome]) -> f64 {
    v.iter().map(|o| o.err_k[0] + o.err_k[1]).sum::<f64>() / (2.0 * v.len() as f64)
}

/// Heater and surface stripes of (nearly) equal width: the image cannot tell them apart.
fn equal_width(o: &FamilyOutcome) -> bool {
    (o.exposed - 0.5).abs() < f64::from(EXPOSED_TOLERANCE) + 0.05
}

#[test]
fn unseen_members_never_swap_and_resolved_ones_are_accurate_and_bounded() {
    let outs = family_outcomes(UNSEEN, members(), PriorCase::Right);
    // None in the fast run; at most one in 500 in a long one (measured: 2 of 2000, both
    // lattices showing about 1.5 periods).
    let swaps = outs.iter().filter(|o| o.swapped).count();
    assert!(swaps * 500 <= outs.len(), "{swaps} swaps in {}", outs.len());
    for o in &outs {
        assert!(o.err_k.iter().all(|e| e.is_finite()), "{o:?}");
        assert!(o.bound_k.is_finite() && o.bound_k >= 0.0);
    }
    let st = CellStats::of(outs.iter().filter(|o| o.gap_k.abs() >= 3.0));
    assert!(st.coverage >= 0.95, "bound coverage {:.3}", st.coverage);
    // Where heater and surface stripes are equally wide the image cannot tell them apart and
    // the frame is merged, whatever the prior (`a_wrong_prior_never_overrides_the_image`).
    let st = CellStats::of(
        outs.iter()
            .filter(|o| o.gap_k.abs() >= 3.0 && !equal_width(o)),
    );
    assert!(st.resolved >= 0.8, "resolved {:.2}", st.resolved);
    // Resolved frames, stripes at least 1.5 px wide: mean error within 0.3 K.
    let sel: Vec<_> = outs
        .iter()
        .filter(|o| o.quality == Quality::Resolved && o.gap_k.abs() >= 3.0)
        .filter(|o| o.period_px * o.exposed.min(1.0 - o.exposed) >= 1.5)
        .collect();
    assert!(sel.len() >= 100, "{} resolved frames", sel.len());
    let mean = mean_err(&sel);
    assert!(mean <= 0.3, "mean error {mean:.2} K");
    // Every frame, resolved or not, with stripes at least 1.5 px: an ambiguous frame gives the
    // fit's T1 and T2 (not the mean), so the mean error holds over all of them, and the
    // ambiguous ones' values lie within their bounds.
    let thick: Vec<_> = outs
        .iter()
        .filter(|o| o.gap_k.abs() >= 3.0)
        .filter(|o| o.period_px * o.exposed.min(1.0 - o.exposed) >= 1.5)
        .collect();
    let mean = mean_err(&thick);
    assert!(mean <= 0.3, "mean error over every frame {mean:.2} K");
    // Every frame with |gap| ≥ 3 K, thin stripes too: the posterior mean over the exposed
    // fraction and the spread, not the grid's best point, where a thin stripe's level trades
    // against its width (measured, mean of |T1| and |T2|: 0.171 K with the best point, 0.133 K
    // with the posterior on these 300; 0.124 K on 1000).
    let every: Vec<_> = outs.iter().filter(|o| o.gap_k.abs() >= 3.0).collect();
    let mean = mean_err(&every);
    assert!(
        mean <= 0.15,
        "mean error over every frame, thin stripes too: {mean:.3} K"
    );
    // A merged frame's value lies within its bound of the true area-weighted mean (with a prior
    // every frame is decided: merged frames are the blind ones, no prior and no earlier frame).
    let blind = family_outcomes(UNSEEN, members(), PriorCase::None);
    for (set, quality, share) in [
        (&outs, Quality::Ambiguous, 0.9),
        (&blind, Quality::Merged, 0.95),
    ] {
        let these: Vec<_> = set.iter().filter(|o| o.quality == quality).collect();
        let within = these.iter().filter(|o| o.covered()).count();
        println!(
            "{quality:?}: {within} of {} within their bound",
            these.len()
        );
        assert!(
            !these.is_empty() && within as f64 >= share * these.len() as f64,
            "{within} of {} {quality:?} frames within their bound",
            these.len()
        );
    }
}

#[test]
fn a_wrong_prior_never_overrides_the_image() {
    let right = family_outcomes(UNSEEN, members(), PriorCase::Right);
    let wrong = family_outcomes(UNSEEN, members(), PriorCase::Wrong);
    // Where heater and surface stripes differ in width, the image decides: no swap, and the
    // wrong prior is no more often confidently wrong than the right one.
    let decidable = |o: &&FamilyOutcome| !equal_width(o) && o.gap_k.abs() >= 3.0;
    let n = wrong.iter().filter(decidable).count();
    let swaps: Vec<_> = wrong
        .iter()
        .filter(decidable)
        .filter(|o| o.swapped)
        .collect();
    assert!(
        swaps.len() * 100 <= n,
        "swapped by a wrong prior: {swaps:?}"
    );
    let cw = |v: &[FamilyOutcome]| {
        v.iter()
            .filter(decidable)
            .filter(|o| o.confidently_wrong())
            .count()
    };
    assert!(
        cw(&wrong) <= cw(&right) + 2 + n / 100,
        "{} vs {}",
        cw(&wrong),
        cw(&right)
    );
    // Where it cannot decide (stripes of equal width), a wrong prior's pick is within the
    // frame's bound: the bound spans both hypotheses, so such a frame is merged unless the
    // gap is small; a resolved frame's error stays within its bound.
    let all = CellStats::of(wrong.iter().filter(|o| o.gap_k.abs() >= 3.0));
    assert!(
        all.coverage >= 0.95,
        "wrong prior: bound coverage {:.3}",
        all.coverage
    );
    let equal: Vec<_> = wrong
        .iter()
        .filter(|o| equal_width(o) && o.gap_k.abs() >= 3.0)
        .collect();
    let bad = equal.iter().filter(|o| o.confidently_wrong()).count();
    assert!(
        bad * 20 <= equal.len(),
        "{bad} of {} equal-width frames resolved beyond their bound",
        equal.len()
    );
    // The right prior's assignment there keeps its accuracy (stripes ≥ 1.5 px).
    let kept: Vec<_> = right
        .iter()
        .filter(|o| equal_width(o) && o.gap_k.abs() >= 3.0)
        .filter(|o| o.period_px * o.exposed.min(1.0 - o.exposed) >= 1.5)
        .collect();
    let mean = mean_err(&kept);
    assert!(
        kept.len() >= 20 && mean <= 0.3,
        "{} frames, mean error {mean:.2} K",
        kept.len()
    );
}

#[test]
fn thin_stripes_of_a_few_pixels_hold_their_level() {
    // Unseen members exposed 0.75–0.85 (surface stripes under a quarter of the period) with
    // periods of 6–16 px and |gap| ≥ 3 K: the thin stripe's target, T2, over every frame. The
    // candidates' model of a thin-stripe design reaches the tenth harmonic within 1.5 cycles
    // per pixel (`lattice::model_for`, `MODEL_BAND_CPP`): on the first 1000 members (98 such
    // frames) their mean is 0.211 K; with the model of seven within 1.25 it was 0.231 K, with
    // six 0.269 K. Pinned to those 1000 members whatever THERMORPH_FAMILY_MEMBERS says: on the
    // first 300 (27 frames) such models are within their scatter (six and seven: 0.283 and
    // 0.272 K), and on 2000 (211 frames) the mean is 0.229 K, a bound that no longer tells the
    // models apart.
    let outs = family_outcomes(UNSEEN, 1000, PriorCase::Right);
    let thin: Vec<f64> = outs
        .iter()
        .filter(|o| (0.75..0.85).contains(&o.exposed) && o.period_px >= 6.0)
        .filter(|o| o.gap_k.abs() >= 3.0)
        .map(|o| o.err_k[1])
        .collect();
    let mean = thin.iter().sum::<f64>() / thin.len() as f64;
    assert!(
        thin.len() >= 90 && mean <= 0.22,
        "{} frames, mean |T2| {mean:.4} K",
        thin.len()
    );
}

#[test]
fn the_thesis_lattice_resolves_within_its_bound() {
    let n = members().min(400);
    let thesis_members = || (UNSEEN.start..UNSEEN.start + n).map(thesis);
    // The mode's prior, first frames; a prior that lags the block once heating frames have
    // confirmed the design (forming's first seconds).
    let right = members_outcomes(thesis_members(), PriorCase::Right);
    let lagging = members_outcomes_lagging_prior(thesis_members(), CONFIRM_FRAMES.into());
    for (what, outs) in [("right", &right), ("lagging", &lagging)] {
        let st = CellStats::of(outs.iter().filter(|o| o.gap_k.abs() >= 3.0));
        assert!(st.resolved >= 0.85, "{what}: resolved {:.2}", st.resolved);
        assert_eq!(st.swapped, 0.0, "{what}");
        assert!(st.coverage >= 0.95, "{what}: coverage {:.3}", st.coverage);
        assert!(st.t1_k.0 <= 0.3, "{what}: T1 {:?}", st.t1_k);
        assert!(st.t2_k.0 <= 1.0, "{what}: T2 {:?}", st.t2_k);
    }
    // The wrong prior on a fresh pipeline: the image's values, but never resolved against the
    // prior (a lattice unlike its design under the right prior shows the same image), the
    // bound spanning both answers.
    let fresh = members_outcomes(thesis_members(), PriorCase::Wrong);
    let st = CellStats::of(fresh.iter().filter(|o| o.gap_k.abs() >= 3.0));
    assert_eq!(st.resolved, 0.0, "fresh, wrong prior");
    assert!(
        st.t1_k.0 <= 0.3 && st.t2_k.0 <= 1.0,
        "{:?} {:?}",
        st.t1_k,
        st.t2_k
    );
    assert!(
        fresh.iter().all(|o| o.covered()),
        "the bound spans both answers"
    );
}

/// Lattices unlike their design (issue 43), the product's default design configured, the
/// mode's prior. A first frame cannot tell such a lattice from its design under a lagging
/// prior: never resolved, never swapped. A block watched for a few seconds: the frames'
/// readings replace the design ([`thermorph::mtts::lattice::Exposure`]), and the exposures
/// 0.2–0.5 resolve without a swap, accurately.
#[test]
fn a_lattice_unlike_its_design_is_never_swapped_and_settles() {
    use host_sim::imaging::mtts_wp::{SETTLED_FRAMES, members_first_and_settled};
    use host_sim::imaging::view_family::unlike_design;
    let n = members().min(400);
    let outs = members_first_and_settled(
        (UNSEEN.start..UNSEEN.start + n).map(unlike_design),
        PriorCase::Right,
        SETTLED_FRAMES,
    );
    for (first, _) in &outs {
        assert!(!first.swapped, "{first:?}");
        if (0.2..0.5).contains(&first.exposed) {
            assert_ne!(first.quality, Quality::Resolved, "{first:?}");
        }
    }
    let settled: Vec<&FamilyOutcome> = outs
        .iter()
        .map(|(_, s)| s)
        .filter(|s| (0.2..0.5).contains(&s.exposed))
        .collect();
    assert!(settled.iter().all(|s| !s.swapped));
    let resolved: Vec<&FamilyOutcome> = settled
        .iter()
        .copied()
        .filter(|s| s.quality == Quality::Resolved)
        .collect();
    let share = resolved.len() as f64 / settled.len() as f64;
    let mean = mean_err(&resolved);
    println!(
        "exposed 0.2–0.5, settled: {} members, resolved {:.0} %, mean error {mean:.2} K",
        settled.len(),
        100.0 * share
    );
    let wrong: Vec<&&FamilyOutcome> = resolved.iter().filter(|s| s.confidently_wrong()).collect();
    assert!(
        share >= 0.7 && mean <= 0.5 && wrong.is_empty(),
        "resolved {share:.2}, mean error {mean:.2} K, outside their bound: {wrong:?}"
    );
}

/// Issue 43: what the frames of a lattice unlike its design say about its exposure. The first
/// frame names the fraction the image shows; within [`ADOPT_FRAMES`] frames the pipeline adopts
/// it once (the supervisor's warning), near the truth; the frames after fit with it.
#[test]
fn a_lattice_unlike_its_design_is_named_and_its_exposure_adopted() {
    use host_sim::imaging::view_family::unlike_design;
    use thermorph::mtts::lattice::ADOPT_FRAMES;
    let mut scratch = Box::new(thermorph::mtts::Scratch::new());
    let mut checked = 0;
    for m in (UNSEEN.start..UNSEEN.start + 60)
        .map(unlike_design)
        .filter(|m| {
            m.geometry.exposed < 0.5 && m.geometry.period_px >= 6.0 && m.gap_k().abs() >= 3.0
        })
    {
        let truth_pct = 100.0 * m.geometry.exposed as f32;
        let mut mtts = mtts_for(&m);
        let view = m.frames();
        let outs: Vec<_> = (0..usize::from(ADOPT_FRAMES) + 4)
            .map(|f| mtts.process(&view.frame(f).image_k, &mut scratch).unwrap())
            .collect();
        let first = outs[0].exposure.expect("a decided first frame");
        let shows = first.shows_pct.expect("the image unlike its design");
        assert!((shows - truth_pct).abs() <= 10.0, "{}: {first:?}", m.seed);
        assert_eq!(first.configured_pct, 71.0);
        let adopted: Vec<_> = outs
            .iter()
            .filter_map(|o| o.exposure.filter(|e| e.adopted))
            .collect();
        assert_eq!(adopted.len(), 1, "{}: {adopted:?}", m.seed);
        assert!(
            (adopted[0].design_pct - truth_pct).abs() <= 6.0,
            "{}: {adopted:?}",
            m.seed
        );
        let last = outs.last().unwrap().exposure.unwrap();
        assert_eq!(last.design_pct, adopted[0].design_pct);
        assert!(
            (last.fitted_pct - truth_pct).abs() <= 6.0,
            "{}: {last:?}",
            m.seed
        );
        checked += 1;
    }
    assert!(checked >= 5, "{checked} members checked");
}

/// A fresh MTTS configured with `m`'s design and the mode's prior (the hotter target's).
fn mtts_for(m: &host_sim::imaging::view_family::Member) -> thermorph::mtts::Mtts {
    use thermorph::mtts::{Config, Mtts, Prior};
    let mut mtts = Mtts::new(Config {
        exposed_pct: m.design_exposed_pct,
        ..Config::default()
    })
    .unwrap();
    mtts.set_prior(if m.gap_k() >= 0.0 {
        Prior::HeaterHotter
    } else {
        Prior::SurfaceHotter
    });
    mtts
}

/// MTTS on `m` with the mode's prior: T1 − truth, T2 − truth, K, the fitted period, pixels,
/// and the fitted exposed fraction.
fn fit(m: &host_sim::imaging::view_family::Member) -> (f32, f32, f32, f32) {
    let out = mtts_for(m)
        .process(
            &m.render().image_k,
            &mut Box::new(thermorph::mtts::Scratch::new()),
        )
        .unwrap();
    (
        out.t1().unwrap().k() - m.temps.heater_k as f32,
        out.t2().unwrap().k() - m.temps.surface_k as f32,
        out.geometry.period_px,
        out.geometry.exposed,
    )
}

#[test]
fn a_lattice_showing_under_two_periods_is_found() {
    // Unseen members whose core shows about 1.6 periods of narrow surface stripes: the
    // periodogram's peak lay between its grid's first two points (24 and 13.9 px), and the
    // fit stayed at 24 px with T2 2.2 K off (seed 1 000 692) or at 21.7 px, 1.9 K off.
    for seed in [1_000_692, 1_000_235] {
        let m = host_sim::imaging::view_family::Member::draw(seed);
        let (_, t2, period, _) = fit(&m);
        let truth = m.geometry.period_px as f32;
        assert!(
            (period / truth - 1.0).abs() < 0.12,
            "{seed}: period {period} px against {truth}"
        );
        assert!(t2.abs() < 0.5, "{seed}: T2 {t2} K off");
    }
}

#[test]
fn the_exposed_fraction_is_fitted_between_its_grid_points() {
    // Over unseen members with stripes at least 1.5 px wide and a gap of 3 K or more, the
    // fitted exposed fraction — the posterior mean over h's half steps and the spreads —
    // lies nearer the truth than the grid alone puts it or the χ² parabola between its
    // points (step 0.025) did (measured on these 233: mean |error| 0.0060 with the posterior,
    // 0.0087 with the parabola, 0.0106 on the grid).
    let mut errs = Vec::new();
    for seed in UNSEEN.start..UNSEEN.start + 300 {
        let m = host_sim::imaging::view_family::Member::draw(seed);
        let g = m.geometry;
        if g.period_px * g.exposed.min(1.0 - g.exposed) < 1.5 || m.gap_k().abs() < 3.0 {
            continue;
        }
        let (_, _, _, fitted) = fit(&m);
        errs.push((fitted as f64 - g.exposed).abs());
    }
    let mean = errs.iter().sum::<f64>() / errs.len() as f64;
    assert!(
        errs.len() >= 100 && mean < 0.0075,
        "{} members: mean |error| {mean}",
        errs.len()
    );
}

#[test]
fn a_period_past_the_longest_searched_never_resolves() {
    // An unseen member whose 0.65 px surface stripes (period 4.0 px, exposed 0.84, σ 0.38 px,
    // a 2.9 K gap) the core does not show: the periodogram peaked at its longest period and the refinement
    // took it past (25.5 px, beyond the 24 searched). Its T2 was 5 K off; with a bound under
    // 1 K it came out resolved and swapped — now it is at most ambiguous (since the bins'
    // slopes, 2.4 K off within a 4.2 K bound).
    let m = host_sim::imaging::view_family::Member::draw(1_000_877);
    let out = host_sim::imaging::mtts_wp::member_outcome(
        &m,
        PriorCase::Right,
        &mut Box::new(thermorph::mtts::Scratch::new()),
    );
    assert_ne!(out.quality, Quality::Resolved, "{out:?}");
    assert!(!out.swapped && !out.confidently_wrong(), "{out:?}");
}

#[test]
fn a_lone_hot_pixel_in_the_core_is_left_out() {
    // Unseen members without bad pixels, |gap| ≥ 3 K, each with one pixel on the axis at row
    // 12 reading 20 K too hot (a hot pixel the EEPROM does not flag): the lattice fit leaves
    // it out. Measured on these 33: mean of |T1| and |T2| 0.091 K with it left out, 0.203 K
    // with it kept.
    let mut scratch = Box::new(thermorph::mtts::Scratch::new());
    let mut errs = Vec::new();
    for seed in UNSEEN.start..UNSEEN.start + 300 {
        let m = host_sim::imaging::view_family::Member::draw(seed);
        if m.bad_count != 0 || m.gap_k().abs() < 3.0 {
            continue;
        }
        let g = m.geometry;
        let row = 12;
        let col = (g.axis_col0 + g.tilt_deg.to_radians().tan() * row as f64).round();
        if !(0.0..32.0).contains(&col) {
            continue;
        }
        let mut img = m.render().image_k;
        img[row * 32 + col as usize] += 20.0;
        let out = mtts_for(&m).process(&img, &mut scratch).unwrap();
        errs.push((out.t1().unwrap().k() as f64 - m.temps.heater_k).abs());
        errs.push((out.t2().unwrap().k() as f64 - m.temps.surface_k).abs());
    }
    let mean = errs.iter().sum::<f64>() / errs.len() as f64;
    assert!(
        errs.len() >= 50 && mean <= 0.13,
        "{} estimates: mean |error| {mean:.3} K",
        errs.len()
    );
}

/// The unseen members among the first 2 000 exposed within `exposed`, of periods within
/// `periods` px and a gap of 3 K or more: how many, and their mean |T2| over every frame, K.
fn thin_stripe_cell(exposed: std::ops::Range<f64>, periods: std::ops::Range<f64>) -> (usize, f64) {
    let members: Vec<_> = (UNSEEN.start..UNSEEN.start + 2000)
        .map(host_sim::imaging::view_family::Member::draw)
        .filter(|m| {
            let g = m.geometry;
            exposed.contains(&g.exposed) && periods.contains(&g.period_px) && m.gap_k().abs() >= 3.0
        })
        .collect();
    let outs = members_outcomes(members.into_iter(), PriorCase::Right);
    let mean = outs.iter().map(|o| o.err_k[1]).sum::<f64>() / outs.len() as f64;
    (outs.len(), mean)
}

#[test]
fn long_lattices_of_thin_stripes_are_fitted_within_0_3_k() {
    // Unseen members exposed 0.75–0.85 (surface stripes 0.15–0.25 of the period) with periods
    // of 10–16 px: the period refined on three harmonics, and six harmonics fitted for a design
    // of thin stripes (measured, mean |T2| over every frame: 0.40 K with the fundamental's
    // refinement and five harmonics, 0.23 K then, 0.235 K with the exposure's prior, 0.229 K
    // with the bins' slopes, on these 128).
    let (n, mean) = thin_stripe_cell(0.75..0.85, 10.0..16.0);
    assert!(
        n >= 100 && mean <= 0.3,
        "{n} members: mean |T2| {mean:.3} K"
    );
}

#[test]
fn thin_stripes_of_short_periods_lean_on_the_design_s_exposure() {
    // Unseen members exposed 0.75–0.85 with periods of 6–10 px: a surface stripe of a pixel or
    // two, whose level trades against its width and the optics' spread along a nearly flat χ²
    // valley; the Gaussian prior on the exposed fraction about the design
    // (`lattice::EXPOSED_PRIOR_SD`) weighs the valley (measured, mean |T2| over every frame:
    // 0.506 K with a flat prior over the window, 0.463 K with the prior, 0.437 K with the
    // candidates' model to the design's harmonics below 1.25 cycles per pixel, 0.425 K with the
    // bins' slopes, on these 83).
    let (n, mean) = thin_stripe_cell(0.75..0.85, 6.0..10.0);
    assert!(
        n >= 80 && mean <= 0.44,
        "{n} members: mean |T2| {mean:.3} K"
    );
}

#[test]
fn the_thesis_s_thin_surface_stripes_take_the_model_s_higher_harmonics() {
    // The thesis's lattice (surface stripes 0.29 of a 4.6–5.4 px period: about 1.5 px) on the
    // 240 unseen members of its corner, |gap| ≥ 3 K, the mode's prior: the candidates' model
    // of the profile keeps the design's five harmonics below 1.25 cycles per pixel
    // (`lattice::MODEL_BAND_CPP`) where the free fit's 0.75 stops at three, and those stripes'
    // harmonics tell their width from the optics' spread (measured, mean |T2| over every
    // frame: 0.208 K with the free fit's harmonics only, 0.178 K with them, 0.173 K with the
    // bins' slopes, on these 194).
    let outs = members_outcomes(
        (UNSEEN.start..UNSEEN.start + 240).map(thesis),
        PriorCase::Right,
    );
    let sel: Vec<_> = outs.iter().filter(|o| o.gap_k.abs() >= 3.0).collect();
    let mean = sel.iter().map(|o| o.err_k[1]).sum::<f64>() / sel.len() as f64;
    assert!(
        sel.len() >= 180 && mean <= 0.19,
        "{} members: mean |T2| {mean:.3} K",
        sel.len()
    );
}

/// An outcome's every field, for comparing two outcomes exactly (NaN included).
fn exact(o: &FamilyOutcome) -> String {
    format!("{o:?}")
}

#[test]
fn lattices_unlike_their_design_are_what_they_claim() {
    use host_sim::imaging::view_family::{UNLIKE_NARROW, UNLIKE_WIDE, unlike_design};
    let design = thermorph::mtts::Config::default().exposed_pct;
    let n = 1000;
    let (mut narrow, mut wide) = (0, 0);
    for seed in UNSEEN.start..UNSEEN.start + n {
        let m = unlike_design(seed);
        assert_eq!(m.seed, seed);
        assert_eq!(m.design_exposed_pct, design, "{seed}");
        let e = m.geometry.exposed;
        if (UNLIKE_NARROW.0..UNLIKE_NARROW.1).contains(&e) {
            narrow += 1;
        } else {
            assert!((UNLIKE_WIDE.0..UNLIKE_WIDE.1).contains(&e), "{seed}: {e}");
            wide += 1;
        }
        // Far from the design, whichever band: at least 0.14 off.
        assert!((e - f64::from(design) / 100.0).abs() >= 0.14, "{seed}: {e}");
    }
    assert_eq!(narrow + wide, n);
    assert!(
        narrow * 5 >= 2 * n && wide * 5 >= 2 * n,
        "{narrow} / {wide}"
    );
    // Their outcomes report the member's own exposure and gap, on both sides of the design.
    let outs = members_outcomes(
        (UNSEEN.start..UNSEEN.start + 40).map(unlike_design),
        PriorCase::Right,
    );
    for o in &outs {
        let m = unlike_design(o.seed);
        assert_eq!(o.exposed, m.geometry.exposed);
        assert_eq!(o.gap_k, m.gap_k());
    }
    assert!(outs.iter().any(|o| o.exposed < 0.5) && outs.iter().any(|o| o.exposed > 0.85));
}

#[test]
fn the_settled_evaluation_of_one_frame_is_the_first_frame_s() {
    use host_sim::imaging::mtts_wp::{
        member_first_and_settled, member_outcome, member_outcome_settled,
    };
    use host_sim::imaging::view_family::{Member, unlike_design};
    let mut scratch = Box::new(thermorph::mtts::Scratch::new());
    for seed in UNSEEN.start..UNSEEN.start + 30 {
        for m in [Member::draw(seed), unlike_design(seed)] {
            for prior in [PriorCase::Right, PriorCase::Wrong, PriorCase::None] {
                let first = member_outcome(&m, prior, &mut scratch);
                let one = member_outcome_settled(&m, prior, 1, &mut scratch);
                assert_eq!(exact(&first), exact(&one), "{seed} {prior:?}");
                let (f, _) = member_first_and_settled(&m, prior, 3, &mut scratch);
                assert_eq!(exact(&first), exact(&f), "{seed} {prior:?}");
            }
        }
    }
}

#[test]
fn the_settled_evaluation_reads_fresh_noise_and_keeps_its_members_order() {
    use host_sim::imaging::mtts_wp::{
        SETTLED_FRAMES, member_first_and_settled, member_outcome_settled,
        members_first_and_settled, members_outcomes_settled,
    };
    use host_sim::imaging::view_family::unlike_design;
    let members = || (UNSEEN.start..UNSEEN.start + 24).map(unlike_design);
    let both = members_first_and_settled(members(), PriorCase::Right, SETTLED_FRAMES);
    let settled = members_outcomes_settled(members(), PriorCase::Right, SETTLED_FRAMES);
    let mut scratch = Box::new(thermorph::mtts::Scratch::new());
    let mut moved = 0;
    for ((m, (first, last)), s) in members().zip(&both).zip(&settled) {
        assert_eq!(first.seed, m.seed);
        assert_eq!(exact(last), exact(s));
        let one = member_outcome_settled(&m, PriorCase::Right, SETTLED_FRAMES, &mut scratch);
        assert_eq!(exact(&one), exact(s), "{}", m.seed);
        // Two frames: the second's noise is its own, not the first's again.
        let (a, b) = member_first_and_settled(&m, PriorCase::Right, 2, &mut scratch);
        moved += usize::from(a.err_k != b.err_k);
    }
    assert!(moved * 2 >= both.len(), "{moved} of {} moved", both.len());
}

#[test]
fn the_table_of_lattices_unlike_their_design_counts_every_member_in_its_band() {
    use host_sim::imaging::mtts_wp::{
        UNLIKE_EXPOSED, members_first_and_settled, unlike_design_markdown,
    };
    use host_sim::imaging::view_family::unlike_design;
    let n = 60;
    let (first, settled): (Vec<_>, Vec<_>) = members_first_and_settled(
        (UNSEEN.start..UNSEEN.start + n).map(unlike_design),
        PriorCase::Right,
        2,
    )
    .into_iter()
    .unzip();
    let md = unlike_design_markdown(&first, &settled);
    let rows: Vec<Vec<&str>> = md
        .lines()
        .skip(2)
        .map(|l| l.trim_matches('|').split(" | ").map(str::trim).collect())
        .collect();
    assert_eq!(rows.len(), 2 * UNLIKE_EXPOSED.len(), "{md}");
    let mut total = [0usize; 2];
    for r in &rows {
        assert_eq!(r.len(), 12, "{md}");
        let i = match r[1] {
            "first" => 0,
            "settled" => 1,
            other => panic!("{other}"),
        };
        let count: usize = r[2].parse().unwrap();
        let swapped: usize = r[10].parse().unwrap();
        let resolved: f64 = r[3].parse().unwrap();
        assert!(
            swapped <= count && (0.0..=100.0).contains(&resolved),
            "{md}"
        );
        total[i] += count;
    }
    assert_eq!(total, [n as usize; 2], "{md}");
}
