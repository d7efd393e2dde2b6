#!/usr/bin/env bash
# The default campaign on a fresh clone: set-up (idempotent), build, run the quickstart.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cargo run --release --locked -- run campaigns/quickstart.toml "$@"
