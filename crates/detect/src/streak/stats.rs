//! Robust statistics of the detector's maps: the histogram median and MAD of the background
//! cells, medians of small sets, and the median and MAD-sigma of a whole map from a regular
//! subsample ([`soig_image::imaging::robust_stats`] of it). The rounding (f64 mean of the middle pair
//! for small sets, histogram for cells, subsampling for maps) is part of the pinned output.

use soig_image::imaging::robust_stats;

/// Continuous CDF and quantiles of an 8-bit histogram, each grey level spread uniformly over
/// [v - 0.5, v + 0.5).
pub(super) struct Hist {
    counts: [u32; 256],
    cum: [u64; 257],
}

impl Hist {
    pub(super) fn new(counts: [u32; 256]) -> Self {
        let mut cum = [0u64; 257];
        for v in 0..256 {
            cum[v + 1] = cum[v] + counts[v] as u64;
        }
        Hist { counts, cum }
    }
    pub(super) fn total(&self) -> u64 {
        self.cum[256]
    }
    fn cdf(&self, x: f64) -> f64 {
        let b = (x + 0.5).floor();
        if b < 0.0 {
            return 0.0;
        }
        if b > 255.0 {
            return self.total() as f64;
        }
        let bi = b as usize;
        self.cum[bi] as f64 + self.counts[bi] as f64 * (x + 0.5 - b)
    }
    pub(super) fn quantile(&self, q: f64) -> f64 {
        let target = q * self.total() as f64;
        // First bin whose cumulative count reaches the target.
        let mut b = 0;
        while b < 255 && (self.cum[b + 1] as f64) < target {
            b += 1;
        }
        let c = self.counts[b].max(1) as f64;
        b as f64 - 0.5 + ((target - self.cum[b] as f64) / c).clamp(0.0, 1.0)
    }
    /// Median absolute deviation around `m`.
    pub(super) fn mad(&self, m: f64) -> f64 {
        let half = 0.5 * self.total() as f64;
        let (mut lo, mut hi) = (0.0f64, 256.0f64);
        for _ in 0..40 {
            let r = 0.5 * (lo + hi);
            if self.cdf(m + r) - self.cdf(m - r) < half {
                lo = r;
            } else {
                hi = r;
            }
        }
        0.5 * (lo + hi)
    }
}

/// Median of a small set (reorders it), the mean of the two middle values for an even count.
/// By selection, not a full sort: the same values, in linear time (the line filter's noise
/// measurement takes hundreds of medians of 4096 sums per image).
pub(super) fn median_of(v: &mut [f64]) -> f64 {
    let n = v.len();
    let (lower, mid, _) = v.select_nth_unstable_by(n / 2, |a, b| a.total_cmp(b));
    let mid = *mid;
    if n % 2 == 1 {
        mid
    } else {
        let below = lower.iter().copied().max_by(|a, b| a.total_cmp(b));
        0.5 * (below.expect("an even, non-empty set has a value below the middle") + mid)
    }
}

/// A regular subsample of a map: every pixel, or every third pixel of every third row above
/// 40 000 pixels.
fn subsample(v: &[f32], w: usize, h: usize) -> Vec<f32> {
    let step = if w * h > 40_000 { 3 } else { 1 };
    let mut s: Vec<f32> = Vec::with_capacity((w / step + 1) * (h / step + 1));
    for y in (0..h).step_by(step) {
        for x in (0..w).step_by(step) {
            s.push(v[y * w + x]);
        }
    }
    s
}

/// Median and robust (1.4826 MAD) standard deviation of a map, from a regular subsample. The
/// maps are finite (derived from 8-bit pixels over a noise floored at `min_noise_sigma`), so
/// [`robust_stats`] drops nothing.
#[inline(never)]
pub(super) fn map_stats(v: &[f32], w: usize, h: usize) -> (f64, f64) {
    robust_stats(&subsample(v, w, h))
}
