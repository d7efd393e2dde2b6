#!/usr/bin/env python3
"""How the star-aware streak detector of `soig detect --catalog` holds when the star catalogue is
not exact (issue #44): missing stars, random position errors, a magnitude cut; and with no
catalogue at all (the frame's own trails).

A survey campaign of the paper's (original frame, so the FITS and the PNG labels share a pixel
grid) is rendered on a development seed, no results row's: FITS, labels and each image's star
list (`[artifacts] star_list`). The union of the star lists is the exact catalogue (what the
renderer drew); each variant degrades it with a seeded random generator. `soig detect` runs on
every FITS with each catalogue, and `soig eval` scores its streak predictions against the labels
(Ultralytics' convention; P and R at conf 0.5).

Run: python3 scripts/catalog-robustness.py [--images 60] [--seed 7001] [--soig target/release/soig]
     (standard library only; a few minutes on 2 cores). Prints a Markdown table.
"""
import argparse
import csv
import json
import math
import random
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def render(soig, work, images, seed):
    out = work / "run"
    sets = [
        f"images={images}",
        f"seed={seed}",
        'stages=["render", "enhance"]',
        "artifacts.fits=true",
        "artifacts.star_list=true",
    ]
    cmd = [soig, "run", "-q", str(ROOT / "campaigns/paper-survey-original.toml"), "--out", str(out)]
    for s in sets:
        cmd += ["--set", s]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return out


def read_stars(run):
    """The union of every image's star list: (ra, dec, mag) rows, one per star."""
    stars = {}
    for f in sorted((run / "truth").glob("*_stars.csv")):
        with f.open() as fh:
            for row in csv.DictReader(fh):
                ra, dec, mag = (float(row[k]) for k in ("ra_deg", "dec_deg", "mag"))
                stars[(round(ra, 9), round(dec, 9))] = (ra, dec, mag)
    return list(stars.values())


def write_catalog(path, stars):
    with path.open("w") as fh:
        fh.write("ra,dec,mag\n")
        for ra, dec, mag in stars:
            fh.write(f"{ra:.10f},{dec:.10f},{mag:.6f}\n")


def variants(stars, seed):
    rng = random.Random(seed)
    yield "no catalogue (own trails)", None
    yield "exact", stars
    for share in (0.01, 0.03, 0.10):
        kept = [s for s in stars if rng.random() >= share]
        yield f"{share:.0%} of stars missing", kept
    for arcsec in (0.3, 1.0):
        sigma = arcsec / 3600.0
        moved = [
            (ra + rng.gauss(0, sigma) / max(math.cos(math.radians(dec)), 1e-6),
             dec + rng.gauss(0, sigma), mag)
            for ra, dec, mag in stars
        ]
        yield f'{arcsec}" random position error (per axis)', moved
    for cut in (14.0,):
        yield f"cut at magnitude {cut:g}", [s for s in stars if s[2] <= cut]


def score(soig, run, cat, out):
    fits = sorted(str(p) for p in (run / "fits").glob("img_*.fits") if "_clean" not in p.name)
    cmd = [soig, "detect", "--campaign", str(ROOT / "campaigns/paper-survey-original.toml"),
           "--out", str(out), "--detector", "streak"]
    if cat is not None:
        cmd += ["--catalog", str(cat)]
    subprocess.run(cmd + fits, check=True, stdout=subprocess.DEVNULL)
    ev = subprocess.run(
        [soig, "eval", "--labels", str(run / "labels"), "--predictions",
         str(out / "predictions" / "streak"), "--images", str(run / "images"), "--json"],
        check=True, capture_output=True, text=True)
    return json.loads(ev.stdout)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--images", type=int, default=60)
    ap.add_argument("--seed", type=int, default=7001)
    ap.add_argument("--soig", default=str(ROOT / "target/release/soig"))
    ap.add_argument("--keep", help="work folder to keep (default: a temporary one)")
    a = ap.parse_args()
    if a.keep:
        Path(a.keep).mkdir(parents=True, exist_ok=True)
        return measure(a, Path(a.keep))
    # The work folder holds about 3 GB (the render and eight detections): removed at the end.
    with tempfile.TemporaryDirectory(prefix="soig-catalog-") as work:
        return measure(a, Path(work))


def measure(a, work):
    run = render(a.soig, work, a.images, a.seed)
    stars = read_stars(run)
    print(f"{a.images} images of paper-survey-original, seed {a.seed}; {len(stars)} stars in the exact catalogue\n")
    print("| catalogue | stars | P | R | false boxes | mAP50 | mAP50-95 |")
    print("|---|---|---|---|---|---|---|")
    for k, (name, cat) in enumerate(variants(stars, a.seed)):
        path = None
        if cat is not None:
            path = work / f"catalog{k}.csv"
            write_catalog(path, cat)
        m = score(a.soig, run, path, work / f"det{k}")
        t = m["at_threshold"]
        print(f"| {name} | {len(cat) if cat is not None else '-'} | {t['precision']:.3f} | "
              f"{t['recall']:.3f} | {t['fp']} | {m['map50']:.3f} | {m['map50_95']:.3f} |", flush=True)


if __name__ == "__main__":
    sys.exit(main())
