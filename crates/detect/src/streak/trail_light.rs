//! Where a predicted star trail's light lies: whether it shows in the map, how far beside its
//! predicted path it wandered, and the pointing's wander over the exposure measured on the
//! trails that show (`sky` follows every trail through it).

use super::stats::median_of;
use soig_image::hint::StarTrail;
use soig_image::imaging::bilinear;

/// Unit-noise level, in the smoothed map, below which a trail or its wings are noise: a trail
/// is subtracted only if three quarters of it are at least this bright.
const SHOWS_SIGMA: f64 = 1.0;
/// How far a trail's light is looked for beside its predicted path (`wander`), pixels, and by how
/// much its median there must beat twice the path's own, in unit noise (a median of 128
/// samples of the smoothed map scatters by about 0.1-0.2).
const WANDER_PX: i64 = 4;
const WANDER_GAIN: f64 = 0.5;
/// Trails are measured for the pointing's wander (`jitter_across`) in pieces of twice this
/// many pixels, this far apart, where a piece shows at least `FOLLOW_SIGMA`; the exposure is cut
/// into `JITTER_BINS` spans, each measured from at least `JITTER_PIECES` pieces of the
/// trails. `FOLLOW_SIGMA` was 3: trails of 2-4 sigma were then left out, spans measured on
/// one bright trail or none held a distant span's offset, and trails 3-5 px off their followed
/// path made 14 of 39 false boxes on the 400 images of the rotated survey row.
const FOLLOW_STEP_PX: usize = 32;
const FOLLOW_SIGMA: f64 = 2.0;
const JITTER_BINS: usize = 16;
const JITTER_PIECES: usize = 3;

/// Whether a predicted trail shows in the map: it moves, and three quarters of its `samples`
/// are at least `SHOWS_SIGMA`.
pub(super) fn shows(nodes: &[(f64, f64)], samples: &[(f64, f64, f64)]) -> bool {
    if nodes.len() < 2 || samples.len() < 8 {
        return false;
    }
    let mut vals: Vec<f64> = samples.iter().map(|s| s.2).collect();
    // The lower quartile by selection: the value a full sort puts there, in linear time.
    let q = vals.len() / 4;
    *vals.select_nth_unstable_by(q, f64::total_cmp).1 >= SHOWS_SIGMA
}

/// How far a trail's light lies beside its predicted path, perpendicular to it, where that is
/// clear: the lateral offset (whole pixels, up to `WANDER_PX`) at which the map's median along
/// the trail is highest, if the trail does not show on its path (`SHOWS_SIGMA`) but does
/// there, by twice the path's median plus `WANDER_GAIN`. (Only lost trails: a trail that
/// shows where predicted and was allowed to move followed a debris streak beside it.) The
/// prediction shifts a still pointing by the image's mean jitter; a trail in the image for part
/// of the exposure follows the jitter of that part only, 2-4 px off on 80-600 e-/px trails of
/// a rotated survey image, whose light then fell beside their reach and made 4 false boxes
/// there. `samples`: the path's points with the map's value at each (`bilinear`).
pub(super) fn wander(
    nodes: &[(f64, f64)],
    samples: &[(f64, f64, f64)],
    z: &[f32],
    w: usize,
    h: usize,
) -> Option<f64> {
    if nodes.len() < 2 || samples.len() < 8 {
        return None;
    }
    let ((ux, uy), len) = heading(nodes);
    if len < 1.0 {
        return None;
    }
    let (nx, ny) = (-uy, ux);
    // At most about 128 samples make each median.
    let stride = (samples.len() / 128).max(1);
    // On the path itself the samples hold the map's values already (the same bilinear reads).
    let on_path: Vec<f64> = samples.iter().step_by(stride).map(|s| s.2).collect();
    let here = median_of(&on_path);
    // A trail that shows where predicted is not lost: the offsets beside it need no reading.
    if here.is_nan() || here >= SHOWS_SIGMA {
        return None;
    }
    // An offset whose median is sure to fall short of `lost`'s bar is read no further: it can
    // be neither lost nor the best of an offset that is (most trails are faint, and most of
    // their offsets are noise). Unread, it counts as -inf: the best, when lost, is the same.
    let bar = SHOWS_SIGMA.max(2.0 * here.max(0.0) + WANDER_GAIN);
    let level = |d: f64| {
        median_across(z, w, h, samples, stride, (nx, ny), d, bar).unwrap_or(f64::NEG_INFINITY)
    };
    let (d, best) = (-WANDER_PX..=WANDER_PX)
        .filter(|&d| d != 0)
        .map(|d| (d as f64, level(d as f64)))
        .fold((0.0, here), |m, c| if c.1 > m.1 { c } else { m });
    let lost = best >= SHOWS_SIGMA && best >= 2.0 * here.max(0.0) + WANDER_GAIN;
    (d != 0.0 && lost).then_some(d)
}

/// A path's direction from its first node to its last: the unit vector and the distance (the
/// vector is the direction over at least 1e-9 px, so a still trail gives zeros, not NaN).
pub(super) fn heading(nodes: &[(f64, f64)]) -> ((f64, f64), f64) {
    let (a, b) = (nodes[0], nodes[nodes.len() - 1]);
    let len = (b.0 - a.0).hypot(b.1 - a.1);
    let l = len.max(1e-9);
    (((b.0 - a.0) / l, (b.1 - a.1) / l), len)
}

/// Visits the points of the path through `nodes` 1 px apart (each segment cut into whole steps
/// no longer than a pixel; one node: that node) that lie inside a `w` x `h` image, with the
/// segment's index and the fraction along it.
pub(super) fn walk(
    nodes: &[(f64, f64)],
    w: usize,
    h: usize,
    mut visit: impl FnMut(f64, f64, usize, f64),
) {
    let inside =
        |x: f64, y: f64| x >= 0.0 && y >= 0.0 && x <= (w - 1) as f64 && y <= (h - 1) as f64;
    if nodes.len() == 1 && inside(nodes[0].0, nodes[0].1) {
        visit(nodes[0].0, nodes[0].1, 0, 0.0);
    }
    for (k, pair) in nodes.windows(2).enumerate() {
        let (a, b) = (pair[0], pair[1]);
        let n = ((b.0 - a.0).hypot(b.1 - a.1)).ceil().max(1.0) as usize;
        for j in 0..n {
            let f = j as f64 / n as f64;
            let (x, y) = (a.0 + f * (b.0 - a.0), a.1 + f * (b.1 - a.1));
            if inside(x, y) {
                visit(x, y, k, f);
            }
        }
    }
}

/// The map's median `d` px across a path (along its normal `n`) over every `stride`-th of its
/// points `pts` (x, y, anything); None, read no further, once more than half the values read
/// are below `below` (then so are the middle two and their mean: the median is too). No value
/// is below -inf: then always the median.
#[allow(clippy::too_many_arguments)]
fn median_across(
    z: &[f32],
    w: usize,
    h: usize,
    pts: &[(f64, f64, f64)],
    stride: usize,
    n: (f64, f64),
    d: f64,
    below: f64,
) -> Option<f64> {
    let count = pts.len().div_ceil(stride);
    let (mut under, mut nan) = (0, false);
    let mut v: Vec<f64> = Vec::with_capacity(count);
    for q in pts.iter().step_by(stride) {
        let x = bilinear(z, w, h, q.0 + d * n.0, q.1 + d * n.1) as f64;
        // A NaN may sort below the rest (`median_of` orders by `total_cmp`): no early answer.
        nan |= x.is_nan();
        under += usize::from(x < below);
        if !nan && 2 * under > count {
            return None;
        }
        v.push(x);
    }
    Some(median_of(&v))
}

/// `t`'s nodes each moved across the trail by `offset(time)` pixels (along (-u_y, u_x), u its
/// direction of motion); a trail without node times, or not moving, as it is.
pub(super) fn across(t: &StarTrail, offset: impl Fn(f64) -> f64) -> Vec<(f64, f64)> {
    let n = t.nodes.len();
    if n < 2 || t.times_s.len() != n {
        return t.nodes.clone();
    }
    let ((ux, uy), len) = heading(&t.nodes);
    if len < 1.0 {
        return t.nodes.clone();
    }
    let (nx, ny) = (-uy, ux);
    t.nodes
        .iter()
        .zip(&t.times_s)
        .map(|(&(x, y), &time)| {
            let o = offset(time);
            (x + o * nx, y + o * ny)
        })
        .collect()
}

/// Linear interpolation in (time, offset) knots sorted by time, held beyond the ends.
pub(super) fn at_time(knots: &[(f64, f64)], time: f64) -> f64 {
    let j = knots.partition_point(|k| k.0 < time);
    if j == 0 {
        knots[0].1
    } else if j == knots.len() {
        knots[knots.len() - 1].1
    } else {
        let ((t0, o0), (t1, o1)) = (knots[j - 1], knots[j]);
        o0 + (o1 - o0) * (time - t0) / (t1 - t0).max(1e-12)
    }
}

/// The pointing's wander across the trails over the exposure, as (time, offset) knots: the
/// prediction shifts a still pointing by the image's mean jitter, but the pointing wanders
/// (Brownian jitter), so a bright trail runs up to 4-5 px beside its predicted path, at an
/// angle to it, and its residue made false boxes. All stars share that wander at each instant,
/// so it is measured on the trails that show: on each piece of `2 FOLLOW_STEP_PX` of such a
/// trail, the lateral offset (up to `WANDER_PX`, refined by a parabola) at which the
/// map's median is highest, where it shows at least `FOLLOW_SIGMA`, at the piece's time; then
/// the median of the pieces in each of `JITTER_BINS` spans of the exposure that holds at least
/// `JITTER_PIECES` of them (so that one trail, or a debris streak or a neighbour beside it,
/// does not move it). None: fewer than two spans measured, or no trail with node times.
pub(super) fn jitter_across(
    trails: &[StarTrail],
    z: &[f32],
    w: usize,
    h: usize,
) -> Option<Vec<(f64, f64)>> {
    let mut pieces: Vec<(f64, f64)> = Vec::new();
    for t in trails {
        let n = t.nodes.len();
        if n < 2
            || t.times_s.len() != n
            || t.nodes.iter().any(|p| !p.0.is_finite() || !p.1.is_finite())
        {
            continue;
        }
        let ((ux, uy), len) = heading(&t.nodes);
        if len < (2 * FOLLOW_STEP_PX) as f64 {
            continue;
        }
        let (nx, ny) = (-uy, ux);
        // Points 1 px apart inside the image, with their times.
        let mut pts: Vec<(f64, f64, f64)> = Vec::new();
        walk(&t.nodes, w, h, |x, y, k, f| {
            let (t0, t1) = (t.times_s[k], t.times_s[k + 1]);
            pts.push((x, y, t0 + f * (t1 - t0)));
        });
        // The median, or None where it is sure to be below `below` (see `median_across`).
        let level = |part: &[(f64, f64, f64)], stride: usize, d: f64, below: f64| {
            median_across(z, w, h, part, stride, (nx, ny), d, below)
        };
        // Only trails that show clearly near their path (judged on about 64 points: most
        // trails are faint, and this is all they cost).
        let stride = (pts.len() / 64).max(2);
        let faint =
            |d: i64| level(&pts, stride, d as f64, FOLLOW_SIGMA).is_none_or(|m| m < FOLLOW_SIGMA);
        if pts.len() < 2 * FOLLOW_STEP_PX || (-WANDER_PX..=WANDER_PX).all(faint) {
            continue;
        }
        let mut c = FOLLOW_STEP_PX;
        while c + FOLLOW_STEP_PX <= pts.len() {
            let part = &pts[c - FOLLOW_STEP_PX..c + FOLLOW_STEP_PX];
            let m: Vec<f64> = (-WANDER_PX..=WANDER_PX)
                // Every offset's median (none is below -inf).
                .filter_map(|d| level(part, 2, d as f64, f64::NEG_INFINITY))
                .collect();
            let k = (0..m.len()).fold(0, |k, j| if m[j] > m[k] { j } else { k });
            // A peak at the search's edge may lie beyond it: no measure.
            if m[k] >= FOLLOW_SIGMA && k > 0 && k < m.len() - 1 {
                let curve = m[k - 1] - 2.0 * m[k] + m[k + 1];
                let sub = if curve < 0.0 {
                    (0.5 * (m[k - 1] - m[k + 1]) / curve).clamp(-0.5, 0.5)
                } else {
                    0.0
                };
                pieces.push((pts[c].2, k as f64 - WANDER_PX as f64 + sub));
            }
            c += FOLLOW_STEP_PX;
        }
    }
    if pieces.is_empty() {
        return None;
    }
    let t_lo = pieces.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
    let t_hi = pieces.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max);
    let span = (t_hi - t_lo).max(1e-9) / JITTER_BINS as f64;
    let mut bins: Vec<Vec<f64>> = vec![Vec::new(); JITTER_BINS];
    for &(time, o) in &pieces {
        bins[(((time - t_lo) / span) as usize).min(JITTER_BINS - 1)].push(o);
    }
    let knots: Vec<(f64, f64)> = bins
        .iter_mut()
        .enumerate()
        .filter(|(_, b)| b.len() >= JITTER_PIECES)
        .map(|(i, b)| (t_lo + (i as f64 + 0.5) * span, median_of(b)))
        .collect();
    (knots.len() >= 2).then_some(knots)
}

#[cfg(test)]
mod jitter_tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    /// Twelve horizontal trails of 6 unit-noise sigmas on a unit-noise map, each in the image
    /// for part of a 10 s exposure, all displaced across their paths by the same wander
    /// (0 -> +3 -> -1 px, piecewise linear in time), predicted straight: the estimate follows
    /// the wander to 0.5 px from the second to the ninth second, and a trail moved by it lies
    /// on its light.
    #[test]
    fn the_pointing_wander_is_measured_on_the_trails() {
        let (w, h) = (600usize, 600usize);
        let wander = |t: f64| {
            if t < 5.0 {
                0.6 * t
            } else {
                3.0 - 0.8 * (t - 5.0)
            }
        };
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut z: Vec<f32> = (0..w * h)
            .map(|_| {
                let v: f64 = StandardNormal.sample(&mut rng);
                v as f32
            })
            .collect();
        // 50 px a second along x; trail k starts at t0 and lasts 4-10 s.
        let mut trails = Vec::new();
        for k in 0..12 {
            let y = 40.0 + 45.0 * k as f64;
            let (t0, t1) = (0.5 * (k % 4) as f64, 10.0 - 0.7 * (k % 3) as f64);
            let times: Vec<f64> = (0..=((t1 - t0) * 10.0) as usize)
                .map(|i| t0 + 0.1 * i as f64)
                .collect();
            let nodes: Vec<(f64, f64)> = times.iter().map(|&t| (50.0 + 50.0 * t, y)).collect();
            // Drawn where the wander puts it: a Gaussian cross-section of sigma 2 px.
            for x in 50..551 {
                let t = (x as f64 - 50.0) / 50.0;
                if t < t0 || t > t1 {
                    continue;
                }
                let yc = y - wander(t);
                for yy in (yc as usize - 8)..(yc as usize + 9) {
                    let d = yy as f64 - yc;
                    z[yy * w + x] += (6.0 * (-d * d / 8.0).exp()) as f32;
                }
            }
            trails.push(StarTrail {
                nodes,
                times_s: times,
                electrons: 1e4,
            });
        }
        let knots = jitter_across(&trails, &z, w, h).expect("measured");
        // Offsets are along (-u_y, u_x) = +y for motion along +x; the wander moved the light
        // to -y.
        for t in [2.0, 3.5, 5.0, 6.5, 8.0] {
            let got = -at_time(&knots, t);
            assert!(
                (got - wander(t)).abs() <= 0.5,
                "at {t} s: {got:.2} px, drawn {:.2}",
                wander(t)
            );
        }
        let moved = across(&trails[5], |t| at_time(&knots, t));
        let (x, y) = moved[40];
        assert!(
            (y - (trails[5].nodes[40].1 - wander(trails[5].times_s[40]))).abs() <= 0.5,
            "{x} {y}"
        );
    }
}
