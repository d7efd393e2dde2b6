//! FITS keywords of a ground observer (issue #46), as observatories write them: the site
//! (SITELAT, SITELONG, SITEELEV, in decimal degrees and metres; some acquisition software
//! writes sexagesimal strings instead) and where the telescope pointed at mid-exposure
//! (ALTITUDE, AZIMUTH of the boresight, geometric, and the AIRMASS of its refracted altitude,
//! Kasten & Young).

use crate::fits::Card;
use crate::sky::radec_unit;
use crate::sky::site::{STANDARD_PRESSURE_HPA, STANDARD_TEMPERATURE_C, Site, refraction_deg};
use soig_sim::atmosphere::airmass;
use soig_sim::scene::Scene;

/// The site's cards and the pointing's altitude, azimuth and airmass at mid-exposure.
pub fn site_cards(site: &Site, scene: &Scene) -> Vec<(String, Card, String)> {
    let mid =
        scene.exposure.start + hifitime::Duration::from_seconds(scene.exposure.exposure_s / 2.0);
    let (ra, dec) = scene.exposure.pointing.mid_radec_deg();
    let (alt, az) = site.alt_az_deg(mid, radec_unit(ra, dec));
    let seen = alt + refraction_deg(alt, STANDARD_PRESSURE_HPA, STANDARD_TEMPERATURE_C);
    let card = |k: &str, v: f64, c: &str| (k.to_string(), Card::Real(v), c.to_string());
    vec![
        card(
            "SITELAT",
            site.lat_deg,
            "[deg] site geodetic latitude (WGS84)",
        ),
        card(
            "SITELONG",
            site.lon_deg,
            "[deg] site longitude, east positive",
        ),
        card(
            "SITEELEV",
            site.height_m,
            "[m] site height above the WGS84 ellipsoid",
        ),
        card(
            "ALTITUDE",
            alt,
            "[deg] boresight altitude at DATE-AVG (geometric)",
        ),
        card(
            "AZIMUTH",
            az,
            "[deg] boresight azimuth at DATE-AVG, N through E",
        ),
        card(
            "AIRMASS",
            airmass(seen),
            "Kasten-Young airmass of the boresight at DATE-AVG",
        ),
    ]
}
