#!/usr/bin/env bash
# Makes docs/collect/collect.png, the README's picture of a multi-frame collect: the five frames
# of collect 0 of campaigns/collect-quickstart.toml (track pointing) in time order, as soig
# writes them (8-bit enhanced PNG), each the 512 x 512 px around the tracked object halved to
# 256 px, its label box drawn (red), and under each the frame, its track id and its start after
# the first frame's, all read from collects/collect_000000.json and the truth sidecars: the
# object holds its pixel while the stars trail, frame after frame.
# Needs a release build and a Python with Pillow (PYTHON, default .venv/bin/python3 from
# scripts/setup.sh, else python3).
# Usage: bash docs/collect/make.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
py=${PYTHON:-.venv/bin/python3}
[ -x "$py" ] || py=python3
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
target/release/soig run campaigns/collect-quickstart.toml --out "$tmp/run" --quiet \
    --set images=5 --set 'stages=["render", "enhance", "dataset"]'
"$py" - docs/collect/collect.png "$tmp/run" <<'PY'
import json, sys
from datetime import datetime
from PIL import Image, ImageDraw
out, run = sys.argv[1], sys.argv[2]
collect = json.load(open(f"{run}/collects/collect_000000.json"))
t0 = datetime.fromisoformat(collect["frames"][0]["date_obs"])
tile, gap, band = 256, 8, 22
sheet = Image.new("RGB", (5 * tile + 4 * gap, tile + band), (255, 255, 255))
for i, f in enumerate(collect["frames"]):
    truth = json.load(open(f"{run}/{f['truth']}"))
    img = Image.open(f"{run}/{f['png']}").convert("RGB")
    b = truth["label_box_final_px"]
    # Pixel centres at integers in the truth: pixel edges are +0.5.
    x0, y0, x1, y1 = (b[k] + 0.5 for k in ("x_min", "y_min", "x_max", "y_max"))
    cx = min(max(int((x0 + x1) / 2), 256), img.width - 256)
    cy = min(max(int((y0 + y1) / 2), 256), img.height - 256)
    crop = img.crop((cx - 256, cy - 256, cx + 256, cy + 256))
    d = ImageDraw.Draw(crop)
    ox, oy = cx - 256, cy - 256
    d.rectangle((x0 - ox - 6, y0 - oy - 6, x1 - ox + 6, y1 - oy + 6), outline=(255, 40, 40), width=4)
    sheet.paste(crop.resize((tile, tile), Image.LANCZOS), (i * (tile + gap), 0))
    dt = (datetime.fromisoformat(f["date_obs"]) - t0).total_seconds()
    c = truth["collect"]
    ImageDraw.Draw(sheet).text(
        (i * (tile + gap) + 4, tile + 4),
        f"frame {c['frame']}  track {c['track_id']}  +{dt:.1f} s",
        fill=(0, 0, 0))
sheet.save(out, optimize=True)
PY
echo "wrote docs/collect/collect.png"
