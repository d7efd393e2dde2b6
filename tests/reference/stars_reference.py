#!/usr/bin/env python3
"""Reference figures pinned in the tests of crates/sky/src/stars/ (galactic.rs, counts.rs, catalog.rs).

1. The ICRS -> galactic matrix astropy uses, and (l, b) of test points (astropy).
2. Eq. 8 proper motion for a Barnard's-star-like star over 6.5 yr (hand formula), compared with
   astropy's rigorous space motion for scale.
3. The star count model, re-implemented independently here with numpy (dense trapezoid
   integration instead of Gauss-Legendre, vectorised PCHIP derivative).

Run: python3 reference/stars_reference.py   (astropy, numpy; no network)
"""
import warnings

import numpy as np
from astropy.utils import iers

iers.conf.auto_download = False

import astropy.units as u  # noqa: E402
from astropy.coordinates import SkyCoord  # noqa: E402
from astropy.time import Time  # noqa: E402

np.set_printoptions(precision=17)


def galactic():
    e = np.eye(3)
    c = SkyCoord(x=e[0], y=e[1], z=e[2], representation_type="cartesian", frame="icrs")
    g = c.galactic.cartesian
    m = np.array([g.x.value, g.y.value, g.z.value])  # row i: galactic axis i of each ICRS axis
    print("ICRS_TO_GALACTIC =")
    for row in m:
        print("  [" + ", ".join(repr(float(v)) for v in row) + "],")
    pts = [
        (0.0, 0.0), (359.999999, 0.0), (0.0, 90.0), (0.0, -90.0), (266.40499, -28.93617),
        (192.85948, 27.12825), (123.4, -45.6), (359.99999999, 10.0), (0.0, 10.0), (180.0, 89.999),
        (45.0, -89.999), (300.0, 60.0),
    ]
    ra = np.array([p[0] for p in pts])
    dec = np.array([p[1] for p in pts])
    g = SkyCoord(ra=ra * u.deg, dec=dec * u.deg, frame="icrs").galactic
    print("galactic points (ra, dec, l, b):")
    for r, d, l, b in zip(ra, dec, g.l.deg, g.b.deg):
        print(f"  ({float(r)!r}, {float(d)!r}, {float(l)!r}, {float(b)!r}),")


def proper_motion():
    # Barnard's star, Gaia DR3 (epoch 2016.0)
    ra, dec, pmra, pmdec = 269.44850252543836, 4.739420051112412, -801.551, 10362.394
    dt = 6.5
    ra1 = float(ra + pmra * dt / (3.6e6 * np.cos(np.radians(dec))))
    dec1 = dec + pmdec * dt / 3.6e6
    print(f"Eq. 8 Barnard 2016.0 -> 2022.5: ra {ra1!r} dec {dec1!r}")
    c = SkyCoord(ra=ra * u.deg, dec=dec * u.deg, pm_ra_cosdec=pmra * u.mas / u.yr,
                 pm_dec=pmdec * u.mas / u.yr, obstime=Time(2016.0, format="jyear"), frame="icrs")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # ERFA: "distance overridden" (no parallax given)
        c1 = c.apply_space_motion(new_obstime=Time(2022.5, format="jyear"))
    sep = c1.separation(SkyCoord(ra=ra1 * u.deg, dec=dec1 * u.deg)).to(u.mas).value
    print(f"  astropy apply_space_motion (no distance/RV): ra {float(c1.ra.deg)!r} dec {float(c1.dec.deg)!r}; "
          f"Eq. 8 differs by {sep:.3f} mas")
    # high-dec star crossing RA 0 backwards
    ra, dec, pmra, pmdec, dt = 0.001, 80.0, -5000.0, -2000.0, 10.0
    ra1 = float((ra + pmra * dt / (3.6e6 * np.cos(np.radians(dec)))) % 360.0)
    dec1 = dec + pmdec * dt / 3.6e6
    print(f"Eq. 8 (0.001, 80, -5000, -2000) over 10 yr: ra {ra1!r} dec {dec1!r}")


# ---------------------------------------------------------------- count model (independent)
EDGES = np.array([0, 5, 10, 20, 30, 45, 60, 90.0])
DENS = np.array([24.4, 20.5, 15.7, 11.2, 8.2, 6.3, 5.2])
SKY = [(6, 0.12), (7, 0.36), (8, 1.0), (9, 2.9), (10, 9.3), (11, 25), (12, 72), (13, 178),
       (14, 417), (15, 955), (16, 2155), (16.5, 3200)]
ALPHA_FAINT = 2.36
X = np.sin(np.radians(EDGES))
H = np.diff(X)
D = DENS / (DENS * H).sum()


def pchip_nodes():
    n = len(D)
    m = np.zeros(n + 1)
    for k in range(1, n):
        w1, w2 = 2 * H[k] + H[k - 1], H[k] + 2 * H[k - 1]
        m[k] = (w1 + w2) / (w1 / D[k - 1] + w2 / D[k])

    def end(h0, h1, d0, d1):
        e = ((2 * h0 + h1) * d0 - h0 * d1) / (h0 + h1)
        return 0.0 if np.sign(e) != np.sign(d0) else e

    m[0] = end(H[0], H[1], D[0], D[1])
    m[n] = end(H[-1], H[-2], D[-1], D[-2])
    return m


GN = pchip_nodes()


def g(x):
    x = np.asarray(x, dtype=float)
    k = np.clip(np.searchsorted(X, x, side="right") - 1, 0, len(H) - 1)
    t = (x - X[k]) / H[k]
    return 6 * t * (1 - t) * D[k] + (3 * t * t - 4 * t + 1) * GN[k] + (3 * t * t - 2 * t) * GN[k + 1]


XS = np.linspace(0.0, 1.0, 400001)
GS = g(XS)


def ln_sky(m):
    ms = np.array([p[0] for p in SKY], float)
    ln = np.log([p[1] for p in SKY])
    k = np.clip(np.searchsorted(ms, m, side="right") - 1, 0, len(ms) - 2)
    return ln[k] + (m - ms[k]) * (ln[k + 1] - ln[k]) / (ms[k + 1] - ms[k])


def alpha(m):
    return float(np.clip(1 + (ALPHA_FAINT - 1) * (m - 10) / 6.5, 1, ALPHA_FAINT))


def big_m(b, m):
    a = alpha(m)
    norm = np.trapezoid(GS ** a, XS)
    return np.exp(ln_sky(m)) * g(np.sin(np.radians(abs(b)))) ** a / norm


def density(b, m):
    return big_m(b, m) - big_m(b, -1.5)


def count_model():
    print(f"g(pole) {float(g(1.0))!r}  g(plane) {float(g(0.0))!r}")
    print("N(b, m) per deg^2 (independent numpy):")
    for b, m in [(90, 16.5), (30, 16.5), (20, 16.5), (0, 16.5), (-45, 12.0), (10, 8.0), (60, 17.0),
                 (2.5, 14.0)]:
        print(f"  ({b}, {m}, {float(density(b, m))!r}),")


if __name__ == "__main__":
    galactic()
    proper_motion()
    count_model()
