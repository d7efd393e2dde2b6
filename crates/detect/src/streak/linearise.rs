//! Step 0 of the star-aware pass where `[detect.streak] linearise` asks for it: the
//! enhancement's stretch undone, so that a faint streak's light adds to the sky as it does on
//! the sensor.
//!
//! The 8-bit image is a non-linear stretch of the flux (square root, log, CLAHE, gamma: see
//! `soig_image::enhance`): on a faint-limit development image (faint-limit-fixed seed 9422,
//! image 150) the sky's grey levels span about 100 levels below their median (152) and 40
//! above it (5th and 95th percentiles 52 and 190). A streak a fraction of a sigma above the sky
//! lands in the compressed upper half, so a line sum of grey levels gains less than its
//! photons' share: along the truth's line of seven faint streaks of that set (line SNR
//! 8.4-10), a Gaussian matched filter read 5-30 % more SNR after this step (every level
//! ranked, 25 levels a sigma: the first form, in numpy). Each grey level
//! below [`RANKED_SHARE`] of the ranks is mapped to the normal quantile of its mid-rank share
//! of the pixels inside the frame's footprint: noise that is a monotonic stretch of Gaussian
//! noise becomes Gaussian again, whatever the stretch, and a faint streak on it adds linearly.
//!
//! Measured (`examples/sky_eval`, scored by `scripts/faint_limit.py` or `soig eval`), off ->
//! on. Held out, `bash scripts/faint-limit.sh faint-limit-survey-linearised
//! faint-limit-survey-semisynthetic-linearised` (seeds 9401 and the dark frame's, 300 images
//! each): survey synthetic SNR50 12.5 -> 9.8, found 160 -> 175, false boxes 6 -> 6 (P 0.964
//! -> 0.967); NEOSSat dark frame SNR50 18.5 -> 12.1, found 83 -> 110, false boxes 2 -> 1 (P
//! 0.976 -> 0.991). Development faint sets (seed 9402, 150 images): 75 -> 91 found, 2 -> 3
//! false boxes; dark frame 41 -> 61, 0 -> 3. The survey rows' development sets (seeds 777 /
//! 778), mAP50-95: original synthetic 0.9472 -> 0.9428, original semisynthetic 0.8856 ->
//! 0.9315, rotated synthetic 0.9727 -> 0.9447, rotated semisynthetic 0.8908 -> 0.9041. The
//! rotated synthetic set loses through its boxes (the same streaks found; a 10 px tall box
//! along the trails a pixel off, ends a few px short): the fit (`fit`) was tuned on the
//! stretched map, and fitted on the image as it is instead (a second unit-noise map) its boxes
//! took the unsubtracted trails' light where debris runs along them. So the rows leave it off.
//! Where stars are points (fixed pointing) the pass does not linearise: on faint-limit-fixed
//! seed 9422 (300 images) it found 194 -> 213 but made 11 -> 28 false boxes (chains of star
//! blobs; tumbling streaks whose dim phase, expanded less than the bright, read as a gap).

use super::fit::inside;
use super::params::Footprint;
use statrs::function::erf::erfc_inv;

/// Grey levels per sigma of the linearised image: 128 +- 10.6 sigma fits in 8 bits, room for
/// a bright streak over a trail (the detector reads levels of 10 sigma and more; at 25 levels
/// a sigma, a test's 8-sigma streak along a 2.5-sigma trail was clipped to the trail's level
/// and explained by it); a level's rounding adds (1/12)^2 / 12 = 0.06 % to the noise's variance.
const LEVELS_PER_SIGMA: f64 = 12.0;
/// The linearised image's median grey level.
const MIDDLE: f64 = 128.0;
/// The ranks' share up to which a level takes its rank's normal quantile: about +1.6 sigma of
/// the sky, where a faint streak's pixels lie. Above it the image holds stars and trails as
/// much as sky (a survey frame's trails are several percent of its pixels), whose ranks would
/// squeeze them into the quantiles' last sigma or two; there each level goes on at the slope
/// the upper half of the sky had (from its median to this share).
const RANKED_SHARE: f64 = 0.95;

/// `pixels` (`w` x `h`) with each grey level replaced by its rank's normal quantile, the
/// ranks counted over the pixels inside `footprint` (all where None); see the module docs.
pub(super) fn rank_normal(
    pixels: &[u8],
    w: usize,
    h: usize,
    footprint: Option<&Footprint>,
) -> Vec<u8> {
    let lut = rank_normal_levels(&histogram(pixels, w, h, footprint));
    pixels.iter().map(|&v| lut[v as usize]).collect()
}

/// How many pixels inside `footprint` (all where None) have each grey level.
fn histogram(pixels: &[u8], w: usize, h: usize, footprint: Option<&Footprint>) -> [u64; 256] {
    let mut counts = [0u64; 256];
    if w == 0 {
        return counts;
    }
    let last = (w - 1) as f64;
    for y in 0..h {
        // The row's pixel centres inside the footprint.
        let (lo, hi) = match footprint {
            Some(f) => {
                let (a, b) = inside(f, (0.0, y as f64), (1.0, 0.0));
                (a.ceil().max(0.0), b.floor().min(last))
            }
            None => (0.0, last),
        };
        if lo > hi {
            continue;
        }
        for &v in &pixels[y * w + lo as usize..=y * w + hi as usize] {
            counts[v as usize] += 1;
        }
    }
    counts
}

/// The grey level each of the 256 takes: `MIDDLE` plus `LEVELS_PER_SIGMA` times the normal
/// quantile of its mid-rank share of `counts`, up to [`RANKED_SHARE`], and beyond it straight
/// on (a level no pixel has takes its neighbours' share, which orders it between them).
fn rank_normal_levels(counts: &[u64; 256]) -> [u8; 256] {
    let n = counts.iter().sum::<u64>().max(1) as f64;
    let mut sigmas = [0.0f64; 256];
    let (mut below, mut median, mut top) = (0.0, None, None);
    for (v, &c) in counts.iter().enumerate() {
        let share = ((below + 0.5 * c as f64) / n).clamp(0.5 / n, 1.0 - 0.5 / n);
        below += c as f64;
        sigmas[v] = -std::f64::consts::SQRT_2 * erfc_inv(2.0 * share);
        let upto = below / n;
        if median.is_none() && upto >= 0.5 {
            median = Some(v);
        }
        if top.is_none() && upto >= RANKED_SHARE {
            top = Some(v);
        }
    }
    let (median, top) = (median.unwrap_or(0), top.unwrap_or(255));
    // Sigmas a grey level above the top: the upper half's slope; where the sky spans no level
    // between its median and the top (a noise-free image), the grey levels' own scale.
    let slope = if top > median {
        (sigmas[top] - sigmas[median]) / (top - median) as f64
    } else {
        1.0 / LEVELS_PER_SIGMA
    };
    let mut lut = [0u8; 256];
    for (v, level) in lut.iter_mut().enumerate() {
        let s = if v > top {
            sigmas[top] + slope * (v - top) as f64
        } else {
            sigmas[v]
        };
        *level = (MIDDLE + LEVELS_PER_SIGMA * s).round().clamp(0.0, 255.0) as u8;
    }
    lut
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    /// `w` x `h` pixels of unit Gaussian noise (seed `seed`), `line` more on row `ROW`, through
    /// a compressive stretch (a log, as the enhancement's) to 8 bits.
    fn stretched_noise(w: usize, h: usize, seed: u64, line: f64) -> Vec<u8> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let normal = Normal::new(0.0, 1.0).unwrap();
        let stretch =
            |x: f64| (40.0 * (1.0 + x / 3.5).max(0.01).ln() + 150.0).clamp(0.0, 255.0) as u8;
        (0..w * h)
            .map(|i| stretch(normal.sample(&mut rng) + if i / w == ROW { line } else { 0.0 }))
            .collect()
    }

    const ROW: usize = 200;

    /// Gaussian noise through a compressive stretch comes back symmetric about the median with
    /// the linearised levels' sigma, where the stretched levels are not: the upper half spans
    /// less than the lower.
    #[test]
    fn a_stretched_gaussian_comes_back_gaussian() {
        let (w, h) = (256, 256);
        let pixels = stretched_noise(w, h, 7, 0.0);
        let spread = |v: &[u8]| {
            let mut s: Vec<f64> = v.iter().map(|&x| x as f64).collect();
            s.sort_by(f64::total_cmp);
            let q = |p: f64| s[(p * (s.len() - 1) as f64) as usize];
            (q(0.5) - q(0.1587), q(0.8413) - q(0.5))
        };
        let (below, above) = spread(&pixels);
        assert!(
            above < 0.85 * below,
            "the stretch compresses the upper half: {below} {above}"
        );
        let lin = rank_normal(&pixels, w, h, None);
        let (below, above) = spread(&lin);
        for s in [below, above] {
            // One sigma is LEVELS_PER_SIGMA levels; the stretch's own 8-bit rounding merges a
            // few levels, so a quantile lands within 2.5 levels (0.2 sigma) of it.
            assert!((s - LEVELS_PER_SIGMA).abs() < 2.5, "{below} {above}");
        }
    }

    /// A faint line on stretched noise: its mean excess over the noise, in the noise's own
    /// sigmas, is larger after linearising (the stretch had compressed it).
    #[test]
    fn a_faint_line_gains_significance() {
        let (w, h) = (512, 512);
        let pixels = stretched_noise(w, h, 11, 0.5);
        let significance = |v: &[u8]| {
            let row = |y: usize| v[y * w..(y + 1) * w].iter().map(|&x| x as f64).sum::<f64>();
            let others: Vec<f64> = (0..h).filter(|&y| y != ROW).map(row).collect();
            let mean = others.iter().sum::<f64>() / others.len() as f64;
            let sd = (others.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / others.len() as f64)
                .sqrt();
            (row(ROW) - mean) / sd
        };
        let before = significance(&pixels);
        let after = significance(&rank_normal(&pixels, w, h, None));
        assert!(after > 1.05 * before, "{before} -> {after}");
    }

    /// Only the pixels inside the footprint are ranked: a padded frame's fill (here all 0)
    /// does not move the sky's median off `MIDDLE`.
    #[test]
    fn the_fill_outside_the_footprint_is_not_ranked() {
        let (w, h) = (100, 100);
        let mut pixels = vec![0u8; w * h];
        for y in 20..80 {
            for x in 20..80 {
                pixels[y * w + x] = if (x + y) % 2 == 0 { 100 } else { 110 };
            }
        }
        let fp: Footprint = [[19.5, 19.5], [79.5, 19.5], [79.5, 79.5], [19.5, 79.5]];
        let lin = rank_normal(&pixels, w, h, Some(&fp));
        // Half the sky at each of two levels: at -0.674 and +0.674 sigma.
        assert_eq!(
            lin[50 * w + 50],
            (MIDDLE - 0.6745 * LEVELS_PER_SIGMA).round() as u8
        );
        assert_eq!(
            lin[50 * w + 51],
            (MIDDLE + 0.6745 * LEVELS_PER_SIGMA).round() as u8
        );
    }
}
