#!/usr/bin/env bash
# The test command: set-up (idempotent), clippy (warnings are errors), then every test. ONNX
# Runtime and the export readers are required here, so the detector and export tests can never
# pass by skipping.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
# Lints first, every warning an error, on every target (tests, benches and examples too):
# clippy.toml lets only the store (src/store/) create, replace or delete files, so a writer that
# bypasses the output-safety rules fails here; tests, benches and examples write their fixtures
# directly and say so with an `allow` at their top.
cargo clippy --workspace --all-targets --release --locked -- -D warnings
# The training relay's adopt, checked before it copies (standard library only, seconds).
python3 scripts/relay_adopt_test.py
# The faint limit's smooth fit against scipy's figures (standard library only, seconds).
python3 scripts/faint_limit_fit_test.py
# --release: the tests reuse the dependencies the quickstart's release build compiled (the test
# profile would build every one of them again).
SOIG_REQUIRE_ONNXRUNTIME=1 SOIG_REQUIRE_EXPORT_READERS=1 cargo test --release --locked "$@"
