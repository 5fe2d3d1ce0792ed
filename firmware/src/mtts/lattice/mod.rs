//! Lattice separation (SPEC section 3, "beyond clustering"): T1 (heater area) and T2 (SMP
//! surface) by least squares on the region-mix forward model of the cylinder's core, with a
//! bound and a per-frame quality (resolved, ambiguous, merged, fallback).
//!
//! Constants (weights, thresholds, spreads, grid) were tuned on the scene family's seen seeds
//! only (`host_sim::imaging::view_family::SEEN`): periods 4–16 px, exposed fractions
//! 0.2–0.85, optics from the footprint alone to σ 0.6 px, tilt ±35°, broken and hot pixels.
//!
//! Model. Along the axis coordinate t the core shows a square wave: stripes of the hotter
//! target, a fraction h of each period P, on the colder one. A sensor pixel integrates its
//! footprint (a unit square, projected on the tilted axis: two boxes of widths cos α and
//! sin α) through the optics' spread (a Gaussian; the datasheet gives no numeric profile, so
//! its σ is a nuisance parameter fitted over the grid [`PSF_SIGMAS_PX`], from none — an
//! MLX90640 pixel may be as sharp as its footprint — to 0.6 px), so its value is
//! `a + b·f(t)` with f the square wave seen through that transfer function H:
//! `f(t) = h + Σ_k 2·sin(πkh)/(πk)·H(k/P)·cos(2πk(t − c)/P)`, a the colder temperature, b the
//! gap (≥ 0) and c the centre of a hot stripe. The frame is linear in (a, b) once (P, c, h)
//! are known:
//! 1. P: the periodogram peak of the core's axial profile (periods [`PERIOD_MIN_PX`]…
//!    [`PERIOD_MAX_PX`]; narrowed to ±12 % of the previous frame's), looked at half a grid
//!    step either side before the parabola (a core showing under two periods peaks between
//!    the grid's first points), refined by a Gauss–Newton step of the least-squares fit of the
//!    mean and the fundamental (near the minimum from as far as the peak may lie), then one of
//!    the mean and the first three harmonics (a thin stripe's harmonics pull the fundamental's
//!    minimum off by several percent where the core shows under two periods);
//! 2. the core pixels are fitted by least squares with the mean and the first harmonics of P
//!    that lie below 0.75 cycles per pixel (at most five, six for a design of stripes under a
//!    quarter of the period, `harmonics_for`; fewer if ill-conditioned: a thin stripe — the
//!    thesis's 1.4 px SMP strips — lives in the higher ones); c is the fundamental's phase;
//! 3. for each h on a grid and each spread, the (a, b) whose square wave best matches the
//!    core's pixels give a misfit χ² (the per-pixel least squares, through the normal matrix
//!    of the fit's basis extended, for a lattice of short period, to the harmonics the design
//!    needs below [`MODEL_BAND_CPP`], 1.5 cycles per pixel — five, ten for a design of
//!    stripes under a quarter of the period, `model_for`: a thin stripe's higher harmonics,
//!    which the free fit cannot hold apart, are the model's own and not noise; each ¼ px bin
//!    of the profile gives its pixels' mean and, where they lie at several places along the
//!    axis, their slope: see `FINE`), with the noise
//!    estimated from the best candidate's residual. The exposed fraction is thus fitted per
//!    frame, and so is the spread: T1, T2 and h are their posterior means over the chosen
//!    hypothesis's window and the spreads (likelihood e^(−χ²/2), flat over the spreads,
//!    a Gaussian prior on the exposed fraction about the design, [`EXPOSED_PRIOR_SD`]; on half
//!    steps of h, a sharp row by its χ² parabola's vertex). A thin stripe's level trades
//!    against its width and the spread along a valley of nearly equal χ², whose minimum the
//!    noise moves from end to end: the mean over it errs far less than the grid's best point
//!    (unseen family members, |gap| ≥ 3 K, every frame, with the lone-pixel rule below:
//!    mean |T1|, |T2| 0.13, 0.19 → 0.08, 0.14 K; `bash scripts/work-precision`).
//!
//! The core's profile leaves out a lone pixel more than [`LONE_PIXEL_K`] beyond every other
//! (a hot or dead pixel the EEPROM does not flag): one such pixel moves its bin by its whole
//! excess, and the fit's harmonics with it. A bad pixel that is not the core's extreme (a hot
//! pixel on a cold stripe) is left out too when it lies beyond both its row neighbours by more
//! than 5 % of the frame's range, and at least [`LONE_PIXEL_K`]: if at most four core pixels
//! do. More are the lattice's own — a thin stripe crossing the rows at a slant puts single
//! pixels beyond both neighbours — and stay (the first four are noted as the pass goes; the
//! rest of the pass is as without the rule). Unseen family members, |gap| ≥ 3 K: mean |T1|,
//! |T2| 0.073, 0.108 → 0.070, 0.104 K; exposed 0.75–0.85 at 6–10 px, T2 0.44 → 0.36 K.
//!
//! The candidates' model of a thin-stripe design reaches the tenth harmonic within
//! [`MODEL_BAND_CPP`] (`model_for`): a thin stripe's spectrum 2·sin(πkh)/(πk) still holds a few
//! percent of its gap past the fit's sixth (6.6 % at the seventh for h = 0.18), which a model
//! stopping short reads as noise, and its misfit goes flatter along the stripe's level and
//! width (unseen member 1000411, exposed 0.84 at 6.4 px, no spread, 0.05 K of noise: |T2| 0.76
//! → 0.44 K with a seventh; 1000632, 0.82 at 9.5 px: 0.44 → 0.27 K). Seen family members,
//! |gap| ≥ 3 K, mean |T1|, |T2|: 0.0760, 0.1064 K with six, 0.0753, 0.1043 K with seven,
//! 0.0752, 0.1023 K with ten up to 1.5 cycles per pixel; unseen 0.069, 0.101 → 0.068, 0.096 →
//! 0.068, 0.091 K (a throwaway host experiment over the first 1 000 members; the cells in
//! `bash scripts/work-precision`). The thesis's block keeps five (`model_for`).
//!
//! A candidate's products cost the model's length, not its square: per spread, the Gram
//! matrix's harmonics' block is folded once into sums over cos πnh (`Spread`), so each
//! candidate is three dot products with its h's sines and cosines (`Trig`); and a surface-hot
//! candidate 1 − h, the heater-hot candidate h's mirror, takes the same terms split by parity.
//! A model of ten costs a thin-stripe design's first frame fewer instructions than the
//! quadratic form of seven did (`bash scripts/bench-m4`).
//!
//! A broken pixel the pipeline filled in from its neighbours ([`super::inpaint`]) is left out
//! too: it is no measurement of its place, and across a stripe a pixel wide it is the mean of
//! both targets (unseen member 1000995, two in its core: |T2| 2.10 → 0.77 K). Unseen members,
//! |gap| ≥ 3 K: mean |T1|, |T2| 0.070, 0.104 → 0.069, 0.101 K, the 6–10 px cell 0.36 →
//! 0.33 K; seen 0.0771, 0.1055 → 0.0760, 0.1064 K. The filled pixels are dropped after the
//! pass (a frame has few), which costs nothing on a frame without.
//!
//! Which target is hotter: hot stripes of fraction h are the heater if the exposed fraction
//! d = h, or the surface if d = 1 − h. The block's design fixes d within
//! [`EXPOSED_TOLERANCE`] ([`super::Config::exposed_pct`]: the lattice's gap over its unit; the
//! view and the lattice's waviness move it a little), so each hypothesis has its own h window
//! and best χ², and the image decides whenever heater and surface stripes differ in width:
//! the thesis's block (71 % exposed) shows hot stripes 0.71 of the period wide while heating
//! and 0.29 wide once forming has inverted the hot zone. A best χ² lower by at least
//! [`AMBIGUOUS_CHI2`] is a clear spatial verdict and stands whatever the prior says. Only
//! between hypotheses the image both allows — a block built near 50 % exposed, whose heater
//! and surface stripes are equally wide, or a lattice too faint to tell — does the supervisor's
//! [`Prior`] (or, without one, the previous frame's decision, [`CONTINUITY_CHI2`]) pick, and
//! then the bound spans both hypotheses: a pick the image did not make is resolved only when
//! either answer lies within a small bound (a small gap), so a wrong prior is never a
//! confident error. A decided frame whose bound is not small (a pick only the prior made, or
//! thin stripes whose level trades against their width) is [`Quality::Ambiguous`]: T1 and T2
//! the fit's, the bound honest. With nothing to pick between two allowed hypotheses the frame
//! is [`Quality::Merged`].
//!
//! A lattice unlike its design (another print, another view; issue 43). Each frame also scans
//! hot-stripe fractions 0.1…0.9 free of the design (`FreeScan`). Where its answer lies far from
//! the design the frame fits about it ([`DESIGN_CHI2`]); where a frame's verdict contradicts
//! the supervisor's prior under a design the frames have not confirmed it is ambiguous (a
//! lagging prior shows the same image); and the frames' readings of the exposed fraction —
//! the image's own answer where it contradicts the design — replace a design they keep
//! disagreeing with ([`Exposure`]), which then carries no prior and a bound over its window's
//! ends. The bound also covers the scan's answer where it lies outside the frame's windows
//! under an unconfirmed design, and spans |T1 − T2| where the image allows the grid's thinnest
//! stripes (a stripe that thin is bounded by nothing but the design). Measured on the family's
//! lattices unlike their design (unseen, settled 12 frames): exposed 0.2–0.5 resolved 73–87 %,
//! every resolved frame within its bound; exposed 0.85–0.95, thin surface stripes the image
//! fits as the design's wider ones, 17 of 250 resolved frames remain outside their bound.
//!
//! The bound: the spread of T1 and T2 over the (h, σ) whose χ² is within [`CONFIDENCE_CHI2`]
//! of the best (in both hypotheses when the image allows both; χ² with the best candidate's
//! residual variance, which includes the model's own mismatch)
//! and over the best candidates of the neighbouring spreads (σ is a grid; the truth lies
//! between two of its values), plus two standard errors of (a, b) from the pixel noise (the
//! scatter within ¼ px bins); scaled by [`BOUND_SCALE`] and floored by [`BOUND_FLOOR_K`], so
//! that ≥ 95 % of resolved frames lie within it (measured on the unseen seeds). A frame
//! is resolved when the hypothesis is decided and the bound is at most [`RESOLVED_BOUND_K`] or
//! at most [`RESOLVED_FRACTION`] of the estimated gap; else merged: both targets carry the core's
//! area-weighted mean, with the bound on how far either may lie from it. Before any lattice
//! was ever found (a cold uniform block at power-up) both are the core's mean: fallback.

use super::Quality;
use super::regions::{CORE_U, Coords, Geometry};
use super::{FilledRows, IMG_COLS, IMG_PIXELS, IMG_ROWS, Prior};
use crate::fmath::{clamp, floor, max, min, sin_cos_turns};

mod bound;
mod candidates;
mod exposure;
mod free_fit;
mod optics;
mod period;
mod posterior;
mod profile;
mod verdict;

use bound::*;
use candidates::*;
pub use exposure::{ADOPT_FRAMES, CONFIRM_FRAMES, Exposure, READING_GAP_K, REVOKE_FRAMES};
use free_fit::*;
use optics::*;
pub use optics::{lattice_core_u, transfer};
use period::*;
use posterior::*;
pub use profile::LONE_PIXEL_K;
use profile::*;
use verdict::*;

/// Smallest exposed (heater) fraction of a lattice unit the view can show.
pub const EXPOSED_MIN: f32 = 0.15;
/// Largest exposed fraction.
pub const EXPOSED_MAX: f32 = 0.9;
/// How far the exposed fraction a frame shows may lie from the block's design
/// ([`super::Config::exposed_pct`]): the lattice's waviness and the view angle.
pub const EXPOSED_TOLERANCE: f32 = 0.06;
/// The prior on the exposed fraction a frame shows: a Gaussian about the block's design of
/// this standard deviation (half of [`EXPOSED_TOLERANCE`]: the window spans ±2 sd), added to
/// each candidate's χ². Where a thin stripe's level trades against its width and the optics'
/// spread, χ² alone is nearly flat to the window's ends; the prior weighs the valley toward
/// the design (seen family members, |gap| ≥ 3 K: mean |T2| 0.122 → 0.118 K, confidently
/// wrong 11 → 8 frames, exposed 0.75–0.85 at 6–10 px 0.52 → 0.48 K). Other widths, on the
/// same members: 0.04 kept less (6–10 px 0.49 K), 0.023 gave 0.117 K but the 10–16 px thin
/// stripes 0.23 → 0.24 K, 0.015 made 15 frames confidently wrong.
pub const EXPOSED_PRIOR_SD: f32 = 0.5 * EXPOSED_TOLERANCE;
/// The spreads the fit tries (a nuisance parameter: the datasheet gives the field of view but
/// no numeric pixel-sensitivity profile), pixels: from the footprint alone to a blur wider
/// than a pixel's half.
pub const PSF_SIGMAS_PX: [f32; 7] = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6];
/// The step of [`PSF_SIGMAS_PX`] (its values are 0, 1, 2… steps), pixels.
const PSF_STEP_PX: f32 = 0.1;
/// Shortest lattice period searched, pixels.
pub const PERIOD_MIN_PX: f32 = 2.9;
/// Longest lattice period searched, pixels.
pub const PERIOD_MAX_PX: f32 = 24.0;
/// Least fundamental amplitude of the axial profile to (re)detect the lattice, K.
pub const MIN_LATTICE_K: f32 = 0.3;
/// χ² bonus of the hypothesis the supervisor's prior expects: more than [`AMBIGUOUS_CHI2`], so
/// between hypotheses the image both allows the prior always picks.
pub const PRIOR_CHI2: f32 = 60.0;
/// χ² bonus of the previous frame's hypothesis when there is no prior.
pub const CONTINUITY_CHI2: f32 = 4.0;
/// χ² margin within which two hypotheses are both allowed by the image.
pub const AMBIGUOUS_CHI2: f32 = 16.0;
/// χ² by which the best candidate within the design's windows may fall short of the best of
/// any exposed fraction before the design is taken not to explain the image.
pub const DESIGN_CHI2: f32 = 16.0;
/// Shortest period at which a frame may find its design wrong, pixels: shorter, a thin
/// stripe's width trades against the optics' spread over the whole grid (unseen family
/// members of 4.1–4.9 px, blurred, found their own design 0.13–0.17 off).
pub const DESIGN_PERIOD_MIN_PX: f32 = 5.0;
/// χ² margin of the confidence set over h.
pub const CONFIDENCE_CHI2: f32 = 4.0;
/// Largest fraction of the estimated gap |T1 − T2| the bound of a resolved frame may reach
/// (when it exceeds [`RESOLVED_BOUND_K`]): the targets stand apart by several bounds.
pub const RESOLVED_FRACTION: f32 = 0.35;
/// Factor on the bound's statistical part (the confidence set and two standard errors), for
/// what the model leaves out: calibrated for ≥ 95 % coverage on the seen seeds.
pub const BOUND_SCALE: f32 = 1.3;
/// Least bound, K: the model's floor (the core's straight edges, the footprint as two boxes).
pub const BOUND_FLOOR_K: f32 = 0.1;
/// Bound up to which a decided frame is resolved whatever its gap, K.
pub const RESOLVED_BOUND_K: f32 = 1.0;

/// Harmonics fitted at most (a design of thin stripes, [`harmonics_for`]).
const FIT_HARMONICS: usize = 6;
/// Harmonics fitted at most whatever the design ([`harmonics_for`]), and the candidates' model
/// of a design of stripes no thinner than a quarter of the period ([`model_for`]).
const BASE_HARMONICS: usize = 5;
/// Harmonics of the candidates' model at most (a design of thin stripes, [`model_for`]): an
/// even count ([`Spread::products`] splits them by parity).
const HARMONICS: usize = 10;
/// Unknowns of the harmonic fit at most.
const NP: usize = 1 + 2 * FIT_HARMONICS;
/// Entries of the fit's right-hand side: the mean and each of the model's harmonics.
const RHS: usize = 1 + 2 * HARMONICS;
/// Least pixel noise the fits assume, K.
const NOISE_FLOOR_K: f32 = 0.05;
/// A candidate's model in the basis (the mean and each harmonic's unit at the phase).
const U: usize = 1 + HARMONICS;
/// Highest frequency the candidates' model of the profile reaches, cycles per pixel: past the
/// free fit's 0.75 (whose coefficients a few periods of samples cannot all tell apart), up to
/// the harmonics the design's thinner stripe needs (`model_for`): a lattice of short period,
/// whose 0.75 cycles per pixel stop the free fit before them, keeps them in the model, where a
/// thin stripe's width and level shape them and where, left out, they weigh in the misfit as
/// noise and hide what tells the stripe's width from the spread. Seen family members, |gap| ≥
/// 3 K: mean |T2| 0.118 → 0.116 K at 1.0 (confidently wrong 8 → 9 frames), the thesis's
/// lattice 0.208 → 0.178 K. Why 1.5 and not 1.25: a pixel's footprint, a box a pixel wide,
/// passes a first sidelobe between 1 and 2 cycles per pixel whose largest gain (0.22) lies at
/// 1.43, and a tilted axis samples the profile at every ¼ px, so a thin stripe's harmonics there
/// reach the bins attenuated, not gone: a band of 1.25 cuts the sidelobe before its peak and
/// reads that part as noise. With a thin-stripe design's ten harmonics the seen members tie
/// (1.25: 0.0750, 0.1019 K; 1.5: 0.0752, 0.1023 K; thin stripes at 4–16 px 0.297 and 0.300 K);
/// unseen members exposed 0.75–0.85 at 6–10 px 0.316 → 0.297 K (a throwaway host experiment).
/// The thesis's block is not changed: its model stops at five, which any period ≥ 4 px holds
/// below either band. A model past the design's harmonics for the thesis's block (at most
/// seven below 1.25) gained the seen members (0.110 K) but lost the camera-on cycle (mean |T2|
/// 0.063 → 0.095 K) and the standard scenes' T1 (0.010 → 0.031 K), as a sixth harmonic had
/// (`harmonics_for`).
pub const MODEL_BAND_CPP: f32 = 1.5;
/// Parameters the best candidate fits (a, b, h and the spread): the degrees of freedom its
/// misfit loses, for the noise it estimates.
const MODEL_PARAMETERS: f32 = 4.0;
/// Axial profile bins (one per pixel of axial length).
const BINS: usize = 48;
/// Frequency step of the first frame's periodogram, cycles per pixel.
const FREQ_STEP: f32 = 0.03;
/// Harmonics of the frequency's refinement ([`gn_step`]) at most.
const REFINE_HARMONICS: usize = 3;
/// Largest relative change of the frequency by its refinement.
const REFINE_LIMIT: f32 = 0.1;
/// Grid of hot-stripe fractions h: H_FIRST + i·H_STEP.
const H_FIRST: f32 = 0.1;
const H_STEP: f32 = 0.025;
const H_COUNT: usize = 33;
/// Spreads tried.
const PSFS: usize = PSF_SIGMAS_PX.len();
/// Most h grid points in one hypothesis's window (2·[`EXPOSED_TOLERANCE`] / `H_STEP` + 1,
/// rounded up).
const SLOTS: usize = 6;
const _: () = assert!((((2.0 * EXPOSED_TOLERANCE + 2e-4) / H_STEP) as usize) < SLOTS);
/// Candidates kept: each window's h under every spread.
const CANDIDATES: usize = 2 * SLOTS * PSFS;

/// Result of one frame's separation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Separation {
    /// T1 estimate, K.
    pub t1_k: f32,
    /// T2 estimate, K.
    pub t2_k: f32,
    /// Area-weighted mean of the core (heater and surface), K.
    pub mean_k: f32,
    /// Bound on |T1 − truth| and |T2 − truth|, K.
    pub bound_k: f32,
    /// Resolved, ambiguous, merged or fallback.
    pub quality: Quality,
    /// The exposed fraction this frame's run of readings adopted as the design in use (the
    /// configured design again, or the image's), if it did ([`Exposure`]).
    pub adopted: Option<f32>,
    /// The exposed fraction this frame's image shows where it is unlike the design in use
    /// (beyond [`EXPOSED_TOLERANCE`]), read as the supervisor's prior orders the targets: the
    /// frame's reading ([`Exposure`]). `None` without a prior or a reading, or where the image
    /// agrees with the design.
    pub shows: Option<f32>,
}

/// The core's reference value, mean and range, K.
struct Core {
    reference: f32,
    mean: f32,
    lo: f32,
    hi: f32,
}

impl Core {
    /// The core of `prof`.
    fn of(prof: &Profile) -> Core {
        Core {
            reference: prof.reference,
            mean: prof.reference + prof.mean_dev,
            lo: prof.lo,
            hi: prof.hi,
        }
    }

    /// The frame without a lattice: both targets the core's mean, the bound half its range.
    fn fallback(&self) -> Separation {
        Separation {
            t1_k: self.mean,
            t2_k: self.mean,
            mean_k: self.mean,
            bound_k: 0.5 * (self.hi - self.lo),
            quality: Quality::Fallback,
            adopted: None,
            shows: None,
        }
    }
}

/// The lattice's frequency this frame, cycles per pixel: the periodogram's peak (searched
/// within ±12 % of the previous frame's, once a lattice is known), refined by a Gauss–Newton
/// step of the fit of the mean and the fundamental, which converges from farther, then one of
/// the fit with three harmonics (a thin stripe's harmonics pull the periodogram's peak, the more
/// so where the core shows few periods). With `found` false the periodogram found no lattice
/// this frame and the previous frame's period stands in (the frame then leaves the geometry as
/// it was). `None`: no lattice found and none known.
struct Period {
    nu: f32,
    found: bool,
    /// Longest period the core can show (its length / 1.2, at most [`PERIOD_MAX_PX`]), pixels.
    p_max: f32,
}

impl Period {
    fn of(prof: &Profile, g: &Geometry) -> Option<Period> {
        let length = prof.length() as f32;
        let p_max = min(PERIOD_MAX_PX, length / 1.2);
        let (lo, hi, step) = if g.lattice_known {
            let nu = 1.0 / g.period_px;
            (0.88 * nu, 1.12 * nu, 0.004)
        } else {
            (1.0 / p_max, 1.0 / PERIOD_MIN_PX, FREQ_STEP)
        };
        let coarse = Coarse::of(prof);
        let found = find_frequency(
            &coarse,
            max(lo, 1.0 / p_max),
            min(hi, 1.0 / PERIOD_MIN_PX),
            step,
        )
        .filter(|&(_, amp)| amp >= MIN_LATTICE_K);
        // Not seen this frame (too little contrast): the previous lattice measures.
        let mut nu = match (found, g.lattice_known) {
            (Some((nu, _)), _) => nu,
            (None, true) => 1.0 / g.period_px,
            (None, false) => return None,
        };
        let mut angles = [(0f32, 0f32); FINE_BINS];
        for k in [1, REFINE_HARMONICS] {
            if let Some(d) = gn_step(prof, nu, ((0.75 / nu) as usize).clamp(1, k), &mut angles) {
                nu += clamp(d, -REFINE_LIMIT * nu, REFINE_LIMIT * nu);
            }
        }
        Some(Period {
            nu,
            found: found.is_some(),
            p_max,
        })
    }
}

/// The free fit at frequency `nu` and the candidates' model's harmonics: harmonics below 0.75
/// cycles per pixel (past Nyquist, a tilted axis samples the profile at many sub-pixel
/// positions), fewer where the fit is ill-conditioned (an untilted axis aliases them onto each
/// other); the model reaches further ([`MODEL_BAND_CPP`]), its sums from the same pass.
/// `None`: not even the fundamental can be fitted.
fn fit_free(prof: &Profile, nu: f32, design_exposed: f32) -> Option<(HarmonicFit, usize)> {
    let mut harmonics = ((0.75 / nu) as usize).clamp(1, harmonics_for(design_exposed));
    let model = ((MODEL_BAND_CPP / nu) as usize).clamp(harmonics, model_for(design_exposed));
    loop {
        match harmonic_fit(prof, nu, harmonics, model) {
            Some(f) => return Some((f, model)),
            None if harmonics > 1 => harmonics -= 1,
            None => return None,
        }
    }
}

/// (T1, T2) of a candidate under a hypothesis, K, with the core's `reference`.
fn temps(reference: f32, c: &Candidate, hyp: Hyp) -> (f32, f32) {
    let (hot, cold) = (reference + c.a + c.b, reference + c.a);
    match hyp {
        Hyp::HeaterHot => (hot, cold),
        Hyp::SurfaceHot => (cold, hot),
    }
}

/// Estimate the lattice and separate T1 from T2 on the inpainted image `img` under the
/// cylinder geometry `g` (its lattice fields are updated), with the coordinates `xy` of `g`;
/// `range_k` is the frame's range (hottest less coldest pixel, K), which scales the test for
/// bad pixels (the module docs); the pixels of `filled` were broken and filled in, and are left
/// out of the fit.
///
/// The steps, each its own (this module's files): the core's profile (`profile`), the period
/// (`Period`), the free fit (`free_fit`), the candidates (`candidates::Grid`), which target is
/// hotter (`verdict`), the estimate (`posterior::Estimate`), the bound (`bound`); then the
/// lattice the frame leaves for the next and the frame's quality.
pub fn separate(
    img: &[f32; IMG_PIXELS],
    xy: &Coords,
    g: &mut Geometry,
    prior: Prior,
    design_exposed: f32,
    range_k: f32,
    filled: &FilledRows,
) -> Separation {
    let bad_k = max(LONE_PIXEL_K, BAD_RANGE_FRACTION * range_k);
    let u_core = lattice_core_u(g.half_width_px);
    let Some(prof) = Profile::of(img, xy, g, u_core, bad_k, filled) else {
        // No core pixel at all (cannot happen with a positive half-width): the image mean.
        let m = img.iter().sum::<f32>() / IMG_PIXELS as f32;
        return Separation {
            t1_k: m,
            t2_k: m,
            mean_k: m,
            bound_k: 0.0,
            quality: Quality::Fallback,
            adopted: None,
            shows: None,
        };
    };
    let core = Core::of(&prof);
    let fallback = core.fallback();
    let Some(period) = Period::of(&prof, g) else {
        return fallback;
    };
    let nu = period.nu;
    // The design in use: the configured one, or what the frames adopted in its place.
    let design = g.exposure.design(design_exposed);
    let Some((fit, model)) = fit_free(&prof, nu, design) else {
        return if g.lattice_known {
            Separation {
                quality: Quality::Merged,
                ..fallback
            }
        } else {
            fallback
        };
    };
    let spreads = Spreads::of(&fit, nu, g.axis_slope, model);
    // Which target the supervisor's prior (or, without one, the previous frame) says is hotter.
    let expects_heater = match prior {
        Prior::HeaterHotter => Some(true),
        Prior::SurfaceHotter => Some(false),
        Prior::Unknown => g.heater_hotter,
    };
    let scan = FreeScan::of(&spreads, design);
    let (frame_design, picked) = frame_design(&scan, design, 1.0 / nu, expects_heater);
    let grid = Grid::of(&spreads, frame_design, g.exposure.adopted.is_none());
    let verdict = Verdict::of(&grid, prior, g.heater_hotter);
    // The image decided against the supervisor's prior with a design the frames have not
    // confirmed: a lattice unlike its design under a right prior shows the same image as its
    // design under a lagging one, so the frame cannot tell which is wrong.
    let supervisor = match prior {
        Prior::HeaterHotter => Some(Hyp::HeaterHot),
        Prior::SurfaceHotter => Some(Hyp::SurfaceHot),
        Prior::Unknown => None,
    };
    let contested = !picked
        && verdict.clear
        && supervisor.is_some_and(|h| h != verdict.hyp)
        && !g.exposure.confirmed();
    let est = Estimate::of(&grid, &verdict, &fit, core.reference);
    let (t1, t2) = (est.t1_k, est.t2_k);
    let mean = core.reference + fit.theta[0];
    let mut bounds = Bounds::of(&grid, &verdict, &est, &fit, core.reference, mean);
    let hyp = verdict.hyp;
    // The image's own answer lies outside the windows the frame fitted in: the design is the
    // frame's assumption, not its finding (a thin stripe's level trades against its width).
    let outside = scan.off(frame_design) > 2.0 * EXPOSED_TOLERANCE;
    if outside && !g.exposure.confirmed() {
        let (f1, f2) = temps(core.reference, &scan.best, hyp);
        let e = max(libm::fabsf(f1 - t1), libm::fabsf(f2 - t2));
        bounds.estimate_k = max(bounds.estimate_k, BOUND_SCALE * e + BOUND_FLOOR_K);
    }
    // A design the frames adopted is the image's own reading, known to its tolerance: the
    // answers at its window's ends (the best spread's) lie within too.
    if g.exposure.adopted.is_some() {
        let first = est.best / (2 * SLOTS) * 2 * SLOTS + Grid::base_of(est.hyp);
        let n = grid.range_of(est.hyp).len();
        for c in [&grid.cand[first], &grid.cand[first + n.max(1) - 1]] {
            let (x1, x2) = temps(core.reference, c, est.hyp);
            let e = max(libm::fabsf(x1 - t1), libm::fabsf(x2 - t2));
            bounds.estimate_k = max(bounds.estimate_k, BOUND_SCALE * e + BOUND_FLOOR_K);
        }
    }
    // The other answer — the same two temperatures the other way round — lies within. So
    // does a thinner stripe than the grid holds, where the image allows the grid's thinnest
    // (`FreeScan::thinnest_allowed`): only the design, if it is right, bounds its level.
    if picked || contested || scan.thinnest_allowed {
        bounds.estimate_k += libm::fabsf(t1 - t2);
    }
    let decided = if picked {
        expects_heater.is_some()
    } else {
        verdict.decided
    };
    let kept = *g;
    let period_px = 1.0 / nu;
    let h = h_at(grid.range_of(est.hyp).start) + est.h_steps * H_STEP;
    let exposed = leave_lattice(g, period_px, h, spreads.psi, hyp);
    if decided {
        g.heater_hotter = Some(hyp == Hyp::HeaterHot);
    }
    // The exposed fraction the frame shows, as the supervisor's prior orders the targets.
    // Where the image contradicts the design (its own answer outside the frame's windows, or
    // its verdict against the prior), that answer, the windows' estimate stopping at their
    // edge; and none below [`DESIGN_PERIOD_MIN_PX`], where a thin stripe's width trades
    // against the optics' spread over the whole grid.
    let unlike = contested || outside;
    let read = if unlike {
        (period_px >= DESIGN_PERIOD_MIN_PX).then_some((Hyp::HeaterHot, scan.hot))
    } else {
        Some((hyp, exposed))
    };
    let reading = supervisor
        .zip(read)
        .filter(|_| period.found && libm::fabsf(t1 - t2) >= READING_GAP_K)
        .map(|(h, (read_hyp, e))| if h == read_hyp { e } else { 1.0 - e });
    let shows = reading.filter(|r| libm::fabsf(r - design) > EXPOSED_TOLERANCE);
    let adopted = g.exposure.take(reading, design_exposed);
    if !period.found {
        *g = Geometry {
            exposure: g.exposure,
            ..kept
        };
    }
    // A period the refinement took past the longest searched (the periodogram peaked at the
    // search's end: no lattice the core shows, a trend or a hot pixel) never resolves.
    let in_range = period_px <= period.p_max;
    let sep = if decided {
        decided_frame(t1, t2, mean, bounds.estimate_k, in_range)
    } else {
        Separation {
            t1_k: mean,
            t2_k: mean,
            mean_k: mean,
            bound_k: bounds.merged_k,
            quality: Quality::Merged,
            adopted: None,
            shows: None,
        }
    };
    Separation {
        adopted,
        shows,
        ..sep
    }
}

/// The design a frame fits about: the design in use, unless the image clearly contradicts it
/// ([`FreeScan::design_fits`]; a period of at least [`DESIGN_PERIOD_MIN_PX`]). Then the hot
/// stripes' width the image shows, read as the heater's if the heater is expected hotter
/// (`expects_heater`), else as the surface's (without any expectation, the reading nearer the
/// design); the prior, not the image, decided (`true`).
fn frame_design(
    scan: &FreeScan,
    design: f32,
    period_px: f32,
    expects_heater: Option<bool>,
) -> (f32, bool) {
    if scan.design_fits(design) || period_px < DESIGN_PERIOD_MIN_PX {
        return (design, false);
    }
    let hot = scan.hot;
    let heater =
        expects_heater.unwrap_or(libm::fabsf(hot - design) <= libm::fabsf(1.0 - hot - design));
    let e = if heater { hot } else { 1.0 - hot };
    (clamp(e, EXPOSED_MIN, EXPOSED_MAX), true)
}

/// Leave in `g` the lattice as the zones and the next frame see it: `period_px`, the hot
/// stripes' fraction `h` under the hypothesis `hyp`, the heater stripes starting at the
/// phase the fundamental's (cos ψ, sin ψ) `psi` gives. Returns the exposed fraction.
fn leave_lattice(g: &mut Geometry, period_px: f32, h: f32, psi: (f32, f32), hyp: Hyp) -> f32 {
    let (cpsi, spsi) = psi;
    let centre = libm::atan2f(spsi, cpsi) / core::f32::consts::TAU * period_px;
    let (exposed, start) = match hyp {
        Hyp::HeaterHot => (h, centre - 0.5 * h * period_px),
        Hyp::SurfaceHot => (1.0 - h, centre + 0.5 * h * period_px),
    };
    g.period_px = period_px;
    g.phase_px = start - floor(start / period_px) * period_px;
    g.exposed = exposed;
    g.lattice_known = true;
    exposed
}

/// A decided frame: T1 and T2 the fit's, resolved when the bound (spanning both assignments
/// where the image did not decide alone) is small — at most [`RESOLVED_BOUND_K`] or
/// [`RESOLVED_FRACTION`] of the gap, a period `in_range` — else ambiguous: the fit's values with
/// that bound, still far closer than the mean a merged frame gives both.
fn decided_frame(t1: f32, t2: f32, mean: f32, bound_k: f32, in_range: bool) -> Separation {
    let small = in_range
        && (bound_k <= RESOLVED_BOUND_K || bound_k <= RESOLVED_FRACTION * libm::fabsf(t1 - t2));
    Separation {
        t1_k: t1,
        t2_k: t2,
        mean_k: mean,
        bound_k,
        quality: if small {
            Quality::Resolved
        } else {
            Quality::Ambiguous
        },
        adopted: None,
        shows: None,
    }
}

#[cfg(test)]
mod tests;
