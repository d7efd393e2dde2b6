#!/usr/bin/env bash
# Makes docs/breakup/breakup.png, the README's picture of a breakup cloud: the first image of
# campaigns/breakup.toml as soig writes it (8-bit enhanced PNG), each label box drawn 6 px
# wider on every side, orange for a fragment (truth `source` generated), red for an object of
# the GEO belt; label lines and the truth's labelled objects are in the same order.
# Needs a release build and a Python with Pillow (PYTHON, default python3).
# Usage: bash docs/breakup/make.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
soig=target/release/soig
tmp=$(mktemp -d)
"$soig" run campaigns/breakup.toml --out "$tmp/run" --quiet
png=$(find "$tmp/run/images" -name img_000000.png)
labels=$(find "$tmp/run/labels" -name img_000000.txt)
"${PYTHON:-python3}" - docs/breakup/breakup.png "$png" "$labels" "$tmp/run/truth/img_000000.json" <<'PY'
import json
import sys
from PIL import Image, ImageDraw
out, png, labels, truth = sys.argv[1:]
objects = [o for o in json.load(open(truth))["objects"] if o["label_box_final_px"] is not None]
im = Image.open(png).convert("RGB")
w, h = im.size
draw = ImageDraw.Draw(im)
lines = open(labels).read().splitlines()
assert len(lines) == len(objects), (len(lines), len(objects))
for line, o in zip(lines, objects):
    _, xc, yc, bw, bh = map(float, line.split())
    color = (255, 160, 0) if o["source"] == "generated" else (255, 40, 40)
    draw.rectangle(
        [(xc - bw / 2) * w - 6, (yc - bh / 2) * h - 6, (xc + bw / 2) * w + 6, (yc + bh / 2) * h + 6],
        outline=color, width=2)
# 64 levels: a quarter of the bytes.
im.convert("P", palette=Image.ADAPTIVE, colors=64).save(out, optimize=True)
PY
rm -rf "$tmp"
ls -l docs/breakup/breakup.png
