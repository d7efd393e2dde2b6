#!/usr/bin/env python3
"""How much more a real frame's line sums vary than white noise of its pixel sigma predicts.

The truth's line SNR of a semisynthetic image (`snr_matched_filter`) is the streak's matched
filter against the background frame's robust pixel sigma (`RealFrame::sigma`: 1.4826 MAD of the
frame after its large-scale structure is flattened), as if that noise were white. A raw dark
frame's is not: hot pixels give it heavy tails that a MAD does not see, and rows and columns
share offsets. This script measures, on the frame itself, the robust spread of sums along
straight lines of L pixels (1.4826 MAD of the sums over random places) against sigma sqrt(L),
the white-noise prediction: a factor of 1 is white noise, a factor of F means a streak of truth
line SNR s is a line-sum SNR of about s / F on that frame. Twice: the frame as it is, and with
pixels clipped at `--clip` sigmas (what a detector that clips its map sees). A control frame of
Gaussian white noise of the same sigma, measured the same way, must give 1 (to the sampling
error of a MAD of `--samples` sums, about 1.7 % at 4096).

The flattening approximates soig's (`crates/sim/src/background/prepare.rs`): 32 px block
medians, interpolated bilinearly; the sigma it gives the NEOSSat dark frame (97.6 ADU at its
28 s) is the truth's `background_sigma_adu` scaled back to 28 s (96.5).

Usage: .venv/bin/python scripts/frame_line_noise.py FRAME.fits [--lengths 4,16,64,256,512]
       [--angles 0,30,60,90] [--samples 4096] [--clip 5] [--seed 1]
Prints a Markdown table. Needs numpy and astropy (the project's .venv has both).
"""

import argparse
import re
import sys

import numpy as np
from astropy.io import fits

BLOCK = 32


def trimmed(path):
    """The frame's data section (TRIMSEC, else DATASEC, FITS 1-based inclusive), as floats."""
    with fits.open(path) as h:
        data = h[0].data.astype(float)
        head = h[0].header
    for key in ("TRIMSEC", "DATASEC"):
        m = re.match(r"\[(\d+):(\d+),(\d+):(\d+)\]", str(head.get(key, "")).replace(" ", ""))
        if m:
            x0, x1, y0, y1 = (int(v) for v in m.groups())
            return data[y0 - 1 : y1, x0 - 1 : x1]
    return data


def flattened(a):
    """`a` less its large-scale structure: block medians, interpolated bilinearly."""
    h, w = a.shape
    hb, wb = h // BLOCK, w // BLOCK
    blocks = a[: hb * BLOCK, : wb * BLOCK].reshape(hb, BLOCK, wb, BLOCK)
    med = np.median(blocks.transpose(0, 2, 1, 3).reshape(hb, wb, -1), axis=2)
    yy = (np.arange(h) + 0.5) / BLOCK - 0.5
    xx = (np.arange(w) + 0.5) / BLOCK - 0.5
    yi = np.clip(np.floor(yy).astype(int), 0, hb - 2)
    xi = np.clip(np.floor(xx).astype(int), 0, wb - 2)
    fy = np.clip(yy - yi, 0, 1)[:, None]
    fx = np.clip(xx - xi, 0, 1)[None, :]
    top = (1 - fx) * med[yi][:, xi] + fx * med[yi][:, xi + 1]
    bottom = (1 - fx) * med[yi + 1][:, xi] + fx * med[yi + 1][:, xi + 1]
    return a - ((1 - fy) * top + fy * bottom)


def robust_sd(v):
    return 1.4826 * np.median(np.abs(v - np.median(v)))


def factor(a, sigma, length, angle_deg, samples, rng):
    """1.4826 MAD of `samples` sums along digital lines of `length` pixels at `angle_deg` (one
    pixel per step of the major axis, so no pixel twice), over sigma sqrt(L)."""
    h, w = a.shape
    t = np.deg2rad(angle_deg)
    ux, uy = np.cos(t), np.sin(t)
    steps = np.arange(length) / max(abs(ux), abs(uy))
    sums = []
    while len(sums) < samples:
        x0, y0 = rng.uniform(0, w), rng.uniform(0, h)
        xs = np.rint(x0 + steps * ux).astype(int)
        ys = np.rint(y0 + steps * uy).astype(int)
        if xs.min() < 0 or ys.min() < 0 or xs.max() >= w or ys.max() >= h:
            continue
        sums.append(a[ys, xs].sum())
    return robust_sd(np.array(sums)) / (sigma * np.sqrt(length))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("frame")
    ap.add_argument("--lengths", default="4,16,64,256,512")
    ap.add_argument("--angles", default="0,30,60,90")
    ap.add_argument("--samples", type=int, default=4096)
    ap.add_argument("--clip", type=float, default=5.0)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    lengths = [int(v) for v in args.lengths.split(",")]
    angles = [float(v) for v in args.angles.split(",")]
    if min(lengths) < 1 or args.samples < 16 or not args.clip > 0:
        sys.exit("frame_line_noise: --lengths must be >= 1, --samples >= 16, --clip > 0")
    flat = flattened(trimmed(args.frame))
    flat -= np.median(flat)
    sigma = robust_sd(flat)
    if not sigma > 0:
        sys.exit(f"frame_line_noise: {args.frame}: no noise (sigma {sigma})")
    if max(lengths) >= min(flat.shape):
        sys.exit(f"frame_line_noise: --lengths must be under the frame's {min(flat.shape)} px")
    rng = np.random.default_rng(args.seed)
    frames = [
        ("as it is", flat),
        (f"clipped at {args.clip:g} sigma", np.clip(flat, -args.clip * sigma, args.clip * sigma)),
        ("control: white Gaussian noise", rng.normal(0.0, sigma, flat.shape)),
    ]
    print(f"Frame `{args.frame}`: {flat.shape[1]} x {flat.shape[0]} px after trimming, "
          f"pixel sigma (1.4826 MAD after flattening) {sigma:.1f} ADU, standard deviation "
          f"{flat.std():.1f} ADU; {args.samples} sums a cell, seed {args.seed}.\n")
    print("| frame | angle (deg) | " + " | ".join(f"L = {n} px" for n in lengths) + " |")
    print("|---|---|" + "---|" * len(lengths))
    for name, a in frames:
        for ang in angles:
            cells = [f"{factor(a, sigma, n, ang, args.samples, rng):.2f}" for n in lengths]
            print(f"| {name} | {ang:g} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
