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
  # About 10 GB at the peak (the 3 GB of wheels unpacked into 6 GB); say so up front rather
  # than fail half-way with ENOSPC (stop 70's CI did, on a machine left with too little).
  free_kb=$(df -Pk . "${TMPDIR:-/tmp}" | awk 'NR>1 {print $4}' | sort -n | head -1)
  if [ "${free_kb:-0}" -lt $((10 * 1024 * 1024)) ]; then
    echo "setup-train: needs about 10 GB free here and in ${TMPDIR:-/tmp}; has $((free_kb / 1024)) MB" >&2
    exit 1
  fi
  echo "setup-train: installing ultralytics $ULTRALYTICS (and torch) into .venv-train" >&2
  # --no-cache-dir: pip's cache would keep a second copy of the 3 GB of wheels.
  .venv-train/bin/pip install --quiet --disable-pip-version-check --no-cache-dir \
    "ultralytics==$ULTRALYTICS" onnx onnxslim "onnxruntime==1.32.0"
fi
