//! Debris sizes and albedos from published models, for the `photometry.preset`s that replace
//! the paper's (area |N(0.956, 2.291)| m^2, albedo 1: GEO debris of magnitude ~12, far brighter
//! than observed debris).
//!
//! - Size: the NASA Standard Breakup Model (N. L. Johnson, P. H. Krisko, J.-C. Liou,
//!   P. D. Anz-Meador, "NASA's new breakup model of EVOLVE 4.0", Advances in Space Research
//!   28(9), 1377-1384, 2001): fragments' characteristic length Lc follows a power law,
//!   N(> Lc) proportional to Lc^-1.71 for collisions (Lc^-1.6 for explosions), and their average
//!   cross-section is A = 0.556945 Lc^2.0047077 m^2 (Lc in m, above 1.67 mm).
//! - Albedo: 0.175, the value NASA's Orbital Debris Program Office applies to optical
//!   brightness to recover fragmentation debris' size (M. Mulrooney, M. Matney et al., 2008,
//!   revising the 0.13 of "A new Bond albedo for performing orbital debris brightness to size
//!   transformations", IAC-08.A6.2.7, with a Lambertian phase function as Eq. 7's).

use rand::RngExt;
use rand_chacha::ChaCha12Rng;

/// NASA SBM's collision exponent of the cumulative characteristic-length distribution.
pub const SBM_COLLISION_EXPONENT: f64 = 1.71;
/// NASA ODPO's transformational albedo for fragmentation debris.
pub const ODPO_ALBEDO: f64 = 0.175;

/// NASA SBM's average cross-section of a fragment of characteristic length `lc_m` (> 1.67 mm).
pub fn sbm_area_m2(lc_m: f64) -> f64 {
    0.556945 * lc_m.powf(2.0047077)
}

/// The characteristic length at quantile `u` in [0, 1) of the power law N(> Lc) ~ Lc^-a
/// truncated to [min, max]: the inverse of F(L) = (min^-a - L^-a) / (min^-a - max^-a).
pub fn power_law_quantile(u: f64, min: f64, max: f64, a: f64) -> f64 {
    let (lo, hi) = (min.powf(-a), max.powf(-a));
    (lo - u * (lo - hi)).powf(-1.0 / a)
}

/// How a scene draws its debris' area.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AreaModel {
    /// The paper's |N(mean, std)| m^2.
    Normal { mean_m2: f64, std_m2: f64 },
    /// NASA SBM: Lc from the truncated power law, then A(Lc).
    Breakup {
        lc_min_m: f64,
        lc_max_m: f64,
        exponent: f64,
    },
}

impl AreaModel {
    /// One area, m^2 (the paper's model takes one normal draw, as before the presets).
    pub fn draw(&self, rng: &mut ChaCha12Rng) -> f64 {
        use rand_distr::{Distribution, Normal};
        match *self {
            AreaModel::Normal { mean_m2, std_m2 } => Normal::new(mean_m2, std_m2)
                .expect("validated std")
                .sample(rng)
                .abs(),
            AreaModel::Breakup {
                lc_min_m,
                lc_max_m,
                exponent,
            } => sbm_area_m2(power_law_quantile(
                rng.random::<f64>(),
                lc_min_m,
                lc_max_m,
                exponent,
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn quantiles_span_the_range_and_follow_the_power_law() {
        let (min, max, a) = (0.1, 1.0, SBM_COLLISION_EXPONENT);
        assert!((power_law_quantile(0.0, min, max, a) - min).abs() < 1e-12);
        assert!((power_law_quantile(1.0, min, max, a) - max).abs() < 1e-12);
        // N(> L) / N(> min) = (L^-a - max^-a) / (min^-a - max^-a) at L = the median.
        let m = power_law_quantile(0.5, min, max, a);
        let share = (m.powf(-a) - max.powf(-a)) / (min.powf(-a) - max.powf(-a));
        assert!((share - 0.5).abs() < 1e-12, "{share}");
        // Johnson et al.'s area of a 1 m fragment.
        assert!((sbm_area_m2(1.0) - 0.556945).abs() < 1e-12);
    }

    #[test]
    fn breakup_draws_lie_between_the_areas_of_the_size_range() {
        let model = AreaModel::Breakup {
            lc_min_m: 0.1,
            lc_max_m: 1.0,
            exponent: SBM_COLLISION_EXPONENT,
        };
        let mut rng = ChaCha12Rng::seed_from_u64(1);
        let draws: Vec<f64> = (0..10_000).map(|_| model.draw(&mut rng)).collect();
        let (lo, hi) = (sbm_area_m2(0.1), sbm_area_m2(1.0));
        assert!(draws.iter().all(|&a| a >= lo && a <= hi));
        // Half the draws below the median's area: 10 000 Bernoulli(1/2) draws have a standard
        // deviation of 50, so 5000 +- 300 is six of them.
        let median = sbm_area_m2(power_law_quantile(0.5, 0.1, 1.0, SBM_COLLISION_EXPONENT));
        let below = draws.iter().filter(|&&a| a < median).count();
        assert!((below as i64 - 5000).abs() < 300, "{below}");
    }
}
