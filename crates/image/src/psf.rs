//! The streak flux model: a Gaussian PSF integrated over each pixel, summed over point samples
//! of a path. The renderer draws its debris from it and takes the label box from it; the
//! streak detector boxes the streak it fitted with it, so truth and detection share one model.

use crate::geometry::{BoxPx, flux_box};
use crate::psf_shape::Psf;
use soig_base::rng::{PixelRng, poisson};
use std::borrow::Cow;

/// Pixels farther than this many PSF sigmas from a debris sample get none of its photons in
/// `DebrisFlux`: a share of 2.6e-12 per side and axis, under 1e-5 of the 0.85 million photons
/// of a quickstart streak, so the per-pixel draw lands what tracing lands.
const DEBRIS_SUPPORT_SIGMA: f64 = 7.0;

/// One object's noise-free photo-electrons within a box of the image (zero outside it): what
/// its label box and its warp into another frame need, without a whole image per object.
pub struct DebrisMap {
    pub x0: usize,
    pub y0: usize,
    pub width: usize,
    pub height: usize,
    pub counts: Vec<u32>,
}

impl DebrisMap {
    /// The box of a whole image's map that holds every lit pixel.
    pub fn crop(image: &[u32], image_width: usize) -> DebrisMap {
        let lit_rows: Vec<(usize, usize, usize)> = image
            .chunks_exact(image_width.max(1))
            .enumerate()
            .filter_map(|(j, row)| {
                let first = row.iter().position(|&v| v > 0)?;
                Some((j, first, row.iter().rposition(|&v| v > 0).unwrap_or(first)))
            })
            .collect();
        let (Some(top), Some(bottom)) = (lit_rows.first(), lit_rows.last()) else {
            return DebrisMap {
                x0: 0,
                y0: 0,
                width: 0,
                height: 0,
                counts: Vec::new(),
            };
        };
        let x0 = lit_rows.iter().map(|r| r.1).min().unwrap_or(0);
        let x1 = lit_rows.iter().map(|r| r.2).max().unwrap_or(0);
        let (y0, width, height) = (top.0, x1 - x0 + 1, bottom.0 - top.0 + 1);
        let counts = (y0..y0 + height)
            .flat_map(|j| &image[j * image_width + x0..j * image_width + x0 + width])
            .copied()
            .collect();
        DebrisMap {
            x0,
            y0,
            width,
            height,
            counts,
        }
    }

    /// The label box ([`flux_box`] holding `share`) in the image's pixel-centre coordinates:
    /// the box of the whole image's map, to the bit (the zeros around change no sum).
    pub fn label_box(&self, share: f64) -> Option<BoxPx> {
        let b = flux_box(&self.counts, self.width, self.height, share)?;
        Some(b.shifted(self.x0 as f64, self.y0 as f64))
    }

    /// Each row of the box: its pixels' range in a whole image (rows `image_width` long) and
    /// in `counts`.
    pub fn rows(
        &self,
        image_width: usize,
    ) -> impl Iterator<Item = (std::ops::Range<usize>, std::ops::Range<usize>)> + '_ {
        (0..self.height).map(move |j| {
            let start = (self.y0 + j) * image_width + self.x0;
            (
                start..start + self.width,
                j * self.width..(j + 1) * self.width,
            )
        })
    }

    /// The whole image's map, as floats (for a warp into another frame).
    pub fn to_image(&self, image_width: usize, image_height: usize) -> Vec<f32> {
        let mut image = vec![0.0f32; image_width * image_height];
        for (to, from) in self.rows(image_width) {
            for (t, &c) in image[to].iter_mut().zip(&self.counts[from]) {
                *t = c as f32;
            }
        }
        image
    }
}

/// The debris' expected photo-electrons per pixel on the box its PSF reaches: each trajectory
/// sample's photons at its jittered position (all arrive at the sample's time), the PSF
/// integrated over each pixel. No node merging: it is exact up to the 7-sigma support and
/// erfc's 1.2e-7.
pub struct DebrisFlux {
    x0: usize,
    y0: usize,
    width: usize,
    mean: Vec<f64>,
    /// The columns of each row of the box that hold flux, [first, end): a diagonal streak
    /// fills a fraction of its box.
    spans: Vec<(usize, usize)>,
}

impl DebrisFlux {
    /// The expected electrons of point samples `(electrons, x, y)` (pixel centres at
    /// integers) through a Gaussian PSF of `psf_px` on a `w` x `h` image: what
    /// the renderer (`render::expected::debris_flux`) does with the debris' trajectory, and what the streak
    /// detector does with the streak it fitted, so that both boxes come from one model.
    pub fn of_samples(samples: &[(f64, f64, f64)], psf_px: f64, w: usize, h: usize) -> DebrisFlux {
        DebrisFlux::of_samples_psf(samples, &Psf::gaussian(psf_px), w, h)
    }

    /// `of_samples` through any PSF shape ([`Psf`]): each of its Gaussians integrated over
    /// the pixels of its own support, weighted.
    pub fn of_samples_psf(
        samples: &[(f64, f64, f64)],
        psf: &Psf,
        w: usize,
        h: usize,
    ) -> DebrisFlux {
        // The box holds the farthest any Gaussian reaches (one "sigma" of that many pixels).
        let reach = psf.reach_px(DEBRIS_SUPPORT_SIGMA);
        let samples: Vec<(f64, f64, f64)> = samples
            .iter()
            .copied()
            .filter(|&(e, x, y)| e > 0.0 && x.is_finite() && y.is_finite())
            .collect();
        // Each Gaussian's nodes: a Gaussian's are its samples; a mixture's wide Gaussians
        // have fewer (`merge_samples`).
        let spacing = max_spacing(&samples);
        let gaussians: Vec<(Supported, Cow<[Sample]>)> = psf
            .supported(DEBRIS_SUPPORT_SIGMA)
            .map(|g| match psf.is_gaussian() {
                true => (g, Cow::Borrowed(samples.as_slice())),
                false => (g, Cow::Owned(merge_samples(&samples, g.1, spacing))),
            })
            .collect();
        // The box: the union of every sample's support within the image, and of every merged
        // node's (a node between a sample off the image and one on it reaches where neither
        // sample's support put the box).
        let (mut lo, mut hi) = ([usize::MAX; 2], [0usize; 2]);
        let mut extend = |xs: Option<(usize, usize)>, ys: Option<(usize, usize)>| {
            if let (Some(xs), Some(ys)) = (xs, ys) {
                lo = [lo[0].min(xs.0), lo[1].min(ys.0)];
                hi = [hi[0].max(xs.1), hi[1].max(ys.1)];
            }
        };
        for &(_, x, y) in &samples {
            extend(support(x, reach, 1.0, w), support(y, reach, 1.0, h));
        }
        if !psf.is_gaussian() {
            for ((_, sigma, n), nodes) in &gaussians {
                for &(_, x, y) in nodes.iter() {
                    extend(support(x, *sigma, *n, w), support(y, *sigma, *n, h));
                }
            }
        }
        if lo[0] > hi[0] || lo[1] > hi[1] {
            return DebrisFlux {
                x0: 0,
                y0: 0,
                width: 0,
                mean: Vec::new(),
                spans: Vec::new(),
            };
        }
        let width = hi[0] - lo[0] + 1;
        let height = hi[1] - lo[1] + 1;
        let mut mean = vec![0.0; width * height];
        let mut spans = vec![(usize::MAX, 0); height];
        let (mut wx, mut wy) = (Vec::new(), Vec::new());
        // A Gaussian's one component has weight 1: `amount * 1.0` is `amount`, bit for bit.
        for ((share, sigma, n), nodes) in &gaussians {
            let (share, sigma, n) = (*share, *sigma, *n);
            for &(amount, x, y) in nodes.iter() {
                let (Some(i0), Some(j0)) = (
                    weights_into(x, sigma, n, w, &mut wx),
                    weights_into(y, sigma, n, h, &mut wy),
                ) else {
                    continue;
                };
                let (col, row) = (i0 - lo[0], j0 - lo[1]);
                for span in &mut spans[row..row + wy.len()] {
                    *span = (span.0.min(col), span.1.max(col + wx.len()));
                }
                add_separable(&mut mean, width, (col, &wx), (row, &wy), amount * share);
            }
        }
        DebrisFlux {
            x0: lo[0],
            y0: lo[1],
            width,
            mean,
            spans,
        }
    }

    /// One Poisson draw per pixel of the box into `counts`, the whole image's debris counts
    /// (rows `image_width` long); returns their sum. N ~ Poisson(lambda) photons of a sample,
    /// each landing in pixel k with the PSF's share p_k, put independent Poisson(lambda p_k)
    /// counts in the pixels, and sums of independent Poissons are Poisson: this is the
    /// distribution of tracing every photon singly, at the cost of the pixels the streak
    /// reaches instead of its photons (0.85 million normal pairs per quickstart image).
    pub fn draw(&self, rng: &mut PixelRng, counts: &mut [u32], image_width: usize) -> u64 {
        self.draw_at(rng, counts, image_width, (self.x0, self.y0))
    }

    /// `draw` into a map of the flux's own box (`DebrisMap`): the same draws in the same
    /// order, without a whole image of zeros around them.
    pub fn draw_own_box(&self, rng: &mut PixelRng) -> (DebrisMap, u64) {
        let mut map = DebrisMap {
            x0: self.x0,
            y0: self.y0,
            width: self.width,
            height: self.spans.len(),
            counts: vec![0; self.width * self.spans.len()],
        };
        let total = self.draw_at(rng, &mut map.counts, self.width, (0, 0));
        (map, total)
    }

    /// `draw` into `counts`, rows `stride` long, the box's corner at `origin`.
    fn draw_at(
        &self,
        rng: &mut PixelRng,
        counts: &mut [u32],
        stride: usize,
        origin: (usize, usize),
    ) -> u64 {
        let mut total = 0u64;
        for (j, &(first, end)) in self.spans.iter().enumerate() {
            if first >= end {
                continue;
            }
            let row = &self.mean[j * self.width + first..j * self.width + end];
            let start = (origin.1 + j) * stride + origin.0 + first;
            for (c, &m) in counts[start..start + row.len()].iter_mut().zip(row) {
                let n = poisson(rng, m);
                *c = c.saturating_add(n.min(u32::MAX as u64) as u32);
                total += n;
            }
        }
        total
    }

    /// The label box of this flux ([`flux_box`] holding `share` of it, as the renderer's
    /// label), in the image's pixel-centre coordinates; None without flux.
    pub fn label_box(&self, share: f64) -> Option<BoxPx> {
        let b = flux_box(&self.mean, self.width, self.spans.len(), share)?;
        Some(b.shifted(self.x0 as f64, self.y0 as f64))
    }

    /// The expected photo-electrons in the image.
    pub fn total(&self) -> f64 {
        self.mean.iter().sum()
    }

    /// The integrated matched-filter signal-to-noise ratio of the streak,
    /// `sqrt(sum_i s_i^2 / sigma_i^2)` over the image's pixels: `s_i` the expected debris ADU
    /// of pixel i (these expected electrons over the gain), `sigma_i^2 = noise_sigma_adu^2 +
    /// s_i / gain` the background-plus-bias variance plus the debris' own Poisson shot noise
    /// (`s_i gain` electrons of that variance, over gain^2). Star light on the streak is left
    /// out. It is the SNR of the ideal linear detector that knows the streak's shape and
    /// place: what no real detector beats.
    pub fn matched_filter_snr(&self, gain: f64, noise_sigma_adu: f64) -> f64 {
        let var = noise_sigma_adu * noise_sigma_adu;
        self.mean
            .iter()
            .filter(|&&e| e > 0.0)
            .map(|&e| {
                let s = e / gain;
                s * s / (var + s / gain)
            })
            .sum::<f64>()
            .sqrt()
    }
}

/// `amount` times the PSF shares `wx` (columns from `col0`) by `wy` (rows from `row0`), added
/// into `image` (rows `width` long): a separable PSF integrated over pixels.
pub fn add_separable(
    image: &mut [f64],
    width: usize,
    (col0, wx): (usize, &[f64]),
    (row0, wy): (usize, &[f64]),
    amount: f64,
) {
    for (j, wy) in wy.iter().enumerate() {
        let row = (row0 + j) * width + col0;
        let a = amount * wy;
        for (v, wx) in image[row..row + wx.len()].iter_mut().zip(wx) {
            *v += a * wx;
        }
    }
}

/// A point sample of a path: (electrons, x, y).
type Sample = (f64, f64, f64);

/// One of a PSF's Gaussians: (weight, sigma px, support in sigmas), as `Psf::supported`.
type Supported = (f64, f64, f64);

/// Samples of a mixture's Gaussian this many of its sigmas apart, at most, once merged: a row
/// of Gaussians of one sigma 1.5 sigmas apart ripples by 2 exp(-2 pi^2 / 1.5^2) = 3e-4 of
/// the line's level (a uniform line's Fourier series), the core Gaussian's own samples (2
/// sigmas apart, `MAX_SAMPLE_SPACING_PSF_SIGMAS`) by 1.4 %.
const MERGED_NODE_SPACING_SIGMA: f64 = 1.0;

/// The largest distance between consecutive samples (0 for fewer than two).
fn max_spacing(samples: &[(f64, f64, f64)]) -> f64 {
    samples
        .windows(2)
        .map(|p| (p[1].1 - p[0].1).hypot(p[1].2 - p[0].2))
        .fold(0.0, f64::max)
}

/// The samples for a mixture's Gaussian of `sigma`: runs of consecutive samples (at most
/// `spacing` apart) merged into one node at their electron-weighted mean, as many as keep the
/// nodes `MERGED_NODE_SPACING_SIGMA` sigmas apart at most. A wide Gaussian changes slowly
/// along the path, so it needs fewer nodes than the core; each of its nodes covers a
/// thousand or more pixels (the debris' expected flux was 20 % of a seeing render).
fn merge_samples(samples: &[(f64, f64, f64)], sigma: f64, spacing: f64) -> Vec<(f64, f64, f64)> {
    // All samples at one place (or none) make one node.
    let run = match spacing > 0.0 {
        true => ((MERGED_NODE_SPACING_SIGMA * sigma / spacing).floor() as usize).max(1),
        false => samples.len().max(1),
    };
    if run == 1 {
        return samples.to_vec();
    }
    samples
        .chunks(run)
        .map(|c| {
            let e: f64 = c.iter().map(|s| s.0).sum();
            let x = c.iter().map(|s| s.0 * s.1).sum::<f64>() / e;
            let y = c.iter().map(|s| s.0 * s.2).sum::<f64>() / e;
            (e, x, y)
        })
        .collect()
}

/// The first and last pixel (inclusive) of the `support_sigma`-sigma PSF support around `c`
/// on an axis of `n` pixels (pixel i spans [i - 0.5, i + 0.5)); None when it misses the axis.
fn support(c: f64, sigma: f64, support_sigma: f64, n: usize) -> Option<(usize, usize)> {
    let lo = (c - support_sigma * sigma + 0.5).floor().max(0.0);
    let hi = (c + support_sigma * sigma + 0.5)
        .floor()
        .min(n as f64 - 1.0);
    (hi >= lo).then_some((lo as usize, hi as usize))
}

/// The PSF share of each pixel of the support into `w`; its first pixel. Each pixel edge's
/// tail probability is computed once, for the two pixels it separates.
pub fn weights_into(
    c: f64,
    sigma: f64,
    support_sigma: f64,
    n: usize,
    w: &mut Vec<f64>,
) -> Option<usize> {
    let (lo, hi) = support(c, sigma, support_sigma, n)?;
    w.clear();
    let edge = |i: usize| {
        let e = (i as f64 - 0.5 - c) / sigma;
        (e, upper_tail(e.abs()))
    };
    let mut a = edge(lo);
    for i in lo..=hi {
        let b = edge(i + 1);
        w.push(normal_mass(a, b));
        a = b;
    }
    Some(lo)
}

/// P(a < Z < b) for a standard normal Z, from `(a, Q(|a|))` and `(b, Q(|b|))` (`upper_tail`),
/// accurate in both tails (differences of small upper-tail probabilities, never of two
/// numbers near 1).
fn normal_mass((a, qa): (f64, f64), (b, qb): (f64, f64)) -> f64 {
    if a >= 0.0 {
        qa - qb
    } else if b <= 0.0 {
        qb - qa
    } else {
        1.0 - qa - qb
    }
}

/// Q(z) = P(Z > z) for a standard normal Z.
fn upper_tail(z: f64) -> f64 {
    0.5 * erfc(z / std::f64::consts::SQRT_2)
}

/// Complementary error function, relative error below 1.2e-7 everywhere (Numerical Recipes'
/// Chebyshev fit, `erfcc`).
pub fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let r = t
        * (-z * z - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07
                                + t * (-1.135_203_98
                                    + t * (1.488_515_87
                                        + t * (-0.822_152_23 + t * 0.170_872_77)))))))))
            .exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A streak's samples: `n` points `step` px apart on a slanted line that enters the image
    /// at its left edge and ends in it, their electrons modulated as a tumbling object's.
    fn streak(n: usize, step: f64) -> Vec<(f64, f64, f64)> {
        let (dx, dy) = (0.94 * step, 0.342 * step);
        (0..n)
            .map(|i| {
                let f = i as f64;
                let e = 100.0 * (1.0 + 0.3 * (f / n as f64 * 20.0).sin());
                (e, -40.0 + f * dx, 30.0 + f * dy)
            })
            .collect()
    }

    /// Every sample through every Gaussian of the mixture, unmerged, on the whole image.
    fn unmerged(samples: &[(f64, f64, f64)], psf: &Psf, w: usize, h: usize) -> Vec<f64> {
        let mut image = vec![0.0; w * h];
        let (mut wx, mut wy) = (Vec::new(), Vec::new());
        for (share, sigma, n) in psf.supported(DEBRIS_SUPPORT_SIGMA) {
            for &(e, x, y) in samples {
                if let (Some(i0), Some(j0)) = (
                    weights_into(x, sigma, n, w, &mut wx),
                    weights_into(y, sigma, n, h, &mut wy),
                ) {
                    add_separable(&mut image, w, (i0, &wx), (j0, &wy), e * share);
                }
            }
        }
        image
    }

    /// The largest pixel difference of two images, over the first one's peak.
    fn worst(a: &[f64], b: &[f64]) -> f64 {
        let peak = a.iter().copied().fold(0.0, f64::max);
        a.iter()
            .zip(b)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
            / peak
    }

    #[test]
    fn merged_nodes_of_wide_gaussians_keep_the_streak() {
        let (w, h) = (256, 200);
        // (FWHM px, beta, sample spacing px, samples): a LEO-like streak sampled 1.6 core
        // sigmas apart, and a slow one sampled 0.2 core sigmas apart.
        for (fwhm, beta, step, n) in [
            (3.0, 4.765, 2.0, 100),
            (3.0, 2.5, 2.0, 100),
            (6.0, 2.5, 0.5, 400),
        ] {
            let psf = Psf::moffat(fwhm, beta);
            let samples = streak(n, step);
            let reference = unmerged(&samples, &psf, w, h);
            let flux = DebrisFlux::of_samples_psf(&samples, &psf, w, h);
            let mut merged = vec![0.0; w * h];
            for (j, row) in flux.mean.chunks(flux.width).enumerate() {
                let at = (flux.y0 + j) * w + flux.x0;
                merged[at..at + flux.width].copy_from_slice(row);
            }
            let err = worst(&reference, &merged);
            // Nodes a sigma apart ripple by 5e-9 along the streak; what is left is the
            // midpoint rule's term at the path's ends ((spacing^2 / 24) times the profile's
            // slope), measured 4.6e-6 (beta 4.765) and 8.1e-5 (2.5) of the peak at 2 px.
            // The streak sampled at the renderer's own coarsest spacing (2 core sigmas,
            // `MAX_SAMPLE_SPACING_PSF_SIGMAS`) moves its end by more than merging does.
            let core = fwhm / (2.0 * (2.0 * 2f64.ln()).sqrt());
            let coarse = merge_samples(&samples, 2.0 * core, step);
            let coarse_err = worst(&reference, &unmerged(&coarse, &psf, w, h));
            eprintln!(
                "fwhm {fwhm} beta {beta} step {step}: {err:.2e} of the peak (2-sigma sampling {coarse_err:.2e})"
            );
            assert!(err <= 2e-4 || err < coarse_err, "{err} {coarse_err}");
            // Merging keeps each Gaussian's electrons; those that leave the image at its
            // left edge differ by where the nodes sit there (measured 5e-5 of the total).
            let total = reference.iter().sum::<f64>();
            assert!(
                (flux.total() / total - 1.0).abs() < 1e-4,
                "{}",
                flux.total() / total
            );
        }
        // A Gaussian's samples are its nodes: nothing merged, bit for bit.
        let samples = streak(100, 0.5);
        let f = DebrisFlux::of_samples(&samples, 1.3, w, h);
        let whole = unmerged(&samples, &Psf::gaussian(1.3), w, h);
        let boxed: Vec<f64> = whole
            .chunks(w)
            .skip(f.y0)
            .take(f.spans.len())
            .flat_map(|r| r[f.x0..f.x0 + f.width].to_vec())
            .collect();
        assert_eq!(f.mean, boxed);
    }
}
