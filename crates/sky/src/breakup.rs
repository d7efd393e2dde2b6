//! Fragments of a breakup by the NASA Standard Breakup Model: N. L. Johnson, P. H. Krisko,
//! J.-C. Liou, P. D. Anz-Meador, "NASA's new breakup model of EVOLVE 4.0", Advances in Space
//! Research 28(9), 1377-1384, 2001 (equation numbers below are that paper's).
//!
//! - Count (Eq. 2, 4): N(> Lc) = 6 S Lc^-1.6 for an explosion, 0.1 M^0.75 Lc^-1.71 for a
//!   collision, Lc in m; M = m_target + m_projectile (kg) when the collision is catastrophic
//!   (projectile energy over target mass of 40 J/g or more), else m_projectile v^2 (v in km/s).
//!   A cloud holds round(N(> Lc_min)) fragments, their sizes drawn from that power law above
//!   Lc_min (a Pareto law: the model sets no upper bound; the largest of a few hundred is a few
//!   metres).
//! - Area (Eq. 8): A = 0.540424 Lc^2 below 1.67 mm, else 0.556945 Lc^2.0047077 m^2.
//! - Area-to-mass, chi = log10(A/M) with lambda = log10(Lc) (Eq. 5-7): above 11 cm a mixture of
//!   two normals, alpha N(mu1, sigma1) + (1 - alpha) N(mu2, sigma2), whose parameters depend on
//!   lambda and on the parent being a spacecraft or a rocket body; below 8 cm one normal
//!   N(mu_soc, sigma_soc); between, the paper's "bridge": here a mixture of the two, the
//!   large-fragment law taken with probability (Lc - 8 cm) / 3 cm, so every moment passes
//!   linearly from one to the other.
//! - Ejection speed (Eq. 11, 12): nu = log10(dv in m/s) normal with mean 0.2 chi + 1.85
//!   (explosion) or 0.9 chi + 2.9 (collision) and sigma 0.4; directions isotropic.
//!
//! Mass is not conserved fragment by fragment (the model does not do so either).

use rand::RngExt;
use rand_chacha::ChaCha12Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::Vec3;

/// What broke up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    /// An explosion; `scaling` is the paper's S (1 for a rocket body's upper stage).
    Explosion { scaling: f64 },
    /// A collision of a projectile with the parent (the target) at `speed_km_s`.
    Collision {
        target_kg: f64,
        projectile_kg: f64,
        speed_km_s: f64,
    },
}

/// The parent's kind, which sets the large fragments' area-to-mass law (Eq. 6, 7).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParentKind {
    Spacecraft,
    RocketBody,
}

/// Specific energy at and above which a collision is catastrophic, J/g.
const CATASTROPHIC_J_PER_G: f64 = 40.0;

impl Event {
    /// Whether the target is destroyed: an explosion, or a collision whose projectile brings
    /// 40 J per gram of target or more.
    pub fn catastrophic(&self) -> bool {
        match *self {
            Event::Explosion { .. } => true,
            Event::Collision {
                target_kg,
                projectile_kg,
                speed_km_s,
            } => {
                let joules = 0.5 * projectile_kg * (speed_km_s * 1e3).powi(2);
                joules / (target_kg * 1e3) >= CATASTROPHIC_J_PER_G
            }
        }
    }

    /// The mass M of Eq. 4, kg (a collision's).
    fn collision_mass_kg(&self) -> f64 {
        match *self {
            Event::Explosion { .. } => 0.0,
            Event::Collision {
                target_kg,
                projectile_kg,
                speed_km_s,
            } => {
                if self.catastrophic() {
                    target_kg + projectile_kg
                } else {
                    projectile_kg * speed_km_s * speed_km_s
                }
            }
        }
    }

    /// The exponent b of N(> Lc) = k Lc^-b.
    pub fn size_exponent(&self) -> f64 {
        match self {
            Event::Explosion { .. } => 1.6,
            Event::Collision { .. } => 1.71,
        }
    }

    /// N(> Lc): the number of fragments larger than `lc_m` (Eq. 2, 4), not rounded.
    pub fn count_above(&self, lc_m: f64) -> f64 {
        let k = match *self {
            Event::Explosion { scaling } => 6.0 * scaling,
            Event::Collision { .. } => 0.1 * self.collision_mass_kg().powf(0.75),
        };
        k * lc_m.powf(-self.size_exponent())
    }

    /// The fragments of a cloud down to `lc_min_m`: round(N(> Lc_min)).
    pub fn fragments(&self, lc_min_m: f64) -> u64 {
        self.count_above(lc_min_m).round() as u64
    }

    /// The mean and sigma of nu = log10(dv / (m/s)) for area-to-mass chi (Eq. 11, 12).
    pub fn speed_law(&self, chi: f64) -> (f64, f64) {
        let mean = match self {
            Event::Explosion { .. } => 0.2 * chi + 1.85,
            Event::Collision { .. } => 0.9 * chi + 2.9,
        };
        (mean, 0.4)
    }
}

/// One fragment as drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fragment {
    /// Characteristic length, m.
    pub lc_m: f64,
    /// Average cross-section, m^2 (Eq. 8).
    pub area_m2: f64,
    /// Area-to-mass ratio, m^2/kg.
    pub area_to_mass: f64,
    /// Ejection velocity relative to the parent, m/s (isotropic).
    pub dv_m_s: Vec3,
}

/// The fragment's average cross-section, m^2 (Eq. 8).
pub fn area_m2(lc_m: f64) -> f64 {
    if lc_m < 0.001_67 {
        0.540424 * lc_m * lc_m
    } else {
        0.556945 * lc_m.powf(2.0047077)
    }
}

/// A piecewise-linear parameter of Eq. 5-7: `low` up to `lo`, `high` from `hi`, a line between.
fn ramp(
    lambda: f64,
    (lo, low): (f64, f64),
    (hi, high): (f64, f64),
    line: impl Fn(f64) -> f64,
) -> f64 {
    if lambda <= lo {
        low
    } else if lambda >= hi {
        high
    } else {
        line(lambda)
    }
}

/// The law of chi = log10(A/M) of one fragment: weighted normals (weight, mean, sigma).
pub type Mixture = Vec<(f64, f64, f64)>;

/// Below 8 cm (Eq. 5): one normal.
fn small_law(lambda: f64) -> (f64, f64) {
    let mu = ramp(lambda, (-1.75, -0.3), (-1.25, -1.0), |l| {
        -0.3 - 1.4 * (l + 1.75)
    });
    let sigma = if lambda <= -3.5 {
        0.2
    } else {
        0.2 + 0.1333 * (lambda + 3.5)
    };
    (mu, sigma)
}

/// Above 11 cm (Eq. 6 rocket bodies, Eq. 7 spacecraft): (alpha, mu1, sigma1, mu2, sigma2).
// The paper's slope 0.318 of mu1 is no approximation of 1/pi.
#[allow(clippy::approx_constant)]
fn large_law(kind: ParentKind, l: f64) -> (f64, f64, f64, f64, f64) {
    match kind {
        ParentKind::RocketBody => (
            ramp(l, (-1.4, 1.0), (0.0, 0.5), |l| 1.0 - 0.3571 * (l + 1.4)),
            ramp(l, (-0.5, -0.45), (0.0, -0.9), |l| -0.45 - 0.9 * (l + 0.5)),
            0.55,
            -0.9,
            ramp(l, (-1.0, 0.28), (0.1, 0.1), |l| 0.28 - 0.1636 * (l + 1.0)),
        ),
        ParentKind::Spacecraft => (
            ramp(l, (-1.95, 0.0), (0.55, 1.0), |l| 0.3 + 0.4 * (l + 1.2)),
            ramp(l, (-1.1, -0.6), (0.0, -0.95), |l| -0.6 - 0.318 * (l + 1.1)),
            ramp(l, (-1.3, 0.1), (-0.3, 0.3), |l| 0.1 + 0.2 * (l + 1.3)),
            ramp(l, (-0.7, -1.2), (-0.1, -2.0), |l| -1.2 - 1.333 * (l + 0.7)),
            ramp(l, (-0.5, 0.5), (-0.3, 0.3), |l| 0.5 - (l + 0.5)),
        ),
    }
}

/// Where the small-fragment law ends and the large-fragment law begins, m.
const BRIDGE_M: (f64, f64) = (0.08, 0.11);

/// The law of chi for a fragment of `lc_m` from a parent of `kind`.
pub fn area_to_mass_law(kind: ParentKind, lc_m: f64) -> Mixture {
    let l = lc_m.log10();
    let (mu, sigma) = small_law(l);
    let (alpha, mu1, s1, mu2, s2) = large_law(kind, l);
    let large_share = ((lc_m - BRIDGE_M.0) / (BRIDGE_M.1 - BRIDGE_M.0)).clamp(0.0, 1.0);
    let mut law = vec![
        ((1.0 - large_share), mu, sigma),
        (large_share * alpha, mu1, s1),
        (large_share * (1.0 - alpha), mu2, s2),
    ];
    law.retain(|(w, _, _)| *w > 0.0);
    law
}

/// The mean and variance of a mixture.
pub fn moments(law: &Mixture) -> (f64, f64) {
    let mean: f64 = law.iter().map(|(w, m, _)| w * m).sum();
    let second: f64 = law.iter().map(|(w, m, s)| w * (s * s + m * m)).sum();
    (mean, second - mean * mean)
}

/// One draw of a mixture: its component by a uniform, then the normal.
fn draw_mixture(law: &Mixture, rng: &mut ChaCha12Rng) -> f64 {
    let mut u: f64 = rng.random();
    let z: f64 = StandardNormal.sample(rng);
    for &(w, m, s) in law {
        if u < w {
            return m + s * z;
        }
        u -= w;
    }
    // Rounding left u at the top: the last component.
    let &(_, m, s) = law.last().expect("a law has a component");
    m + s * z
}

/// Fragment `rng` (its own stream): its size above `lc_min_m`, area, area-to-mass and
/// ejection velocity, in that order of draws.
pub fn draw(event: &Event, kind: ParentKind, lc_min_m: f64, rng: &mut ChaCha12Rng) -> Fragment {
    // Pareto above lc_min: P(> L) = (L / lc_min)^-b; 1 - u in (0, 1] keeps it finite.
    let u: f64 = rng.random();
    let lc_m = lc_min_m * (1.0 - u).powf(-1.0 / event.size_exponent());
    let chi = draw_mixture(&area_to_mass_law(kind, lc_m), rng);
    let (mean, sigma) = event.speed_law(chi);
    let z: f64 = StandardNormal.sample(rng);
    let speed = 10f64.powf(mean + sigma * z);
    // Isotropic: cos(polar) uniform in [-1, 1], azimuth uniform.
    let cos_t = 2.0 * rng.random::<f64>() - 1.0;
    let phi = std::f64::consts::TAU * rng.random::<f64>();
    let sin_t = (1.0 - cos_t * cos_t).sqrt();
    Fragment {
        lc_m,
        area_m2: area_m2(lc_m),
        area_to_mass: 10f64.powf(chi),
        dv_m_s: [
            speed * sin_t * phi.cos(),
            speed * sin_t * phi.sin(),
            speed * cos_t,
        ],
    }
}

#[cfg(test)]
mod tests;
