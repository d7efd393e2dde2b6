//! The night at a ground site: when it can see an object. Three conditions hold together: the
//! Sun below a chosen altitude (-12 deg: nautical twilight's end, a common SSA limit; -18 for
//! astronomical night), the object above a chosen altitude (the telescope's horizon limit,
//! airmass) and the object sunlit (a body in the Earth's shadow sends no light). The campaign
//! window is searched on a grid for the spans where they hold; when none does, the refusal
//! says which condition failed and by how much.

use hifitime::{Duration, Epoch};

use super::ephemeris::sun_position_km;
use super::site::Site;
use super::{Vec3, segment_hits_sphere, sub};

/// The Earth's radius for the shadow test, km (WGS84 equatorial, as the simulator's checks).
const SHADOW_RADIUS_KM: f64 = 6378.137;

/// The conditions of a night's observation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NightRule {
    /// The Sun's geometric altitude must be at most this, degrees.
    pub sun_max_alt_deg: f64,
    /// The object's geometric altitude must be at least this, degrees.
    pub object_min_alt_deg: f64,
}

/// What one instant looks like from the site.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conditions {
    pub sun_alt_deg: f64,
    pub object_alt_deg: f64,
    pub object_sunlit: bool,
}

impl NightRule {
    pub fn holds(&self, c: &Conditions) -> bool {
        c.sun_alt_deg <= self.sun_max_alt_deg
            && c.object_alt_deg >= self.object_min_alt_deg
            && c.object_sunlit
    }
}

/// The Sun's and the object's altitude at the site and whether the object is sunlit at `t`,
/// given the object's geocentric GCRS position (km).
pub fn conditions(site: &Site, t: Epoch, object_gcrs_km: Vec3) -> Conditions {
    let (r, horizon) = site.gcrs_horizon(t);
    let sun = sun_position_km(t);
    Conditions {
        sun_alt_deg: horizon.alt_az_deg(sub(sun, r)).0,
        object_alt_deg: horizon.alt_az_deg(sub(object_gcrs_km, r)).0,
        object_sunlit: !segment_hits_sphere(object_gcrs_km, sun, SHADOW_RADIUS_KM),
    }
}

/// Why no instant of a window holds: the best each condition reached on the grid.
#[derive(thiserror::Error, Clone, Debug, PartialEq)]
#[error(
    "no time in the window suits the site: {reason} (searched {samples} instants {step_s} s apart; lowest Sun {lowest_sun_deg:.1} deg against at most {sun_max_deg}, highest object {highest_object_deg:.1} deg against at least {object_min_deg}, sunlit at {sunlit_share:.0} % of them)"
)]
pub struct NoNight {
    pub reason: &'static str,
    pub samples: usize,
    pub step_s: f64,
    pub lowest_sun_deg: f64,
    pub sun_max_deg: f64,
    pub highest_object_deg: f64,
    pub object_min_deg: f64,
    pub sunlit_share: f64,
}

/// The spans `[from, to]` of the window `[start, end]` where `rule` holds, found on a grid of
/// `step_s` (a span starts and ends at grid instants: an edge is known to `step_s`).
/// `object` gives the object's GCRS position at t, None where it cannot be propagated (such an
/// instant does not hold). Err when no grid instant holds, saying which condition failed.
pub fn search(
    site: &Site,
    rule: &NightRule,
    (start, end): (Epoch, Epoch),
    step_s: f64,
    object: &dyn Fn(Epoch) -> Option<Vec3>,
) -> Result<Vec<(Epoch, Epoch)>, NoNight> {
    let span_s = (end - start).to_seconds().max(0.0);
    let samples = (span_s / step_s).floor() as usize + 1;
    let (mut lowest_sun, mut highest_obj, mut sunlit) = (f64::INFINITY, f64::NEG_INFINITY, 0);
    let (mut dark, mut dark_and_up) = (0, 0);
    let mut spans: Vec<(Epoch, Epoch)> = Vec::new();
    let mut open: Option<(Epoch, Epoch)> = None;
    for k in 0..samples {
        let t = start + Duration::from_seconds(k as f64 * step_s);
        let c = object(t).map(|r| conditions(site, t, r));
        let ok = c.as_ref().is_some_and(|c| rule.holds(c));
        if let Some(c) = c {
            lowest_sun = lowest_sun.min(c.sun_alt_deg);
            highest_obj = highest_obj.max(c.object_alt_deg);
            sunlit += usize::from(c.object_sunlit);
            let is_dark = c.sun_alt_deg <= rule.sun_max_alt_deg;
            dark += usize::from(is_dark);
            dark_and_up += usize::from(is_dark && c.object_alt_deg >= rule.object_min_alt_deg);
        }
        open = match (open, ok) {
            (None, true) => Some((t, t)),
            (Some((a, _)), true) => Some((a, t)),
            (Some(s), false) => {
                spans.push(s);
                None
            }
            (None, false) => None,
        };
    }
    spans.extend(open);
    if !spans.is_empty() {
        return Ok(spans);
    }
    let reason = if dark == 0 {
        "the Sun never sets far enough"
    } else if highest_obj < rule.object_min_alt_deg {
        "the object never rises high enough"
    } else if dark_and_up == 0 {
        "the object is high enough only while the Sun is up"
    } else {
        "the object is in the Earth's shadow whenever it is up at night"
    };
    Err(NoNight {
        reason,
        samples,
        step_s,
        lowest_sun_deg: lowest_sun,
        sun_max_deg: rule.sun_max_alt_deg,
        highest_object_deg: highest_obj,
        object_min_deg: rule.object_min_alt_deg,
        sunlit_share: 100.0 * sunlit as f64 / samples as f64,
    })
}

#[cfg(test)]
#[path = "night_tests.rs"]
mod tests;
