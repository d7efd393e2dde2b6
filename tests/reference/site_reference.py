#!/usr/bin/env python3
"""Reference figures for `crates/sky/src/site_tests.rs` (the table `tests/fixtures/sky/site.rs`):
objects of the repository's TLE catalogue seen from ground sites at three latitudes.

Run: pip install sgp4==2.27 astropy==8.0.2; python tests/reference/site_reference.py > tests/fixtures/sky/site.rs
     and python tests/reference/site_reference.py night > tests/fixtures/sky/night.rs
(in this project: /work/.venv-satsim/bin/python; no network: astropy's IERS download is off).

Earth orientation is set to zero (UT1 = UTC, no polar motion, no celestial pole offsets) by
replacing astropy's IERS table with a copy whose columns are zeroed: soig reads no EOP data, and
this checks its geometry, not the size of the EOP (which the module docs state).

For each site, each object and each pass above 20 deg in the two days from the catalogue's date,
the first whole minute above 20 deg and one 6 minutes later (if still above); for an object up
at the start (GEO), the start and 10 h later; prints:
  * the site's GCRS position (km) and velocity (km/s): astropy `EarthLocation.get_gcrs_posvel`;
  * the object's apparent (ra, dec), deg, in GCRS axes as seen from the site: python-sgp4 TEME
    -> astropy GCRS at the light-time instant t - tau (tau iterated to convergence), minus the
    site's GCRS position at t, aberrated by the site's GCRS velocity with `erfa.ab` (the
    object co-moves with the geocentre, so only the site's velocity aberrates it);
  * its geometric (alt, az), deg, at t (no light-time, no aberration): astropy TEME -> ITRS ->
    AltAz with pressure 0, through astropy's topocentric ITRS (its recipe for near objects);
  * its refracted altitude, deg: the same AltAz with 1010 hPa, 10 C, dry air, 0.55 um (ERFA
    `refco`'s model, independent of the Saemundsson formula soig uses).
With `night`: the hours in 2022-01-22T00:00 .. 2022-01-24T00:00 UTC when the Sun (astropy
`get_sun`, geometric altitude, pressure 0) is at most -12 deg up at La Palma, on a 30 s grid.
"""
import math
import warnings

import erfa
import numpy as np
import astropy.units as u
from astropy.coordinates import (GCRS, ITRS, TEME, AltAz, CartesianDifferential,
                                 CartesianRepresentation, EarthLocation, get_sun)
from astropy.time import Time, TimeDelta
from astropy.utils import iers
from sgp4.api import Satrec

iers.conf.auto_download = False
warnings.simplefilter("ignore")

table = iers.IERS_B.open(iers.IERS_B_FILE)
for col in ("UT1_UTC", "PM_x", "PM_y", "dX_2000A", "dY_2000A"):
    if col in table.colnames:
        table[col] = 0 * table[col]
iers.earth_orientation_table.set(table)

C_KM_S = 299792.458
CATALOG = "campaigns/data/catalog-2022-01-22.tle"
SITES = [  # (name, lat, lon, height m)
    ("Siding Spring", -31.2733, 149.0644, 1165.0),
    ("La Palma", 28.7606, -17.8816, 2396.0),
    ("Kiruna", 67.8558, 20.2253, 390.0),
]
OBJECTS = [3, 0, 2]  # catalogue indices: SENTINEL 3A (LEO), FENGYUN 1C DEB, MSG 4 DEB (GEO)
START = Time("2022-01-22T00:00:00", scale="utc")
MIN_ALT = 20.0


def load_catalog():
    lines = [l.rstrip("\n") for l in open(CATALOG) if l.strip()]
    return [(lines[i].strip(), lines[i + 1], lines[i + 2]) for i in range(0, len(lines), 3)]


def teme(sat, t):
    e, r, v = sat.sgp4_array(np.atleast_1d(t.jd1), np.atleast_1d(t.jd2))
    assert not np.any(e)
    return r, v


def gcrs_km(sat, t):
    r, v = teme(sat, t)
    c = TEME(CartesianRepresentation(r.T * u.km, differentials=CartesianDifferential(v.T * u.km / u.s)),
             obstime=t).transform_to(GCRS(obstime=t))
    return c.cartesian.xyz.to_value(u.km).T[0]


def alt_az(sat, t, loc, pressure_hpa):
    r, v = teme(sat, t)
    geo = TEME(CartesianRepresentation(r.T * u.km), obstime=t).transform_to(ITRS(obstime=t))
    # astropy's recipe for near objects: the topocentric ITRS vector, tagged with the site
    # (a geocentric ITRS coordinate would be re-centred through the celestial frames, which
    # aberrates it as if it were a star).
    topo = geo.cartesian.without_differentials() - loc.get_itrs(t).cartesian
    itrs = ITRS(topo, obstime=t, location=loc)
    frame = AltAz(obstime=t, location=loc, pressure=pressure_hpa * u.hPa,
                  temperature=10 * u.deg_C, relative_humidity=0, obswl=0.55 * u.um)
    aa = itrs.transform_to(frame)
    return np.ravel(aa.alt.deg), np.ravel(aa.az.deg)


def instants(sat, loc):
    t = START + TimeDelta(np.arange(0, 2 * 1440) * 60.0, format="sec")
    alt, _ = alt_az(sat, t, loc, 0.0)
    up = alt > MIN_ALT
    rises = np.flatnonzero(up & ~np.roll(up, 1))
    if up[0]:  # up all along (GEO) or at the start
        rises = np.concatenate(([0, 600], rises[rises > 0]))
    picked = []
    for i in rises[:2]:
        picked.append(i)
        if i + 6 < len(up) and up[i + 6]:
            picked.append(i + 6)
    return [t[i] for i in picked]


def main():
    cat = load_catalog()
    print(f"// astropy {__import__('astropy').__version__}, pyerfa {erfa.__version__}, "
          f"sgp4 {__import__('sgp4').__version__}; EOP zeroed (see the script).")
    print("// (lat, lon, height m), catalogue index, UTC, site GCRS km, km/s, apparent (ra, dec),")
    print("// geometric (alt, az), refracted alt (1010 hPa, 10 C).")
    print("#[rustfmt::skip]")
    print("const SITE_REFERENCE: &[SiteCase] = &[")
    for name, lat, lon, h in SITES:
        loc = EarthLocation.from_geodetic(lon * u.deg, lat * u.deg, h * u.m)
        for k in OBJECTS:
            _, l1, l2 = cat[k]
            sat = Satrec.twoline2rv(l1, l2)
            for t in instants(sat, loc):
                t = Time(t.isot[:19], scale="utc")
                pos, vel = loc.get_gcrs_posvel(t)
                site_r = pos.xyz.to_value(u.km)
                site_v = vel.xyz.to_value(u.km / u.s)
                tau = 0.0
                for _ in range(5):
                    obj = gcrs_km(sat, t - TimeDelta(tau, format="sec"))
                    tau = np.linalg.norm(obj - site_r) / C_KM_S
                rel = obj - site_r
                pnat = rel / np.linalg.norm(rel)
                beta = site_v / C_KM_S
                app = erfa.ab(pnat, beta, 1.0, math.sqrt(1.0 - beta @ beta))
                ra = math.degrees(math.atan2(app[1], app[0])) % 360.0
                dec = math.degrees(math.asin(app[2]))
                (alt,), (az,) = alt_az(sat, t, loc, 0.0)
                (alt_r,), _ = alt_az(sat, t, loc, 1010.0)
                f = lambda v: ", ".join(f"{x:.9f}" for x in v)
                print(f"    (({lat}, {lon}, {h}), {k}, \"{t.isot[:19]}\", [{f(site_r)}], "
                      f"[{f(site_v)}], ({ra:.9f}, {dec:.9f}), ({float(alt):.9f}, {float(az):.9f}), "
                      f"{float(alt_r):.9f}), // {name}, {cat[k][0]}")
    print("];")


def night():
    lat, lon, h = SITES[1][1:]
    loc = EarthLocation.from_geodetic(lon * u.deg, lat * u.deg, h * u.m)
    t = START + TimeDelta(np.arange(0, 2 * 86400 // 30 + 1) * 30.0, format="sec")
    alt = get_sun(t).transform_to(AltAz(obstime=t, location=loc)).alt.deg
    print(f"// tests/reference/site_reference.py night (astropy {__import__('astropy').__version__})")
    print(f"const LA_PALMA_NAUTICAL_NIGHT_H: f64 = {np.count_nonzero(alt <= -12.0) * 30.0 / 3600.0:.4f};")


if __name__ == "__main__":
    import sys
    night() if sys.argv[1:] == ["night"] else main()
