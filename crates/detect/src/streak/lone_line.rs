//! A line along the frame's own trails that no trail explains (issue #44): within a degree of
//! the trails the direction cannot tell debris from a star, but its length and profile can.
//! Every trail of a frame has one length (the stars drift alike); a line much longer than
//! that, lit evenly from end to end and inside the frame, is no star's trail. Two trails
//! laterally close and end to end (or overlapping) make a long line too, but it shows their
//! seams: a step where one trail's light ends (another brightness), a gap, or a bump where
//! they overlap; the profile is then fitted as well by two trails of the measured length
//! from the line's ends as by one even line.
//!
//! A few degrees off the trails, two trails side by side (laterally close, one ahead of the
//! other) make a short line whose light leaves its axis where each trail slants away from it:
//! uneven, or fitted as well by two trails from its ends (`Seams::pair`).
//!
//! Measured on development SatSim frames (scripts/independent/satsim_frames.py: seed 12, 40
//! frames, `--near 0.6`; seed 11, 40 frames; and seed 2's 40, looked at before), with the
//! seams of every line the second pass found printed (a debugging print, not committed) and
//! sorted by whether it lay on the truth's streak: the ranges quoted at each constant. The
//! thresholds sit between the two groups, some with little room (`EVEN_GAIN`, `PAIR_HIGH`).

use super::output::Candidate;
use super::seam_cut::crossing;
use super::stats::median_of;
use soig_image::imaging::bilinear;

/// A lone line is at least this many trail lengths long (debris found at 1.74; two trails end
/// to end with a seam too faint to see reach 2).
const LONGER: f64 = 1.6;
/// Down to this many trail lengths a line within the trails' tolerance of their direction is
/// still looked at (`Seams::short_lone`), where its light runs along its own direction
/// (`slant::own_way`): on SatSim seeds 7 and 8 two debris streaks 1.25-2.1 degrees off the
/// trails were 1.30 and 1.37 trail lengths long, evenly lit (pieces 0.97-1.01), one-line gain
/// 130 and 174; of the 28 other lines of 1.1-1.6 trail lengths along the trails (not
/// `like_others`), the evenly lit ones had gains of -22 to 27 (and the 27 a slant of 1.08 and
/// 1.02).
const SHORT_LONGER: f64 = 1.2;
/// Pieces of half a trail's length each lie within these fractions of the line's median level
/// (debris along the trails: 0.85-1.17 inside the frame; chains of trails with a one-line gain
/// of `EVEN_GAIN` or more: 0.79-1.17, at the frame's edge or shorter than `LONGER`, and one at
/// 0.98-1.07, two overlapping trails whose seam the 8-bit stretch flattened).
const PIECE_LOW: f64 = 0.75;
const PIECE_HIGH: f64 = 1.25;
/// One even line fits the profile better than two trails from its ends by at least this:
/// the difference of the squared residuals over `CORR_PX` (the smoothed map's noise is
/// correlated over about 2 sqrt(pi) psf_sigma, 5 px; unit noise, so a chi-square-like figure).
/// Debris: 11.2 and more (the least, 1.95 trail lengths long: debris of two trail lengths is
/// two trails end to end); evenly lit chains inside the frame: 7.3 at most.
const EVEN_GAIN: f64 = 10.0;
const CORR_PX: f64 = 5.0;
/// A line reaching within this many pixels of the frame's edge may be a trail cut by it (its
/// ends are not its own), unless it is this many trail lengths long (two trails make at most
/// two; none of the chains of three or more was lit evenly).
const EDGE_PX: f64 = 4.0;
const LONG_AT_EDGE: f64 = 3.0;
/// Two trails side by side make a line of at most about two trail lengths (`PAIR_LONGEST`), a
/// few degrees off them (`NEAR_DEG`: the first pass drops lines within 5 degrees and a short
/// line's orientation uncertainty), unevenly lit: a piece above `PAIR_HIGH` of its level or
/// below `PIECE_LOW` (pairs 1.32-14 / 0.80 and below; debris 1.02-1.25 / 0.77 and above).
pub(super) const PAIR_LONGEST: f64 = 2.5;
pub(super) const NEAR_DEG: f64 = 8.0;
const PAIR_HIGH: f64 = 1.3;
/// The fewest lines along the trails whose median length is the trails' length.
const MIN_LINES: usize = 3;
/// A line with this many others along the trails of its own length (within `ALIKE_LOW` to
/// `ALIKE_HIGH` of it) is a star's trail like them, however long against the trails' median:
/// in soig's survey frames the trails drift 400-1000 px, most are cut by the frame's edge or
/// broken, and the median of the lines along them (308 px in one frame whose whole trails were
/// 670-720) made whole trails "lone" (`python3 scripts/catalog-robustness.py --images 40
/// --seed 7001`, no catalogue: 24 false boxes, 2 before the lone rule). On the development
/// SatSim frames (seeds 3-6, 11, 12) no debris line kept as lone had more than one other line
/// within 0.85-1.2 of its length.
const MIN_ALIKE: usize = 2;
const ALIKE_LOW: f64 = 0.85;
const ALIKE_HIGH: f64 = 1.2;

/// Whether `MIN_ALIKE` lines of `along` other than `c` (by its ends) are about as long as it.
pub(super) fn like_others(c: &Candidate, along: &[&Candidate]) -> bool {
    along
        .iter()
        .filter(|o| o.ends != c.ends)
        .filter(|o| (ALIKE_LOW..=ALIKE_HIGH).contains(&(o.length_px / c.length_px.max(1.0))))
        .count()
        >= MIN_ALIKE
}

/// The trails' length: the median length of the lines `along` them (most are single trails),
/// where at least `MIN_LINES`.
pub(super) fn trail_length(along: &[&Candidate]) -> Option<f64> {
    if along.len() < MIN_LINES {
        return None;
    }
    Some(median_of(
        &along.iter().map(|c| c.length_px).collect::<Vec<f64>>(),
    ))
}

/// What a line's profile says of the trails of length `trail_px` that might make it: its
/// length in trail lengths, its level (median, unit noise), its pieces of half a trail's length
/// (the lowest and highest median over the level), and how much better one even line fits it
/// than two trails from its ends (`one_line_gain`).
#[derive(Clone, Copy, Debug)]
pub(super) struct Seams {
    pub ratio: f64,
    pub level: f64,
    pub low: f64,
    pub high: f64,
    pub gain: f64,
    pub inside: bool,
    /// `low` and `high` without the light of a trail crossing the line, where the line is
    /// longer than `PAIR_LONGEST` (no two trails side by side make it) and one crosses it
    /// (`seam_cut::crossing`); else `low` and `high`.
    pub crossed: (f64, f64),
}

impl Seams {
    /// The seams of the line `c` on the unit-noise map `z` (`w` x `h`).
    pub(super) fn of(c: &Candidate, trail_px: f64, z: &[f32], w: usize, h: usize) -> Seams {
        let inside = c.ends.iter().all(|e| {
            e[0] >= EDGE_PX
                && e[1] >= EDGE_PX
                && e[0] <= w as f64 - EDGE_PX
                && e[1] <= h as f64 - EDGE_PX
        });
        let prof = profile(c, z, w, h);
        let level = median_of(&prof);
        let (low, high) = pieces(&prof, trail_px, level);
        let ratio = c.length_px / trail_px;
        let crossed = match crossing(&prof, trail_px) {
            Some((i, j)) if ratio > PAIR_LONGEST => {
                // With its shoulders, where its light leaves the axis (half as long again).
                let pad = (j - i) / 4;
                let (i, j) = (i.saturating_sub(pad), (j + pad).min(prof.len()));
                let rest: Vec<f64> = prof[..i].iter().chain(&prof[j..]).copied().collect();
                pieces(&rest, trail_px, median_of(&rest))
            }
            _ => (low, high),
        };
        Seams {
            ratio,
            level,
            low,
            high,
            gain: one_line_gain(&prof, trail_px),
            inside,
            crossed,
        }
    }

    /// Evenly lit: every piece within `PIECE_LOW`-`high` of the level.
    fn even(&self, high: f64) -> bool {
        self.level > 0.0 && self.low >= PIECE_LOW && self.high <= high
    }

    /// Evenly lit but where a trail crosses it (`crossed`).
    fn even_crossed(&self, high: f64) -> bool {
        self.level > 0.0 && self.crossed.0 >= PIECE_LOW && self.crossed.1 <= high
    }

    /// A line along the trails that is no star's: `LONGER` trail lengths or more, inside the
    /// frame (or `LONG_AT_EDGE` lengths), evenly lit, and fitted better by one even line than
    /// by two trails from its ends.
    pub(super) fn lone(&self) -> bool {
        self.ratio >= LONGER
            && (self.inside || self.ratio >= LONG_AT_EDGE)
            && self.even(PIECE_HIGH)
            && self.gain >= EVEN_GAIN
    }

    /// A line along the trails but shorter than `LONGER` trail lengths that may still be no
    /// star's: `SHORT_LONGER` lengths or more, inside the frame, evenly lit and fitted better
    /// by one even line than by two trails from its ends (`lone` but for its length); whether
    /// its light runs along its own direction is `slant::own_way`'s to say.
    pub(super) fn short_lone(&self) -> bool {
        (SHORT_LONGER..LONGER).contains(&self.ratio)
            && self.inside
            && self.even(PIECE_HIGH)
            && self.gain >= EVEN_GAIN
    }

    /// A line a few degrees off the trails that two of them side by side make: unevenly lit
    /// (each trail crosses the line's axis at a slant, so its light leaves the axis towards
    /// its ends; but for one trail crossing a line too long to be two), or, longer than a trail but not than `PAIR_LONGEST`, fitted as well by two
    /// trails from its ends.
    pub(super) fn pair(&self) -> bool {
        !self.even_crossed(PAIR_HIGH)
            || (self.ratio > 1.0 && self.ratio <= PAIR_LONGEST && self.gain < EVEN_GAIN)
    }
}

/// The mean of `z` at -1, 0 and 1 px across the line `c`, every pixel along it from end to end
/// (the ends are in pixel-edge coordinates, `z`'s pixel centres at integers).
pub(super) fn profile(c: &Candidate, z: &[f32], w: usize, h: usize) -> Vec<f64> {
    let [a, b] = c.ends;
    profile_at(a, b, 0.0, 0.0, z, w, h)
}

/// The profile from `a` to `b` (pixel-edge coordinates) along a run shifted `offset` px across
/// it and turned by `slope` (lateral px per px along) about its midpoint: the mean of `z` at
/// -1, 0 and 1 px across the run, every pixel along it.
pub(super) fn profile_at(
    a: [f64; 2],
    b: [f64; 2],
    offset: f64,
    slope: f64,
    z: &[f32],
    w: usize,
    h: usize,
) -> Vec<f64> {
    let (x0, y0, x1, y1) = (a[0] - 0.5, a[1] - 0.5, b[0] - 0.5, b[1] - 0.5);
    let len = (x1 - x0).hypot(y1 - y0).max(1.0);
    let (ux, uy) = ((x1 - x0) / len, (y1 - y0) / len);
    (0..len as usize)
        .map(|i| {
            let t = i as f64 + 0.5;
            let o = offset + slope * (t - 0.5 * len);
            let (x, y) = (x0 + t * ux - o * uy, y0 + t * uy + o * ux);
            [-1.0, 0.0, 1.0]
                .iter()
                .map(|o| bilinear(z, w, h, x - o * uy, y + o * ux) as f64)
                .filter(|v| v.is_finite())
                .sum::<f64>()
                / 3.0
        })
        .collect()
}

/// The lowest and highest median of the pieces of half a trail's length of `prof`, over
/// `level` (NaN where the level is not positive).
fn pieces(prof: &[f64], trail_px: f64, level: f64) -> (f64, f64) {
    if level.is_nan() || level <= 0.0 || prof.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let k = ((prof.len() as f64 / (0.5 * trail_px)).round() as usize).clamp(2, prof.len());
    (0..k)
        .map(|i| median_of(&prof[i * prof.len() / k..(i + 1) * prof.len() / k]) / level)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), m| {
            (lo.min(m), hi.max(m))
        })
}

/// How much better one even line fits `prof` than two trails of `trail_px`, one from each end,
/// each of its own brightness (least squares): the difference of the squared residuals over
/// `CORR_PX`.
fn one_line_gain(prof: &[f64], trail_px: f64) -> f64 {
    let n = prof.len();
    if n == 0 {
        return 0.0;
    }
    let mean = prof.iter().sum::<f64>() / n as f64;
    let sse_one: f64 = prof.iter().map(|v| (v - mean).powi(2)).sum();
    // Sample i lies at t = i + 0.5; trail a covers t < trail_px, trail b t > n - trail_px.
    let (a, b): (Vec<bool>, Vec<bool>) = (0..n)
        .map(|i| {
            let t = i as f64 + 0.5;
            (t < trail_px, t > n as f64 - trail_px)
        })
        .unzip();
    // Normal equations of v = alpha a + beta b.
    let (mut saa, mut sbb, mut sab, mut sav, mut sbv) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for i in 0..n {
        let (fa, fb, v) = (a[i] as u8 as f64, b[i] as u8 as f64, prof[i]);
        saa += fa;
        sbb += fb;
        sab += fa * fb;
        sav += fa * v;
        sbv += fb * v;
    }
    let det = saa * sbb - sab * sab;
    let (alpha, beta) = if det.abs() > 1e-9 {
        ((sav * sbb - sbv * sab) / det, (sbv * saa - sav * sab) / det)
    } else {
        // The two trails coincide: one trail over the whole line.
        let s = (sav + sbv) / (saa + sbb).max(1.0);
        (s, 0.0)
    };
    let sse_two: f64 = (0..n)
        .map(|i| {
            let m = alpha * a[i] as u8 as f64 + beta * b[i] as u8 as f64;
            (prof[i] - m).powi(2)
        })
        .sum();
    (sse_two - sse_one) / CORR_PX
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// A segment from (x0, y0) to (x1, y1), x0 < x1, and its level.
    pub(in crate::streak) type Drawn = ((usize, f64), (usize, f64), f32);

    /// A noise-free map of `w` x `h` with the given segments, 3 px wide (levels add where two
    /// overlap).
    pub(in crate::streak) fn map(w: usize, h: usize, segs: &[Drawn]) -> Vec<f32> {
        let mut z = vec![0f32; w * h];
        for &((x0, y0), (x1, y1), level) in segs {
            for x in x0..x1 {
                let y = (y0 + (y1 - y0) * (x - x0) as f64 / (x1 - x0) as f64).round() as usize;
                for y in y - 1..=y + 1 {
                    z[y * w + x] += level;
                }
            }
        }
        z
    }

    /// A horizontal segment on row `row`, x from `a` to `b`.
    pub(in crate::streak) fn flat(a: usize, b: usize, row: f64, level: f32) -> Drawn {
        ((a, row), (b, row), level)
    }

    /// The seams of the line along row 20 from `x0` to `x1`, beside trails `trail_px` long, on
    /// a 400 x 40 map of `drawn`.
    fn seams(drawn: &[Drawn], (x0, x1): (f64, f64), trail_px: f64) -> Seams {
        Seams::of(&line(x0, x1, 20.0), trail_px, &map(400, 40, drawn), 400, 40)
    }

    pub(in crate::streak) fn line(x0: f64, x1: f64, row: f64) -> Candidate {
        Candidate {
            detection: crate::Detection {
                x1: x0,
                y1: row - 3.0,
                x2: x1,
                y2: row + 3.0,
                score: 0.9,
                class: 0,
            },
            ends: [[x0, row + 0.5], [x1, row + 0.5]],
            length_px: x1 - x0,
            orientation_deg: 0.0,
            elongation: 10.0,
            flux: 0.0,
            snr: 20.0,
        }
    }

    #[test]
    fn an_even_line_three_trails_long_is_lone() {
        let even = [flat(50, 350, 20.0, 4.0)];
        assert!(seams(&even, (50.0, 350.0), 100.0).lone());
        // Not when trails are as long as it (another length is the test).
        assert!(!seams(&even, (50.0, 350.0), 200.0).lone());
        // Nor when it reaches the frame's edge (a trail cut by it), unless three trails long.
        assert!(!seams(&[flat(0, 250, 20.0, 4.0)], (0.0, 250.0), 100.0).lone());
        assert!(seams(&[flat(0, 300, 20.0, 4.0)], (0.0, 300.0), 100.0).lone());
    }

    #[test]
    fn two_trails_end_to_end_are_not_lone() {
        // Of unequal brightness (a step at the seam).
        let step = [flat(50, 150, 20.0, 6.0), flat(150, 250, 20.0, 3.0)];
        assert!(!seams(&step, (50.0, 250.0), 100.0).lone());
        // Overlapping by a third of their length (a bump where they overlap).
        let bump = [flat(50, 150, 20.0, 4.0), flat(117, 217, 20.0, 4.0)];
        assert!(!seams(&bump, (50.0, 217.0), 100.0).lone());
        // With a gap between them.
        let gap = [flat(50, 150, 20.0, 4.0), flat(170, 270, 20.0, 4.0)];
        assert!(!seams(&gap, (50.0, 270.0), 100.0).lone());
        // An even line of the same extent is lone.
        assert!(seams(&[flat(50, 217, 20.0, 4.0)], (50.0, 217.0), 100.0).lone());
    }

    #[test]
    fn two_slanted_trails_side_by_side_are_a_pair() {
        // Trails of 100 px at 4 degrees to the line through both (slope 0.07, 7 px across
        // over their length): each crosses the line's axis and leaves it.
        let slanted = [
            ((50, 16.5), (150, 23.5), 4.0),
            ((120, 16.5), (220, 23.5), 4.0),
        ];
        assert!(seams(&slanted, (50.0, 220.0), 100.0).pair());
        // Debris as long, evenly lit along it, is none.
        assert!(!seams(&[flat(50, 220, 20.0, 6.0)], (50.0, 220.0), 100.0).pair());
        // Nor when shorter than a trail (the two trails' fit is then one even line).
        assert!(!seams(&[flat(50, 130, 20.0, 6.0)], (50.0, 130.0), 100.0).pair());
    }

    #[test]
    fn a_trail_crossing_a_long_line_leaves_it_no_pair() {
        // Debris of four trail lengths, 3 px wide, crossed by a trail of 100 px at 4 degrees
        // (a bump of its light on the axis): evenly lit but for it, so no pair.
        let crossed = |a: usize, b: usize| {
            map(
                600,
                40,
                &[flat(a, b, 20.0, 4.0), ((250, 16.5), (350, 23.5), 8.0)],
            )
        };
        let z = crossed(50, 450);
        let s = Seams::of(&line(50.0, 450.0, 20.0), 100.0, &z, 600, 40);
        assert!(s.high > PAIR_HIGH && s.crossed.1 <= PAIR_HIGH, "{s:?}");
        assert!(!s.pair(), "{s:?}");
        // Two trail lengths long, it may be two trails side by side: the bump still counts.
        let z = crossed(200, 400);
        assert!(Seams::of(&line(200.0, 400.0, 20.0), 100.0, &z, 600, 40).pair());
    }

    #[test]
    fn a_line_as_long_as_two_others_is_a_trail_like_them() {
        let (a, b, c, d) = (
            line(0.0, 700.0, 5.0),
            line(0.0, 680.0, 15.0),
            line(0.0, 720.0, 25.0),
            line(0.0, 300.0, 35.0),
        );
        assert!(like_others(&a, &[&a, &b, &c, &d]));
        // One other of its length is not enough (a chain of trails beside debris).
        assert!(!like_others(&a, &[&a, &b, &d]));
        // Nor others much shorter or longer.
        let e = line(0.0, 900.0, 45.0);
        assert!(!like_others(&a, &[&a, &d, &e]));
    }

    #[test]
    fn the_trails_length_is_the_median_of_the_lines_along_them() {
        let (a, b, c) = (
            line(0.0, 80.0, 5.0),
            line(0.0, 100.0, 5.0),
            line(0.0, 400.0, 5.0),
        );
        assert_eq!(trail_length(&[&a, &b, &c]), Some(100.0));
        assert_eq!(trail_length(&[&a, &c]), None);
    }
}
