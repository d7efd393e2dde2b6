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

use super::maps::Maps;
use super::params::Footprint;
use super::segment::Seg;
use soig_image::geometry::{BoxPx, LABEL_SHARE};
use soig_image::psf::DebrisFlux;

/// Offset across a Gaussian profile, in its sigmas, where it is at half its peak: sqrt(2 ln 2).
const HALF_WIDTH: f64 = 1.177_410_022_515_474_5;

/// Length of the pieces in which the centre line and the brightness are measured, pixels:
/// long enough for a faint streak's piece to have a centroid (16 samples), short enough to
/// follow the pointing jitter's wander (a few pixels over a 1000 px streak).
const PIECE_PX: f64 = 16.0;

/// A piece's measured centre-line offset is dropped (and taken from its neighbours, as an
/// unmeasured one's) where it lies more than this many pixels from the median of the
/// `OFFSET_NEIGHBOURS` nearest measured pieces: the pointing jitter moves a streak's centre
/// line 1-1.5 px (`sky::JITTER_PX`), so a jump of more is a star, a trail's residue or noise
/// pulling a faint piece's centroid. Carried to an end, two such pieces boxed a 978 px streak
/// 6 px too thick (rotated semisynthetic development 777, image 35: IoU 0.79 -> 0.96). Six
/// neighbours, so that two pulled pieces at an end do not move the median of the piece before
/// them (with four the rule alone gave the same figures as below within 0.001).
const OFFSET_JUMP_PX: f64 = 2.0;
const OFFSET_NEIGHBOURS: usize = 6;

/// The centre line is then the running median of this many pieces' offsets (80 px): on a
/// faint streak each piece's centroid scatters by about a pixel, and the box, 99 % of the
/// flux along that line, widened with it. Development sets (`examples/sky_eval`, streak
/// mAP50-95, 150 images each), before -> with both rules: rotated semisynthetic 777 0.9488 ->
/// 0.9567, 778 0.9167 -> 0.9185; rotated synthetic 778 0.9721 -> 0.9756; original synthetic
/// 777 0.9630 -> 0.9613; original semisynthetic 778 0.9335 -> 0.9349; fixed original
/// semisynthetic 777 0.9858 -> 0.9853; fixed padded synthetic 777 0.9868 -> 0.9922. A
/// straight line fitted to the offsets instead lost 0.01-0.02 on the rotated semisynthetic
/// sets: their streaks bend by more than the jitter.
const OFFSET_MEDIAN_PIECES: usize = 5;

/// Step between profile samples along the axis, pixels.
const STEP_PX: f64 = 0.5;

/// How far beyond the refined (half-level of the clipped map) ends an end is looked for,
/// pixels, and how far inside (a bright streak's half-level ends lie up to ~20 px beyond the
/// true ones). A faint streak's refined end on real noise lies more than 10 px inside its true
/// end at 13-22 % of the ends of the semisynthetic development sets (0-11 % on the synthetic
/// ones), and up to a few hundred px where a stretch of it was too faint to refine; where the
/// level beside the line is matched the search finds them, and beyond the end the profile falls
/// below that level, so a longer search adds no length. Development sets (`examples/sky_eval`,
/// then `soig eval`), mAP50-95 at 10 -> 40 -> 80 px: rotated semisynthetic (seed 778, 150
/// images) 0.8396 -> 0.8497 -> 0.8536, original semisynthetic (778, 300) 0.8371 -> 0.8496 ->
/// 0.8542, original synthetic (777, 100) 0.9258 -> 0.9286 -> 0.9286, rotated synthetic (778,
/// 150) 0.9595 -> 0.9607 -> 0.9607; at 80 -> 400 px, with `EXIT_ODDS`, `BRIGHTNESS_SCATTER` and
/// the footprint: rotated semisynthetic 0.8766 -> 0.8814, original semisynthetic 0.8719 ->
/// 0.8777.
const SEARCH_OUT_PX: f64 = 400.0;
const SEARCH_IN_PX: f64 = 40.0;

/// Prior odds that a streak whose end search runs on to the frame's border (or its footprint's
/// outline) leaves the frame there rather than ends in the stretch before it. Survey streaks
/// are long: of the matched streaks' ends on the original semisynthetic development set (seed
/// 778, 300 images) 413 leave the frame and 119 are the streak's own, spread along it, so within
/// the last tens of pixels the odds are far above 10; 10 keeps a bright streak's real end near
/// the border. A faint streak's last stretch is mostly noise (there the change point lands
/// 10-20 px short of the border as often as not), and the odds decide. Development sets
/// (mAP50-95, the change point alone -> with the odds): original semisynthetic 0.8550 ->
/// 0.8628, one false box fewer and two more found at confidence 0.5.
const EXIT_ODDS: f64 = 10.0;

/// `EXIT_ODDS` where stars are points (fixed pointing): there streaks are shorter and most end
/// in the frame. Of the streak ends of the faint-limit-fixed development set (seed 9422, 300
/// images) 184 lie beyond the frame and 416 in it, against the survey set's 413 and 119 above,
/// so the odds are about 8 times lower: 1. With 10 a faint streak whose light beside the line
/// is below its level was carried on to the border by the prior alone (faint-limit-fixed 9423,
/// image 126: a 150 px streak boxed to the frame's edge, 50 px too long, IoU 0.35; with 1, 0.9).
/// Faint-limit-fixed development 9423 (600 images): found 404 -> 405, false boxes 23 -> 22;
/// 9421 and 9422 the same.
const POINTS_EXIT_ODDS: f64 = 1.0;

/// The share of its brightness at which the streak, in the hypothesis that it leaves the frame,
/// goes on over the stretch between its change point and the border. A tumbling streak's light
/// varies by a factor 2-3 along it (the survey rows' tumble amplitudes are up to 0.5), so its
/// dimmer far part falls below half the level matched 40 px inside the change point, and the
/// test against the full brightness ended it there: on the rotated semisynthetic development set
/// (seed 778, 150 images) 11 ends that leave the frame were more than 10 px short (up to 218
/// px), 3.2 of the 7.2 matches' worth of mAP50-95 credit lost to IoU. Development sets,
/// mAP50-95 at 1 (before) -> 0.85 -> 0.7 -> 0.5, the level-based test alone: rotated
/// semisynthetic 0.8821 -> 0.8829 -> 0.8947 -> 0.8865; at 0.7 original synthetic 0.9440 ->
/// 0.9302 and original semisynthetic 0.8796 -> 0.8751 (two more false boxes at confidence 0.5):
/// a weaker alternative lets the prior odds carry the streak on where the level is measured
/// low or other light lies on the line beyond. Hence the brightness is the larger of the centre
/// line's own (`end`'s `centre_in`) and twice the level, and the light beside the streak
/// (`BESIDE_SIGMAS`) is taken off the stretch's: see `goes_on`.
const GOES_ON_SHARE: f64 = 0.7;

/// The lines beside the streak (offsets in the smoothed map's cross-section sigmas, on either
/// side) whose median light over the stretch is taken off the centre line's before the exit
/// test: light that is no narrow line (a real frame's broad background, a trail's residue
/// beside as much as on the line) is no streak going on.
const BESIDE_SIGMAS: std::ops::RangeInclusive<i32> = 4..=10;

/// The relative scatter a piece's brightness is smoothed to before the box is drawn. On a faint
/// streak a 16 px piece's brightness is mostly noise (0.1 to 4 times the median along a line
/// SNR 40 streak), and the 99 % flux box ended where noise had dimmed the last pieces, 10-20 px
/// short; a running median over as many pieces as bring the scatter to this keeps a bright
/// streak's (and a tumbling one's) real variation. Development sets, mAP50-95 without -> with
/// (both with `EXIT_ODDS`): original semisynthetic 0.8628 -> 0.8719 (0.05 and 0.2: 0.8719 and
/// 0.8670).
const BRIGHTNESS_SCATTER: f64 = 0.1;

/// The fitted streak: its centre line as (t, lateral offset, brightness) nodes along the
/// refined axis, and the extent of the streak along it.
struct Fit {
    /// Per piece: centre t, lateral offset (px, along the normal), brightness (z summed across).
    pieces: Vec<(f64, f64, f64)>,
    t0: f64,
    t1: f64,
}

/// The label box of the fitted streak in pixel-edge coordinates (pixel `i` spans
/// `[i, i + 1]`), clipped to the image; None when no fit is possible (the caller keeps the
/// padded box).
pub(super) fn fitted_box(maps: &Maps, s: &Seg) -> Option<BoxPx> {
    let fit = fit(maps, s)?;
    let psf = maps.p.psf_sigma;
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
    let b = DebrisFlux::of_samples(&samples, psf, maps.w, maps.h).label_box(LABEL_SHARE)?;
    let (w, h) = (maps.w as f64, maps.h as f64);
    Some(BoxPx {
        x_min: (b.x_min + 0.5).clamp(0.0, w),
        y_min: (b.y_min + 0.5).clamp(0.0, h),
        x_max: (b.x_max + 0.5).clamp(0.0, w),
        y_max: (b.y_max + 0.5).clamp(0.0, h),
    })
}

/// The smoothed map's cross-section sigma: the PSF smoothed by the detector's Gaussian
/// of the same width.
fn z_sigma(maps: &Maps) -> f64 {
    std::f64::consts::SQRT_2 * maps.p.psf_sigma
}

/// Two passes: pieces and ends on the refined segment, then pieces again between the ends
/// found and the ends again (a refined segment can reach 20 px beyond a bright streak's
/// end, and pieces there hold no streak).
fn fit(maps: &Maps, s: &Seg) -> Option<Fit> {
    let (ux, uy) = s.dir();
    let (lo, hi) = maps.t_range(s.cx, s.cy, ux, uy);
    // Beyond the image's border the streak goes on, and its box is clipped there; beyond the
    // footprint's outline the frame holds no data, and the streak's light stops at it.
    let (lo, hi, beyond) = match &maps.p.footprint {
        Some(f) => {
            let (a, b) = inside(f, (s.cx, s.cy), (ux, uy));
            (lo.max(a), hi.min(b), 0.0)
        }
        None => (lo, hi, 5.0 * maps.p.psf_sigma),
    };
    if lo > hi {
        return None;
    }
    let half = 0.5 * s.length;
    let mut fit = Fit {
        pieces: Vec::new(),
        t0: -half,
        t1: half,
    };
    for _ in 0..2 {
        fit.pieces = pieces(maps, s, fit.t0.max(lo), fit.t1.min(hi));
        if fit.pieces.is_empty() {
            return None;
        }
        let t1 = end(maps, s, &fit, 1.0, (lo, hi), beyond);
        let t0 = -end(maps, s, &fit, -1.0, (lo, hi), beyond);
        (fit.t0, fit.t1) = (t0, t1);
        if fit.t1 <= fit.t0 {
            return None;
        }
    }
    Some(fit)
}

/// The range of t for which the point `c + t u` lies inside the convex `footprint` (empty:
/// lo > hi).
pub(super) fn inside(footprint: &Footprint, c: (f64, f64), u: (f64, f64)) -> (f64, f64) {
    let f = footprint;
    // The corners' turning sense: inside lies on that side of every edge.
    let sense: f64 = (0..4)
        .map(|i| {
            let (a, b) = (f[i], f[(i + 1) % 4]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f64>()
        .signum();
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    for i in 0..4 {
        let (a, b) = (f[i], f[(i + 1) % 4]);
        let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
        // sense * cross(edge, c + t u - a) >= 0, i.e. at + bt * t >= 0.
        let at = sense * (ex * (c.1 - a[1]) - ey * (c.0 - a[0]));
        let bt = sense * (ex * u.1 - ey * u.0);
        if bt.abs() < 1e-12 {
            if at < 0.0 {
                return (1.0, 0.0);
            }
        } else if bt > 0.0 {
            lo = lo.max(-at / bt);
        } else {
            hi = hi.min(-at / bt);
        }
    }
    (lo, hi)
}

/// Centre line and brightness, piece by piece over [ta, tb] along the axis: lateral
/// offset (centroid of the mean cross-section of z) and brightness (z summed across).
/// A piece too faint for a centroid, or far fainter than the streak (beyond its end, or
/// a masked star on it), takes its neighbours' offset.
fn pieces(maps: &Maps, s: &Seg, ta: f64, tb: f64) -> Vec<(f64, f64, f64)> {
    let (ux, uy) = s.dir();
    let (nx, ny) = (-uy, ux);
    let sz = z_sigma(maps);
    let at = |t: f64, v: f64| maps.z_at(s.cx + t * ux + v * nx, s.cy + t * uy + v * ny);
    let length = tb - ta;
    if length <= 0.0 {
        return Vec::new();
    }
    // At least three pieces where they can be 6 px long: a short streak bends with the
    // jitter too, and one straight piece boxes it a pixel off.
    let n_pieces = ((length / PIECE_PX).floor() as usize)
        .max(((length / 6.0).floor() as usize).min(3))
        .max(1);
    let piece = length / n_pieces as f64;
    let reach = (3.0 * sz).ceil() as i64;
    let offs: Vec<f64> = (-2 * reach..=2 * reach).map(|i| i as f64 * 0.5).collect();
    let mut pieces = Vec::with_capacity(n_pieces);
    for k in 0..n_pieces {
        let start = ta + k as f64 * piece;
        let ts: Vec<f64> = (0..piece.round().max(1.0) as usize)
            .map(|i| start + i as f64 + 0.5)
            .collect();
        let prof: Vec<f64> = offs
            .iter()
            .map(|&v| ts.iter().map(|&t| at(t, v)).sum::<f64>() / ts.len() as f64)
            .collect();
        let imax = (0..prof.len())
            .max_by(|&a, &b| prof[a].total_cmp(&prof[b]))
            .unwrap_or(0);
        let v0 = offs[imax];
        // Centroid of the positive part within 1.5 sigma of the peak.
        let (mut sw, mut sv) = (0.0, 0.0);
        for (&v, &p) in offs.iter().zip(&prof) {
            if (v - v0).abs() <= 1.5 * sz && p > 0.0 {
                sw += p;
                sv += p * v;
            }
        }
        // The noise sd of a piece's mean: z has unit noise, correlated over about
        // 2 sqrt(pi) sigma along the axis.
        let sd = (2.0 * std::f64::consts::PI.sqrt() * sz / ts.len() as f64)
            .sqrt()
            .min(1.0);
        let off = if prof[imax] > 3.0 * sd && sw > 0.0 {
            sv / sw
        } else {
            f64::NAN
        };
        // Summed within 2 sigma of the centre line (of the axis where none is measured):
        // the refined axis can be tilted by a degree or two.
        let centre = if off.is_finite() { off } else { 0.0 };
        let bright: f64 = offs
            .iter()
            .zip(&prof)
            .filter(|(v, _)| (*v - centre).abs() <= 2.0 * sz)
            .map(|(_, &p)| 0.5 * p)
            .sum();
        pieces.push((start + 0.5 * piece, off, bright));
    }
    let bright: Vec<f64> = pieces.iter().map(|p| p.2).collect();
    let med = super::stats::median_of(&bright).max(1e-6);
    for p in &mut pieces {
        if p.2 < 0.3 * med {
            p.1 = f64::NAN;
        }
        // Kept positive and bounded: a dip is not an end, a star on the line no peak.
        p.2 = p.2.clamp(0.1 * med, 10.0 * med);
    }
    smooth_brightness(&mut pieces, med);
    steady_centre_line(&mut pieces);
    pieces
}

/// The pieces' centre-line offsets (`(t, offset, brightness)`, NaN where none was measured)
/// made a line a streak can follow: a measured offset that jumps from its neighbours' is
/// dropped (`OFFSET_JUMP_PX`), a missing one is the nearest measured one's (none measured:
/// the refined axis), and the line is their running median (`OFFSET_MEDIAN_PIECES`).
pub(super) fn steady_centre_line(pieces: &mut [(f64, f64, f64)]) {
    let measured = |pieces: &[(f64, f64, f64)]| -> Vec<(f64, f64)> {
        pieces
            .iter()
            .filter(|p| p.1.is_finite())
            .map(|p| (p.0, p.1))
            .collect()
    };
    let known = measured(pieces);
    if known.len() > OFFSET_NEIGHBOURS {
        for p in pieces.iter_mut().filter(|p| p.1.is_finite()) {
            let mut others: Vec<(f64, f64)> =
                known.iter().copied().filter(|q| q.0 != p.0).collect();
            others.sort_by(|a, b| (a.0 - p.0).abs().total_cmp(&(b.0 - p.0).abs()));
            let near: Vec<f64> = others.iter().take(OFFSET_NEIGHBOURS).map(|q| q.1).collect();
            if (p.1 - super::stats::median_of(&near)).abs() > OFFSET_JUMP_PX {
                p.1 = f64::NAN;
            }
        }
    }
    let known = measured(pieces);
    for p in pieces.iter_mut().filter(|p| !p.1.is_finite()) {
        p.1 = known
            .iter()
            .min_by(|a, b| (a.0 - p.0).abs().total_cmp(&(b.0 - p.0).abs()))
            .map_or(0.0, |k| k.1);
    }
    if pieces.len() >= OFFSET_MEDIAN_PIECES {
        let offsets: Vec<f64> = pieces.iter().map(|p| p.1).collect();
        let line = super::stats::running_median(&offsets, OFFSET_MEDIAN_PIECES);
        for (p, o) in pieces.iter_mut().zip(line) {
            p.1 = o;
        }
    }
}

/// The pieces' brightness as a running median over as many pieces as bring its relative
/// scatter (about the median `med`) down to `BRIGHTNESS_SCATTER`: one piece on a bright streak.
fn smooth_brightness(pieces: &mut [(f64, f64, f64)], med: f64) {
    let dev: Vec<f64> = pieces.iter().map(|p| (p.2 - med).abs()).collect();
    if dev.is_empty() {
        return;
    }
    let scatter = 1.4826 * super::stats::median_of(&dev) / med;
    let n = ((scatter / BRIGHTNESS_SCATTER).powi(2).ceil() as usize).clamp(1, pieces.len());
    if n == 1 {
        return;
    }
    let bright: Vec<f64> = pieces.iter().map(|p| p.2).collect();
    for (p, b) in pieces
        .iter_mut()
        .zip(super::stats::running_median(&bright, n))
    {
        p.2 = b;
    }
}

/// The end of the streak on the side `sign` (+1: towards +t) as a distance from the
/// centre along `sign`: where the centre-line profile crosses the level seen `HALF_WIDTH`
/// sigmas beside the line near that end (see the module docs), looked for around the
/// current end (`fit`). An end not reached inside the image (`lo`..`hi` along the axis)
/// lies beyond it: the streak leaves the frame.
fn end(maps: &Maps, s: &Seg, fit: &Fit, sign: f64, (lo, hi): (f64, f64), beyond: f64) -> f64 {
    let (ux, uy) = s.dir();
    let (nx, ny) = (-uy, ux);
    let sz = z_sigma(maps);
    let at = |t: f64, v: f64| {
        let (off, _) = fit.at(t);
        maps.z_at(
            s.cx + t * ux + (v + off) * nx,
            s.cy + t * uy + (v + off) * ny,
        )
    };
    // Distances from the centre along `sign`: this end, the other end, the border.
    let (near, far) = if sign > 0.0 {
        (fit.t1, -fit.t0)
    } else {
        (-fit.t0, fit.t1)
    };
    let border = if sign > 0.0 { hi } else { -lo };
    // The level beside the line, over the stretch inside this end.
    let margin = (3.0 * sz).min(0.25 * (near + far));
    let inner_b = (near - margin).min(border);
    let inner_a = (inner_b - SEARCH_IN_PX).max(margin - far);
    let vh = HALF_WIDTH * sz;
    // And the centre line's own brightness over the same stretch (the median: a star on it is
    // no streak), for the exit test: the 8-bit stretch and a faint streak's noise can put the
    // level beside the line far below half of it.
    let (mut level, mut along) = (0.0, Vec::new());
    let mut d = inner_a;
    while d <= inner_b {
        let t = sign * d;
        if t >= lo && t <= hi {
            level += 0.5 * (at(t, vh) + at(t, -vh));
            along.push(at(t, 0.0));
        }
        d += 1.0;
    }
    if along.is_empty() || level <= 0.0 {
        return near;
    }
    let level = level / along.len() as f64;
    let centre_in = super::stats::median_of(&along);
    // Change point: the distance maximising the cumulative excess of the profile over
    // the level, outwards from inside the streak (robust to noise and to dips).
    let start = (near - SEARCH_IN_PX).max(0.5 * (near - far)).min(border);
    let stop = (near + SEARCH_OUT_PX).min(border);
    let (mut acc, mut best, mut best_d) = (0.0, 0.0, start);
    let (mut d, mut last) = (start, start);
    while d <= stop {
        acc += (at(sign * d, 0.0) - level).min(level) * STEP_PX;
        if acc > best {
            best = acc;
            best_d = d + 0.5 * STEP_PX;
        }
        last = d;
        d += STEP_PX;
    }
    // The search ran on to the border: still above the level there, or the stretch after the
    // change point lit as a dimmer streak's would be (`goes_on`), the streak goes on beyond it.
    if last >= border - STEP_PX {
        // The samples after the change point (none: it is the last).
        let stretch = last + 0.5 * STEP_PX - best_d;
        let bright = centre_in.max(2.0 * level);
        let odds = if maps.points {
            POINTS_EXIT_ODDS
        } else {
            EXIT_ODDS
        };
        if stretch < 0.5 * STEP_PX || goes_on(&at, sign, (best_d, last), (bright, sz), odds) {
            return border + beyond;
        }
    }
    best_d
}

/// Whether a streak of centre-line brightness `bright` goes on over the stretch of distances
/// `from..=to` along `sign` (sampled every `STEP_PX`; `at(t, v)` reads the smoothed map at `t`
/// along the fitted centre line and `v` across it) rather than ends before it: a likelihood
/// ratio of the stretch's mean light on the centre line (each sample clipped at `bright`, a
/// star's trail across it no streak; less the median of the lines beside it,
/// `BESIDE_SIGMAS`, where that is above zero) between `GOES_ON_SHARE` of `bright` and none,
/// over its white-noise variance (z's correlation length, 2 sqrt(pi) sigma, over the
/// stretch's length), against the prior `odds` that it leaves the frame (`EXIT_ODDS`,
/// `POINTS_EXIT_ODDS`).
fn goes_on(
    at: &impl Fn(f64, f64) -> f64,
    sign: f64,
    (from, to): (f64, f64),
    (bright, sz): (f64, f64),
    odds: f64,
) -> bool {
    let mean_along = |v: f64| {
        let (mut sum, mut count) = (0.0, 0.0);
        let mut d = from;
        while d <= to {
            sum += at(sign * d, v).min(bright);
            count += 1.0;
            d += STEP_PX;
        }
        if count > 0.0 { sum / count } else { 0.0 }
    };
    let beside: Vec<f64> = BESIDE_SIGMAS
        .flat_map(|k| [k as f64 * sz, -k as f64 * sz])
        .map(mean_along)
        .collect();
    let mean = mean_along(0.0) - super::stats::median_of(&beside).max(0.0);
    let stretch = to + 0.5 * STEP_PX - from;
    let var = 2.0 * std::f64::consts::PI.sqrt() * sz / stretch;
    let lit = GOES_ON_SHARE * bright;
    lit * (mean - 0.5 * lit) / var > -odds.ln()
}

impl Fit {
    /// Lateral offset and brightness at t, linear between the pieces' centres; beyond the
    /// first and last centres the offset goes on along the nearest pair's slope (the refined
    /// axis may be tilted) and the brightness stays.
    fn at(&self, t: f64) -> (f64, f64) {
        let p = &self.pieces;
        let n = p.len();
        let beyond = |a: (f64, f64, f64), b: (f64, f64, f64)| {
            let slope = (b.1 - a.1) / (b.0 - a.0);
            (b.1 + slope * (t - b.0), b.2)
        };
        if n >= 2 && t <= p[0].0 {
            return beyond(p[1], p[0]);
        }
        if n >= 2 && t >= p[n - 1].0 {
            return beyond(p[n - 2], p[n - 1]);
        }
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
