#!/usr/bin/env python3
"""Independent places of a catalogue scene's objects, for tests/catalogue.rs (issue #45).

Reads a run of campaigns/geo-stare.toml (its truth sidecars for each frame's start and
exposure, its FITS headers for the WCS), propagates EVERY object of the campaign's population
and the observer with python-sgp4 (WGS72, AFSPC opsmode 'a', as soig), turns TEME into GCRS
with astropy, and gives each object's geometric direction from the observer (the campaign
keeps `render.apparent_positions` off: no light time, no aberration) at mid-exposure and at
the times of the first and last trajectory samples (0.5 and n - 0.5 of n = 2000 equal
slices), as (RA, Dec) and as pixels through the FITS WCS (astropy.wcs, 0-based). An object
is in the field when any of 201 instants over the exposure puts it within the image
(pixel centres at integers: [-0.5, size - 0.5)).

Prints JSON: per frame its start, and for each object in the field, or within 20 px of it,
its NORAD number, whether it is in the field, its mid (RA, Dec) and its first and last
sample pixels. The figures are pinned in tests/fixtures/catalogue/geo_stare_reference.json.

Run: pip install sgp4==2.27 astropy==8.0.2
     soig run campaigns/geo-stare.toml
     python tests/reference/catalogue_reference.py runs/geo-stare > tests/fixtures/catalogue/geo_stare_reference.json
(here with /work/.venv-satsim/bin/python)
"""
import json
import pathlib
import sys
import warnings

import numpy as np
import astropy.units as u
from astropy.coordinates import GCRS, TEME, CartesianRepresentation
from astropy.io import fits
from astropy.time import Time
from astropy.utils import iers
from astropy.wcs import WCS
from sgp4.api import WGS72, Satrec

iers.conf.auto_download = False
warnings.simplefilter("ignore")

ROOT = pathlib.Path(__file__).resolve().parents[2]
POPULATION = ROOT / "campaigns/data/geo-belt-2022-01-22.tle"
CATALOGUE = ROOT / "campaigns/data/catalog-2022-01-22.tle"
OBSERVER = 41335
SAMPLES = 2000
MARGIN_PX = 20.0


def read_tles(path):
    lines = [l.rstrip() for l in open(path) if l.strip()]
    sats = []
    for i, l in enumerate(lines):
        if l.startswith("1 ") and i + 1 < len(lines) and lines[i + 1].startswith("2 "):
            p = Satrec.twoline2rv(l, lines[i + 1], WGS72)
            # twoline2rv parses in opsmode 'i'; sgp4init re-initialises in 'a'.
            a = Satrec()
            a.sgp4init(WGS72, "a", p.satnum, (p.jdsatepoch - 2433281.5) + p.jdsatepochF,
                       p.bstar, p.ndot, p.nddot, p.ecco, p.argpo, p.inclo, p.mo,
                       p.no_kozai, p.nodeo)
            sats.append(a)
    return sats


def gcrs_km(sats, t):
    """GCRS positions (km) of `sats` at Time `t`, shape (n, 3)."""
    r = []
    for s in sats:
        e, p, _ = s.sgp4(t.jd1, t.jd2)
        r.append(p if e == 0 else [np.nan] * 3)
    r = np.array(r).T
    teme = TEME(CartesianRepresentation(r * u.km), obstime=t)
    return teme.transform_to(GCRS(obstime=t)).cartesian.xyz.to(u.km).value.T


def radec(v):
    ra = np.degrees(np.arctan2(v[:, 1], v[:, 0])) % 360.0
    dec = np.degrees(np.arcsin(v[:, 2] / np.linalg.norm(v, axis=1)))
    return ra, dec


def main():
    run = pathlib.Path(sys.argv[1])
    population = [s for s in read_tles(POPULATION) if s.satnum != OBSERVER]
    json.dump({"frames": frames_of(run, population)}, sys.stdout, indent=1)
    print()


def frames_of(run, population):
    """Per frame of `run`: the objects of `population` (Satrec) in or near its field."""
    observer = [s for s in read_tles(CATALOGUE) if s.satnum == OBSERVER]
    frames = []
    for truth_path in sorted((run / "truth").glob("img_*.json")):
        truth = json.load(open(truth_path))
        stem = truth_path.stem
        header = fits.getheader(run / "fits" / f"{stem}.fits")
        wcs = WCS(header)
        width, height = header["NAXIS1"], header["NAXIS2"]
        start = Time(truth["start_utc"], scale="utc")
        exposure = truth["exposure_s"]

        def place(f):
            t = start + f * exposure * u.s
            los = gcrs_km(population, t) - gcrs_km(observer, t)[0]
            ra, dec = radec(los)
            x, y = wcs.all_world2pix(ra, dec, 0)
            return ra, dec, x, y

        inside = np.zeros(len(population), bool)
        near = np.zeros(len(population), bool)
        for f in np.linspace(0.0, 1.0, 201):
            _, _, x, y = place(f)
            inside |= (x >= -0.5) & (x < width - 0.5) & (y >= -0.5) & (y < height - 0.5)
            near |= (x >= -0.5 - MARGIN_PX) & (x < width - 0.5 + MARGIN_PX) & (
                y >= -0.5 - MARGIN_PX) & (y < height - 0.5 + MARGIN_PX)
        ra_m, dec_m, _, _ = place(0.5)
        _, _, x0, y0 = place(0.5 / SAMPLES)
        _, _, x1, y1 = place(1.0 - 0.5 / SAMPLES)
        objects = [
            {
                "norad": int(population[k].satnum),
                "in_field": bool(inside[k]),
                "radec_mid_deg": [float(ra_m[k]), float(dec_m[k])],
                "first_sample_px": [float(x0[k]), float(y0[k])],
                "last_sample_px": [float(x1[k]), float(y1[k])],
            }
            for k in np.flatnonzero(near)
        ]
        frames.append({"image": stem, "start_utc": truth["start_utc"], "objects": objects})
    return frames


if __name__ == "__main__":
    main()
