//! The digital straight line that the line filter sums along and its noise measurement samples,
//! and the white-noise sd of such a sum: shared by `lines` and `noise`.

use std::f64::consts::PI;

use super::params::Sanitized;
use super::smooth::corr;

/// Whether orientation `j` of `n` is x-major (steps along x), and its slope: minor-axis
/// offset per major-axis step, |t| <= 1.
pub(super) fn slope(j: usize, n: usize) -> (bool, f64) {
    let th = j as f64 * PI / n as f64;
    let (c, s) = (th.cos(), th.sin());
    let x_major = c.abs() >= s.abs() - 1e-12;
    (x_major, if x_major { s / c } else { c / s })
}

/// White-noise sd of the sums of the unit-noise smoothed map along the digital line of
/// orientation `j`, one per filter length (pixels of the line correlated through the Gaussian).
pub(super) fn model_sd(j: usize, p: &Sanitized) -> Vec<f64> {
    let t = slope(j, p.n_angles).1;
    let kmax = 2 * p.half_lengths.last().expect("at least one length") + 1;
    let pts: Vec<(f64, f64)> = (0..kmax)
        .map(|k| (k as f64, (k as f64 * t).round()))
        .collect();
    // sd[m]: noise sd of the sum of the first m terms.
    let mut sd = vec![1f64; kmax + 1];
    let mut var = 0.0;
    for m in 0..kmax {
        let mut add = 1.0;
        for q in &pts[..m] {
            let (dx, dy) = (pts[m].0 - q.0, pts[m].1 - q.1);
            add += 2.0 * corr(dx * dx + dy * dy, p.psf_sigma);
        }
        var += add;
        sd[m + 1] = var.sqrt();
    }
    p.half_lengths.iter().map(|&hk| sd[2 * hk + 1]).collect()
}
