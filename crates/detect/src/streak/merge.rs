//! Step 6, merging: collinear fragments are merged and re-refined until none merge.

use super::maps::Maps;
use super::params::Sanitized;
use super::refine::{Regime, Seed, refine};
use super::segment::{Seg, angle_diff_deg};

/// Merge collinear fragments until none merge. Fragments join `done`, in which no two
/// merge, one at a time: each is tried against `done` in order, and a merge product is
/// tried again from the start. A merge is refined in the `regime` of the fragments' stage:
/// two full-line fragments of one sub-noise streak refined as a resolved one collapsed to
/// 37 px (development image 68 of `scripts/faint-limit-dev.sh`, line SNR 10). Development
/// sets (`sky_eval` + `soig eval`, mAP50-95, resolved -> the stage's regime): original
/// semisynthetic (seed 778, 300 images) 0.8777 -> 0.8796, rotated semisynthetic (778, 150)
/// 0.8814 -> 0.8821, rotated synthetic (778, 150) 0.9621 -> 0.9633, original synthetic (777,
/// 100) 0.9440 the same. Linear in merges times fragments, where restarting a scan of
/// every pair after each merge was cubic (minutes on a real frame's thousands of fragments).
pub(super) fn merge(
    maps: &Maps,
    segs: Vec<Seg>,
    regime: Regime,
    aligned: &dyn Fn(&Seg) -> bool,
) -> Vec<Seg> {
    // Orientations further apart than `merge_angle` never merge: a dot product rules them
    // out before the offsets and gap are measured.
    let cos_max = maps.p.merge_angle.to_radians().cos();
    let mut done: Vec<(Seg, (f64, f64))> = Vec::with_capacity(segs.len());
    for mut s in segs {
        'retry: loop {
            let u = s.dir();
            for k in 0..done.len() {
                let (d, v) = done[k];
                if (u.0 * v.0 + u.1 * v.1).abs() < cos_max || !collinear(maps.p, &d, &s) {
                    continue;
                }
                if let Some(m) = joined(maps, &d, &s, regime)
                    && !aligned(&m)
                {
                    done.remove(k);
                    s = m;
                    continue 'retry;
                }
            }
            done.push((s, u));
            break;
        }
    }
    done.into_iter().map(|(s, _)| s).collect()
}

/// `a` and `b` refined as one segment spanning their two farthest ends, if it refines.
fn joined(maps: &Maps, a: &Seg, b: &Seg, regime: Regime) -> Option<Seg> {
    let (a0, a1) = a.ends();
    let (b0, b1) = b.ends();
    let pts = [a0, a1, b0, b1];
    let (mut bd, mut e0, mut e1) = (-1.0, a0, a1);
    for u in 0..4 {
        for v in (u + 1)..4 {
            let d = (pts[u].0 - pts[v].0).hypot(pts[u].1 - pts[v].1);
            if d > bd {
                (bd, e0, e1) = (d, pts[u], pts[v]);
            }
        }
    }
    refine(
        maps,
        &Seed {
            cx: 0.5 * (e0.0 + e1.0),
            cy: 0.5 * (e0.1 + e1.1),
            theta: (e1.1 - e0.1).atan2(e1.0 - e0.0),
            half: 0.5 * bd,
            shrink: 0.0,
            ext: 4.0 * maps.p.psf_sigma + 4.0,
            contrast: a.contrast || b.contrast,
            regime,
        },
    )
}

/// Whether `a` and `b` may be one streak: their orientations, lateral offsets and the gap
/// between them within the merge knobs.
fn collinear(p: &Sanitized, a: &Seg, b: &Seg) -> bool {
    if angle_diff_deg(a.theta.to_degrees(), b.theta.to_degrees()) > p.merge_angle {
        return false;
    }
    let off = |s: &Seg, q: (f64, f64)| {
        let (ux, uy) = s.dir();
        ((q.0 - s.cx) * -uy + (q.1 - s.cy) * ux).abs()
    };
    let (a0, a1) = a.ends();
    let (b0, b1) = b.ends();
    if off(a, b0).max(off(a, b1)) > p.merge_offset || off(b, a0).max(off(b, a1)) > p.merge_offset {
        return false;
    }
    // Gap along a's axis.
    let (ux, uy) = a.dir();
    let proj = |q: (f64, f64)| (q.0 - a.cx) * ux + (q.1 - a.cy) * uy;
    let (pa0, pa1) = (-0.5 * a.length, 0.5 * a.length);
    let (pb0, pb1) = {
        let (u, v) = (proj(b0), proj(b1));
        (u.min(v), u.max(v))
    };
    let gap = (pb0 - pa1).max(pa0 - pb1).max(0.0);
    gap <= p.merge_gap
}
