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
/// The candidates' products' length for a model of the base harmonics: an even count.
const BASE_PAIRS: usize = BASE_HARMONICS + BASE_HARMONICS % 2;
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
}

/// The next harmonic's (cos, sin): (`c`, `s`) of an angle kθ turned by θ, whose (cos, sin) is
/// (`c1`, `s1`) — the angle-sum formulas, so a profile's harmonics cost one `sin_cos_turns`.
#[inline(always)]
fn turn((c, s): (f32, f32), (c1, s1): (f32, f32)) -> (f32, f32) {
    (c * c1 - s * s1, s * c1 + c * s1)
}

/// sin(πx)/(πx).
fn sinc(x: f32) -> f32 {
    sinc_of(sin_cos_turns(0.5 * x).0, x)
}

/// sin(πx)/(πx) given sin(πx) (`sin_pi_x`).
fn sinc_of(sin_pi_x: f32, x: f32) -> f32 {
    if libm::fabsf(x) < 1e-4 {
        1.0
    } else {
        sin_pi_x / (core::f32::consts::PI * x)
    }
}

/// Transfer function of pixel footprint and optics at `nu` cycles per pixel along an axis of
/// slope `slope` (columns per row), through a Gaussian point-spread function of standard
/// deviation `sigma_px`.
pub fn transfer(nu: f32, slope: f32, sigma_px: f32) -> f32 {
    let inv = 1.0 / crate::fmath::sqrt(1.0 + slope * slope);
    let (ca, sa) = (inv, libm::fabsf(slope) * inv);
    let g = core::f32::consts::PI * sigma_px * nu;
    sinc(nu * ca) * sinc(nu * sa) * libm::expf(-2.0 * g * g)
}

/// Distance ratio below which a pixel belongs to the lattice core: the core less about one
/// pixel (the footprint and the optics' spread reach the edges), at least the axis pixels.
pub fn lattice_core_u(half_width_px: f32) -> f32 {
    let w = max(0.5, half_width_px);
    min(max(CORE_U - 0.75 / w, 0.6 / w), CORE_U)
}

/// The core's reference value, mean and range, K.
struct Core {
    reference: f32,
    mean: f32,
    lo: f32,
    hi: f32,
}

/// How far a core pixel must lie beyond every other (above the second highest, or below the
/// second lowest) to be left out as a lone bad pixel, K: pixel noise (≤ 0.5 K rms) leaves the
/// extremes of a lattice's stripes within a kelvin or so of each other. Seen family members,
/// |gap| ≥ 3 K: mean |T1|, |T2| 0.106, 0.147 → 0.093, 0.133 K (1.5, 2 and 3 K alike).
pub const LONE_PIXEL_K: f32 = 2.0;
/// Fewest core pixels for [`LONE_PIXEL_K`]'s test (a core of a few pixels has no "every other").
const LONE_MIN_PIXELS: f32 = 8.0;
/// A core pixel more than this share of the frame's range (and at least [`LONE_PIXEL_K`])
/// beyond both its row neighbours is a hot or dead pixel (if there are at most [`ODD_MAX`]).
/// Without that limit a fixed 2 K took the 273 K camera-on cycle's mean |T2| from 0.077 to
/// 0.113 K: gaps of tens of kelvin put a slanted stripe's single pixels that far beyond their
/// neighbours. With it, a fixed 2 K and this share tie on the seen family members (mean |T1|,
/// |T2| 0.0766, 0.1060 against 0.0771, 0.1055 K), whose gaps stop at 15 K; the share keeps the
/// few such pixels of a larger gap.
const BAD_RANGE_FRACTION: f32 = 0.05;
/// Most core pixels beyond both row neighbours that the profile leaves out as bad: more are
/// the lattice's own stripes, and all stay. Seen family members, |gap| ≥ 3 K, mean |T1|, |T2|:
/// no rule 0.0772, 0.1084 K; at most 3 0.0781, 0.1055; 4 or 6 0.0771, 0.1055; no limit 0.0769,
/// 0.1055. Without a limit a thin stripe at a slant lost its pixels (unseen member 1000543,
/// tilt −30°, exposed 0.83: |T2| 0.27 → 0.70 K, past its bound).
const ODD_MAX: usize = 4;

/// Least spread Σ (t − t̄)² of a bin's pixels along the axis for its slope to count, px²
/// (pixels at one place, within rounding, tell no slope).
const SLOPE_MIN_PX2: f32 = 1e-6;
/// Fine bins per pixel of axial length.
///
/// A tilted axis puts a bin's pixels at several places within it, and across a sharp stripe's
/// edge their values differ by a kelvin or more: that slope is what tells a stripe's width from
/// the optics' spread, which a bin's mean alone throws away. So the candidates' misfit takes
/// each bin to first order — its pixels at t̄ + δ see the model plus δ times its derivative —
/// which adds the bins' slopes Y/S (S = Σ δ², Y = Σ δ·y, from [`Bin`]'s sums) weighed by S,
/// exact up to the profile's curvature within ¼ px (`gram`; the free fit and the frequency's
/// refinement keep the means alone). Unseen family members, |gap| ≥ 3 K: mean |T2| 0.114 →
/// 0.110 K, exposed 0.75–0.85 at 6–10 px 0.48 → 0.46 K, the thesis's lattice 0.18 → 0.17 K;
/// seen members 0.113 → 0.111 K (their thin-stripe cells at 10–16 px 0.26 → 0.24 K, at 4–6 px
/// 0.64 → 0.67 K). Finer bins instead (16 per px, the means alone) bought less (0.112
/// K unseen) for 28 700 more Cortex-M4 instructions; the slopes, with the profile's pass
/// made cheaper (one array of bins, only the columns each row's core can reach), cost 3 470
/// (`bash scripts/bench-m4`, first frame).
const FINE: usize = 4;
/// Fine bins of the core's axial profile.
const FINE_BINS: usize = FINE * BINS;

/// Axial position `t` (pixels) in fine-bin widths from the profile's start `t0` (pixels): its
/// integer part is the pixel's bin, the rest its place τ within that bin (0…1), as [`Bin`]
/// keeps it.
#[inline(always)]
fn fine_place(t: f32, t0: f32) -> f32 {
    (t - t0) * FINE as f32
}

/// One fine bin of the core's axial profile: its pixels' sum of values less the reference,
/// count and sum of axial positions; Σ τ² and Σ τ·y, τ a pixel's place within the bin (bin
/// widths, 0…1): how far its pixels spread along the axis and how their values slope over it.
#[derive(Clone, Copy, Default)]
struct Bin {
    sum: f32,
    cnt: f32,
    tsum: f32,
    tt: f32,
    ty: f32,
}

/// The core's pixels binned along the axis (one pass over the columns each row's core can
/// reach): a [`Bin`] per ¼ px; with the core's count, mean and range. Bad pixels are left out
/// (the module docs): a few beyond both row neighbours, a lone extreme, and every pixel filled
/// in.
struct Profile {
    bins: [Bin; FINE_BINS],
    /// Fine bins in use (the last non-empty one + 1).
    used: usize,
    /// Axial position of bin 0's start, pixels.
    t0: f32,
    reference: f32,
    total: f32,
    mean_dev: f32,
    /// Σ of squared values less the reference, K².
    sq: f32,
    lo: f32,
    hi: f32,
}

impl Profile {
    fn of(
        img: &[f32; IMG_PIXELS],
        xy: &Coords,
        g: &Geometry,
        u_core: f32,
        bad_k: f32,
        filled: &FilledRows,
    ) -> Option<Profile> {
        // The smallest axial coordinate in the image is at a corner.
        let corners = [0, IMG_COLS - 1, (IMG_ROWS - 1) * IMG_COLS, IMG_PIXELS - 1];
        let mut tmin = f32::INFINITY;
        for p in corners {
            if xy.t[p] < tmin {
                tmin = xy.t[p];
            }
        }
        let t0 = floor(tmin);
        let mut p = Profile {
            bins: [Bin::default(); FINE_BINS],
            used: 0,
            t0,
            reference: 0.0,
            total: 0.0,
            mean_dev: 0.0,
            sq: 0.0,
            lo: f32::INFINITY,
            hi: f32::NEG_INFINITY,
        };
        let mut s = 0f32;
        // The second highest and lowest values, and the (bin, axial position) of the extremes.
        let (mut hi2, mut lo2) = (f32::NEG_INFINITY, f32::INFINITY);
        let (mut hi_at, mut lo_at) = ((0usize, 0f32), (0usize, 0f32));
        // Pixels beyond both row neighbours (value, axial position, index): the first ODD_MAX.
        let mut odd = [(0f32, 0f32, 0usize); ODD_MAX];
        let mut n_odd = 0usize;
        // Each row's core lies within u_core·w·√(1 + slope²) columns of the axis: only those
        // columns (and one more either side, for rounding) are looked at, in the same order.
        let reach =
            u_core * g.half_width_px * crate::fmath::sqrt(1.0 + g.axis_slope * g.axis_slope);
        // The values are kept less a reference near the core's, for the sums' precision: the
        // pixel on the axis in the middle row (the nearest column in the image).
        let mid = IMG_ROWS / 2;
        let axis_col = floor(g.axis_col0 + g.axis_slope * mid as f32 + 0.5);
        p.reference = img[mid * IMG_COLS + min(max(0.0, axis_col), (IMG_COLS - 1) as f32) as usize];
        // The columns of row r looked at: first..end.
        let columns = |r: usize| {
            let centre = g.axis_col0 + g.axis_slope * r as f32;
            let first = (floor(centre - reach) as i32).clamp(0, IMG_COLS as i32) as usize;
            let end = (floor(centre + reach) as i32 + 2).clamp(0, IMG_COLS as i32) as usize;
            (first.min(end), end)
        };
        for r in 0..IMG_ROWS {
            let (first, end) = columns(r);
            let row = r * IMG_COLS;
            // Whole rows of 32, indexed under a mask: no range checks in the loop (a row always
            // fits, so the fallbacks are never taken).
            let m = IMG_COLS - 1;
            let line: &[f32; IMG_COLS] = img[row..row + IMG_COLS]
                .try_into()
                .unwrap_or(&[0.0; IMG_COLS]);
            let us: &[f32; IMG_COLS] = xy.u[row..row + IMG_COLS]
                .try_into()
                .unwrap_or(&[0.0; IMG_COLS]);
            let ts: &[f32; IMG_COLS] = xy.t[row..row + IMG_COLS]
                .try_into()
                .unwrap_or(&[0.0; IMG_COLS]);
            for c in first..end {
                if us[c & m] < u_core {
                    let (t, v) = (ts[c & m], line[c & m]);
                    // Beyond both row neighbours: the left one first, the right one only past
                    // it — most pixels are not (the pixel itself at the image's sides).
                    let dl = v - line[c.wrapping_sub(1) & m];
                    if c > 0 && dl.abs() > bad_k {
                        let dr = v - line[(c + 1).min(m)];
                        if dl * dr > 0.0 && dr.abs() > bad_k {
                            if let Some(o) = odd.get_mut(n_odd) {
                                *o = (v, t, row + c);
                            }
                            n_odd += 1;
                        }
                    }
                    let q = fine_place(t, t0);
                    let b = (q as usize).min(FINE_BINS - 1);
                    let y = v - p.reference;
                    let tau = q - b as f32;
                    let bin = &mut p.bins[b];
                    bin.sum += y;
                    bin.cnt += 1.0;
                    bin.tsum += t;
                    bin.tt += tau * tau;
                    bin.ty += tau * y;
                    p.total += 1.0;
                    p.sq += y * y;
                    s += y;
                    if b >= p.used {
                        p.used = b + 1;
                    }
                    // Most pixels pass neither second extreme: one comparison each.
                    if v < lo2 {
                        if v < p.lo {
                            lo2 = p.lo;
                            p.lo = v;
                            lo_at = (b, t);
                        } else {
                            lo2 = v;
                        }
                    }
                    if v > hi2 {
                        if v > p.hi {
                            hi2 = p.hi;
                            p.hi = v;
                            hi_at = (b, t);
                        } else {
                            hi2 = v;
                        }
                    }
                }
            }
        }
        // Left out: a few pixels beyond both row neighbours, hot or dead pixels the EEPROM does
        // not flag (many are the lattice's own, thin stripes crossing the rows at a slant, and
        // stay), and every pixel that was broken and filled in from its neighbours (no
        // measurement of its place: across a thin stripe, the mean of both targets). The
        // core's range may keep another of them: it serves only the fallback's bound, which it
        // widens.
        let (mut hi_kept, mut lo_kept) = (true, true);
        let is_filled = |q: usize| (filled[q / IMG_COLS] >> (q % IMG_COLS)) & 1 != 0;
        let mut leave_out = |p: &mut Profile, v: f32, t: f32| {
            let b = (fine_place(t, t0) as usize).min(FINE_BINS - 1);
            p.drop(v, (b, t), &mut s);
            if (v, t) == (p.hi, hi_at.1) {
                p.hi = hi2;
                hi_kept = false;
            }
            if (v, t) == (p.lo, lo_at.1) {
                p.lo = lo2;
                lo_kept = false;
            }
        };
        if n_odd <= ODD_MAX {
            for &(v, t, q) in &odd[..n_odd] {
                if !is_filled(q) {
                    leave_out(&mut p, v, t);
                }
            }
        }
        for (r, &fill) in filled.iter().enumerate() {
            if fill == 0 {
                continue;
            }
            let (first, end) = columns(r);
            for c in first..end {
                let q = r * IMG_COLS + c;
                if (fill >> c) & 1 != 0 && xy.u[q] < u_core {
                    leave_out(&mut p, img[q], xy.t[q]);
                }
            }
        }
        // A lone pixel far beyond every other in the core (a hot or dead pixel the EEPROM does
        // not flag) is left out: one such pixel shifts its bin by its whole excess.
        if hi_kept && p.total > LONE_MIN_PIXELS && p.hi - hi2 > LONE_PIXEL_K {
            p.drop(p.hi, hi_at, &mut s);
            p.hi = hi2;
        }
        if lo_kept && p.total > LONE_MIN_PIXELS && lo2 - p.lo > LONE_PIXEL_K {
            p.drop(p.lo, lo_at, &mut s);
            p.lo = lo2;
        }
        (p.total > 0.0).then(|| {
            p.mean_dev = s / p.total;
            p
        })
    }

    /// Take the pixel of value `v` at (bin, axial position) `at` back out of the profile, and
    /// out of the running sum `s` of values less the reference.
    fn drop(&mut self, v: f32, (b, t): (usize, f32), s: &mut f32) {
        let y = v - self.reference;
        let tau = fine_place(t, self.t0) - b as f32;
        let bin = &mut self.bins[b];
        bin.sum -= y;
        bin.cnt -= 1.0;
        bin.tsum -= t;
        bin.tt -= tau * tau;
        bin.ty -= tau * y;
        self.total -= 1.0;
        self.sq -= y * y;
        *s -= y;
    }

    /// Pixels of axial length covered (1 px bins).
    fn length(&self) -> usize {
        self.used.div_ceil(FINE)
    }
}

/// The profile on 1 px bins, mean removed (bin b centred at t0 + b + ½), for the periodogram.
struct Coarse {
    y: [f32; BINS],
    used: usize,
    t0: f32,
    total: f32,
}

impl Coarse {
    fn of(p: &Profile) -> Coarse {
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
fn amplitude(p: &Coarse, nu: f32) -> f32 {
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
fn find_frequency(p: &Coarse, lo: f32, hi: f32, step: f32) -> Option<(f32, f32)> {
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

/// Per-pixel least squares at frequency `nu`: the normal matrix, its right-hand side, the
/// solution and the residual variance per pixel; with the bins' slopes (see [`FINE`]) for the
/// candidates' model.
struct HarmonicFit {
    n: usize,
    normal: [[f32; NP]; NP],
    /// Σ w·y·(1, cos kθ, sin kθ…) up to the candidates' model's harmonics.
    rhs: [f32; RHS],
    theta: [f32; NP],
    /// Σ w·cos mθ and Σ w·sin mθ, m = 0…2·(the model's harmonics): every entry of the normal
    /// matrix, the fit's and the model's (each half a sum or difference of two; [`gram`]).
    cs: [f32; 2 * HARMONICS + 1],
    sn: [f32; 2 * HARMONICS + 1],
    /// Σ w·y², K², and the bins in use.
    yy: f32,
    bins: f32,
    /// The bins' slopes (with `slopes`, else zero): Σ S·cos mθ and Σ S·sin mθ, S a bin's
    /// Σ (t − t̄)² (px²), m = 0…2·(the model's harmonics); Σ Y·(cos kθ, sin kθ), Y its
    /// Σ (t − t̄)·y (K·px), k = 1…(the model's harmonics), in the slots of [`Self::rhs`].
    ds_c: [f32; 2 * HARMONICS + 1],
    ds_s: [f32; 2 * HARMONICS + 1],
    dy: [f32; RHS],
    /// Σ Y²/S over the bins of more than one axial position, K², and how many: what their
    /// slopes add to Σ w·y² and to the bins.
    slope_yy: f32,
    slope_bins: f32,
    sigma2: f32,
    /// Pixel noise variance: the scatter of the pixels within a fine bin (same lattice
    /// phase), K².
    noise2: f32,
    /// Weighted residual sum of squares, K².
    rss: f32,
}

/// [`harmonic_fit_by`] at frequency `nu`, with the sums of the candidates' model up to `model`
/// harmonics and the bins' slopes.
fn harmonic_fit(p: &Profile, nu: f32, harmonics: usize, model: usize) -> Option<HarmonicFit> {
    harmonic_fit_by::<true>(p, harmonics, model, |_, t| sin_cos_turns(nu * t))
}

/// [`harmonic_fit`] with the fundamental's (sin, cos) at bin b, axial position t from
/// `angle(b, t)` (which may keep them for a second pass); the bins' slopes' sums only with
/// `SLOPES` (the frequency's refinement, [`gn_step`], does without).
fn harmonic_fit_by<const SLOPES: bool>(
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
fn harmonics_for(design_exposed: f32) -> usize {
    let thin = max(min(design_exposed, 1.0 - design_exposed), 0.05);
    // 1 + ⌈1/h⌉.
    ((1.0 - floor(-1.0 / thin)) as usize).clamp(BASE_HARMONICS, FIT_HARMONICS)
}

/// Harmonics of the candidates' model at most for a block whose design exposes
/// `design_exposed` of each unit: [`BASE_HARMONICS`] where the fit keeps them (the thesis's
/// block, whose camera-on cycle and standard scenes lost with more: [`MODEL_BAND_CPP`]), else
/// [`HARMONICS`], ten (the module docs). The fit keeps its six: the model's harmonics are fixed
/// by each candidate's stripe and spread, not unknowns.
fn model_for(design_exposed: f32) -> usize {
    if harmonics_for(design_exposed) > BASE_HARMONICS {
        HARMONICS
    } else {
        BASE_HARMONICS
    }
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
fn gn_step(p: &Profile, nu: f32, k: usize, angles: &mut [(f32, f32); FINE_BINS]) -> Option<f32> {
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

/// Solve the symmetric positive definite system `a·x = b` (size n) by Cholesky; `None` when a
/// pivot is not clearly positive (an ill-conditioned fit).
fn solve(a: &[[f32; NP]; NP], b: &[f32], n: usize) -> Option<[f32; NP]> {
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

/// One h of the grid: the colder temperature a (less the reference), the gap b, their
/// standard errors on (a + b) and a, and the misfit χ².
#[derive(Clone, Copy, Default)]
struct Candidate {
    a: f32,
    b: f32,
    /// Variance of the larger of T_hot, T_cold per unit pixel-noise variance.
    var: f32,
    chi2: f32,
}

/// 2/(πk), k = 1…[`HARMONICS`] (index k − 1): a stripe's k-th harmonic per unit gap and
/// unit transfer is 2·sin(πkh)/(πk).
const TWO_OVER_PI_K: [f32; HARMONICS] = {
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
struct Trig {
    sin: [f32; HARMONICS],
    cos: [f32; 2 * HARMONICS + 1],
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
    fn of(h: f32) -> Trig {
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
struct Spread {
    m00: f32,
    ur0: f32,
    a: [f32; HARMONICS],
    r: [f32; HARMONICS],
    q: [f32; 2 * HARMONICS + 1],
}

impl Spread {
    /// The sums of one spread whose transfers (harmonic k at `mtf[k − 1]`) are `mtf`, for a
    /// model of `model` harmonics, in loops of the fixed length `K` (≥ `model`; the rest zero).
    #[inline(always)]
    fn of<const K: usize>(
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
    fn row<const K: usize>(
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
    fn products<const K: usize>(&self, h: f32, t: &Trig) -> [(f32, f32, f32); 2] {
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
    fn of(g00: f32, r0: f32, yy: f32, (g01, g11, rv): (f32, f32, f32)) -> Candidate {
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
enum Hyp {
    HeaterHot,
    SurfaceHot,
}

/// Write [`transfer`] at the first `model` harmonics of `nu` (cycles per pixel, along an axis
/// of slope `slope`) and each spread of [`PSF_SIGMAS_PX`] into `mtf` (`mtf[spread][k]`): the
/// footprint's two boxes, cos α and sin α wide, their sines at k·ν by the angle-sum step from
/// ν's, times the Gaussian's: the spreads are multiples i·δ of one step, so
/// exp(−2(πσkν)²) = E_k^(i²) with E_k = E_1^(k²), both stepped by products (one `expf` in all).
fn transfers(nu: f32, slope: f32, model: usize, mtf: &mut [[f32; HARMONICS]; PSFS]) {
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
fn gram(
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
fn h_at(j: usize) -> f32 {
    H_FIRST + (j % H_COUNT) as f32 * H_STEP
}

/// The exposed fractions a frame of a block designed with `design` may show.
fn window(design: f32) -> (f32, f32) {
    (
        max(design - EXPOSED_TOLERANCE, EXPOSED_MIN) - 1e-4,
        min(design + EXPOSED_TOLERANCE, EXPOSED_MAX) + 1e-4,
    )
}

/// The grid indices `i` (h = h_at(i)) a hypothesis allows in the window `(lo, hi)` of exposed
/// fractions: a range, empty when none. The surface-hot range is the heater-hot one's mirror
/// (h ↔ 1 − h, i ↔ `H_COUNT` − 1 − i; the grid is symmetric about ½), which lets a candidate's
/// products serve both ([`Spread::products`]).
fn h_range(hyp: Hyp, (lo, hi): (f32, f32)) -> core::ops::Range<usize> {
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

/// χ² above the best point beyond which [`posterior`] leaves a point out (its weight
/// e^(−Δ/2) < 3.4·10⁻⁴).
const POSTERIOR_CHI2: f32 = 16.0;
/// The posterior means of a, b and h.
struct Posterior {
    a: f32,
    b: f32,
    /// h less the window's first, in grid steps.
    h_steps: f32,
}

/// The value midway between points `i` and `i + 1` of `n` (≥ 2) equally spaced values `f`:
/// the cubic through the four around it, the quadratic through three at an end, the line
/// between two.
fn midpoint(f: impl Fn(usize) -> f32, i: usize, n: usize) -> f32 {
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
const POSTERIOR_SHARPEN: f32 = 4.0;

/// Second difference over one h step of the posterior's χ² (sharpened, see
/// [`POSTERIOR_SHARPEN`]) above which a spread's row is sharp: its posterior's width in h,
/// √(2/Δ²χ²) steps, is under half a step, finer than the half steps (see [`posterior`]).
const POSTERIOR_SHARP: f32 = 8.0;

/// A sharp row's χ² parabola through its best h and their neighbours, at its vertex: χ², a, b,
/// the place in half h steps, and the row's weight against one point of the half-step grid
/// (the Gaussian's integral, √(4π/Δ²χ²) steps, over half a step).
struct Vertex {
    chi2: f32,
    a: f32,
    b: f32,
    half_steps: f32,
    mass: f32,
}

/// [`Vertex`] of the row `r` whose best candidate is `k`, if the row is sharp (its second
/// difference of χ² times `sharpen` exceeds [`POSTERIOR_SHARP`]) and `k` is not at the
/// window's ends.
fn sharp_vertex(r: &[Candidate], k: usize, sharpen: f32) -> Option<Vertex> {
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
fn posterior<'a>(row: impl Fn(usize) -> &'a [Candidate], nh: usize, sharpen: f32) -> Posterior {
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

/// Estimate the lattice and separate T1 from T2 on the inpainted image `img` under the
/// cylinder geometry `g` (its lattice fields are updated), with the coordinates `xy` of `g`;
/// `range_k` is the frame's range (hottest less coldest pixel, K), which scales the test for
/// bad pixels (the module docs); the pixels of `filled` were broken and filled in, and are left
/// out of the fit.
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
    let win = window(design_exposed);
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
        };
    };
    let core = Core {
        reference: prof.reference,
        mean: prof.reference + prof.mean_dev,
        lo: prof.lo,
        hi: prof.hi,
    };
    let fallback = Separation {
        t1_k: core.mean,
        t2_k: core.mean,
        mean_k: core.mean,
        bound_k: 0.5 * (core.hi - core.lo),
        quality: Quality::Fallback,
    };
    let length = prof.length() as f32;
    let p_max = min(PERIOD_MAX_PX, length / 1.2);
    let (lo, hi, step) = if g.lattice_known {
        let nu = 1.0 / g.period_px;
        (0.88 * nu, 1.12 * nu, 0.004)
    } else {
        (1.0 / p_max, 1.0 / PERIOD_MIN_PX, FREQ_STEP)
    };
    let coarse = Coarse::of(&prof);
    let found = find_frequency(
        &coarse,
        max(lo, 1.0 / p_max),
        min(hi, 1.0 / PERIOD_MIN_PX),
        step,
    )
    .filter(|&(_, amp)| amp >= MIN_LATTICE_K);
    // Not seen this frame (too little contrast): the previous lattice measures, unchanged.
    let kept = *g;
    let nu = match (found, g.lattice_known) {
        (Some((nu, _)), _) => nu,
        (None, true) => 1.0 / g.period_px,
        (None, false) => return fallback,
    };
    // The periodogram's peak is biased when the core shows few periods, the more so when its
    // stripes are thin (their harmonics, which the periodogram leaves out, pull the fundamental's
    // peak): a Gauss–Newton step of the frequency in the least-squares fit of the mean and the
    // fundamental, which converges from farther, then one in the fit with three harmonics.
    let mut nu = nu;
    let mut angles = [(0f32, 0f32); FINE_BINS];
    for k in [1, REFINE_HARMONICS] {
        if let Some(d) = gn_step(&prof, nu, ((0.75 / nu) as usize).clamp(1, k), &mut angles) {
            nu += clamp(d, -REFINE_LIMIT * nu, REFINE_LIMIT * nu);
        }
    }
    // Harmonics below 0.75 cycles per pixel (past Nyquist, a tilted axis samples the profile
    // at many sub-pixel positions); fewer when the fit is ill-conditioned (an untilted axis
    // aliases them onto each other).
    let mut harmonics = ((0.75 / nu) as usize).clamp(1, harmonics_for(design_exposed));
    // The candidates' model reaches further (MODEL_BAND_CPP): its sums come from the same pass.
    let model = ((MODEL_BAND_CPP / nu) as usize).clamp(harmonics, model_for(design_exposed));
    let fit = loop {
        match harmonic_fit(&prof, nu, harmonics, model) {
            Some(f) => break Some(f),
            None if harmonics > 1 => harmonics -= 1,
            None => break None,
        }
    };
    let Some(fit) = fit else {
        return if g.lattice_known {
            Separation {
                quality: Quality::Merged,
                ..fallback
            }
        } else {
            fallback
        };
    };
    let (a1, b1) = (fit.theta[1], fit.theta[2]);
    let r1 = max(1e-12, crate::fmath::sqrt(a1 * a1 + b1 * b1));
    let (cpsi, spsi) = (a1 / r1, b1 / r1);
    let mut mtf = [[0f32; HARMONICS]; PSFS];
    transfers(nu, g.axis_slope, model, &mut mtf);
    let g00 = fit.cs[0];
    let r0 = fit.rhs[0];
    // The model's coefficients per unit gap are v = Σ_k c_k·u_k with u_0 = e_0 (weight h)
    // and u_k = (cos kψ, sin kψ) in harmonic k's slots (weight 2·S_k(h)·H_k), k up to the
    // model's harmonics: the Gram matrix m = uᵀ·N·u and uᵀ·rhs, computed once, make each
    // candidate a (1 + H) × (1 + H) product, and its misfit Σ w·y² less what it explains.
    let (mut m, mut ur) = ([[0f32; U]; U], [0f32; U]);
    gram(&fit, model, nu, (cpsi, spsi), &mut m, &mut ur);
    // Per h, 2·S_k(h) = 2·sin(πkh)/(πk), shared by every spread.
    let (range_a, range_b) = (h_range(Hyp::HeaterHot, win), h_range(Hyp::SurfaceHot, win));
    // Only the two windows' candidates are computed and kept: key = spread·2·SLOTS + the
    // window's base (0 heater hot, SLOTS surface hot) + the h's place in the window (a few
    // hundred bytes of stack, not the whole grid's). Windows that overlap (a design near 50 %)
    // compute their common h twice.
    let base_of = |hyp: Hyp| match hyp {
        Hyp::HeaterHot => 0,
        Hyp::SurfaceHot => SLOTS,
    };
    let range_of = |hyp: Hyp| match hyp {
        Hyp::HeaterHot => range_a.clone(),
        Hyp::SurfaceHot => range_b.clone(),
    };
    // A key's hypothesis and its h's place in that hypothesis's window.
    let slot_of = |key: usize| {
        let w = key % (2 * SLOTS);
        if w < SLOTS {
            (Hyp::HeaterHot, w)
        } else {
            (Hyp::SurfaceHot, w - SLOTS)
        }
    };
    // Keys outside the windows keep an infinite misfit (the passes below run over all).
    let mut cand = [Candidate {
        chi2: f32::INFINITY,
        ..Candidate::default()
    }; CANDIDATES];
    // Per place of the heater-hot window, the stripe's harmonics' sines sin(πkh), k = 1…, and
    // the cosines cos(πnh), n = 0…, of its h: with each spread's sums below, a candidate's
    // products are three dot products, and its mirror's (1 − h, the surface-hot window's) the
    // same sums split by parity ([`Spread`]).
    let mut trig = [Trig::default(); SLOTS];
    for (t, i) in trig.iter_mut().zip(range_a.clone()) {
        *t = Trig::of(h_at(i));
    }
    // Each candidate's misfit Σ w·r² first, its χ² once the noise is known.
    let mut rss_min = f32::INFINITY;
    // The design's prior, z² per place of the two windows: the exposed fraction a candidate
    // says the frame shows, against the design.
    let inv_prior_sd = 1.0 / EXPOSED_PRIOR_SD;
    let mut prior_chi2 = [0f32; 2 * SLOTS];
    for hyp in [Hyp::HeaterHot, Hyp::SurfaceHot] {
        for (k, i) in range_of(hyp).enumerate() {
            let exposed = if hyp == Hyp::HeaterHot {
                h_at(i)
            } else {
                1.0 - h_at(i)
            };
            let z = (exposed - design_exposed) * inv_prior_sd;
            prior_chi2[base_of(hyp) + k] = z * z;
        }
    }
    // The products run to an even length: the model's harmonics, or a base model's rounded up
    // (its sums past the model are zero).
    let base_model = model <= BASE_PAIRS;
    let fit_yy = fit.yy + fit.slope_yy;
    let na = range_a.len();
    for psf in 0..PSFS {
        let spread = if base_model {
            Spread::of::<BASE_PAIRS>(&m, &ur, &mtf[psf], model)
        } else {
            Spread::of::<HARMONICS>(&m, &ur, &mtf[psf], model)
        };
        let first = psf * 2 * SLOTS;
        for (slot, i) in range_a.clone().enumerate() {
            let t = &trig[slot];
            let h = h_at(i);
            let [pa, pb] = if base_model {
                spread.products::<BASE_PAIRS>(h, t)
            } else {
                spread.products::<HARMONICS>(h, t)
            };
            // The heater-hot candidate h, and its mirror 1 − h: the surface-hot window's place
            // na − 1 − slot.
            for (key, products) in [(first + slot, pa), (first + SLOTS + na - 1 - slot, pb)] {
                let c = Candidate::of(g00, r0, fit_yy, products);
                if c.chi2 < rss_min {
                    rss_min = c.chi2;
                }
                cand[key] = c;
            }
        }
    }
    // The noise: the best candidate's misfit per degree of freedom (the model holds the
    // stripes' harmonics to the model's band; what is left is the pixels' noise, and what the
    // model still misses), floored as the fit's.
    let sigma2 = (rss_min / (fit.bins + fit.slope_bins - MODEL_PARAMETERS).max(1.0))
        .max(NOISE_FLOOR_K * NOISE_FLOOR_K);
    let inv_sigma2 = 1.0 / sigma2;
    for row in cand.chunks_exact_mut(2 * SLOTS) {
        for (c, z2) in row.iter_mut().zip(&prior_chi2) {
            c.chi2 = c.chi2 * inv_sigma2 + z2;
        }
    }
    // The best candidate (its key) of a hypothesis at the spreads `psfs`.
    let best_in = |hyp: Hyp, psfs: core::ops::Range<usize>| {
        let mut best: Option<usize> = None;
        let (base, nh) = (base_of(hyp), range_of(hyp).len());
        for psf in psfs {
            let first = psf * 2 * SLOTS + base;
            for j in first..first + nh {
                if best.is_none_or(|b| cand[j].chi2 < cand[b].chi2) {
                    best = Some(j);
                }
            }
        }
        best
    };
    let (ia, ib) = (
        best_in(Hyp::HeaterHot, 0..PSFS),
        best_in(Hyp::SurfaceHot, 0..PSFS),
    );
    let chi2_of = |i: Option<usize>| i.map_or(f32::INFINITY, |i| cand[i].chi2);
    let (ca, cb) = (chi2_of(ia), chi2_of(ib));
    let (bonus_a, bonus_b, informed) = match (prior, g.heater_hotter) {
        (Prior::HeaterHotter, _) => (PRIOR_CHI2, 0.0, true),
        (Prior::SurfaceHotter, _) => (0.0, PRIOR_CHI2, true),
        (Prior::Unknown, Some(true)) => (CONTINUITY_CHI2, 0.0, true),
        (Prior::Unknown, Some(false)) => (0.0, CONTINUITY_CHI2, true),
        (Prior::Unknown, None) => (0.0, 0.0, false),
    };
    // A clear spatial verdict stands whatever the prior says; between hypotheses the image
    // both allows, the prior (or the previous frame) picks.
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
    let decided = informed || clear;
    // (T1, T2) of a candidate under a hypothesis, K.
    let temps = |c: &Candidate, hyp: Hyp| {
        let (hot, cold) = (core.reference + c.a + c.b, core.reference + c.a);
        match hyp {
            Hyp::HeaterHot => (hot, cold),
            Hyp::SurfaceHot => (cold, hot),
        }
    };
    // At least one hypothesis has a window (the design is within EXPOSED_MIN…EXPOSED_MAX).
    let chosen = if hyp == Hyp::HeaterHot { ia } else { ib };
    let ibest = chosen.or(ia).or(ib).unwrap_or(0);
    // The estimate: the posterior mean over the hypothesis's window (h) and the spreads (σ),
    // not the grid's best point. Along the valley where a thin stripe's level trades against
    // its width and the optics' spread, χ² is nearly flat, and its minimum wanders with the
    // noise to the window's or the spreads' ends; where it is sharp, the grid's steps are
    // coarse against it. See [`posterior`].
    let (hyp_best, _) = slot_of(ibest);
    let post = {
        let (base, nh) = (base_of(hyp_best), range_of(hyp_best).len());
        // A hypothesis's candidates at one spread lie side by side, in h order.
        let row = |psf: usize| &cand[psf * 2 * SLOTS + base..][..nh];
        // χ² is against the best candidate's residual variance, which holds the model's
        // mismatch as well as the pixels' noise (their scatter within a fine bin); the
        // posterior takes the noise, but no less than 1/POSTERIOR_SHARPEN of the residual
        // variance.
        let ratio = sigma2 / fit.noise2;
        posterior(
            row,
            nh,
            if ratio < POSTERIOR_SHARPEN {
                ratio
            } else {
                POSTERIOR_SHARPEN
            },
        )
    };
    let best = Candidate {
        a: post.a,
        b: post.b,
        ..cand[ibest]
    };
    let (t1, t2) = temps(&best, hyp);
    let mean = core.reference + fit.theta[0];
    // Envelopes over the confidence sets: around the estimate, and around the mean.
    let mut spread = 0f32;
    let mut merged_spread = 0f32;
    for hy in [Hyp::HeaterHot, Hyp::SurfaceHot] {
        let cmin = if hy == Hyp::HeaterHot { ca } else { cb };
        let (base, nh) = (base_of(hy), range_of(hy).len());
        for j in (0..PSFS).flat_map(|psf| psf * 2 * SLOTS + base..psf * 2 * SLOTS + base + nh) {
            let c = &cand[j];
            if c.chi2 > cmin + CONFIDENCE_CHI2 {
                continue;
            }
            let (x1, x2) = temps(c, hy);
            let sd = crate::fmath::sqrt(fit.noise2 * c.var);
            let m = max(libm::fabsf(x1 - mean), libm::fabsf(x2 - mean)) + 2.0 * sd;
            if m > merged_spread {
                merged_spread = m;
            }
            // The chosen hypothesis's set, and, when the image allows the other one too (no
            // clear verdict: the prior or the previous frame picked), the other's: a wrong
            // pick lies within that.
            if hy == hyp || !clear {
                let e = max(libm::fabsf(x1 - t1), libm::fabsf(x2 - t2)) + 2.0 * sd;
                spread = max(spread, e);
            }
        }
    }
    // The spread is a grid: the truth lies between two of its values. What the best candidate
    // would be at the neighbouring spreads (each one's best h in the hypothesis) is within the
    // bound too.
    let psf_best = ibest / (2 * SLOTS);
    for psf in [psf_best.wrapping_sub(1), psf_best + 1] {
        if psf >= PSFS {
            continue;
        }
        if let Some(j) = best_in(hyp, psf..psf + 1) {
            let (x1, x2) = temps(&cand[j], hyp);
            let e = max(libm::fabsf(x1 - t1), libm::fabsf(x2 - t2));
            if e > spread {
                spread = e;
            }
        }
    }
    // Calibrated on the seen seeds: what the grids and the model's approximations (the core's
    // straight edges, the footprint's two boxes) add.
    let spread = BOUND_SCALE * spread + BOUND_FLOOR_K;
    let merged_spread = BOUND_SCALE * merged_spread + BOUND_FLOOR_K;
    // The lattice as zones see it: the heater stripes start at `phase`.
    let period = 1.0 / nu;
    let h = h_at(range_of(hyp_best).start) + post.h_steps * H_STEP;
    let centre = libm::atan2f(spsi, cpsi) / core::f32::consts::TAU * period;
    let (exposed, start) = match hyp {
        Hyp::HeaterHot => (h, centre - 0.5 * h * period),
        Hyp::SurfaceHot => (1.0 - h, centre + 0.5 * h * period),
    };
    g.period_px = period;
    g.phase_px = start - floor(start / period) * period;
    g.exposed = exposed;
    g.lattice_known = true;
    if decided {
        g.heater_hotter = Some(hyp == Hyp::HeaterHot);
    }
    if found.is_none() {
        *g = kept;
    }
    // A period the refinement took past the longest searched (the periodogram peaked at the
    // search's end: no lattice the core shows, a trend or a hot pixel) never resolves.
    let in_range = period <= p_max;
    let small = |b: f32| {
        in_range && (b <= RESOLVED_BOUND_K || b <= RESOLVED_FRACTION * libm::fabsf(t1 - t2))
    };
    if decided {
        // T1 and T2 are the fit's: resolved when the bound (spanning both assignments where
        // the image allowed both) is small, else ambiguous — the fit's values with that
        // bound, still far closer than the mean the merged frame gives both.
        let quality = if small(spread) {
            Quality::Resolved
        } else {
            Quality::Ambiguous
        };
        Separation {
            t1_k: t1,
            t2_k: t2,
            mean_k: mean,
            bound_k: spread,
            quality,
        }
    } else {
        Separation {
            t1_k: mean,
            t2_k: mean,
            mean_k: mean,
            bound_k: merged_spread,
            quality: Quality::Merged,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let all =
            Profile::of(&clean, &xy, &g, u_core, f32::INFINITY, &[0; IMG_ROWS]).expect("a core");
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
        // within [1 − hi, 1 − lo] for every design the configuration accepts (15–90 %): the
        // candidates' mirror products are its own.
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
                (if i == j { 2.0 } else { 0.0 })
                    + 1.0 / (1.0 + d * d)
                    + 0.1 / (1.0 + (i + j) as f32)
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
}
