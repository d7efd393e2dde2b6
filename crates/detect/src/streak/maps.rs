//! What a pass's later stages read, passed to each explicitly: the image, its background, the
//! smoothed unit-noise map, the line filter's measured noise and, in the star-aware pass, where
//! the predicted trails were subtracted. Its methods sample the maps: profile samples across an
//! axis and the noise of their sums.

use super::gather;
use super::noise::LineNoise;
use super::params::Sanitized;
use super::smooth::corr;
use soig_image::imaging::bilinear;
use std::cell::RefCell;

/// Where stars are points, the contrast's side samples are this many pixels apart (8-23 px
/// from the axis for the default PSF), not 1. On the smoothed map samples 1 px apart are
/// correlated at 0.9, so six of them average little noise away: in white noise the contrast
/// keeps 0.85 of the line's SNR with them and 0.93 with these (theory; measured 0.83 and 0.90,
/// `tests::the_contrast_keeps_most_of_the_line_snr`), and at the faint limit that is the
/// difference between a streak found and one dropped at `min_snr`. Survey frames keep the near
/// sides: farther out, a parallel star trail's light would enter them. Faint-limit-fixed sets
/// (`examples/sky_eval`, `scripts/faint_limit.py`; found, false boxes at confidence 0.5, SNR50
/// fitted), 1 -> 3 px: development 9422 (300 images) 199 / 8 / 9.65 -> 212 / 9 / 8.85; 9423
/// (600) 377 / 20 / 9.56 -> 404 / 23 / 8.77; held out 9421 (300) 189 / 8 / 9.67 -> 195 / 10 /
/// 9.23. 2 px apart (or ten samples 2 px apart) gained as much and cost more false boxes on one
/// set or the other; 4 px, as 3. The fixed rows' development sets (seed 777, 150 images,
/// mAP50-95): original synthetic 0.9908 -> 0.9922, original semisynthetic 0.9854 -> 0.9864,
/// padded synthetic 0.9922 -> 0.9907.
const POINTS_SIDE_STEP_PX: f64 = 3.0;

/// The far sides only where the line filter's measured noise excess on its longest lines
/// (`LineNoise::long_excess`) is at most this: white noise on a line's scale. In a real
/// frame's correlated noise the near sides cancel much of the background's wander, the far
/// ones less, while the SNR's noise model (white noise times that excess) is the same for
/// both, so the far sides raised the SNR of noise lines too: the fixed rows (400 images each,
/// streak mAP50-95) with the far sides everywhere, then only where the excess is at most 1.25:
/// padded semisynthetic 0.9671 -> 0.9610 -> 0.9692, original semisynthetic 0.9753 -> 0.9747 ->
/// 0.9753, padded synthetic 0.9882 -> 0.9892 -> 0.9892, original synthetic 0.9877 -> 0.9865 ->
/// 0.9866; the faint-limit-fixed sets (synthetic) as with them everywhere.
const WHITE_EXCESS: f64 = 1.25;

/// The maps of one pass (see the module docs).
pub(super) struct Maps<'a> {
    pub(super) w: usize,
    pub(super) h: usize,
    pub(super) pixels: &'a [u8],
    pub(super) bg: &'a [f32],
    pub(super) z: &'a [f32],
    pub(super) p: &'a Sanitized,
    /// The line filter's measured noise, which inflates the white-noise sd of profile sums.
    pub(super) noise: &'a LineNoise,
    /// The star-aware pass: the pixels under a subtracted star trail, and what was subtracted
    /// at each (see `Sky::subtract`).
    pub(super) under_trails: Option<&'a [bool]>,
    pub(super) removed: Option<&'a [f32]>,
    /// The stars are points: no trail direction given or measured (fixed pointing, or a frame
    /// whose stars share no direction). Acceptance and the confidence then reckon with pairs
    /// and chains of star blobs.
    pub(super) points: bool,
    /// [`Maps::contrast_sum_sd`]'s correlations of two contrast samples `d` px apart along
    /// the axis, per set of taps, taken once a pass: each is 225 exponentials, and the sd is
    /// asked for hundreds of times an image (3 % of the detector's time).
    pub(super) sample_corr: SampleCorr,
}

/// Per set of taps, the correlation of two contrast samples 0, 1, 2, ... px apart.
pub(super) type SampleCorr = RefCell<Vec<(Vec<(f64, f64)>, Vec<f64>)>>;

impl Maps<'_> {
    /// z at (x, y), bilinear between pixel centres. Inlined: `refine` samples it ~10^6 times
    /// an image, and LLVM's own choice left it a call there.
    #[inline(always)]
    pub(super) fn z_at(&self, x: f64, y: f64) -> f64 {
        bilinear(self.z, self.w, self.h, x, y) as f64
    }

    /// Profile sample: the mean of z at lateral offsets -1, 0, 1 along the normal (nx, ny).
    pub(super) fn cross_mean(&self, x: f64, y: f64, nx: f64, ny: f64) -> f64 {
        (self.z_at(x - nx, y - ny) + self.z_at(x, y) + self.z_at(x + nx, y + ny)) / 3.0
    }

    /// Lateral taps (offset along the normal, weight) of a contrast sample: the profile sample
    /// (offsets -1, 0, 1) less the mean of side bands beyond the streak's smoothed
    /// cross-section (z falls below 1 % of its peak by 3 sqrt(2) psf_sigma), six samples on
    /// each side, 1 px apart (`POINTS_SIDE_STEP_PX` apart where stars are points and the noise
    /// is white, `WHITE_EXCESS`). A line through a patch of raised background (a dark frame's
    /// warm region, the halo of a bright object) has its sides raised too and no contrast; a
    /// streak keeps its level.
    pub(super) fn contrast_taps(&self) -> Vec<(f64, f64)> {
        let d = (3.0 * std::f64::consts::SQRT_2 * self.p.psf_sigma).ceil() + 1.0;
        let step = if self.points && self.noise.long_excess() <= WHITE_EXCESS {
            POINTS_SIDE_STEP_PX
        } else {
            1.0
        };
        let mut taps: Vec<(f64, f64)> = (-1..=1).map(|u| (u as f64, 1.0 / 3.0)).collect();
        for k in 0..6 {
            let off = d + k as f64 * step;
            taps.push((off, -1.0 / 12.0));
            taps.push((-off, -1.0 / 12.0));
        }
        taps
    }

    /// Contrast sample at (x, y) with the normal (nx, ny) (see [`Maps::contrast_taps`]): its
    /// taps' samples read four a vector (`gather`), the same bits as one at a time.
    pub(super) fn contrast(&self, taps: &[(f64, f64)], x: f64, y: f64, nx: f64, ny: f64) -> f64 {
        gather::contrast(self.z, (self.w, self.h), taps, (x, y), (nx, ny))
    }

    /// Range of t for which (cx, cy) + t (ux, uy) lies inside the pixel-centre rectangle.
    pub(super) fn t_range(&self, cx: f64, cy: f64, ux: f64, uy: f64) -> (f64, f64) {
        let mut lo = f64::NEG_INFINITY;
        let mut hi = f64::INFINITY;
        for (c, u, max) in [(cx, ux, (self.w - 1) as f64), (cy, uy, (self.h - 1) as f64)] {
            if u.abs() < 1e-12 {
                if c < 0.0 || c > max {
                    return (1.0, 0.0);
                }
            } else {
                let (a, b) = ((0.0 - c) / u, (max - c) / u);
                lo = lo.max(a.min(b));
                hi = hi.min(a.max(b));
            }
        }
        (lo, hi)
    }

    /// Noise sd of the sum of `n` consecutive contrast samples (`taps`) along orientation
    /// `theta`: the white-noise model (z has unit noise, correlated through the Gaussian), times
    /// the line filter's measured excess ([`LineNoise::for_sum`]).
    pub(super) fn contrast_sum_sd(&self, taps: &[(f64, f64)], theta: f64, n: usize) -> f64 {
        let sp = self.p.psf_sigma;
        let c = |dt: f64| -> f64 {
            let mut s = 0.0;
            for &(u, a) in taps {
                for &(v, b) in taps {
                    s += a * b * corr(dt * dt + (u - v) * (u - v), sp);
                }
            }
            s
        };
        let dmax_all = (12.0 * sp).ceil() as usize;
        let mut memo = self.sample_corr.borrow_mut();
        let i = match memo.iter().position(|(t, _)| t == taps) {
            Some(i) => i,
            None => {
                memo.push((taps.to_vec(), (0..=dmax_all).map(|d| c(d as f64)).collect()));
                memo.len() - 1
            }
        };
        let cd = &memo[i].1;
        let nf = n as f64;
        let mut var = nf * cd[0];
        let dmax = dmax_all.min(n.saturating_sub(1));
        for (d, &r) in cd.iter().enumerate().take(dmax + 1).skip(1) {
            var += 2.0 * (nf - d as f64) * r;
        }
        var.max(1e-12).sqrt() * self.noise.for_sum(theta, n)
    }
}
