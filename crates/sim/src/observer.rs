//! Who takes the images: a satellite (the paper's observer) or a telescope on the ground
//! (issue #46), and the one thing the sighting asks of either, its state over an exposure.

use hifitime::{Duration, Epoch};
use soig_sky::Vec3;
use soig_sky::night::NightRule;
use soig_sky::orbit::Propagator;
use soig_sky::site::Site;

use crate::scene::Body;

/// A body whose TEME position (km) and velocity (km/s) are known at any instant.
pub trait Viewpoint {
    /// None where it cannot be propagated.
    fn teme_state(&self, t: Epoch) -> Option<(Vec3, Vec3)>;

    /// For a telescope held fixed in altitude and azimuth: the GCRS axis and rate (deg/s) its
    /// boresight turns about (`Site::stare_axis`); None for a satellite, whose survey
    /// attitude follows its orbit.
    fn stare_axis(&self, _t: Epoch) -> Option<(Vec3, f64)> {
        None
    }
}

impl Viewpoint for Propagator {
    fn teme_state(&self, t: Epoch) -> Option<(Vec3, Vec3)> {
        self.state_teme(t).ok()
    }
}

impl Viewpoint for Site {
    fn teme_state(&self, t: Epoch) -> Option<(Vec3, Vec3)> {
        Some(Site::teme_state(self, t))
    }

    fn stare_axis(&self, t: Epoch) -> Option<(Vec3, f64)> {
        Some(Site::stare_axis(self, t))
    }
}

/// A telescope at a ground site.
#[derive(Clone, Debug)]
pub struct Ground {
    pub name: String,
    pub site: Site,
}

/// What a ground campaign asks of its scenes: the site, the conditions of its night and, for
/// each debris object in the order of `Inputs::debris`, the spans of the campaign's window
/// where they hold (`night::search`, at resolve time); the scene draws its start times there.
#[derive(Clone, Debug, PartialEq)]
pub struct GroundGate {
    pub site: Site,
    pub night: NightRule,
    pub spans: Vec<Vec<(Epoch, Epoch)>>,
}

impl GroundGate {
    /// The instant `u` in [0, 1) of the way through the object's spans, laid end to end.
    pub fn instant(&self, debris_index: usize, u: f64) -> Option<Epoch> {
        let spans = self.spans.get(debris_index)?;
        let total: f64 = spans.iter().map(|(a, b)| (*b - *a).to_seconds()).sum();
        let mut left = u * total;
        for (a, b) in spans {
            let len = (*b - *a).to_seconds();
            if left <= len {
                return Some(*a + Duration::from_seconds(left));
            }
            left -= len;
        }
        spans.last().map(|(_, b)| *b)
    }
}

/// The observer of a campaign.
#[derive(Clone, Debug)]
pub enum Observer {
    Orbit(Body),
    Ground(Ground),
}

impl Observer {
    pub fn name(&self) -> &str {
        match self {
            Observer::Orbit(b) => &b.name,
            Observer::Ground(g) => &g.name,
        }
    }

    pub fn viewpoint(&self) -> &dyn Viewpoint {
        match self {
            Observer::Orbit(b) => &b.propagator,
            Observer::Ground(g) => &g.site,
        }
    }

    pub fn orbit(&self) -> Option<&Body> {
        match self {
            Observer::Orbit(b) => Some(b),
            Observer::Ground(_) => None,
        }
    }

    pub fn ground(&self) -> Option<&Ground> {
        match self {
            Observer::Ground(g) => Some(g),
            Observer::Orbit(_) => None,
        }
    }
}
