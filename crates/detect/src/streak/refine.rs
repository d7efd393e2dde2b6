//! Step 5, refinement of a component's axis into a measured segment: orientation and lateral
//! offset by a coarse-to-fine search, the ends as change points of the profile along the axis,
//! then length, SNR, flux and elongation.

use std::f64::consts::PI;

use super::explain::Seeds;
use super::full_lines::MIN_LENGTH_PX;
use super::gather::{Axis, axis_sums};
use super::maps::Maps;
use super::segment::{Point, Seg, point_segment_distance};
use super::stats::median_of;

/// A starting axis for refinement: centre, orientation (rad), half extent, how much of each end
/// to leave out when measuring the level, and how far beyond the extent to look for the ends.
pub(super) struct Seed {
    pub(super) cx: f64,
    pub(super) cy: f64,
    pub(super) theta: f64,
    pub(super) half: f64,
    pub(super) shrink: f64,
    pub(super) ext: f64,
    /// Read the profile as the contrast instead of the mean of z (see [`refine`]).
    pub(super) contrast: bool,
    /// How bright its samples are against the noise: how it is searched, its ends found and
    /// its SNR read.
    pub(super) regime: Regime,
}

/// A full-line streak's samples are clipped to this many times their noise before their mean
/// (see [`refine`]'s SNR).
const SAMPLE_CLIP: f64 = 3.0;

/// How a seed's streak stands against the noise, sample by sample along its axis, and so how
/// [`refine`] searches its axis, finds its ends and reads its SNR.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum Regime {
    /// Samples at or above the noise (steps 3 and 3b's seeds): the axis searched widely; the
    /// ends at the change points of the half-level excess from the centre, each sample capped
    /// at 1.5 times the level (a star on the axis moves no end); the level from the median.
    Resolved,
    /// Each sample far below the noise (the full-line stage's seeds, whose axis is known to a
    /// fraction of a degree): the axis searched narrowly; the ends those of the stretch of
    /// the profile whose sum is the most significant (sum / sqrt(samples)), at least `min`
    /// samples long, the matched filter's own ends (the cap clips the noise's upper half, and
    /// the capped excess of a faint streak falls below zero, which pulled the ends of a
    /// 1089-pixel streak at line SNR 11.8 in to 700 pixels: development image 34 of
    /// `scripts/faint-limit-dev.sh`); the level from a clipped mean.
    SubNoise { min: usize },
}

impl Regime {
    /// The regime of a stage's seeds: the full-line stage's streaks are each far below the
    /// noise sample by sample.
    pub(super) fn of(seeds: Seeds) -> Regime {
        match seeds {
            Seeds::FullLine => Regime::SubNoise {
                min: (MIN_LENGTH_PX / 2.0) as usize,
            },
            Seeds::Local | Seeds::LongLine => Regime::Resolved,
        }
    }
}

/// The axes of a search level, angle by angle (`thetas`), each angle's `2 nu + 1` axes through
/// (cx, cy) + k du n, k = -nu..=nu (n the normal), summed over integer t in [-half, half]
/// inside the image, every `stride`-th t from the least of the angle's axes (`gather`). The
/// axes of all the level's angles go to the gathers together: lanes of four.
pub(super) fn level_axes(
    maps: &Maps,
    (cx, cy): Point,
    thetas: &[f64],
    half: f64,
    (du, nu): (f64, i32),
) -> Vec<Axis> {
    let mut out = Vec::with_capacity(thetas.len() * (2 * nu + 1) as usize);
    for &theta in thetas {
        let (ux, uy) = (theta.cos(), theta.sin());
        let (nx, ny) = (-uy, ux);
        let first = out.len();
        for k in -nu..=nu {
            let (x, y) = (cx + k as f64 * du * nx, cy + k as f64 * du * ny);
            let (lo, hi) = maps.t_range(x, y, ux, uy);
            let a = (-half).max(lo).ceil() as i64;
            let b = half.min(hi).floor() as i64;
            out.push(Axis {
                x,
                y,
                ux,
                uy,
                from: 0,
                a,
                b,
            });
        }
        let from = out[first..].iter().map(|a| a.a).min().unwrap_or(0);
        out[first..].iter_mut().for_each(|a| a.from = from);
    }
    out
}

/// The scalar axis search, one angle: the reference `level_axes` and `gather` give the bits
/// of (`simd`'s test).
#[cfg(test)]
pub(super) fn axis_scores_at(
    maps: &Maps,
    (cx, cy): Point,
    theta: f64,
    half: f64,
    clip: f64,
    (du, nu): (f64, i32),
    stride: usize,
) -> Vec<(f64, Point)> {
    let (ux, uy) = (theta.cos(), theta.sin());
    let (nx, ny) = (-uy, ux);
    // Each axis's point and range of t.
    let axes: Vec<(Point, i64, i64)> = (-nu..=nu)
        .map(|k| {
            let (x, y) = (cx + k as f64 * du * nx, cy + k as f64 * du * ny);
            let (lo, hi) = maps.t_range(x, y, ux, uy);
            let a = (-half).max(lo).ceil() as i64;
            let b = half.min(hi).floor() as i64;
            ((x, y), a, b)
        })
        .collect();
    let mut sums = vec![0.0; axes.len()];
    let from = axes.iter().map(|a| a.1).min().unwrap_or(0);
    let to = axes.iter().map(|a| a.2).max().unwrap_or(-1);
    let stride = stride.max(1) as i64;
    let mut t = from;
    while t <= to {
        let tf = t as f64;
        for (s, &((x, y), a, b)) in sums.iter_mut().zip(&axes) {
            if a <= t && t <= b {
                *s += maps.z_at(x + tf * ux, y + tf * uy).clamp(-clip, clip);
            }
        }
        t += stride;
    }
    sums.into_iter().zip(axes).map(|(s, a)| (s, a.0)).collect()
}

/// The segment `seed` refines into (None: no positive level along its axis).
pub(super) fn refine(maps: &Maps, seed: &Seed) -> Option<Seg> {
    let p = maps.p;
    let step = PI / p.n_angles as f64;
    let (mut cx, mut cy, mut th) = (seed.cx, seed.cy, seed.theta);
    let half = seed.half.max(2.0);
    // Coarse-to-fine search of orientation and lateral offset. z is clipped at 4 times
    // `clip_sigma` (bright stars are masked already): the core of a bright streak, not a
    // flat clipped band, sets the axis.
    let clip = 4.0 * p.clip;
    // A full-line seed (`Regime::SubNoise`) knows its axis to a fraction of a degree and a
    // few pixels: searched as widely as a local one, a star trail through its centre (17
    // degrees off a streak at line SNR 11, development image 7) took the axis.
    // Each level reads every `stride`-th sample along its axes: z is smoothed by the PSF
    // (its noise correlated over about 2 psf_sigma), so the coarse levels, which only centre
    // the next, lose little by it; the finest reads every sample. With every sample at every
    // level the search was about a fifth of the detector's time on survey frames (perf).
    let first = match seed.regime {
        Regime::Resolved => (step / 4.0, 8i32, 0.5, 4i32, 4usize),
        Regime::SubNoise { .. } => (step / 16.0, 2, 0.5, 4, 4),
    };
    for (dth, nth, du, nu, stride) in [
        first,
        (step / 16.0, 3, 0.25, 2, 2),
        (step / 64.0, 3, 0.125, 2, 2),
        (step / 256.0, 3, 0.125, 1, 1),
    ] {
        let (mut bs, mut bx, mut by, mut bt) = (f64::NEG_INFINITY, cx, cy, th);
        let thetas: Vec<f64> = (-nth..=nth).map(|i| th + i as f64 * dth).collect();
        let axes = level_axes(maps, (cx, cy), &thetas, half, (du, nu));
        let sums = axis_sums(maps.z, (maps.w, maps.h), &axes, clip, stride);
        // The best in the order of angles, then axes, as one angle at a time took them.
        let per = (2 * nu + 1) as usize;
        for (k, (&s, ax)) in sums.iter().zip(&axes).enumerate() {
            if s > bs {
                (bs, bx, by, bt) = (s, ax.x, ax.y, thetas[k / per]);
            }
        }
        (cx, cy, th) = (bx, by, bt);
    }
    let (ux, uy) = (th.cos(), th.sin());
    let (nx, ny) = (-uy, ux);
    let (lo, hi) = maps.t_range(cx, cy, ux, uy);
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
    let taps = maps.contrast_taps();
    let prof: Vec<f64> = (ta..=tb)
        .map(|t| {
            let (x, y) = (cx + t as f64 * ux, cy + t as f64 * uy);
            if seed.contrast {
                maps.contrast(&taps, x, y, nx, ny)
            } else {
                maps.cross_mean(x, y, nx, ny)
            }
        })
        .collect();
    let at = |t: i64| prof[(t - ta) as usize];
    let inner = (half - seed.shrink).max(1.0);
    let ia = (-inner).ceil().max(ta as f64) as i64;
    let ib = inner.floor().min(tb as f64) as i64;
    let vals: Vec<f64> = (ia..=ib).map(at).collect();
    if vals.is_empty() {
        return None;
    }
    let level = median_of(&vals);
    if level <= 0.0 {
        return None;
    }
    let stretch = match seed.regime {
        Regime::Resolved => Some(change_points(&prof, ta, tb, level)),
        Regime::SubNoise { min } => best_stretch(&prof, ta, min),
    };
    let (s, e) = stretch.unwrap_or((0, 0));
    // Robust SNR: the median contrast over the segment times its sample count, so that a
    // bright star on the axis does not make a streak, nor a raised patch of background.
    // (A contrast profile holds these samples already.)
    let seg_vals: Vec<f64> = (s..=e)
        .map(|t| {
            if seed.contrast {
                at(t)
            } else {
                maps.contrast(&taps, cx + t as f64 * ux, cy + t as f64 * uy, nx, ny)
            }
        })
        .collect();
    let n = seg_vals.len();
    let (level, sd) = match seed.regime {
        Regime::Resolved => (median_of(&seg_vals), maps.contrast_sum_sd(&taps, th, n)),
        // Each sample of a full-line streak is far below the noise, where the median keeps
        // only 0.8 of the mean's SNR (sqrt(2 / pi)); the mean of the samples clipped to
        // `SAMPLE_CLIP` of their noise keeps nearly all of it, and a star on the axis adds
        // at most that clip over its few samples.
        Regime::SubNoise { .. } => {
            let c = SAMPLE_CLIP * maps.contrast_sum_sd(&taps, th, 1);
            let level = seg_vals.iter().map(|v| v.clamp(-c, c)).sum::<f64>() / n.max(1) as f64;
            (
                level,
                parallels_sd(maps, &taps, (cx, cy), th, (s, e), (c, level)),
            )
        }
    };
    let snr = level * n as f64 / sd;
    // The SNR is the stretch's; the box spans the light beyond it too.
    let (s, e) = match (seed.regime, stretch) {
        (Regime::SubNoise { .. }, Some(st)) => carried(&prof, ta, st),
        _ => (s, e),
    };
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
    let (flux, elong) = flux_and_elongation(maps, &seg);
    seg.flux = flux;
    seg.elongation = elong;
    Some(seg)
}

/// The parallels of a full-line segment that measure its sum's noise (see [`parallels_sd`]):
/// this many on each side, the first `PARALLEL_FIRST` pixels away (its side bands clear of
/// the streak's cross-section and its wander), then every `PARALLEL_STEP` pixels.
const PARALLELS: usize = 8;
const PARALLEL_FIRST: f64 = 20.0;
const PARALLEL_STEP: f64 = 13.0;

/// Noise sd of the clipped contrast sum of a full-line segment (axis through `c` at `theta`,
/// positions `s..=e`, samples clipped to `clip`). The line filter's measured excess
/// (`LineNoise`) is measured on its short filters; near the star trails' direction their
/// residuals fill it (1.2-2.0 at 7.6-10 degrees off the trails on the faint development set,
/// where every such streak's contrast sum stood at 7.3-9.3 white-noise sigma and fell below
/// `min_snr`), but a line of hundreds of pixels crosses each residual over a few tens only.
/// So where that excess is above 1, the segment's own parallels measure it: the spread (MAD)
/// of the same sum along them, each in units of its white-noise sd, floored at 1 (the white
/// noise) and capped at the line filter's excess (never less significant than before). Only
/// below `confidence_snr` (with `level`, the clipped mean): a brighter segment's confidence
/// is near 1 already, and raising it only reorders it against the other stages' segment of
/// the same streak in explaining away (a worse box on 1 of 150 rotated development images).
fn parallels_sd(
    maps: &Maps,
    taps: &[(f64, f64)],
    (cx, cy): Point,
    theta: f64,
    (s, e): (i64, i64),
    (clip, level): (f64, f64),
) -> f64 {
    let n = (e - s + 1).max(1) as usize;
    let modelled = maps.contrast_sum_sd(taps, theta, n);
    let ratio = maps.noise.for_sum(theta, n);
    if ratio <= 1.0 || level * n as f64 / modelled >= maps.p.confidence_snr {
        return modelled;
    }
    let white = |m: usize| maps.contrast_sum_sd(taps, theta, m) / maps.noise.for_sum(theta, m);
    let (ux, uy) = (theta.cos(), theta.sin());
    let (nx, ny) = (-uy, ux);
    let (xmax, ymax) = ((maps.w - 1) as f64, (maps.h - 1) as f64);
    let mut t: Vec<f64> = Vec::with_capacity(2 * PARALLELS);
    for k in 0..2 * PARALLELS {
        let side = if k % 2 == 0 { 1.0 } else { -1.0 };
        let off = side * (PARALLEL_FIRST + (k / 2) as f64 * PARALLEL_STEP);
        let (px, py) = (cx + off * nx, cy + off * ny);
        let (mut sum, mut m) = (0.0, 0usize);
        for i in s..=e {
            let (x, y) = (px + i as f64 * ux, py + i as f64 * uy);
            if (0.0..=xmax).contains(&x) && (0.0..=ymax).contains(&y) {
                sum += maps.contrast(taps, x, y, nx, ny).clamp(-clip, clip);
                m += 1;
            }
        }
        if 2 * m >= n {
            t.push(sum / white(m));
        }
    }
    if t.len() < PARALLELS {
        return modelled;
    }
    // The spread's median deviation does not depend on the order `median_of` leaves.
    let m = median_of(&t);
    let dev: Vec<f64> = t.iter().map(|v| (v - m).abs()).collect();
    let spread = 1.4826 * median_of(&dev);
    white(n) * spread.clamp(1.0, ratio)
}

/// The ends (axis positions, the profile `prof` starting at `ta`, ending at `tb`) maximising
/// the cumulative half-`level` excess outwards from the centre, each sample capped at 1.5
/// `level`.
fn change_points(prof: &[f64], ta: i64, tb: i64, level: f64) -> (i64, i64) {
    let at = |t: i64| prof[(t - ta) as usize];
    let cap = 1.5 * level;
    let gain = |t: i64| at(t).min(cap) - 0.5 * level;
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
    (s, e)
}

/// The stretch of `prof` (axis positions from `ta`) of at least `min` samples whose sum over
/// the square root of its length is largest, as its first and last axis positions: searched
/// on a grid of `GRID` samples, then each end to the sample (the other held) until neither
/// moves; a profile of 1450 samples took 5 ms a seed searched exhaustively.
pub(super) fn best_stretch(prof: &[f64], ta: i64, min: usize) -> Option<(i64, i64)> {
    const GRID: usize = 8;
    let n = prof.len();
    let min = min.max(1);
    if n < min {
        return None;
    }
    let mut cum = vec![0.0; n + 1];
    for (i, v) in prof.iter().enumerate() {
        cum[i + 1] = cum[i] + v;
    }
    let score = |i: usize, j: usize| (cum[j] - cum[i]) / ((j - i) as f64).sqrt();
    let (mut best, mut at) = (f64::NEG_INFINITY, (0, min));
    for i in (0..=n - min).step_by(GRID) {
        for j in (i + min..=n).step_by(GRID).chain([n]) {
            if score(i, j) > best {
                (best, at) = (score(i, j), (i, j));
            }
        }
    }
    loop {
        let (i0, j0) = at;
        for i in i0.saturating_sub(GRID)..=(i0 + GRID).min(at.1 - min) {
            if score(i, at.1) > best {
                (best, at) = (score(i, at.1), (i, at.1));
            }
        }
        for j in (at.1.saturating_sub(GRID)).max(at.0 + min)..=(at.1 + GRID).min(n) {
            if score(at.0, j) > best {
                (best, at) = (score(at.0, j), (at.0, j));
            }
        }
        if at == (i0, j0) {
            break;
        }
    }
    Some((ta + at.0 as i64, ta + at.1 as i64 - 1))
}

/// A sub-noise streak's light beyond its most significant stretch (see [`carried`]) carries its
/// end on to the profile's end when the rest of the profile holds more than this fraction of
/// the stretch's mean level: half way between no light and light at half the level (a
/// tumbling object's dim phase; the streak wandering off the straight axis with the pointing
/// jitter). Measured on the faint development set (`bash scripts/faint-limit-dev.sh 9402
/// 150`): of 150 streaks, most faint ones cross the frame, and their stretch held only the
/// brighter part (image 92: rows 443-1021 of a streak across all 1024, IoU 0.33); at 0.25
/// (with `full_lines::CONFIDENCE_CREDIT` 2) both such boxes became found streaks and no false
/// box left at confidence 0.5 was the debris boxed in part; at 0.4 one stayed short.
pub(super) const CARRIED: f64 = 0.25;

/// The ends of the stretch `(s, e)` of `prof` (axis positions from `ta`), each carried on to
/// the profile's end where the samples beyond hold more than [`CARRIED`] of its mean level.
/// A stretch's SNR stays its own: the dimmer rest would only dilute it.
pub(super) fn carried(prof: &[f64], ta: i64, (s, e): (i64, i64)) -> (i64, i64) {
    let (i, j) = ((s - ta) as usize, (e - ta) as usize + 1);
    let level = prof[i..j].iter().sum::<f64>() / (j - i) as f64;
    let holds = |rest: &[f64]| rest.iter().sum::<f64>() > rest.len() as f64 * level * CARRIED;
    let a = if i > 0 && holds(&prof[..i]) { ta } else { s };
    let b = if j < prof.len() && holds(&prof[j..]) {
        ta + prof.len() as i64 - 1
    } else {
        e
    };
    (a, b)
}

/// Flux (grey levels) and weighted elongation within 3 PSF sigmas of the segment.
pub(super) fn flux_and_elongation(maps: &Maps, s: &Seg) -> (f64, f64) {
    let r = 3.0 * maps.p.psf_sigma;
    let (a, b) = s.ends();
    let x0 = (a.0.min(b.0) - r).floor().max(0.0) as usize;
    let x1 = (a.0.max(b.0) + r).ceil().min((maps.w - 1) as f64).max(0.0) as usize;
    let y0 = (a.1.min(b.1) - r).floor().max(0.0) as usize;
    let y1 = (a.1.max(b.1) + r).ceil().min((maps.h - 1) as f64).max(0.0) as usize;
    let clip = maps.p.clip;
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
            let i = y * maps.w + x;
            flux += maps.pixels[i] as f64 - maps.bg[i] as f64;
            let wgt = (maps.z[i] as f64).clamp(0.0, clip);
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
