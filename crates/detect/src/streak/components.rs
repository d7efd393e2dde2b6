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

/// Pixels tested together for whether any is kept or labelled (a test the compiler
/// vectorises), in the same order as one at a time.
const RUN: usize = 16;

/// The runs of `RUN` pixels (fewer at a row's end) of a `w` x `h` map in row order, as (row,
/// columns).
fn runs(w: usize, h: usize) -> impl Iterator<Item = (usize, std::ops::Range<usize>)> {
    (0..h).flat_map(move |y| (0..w).step_by(RUN).map(move |x| (y, x..(x + RUN).min(w))))
}

/// Whether no label of `run` is a component's.
fn none(run: &[u32]) -> bool {
    run.iter().fold(true, |none, &l| none & (l == NONE))
}

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
    for (y, run) in runs(w, h) {
        let row = y * w;
        // Most of a map is not kept: a run of it passed over as a whole.
        if !run.clone().fold(false, |any, x| any | keep(row + x)) {
            continue;
        }
        for x in run {
            let i = row + x;
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
    for run in label.chunks_mut(RUN).filter(|run| !none(run)) {
        for l in run.iter_mut().filter(|l| **l != NONE) {
            *l = find(&mut parent, *l);
        }
    }
    (label, parent.len())
}

/// A component's pixel count and first and second moments of its pixel places.
#[derive(Default, Clone, Copy)]
pub(super) struct Moments {
    pub(super) n: usize,
    sx: f64,
    sy: f64,
    sxx: f64,
    sxy: f64,
    syy: f64,
}

/// A component's centroid and principal axes from its [`Moments`] (pixels as unit squares).
pub(super) struct Shape {
    pub(super) cx: f64,
    pub(super) cy: f64,
    /// The major axis' direction, radians in (-pi/2, pi/2].
    pub(super) theta: f64,
    /// Variance along the major and the minor axis, px^2.
    pub(super) major: f64,
    pub(super) minor: f64,
}

impl Moments {
    fn add(&mut self, x: usize, y: usize) {
        let (xf, yf) = (x as f64, y as f64);
        self.n += 1;
        self.sx += xf;
        self.sy += yf;
        self.sxx += xf * xf;
        self.sxy += xf * yf;
        self.syy += yf * yf;
    }

    pub(super) fn shape(&self) -> Shape {
        let n = self.n as f64;
        let (cx, cy) = (self.sx / n, self.sy / n);
        let mxx = self.sxx / n - cx * cx + 1.0 / 12.0;
        let myy = self.syy / n - cy * cy + 1.0 / 12.0;
        let mxy = self.sxy / n - cx * cy;
        let tr = 0.5 * (mxx + myy);
        let det = (0.25 * (mxx - myy) * (mxx - myy) + mxy * mxy).sqrt();
        Shape {
            cx,
            cy,
            theta: 0.5 * (2.0 * mxy).atan2(mxx - myy),
            major: tr + det,
            minor: tr - det,
        }
    }
}

/// The [`Moments`] of each of the `roots` components of `label` (`w` x `h`), in row order,
/// calling `also(root, pixel, x, y)` on every labelled pixel for what a caller adds up beside.
pub(super) fn moments_by_label(
    label: &[u32],
    roots: usize,
    w: usize,
    h: usize,
    mut also: impl FnMut(usize, usize, usize, usize),
) -> Vec<Moments> {
    let mut moments = vec![Moments::default(); roots];
    for (y, run) in runs(w, h) {
        let row = y * w;
        if none(&label[row + run.start..row + run.end]) {
            continue;
        }
        for x in run {
            let i = row + x;
            if label[i] == NONE {
                continue;
            }
            let root = label[i] as usize;
            moments[root].add(x, y);
            also(root, i, x, y);
        }
    }
    moments
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
    let mut peaks = vec![0f32; roots];
    let moments = moments_by_label(&label, roots, w, h, |root, i, _, _| {
        peaks[root] = peaks[root].max(best[i]);
    });
    let mut out = Vec::new();
    for (m, peak) in moments.iter().zip(peaks) {
        if m.n < p.min_pixels || peak < p.seed {
            continue;
        }
        let s = m.shape();
        // A uniform line of length L has variance L^2 / 12 along it.
        let half_len = (3.0 * s.major).sqrt();
        if 2.0 * half_len < p.min_fragment {
            continue;
        }
        out.push(Component {
            cx: s.cx,
            cy: s.cy,
            theta: s.theta,
            half_len,
        });
    }
    out
}
