#!/usr/bin/env python3
"""A smooth fit of the faint limit, with its uncertainty (issue #44): for each faint-limit set's
objects.csv (written by scripts/faint_limit.py: each object's truth line SNR and whether the
detector found it), the maximum-likelihood fit of

    P(found | SNR s) = a / (1 + exp(-(ln s - m) / w))

(a logistic in ln SNR with a plateau `a` <= 1: some bright streaks are missed at the frame's
edge or along the trails) and the SNR of 50 % recall it gives, with the 68 % interval of its
profile likelihood (where twice the log-likelihood falls by 1 from its maximum, the other two
parameters refitted at each SNR50). The interval is the asymptotic one: on 30 simulated sets of
300 objects from a known curve (SNR50 10, plateau 0.95, width 0.15) it held the true SNR50 in 16
(median width 0.97), a little under 68 %: read it as a lower bound on the spread.

Why beside faint_limit.py's isotonic SNR50: the isotonic fit is a step function, so its SNR50
jumps with single objects near the threshold, and 300 objects resolve it only to about +-0.5
(fixed) or +-1.4 (survey) by resampling; a bar such as "SNR50 <= 9" needs that spread said.
Standard library only, like faint_limit.py.

    python3 scripts/faint_limit_fit.py results/faint-limit*/objects.csv
        -> Markdown (results/faint-limit-fit.md): a table of set, objects, found, isotonic
           SNR50 (faint_limit.py's), fitted SNR50 and its 68 % interval, plateau a, width w
"""
import csv
import json
import math
import os
import sys


def read(path):
    """(ln SNR, found) of each object of an objects.csv."""
    with open(path, newline="") as f:
        return [(math.log(float(r["snr_matched_filter"])), int(r["found"]))
                for r in csv.DictReader(f)]


def sigmoid(t):
    return 1.0 / (1.0 + math.exp(-t)) if t >= 0 else math.exp(t) / (1.0 + math.exp(t))


def log_likelihood(data, x50, log_w, alpha):
    """The model's log-likelihood with the 50 %-recall point `x50` (ln SNR) as a parameter:
    a = 0.5 + 0.5 sigmoid(alpha) keeps the plateau above 0.5 (else recall never reaches 0.5),
    and m follows from a sigmoid((x50 - m) / w) = 0.5."""
    w = math.exp(log_w)
    a = 0.5 + 0.5 * sigmoid(alpha)
    m = x50 - w * math.log(0.5 / (a - 0.5))  # logit(0.5 / a) = ln(0.5 / (a - 0.5))
    total = 0.0
    for x, found in data:
        p = a * sigmoid((x - m) / w)
        p = min(max(p, 1e-12), 1.0 - 1e-12)
        total += math.log(p) if found else math.log(1.0 - p)
    return total


def nelder_mead(f, start, step=0.3, iterations=400, tolerance=1e-9):
    """Maximise f (a function of a list of floats) by the Nelder-Mead simplex."""
    n = len(start)
    simplex = [list(start)] + [
        [v + (step if i == j else 0.0) for j, v in enumerate(start)] for i in range(n)
    ]
    values = [f(p) for p in simplex]
    for _ in range(iterations):
        order = sorted(range(n + 1), key=lambda i: -values[i])
        simplex = [simplex[i] for i in order]
        values = [values[i] for i in order]
        if values[0] - values[-1] < tolerance:
            break
        centre = [sum(p[j] for p in simplex[:-1]) / n for j in range(n)]
        worst = simplex[-1]

        def towards(t):
            return [c + t * (w - c) for c, w in zip(centre, worst)]

        reflected = towards(-1.0)
        fr = f(reflected)
        if fr > values[0]:
            expanded = towards(-2.0)
            fe = f(expanded)
            simplex[-1], values[-1] = (expanded, fe) if fe > fr else (reflected, fr)
        elif fr > values[-2]:
            simplex[-1], values[-1] = reflected, fr
        else:
            contracted = towards(0.5)
            fc = f(contracted)
            if fc > values[-1]:
                simplex[-1], values[-1] = contracted, fc
            else:  # shrink towards the best
                best = simplex[0]
                simplex = [best] + [[b + 0.5 * (v - b) for b, v in zip(best, p)]
                                    for p in simplex[1:]]
                values = [values[0]] + [f(p) for p in simplex[1:]]
    i = max(range(n + 1), key=lambda k: values[k])
    return simplex[i], values[i]


def fit(data):
    """The maximum-likelihood (x50, ln w, alpha) and its log-likelihood."""
    found = sorted(x for x, k in data if k)
    start = [found[len(found) // 4] if found else 0.0, math.log(0.2), 2.0]
    best, value = nelder_mead(lambda p: log_likelihood(data, *p), start)
    # A restart from the optimum: one simplex run can stall on the plateau's flat direction.
    return nelder_mead(lambda p: log_likelihood(data, *p), best, step=0.1)


def profile_interval(data, best, value, drop=0.5):
    """The x50 where the profile log-likelihood (w and a refitted) is `drop` below its
    maximum, either side of the best x50 (0.5: twice the log-likelihood down by 1, 68 %)."""
    x50, log_w, alpha = best

    def profile(x):
        _, v = nelder_mead(lambda p: log_likelihood(data, x, *p), [log_w, alpha], step=0.1)
        return v

    bounds = []
    for direction in (-1.0, 1.0):
        inside, outside = x50, x50 + direction * 0.05
        while value - profile(outside) < drop:
            inside, outside = outside, outside + direction * 0.05
            if abs(outside - x50) > 3.0:  # a factor of 20 in SNR: say unbounded
                return None
        for _ in range(30):  # bisection between the last step inside and the first outside
            mid = 0.5 * (inside + outside)
            if value - profile(mid) < drop:
                inside = mid
            else:
                outside = mid
        bounds.append(0.5 * (inside + outside))
    return bounds


def fitted(data):
    """The fit's figures for a summary: `snr50_fit`, its 68 % interval (None where unbounded),
    plateau and width; all None where recall never passes 0.5 (no object found above half of
    those at least as bright: there is no 50 % point to fit)."""
    none = {"snr50_fit": None, "snr50_fit_lo68": None, "snr50_fit_hi68": None,
            "fit_plateau": None, "fit_width": None}
    ranked = sorted(data, reverse=True)
    found = 0
    for n, (_, k) in enumerate(ranked, 1):
        found += k
        if found > n / 2 and n >= 10:
            break
    else:
        return none
    best, value = fit(data)
    x50, log_w, alpha = best
    interval = profile_interval(data, best, value)
    return {
        "snr50_fit": math.exp(x50),
        "snr50_fit_lo68": math.exp(interval[0]) if interval else None,
        "snr50_fit_hi68": math.exp(interval[1]) if interval else None,
        "fit_plateau": 0.5 + 0.5 * sigmoid(alpha),
        "fit_width": math.exp(log_w),
    }


def summarise(path):
    """`fitted` of one objects.csv, with the set's name, its counts and faint_limit.py's
    isotonic SNR50 (from the summary.json beside it, where there is one)."""
    data = read(path)
    isotonic = None
    summary = os.path.join(os.path.dirname(path), "summary.json")
    if os.path.exists(summary):
        isotonic = json.load(open(summary)).get("snr50")
    return {
        "set": os.path.basename(os.path.dirname(os.path.abspath(path))),
        "objects": len(data),
        "found": sum(k for _, k in data),
        "snr50_isotonic": isotonic,
        **fitted(data),
    }


HEADING = """# The faint limits, fitted

Written by `bash scripts/faint-limit.sh` (`python3 scripts/faint_limit_fit.py`): each set's
objects.csv, the maximum-likelihood logistic in ln SNR with a plateau, its SNR of 50 % recall
and that SNR's 68 % profile-likelihood interval, beside faint_limit.py's isotonic SNR50.
"""


def main():
    paths = sys.argv[1:]
    if not paths:
        raise SystemExit(__doc__)
    print(HEADING)
    print("| set | objects | found | SNR50 (isotonic) | SNR50 (fit) | 68 % interval "
          "| plateau a | width w (ln SNR) |")
    print("|---|---|---|---|---|---|---|---|")
    for path in paths:
        s = summarise(path)
        if s["snr50_fit"] is None:
            print(f"| {s['set']} | {s['objects']} | {s['found']} | - | - | - | - | - |")
            continue
        iso = f"{s['snr50_isotonic']:.2f}" if s["snr50_isotonic"] else "-"
        ci = (f"{s['snr50_fit_lo68']:.2f}-{s['snr50_fit_hi68']:.2f}" if s["snr50_fit_lo68"]
              else "unbounded")
        print(f"| {s['set']} | {s['objects']} | {s['found']} | {iso} | {s['snr50_fit']:.2f} "
              f"| {ci} | {s['fit_plateau']:.3f} | {s['fit_width']:.3f} |")


if __name__ == "__main__":
    main()
