//! Step 7, explaining away: best first, a candidate must still be long and significant enough
//! outside the neighbourhood of every better one (drops duplicates and the off-axis responses of
//! bright streaks), and at most `max_candidates` are kept.

use super::explain::{Dropped, Reason, Seeds};
use super::maps::Maps;
use super::segment::{Point, Seg, point_segment_distance};
use super::stats::median_of;

/// The accepted candidates (best first) kept, with their scores, and those dropped, with why.
pub(super) fn explain_away(
    maps: &Maps,
    cands: Vec<(Seg, Seeds, f64)>,
) -> (Vec<(Seg, f64)>, Vec<Dropped>) {
    let (mut kept, mut dropped): (Vec<(Seg, f64)>, Vec<Dropped>) = (Vec::new(), Vec::new());
    for (s, seeds, sc) in cands {
        if kept.len() >= maps.p.max_candidates {
            let r = Reason::OverCap {
                limit: maps.p.max_candidates,
            };
            dropped.push(Dropped::of_seg(&s, seeds, r));
            continue;
        }
        let others: Vec<(Point, Point)> = kept.iter().map(|(k, _)| k.ends()).collect();
        if !others.is_empty() && !survives(maps, &s, &others) {
            dropped.push(Dropped::of_seg(&s, seeds, Reason::Duplicate));
            continue;
        }
        kept.push((s, sc));
    }
    (kept, dropped)
}

/// Whether the profile samples of `s` farther than `duplicate_distance_px` from all `others`
/// still make `min_length_px` samples and `min_snr` (median contrast times count over the
/// noise sd of that many samples).
fn survives(maps: &Maps, s: &Seg, others: &[(Point, Point)]) -> bool {
    let (ux, uy) = s.dir();
    let (nx, ny) = (-uy, ux);
    let taps = maps.contrast_taps();
    let vals: Vec<f64> = s
        .axis_points()
        .filter(|&q| {
            !others
                .iter()
                .any(|&(a, b)| point_segment_distance(q, a, b) <= maps.p.dup_dist)
        })
        .map(|(x, y)| maps.contrast(&taps, x, y, nx, ny))
        .collect();
    let n = vals.len();
    if (n as f64) < maps.p.min_length || n == 0 {
        return false;
    }
    median_of(&vals) * n as f64 / maps.contrast_sum_sd(&taps, s.theta, n) >= maps.p.min_snr
}
