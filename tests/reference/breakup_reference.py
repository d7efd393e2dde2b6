#!/usr/bin/env python3
"""Independent figures of the NASA Standard Breakup Model for tests/breakup.rs (issue #45).

A numpy implementation written from the paper, not from soig's code: N. L. Johnson,
P. H. Krisko, J.-C. Liou, P. D. Anz-Meador, "NASA's new breakup model of EVOLVE 4.0",
Adv. Space Res. 28(9), 1377-1384, 2001. Eq. 2, 4: N(>Lc) = 6 S Lc^-1.6 (explosion),
0.1 M^0.75 Lc^-1.71 (collision; M = mt + mp if catastrophic, 40 J/g, else mp v^2, v km/s).
Eq. 5-7: chi = log10(A/M): below 8 cm N(mu_soc, sigma_soc); above 11 cm the mixture
alpha N(mu1, s1) + (1 - alpha) N(mu2, s2), rocket body (Eq. 6) or spacecraft (Eq. 7); between,
soig's reading of the bridge: the large law with probability (Lc - 0.08) / 0.03, else the small.
Eq. 11, 12: nu = log10(dv m/s) ~ N(0.2 chi + 1.85 | 0.9 chi + 2.9, 0.4).

Prints JSON with, for a set of events, N(>Lc) and its rounded count; for each parent kind and
size, the mixture's mean and variance of chi (exact, from the formulas) and numpy's sampled
ones (2e6 draws, as a check of the exact ones here); and for two whole clouds (sizes drawn by
the power law, then chi and nu) the sampled mean and standard deviation of chi, of nu and of
log10(Lc / Lc_min), from 4e6 fragments (their standard errors well under 1e-3).

Run: python tests/reference/breakup_reference.py > tests/fixtures/breakup/sbm_reference.json
(numpy 1.x or 2.x; here /work/main/.venv/bin/python)
"""
import json

import numpy as np


def piece(lam, lo, low, hi, high, line):
    return np.where(lam <= lo, low, np.where(lam >= hi, high, line(lam)))


def small(lam):
    mu = piece(lam, -1.75, -0.3, -1.25, -1.0, lambda l: -0.3 - 1.4 * (l + 1.75))
    sigma = np.where(lam <= -3.5, 0.2, 0.2 + 0.1333 * (lam + 3.5))
    return mu, sigma


def large(kind, lam):
    if kind == "rocket-body":
        alpha = piece(lam, -1.4, 1.0, 0.0, 0.5, lambda l: 1.0 - 0.3571 * (l + 1.4))
        mu1 = piece(lam, -0.5, -0.45, 0.0, -0.9, lambda l: -0.45 - 0.9 * (l + 0.5))
        s1 = np.full_like(lam, 0.55)
        mu2 = np.full_like(lam, -0.9)
        s2 = piece(lam, -1.0, 0.28, 0.1, 0.1, lambda l: 0.28 - 0.1636 * (l + 1.0))
    else:
        alpha = piece(lam, -1.95, 0.0, 0.55, 1.0, lambda l: 0.3 + 0.4 * (l + 1.2))
        mu1 = piece(lam, -1.1, -0.6, 0.0, -0.95, lambda l: -0.6 - 0.318 * (l + 1.1))
        s1 = piece(lam, -1.3, 0.1, -0.3, 0.3, lambda l: 0.1 + 0.2 * (l + 1.3))
        mu2 = piece(lam, -0.7, -1.2, -0.1, -2.0, lambda l: -1.2 - 1.333 * (l + 0.7))
        s2 = piece(lam, -0.5, 0.5, -0.3, 0.3, lambda l: 0.5 - (l + 0.5))
    return alpha, mu1, s1, mu2, s2


def components(kind, lc):
    """(weights, means, sigmas), each of shape (3, len(lc))."""
    lam = np.log10(lc)
    mu, sigma = small(lam)
    alpha, mu1, s1, mu2, s2 = large(kind, lam)
    w = np.clip((lc - 0.08) / 0.03, 0.0, 1.0)
    weights = np.stack([1.0 - w, w * alpha, w * (1.0 - alpha)])
    return weights, np.stack([mu, mu1, mu2]), np.stack([sigma, s1, s2])


def exact_moments(kind, lc):
    w, m, s = components(kind, np.array([lc]))
    mean = float((w * m).sum())
    second = float((w * (s * s + m * m)).sum())
    return mean, second - mean * mean


def sample_chi(kind, lc, rng):
    w, m, s = components(kind, lc)
    u = rng.random(lc.size)
    pick = np.where(u < w[0], 0, np.where(u < w[0] + w[1], 1, 2))
    cols = np.arange(lc.size)
    return m[pick, cols] + s[pick, cols] * rng.standard_normal(lc.size)


def count(event, lc):
    if event["kind"] == "explosion":
        return 6.0 * event["scaling"] * lc ** -1.6
    mt, mp, v = event["target_kg"], event["projectile_kg"], event["speed_km_s"]
    catastrophic = 0.5 * mp * (v * 1e3) ** 2 / (mt * 1e3) >= 40.0
    m = mt + mp if catastrophic else mp * v * v
    return 0.1 * m ** 0.75 * lc ** -1.71


def exponent(event):
    return 1.6 if event["kind"] == "explosion" else 1.71


def speed_mean(event, chi):
    return 0.2 * chi + 1.85 if event["kind"] == "explosion" else 0.9 * chi + 2.9


def main():
    rng = np.random.default_rng(4502)
    events = {
        "explosion": {"kind": "explosion", "scaling": 1.0},
        "catastrophic": {"kind": "collision", "target_kg": 1000.0, "projectile_kg": 10.0, "speed_km_s": 10.0},
        "cratering": {"kind": "collision", "target_kg": 1000.0, "projectile_kg": 0.01, "speed_km_s": 1.0},
    }
    counts = []
    for name, e in events.items():
        for lc in (0.01, 0.05, 0.1, 0.3):
            n = float(count(e, lc))
            counts.append({"event": name, "lc_min_m": lc, "n_above": n, "fragments": int(round(n))})
    laws = []
    for kind in ("spacecraft", "rocket-body"):
        for lc in (0.002, 0.02, 0.05, 0.085, 0.095, 0.105, 0.2, 0.5, 1.0, 3.0):
            mean, var = exact_moments(kind, lc)
            chi = sample_chi(kind, np.full(2_000_000, lc), rng)
            assert abs(chi.mean() - mean) < 6 * np.sqrt(var / chi.size), (kind, lc)
            laws.append({"kind": kind, "lc_m": lc, "chi_mean": mean, "chi_var": var,
                         "sampled_mean": float(chi.mean()), "sampled_var": float(chi.var())})
    clouds = []
    for name, kind, lc_min in (("explosion", "rocket-body", 0.05), ("catastrophic", "spacecraft", 0.1)):
        e = events[name]
        n = 4_000_000
        lc = lc_min * (1.0 - rng.random(n)) ** (-1.0 / exponent(e))
        chi = sample_chi(kind, lc, rng)
        nu = speed_mean(e, chi) + 0.4 * rng.standard_normal(n)
        x = np.log10(lc / lc_min)
        clouds.append({"event": name, "kind": kind, "lc_min_m": lc_min,
                       "log_size_mean": float(x.mean()), "chi_mean": float(chi.mean()),
                       "chi_std": float(chi.std()), "nu_mean": float(nu.mean()),
                       "nu_std": float(nu.std())})
    print(json.dumps({"source": "tests/reference/breakup_reference.py", "seed": 4502,
                      "counts": counts, "laws": laws, "clouds": clouds}, indent=1))


main()
