"""Shared fixtures: the repository, the `soig` command built from it, and one 20-image
campaign run by that command (the reference the Python side must reproduce)."""

import os
import subprocess
from pathlib import Path

import pytest

import soig

REPO = Path(__file__).resolve().parents[2]
# 20 fixed-pointing images of the quickstart (1024 px, the paper's sensor), stopping at the
# dataset: the detect stage's YOLO needs ONNX Runtime, which this package does not ship.
# Each as (key, Python value for Campaign.set, the same as the CLI's --set text).
OVERRIDES = [
    ("images", 20, "20"),
    ("stages", ["render", "enhance", "dataset"], '["render", "enhance", "dataset"]'),
]


def soig_command() -> Path:
    """The CLI of this checkout (scripts/python-test.sh builds it first)."""
    exe = Path(os.environ.get("SOIG_BIN", REPO / "target" / "release" / "soig"))
    if not exe.is_file():
        pytest.fail(f"{exe}: no soig command; run `cargo build --release --locked` first")
    return exe


def cli_sets() -> list:
    return [f"--set={k}={text}" for k, _, text in OVERRIDES]


def small_campaign() -> soig.Campaign:
    c = soig.Campaign(REPO / "campaigns" / "quickstart.toml")
    for k, v, _ in OVERRIDES:
        c.set(k, v)
    return c


@pytest.fixture(scope="session")
def cli_run(tmp_path_factory) -> Path:
    """The 20-image campaign written by `soig run --set ...`."""
    out = tmp_path_factory.mktemp("cli") / "run"
    subprocess.run(
        [str(soig_command()), "run", str(REPO / "campaigns" / "quickstart.toml"), "--quiet",
         "--out", str(out), *cli_sets()],
        check=True,
    )
    return out
