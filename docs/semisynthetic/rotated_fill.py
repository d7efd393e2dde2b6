"""Issue #30 item 5: does the fill outside a rotated frame look like the frame?

For each test PNG of a `soig run` output with rotated frames: the standard deviation (plain and
1.4826 MAD) of the fill against the frame's, the step in mean grey level across the outline, and
the false positives at confidence 0.5 (no label box at IoU 0.5) whose box straddles the outline.
Regions, through the truth's frame matrix: inside = PNG pixels whose original position is 2 px
or more inside the original image, fill = 2 px or more outside it, join bands 0-3 px on either
side.

    soig run results/campaigns/results-survey-rotated-semisynthetic.toml --set images=60 --out OUT
    python docs/semisynthetic/rotated_fill.py OUT [ORIGINAL_SIZE_PX, default 1024]

Needs numpy and Pillow (the project's .venv has both).
"""
import csv
import glob
import json
import os
import sys

import numpy as np
from PIL import Image

run = sys.argv[1]
W = H = int(sys.argv[2]) if len(sys.argv) > 2 else 1024
dets = {}
for r in csv.DictReader(open(f"{run}/report/detections.csv")):
    dets.setdefault(r["image"], []).append(r)


def iou(a, b):
    ix = max(0, min(a[2], b[2]) - max(a[0], b[0]))
    iy = max(0, min(a[3], b[3]) - max(a[1], b[1]))
    u = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - ix * iy
    return ix * iy / u if u > 0 else 0


def mad(v):
    return 1.4826 * np.median(abs(v - np.median(v)))


ratios, robust, steps, rows = [], [], [], []
fp = {d["detector"]: [0, 0] for ds in dets.values() for d in ds}
for png in sorted(glob.glob(f"{run}/images/test/*.png")):
    stem = os.path.basename(png)[:-4]
    t = json.load(open(f"{run}/truth/{stem}.json"))
    A = np.array(t["frame"]["matrix"])
    img = np.asarray(Image.open(png).convert("L"), dtype=float)
    h, w = img.shape
    jj, ii = np.mgrid[0:h, 0:w]
    Minv, tv = np.linalg.inv(A[:, :2]), A[:, 2]
    x = Minv[0, 0] * (ii - tv[0]) + Minv[0, 1] * (jj - tv[1])
    y = Minv[1, 0] * (ii - tv[0]) + Minv[1, 1] * (jj - tv[1])
    # Distance inside the original image (negative outside), pixels.
    d = np.minimum.reduce([x + 0.5, W - 0.5 - x, y + 0.5, H - 0.5 - y])
    inside, fill = img[d >= 2], img[d <= -2]
    ratios.append(fill.std() / inside.std())
    robust.append(mad(fill) / mad(inside))
    steps.append(img[(d > 0) & (d < 3)].mean() - img[(d < 0) & (d > -3)].mean())
    labels = [list(map(float, l.split()[1:])) for l in open(f"{run}/labels/test/{stem}.txt") if l.strip()]
    truth = [((xc - bw / 2) * w, (yc - bh / 2) * h, (xc + bw / 2) * w, (yc + bh / 2) * h)
             for xc, yc, bw, bh in labels]
    for det in dets.get(stem, []):
        if float(det["score"]) < 0.5:
            continue
        b = tuple(float(det[k]) for k in ("x1", "y1", "x2", "y2"))
        if any(iou(b, tb) >= 0.5 for tb in truth):
            continue
        x1, y1, x2, y2 = (int(round(v)) for v in b)
        sub = d[max(0, y1):min(h, y2 + 1), max(0, x1):min(w, x2 + 1)]
        straddles = bool(sub.size and sub.max() > 0 and sub.min() < 0)
        n = fp[det["detector"]]
        n[0] += 1
        n[1] += straddles
        rows.append((stem, det["detector"], det["score"], b, straddles))
r, q, s = np.array(ratios), np.array(robust), np.array(steps)
print(f"{len(r)} images")
print(f"fill sd / frame sd: min {r.min():.3f} median {np.median(r):.3f} max {r.max():.3f}; "
      f"within 5%: {(abs(r - 1) <= 0.05).sum()} of {len(r)}")
print(f"robust (MAD) ratio: min {q.min():.3f} median {np.median(q):.3f} max {q.max():.3f}")
print(f"step at the outline (frame band - fill band, grey levels): min {s.min():.2f} "
      f"median {np.median(s):.2f} max {s.max():.2f}")
for k, (n, st) in sorted(fp.items()):
    print(f"{k}: false positives at conf >= 0.5: {n}, straddling the outline: {st}")
for row in rows:
    print("  ", row)
