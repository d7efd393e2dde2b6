//! The distance from a point to a trail's path, pruned to the parts of the path near it.

use super::segment::point_segment_distance;

/// Distance from `q` to the polyline through `nodes`.
fn distance_to_path(q: (f64, f64), nodes: &[(f64, f64)]) -> f64 {
    if nodes.len() == 1 {
        return (q.0 - nodes[0].0).hypot(q.1 - nodes[0].1);
    }
    nodes
        .windows(2)
        .map(|p| point_segment_distance(q, p[0], p[1]))
        .fold(f64::INFINITY, f64::min)
}

/// Segments of a path in one run of `Runs`.
const RUN: usize = 8;

/// A trail's path cut into runs of `RUN` segments, each with its bounding box, so that the
/// distance from a point to a path of ~100 nodes visits only the runs that come near it (the
/// search over every segment was a third of the survey detector's time).
pub(super) struct Runs {
    boxes: Vec<[f64; 4]>,
    corridor: Option<Corridor>,
}

/// The band about a path's chord (its first node to its last) that holds the whole path: the
/// chord's start and unit direction, and the farthest any node lies from its line (every
/// point of a segment lies no farther than its ends). A point farther from the line than that
/// plus a distance is farther from the path than the distance: a test of a few flops, where a
/// diagonal trail's bounding box holds most of the points it is asked of, each then put to
/// every run's box (a survey frame's star test spent most of its time so).
struct Corridor {
    start: (f64, f64),
    dir: (f64, f64),
    half_width: f64,
}

impl Corridor {
    fn of(nodes: &[(f64, f64)]) -> Option<Corridor> {
        let (a, b) = (*nodes.first()?, *nodes.last()?);
        let len = (b.0 - a.0).hypot(b.1 - a.1);
        if !(len > 0.0 && len.is_finite()) {
            return None;
        }
        let dir = ((b.0 - a.0) / len, (b.1 - a.1) / len);
        let off = |q: (f64, f64)| ((q.0 - a.0) * dir.1 - (q.1 - a.1) * dir.0).abs();
        let half_width = nodes.iter().map(|&q| off(q)).fold(0.0, f64::max);
        half_width.is_finite().then_some(Corridor {
            start: a,
            dir,
            half_width,
        })
    }

    /// Whether `q` lies more than `reach` beyond the band (by more than `MARGIN_PX`).
    fn beyond(&self, q: (f64, f64), reach: f64) -> bool {
        let (a, u) = (self.start, self.dir);
        let off = ((q.0 - a.0) * u.1 - (q.1 - a.1) * u.0).abs();
        off > self.half_width + reach + MARGIN_PX
    }
}

/// What a pruning test leaves beyond a reach: a pixel covers the rounding of a segment
/// distance, and of a distance from the chord, many times over.
const MARGIN_PX: f64 = 1.0;

impl Runs {
    pub(super) fn of(nodes: &[(f64, f64)]) -> Runs {
        let boxes = (0..nodes.len().saturating_sub(1))
            .step_by(RUN)
            .map(|k| {
                let run = &nodes[k..(k + RUN + 1).min(nodes.len())];
                run.iter()
                    .fold([f64::MAX, f64::MAX, f64::MIN, f64::MIN], |b, &(x, y)| {
                        [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)]
                    })
            })
            .collect();
        Runs {
            boxes,
            corridor: Corridor::of(nodes),
        }
    }

    /// `distance_to_path(q, nodes)`, the same float, where it is at most `reach`; else None.
    /// A point beyond the path's corridor by more than `reach`, or a run whose box lies more
    /// than `reach` + `MARGIN_PX` from `q`, holds no segment within `reach`, and the nearest
    /// segment is the same whichever others are left out.
    pub(super) fn distance_within(
        &self,
        q: (f64, f64),
        nodes: &[(f64, f64)],
        reach: f64,
    ) -> Option<f64> {
        if self.corridor.as_ref().is_some_and(|c| c.beyond(q, reach)) {
            return None;
        }
        let m = reach + MARGIN_PX;
        let d = self
            .boxes
            .iter()
            .enumerate()
            .filter(|(_, b)| {
                q.0 >= b[0] - m && q.0 <= b[2] + m && q.1 >= b[1] - m && q.1 <= b[3] + m
            })
            .map(|(r, _)| {
                let run = &nodes[r * RUN..(r * RUN + RUN + 1).min(nodes.len())];
                distance_to_path(q, run)
            })
            .fold(f64::INFINITY, f64::min);
        (d <= reach).then_some(d)
    }
}

#[cfg(test)]
mod runs_tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The pruned search gives the full search's float, bit for bit, wherever that is within
    /// reach, and None elsewhere: on bent paths of 1 to 130 nodes (a run's trail: ~100 nodes
    /// 1-6 px apart) and points scattered within 40 px of them.
    #[test]
    fn distance_within_is_the_full_search_within_reach() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut within = 0;
        for _ in 0..200 {
            let n = rng.random_range(2..130);
            let (mut x, mut y) = (rng.random_range(0.0..1000.0), rng.random_range(0.0..1000.0));
            let mut a: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            let nodes: Vec<(f64, f64)> = (0..n)
                .map(|_| {
                    let step = rng.random_range(0.0..6.0);
                    a += rng.random_range(-0.05..0.05);
                    (x, y) = (x + step * a.cos(), y + step * a.sin());
                    (x, y)
                })
                .collect();
            let runs = Runs::of(&nodes);
            let reach = rng.random_range(0.5..25.0);
            for _ in 0..200 {
                let at = nodes[rng.random_range(0..n)];
                let q = (
                    at.0 + rng.random_range(-40.0..40.0),
                    at.1 + rng.random_range(-40.0..40.0),
                );
                let full = distance_to_path(q, &nodes);
                let got = runs.distance_within(q, &nodes, reach);
                if full <= reach {
                    within += 1;
                    assert_eq!(got.map(f64::to_bits), Some(full.to_bits()));
                } else {
                    assert_eq!(got, None);
                }
            }
        }
        // Both branches are exercised.
        assert!(within > 1000 && within < 39_000, "{within}");
    }
}
