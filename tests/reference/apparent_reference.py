#!/usr/bin/env python3
"""Reference apparent star places for `crates/sky/src/apparent.rs` (`STARS`).

For each case: a UTC instant, an observer's GCRS position (km) and velocity (km/s) (a LEO
circular orbit, 7000 km), a star's ICRS (ra, dec) with no distance (infinitely far), its
apparent (ra, dec) seen by that observer: astropy's `GCRS(obstime, obsgeoloc, obsgeovel)`,
which aberrates by the Earth's barycentric velocity (ERFA epv00) plus `obsgeovel` and deflects
light by the Sun; and the Earth's barycentric velocity (km/s, ERFA epv00) at that instant.

Run: .venv/bin/python tests/reference/apparent_reference.py   (no network)
"""
import math
import warnings

import erfa
import numpy as np
import astropy.units as u
from astropy.coordinates import GCRS, ICRS, CartesianRepresentation, SkyCoord, get_sun
from astropy.time import Time
from astropy.utils import iers

iers.conf.auto_download = False
warnings.simplefilter("ignore")

CASES = [
    # utc, observer orbit phase (deg), star ra, dec (deg)
    ("2022-01-01T00:00:00", 0.0, 100.0, 23.0),
    ("2022-03-20T15:33:00", 90.0, 90.0, 0.0),
    ("2022-06-21T09:13:00", 200.0, 270.0, -66.0),
    ("2022-09-23T01:03:00", 300.0, 1.0, -5.0),
    ("2022-12-21T21:48:00", 45.0, 45.0, 89.5),
    ("2024-08-26T17:45:45", 130.0, 310.0, -30.0),
]


def main():
    print(f"    // astropy {__import__('astropy').__version__}, pyerfa {erfa.__version__}")
    for utc, phase, ra, dec in CASES:
        t = Time(utc, scale="utc")
        p = math.radians(phase)
        r, v = 7000.0, math.sqrt(398600.4418 / 7000.0)
        # An orbit inclined by 60 deg about the x axis.
        ci, si = math.cos(math.radians(60)), math.sin(math.radians(60))
        pos = np.array([r * math.cos(p), r * math.sin(p) * ci, r * math.sin(p) * si])
        vel = np.array([-v * math.sin(p), v * math.cos(p) * ci, v * math.cos(p) * si])
        frame = GCRS(obstime=t,
                     obsgeoloc=CartesianRepresentation(pos * u.km),
                     obsgeovel=CartesianRepresentation(vel * u.km / u.s))
        star = SkyCoord(ra=ra * u.deg, dec=dec * u.deg, frame=ICRS())
        app = star.transform_to(frame)
        # More than 40 deg from the Sun: light deflection below 0.011 arcsec.
        sun = get_sun(t)
        assert sun.separation(SkyCoord(ra=ra * u.deg, dec=dec * u.deg)).deg > 40
        tdb = t.tdb
        pvh, pvb = erfa.epv00(tdb.jd1, tdb.jd2)
        au_day = 149_597_870.7 / 86_400.0
        vb = pvb["v"] * au_day
        f = lambda x: ", ".join(f"{c:.12}" for c in x)
        print(f'    ("{utc}", [{f(pos)}], [{f(vel)}], ({ra:.1f}, {dec:.1f}), '
              f'({app.ra.deg:.12f}, {app.dec.deg:.12f}), [{f(vb)}]),')


if __name__ == "__main__":
    main()
