//! One pass of the detector from the unit-noise map on, its stages in order. The first pass
//! subtracts everything along the trails' direction (a survey image) and drops what lies
//! along it; the star-aware pass subtracts the predicted trails and drops what they explain.

use std::borrow::Cow;
use std::cell::RefCell;
use std::collections::HashMap;

use super::accept::accept;
use super::explain::{Dropped, Reason, Seeds};
use super::explain_away::explain_away;
use super::flatten::flatten;
use super::fragments::fragments;
use super::full_lines::{PREDICTED_SKIP_DEG, full_line_components};
use super::maps::Maps;
use super::merge::merge;
use super::output::{Candidate, boxed, unboxed};
use super::params::Sanitized;
use super::radon::long_line_components;
use super::reach::reach;
use super::refine::Regime;
use super::seeds::{line_noise, local_seeds};
use super::segment::{Seg, angle_diff_deg};
use super::sky::{Sky, StarTrail};
use super::star_test::StarTest;

/// One pass on the background `bg` and unit-noise map `z` of `pixels`: its candidates,
/// unboxed ([`unboxed`]), each with its segment, handed to `then` with the pass's maps, on
/// which `then` boxes those it keeps ([`boxed`]; [`box_all`] boxes every one); what `then`
/// returns, and the segments dropped on the way, with why. `trail`: the trails' direction
/// (degrees) of a survey image; `stars`: the predicted trails, for the star-aware pass.
#[allow(clippy::too_many_arguments)]
pub(super) fn pass<R>(
    pixels: &[u8],
    w: usize,
    h: usize,
    p: &Sanitized,
    bg: &[f32],
    z: Cow<'_, [f32]>,
    (trail, stars): (Option<f64>, Option<&[StarTrail]>),
    then: impl FnOnce(&Maps, Vec<(Seg, Candidate)>) -> R,
) -> (R, Vec<Dropped>) {
    let trail = trail.filter(|a| a.is_finite());
    // The predicted trails and the map before any is subtracted, which the star test reads.
    // Borrowed where the caller keeps the map (both passes of a survey image start from it):
    // then only `flatten` copies it.
    let sky = stars.map(|t| (Sky::new(t, &z, w, h, p), z.clone()));
    let flat = flatten(z.into_owned(), w, h, p, trail, sky.as_ref().map(|(s, _)| s));
    let noise = line_noise(&flat.zc, w, h, p);
    let local = local_seeds(&flat.zc, w, h, p, &noise);
    let (long, binned) = long_line_components(&flat.zc, w, h, p);
    // Lines across the frame (`full_lines`): in the star-aware pass with predicted trails
    // subtracted, to within `PREDICTED_SKIP_DEG` of the trails, and where stars are points,
    // at every angle
    // (faint-limit-fixed development seed 9422, 300 images: found 162 -> 181, false boxes 13
    // -> 10 with the tumbling floor of `accept::gap`; the fixed rows' development sets, seed
    // 777, the same but one box). Not in the pass along a frame's own trails (none
    // predicted, none subtracted: every line across the frame crosses them all, which made 5
    // false boxes for 4 in `tests/own_trails.rs`).
    let skip = p.trail_tol.min(PREDICTED_SKIP_DEG);
    let full = match (trail, stars) {
        (Some(a), Some(t)) if !t.is_empty() => {
            full_line_components(&flat.zc, w, h, Some((a, skip)), binned)
        }
        (None, None) => full_line_components(&flat.zc, w, h, None, binned),
        _ => Vec::new(),
    };
    let star_test = match (&sky, trail) {
        (Some((sky, z_sky)), _) => StarTest::Predicted(sky, z_sky),
        (None, Some(a)) => StarTest::Along(a),
        (None, None) => StarTest::Round,
    };
    let maps = Maps {
        w,
        h,
        pixels,
        bg,
        z: &flat.z,
        p,
        noise: &noise,
        under_trails: flat.under_trails.as_deref(),
        removed: flat.removed.as_deref(),
        points: matches!(star_test, StarTest::Round),
        sample_corr: Default::default(),
    };
    // Each segment's answer kept: `accept` asks again of every segment it is given, each
    // one a fragment or a joined segment that was asked of already (`fragments`, `merge`).
    let answers: RefCell<HashMap<[u64; 8], bool>> = RefCell::default();
    let is_star = |s: &Seg| {
        let key = s.bits();
        let asked = answers.borrow().get(&key).copied();
        asked.unwrap_or_else(|| {
            let star = star_test.explains(s, w, h, p);
            answers.borrow_mut().insert(key, star);
            star
        })
    };
    // Profiles by contrast (see `refine`), except for the local seeds of survey images, where
    // parallel star trails fall in the side bands (a false candidate at confidence 0.66 in
    // `survey_trails_rejected_and_debris_found`).
    let (local_frags, mut dropped) =
        fragments(&maps, &local, trail.is_none(), Seeds::Local, &is_star);
    let (long_frags, d) = fragments(&maps, &long, true, Seeds::LongLine, &is_star);
    dropped.extend(d);
    let (full_frags, d) = fragments(&maps, &full, true, Seeds::FullLine, &is_star);
    dropped.extend(d);
    // The two stages' fragments are merged apart: a long-line fragment overlapping a local
    // one (the same streak, its ends less sharp) would otherwise re-refine it into a segment
    // that can fail where the local one passed. Where both find a streak, explaining away
    // keeps the better scoring one.
    let mut merged: Vec<(Seg, Seeds)> = Vec::new();
    for (frags, seeds) in [
        (local_frags, Seeds::Local),
        (long_frags, Seeds::LongLine),
        (full_frags, Seeds::FullLine),
    ] {
        let mut segs = merge(&maps, frags, Regime::of(seeds), &is_star);
        // A full line refined or merged to nearer the trails than the stage looks has come to
        // lie along a trail's residual, or beside a trough where trails were subtracted (the
        // side bands below zero): `debris_running_through_overlapping_trails_is_boxed_whole`
        // got two such boxes crossing its streak's ends, and the faint development set (seed
        // 9402, not linearised) lost 3 false boxes of 10.
        if seeds == Seeds::FullLine
            && stars.is_some()
            && let Some(a) = trail
        {
            segs.retain(|s| {
                let along = angle_diff_deg(s.theta.to_degrees(), a) < skip;
                if along {
                    dropped.push(Dropped::of_seg(s, seeds, Reason::StarTrail));
                }
                !along
            });
        }
        merged.extend(segs.into_iter().map(|s| (s, seeds)));
    }
    let (cands, d) = accept(&maps, merged, &is_star);
    dropped.extend(d);
    let (kept, d) = explain_away(&maps, cands);
    dropped.extend(d);
    // In the star-aware pass each streak is first followed across the trails that hide it
    // (`reach`).
    let found = kept
        .into_iter()
        .map(|(s, score)| {
            let s = reach(&maps, &s);
            (s, unboxed(&maps, &s, score))
        })
        .collect();
    (then(&maps, found), dropped)
}

/// Every candidate of a pass boxed on its maps: [`pass`]'s `then` where it keeps them all.
pub(super) fn box_all(maps: &Maps, kept: Vec<(Seg, Candidate)>) -> Vec<Candidate> {
    kept.into_iter().map(|(s, c)| boxed(maps, &s, c)).collect()
}
