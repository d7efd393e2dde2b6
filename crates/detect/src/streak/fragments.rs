//! Step 5, fragments: each component's axis refined into a measured segment; those shorter than
//! `min_fragment_px` or explained by the star trails are dropped before merging.

use super::components::Component;
use super::explain::{Dropped, Reason, Seeds};
use super::maps::Maps;
use super::refine::{Regime, Seed, refine};
use super::segment::Seg;

/// The fragments of the components `comps` (each with the filter length it came from, in
/// pixels: how far beyond its extent to look for its ends) of stage `seeds`, their profiles
/// read as the contrast where `contrast` (see `refine`); and the axes dropped, with why.
pub(super) fn fragments(
    maps: &Maps,
    comps: &[(Component, f64)],
    contrast: bool,
    seeds: Seeds,
    is_star: &dyn Fn(&Seg) -> bool,
) -> (Vec<Seg>, Vec<Dropped>) {
    let p = maps.p;
    let regime = Regime::of(seeds);
    let (mut frags, mut dropped) = (Vec::new(), Vec::new());
    for &(ref c, kmax) in comps {
        let shrink = (kmax / 2.0).min(c.half_len / 2.0);
        let seed = Seed {
            cx: c.cx,
            cy: c.cy,
            theta: c.theta,
            half: c.half_len,
            shrink,
            ext: kmax,
            contrast,
            regime,
        };
        let Some(s) = refine(maps, &seed) else {
            dropped.push(Dropped::of_axis((c.cx, c.cy), c.theta, c.half_len, seeds));
            continue;
        };
        if s.length < p.min_fragment {
            let r = Reason::ShortFragment {
                length_px: s.length,
                limit: p.min_fragment,
            };
            dropped.push(Dropped::of_seg(&s, seeds, r));
        } else if is_star(&s) {
            dropped.push(Dropped::of_seg(&s, seeds, Reason::StarTrail));
        } else {
            frags.push(s);
        }
    }
    (frags, dropped)
}
