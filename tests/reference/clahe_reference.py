#!/usr/bin/env python3
"""Reference fixtures for soig's `clahe_u8` (crates/image/src/enhance/clahe.rs).

Builds deterministic 8-bit test images (closed-form formulas and a seeded numpy
generator), runs OpenCV's `cv2.createCLAHE(clipLimit, tileGridSize).apply(img)`
and writes into tests/fixtures/clahe/:

  <name>_in.png                 the input image (8-bit grey PNG)
  <name>_c<clip>_g<tx>x<ty>.png OpenCV's output for that clip limit / grid
  manifest.txt                  one line per case, read by the Rust tests:
      png <name> <clip> <tx> <ty> <output file>
      sha <name> <clip> <tx> <ty> <sha256 of the raw row-major output bytes>

The 1024x1024 case ("big1024") is stored only by the sha256 of its output; its
input is the integer formula `big_formula` below, repeated in the Rust test.

Usage: python3 tests/reference/clahe_reference.py   (from the crate root or anywhere)
Optional: --time  prints cv2's time for one 1024x1024 apply (default threads and 1 thread).
"""
import hashlib
import os
import sys
import time

import cv2
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "fixtures", "clahe")

# (clip limit, tiles_x, tiles_y). clip 0 = no clipping in OpenCV (plain AHE).
PARAMS = [
    (40.0, 8, 8),   # OpenCV defaults
    (2.0, 8, 8),    # the usual choice
    (3.0, 5, 7),    # grid that divides none of the sizes below (except 100x77)
    (0.0, 8, 8),    # no clipping
    (1.5, 16, 16),  # many small tiles
    (10.0, 1, 1),   # single tile (plain clipped HE)
]


def grad256():
    """256x256: gradients, rings, disks and a sparse seeded speckle."""
    rng = np.random.default_rng(12345)
    y, x = np.mgrid[0:256, 0:256].astype(np.float64)
    img = 40 + 0.35 * x + 0.2 * y
    img += 12 * np.sin((x + 2 * y) / 17.0)
    r = np.hypot(x - 170, y - 90)
    img += np.where(r < 30, 60, 0) + 20 * np.cos(r / 4.0) * (r < 60)
    img = np.where(np.hypot(x - 60, y - 190) < 20, 15, img)
    img += 40 * (rng.random(img.shape) < 0.002)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def odd100x77():
    """100 wide x 77 tall, full-range texture (seeded uniform noise + pattern)."""
    rng = np.random.default_rng(777)
    y, x = np.mgrid[0:77, 0:100]
    img = ((x * 7 + y * 13) % 64) * 2 + rng.integers(0, 64, size=(77, 100))
    return np.clip(img, 0, 255).astype(np.uint8)


def tall64x300():
    """64 wide x 300 tall: width divisible by 8, height not (OpenCV then pads
    8 extra columns anyway)."""
    rng = np.random.default_rng(64300)
    y, x = np.mgrid[0:300, 0:64].astype(np.float64)
    img = 128 + 100 * np.sin(y / 23.0) + 10 * np.cos(x / 5.0) + rng.normal(0, 0.5, (300, 64))
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def const():
    return np.full((30, 40), 117, dtype=np.uint8)


def stars():
    """128x96 star field: dark sky with faint noise, a few PSF stars and hot pixels."""
    rng = np.random.default_rng(2024)
    h, w = 96, 128
    img = rng.normal(12.0, 0.6, (h, w))
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    for _ in range(8):
        cx, cy = rng.uniform(0, w), rng.uniform(0, h)
        amp = rng.uniform(30, 240)
        s = rng.uniform(0.7, 2.0)
        img += amp * np.exp(-((x - cx) ** 2 + (y - cy) ** 2) / (2 * s * s))
    for _ in range(5):
        img[rng.integers(0, h), rng.integers(0, w)] = 255
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def tiny(h, w, seed):
    rng = np.random.default_rng(seed)
    return rng.integers(0, 256, size=(h, w)).astype(np.uint8)


def big_formula():
    """1024x1024, integer formula (repeated verbatim in the Rust test):
    v = ((x ^ y) & 63) + ((x*x + 3*y*y) >> 14) + 17*((x // 128 + y // 128) & 1), mod 256."""
    y, x = np.mgrid[0:1024, 0:1024].astype(np.int64)
    v = ((x ^ y) & 63) + ((x * x + 3 * y * y) >> 14) + 17 * ((x // 128 + y // 128) & 1)
    return (v % 256).astype(np.uint8)


IMAGES = [
    ("grad256", grad256),
    ("odd100x77", odd100x77),
    ("tall64x300", tall64x300),
    ("const40x30", const),
    ("stars128x96", stars),
    ("tiny1x1", lambda: tiny(1, 1, 1)),
    ("tiny3x2", lambda: tiny(2, 3, 2)),
    ("tiny7x5", lambda: tiny(5, 7, 3)),
    ("tiny2x9", lambda: tiny(9, 2, 4)),
]


def clahe(img, clip, tx, ty):
    return cv2.createCLAHE(clipLimit=clip, tileGridSize=(tx, ty)).apply(img)


def main():
    os.makedirs(OUT, exist_ok=True)
    png = [cv2.IMWRITE_PNG_COMPRESSION, 9, cv2.IMWRITE_PNG_STRATEGY, cv2.IMWRITE_PNG_STRATEGY_FILTERED]
    lines = []
    for name, make in IMAGES:
        img = np.ascontiguousarray(make())
        assert img.dtype == np.uint8 and img.ndim == 2
        cv2.imwrite(os.path.join(OUT, f"{name}_in.png"), img, png)
        for clip, tx, ty in PARAMS:
            out = clahe(img, clip, tx, ty)
            fname = f"{name}_c{clip:g}_g{tx}x{ty}.png"
            cv2.imwrite(os.path.join(OUT, fname), out, png)
            lines.append(f"png {name} {clip!r} {tx} {ty} {fname}")
    big = big_formula()
    for clip, tx, ty in PARAMS:
        out = np.ascontiguousarray(clahe(big, clip, tx, ty))
        lines.append(f"sha big1024 {clip!r} {tx} {ty} {hashlib.sha256(out.tobytes()).hexdigest()}")
    with open(os.path.join(OUT, "manifest.txt"), "w") as f:
        f.write(f"# generated by tests/reference/clahe_reference.py with OpenCV {cv2.__version__}\n")
        f.write("\n".join(lines) + "\n")

    if "--time" in sys.argv:
        c = cv2.createCLAHE(clipLimit=2.0, tileGridSize=(8, 8))
        for threads in (cv2.getNumThreads(), 1):
            cv2.setNumThreads(threads)
            c.apply(big)
            n = 200
            t = time.perf_counter()
            for _ in range(n):
                c.apply(big)
            dt = (time.perf_counter() - t) / n
            print(f"cv2 {cv2.__version__} CLAHE 1024x1024 (2.0, 8x8), {threads} thread(s): {dt * 1e3:.3f} ms")


if __name__ == "__main__":
    main()
