#!/usr/bin/env bash
# The streak detector's faint limit (issue #44): run results/campaigns/faint-limit-survey.toml
# (the survey original-frame synthetic test set with dim debris and no SNR gate; about 3 min on
# 2 cores) and write results/faint-limit/ from it: the recall against the streak's integrated
# matched-filter SNR, its 50% point and the precision (scripts/faint_limit.py).
#
#   bash scripts/faint-limit.sh            # OUT (default runs/faint-limit-survey) is the run
set -euo pipefail
cd "$(dirname "$0")/.."
SOIG=${SOIG:-target/release/soig}
OUT=${OUT:-runs/faint-limit-survey}
"$SOIG" run results/campaigns/faint-limit-survey.toml --out "$OUT" --quiet
python3 scripts/faint_limit.py "$OUT" results/faint-limit
cp "$OUT"/report/report.md results/faint-limit/report.md
"$SOIG" verify "$OUT" | sed -n 's/.*digest //p' > results/faint-limit/digest.txt
