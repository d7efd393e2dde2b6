#!/usr/bin/env bash
# Makes docs/multi/multi.png, the README's picture of several objects per frame: from
# campaigns/quickstart-multi.toml (rendered and enhanced only), the first image with three
# objects and the first empty one, as soig writes them (8-bit enhanced PNG), each label box
# drawn 8 px wider on every side (a streak is a few pixels wide), halved to 512 px.
# Needs a release build, jq, and a Python with Pillow (PYTHON, default python3).
# Usage: bash docs/multi/make.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
soig=target/release/soig
tmp=$(mktemp -d)
"$soig" run campaigns/quickstart-multi.toml --out "$tmp/run" --quiet \
    --set images=20 --set 'stages=["render", "enhance", "dataset"]'
first_with() { # the first image whose truth lists $1 objects
    for t in "$tmp"/run/truth/img_??????.json; do
        if jq -e --argjson n "$1" '(.objects | length) == $n' "$t" > /dev/null; then
            basename "$t" .json
            return
        fi
    done
}
panels=()
for n in 3 0; do
    stem=$(first_with "$n")
    panels+=("$(find "$tmp/run/images" -name "$stem.png")" "$(find "$tmp/run/labels" -name "$stem.txt")")
done
"${PYTHON:-python3}" - docs/multi/multi.png "${panels[@]}" <<'PY'
import sys
from PIL import Image, ImageDraw
sys.path.insert(0, "docs")
from boxes import label_rects
out, args = sys.argv[1], sys.argv[2:]
tiles = []
for png, labels in zip(args[::2], args[1::2]):
    im = Image.open(png).convert("RGB")
    draw = ImageDraw.Draw(im)
    for rect in label_rects(labels, *im.size, pad=8):
        draw.rectangle(rect, outline=(255, 40, 40), width=3)
    tiles.append(im.resize((512, 512), Image.LANCZOS))
sheet = Image.new("RGB", (512 * len(tiles) + 8 * (len(tiles) - 1), 512), (255, 255, 255))
for i, t in enumerate(tiles):
    sheet.paste(t, (i * 520, 0))
sheet.save(out, optimize=True)
PY
rm -rf "$tmp"
ls -l docs/multi/multi.png
