#!/usr/bin/env bash
# Resumable training on CPU (issue 13): on a tiny dataset (12 images of 256 px, imgsz 64), one
# 4-epoch schedule (A), the same schedule as 2 + 2 epochs (B: --chunk-epochs 2, then --resume)
# and as time-budgeted chunks (C: --budget 1s stops after each first epoch, since every epoch
# takes longer than 1 s; then --resume to the end) must run the same epochs with the same
# per-epoch learning rates and leave the same files. Needs a Python with Ultralytics
# (`bash scripts/setup-train.sh`; $SOIG_TRAIN_PYTHON overrides) and target/release/soig.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${SOIG_TRAIN_PYTHON:-.venv-train/bin/python3}
"$PY" -c "import ultralytics" || { echo "train-resume-test: no Ultralytics in $PY" >&2; exit 1; }
SOIG=target/release/soig
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
sets=(--set images=12 --set sensor.width_px=256 --set sensor.height_px=256
      --set 'stages=["render","enhance","dataset"]' --set train.epochs=4 --set train.device=cpu
      --set train.workers=0 --set train.imgsz=64 --set train.batch=4)
train() { "$SOIG" train campaigns/quickstart.toml --python "$PY" -q "${sets[@]}" "$@"; }
train --out "$work/A" > "$work/A.txt"
train --out "$work/B" --chunk-epochs 2 > "$work/B1.txt"
grep -q "training unfinished" "$work/B1.txt"
train --out "$work/B" --resume > "$work/B2.txt"
train --out "$work/C" --budget 1s > "$work/C1.txt"
train --out "$work/C" --resume --budget 1s > "$work/C2.txt"
train --out "$work/C" --resume > "$work/C3.txt"
"$PY" - "$work" <<'PY'
import csv, hashlib, json, os, sys
from pathlib import Path
work = Path(sys.argv[1])

def rows(run):
    with open(work / run / "train/run/train/results.csv") as f:
        return [{k.strip(): v.strip() for k, v in r.items()} for r in csv.DictReader(f)]

def files(run):
    root = work / run / "train/run/train"
    return sorted(str(p.relative_to(root)) for p in root.rglob("*") if p.is_file())

def training(run):
    return json.loads((work / run / "manifest.json").read_text())["training"]

a = rows("A")
assert [r["epoch"] for r in a] == ["1", "2", "3", "4"], a
lr_cols = [k for k in a[0] if k.startswith("lr/")]
for run, chunks in (("B", [[1, 2], [3, 4]]), ("C", [[1, 1], [2, 2], [3, 4]])):
    r = rows(run)
    assert [x["epoch"] for x in r] == [x["epoch"] for x in a], (run, r)
    # Learning rates as Ultralytics writes them (5 significant digits): equal, not close.
    assert [[x[k] for k in lr_cols] for x in r] == [[x[k] for k in lr_cols] for x in a], run
    assert files(run) == files("A"), (run, files(run), files("A"))
    t = training(run)
    assert t["finished"] is True and t["epochs_completed"] == 4, t
    assert [c["epochs"] for c in t["chunks"]] == chunks, t["chunks"]
    assert os.path.isfile(work / run / "train/model.onnx")
assert [c["epochs"] for c in training("A")["chunks"]] == [[1, 4]]
same = {run: hashlib.sha256((work / run / "train/model.onnx").read_bytes()).hexdigest()
        == hashlib.sha256((work / "A/train/model.onnx").read_bytes()).hexdigest() for run in "BC"}
print("train-resume-test: epochs, learning rates, files and chunk records agree;",
      "ONNX identical to the whole run:", same)
PY
