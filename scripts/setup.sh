#!/usr/bin/env bash
# Installs what soig needs besides the Rust toolchain: ONNX Runtime's shared library, from the
# PyPI `onnxruntime` wheel, into the project's .venv (where soig finds it). Idempotent.
# Training (`soig train`, issue #5) will add Ultralytics here.
set -euo pipefail
cd "$(dirname "$0")/.."
ORT_VERSION=1.32.0
if [ ! -x .venv/bin/python3 ]; then
  python3 -m venv .venv
fi
if ! .venv/bin/python3 -c "import onnxruntime, sys; sys.exit(onnxruntime.__version__ != '$ORT_VERSION')" 2>/dev/null; then
  echo "setup: installing onnxruntime $ORT_VERSION into .venv" >&2
  .venv/bin/pip install --quiet --disable-pip-version-check "onnxruntime==$ORT_VERSION"
fi
# astropy, which reads soig's FITS in a test as an astronomer would (tests/fits_astropy.rs).
ASTROPY_VERSION=8.0.2
if ! .venv/bin/python3 -c "import astropy, sys; sys.exit(astropy.__version__ != '$ASTROPY_VERSION')" 2>/dev/null; then
  echo "setup: installing astropy $ASTROPY_VERSION into .venv" >&2
  .venv/bin/python3 -m pip install --quiet --disable-pip-version-check "astropy==$ASTROPY_VERSION"
fi
