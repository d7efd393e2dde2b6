//! The star count model `N(b, m)`: stars per deg^2 brighter than `m` at galactic latitude `b`.
//!
//! ```text
//! N(b, m)   = M(b, m) - M(b, -1.5)           (0 for m <= -1.5)
//! ln M(b,m) = ln N_sky(m) + alpha(m) ln g(|b|) - ln <g^alpha(m)>
//! ```
//! * `N_sky(m)`: all-sky mean, log-linear in `m` through 0.12 (<6), 0.36 (<7), 1.0 (<8), 2.9 (<9)
//!   (standard all-sky star totals) and the Tycho-2 + UCAC4 figures 9.3 (<10), 25 (<11), 72 (<12),
//!   178 (<13), 417 (<14), 955 (<15), 2155 (<16), 3200 (<16.5); extrapolated with the end slopes
//!   (brighter than 6 with the 6-7 slope, fainter than 16.5 with the 16-16.5 slope).
//! * `g(|b|)`: the Gaia DR3 G < 10 counts per |b| bin (0-5: 24.4, 5-10: 20.5, 10-20: 15.7,
//!   20-30: 11.2, 30-45: 8.2, 45-60: 6.3, 60-90: 5.2 per deg^2) divided by their all-sky mean
//!   (11.7086), made continuous in |b|: with `x = sin|b|` (proportional to area), the cumulative
//!   `C(x) = int_0^x g` is known exactly at the bin edges and interpolated by a monotone cubic
//!   (Fritsch-Butland harmonic-mean slopes, SciPy-PCHIP end slopes), `g = C'`. So `g` is continuous,
//!   positive (0.401 at the pole, 2.251 in the plane), keeps every bin's mean exactly and
//!   `<g> = 1`.
//! * `alpha(m)`: 1 for `m <= 10`, linear up to [`ALPHA_FAINT`] = 2.36 at 16.5, constant beyond
//!   (no data). 2.36 puts the galactic pole at 255 per deg^2 for V < 16.5 (Bahcall & Soneira 1980);
//!   the model then gives 1356 at |b| = 30 and 2844 at |b| = 20, inside the B&S ranges 600-2000 and
//!   1200-5400. (`alpha` = 3 would give only 107 at the pole, since `g(90) = 0.40`.)
//! * `<g^alpha>` = `int_0^1 g(x)^alpha dx` (all-sky mean, Gauss-Legendre), so the all-sky mean of
//!   `M` is exactly `N_sky(m)`.
//!
//! `ln M` is evaluated exactly on a 0.1 mag grid from -1.5 to 17 and interpolated linearly in `m`
//! between grid nodes (exact for `ln N_sky` and `alpha`, which are piecewise linear with kinks on
//! the grid). The all-sky mean of `N` is thus the table value at every grid node (minus the
//! `M(b, -1.5)` offset, 3e-5 per deg^2) and within 2e-5 relative between nodes.

use std::sync::OnceLock;

/// Bright end of the magnitude model: no star is brighter.
pub const BRIGHT_MAG_LIMIT: f64 = -1.5;
/// Every cell of the procedural sky is generated down to this magnitude.
pub const GENERATION_MAG_LIMIT: f64 = 17.0;
/// Exponent of the galactic latitude factor at V = 16.5 (1 at V <= 10, linear in between).
pub const ALPHA_FAINT: f64 = 2.36;

/// All-sky mean cumulative counts (magnitude, stars per deg^2 brighter).
const SKY_COUNTS: [(f64, f64); 12] = [
    (6.0, 0.12),
    (7.0, 0.36),
    (8.0, 1.0),
    (9.0, 2.9),
    (10.0, 9.3),
    (11.0, 25.0),
    (12.0, 72.0),
    (13.0, 178.0),
    (14.0, 417.0),
    (15.0, 955.0),
    (16.0, 2155.0),
    (16.5, 3200.0),
];

/// Gaia DR3 G < 10 stars per deg^2 by |b| bin: bin edges in degrees and densities.
const GAIA_B_EDGES: [f64; 8] = [0.0, 5.0, 10.0, 20.0, 30.0, 45.0, 60.0, 90.0];
const GAIA_B_DENSITY: [f64; 7] = [24.4, 20.5, 15.7, 11.2, 8.2, 6.3, 5.2];

const MAG_STEP: f64 = 0.1;
const N_MAG: usize = 186; // (17 - (-1.5)) / 0.1 + 1

fn mag_node(i: usize) -> f64 {
    BRIGHT_MAG_LIMIT + i as f64 * MAG_STEP
}

/// ln of the all-sky mean cumulative count, log-linear through [`SKY_COUNTS`].
fn ln_sky_counts(m: f64) -> f64 {
    let t = &SKY_COUNTS;
    let k = if m <= t[1].0 {
        0
    } else if m >= t[t.len() - 2].0 {
        t.len() - 2
    } else {
        t.iter().rposition(|&(mk, _)| mk <= m).unwrap_or(0)
    };
    let (m0, n0) = t[k];
    let (m1, n1) = t[k + 1];
    n0.ln() + (m - m0) * (n1.ln() - n0.ln()) / (m1 - m0)
}

fn alpha(m: f64) -> f64 {
    if m <= 10.0 {
        1.0
    } else if m >= 16.5 {
        ALPHA_FAINT
    } else {
        1.0 + (ALPHA_FAINT - 1.0) * (m - 10.0) / 6.5
    }
}

/// Precomputed model: the latitude profile and the ln M grid coefficients.
pub(super) struct Model {
    /// sin of the bin edges.
    x: [f64; 8],
    /// Normalised bin densities (secant slopes of C).
    d: [f64; 7],
    /// g at the bin edges (derivatives of C).
    g_nodes: [f64; 8],
    /// ln M(b, m_i) = a[i] + alpha[i] * ln g(b).
    a: [f64; N_MAG],
    alpha: [f64; N_MAG],
}

/// 8-point Gauss-Legendre nodes and weights on [-1, 1] (positive half).
const GL8: [(f64, f64); 4] = [
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_5),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_3),
];

impl Model {
    fn build() -> Self {
        let x: [f64; 8] = std::array::from_fn(|k| GAIA_B_EDGES[k].to_radians().sin());
        let h: [f64; 7] = std::array::from_fn(|k| x[k + 1] - x[k]);
        let mean: f64 = (0..7).map(|k| GAIA_B_DENSITY[k] * h[k]).sum();
        let d: [f64; 7] = std::array::from_fn(|k| GAIA_B_DENSITY[k] / mean);
        let mut g_nodes = [0.0; 8];
        for k in 1..7 {
            g_nodes[k] = if d[k - 1] * d[k] <= 0.0 {
                0.0
            } else {
                let w1 = 2.0 * h[k] + h[k - 1];
                let w2 = h[k] + 2.0 * h[k - 1];
                (w1 + w2) / (w1 / d[k - 1] + w2 / d[k])
            };
        }
        let end = |h0: f64, h1: f64, d0: f64, d1: f64| {
            let m = ((2.0 * h0 + h1) * d0 - h0 * d1) / (h0 + h1);
            if m.signum() != d0.signum() {
                0.0
            } else if d0.signum() != d1.signum() && m.abs() > 3.0 * d0.abs() {
                3.0 * d0
            } else {
                m
            }
        };
        g_nodes[0] = end(h[0], h[1], d[0], d[1]);
        g_nodes[7] = end(h[6], h[5], d[6], d[5]);
        let mut model = Model {
            x,
            d,
            g_nodes,
            a: [0.0; N_MAG],
            alpha: [0.0; N_MAG],
        };
        for i in 0..N_MAG {
            let m = mag_node(i);
            let al = alpha(m);
            model.alpha[i] = al;
            model.a[i] = ln_sky_counts(m) - model.mean_g_pow(al).ln();
        }
        model
    }

    /// Normalised latitude profile g at x = sin|b|.
    pub(super) fn g(&self, x: f64) -> f64 {
        let x = x.clamp(0.0, 1.0);
        let k = self.x[1..7].iter().take_while(|&&xk| xk <= x).count();
        let hk = self.x[k + 1] - self.x[k];
        let t = (x - self.x[k]) / hk;
        let h01 = 6.0 * t * (1.0 - t);
        let h10 = (3.0 * t - 4.0) * t + 1.0;
        let h11 = (3.0 * t - 2.0) * t;
        h01 * self.d[k] + h10 * self.g_nodes[k] + h11 * self.g_nodes[k + 1]
    }

    /// All-sky mean of g^alpha: int_0^1 g(x)^alpha dx.
    fn mean_g_pow(&self, al: f64) -> f64 {
        let mut sum = 0.0;
        for k in 0..7 {
            let (x0, x1) = (self.x[k], self.x[k + 1]);
            let (c, hw) = (0.5 * (x0 + x1), 0.5 * (x1 - x0));
            for &(u, w) in &GL8 {
                sum += w * hw * (self.g(c - hw * u).powf(al) + self.g(c + hw * u).powf(al));
            }
        }
        sum
    }

    /// ln M(b, m) with `lg = ln g(|b|)`, linear in m between grid nodes, extrapolated beyond.
    pub(super) fn ln_m(&self, lg: f64, m: f64) -> f64 {
        let f = ((m - BRIGHT_MAG_LIMIT) / MAG_STEP).floor();
        let i = if f < 0.0 {
            0
        } else {
            (f as usize).min(N_MAG - 2)
        };
        let y0 = self.a[i] + self.alpha[i] * lg;
        let y1 = self.a[i + 1] + self.alpha[i + 1] * lg;
        y0 + (y1 - y0) * (m - mag_node(i)) / MAG_STEP
    }

    /// Inverse of ln M in m for a target `y` between the first and last grid values.
    pub(super) fn mag_of_ln_m(&self, lg: f64, y: f64) -> f64 {
        let node = |i: usize| self.a[i] + self.alpha[i] * lg;
        // first node with value > y, in 1..N_MAG-1
        let (mut lo, mut hi) = (0usize, N_MAG - 1);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if node(mid) <= y { lo = mid } else { hi = mid }
        }
        let (y0, y1) = (node(lo), node(hi));
        let t = if y1 > y0 {
            ((y - y0) / (y1 - y0)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        mag_node(lo) + t * MAG_STEP
    }
}

pub(super) fn model() -> &'static Model {
    static MODEL: OnceLock<Model> = OnceLock::new();
    MODEL.get_or_init(Model::build)
}

/// Model density of stars brighter than `mag` per square degree at galactic latitude b.
///
/// See the module documentation for the formula. Zero at `mag <= -1.5`; beyond the generation
/// limit 17 the last 0.1 mag segment is extrapolated.
pub fn cumulative_density_per_deg2(b_deg: f64, mag: f64) -> f64 {
    if mag.is_nan() || mag <= BRIGHT_MAG_LIMIT {
        return 0.0;
    }
    let md = model();
    let lg = md.g(b_deg.abs().min(90.0).to_radians().sin()).ln();
    (md.ln_m(lg, mag).exp() - md.ln_m(lg, BRIGHT_MAG_LIMIT).exp()).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_is_exact_for_degree_15() {
        let int = |p: i32| {
            GL8.iter()
                .map(|&(u, w)| w * (u.powi(p) + (-u).powi(p)))
                .sum::<f64>()
        };
        for p in 0..16 {
            let exact = if p % 2 == 1 {
                0.0
            } else {
                2.0 / (p as f64 + 1.0)
            };
            assert!((int(p) - exact).abs() < 1e-14, "x^{p}");
        }
    }

    /// N(b, m) from the independent numpy implementation in tests/reference/stars_reference.py.
    #[test]
    fn count_model_matches_reference() {
        let reference = [
            (90.0, 16.5, 254.98049181436636),
            (30.0, 16.5, 1355.6673904533466),
            (20.0, 16.5, 2843.937871848445),
            (0.0, 16.5, 14940.916788473076),
            (-45.0, 12.0, 32.780500596660175),
            (10.0, 8.0, 1.54051436985776),
            (60.0, 17.0, 593.4226873407674),
            (2.5, 14.0, 1336.5082117190452),
        ];
        for (b, m, n_ref) in reference {
            let n = cumulative_density_per_deg2(b, m);
            assert!(
                (n / n_ref - 1.0).abs() < 1e-8,
                "N({b}, {m}) = {n}, reference {n_ref}"
            );
        }
        let md = model();
        assert!((md.g(1.0) - 0.40114311132169367).abs() < 1e-12);
        assert!((md.g(0.0) - 2.251111009181943).abs() < 1e-12);
    }

    #[test]
    fn latitude_profile_is_continuous_positive_and_keeps_bin_means() {
        let md = model();
        for (&x, &b) in md.x.iter().zip(&GAIA_B_EDGES).take(7).skip(1) {
            assert!(
                (md.g(x - 1e-12) - md.g(x + 1e-12)).abs() < 1e-9,
                "jump at |b| = {b}"
            );
        }
        let n = 100_000;
        let mut prev = md.g(0.0);
        for i in 1..=n {
            let g = md.g(i as f64 / n as f64);
            assert!(g > 0.0);
            assert!(
                (g - prev).abs() < 1e-3,
                "g not smooth at x = {}",
                i as f64 / n as f64
            );
            prev = g;
        }
        // each Gaia bin keeps its mean; the all-sky mean is 1
        for (k, &table) in GAIA_B_DENSITY.iter().enumerate() {
            let (x0, x1) = (md.x[k], md.x[k + 1]);
            let (c, hw) = (0.5 * (x0 + x1), 0.5 * (x1 - x0));
            let mean = GL8
                .iter()
                .map(|&(u, w)| w * (md.g(c - hw * u) + md.g(c + hw * u)))
                .sum::<f64>()
                / 2.0;
            assert!((mean - md.d[k]).abs() < 1e-12);
            assert!((md.d[k] * 11.708640122899963 - table).abs() < 1e-9);
        }
        assert!((md.mean_g_pow(1.0) - 1.0).abs() < 1e-14);
    }

    /// All-sky mean of N by Simpson's rule in x = sin|b| (equal area), per x interval of the profile.
    fn sky_mean(m: f64) -> f64 {
        let md = model();
        let mut sum = 0.0;
        for k in 0..7 {
            let (x0, x1) = (md.x[k], md.x[k + 1]);
            let n = 2000;
            let h = (x1 - x0) / n as f64;
            let f = |x: f64| cumulative_density_per_deg2(x.min(1.0).asin().to_degrees(), m);
            let mut s = f(x0) + f(x1);
            for i in 1..n {
                s += if i % 2 == 1 { 4.0 } else { 2.0 } * f(x0 + i as f64 * h);
            }
            sum += s * h / 3.0;
        }
        sum
    }

    #[test]
    fn all_sky_mean_is_the_table() {
        let offset = model().ln_m(0.0, BRIGHT_MAG_LIMIT).exp(); // M(-1.5) sky mean, about 3e-5
        assert!(offset < 1e-4);
        for &(m, n) in &SKY_COUNTS {
            let mean = sky_mean(m);
            assert!(
                ((mean + offset) / n - 1.0).abs() < 1e-7,
                "all-sky mean at {m}: {mean} vs {n}"
            );
        }
        // between grid nodes too (0.1 mag interpolation of the normaliser)
        for m in [10.05, 12.35, 13.55, 16.25, 16.45] {
            let (mean, table) = (sky_mean(m), ln_sky_counts(m).exp());
            println!(
                "all-sky mean at {m}: relative deviation {:.2e}",
                mean / table - 1.0
            );
            assert!((mean / table - 1.0).abs() < 2e-5, "{mean} vs {table}");
        }
    }

    #[test]
    fn bahcall_soneira_checks() {
        let pole = cumulative_density_per_deg2(90.0, 16.5);
        assert!((pole - 255.0).abs() < 2.0, "{pole}");
        assert!((600.0..=2000.0).contains(&cumulative_density_per_deg2(30.0, 16.5)));
        assert!((1200.0..=5400.0).contains(&cumulative_density_per_deg2(-20.0, 16.5)));
        // bright end: the Gaia-shaped profile at V = 10 (pole : plane = g(90) : g(0))
        let ratio =
            cumulative_density_per_deg2(90.0, 10.0) / cumulative_density_per_deg2(0.0, 10.0);
        assert!((ratio - 0.40114311132169367 / 2.251111009181943).abs() < 1e-9);
    }

    #[test]
    fn cumulative_counts_are_monotone_in_magnitude() {
        for ib in 0..=180 {
            let b = ib as f64 * 0.5;
            assert_eq!(cumulative_density_per_deg2(b, BRIGHT_MAG_LIMIT), 0.0);
            assert_eq!(cumulative_density_per_deg2(b, -5.0), 0.0);
            let mut prev = 0.0;
            for im in 1..=400 {
                let m = BRIGHT_MAG_LIMIT + im as f64 * 0.05;
                let n = cumulative_density_per_deg2(b, m);
                assert!(n > prev, "N({b}, {m}) = {n} <= {prev}");
                prev = n;
            }
        }
        // the magnitude inverse CDF inverts the model
        let md = model();
        for b in [0.0f64, 17.0, 90.0] {
            let lg = md.g(b.to_radians().sin()).ln();
            for im in 0..=370 {
                let m = BRIGHT_MAG_LIMIT + im as f64 * 0.05;
                let back = md.mag_of_ln_m(lg, md.ln_m(lg, m));
                assert!((back - m).abs() < 1e-9, "{m} -> {back}");
            }
        }
    }
}
