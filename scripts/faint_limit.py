#!/usr/bin/env python3
"""The streak detector's faint limit (issue #44) from a finished `soig run` output: each test
image's one debris object, its integrated matched-filter SNR (`snr_matched_filter` of the truth
sidecar: the "line SNR" of the issue) and whether the detector found it (a box of confidence >=
0.5 with IoU >= 0.5 against the label, greedy by score, as the report's fixed-threshold precision
and recall count); every other box of confidence >= 0.5 is a false positive.

Writes into OUT_DIR: curve.csv (recall by half-octave SNR bin, with a 68% Wilson interval),
objects.csv (each object: SNR, magnitude, found) and summary.json (the SNR at 50% recall on the
isotonic fit of found against SNR, per object, interpolated linearly between the fit's steps; the
precision at confidence 0.5, overall and above that SNR; and `snr50_fit` with its 68 % interval,
the smooth fit of scripts/faint_limit_fit.py, steadier than the isotonic steps). Standard
library only.

    python3 scripts/faint_limit.py RUN_OUTPUT OUT_DIR [--detector streak] [--predictions DIR]
"""
import argparse
import csv
import glob
import json
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from faint_limit_fit import fitted  # noqa: E402

CONF = 0.5
IOU = 0.5


def boxes(path, with_score):
    """YOLO rows `cls xc yc w h [score]` (normalised) as (x1, y1, x2, y2, score)."""
    out = []
    if not os.path.exists(path):
        return out
    for line in open(path):
        v = line.split()
        if not v:
            continue
        xc, yc, w, h = map(float, v[1:5])
        score = float(v[5]) if with_score else 1.0
        out.append((xc - w / 2, yc - h / 2, xc + w / 2, yc + h / 2, score))
    return out


def iou(a, b):
    iw = min(a[2], b[2]) - max(a[0], b[0])
    ih = min(a[3], b[3]) - max(a[1], b[1])
    if iw <= 0 or ih <= 0:
        return 0.0
    inter = iw * ih
    union = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter
    return inter / union


def isotonic(values):
    """Pool-adjacent-violators: the non-decreasing least-squares fit of `values` (in order)."""
    blocks = []  # [mean, weight]
    for v in values:
        blocks.append([float(v), 1.0])
        while len(blocks) > 1 and blocks[-2][0] > blocks[-1][0]:
            m2, w2 = blocks.pop()
            m1, w1 = blocks.pop()
            blocks.append([(m1 * w1 + m2 * w2) / (w1 + w2), w1 + w2])
    fit = []
    for m, w in blocks:
        fit.extend([m] * int(w))
    return fit


def half_recall_snr(objects):
    """The SNR at which the isotonic fit of found (0/1) against SNR reaches 0.5, linear in log
    SNR between the centres of the fit's steps; None where it never does (or always does)."""
    objects = sorted(objects, key=lambda o: o["snr"])
    fit = isotonic([o["found"] for o in objects])
    # The steps of the fit: (log SNR at the step's centre, level).
    steps, i = [], 0
    while i < len(fit):
        j = i
        while j + 1 < len(fit) and fit[j + 1] == fit[i]:
            j += 1
        logs = [math.log(objects[k]["snr"]) for k in range(i, j + 1)]
        steps.append((sum(logs) / len(logs), fit[i]))
        i = j + 1
    if not steps or steps[0][1] >= 0.5 or steps[-1][1] < 0.5:
        return None
    for (x0, y0), (x1, y1) in zip(steps, steps[1:]):
        if y0 < 0.5 <= y1:
            return math.exp(x0 + (0.5 - y0) / (y1 - y0) * (x1 - x0))
    return None


def wilson(k, n, z=1.0):
    if n == 0:
        return (float("nan"), float("nan"))
    p = k / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return (c - h, c + h)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("run")
    ap.add_argument("out")
    ap.add_argument("--detector", default="streak")
    ap.add_argument(
        "--predictions",
        help="a folder of YOLO prediction files to score instead of the run's own "
        "(e.g. from `cargo run --example sky_eval`)",
    )
    a = ap.parse_args()
    predictions = a.predictions or os.path.join(a.run, "report", "predictions", a.detector)
    objects, false_positives = [], []
    for truth_path in sorted(glob.glob(os.path.join(a.run, "truth", "*.json"))):
        stem = os.path.basename(truth_path)[:-5]
        truth = json.load(open(truth_path))
        labels = glob.glob(os.path.join(a.run, "labels", "*", stem + ".txt"))
        if not labels:
            continue  # not a test image
        gt = boxes(labels[0], False)
        pred = boxes(os.path.join(predictions, stem + ".txt"), True)
        pred = sorted((p for p in pred if p[4] >= CONF), key=lambda p: -p[4])
        matched = [False] * len(gt)
        fps = 0
        for p in pred:
            best, at = 0.0, None
            for k, g in enumerate(gt):
                overlap = iou(p, g)
                if not matched[k] and overlap > best:
                    best, at = overlap, k
            if at is not None and best >= IOU:
                matched[at] = True
            else:
                fps += 1
        if len(gt) != 1:
            raise SystemExit(f"{stem}: {len(gt)} labels; the curve is for one object an image")
        snr = truth["snr_matched_filter"]
        objects.append(
            {"image": stem, "snr": snr, "magnitude": truth["magnitude"], "found": int(matched[0])}
        )
        false_positives.append((snr, fps))
    if not objects:
        raise SystemExit(f"{a.run}: no test image with a truth sidecar and a label")
    os.makedirs(a.out, exist_ok=True)
    with open(os.path.join(a.out, "objects.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["image", "snr_matched_filter", "magnitude", "found"])
        for o in objects:
            w.writerow([o["image"], f"{o['snr']:.4f}", f"{o['magnitude']:.4f}", o["found"]])
    # Half-octave bins from 2^1.
    lo_k = math.floor(2 * math.log2(min(o["snr"] for o in objects)))
    hi_k = math.ceil(2 * math.log2(max(o["snr"] for o in objects)))
    rows = []
    for k in range(lo_k, hi_k):
        lo, hi = 2 ** (k / 2), 2 ** ((k + 1) / 2)
        inside = [o for o in objects if lo <= o["snr"] < hi]
        if not inside:
            continue
        found = sum(o["found"] for o in inside)
        fps = sum(n for s, n in false_positives if lo <= s < hi)
        r_lo, r_hi = wilson(found, len(inside))
        rows.append([lo, hi, len(inside), found, fps, found / len(inside), r_lo, r_hi])
    with open(os.path.join(a.out, "curve.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["snr_lo", "snr_hi", "objects", "found", "false_positives", "recall",
                    "recall_lo68", "recall_hi68"])
        for r in rows:
            w.writerow([f"{r[0]:.3f}", f"{r[1]:.3f}", r[2], r[3], r[4], f"{r[5]:.4f}",
                        f"{r[6]:.4f}", f"{r[7]:.4f}"])
    snr50 = half_recall_snr(objects)
    tp = sum(o["found"] for o in objects)
    fp = sum(n for _, n in false_positives)
    above = [o for o in objects if snr50 is not None and o["snr"] >= snr50]
    tp_above = sum(o["found"] for o in above)
    fp_above = sum(n for s, n in false_positives if snr50 is not None and s >= snr50)
    summary = {
        "run": os.path.basename(os.path.normpath(a.run)),
        "detector": a.detector,
        "objects": len(objects),
        "found": tp,
        "false_positives": fp,
        "precision": tp / (tp + fp) if tp + fp else None,
        "snr50": snr50,
        "precision_above_snr50": tp_above / (tp_above + fp_above)
        if tp_above + fp_above else None,
        "conf": CONF,
        "iou": IOU,
    }
    # The fit of objects.csv as written (SNR to 4 decimals), so that faint_limit_fit.py on the
    # file gives these figures to the last digit.
    summary.update(fitted([(math.log(float(f"{o['snr']:.4f}")), o["found"]) for o in objects]))
    with open(os.path.join(a.out, "summary.json"), "w") as f:
        json.dump(summary, f, indent=2)
        f.write("\n")
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
