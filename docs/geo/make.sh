#!/usr/bin/env bash
# Makes docs/geo/geo-stare.png, the README's picture of a catalogue scene: the first image of
# campaigns/geo-stare.toml (a GEO stare, every object of the population where its orbit puts
# it) as soig writes it (8-bit enhanced PNG), each label box drawn 6 px wider on every side
# (the streaks are a few pixels long at 14"/px).
# Needs a release build and a Python with Pillow (PYTHON, default python3).
# Usage: bash docs/geo/make.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
soig=target/release/soig
tmp=$(mktemp -d)
"$soig" run campaigns/geo-stare.toml --out "$tmp/run" --quiet
png=$(find "$tmp/run/images" -name img_000000.png)
labels=$(find "$tmp/run/labels" -name img_000000.txt)
"${PYTHON:-python3}" - docs/geo/geo-stare.png "$png" "$labels" <<'PY'
import sys
from PIL import Image, ImageDraw
sys.path.insert(0, "docs")
from boxes import label_rects
out, png, labels = sys.argv[1:]
im = Image.open(png).convert("RGB")
draw = ImageDraw.Draw(im)
for rect in label_rects(labels, *im.size, pad=6):
    draw.rectangle(rect, outline=(255, 40, 40), width=2)
# 64 grey levels and the red: a quarter of the bytes.
im.convert("P", palette=Image.ADAPTIVE, colors=64).save(out, optimize=True)
PY
rm -rf "$tmp"
ls -l docs/geo/geo-stare.png
