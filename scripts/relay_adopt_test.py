#!/usr/bin/env python3
"""`relay.py adopt` checks everything before it copies anything (issue 43): a queue entry named
by a TOML literal string, a stage record without test metrics, a file whose sha256 differs, a
destination that is a folder; each refusal leaves models/ and the queue as they were, byte for
byte, and no temporary file beside them. Standard library only, no Ultralytics: the stage's
files are small stand-ins whose sha256 the record states, as `relay.py stage` writes them.

    python3 scripts/relay_adopt_test.py      (scripts/test.sh runs it)
"""
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

# $RELAY_PY: another relay.py to hold to the same test (an older one, to see it fail).
RELAY = Path(os.environ.get("RELAY_PY", Path(__file__).resolve().parent / "relay.py"))
RECORDS = ("summary.json", "results.csv", "soig-train.txt", "manifest-summary.json")

QUEUE = """# the lead's queue
[[model]]
name = {name}
campaign = "campaigns/quickstart.toml"
weights = "models/tiny.pt"
onnx = "models/tiny.onnx"
records = "models/training/tiny"
epochs_target = 4
stage = {{ epochs = 2 }}
stages_done = 0   # progress, rewritten by adopt
epochs_done = 0
weights_sha256 = ""
onnx_sha256 = ""
"""


def sha(b: bytes) -> str:
    return hashlib.sha256(b).hexdigest()


def tree(root: Path) -> dict:
    """Every file under `root` with its bytes, every folder as None."""
    out = {}
    for p in sorted(root.rglob("*")):
        out[str(p.relative_to(root))] = p.read_bytes() if p.is_file() else None
    return out


class Adopt(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.root = Path(self.tmp.name) / "repo"
        (self.root / "models").mkdir(parents=True)
        # Weights committed before: adopt must replace them only when everything holds.
        (self.root / "models/tiny.pt").write_bytes(b"old weights")
        (self.root / "models/tiny.onnx").write_bytes(b"old onnx")
        self.queue = self.root / "models/queue.toml"
        self.queue.write_text(QUEUE.format(name='"tiny"'))
        self.stage = Path(self.tmp.name) / "out/tiny/stage1"
        self.stage.mkdir(parents=True)
        weights, onnx = b"new weights", b"new onnx"
        (self.stage / "weights.pt").write_bytes(weights)
        (self.stage / "model.onnx").write_bytes(onnx)
        for f in RECORDS:
            (self.stage / f).write_text(f"{f}\n")
        self.record = {
            "model": "tiny", "stage": 1, "start": None, "epochs": 2, "epochs_done": 2,
            "test": {"mAP50-95": 0.5, "mAP50": 0.7},
            "weights_sha256": sha(weights), "onnx_sha256": sha(onnx),
        }
        self.write_record()

    def tearDown(self):
        self.tmp.cleanup()

    def write_record(self):
        (self.stage / "stage.json").write_text(json.dumps(self.record, indent=1) + "\n")

    def adopt(self):
        return subprocess.run(
            [sys.executable, str(RELAY), "--queue", str(self.queue), "--root", str(self.root),
             "adopt", str(self.stage)],
            capture_output=True, text=True, timeout=60)

    def refused(self, *words):
        """adopt fails naming `words`, and the repository is byte for byte as it was."""
        before = tree(self.root)
        done = self.adopt()
        self.assertNotEqual(done.returncode, 0, done.stdout)
        for w in words:
            self.assertIn(w, done.stderr)
        self.assertNotIn("Traceback", done.stderr)
        self.assertEqual(tree(self.root), before)

    def test_adopts_an_entry_named_by_a_literal_string(self):
        self.queue.write_text(QUEUE.format(name="'tiny'"))
        done = self.adopt()
        self.assertEqual(done.returncode, 0, done.stderr)
        self.assertEqual((self.root / "models/tiny.pt").read_bytes(), b"new weights")
        self.assertEqual((self.root / "models/tiny.onnx").read_bytes(), b"new onnx")
        text = self.queue.read_text()
        self.assertIn("name = 'tiny'", text)
        self.assertIn("stages_done = 1   # progress, rewritten by adopt", text)
        self.assertIn(f'weights_sha256 = "{self.record["weights_sha256"]}"', text)
        self.assertTrue(text.startswith("# the lead's queue"))
        for f in RECORDS + ("stage.json",):
            self.assertTrue((self.root / "models/training/tiny/stage1" / f).is_file(), f)
        hidden = [p for p in self.root.rglob(".*")]
        self.assertEqual(hidden, [], "temporary files left")
        # Adopted once: a second adopt of the same stage is refused and changes nothing.
        self.refused("stage 1 of tiny", "queue's next is stage 2")

    def test_a_record_without_test_metrics(self):
        del self.record["test"]
        self.write_record()
        self.refused("stage.json", "test metrics")

    def test_a_record_with_test_metrics_of_another_kind(self):
        self.record["test"] = {"mAP50-95": "high"}
        self.write_record()
        self.refused("stage.json", "test metrics")

    def test_weights_whose_sha256_differs(self):
        (self.stage / "weights.pt").write_bytes(b"other weights")
        self.refused("weights.pt", "sha256")

    def test_a_destination_that_is_a_folder(self):
        (self.root / "models/tiny.onnx").unlink()
        (self.root / "models/tiny.onnx").mkdir()
        self.refused("tiny.onnx", "not a file")

    def test_a_queue_whose_entry_the_update_cannot_find(self):
        # Two entries of one name: load_queue takes the first, the update cannot tell.
        self.queue.write_text(QUEUE.format(name='"tiny"') + QUEUE.format(name="'tiny'")[18:])
        self.refused("2 entries named 'tiny'")

    def test_a_missing_record_file(self):
        (self.stage / "results.csv").unlink()
        self.refused("results.csv missing")

    def test_a_records_folder_that_cannot_be_made(self):
        # The records folder would lie under a file: the copy fails after every check passed.
        self.queue.write_text(QUEUE.format(name='"tiny"').replace(
            'records = "models/training/tiny"', 'records = "models/tiny.pt/training"'))
        self.refused("nothing was adopted")

    @unittest.skipIf(os.geteuid() == 0, "root writes into a read-only folder")
    def test_a_failed_copy_leaves_models_as_they_were(self):
        (self.root / "models").chmod(0o555)
        try:
            self.refused("nothing was adopted")
        finally:
            (self.root / "models").chmod(0o755)


if __name__ == "__main__":
    unittest.main(verbosity=2)
