//! A line along the frame's own trails cut at its seams (issue #44): a debris streak a few
//! degrees off the trails meets a trail at one end, or both, and the pass follows the line on
//! along that trail (overlapping it, or end to end). The joined line is then unevenly lit and
//! dropped as two trails side by side, or boxed a trail's length too long. Where it joins, the
//! profile along the line steps to the trail's level (brighter or fainter); the piece beyond
//! the step, at most a trail long, is cut off, and what is left is judged on its own
//! (`lone_line`).
//!
//! Looked at on the development SatSim frames (`scripts/independent/satsim_frames.py` seeds 3
//! and 4, 11, and 12 with `--near 0.6`: 160 frames) with `soig detect FRAMES --psf-fwhm-px
//! 3.34` and a debugging print of each line's profile (not committed): the pieces joined to
//! debris were 0.9-1.4 trail lengths long (61 px of a 66 px trail; about 100 and 70 px of 103;
//! a 60 px bump 20 px from the end, 57 px trails) and 2.5-10 times the debris' level, or 0.3
//! of it. One joins at the debris' own level in the 8-bit map (7.5 against 7.4-9.2) and is
//! not cut. The constants were set from these figures, not swept; `soig detect` and
//! `scripts/independent/score.py` on the four sets: within 5 degrees 54/60 -> 57/60 with
//! this, the quieter-side gap test (`accept`) and the crossing (`lone_line`).

use super::lone_line::profile;
use super::output::{Candidate, confidence};
use super::params::Sanitized;

/// A piece cut off an end is at most this many trail lengths long (a trail overlapping the
/// debris reaches at most one trail length beyond it; the trails' length, a median, is off by
/// a tenth or two), and at least `MIN_PIECE` of one and `MIN_PIECE_PX` (a shorter piece's
/// level is noise).
const CUT_MAX: f64 = 1.25;
const MIN_PIECE: f64 = 0.25;
const MIN_PIECE_PX: usize = 12;
/// What is left is at least this many trail lengths long: a single trail cut out of two side
/// by side is no debris (its length is a trail's, within the median's error).
const KEEP_MIN: f64 = 1.3;
/// A cut is made where two levels fit the profile better than one by at least this, in the
/// squared residuals over `CORR_PX` (as `lone_line`'s `EVEN_GAIN`: the smoothed map's noise is
/// correlated over about 5 px), and the piece's level lies outside `LEVEL_LOW`-`LEVEL_HIGH`
/// of the rest's (`lone_line`'s evenness band: a debris streak's own pieces stay inside it).
const STEP_GAIN: f64 = 10.0;
const CORR_PX: f64 = 5.0;
const LEVEL_LOW: f64 = 0.75;
const LEVEL_HIGH: f64 = 1.3;

/// The line `c` with the trails of length `trail_px` joined to its ends cut off, on the
/// unit-noise map `z` (`w` x `h`), or None where no end steps to another level. The piece
/// keeps the line's axis and its box's margins around the ends; its SNR is the line's scaled by
/// the share of the light it keeps over the square root of the share of its length (a matched
/// filter's, the noise even along the line).
pub(super) fn cut(
    c: &Candidate,
    trail_px: f64,
    z: &[f32],
    (w, h): (usize, usize),
    p: &Sanitized,
) -> Option<Candidate> {
    let prof = profile(c, z, w, h);
    let n = prof.len();
    if n == 0 || trail_px <= 0.0 {
        return None;
    }
    // One cut at each end at most (a trail joins an end once).
    let (mut a, mut b) = (0usize, n);
    for _ in 0..2 {
        match end_step(&prof[a..b], trail_px, (a == 0, b == n)) {
            Some(End::Start(k)) => a += k,
            Some(End::Finish(k)) => b -= k,
            None => break,
        }
    }
    let kept = b - a;
    if kept == n || (kept as f64) < KEEP_MIN * trail_px {
        return None;
    }
    Some(piece(c, &prof, (a, b), (w * h) as f64, p))
}

/// Which end of a profile steps to another level, and how many samples beyond the step.
#[derive(Clone, Copy, Debug, PartialEq)]
enum End {
    Start(usize),
    Finish(usize),
}

/// The end piece of `prof` (at most `CUT_MAX` trails of `trail_px`, at least `MIN_PIECE` of
/// one and `MIN_PIECE_PX`) whose own level fits it best, where that beats one level by
/// `STEP_GAIN` and the piece's level lies outside the rest's evenness band; at the `start`
/// and `finish` ends where asked.
fn end_step(prof: &[f64], trail_px: f64, (start, finish): (bool, bool)) -> Option<End> {
    let n = prof.len();
    let lo = ((MIN_PIECE * trail_px).ceil() as usize).max(MIN_PIECE_PX);
    let hi = ((CUT_MAX * trail_px) as usize).min(n.saturating_sub(lo));
    if lo > hi {
        return None;
    }
    let (s, q) = prefix_sums(prof);
    let sse = |i: usize, j: usize| {
        let m = (j - i) as f64;
        q[j] - q[i] - (s[j] - s[i]).powi(2) / m
    };
    let mean = |i: usize, j: usize| (s[j] - s[i]) / (j - i) as f64;
    let one = sse(0, n);
    let mut best: Option<(f64, End)> = None;
    for k in lo..=hi {
        let ends = [
            (start, End::Start(k), (0, k), (k, n)),
            (finish, End::Finish(k), (n - k, n), (0, n - k)),
        ];
        for (_, end, (pa, pb), (ra, rb)) in ends.into_iter().filter(|e| e.0) {
            let gain = (one - sse(pa, pb) - sse(ra, rb)) / CORR_PX;
            let rest = mean(ra, rb);
            let ratio = mean(pa, pb) / rest;
            let stepped = rest > 0.0 && !(LEVEL_LOW..=LEVEL_HIGH).contains(&ratio);
            if gain >= STEP_GAIN && stepped && best.is_none_or(|b| gain > b.0) {
                best = Some((gain, end));
            }
        }
    }
    best.map(|b| b.1)
}

/// The interior run of `prof` that a trail crossing the line lights, where one does: at most
/// `CUT_MAX` trails of `trail_px` long, at least `MIN_PIECE` of one and `MIN_PIECE_PX`, and as
/// far from either end; brighter than `LEVEL_HIGH` times the rest, fitted better so than by one
/// level by `STEP_GAIN` (the best fitting such run).
pub(super) fn crossing(prof: &[f64], trail_px: f64) -> Option<(usize, usize)> {
    let n = prof.len();
    let lo = ((MIN_PIECE * trail_px).ceil() as usize).max(MIN_PIECE_PX);
    let hi = (CUT_MAX * trail_px) as usize;
    if n < 2 * lo + lo.max(1) || lo > hi {
        return None;
    }
    let (s, q) = prefix_sums(prof);
    let sum = |i: usize, j: usize| s[j] - s[i];
    let one = q[n] - s[n] * s[n] / n as f64;
    let mut best: Option<(f64, (usize, usize))> = None;
    for i in lo..n - 2 * lo {
        for j in (i + lo)..=(i + hi).min(n - lo) {
            let (m_in, m_out) = ((j - i) as f64, (n - j + i) as f64);
            let (s_in, s_out) = (sum(i, j), s[n] - sum(i, j));
            let (q_in, q_out) = (q[j] - q[i], q[n] - q[j] + q[i]);
            let two = q_in - s_in * s_in / m_in + q_out - s_out * s_out / m_out;
            let gain = (one - two) / CORR_PX;
            let rest = s_out / m_out;
            let bright = rest > 0.0 && s_in / m_in > LEVEL_HIGH * rest;
            if bright && gain >= STEP_GAIN && best.is_none_or(|b| gain > b.0) {
                best = Some((gain, (i, j)));
            }
        }
    }
    best.map(|b| b.1)
}

/// Prefix sums of `v` and of its squares (the squared residuals about the mean of any span in
/// constant time).
fn prefix_sums(v: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let (mut s, mut q) = (vec![0.0; v.len() + 1], vec![0.0; v.len() + 1]);
    for (i, x) in v.iter().enumerate() {
        s[i + 1] = s[i] + x;
        q[i + 1] = q[i] + x * x;
    }
    (s, q)
}

/// The samples `a..b` of the line `c` (profile `prof`) as a candidate of their own, scored
/// as the pass scores (`confidence`) in an image of `area` pixels.
fn piece(
    c: &Candidate,
    prof: &[f64],
    (a, b): (usize, usize),
    area: f64,
    p: &Sanitized,
) -> Candidate {
    let n = prof.len() as f64;
    let [[x0, y0], [x1, y1]] = c.ends;
    let len = (x1 - x0).hypot(y1 - y0).max(1.0);
    let (ux, uy) = ((x1 - x0) / len, (y1 - y0) / len);
    // Sample i lies i + 0.5 px from the first end; the piece spans its samples' pixels.
    let at = |t: f64| [x0 + t * ux, y0 + t * uy];
    let ends = [at(a as f64), at(b as f64)];
    // The box keeps its margins beyond the ends, per axis.
    let d = &c.detection;
    let pad_x = 0.5 * ((d.x2 - d.x1) - (x1 - x0).abs()).max(0.0);
    let pad_y = 0.5 * ((d.y2 - d.y1) - (y1 - y0).abs()).max(0.0);
    let mut out = *c;
    out.detection.x1 = (ends[0][0].min(ends[1][0]) - pad_x).max(d.x1);
    out.detection.x2 = (ends[0][0].max(ends[1][0]) + pad_x).min(d.x2);
    out.detection.y1 = (ends[0][1].min(ends[1][1]) - pad_y).max(d.y1);
    out.detection.y2 = (ends[0][1].max(ends[1][1]) + pad_y).min(d.y2);
    out.ends = ends;
    let share = (b - a) as f64 / n;
    out.length_px = c.length_px * share;
    out.elongation = c.elongation * share;
    let total: f64 = prof.iter().sum();
    let light = if total > 0.0 {
        (prof[a..b].iter().sum::<f64>() / total).max(0.0)
    } else {
        share
    };
    out.flux = c.flux * light;
    out.snr = c.snr * light / share.sqrt();
    out.detection.score = confidence(out.snr, out.elongation, area, p);
    out
}

#[cfg(test)]
mod tests {
    use super::super::lone_line::tests::{flat, line, map};
    use super::super::params::StreakParams;
    use super::*;

    fn cut_of(c: &Candidate, z: &[f32]) -> Option<Candidate> {
        cut(
            c,
            80.0,
            z,
            (500, 40),
            &Sanitized::new(&StreakParams::default()),
        )
    }

    /// Where the line's piece begins and ends along x.
    fn span(c: &Candidate) -> (f64, f64) {
        let x = [c.ends[0][0], c.ends[1][0]];
        (x[0].min(x[1]), x[0].max(x[1]))
    }

    #[test]
    fn a_trail_joined_to_an_end_is_cut_off() {
        // Debris of 250 px (level 2) and a trail of 80 px beyond it, brighter or fainter.
        for level in [6.0, 0.6] {
            let z = map(
                500,
                40,
                &[flat(50, 300, 20.0, 2.0), flat(300, 380, 20.0, level)],
            );
            let c = cut_of(&line(50.0, 380.0, 20.0), &z).expect("cut");
            let (a, b) = span(&c);
            assert!(
                (a - 50.0).abs() <= 1.0 && (b - 300.0).abs() <= 3.0,
                "{level}: {a} {b}"
            );
            assert!((c.length_px - 250.0).abs() <= 3.0, "{}", c.length_px);
            // The box shrinks with it.
            assert!(c.detection.x2 <= 300.0 + 4.0, "{:?}", c.detection);
        }
        // A trail at each end: both cut.
        let z = map(
            500,
            40,
            &[
                flat(20, 90, 20.0, 5.0),
                flat(90, 350, 20.0, 2.0),
                flat(350, 420, 20.0, 4.0),
            ],
        );
        let (a, b) = span(&cut_of(&line(20.0, 420.0, 20.0), &z).expect("cut"));
        assert!(
            (a - 90.0).abs() <= 3.0 && (b - 350.0).abs() <= 3.0,
            "{a} {b}"
        );
    }

    #[test]
    fn an_even_line_or_a_trail_and_a_trail_are_not_cut() {
        // Evenly lit: no step.
        let z = map(500, 40, &[flat(50, 380, 20.0, 2.0)]);
        assert!(cut_of(&line(50.0, 380.0, 20.0), &z).is_none());
        // A step of less than the evenness band (1.2 times) is none.
        let z = map(
            500,
            40,
            &[flat(50, 300, 20.0, 2.0), flat(300, 380, 20.0, 2.4)],
        );
        assert!(cut_of(&line(50.0, 380.0, 20.0), &z).is_none());
        // Two trails end to end: what a cut leaves is a trail (under `KEEP_MIN` of one).
        let z = map(
            500,
            40,
            &[flat(50, 130, 20.0, 5.0), flat(130, 210, 20.0, 2.0)],
        );
        assert!(cut_of(&line(50.0, 210.0, 20.0), &z).is_none());
        // Of a brighter piece longer than `CUT_MAX` trails, at most that is cut.
        let z = map(
            500,
            40,
            &[flat(50, 250, 20.0, 2.0), flat(250, 380, 20.0, 6.0)],
        );
        let c = cut_of(&line(50.0, 380.0, 20.0), &z);
        assert!(
            c.is_none_or(|c| span(&c).1 >= 380.0 - CUT_MAX * 80.0 - 1.0),
            "{c:?}"
        );
    }

    #[test]
    fn a_crossing_is_a_bright_run_inside_the_line() {
        let mut prof = vec![2.0; 400];
        prof[200..260].iter_mut().for_each(|v| *v = 6.0);
        let (i, j) = crossing(&prof, 80.0).expect("crossing");
        assert!(i.abs_diff(200) <= 1 && j.abs_diff(260) <= 1, "{i} {j}");
        // Not at an end (a joined trail, `cut`), nor longer than a trail, nor faint.
        let mut end = vec![2.0; 400];
        end[390..].iter_mut().for_each(|v| *v = 6.0);
        assert_eq!(crossing(&end, 80.0), None);
        let mut long = vec![2.0; 400];
        long[100..300].iter_mut().for_each(|v| *v = 6.0);
        assert!(crossing(&long, 80.0).is_none_or(|(i, j)| j - i <= 100));
        let mut faint = vec![2.0; 400];
        faint[200..260].iter_mut().for_each(|v| *v = 2.4);
        assert_eq!(crossing(&faint, 80.0), None);
    }
}
