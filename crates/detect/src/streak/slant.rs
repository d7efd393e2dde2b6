//! Which way a line's light runs, half by half (issue #44). Two star trails side by side, one
//! ahead of the other, make a line a few degrees off the trails: the chord from one trail to
//! the other. Each half of it holds (mostly) one trail, whose light runs along the trails'
//! direction and so crosses the chord's axis at a slant. A debris streak's light runs along
//! its own axis from end to end. So each half is fitted by a straight run of its length along
//! the line's direction and by one along the trails', each at its best lateral offset: the
//! light the trails' direction gathers over the line's is the half's slant.
//!
//! Measured on the development SatSim frames (`scripts/independent/satsim_frames.py` seeds 3,
//! 4, 5, 6, 11 and 12: 240 frames; `soig detect FRAMES --psf-fwhm-px 3.34` with a debugging
//! print of each line the passes along the own trails box, not committed, sorted by whether it
//! lay on the truth's streak): of the 233 debris lines, at any angle, none has both halves at
//! 1 or more (the most, 0.99 and 0.99, 0.44 degrees off the trails, where both directions are
//! nearly one; one half of a streak crossing a trail reached 1.12); the five pairs of trails
//! side by side boxed, 2.1-9.4 degrees off and 1.2-2 trail lengths long, have 1.045-1.31 in
//! both halves.

use super::lone_line::{PAIR_LONGEST, Seams, profile_at};
use super::output::Candidate;

/// Both halves of a pair of trails side by side gather at least this share more light along
/// the trails' direction than along the line's (pairs 1.045 and more; debris 0.99 at most,
/// where the line lies along the trails and both runs are one).
const SLANT_MIN: f64 = 1.02;

/// Whether the line `c` (its seams `s`, in trails of the frame's length) is two trails side by
/// side: at most `PAIR_LONGEST` trail lengths long and both halves' light runs along the
/// trails' direction `trail_deg` (`halves`) rather than along its own.
pub(super) fn side_by_side(
    c: &Candidate,
    s: &Seams,
    trail_deg: f64,
    z: &[f32],
    (w, h): (usize, usize),
) -> bool {
    s.ratio <= PAIR_LONGEST
        && halves(c, trail_deg, z, w, h)
            .iter()
            .all(|r| r.is_some_and(|r| r >= SLANT_MIN))
}

/// Both halves of a debris streak a degree or more off the trails gather at most this share of
/// their light along the trails' direction (SatSim seeds 7 and 8: 0.93 and 0.93, 0.98 and
/// 0.97, 1.25-2.1 degrees off at 164-178 px); a star's own trail, whose direction lies within
/// the frame's spread (0.1-0.4 degrees) of the trails', gathers as much either way (1 within
/// a percent: its lateral drift over a half is a few tenths of a pixel).
const OWN_WAY_MAX: f64 = 0.985;

/// Whether the light of both halves of `c` runs along its own direction rather than the
/// trails' `trail_deg` (`halves` below `OWN_WAY_MAX`).
pub(super) fn own_way(c: &Candidate, trail_deg: f64, z: &[f32], (w, h): (usize, usize)) -> bool {
    halves(c, trail_deg, z, w, h)
        .iter()
        .all(|r| r.is_some_and(|r| r < OWN_WAY_MAX))
}

/// The lateral offsets tried for each direction, pixels either side of the axis, in steps of
/// `STEP_PX` (a trail's centre lies within a few pixels of the chord of a pair).
const REACH_PX: f64 = 4.0;
const STEP_PX: f64 = 0.5;

/// Each half's light along the trails' direction `trail_deg` over its light along the line's
/// own, at their best lateral offsets (1 where it runs along the trails as well as along the
/// line; above 1 where the trails' direction holds more of it), on the unit-noise map `z`
/// (`w` x `h`). None for a half with no light (its best sum not positive).
pub(super) fn halves(
    c: &Candidate,
    trail_deg: f64,
    z: &[f32],
    w: usize,
    h: usize,
) -> [Option<f64>; 2] {
    let [[x0, y0], [x1, y1]] = c.ends;
    let line_deg = (y1 - y0).atan2(x1 - x0).to_degrees();
    // The trails' direction against the line's, signed, in (-90, 90].
    let d = (trail_deg - line_deg + 90.0).rem_euclid(180.0) - 90.0;
    let slope = d.to_radians().tan();
    let mid = [0.5 * (x0 + x1), 0.5 * (y0 + y1)];
    let half = |a: [f64; 2], b: [f64; 2]| -> Option<f64> {
        let best = |k: f64| {
            let steps = (REACH_PX / STEP_PX) as i32;
            (-steps..=steps)
                .map(|i| {
                    let p = profile_at(a, b, i as f64 * STEP_PX, k, z, w, h);
                    p.iter().sum::<f64>()
                })
                .fold(f64::NEG_INFINITY, f64::max)
        };
        let along_line = best(0.0);
        (along_line > 0.0).then(|| best(slope) / along_line)
    };
    [half([x0, y0], mid), half(mid, [x1, y1])]
}

#[cfg(test)]
mod tests {
    use super::super::lone_line::tests::{flat, line, map};
    use super::*;

    /// Trails of 100 px at 4 degrees (slope 0.07), side by side, and the horizontal line
    /// through both; the trails' direction in degrees.
    fn pair_map() -> (Vec<f32>, f64) {
        let z = map(
            400,
            40,
            &[
                ((50, 16.5), (150, 23.5), 4.0),
                ((120, 16.5), (220, 23.5), 4.0),
            ],
        );
        (z, 0.07f64.atan().to_degrees())
    }

    fn judged(c: &Candidate, z: &[f32], trail_deg: f64) -> bool {
        let s = Seams::of(c, 100.0, z, 400, 40);
        side_by_side(c, &s, trail_deg, z, (400, 40))
    }

    #[test]
    fn two_trails_side_by_side_run_along_the_trails_in_each_half() {
        let (z, trail_deg) = pair_map();
        let c = line(50.0, 220.0, 20.0);
        let [a, b] = halves(&c, trail_deg, &z, 400, 40);
        assert!(
            a.unwrap() >= SLANT_MIN && b.unwrap() >= SLANT_MIN,
            "{a:?} {b:?}"
        );
        assert!(judged(&c, &z, trail_deg));
        // Told that the trails run along the line, the two directions are one: no pair.
        assert!(!judged(&c, &z, 0.0));
    }

    #[test]
    fn debris_runs_along_its_own_axis() {
        let (_, trail_deg) = pair_map();
        // Evenly lit, as long as the pair, 4 degrees off the trails.
        let z = map(400, 40, &[flat(50, 220, 20.0, 4.0)]);
        let c = line(50.0, 220.0, 20.0);
        let [a, b] = halves(&c, trail_deg, &z, 400, 40);
        assert!(a.unwrap() < 1.0 && b.unwrap() < 1.0, "{a:?} {b:?}");
        assert!(!judged(&c, &z, trail_deg));
        // A half with no light has no slant, and is no trail's.
        let dark = vec![0f32; 400 * 40];
        assert_eq!(halves(&c, trail_deg, &dark, 400, 40), [None, None]);
        assert!(!judged(&c, &dark, trail_deg));
    }

    #[test]
    fn a_short_line_off_the_trails_runs_its_own_way() {
        // Evenly lit, 1.3 trails of 100 px long: 2 degrees off the trails, its light runs
        // along its own direction in each half; along them, both directions are one.
        let z = map(400, 40, &[flat(50, 180, 20.0, 4.0)]);
        let c = line(50.0, 180.0, 20.0);
        let s = Seams::of(&c, 100.0, &z, 400, 40);
        assert!(s.short_lone() && !s.lone(), "{s:?}");
        assert!(own_way(&c, 2.0, &z, (400, 40)));
        assert!(!own_way(&c, 0.0, &z, (400, 40)));
        // A trail's length (1.1 of the median) is not looked at.
        let c = line(50.0, 160.0, 20.0);
        assert!(!Seams::of(&c, 100.0, &z, 400, 40).short_lone());
    }

    #[test]
    fn a_line_longer_than_two_trails_is_no_pair() {
        // Three trails of 100 px at 4 degrees in a row: the chord is 2.7 trail lengths, beyond
        // `PAIR_LONGEST`, though every half's light runs along the trails.
        let (_, trail_deg) = pair_map();
        let z = map(
            400,
            40,
            &[
                ((50, 16.5), (150, 23.5), 4.0),
                ((135, 16.5), (235, 23.5), 4.0),
                ((220, 16.5), (320, 23.5), 4.0),
            ],
        );
        let c = line(50.0, 320.0, 20.0);
        assert!(Seams::of(&c, 100.0, &z, 400, 40).ratio > PAIR_LONGEST);
        assert!(!judged(&c, &z, trail_deg));
    }
}
