//! Step 3b, long faint lines: the line filter of step 3 run again on the clipped map binned by
//! 2, 4 and 8 (block means), so that one filter integrates 100, 200 and 400 image pixels.
//!
//! Why: step 3 sums at most `line_lengths_px` pixels, and a component needs a pixel whose
//! local sum is a few sigma. A streak whose per-pixel signal is well below the noise never
//! becomes a candidate there, however long it is, while its integrated (matched-filter) SNR
//! grows as the square root of its length. Binning is the tree step of a multi-scale Radon
//! sum: each level doubles the length a sum covers at the same cost per binned pixel, so the
//! three levels together cost less than the full-resolution filter.
//!
//! Real sensors' noise (skewed, row- and column-correlated, hot pixels) is handled as in step
//! 3: the map is clipped before binning (a hot pixel adds at most `clip_sigma`), each binned
//! map is scaled to unit robust noise, and each filter's sigma is the larger of the
//! white-noise model and the spread measured on the map itself ([`LineNoise::measure`]), so
//! correlated structure raises the threshold instead of making lines. What it finds are only
//! seeds: the full-resolution refinement, merging and SNR tests of steps 5-7 decide.

use super::components::{Component, components};
use super::lines::line_filter;
use super::noise::LineNoise;
use super::params::Sanitized;
use super::stats::map_stats;

/// Binning factors, and the line-filter length (binned pixels) at each.
const FACTORS: [usize; 3] = [2, 4, 8];
const LENGTH: usize = 51;
/// Sums per filter for its measured noise: the MAD of 1024 Gaussian values has a relative
/// standard error of about 3.4 %; these filters only seed, so that is precise enough, at a
/// quarter of the cost of step 3's 4096.
const NOISE_SAMPLES: usize = 1024;
/// A binned map smaller than this on a side has no room for a 51-pixel line.
const MIN_SIDE: usize = 64;

/// Components of the binned line filters, in full-resolution pixel coordinates, each with the
/// filter length it came from (full-resolution pixels: how far beyond its extent to look for
/// its ends); and the map binned by `SHARED` where it was made (`binned_unit`), which the
/// full-line stage bins the same map by (one read of the full map fewer).
pub(super) fn long_line_components(
    zc: &[f32],
    w: usize,
    h: usize,
    p: &Sanitized,
) -> (Vec<(Component, f64)>, Option<Vec<f32>>) {
    let (mut out, mut shared) = (Vec::new(), None);
    for b in FACTORS {
        let (bw, bh) = (w / b, h / b);
        if bw < MIN_SIDE || bh < MIN_SIDE {
            continue;
        }
        let Some(map) = binned_unit(zc, w, b, bw, bh) else {
            continue;
        };
        let q = binned_params(p, b);
        let noise = LineNoise::measure_at(&map, bw, bh, &q, NOISE_SAMPLES);
        let (best, arg) = line_filter(&map, bw, bh, &q, &noise);
        let bf = b as f64;
        for c in components(&best, &arg, bw, bh, &q) {
            out.push((
                Component {
                    cx: (c.cx + 0.5) * bf - 0.5,
                    cy: (c.cy + 0.5) * bf - 0.5,
                    theta: c.theta,
                    half_len: c.half_len * bf,
                },
                (LENGTH * b) as f64,
            ));
        }
        if b == SHARED {
            shared = Some(map);
        }
    }
    (out, shared)
}

/// The binning factor whose map [`long_line_components`] hands on.
pub(super) const SHARED: usize = 4;

/// The `bw` x `bh` block means of `b` x `b` pixels of `zc` scaled to unit robust noise, so
/// that the white-noise model of line sums on it is the right floor; `None` for a map with no
/// noise to scale to (constant, sd 0, or NaN).
pub(super) fn binned_unit(
    zc: &[f32],
    w: usize,
    b: usize,
    bw: usize,
    bh: usize,
) -> Option<Vec<f32>> {
    let mut map = bin(zc, w, b, bw, bh);
    let sd = map_stats(&map, bw, bh).1;
    if sd.is_nan() || sd <= 0.0 {
        return None;
    }
    let inv = (1.0 / sd) as f32;
    map.iter_mut().for_each(|v| *v *= inv);
    Some(map)
}

/// Block means of `b` x `b` pixels (the last partial blocks left out). The stage's factors are
/// built each with its block width known ([`bin_by`]): its sums unrolled, where a width known
/// only at run time left a loop of one add per pixel.
fn bin(zc: &[f32], w: usize, b: usize, bw: usize, bh: usize) -> Vec<f32> {
    match b {
        2 => bin_by::<2>(zc, w, bw, bh),
        4 => bin_by::<4>(zc, w, bw, bh),
        8 => bin_by::<8>(zc, w, bw, bh),
        _ => bin_at(zc, w, b, bw, bh),
    }
}

/// [`bin`] of blocks `B` pixels wide.
fn bin_by<const B: usize>(zc: &[f32], w: usize, bw: usize, bh: usize) -> Vec<f32> {
    bin_at(zc, w, B, bw, bh)
}

/// The body of [`bin`]: each block's rows summed in turn, each row's `b` pixels in order from
/// -0 (`sum`), whatever the width is known as.
#[inline(always)]
fn bin_at(zc: &[f32], w: usize, b: usize, bw: usize, bh: usize) -> Vec<f32> {
    let mut out = vec![0f32; bw * bh];
    let inv = 1.0 / (b * b) as f32;
    for by in 0..bh {
        let row = &mut out[by * bw..(by + 1) * bw];
        for y in by * b..(by + 1) * b {
            let src = &zc[y * w..y * w + bw * b];
            for (o, chunk) in row.iter_mut().zip(src.chunks_exact(b)) {
                *o += chunk.iter().sum::<f32>();
            }
        }
        row.iter_mut().for_each(|v| *v *= inv);
    }
    out
}

/// The parameters of one binned level: one filter length, finer orientations (a 51-pixel line
/// of a binned streak about one pixel wide drifts off it by more than half a pixel at its ends
/// beyond about 1 degree of misalignment at 8x, 2 degrees at 2x), the PSF shrunk by the
/// binning (the white-noise model's correlation length), lengths in binned pixels.
fn binned_params(p: &Sanitized, b: usize) -> Sanitized {
    let bf = b as f64;
    Sanitized {
        n_angles: if b <= 2 { 48 } else { 96 },
        half_lengths: vec![LENGTH / 2],
        psf_sigma: (p.psf_sigma / bf).max(0.3),
        min_fragment: p.min_fragment / bf,
        min_pixels: p.min_pixels,
        ..p.clone()
    }
}
