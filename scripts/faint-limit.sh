#!/usr/bin/env bash
# The streak detector's faint limit (issue #44): run the faint-limit campaigns of
# results/campaigns/ (a results test set with dim debris and no SNR gate; 1-3 min each on 2
# cores, faint-limit-fixed's 1200 images about 10) and write, from each, the recall against
# the streak's integrated matched-filter SNR, its 50% point and the precision
# (scripts/faint_limit.py): the streak detector's in the folder,
# YOLO's (the row's model, run beside it) in its yolo/:
#   faint-limit-survey                -> results/faint-limit/ (survey, synthetic noise)
#   faint-limit-fixed                 -> results/faint-limit-fixed/ (point stars)
#   faint-limit-survey-semisynthetic  -> results/faint-limit-survey-semisynthetic/ (real noise)
#   faint-limit-survey-science, faint-limit-survey-calibrated -> results/NAME/ (the third on
#     the other two real frames: the raw 187 s science frame and the calibrated 10 s one)
#   faint-limit-survey-linearised, faint-limit-survey-semisynthetic-linearised,
#   faint-limit-survey-science-linearised, faint-limit-survey-calibrated-linearised ->
#     results/NAME/ (the first, third and the two before with `[detect.streak] linearise`)
#
#   bash scripts/faint-limit.sh [NAME...]   # default all nine; runs under RUNS (default runs/)
set -euo pipefail
cd "$(dirname "$0")/.."
SOIG=${SOIG:-target/release/soig}
RUNS=${RUNS:-runs}
names=("$@")
[ ${#names[@]} -gt 0 ] || names=(faint-limit-survey faint-limit-fixed faint-limit-survey-semisynthetic
    faint-limit-survey-science faint-limit-survey-calibrated faint-limit-survey-linearised
    faint-limit-survey-semisynthetic-linearised faint-limit-survey-science-linearised
    faint-limit-survey-calibrated-linearised)
for name in "${names[@]}"; do
    # Every faint-limit campaign of results/campaigns/ writes results/NAME/, but the first's
    # (committed before the others as results/faint-limit/).
    case $name in
        faint-limit-survey) dest=results/faint-limit ;;
        faint-limit-*) dest=results/$name ;;
        *) dest= ;;
    esac
    if [ -z "$dest" ] || [ ! -f "results/campaigns/$name.toml" ]; then
        echo "faint-limit.sh: no faint-limit campaign $name" >&2; exit 2
    fi
    out="$RUNS/$name"
    "$SOIG" run "results/campaigns/$name.toml" --out "$out" --quiet
    python3 scripts/faint_limit.py "$out" "$dest"
    python3 scripts/faint_limit.py "$out" "$dest/yolo" --detector yolo
    cp "$out"/report/report.md "$dest"/report.md
    "$SOIG" verify "$out" | sed -n 's/.*digest //p' > "$dest"/digest.txt
done
# The smooth fit of every committed set, with its interval (results/faint-limit-fit.md).
python3 scripts/faint_limit_fit.py results/faint-limit*/objects.csv > results/faint-limit-fit.md
