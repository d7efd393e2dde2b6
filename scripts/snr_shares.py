"""Share of a run's images whose streak has an integrated matched-filter SNR below a threshold.

Reads every truth sidecar (truth/img_NNNNNN.json) of each soig output folder given and prints,
per folder, the number of images, the share with `snr_matched_filter` below THRESHOLD (default
7), its percentiles, and the images per object. The README's signal-to-noise paragraph quotes it.
Usage: python3 scripts/snr_shares.py OUT... [--threshold 7]
"""
import argparse
import collections
import glob
import json
import os


def percentile(sorted_values, q):
    i = min(len(sorted_values) - 1, max(0, round(q / 100 * (len(sorted_values) - 1))))
    return sorted_values[i]


parser = argparse.ArgumentParser()
parser.add_argument("outputs", nargs="+")
parser.add_argument("--threshold", type=float, default=7.0)
args = parser.parse_args()
for out in args.outputs:
    truths = [
        json.load(open(f))
        for f in sorted(glob.glob(os.path.join(out, "truth", "img_*.json")))
    ]
    mf = sorted(t["snr_matched_filter"] for t in truths)
    below = sum(v < args.threshold for v in mf)
    mix = collections.Counter(t["norad"] for t in truths)
    print(
        f"{out}: {len(mf)} images, {below} ({100 * below / len(mf):.1f}%) with matched-filter "
        f"SNR < {args.threshold:g}; percentiles 1/10/50: {percentile(mf, 1):.1f} / "
        f"{percentile(mf, 10):.1f} / {percentile(mf, 50):.1f}; images per NORAD {dict(sorted(mix.items()))}"
    )
