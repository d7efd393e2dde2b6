"""Independent check of soig's detection astrometry (src/product/observations.rs): PNG pixel
-> original image pixel -> (RA, Dec) with astropy, from a soig FITS header alone.

The PNG pixel is in the detectors' pixel-edge convention (pixel i spans [i, i + 1]); the FITS
`GEOA` cards say PNG = A (x, y, 1) with 0-based pixel centres, inverted here with numpy; the
sky is astropy's `WCS(header).all_pix2world(x, y, 0)` through the WCS at mid-exposure, or, where
the header has them (survey and track), the alternate WCS `S` at the exposure's start and `E`
at its end (`WCS(header, key="S")`).

Usage: python3 tests/reference/astrometry_reference.py FITS < points
  each input line `x y at_end` (at_end 0 or 1); each output line `ra dec`, degrees, 10
  decimals.
"""
import sys

import numpy as np
from astropy.io import fits
from astropy.wcs import WCS

header = fits.getheader(sys.argv[1])
a = np.array(
    [[header[f"GEOA{i}{j}"] for j in (1, 2, 3)] for i in (1, 2)], dtype=float
)
inverse = np.linalg.inv(a[:, :2])
moving = "CTYPE1S" in header
wcs = {
    0: WCS(header, key="S") if moving else WCS(header),
    1: WCS(header, key="E") if moving else WCS(header),
}
for line in sys.stdin:
    if not line.strip():
        continue
    x, y, at_end = line.split()
    png = np.array([float(x) - 0.5, float(y) - 0.5])
    px, py = inverse @ (png - a[:, 2])
    ra, dec = wcs[int(at_end)].all_pix2world([[px, py]], 0)[0]
    print(f"{ra % 360.0:.10f} {dec:.10f}")
