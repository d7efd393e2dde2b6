#!/usr/bin/env bash
# One GPU loan, one command (issue 32; models/README.md, "The training relay"): on the lent
# machine, inside one 10-minute command, train the next stage of models/queue.toml and leave in
# $OUT/<model>/stage<N>/ exactly the files to commit, which `python3 scripts/relay.py adopt`
# takes into models/ here. Needs what scripts/relay-carry.sh puts in .carry/ (the stripped
# soig and the training wheels the machine lacks; torch is there). Extra arguments go to
# `relay.py stage` (e.g. --model fixed-original). $RELAY_CARRY, $RELAY_QUEUE and $RELAY_PYTHON
# override .carry, models/queue.toml and python3 (scripts/relay-test.sh runs this on CPU).
set -euo pipefail
cd "$(dirname "$0")/.."
: "${OUT:?gpu-session: \$OUT is not set (run this on the lent machine, through the device tool)}"
carry=${RELAY_CARRY:-.carry}
[ -x "$carry/soig" ] || { echo "gpu-session: no $carry/soig: run scripts/relay-carry.sh here and carry $carry" >&2; exit 1; }
echo "gpu-session: $(nproc) cores; $(nvidia-smi -L 2>/dev/null || echo 'no nvidia-smi')"
if compgen -G "$carry/whl/*.whl" > /dev/null; then
  python3 -m pip install -q --no-index --no-deps --target /tmp/relay-site "$carry"/whl/*.whl
  export PYTHONPATH=/tmp/relay-site${PYTHONPATH:+:$PYTHONPATH}
fi
python3 scripts/relay.py --queue "${RELAY_QUEUE:-models/queue.toml}" stage --soig "$carry/soig" \
  --python "${RELAY_PYTHON:-python3}" --out "$OUT" --monitor "$@"
