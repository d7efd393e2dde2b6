//! Field stars: a deterministic procedural sky and real catalogs with proper motion.
//!
//! # Procedural sky
//!
//! The sphere is tiled into cells: declination bands of [`CELL_DEG`] height, band `j` covering
//! `[-90 + j h, -90 + (j + 1) h]`, each band cut in right ascension into
//! `max(1, round(360 cos(dec_mid) / h))` equal cells. Every cell has its own ChaCha12 stream
//! seeded by `sha256("soig-procedural-sky-v1" | seed | band | cell)` (little-endian integers), so a
//! cell's stars never depend on which cells are queried, or in what order, or on the magnitude limit
//! of the query: each cell always draws all its stars down to [`GENERATION_MAG_LIMIT`] and queries
//! filter afterwards. In a cell: a Poisson number of stars with mean
//! `N(b_c, 17) * cell solid angle` (`b_c`: galactic latitude of the cell centre), positions uniform on
//! the sphere within the cell (uniform in RA and in sin dec), magnitudes by inverse CDF of
//! `N(b_c, m)` over `[-1.5, 17]`.
//!
//! # Count model `N(b, m)` (stars per deg^2 brighter than `m`)
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
//!
//! # Catalogs
//!
//! [`StarCatalog`] reads Gaia archive, VizieR or plain CSV exports and moves the stars to the
//! observation epoch with Eq. 8 of the paper (linear in RA/Dec, RA rate = `pmra / cos dec`).

use std::fmt;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha12Rng;
use rand_distr::{Distribution, Poisson};
use sha2::{Digest, Sha256};

/// A star: ICRS position in degrees and magnitude.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Star {
    pub ra_deg: f64,
    pub dec_deg: f64,
    pub mag: f64,
}

// ---------------------------------------------------------------------------------------------
// Galactic coordinates
// ---------------------------------------------------------------------------------------------

/// ICRS -> galactic rotation as astropy composes it: the ICRS -> FK5 (J2000) frame bias, then
/// FK5 -> galactic with the pole (192.8594812065348, 27.12825118085622) and l(NCP) =
/// 122.9319185680026 deg. Printed by `tests/reference/stars_reference.py`; it differs from the rounded
/// Hipparcos matrix (ESA 1997, vol. 1, 1.5.3) by about 4e-8.
const ICRS_TO_GALACTIC: [[f64; 3]; 3] = [
    [
        -0.054_875_657_712_591_63,
        -0.873_437_051_955_615_9,
        -0.483_835_073_616_715_46,
    ],
    [
        0.494_109_437_192_726_8,
        -0.444_829_721_223_295_2,
        0.746_982_183_986_667_6,
    ],
    [
        -0.867_666_137_559_657_6,
        -0.198_076_337_273_000_53,
        0.455_983_813_687_301_6,
    ],
];

/// ICRS -> galactic (IAU 1958 / Hipparcos rotation matrix as astropy uses).
/// Returns `(l, b)` in degrees, `l` in `[0, 360)`, `b` in `[-90, 90]`.
pub fn equatorial_to_galactic(ra_deg: f64, dec_deg: f64) -> (f64, f64) {
    let v = unit_vector(ra_deg, dec_deg);
    let m = &ICRS_TO_GALACTIC;
    let g: [f64; 3] = std::array::from_fn(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2]);
    let l = normalize_ra(g[1].atan2(g[0]).to_degrees());
    let b = g[2].atan2(g[0].hypot(g[1])).to_degrees();
    (l, b)
}

fn unit_vector(ra_deg: f64, dec_deg: f64) -> [f64; 3] {
    let (sa, ca) = ra_deg.to_radians().sin_cos();
    let (sd, cd) = dec_deg.to_radians().sin_cos();
    [cd * ca, cd * sa, sd]
}

/// Wraps an angle into `[0, 360)`.
fn normalize_ra(ra: f64) -> f64 {
    let r = ra.rem_euclid(360.0);
    if r >= 360.0 { 0.0 } else { r }
}

/// Squared chord length between two unit vectors (monotone in the angular distance, accurate for
/// small angles, unlike `acos` of the dot product).
fn chord2(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
}

/// Squared chord of an angular radius; `None` for a radius that selects nothing.
fn chord2_of_radius(radius_deg: f64) -> Option<f64> {
    if radius_deg.is_nan() || radius_deg < 0.0 {
        return None;
    }
    if radius_deg >= 180.0 {
        return Some(4.0);
    }
    let c = 2.0 * (0.5 * radius_deg.to_radians()).sin();
    Some(c * c)
}

fn sort_stars(stars: &mut [Star]) {
    stars.sort_unstable_by(|a, b| {
        a.mag
            .total_cmp(&b.mag)
            .then(a.ra_deg.total_cmp(&b.ra_deg))
            .then(a.dec_deg.total_cmp(&b.dec_deg))
    });
}

// ---------------------------------------------------------------------------------------------
// Count model
// ---------------------------------------------------------------------------------------------

/// Bright end of the magnitude model: no star is brighter.
pub const BRIGHT_MAG_LIMIT: f64 = -1.5;
/// Every cell of the procedural sky is generated down to this magnitude.
pub const GENERATION_MAG_LIMIT: f64 = 17.0;
/// Exponent of the galactic latitude factor at V = 16.5 (1 at V <= 10, linear in between).
pub const ALPHA_FAINT: f64 = 2.36;
/// Height of the declination bands (and about the width of the cells) of the procedural sky.
pub const CELL_DEG: f64 = 0.1;
const N_BANDS: usize = 1800; // 180 / CELL_DEG
const SEED_TAG: &[u8] = b"soig-procedural-sky-v1";

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
struct Model {
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
    fn g(&self, x: f64) -> f64 {
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
    fn ln_m(&self, lg: f64, m: f64) -> f64 {
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
    fn mag_of_ln_m(&self, lg: f64, y: f64) -> f64 {
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

fn model() -> &'static Model {
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

// ---------------------------------------------------------------------------------------------
// Procedural sky
// ---------------------------------------------------------------------------------------------

/// A procedural sky: deterministic per region, the same sky gives the same stars in every image
/// and campaign.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ProceduralSky {
    seed: u64,
}

fn band_dec_edges(band: usize) -> (f64, f64) {
    (
        -90.0 + band as f64 * CELL_DEG,
        -90.0 + (band + 1) as f64 * CELL_DEG,
    )
}

fn cells_in_band(band: usize) -> usize {
    let (lo, hi) = band_dec_edges(band);
    let mid = 0.5 * (lo + hi);
    ((360.0 * mid.to_radians().cos() / CELL_DEG).round() as usize).max(1)
}

/// Angular distance (deg) from `centre` to the centre of a cell, and the cell's circumradius
/// about that centre (the largest distance to a corner: in a lat-lon cell that is the farthest
/// point).
fn cell_centre_and_radius(
    band: usize,
    cell: usize,
    n_cells: usize,
    centre: &[f64; 3],
) -> (f64, f64) {
    let (dec_lo, dec_hi) = band_dec_edges(band);
    let w = 360.0 / n_cells as f64;
    let (ra_lo, ra_hi) = (cell as f64 * w, (cell + 1) as f64 * w);
    let mid = unit_vector(0.5 * (ra_lo + ra_hi), 0.5 * (dec_lo + dec_hi));
    let angle =
        |a: &[f64; 3], b: &[f64; 3]| 2.0 * (0.5 * chord2(a, b).sqrt()).min(1.0).asin().to_degrees();
    let corners = [
        (ra_lo, dec_lo),
        (ra_hi, dec_lo),
        (ra_lo, dec_hi),
        (ra_hi, dec_hi),
    ];
    let radius = corners
        .iter()
        .map(|&(a, d)| angle(&mid, &unit_vector(a, d)))
        .fold(0.0, f64::max);
    (angle(centre, &mid), radius)
}

/// One cell's generator state: its random stream and magnitude model.
struct Cell {
    rng: ChaCha12Rng,
    count: u64,
    ra_lo: f64,
    ra_width: f64,
    s_lo: f64,
    s_width: f64,
    lg: f64,
    m_bright: f64,
    m_faint: f64,
}

impl Cell {
    /// Draws one star: (ra_deg, sin dec, magnitude uniform). The three draws are always made,
    /// so the stream does not depend on what the caller keeps.
    fn next_raw(&mut self) -> (f64, f64, f64) {
        let u: f64 = self.rng.random();
        let v: f64 = self.rng.random();
        let q: f64 = self.rng.random();
        let ra = (self.ra_lo + u * self.ra_width).min(self.ra_lo + self.ra_width);
        let s = (self.s_lo + v * self.s_width).clamp(-1.0, 1.0);
        (ra, s, q)
    }

    /// The magnitude uniform `q` at which `mag(q) == m` (clamped to [0, 1]).
    fn q_of_mag(&self, m: f64) -> f64 {
        if m >= GENERATION_MAG_LIMIT {
            return 1.0;
        }
        let mm = if m <= BRIGHT_MAG_LIMIT {
            self.m_bright
        } else {
            model().ln_m(self.lg, m).exp()
        };
        ((mm - self.m_bright) / (self.m_faint - self.m_bright)).clamp(0.0, 1.0)
    }

    fn mag(&self, q: f64) -> f64 {
        let target = self.m_bright + q * (self.m_faint - self.m_bright);
        model()
            .mag_of_ln_m(self.lg, target.ln())
            .min(GENERATION_MAG_LIMIT)
    }
}

impl ProceduralSky {
    pub fn new(seed: u64) -> Self {
        Self { seed }
    }

    fn cell(&self, band: usize, cell: usize, n_cells: usize) -> Cell {
        let mut h = Sha256::new();
        h.update(SEED_TAG);
        h.update(self.seed.to_le_bytes());
        h.update((band as u32).to_le_bytes());
        h.update((cell as u32).to_le_bytes());
        let key: [u8; 32] = h.finalize().into();
        let mut rng = ChaCha12Rng::from_seed(key);

        let (dec_lo, dec_hi) = band_dec_edges(band);
        let ra_width = 360.0 / n_cells as f64;
        let ra_lo = cell as f64 * ra_width;
        let s_lo = dec_lo.to_radians().sin();
        let s_hi = dec_hi.to_radians().sin();
        let (_, b) = equatorial_to_galactic(ra_lo + 0.5 * ra_width, 0.5 * (dec_lo + dec_hi));
        let md = model();
        let lg = md.g(b.abs().to_radians().sin()).ln();
        let m_bright = md.ln_m(lg, BRIGHT_MAG_LIMIT).exp();
        let m_faint = md.ln_m(lg, GENERATION_MAG_LIMIT).exp();
        let sr_to_deg2 = (180.0 / std::f64::consts::PI).powi(2);
        let area_deg2 = ra_width.to_radians() * (s_hi - s_lo) * sr_to_deg2;
        let mean = area_deg2 * (m_faint - m_bright);
        let count = match Poisson::new(mean) {
            Ok(p) => p.sample(&mut rng) as u64,
            Err(_) => 0,
        };
        Cell {
            rng,
            count,
            ra_lo,
            ra_width,
            s_lo,
            s_width: s_hi - s_lo,
            lg,
            m_bright,
            m_faint,
        }
    }

    /// Every star of one cell, in generation order (for tests and diagnostics).
    #[cfg(test)]
    fn cell_stars(&self, band: usize, cell: usize) -> Vec<Star> {
        let mut c = self.cell(band, cell, cells_in_band(band));
        (0..c.count)
            .map(|_| {
                let (ra, s, q) = c.next_raw();
                Star {
                    ra_deg: ra,
                    dec_deg: s.asin().to_degrees(),
                    mag: c.mag(q),
                }
            })
            .collect()
    }

    /// Visits the (band, cell, n_cells) triples that may hold stars within the cone.
    fn cells_for_cone(
        ra_deg: f64,
        dec_deg: f64,
        radius_deg: f64,
        mut f: impl FnMut(usize, usize, usize),
    ) {
        const EPS: f64 = 1e-7;
        let r = radius_deg.min(180.0);
        let band_of =
            |dec: f64| (((dec + 90.0) / CELL_DEG).floor().max(0.0) as usize).min(N_BANDS - 1);
        let j_lo = band_of(dec_deg - r - EPS);
        let j_hi = band_of(dec_deg + r + EPS);
        let half_width = if dec_deg + r >= 90.0 - EPS || dec_deg - r <= -90.0 + EPS {
            None
        } else {
            let s = r.to_radians().sin() / dec_deg.to_radians().cos();
            if s >= 1.0 {
                None
            } else {
                Some(s.asin().to_degrees() + EPS)
            }
        };
        for band in j_lo..=j_hi {
            let n = cells_in_band(band);
            let all = |f: &mut dyn FnMut(usize, usize, usize)| (0..n).for_each(|k| f(band, k, n));
            match half_width {
                None => all(&mut f),
                Some(hw) => {
                    let w = 360.0 / n as f64;
                    let k_lo = ((ra_deg - hw) / w).floor() as i64;
                    let k_hi = ((ra_deg + hw) / w).floor() as i64;
                    if k_hi - k_lo + 1 >= n as i64 {
                        all(&mut f);
                    } else {
                        for k in k_lo..=k_hi {
                            f(band, k.rem_euclid(n as i64) as usize, n);
                        }
                    }
                }
            }
        }
    }

    /// All stars with mag <= mag_max within radius_deg of (ra_deg, dec_deg), sorted by
    /// (mag, ra, dec) so order is deterministic.
    pub fn stars_in_cone(
        &self,
        ra_deg: f64,
        dec_deg: f64,
        radius_deg: f64,
        mag_max: f64,
    ) -> Vec<Star> {
        let mut out = Vec::new();
        let Some(max_chord2) = chord2_of_radius(radius_deg) else {
            return out;
        };
        if !ra_deg.is_finite() || !dec_deg.is_finite() || mag_max.is_nan() {
            return out;
        }
        let ra0 = normalize_ra(ra_deg);
        let dec0 = dec_deg.clamp(-90.0, 90.0);
        let centre = unit_vector(ra0, dec0);
        let r = radius_deg.min(180.0);
        Self::cells_for_cone(ra0, dec0, radius_deg, |band, k, n| {
            // Skip cells wholly outside the cone; take cells wholly inside without testing stars
            // (triangle inequality with the cell's circumradius, with a margin far above rounding).
            const MARGIN: f64 = 1e-9;
            let (centre_dist, circumradius) = cell_centre_and_radius(band, k, n, &centre);
            if centre_dist > r + circumradius + MARGIN {
                return;
            }
            let inside = centre_dist + circumradius < r - MARGIN;
            let mut c = self.cell(band, k, n);
            // magnitude is monotone in q: a cheap prefilter (with slack; the exact test follows)
            let q_max = c.q_of_mag(mag_max) + 1e-9;
            for _ in 0..c.count {
                let (ra, s, q) = c.next_raw();
                if q > q_max {
                    continue;
                }
                if !inside {
                    let cd = (1.0 - s * s).max(0.0).sqrt();
                    let (sa, ca) = ra.to_radians().sin_cos();
                    if chord2(&[cd * ca, cd * sa, s], &centre) > max_chord2 {
                        continue;
                    }
                }
                let mag = c.mag(q);
                if mag <= mag_max {
                    out.push(Star {
                        ra_deg: ra,
                        dec_deg: s.asin().to_degrees(),
                        mag,
                    });
                }
            }
        });
        sort_stars(&mut out);
        out
    }
}

// ---------------------------------------------------------------------------------------------
// Real catalogs
// ---------------------------------------------------------------------------------------------

/// Milliarcseconds per degree: the "conversion factor" of Eq. 8.
const MAS_PER_DEG: f64 = 3.6e6;

#[derive(Clone, Copy, Debug)]
struct CatalogStar {
    ra: f64,
    dec: f64,
    pmra: f64,
    pmdec: f64,
    mag: f64,
}

/// A real catalog read from CSV, as the Gaia archive (ra, dec, pmra, pmdec, phot_g_mean_mag) or
/// VizieR (RA_ICRS, DE_ICRS, pmRA, pmDE, Gmag) export it, or plain (ra, dec, pmra, pmdec, mag);
/// case-insensitive headers; empty proper motions count as 0; `#` comment lines allowed.
///
/// Positions in degrees at the catalog epoch, `pmra` = mu_alpha* = mu_alpha cos dec and `pmdec`
/// in mas/yr. Proper-motion columns may be absent (all zero); other columns are ignored.
#[derive(Clone, Debug)]
pub struct StarCatalog {
    epoch_jyear: f64,
    /// Sorted by catalog declination.
    stars: Vec<CatalogStar>,
    max_abs_pmdec: f64,
}

/// Errors reading a star catalog. Every error names the file (`<reader>` when read from a
/// reader), and where it applies the 1-based line and the column.
#[derive(thiserror::Error, Debug)]
pub enum CatalogError {
    #[error("cannot read star catalog {}: {source}", .path.display())]
    Open {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot read star catalog {}: {source}", FileLabel(.file))]
    Read {
        file: Option<PathBuf>,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: no header line", FileLabel(.file))]
    NoHeader { file: Option<PathBuf> },
    #[error("{}:{line}: header has no {field} column (accepted, any case: {accepted})", FileLabel(.file))]
    MissingColumn {
        file: Option<PathBuf>,
        line: u64,
        field: &'static str,
        accepted: String,
    },
    #[error("{}:{line}: columns `{first}` and `{second}` both name the {field}", FileLabel(.file))]
    AmbiguousColumn {
        file: Option<PathBuf>,
        line: u64,
        field: &'static str,
        first: String,
        second: String,
    },
    #[error("{}:{line}: column `{column}`: {problem} (value {value:?})", FileLabel(.file))]
    BadValue {
        file: Option<PathBuf>,
        line: u64,
        column: String,
        value: String,
        problem: &'static str,
    },
    #[error("{}:{line}: malformed CSV: {message}", FileLabel(.file))]
    Malformed {
        file: Option<PathBuf>,
        line: u64,
        message: String,
    },
    #[error("{}: catalog epoch {epoch} is not a finite Julian year", FileLabel(.file))]
    BadEpoch { file: Option<PathBuf>, epoch: f64 },
}

struct FileLabel<'a>(&'a Option<PathBuf>);

impl fmt::Display for FileLabel<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some(p) => write!(f, "{}", p.display()),
            None => f.write_str("<reader>"),
        }
    }
}

/// The input without comment (`#`) and blank lines, `\n`-terminated, with the original 1-based
/// line number of every kept line. (The csv crate miscounts lines after comments and CRLF.)
struct FilteredText {
    bytes: Vec<u8>,
    starts: Vec<usize>,
    lines: Vec<u64>,
}

impl FilteredText {
    fn new(raw: &[u8]) -> Self {
        let raw = raw.strip_prefix(b"\xef\xbb\xbf").unwrap_or(raw);
        let mut t = FilteredText {
            bytes: Vec::with_capacity(raw.len()),
            starts: Vec::new(),
            lines: Vec::new(),
        };
        for (i, line) in raw.split(|&c| c == b'\n').enumerate() {
            let line = line.strip_suffix(b"\r").unwrap_or(line);
            match line.iter().position(|c| !c.is_ascii_whitespace()) {
                None => continue,
                Some(k) if line[k] == b'#' => continue,
                Some(_) => {}
            }
            t.starts.push(t.bytes.len());
            t.lines.push(i as u64 + 1);
            t.bytes.extend_from_slice(line);
            t.bytes.push(b'\n');
        }
        t
    }

    /// Original line of the record whose csv position is `byte` (that position may point at the
    /// previous line's terminator).
    fn line_of(&self, byte: u64) -> u64 {
        let mut b = byte as usize;
        while b < self.bytes.len() && self.bytes[b] == b'\n' {
            b += 1;
        }
        let k = self.starts.partition_point(|&s| s <= b).saturating_sub(1);
        self.lines.get(k).copied().unwrap_or(0)
    }
}

/// Accepted header names (lower case) per field, and whether the field is required.
const COLUMNS: [(&str, &[&str], bool); 5] = [
    ("right ascension", &["ra", "ra_icrs"], true),
    ("declination", &["dec", "de_icrs"], true),
    ("RA proper motion", &["pmra"], false),
    ("Dec proper motion", &["pmdec", "pmde"], false),
    ("magnitude", &["phot_g_mean_mag", "gmag", "mag"], true),
];

impl StarCatalog {
    pub fn from_csv_path(path: &Path, epoch_jyear: f64) -> Result<Self, CatalogError> {
        let file = std::fs::File::open(path).map_err(|source| CatalogError::Open {
            path: path.to_path_buf(),
            source,
        })?;
        Self::read(
            std::io::BufReader::new(file),
            epoch_jyear,
            Some(path.to_path_buf()),
        )
    }

    pub fn from_reader<R: Read>(r: R, epoch_jyear: f64) -> Result<Self, CatalogError> {
        Self::read(r, epoch_jyear, None)
    }

    fn read<R: Read>(
        mut r: R,
        epoch_jyear: f64,
        file: Option<PathBuf>,
    ) -> Result<Self, CatalogError> {
        if !epoch_jyear.is_finite() {
            return Err(CatalogError::BadEpoch {
                file,
                epoch: epoch_jyear,
            });
        }
        let mut raw = Vec::new();
        r.read_to_end(&mut raw)
            .map_err(|source| CatalogError::Read {
                file: file.clone(),
                source,
            })?;
        let text = FilteredText::new(&raw);
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .trim(csv::Trim::All)
            .from_reader(&text.bytes[..]);
        let mut records = reader.records();
        let malformed = |e: csv::Error, file: &Option<PathBuf>| {
            let line = e.position().map_or(0, |p| text.line_of(p.byte()));
            let message = match e.kind() {
                csv::ErrorKind::UnequalLengths {
                    expected_len, len, ..
                } => {
                    format!("{len} fields where the header has {expected_len}")
                }
                csv::ErrorKind::Utf8 { err, .. } => {
                    format!("field {}: invalid UTF-8", err.field() + 1)
                }
                _ => e.to_string(),
            };
            CatalogError::Malformed {
                file: file.clone(),
                line,
                message,
            }
        };
        let header = match records.next() {
            None => return Err(CatalogError::NoHeader { file }),
            Some(Err(e)) => return Err(malformed(e, &file)),
            Some(Ok(h)) => h,
        };
        let line_of =
            |rec: &csv::StringRecord| rec.position().map_or(0, |p| text.line_of(p.byte()));
        let header_line = line_of(&header);
        let names: Vec<String> = header.iter().map(str::to_string).collect();
        let mut index: [Option<usize>; 5] = [None; 5];
        for (f, (field, aliases, required)) in COLUMNS.iter().enumerate() {
            for (i, name) in names.iter().enumerate() {
                if aliases.iter().any(|a| a.eq_ignore_ascii_case(name)) {
                    if let Some(prev) = index[f] {
                        return Err(CatalogError::AmbiguousColumn {
                            file,
                            line: header_line,
                            field,
                            first: names[prev].clone(),
                            second: name.clone(),
                        });
                    }
                    index[f] = Some(i);
                }
            }
            if *required && index[f].is_none() {
                return Err(CatalogError::MissingColumn {
                    file,
                    line: header_line,
                    field,
                    accepted: aliases.join(", "),
                });
            }
        }

        let mut stars = Vec::new();
        for rec in records {
            let rec = rec.map_err(|e| malformed(e, &file))?;
            let line = line_of(&rec);
            let mut values = [0.0f64; 5];
            for (f, idx) in index.iter().enumerate() {
                let Some(i) = *idx else { continue };
                let text = rec.get(i).unwrap_or("");
                let bad = |problem: &'static str| CatalogError::BadValue {
                    file: file.clone(),
                    line,
                    column: names[i].clone(),
                    value: text.to_string(),
                    problem,
                };
                let is_pm = f == 2 || f == 3;
                if text.is_empty() {
                    if is_pm {
                        continue;
                    }
                    return Err(bad("empty value"));
                }
                let v: f64 = text.parse().map_err(|_| bad("not a number"))?;
                if !v.is_finite() {
                    return Err(bad("not finite"));
                }
                let in_range = match f {
                    0 => (0.0..=360.0).contains(&v),
                    1 => (-90.0..=90.0).contains(&v),
                    _ => true,
                };
                if !in_range {
                    return Err(bad(if f == 0 {
                        "out of range [0, 360] deg"
                    } else {
                        "out of range [-90, 90] deg"
                    }));
                }
                values[f] = v;
            }
            let [ra, dec, pmra, pmdec, mag] = values;
            stars.push(CatalogStar {
                ra: normalize_ra(ra),
                dec,
                pmra,
                pmdec,
                mag,
            });
        }
        stars.sort_by(|a, b| a.dec.total_cmp(&b.dec));
        let max_abs_pmdec = stars.iter().fold(0.0f64, |m, s| m.max(s.pmdec.abs()));
        Ok(Self {
            epoch_jyear,
            stars,
            max_abs_pmdec,
        })
    }

    pub fn len(&self) -> usize {
        self.stars.len()
    }

    pub fn is_empty(&self) -> bool {
        self.stars.is_empty()
    }

    /// Catalog epoch (Julian year) the positions refer to.
    pub fn epoch_jyear(&self) -> f64 {
        self.epoch_jyear
    }

    /// Stars in the cone after proper motion to `at_jyear` (Eq. 8: RA rate divided by cos dec,
    /// pmra given as mu_alpha* in mas/yr), same order rule.
    pub fn stars_in_cone(
        &self,
        ra_deg: f64,
        dec_deg: f64,
        radius_deg: f64,
        mag_max: f64,
        at_jyear: f64,
    ) -> Vec<Star> {
        let mut out = Vec::new();
        let Some(max_chord2) = chord2_of_radius(radius_deg) else {
            return out;
        };
        if !ra_deg.is_finite() || !dec_deg.is_finite() || !at_jyear.is_finite() || mag_max.is_nan()
        {
            return out;
        }
        let dt = at_jyear - self.epoch_jyear;
        let centre = unit_vector(normalize_ra(ra_deg), dec_deg.clamp(-90.0, 90.0));
        // Eq. 8 moves dec by at most max|pmdec| dt (a pole crossing only folds it back), so only
        // stars whose catalog dec is that close to the cone's dec range can end up inside.
        let slack = self.max_abs_pmdec * dt.abs() / MAS_PER_DEG + 1e-9;
        let r = radius_deg.min(180.0);
        let lo = self.stars.partition_point(|s| s.dec < dec_deg - r - slack);
        let hi = self.stars.partition_point(|s| s.dec <= dec_deg + r + slack);
        for s in &self.stars[lo..hi.max(lo)] {
            if s.mag > mag_max {
                continue;
            }
            let (ra, dec) = apply_proper_motion(s.ra, s.dec, s.pmra, s.pmdec, dt);
            if chord2(&unit_vector(ra, dec), &centre) <= max_chord2 {
                out.push(Star {
                    ra_deg: ra,
                    dec_deg: dec,
                    mag: s.mag,
                });
            }
        }
        sort_stars(&mut out);
        out
    }
}

/// Eq. 8 of the paper: `RA = ra + pmra dt / (3.6e6 cos dec)`, `DEC = dec + pmdec dt / 3.6e6`
/// (degrees, mas/yr, years; `pmra` is mu_alpha*). A star exactly at a pole keeps its RA; a
/// declination carried past a pole is folded back (RA + 180). RA is wrapped into [0, 360).
fn apply_proper_motion(ra: f64, dec: f64, pmra: f64, pmdec: f64, dt_years: f64) -> (f64, f64) {
    let cos_dec = dec.to_radians().cos();
    let mut ra_new = if cos_dec > 1e-12 {
        ra + pmra * dt_years / (MAS_PER_DEG * cos_dec)
    } else {
        ra
    };
    let mut dec_new = dec + pmdec * dt_years / MAS_PER_DEG;
    if dec_new > 90.0 {
        dec_new = 180.0 - dec_new;
        ra_new += 180.0;
    } else if dec_new < -90.0 {
        dec_new = -180.0 - dec_new;
        ra_new += 180.0;
    }
    (normalize_ra(ra_new), dec_new)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Angular distance in degrees by the haversine formula (independent of the module's chords).
    fn separation_deg(ra1: f64, dec1: f64, ra2: f64, dec2: f64) -> f64 {
        let (p1, p2) = (dec1.to_radians(), dec2.to_radians());
        let dp = p2 - p1;
        let dl = (ra2 - ra1).to_radians();
        let a = (dp / 2.0).sin().powi(2) + p1.cos() * p2.cos() * (dl / 2.0).sin().powi(2);
        2.0 * a.sqrt().min(1.0).asin().to_degrees()
    }

    fn galactic_to_equatorial(l: f64, b: f64) -> (f64, f64) {
        let g = unit_vector(l, b);
        let m = &ICRS_TO_GALACTIC;
        let v: [f64; 3] = std::array::from_fn(|j| m[0][j] * g[0] + m[1][j] * g[1] + m[2][j] * g[2]);
        (
            normalize_ra(v[1].atan2(v[0]).to_degrees()),
            v[2].atan2(v[0].hypot(v[1])).to_degrees(),
        )
    }

    fn within(stars: &[Star], ra: f64, dec: f64, r: f64) -> Vec<Star> {
        let (c, max) = (unit_vector(ra, dec), chord2_of_radius(r).unwrap());
        stars
            .iter()
            .copied()
            .filter(|s| chord2(&unit_vector(s.ra_deg, s.dec_deg), &c) <= max)
            .collect()
    }

    // ----- galactic coordinates -------------------------------------------------------------

    /// (ra, dec, l, b) from tests/reference/stars_reference.py (astropy 8.0.2).
    const ASTROPY_GALACTIC: [(f64, f64, f64, f64); 12] = [
        (0.0, 0.0, 96.33728336969006, -60.188551946914465),
        (359.999999, 0.0, 96.33728152476306, -60.18855154848863),
        (0.0, 90.0, 122.93192525541662, 27.128252414968),
        (0.0, -90.0, 302.9319252554166, -27.12825241496801),
        (
            266.40499,
            -28.93617,
            7.406296754018056e-06,
            2.7642021878106933e-06,
        ),
        (192.85948, 27.12825, 340.73759881165375, 89.99999694344345),
        (123.4, -45.6, 261.7092969378496, -6.159936682658481),
        (359.99999999, 10.0, 102.62623650087524, -50.83256438208554),
        (0.0, 10.0, 102.62623651568119, -50.83256438517407),
        (180.0, 89.999, 122.93217532911345, 27.129227333589267),
        (45.0, -89.999, 302.9313274927996, -27.129099159583586),
        (300.0, 60.0, 93.24034002695457, 15.292488983097952),
    ];

    #[test]
    fn galactic_matches_astropy() {
        for &(ra, dec, l_ref, b_ref) in &ASTROPY_GALACTIC {
            let (l, b) = equatorial_to_galactic(ra, dec);
            assert!((0.0..360.0).contains(&l) && (-90.0..=90.0).contains(&b));
            let sep = separation_deg(l, b, l_ref, b_ref);
            assert!(
                sep < 1e-9,
                "({ra}, {dec}): ({l}, {b}) vs astropy ({l_ref}, {b_ref}), {sep:e} deg"
            );
            assert!((b - b_ref).abs() < 1e-9);
            if b_ref.abs() < 89.0 {
                let dl = (l - l_ref + 180.0).rem_euclid(360.0) - 180.0;
                assert!(dl.abs() < 1e-6, "({ra}, {dec}): l {l} vs {l_ref}");
            }
        }
        // RA 360 is RA 0
        let (a, b) = (
            equatorial_to_galactic(0.0, 10.0),
            equatorial_to_galactic(360.0, 10.0),
        );
        assert!(separation_deg(a.0, a.1, b.0, b.1) < 1e-12);
    }

    #[test]
    fn galactic_matrix_is_a_rotation() {
        let m = &ICRS_TO_GALACTIC;
        for i in 0..3 {
            for j in 0..3 {
                let dot: f64 = (0..3).map(|k| m[i][k] * m[j][k]).sum();
                assert!((dot - if i == j { 1.0 } else { 0.0 }).abs() < 1e-14);
            }
        }
        let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        assert!((det - 1.0).abs() < 1e-14);
    }

    // ----- count model ----------------------------------------------------------------------

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

    // ----- procedural sky: tiling and determinism --------------------------------------------

    #[test]
    fn tiling_covers_the_sphere() {
        assert_eq!(N_BANDS as f64 * CELL_DEG, 180.0);
        assert_eq!(band_dec_edges(N_BANDS - 1).1, 90.0);
        assert_eq!(cells_in_band(0), 3);
        assert_eq!(cells_in_band(N_BANDS - 1), 3);
        assert_eq!(cells_in_band(N_BANDS / 2), 3600);
        let sr: f64 = (0..N_BANDS)
            .map(|j| {
                let (lo, hi) = band_dec_edges(j);
                let n = cells_in_band(j) as f64;
                n * (2.0 * std::f64::consts::PI / n)
                    * (hi.to_radians().sin() - lo.to_radians().sin())
            })
            .sum();
        assert!((sr - 4.0 * std::f64::consts::PI).abs() < 1e-9);
        // stars stay inside their cell
        let sky = ProceduralSky::new(5);
        for band in [0, 1, 700, 900, N_BANDS - 1] {
            let n = cells_in_band(band);
            let (lo, hi) = band_dec_edges(band);
            for cell in [0, n / 2, n - 1] {
                let w = 360.0 / n as f64;
                for s in sky.cell_stars(band, cell) {
                    assert!(s.ra_deg >= cell as f64 * w && s.ra_deg <= (cell + 1) as f64 * w);
                    assert!(
                        s.dec_deg >= lo - 1e-9 && s.dec_deg <= hi + 1e-9,
                        "{s:?} not in [{lo}, {hi}]"
                    );
                    assert!(s.mag >= BRIGHT_MAG_LIMIT && s.mag <= GENERATION_MAG_LIMIT);
                }
            }
        }
    }

    #[test]
    fn same_query_same_stars() {
        let a = ProceduralSky::new(7).stars_in_cone(83.8, -5.4, 0.15, 16.5);
        let b = ProceduralSky::new(7).stars_in_cone(83.8, -5.4, 0.15, 16.5);
        assert!(!a.is_empty());
        assert_eq!(a, b);
        let c = ProceduralSky::new(8).stars_in_cone(83.8, -5.4, 0.15, 16.5);
        assert_ne!(a, c);
        for w in a.windows(2) {
            assert!((w[0].mag, w[0].ra_deg, w[0].dec_deg) <= (w[1].mag, w[1].ra_deg, w[1].dec_deg));
        }
        for s in &a {
            assert!(
                separation_deg(s.ra_deg, s.dec_deg, 83.8, -5.4) <= 0.15 + 1e-12 && s.mag <= 16.5
            );
        }
    }

    #[test]
    fn query_order_and_magnitude_limit_do_not_change_the_sky() {
        let sky = ProceduralSky::new(11);
        let q = [(10.0, 20.0, 0.3), (10.2, 20.1, 0.2), (250.0, -60.0, 0.25)];
        let forward: Vec<_> = q
            .iter()
            .map(|&(a, d, r)| sky.stars_in_cone(a, d, r, 16.5))
            .collect();
        let mut backward: Vec<_> = q
            .iter()
            .rev()
            .map(|&(a, d, r)| sky.stars_in_cone(a, d, r, 16.5))
            .collect();
        backward.reverse();
        assert_eq!(forward, backward);
        let faint = sky.stars_in_cone(10.0, 20.0, 0.3, 17.0);
        for mag_max in [6.0, 12.0, 14.5, 16.5] {
            let bright: Vec<Star> = faint.iter().copied().filter(|s| s.mag <= mag_max).collect();
            assert_eq!(sky.stars_in_cone(10.0, 20.0, 0.3, mag_max), bright);
        }
    }

    #[test]
    fn overlapping_cones_agree_where_they_overlap() {
        let sky = ProceduralSky::new(3);
        let (a, b, r) = ((120.0, 33.0), (120.17, 33.08), 0.15);
        let sa = sky.stars_in_cone(a.0, a.1, r, 17.0);
        let sb = sky.stars_in_cone(b.0, b.1, r, 17.0);
        let ab = within(&sa, b.0, b.1, r);
        assert!(ab.len() > 10, "{}", ab.len());
        assert_eq!(ab, within(&sb, a.0, a.1, r));
    }

    /// A cone query returns exactly the stars of a larger concentric query inside its radius, at
    /// random places including the poles and RA 0/360: the cell selection misses nothing.
    #[test]
    fn cone_is_the_restriction_of_a_larger_cone() {
        let sky = ProceduralSky::new(2024);
        let mut rng = ChaCha12Rng::seed_from_u64(1);
        let mut places: Vec<(f64, f64)> = vec![
            (0.0, 0.0),
            (359.99, 0.0),
            (0.01, 45.0),
            (0.0, 89.99),
            (180.0, -89.99),
            (10.0, 90.0),
            (0.0, -90.0),
        ];
        for _ in 0..25 {
            places.push((
                rng.random::<f64>() * 360.0,
                (2.0 * rng.random::<f64>() - 1.0).asin().to_degrees(),
            ));
        }
        for (ra, dec) in places {
            let big = sky.stars_in_cone(ra, dec, 0.4, 15.0);
            for r in [0.05, 0.15, 0.3] {
                let small = sky.stars_in_cone(ra, dec, r, 15.0);
                assert_eq!(small, within(&big, ra, dec, r), "({ra}, {dec}) r {r}");
            }
        }
    }

    #[test]
    fn ra_wrap_and_poles() {
        let sky = ProceduralSky::new(9);
        let wrap = sky.stars_in_cone(0.05, 5.0, 0.3, 17.0);
        assert!(wrap.iter().any(|s| s.ra_deg > 359.0) && wrap.iter().any(|s| s.ra_deg < 1.0));
        assert_eq!(wrap, sky.stars_in_cone(360.05, 5.0, 0.3, 17.0));
        assert_eq!(wrap, sky.stars_in_cone(-359.95, 5.0, 0.3, 17.0));
        let other = sky.stars_in_cone(359.9, 5.0, 0.3, 17.0);
        assert_eq!(
            within(&wrap, 359.9, 5.0, 0.3),
            within(&other, 0.05, 5.0, 0.3)
        );
        for s in &wrap {
            assert!((0.0..360.0).contains(&s.ra_deg));
        }
        for dec in [89.99, -89.99] {
            let stars = sky.stars_in_cone(123.0, dec, 0.15, 17.0);
            assert!(stars.len() > 5);
            let quadrants: std::collections::BTreeSet<u32> =
                stars.iter().map(|s| (s.ra_deg / 90.0) as u32).collect();
            assert_eq!(quadrants.len(), 4, "a cone around the pole spans all RA");
            for s in &stars {
                assert!(separation_deg(s.ra_deg, s.dec_deg, 123.0, dec) <= 0.15 + 1e-9);
            }
            let pole = sky.stars_in_cone(0.0, dec.signum() * 90.0, 0.2, 17.0);
            assert_eq!(stars, within(&pole, 123.0, dec, 0.15));
        }
        assert!(sky.stars_in_cone(1.0, 1.0, -1.0, 17.0).is_empty());
        assert!(sky.stars_in_cone(f64::NAN, 1.0, 0.1, 17.0).is_empty());
    }

    /// Regression pin (values produced by this code; they change only if the generator, the count
    /// model or the random streams of rand_chacha / rand_distr change).
    #[test]
    fn pinned_sky() {
        let stars = ProceduralSky::new(42).stars_in_cone(10.0, 20.0, 0.15, 16.5);
        let first = stars[0];
        println!("{} stars, first {:?}", stars.len(), first);
        assert_eq!(stars.len(), PINNED_COUNT);
        assert_eq!((first.ra_deg, first.dec_deg, first.mag), PINNED_FIRST);
    }
    const PINNED_COUNT: usize = 66;
    const PINNED_FIRST: (f64, f64, f64) =
        (10.074086009249779, 19.926618792671242, 10.917027913866882);

    // ----- procedural sky: statistics -----------------------------------------------------------

    /// Model expectation of the number of stars with mag <= m in a cone (polar midpoint rule).
    fn expected_in_cone(ra: f64, dec: f64, r: f64, m: f64) -> f64 {
        let (nr, nphi) = (24, 48);
        let c = unit_vector(ra, dec);
        // orthonormal basis around c
        let e1 = {
            let t = if c[2].abs() < 0.9 {
                [0.0, 0.0, 1.0]
            } else {
                [1.0, 0.0, 0.0]
            };
            let d = t[0] * c[0] + t[1] * c[1] + t[2] * c[2];
            let v = [t[0] - d * c[0], t[1] - d * c[1], t[2] - d * c[2]];
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            [v[0] / n, v[1] / n, v[2] / n]
        };
        let e2 = [
            c[1] * e1[2] - c[2] * e1[1],
            c[2] * e1[0] - c[0] * e1[2],
            c[0] * e1[1] - c[1] * e1[0],
        ];
        let r_rad = r.to_radians();
        let mut sum = 0.0;
        for i in 0..nr {
            let rho = (i as f64 + 0.5) / nr as f64 * r_rad;
            for k in 0..nphi {
                let phi = (k as f64 + 0.5) / nphi as f64 * 2.0 * std::f64::consts::PI;
                let (sr, cr) = rho.sin_cos();
                let v: [f64; 3] = std::array::from_fn(|j| {
                    cr * c[j] + sr * (phi.cos() * e1[j] + phi.sin() * e2[j])
                });
                let (a, d) = (v[1].atan2(v[0]).to_degrees(), v[2].asin().to_degrees());
                let (_, b) = equatorial_to_galactic(a, d);
                sum += cumulative_density_per_deg2(b, m) * sr;
            }
        }
        sum * (r_rad / nr as f64)
            * (2.0 * std::f64::consts::PI / nphi as f64)
            * (180.0 / std::f64::consts::PI).powi(2)
    }

    /// Non-overlapping 1 deg^2 patches at random places with |b| in [b_lo, b_hi].
    fn patches(n: usize, b_lo: f64, b_hi: f64, r: f64, seed: u64) -> Vec<(f64, f64)> {
        let mut rng = ChaCha12Rng::seed_from_u64(seed);
        let (s_lo, s_hi) = (b_lo.to_radians().sin(), b_hi.to_radians().sin());
        let mut out: Vec<(f64, f64)> = Vec::new();
        while out.len() < n {
            let l = rng.random::<f64>() * 360.0;
            let b = (s_lo + rng.random::<f64>() * (s_hi - s_lo))
                .asin()
                .to_degrees();
            let b = if rng.random::<bool>() { b } else { -b };
            let (ra, dec) = galactic_to_equatorial(l, b);
            if out
                .iter()
                .all(|&(a, d)| separation_deg(a, d, ra, dec) > 2.0 * r + 0.01)
            {
                out.push((ra, dec));
            }
        }
        out
    }

    /// Total counts against the model: the sum over disjoint patches is Poisson with mean
    /// sum(lambda_i), so |S - L| <= 5 sqrt(L) (two-sided p = 6e-7); the dispersion
    /// sum((n_i - lambda_i)^2 / lambda_i) is chi-square with n degrees of freedom:
    /// within n +/- 5 sqrt(2n).
    fn check_counts(label: &str, b_lo: f64, b_hi: f64, n_patches: usize, mags: &[f64]) {
        let sky = ProceduralSky::new(77);
        let r = (1.0 - (std::f64::consts::PI / 180.0).powi(2) / (2.0 * std::f64::consts::PI))
            .acos()
            .to_degrees();
        let places = patches(n_patches, b_lo, b_hi, r, 5);
        for &m in mags {
            let (mut s, mut lam, mut chi2) = (0.0, 0.0, 0.0);
            for &(ra, dec) in &places {
                let n = sky.stars_in_cone(ra, dec, r, m).len() as f64;
                let l = expected_in_cone(ra, dec, r, m);
                s += n;
                lam += l;
                chi2 += (n - l).powi(2) / l;
            }
            let k = n_patches as f64;
            println!(
                "{label} mag<={m}: {s} stars, model {lam:.1}, z = {:.2}, chi2/dof = {:.3}",
                (s - lam) / lam.sqrt(),
                chi2 / k
            );
            assert!(
                (s - lam).abs() <= 5.0 * lam.sqrt(),
                "{label} mag {m}: {s} vs {lam}"
            );
            assert!(
                (chi2 - k).abs() <= 5.0 * (2.0 * k).sqrt(),
                "{label} mag {m}: chi2 {chi2} for {k} patches"
            );
        }
    }

    #[test]
    fn counts_at_high_latitude_match_the_model() {
        check_counts("|b| 60-90", 60.0, 90.0, 80, &[12.0, 16.5]);
    }

    #[test]
    fn counts_at_low_latitude_match_the_model() {
        check_counts("|b| 0-10", 0.0, 10.0, 16, &[12.0, 16.5]);
    }

    /// The magnitudes drawn follow the model CDF (Kolmogorov-Smirnov at alpha = 0.001 on a 0.05 mag
    /// grid), and the per-magnitude histogram grows monotonically.
    #[test]
    fn magnitude_distribution() {
        let sky = ProceduralSky::new(123);
        let (ra, dec) = galactic_to_equatorial(0.0, 90.0);
        let r = 2.0;
        let stars = sky.stars_in_cone(ra, dec, r, GENERATION_MAG_LIMIT);
        let n = stars.len() as f64;
        let total = expected_in_cone(ra, dec, r, GENERATION_MAG_LIMIT);
        assert!((n - total).abs() < 5.0 * total.sqrt());
        let mut d_max: f64 = 0.0;
        for im in 0..=370 {
            let m = BRIGHT_MAG_LIMIT + im as f64 * 0.05;
            let emp = stars.partition_point(|s| s.mag <= m) as f64 / n;
            let model = expected_in_cone(ra, dec, r, m) / total;
            d_max = d_max.max((emp - model).abs());
        }
        println!("KS distance {d_max:.4} for {n} stars");
        assert!(d_max < 1.95 / n.sqrt(), "KS {d_max}");
        let mut hist = [0usize; 17];
        for s in &stars {
            hist[(s.mag.max(0.0) as usize).min(16)] += 1;
        }
        println!("per-magnitude counts {hist:?}");
        for m in 9..16 {
            assert!(hist[m + 1] > hist[m], "{hist:?}");
        }
    }

    // ----- catalogs -----------------------------------------------------------------------------

    const BARNARD: (f64, f64, f64, f64) =
        (269.44850252543836, 4.739420051112412, -801.551, 10362.394);

    fn cat(text: &str) -> Result<StarCatalog, CatalogError> {
        StarCatalog::from_reader(text.as_bytes(), 2016.0)
    }

    #[test]
    fn parses_the_three_header_styles() {
        let gaia = "# Gaia archive export\nsource_id,ra,dec,pmra,pmdec,phot_g_mean_mag\n\
                    1,10.0,20.0,1.5,-2.5,12.25\n2,10.01,20.01,,,9.5\n";
        let vizier = "RA_ICRS,DE_ICRS,Source,pmRA,pmDE,Gmag\n10.0,20.0,1,1.5,-2.5,12.25\n10.01,20.01,2,,,9.5\n";
        let plain =
            "RA, DEC ,PMRA,PMDEC,MAG\n# comment\n 10.0 ,20.0,1.5,-2.5,12.25\n10.01,20.01,,,9.5\n";
        let nopm = "ra,dec,mag\n10.0,20.0,12.25\n10.01,20.01,9.5\n";
        let mut results = Vec::new();
        for text in [gaia, vizier, plain, nopm] {
            let c = cat(text).unwrap();
            assert_eq!(c.len(), 2);
            assert!(!c.is_empty());
            results.push(c.stars_in_cone(10.0, 20.0, 1.0, 20.0, 2016.0));
        }
        let expected = vec![
            Star {
                ra_deg: 10.01,
                dec_deg: 20.01,
                mag: 9.5,
            },
            Star {
                ra_deg: 10.0,
                dec_deg: 20.0,
                mag: 12.25,
            },
        ];
        for r in &results {
            assert_eq!(r, &expected);
        }
        // proper motion applies only where given
        let moved = cat(gaia)
            .unwrap()
            .stars_in_cone(10.0, 20.0, 1.0, 20.0, 2116.0);
        assert_eq!(moved[0], expected[0]);
        assert!((moved[1].dec_deg - (20.0 - 2.5 * 100.0 / 3.6e6)).abs() < 1e-12);
        assert!(cat("ra,dec,mag\n").unwrap().is_empty());
    }

    /// Barnard's star, Gaia DR3, 2016.0 -> 2022.5 (6.5 yr) by Eq. 8; reference figures from
    /// tests/reference/stars_reference.py (astropy's rigorous motion differs by 0.14 mas).
    #[test]
    fn proper_motion_is_eq_8() {
        let (ra, dec, pmra, pmdec) = BARNARD;
        let text = format!("ra,dec,pmra,pmdec,phot_g_mean_mag\n{ra},{dec},{pmra},{pmdec},8.19\n");
        let c = cat(&text).unwrap();
        let (ra1, dec1) = (269.4470503151456, 4.758129929167968);
        let s = c.stars_in_cone(ra1, dec1, 1e-4, 10.0, 2022.5);
        assert_eq!(s.len(), 1);
        assert!(
            (s[0].ra_deg - ra1).abs() < 1e-11 && (s[0].dec_deg - dec1).abs() < 1e-11,
            "{s:?}"
        );
        // it moved 67 arcsec: no longer at its 2016 place, and still there at 2016
        assert!(c.stars_in_cone(ra, dec, 0.01, 10.0, 2022.5).is_empty());
        assert_eq!(c.stars_in_cone(ra, dec, 1e-6, 10.0, 2016.0).len(), 1);
        // RA wrap backwards through 0 at dec 80 (reference figure from the script)
        let (r2, d2) = apply_proper_motion(0.001, 80.0, -5000.0, -2000.0, 10.0);
        assert!((r2 - 359.921017076623).abs() < 1e-11 && (d2 - 79.99444444444444).abs() < 1e-12);
        // pole crossing folds back
        let (r3, d3) = apply_proper_motion(10.0, 89.9999, 0.0, 1000.0, 1.0);
        assert!(
            (r3 - 190.0).abs() < 1e-12
                && (d3 - (90.0 - (89.9999 + 1.0 / 3600.0 - 90.0))).abs() < 1e-9
        );
        // a catalog cone query finds a fast star after it moved into the cone
        let c = cat("ra,dec,pmra,pmdec,mag\n10.0,-30.0,0,36000,5\n").unwrap();
        assert_eq!(c.stars_in_cone(10.0, -29.9, 0.001, 6.0, 2026.0).len(), 1);
        assert!(c.stars_in_cone(10.0, -29.9, 0.001, 4.0, 2026.0).is_empty());
    }

    fn err_text(text: &str) -> String {
        cat(text).unwrap_err().to_string()
    }

    #[test]
    fn malformed_rows_name_line_and_field() {
        let e = err_text("# c1\n# c2\nra,dec,pmra,pmdec,mag\n1,2,3,4,5\n1,2,x3,4,5\n");
        assert!(
            e.contains("<reader>:5:") && e.contains("`pmra`") && e.contains("x3"),
            "{e}"
        );
        let e = err_text("ra,dec,pmra,pmdec,phot_g_mean_mag\n1,2,3,4,5\n1,2,3,4,\n");
        assert!(
            e.contains(":3:") && e.contains("`phot_g_mean_mag`") && e.contains("empty"),
            "{e}"
        );
        let e = err_text("RA_ICRS,DE_ICRS,pmRA,pmDE,Gmag\n1,95,3,4,5\n");
        assert!(
            e.contains(":2:") && e.contains("`DE_ICRS`") && e.contains("range"),
            "{e}"
        );
        let e = err_text("ra,dec,mag\n1,2,3\n# note\n1,2\n");
        assert!(e.contains(":4:") && e.contains("2 fields"), "{e}");
        let e = err_text("\u{feff}ra,dec,mag\r\n1,2,3\r\n\r\n#x\r\n  # y\r\n1,2\r\n");
        assert!(e.contains("<reader>:6:") && e.contains("2 fields"), "{e}");
        let e = err_text("\n\nra,dec,mag\r\n1,2,3\r\n1,2,3,4\r\n");
        assert!(e.contains("<reader>:5:") && e.contains("4 fields"), "{e}");
        let e = err_text("ra,dec,mag\n1,2,3\n\n\n\"1\",\"x\n\",3\n");
        assert!(e.contains("<reader>:5:") && e.contains("`dec`"), "{e}");
        let e = err_text("ra,dec,mag\n1,2,NaN\n");
        assert!(
            e.contains(":2:") && e.contains("`mag`") && e.contains("finite"),
            "{e}"
        );
        let e = err_text("# only\nra,dec,pmra,pmdec\n1,2,3,4\n");
        assert!(
            e.contains(":2:") && e.contains("magnitude") && e.contains("gmag"),
            "{e}"
        );
        let e = err_text("ra,dec,gmag,mag\n");
        assert!(
            e.contains(":1:") && e.contains("`gmag`") && e.contains("`mag`"),
            "{e}"
        );
        assert!(err_text("").contains("no header"));
        assert!(err_text("# nothing\n").contains("no header"));
    }

    #[test]
    fn files_are_named_in_errors() {
        let missing = Path::new("/nonexistent/dir/gaia-cone.csv");
        let e = StarCatalog::from_csv_path(missing, 2016.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("/nonexistent/dir/gaia-cone.csv"), "{e}");
        let dir = std::env::temp_dir().join(format!("soig-stars-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("bad.csv");
        std::fs::write(&path, "ra,dec,mag\n1,2,3\n1,abc,3\n").unwrap();
        let e = StarCatalog::from_csv_path(&path, 2016.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with(&format!("{}:3:", path.display())) && e.contains("`dec`"),
            "{e}"
        );
        std::fs::write(&path, "ra,dec,mag\n1,2,3\n").unwrap();
        assert_eq!(StarCatalog::from_csv_path(&path, 2016.0).unwrap().len(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// The same statistics with 200 patches per latitude range and three magnitudes (slow in a
    /// debug build: `cargo test --release -- --ignored --nocapture many_patches`).
    #[test]
    #[ignore]
    fn counts_in_many_patches() {
        check_counts("|b| 0-10", 0.0, 10.0, 200, &[12.0, 14.0, 16.5]);
        check_counts("|b| 20-40", 20.0, 40.0, 200, &[12.0, 14.0, 16.5]);
    }

    /// Timing of the typical query (run with
    /// `cargo test --release -- --ignored --nocapture timing`).
    #[test]
    #[ignore]
    fn timing_stars_in_cone() {
        let sky = ProceduralSky::new(1);
        let _ = cumulative_density_per_deg2(0.0, 10.0); // build the model
        let mut rng = ChaCha12Rng::seed_from_u64(2);
        for (label, b_lo, b_hi) in [
            ("all sky", -90.0, 90.0),
            ("|b|<5", -5.0, 5.0),
            ("|b|>60", 60.0, 90.0),
        ] {
            let (s_lo, s_hi) = (
                f64::sin(f64::to_radians(b_lo)),
                f64::sin(f64::to_radians(b_hi)),
            );
            let places: Vec<(f64, f64)> = (0..2000)
                .map(|_| {
                    let b = (s_lo + rng.random::<f64>() * (s_hi - s_lo))
                        .asin()
                        .to_degrees();
                    let b = if label == "|b|>60" && rng.random::<bool>() {
                        -b
                    } else {
                        b
                    };
                    galactic_to_equatorial(rng.random::<f64>() * 360.0, b)
                })
                .collect();
            // best of 7 passes (the machine is shared)
            let mut per = f64::INFINITY;
            let mut n = 0;
            for _ in 0..7 {
                let t = std::time::Instant::now();
                n = 0;
                for &(ra, dec) in &places {
                    n += sky.stars_in_cone(ra, dec, 0.15, 16.5).len();
                }
                per = per.min(t.elapsed().as_secs_f64() / places.len() as f64);
            }
            println!(
                "{label}: {:.1} us per stars_in_cone(r=0.15, mag<=16.5), {:.0} stars",
                per * 1e6,
                n as f64 / places.len() as f64
            );
        }
    }
}
