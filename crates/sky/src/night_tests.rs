use super::*;
use crate::frames::teme_to_gcrs;
use crate::orbit::Propagator;
use crate::scale;
use crate::testing::catalog;

include!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../tests/fixtures/sky/night.rs"
));

const NAUTICAL: NightRule = NightRule {
    sun_max_alt_deg: -12.0,
    object_min_alt_deg: 20.0,
};

fn utc(s: &str) -> Epoch {
    format!("{s} UTC").parse().unwrap()
}

/// An object of the catalogue (3: SENTINEL 3A, 2: MSG 4 DEB, near GEO).
fn catalogued(k: usize) -> impl Fn(Epoch) -> Option<Vec3> {
    let p = Propagator::from_tle(&catalog()[k]).unwrap();
    move |t| p.position_teme_km(t).ok().map(|r| teme_to_gcrs(r, t))
}

/// A body `height_km` straight above the site (geodetic up) at every instant.
fn overhead(site: Site, height_km: f64) -> impl Fn(Epoch) -> Option<Vec3> {
    move |t| {
        let (r, _) = site.gcrs_state(t);
        let up = scale(site.direction_of(t, 90.0, 0.0), height_km);
        Some([r[0] + up[0], r[1] + up[1], r[2] + up[2]])
    }
}

/// Svalbard in June: the midnight Sun never goes below -12 deg, so the search refuses and
/// says why.
#[test]
fn polar_summer_is_refused() {
    let svalbard = Site {
        lat_deg: 78.22,
        lon_deg: 15.65,
        height_m: 10.0,
    };
    let window = (utc("2022-06-20T00:00:00"), utc("2022-06-22T00:00:00"));
    let err = search(&svalbard, &NAUTICAL, window, 60.0, &catalogued(3)).unwrap_err();
    assert_eq!(err.reason, "the Sun never sets far enough");
    // At the solstice the Sun's lowest (lower culmination) is lat + dec - 90 = 78.22 + 23.44
    // - 90 = 11.66 deg; 1 deg covers the 60 s grid, refraction left out and the declination's
    // change over the two days.
    assert!(
        (err.lowest_sun_deg - 11.66).abs() < 1.0,
        "{}",
        err.lowest_sun_deg
    );
    let msg = err.to_string();
    assert!(
        msg.contains("Sun never sets") && msg.contains("-12"),
        "{msg}"
    );
}

/// La Palma in January: the GEO fragment (29-34 deg up all day, sunlit outside the eclipse
/// seasons) is seen all night; every grid instant of the spans found holds the three
/// conditions, the instants between spans do not, and the spans are the nights.
#[test]
fn winter_passes_are_found() {
    let la_palma = Site {
        lat_deg: 28.7606,
        lon_deg: -17.8816,
        height_m: 2396.0,
    };
    let (start, end) = (utc("2022-01-22T00:00:00"), utc("2022-01-24T00:00:00"));
    let object = catalogued(2);
    let spans = search(&la_palma, &NAUTICAL, (start, end), 30.0, &object).unwrap();
    assert!(!spans.is_empty());
    let mut held = 0;
    for k in 0..=(2 * 86_400 / 30) {
        let t = start + Duration::from_seconds(f64::from(k) * 30.0);
        let c = conditions(&la_palma, t, object(t).unwrap());
        let inside = spans.iter().any(|(a, b)| *a <= t && t <= *b);
        assert_eq!(inside, NAUTICAL.holds(&c), "{t}");
        if inside {
            held += 1;
            assert!(c.sun_alt_deg <= -12.0 && c.object_alt_deg >= 20.0 && c.object_sunlit);
        }
    }
    // Two nights from midnight to midnight: the end of one, a whole one, the start of the
    // next, as long as astropy's Sun says (tests/fixtures/sky/night.rs). Each of the four
    // edges may move by one 30 s grid instant (the Sun's 25 arcsec of model error and
    // astropy's aberration of it are ~2 s of its motion): 4 x 30 s = 0.034 h.
    assert_eq!(spans.len(), 3, "{spans:?}");
    let hours = f64::from(held) * 30.0 / 3600.0;
    assert!(
        (hours - LA_PALMA_NAUTICAL_NIGHT_H).abs() < 0.035,
        "{hours} h vs {LA_PALMA_NAUTICAL_NIGHT_H} h"
    );
}

/// A body 500 km over the site at local midnight is in the Earth's shadow; one 36 000 km up
/// is not (the shadow's cone reaches past GEO only near the equinoxes' eclipse season, and
/// this is January at 28.8 deg).
#[test]
fn the_shadow_is_judged() {
    let la_palma = Site {
        lat_deg: 28.7606,
        lon_deg: -17.8816,
        height_m: 2396.0,
    };
    // Local midnight at -17.9 deg: 01:11 UTC.
    let window = (utc("2022-01-22T00:50:00"), utc("2022-01-22T01:30:00"));
    let low = search(
        &la_palma,
        &NAUTICAL,
        window,
        60.0,
        &overhead(la_palma, 500.0),
    );
    let err = low.unwrap_err();
    assert_eq!(
        err.reason,
        "the object is in the Earth's shadow whenever it is up at night"
    );
    assert_eq!(err.sunlit_share, 0.0);
    let high = search(
        &la_palma,
        &NAUTICAL,
        window,
        60.0,
        &overhead(la_palma, 36_000.0),
    );
    assert_eq!(high.unwrap(), vec![window]);
}
