//! Who takes the images: a satellite (the paper's observer) or a telescope on the ground
//! (issue #46), and the one thing the sighting asks of either, its state over an exposure.

use hifitime::{Duration, Epoch};
use soig_sky::Vec3;
use soig_sky::ephemeris::{moon_position_km, sun_position_km};
use soig_sky::night::NightRule;
use soig_sky::orbit::Propagator;
use soig_sky::site::{STANDARD_PRESSURE_HPA, STANDARD_TEMPERATURE_C, Site, refraction_deg};
use soig_sky::{angle_deg, dot, scale, sub, unit};

use crate::sky_glow::{SkyGeometry, sky_v};

use crate::atmosphere::{
    Seeing, airmass, extinction_mag, scintillation_variance, seeing_fwhm_arcsec,
};

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
    /// The band's extinction, magnitudes per airmass (0: none).
    pub extinction_mag_per_airmass: f64,
    /// The seeing at the zenith: FWHM (arcsec) and Moffat beta; None: the sensor's own PSF.
    pub seeing_zenith: Option<(f64, f64)>,
    /// Scintillation: Osborn et al.'s C_Y and the telescope's aperture, metres; None: none.
    pub scintillation: Option<(f64, f64)>,
    /// The sky's glow from the site's dark sky, twilight and Moon (`sky_glow`); None: the
    /// noise model's own sky.
    pub sky: Option<SkyModel>,
}

/// A ground site's sky (`sky_glow::sky_v`): its dark zenith in V mag/arcsec^2, and whether
/// twilight and the Moon brighten it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkyModel {
    pub zenith_v: f64,
    pub twilight: bool,
    pub moon: bool,
}

/// The air's dimming of a source over one exposure: the site's zenith at mid-exposure (it
/// turns 2 arcmin in 8 s, nothing to an airmass) and the extinction coefficient.
#[derive(Clone, Copy, Debug)]
pub struct Extinction {
    pub up: Vec3,
    pub k_mag_per_airmass: f64,
}

impl Extinction {
    /// Magnitudes taken from a source in GCRS direction `dir`: k X, X the Kasten-Young airmass of
    /// its refracted altitude.
    pub fn mag(&self, dir: Vec3) -> f64 {
        extinction_mag(self.k_mag_per_airmass, airmass_toward(self.up, dir))
    }
}

/// The Kasten-Young airmass of GCRS direction `dir` seen from a site whose zenith is `up`, at
/// its refracted altitude.
pub fn airmass_toward(up: Vec3, dir: Vec3) -> f64 {
    let alt = dot(unit(dir), up).clamp(-1.0, 1.0).asin().to_degrees();
    let seen = alt + refraction_deg(alt, STANDARD_PRESSURE_HPA, STANDARD_TEMPERATURE_C);
    airmass(seen)
}

impl GroundGate {
    /// The extinction over an exposure whose middle is `mid`; None when there is none.
    pub fn extinction(&self, mid: Epoch) -> Option<Extinction> {
        (self.extinction_mag_per_airmass > 0.0).then(|| Extinction {
            up: self.site.up(mid),
            k_mag_per_airmass: self.extinction_mag_per_airmass,
        })
    }

    /// The seeing of an exposure whose middle is `mid` and boresight GCRS direction
    /// `boresight`: the zenith FWHM times its airmass^0.6 (`seeing_fwhm_arcsec`); None
    /// without seeing.
    pub fn seeing(&self, mid: Epoch, boresight: Vec3) -> Option<Seeing> {
        self.seeing_zenith.map(|(fwhm, beta)| {
            let x = airmass_toward(self.site.up(mid), boresight);
            Seeing {
                fwhm_arcsec: seeing_fwhm_arcsec(fwhm, x),
                beta,
                airmass: x,
            }
        })
    }

    /// The sky toward `boresight` over an exposure whose middle is `mid`, V mag/arcsec^2, and
    /// the geometry it came from (the Moon seen from the site: topocentric); None without a
    /// sky model.
    pub fn sky(&self, mid: Epoch, boresight: Vec3) -> Option<(f64, SkyGeometry)> {
        let model = self.sky?;
        let up = self.site.up(mid);
        let (site_km, _) = self.site.gcrs_state(mid);
        let alt = |dir: Vec3| dot(unit(dir), up).clamp(-1.0, 1.0).asin().to_degrees();
        let moon_geo = moon_position_km(mid);
        let moon = sub(moon_geo, site_km);
        let sun = sun_position_km(mid);
        // The phase angle: Sun - Moon - observer, at the Moon.
        let phase = angle_deg(sub(sun, moon_geo), scale(moon, -1.0));
        let g = SkyGeometry {
            target_z_deg: 90.0 - alt(boresight),
            sun_alt_deg: alt(sub(sun, site_km)),
            moon_z_deg: 90.0 - alt(moon),
            moon_sep_deg: angle_deg(boresight, moon),
            moon_phase_deg: phase,
        };
        let v = sky_v(
            model.zenith_v,
            self.extinction_mag_per_airmass,
            &g,
            model.twilight,
            model.moon,
        );
        Some((v, g))
    }

    /// The relative variance of an object's flux from scintillation over an exposure of
    /// `exposure_s` whose middle is `mid`, the object then in GCRS direction `dir`, and its
    /// airmass; None without scintillation.
    pub fn scintillation(&self, mid: Epoch, dir: Vec3, exposure_s: f64) -> Option<(f64, f64)> {
        self.scintillation.map(|(c_y, aperture_m)| {
            let x = airmass_toward(self.site.up(mid), dir);
            let v = scintillation_variance(c_y, aperture_m, x, self.site.height_m, exposure_s);
            (v, x)
        })
    }

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
    Orbit(Box<Body>),
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
            Observer::Orbit(b) => Some(b.as_ref()),
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
