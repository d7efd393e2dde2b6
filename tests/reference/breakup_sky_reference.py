#!/usr/bin/env python3
"""Independent places of a breakup cloud's scene, for tests/breakup.rs (issue #45).

Reads a run of campaigns/breakup.toml: the fragments' catalogue entries soig wrote
(`population/generated.omm.json`: the SGP4 mean elements soig fitted to each fragment's state
at the breakup, CCSDS OMM keywords), its truth sidecars (each frame's start and exposure) and
its FITS headers (the WCS). Propagates every fragment from those elements and every object of
the belt's TLE file (less the observer and the exploded parent, NORAD 90227) with python-sgp4
(sgp4init, WGS72, AFSPC opsmode 'a', as soig), the observer from the catalogue's TLE, turns
TEME into GCRS with astropy and gives each object's geometric direction from the observer
(no light time, no aberration: the campaign keeps render.apparent_positions off) at
mid-exposure and at the first and last trajectory samples, as (RA, Dec) and through the FITS
WCS (astropy.wcs) as pixels; an object is in the field when any of 201 instants over the
exposure puts it inside the image. The per-frame work is catalogue_reference.py's (the GEO
stare's check), with this population.

Prints JSON: the sha256 of the OMM file read (so the test knows these are its fragments), the
fragments' count, and per frame its start and each object in or within 20 px of the field:
its id, whether it is in the field, its mid (RA, Dec) and its first and last sample pixels.
Pinned in tests/fixtures/breakup/sky_reference.json.

Run: soig run campaigns/breakup.toml
     python tests/reference/breakup_sky_reference.py runs/breakup > tests/fixtures/breakup/sky_reference.json
(here /work/.venv-satsim/bin/python: sgp4 2.27, astropy 8.0.2, numpy)
"""
import hashlib
import json
import pathlib
import sys

from astropy.time import Time
from sgp4.api import WGS72, Satrec

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import catalogue_reference as catalogue  # noqa: E402

PARENT = 90227
OMM = "population/generated.omm.json"


def read_omm(path):
    """Satrecs of the OMM entries of `path`, initialised by sgp4init in opsmode 'a'."""
    sats = []
    for e in json.load(open(path)):
        epoch = Time(e["EPOCH"], format="isot", scale="utc")
        # sgp4init's epoch: days since 1949 December 31 00:00 UTC; angles in radians, mean
        # motion in radians per minute.
        days = (epoch.jd1 - 2433281.5) + epoch.jd2
        rad = 3.141592653589793 / 180.0
        s = Satrec()
        s.sgp4init(WGS72, "a", 0, days, float(e["BSTAR"]),
                   float(e["MEAN_MOTION_DOT"]) * 2 * 3.141592653589793 / 1440.0 ** 2,
                   float(e["MEAN_MOTION_DDOT"]) * 2 * 3.141592653589793 / 1440.0 ** 3,
                   float(e["ECCENTRICITY"]), float(e["ARG_OF_PERICENTER"]) * rad,
                   float(e["INCLINATION"]) * rad, float(e["MEAN_ANOMALY"]) * rad,
                   float(e["MEAN_MOTION"]) * 2 * 3.141592653589793 / 1440.0,
                   float(e["RA_OF_ASC_NODE"]) * rad)
        # A generated id has more digits than a Satrec's number holds: kept beside it.
        sats.append((int(e["NORAD_CAT_ID"]), s))
    return sats


class Numbered:
    """A Satrec under an id of any size (catalogue_reference reads `satnum`)."""

    def __init__(self, satnum, sat):
        self.satnum = satnum
        self.sat = sat

    def sgp4(self, jd1, jd2):
        return self.sat.sgp4(jd1, jd2)


def main():
    run = pathlib.Path(sys.argv[1])
    omm = run / OMM
    fragments = [Numbered(n, s) for n, s in read_omm(omm)]
    belt = [s for s in catalogue.read_tles(catalogue.POPULATION)
            if s.satnum not in (catalogue.OBSERVER, PARENT)]
    frames = catalogue.frames_of(run, belt + fragments)
    json.dump({
        "omm_sha256": hashlib.sha256(omm.read_bytes()).hexdigest(),
        "fragments": len(fragments),
        "frames": frames,
    }, sys.stdout, indent=1)
    print()


if __name__ == "__main__":
    main()
