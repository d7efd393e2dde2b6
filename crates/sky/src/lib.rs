//! soig's sky layer, which imports nothing of soig.
//!
//! The sky: time, orbits, Sun and Moon, stars, projection onto the detector and photometry.
//! Geometry is in f64, positions in km, angles in degrees unless a name says otherwise.

// Unit tests write their fixtures with std::fs; everything the product writes goes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![cfg_attr(test, allow(clippy::disallowed_methods))]

pub mod apparent;
pub mod breakup;
pub mod debris_sizes;
pub mod ephemeris;
pub mod frames;
pub mod motion;
pub mod night;
pub mod orbit;
pub mod photometry;
pub mod pointing;
pub mod projection;
pub mod site;
pub mod stars;
#[cfg(test)]
mod testing;
pub mod vec3;
pub mod wcs;

pub use vec3::{
    Mat3, Turn, Vec3, angle_deg, cross, dot, mat_mul, mat_vec, norm, radec_deg, radec_unit, rotate,
    scale, segment_hits_sphere, sub, transpose, unit,
};

/// One arcsecond in radians.
const ARCSEC: f64 = std::f64::consts::PI / (180.0 * 3600.0);
