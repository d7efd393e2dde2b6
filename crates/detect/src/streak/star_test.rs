//! Steps 5-7, the star test: whether a segment is a star's trail rather than debris.

use super::params::Sanitized;
use super::segment::{Seg, angle_diff_deg};
use super::sky::Sky;

/// What a pass knows of the stars' trails.
pub(super) enum StarTest<'a> {
    /// Fixed pointing: stars are round, no segment is a trail.
    Round,
    /// A survey image: the trails' direction, degrees.
    Along(f64),
    /// The star-aware pass: the predicted trails, and the map before they were subtracted.
    Predicted(&'a Sky, &'a [f32]),
}

impl StarTest<'_> {
    /// Whether the trails explain `s`: it lies along their direction (within
    /// `star_trail_tolerance_deg`), or predicted trails cover it and it is no brighter than
    /// they are (`Sky::explains`).
    pub(super) fn explains(&self, s: &Seg, w: usize, h: usize, p: &Sanitized) -> bool {
        match *self {
            StarTest::Predicted(sky, z_sky) => sky.explains(s, z_sky, w, h, p.trail_tol),
            // A short segment's orientation is uncertain by about its width over its length,
            // so the tolerance grows by atan(4 psf_sigma / length).
            StarTest::Along(a) => {
                let slack = (4.0 * p.psf_sigma / s.length.max(1.0)).atan().to_degrees();
                angle_diff_deg(s.theta.to_degrees(), a) <= p.trail_tol + slack
            }
            StarTest::Round => false,
        }
    }
}
