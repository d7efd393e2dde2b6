//! Steps 3-4, the local seeds: the line filter's noise measured on the clipped map, the
//! oriented line filter in units of it, and its connected components.

use super::components::{Component, components};
use super::lines::line_filter;
use super::noise::LineNoise;
use super::params::Sanitized;

/// The line filter's noise on the clipped map `zc`: measured on it where the noise is
/// calibrated (see `noise`), else the white-noise model.
pub(super) fn line_noise(zc: &[f32], w: usize, h: usize, p: &Sanitized) -> LineNoise {
    if p.calibrate_noise {
        LineNoise::measure(zc, w, h, p)
    } else {
        LineNoise::white(p)
    }
}

/// The components of the line filter on `zc`, each with the longest filter's length (how far
/// beyond its extent to look for its ends).
pub(super) fn local_seeds(
    zc: &[f32],
    w: usize,
    h: usize,
    p: &Sanitized,
    noise: &LineNoise,
) -> Vec<(Component, f64)> {
    let (best, arg) = line_filter(zc, w, h, p, noise);
    let kmax = p.half_lengths.iter().copied().max().unwrap_or(10) as f64 * 2.0 + 1.0;
    components(&best, &arg, w, h, p)
        .into_iter()
        .map(|c| (c, kmax))
        .collect()
}
