#!/usr/bin/env bash
# Installs the training side of soig (`soig train`): Ultralytics, pinned, with torch, into
# .venv-train/. Large: PyPI's torch wheel for Linux carries CUDA (about 3 GB download, 6 GB
# installed), and it runs on CPU too. Idempotent. On a machine that already has torch, use
# `pip install --no-deps ultralytics==$ULTRALYTICS polars polars-runtime-32` there instead.
set -euo pipefail
cd "$(dirname "$0")/.."
ULTRALYTICS=8.4.190
if [ ! -x .venv-train/bin/python3 ]; then
  python3 -m venv .venv-train
fi
if ! .venv-train/bin/python3 -c "import ultralytics, sys; sys.exit(ultralytics.__version__ != '$ULTRALYTICS')" 2>/dev/null; then
  echo "setup-train: installing ultralytics $ULTRALYTICS (and torch) into .venv-train" >&2
  .venv-train/bin/pip install --quiet --disable-pip-version-check "ultralytics==$ULTRALYTICS" onnx onnxslim "onnxruntime==1.32.0"
fi
