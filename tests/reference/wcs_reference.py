"""Reference pixel positions from astropy's WCS for the header soig writes.

Prints (ra, dec) -> 0-based pixel (x, y) through astropy.wcs for a TAN header with soig's
conventions (CRPIX at the image centre, 1-based; CD = diag(+s, +s): +x is +RA, +y is +Dec).
The figures are pinned in crates/sky/src/projection.rs (test `matches_astropy_wcs`).
Usage: python3 tests/reference/wcs_reference.py
"""
from astropy.io import fits
from astropy.wcs import WCS

cases = [
    # (ra0, dec0, [(ra, dec), ...])
    (123.4, -56.7, [(123.4, -56.7), (123.45, -56.68), (123.33, -56.75)]),
    (359.98, 10.0, [(0.03, 10.02), (359.93, 9.97)]),
    (45.0, 89.95, [(225.0, 89.97), (100.0, 89.9)]),
]
scale = 0.1 / 512
for ra0, dec0, points in cases:
    h = fits.Header()
    h["NAXIS"] = 2
    h["NAXIS1"] = 1024
    h["NAXIS2"] = 1024
    h["CTYPE1"] = "RA---TAN"
    h["CTYPE2"] = "DEC--TAN"
    h["CUNIT1"] = "deg"
    h["CUNIT2"] = "deg"
    h["RADESYS"] = "ICRS"
    h["CRVAL1"] = ra0
    h["CRVAL2"] = dec0
    h["CRPIX1"] = 512.5
    h["CRPIX2"] = 512.5
    h["CD1_1"] = scale
    h["CD1_2"] = 0.0
    h["CD2_1"] = 0.0
    h["CD2_2"] = scale
    w = WCS(h)
    for ra, dec in points:
        x, y = w.all_world2pix([[ra, dec]], 0)[0]
        print(f"({ra0}, {dec0}, {ra}, {dec}, {x:.9f}, {y:.9f}),")
