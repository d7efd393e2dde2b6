"""Reference sky positions from astropy's WCS for the TAN headers of real frames.

Prints 0-based pixel (x, y) -> (RA, Dec) through astropy.wcs `all_pix2world(x, y, 0)` for
(1) the WCS cards of the raw NEOSSat frame NEOSSAT_240__30_2026025124741.fits (CD and CDELT
both present: CD wins) and (2) a PC x CDELT header near the pole with a rotation and a flip.
The figures are pinned in crates/sky/src/wcs.rs (test `matches_astropy`).
Usage: python3 tests/reference/tan_wcs_reference.py  (needs astropy; run with astropy 8.0.2)
"""
import warnings

from astropy.io import fits
from astropy.wcs import WCS

NEOSSAT_RAW = {
    "CTYPE1": "RA---TAN", "CTYPE2": "DEC--TAN", "CUNIT1": "degrees", "CUNIT2": "degrees",
    "CRPIX1": 558, "CRPIX2": 509, "CRVAL1": 240.32140211, "CRVAL2": -29.55762221,
    "CDELT1": 0.0008325, "CDELT2": 0.0008325,
    "CD1_1": 0.0007414, "CD1_2": -0.00037866, "CD2_1": 0.00037866, "CD2_2": 0.0007414,
}
PC_CDELT = {
    "CTYPE1": "RA---TAN", "CTYPE2": "DEC--TAN", "CRPIX1": 100.5, "CRPIX2": 200.0,
    "CRVAL1": 12.5, "CRVAL2": 89.9, "CDELT1": -0.0005, "CDELT2": 0.0005,
    "PC1_1": 0.8, "PC1_2": 0.6, "PC2_1": -0.6, "PC2_2": 0.8,
}
cases = [
    ("NEOSSAT_RAW", NEOSSAT_RAW, [(0.0, 0.0), (557.0, 508.0), (1077.0, 1019.0), (100.5, 980.25)]),
    ("PC_CDELT", PC_CDELT, [(10.0, 20.0), (300.0, -40.0)]),
]
for name, cards, points in cases:
    h = fits.Header()
    for k, v in cards.items():
        h[k] = v
    with warnings.catch_warnings():
        # 'degrees' is not the standard spelling of CUNIT ('deg'); astropy reads it and warns.
        warnings.simplefilter("ignore")
        w = WCS(h)
    for x, y in points:
        ra, dec = w.all_pix2world([[x, y]], 0)[0]
        print(f"({name}, {x!r}, {y!r}, {ra:.9f}, {dec:.9f}),")
