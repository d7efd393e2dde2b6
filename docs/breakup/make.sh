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
sys.path.insert(0, "docs")
from boxes import label_rects
out, png, labels, truth = sys.argv[1:]
objects = [o for o in json.load(open(truth))["objects"] if o["label_box_final_px"] is not None]
im = Image.open(png).convert("RGB")
draw = ImageDraw.Draw(im)
rects = label_rects(labels, *im.size, pad=6)
assert len(rects) == len(objects), (len(rects), len(objects))
for rect, o in zip(rects, objects):
    color = (255, 160, 0) if o["source"] == "generated" else (255, 40, 40)
    draw.rectangle(rect, outline=color, width=2)
# 64 levels: a quarter of the bytes.
im.convert("P", palette=Image.ADAPTIVE, colors=64).save(out, optimize=True)
PY
rm -rf "$tmp"
ls -l docs/breakup/breakup.png
