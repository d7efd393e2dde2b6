#!/usr/bin/env bash
# The training relay end to end on CPU (issue 32): a queue of one tiny model (12 images of
# 256 px, imgsz 64, 2 epochs a stage, 4 in all) goes queue -> stage -> adopt twice, the second
# stage training on from the first's adopted weights and run by the loan's own command,
# scripts/gpu-session.sh (validation at the end only, as the queue's paper models train, and
# `train.amp`, which a queue may set and which stays off on CPU); a stage adopted twice, a stage whose
# file was changed, and a finished queue are refused. Needs a Python with Ultralytics
# (`bash scripts/setup-train.sh`; $SOIG_TRAIN_PYTHON overrides) and target/release/soig.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${SOIG_TRAIN_PYTHON:-.venv-train/bin/python3}
"$PY" -c "import ultralytics" || { echo "relay-test: no Ultralytics in $PY" >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
Q=$work/queue.toml
# A tiny stage on CPU, for every model of the test's queue.
tiny=$(cat <<'SET'
"images=12", "sensor.width_px=256", "sensor.height_px=256", 'stages=["render","enhance","dataset"]', "train.device=cpu", "train.workers=0", "train.imgsz=64", "train.batch=4"
SET
)
cat > "$Q" <<TOML
# the relay test's queue
[[model]]
name = "tiny"
campaign = "campaigns/quickstart.toml"
weights = "$work/models/tiny.pt"
onnx = "$work/models/tiny.onnx"
records = "$work/models/training/tiny"
epochs_target = 4
stage = { epochs = 2, set = [$tiny, "train.amp=true", "train.val=false"] }
stages_done = 0   # progress, rewritten by adopt
epochs_done = 0
weights_sha256 = ""
onnx_sha256 = ""
TOML
relay() { python3 scripts/relay.py --queue "$Q" "$@"; }
expect_fail() { # a refusal: non-zero exit and a message naming what is wrong
  local pattern=$1; shift
  if relay "$@" > "$work/refused.txt" 2>&1; then echo "relay-test: accepted: $*" >&2; exit 1; fi
  grep -q "$pattern" "$work/refused.txt" || { cat "$work/refused.txt" >&2; exit 1; }
}
[ "$(relay next)" = "tiny stage 1 (0 of 4 epochs done)" ]
relay stage --out "$work/out1" --python "$PY" --work "$work/w1" > "$work/stage1.txt"
relay adopt "$work/out1/tiny/stage1"
[ "$(relay next)" = "tiny stage 2 (2 of 4 epochs done)" ]
expect_fail "the queue's next is stage 2" adopt "$work/out1/tiny/stage1"
cp "$work/models/tiny.pt" "$work/stage1.pt"
mkdir "$work/carry" && cp target/release/soig "$work/carry/soig"
OUT="$work/out2" RELAY_CARRY="$work/carry" RELAY_QUEUE="$Q" RELAY_PYTHON="$PY" \
  bash scripts/gpu-session.sh --work "$work/w2" > "$work/stage2.txt"
cp -r "$work/out2" "$work/bad"
printf 'x' >> "$work/bad/tiny/stage2/model.onnx"
expect_fail "model.onnx: sha256" adopt "$work/bad/tiny/stage2"
relay adopt "$work/out2/tiny/stage2"
expect_fail "nothing to train" next
# A model trained before the relay joins it: its entry names starting weights, which its first
# stage trains on from (and only from: a changed file is refused).
cp "$work/models/tiny.pt" "$work/models/tiny-b.pt"
start_b=$(sha256sum "$work/models/tiny-b.pt" | cut -d' ' -f1)
cat >> "$Q" <<TOML

[[model]]
name = "tiny-b"
campaign = "campaigns/quickstart.toml"
weights = "$work/models/tiny-b.pt"
onnx = "$work/models/tiny-b.onnx"
records = "$work/models/training/tiny-b"
epochs_target = 1
stage = { epochs = 1, set = [$tiny, "train.val=false"] }
stages_done = 0
epochs_done = 0
weights_sha256 = "$start_b"
onnx_sha256 = ""
TOML
printf 'x' >> "$work/models/tiny-b.pt"
expect_fail "tiny-b.pt: sha256" stage --out "$work/outb" --python "$PY" --work "$work/wb"
cp "$work/models/tiny.pt" "$work/models/tiny-b.pt"
relay stage --out "$work/outb" --python "$PY" --work "$work/wb" > "$work/stageb.txt"
python3 -c 'import json,sys; s=json.load(open(sys.argv[1])); assert s["start"]["sha256"] == sys.argv[2] and s["stage"] == 1, s' \
  "$work/outb/tiny-b/stage1/stage.json" "$start_b"
relay adopt "$work/outb/tiny-b/stage1"
"$PY" - "$work" <<'PY'
import hashlib, json, sys, tomllib
from pathlib import Path
w = Path(sys.argv[1])
sha = lambda p: hashlib.sha256(p.read_bytes()).hexdigest()
text = (w / "queue.toml").read_text()
q = tomllib.loads(text)["model"][0]
assert text.startswith("# the relay test's queue") and "# progress, rewritten by adopt" in text, text
assert (q["stages_done"], q["epochs_done"]) == (2, 4), q
assert q["weights_sha256"] == sha(w / "models/tiny.pt") and q["onnx_sha256"] == sha(w / "models/tiny.onnx"), q
s1 = json.loads((w / "models/training/tiny/stage1/stage.json").read_text())
s2 = json.loads((w / "models/training/tiny/stage2/stage.json").read_text())
assert s1["start"] is None and s1["epochs"] == 2 and s1["epochs_done"] == 2, s1
# Stage 2 trained on from stage 1's adopted weights, and moved them.
assert s2["start"]["sha256"] == s1["weights_sha256"] == sha(w / "stage1.pt"), (s1, s2)
assert s2["epochs"] == 2 and s2["epochs_done"] == 4 and s2["weights_sha256"] != s1["weights_sha256"], s2
m2 = json.loads((w / "models/training/tiny/stage2/manifest-summary.json").read_text())
assert m2["training"]["start_weights"]["sha256"] == s1["weights_sha256"], m2["training"]
assert m2["training"]["finished"] is True and "files" not in m2, m2.keys()
for n in (1, 2):
    summary = json.loads((w / f"models/training/tiny/stage{n}/summary.json").read_text())
    args = summary["args"]
    assert args["amp"] is True and args["no_val"] is True and args["epochs"] == 2, args
    assert summary["amp"] is False, "AMP asked for, but it must stay off on CPU"
    d = w / f"models/training/tiny/stage{n}"
    assert sorted(p.name for p in d.iterdir()) == sorted(
        ["stage.json", "summary.json", "results.csv", "soig-train.txt", "manifest-summary.json"]), n
print("relay-test: queue -> stage -> adopt twice; stage 2 trained on from stage 1's weights;",
      "refusals of a re-adopt, a changed file and a finished queue; a first stage from given",
      "weights; test mAP50-95",
      s1["test"]["mAP50-95"], s2["test"]["mAP50-95"])
PY
