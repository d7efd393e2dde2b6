#!/usr/bin/env bash
# The Python package's tests (issue #35): build the `soig` command the tests compare against,
# install the package with the README's command into a virtual environment, and run pytest.
# PYTHON=/path/to/python3 tests in that interpreter's environment instead of .venv-py/ (e.g.
# .venv-train's, which has torch for the DataLoader test); arguments go to pytest.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --locked
if [ -z "${PYTHON:-}" ]; then
  [ -x .venv-py/bin/python3 ] || python3 -m venv .venv-py
  PYTHON=.venv-py/bin/python3
fi
case $PYTHON in /*) ;; *) PYTHON=$PWD/$PYTHON ;; esac
"$PYTHON" -m pip install --quiet --disable-pip-version-check '.[test]'
# Run from the tests' folder, so `import soig` is the installed package, not the source tree.
cd soig-py/tests
"$PYTHON" -m pytest -q "$@"
