//! Step 4, connected components of the line-filter response: 8-connected pixels above the
//! threshold with compatible orientations, kept by size and peak, with their centroid, axis and
//! extent from the second moments.

use super::params::Sanitized;

/// A kept component: centroid, axis orientation (rad) and half extent along it.
pub(super) struct Component {
    pub(super) cx: f64,
    pub(super) cy: f64,
    pub(super) theta: f64,
    pub(super) half_len: f64,
}

/// The label of a pixel in no component.
pub(super) const NONE: u32 = u32::MAX;

fn find(parent: &mut [u32], mut a: u32) -> u32 {
    while parent[a as usize] != a {
        let g = parent[parent[a as usize] as usize];
        parent[a as usize] = g;
        a = g;
    }
    a
}

/// 8-connected components of the `w` x `h` pixels that `keep` accepts, a pixel joining a
/// neighbour only where `joins(pixel, neighbour)` holds: each pixel's label is its
/// component's root ([`NONE`] where not kept), and every root is below the returned count.
pub(super) fn label_components(
    w: usize,
    h: usize,
    keep: impl Fn(usize) -> bool,
    joins: impl Fn(usize, usize) -> bool,
) -> (Vec<u32>, usize) {
    let mut label = vec![NONE; w * h];
    let mut parent: Vec<u32> = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if !keep(i) {
                continue;
            }
            let mut l = NONE;
            let consider = |ni: usize, l: &mut u32, parent: &mut Vec<u32>| {
                let nl = label[ni];
                if nl != NONE && joins(i, ni) {
                    let r = find(parent, nl);
                    if *l == NONE {
                        *l = r;
                    } else if r != *l {
                        let (lo, hi) = if r < *l { (r, *l) } else { (*l, r) };
                        parent[hi as usize] = lo;
                        *l = lo;
                    }
                }
            };
            if x > 0 {
                consider(i - 1, &mut l, &mut parent);
            }
            if y > 0 {
                if x > 0 {
                    consider(i - w - 1, &mut l, &mut parent);
                }
                consider(i - w, &mut l, &mut parent);
                if x + 1 < w {
                    consider(i - w + 1, &mut l, &mut parent);
                }
            }
            if l == NONE {
                l = parent.len() as u32;
                parent.push(l);
            }
            label[i] = l;
        }
    }
    for l in label.iter_mut().filter(|l| **l != NONE) {
        *l = find(&mut parent, *l);
    }
    (label, parent.len())
}

#[derive(Default, Clone, Copy)]
struct Acc {
    n: u64,
    peak: f32,
    sx: f64,
    sy: f64,
    sxx: f64,
    sxy: f64,
    syy: f64,
}

#[inline(never)]
pub(super) fn components(
    best: &[f32],
    arg: &[u8],
    w: usize,
    h: usize,
    p: &Sanitized,
) -> Vec<Component> {
    let n_ang = p.n_angles;
    let link = p.link_bins.min(n_ang / 2);
    let compat = |a: u8, b: u8| {
        let d = (a as isize - b as isize).unsigned_abs();
        d.min(n_ang - d) <= link
    };
    let thr = p.threshold;
    let (label, roots) = label_components(
        w,
        h,
        |i| !(best[i].is_nan() || best[i] < thr),
        |i, ni| compat(arg[ni], arg[i]),
    );
    let mut accs = vec![Acc::default(); roots];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if label[i] == NONE {
                continue;
            }
            let a = &mut accs[label[i] as usize];
            let (xf, yf) = (x as f64, y as f64);
            a.n += 1;
            a.peak = a.peak.max(best[i]);
            a.sx += xf;
            a.sy += yf;
            a.sxx += xf * xf;
            a.sxy += xf * yf;
            a.syy += yf * yf;
        }
    }
    let mut out = Vec::new();
    for a in accs {
        if (a.n as usize) < p.min_pixels || a.peak < p.seed {
            continue;
        }
        let n = a.n as f64;
        let (cx, cy) = (a.sx / n, a.sy / n);
        let mxx = a.sxx / n - cx * cx + 1.0 / 12.0;
        let myy = a.syy / n - cy * cy + 1.0 / 12.0;
        let mxy = a.sxy / n - cx * cy;
        let theta = 0.5 * (2.0 * mxy).atan2(mxx - myy);
        let tr = 0.5 * (mxx + myy);
        let det = (0.25 * (mxx - myy) * (mxx - myy) + mxy * mxy).sqrt();
        let l1 = tr + det;
        let half_len = (3.0 * l1).sqrt();
        if 2.0 * half_len < p.min_fragment {
            continue;
        }
        out.push(Component {
            cx,
            cy,
            theta,
            half_len,
        });
    }
    out
}
