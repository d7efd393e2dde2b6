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

/// Median of a small set, the mean of the two middle values for an even count. By selection,
/// not a full sort: the same values, in linear time (the line filter's noise measurement
/// takes hundreds of medians of 4096 sums per image). The selection orders integer keys that
/// order as `f64::total_cmp` orders the values (`total_cmp` makes that key of both values at
/// every comparison; here each is made once), so the values picked are `total_cmp`'s, bit for
/// bit; `v` is left as it is.
pub(super) fn median_of(v: &[f64]) -> f64 {
    let n = v.len();
    let mut keys: Vec<i64> = v.iter().map(|&x| total_key(x)).collect();
    let (lower, mid, _) = keys.select_nth_unstable(n / 2);
    let mid = from_total_key(*mid);
    if n % 2 == 1 {
        mid
    } else {
        let below = lower.iter().copied().max().map(from_total_key);
        0.5 * (below.expect("an even, non-empty set has a value below the middle") + mid)
    }
}

/// The running median of `v` over windows of `n` values centred on each (`n / 2` either side,
/// fewer at the ends), by [`median_of`].
pub(super) fn running_median(v: &[f64], n: usize) -> Vec<f64> {
    let half = n / 2;
    (0..v.len())
        .map(|i| median_of(&v[i.saturating_sub(half)..(i + half + 1).min(v.len())]))
        .collect()
}

/// `f64::total_cmp`'s key: the bits as a signed integer, a negative's flipped but for the
/// sign, so that integer order is `total_cmp`'s order.
fn total_key(x: f64) -> i64 {
    let b = x.to_bits() as i64;
    b ^ ((((b >> 63) as u64) >> 1) as i64)
}

/// The value of a [`total_key`] (the flip is its own inverse).
fn from_total_key(k: i64) -> f64 {
    f64::from_bits((k ^ ((((k >> 63) as u64) >> 1) as i64)) as u64)
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

#[cfg(test)]
mod tests {
    use super::median_of;

    /// `median_of` by integer keys picks the bits `select_nth_unstable_by(f64::total_cmp)`
    /// picks: odd and even counts, negatives, both zeros, repeats, infinities and NaN.
    #[test]
    fn median_by_keys_is_total_cmp_s_median() {
        let reference = |v: &[f64]| -> f64 {
            let mut v = v.to_vec();
            let n = v.len();
            let (lower, mid, _) = v.select_nth_unstable_by(n / 2, f64::total_cmp);
            let mid = *mid;
            if n % 2 == 1 {
                mid
            } else {
                0.5 * (lower.iter().copied().max_by(f64::total_cmp).unwrap() + mid)
            }
        };
        let mut state = 7u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            state >> 11
        };
        let special = [
            0.0,
            -0.0,
            1.5,
            -1.5,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            -f64::NAN,
        ];
        for n in 1..60 {
            for _ in 0..20 {
                let v: Vec<f64> = (0..n)
                    .map(|_| match next() % 5 {
                        0 => special[(next() % 8) as usize],
                        1 => (next() % 7) as f64 - 3.0,
                        _ => (next() as f64 / (1u64 << 53) as f64 - 0.5) * 1e3,
                    })
                    .collect();
                let got = median_of(&v);
                assert_eq!(got.to_bits(), reference(&v).to_bits(), "{v:?}");
            }
        }
    }
}
