//! Star-aware pass, after explaining away: a kept streak followed beyond its ends, piece by
//! piece, across the star trails that hide it and along the pointing's wander, to where it
//! truly ends.
//!
//! Where a debris streak runs onto a bright star's trail (along it, or into it at a small
//! angle), the 8-bit stretch compresses its light: on the rotated survey row a streak of 4.3
//! unit-noise sigmas alone added 0.3-1 to a trail of 5 sigmas, and where two or three trails
//! overlap their subtraction left the map 2-7 sigmas below zero. The ends found on the
//! subtracted map (`refine`, `fit`) stop where the trail begins: 8 debris streaks of that row's
//! 400 images were boxed too short so (IoU 0.27-0.48), in one or two pieces. And a long streak
//! is not straight: the pointing's wander bends it by a few pixels, so the refined (straight)
//! axis of a piece of it leaves it beyond that piece. The map cannot tell under a bright trail
//! whether the streak goes on; beyond the trail it can. So the streak is followed outwards from
//! each end in pieces of `PIECE_PX`, each looked for within `ACROSS_PX` across of the last one's
//! line (wider for each piece it was not seen in), and the end is the change point of the same
//! half-level excess as `refine`'s (`min(mean, 1.5 level) - level / 2`, summed outwards),
//! except that a piece where the trails' subtraction removed at least half the streak's level
//! on any line it may take is hidden: a dip there is no end (only light counts). The streak is
//! thus followed across a trail only as far as it shows again beyond it (or beside it, where the
//! trail is fainter), by at least `MIN_GAIN_PX` of excess: an end lands on a piece where the
//! streak shows, seen above half its level, or hidden but brighter than the noise of the
//! offsets searched (`SHOWS_SIGMA`), or where the trail hides it up to the frame's edge.

use super::maps::Maps;
use super::refine::flux_and_elongation;
use super::segment::{Point, Seg};
use super::stats::median_of;

/// Length of a piece, pixels: 16 samples of the smoothed map average its noise to about 0.7.
const PIECE_PX: f64 = 16.0;
/// How far across a piece is looked for from the last one's line, pixels, and in what steps:
/// the wander bends a streak by a few pixels over hundreds. Each piece since the streak last
/// showed (hidden, or too faint) widens the search by as much, up to `MAX_ACROSS_PX`: a short
/// fragment's axis is a degree or so off, 4 px over a 250 px trail.
const ACROSS_PX: f64 = 1.5;
const ACROSS_STEP_PX: f64 = 0.5;
const MAX_ACROSS_PX: f64 = 8.0;
/// A piece is hidden where the trails' subtraction removed at least this share of the streak's
/// level (median along the piece).
const HIDDEN_SHARE: f64 = 0.5;
/// An end moves only if the pieces beyond it hold at least this many pixels' worth of
/// half-level excess (a streak at its level gains half its level per pixel) ...
const MIN_GAIN_PX: f64 = 16.0;
/// ... and the walk stops where it has lost this many pieces' worth since the best end.
const GIVE_UP_PIECES: f64 = 4.0;
/// A hidden piece holds an end only where its best offset reads at least this many times the
/// noise of a piece's mean (and half the streak's level): the best of up to 33 offsets,
/// searched 8 px wide once the streak is lost, reads about 1.3 such sigmas on noise alone, and
/// under a trail running on from a faint streak's end (level 1.6, a piece's sigma 0.59) it
/// read 0.8-1.5 over 430 px, which carried the end along the trail (rotated semisynthetic
/// development seed 777, image 78: a box 923 px long for a 510 px streak). A streak that goes
/// on under a trail reads its own level there (2.2-4.4 at level 3.8: rotated synthetic
/// development seed 778, image 28). Hidden pieces that read less still carry the walk on
/// (their light counts), and hold the end where the trail hides the streak up to the frame's
/// edge (original synthetic development seed 777, image 95: a streak hidden for its last
/// 300 px). Measured with `LONGER_SHARE` 0.02 in `sky`, streak mAP50-95 on the development
/// sets (150 images each, `examples/sky_eval`): rotated semisynthetic seeds 777 / 778 0.9406
/// -> 0.9488, 0.9176 -> 0.9167; rotated synthetic 778, original synthetic 777 and original
/// semisynthetic 778 unchanged (0.9721, 0.9630, 0.9335); false boxes 13 -> 12 in all.
const SHOWS_SIGMA: f64 = 3.0;

/// `s` with each end moved outwards to where the streak followed beyond it ends (see the
/// module docs); `s` itself where no end moves, or outside the star-aware pass.
pub(super) fn reach(maps: &Maps, s: &Seg) -> Seg {
    if maps.removed.is_none() {
        return *s;
    }
    let (ux, uy) = s.dir();
    let (nx, ny) = (-uy, ux);
    // The streak's level: the median along it (its ends stopped where trails hide it).
    let along: Vec<f64> = s
        .axis_points()
        .map(|(x, y)| maps.cross_mean(x, y, nx, ny))
        .collect();
    let level = median_of(&along);
    if level <= 0.0 {
        return *s;
    }
    let (a, b) = s.ends();
    let (a2, b2) = (
        follow(maps, a, (-ux, -uy), level),
        follow(maps, b, (ux, uy), level),
    );
    if a2 == a && b2 == b {
        return *s;
    }
    let length = (b2.0 - a2.0).hypot(b2.1 - a2.1);
    let mut r = Seg {
        cx: 0.5 * (a2.0 + b2.0),
        cy: 0.5 * (a2.1 + b2.1),
        theta: (b2.1 - a2.1).atan2(b2.0 - a2.0),
        length,
        ..*s
    };
    (r.flux, r.elongation) = flux_and_elongation(maps, &r);
    r
}

/// The end of a streak of `level` followed from its end `e` outwards along `u`.
fn follow(maps: &Maps, e: Point, u: (f64, f64), level: f64) -> Point {
    let (nx, ny) = (-u.1, u.0);
    let cap = 1.5 * level;
    // Lateral offset of the streak from the line through `e` along `u`, and the pieces
    // since it was last seen.
    let (mut off, mut missed) = (0.0, 0.0);
    let (mut acc, mut best, mut best_end) = (0.0, 0.0, e);
    // The walk's best end among pieces where the streak does not show, and whether the walk
    // reached the frame's edge with the streak hidden.
    let mut unshown = (f64::NEG_INFINITY, e);
    let (mut hidden_to_edge, mut last_hidden) = (false, false);
    // What a hidden piece's best offset must read to hold an end.
    let n = PIECE_PX as usize;
    let piece_sd = maps.contrast_sum_sd(&[(0.0, 1.0)], u.1.atan2(u.0), n) / n as f64;
    let shows_hidden = (0.5 * level).max(SHOWS_SIGMA * piece_sd);
    let mut start = 0.0;
    loop {
        // The piece's k-th sample (1 px apart) at lateral offset `o`.
        let at = |o: f64, k: usize| {
            let t = start + k as f64 + 0.5;
            (e.0 + t * u.0 + o * nx, e.1 + t * u.1 + o * ny)
        };
        let (x1, y1) = at(off, n - 1);
        if x1 < 0.0 || y1 < 0.0 || x1 > (maps.w - 1) as f64 || y1 > (maps.h - 1) as f64 {
            hidden_to_edge = last_hidden;
            break;
        }
        let mean = |o: f64| {
            (0..n)
                .map(|k| {
                    let (x, y) = at(o, k);
                    maps.z_at(x, y)
                })
                .sum::<f64>()
                / n as f64
        };
        let across = (ACROSS_PX * (1.0 + missed)).min(MAX_ACROSS_PX);
        let n_across = (across / ACROSS_STEP_PX).round() as i64;
        let offsets = (-n_across..=n_across).map(|j| off + j as f64 * ACROSS_STEP_PX);
        let means: Vec<(f64, f64)> = offsets.clone().map(|o| (o, mean(o))).collect();
        // The mean on the followed line itself (the centre offset, `j` 0) ...
        let on_line = means[n_across as usize].1;
        // ... and the best of them, which the walk follows.
        let (o_best, m) =
            means.iter().fold(
                (off, f64::NEG_INFINITY),
                |b, &c| {
                    if c.1 > b.1 { c } else { b }
                },
            );
        // Hidden where the trails hide any line the streak may take (whole pixels apart).
        let hidden = offsets.step_by((1.0 / ACROSS_STEP_PX) as usize).any(|o| {
            let removed: Vec<f64> = (0..n).map(|k| removed_at(maps, at(o, k))).collect();
            median_of(&removed) >= HIDDEN_SHARE * level
        });
        // A seen piece's gain is read on the line the streak is followed along, not on the
        // best of the offsets searched, which noise alone lifts: on the original
        // semisynthetic development row (seed 777) that reading carried two streaks' ends
        // 175 and 240 px past their true ends (`reach_does_not_follow_noise_beyond_the_end`).
        // Under a hidden piece the followed line has no fair reading (the subtraction took
        // the streak's light with the trail's), so the best offset stays, and only light
        // counts there.
        let read = if hidden { m } else { on_line };
        let gain = (read.min(cap) - 0.5 * level) * PIECE_PX;
        if !hidden && m >= 0.5 * level {
            (off, missed) = (o_best, 0.0);
        } else {
            missed += 1.0;
        }
        acc += if hidden { gain.max(0.0) } else { gain };
        let shows = match hidden {
            true => m.min(cap) >= shows_hidden,
            false => gain > 0.0,
        };
        let (x, y) = at(off, n - 1);
        let end = (x + 0.5 * u.0, y + 0.5 * u.1);
        if acc > best && shows {
            (best, best_end) = (acc, end);
        } else if acc > best.max(unshown.0) {
            unshown = (acc, end);
        }
        last_hidden = hidden;
        start += PIECE_PX;
        if acc < best.max(unshown.0) - GIVE_UP_PIECES * PIECE_PX * 0.5 * level {
            break;
        }
    }
    if hidden_to_edge && unshown.0 > best {
        (best, best_end) = unshown;
    }
    if best >= MIN_GAIN_PX * 0.5 * level {
        best_end
    } else {
        e
    }
}

/// What the trails' subtraction removed at the pixel nearest `q` (0 outside the image).
fn removed_at(maps: &Maps, (x, y): Point) -> f64 {
    let (i, j) = (x.round(), y.round());
    match maps.removed {
        Some(r) if i >= 0.0 && j >= 0.0 && i < maps.w as f64 && j < maps.h as f64 => {
            r[j as usize * maps.w + i as usize] as f64
        }
        _ => 0.0,
    }
}
