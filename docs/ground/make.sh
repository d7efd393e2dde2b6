#!/usr/bin/env bash
# Makes docs/ground/ground.png, the README's picture of the ground campaigns: the first image of
# campaigns/ground-sidereal-leo.toml, ground-geo-stare.toml and ground-geo-track.toml as soig
# writes it (8-bit enhanced PNG), each halved to 512 px with the label box drawn (grey): a LEO
# streak among point stars (sidereal tracking), then a near-GEO object standing among trailed
# stars (stare held in altitude and azimuth, and rate tracking).
# Needs a release build and a Python with Pillow (PYTHON, default python3).
# Usage: bash docs/ground/make.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
tmp=$(mktemp -d)
runs=()
for c in ground-sidereal-leo ground-geo-stare ground-geo-track; do
    target/release/soig run "campaigns/$c.toml" --out "$tmp/$c" --quiet --set images=4 \
        --set 'stages=["render", "enhance", "dataset"]'
    runs+=("$tmp/$c")
done
"${PYTHON:-python3}" - docs/ground/ground.png "${runs[@]}" <<'PY'
import json, sys, glob
from PIL import Image, ImageDraw
out, runs = sys.argv[1], sys.argv[2:]
sheet = Image.new("L", (512 * len(runs) + 8 * (len(runs) - 1), 512), 255)
for k, run in enumerate(runs):
    png = glob.glob(f"{run}/images/*/img_000000.png")[0]
    box = json.load(open(f"{run}/truth/img_000000.json"))["label_box_px"]
    img = Image.open(png).convert("L")
    half = img.resize((512, 512), Image.LANCZOS)
    # Pixel centres at integers in the truth: pixel edges are +0.5.
    x0, y0, x1, y1 = (box[k2] + 0.5 for k2 in ("x_min", "y_min", "x_max", "y_max"))
    ImageDraw.Draw(half).rectangle((x0 / 2 - 4, y0 / 2 - 4, x1 / 2 + 4, y1 / 2 + 4), outline=255)
    sheet.paste(half, (k * 520, 0))
sheet.save(out, optimize=True)
PY
rm -rf "$tmp"
echo "wrote docs/ground/ground.png"
