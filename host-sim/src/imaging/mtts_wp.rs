//! `host-sim mtts-wp`: the MTTS work-precision table — speed against error.
//!
//! This module owns the measurement behind `docs/mtts-work-precision.md` and its rendering:
//! - for every upsampling factor s × clustering method, over the standard scenes × noise seeds
//!   × method seeds ([`measure`]): |T1 − truth| and |T2 − truth| (mean, max), the SSE gap to
//!   the optimum, the run-to-run spread over method seeds, host ns per frame;
//! - the optimum ([`optimal_sse`]): exact 1-D k-means in f64 of the very values the pipeline
//!   clusters — the filled image upsampled by the firmware's own upsampler, clamped to the
//!   image's range as its histogram does — on the sorted values by dynamic programming with
//!   the divide-and-conquer speed-up (O(K·n·log n), exact because the optimal split is
//!   monotone), independent of the firmware's binned solver;
//! - Cortex-M4 instruction counts parsed from a saved `scripts/bench-m4` output ([`M4Counts`]);
//! - the roots table (variant, max |ΔTo| against the f64 reference of [`crate::imaging::to_roots`],
//!   to_768 instructions) and the Pareto fronts of both tables ([`pareto`]);
//! - the scene family ([`crate::imaging::view_family`]): T1/T2 error distributions by lattice period
//!   and gap on the tuning seeds and on unseen ones, quality, swaps ([`family_outcomes`],
//!   [`family_markdown`]), beside what the views hold ([`crate::imaging::view_limit`]); and
//!   lattices unlike the default design, on their first frame and settled after
//!   [`SETTLED_FRAMES`] frames of one pipeline ([`member_outcome_settled`],
//!   [`unlike_design_markdown`]).

use std::collections::HashMap;
use std::fmt::Write as _;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;
use thermorph::mtts::upsample::{UpsampleScratch, Upsampler};
use thermorph::mtts::{self, Config, IMG_PIXELS, Method, Mtts, Prior, Quality, Scratch};
use thermorph::units::k_or_nan;

use anyhow::{Context as _, bail};

use crate::imaging::SensingError;
use crate::imaging::mtts_cli::method_name;
use crate::imaging::to_roots;
use crate::imaging::view::{Scene, standard_scenes};
use crate::imaging::view_family::Member;
use crate::imaging::view_limit;

/// Options of `host-sim mtts-wp`.
#[derive(Args, Clone, Debug)]
pub struct WpArgs {
    /// A saved `scripts/bench-m4` output: the M4 instruction columns (empty without it).
    #[arg(long)]
    pub m4: Option<PathBuf>,
    /// Write the markdown here instead of standard output.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Noise seeds per scene, and method seeds per image (≥ 2 for a spread).
    #[arg(long, default_value_t = 5)]
    pub seeds: u64,
    /// Scene-family members per seed range (tuning seeds, unseen seeds); the full run: 3000.
    #[arg(long, default_value_t = 300)]
    pub family: u64,
    /// Print only the scene-family section (no standard scenes, no sensor data needed).
    #[arg(long)]
    pub family_only: bool,
    /// Add the exact Bayesian estimate that knows the view's geometry to the family's table by
    /// exposed fraction and period (`view_limit::exact_bayes`; a minute more on two cores).
    #[arg(long)]
    pub bayes: bool,
    /// Print only the confidently wrong frames of the lattices unlike their design (the
    /// table's last column), a line each: seed, period, exposed fraction, spread, gap, errors
    /// and bound, to look at one member (`view_family::unlike_design(seed)`).
    #[arg(long, conflicts_with_all = ["family_only", "bayes", "m4", "out"])]
    pub wrong: bool,
}

/// What to measure.
#[derive(Clone, Debug)]
pub struct WpConfig {
    /// Upsampling factors.
    pub scales: Vec<u8>,
    /// Clustering methods.
    pub methods: Vec<Method>,
    /// Scenes.
    pub scenes: Vec<Scene>,
    /// Noise seeds 1…n per scene.
    pub noise_seeds: u64,
    /// Method seeds 1…n per image.
    pub method_seeds: u64,
    /// Timed passes over the scenes per setting (the median is reported); 0: no timing.
    pub timing_repeats: usize,
}

impl WpConfig {
    /// The full table: s ∈ {1, 2, 4, 8} × the three methods × the twelve standard scenes,
    /// `seeds` noise seeds and `seeds` method seeds.
    pub fn full(seeds: u64) -> Self {
        WpConfig {
            scales: vec![1, 2, 4, 8],
            methods: vec![Method::Exact, Method::Lloyd, Method::KMeansPlusPlus],
            scenes: standard_scenes().to_vec(),
            noise_seeds: seeds,
            method_seeds: seeds,
            timing_repeats: 15,
        }
    }
}

/// One row of the work-precision table.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// Upsampling factor.
    pub scale: u8,
    /// Clustering method.
    pub method: Method,
    /// Mean |T1 − truth| over all runs, K.
    pub t1_mean_err_k: f64,
    /// Largest |T1 − truth|, K.
    pub t1_max_err_k: f64,
    /// Mean |T2 − truth|, K.
    pub t2_mean_err_k: f64,
    /// Largest |T2 − truth|, K.
    pub t2_max_err_k: f64,
    /// Mean relative SSE gap to the optimum, (SSE − SSE_opt)/SSE_opt.
    pub gap_mean: f64,
    /// Largest relative SSE gap.
    pub gap_max: f64,
    /// Smallest relative SSE gap (≥ 0 up to rounding: nothing beats the optimum).
    pub gap_min: f64,
    /// Largest max − min of T1 or T2 over the method seeds for one image, K.
    pub spread_max_k: f64,
    /// Mean over images of that spread (the larger of T1's and T2's), K.
    pub spread_mean_k: f64,
    /// Median host time of one frame (the whole MTTS, a first frame), ns; `None` untimed.
    pub host_ns_per_frame: Option<f64>,
    /// Cortex-M4 instructions of the whole MTTS of one frame (bench-m4), if known.
    pub m4_insns: Option<u64>,
    /// Runs (images × method seeds).
    pub runs: usize,
}

impl Row {
    /// The larger of the mean T1 and T2 errors, K.
    pub fn mean_err_k(&self) -> f64 {
        self.t1_mean_err_k.max(self.t2_mean_err_k)
    }

    /// The larger of the max T1 and T2 errors, K.
    pub fn max_err_k(&self) -> f64 {
        self.t1_max_err_k.max(self.t2_max_err_k)
    }
}

/// The upsampled values the pipeline clusters for `filled` (an inpainted image) at `scale`:
/// the bicubic output clamped to the image's range, sorted ascending.
pub fn upsampled_sorted(filled: &[f32; IMG_PIXELS], scale: u8) -> Result<Vec<f64>, SensingError> {
    let up = Upsampler::new(scale).map_err(SensingError::Mtts)?;
    let (lo, hi) = filled
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let mut sc = Box::new(UpsampleScratch::new());
    let (r, c) = up.out_size();
    let mut v = Vec::with_capacity(r * c);
    up.run(filled, &mut sc, |_, row| {
        v.extend(row.iter().map(|&x| x.clamp(lo, hi) as f64))
    });
    v.sort_by(f64::total_cmp);
    Ok(v)
}

/// The least SSE of `sorted` (ascending) split into at most `k` groups, K², in f64.
///
/// Dynamic programming over prefix sums of the values (shifted by their mean for precision):
/// `D[m][j] = min_{i ≤ j} D[m−1][i−1] + cost(i, j)`, each layer by divide and conquer on the
/// monotone optimal split (Grønlund et al. 2017) — exact, O(k·n·log n).
pub fn optimal_sse(sorted: &[f64], k: usize) -> f64 {
    let n = sorted.len();
    if n == 0 || k == 0 {
        return 0.0;
    }
    let mean = sorted.iter().sum::<f64>() / n as f64;
    let mut s1 = vec![0.0; n + 1];
    let mut s2 = vec![0.0; n + 1];
    for (i, &x) in sorted.iter().enumerate() {
        let d = x - mean;
        s1[i + 1] = s1[i] + d;
        s2[i + 1] = s2[i] + d * d;
    }
    // SSE of values i..=j.
    let cost = |i: usize, j: usize| {
        let m = (j + 1 - i) as f64;
        let a = s1[j + 1] - s1[i];
        (s2[j + 1] - s2[i] - a * a / m).max(0.0)
    };
    let mut prev: Vec<f64> = (0..n).map(|j| cost(0, j)).collect();
    let mut cur = vec![0.0; n];
    for m in 1..k.min(n) {
        // cur[j] for j ≥ m: the last group starts at i ∈ m..=j.
        let mut stack = vec![(m, n - 1, m, n - 1)];
        while let Some((lo, hi, olo, ohi)) = stack.pop() {
            let j = (lo + hi) / 2;
            let (mut best, mut bi) = (f64::INFINITY, olo);
            for i in olo..=ohi.min(j) {
                let c = prev[i - 1] + cost(i, j);
                if c < best {
                    best = c;
                    bi = i;
                }
            }
            cur[j] = best;
            if j > lo {
                stack.push((lo, j - 1, olo, bi));
            }
            if j < hi {
                stack.push((j + 1, hi, bi, ohi));
            }
        }
        for j in 0..m {
            cur[j] = 0.0; // j + 1 ≤ m values in m + 1 groups: no error
        }
        std::mem::swap(&mut prev, &mut cur);
    }
    prev[n - 1]
}

/// The SSE of `sorted` split where `clusters` puts its boundaries (each group about its own
/// mean), K²: the partition a method's result induces on the unbinned values.
pub fn partition_sse(sorted: &[f64], clusters: &mtts::cluster::Clusters) -> f64 {
    let mut n = [0f64; mtts::cluster::MAX_K];
    let mut s1 = [0f64; mtts::cluster::MAX_K];
    let mut s2 = [0f64; mtts::cluster::MAX_K];
    let shift = sorted.iter().sum::<f64>() / sorted.len().max(1) as f64;
    for &x in sorted {
        let c = clusters.label(x as f32);
        let d = x - shift;
        n[c] += 1.0;
        s1[c] += d;
        s2[c] += d * d;
    }
    (0..mtts::cluster::MAX_K)
        .filter(|&c| n[c] > 0.0)
        .map(|c| (s2[c] - s1[c] * s1[c] / n[c]).max(0.0))
        .sum()
}

/// Run the measurement of `cfg` (M4 columns empty: see [`M4Counts::fill`]).
pub fn measure(cfg: &WpConfig) -> Result<Vec<Row>, SensingError> {
    let k = Config::default().k as usize;
    let mut scratch = Box::new(Scratch::new());
    // Render each image once; keep it with its inpainted copy and truth.
    let mut images = Vec::new();
    for s in &cfg.scenes {
        for seed in 1..=cfg.noise_seeds {
            let r = s.render(seed);
            let mut filled = r.image_k;
            mtts::inpaint(&mut filled)
                .map_err(|err| SensingError::Inpaint { scene: s.name, err })?;
            images.push((r.image_k, filled, r.truth_k));
        }
    }
    let mut rows = Vec::new();
    for &scale in &cfg.scales {
        // The optimum of each image at this factor.
        let mut prepared = Vec::new();
        for (img, filled, truth) in &images {
            let v = upsampled_sorted(filled, scale)?;
            let opt = optimal_sse(&v, k);
            prepared.push((img, v, opt, truth));
        }
        for &method in &cfg.methods {
            let (mut e1, mut e2) = (Vec::new(), Vec::new());
            let mut gaps = Vec::new();
            let mut spreads = Vec::new();
            for (img, v, opt, truth) in &prepared {
                let (mut t1s, mut t2s) = (Vec::new(), Vec::new());
                for mseed in 1..=cfg.method_seeds {
                    let mut m = Mtts::new(Config {
                        scale,
                        method,
                        seed: mseed,
                        ..Config::default()
                    })
                    .map_err(SensingError::Mtts)?;
                    // The mode's prior (heating: heater hotter; forming: surface hotter).
                    m.set_prior(if truth[0] >= truth[1] {
                        Prior::HeaterHotter
                    } else {
                        Prior::SurfaceHotter
                    });
                    let out = m.process(img, &mut scratch).map_err(SensingError::Mtts)?;
                    // The clustering's T1 and T2 (what s and the method change); the lattice
                    // fit's are in the family section.
                    let (t1, t2) = (
                        k_or_nan(out.clustered[0]) as f64,
                        k_or_nan(out.clustered[1]) as f64,
                    );
                    // A missing region (NaN) is an infinite error.
                    let err = |t: f64, want: f64| {
                        let d = (t - want).abs();
                        if d.is_nan() { f64::INFINITY } else { d }
                    };
                    e1.push(err(t1, truth[0]));
                    e2.push(err(t2, truth[1]));
                    t1s.push(t1);
                    t2s.push(t2);
                    let sse = partition_sse(v, &out.clusters);
                    gaps.push(if *opt > 0.0 { (sse - opt) / opt } else { 0.0 });
                }
                let range = |t: &[f64]| {
                    let (a, b) = t
                        .iter()
                        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                            (a.min(x), b.max(x))
                        });
                    b - a
                };
                spreads.push(range(&t1s).max(range(&t2s)));
            }
            let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len().max(1) as f64;
            let max = |x: &[f64]| x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let min = |x: &[f64]| x.iter().copied().fold(f64::INFINITY, f64::min);
            let host_ns = if cfg.timing_repeats > 0 {
                Some(time_per_frame_ns(cfg, scale, method, &mut scratch)?)
            } else {
                None
            };
            rows.push(Row {
                scale,
                method,
                t1_mean_err_k: mean(&e1),
                t1_max_err_k: max(&e1),
                t2_mean_err_k: mean(&e2),
                t2_max_err_k: max(&e2),
                gap_mean: mean(&gaps),
                gap_max: max(&gaps),
                gap_min: min(&gaps),
                spread_max_k: max(&spreads),
                spread_mean_k: mean(&spreads),
                host_ns_per_frame: host_ns,
                m4_insns: None,
                runs: e1.len(),
            });
        }
    }
    Ok(rows)
}

/// Median over `cfg.timing_repeats` passes of the host time of one frame's whole MTTS (a first
/// frame: the pipeline is reset before each), over the scenes rendered with noise seed 1, ns.
fn time_per_frame_ns(
    cfg: &WpConfig,
    scale: u8,
    method: Method,
    scratch: &mut Scratch,
) -> Result<f64, SensingError> {
    let imgs: Vec<[f32; IMG_PIXELS]> = cfg.scenes.iter().map(|s| s.render(1).image_k).collect();
    let mut m = Mtts::new(Config {
        scale,
        method,
        ..Config::default()
    })
    .map_err(SensingError::Mtts)?;
    let mut pass = |m: &mut Mtts| -> Result<f64, SensingError> {
        let t0 = Instant::now();
        for img in &imgs {
            m.reset();
            let out = m
                .process(std::hint::black_box(img), scratch)
                .map_err(SensingError::Mtts)?;
            std::hint::black_box(out);
        }
        Ok(t0.elapsed().as_nanos() as f64 / imgs.len() as f64)
    };
    pass(&mut m)?; // warm-up
    let mut t = (0..cfg.timing_repeats)
        .map(|_| pass(&mut m))
        .collect::<Result<Vec<_>, _>>()?;
    t.sort_by(f64::total_cmp);
    Ok(t[t.len() / 2])
}

/// The counts of a saved `scripts/bench-m4` output.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct M4Counts {
    /// `wp_mtts scale=S method=M insns=N`: whole MTTS of one frame.
    pub mtts: HashMap<(u8, String), u64>,
    /// `wp_roots variant=V to768_insns=N`: the to_768 stage with each roots variant.
    pub roots: HashMap<String, u64>,
}

impl M4Counts {
    /// Parse a bench-m4 output; other lines are ignored. Errors: malformed `wp_` lines (with
    /// their line number), or no `wp_mtts` line at all (not a bench-m4 output).
    pub fn parse(text: &str) -> Result<Self, SensingError> {
        let mut c = M4Counts::default();
        for (n, line) in text.lines().enumerate() {
            let line = line.trim();
            let bad = || SensingError::M4Line {
                line: n + 1,
                text: line.to_string(),
            };
            let fields = |line: &str| -> HashMap<String, String> {
                line.split_whitespace()
                    .skip(1)
                    .filter_map(|f| f.split_once('='))
                    .map(|(a, b)| (a.to_string(), b.to_string()))
                    .collect()
            };
            if line.starts_with("wp_mtts ") {
                let f = fields(line);
                let scale = f
                    .get("scale")
                    .and_then(|s| s.parse().ok())
                    .ok_or_else(bad)?;
                let method = f.get("method").ok_or_else(bad)?.clone();
                let insns = f
                    .get("insns")
                    .and_then(|s| s.parse().ok())
                    .ok_or_else(bad)?;
                c.mtts.insert((scale, method), insns);
            } else if line.starts_with("wp_roots ") {
                let f = fields(line);
                let variant = f.get("variant").ok_or_else(bad)?.clone();
                let insns = f
                    .get("to768_insns")
                    .and_then(|s| s.parse().ok())
                    .ok_or_else(bad)?;
                c.roots.insert(variant, insns);
            }
        }
        if c.mtts.is_empty() {
            return Err(SensingError::NotM4);
        }
        Ok(c)
    }

    /// Read and parse `path`; errors name the file.
    pub fn read(path: &Path) -> Result<Self, SensingError> {
        let text = std::fs::read_to_string(path).map_err(|err| SensingError::Read {
            path: path.to_path_buf(),
            err,
        })?;
        Self::parse(&text).map_err(|e| SensingError::InFile {
            path: path.to_path_buf(),
            err: Box::new(e),
        })
    }

    /// Put the counts into `rows`; every row and every roots variant must have one.
    pub fn fill(&self, rows: &mut [Row], roots: &mut [RootsRow]) -> Result<(), SensingError> {
        for r in rows.iter_mut() {
            let name = method_name(r.method);
            r.m4_insns = Some(*self.mtts.get(&(r.scale, name.to_string())).ok_or(
                SensingError::NoMttsCount {
                    scale: r.scale,
                    method: name,
                },
            )?);
        }
        for r in roots.iter_mut() {
            r.to768_insns = Some(
                *self
                    .roots
                    .get(&r.variant)
                    .ok_or_else(|| SensingError::NoRootsCount(r.variant.clone()))?,
            );
        }
        Ok(())
    }
}

/// One row of the roots table.
#[derive(Clone, Debug, PartialEq)]
pub struct RootsRow {
    /// Variant name.
    pub variant: String,
    /// Its To error against the f64 reference.
    pub error: to_roots::ToError,
    /// Cortex-M4 instructions of the to_768 stage (both subpages) with it, if known.
    pub to768_insns: Option<u64>,
}

/// The roots table over `cases` (M4 column empty).
pub fn roots_table(cases: &[to_roots::Case]) -> Vec<RootsRow> {
    to_roots::VARIANTS
        .iter()
        .map(|&(name, calc)| RootsRow {
            variant: name.to_string(),
            error: to_roots::max_error_k(calc, cases),
            to768_insns: None,
        })
        .collect()
}

/// Indices of the points not dominated by another (≤ in every objective, < in one); every
/// objective is to be minimised.
pub fn pareto(points: &[Vec<f64>]) -> Vec<bool> {
    points
        .iter()
        .map(|p| {
            !points.iter().any(|q| {
                q.iter().zip(p).all(|(a, b)| a <= b) && q.iter().zip(p).any(|(a, b)| a < b)
            })
        })
        .collect()
}

/// The objectives of a row: cost (M4 instructions, else host ns), mean error, max error and
/// run-to-run spread.
fn objectives(r: &Row) -> Vec<f64> {
    let cost = match (r.m4_insns, r.host_ns_per_frame) {
        (Some(i), _) => i as f64,
        (None, Some(ns)) => ns,
        (None, None) => 0.0,
    };
    vec![cost, r.mean_err_k(), r.max_err_k(), r.spread_max_k]
}

fn opt_u64(v: Option<u64>) -> String {
    v.map(|v| v.to_string()).unwrap_or_default()
}

fn label(r: &Row) -> String {
    format!("s={} {}", r.scale, method_name(r.method))
}

/// Render the document.
pub fn markdown(cfg: &WpConfig, rows: &[Row], roots: &[RootsRow]) -> String {
    let mut s = String::new();
    let front = pareto(&rows.iter().map(objectives).collect::<Vec<_>>());
    let cost_name = if rows.iter().all(|r| r.m4_insns.is_some()) {
        "M4 instructions"
    } else {
        "host ns/frame"
    };
    let _ = writeln!(s, "# MTTS work-precision: speed against error\n");
    let _ = writeln!(
        s,
        "Generated by `scripts/work-precision` (`bash scripts/bench-m4`, then `host-sim mtts-wp \
         --m4 <its output> --out docs/mtts-work-precision.md`); every figure below is measured \
         by that run. Do not edit by hand.\n"
    );
    let names: Vec<&str> = cfg.scenes.iter().map(|s| s.name).collect();
    let _ = writeln!(
        s,
        "**Setup.** K = {}, {} histogram bins. {} scenes ({}), each rendered with noise seeds \
         1…{}; each image clustered with method seeds 1…{} by a fresh pipeline (a first \
         frame: no previous geometry) — {} runs per row. Truth: the scene's region \
         temperatures.\n",
        Config::default().k,
        Config::default().bins,
        cfg.scenes.len(),
        names.join(", "),
        cfg.noise_seeds,
        cfg.method_seeds,
        rows.first().map(|r| r.runs).unwrap_or(0)
    );
    let _ = writeln!(
        s,
        "- **|T1−truth|, |T2−truth|**: of the clustering's T1 and T2 (each region's cluster \
         mean, the thesis method made deterministic; the mode's prior), mean and max over all \
         runs, K. The lattice least-squares estimate the firmware reports is measured in the \
         scene-family section below.\n\
         - **SSE gap**: (SSE − SSE_opt)/SSE_opt on the values the pipeline clusters (the filled \
         image upsampled by the firmware's upsampler, clamped to the image's range). SSE: the \
         method's cluster boundaries applied to those unbinned values, each group about its own \
         mean. SSE_opt: exact 1-D k-means of the same values in f64 — sorted values, prefix \
         sums, dynamic programming with the divide-and-conquer split search (exact: the optimal \
         split is monotone), O(K·n·log n), independent of the firmware's binned solver.\n\
         - **spread**: max − min of T1 (and of T2) over the method seeds for one image; the \
         larger of the two, mean and max over images, K.\n\
         - **host ns/frame**: the whole MTTS of one frame on this computer, median of {} \
         timed passes over the scenes (noise seed 1); a benchmark figure, machine-dependent.\n\
         - **M4 insns**: the whole MTTS of one frame on the Cortex-M4F under QEMU, exact \
         instruction counts (the `wp_mtts` lines of `scripts/bench-m4`; its input frame: the \
         rendered `heating-358` scene through the virtual sensor; a first frame){}.\n",
        cfg.timing_repeats,
        if rows.iter().all(|r| r.m4_insns.is_some()) {
            ""
        } else {
            " — no bench-m4 output was given: column empty, the front uses host time"
        }
    );
    let _ = writeln!(
        s,
        "| s | method | mean abs T1−truth K | max abs T1−truth K | mean abs T2−truth K | \
         max abs T2−truth K | mean SSE gap % | max SSE gap % | mean spread K | max spread K | \
         host ns/frame | M4 insns | front |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (r, &f) in rows.iter().zip(&front) {
        let default = r.scale == 4 && r.method == Method::Exact;
        let _ = writeln!(
            s,
            "| {} | {}{} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {} | {} | {} |",
            r.scale,
            method_name(r.method),
            if default { " (default)" } else { "" },
            r.t1_mean_err_k,
            r.t1_max_err_k,
            r.t2_mean_err_k,
            r.t2_max_err_k,
            100.0 * r.gap_mean,
            100.0 * r.gap_max,
            r.spread_mean_k,
            r.spread_max_k,
            r.host_ns_per_frame
                .map(|v| format!("{v:.0}"))
                .unwrap_or_default(),
            opt_u64(r.m4_insns),
            if f { "**yes**" } else { "" }
        );
    }
    let _ = writeln!(
        s,
        "\n**Front.** A setting is on the Pareto front when no other is at least as good in \
         every one of: cost ({cost_name}), mean error (the larger of the mean |T1−truth| and \
         |T2−truth|), worst error (the larger of the max ones) and max spread — and better in \
         one.\n"
    );
    s += &default_verdict(rows, &front, cost_name);

    // Roots.
    let _ = writeln!(s, "\n## Roots in the To calculation\n");
    let pixels = roots.first().map(|r| r.error.pixels).unwrap_or(0);
    let _ = writeln!(
        s,
        "Three fourth roots per pixel (the extended-range Sx term, a first To that picks the \
         temperature range, the final To). Each variant replaces the square and fourth roots \
         (`thermorph::mlx90640::Roots`); its To over {pixels} pixels — the shared real dumps \
         (Melexis example, datasheet example, Signaloid, ceri) and synthetic subpages of three \
         virtual sensors (the twelve scenes, random fields of 263–573 K through every \
         extended range, 16/18/19-bit) — is compared with an f64 evaluation of the same \
         formulas (`host_sim::imaging::to_roots::to_f64`). to_768: both subpages of bench-m4's frame \
         (To and bad-pixel correction), Cortex-M4F under QEMU (`wp_roots` lines).\n"
    );
    let _ = writeln!(
        s,
        "| variant | max abs ΔTo K | max relative ΔTo | to_768 M4 insns | front |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|");
    let rfront = pareto(
        &roots
            .iter()
            .map(|r| {
                vec![
                    r.to768_insns.map(|v| v as f64).unwrap_or(0.0),
                    r.error.max_abs_k,
                ]
            })
            .collect::<Vec<_>>(),
    );
    for (r, &f) in roots.iter().zip(&rfront) {
        let _ = writeln!(
            s,
            "| {}{} | {:.3e} | {:.2e} | {} | {} |",
            r.variant,
            if r.variant == "vsqrt" {
                " (default)"
            } else {
                ""
            },
            r.error.max_abs_k,
            r.error.max_rel,
            opt_u64(r.to768_insns),
            if f { "**yes**" } else { "" }
        );
    }
    let _ = writeln!(
        s,
        "\nQEMU counts instructions, not cycles: `VSQRT.F32` is one instruction that takes 14 \
         cycles on the Cortex-M4F (ARM DDI 0439B, table 7-1), so in cycles the hardware path's \
         lead over the software roots is narrower than the instruction counts show, and a \
         bit-trick root such as micromath's may even be cheaper — at its error above, which \
         rules it out for To."
    );
    if let Some(hw) = roots.iter().find(|r| r.variant == "vsqrt") {
        let verdict = rfront[roots.iter().position(|r| r.variant == "vsqrt").unwrap_or(0)];
        let same_as_libm = roots
            .iter()
            .any(|r| r.variant == "libm_sqrtf" && r.error == hw.error);
        let cheaper: Vec<String> = roots
            .iter()
            .filter(|r| match (r.to768_insns, hw.to768_insns) {
                (Some(a), Some(b)) => a < b,
                _ => false,
            })
            .map(|r| format!("{} ({:.1e} K)", r.variant, r.error.max_abs_k))
            .collect();
        let _ = writeln!(
            s,
            "\n**Default `vsqrt`: {}.** Max |ΔTo| {:.1e} K{} — the f32 calculation's own \
             rounding; {}.",
            if verdict {
                "on the front"
            } else {
                "NOT on the front"
            },
            hw.error.max_abs_k,
            if same_as_libm {
                ", the same as libm's correctly rounded `sqrtf` (bit-identical images)"
            } else {
                ""
            },
            if hw.to768_insns.is_none() {
                "no M4 counts were given, so the front compares errors only".to_string()
            } else if cheaper.is_empty() {
                let better: Vec<String> = roots
                    .iter()
                    .filter(|r| r.error.max_abs_k < hw.error.max_abs_k)
                    .map(|r| {
                        format!(
                            "{} ({:.1e} K at {} instructions)",
                            r.variant,
                            r.error.max_abs_k,
                            opt_u64(r.to768_insns)
                        )
                    })
                    .collect();
                format!(
                    "no variant takes fewer Cortex-M4 instructions{}",
                    if better.is_empty() {
                        String::new()
                    } else {
                        format!(
                            "; more accurate, within the same f32 rounding, but dearer: {}",
                            better.join(", ")
                        )
                    }
                )
            } else {
                format!("cheaper in instructions: {}", cheaper.join(", "))
            }
        );
    }
    s
}

/// The paragraph on the default setting (s = 4, exact): on the front or not, and against what.
fn default_verdict(rows: &[Row], front: &[bool], cost_name: &str) -> String {
    let Some(di) = rows
        .iter()
        .position(|r| r.scale == 4 && r.method == Method::Exact)
    else {
        return String::new();
    };
    let d = &rows[di];
    let od = objectives(d);
    let mut s = String::new();
    if front[di] {
        let cheaper: Vec<String> = rows
            .iter()
            .filter(|r| objectives(r)[0] < od[0])
            .map(|r| {
                let o = objectives(r);
                let mut why = Vec::new();
                if o[1] > od[1] {
                    why.push(format!("mean error {:.3} K", o[1]));
                }
                if o[2] > od[2] {
                    why.push(format!("worst error {:.3} K", o[2]));
                }
                if o[3] > od[3] {
                    why.push(format!("spread {:.3} K", o[3]));
                }
                format!("{} ({})", label(r), why.join(", "))
            })
            .collect();
        let _ = writeln!(
            s,
            "**Default s = 4, exact: on the front.** Mean error {:.3} K, worst {:.3} K, spread \
             {:.3} K (deterministic), {:.0} {cost_name}. Every cheaper setting is worse in some \
             error measure: {}.",
            od[1],
            od[2],
            od[3],
            od[0],
            if cheaper.is_empty() {
                "none is cheaper".to_string()
            } else {
                cheaper.join("; ")
            }
        );
        let dearer_better: Vec<String> = rows
            .iter()
            .filter(|r| objectives(r)[0] > od[0] && objectives(r)[1] < od[1])
            .map(|r| {
                format!(
                    "{} (mean error {:.3} K, {:.0})",
                    label(r),
                    objectives(r)[1],
                    objectives(r)[0]
                )
            })
            .collect();
        if !dearer_better.is_empty() {
            let _ = writeln!(
                s,
                "More accurate settings cost more: {}.",
                dearer_better.join("; ")
            );
        }
    } else {
        let dom: Vec<String> = rows
            .iter()
            .filter(|r| {
                let o = objectives(r);
                o.iter().zip(&od).all(|(a, b)| a <= b) && o.iter().zip(&od).any(|(a, b)| a < b)
            })
            .map(label)
            .collect();
        let _ = writeln!(
            s,
            "**Default s = 4, exact: NOT on the front** — dominated by {}.",
            dom.join(", ")
        );
    }
    s
}

/// Run `host-sim mtts-wp`.
pub fn run(args: &WpArgs) -> anyhow::Result<()> {
    if args.wrong {
        print!("{}", confidently_wrong_lines(&unlike_outcomes(args.family)));
        return Ok(());
    }
    if args.family_only {
        let md = family_section(args.family, args.bayes);
        return match &args.out {
            Some(p) => {
                std::fs::write(p, md).with_context(|| format!("{}: cannot write", p.display()))
            }
            None => {
                print!("{md}");
                Ok(())
            }
        };
    }
    if args.seeds < 2 {
        bail!("--seeds must be at least 2 (the spread needs two method seeds)");
    }
    // Read the M4 counts first: a bad file fails before the long measurement.
    let m4 = args.m4.as_deref().map(M4Counts::read).transpose()?;
    let cfg = WpConfig::full(args.seeds);
    let mut rows = measure(&cfg)?;
    let dir = crate::imaging::data::mlx90640_dir();
    if !dir.is_dir() {
        bail!(
            "sensor data folder {} is missing (the roots table reads the real dumps; set {})",
            dir.display(),
            crate::imaging::data::DATA_DIR_ENV
        );
    }
    let cases = to_roots::cases(Some(&dir))?;
    let mut roots = roots_table(&cases);
    if let Some(m4) = &m4 {
        m4.fill(&mut rows, &mut roots)
            .with_context(|| args.m4.as_ref().unwrap().display().to_string())?;
    }
    let md = markdown(&cfg, &rows, &roots) + "\n" + &family_section(args.family, args.bayes);
    match &args.out {
        Some(p) => std::fs::write(p, md).with_context(|| format!("{}: cannot write", p.display())),
        None => {
            print!("{md}");
            Ok(())
        }
    }
}

/// What the supervisor's mode tells MTTS in a family run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PriorCase {
    /// The mode's prior, right (the sign of the true gap).
    Right,
    /// The opposite prior: a mode that expects the wrong target hotter (forming's first
    /// seconds, before the hot zone inverts).
    Wrong,
    /// No prior.
    None,
}

/// One family member's outcome under the default MTTS.
#[derive(Clone, Copy, Debug)]
pub struct FamilyOutcome {
    /// The member's seed.
    pub seed: u64,
    /// Lattice period, pixels.
    pub period_px: f64,
    /// Exposed fraction the view shows.
    pub exposed: f64,
    /// Point-spread σ, pixels.
    pub psf_sigma_px: f64,
    /// True T1 − T2, K.
    pub gap_k: f64,
    /// |T1 − truth|, |T2 − truth|, K.
    pub err_k: [f64; 2],
    /// The same for the clustering alone (the thesis method).
    pub cluster_err_k: [f64; 2],
    /// |merged value − true area-weighted mean|, K (merged frames).
    pub merged_err_k: Option<f64>,
    /// The frame's quality.
    pub quality: Quality,
    /// The bound the frame reported, K.
    pub bound_k: f64,
    /// A resolved frame whose T1 − T2 has the wrong sign (|gap| ≥ 1 K).
    pub swapped: bool,
}

impl FamilyOutcome {
    /// The frame's reported values lie within its bound of the truth: for a resolved frame
    /// T1 and T2 each; for a merged one, the merged value of the true area-weighted mean.
    pub fn covered(&self) -> bool {
        match self.quality {
            Quality::Resolved | Quality::Ambiguous => self.err_k.iter().all(|&e| e <= self.bound_k),
            Quality::Merged => self.merged_err_k.is_some_and(|e| e <= self.bound_k),
            Quality::Fallback => true,
        }
    }

    /// A resolved frame whose error exceeds its bound: a confident wrong answer.
    pub fn confidently_wrong(&self) -> bool {
        self.quality == Quality::Resolved && !self.covered()
    }
}

/// The default MTTS configured with the member's design exposed fraction and the prior of
/// `prior`, fresh.
fn member_mtts(m: &Member, prior: PriorCase) -> Mtts {
    let mut mtts = Mtts::new(Config {
        exposed_pct: m.design_exposed_pct,
        ..Config::default()
    })
    .expect("a family member's design is a valid config");
    let (right, wrong) = if m.gap_k() >= 0.0 {
        (Prior::HeaterHotter, Prior::SurfaceHotter)
    } else {
        (Prior::SurfaceHotter, Prior::HeaterHotter)
    };
    mtts.set_prior(match prior {
        PriorCase::Right => right,
        PriorCase::Wrong => wrong,
        PriorCase::None => Prior::Unknown,
    });
    mtts
}

/// The outcome of MTTS's output `out` on a frame of `m`.
fn outcome_of(m: &Member, out: &mtts::Output) -> FamilyOutcome {
    let gap = m.gap_k();
    let (t1, t2) = (k_or_nan(out.t1()) as f64, k_or_nan(out.t2()) as f64);
    let truth = [m.temps.heater_k, m.temps.surface_k];
    let est_gap = t1 - t2;
    FamilyOutcome {
        seed: m.seed,
        period_px: m.geometry.period_px,
        exposed: m.geometry.exposed,
        psf_sigma_px: m.psf_sigma_px,
        gap_k: gap,
        err_k: [(t1 - truth[0]).abs(), (t2 - truth[1]).abs()],
        cluster_err_k: [
            (k_or_nan(out.clustered[0]) as f64 - truth[0]).abs(),
            (k_or_nan(out.clustered[1]) as f64 - truth[1]).abs(),
        ],
        merged_err_k: (out.quality == Quality::Merged).then(|| (t1 - m.mean_k()).abs()),
        quality: out.quality,
        bound_k: out.bound.k() as f64,
        swapped: out.quality == Quality::Resolved && gap.abs() >= 1.0 && est_gap * gap < 0.0,
    }
}

/// Run the default MTTS (the member's design exposed fraction configured) on one member:
/// a first frame, fresh pipeline.
pub fn member_outcome(m: &Member, prior: PriorCase, scratch: &mut Scratch) -> FamilyOutcome {
    let r = m.render();
    let out = member_mtts(m, prior)
        .process(&r.image_k, scratch)
        .expect("a family frame is valid");
    outcome_of(m, &out)
}

/// Frames of the settled evaluation ([`member_outcome_settled`]) in the work-precision table:
/// a lattice unlike its design is a lasting condition of the block, which a user watches for
/// many frames (12: 3 s at the camera's 4 Hz).
pub const SETTLED_FRAMES: usize = 12;

/// Run the default MTTS as [`member_outcome`] does (same configuration and prior), but one
/// pipeline fed `frames` frames of the member, each with its own sensor noise
/// ([`Member::noise_seed`]; the first is [`Member::render`]'s), the same view and bad pixels:
/// the outcome of the last frame. With `frames == 1` it is [`member_outcome`]'s.
///
/// # Panics
/// If `frames` is 0.
pub fn member_outcome_settled(
    m: &Member,
    prior: PriorCase,
    frames: usize,
    scratch: &mut Scratch,
) -> FamilyOutcome {
    member_first_and_settled(m, prior, frames, scratch).1
}

/// [`member_outcome`] and [`member_outcome_settled`] from one run: the outcomes of the first
/// and the last of `frames` frames fed to one pipeline.
///
/// # Panics
/// If `frames` is 0.
pub fn member_first_and_settled(
    m: &Member,
    prior: PriorCase,
    frames: usize,
    scratch: &mut Scratch,
) -> (FamilyOutcome, FamilyOutcome) {
    assert!(frames > 0, "a settled evaluation needs a frame");
    let mut mtts = member_mtts(m, prior);
    let view = m.frames();
    let mut run = |f: usize| {
        let out = mtts
            .process(&view.frame(f).image_k, scratch)
            .expect("a family frame is valid");
        outcome_of(m, &out)
    };
    let first = run(0);
    let last = (1..frames).map(&mut run).last().unwrap_or(first);
    (first, last)
}

/// A prior that lags the block after its design was confirmed: one pipeline fed `confirm`
/// frames of the member under the mode's prior (each with its own noise), then one under the
/// wrong prior — forming's first seconds, after heating showed the lattice as designed. The
/// outcome of that last frame.
pub fn member_outcome_lagging_prior(
    m: &Member,
    confirm: usize,
    scratch: &mut Scratch,
) -> FamilyOutcome {
    let mut mtts = member_mtts(m, PriorCase::Right);
    let view = m.frames();
    for f in 0..confirm {
        mtts.process(&view.frame(f).image_k, scratch)
            .expect("a family frame is valid");
    }
    let wrong = member_mtts(m, PriorCase::Wrong).prior();
    mtts.set_prior(wrong);
    let out = mtts
        .process(&view.frame(confirm).image_k, scratch)
        .expect("a family frame is valid");
    outcome_of(m, &out)
}

/// [`member_outcome_lagging_prior`] over `members`, in parallel, in order.
pub fn members_outcomes_lagging_prior(
    members: impl Iterator<Item = Member>,
    confirm: usize,
) -> Vec<FamilyOutcome> {
    par_members(members, |m, scratch| {
        member_outcome_lagging_prior(m, confirm, scratch)
    })
}

/// `f` over `members`, in parallel, in order, each thread with its own MTTS scratch.
fn par_members<T: Send>(
    members: impl Iterator<Item = Member>,
    f: impl Fn(&Member, &mut Scratch) -> T + Sync + Send,
) -> Vec<T> {
    use rayon::prelude::*;
    let members: Vec<Member> = members.collect();
    members
        .par_iter()
        .map_init(|| Box::new(Scratch::new()), |scratch, m| f(m, scratch))
        .collect()
}

/// Run the default MTTS on `count` members of the family from `seeds` (first frames, fresh
/// pipeline each; in parallel), with the prior `prior`.
pub fn family_outcomes(seeds: Range<u64>, count: u64, prior: PriorCase) -> Vec<FamilyOutcome> {
    members_outcomes(
        (seeds.start..seeds.start + count.min(seeds.end - seeds.start)).map(Member::draw),
        prior,
    )
}

/// [`member_outcome`] over `members`, in parallel, in order.
pub fn members_outcomes(
    members: impl Iterator<Item = Member>,
    prior: PriorCase,
) -> Vec<FamilyOutcome> {
    par_members(members, |m, scratch| member_outcome(m, prior, scratch))
}

/// [`member_outcome_settled`] over `members` with `frames` frames each, in parallel, in order.
pub fn members_outcomes_settled(
    members: impl Iterator<Item = Member>,
    prior: PriorCase,
    frames: usize,
) -> Vec<FamilyOutcome> {
    members_first_and_settled(members, prior, frames)
        .into_iter()
        .map(|(_, last)| last)
        .collect()
}

/// [`member_first_and_settled`] over `members`, in parallel, in order.
pub fn members_first_and_settled(
    members: impl Iterator<Item = Member>,
    prior: PriorCase,
    frames: usize,
) -> Vec<(FamilyOutcome, FamilyOutcome)> {
    par_members(members, |m, scratch| {
        member_first_and_settled(m, prior, frames, scratch)
    })
}

/// Exposed-fraction bands of the family table.
pub const FAMILY_EXPOSED: [(f64, f64); 6] = [
    (0.2, 0.35),
    (0.35, 0.45),
    (0.45, 0.55),
    (0.55, 0.65),
    (0.65, 0.75),
    (0.75, 0.85),
];
/// Period bands of the family table, pixels.
pub const FAMILY_PERIODS: [(f64, f64); 3] = [(4.0, 6.0), (6.0, 10.0), (10.0, 16.0)];
/// |T1 − T2| bands, K.
pub const FAMILY_GAPS: [(f64, f64); 4] = [(1.0, 3.0), (3.0, 6.0), (6.0, 10.0), (10.0, 15.0)];
/// Point-spread bands, pixels (the first: the footprint alone).
pub const FAMILY_PSFS: [(f64, f64); 4] = [(0.0, 1e-9), (1e-9, 0.2), (0.2, 0.4), (0.4, 0.6)];

/// Summary of a set of outcomes.
#[derive(Clone, Copy, Debug, Default)]
pub struct CellStats {
    /// Members.
    pub n: usize,
    /// Share resolved.
    pub resolved: f64,
    /// Share ambiguous.
    pub ambiguous: f64,
    /// Share swapped (resolved, wrong sign).
    pub swapped: f64,
    /// How many frames were swapped.
    pub swaps: usize,
    /// Resolved frames whose error exceeds their bound.
    pub confidently_wrong: usize,
    /// Share of resolved frames within their bound.
    pub coverage: f64,
    /// Mean and max |T1 − truth|, K.
    pub t1_k: (f64, f64),
    /// Mean and max |T2 − truth|, K.
    pub t2_k: (f64, f64),
    /// Mean |T1 − truth| and |T2 − truth| over the resolved frames, K (NaN without one).
    pub resolved_err_k: [f64; 2],
}

impl CellStats {
    /// The summary of `outs`.
    pub fn of<'a>(outs: impl Iterator<Item = &'a FamilyOutcome>) -> CellStats {
        let outs: Vec<&FamilyOutcome> = outs.collect();
        let n = outs.len();
        if n == 0 {
            return CellStats::default();
        }
        let resolved: Vec<&&FamilyOutcome> = outs
            .iter()
            .filter(|o| o.quality == Quality::Resolved)
            .collect();
        let mean_max = |i: usize| {
            let v: Vec<f64> = outs.iter().map(|o| o.err_k[i]).collect();
            (
                v.iter().sum::<f64>() / n as f64,
                v.iter().copied().fold(0.0, f64::max),
            )
        };
        let swaps = outs.iter().filter(|o| o.swapped).count();
        let resolved_mean =
            |i: usize| resolved.iter().map(|o| o.err_k[i]).sum::<f64>() / resolved.len() as f64;
        CellStats {
            n,
            resolved: resolved.len() as f64 / n as f64,
            ambiguous: outs
                .iter()
                .filter(|o| o.quality == Quality::Ambiguous)
                .count() as f64
                / n as f64,
            swapped: swaps as f64 / n as f64,
            swaps,
            confidently_wrong: outs.iter().filter(|o| o.confidently_wrong()).count(),
            coverage: if resolved.is_empty() {
                1.0
            } else {
                resolved.iter().filter(|o| o.covered()).count() as f64 / resolved.len() as f64
            },
            t1_k: mean_max(0),
            t2_k: mean_max(1),
            resolved_err_k: [resolved_mean(0), resolved_mean(1)],
        }
    }

    /// The table row's cells after the label columns.
    fn cells(&self) -> String {
        format!(
            "{} | {:.0} | {:.1} | {:.0} | {} | {:.2} | {:.2} | {:.2} | {:.2} |",
            self.n,
            100.0 * self.resolved,
            100.0 * self.swapped,
            100.0 * self.coverage,
            self.confidently_wrong,
            self.t1_k.0,
            self.t1_k.1,
            self.t2_k.0,
            self.t2_k.1,
        )
    }
}

const STATS_HEADER: &str = "n | resolved % | swapped % | bound coverage % | confidently wrong | mean abs T1 err K | max | mean abs T2 err K | max |";

fn in_band(x: f64, (lo, hi): (f64, f64)) -> bool {
    x >= lo && x < hi
}

/// A table of [`CellStats`] rows: `labels` names the label columns (`"a | b"`), each row's
/// label fills them.
fn stats_table(labels: &str, rows: impl IntoIterator<Item = (String, CellStats)>) -> String {
    stats_table_with(
        labels,
        "",
        rows.into_iter().map(|(l, st)| (l, st, String::new())),
    )
}

/// [`stats_table`] with extra columns after the statistics: `extra` names them (`"x | y |"`),
/// each row's third field fills them (`"1 | 2 |"`).
fn stats_table_with(
    labels: &str,
    extra: &str,
    rows: impl IntoIterator<Item = (String, CellStats, String)>,
) -> String {
    let columns = labels.split(" | ").count()
        + STATS_HEADER.matches(" | ").count()
        + 1
        + extra.matches('|').count();
    let mut s = String::new();
    let _ = writeln!(s, "| {labels} | {STATS_HEADER}{extra}");
    let _ = writeln!(s, "|{}", "---|".repeat(columns));
    for (label, st, more) in rows {
        let _ = writeln!(s, "| {label} | {}{more}", st.cells());
    }
    s
}

/// Members whose gap is at least 3 K.
fn clear_gap(o: &FamilyOutcome) -> bool {
    o.gap_k.abs() >= 3.0
}

/// Table by exposed-fraction band × period band over members whose gap is at least 3 K, with
/// what the views hold: the mean over the cell of each member's least mean |error| of T1 and
/// T2 ([`crate::imaging::view_limit`]) and, with `bayes`, of the errors of the exact Bayesian
/// estimate that knows the view's geometry ([`view_limit::exact_bayes`]). `outs` are outcomes
/// of [`Member::draw`] members: their views are drawn again from their seeds.
pub fn family_markdown(outs: &[FamilyOutcome], bayes: bool) -> String {
    use rayon::prelude::*;
    let limits: Vec<Option<[f64; 4]>> = outs
        .par_iter()
        .map(|o| {
            if !clear_gap(o) {
                return None;
            }
            let m = Member::draw(o.seed);
            let l = view_limit::limit(&m)?.mean_abs_k();
            let b = if bayes {
                view_limit::exact_bayes(&m)?
            } else {
                [f64::NAN; 2]
            };
            Some([l[0], l[1], b[0], b[1]])
        })
        .collect();
    let rows = FAMILY_EXPOSED.iter().flat_map(|&e| {
        let limits = &limits;
        FAMILY_PERIODS.iter().filter_map(move |&p| {
            let inside = |o: &FamilyOutcome| {
                in_band(o.exposed, e) && in_band(o.period_px, p) && clear_gap(o)
            };
            let st = CellStats::of(outs.iter().filter(|o| inside(o)));
            let cell: Vec<[f64; 4]> = outs
                .iter()
                .zip(limits)
                .filter(|(o, _)| inside(o))
                .filter_map(|(_, l)| *l)
                .collect();
            let mean = |i: usize| cell.iter().map(|l| l[i]).sum::<f64>() / cell.len().max(1) as f64;
            let mut more = format!(" {:.2} | {:.2} |", mean(0), mean(1));
            if bayes {
                more += &format!(" {:.2} | {:.2} |", mean(2), mean(3));
            }
            (st.n > 0).then(|| (format!("{}–{} | {}–{}", e.0, e.1, p.0, p.1), st, more))
        })
    });
    stats_table_with(
        "exposed | period px",
        if bayes {
            " image's limit T1 K | limit T2 K | exact Bayes T1 K | exact Bayes T2 K |"
        } else {
            " image's limit T1 K | limit T2 K |"
        },
        rows,
    )
}

/// Table by exposed-fraction band (every period) over members whose gap is at least 3 K.
pub fn family_exposed_markdown(outs: &[FamilyOutcome]) -> String {
    let rows = FAMILY_EXPOSED.iter().map(|&e| {
        let st = CellStats::of(
            outs.iter()
                .filter(|o| in_band(o.exposed, e) && clear_gap(o)),
        );
        (format!("{}–{}", e.0, e.1), st)
    });
    stats_table("exposed", rows)
}

/// Table by gap band, one row per prior case.
pub fn family_gap_markdown(cases: &[(&str, &[FamilyOutcome])]) -> String {
    let rows = cases.iter().flat_map(|&(name, outs)| {
        FAMILY_GAPS.iter().map(move |&g| {
            let st = CellStats::of(outs.iter().filter(|o| in_band(o.gap_k.abs(), g)));
            (format!("{name} | {}–{}", g.0, g.1), st)
        })
    });
    stats_table("prior | abs gap K", rows)
}

/// Table by point-spread band over members whose gap is at least 3 K.
pub fn family_psf_markdown(outs: &[FamilyOutcome]) -> String {
    let rows = FAMILY_PSFS.iter().map(|&b| {
        let st = CellStats::of(
            outs.iter()
                .filter(|o| in_band(o.psf_sigma_px, b) && clear_gap(o)),
        );
        let label = if b.1 < 1e-6 {
            "none (footprint)".to_string()
        } else {
            format!("{}–{}", if b.0 < 1e-6 { 0.0 } else { b.0 }, b.1)
        };
        (label, st)
    });
    stats_table("PSF σ px", rows)
}

/// The headline: members at periods ≥ 4 px and gaps ≥ 3 K.
pub fn family_headline(outs: &[FamilyOutcome]) -> CellStats {
    CellStats::of(
        outs.iter()
            .filter(|o| o.period_px >= 4.0 && o.gap_k.abs() >= 3.0),
    )
}

/// Exposed-fraction bands of the table of lattices unlike their design.
pub const UNLIKE_EXPOSED: [(f64, f64); 3] = [(0.2, 0.35), (0.35, 0.5), (0.85, 0.95)];

/// Table of lattices unlike their design ([`crate::imaging::view_family::unlike_design`]): by
/// exposed band, the first frames `first` and the settled ones `settled` (every member, whatever
/// its gap).
pub fn unlike_design_markdown(first: &[FamilyOutcome], settled: &[FamilyOutcome]) -> String {
    let mut s = String::from(
        "| exposed | frame | members | resolved % | ambiguous % | mean abs T1 err, resolved K \
         | T2, resolved K | mean abs T1 err, every frame K | T2, every frame K \
         | bound coverage % | swapped | confidently wrong |\n",
    );
    s += &format!("|{}\n", "---|".repeat(12));
    for &e in &UNLIKE_EXPOSED {
        for (name, outs) in [("first", first), ("settled", settled)] {
            let st = CellStats::of(outs.iter().filter(|o| in_band(o.exposed, e)));
            if st.n == 0 {
                continue;
            }
            let _ = writeln!(
                s,
                "| {}–{} | {name} | {} | {:.0} | {:.0} | {:.2} | {:.2} | {:.2} | {:.2} | {:.0} | {} | {} |",
                e.0,
                e.1,
                st.n,
                100.0 * st.resolved,
                100.0 * st.ambiguous,
                st.resolved_err_k[0],
                st.resolved_err_k[1],
                st.t1_k.0,
                st.t2_k.0,
                100.0 * st.coverage,
                st.swaps,
                st.confidently_wrong,
            );
        }
    }
    s
}

/// Members of the thesis's corner reported.
pub const THESIS_MEMBERS: u64 = 240;

/// The lattices unlike their design of the family section of `count` (`count / 2` unseen
/// members: each is watched for [`SETTLED_FRAMES`] frames), their first and settled outcomes.
pub fn unlike_outcomes(count: u64) -> Vec<(FamilyOutcome, FamilyOutcome)> {
    use crate::imaging::view_family::{UNSEEN, unlike_design};
    let unlike = (UNSEEN.start..UNSEEN.start + count.div_ceil(2).min(UNSEEN.end - UNSEEN.start))
        .map(unlike_design);
    members_first_and_settled(unlike, PriorCase::Right, SETTLED_FRAMES)
}

/// The confidently wrong frames among `outcomes` (first and settled, [`unlike_outcomes`]), a
/// line each: which frame, the member's seed, period, exposed fraction, spread and gap, the
/// errors and the bound — what to look at first when the table's last column is not 0.
pub fn confidently_wrong_lines(outcomes: &[(FamilyOutcome, FamilyOutcome)]) -> String {
    let mut s = String::from(
        "# frame seed period_px exposed psf_sigma_px gap_k t1_err_k t2_err_k bound_k\n",
    );
    for (first, settled) in outcomes {
        for (frame, o) in [("first", first), ("settled", settled)] {
            if o.confidently_wrong() {
                let _ = writeln!(
                    s,
                    "{frame} {} {:.1} {:.3} {:.2} {:.1} {:.2} {:.2} {:.2}",
                    o.seed,
                    o.period_px,
                    o.exposed,
                    o.psf_sigma_px,
                    o.gap_k,
                    o.err_k[0],
                    o.err_k[1],
                    o.bound_k
                );
            }
        }
    }
    s
}

/// The scene-family section of the table: `count` members from the tuning seeds and `count`
/// unseen ones with the mode's prior, the unseen ones with the wrong prior and without one,
/// the thesis's corner, and `count / 2` lattices unlike their design (their first frames and
/// settled after [`SETTLED_FRAMES`]).
pub fn family_section(count: u64, bayes: bool) -> String {
    use crate::imaging::view_family::{SEEN, UNLIKE_NARROW, UNLIKE_WIDE, UNSEEN, thesis};
    let seen = family_outcomes(SEEN, count, PriorCase::Right);
    let unseen = family_outcomes(UNSEEN, count, PriorCase::Right);
    let wrong = family_outcomes(UNSEEN, count, PriorCase::Wrong);
    let blind = family_outcomes(UNSEEN, count, PriorCase::None);
    let corner = |prior| {
        members_outcomes(
            (UNSEEN.start..UNSEEN.start + THESIS_MEMBERS).map(thesis),
            prior,
        )
    };
    let (thesis_right, thesis_wrong) = (corner(PriorCase::Right), corner(PriorCase::Wrong));
    let (unlike_first, unlike_settled): (Vec<_>, Vec<_>) =
        unlike_outcomes(count).into_iter().unzip();
    let mut s = String::new();
    let _ = writeln!(s, "## Scene family: seen and unseen seeds\n");
    let _ = writeln!(
        s,
        "`host-sim mtts-wp --family-only --family {count}{}` (the full run: `--family 3000`). \
         Members of `host_sim::imaging::view_family`: period 4–16 px, width 6–20 px, exposed \
         fraction 0.2–0.85, tilt ±35°, shifts, 50–100 mm, footprint alone or ⊗ Gaussian PSF \
         σ up to 0.6 px, noise 0.05–0.5 K, |T1 − T2| 1–15 K of either sign, background \
         278–318 K, up to 4 broken and 2 hot pixels; MTTS configured with the block's design \
         exposed fraction (the view's ± 0.04), except for the lattices unlike their design \
         (their own subsection). First frames of the default MTTS (s = 4, exact, \
         K = 5). Seen: seeds {}…, the range the constants of `mtts::lattice` were tuned on; \
         unseen: seeds {}…, never used while tuning. Errors are over every frame, whatever its \
         quality (a merged frame's T1 and T2 are the core's area-weighted mean). *Swapped*: a \
         resolved frame whose T1 − T2 has the wrong sign. *Bound coverage*: the share of \
         resolved frames whose T1 and T2 both lie within their reported bound of the truth. \
         *Confidently wrong*: resolved frames outside their bound.\n",
        if bayes { " --bayes" } else { "" },
        SEEN.start,
        UNSEEN.start
    );
    let _ = writeln!(
        s,
        "### Unseen members, the mode's prior, |gap| ≥ 3 K, by exposed fraction and period\n\n\
         *Image's limit*: the least mean |error| any unbiased estimate from the member's core \
         pixels can have — the Cramér–Rao bound of `host_sim::imaging::view_limit` (the \
         lattice seen through the footprint and spread, every harmonic; exposed fraction, \
         phase, period and spread unknown, the design's ±0.04 as a prior; tilt and axis \
         known, so if anything too low), √(2/π)·sd, averaged over the cell. Where it exceeds \
         0.3 K the image does not hold the goal; where MTTS's error is far above it, the fit \
         leaves information unused.{}\n",
        if bayes {
            " *Exact Bayes*: the mean |error| of the posterior mean of T1 and T2 from the same \
             pixels for an estimator that knows the view's geometry (axis, tilt, period, the \
             stripes' place) and noise level and weighs every exposed fraction and spread the \
             family draws (`view_limit::exact_bayes`): the bound is local and no estimate \
             reaches it where a thin stripe's level trades against its width and the spread \
             along a curved valley; the firmware must also find the geometry, so where this \
             estimate exceeds 0.3 K the goal is beyond the image."
        } else {
            ""
        }
    );
    s += &family_markdown(&unseen, bayes);
    let _ = writeln!(s, "\n### Unseen members by gap, under each prior\n");
    let _ = writeln!(
        s,
        "*Wrong*: the prior says the other target is hotter (forming's first seconds, before \
         the hot zone inverts). *Unlike design*: the first frames of the lattices unlike their \
         design (their subsection below).\n"
    );
    s += &family_gap_markdown(&[
        ("seen, right", &seen),
        ("unseen, right", &unseen),
        ("unseen, wrong", &wrong),
        ("unseen, none", &blind),
        ("unlike design, right", &unlike_first),
    ]);
    let _ = writeln!(
        s,
        "\n### Unseen members under the wrong prior, |gap| ≥ 3 K, by exposed fraction\n\n\
         Where heater and surface stripes differ in width the image decides against the prior; \
         a block exposed near one half (0.45–0.55) shows equal stripes: the prior assigns T1 and T2, \
         and the frame is ambiguous, its bound spanning both assignments (not resolved, so not \
         counted as swapped; its errors are in the means).\n"
    );
    s += &family_exposed_markdown(&wrong);
    let _ = writeln!(
        s,
        "\n### Unseen members by optics, the mode's prior, |gap| ≥ 3 K\n"
    );
    s += &family_psf_markdown(&unseen);
    let _ = writeln!(
        s,
        "\n### The thesis's lattice\n\n{THESIS_MEMBERS} members of \
         `view_family::thesis` (exposed ≈ 0.71, period 4.6–5.4 px, no spread beyond the \
         footprint, noise 0.1–0.5 K, gaps 1–12 K, tilt ±20°, broken and hot pixels), seeds {}….\n",
        UNSEEN.start
    );
    s += &family_gap_markdown(&[("right", &thesis_right), ("wrong", &thesis_wrong)]);
    let _ = writeln!(
        s,
        "\n### Lattices unlike their design\n\n{} members of `view_family::unlike_design`, \
         seeds {}… (half as many as the other sets: each is watched for {SETTLED_FRAMES} \
         frames): drawn as the family's, but exposed {}–{} (even seeds) or {}–{} (odd seeds) \
         while MTTS is configured with the product's default design, {} % (another \
         print, another view angle: issue 43); the mode's prior; every member, |gap| 1–15 K (a \
         swap at any gap counts). *First*: the first frame of a fresh pipeline, as in the tables \
         above. *Settled*: the last of {SETTLED_FRAMES} frames of the same view ({} s at the \
         camera's 4 Hz), each with its own sensor noise, fed to one pipeline: what a user sees \
         of a block that stays unlike its design. *Resolved*, *ambiguous*: shares of the \
         frames. *Mean abs err, resolved*: over the resolved frames alone; *every frame*: over \
         all, whatever their quality. *Bound coverage*: as above, on the resolved frames. \
         *Swapped*, *confidently wrong*: how many frames.\n",
        unlike_first.len(),
        UNSEEN.start,
        UNLIKE_NARROW.0,
        UNLIKE_NARROW.1,
        UNLIKE_WIDE.0,
        UNLIKE_WIDE.1,
        Config::default().exposed_pct,
        SETTLED_FRAMES as f64 / 4.0,
    );
    s += &unlike_design_markdown(&unlike_first, &unlike_settled);
    let _ = writeln!(s);
    for (name, outs) in [
        ("seen, right prior", &seen),
        ("unseen, right prior", &unseen),
        ("unseen, wrong prior", &wrong),
        ("unseen, no prior", &blind),
        ("thesis lattice, right prior", &thesis_right),
        ("unlike design, right prior", &unlike_first),
    ] {
        let h = family_headline(outs);
        let _ = writeln!(
            s,
            "- {name}: periods ≥ 4 px, gaps ≥ 3 K: mean abs T1 error {:.2} K, T2 {:.2} K; \
             resolved {:.0} %, swapped {:.1} %, bound coverage {:.0} %, confidently wrong {}.",
            h.t1_k.0,
            h.t2_k.0,
            100.0 * h.resolved,
            100.0 * h.swapped,
            100.0 * h.coverage,
            h.confidently_wrong
        );
    }
    s
}
