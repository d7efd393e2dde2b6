#!/usr/bin/env python3
"""Independent check of a breakup cloud's fragments, for tests/breakup.rs (issue #45).

Reads a run of campaigns/breakup.toml: every fragment it shows (truth `source` generated)
with its geometric GCRS state at mid-exposure. Turns that state into TEME with astropy,
integrates it BACK to the breakup epoch with a two-body + J2 force model of its own (WGS72
mu and J2, as SGP4; RK4, 10 s steps; TEME taken as inertial over the hour), and measures
how far it lands from the parent's place at the epoch by python-sgp4 (WGS72, opsmode 'a').
Every fragment left from its parent: the miss is the disagreement of SGP4/SDP4 and this
simpler force model over the hour (no lunisolar terms here), not a fragment's ejection.
Also prints the speed each fragment left with (the back-integrated velocity less the
parent's), which the model draws log-normally (tens of m/s for an explosion).

Prints JSON: per fragment its id, image, mid-exposure GCRS position (to pin what was
checked), miss (km) and ejection speed (m/s). Pinned in
tests/fixtures/breakup/cloud_reference.json.

Run: soig run campaigns/breakup.toml
     python tests/reference/breakup_cloud_reference.py runs/breakup > tests/fixtures/breakup/cloud_reference.json
(here /work/.venv-satsim/bin/python: sgp4 2.27, astropy 8.0.2, numpy)
"""
import json
import pathlib
import sys

import numpy as np
import astropy.units as u
from astropy.coordinates import GCRS, TEME, CartesianDifferential, CartesianRepresentation
from astropy.time import Time
from sgp4.api import WGS72, Satrec

MU = 398600.8
J2 = 0.001082616
RE = 6378.135
PARENT = 90227
EPOCH = "2022-01-22T00:10:00"


def accel(r):
    x, y, z = r
    rn = np.linalg.norm(r)
    k = 1.5 * J2 * MU * RE ** 2 / rn ** 5
    f = 5.0 * z * z / (rn * rn)
    return -MU * r / rn ** 3 + k * np.array([x * (f - 1.0), y * (f - 1.0), z * (f - 3.0)])


def integrate(r, v, seconds, step=10.0):
    n = int(round(abs(seconds) / step))
    h = seconds / n
    for _ in range(n):
        k1r, k1v = v, accel(r)
        k2r, k2v = v + 0.5 * h * k1v, accel(r + 0.5 * h * k1r)
        k3r, k3v = v + 0.5 * h * k2v, accel(r + 0.5 * h * k2r)
        k4r, k4v = v + h * k3v, accel(r + h * k3r)
        r = r + h / 6.0 * (k1r + 2 * k2r + 2 * k3r + k4r)
        v = v + h / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v)
    return r, v


def parent_state(root):
    lines = pathlib.Path(root, "campaigns/data/geo-belt-2022-01-22.tle").read_text().splitlines()
    i = next(k for k, l in enumerate(lines) if l.startswith(f"1 {PARENT}"))
    sat = Satrec.twoline2rv(lines[i], lines[i + 1], WGS72)
    t = Time(EPOCH, scale="utc")
    e, r, v = sat.sgp4(t.jd1, t.jd2)
    assert e == 0
    return t, np.array(r), np.array(v)


def main():
    run = pathlib.Path(sys.argv[1])
    root = pathlib.Path(__file__).resolve().parents[2]
    t0, r0, v0 = parent_state(root)
    out = []
    for f in sorted(run.glob("truth/img_*.json")):
        if not f.stem[4:].isdigit():
            continue
        truth = json.loads(f.read_text())
        start = Time(truth["start_utc"], scale="utc")
        mid = start + truth["exposure_s"] / 2.0 * u.s
        for o in truth["objects"]:
            if o["source"] != "generated":
                continue
            e = o["ephemeris"]
            rep = CartesianRepresentation(e["debris_gcrs_km"] * u.km).with_differentials(
                CartesianDifferential(e["debris_gcrs_km_s"] * u.km / u.s))
            teme = GCRS(rep, obstime=mid).transform_to(TEME(obstime=mid)).cartesian
            r = teme.xyz.to_value(u.km)
            v = teme.differentials["s"].d_xyz.to_value(u.km / u.s)
            r1, v1 = integrate(r, v, (t0 - mid).to_value(u.s))
            out.append({"image": f.stem, "id": o["norad"], "debris_gcrs_km": e["debris_gcrs_km"],
                        "miss_km": float(np.linalg.norm(r1 - r0)),
                        "ejection_m_s": float(np.linalg.norm(v1 - v0) * 1e3)})
    misses = [x["miss_km"] for x in out]
    print(json.dumps({"source": "tests/reference/breakup_cloud_reference.py", "parent": PARENT,
                      "epoch": EPOCH, "max_miss_km": max(misses), "fragments": out}, indent=1))


main()
