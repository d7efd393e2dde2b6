//! The union of [`super::detect_streaks_among_stars`]' two passes. The star-aware pass adds
//! what the first cannot find (streaks near the trails' direction) and, beyond that, the
//! streaks the first missed, or a box of the same streak that scores higher and is as long.
//! Then one streak keeps one box, the longest.

use std::borrow::Borrow;

use super::output::Candidate;
use super::params::Sanitized;
use super::segment::{angle_diff_deg, point_segment_distance};

/// A second-pass box replaces the first pass's box of the same streak (beyond the trails'
/// tolerance) only if at least this long: a piece of it scoring higher does not replace the
/// whole (3 debris boxes 11-18 degrees off fell to IoU 0.12-0.27 so).
const SAME_LENGTH: f64 = 0.9;

/// The first pass's candidates `first` and the star-aware pass's `second` (trails along
/// `trail`, degrees) as one list, best first, at most `max_candidates`. Each may carry more
/// than its candidate (what boxes it: `two_passes`).
pub(super) fn union<C: Borrow<Candidate>>(
    mut first: Vec<C>,
    second: Vec<C>,
    trail: f64,
    p: &Sanitized,
) -> Vec<C> {
    // Beyond the tolerance the second pass adds the streaks the first missed, and replaces
    // the first's box of the same streak where it scores higher. The first pass's trail filter
    // (`trail_filter_px` along the trails) removes most of a line up to about 10 degrees off
    // them, which the tolerance (5 degrees plus slack) does not cover: 4 debris streaks at
    // 5.6-7 degrees, SNR 60-110, were lost on 200 rotated survey images; and 9 of 21 streaks
    // missed on the 400 of the rotated row, 7.1-9.8 degrees off, SNR 49-350, were boxed by the
    // first pass but scored 0.001-0.47 on what its filter had left of them.
    let (mut within, beyond): (Vec<C>, Vec<C>) = second
        .into_iter()
        .partition(|c| near_trail(c.borrow(), trail, p));
    for c in beyond {
        let k = first
            .iter()
            .position(|k| same_streak(c.borrow(), k.borrow(), p.dup_dist));
        match k {
            None => within.push(c),
            Some(i) if prefer_longer_second(first[i].borrow(), c.borrow(), p.dup_dist) => {
                first[i] = c
            }
            Some(_) => {}
        }
    }
    first.extend(within);
    let mut found = one_box_per_streak(first, p.dup_dist);
    let score = |c: &C| c.borrow().detection.score;
    found.sort_by(|a, b| score(b).total_cmp(&score(a)));
    found.truncate(p.max_candidates);
    found
}

/// Whether `c` lies along the trails within the tolerance, where the first pass drops every
/// candidate (its orientation uncertain by atan(4 psf_sigma / length)).
fn near_trail(c: &Candidate, trail: f64, p: &Sanitized) -> bool {
    let slack = (4.0 * p.psf_sigma / c.length_px.max(1.0))
        .atan()
        .to_degrees();
    angle_diff_deg(c.orientation_deg, trail) <= p.trail_tol + slack
}

/// Whether `a` and `b` are the same streak: half of either's axis lies along the other.
fn same_streak(a: &Candidate, b: &Candidate, dist: f64) -> bool {
    lies_along(a, b, dist) || lies_along(b, a, dist)
}

/// Whether the second pass's box `second` of the same streak replaces the first's `first`: it
/// scores higher, is as long (`SAME_LENGTH`) and the first lies along it.
fn prefer_longer_second(first: &Candidate, second: &Candidate, dist: f64) -> bool {
    first.detection.score < second.detection.score
        && second.length_px >= SAME_LENGTH * first.length_px
        && lies_along(first, second, dist)
}

/// One streak, one box: longest first, a candidate lying mostly along a longer one (the same
/// streak from both passes, or a piece of it) is dropped, whatever its score.
fn one_box_per_streak<C: Borrow<Candidate>>(mut found: Vec<C>, dist: f64) -> Vec<C> {
    let length = |c: &C| c.borrow().length_px;
    found.sort_by(|a, b| length(b).total_cmp(&length(a)));
    let mut kept: Vec<C> = Vec::new();
    for c in found {
        if !kept
            .iter()
            .any(|k| lies_along(c.borrow(), k.borrow(), dist))
        {
            kept.push(c);
        }
    }
    kept
}

/// Whether half of `c`'s axis lies within `dist` of `other`'s segment.
fn lies_along(c: &Candidate, other: &Candidate, dist: f64) -> bool {
    let [a, b] = c.ends;
    let (o0, o1) = (
        (other.ends[0][0], other.ends[0][1]),
        (other.ends[1][0], other.ends[1][1]),
    );
    let n = c.length_px.ceil().max(1.0) as usize;
    let near = (0..=n)
        .filter(|&k| {
            let f = k as f64 / n as f64;
            let q = (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]));
            point_segment_distance(q, o0, o1) <= dist
        })
        .count();
    2 * near > n
}

#[cfg(test)]
mod tests {
    use super::super::params::StreakParams;
    use super::super::tests_stages::cand;
    use super::*;

    #[test]
    fn the_union_rules() {
        let a = cand(10.0, 10.0, 90.0, 10.0, 0.5);
        // Overlapping along the same line, or 30 px beside it.
        let overlapping = cand(50.0, 11.0, 120.0, 11.0, 0.9);
        let beside = cand(10.0, 40.0, 90.0, 40.0, 0.9);
        assert!(same_streak(&a, &overlapping, 10.0) && same_streak(&overlapping, &a, 10.0));
        assert!(!same_streak(&a, &beside, 10.0));
        // The second pass's box replaces the first's only if it scores higher and is as long.
        let longer = cand(8.0, 10.0, 95.0, 10.0, 0.8);
        let piece = cand(40.0, 10.0, 70.0, 10.0, 0.9);
        assert!(prefer_longer_second(&a, &longer, 10.0));
        assert!(!prefer_longer_second(&a, &piece, 10.0));
        assert!(!prefer_longer_second(&longer, &a, 10.0));

        // Trails at 60 degrees: the longer box replaces the first's, a streak along the
        // trails (which only the second pass can give) joins, the piece is the same streak.
        let p = Sanitized::new(&StreakParams::default());
        let along = cand(20.0, 100.0, 50.0, 100.0 + 30.0 * 3f64.sqrt(), 0.3);
        let found = union(vec![a], vec![piece, longer, along], 60.0, &p);
        assert_eq!(found, vec![longer, along]);
    }
}
