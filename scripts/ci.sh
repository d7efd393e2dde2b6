#!/usr/bin/env bash
# The CI check (.github/workflows/soig.yml runs exactly this; tests/compare.rs runs it too):
# run the pinned quickstart campaign and `soig compare` it with its baseline in
# results/ci-quickstart/. Exit 0: identical, or every metric within tolerance; 1: a regression;
# 2: an error.
#
#   bash scripts/ci.sh          compare a fresh run with the baseline
#   bash scripts/ci.sh --pin    make the fresh run the baseline (commit results/ci-quickstart/)
#
# SOIG (default target/release/soig) is the binary; OUT (default runs/ci-quickstart) the run.
set -euo pipefail
cd "$(dirname "$0")/.."
SOIG=${SOIG:-target/release/soig}
OUT=${OUT:-runs/ci-quickstart}
BASELINE=results/ci-quickstart
"$SOIG" run campaigns/quickstart.toml --out "$OUT" --quiet
if [ "${1:-}" = "--pin" ]; then
  mkdir -p "$BASELINE"
  cp "$OUT"/report/report.json "$OUT"/report/metrics.csv "$OUT"/report/report.md "$OUT"/report/timing.md "$BASELINE"/
  "$SOIG" verify "$OUT" | sed -n 's/.*digest //p' > "$BASELINE"/digest.txt
  echo "pinned $OUT as $BASELINE (digest $(cat "$BASELINE"/digest.txt))"
else
  "$SOIG" compare "$BASELINE" "$OUT"
fi
