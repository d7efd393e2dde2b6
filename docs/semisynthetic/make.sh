#!/usr/bin/env bash
# Makes docs/semisynthetic/*.png, the README's picture of the semisynthetic backgrounds: the
# first image of the paper's fixed-pointing semisynthetic test set on each NEOSSat frame,
# and the first synthetic image, as soig writes them (8-bit enhanced PNG), halved to 512 px.
# Needs a release build, jq, and a Python with Pillow (PYTHON, default python3).
# Usage: bash docs/semisynthetic/make.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
soig=target/release/soig
tmp=$(mktemp -d)
# All three frames (the paper's campaigns use the dark frame only; see README).
"$soig" run campaigns/paper-fixed-original-semisynthetic-small.toml --out "$tmp/semi" --quiet \
    --set 'background.paths=["../tests/fixtures/neossat/NEOSSAT_240__30_2020214095318.fits", "../tests/fixtures/neossat/NEOSSAT_240__30_2026025124741.fits", "../tests/fixtures/neossat/NEOS_SCI_2024239174545_cord.fits"]'
"$soig" run campaigns/paper-fixed-original-small.toml --out "$tmp/syn" --quiet
png_of() { find "$1/images" -name "$2.png" | head -1; }
first_on() { # the first image whose truth names frame $2
    for t in "$1"/truth/*.json; do
        case "$t" in *_stars*) continue ;; esac
        if jq -e --arg f "$2" '.background_frame == $f' "$t" > /dev/null; then
            basename "$t" .json
            return
        fi
    done
}
syn="$(ls "$tmp"/syn/truth/*.json | grep -v _stars | head -1)"
panels=("$(png_of "$tmp/syn" "$(basename "$syn" .json)")")
for frame in NEOSSAT_240__30_2020214095318 NEOSSAT_240__30_2026025124741 NEOS_SCI_2024239174545_cord; do
    panels+=("$(png_of "$tmp/semi" "$(first_on "$tmp/semi" "$frame.fits")")")
done
# Side by side, each halved to 512 px, 8 px apart: synthetic, dark frame, raw science frame,
# calibrated frame.
"${PYTHON:-python3}" - docs/semisynthetic/semisynthetic.png "${panels[@]}" <<'PY'
import sys
from PIL import Image
out, paths = sys.argv[1], sys.argv[2:]
tiles = [Image.open(p).convert("L").resize((512, 512), Image.LANCZOS) for p in paths]
sheet = Image.new("L", (512 * len(tiles) + 8 * (len(tiles) - 1), 512), 255)
for i, t in enumerate(tiles):
    sheet.paste(t, (i * 520, 0))
sheet.save(out, optimize=True)
PY
rm -rf "$tmp"
ls -l docs/semisynthetic/semisynthetic.png
