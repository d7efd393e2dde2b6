//! Step 3a, the measured noise of the line filter. The white-noise model (`digital_line`) holds for
//! synthetic images, but a real sensor's noise (a dark frame's hot pixels, column structure and
//! row-to-row correlation, stretched by the enhancement) makes line sums vary more than it
//! predicts: on the semisynthetic dark-frame images a 51 px sum of pure noise reached "6
//! sigma" everywhere, and the detector returned its 16-candidate cap on debris-free images.
//! So each filter's noise is also measured on the image itself, as the robust (MAD) standard
//! deviation of its sums at a grid of sample centres (a streak covers too few of them to move
//! a median), and the larger of the two is the filter's sigma. The ratio measured / model is
//! kept per orientation and length: the segment SNR of `refine` is inflated by it too.

use std::f64::consts::PI;

use super::digital_line::{CorrTable, model_sd, slope};
use super::params::Sanitized;
use super::stats::median_of;

/// About this many sample centres per filter: the MAD of 4096 Gaussian values has a relative
/// standard error of about 1.7 %, small beside the factors it corrects (1.3 to 2 on dark frames).
const SAMPLES: usize = 4096;

/// Measured over modelled noise sd per filter, at least 1.
#[cfg_attr(test, derive(Debug, PartialEq))]
pub(super) struct LineNoise {
    n_angles: usize,
    /// Line lengths (pixels, odd, ascending), one column of `ratio` each.
    lengths: Vec<usize>,
    /// `ratio[j * lengths.len() + l]`: orientation j, length l.
    ratio: Vec<f64>,
    /// [`model_sd`] of each filter the pass runs (`p.uses(j)`), laid out as `ratio` (0 for the
    /// others): computed once here for the line filter too (an exp per pair of a line's
    /// pixels, 96 orientations of 51 px at the binned levels).
    model: Vec<f64>,
    /// The upper median over orientations of the longest filter's ratio (a filter the pass
    /// does not run counts as 1; where stars are points it runs them all): near 1 where the
    /// frame's noise is white on a line's scale (synthetic frames: 1.02-1.38 measured on
    /// three fixed images), above where it is correlated (the NEOSSat dark frame under fixed
    /// stars: 1.18-1.72). Taken once here: every contrast sample's taps ask for it
    /// (`Maps::contrast_taps`).
    long_excess: f64,
}

/// [`LineNoise`]'s `long_excess` of its `ratio` table (`n_angles` rows of `n_lengths`).
fn long_excess(ratio: &[f64], n_angles: usize, n_lengths: usize) -> f64 {
    let mut v: Vec<f64> = (0..n_angles)
        .map(|j| ratio[j * n_lengths + n_lengths - 1])
        .collect();
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The sums along a line of two lengths at `centres` (a multiple of four, each centre's lines
/// inside the map): `linear` the row-major offsets of the longer line, `middle` the first and
/// last index of the shorter one's among them; into `short` and `long`. Each value is gathered
/// once and added to both sums where both lines hold it, each sum in its line's order from -0,
/// as `sum` adds (the same bits as one length at a time, which gathered the shorter line's
/// values again: 29 % of the gathers at 21 and 51 px). Four centres at a time: four independent
/// chains of adds (one chain waits on each add).
/// Inlined into `measured`'s two builds (see `simd`).
#[inline(always)]
fn two_lengths(
    zc: &[f32],
    w: usize,
    centres: &[(isize, isize)],
    linear: &[isize],
    (m0, m1): (usize, usize),
    (short, long): (&mut [f64], &mut [f64]),
) {
    let base = |&(x, y): &(isize, isize)| y * w as isize + x;
    for ((c4, s4), l4) in centres
        .chunks_exact(4)
        .zip(short.chunks_exact_mut(4))
        .zip(long.chunks_exact_mut(4))
    {
        let c = [base(&c4[0]), base(&c4[1]), base(&c4[2]), base(&c4[3])];
        let at = |o: isize| [0, 1, 2, 3].map(|k| zc[(c[k] + o) as usize] as f64);
        let (mut a, mut b) = ([-0.0f64; 4], [-0.0f64; 4]);
        for &o in &linear[..m0] {
            let v = at(o);
            for k in 0..4 {
                b[k] += v[k];
            }
        }
        for &o in &linear[m0..=m1] {
            let v = at(o);
            for k in 0..4 {
                a[k] += v[k];
                b[k] += v[k];
            }
        }
        for &o in &linear[m1 + 1..] {
            let v = at(o);
            for k in 0..4 {
                b[k] += v[k];
            }
        }
        s4.copy_from_slice(&a);
        l4.copy_from_slice(&b);
    }
}

impl LineNoise {
    /// Measure the sums of the clipped map `zc` along every filter (orientation j of
    /// `p.n_angles`, each length) against their white-noise sd ([`model_sd`]).
    pub(super) fn measure(zc: &[f32], w: usize, h: usize, p: &Sanitized) -> Self {
        Self::measure_at(zc, w, h, p, SAMPLES)
    }

    /// [`LineNoise::measure`] from about `samples` sums per filter.
    pub(super) fn measure_at(
        zc: &[f32],
        w: usize,
        h: usize,
        p: &Sanitized,
        samples: usize,
    ) -> Self {
        measured(zc, w, h, p, samples)
    }

    /// The white-noise model alone: every ratio 1.
    pub(super) fn white(p: &Sanitized) -> Self {
        let mut table = CorrTable::new(p.psf_sigma);
        LineNoise {
            n_angles: p.n_angles,
            lengths: p.half_lengths.iter().map(|&h| 2 * h + 1).collect(),
            ratio: vec![1.0; p.n_angles * p.half_lengths.len()],
            long_excess: 1.0,
            model: (0..p.n_angles)
                .flat_map(|j| {
                    if p.uses(j) {
                        model_sd(j, p, &mut table)
                    } else {
                        vec![0.0; p.half_lengths.len()]
                    }
                })
                .collect(),
        }
    }

    /// [`model_sd`] of orientation `j`, one per length (`j` a filter the pass runs).
    pub(super) fn model_sd(&self, j: usize) -> &[f64] {
        let n = self.lengths.len();
        &self.model[j * n..(j + 1) * n]
    }

    /// The ratio for filter (j, l).
    pub(super) fn at(&self, j: usize, l: usize) -> f64 {
        self.ratio[j * self.lengths.len() + l]
    }

    /// See [`LineNoise::long_excess`]'s field.
    pub(super) fn long_excess(&self) -> f64 {
        self.long_excess
    }

    /// The ratio for a sum of `n` samples along orientation `theta` (rad): the nearest
    /// orientation, linear in length between the filter lengths, constant beyond them (the
    /// measured correlations are short-range, so the ratio levels off).
    pub(super) fn for_sum(&self, theta: f64, n: usize) -> f64 {
        let j =
            ((theta.rem_euclid(PI) / PI * self.n_angles as f64).round() as usize) % self.n_angles;
        let r = |l: usize| self.at(j, l);
        let n = n as f64;
        let last = self.lengths.len() - 1;
        if n <= self.lengths[0] as f64 {
            return r(0);
        }
        for l in 0..last {
            let (a, b) = (self.lengths[l] as f64, self.lengths[l + 1] as f64);
            if n <= b {
                return r(l) + (r(l + 1) - r(l)) * (n - a) / (b - a);
            }
        }
        r(last)
    }
}

avx2_dispatch! {
    /// The body of [`LineNoise::measure_at`] (its sums are most of its time).
    pub(super) fn measured(zc: &[f32], w: usize, h: usize, p: &Sanitized, samples: usize) -> LineNoise = measured_at
}

#[inline(always)]
pub(super) fn measured_at(
    zc: &[f32],
    w: usize,
    h: usize,
    p: &Sanitized,
    samples: usize,
) -> LineNoise {
    let lengths: Vec<usize> = p.half_lengths.iter().map(|&h| 2 * h + 1).collect();
    let hmax = *p.half_lengths.last().expect("at least one length") as isize;
    // Sample centres on a regular grid, away from the edges where sums are cut short.
    let (x0, x1) = (
        hmax.min(w as isize / 2),
        (w as isize - hmax).max(w as isize / 2 + 1),
    );
    let (y0, y1) = (
        hmax.min(h as isize / 2),
        (h as isize - hmax).max(h as isize / 2 + 1),
    );
    let area = ((x1 - x0) * (y1 - y0)).max(1) as f64;
    let step = ((area / samples.max(1) as f64).sqrt().floor() as isize).max(1);
    let centres: Vec<(isize, isize)> = (y0..y1)
        .step_by(step as usize)
        .flat_map(|y| (x0..x1).step_by(step as usize).map(move |x| (x, y)))
        .collect();
    // Every centre's lines stay inside the map (an image over twice the longest filter).
    let inside =
        x0 >= hmax && x1 - 1 + hmax < w as isize && y0 >= hmax && y1 - 1 + hmax < h as isize;
    let at = |x: isize, y: isize| -> f64 {
        if x < 0 || y < 0 || x >= w as isize || y >= h as isize {
            0.0
        } else {
            zc[y as usize * w + x as usize] as f64
        }
    };
    let mut ratio = Vec::with_capacity(p.n_angles * lengths.len());
    let mut models = Vec::with_capacity(p.n_angles * lengths.len());
    let mut sums = vec![0f64; centres.len()];
    let mut table = CorrTable::new(p.psf_sigma);
    // With two lengths, their sums at the first centres, four at a time (`two_lengths`).
    let mut pairs = match p.half_lengths.len() {
        2 => vec![vec![0f64; centres.len() / 4 * 4]; 2],
        _ => Vec::new(),
    };
    for j in 0..p.n_angles {
        if !p.uses(j) {
            // A filter the pass does not run.
            ratio.extend(p.half_lengths.iter().map(|_| 1.0));
            models.extend(p.half_lengths.iter().map(|_| 0.0));
            continue;
        }
        let (x_major, t) = slope(j, p.n_angles);
        // The same digital line as `lines`: one step along the major axis, the minor
        // offset rounded.
        // Tabulated once per orientation (it was rounded again for every sample: 7% of
        // the detector); offset(i) is at index i + hmax.
        let offsets: Vec<(isize, isize)> = (-hmax..=hmax)
            .map(|i| {
                let m = (i as f64 * t).round() as isize;
                if x_major { (i, m) } else { (m, i) }
            })
            .collect();
        let offset = |i: isize| offsets[(i + hmax) as usize];
        // The same offsets in the row-major map, for centres whose every line lies inside.
        let linear: Vec<isize> = offsets
            .iter()
            .map(|&(dx, dy)| dy * w as isize + dx)
            .collect();
        let model = model_sd(j, p, &mut table);
        models.extend(&model);
        // Two lengths (the default): both sums in one pass along the longer line.
        let quads = sums.len() / 4 * 4;
        if inside && let [h0, _] = p.half_lengths[..] {
            let middle = (hmax as usize - h0, hmax as usize + h0);
            let (q0, q1) = pairs.split_at_mut(1);
            two_lengths(
                zc,
                w,
                &centres[..quads],
                &linear,
                middle,
                (&mut q0[0], &mut q1[0]),
            );
        }
        for (l, &hk) in p.half_lengths.iter().enumerate() {
            let hk = hk as isize;
            let line = &linear[(hmax - hk) as usize..=(hmax + hk) as usize];
            if inside {
                let base = |&(x, y): &(isize, isize)| y * w as isize + x;
                if pairs.len() == 2 {
                    sums[..quads].copy_from_slice(&pairs[l][..quads]);
                } else {
                    // Four centres at a time: four independent chains of adds (one chain
                    // waits on each add), each in the line's order from -0, as `sum` adds.
                    for (s4, c4) in sums[..quads]
                        .chunks_exact_mut(4)
                        .zip(centres[..quads].chunks_exact(4))
                    {
                        let c = [base(&c4[0]), base(&c4[1]), base(&c4[2]), base(&c4[3])];
                        let mut acc = [-0.0f64; 4];
                        // The four values read first, then added: read and added in turn,
                        // each bounds check stood between two adds, which stayed scalar.
                        for &o in line {
                            let v = [0, 1, 2, 3].map(|k| zc[(c[k] + o) as usize] as f64);
                            for k in 0..4 {
                                acc[k] += v[k];
                            }
                        }
                        s4.copy_from_slice(&acc);
                    }
                }
                for (sum, c) in sums[quads..].iter_mut().zip(&centres[quads..]) {
                    *sum = line
                        .iter()
                        .map(|&o| zc[(base(c) + o) as usize] as f64)
                        .sum();
                }
            } else {
                for (sum, &(x, y)) in sums.iter_mut().zip(&centres) {
                    *sum = (-hk..=hk)
                        .map(|i| {
                            let (dx, dy) = offset(i);
                            at(x + dx, y + dy)
                        })
                        .sum();
                }
            }
            let med = median_of(&sums);
            let dev: Vec<f64> = sums.iter().map(|s| (s - med).abs()).collect();
            let sd = 1.4826 * median_of(&dev);
            ratio.push((sd / model[l]).max(1.0));
        }
    }
    LineNoise {
        n_angles: p.n_angles,
        long_excess: long_excess(&ratio, p.n_angles, lengths.len()),
        lengths,
        ratio,
        model: models,
    }
}
