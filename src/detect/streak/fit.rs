//! Step 7, the box: the refined segment fitted as the label's model of a streak (its centre
//! line, its ends and its brightness along it), rendered through the PSF by the renderer's own
//! code and boxed by the label's own rule (`geometry::flux_box`, 99 % of the flux).
//!
//! The 8-bit image is a non-linear stretch of the flux (square root, log, CLAHE, gamma), so a
//! bright streak's half-level in grey levels lies far out in its PSF wings, and a box padded
//! around the half-level ends was 5-20 px too long at each end. The ends are instead found by
//! level matching: across the streak the flux is the PSF, so the level the image shows at
//! `HALF_WIDTH` PSF sigmas beside the centre line is the one of half the streak's flux, whatever
//! the stretch; along the axis the flux falls to half where the exposure (the segment) ends. So
//! each end is where the centre-line profile crosses the level measured beside the line.

use super::refine::{Ctx, Seg};
use crate::geometry::{BoxPx, LABEL_SHARE};
use crate::render::expected::DebrisFlux;

/// Offset across a Gaussian profile, in its sigmas, where it is at half its peak: sqrt(2 ln 2).
const HALF_WIDTH: f64 = 1.177_410_022_515_474_5;

/// Length of the pieces in which the centre line and the brightness are measured, pixels:
/// long enough for a faint streak's piece to have a centroid (16 samples), short enough to
/// follow the pointing jitter's wander (a few pixels over a 1000 px streak).
const PIECE_PX: f64 = 16.0;

/// Step between profile samples along the axis, pixels.
const STEP_PX: f64 = 0.5;

/// How far beyond the refined (half-level of the clipped map) ends an end is looked for,
/// pixels, and how far inside (a bright streak's half-level ends lie up to ~20 px beyond the
/// true ones).
const SEARCH_OUT_PX: f64 = 10.0;
const SEARCH_IN_PX: f64 = 40.0;

/// The fitted streak: its centre line as (t, lateral offset, brightness) nodes along the
/// refined axis, and the extent of the streak along it.
struct Fit {
    /// Per piece: centre t, lateral offset (px, along the normal), brightness (z summed across).
    pieces: Vec<(f64, f64, f64)>,
    t0: f64,
    t1: f64,
}

impl Ctx<'_> {
    /// The label box of the fitted streak in pixel-edge coordinates (pixel `i` spans
    /// `[i, i + 1]`), clipped to the image; None when no fit is possible (the caller keeps the
    /// padded box).
    pub(super) fn fitted_box(&self, s: &Seg) -> Option<BoxPx> {
        let fit = self.fit(s)?;
        let psf = self.p.psf_sigma;
        let (ux, uy) = s.dir();
        let (nx, ny) = (-uy, ux);
        // Samples every quarter pixel from end to end (the renderer's nodes are closer, but
        // a quarter pixel moves no 99 % box by a measurable amount).
        let n = ((fit.t1 - fit.t0) / 0.25).ceil().max(1.0) as usize;
        let dt = (fit.t1 - fit.t0) / n as f64;
        let samples: Vec<(f64, f64, f64)> = (0..n)
            .map(|k| {
                let t = fit.t0 + (k as f64 + 0.5) * dt;
                let (off, bright) = fit.at(t);
                let (x, y) = (s.cx + t * ux + off * nx, s.cy + t * uy + off * ny);
                (bright * dt, x, y)
            })
            .collect();
        let b = DebrisFlux::of_samples(&samples, psf, self.w, self.h).label_box(LABEL_SHARE)?;
        let (w, h) = (self.w as f64, self.h as f64);
        Some(BoxPx {
            x_min: (b.x_min + 0.5).clamp(0.0, w),
            y_min: (b.y_min + 0.5).clamp(0.0, h),
            x_max: (b.x_max + 0.5).clamp(0.0, w),
            y_max: (b.y_max + 0.5).clamp(0.0, h),
        })
    }

    /// The smoothed map's cross-section sigma: the PSF smoothed by the detector's Gaussian
    /// of the same width.
    fn z_sigma(&self) -> f64 {
        std::f64::consts::SQRT_2 * self.p.psf_sigma
    }

    fn fit(&self, s: &Seg) -> Option<Fit> {
        let (ux, uy) = s.dir();
        let (nx, ny) = (-uy, ux);
        let sz = self.z_sigma();
        let at = |t: f64, v: f64| self.z_at(s.cx + t * ux + v * nx, s.cy + t * uy + v * ny);
        let (lo, hi) = self.t_range(s.cx, s.cy, ux, uy);
        if lo > hi {
            return None;
        }
        let half = 0.5 * s.length;

        // Centre line and brightness, piece by piece over the refined segment.
        let n_pieces = ((s.length / PIECE_PX).floor() as usize).max(1);
        let piece = s.length / n_pieces as f64;
        let reach = (3.0 * sz).ceil();
        let mut pieces = Vec::with_capacity(n_pieces);
        for k in 0..n_pieces {
            let ta = -half + k as f64 * piece;
            let ts: Vec<f64> = (0..piece.round().max(1.0) as usize)
                .map(|i| ta + i as f64 + 0.5)
                .filter(|&t| t >= lo && t <= hi)
                .collect();
            if ts.is_empty() {
                continue;
            }
            let profile = |v: f64| ts.iter().map(|&t| at(t, v)).sum::<f64>() / ts.len() as f64;
            let offs: Vec<f64> = (-(2.0 * reach) as i64..=(2.0 * reach) as i64)
                .map(|i| i as f64 * 0.5)
                .collect();
            let prof: Vec<f64> = offs.iter().map(|&v| profile(v)).collect();
            // Centroid of the positive part within 1.5 sigma of the peak.
            let (imax, _) = prof.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1))?;
            let v0 = offs[imax];
            let (mut sw, mut sv) = (0.0, 0.0);
            for (&v, &p) in offs.iter().zip(&prof) {
                if (v - v0).abs() <= 1.5 * sz && p > 0.0 {
                    sw += p;
                    sv += p * v;
                }
            }
            // The noise sd of a piece's mean: z has unit noise, correlated over about
            // 2 sqrt(pi) psf sigma along the axis.
            let sd = (2.0 * std::f64::consts::PI.sqrt() * sz / ts.len() as f64)
                .sqrt()
                .min(1.0);
            let bright: f64 = offs
                .iter()
                .zip(&prof)
                .filter(|(v, _)| v.abs() <= 2.0 * sz)
                .map(|(_, &p)| p * 0.5)
                .sum();
            let off = if prof[imax] > 3.0 * sd && sw > 0.0 {
                sv / sw
            } else {
                f64::NAN
            };
            pieces.push((ta + 0.5 * piece, off, bright));
        }
        if pieces.is_empty() {
            return None;
        }
        // Pieces without a clear centroid take the line's (offset 0), and brightness is kept
        // positive: a dip (a star masked on the line) is not an end.
        let mut bright: Vec<f64> = pieces.iter().map(|p| p.2).collect();
        let med = super::stats::median_of(&mut bright).max(1e-6);
        for p in &mut pieces {
            if !p.1.is_finite() {
                p.1 = 0.0;
            }
            p.2 = p.2.clamp(0.1 * med, 10.0 * med);
        }
        let mut fit = Fit {
            pieces,
            t0: -half,
            t1: half,
        };
        fit.t1 = self.end(s, &fit, 1.0, lo, hi);
        fit.t0 = -self.end(s, &fit, -1.0, lo, hi);
        (fit.t1 > fit.t0).then_some(fit)
    }

    /// The end of the streak on the side `sign` (+1: towards +t), as a distance along `sign`
    /// from the centre: where the centre-line profile crosses the level seen `HALF_WIDTH`
    /// sigmas beside the line near that end (see the module docs). An end not reached inside
    /// the image lies beyond it (the streak leaves the frame).
    fn end(&self, s: &Seg, fit: &Fit, sign: f64, lo: f64, hi: f64) -> f64 {
        let (ux, uy) = s.dir();
        let (nx, ny) = (-uy, ux);
        let sz = self.z_sigma();
        let at = |t: f64, v: f64| {
            let (off, _) = fit.at(t);
            self.z_at(
                s.cx + t * ux + (v + off) * nx,
                s.cy + t * uy + (v + off) * ny,
            )
        };
        let half = 0.5 * s.length;
        let border = if sign > 0.0 { hi } else { -lo };
        // The level beside the line, over the inner stretch next to the end.
        let margin = (3.0 * sz).min(0.25 * s.length);
        let inner_b = half - margin;
        let inner_a = (inner_b - SEARCH_IN_PX).max(-half + margin).min(inner_b);
        let vh = HALF_WIDTH * sz;
        let (mut level, mut count) = (0.0, 0.0);
        let mut d = inner_a;
        while d <= inner_b {
            let t = sign * d;
            if t >= lo && t <= hi {
                level += 0.5 * (at(t, vh) + at(t, -vh));
                count += 1.0;
            }
            d += 1.0;
        }
        if count == 0.0 {
            return half;
        }
        let level = level / count;
        if level <= 0.0 {
            return half;
        }
        // Change point: the distance maximising the cumulative excess of the profile over
        // the level, outwards from inside the streak (robust to noise and to dips).
        let start = (half - SEARCH_IN_PX).max(0.0).min(border);
        let stop = (half + SEARCH_OUT_PX).min(border);
        let (mut acc, mut best, mut best_d) = (0.0, 0.0, start);
        let mut d = start;
        let mut last = start;
        while d <= stop {
            acc += (at(sign * d, 0.0) - level).min(level) * STEP_PX;
            if acc > best {
                best = acc;
                best_d = d + 0.5 * STEP_PX;
            }
            last = d;
            d += STEP_PX;
        }
        // Still above the level at the image's border: the streak goes on beyond it.
        if best_d >= last && last >= border - STEP_PX {
            return border + 5.0 * self.p.psf_sigma;
        }
        best_d
    }
}

impl Fit {
    /// Lateral offset and brightness at t, linear between the pieces' centres.
    fn at(&self, t: f64) -> (f64, f64) {
        let p = &self.pieces;
        if t <= p[0].0 {
            return (p[0].1, p[0].2);
        }
        for w in p.windows(2) {
            if t <= w[1].0 {
                let f = (t - w[0].0) / (w[1].0 - w[0].0);
                return (
                    w[0].1 + f * (w[1].1 - w[0].1),
                    w[0].2 + f * (w[1].2 - w[0].2),
                );
            }
        }
        let l = p[p.len() - 1];
        (l.1, l.2)
    }
}
