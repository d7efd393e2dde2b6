#!/usr/bin/env python3
"""Reference figures for the tests of crates/sky/src/orbit/ and crates/sky/src/frames.rs (the tables of
tests/fixtures/sky/orbit_teme.rs and teme_gcrs.csv, and the figures inline in those tests).

Run: python3 reference/orbit_reference.py [path/to/catalog.tle]
Needs the PyPI packages sgp4 (2.x), astropy and numpy (pyerfa comes with astropy). No network:
astropy's IERS auto-download is switched off, so it uses the tables bundled with it.

Prints Rust literals that the tests pin:
  * TEME positions (km) from python-sgp4, WGS72, opsmode 'a' (AFSPC compatibility), for every TLE of
    the catalog at the TLE epoch, epoch + 1440 min and three UTC dates in 2022; minutes since epoch are
    computed exactly (rational arithmetic) from the TLE epoch field, which is UTC;
  * the same for the Table-1 orbit of NORAD 40649 built with sgp4init;
  * TEME -> GCRS rotations from astropy (TEME frame -> GCRS, obstime UTC), and from the same
    IAU-76/80 route as the Rust code, built from pyerfa routines (pmat76, nut80, obl80, bp00), which
    checks the Rust transcription of the nutation series to far below a milliarcsecond: written
    to tests/fixtures/sky/teme_gcrs.csv rather than printed.
"""
import sys
from datetime import datetime, timedelta
from fractions import Fraction
from pathlib import Path

import numpy as np
import astropy
import erfa
from astropy.utils import iers

iers.conf.auto_download = False
import astropy.units as u
from astropy.coordinates import GCRS, TEME, CartesianRepresentation
from astropy.time import Time
from sgp4.api import WGS72, Satrec

CATALOG = sys.argv[1] if len(sys.argv) > 1 else "campaigns/data/catalog-2022-01-22.tle"
DATES = ["2022-01-01T00:00:00", "2022-06-15T12:34:56", "2022-12-31T23:00:00"]
SGP4_EPOCH0 = datetime(1949, 12, 31)  # sgp4init's epoch: days since 1949-12-31 00:00 UT


def tle_epoch(line1):
    """Exact TLE epoch (UTC) as (datetime of the year start, Fraction of days since it)."""
    yy = int(line1[18:20])
    year = yy + (2000 if yy < 57 else 1900)
    return datetime(year, 1, 1), Fraction(line1[20:32].strip()) - 1


def minutes_between(start, start_days, target):
    """(target - (start + start_days)) in minutes, exactly; no leap second falls in 2022."""
    delta = target - start
    seconds = Fraction(delta.days * 86400 + delta.seconds) + Fraction(delta.microseconds, 10**6)
    return float((seconds - start_days * 86400) / 60)


def afspc_satrec(l1, l2):
    """Satrec in opsmode 'a': twoline2rv parses (opsmode 'i'), sgp4init re-initialises in 'a'."""
    s = Satrec.twoline2rv(l1, l2, WGS72)
    a = Satrec()
    a.sgp4init(WGS72, "a", s.satnum, (s.jdsatepoch - 2433281.5) + s.jdsatepochF, s.bstar, s.ndot,
               s.nddot, s.ecco, s.argpo, s.inclo, s.mo, s.no_kozai, s.nodeo)
    return s, a


def when(label):
    """Rust literal of the instant a row is for (`When` of crates/sky/src/testing.rs)."""
    if label.startswith("epoch"):
        return f"When::SinceEpoch({float(label[5:] or 0)!r})"
    d = datetime.fromisoformat(label)
    return f"When::Utc({d.year}, {d.month}, {d.day}, {d.hour}, {d.minute}, {d.second})"


def fmt(v):
    return "[" + ", ".join(f"{x:.9f}" for x in v) + "]"


def read_tles(path):
    lines = [ln.rstrip() for ln in open(path) if ln.strip()]
    out, i = [], 0
    while i < len(lines):
        if lines[i].startswith("1 ") and i + 1 < len(lines) and lines[i + 1].startswith("2 "):
            out.append((None, lines[i], lines[i + 1])); i += 2
        else:
            out.append((lines[i].strip(), lines[i + 1], lines[i + 2])); i += 3
    return out


def teme_block():
    print("// ---- TEME positions (km), python-sgp4 WGS72 opsmode 'a' ----")
    print("// (norad, label, minutes since TLE epoch, [x, y, z])")
    max_ai = 0.0
    for name, l1, l2 in read_tles(CATALOG):
        s_i, s_a = afspc_satrec(l1, l2)
        y0, d0 = tle_epoch(l1)
        period = 2 * np.pi / s_a.no_kozai
        cases = [("epoch", 0.0), ("epoch+1440", 1440.0)]
        cases += [(d, minutes_between(y0, d0, datetime.fromisoformat(d))) for d in DATES]
        for label, tsince in cases:
            e, r, _ = s_a.sgp4_tsince(tsince)
            assert e == 0, (name, label, e)
            e_i, r_i, _ = s_i.sgp4_tsince(tsince)
            max_ai = max(max_ai, float(np.linalg.norm(np.subtract(r, r_i))))
            print(f'({s_a.satnum}, {when(label)}, {tsince!r}, {fmt(r)}),')
        print(f"// {s_a.satnum} {name}: Kozai period {period:.3f} min")
    print(f"// max |opsmode a - opsmode i| over these cases: {max_ai:.3e} km")


def table1_block():
    print("// ---- NORAD 40649, paper Table 1, sgp4init WGS72 opsmode 'a' ----")
    re = 6378.135
    period, incl, apo, peri = 375.48, 52.78, 20490.0, 1235.0
    ra, rp = re + apo, re + peri
    ecc = (ra - rp) / (ra + rp)
    epoch = datetime(2022, 1, 1)
    s = Satrec()
    s.sgp4init(WGS72, "a", 40649, (epoch - SGP4_EPOCH0).days, 0.0, 0.0, 0.0, ecc, 0.0,
               np.radians(incl), 0.0, 2 * np.pi / period, 0.0)
    print(f"// eccentricity {ecc!r}")
    for label, tsince in [("epoch", 0.0), ("epoch+60", 60.0), ("epoch-90", -90.0), ("epoch+1440", 1440.0),
                          (DATES[1], minutes_between(epoch, Fraction(0), datetime.fromisoformat(DATES[1])))]:
        e, r, _ = s.sgp4_tsince(tsince)
        assert e == 0
        print(f'({when(label)}, {tsince!r}, {fmt(r)}),  // |r| = {np.linalg.norm(r):.3f} km')
    print(f"// perigee radius {rp:.3f} km")


def R3(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def vallado_route(r, t):
    """TEME -> TOD (equation of the equinoxes, geometric term) -> MOD (IAU-80) -> J2000 (IAU-76)
    -> GCRS (IERS 2003 frame bias)."""
    tt = t.tt
    p = erfa.pmat76(tt.jd1, tt.jd2)              # J2000 mean -> MOD
    dpsi, deps = erfa.nut80(tt.jd1, tt.jd2)
    eps0 = erfa.obl80(tt.jd1, tt.jd2)
    n = erfa.numat(eps0, dpsi, deps)              # MOD -> TOD
    rb = erfa.bp00(tt.jd1, tt.jd2)[0]             # GCRS -> J2000 mean (frame bias)
    return rb.T @ (p.T @ (n.T @ (R3(-dpsi * np.cos(eps0)) @ r)))


def astropy_gcrs(r, t):
    teme = TEME(CartesianRepresentation(np.asarray(r) * u.km), obstime=t)
    return teme.transform_to(GCRS(obstime=t)).cartesian.xyz.to_value(u.km)


def arcsec(a, b):
    return float(np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b)), np.dot(a, b))) * 3600)


GCRS_CSV = Path(__file__).resolve().parents[1] / "fixtures/sky/teme_gcrs.csv"


def gcrs_csv(provenance, rows):
    """tests/fixtures/sky/teme_gcrs.csv: a '#' line of provenance, a header, then a row per
    (UTC, TEME km, astropy GCRS km, IAU-76/80 route via pyerfa km), the km as fmt() writes them."""
    header = ["utc"] + [f"{what}_{axis}_km" for what in ("teme", "astropy_gcrs", "erfa_gcrs") for axis in "xyz"]
    lines = [f"# {provenance}", ",".join(header)]
    lines += [",".join([ts] + [f"{x:.9f}" for x in (*v, *a, *e)]) for ts, v, a, e in rows]
    return "\n".join(lines) + "\n"


def gcrs_block():
    vecs = [[7000.0, 0.0, 0.0], [0.0, 7000.0, 0.0], [0.0, 0.0, 7000.0], [-4000.0, 3000.0, 20000.0],
            [42164.0, -1000.0, 500.0]]
    times = DATES + ["2023-01-01T06:00:00"]
    worst_raw, worst_bias = 0.0, 0.0
    rows = []
    for ts in times:
        t = Time(ts, scale="utc")
        for v in vecs:
            a = astropy_gcrs(v, t)
            e = vallado_route(np.array(v), t)
            worst_bias = max(worst_bias, arcsec(a, e))
            rb = erfa.bp00(t.tt.jd1, t.tt.jd2)[0]
            worst_raw = max(worst_raw, arcsec(a, rb @ e))
            rows.append((ts, v, a, e))
    provenance = (f"Written by tests/reference/orbit_reference.py (astropy {astropy.__version__} with its bundled "
                  f"IERS tables, pyerfa {erfa.__version__}); read by the unit tests of crates/sky/src/frames.rs.")
    GCRS_CSV.write_text(gcrs_csv(provenance, rows))
    print(f"// ---- TEME -> GCRS: wrote {GCRS_CSV} ----")
    print(f"// astropy vs IAU-76/80 + frame bias: max {worst_bias:.4f} arcsec; "
          f"without the frame bias (J2000 mean equator): max {worst_raw:.4f} arcsec")


def propagated_gcrs_block():
    print("// ---- SENTINEL 3A (41335) GCRS position: python-sgp4 'a' TEME -> astropy GCRS ----")
    for name, l1, l2 in read_tles(CATALOG):
        if l1[2:7] != "41335":
            continue
        _, s = afspc_satrec(l1, l2)
        y0, d0 = tle_epoch(l1)
        ts = DATES[1]
        e, r, _ = s.sgp4_tsince(minutes_between(y0, d0, datetime.fromisoformat(ts)))
        print(f'({when(ts)}, {fmt(astropy_gcrs(r, Time(ts, scale="utc")))}),')


def checksum(line):
    return sum(int(c) if c.isdigit() else (1 if c == "-" else 0) for c in line[:68]) % 10


def decay_block():
    print("// ---- decay: low, high-drag TLE; python-sgp4 error code at 30 days ----")
    l1 = "1 99999U 22001A   22001.00000000  .01000000  00000-0  50000-2 0  999"
    l2 = "2 99999  51.6000 100.0000 0005000  90.0000 270.0000 16.2000000000001"
    l1 += str(checksum(l1)); l2 += str(checksum(l2))
    print(f'"{l1}"\n"{l2}"')
    _, s = afspc_satrec(l1, l2)
    first = None
    for k in range(0, 30 * 24 + 1):
        e, r, _ = s.sgp4_tsince(60.0 * k)
        if e and first is None:
            first = (k, e)
    e, r, _ = s.sgp4_tsince(0.0)
    print(f"// at epoch: |r| = {np.linalg.norm(r):.3f} km; first error on an hourly grid: hour {first[0]}, code {first[1]}")


if __name__ == "__main__":
    teme_block()
    table1_block()
    gcrs_block()
    propagated_gcrs_block()
    decay_block()
