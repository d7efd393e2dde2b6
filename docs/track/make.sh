#!/usr/bin/env bash
# Makes docs/track/track.png, the README's picture of track pointing: the first image of
# campaigns/track-quickstart.toml as soig writes it (8-bit enhanced PNG), halved to 512 px with
# the label box drawn (grey), beside the 64 x 64 px around the debris enlarged 8 times: the
# tracked object is a point, the stars trail.
# Needs a release build and a Python with Pillow (PYTHON, default python3).
# Usage: bash docs/track/make.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
tmp=$(mktemp -d)
target/release/soig run campaigns/track-quickstart.toml --out "$tmp/run" --quiet --set images=1
"${PYTHON:-python3}" - docs/track/track.png "$tmp/run" <<'PY'
import json, sys, glob
from PIL import Image, ImageDraw
out, run = sys.argv[1], sys.argv[2]
png = glob.glob(f"{run}/images/*/img_000000.png")[0]
box = json.load(open(f"{run}/truth/img_000000.json"))["label_box_px"]
img = Image.open(png).convert("L")
# Pixel centres at integers in the truth: pixel edges are +0.5.
x0, y0, x1, y1 = (box[k] + 0.5 for k in ("x_min", "y_min", "x_max", "y_max"))
cx, cy = int((x0 + x1) / 2), int((y0 + y1) / 2)
crop = img.crop((cx - 32, cy - 32, cx + 32, cy + 32)).resize((512, 512), Image.NEAREST)
half = img.resize((512, 512), Image.LANCZOS)
d = ImageDraw.Draw(half)
d.rectangle((x0 / 2 - 4, y0 / 2 - 4, x1 / 2 + 4, y1 / 2 + 4), outline=255)
sheet = Image.new("L", (1032, 512), 255)
sheet.paste(half, (0, 0))
sheet.paste(crop, (520, 0))
sheet.save(out, optimize=True)
PY
rm -rf "$tmp"
echo "wrote docs/track/track.png"
