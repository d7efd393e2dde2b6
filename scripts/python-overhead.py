"""Per-image cost of soig from Python against the `soig` command (README "From Python").

Usage: RAYON_NUM_THREADS=1 .venv-py/bin/python scripts/python-overhead.py [IMAGES] [ROUNDS]
Rounds alternate: the CLI's `soig run` (one thread), `soig.run` from Python (the same
campaign, one thread), and `campaign.image(i)` for every i (one thread; no files written);
then 2 Python threads sharing the images. Prints medians of wall and CPU seconds per image.
"""

import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import soig

REPO = Path(__file__).resolve().parents[1]
N = int(sys.argv[1]) if len(sys.argv) > 1 else 30
ROUNDS = int(sys.argv[2]) if len(sys.argv) > 2 else 3
assert os.environ.get("RAYON_NUM_THREADS") == "1", "run with RAYON_NUM_THREADS=1"
CAMPAIGN = REPO / "campaigns" / "quickstart.toml"
SETS = [("images", N, str(N)), ("stages", ["render", "enhance", "dataset"],
                                 '["render", "enhance", "dataset"]')]


def campaign():
    c = soig.Campaign(CAMPAIGN)
    for k, v, _ in SETS:
        c.set(k, v)
    return c


def children_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def cli(out):
    c0, t0 = children_cpu(), time.perf_counter()
    subprocess.run([str(REPO / "target/release/soig"), "run", str(CAMPAIGN), "--quiet",
                    "--out", str(out), *[f"--set={k}={t}" for k, _, t in SETS]],
                   check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t0, children_cpu() - c0


def timed(f):
    c0, t0 = time.process_time(), time.perf_counter()
    f()
    return time.perf_counter() - t0, time.process_time() - c0


rows = {"cli run": [], "soig.run": [], "image(i)": [], "image(i), 2 threads": []}
with tempfile.TemporaryDirectory() as tmp:
    for r in range(ROUNDS):
        rows["cli run"].append(cli(Path(tmp) / f"cli{r}"))
        c = campaign()
        rows["soig.run"].append(timed(lambda: soig.run(c, out=Path(tmp) / f"py{r}")))
        c = campaign()
        c.image(0)  # the inputs (orbits, star field) are built once, as a run does
        rows["image(i)"].append(timed(lambda: [c.image(i) for i in range(N)]))
        with ThreadPoolExecutor(2) as pool:
            rows["image(i), 2 threads"].append(
                timed(lambda: list(pool.map(c.image, range(N)))))
print(f"{N} images x {ROUNDS} rounds, quickstart 1024 px; {os.uname().nodename}")
print(os.popen("uptime").read().strip())
for name, v in rows.items():
    wall = statistics.median(w for w, _ in v) / N * 1e3
    cpus = sorted(c / N * 1e3 for _, c in v)
    print(f"{name:22s} wall {wall:6.1f} ms/image   cpu {statistics.median(cpus):5.1f} ms/image"
          f" (rounds {cpus[0]:.1f}-{cpus[-1]:.1f})")
