//! Field stars: a deterministic procedural sky and real catalogs with proper motion.
//!
//! [`ProceduralSky`] (`procedural.rs`) tiles the sphere into cells and draws each cell's stars
//! from the count model `N(b, m)` (`counts.rs`), which depends on galactic latitude
//! (`galactic.rs`). [`StarCatalog`] (`catalog.rs`) reads Gaia archive, VizieR or plain CSV exports
//! and moves the stars to the observation epoch. Both answer cone queries with [`Star`]s in the
//! same order; the chord and sorting helpers they share are here.

mod catalog;
mod counts;
mod galactic;
mod procedural;

pub use catalog::{CatalogError, StarCatalog};
pub use counts::{
    ALPHA_FAINT, BRIGHT_MAG_LIMIT, GENERATION_MAG_LIMIT, cumulative_density_per_deg2,
};
pub use galactic::equatorial_to_galactic;
pub use procedural::{CELL_DEG, ProceduralSky};

use crate::{Vec3, dot, radec_unit, sub};

/// A star: ICRS position in degrees and magnitude.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Star {
    pub ra_deg: f64,
    pub dec_deg: f64,
    pub mag: f64,
}

/// Wraps an angle into `[0, 360)`.
fn normalize_ra(ra: f64) -> f64 {
    let r = ra.rem_euclid(360.0);
    if r >= 360.0 { 0.0 } else { r }
}

/// Squared chord length between two unit vectors (monotone in the angular distance, accurate for
/// small angles, unlike `acos` of the dot product).
fn chord2(a: &Vec3, b: &Vec3) -> f64 {
    let d = sub(*a, *b);
    dot(d, d)
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

/// Centre (unit vector, RA wrapped, Dec clamped to the poles) and squared chord radius of a cone
/// query; `None` when the query selects nothing: a negative or NaN radius, a non-finite centre,
/// a NaN magnitude limit.
fn cone(ra_deg: f64, dec_deg: f64, radius_deg: f64, mag_max: f64) -> Option<(Vec3, f64)> {
    let max_chord2 = chord2_of_radius(radius_deg)?;
    if !ra_deg.is_finite() || !dec_deg.is_finite() || mag_max.is_nan() {
        return None;
    }
    let centre = radec_unit(normalize_ra(ra_deg), dec_deg.clamp(-90.0, 90.0));
    Some((centre, max_chord2))
}

fn sort_stars(stars: &mut [Star]) {
    stars.sort_unstable_by(|a, b| {
        a.mag
            .total_cmp(&b.mag)
            .then(a.ra_deg.total_cmp(&b.ra_deg))
            .then(a.dec_deg.total_cmp(&b.dec_deg))
    });
}

/// Angular distance in degrees by the haversine formula (independent of the module's chords),
/// for the tests of the submodules.
#[cfg(test)]
fn separation_deg(ra1: f64, dec1: f64, ra2: f64, dec2: f64) -> f64 {
    let (p1, p2) = (dec1.to_radians(), dec2.to_radians());
    let dp = p2 - p1;
    let dl = (ra2 - ra1).to_radians();
    let a = (dp / 2.0).sin().powi(2) + p1.cos() * p2.cos() * (dl / 2.0).sin().powi(2);
    2.0 * a.sqrt().min(1.0).asin().to_degrees()
}
