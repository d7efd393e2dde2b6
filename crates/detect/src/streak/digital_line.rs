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

/// [`corr`] at the squared distances between two pixels of a digital line (whole numbers),
/// each computed once: a 51 px line's 1275 pairs repeat a few hundred distances, and a
/// measurement models 48-96 orientations (an exp per pair was 2 % of the detector). The same
/// values as `corr` itself.
pub(super) struct CorrTable {
    psf_sigma: f64,
    /// `at[d2]`: `corr(d2)`, NaN until computed.
    at: Vec<f64>,
}

impl CorrTable {
    pub(super) fn new(psf_sigma: f64) -> Self {
        CorrTable {
            psf_sigma,
            at: Vec::new(),
        }
    }

    fn get(&mut self, d2: f64) -> f64 {
        debug_assert!(d2 >= 0.0 && d2.fract() == 0.0, "a whole squared distance");
        let i = d2 as usize;
        if i >= self.at.len() {
            self.at.resize(i + 1, f64::NAN);
        }
        if self.at[i].is_nan() {
            self.at[i] = corr(d2, self.psf_sigma);
        }
        self.at[i]
    }
}

/// White-noise sd of the sums of the unit-noise smoothed map along the digital line of
/// orientation `j`, one per filter length (pixels of the line correlated through the Gaussian).
/// `table`: made for `p.psf_sigma`.
pub(super) fn model_sd(j: usize, p: &Sanitized, table: &mut CorrTable) -> Vec<f64> {
    debug_assert_eq!(table.psf_sigma.to_bits(), p.psf_sigma.to_bits());
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
            add += 2.0 * table.get(dx * dx + dy * dy);
        }
        var += add;
        sd[m + 1] = var.sqrt();
    }
    p.half_lengths.iter().map(|&hk| sd[2 * hk + 1]).collect()
}
