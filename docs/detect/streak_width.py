"""The PSF FWHM of the raw NEOSSat science frame, from the cross-section of its bright streak.

Across each 10th row of the streak (rows 20-180, columns 680-760 of the FITS array, 0-based;
5-row medians, background the row's median, saturated rows skipped) the full width at half
maximum, interpolated linearly between pixels. The streak leans 7.5 deg from the columns, so a
row crosses it 1 % wider than its true cross-section: the median, 3.36 px, gives 3.3 px (10
arcsec at 3.0 arcsec/px), the value the README passes as --psf-fwhm-px.
Usage: python3 docs/detect/streak_width.py  (needs numpy and astropy)
"""
import numpy as np
from astropy.io import fits

d = fits.getdata("tests/fixtures/neossat/NEOSSAT_240__30_2026025124741.fits").astype(float)
widths = []
for y in range(20, 190, 10):
    row = np.median(d[y - 2:y + 3, 680:760], axis=0)
    r = row - np.median(row)
    i = int(np.argmax(r))
    peak = r[i]
    if row[i] >= 60000:
        continue
    above = np.where(r > peak / 2)[0]
    lo, hi = above[0], above[-1]
    x_lo = lo - 1 + (peak / 2 - r[lo - 1]) / (r[lo] - r[lo - 1])
    x_hi = hi + (r[hi] - peak / 2) / (r[hi] - r[hi + 1])
    widths.append(x_hi - x_lo)
    print(f"row {y}: column {i + 680}, peak {peak:.0f} ADU, FWHM {x_hi - x_lo:.2f} px")
print(f"median FWHM across rows {np.median(widths):.2f} px")
