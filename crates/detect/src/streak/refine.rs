//! Step 5, refinement of a component's axis into a measured segment: orientation and lateral
//! offset by a coarse-to-fine search, the ends as change points of the profile along the axis,
//! then length, SNR, flux and elongation.

use std::f64::consts::PI;

use super::Sanitized;
use super::noise::LineNoise;
use super::smooth::corr;
use super::stats::median_of;
use soig_image::imaging::bilinear;

/// A starting axis for refinement: centre, orientation (rad), half extent, how much of each end
/// to leave out when measuring the level, and how far beyond the extent to look for the ends.
pub(super) struct Seed {
    pub(super) cx: f64,
    pub(super) cy: f64,
    pub(super) theta: f64,
    pub(super) half: f64,
    pub(super) shrink: f64,
    pub(super) ext: f64,
    /// Read the profile as the contrast instead of the mean of z (see [`Ctx::refine`]).
    pub(super) contrast: bool,
}

/// A point (x, y) in pixel-centre coordinates.
pub(super) type Point = (f64, f64);

/// A refined segment: centre, orientation (rad), length and measurements.
#[derive(Clone, Copy, Debug)]
pub(super) struct Seg {
    pub(super) cx: f64,
    pub(super) cy: f64,
    pub(super) theta: f64,
    pub(super) length: f64,
    pub(super) snr: f64,
    pub(super) flux: f64,
    pub(super) elongation: f64,
    /// Its profile was read as the contrast (kept when it is merged).
    pub(super) contrast: bool,
}

impl Seg {
    pub(super) fn dir(&self) -> (f64, f64) {
        (self.theta.cos(), self.theta.sin())
    }
    pub(super) fn ends(&self) -> ((f64, f64), (f64, f64)) {
        let (ux, uy) = self.dir();
        let hl = 0.5 * self.length;
        (
            (self.cx - hl * ux, self.cy - hl * uy),
            (self.cx + hl * ux, self.cy + hl * uy),
        )
    }
    /// The axis points 1 px apart from the centre, whole steps only (the profile samples).
    pub(super) fn axis_points(&self) -> impl Iterator<Item = (f64, f64)> + use<> {
        let (ux, uy) = self.dir();
        let (cx, cy) = (self.cx, self.cy);
        let hl = 0.5 * self.length;
        let ta = (-hl + 0.5).ceil() as i64;
        let tb = (hl - 0.5).floor() as i64;
        (ta..=tb).map(move |t| (cx + t as f64 * ux, cy + t as f64 * uy))
    }
}

/// What refinement, merging and output read: the image, its background and the smoothed map.
pub(super) struct Ctx<'a> {
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
}

/// Distance from `p` to the segment `a`-`b`.
pub(super) fn point_segment_distance(p: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let l2 = dx * dx + dy * dy;
    let t = if l2 > 0.0 {
        (((p.0 - a.0) * dx + (p.1 - a.1) * dy) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let (ex, ey) = (a.0 + t * dx - p.0, a.1 + t * dy - p.1);
    (ex * ex + ey * ey).sqrt()
}

impl Ctx<'_> {
    /// z at (x, y), bilinear between pixel centres.
    pub(super) fn z_at(&self, x: f64, y: f64) -> f64 {
        bilinear(self.z, self.w, self.h, x, y) as f64
    }

    /// Profile sample: the mean of z at lateral offsets -1, 0, 1 along the normal (nx, ny).
    pub(super) fn cross_mean(&self, x: f64, y: f64, nx: f64, ny: f64) -> f64 {
        (self.z_at(x - nx, y - ny) + self.z_at(x, y) + self.z_at(x + nx, y + ny)) / 3.0
    }

    /// Lateral taps (offset along the normal, weight) of a contrast sample: the profile sample
    /// (offsets -1, 0, 1) less the mean of side bands beyond the streak's smoothed
    /// cross-section (z falls below 1 % of its peak by 3 sqrt(2) psf_sigma), six pixels on
    /// each side. A line through a patch of raised background (a dark frame's warm region, the
    /// halo of a bright object) has its sides raised too and no contrast; a streak keeps its
    /// level.
    pub(super) fn contrast_taps(&self) -> Vec<(f64, f64)> {
        let d = (3.0 * std::f64::consts::SQRT_2 * self.p.psf_sigma).ceil() + 1.0;
        let mut taps: Vec<(f64, f64)> = (-1..=1).map(|u| (u as f64, 1.0 / 3.0)).collect();
        for k in 0..6 {
            let off = d + k as f64;
            taps.push((off, -1.0 / 12.0));
            taps.push((-off, -1.0 / 12.0));
        }
        taps
    }

    /// Contrast sample at (x, y) with the normal (nx, ny) (see [`Ctx::contrast_taps`]).
    pub(super) fn contrast(&self, taps: &[(f64, f64)], x: f64, y: f64, nx: f64, ny: f64) -> f64 {
        taps.iter()
            .map(|&(u, a)| a * self.z_at(x + u * nx, y + u * ny))
            .sum()
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

    /// For the axes of orientation `theta` through (cx, cy) + k du n, k = -nu..=nu (n the
    /// normal): the axis point and z clipped to +-`clip` summed along the axis over integer t
    /// in [-half, half] inside the image. The axes lie within a few pixels of each other, so
    /// they are summed together, t by t (each in increasing t, as alone): their samples share
    /// cache lines, where one axis at a time streamed the whole band in again for each.
    fn axis_scores(
        &self,
        (cx, cy): Point,
        theta: f64,
        half: f64,
        clip: f64,
        (du, nu): (f64, i32),
    ) -> Vec<(f64, Point)> {
        let (ux, uy) = (theta.cos(), theta.sin());
        let (nx, ny) = (-uy, ux);
        // Each axis's point and range of t.
        let axes: Vec<(Point, i64, i64)> = (-nu..=nu)
            .map(|k| {
                let (x, y) = (cx + k as f64 * du * nx, cy + k as f64 * du * ny);
                let (lo, hi) = self.t_range(x, y, ux, uy);
                let a = (-half).max(lo).ceil() as i64;
                let b = half.min(hi).floor() as i64;
                ((x, y), a, b)
            })
            .collect();
        let mut sums = vec![0.0; axes.len()];
        let from = axes.iter().map(|a| a.1).min().unwrap_or(0);
        let to = axes.iter().map(|a| a.2).max().unwrap_or(-1);
        for t in from..=to {
            let tf = t as f64;
            for (s, &((x, y), a, b)) in sums.iter_mut().zip(&axes) {
                if a <= t && t <= b {
                    *s += self.z_at(x + tf * ux, y + tf * uy).clamp(-clip, clip);
                }
            }
        }
        sums.into_iter().zip(axes).map(|(s, a)| (s, a.0)).collect()
    }

    pub(super) fn refine(&self, seed: &Seed) -> Option<Seg> {
        let p = self.p;
        let step = PI / p.n_angles as f64;
        let (mut cx, mut cy, mut th) = (seed.cx, seed.cy, seed.theta);
        let half = seed.half.max(2.0);
        // Coarse-to-fine search of orientation and lateral offset. z is clipped at 4 times
        // `clip_sigma` (bright stars are masked already): the core of a bright streak, not a
        // flat clipped band, sets the axis.
        let clip = 4.0 * p.clip;
        for (dth, nth, du, nu) in [
            (step / 4.0, 8i32, 0.5, 4i32),
            (step / 16.0, 3, 0.25, 2),
            (step / 64.0, 3, 0.125, 2),
            (step / 256.0, 3, 0.125, 1),
        ] {
            let (mut bs, mut bx, mut by, mut bt) = (f64::NEG_INFINITY, cx, cy, th);
            for i in -nth..=nth {
                let t2 = th + i as f64 * dth;
                for (s, (x, y)) in self.axis_scores((cx, cy), t2, half, clip, (du, nu)) {
                    if s > bs {
                        (bs, bx, by, bt) = (s, x, y, t2);
                    }
                }
            }
            (cx, cy, th) = (bx, by, bt);
        }
        let (ux, uy) = (th.cos(), th.sin());
        let (nx, ny) = (-uy, ux);
        let (lo, hi) = self.t_range(cx, cy, ux, uy);
        let reach = half + seed.ext;
        let ta = (-reach).max(lo).ceil() as i64;
        let tb = reach.min(hi).floor() as i64;
        if ta > 0 || tb < 0 {
            return None;
        }
        // Profile along the axis: the mean of z at lateral offsets -1, 0, 1, less the side
        // bands (the contrast) where the seed asks. Beyond a faint streak's ends the mean of z
        // alone can sit above zero (a real frame's skewed noise after the enhancement), enough
        // against a level of a few tenths of sigma to carry the ends to the image border; the
        // contrast's is zero.
        let taps = self.contrast_taps();
        let prof: Vec<f64> = (ta..=tb)
            .map(|t| {
                let (x, y) = (cx + t as f64 * ux, cy + t as f64 * uy);
                if seed.contrast {
                    self.contrast(&taps, x, y, nx, ny)
                } else {
                    self.cross_mean(x, y, nx, ny)
                }
            })
            .collect();
        let at = |t: i64| prof[(t - ta) as usize];
        let inner = (half - seed.shrink).max(1.0);
        let ia = (-inner).ceil().max(ta as f64) as i64;
        let ib = inner.floor().min(tb as f64) as i64;
        let mut vals: Vec<f64> = (ia..=ib).map(at).collect();
        if vals.is_empty() {
            return None;
        }
        let level = median_of(&mut vals);
        if level <= 0.0 {
            return None;
        }
        let cap = 1.5 * level;
        let gain = |t: i64| at(t).min(cap) - 0.5 * level;
        // Change points: the ends maximising the cumulative half-level excess from the centre.
        let (mut acc, mut bacc, mut e) = (0.0, 0.0, 0i64);
        for t in 1..=tb {
            acc += gain(t);
            if acc > bacc {
                bacc = acc;
                e = t;
            }
        }
        let (mut acc, mut bacc, mut s) = (0.0, 0.0, 0i64);
        for t in (ta..=-1).rev() {
            acc += gain(t);
            if acc > bacc {
                bacc = acc;
                s = t;
            }
        }
        // Robust SNR: the median contrast over the segment times its sample count, so that a
        // bright star on the axis does not make a streak, nor a raised patch of background.
        // (A contrast profile holds these samples already.)
        let mut seg_vals: Vec<f64> = (s..=e)
            .map(|t| {
                if seed.contrast {
                    at(t)
                } else {
                    self.contrast(&taps, cx + t as f64 * ux, cy + t as f64 * uy, nx, ny)
                }
            })
            .collect();
        let n = seg_vals.len();
        let snr = median_of(&mut seg_vals) * n as f64 / self.contrast_sum_sd(&taps, th, n);
        let (t0, t1) = (s as f64 - 0.5, e as f64 + 0.5);
        let mid = 0.5 * (t0 + t1);
        let mut seg = Seg {
            cx: cx + mid * ux,
            cy: cy + mid * uy,
            theta: th,
            length: t1 - t0,
            snr,
            flux: 0.0,
            elongation: 1.0,
            contrast: seed.contrast,
        };
        let (flux, elong) = self.flux_and_elongation(&seg);
        seg.flux = flux;
        seg.elongation = elong;
        Some(seg)
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
        let nf = n as f64;
        let mut var = nf * c(0.0);
        let dmax = ((12.0 * sp).ceil() as usize).min(n.saturating_sub(1));
        for d in 1..=dmax {
            var += 2.0 * (nf - d as f64) * c(d as f64);
        }
        var.max(1e-12).sqrt() * self.noise.for_sum(theta, n)
    }

    /// Flux (grey levels) and weighted elongation within 3 PSF sigmas of the segment.
    pub(super) fn flux_and_elongation(&self, s: &Seg) -> (f64, f64) {
        let r = 3.0 * self.p.psf_sigma;
        let (a, b) = s.ends();
        let x0 = (a.0.min(b.0) - r).floor().max(0.0) as usize;
        let x1 = (a.0.max(b.0) + r).ceil().min((self.w - 1) as f64).max(0.0) as usize;
        let y0 = (a.1.min(b.1) - r).floor().max(0.0) as usize;
        let y1 = (a.1.max(b.1) + r).ceil().min((self.h - 1) as f64).max(0.0) as usize;
        let clip = self.p.clip;
        let (mut flux, mut sw, mut sx, mut sy) = (0.0, 0.0, 0.0, 0.0);
        let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
        // Each row's pixels within r of the segment lie within r of its line: only those (and
        // a pixel more each side, for rounding) are tested, not the whole box of a diagonal
        // segment (1/2 to 1/4 million pixels for a long one), in the same order.
        let (ux, uy) = s.dir();
        for y in y0..=y1 {
            let (mut xa, mut xb) = (x0, x1);
            if uy.abs() > 1e-6 {
                // |(x - a.x) uy - (y - a.y) ux| <= r, solved for x.
                let along = a.0 + (y as f64 - a.1) * ux / uy;
                let half = r / uy.abs() + 1.0;
                xa = xa.max((along - half).floor().max(0.0) as usize);
                xb = xb.min((along + half).ceil().max(0.0) as usize);
            }
            for x in xa..=xb {
                let pt = (x as f64, y as f64);
                if point_segment_distance(pt, a, b) > r {
                    continue;
                }
                let i = y * self.w + x;
                flux += self.pixels[i] as f64 - self.bg[i] as f64;
                let wgt = (self.z[i] as f64).clamp(0.0, clip);
                // Moments relative to the segment centre for accuracy.
                let (dx, dy) = (pt.0 - s.cx, pt.1 - s.cy);
                sw += wgt;
                sx += wgt * dx;
                sy += wgt * dy;
                sxx += wgt * dx * dx;
                sxy += wgt * dx * dy;
                syy += wgt * dy * dy;
            }
        }
        if sw <= 0.0 {
            return (flux, 1.0);
        }
        let (mx, my) = (sx / sw, sy / sw);
        let cxx = sxx / sw - mx * mx + 1.0 / 12.0;
        let cyy = syy / sw - my * my + 1.0 / 12.0;
        let cxy = sxy / sw - mx * my;
        let tr = 0.5 * (cxx + cyy);
        let det = (0.25 * (cxx - cyy) * (cxx - cyy) + cxy * cxy).sqrt();
        let (l1, l2) = (tr + det, (tr - det).max(1e-9));
        (flux, (l1 / l2).sqrt())
    }
}
