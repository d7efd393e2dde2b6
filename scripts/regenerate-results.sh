#!/usr/bin/env bash
# Reruns every committed reference run in results/ and copies back what is committed of each
# (digest, metrics, reports, PR curve; the images stay in the scratch folder), then the study,
# the committed experiments, the faint limits (results/faint-limit*),
# the CI baseline (results/ci-quickstart) and the tables of results/README.md.
# Run after any change that moves a digest, on a quiet machine; results/README.md says when
# it was last done. Usage: bash scripts/regenerate-results.sh [SCRATCH_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
scratch="${1:-$(mktemp -d)}"
soig=target/release/soig
cargo build --release --locked
for campaign in results/campaigns/*.toml; do
    name=$(basename "$campaign" .toml)
    # The faint limit's runs write results/faint-limit*/ (below), not results rows.
    case $name in faint-limit-*) continue ;; esac
    "$soig" run "$campaign" --out "$scratch/$name"
    mkdir -p "results/$name"
    python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["digest"])' \
        "$scratch/$name/manifest.json" > "results/$name/digest.txt"
    for f in metrics.csv report.json report.md timing.md pr_curve.png efficiency.png efficiency.csv; do
        cp "$scratch/$name/report/$f" "results/$name/$f"
    done
done
"$soig" study campaigns/quickstart.toml --seeds 16 --out "$scratch/study"
rm -rf results/study && mkdir -p results/study
cp "$scratch/study/"{errors.csv,manifest.json,study.csv,study.json,study.md,study.png} results/study/
# The committed experiments: their summaries, plots and digests (not the point folders).
for experiment in experiments/*.toml; do
    name=$(basename "$experiment" .toml)
    "$soig" experiment "$experiment" --out "$scratch/experiments/$name" --quiet
    rm -rf "results/experiments/$name" && mkdir -p "results/experiments/$name"
    cp -r "$scratch/experiments/$name/"{digest.txt,experiment.json,plots,summary.csv,summary.md} \
        "results/experiments/$name/"
    # Each point's values (`points/<hash>.json`: the folder names are hashes of them).
    mkdir -p "results/experiments/$name/points"
    cp "$scratch/experiments/$name/points/"*.json "results/experiments/$name/points/"
    # Each point's detection-efficiency curves (runs with a detect stage).
    for point in "$scratch/experiments/$name/points/"*/; do
        [ -f "$point/report/efficiency.png" ] || continue
        mkdir -p "results/experiments/$name/points/$(basename "$point")"
        cp "$point/report/"{efficiency.png,efficiency.csv} \
            "results/experiments/$name/points/$(basename "$point")/"
    done
done
SOIG="$soig" RUNS="$scratch" bash scripts/faint-limit.sh
SOIG="$soig" OUT="$scratch/ci-quickstart" bash scripts/ci.sh --pin
"$soig" tables results/results-* --models models/queue.toml --readme results/README.md > /dev/null
echo "results regenerated (scratch: $scratch)"
