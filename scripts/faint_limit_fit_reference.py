#!/usr/bin/env python3
"""The independent reference for scripts/faint_limit_fit_test.py: the same model's maximum
likelihood by scipy (Nelder-Mead from three starts, tight tolerances) on committed objects.csv
files; its printed figures are pinned in the test. Needs numpy and scipy (not in CI):

    .venv/bin/python -m pip install numpy scipy
    .venv/bin/python scripts/faint_limit_fit_reference.py results/faint-limit-fixed/objects.csv ...
"""
import csv
import sys

import numpy as np
from scipy.optimize import minimize
from scipy.special import expit

for path in sys.argv[1:]:
    d = np.array([(np.log(float(r["snr_matched_filter"])), int(r["found"]))
                  for r in csv.DictReader(open(path))])
    x, k = d[:, 0], d[:, 1]

    def nll(p):
        m, log_w, alpha = p
        pr = np.clip(expit(alpha) * expit((x - m) / np.exp(log_w)), 1e-12, 1 - 1e-12)
        return -np.sum(k * np.log(pr) + (1 - k) * np.log(1 - pr))

    best = min((minimize(nll, [m0, np.log(0.2), 3.0], method="Nelder-Mead",
                         options={"xatol": 1e-8, "fatol": 1e-10, "maxiter": 20000})
                for m0 in (2.0, 2.3, 2.6)), key=lambda r: r.fun)
    m, log_w, alpha = best.x
    a, w = expit(alpha), np.exp(log_w)
    snr50 = np.exp(m + w * np.log(0.5 / (a - 0.5)))
    print(f"{path}: snr50 {snr50:.4f} plateau {a:.4f} width {w:.4f} log-likelihood {-best.fun:.4f}")
