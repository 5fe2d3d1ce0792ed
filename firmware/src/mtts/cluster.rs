//! One-dimensional k-means on temperature (thesis eq. 6.11–6.13): exact and deterministic.
//!
//! The upsampled values are streamed into a [`Histogram`] of `B` equal bins between the
//! image's minimum and maximum, keeping each bin's count (the hot loop of the pipeline: a
//! conversion, a saturation and an increment per value). Values are handled in bin units,
//! u = (T − lo)/w; an interpolated value beyond the image's range (cubic ringing) counts in
//! the end bin. Every value stands at its bin's centre: cluster means and SSE are those of the
//! binned values, within w/2 of the unbinned ones.
//!
//! [`exact_binned`] finds the partition of the bins into K contiguous groups with the least
//! SSE, by dynamic programming (`D[m][j] = min_i D[m−1][i−1] + cost(i, j)`) with the
//! divide-and-conquer speed-up, which is exact because the optimal split point is monotone in
//! j for this cost (Grønlund et al., "Fast exact k-means, k-medians and Bregman divergence
//! clustering in 1D", 2017). Costs use bin indices as integer coordinates, so the prefix sums
//! and the cost numerators N·S2 − S1² are exact `i64`; cluster means and SSE are then taken from
//! the real values. Binning forces the values of one bin into one cluster; the optimal 1-D
//! clusters are separated at midpoints between adjacent means, so only the bins straddling a
//! boundary can be misplaced, and moving a value x across the midpoint of means a < b costs at
//! most (b − a)·2·w for bin width w. [`Clusters::binning_bound`] reports
//! Σ_boundaries n_bin·2w·(b − a), an upper bound of the SSE gap to the unbinned optimum.
//!
//! The host crate solves the same problem on the sorted values without binning as the reference
//! (`host_sim::mtts_wp::optimal_sse`); [`lloyd`] is the thesis's Lloyd iteration with random or
//! k-means++ seeding from a seeded generator, kept for comparison.

use super::MttsError;

/// Most clusters.
pub const MAX_K: usize = 8;
/// Most histogram bins.
pub const MAX_BINS: usize = 512;
/// Default number of bins.
pub const DEFAULT_BINS: usize = 128;

/// Counts of equal-width bins over [lo, hi].
#[derive(Clone)]
pub struct Histogram {
    lo: f32,
    scale: f32,
    width: f32,
    bins: usize,
    /// Values per bin.
    pub count: [u32; MAX_BINS],
}

impl Histogram {
    /// An all-zero histogram of no bins (storage for [`Histogram::reset`]).
    pub const EMPTY: Histogram = Histogram {
        lo: 0.0,
        scale: 0.0,
        width: 0.0,
        bins: 0,
        count: [0; MAX_BINS],
    };

    /// Make an empty histogram of `bins` bins over [lo_k, hi_k] (hi may equal lo).
    pub fn new(lo_k: f32, hi_k: f32, bins: usize) -> Result<Self, MttsError> {
        let mut h = Self::EMPTY;
        h.reset(lo_k, hi_k, bins)?;
        Ok(h)
    }

    /// Empty the histogram and give it `bins` bins over [lo_k, hi_k]; on error it is unchanged.
    pub fn reset(&mut self, lo_k: f32, hi_k: f32, bins: usize) -> Result<(), MttsError> {
        if !(2..=MAX_BINS).contains(&bins) {
            return Err(MttsError::BadBins { bins: bins as u16 });
        }
        if !(lo_k.is_finite() && hi_k.is_finite() && hi_k >= lo_k) {
            return Err(MttsError::NoValidPixels);
        }
        let span = (hi_k - lo_k).max(1e-6);
        self.lo = lo_k;
        self.scale = bins as f32 / span;
        self.width = span / bins as f32;
        self.bins = bins;
        self.count = [0; MAX_BINS];
        Ok(())
    }

    /// Return the number of bins.
    pub fn bins(&self) -> usize {
        self.bins
    }

    /// Return the bin width, K.
    pub fn width(&self) -> f32 {
        self.width
    }

    /// Return the bin of a value, K (values outside the range go to the end bins).
    #[inline]
    pub fn bin_of(&self, v: f32) -> usize {
        let b = ((v - self.lo) * self.scale) as i32;
        b.clamp(0, self.bins as i32 - 1) as usize
    }

    /// Return the range's low end, K, and bins per kelvin: a value's bin units are
    /// `(v − lo) · scale`.
    #[inline]
    pub fn units(&self) -> (f32, f32) {
        (self.lo, self.scale)
    }

    /// Return a temperature in bin units.
    #[inline]
    pub fn to_units(&self, v_k: f32) -> f32 {
        (v_k - self.lo) * self.scale
    }

    /// Return the centre of bin `b`, K.
    #[inline]
    pub fn bin_mean_k(&self, b: usize) -> f32 {
        self.lo + (b as f32 + 0.5) * self.width
    }

    /// Add values given in K.
    pub fn add_slice(&mut self, values: &[f32]) {
        for &v in values {
            self.add_units(&[self.to_units(v)]);
        }
    }

    /// Add values given in bin units (the fast path: MTTS upsamples in bin units).
    #[inline]
    pub fn add_units(&mut self, values: &[f32]) {
        let last = self.bins as u32 - 1;
        for &u in values {
            // `as u32` saturates (negative and NaN → 0, too large → u32::MAX); `min` puts
            // values beyond the range in the end bins; the mask (a no-op, bins ≤ MAX_BINS, a
            // power of two) spares the bounds check.
            let b = (u as u32).min(last) as usize & (MAX_BINS - 1);
            self.count[b] += 1;
        }
    }

    /// Return the number of values added.
    pub fn total(&self) -> u32 {
        self.count[..self.bins].iter().sum()
    }
}

/// The result of a clustering: K groups ordered by temperature.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Clusters {
    /// Number of non-empty clusters (≤ the K asked for when there are fewer distinct values).
    pub k: usize,
    /// Mean temperature of each cluster, K, ascending.
    pub means: [f32; MAX_K],
    /// Values in each cluster.
    pub counts: [u32; MAX_K],
    /// Upper boundary of each cluster (a value v belongs to the first cluster whose upper
    /// boundary exceeds it); the last is +∞.
    pub upper: [f32; MAX_K],
    /// Sum of squared errors, K² (eq. 6.13) — of the binned problem (each value at its bin's
    /// centre) for [`exact_binned`], of the bin means for [`lloyd`].
    pub sse: f32,
    /// Upper bound of the SSE gap to the unbinned optimum, K² (0 for unbinned methods).
    pub binning_bound: f32,
}

impl Clusters {
    /// Return the cluster index of a value.
    ///
    /// The count of boundaries at or below `v`, by a three-step binary search over the eight
    /// ascending boundaries (those from `k − 1` on are +∞); NaN is cluster 0.
    #[inline]
    pub fn label(&self, v: f32) -> usize {
        let u = &self.upper;
        let mut c = 0;
        if v >= u[3] {
            c = 4;
        }
        if v >= u[(c + 1) & (MAX_K - 1)] {
            c += 2;
        }
        if v >= u[c & (MAX_K - 1)] {
            c += 1;
        }
        c.min(self.k.saturating_sub(1))
    }

    fn empty() -> Self {
        Clusters {
            k: 0,
            means: [f32::NAN; MAX_K],
            counts: [0; MAX_K],
            upper: [f32::INFINITY; MAX_K],
            sse: 0.0,
            binning_bound: 0.0,
        }
    }
}

/// Scratch of the dynamic programme.
pub struct DpScratch {
    // Prefix sums over the non-empty bins of the count, count·index and count·index² (at most
    // 256·192 values · 511 < 2^25 and · 511² < 2^34: u32, u32, u64).
    n: [u32; MAX_BINS + 1],
    s1: [u32; MAX_BINS + 1],
    s2: [u64; MAX_BINS + 1],
    idx: [u16; MAX_BINS],
    prev: [f32; MAX_BINS],
    cur: [f32; MAX_BINS],
    opt: [[u16; MAX_BINS]; MAX_K],
    /// Highest j whose `opt[m][j]` layer m has filled.
    done: [usize; MAX_K],
}

impl Default for DpScratch {
    fn default() -> Self {
        Self::new()
    }
}

impl DpScratch {
    /// Return empty scratch (≈ 18 KB).
    pub const fn new() -> Self {
        DpScratch {
            n: [0; MAX_BINS + 1],
            s1: [0; MAX_BINS + 1],
            s2: [0; MAX_BINS + 1],
            idx: [0; MAX_BINS],
            prev: [0.0; MAX_BINS],
            cur: [0.0; MAX_BINS],
            opt: [[0; MAX_BINS]; MAX_K],
            done: [0; MAX_K],
        }
    }

    /// SSE of the non-empty bins i..=j in bin-index units.
    #[inline]
    fn cost(&self, i: usize, j: usize) -> f32 {
        sse(
            self.n[j + 1] - self.n[i],
            self.s1[j + 1] - self.s1[i],
            self.s2[j + 1] - self.s2[i],
        )
    }
}

/// SSE of a group of `n` values with sum `s1` and sum of squares `s2` (bin-index units).
#[inline(always)]
fn sse(n: u32, s1: u32, s2: u64) -> f32 {
    // n·S2 − S1² ≥ 0 (Cauchy–Schwarz), exact in u64.
    u64_to_f32(n as u64 * s2 - s1 as u64 * s1 as u64) / n as f32
}

/// Convert without the soft-float library call `u64 as f32` becomes on the Cortex-M4: two
/// 32-bit conversions (the result may differ from `as f32` in the last bit).
#[inline]
fn u64_to_f32(x: u64) -> f32 {
    (x >> 32) as u32 as f32 * 4_294_967_296.0 + x as u32 as f32
}

/// Fill `cur[j]` for j in lo..=hi knowing its optimal split lies in opt_lo..=opt_hi.
fn dc_layer(sc: &mut DpScratch, m: usize, lo: usize, hi: usize, opt_lo: usize, opt_hi: usize) {
    // An explicit stack: depth is log2(bins), 16 frames are plenty.
    let mut stack = [(0usize, 0usize, 0usize, 0usize); 16];
    let mut sp = 0;
    stack[sp] = (lo, hi, opt_lo, opt_hi);
    sp += 1;
    while sp > 0 {
        sp -= 1;
        let (lo, hi, olo, ohi) = stack[sp];
        if lo > hi {
            continue;
        }
        let j = (lo + hi) / 2;
        // Split i: cluster m covers bins i..=j, clusters before cover 0..i (needs i ≥ m).
        // Knuth's bound: with one cluster fewer the last cluster starts no later
        // (opt[m − 1][j] ≤ opt[m][j], the split points of 1-D k-means are monotone).
        let knuth = if m >= 2 && j <= sc.done[m - 1] {
            sc.opt[m - 1][j] as usize
        } else {
            0
        };
        let first = olo.max(m).max(knuth.min(ohi.min(j)));
        let mut best = f32::INFINITY;
        let mut best_i = first;
        let last = ohi.min(j);
        if first <= last {
            // The loop over zipped slices has no bounds checks: it is most of the clustering.
            let (nj, s1j, s2j) = (sc.n[j + 1], sc.s1[j + 1], sc.s2[j + 1]);
            let prev = &sc.prev[first - 1..last];
            let ns = &sc.n[first..=last];
            let s1s = &sc.s1[first..=last];
            let s2s = &sc.s2[first..=last];
            for (d, (((&p, &ni), &s1i), &s2i)) in prev.iter().zip(ns).zip(s1s).zip(s2s).enumerate()
            {
                let c = p + sse(nj - ni, s1j - s1i, s2j - s2i);
                if c < best {
                    best = c;
                    best_i = first + d;
                }
            }
        }
        sc.cur[j] = best;
        sc.opt[m][j] = best_i as u16;
        if j > lo && sp < stack.len() {
            stack[sp] = (lo, j - 1, olo, best_i);
            sp += 1;
        }
        if j < hi && sp < stack.len() {
            stack[sp] = (j + 1, hi, best_i, ohi);
            sp += 1;
        }
    }
}

/// Exact K-means of the binned values (contiguous groups of bins), deterministic.
pub fn exact_binned(h: &Histogram, k: usize, sc: &mut DpScratch) -> Result<Clusters, MttsError> {
    if !(1..=MAX_K).contains(&k) {
        return Err(MttsError::BadK { k: k as u8 });
    }
    // Compress to the non-empty bins.
    let mut ne = 0;
    sc.n[0] = 0;
    sc.s1[0] = 0;
    sc.s2[0] = 0;
    for b in 0..h.bins {
        let c = h.count[b];
        if c == 0 {
            continue;
        }
        sc.idx[ne] = b as u16;
        sc.n[ne + 1] = sc.n[ne] + c;
        sc.s1[ne + 1] = sc.s1[ne] + c * b as u32;
        sc.s2[ne + 1] = sc.s2[ne] + c as u64 * (b * b) as u64;
        ne += 1;
    }
    if ne == 0 {
        return Err(MttsError::NoValidPixels);
    }
    let k = k.min(ne);
    sc.done = [0; MAX_K];
    for j in 0..ne {
        sc.prev[j] = sc.cost(0, j);
        sc.opt[0][j] = 0;
    }
    for m in 1..k.saturating_sub(1) {
        // Layer m needs at least m + 1 bins (j ≥ m) and must leave one bin to each later
        // cluster (j ≤ ne − 1 − (k − 1 − m)).
        let hi = ne - k + m;
        dc_layer(sc, m, m, hi, m, hi);
        sc.done[m] = hi;
        sc.prev[m..=hi].copy_from_slice(&sc.cur[m..=hi]);
    }
    if k >= 2 {
        // The last layer is only needed at j = ne − 1.
        let (m, j) = (k - 1, ne - 1);
        let mut best = (f32::INFINITY, m);
        for i in m..=j {
            let c = sc.prev[i - 1] + sc.cost(i, j);
            if c < best.0 {
                best = (c, i);
            }
        }
        sc.opt[m][j] = best.1 as u16;
    }
    // Walk the splits back: cluster m covers compressed bins start[m]..=end[m].
    let mut start = [0usize; MAX_K];
    let mut end = ne - 1;
    let mut ends = [0usize; MAX_K];
    for m in (0..k).rev() {
        ends[m] = end;
        start[m] = sc.opt[m][end] as usize;
        if m > 0 {
            end = start[m] - 1;
        }
    }
    let mut out = Clusters::empty();
    out.k = k;
    let w = h.width();
    for m in 0..k {
        // Mean of the bin centres, from the exact integer prefix sums.
        let n = (sc.n[ends[m] + 1] - sc.n[start[m]]) as u64;
        let s1 = (sc.s1[ends[m] + 1] - sc.s1[start[m]]) as u64;
        out.counts[m] = n as u32;
        out.means[m] = (h.lo as f64 + (s1 as f64 / n as f64 + 0.5) * w as f64) as f32;
        // The boundary is the lower edge of the next cluster's first bin.
        out.upper[m] = if m + 1 < k {
            h.lo + sc.idx[start[m + 1]] as f32 * w
        } else {
            f32::INFINITY
        };
    }
    // The SSE of the binned problem (values at bin centres), converted to K².
    let mut sse = 0f64;
    for m in 0..k {
        let c = sc.cost(start[m], ends[m]) as f64;
        sse += c * (w as f64) * (w as f64);
    }
    out.sse = sse as f32;
    let mut bound = 0f32;
    for m in 0..k.saturating_sub(1) {
        let mid = 0.5 * (out.means[m] + out.means[m + 1]);
        let b = h.bin_of(mid);
        bound += h.count[b] as f32 * 2.0 * w * (out.means[m + 1] - out.means[m]);
    }
    out.binning_bound = bound;
    Ok(out)
}

/// Seeding of [`lloyd`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Seeding {
    /// K distinct values drawn at random (the thesis).
    Random,
    /// k-means++ (D² sampling).
    KMeansPlusPlus,
}

/// A small seeded generator (xorshift64*), deterministic for a seed.
#[derive(Clone, Copy, Debug)]
pub struct XorShift(u64);

impl XorShift {
    /// Make a generator (a zero seed is replaced by a constant).
    pub const fn new(seed: u64) -> Self {
        XorShift(if seed == 0 {
            0x9E37_79B9_7F4A_7C15
        } else {
            seed
        })
    }

    /// Return a uniform value in [0, 1).
    pub fn next_f32(&mut self) -> f32 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let r = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D);
        (r >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// Lloyd's algorithm on the histogram (each bin a weighted point at its mean), seeded, at most
/// `max_iter` iterations; stops when the assignment no longer changes.
pub fn lloyd(
    h: &Histogram,
    k: usize,
    seeding: Seeding,
    rng: &mut XorShift,
    max_iter: usize,
) -> Result<Clusters, MttsError> {
    if !(1..=MAX_K).contains(&k) {
        return Err(MttsError::BadK { k: k as u8 });
    }
    let total = h.total();
    if total == 0 {
        return Err(MttsError::NoValidPixels);
    }
    let bins = h.bins;
    let mean_of = |b: usize| h.bin_mean_k(b);
    // Draw a bin with probability ∝ weight(b).
    let draw = |rng: &mut XorShift, weight: &dyn Fn(usize) -> f32| -> Option<usize> {
        let tot: f32 = (0..bins).map(weight).sum();
        if tot <= 0.0 {
            return None;
        }
        let mut r = rng.next_f32() * tot;
        let mut last = None;
        for b in 0..bins {
            let w = weight(b);
            if w > 0.0 {
                last = Some(b);
                if r < w {
                    return Some(b);
                }
                r -= w;
            }
        }
        last
    };
    let mut c = [0f32; MAX_K];
    let mut kk = 0;
    while kk < k {
        let chosen = match seeding {
            Seeding::Random => draw(rng, &|b| {
                if h.count[b] > 0 && !c[..kk].contains(&mean_of(b)) {
                    h.count[b] as f32
                } else {
                    0.0
                }
            }),
            Seeding::KMeansPlusPlus => draw(rng, &|b| {
                if h.count[b] == 0 {
                    return 0.0;
                }
                let v = mean_of(b);
                let d = c[..kk]
                    .iter()
                    .fold(f32::INFINITY, |m, &ci| m.min((v - ci).abs()));
                if kk == 0 {
                    h.count[b] as f32
                } else {
                    h.count[b] as f32 * d * d
                }
            }),
        };
        match chosen {
            Some(b) => {
                c[kk] = mean_of(b);
                kk += 1;
            }
            None => break, // fewer distinct values than K
        }
    }
    let k = kk;
    let mut assign = [0u8; MAX_BINS];
    for it in 0..=max_iter {
        let mut changed = false;
        for (b, a) in assign.iter_mut().enumerate().take(bins) {
            if h.count[b] == 0 {
                continue;
            }
            let v = mean_of(b);
            let mut best = 0;
            for j in 1..k {
                if (v - c[j]).abs() < (v - c[best]).abs() {
                    best = j;
                }
            }
            changed |= *a as usize != best;
            *a = best as u8;
        }
        if it > 0 && !changed {
            break;
        }
        let mut n = [0f64; MAX_K];
        let mut s = [0f64; MAX_K];
        for b in 0..bins {
            if h.count[b] > 0 {
                n[assign[b] as usize] += h.count[b] as f64;
                s[assign[b] as usize] += h.count[b] as f64 * mean_of(b) as f64;
            }
        }
        for j in 0..k {
            if n[j] > 0.0 {
                c[j] = (s[j] / n[j]) as f32;
            }
        }
    }
    // Order clusters by mean and report them.
    // An insertion sort of at most MAX_K (`core`'s sort would take 4.9 KB of the board's flash).
    let mut order: [usize; MAX_K] = core::array::from_fn(|i| i);
    for i in 1..k {
        let mut j = i;
        while j > 0 && c[order[j - 1]].total_cmp(&c[order[j]]).is_gt() {
            order.swap(j - 1, j);
            j -= 1;
        }
    }
    let mut out = Clusters::empty();
    let mut sse = 0f64;
    let mut rank = [0usize; MAX_K];
    for (r, &j) in order[..k].iter().enumerate() {
        rank[j] = r;
    }
    let mut maxv = [f32::NEG_INFINITY; MAX_K];
    for b in 0..bins {
        if h.count[b] == 0 {
            continue;
        }
        let r = rank[assign[b] as usize];
        out.counts[r] += h.count[b];
        let d = (mean_of(b) - c[assign[b] as usize]) as f64;
        sse += h.count[b] as f64 * d * d;
        maxv[r] = maxv[r].max(mean_of(b));
    }
    let mut m = 0;
    for r in 0..k {
        if out.counts[r] == 0 {
            continue;
        }
        out.means[m] = c[order[r]];
        out.counts[m] = out.counts[r];
        maxv[m] = maxv[r];
        m += 1;
    }
    out.k = m;
    for r in 0..m {
        out.upper[r] = if r + 1 < m {
            0.5 * (out.means[r] + out.means[r + 1])
        } else {
            f32::INFINITY
        };
    }
    for r in m..MAX_K {
        out.counts[r] = 0;
        out.means[r] = f32::NAN;
    }
    out.sse = sse as f32;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute force over every split of the non-empty bins into k contiguous groups.
    fn brute(h: &Histogram, k: usize) -> f64 {
        let bins: std::vec::Vec<usize> = (0..h.bins()).filter(|&b| h.count[b] > 0).collect();
        let n = bins.len();
        let cost = |a: usize, b: usize| {
            let (mut c, mut s1, mut s2) = (0f64, 0f64, 0f64);
            for &x in &bins[a..=b] {
                let w = h.count[x] as f64;
                c += w;
                s1 += w * x as f64;
                s2 += w * (x * x) as f64;
            }
            s2 - s1 * s1 / c
        };
        fn rec(start: usize, k: usize, n: usize, cost: &dyn Fn(usize, usize) -> f64) -> f64 {
            if k == 1 {
                return cost(start, n - 1);
            }
            (start..=n - k)
                .map(|end| cost(start, end) + rec(end + 1, k - 1, n, cost))
                .fold(f64::INFINITY, f64::min)
        }
        rec(0, k.min(n), n, &cost) * (h.width() as f64).powi(2)
    }

    fn random_hist(seed: u64, bins: usize, n: usize) -> Histogram {
        let mut rng = XorShift::new(seed);
        let mut h = Histogram::new(290.0, 350.0, bins).unwrap();
        let centres = [300.0, 312.0, 325.0, 331.0, 345.0];
        for i in 0..n {
            let c = centres[i % centres.len()];
            let v = c + 6.0 * (rng.next_f32() - 0.5) * (1.0 + (i % 3) as f32);
            h.add_slice(&[v.clamp(290.0, 350.0)]);
        }
        h
    }

    #[test]
    fn dynamic_programme_matches_brute_force() {
        let mut sc = std::boxed::Box::new(DpScratch::new());
        for seed in 1..40 {
            let h = random_hist(seed, 24, 200);
            for k in 1..=5 {
                let c = exact_binned(&h, k, &mut sc).unwrap();
                let want = brute(&h, k);
                assert!(
                    (c.sse as f64 - want).abs() <= 1e-3 * want.max(1.0),
                    "seed {seed} k {k}: {} vs {want}",
                    c.sse
                );
                assert_eq!(c.counts[..c.k].iter().sum::<u32>(), 200);
                assert!(c.means[..c.k].windows(2).all(|w| w[0] < w[1]));
            }
        }
    }

    #[test]
    fn fewer_distinct_values_than_k() {
        let mut h = Histogram::new(300.0, 310.0, 64).unwrap();
        h.add_slice(&[300.0, 300.0, 310.0]);
        let mut sc = std::boxed::Box::new(DpScratch::new());
        let c = exact_binned(&h, 5, &mut sc).unwrap();
        assert_eq!(c.k, 2);
        assert_eq!(c.counts[..2], [2, 1]);
        assert_eq!(c.label(300.0), 0);
        assert_eq!(c.label(310.0), 1);
        let l = lloyd(&h, 5, Seeding::KMeansPlusPlus, &mut XorShift::new(3), 50).unwrap();
        assert_eq!(l.k, 2);
    }

    #[test]
    fn lloyd_is_deterministic_per_seed_and_never_beats_the_optimum() {
        let mut sc = std::boxed::Box::new(DpScratch::new());
        let h = random_hist(7, 256, 3000);
        let best = exact_binned(&h, 5, &mut sc).unwrap();
        for seeding in [Seeding::Random, Seeding::KMeansPlusPlus] {
            let a = lloyd(&h, 5, seeding, &mut XorShift::new(11), 100).unwrap();
            let b = lloyd(&h, 5, seeding, &mut XorShift::new(11), 100).unwrap();
            assert_eq!(std::format!("{a:?}"), std::format!("{b:?}"));
            // Lloyd's SSE is of bin means, the DP's of bin centres: compare loosely.
            assert!(a.sse >= best.sse - h.total() as f32 * h.width() * h.width());
        }
    }

    #[test]
    fn argument_errors() {
        let h = Histogram::new(0.0, 1.0, 8).unwrap();
        let mut sc = std::boxed::Box::new(DpScratch::new());
        assert_eq!(
            exact_binned(&h, 3, &mut sc).unwrap_err(),
            MttsError::NoValidPixels
        );
        assert_eq!(
            exact_binned(&h, 9, &mut sc).unwrap_err(),
            MttsError::BadK { k: 9 }
        );
        assert!(Histogram::new(0.0, 1.0, 1).is_err());
        assert!(Histogram::new(f32::NAN, 1.0, 8).is_err());
    }

    #[test]
    fn label_is_the_count_of_boundaries_below() {
        for k in 1..=MAX_K {
            let mut c = Clusters::empty();
            c.k = k;
            for m in 0..k - 1 {
                c.upper[m] = 300.0 + 5.0 * m as f32;
            }
            for i in 0..200 {
                let v = 295.0 + i as f32 * 0.25;
                let want = (0..k - 1).filter(|&m| v >= c.upper[m]).count();
                assert_eq!(c.label(v), want, "k={k} v={v}");
            }
            assert_eq!(c.label(f32::NAN), 0);
        }
    }
}
