#!/usr/bin/env python3
"""The tools a user would pick instead of soig, doing the same work, for scripts/bench.sh.

  peer.py enhance OUT_DIR SQRT CLIP TX TY GAMMA FITS...
      soig's FITS -> PNG enhancement (crates/image/src/enhance/mod.rs) in numpy + astropy + OpenCV, step for
      step: square root, normalise, the log stretch whose gain puts the median at 0.25 (the same
      bisection), round half away from zero, cv2 CLAHE (soig's CLAHE is bit-exact against it),
      the gamma table, cv2.imwrite. Prints one line per image: name and seconds for enhancement
      and PNG writing (what soig's `timing.json` holds), one thread (cv2.setNumThreads(1)).
  peer.py yolo MODEL THREADS PNG...
      onnxruntime from Python on the same PNGs, Ultralytics' letterbox to the model's input:
      prints seconds per image (preprocessing and inference, as `soig detect`'s timing).
  peer.py coco LABELS PREDICTIONS SIZE
      pycocotools COCOeval (bbox) on YOLO-format folders: prints AP and the seconds of
      loading, evaluate, accumulate and summarize.
  peer.py make-eval DIR N SEED
      N images of YOLO labels and predictions (1-3 boxes each, jittered) for the eval benchmark.
"""
import math
import os
import sys
import time

import numpy as np


def log_gain_for(x, target):
    # crates/image/src/enhance/mod.rs `log_gain_for`, the same bisection in the same float arithmetic.
    if math.isnan(x) or x <= 0.0 or x >= target:
        return 0.0
    f = lambda g: math.log(1.0 + g * x) / math.log(1.0 + g) - target
    a, b = 1e-9, 1.0
    while f(b) < 0.0 and b < 1e15:
        b *= 10.0
    for _ in range(200):
        m = math.sqrt(a * b)
        if f(m) < 0.0:
            a = m
        else:
            b = m
    return math.sqrt(a * b)


def enhance(out_dir, sqrt, clip, tx, ty, gamma, paths):
    import cv2
    from astropy.io import fits

    cv2.setNumThreads(1)
    lut = np.array([math.floor((i / 255.0) ** gamma * 255.0 + 0.5) for i in range(256)], np.uint8)
    clahe = cv2.createCLAHE(clipLimit=clip, tileGridSize=(tx, ty))
    for p in paths:
        adu = fits.getdata(p).astype(np.float32)
        t = time.perf_counter()
        v = np.sqrt(np.maximum(adu, 0).astype(np.float64)) if sqrt else adu.astype(np.float64)
        lo, hi = v.min(), v.max()
        span = hi - lo if hi > lo else 1.0
        n = (v - lo) / span
        flat = n.ravel()
        mid = flat.size // 2
        median = np.partition(flat, mid)[mid]
        gain = log_gain_for(float(median), 0.25)
        y = np.log(1.0 + gain * n) / math.log(1.0 + gain) if gain > 0.0 else n
        stretched = np.clip(np.floor(y * 255.0 + 0.5), 0, 255).astype(np.uint8)
        out = cv2.LUT(clahe.apply(stretched), lut)
        name = os.path.splitext(os.path.basename(p))[0] + ".png"
        cv2.imwrite(os.path.join(out_dir, name), out)
        print(name, time.perf_counter() - t)


def letterbox(gray, size):
    import cv2

    h, w = gray.shape
    r = min(size / h, size / w)
    nw, nh = round(w * r), round(h * r)
    img = cv2.resize(gray, (nw, nh), interpolation=cv2.INTER_LINEAR) if (nw, nh) != (w, h) else gray
    top, left = (size - nh) // 2, (size - nw) // 2
    canvas = np.full((size, size), 114, np.uint8)
    canvas[top:top + nh, left:left + nw] = img
    x = np.repeat(canvas[None, None].astype(np.float32) / 255.0, 3, axis=1)
    return x


def yolo(model, threads, paths):
    import cv2
    import onnxruntime as ort

    cv2.setNumThreads(1)
    so = ort.SessionOptions()
    so.intra_op_num_threads = threads
    so.inter_op_num_threads = 1
    s = ort.InferenceSession(model, so, providers=["CPUExecutionProvider"])
    inp = s.get_inputs()[0]
    size = inp.shape[2] if isinstance(inp.shape[2], int) else 1024
    for p in paths:
        gray = cv2.imread(p, cv2.IMREAD_GRAYSCALE)
        t = time.perf_counter()
        s.run(None, {inp.name: letterbox(gray, size)})
        print(os.path.basename(p), time.perf_counter() - t)


def read_yolo(folder, with_score):
    out = {}
    for name in sorted(os.listdir(folder)):
        rows = []
        with open(os.path.join(folder, name)) as f:
            for line in f:
                v = line.split()
                if v:
                    rows.append([float(x) for x in v])
        out[os.path.splitext(name)[0]] = rows
    return out


def coco(labels, predictions, size):
    from pycocotools.coco import COCO
    from pycocotools.cocoeval import COCOeval
    import contextlib
    import io

    t0 = time.perf_counter()
    gt, dt = read_yolo(labels, False), read_yolo(predictions, True)
    images, anns, dets = [], [], []
    for i, stem in enumerate(sorted(gt)):
        images.append({"id": i, "width": size, "height": size})
        box = lambda r: [(r[1] - r[3] / 2) * size, (r[2] - r[4] / 2) * size, r[3] * size, r[4] * size]
        for r in gt[stem]:
            b = box(r)
            anns.append({"id": len(anns) + 1, "image_id": i, "category_id": int(r[0]), "bbox": b,
                         "area": b[2] * b[3], "iscrowd": 0})
        for r in dt.get(stem, []):
            dets.append({"image_id": i, "category_id": int(r[0]), "bbox": box(r), "score": r[5]})
    g = COCO()
    g.dataset = {"images": images, "annotations": anns, "categories": [{"id": 0}]}
    with contextlib.redirect_stdout(io.StringIO()):
        g.createIndex()
        d = g.loadRes(dets)
        e = COCOeval(g, d, "bbox")
        e.evaluate()
        e.accumulate()
        e.summarize()
    print("ap", e.stats[0], "seconds", time.perf_counter() - t0)


def make_eval(folder, n, seed):
    rng = np.random.default_rng(seed)
    os.makedirs(os.path.join(folder, "labels"), exist_ok=True)
    os.makedirs(os.path.join(folder, "predictions"), exist_ok=True)
    for i in range(n):
        k = rng.integers(1, 4)
        lab, pred = [], []
        for _ in range(k):
            xc, yc = rng.uniform(0.1, 0.9, 2)
            w, h = rng.uniform(0.01, 0.2, 2)
            lab.append(f"0 {xc:.6f} {yc:.6f} {w:.6f} {h:.6f}")
            if rng.uniform() < 0.9:
                j = rng.normal(0, 0.1, 4) * [w, h, w, h]
                pred.append(f"0 {xc + j[0]:.6f} {yc + j[1]:.6f} {abs(w + j[2]):.6f} {abs(h + j[3]):.6f} {rng.uniform(0.05, 1):.6f}")
        if rng.uniform() < 0.3:
            pred.append(f"0 {rng.uniform(0.1, 0.9):.6f} {rng.uniform(0.1, 0.9):.6f} 0.05 0.05 {rng.uniform(0.05, 0.6):.6f}")
        with open(os.path.join(folder, "labels", f"im{i:06d}.txt"), "w") as f:
            f.write("\n".join(lab) + "\n")
        with open(os.path.join(folder, "predictions", f"im{i:06d}.txt"), "w") as f:
            f.write("\n".join(pred) + ("\n" if pred else ""))


if __name__ == "__main__":
    cmd, args = sys.argv[1], sys.argv[2:]
    if cmd == "enhance":
        enhance(args[0], args[1] == "true", float(args[2]), int(args[3]), int(args[4]), float(args[5]), args[6:])
    elif cmd == "yolo":
        yolo(args[0], int(args[1]), args[2:])
    elif cmd == "coco":
        coco(args[0], args[1], int(args[2]))
    elif cmd == "make-eval":
        make_eval(args[0], int(args[1]), int(args[2]))
    else:
        sys.exit(f"unknown command {cmd}")
