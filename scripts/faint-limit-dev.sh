#!/usr/bin/env bash
# A development loop for the streak detector's faint limit (issue #44), about a minute a try on
# 2 cores: render a development set of results/campaigns/faint-limit-survey.toml once (another
# seed than the committed curve's 9401, which is for reporting), then re-run the detector of
# the run's detect stage on it (`cargo run --example sky_eval`: the star-trail prediction and
# the streak detector told of it) and score it as scripts/faint-limit.sh does.
#
#   bash scripts/faint-limit-dev.sh [SEED] [IMAGES] [TAG]   # defaults 9402 150 dev
#   -> runs/faint-limit-dev-SEED (the images, kept), runs/faint-limit-dev-SEED-TAG/{predictions,summary}
set -euo pipefail
cd "$(dirname "$0")/.."
SEED=${1:-9402}
IMAGES=${2:-150}
TAG=${3:-dev}
CAMPAIGN=results/campaigns/faint-limit-survey.toml
RUN=runs/faint-limit-dev-$SEED
OUT=runs/faint-limit-dev-$SEED-$TAG
SETS=(--set "seed=$SEED" --set "images=$IMAGES")
cargo build --release --locked --example sky_eval
if [ ! -f "$RUN/manifest.json" ]; then
    target/release/soig run "$CAMPAIGN" --out "$RUN" --quiet "${SETS[@]}" \
        --set 'stages=["render","enhance","dataset"]'
fi
rm -rf "$OUT" && mkdir -p "$OUT"
target/release/examples/sky_eval "$CAMPAIGN" "$RUN" "$OUT/predictions" "${SETS[@]}" 2>/dev/null
python3 scripts/faint_limit.py "$RUN" "$OUT/summary" --predictions "$OUT/predictions"
