#!/usr/bin/env python3
"""Reference figures for `soig eval --mode ultralytics-obb` (crates/detect/src/metrics/obb.rs):
Ultralytics' own OBB validation code on the fixture in tests/fixtures/obb/.

The fixture (4 images of 1024 x 1024 px: long thin streak boxes at several angles, predictions
near and off them, a duplicate, a miss, a wrong class, an image without objects) is written by
`--write-fixture DIR` from the numbers below. The figures come from Ultralytics 8.4.190, fed as
`OBBValidator.update_metrics` feeds them: label corners in pixels -> `ops.xyxyxyxy2xywhr`
(OpenCV minAreaRect, as the OBB dataset does), the predictions likewise (an OBB model's
`save_txt` corners of its xywhr boxes), `OBBValidator._process_batch` (`batch_probiou` ->
`match_predictions`), `OBBMetrics.update_stats` / `process` (`ap_per_class`).

Run: pip install ultralytics==8.4.190; python tests/reference/obb_metrics_reference.py
(as pinned: /work/main/.venv-train/bin/python, ultralytics 8.4.190, torch 2.15.0, numpy 2.4,
opencv-python-headless). Prints JSON: the metrics, each object-prediction probiou, and the
smallest distance of any probiou from an IoU threshold (a match decided by less than float32
rounding could differ between implementations).
"""
import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
import torch

SIZE = 1024
FIXTURE = Path(__file__).resolve().parent.parent / "fixtures/obb"

# Per image: objects (class, cx, cy, w, h, degrees) and predictions (the same and a score).
IMAGES = {
    "img_a": (
        [(0, 300.0, 400.0, 400.0, 6.0, 30.0), (0, 700.0, 200.0, 200.0, 5.0, -60.0)],
        [(0, 301.0, 400.5, 390.0, 6.0, 30.4, 0.92), (0, 702.0, 203.0, 190.0, 6.0, -58.5, 0.81),
         (0, 150.0, 900.0, 120.0, 5.0, 10.0, 0.40)],
    ),
    "img_b": (
        [(0, 500.0, 500.0, 700.0, 7.0, 45.0)],
        [(0, 500.5, 499.0, 690.0, 7.5, 44.6, 0.77), (0, 505.0, 495.0, 650.0, 9.0, 44.0, 0.55)],
    ),
    "img_c": (
        [(0, 200.0, 800.0, 150.0, 5.0, 0.0), (1, 800.0, 700.0, 300.0, 6.0, 90.0)],
        [(0, 200.0, 800.5, 148.0, 8.0, 0.3, 0.66), (0, 800.0, 702.0, 290.0, 6.0, 89.0, 0.61)],
    ),
    "img_d": (
        [],
        [(0, 512.0, 512.0, 80.0, 4.0, 135.0, 0.33)],
    ),
}


def corners(cx, cy, w, h, deg):
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    out = []
    for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
        x, y = a * w / 2, b * h / 2
        out += [(cx + x * c - y * s) / SIZE, (cy + x * s + y * c) / SIZE]
    return out


def write_fixture(root):
    for sub in ("labels", "predictions"):
        (root / sub).mkdir(parents=True, exist_ok=True)
    for stem, (truth, preds) in IMAGES.items():
        lines = [" ".join([str(k)] + [f"{v:.9f}" for v in corners(*t)]) for k, *t in truth]
        (root / "labels" / f"{stem}.txt").write_text("".join(x + "\n" for x in lines))
        lines = [" ".join([str(k)] + [f"{v:.9f}" for v in corners(*p[:5])] + [str(p[5])])
                 for k, *p in preds]
        (root / "predictions" / f"{stem}.txt").write_text("".join(x + "\n" for x in lines))


def read(path, n):
    rows = [list(map(float, x.split())) for x in path.read_text().splitlines() if x.strip()]
    return np.array(rows, dtype=np.float64).reshape(-1, n)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--write-fixture", type=Path)
    args = ap.parse_args()
    if args.write_fixture:
        write_fixture(args.write_fixture)
        return
    import ultralytics
    from ultralytics.models.yolo.obb.val import OBBValidator
    from ultralytics.utils.metrics import OBBMetrics, batch_probiou
    from ultralytics.utils.ops import xyxyxyxy2xywhr

    v = OBBValidator.__new__(OBBValidator)  # only iouv / niou are used by _process_batch
    v.iouv = torch.linspace(0.5, 0.95, 10)
    v.niou = v.iouv.numel()
    metrics = OBBMetrics(names={0: "debris", 1: "other"})
    ious, closest = {}, 1.0
    for stem in sorted(p.stem for p in (FIXTURE / "labels").glob("*.txt")):
        lab = read(FIXTURE / "labels" / f"{stem}.txt", 9)
        pred = read(FIXTURE / "predictions" / f"{stem}.txt", 10)
        pred = pred[np.argsort(-pred[:, 9].astype(np.float32), kind="stable")]  # NMS order
        rbox = lambda a: torch.from_numpy(xyxyxyxy2xywhr(a[:, 1:9] * SIZE)).float() if len(a) else torch.zeros((0, 5))
        batch = {"bboxes": rbox(lab), "cls": torch.tensor(lab[:, 0], dtype=torch.float32)}
        predn = {"bboxes": rbox(pred), "cls": torch.tensor(pred[:, 0], dtype=torch.float32),
                 "conf": torch.tensor(pred[:, 9], dtype=torch.float32)}
        if len(lab) and len(pred):
            m = batch_probiou(batch["bboxes"], predn["bboxes"])
            ious[stem] = [[float(x) for x in row] for row in m]
            for x in m.flatten().tolist():
                closest = min(closest, *(abs(x - float(t)) for t in v.iouv))
        cls = batch["cls"].numpy()
        metrics.update_stats({  # as OBBValidator (DetectionValidator).update_metrics
            **v._process_batch(predn, batch),
            "target_cls": cls,
            "target_img": np.unique(cls),
            "conf": predn["conf"].numpy(),
            "pred_cls": predn["cls"].numpy(),
            "im_name": f"{stem}.png",
        })
    metrics.process(plot=False)
    b = metrics.box
    json.dump({
        "ultralytics": ultralytics.__version__,
        "precision": float(b.mp), "recall": float(b.mr), "map50": float(b.map50),
        "map50_95": float(b.map), "probiou": ious, "closest_to_threshold": closest,
    }, sys.stdout, indent=1)
    print()


if __name__ == "__main__":
    main()
