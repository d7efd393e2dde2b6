#!/usr/bin/env bash
# Installs what soig needs besides the Rust toolchain: ONNX Runtime's shared library, from the
# PyPI `onnxruntime` wheel, into the project's .venv (where soig finds it), and the readers of
# soig's exports (pycocotools, astropy-regions) that the tests use. Idempotent.
# Training (`soig train`, issue #5) will add Ultralytics here.
set -euo pipefail
cd "$(dirname "$0")/.."
ORT_VERSION=1.32.0
if [ ! -x .venv/bin/python3 ]; then
  python3 -m venv .venv
fi
# `python3 -m pip`, not .venv/bin/pip: a .venv copied from another checkout keeps that one's
# path in its pip script, and would install there.
if ! .venv/bin/python3 -c "import onnxruntime, sys; sys.exit(onnxruntime.__version__ != '$ORT_VERSION')" 2>/dev/null; then
  echo "setup: installing onnxruntime $ORT_VERSION into .venv" >&2
  .venv/bin/python3 -m pip install --quiet --disable-pip-version-check "onnxruntime==$ORT_VERSION"
fi
# The readers tests/export.rs checks soig's COCO and DS9 exports with.
PYCOCOTOOLS_VERSION=2.0.11
REGIONS_VERSION=0.12
if ! .venv/bin/python3 -c "
import sys
from importlib.metadata import version
sys.exit(version('pycocotools') != '$PYCOCOTOOLS_VERSION' or version('regions') != '$REGIONS_VERSION')" 2>/dev/null; then
  echo "setup: installing pycocotools $PYCOCOTOOLS_VERSION and regions $REGIONS_VERSION into .venv" >&2
  .venv/bin/python3 -m pip install --quiet --disable-pip-version-check \
    "pycocotools==$PYCOCOTOOLS_VERSION" "regions==$REGIONS_VERSION"
fi
# astropy, which reads soig's FITS in a test as an astronomer would (tests/fits_astropy.rs).
ASTROPY_VERSION=8.0.2
if ! .venv/bin/python3 -c "import astropy, sys; sys.exit(astropy.__version__ != '$ASTROPY_VERSION')" 2>/dev/null; then
  echo "setup: installing astropy $ASTROPY_VERSION into .venv" >&2
  .venv/bin/python3 -m pip install --quiet --disable-pip-version-check "astropy==$ASTROPY_VERSION"
fi
