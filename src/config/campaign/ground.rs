//! A ground observer (issue #46): `[observer] site = { lat_deg, lon_deg, height_m }` in place of
//! the observer's orbit, with the limits of its night, and the search of the campaign's window
//! for the spans where each debris object can be seen from it (refused, naming the field, when
//! an object never can).

use hifitime::Epoch;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::{Body, CampaignFile, MAX_SURVEY_DRIFT_DEG, ObjectSpec, Observer, PointingMode};
use crate::sky::frames::teme_to_gcrs;
use crate::sky::night::{self, NightRule};
use crate::sky::site::EARTH_RATE_DEG_S;
use crate::sky::site::Site;
use soig_sim::observer::{Ground, GroundGate, SkyModel};

/// A telescope on the ground: its WGS84 place and the limits of its night.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SiteSpec {
    /// Geodetic latitude, degrees north (-90..90).
    pub lat_deg: f64,
    /// Longitude, degrees east (-180..360).
    pub lon_deg: f64,
    /// Height above the WGS84 ellipsoid, metres.
    #[serde(default)]
    pub height_m: f64,
    /// The Sun's geometric altitude must be at most this, degrees (-12: nautical night).
    #[serde(default = "nautical")]
    pub sun_max_alt_deg: f64,
    /// The object's geometric altitude must be at least this, degrees.
    #[serde(default = "twenty")]
    pub min_alt_deg: f64,
    /// The band's atmospheric extinction, magnitudes per airmass (Bouguer's k: ~0.12-0.2 in V
    /// at a good site), dimming the debris at each trajectory sample and the field's stars at
    /// the boresight's airmass. 0 (default): no air.
    #[serde(default)]
    pub extinction_mag_per_airmass: f64,
    /// The seeing at the zenith: the renderer's PSF becomes a Moffat of this FWHM times the
    /// boresight's airmass^0.6 (in place of the sensor's Gaussian). Absent: no seeing.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seeing: Option<SeeingSpec>,
    /// Scintillation: each object's flux in each exposure multiplied by a log-normal factor
    /// of mean 1 and Young's relative rms with Osborn et al.'s correction. Absent: none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scintillation: Option<ScintillationSpec>,
    /// The sky's glow per image toward the boresight (Krisciunas & Schaefer 1991, twilight),
    /// replacing `[noise] sky_*` of the physical noise model (required). Absent: the noise
    /// model's own sky.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sky: Option<SkySpec>,
}

/// A ground site's sky (docs/ground.md): the dark sky at the zenith, brightened by twilight
/// and the Moon.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SkySpec {
    /// The dark night sky at the zenith, V mag/arcsec^2 (15 .. 25; ~21.5-22 at a dark site).
    pub zenith_v_mag_per_arcsec2: f64,
    /// Brighten it in twilight by the Sun's altitude (default true).
    #[serde(default = "yes")]
    pub twilight: bool,
    /// Add the Moon's scattered light (default true; it needs the site's extinction).
    #[serde(default = "yes")]
    pub moon: bool,
}

fn yes() -> bool {
    true
}

/// Scintillation noise (docs/ground.md): sigma^2 = 10e-6 C_Y^2 D^-4/3 t^-1 X^3 exp(-2h/8000 m).
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ScintillationSpec {
    /// The telescope's aperture D, metres (0.01 .. 50).
    pub aperture_m: f64,
    /// Osborn et al.'s (2015) empirical correction C_Y of the site (0.1 .. 10; default 1.5).
    #[serde(default = "typical_c_y")]
    pub c_y: f64,
}

fn typical_c_y() -> f64 {
    1.5
}

/// Seeing-limited imaging: a Moffat profile (docs/ground.md).
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SeeingSpec {
    /// FWHM at the zenith, arcsec (0.05 .. 20; ~0.7-1.5 at a good site).
    pub fwhm_arcsec: f64,
    /// Moffat index beta (1.1 .. 20): 4.765 (default) is Trujillo et al.'s (2001) Kolmogorov
    /// fit, 2.5 has wider wings.
    #[serde(default = "kolmogorov_beta")]
    pub beta: f64,
}

fn kolmogorov_beta() -> f64 {
    4.765
}

fn nautical() -> f64 {
    -12.0
}

fn twenty() -> f64 {
    20.0
}

/// Grid of the night search, seconds: an edge of a night span is known to a minute, and a
/// window of a year is searched in at most `MAX_SEARCH_STEPS` steps.
const SEARCH_STEP_S: f64 = 60.0;
const MAX_SEARCH_STEPS: f64 = 20_000.0;

/// The ground observer of `spec`, if it has a site; Err (field suffix, message) when the site
/// is given with an orbit, or is out of range.
pub(super) fn ground_of(spec: &ObjectSpec) -> Result<Option<Ground>, (String, String)> {
    let Some(s) = &spec.site else {
        return Ok(None);
    };
    if spec.tle.is_some() || spec.tle_file.is_some() || spec.elements.is_some() {
        return Err((
            ".site".into(),
            "a ground site replaces the observer's orbit: give `site` or one of `tle`, `tle_file`, `elements`, not both".into(),
        ));
    }
    if spec.norad.is_some() {
        return Err((".norad".into(), "a ground site has no NORAD number".into()));
    }
    let checks = [
        (".site.lat_deg", s.lat_deg, -90.0, 90.0),
        (".site.lon_deg", s.lon_deg, -180.0, 360.0),
        (".site.height_m", s.height_m, -500.0, 10_000.0),
        (".site.sun_max_alt_deg", s.sun_max_alt_deg, -90.0, 90.0),
        (".site.min_alt_deg", s.min_alt_deg, 0.0, 90.0),
        (
            ".site.extinction_mag_per_airmass",
            s.extinction_mag_per_airmass,
            0.0,
            5.0,
        ),
    ];
    let seeing = s.seeing.as_ref().map_or([None, None], |g| {
        [
            Some((".site.seeing.fwhm_arcsec", g.fwhm_arcsec, 0.05, 20.0)),
            Some((".site.seeing.beta", g.beta, 1.1, 20.0)),
        ]
    });
    let scintillation = s.scintillation.as_ref().map_or([None, None], |c| {
        [
            Some((".site.scintillation.aperture_m", c.aperture_m, 0.01, 50.0)),
            Some((".site.scintillation.c_y", c.c_y, 0.1, 10.0)),
        ]
    });
    let sky = s.sky.as_ref().map(|k| {
        (
            ".site.sky.zenith_v_mag_per_arcsec2",
            k.zenith_v_mag_per_arcsec2,
            15.0,
            25.0,
        )
    });
    let optional = seeing.into_iter().chain(scintillation).flatten().chain(sky);
    for (field, v, lo, hi) in checks.into_iter().chain(optional) {
        if !(lo..=hi).contains(&v) {
            return Err((field.into(), format!("is {v}: must be within {lo} .. {hi}")));
        }
    }
    Ok(Some(Ground {
        name: spec.name.clone().unwrap_or_else(|| {
            format!("site {:.4} {:.4} {:.0} m", s.lat_deg, s.lon_deg, s.height_m)
        }),
        site: Site {
            lat_deg: s.lat_deg,
            lon_deg: s.lon_deg,
            height_m: s.height_m,
        },
    }))
}

/// Only the observer can stand on the ground.
pub(super) fn no_debris_sites(file: &CampaignFile) -> Result<(), (String, String)> {
    match file.debris.iter().position(|d| d.site.is_some()) {
        Some(i) => Err((
            format!("debris[{i}].site"),
            "only the observer can be a ground site".into(),
        )),
        None => Ok(()),
    }
}

/// A ground observer's gate: the spans where each object can be seen (refused if one never
/// can), and the stare's drift (the Earth's 15 arcsec/s) bounded as a survey's. None for a
/// satellite observer.
pub(super) fn ground_gate(
    resolved: &CampaignFile,
    observer: &Observer,
    debris: &[Body],
    window: (Epoch, Epoch),
) -> Result<Option<GroundGate>, (String, String)> {
    let (Observer::Ground(g), Some(spec)) = (observer, &resolved.observer.site) else {
        return Ok(None);
    };
    if spec.sky.is_some() && resolved.noise.is_paper() {
        return Err((
            "observer.site.sky".into(),
            "a ground sky in mag/arcsec^2 needs the physical noise model: add `[noise] model = \"physical\"`".into(),
        ));
    }
    let max_s = resolved.exposure.max_s;
    let drift = EARTH_RATE_DEG_S * max_s;
    if resolved.pointing.mode == PointingMode::Survey && drift > MAX_SURVEY_DRIFT_DEG {
        return Err((
            "exposure.max_s".into(),
            format!(
                "a ground stare drifts {drift:.1} deg in {max_s} s; at most {MAX_SURVEY_DRIFT_DEG} deg is supported: shorten the exposure"
            ),
        ));
    }
    night_spans(spec, &g.site, debris, window).map(Some)
}

/// The spans of the window where each debris object can be seen from the site; Err (field,
/// message) naming the first object that never can, with why.
fn night_spans(
    spec: &SiteSpec,
    site: &Site,
    debris: &[Body],
    (start, end): (Epoch, Epoch),
) -> Result<GroundGate, (String, String)> {
    let night = NightRule {
        sun_max_alt_deg: spec.sun_max_alt_deg,
        object_min_alt_deg: spec.min_alt_deg,
    };
    let step_s = SEARCH_STEP_S.max((end - start).to_seconds() / MAX_SEARCH_STEPS);
    let mut spans = Vec::with_capacity(debris.len());
    for (i, body) in debris.iter().enumerate() {
        let p = &body.propagator;
        let object = |t: Epoch| p.position_teme_km(t).ok().map(|r| teme_to_gcrs(r, t));
        let found = night::search(site, &night, (start, end), step_s, &object).map_err(|e| {
            (
                "observer.site".to_string(),
                format!(
                    "debris[{i}] ({}) can never be seen from this site: {e}",
                    body.name
                ),
            )
        })?;
        spans.push(found);
    }
    Ok(GroundGate {
        site: *site,
        night,
        spans,
        extinction_mag_per_airmass: spec.extinction_mag_per_airmass,
        seeing_zenith: spec.seeing.as_ref().map(|g| (g.fwhm_arcsec, g.beta)),
        scintillation: spec.scintillation.as_ref().map(|c| (c.c_y, c.aperture_m)),
        sky: spec.sky.as_ref().map(|k| SkyModel {
            zenith_v: k.zenith_v_mag_per_arcsec2,
            twilight: k.twilight,
            moon: k.moon,
        }),
    })
}
