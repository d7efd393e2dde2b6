"""Reference integrated matched-filter SNR of a rendered Gaussian streak, computed densely.

A debris of constant magnitude moves uniformly from pixel `a` to pixel `b` over the exposure,
cut into 200 samples at the centres of equal time slices (soig's `Scene::fixed_streak`); each
sample's expected photo-electrons, 10^(-0.4 (m - ZP)) t / 200, are spread by a Gaussian PSF
integrated over every pixel of the whole image (pixel i spans [i - 0.5, i + 0.5): no support
cut), no jitter. With s_i = e_i / gain (ADU) and sigma_i^2 = sigma_bg^2 + s_i / gain, where
sigma_bg is the standard deviation of the paper's uniform background (190..210 ADU per 5 s,
scaled by t) plus bias (2..3 ADU), the SNR is sqrt(sum_i s_i^2 / sigma_i^2).
The figures are pinned in crates/sim/src/render/tests.rs (test `matched_filter_snr_matches_numpy`).
Usage: .venv/bin/python tests/reference/matched_filter_reference.py
"""
import math

import numpy as np

W = H = 128
SCALE_DEG = 0.0125 / 64  # the tests' 128 px sensor with a 0.0125 deg field radius
PSF_PX = 1.0 / 3600 / SCALE_DEG
ZP, GAIN = 22.26, 1.6
erfc = np.vectorize(math.erfc)


def pixel_mass(c, n):
    edges = np.arange(n + 1) - 0.5
    upper = 0.5 * erfc((edges - c) / (PSF_PX * math.sqrt(2)))  # P(Z > edge)
    return upper[:-1] - upper[1:]


def snr(mag, a, b, t):
    n = 200
    e = np.zeros((H, W))
    per_sample = 10 ** (-0.4 * (mag - ZP)) * t / n
    for k in range(n):
        f = (k + 0.5) / n
        x, y = a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])
        e += per_sample * np.outer(pixel_mass(y, H), pixel_mass(x, W))
    bg = 20.0 * t / 5.0
    var_bg = bg * bg / 12 + 1.0 / 12
    s = e / GAIN
    return math.sqrt(np.sum(s * s / (var_bg + s / GAIN))), e.sum()


for mag, a, b, t in [
    (13.0, (30.3, 40.7), (150.0, 100.2), 2.0),
    (17.0, (40.0, 40.0), (43.0, 41.0), 5.0),
]:
    value, landed = snr(mag, a, b, t)
    print(f"({mag}, ({a[0]}, {a[1]}), ({b[0]}, {b[1]}), {t}, {value:.9f}),  # {landed:.3f} e- in the image")
