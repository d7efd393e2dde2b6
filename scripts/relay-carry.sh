#!/usr/bin/env bash
# Prepares, on this machine, what a GPU loan carries for scripts/gpu-session.sh: .carry/soig
# (the release binary stripped: 8 MB rather than 61, under the 64 MiB that travels) and
# .carry/whl/ (Ultralytics and the small wheels the lent machine lacks, for its Python 3.12;
# torch and onnxruntime are there, polars is not needed: python/train.py trains without plots).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --locked
mkdir -p .carry/whl
strip -o .carry/soig target/release/soig
python3 -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 -d .carry/whl \
  ultralytics==8.4.190 ultralytics-thop ultralytics-platform onnxslim
du -sh .carry
