#!/usr/bin/env python3
"""Synthetic TLE populations for catalogue scenes (`[population]`, issue #45).

    geo        a GEO belt band: objects near the geostationary ring between two east
               longitudes at the epoch, with small inclinations and eccentricities (a crowded
               stretch of the belt, for a stare);
    replicate  N copies of the objects of a TLE file, each with its RAAN and mean anomaly
               drawn anew (the catalogue's orbit regimes, spread around the Earth: the culling
               benchmark's 25,000-object population).

Each set is built with python-sgp4's `Satrec.sgp4init` (WGS72, AFSPC mode 'a', as soig
propagates) and written by `sgp4.exporter.export_tle` (checksums included), with a name line
`SYN <kind> <number>` and NORAD numbers from --first-norad. Deterministic for a --seed.

Run: pip install sgp4==2.27; python scripts/population.py geo --count 400 > file.tle
     (here: /work/.venv-satsim/bin/python scripts/population.py ...)
"""
import argparse
import math
import random
import sys

from sgp4.api import WGS72, Satrec, jday
from sgp4.exporter import export_tle
from sgp4.propagation import gstime

# Days from 1949-12-31 00:00 UT to the Julian date 2433281.5 (sgp4init's epoch origin).
SGP4_EPOCH_JD = 2433281.5
SIDEREAL_REV_PER_DAY = 1.00273791


def parse_epoch(text):
    date, time = text.split("T")
    y, mo, d = (int(x) for x in date.split("-"))
    h, mi, s = (float(x) for x in time.rstrip("Z").split(":"))
    jd, fr = jday(y, mo, d, int(h), int(mi), s)
    return jd + fr


def satrec(norad, epoch_jd, ecc, argp, inc, mo, rev_per_day, raan, bstar=0.0):
    sat = Satrec()
    sat.sgp4init(
        WGS72, "a", norad, epoch_jd - SGP4_EPOCH_JD, bstar, 0.0, 0.0, ecc,
        argp, inc, mo, rev_per_day * 2.0 * math.pi / 1440.0, raan,
    )
    return sat


def write(sat, name, out):
    line1, line2 = export_tle(sat)
    out.write(f"{name}\n{line1}\n{line2}\n")


def geo(args, out):
    rng = random.Random(args.seed)
    epoch = parse_epoch(args.epoch)
    gmst = gstime(epoch)
    for k in range(args.count):
        lon = math.radians(rng.uniform(args.lon_min, args.lon_max))
        inc = math.radians(rng.uniform(0.0, args.inc_max))
        raan = rng.uniform(0.0, 2.0 * math.pi)
        ecc = rng.uniform(0.0, 5e-4)
        # On a near-circular, near-equatorial orbit the angle from the equinox is
        # RAAN + argp + M: the sub-satellite longitude at the epoch is that minus GMST.
        mo = (gmst + lon - raan) % (2.0 * math.pi)
        # Drift up to +-0.5 deg/day about the sidereal rate.
        n = SIDEREAL_REV_PER_DAY + rng.uniform(-0.5, 0.5) / 360.0
        sat = satrec(args.first_norad + k, epoch, ecc, 0.0, inc, mo, n, raan)
        write(sat, f"SYN GEO {k + 1}", out)


def replicate(args, out):
    rng = random.Random(args.seed)
    parents = []
    with open(args.tle_file) as f:
        lines = [l.rstrip() for l in f if l.strip()]
    for i, l in enumerate(lines):
        if l.startswith("1 ") and i + 1 < len(lines) and lines[i + 1].startswith("2 "):
            parents.append(Satrec.twoline2rv(l, lines[i + 1], WGS72))
    if not parents:
        sys.exit(f"{args.tle_file}: no TLE")
    for k in range(args.count):
        p = parents[k % len(parents)]
        epoch = p.jdsatepoch + p.jdsatepochF
        sat = satrec(
            args.first_norad + k, epoch, p.ecco, p.argpo, p.inclo,
            rng.uniform(0.0, 2.0 * math.pi), p.no_kozai * 1440.0 / (2.0 * math.pi),
            rng.uniform(0.0, 2.0 * math.pi), p.bstar,
        )
        write(sat, f"SYN COPY {k + 1} OF {p.satnum}", out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="kind", required=True)
    g = sub.add_parser("geo")
    g.add_argument("--count", type=int, default=400)
    g.add_argument("--lon-min", type=float, default=0.0, help="east longitude, deg")
    g.add_argument("--lon-max", type=float, default=40.0)
    g.add_argument("--inc-max", type=float, default=3.0, help="deg")
    g.add_argument("--epoch", default="2022-01-22T00:00:00")
    g.add_argument("--first-norad", type=int, default=90001)
    g.add_argument("--seed", type=int, default=1)
    r = sub.add_parser("replicate")
    r.add_argument("tle_file")
    r.add_argument("--count", type=int, default=25000)
    r.add_argument("--first-norad", type=int, default=70000)
    r.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    if args.first_norad + args.count - 1 > 99999:
        sys.exit("NORAD numbers beyond 99999 do not fit a TLE's 5 columns")
    (geo if args.kind == "geo" else replicate)(args, sys.stdout)


if __name__ == "__main__":
    main()
