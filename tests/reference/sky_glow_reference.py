"""Reference night-sky brightness over a ground site, V mag/arcsec^2, written from the papers'
equations (independently of soig's Rust):

- Krisciunas & Schaefer (1991, PASP 103, 1033): eq. 1 (nanolamberts of V mag/arcsec^2),
  eq. 2 (dark sky at zenith distance Z), eq. 3 (X = (1 - 0.96 sin^2 Z)^-1/2), eqs. 15-21
  (the Moon's scattered light: f(rho) = 10^5.36 (1.06 + cos^2 rho) + 10^(6.15 - rho/40),
  6.2e7 / rho^2 for the Mie term below 10 deg; I* = 10^(-0.4 (3.84 + 0.026 |a| + 4e-9 a^4))),
  eq. 22 (the change in V, -2.5 log10((B_moon + B0) / B0));
- twilight: Thorstensen's skycalc polynomial of the zenith's brightening against the Sun's
  altitude (fit to Meinel & Meinel 1983), 0 at or below -18 deg.

Each row: (alpha, rho, moon Z, target Z, k, zenith V, sun altitude) -> (delta V of the Moon,
V with the Moon, V with the Moon and twilight). Pinned in crates/sim/src/sky_glow.rs (its tests).
Usage: .venv/bin/python tests/reference/sky_glow_reference.py
"""
import numpy as np

CASES = [
    # alpha, rho, moon_z, z, k, zenith V, sun alt
    (0.0, 60.0, 40.0, 20.0, 0.172, 21.587, -30.0),   # full Moon, Mauna Kea's k and dark sky
    (0.0, 30.0, 40.0, 50.0, 0.172, 21.587, -30.0),
    (60.0, 90.0, 60.0, 10.0, 0.15, 21.7, -30.0),
    (90.0, 20.0, 30.0, 45.0, 0.2, 21.5, -15.0),      # quarter Moon, nautical twilight
    (120.0, 5.0, 50.0, 50.0, 0.172, 21.587, -20.0),  # within 10 deg: eq. 19
    (30.0, 120.0, 80.0, 70.0, 0.25, 21.0, -12.0),
]


def nl(v):
    return 34.08 * np.exp(20.7233 - 0.92104 * v)


def mag(b):
    return (20.7233 - np.log(b / 34.08)) / 0.92104


def X(z):
    return 1.0 / np.sqrt(1.0 - 0.96 * np.sin(np.radians(z)) ** 2)


def moon(alpha, rho, zm, z, k):
    istar = 10 ** (-0.4 * (3.84 + 0.026 * abs(alpha) + 4e-9 * alpha ** 4))
    fm = 10 ** (6.15 - rho / 40.0) if rho >= 10 else 6.2e7 / rho ** 2
    f = 10 ** 5.36 * (1.06 + np.cos(np.radians(rho)) ** 2) + fm
    return f * istar * 10 ** (-0.4 * k * X(zm)) * (1 - 10 ** (-0.4 * k * X(z)))


def twilight(h):
    if h <= -18:
        return 0.0
    y = (-min(h, 0.0) - 9.0) / 9.0
    return ((2.0635175 * y + 1.246602) * y - 9.4084495) * y + 6.132725


for alpha, rho, zm, z, k, vz, sun in CASES:
    b0 = nl(vz) * 10 ** (-0.4 * k * (X(z) - 1)) * X(z)
    bm = moon(alpha, rho, zm, z, k)
    dv = -2.5 * np.log10((bm + b0) / b0)
    v = mag(b0 + bm)
    vt = mag(b0 * 10 ** (0.4 * twilight(sun)) + bm)
    print(f"    ({alpha}, {rho}, {zm}, {z}, {k}, {vz}, {sun}, {dv:.6f}, {v:.6f}, {vt:.6f}),")
