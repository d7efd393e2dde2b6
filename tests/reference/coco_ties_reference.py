#!/usr/bin/env python3
"""pycocotools' figures for tied scores that mix true and false positives (issue #43): the order
of tied detections then decides the precision-recall curve. pycocotools sorts each image's
detections by score with a stable mergesort (ties in input order), concatenates the images in
image-id order and sorts again, stably; `crates/detect/src/metrics/coco_eval.rs` keeps that order
and the test `coco_breaks_ties_as_pycocotools` (cases.rs) pins these figures. The same case with
the tied detections of image 1 given the other way round gives other figures: both are pinned,
so an order that only happens to agree fails one of them.

(Ultralytics' `np.argsort(-conf)` is unstable and, on current numpy, SIMD sorting networks order
ties differently on different CPUs: no figure of it can be pinned across machines; see the
module docs of crates/detect/src/metrics/mod.rs.)

Run (no torch needed; pycocotools 2.0.11 and numpy from the project's .venv):
    .venv/bin/python tests/reference/coco_ties_reference.py
"""
import sys
import types
from pathlib import Path

# metrics_reference imports torch at its top for its Ultralytics half, which this case does not use.
sys.modules.setdefault("torch", types.ModuleType("torch"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from metrics_reference import box, coco_reference  # noqa: E402

FAR = box(900, 900, 20, 20)
# Image 1: a hit and a miss tied at 0.7; image 2: a miss and a hit tied at 0.7; image 3: a box of
# IoU 0.6 (a hit at 0.5, a miss at 0.75) tied at 0.5 with a miss.
CASE = [
    ([box(10, 10, 20, 20)], [0], [box(10, 10, 20, 20) + [0.7, 0], FAR + [0.7, 0]]),
    ([box(100, 100, 20, 20)], [0], [FAR + [0.7, 0], box(100, 100, 20, 20) + [0.7, 0]]),
    ([box(300, 300, 20, 20), box(500, 500, 20, 20)], [0, 0],
     [box(300, 300, 20, 12) + [0.5, 0], FAR + [0.5, 0], box(500, 500, 20, 20) + [0.9, 0]]),
]
SWAPPED = [(CASE[0][0], CASE[0][1], CASE[0][2][::-1])] + CASE[1:]

for name, images in (("as given", CASE), ("image 1's ties swapped", SWAPPED)):
    m = coco_reference(images)
    print(name, {k: m[k] for k in ("ap", "ap50", "ap75", "ar100")})
