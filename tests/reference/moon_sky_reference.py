"""Reference Moon and Sun geometry over a ground site for the sky model (`GroundGate::sky`),
pinned in tests/ground_air.rs (`MOON_REFERENCE`).

Siding Spring (-31.2733, 149.0644, 1165 m); at each instant (UTC) and boresight (RA, Dec in
GCRS, deg) prints the Moon's zenith distance (astropy `get_body('moon')` with the site's
location: topocentric, AltAz with pressure 0: geometric), the Sun's altitude (`get_sun`, same
frame), the boresight's separation from the topocentric Moon (GCRS), and the Moon's phase angle
(Sun - Moon - site, from the geocentric GCRS positions of both).
Usage: /work/.venv-satsim/bin/python tests/reference/moon_sky_reference.py
(no network: astropy's built-in ephemeris, its bundled IERS table).
"""
import numpy as np
import astropy.units as u
from astropy.coordinates import AltAz, EarthLocation, GCRS, SkyCoord, get_body, get_sun
from astropy.time import Time
from astropy.utils import iers

iers.conf.auto_download = False
site = EarthLocation.from_geodetic(149.0644 * u.deg, -31.2733 * u.deg, 1165.0 * u.m)
CASES = [
    ("2022-01-22T12:00:00", 120.0, -40.0),
    ("2022-01-23T14:30:00", 200.0, -20.0),
    ("2022-01-18T13:00:00", 110.0, 20.0),   # near full Moon
    ("2022-01-25T16:00:00", 250.0, -60.0),
]
for iso, ra, dec in CASES:
    t = Time(iso, scale="utc")
    altaz = AltAz(obstime=t, location=site, pressure=0 * u.hPa)
    moon = get_body("moon", t, location=site)  # topocentric GCRS
    sun = get_sun(t)
    moon_z = 90.0 - moon.transform_to(altaz).alt.deg
    sun_alt = sun.transform_to(altaz).alt.deg
    target = SkyCoord(ra * u.deg, dec * u.deg, frame=GCRS(obstime=t))
    sep = target.separation(SkyCoord(moon.ra, moon.dec, frame=GCRS(obstime=t))).deg
    mg = get_body("moon", t).cartesian.xyz.to_value(u.km)
    sg = sun.cartesian.xyz.to_value(u.km)
    # The phase angle at the Moon, between the Sun and the site.
    site_gcrs = site.get_gcrs_posvel(t)[0].xyz.to_value(u.km)
    to_sun = sg - mg
    to_site = site_gcrs - mg
    phase = np.degrees(np.arccos(np.dot(to_sun, to_site) / np.linalg.norm(to_sun) / np.linalg.norm(to_site)))
    print(f'    ("{iso}", {ra}, {dec}, {moon_z:.4f}, {sun_alt:.4f}, {sep:.4f}, {phase:.4f}),')
