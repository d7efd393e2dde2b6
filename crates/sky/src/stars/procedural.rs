//! The procedural sky: a deterministic star field drawn cell by cell from the count model.
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

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha12Rng;
use rand_distr::{Distribution, Poisson};
use sha2::{Digest, Sha256};

use super::counts::{BRIGHT_MAG_LIMIT, GENERATION_MAG_LIMIT, model};
use super::{Star, chord2, cone, equatorial_to_galactic, normalize_ra, sort_stars};
use crate::radec_unit;

/// Height of the declination bands (and about the width of the cells) of the procedural sky.
pub const CELL_DEG: f64 = 0.1;
const N_BANDS: usize = 1800; // 180 / CELL_DEG
const SEED_TAG: &[u8] = b"soig-procedural-sky-v1";

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
    let mid = radec_unit(0.5 * (ra_lo + ra_hi), 0.5 * (dec_lo + dec_hi));
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
        .map(|&(a, d)| angle(&mid, &radec_unit(a, d)))
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
        let Some((centre, max_chord2)) = cone(ra_deg, dec_deg, radius_deg, mag_max) else {
            return out;
        };
        let ra0 = normalize_ra(ra_deg);
        let dec0 = dec_deg.clamp(-90.0, 90.0);
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

#[cfg(test)]
mod tests {
    use super::super::counts::cumulative_density_per_deg2;
    use super::super::galactic::galactic_to_equatorial;
    use super::super::{chord2_of_radius, separation_deg};
    use super::*;
    use crate::{cross, dot, norm, scale, sub};

    fn within(stars: &[Star], ra: f64, dec: f64, r: f64) -> Vec<Star> {
        let (c, max) = (radec_unit(ra, dec), chord2_of_radius(r).unwrap());
        stars
            .iter()
            .copied()
            .filter(|s| chord2(&radec_unit(s.ra_deg, s.dec_deg), &c) <= max)
            .collect()
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
        let c = radec_unit(ra, dec);
        // orthonormal basis around c
        let e1 = {
            let t = if c[2].abs() < 0.9 {
                [0.0, 0.0, 1.0]
            } else {
                [1.0, 0.0, 0.0]
            };
            let v = sub(t, scale(c, dot(t, c)));
            let n = norm(v);
            v.map(|x| x / n)
        };
        let e2 = cross(c, e1);
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
