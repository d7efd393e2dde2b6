#!/usr/bin/env python3
"""The training relay: models that grow with every short GPU loan (issue 32, models/README.md).

`models/queue.toml` lists the models in the order they are trained, each with its dataset
campaign, its committed weights and how many epochs and stages are done. A loan runs one
stage of the first model not yet at its target; the files the stage leaves are adopted here,
where the next loan starts from them.

  relay.py next                     the model the next stage trains
  relay.py stage --out DIR          (on the lent machine) render the dataset, train the next
                                    stage from the committed weights, leave in DIR/NAME/stageN/
                                    exactly the files to commit
  relay.py adopt DIR/NAME/stageN    (here) check those files and take them into models/,
                                    advancing the queue

Standard library only (Python 3.11: tomllib), so it runs on the GPU machine without installs.
"""
import argparse
import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
# What `adopt` files under the model's records folder, besides the weights and the ONNX.
RECORDS = ("stage.json", "summary.json", "results.csv", "soig-train.txt", "manifest-summary.json")
OPTIONAL_RECORDS = ("gpu-dmon.txt",)
# Fields `adopt` rewrites in the queue entry; the rest is the lead's to edit.
PROGRESS = ("stages_done", "epochs_done", "weights_sha256", "onnx_sha256")


class RelayError(Exception):
    pass


def cpu_times() -> tuple[int, int] | None:
    """(busy, total) jiffies of all CPUs from /proc/stat; None where there is none."""
    try:
        fields = [int(x) for x in Path("/proc/stat").read_text().split("\n")[0].split()[1:]]
    except (OSError, ValueError):
        return None
    idle = fields[3] + (fields[4] if len(fields) > 4 else 0)  # idle + iowait
    return sum(fields) - idle, sum(fields)


class CpuSampler:
    """The machines' CPU busy share every `period` s while a stage trains: with the GPU's
    utilisation (gpu-dmon.txt) it says which of the two bounds an epoch (the first loan's GPU was
    30% busy; issue 47)."""

    def __init__(self, period: float = 5.0):
        import threading
        self.period, self.shares, self.stop = period, [], threading.Event()
        self.thread = threading.Thread(target=self.run, daemon=True)

    def run(self):
        last = cpu_times()
        while last is not None and not self.stop.wait(self.period):
            now = cpu_times()
            if now is None or now[1] == last[1]:
                continue
            self.shares.append(round((now[0] - last[0]) / (now[1] - last[1]), 3))
            last = now

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.stop.set()
        self.thread.join()


def sha256(path: Path) -> str:
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


def load_queue(path: Path) -> list[dict]:
    try:
        queue = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise RelayError(f"{path}: no such queue")
    except tomllib.TOMLDecodeError as e:
        raise RelayError(f"{path}: {e}")
    models = queue.get("model")
    if not isinstance(models, list) or not models:
        raise RelayError(f"{path}: no [[model]] entries")
    need = {"name": str, "campaign": str, "weights": str, "onnx": str, "records": str,
            "epochs_target": int, "stages_done": int, "epochs_done": int,
            "weights_sha256": str, "onnx_sha256": str}
    for i, m in enumerate(models, 1):
        for field, kind in need.items():
            if not isinstance(m.get(field), kind):
                raise RelayError(f"{path}: [[model]] number {i} ({m.get('name', 'unnamed')}): "
                                 f"field `{field}` missing or not a {kind.__name__}")
        stage = m.get("stage", {})
        if ("time_hours" in stage) == ("epochs" in stage):
            raise RelayError(f"{path}: model {m['name']}: [model.stage] needs one of "
                             "`time_hours` (a stage as long as fits) or `epochs`")
        if not all(isinstance(s, str) and "=" in s for s in stage.get("set", [])):
            raise RelayError(f"{path}: model {m['name']}: stage.set holds `key=value` strings")
    return models


def entry(models: list[dict], name: str | None, path: Path) -> dict:
    """The named entry, or the first one short of its target."""
    if name is not None:
        for m in models:
            if m["name"] == name:
                return m
        raise RelayError(f"{path}: no model named {name!r}")
    for m in models:
        if m["epochs_done"] < m["epochs_target"]:
            return m
    raise RelayError(f"{path}: every model has reached its epochs_target; nothing to train")


def resolve(root: Path, p: str) -> Path:
    return (root / p).resolve()


def stage(a) -> None:
    queue_path = Path(a.queue).resolve()
    root = Path(a.root).resolve()
    m = entry(load_queue(queue_path), a.model, queue_path)
    n = m["stages_done"] + 1
    campaign = resolve(root, m["campaign"])
    sets = list(m.get("stage", {}).get("set", []))
    st = m["stage"]
    if "time_hours" in st:
        sets.append(f"train.time_hours={st['time_hours']}")
    else:
        sets.append(f"train.epochs={st['epochs']}")
    start = None
    if m["stages_done"] > 0 or m["weights_sha256"]:
        # A later stage trains on from the committed weights, and only from those; so does a
        # first stage whose queue entry names starting weights (a model trained before the relay).
        weights = resolve(root, m["weights"])
        if not weights.is_file():
            raise RelayError(f"{queue_path}: model {m['name']}: weights {weights} not found")
        found = sha256(weights)
        if found != m["weights_sha256"]:
            raise RelayError(f"{weights}: sha256 {found}, the queue says {m['weights_sha256']}")
        start = {"weights": m["weights"], "sha256": found}
        sets.append(f"train.model={os.path.relpath(weights, campaign.parent)}")
    work = Path(a.work).resolve()
    out = Path(a.out).resolve() / m["name"] / f"stage{n}"
    out.mkdir(parents=True, exist_ok=True)
    cmd = [a.soig, "train", str(campaign), "--out", str(work)]
    if a.python:
        cmd += ["--python", a.python]
    for s in sets:
        cmd += ["--set", s]
    print("relay: model", m["name"], "stage", n, ":", " ".join(cmd), flush=True)
    t0 = time.time()
    # Where an epoch goes: the GPU's utilisation and memory every 5 s, beside soig's log.
    monitor = None
    if a.monitor and shutil.which("nvidia-smi"):
        monitor = subprocess.Popen(["nvidia-smi", "dmon", "-s", "um", "-d", "5"],
                                   stdout=open(out / "gpu-dmon.txt", "w"), stderr=subprocess.STDOUT)
    try:
        with open(out / "soig-train.txt", "w") as log, CpuSampler() as cpu:
            done = subprocess.run(cmd, stdout=log, stderr=subprocess.STDOUT)
    finally:
        if monitor is not None:
            monitor.terminate()
            monitor.wait()
    wall = round(time.time() - t0, 1)
    if done.returncode != 0:
        sys.stdout.write((out / "soig-train.txt").read_text()[-4000:])
        raise RelayError(f"soig train failed (exit {done.returncode}) after {wall} s; "
                         f"log in {out / 'soig-train.txt'}")
    summary = json.loads((work / "train/run/summary.json").read_text())
    manifest = json.loads((work / "manifest.json").read_text())
    shutil.copyfile(work / "train/model.onnx", out / "model.onnx")
    # best.pt, stripped of its optimizer state by Ultralytics at the end of training: the weights.
    shutil.copyfile(summary["best_pt"], out / "weights.pt")
    shutil.copyfile(summary["results_csv"], out / "results.csv")
    shutil.copyfile(work / "train/run/summary.json", out / "summary.json")
    files = manifest.pop("files", [])
    manifest["files_listed"] = len(files)
    (out / "manifest-summary.json").write_text(json.dumps(manifest, indent=1) + "\n")
    record = {
        "model": m["name"],
        "stage": n,
        "campaign": m["campaign"],
        "set": sets,
        "start": start,
        "epochs": summary["epochs_completed"],
        "epochs_done": m["epochs_done"] + summary["epochs_completed"],
        "best_epoch": summary.get("best_epoch"),
        "epoch_s": [s for c in summary["chunks"] for s in c["epoch_s"]],
        "train_wall_s": summary["train_wall_s"],
        "soig_train_wall_s": wall,
        "cpus": os.cpu_count(),
        "cpu_busy_5s": cpu.shares,
        "test": summary["metrics"]["test"],
        "test_conf0.5_iou0.5": summary["metrics"]["test_conf0.5_iou0.5"],
        "dataset_digest": manifest["digest"],
        "ultralytics": summary["ultralytics"],
        "torch": summary["torch"],
        "weights_sha256": sha256(out / "weights.pt"),
        "onnx_sha256": sha256(out / "model.onnx"),
    }
    (out / "stage.json").write_text(json.dumps(record, indent=1) + "\n")
    for f in sorted(out.iterdir()):
        print(f"relay: {f} {f.stat().st_size} bytes", flush=True)
    print(f"relay: stage {n} of {m['name']}: {record['epochs']} epochs in {wall} s, "
          f"test mAP50-95 {record['test']['mAP50-95']:.3f}; adopt with "
          f"`python3 scripts/relay.py adopt {out.relative_to(Path(a.out).resolve())}` "
          "where the files come back", flush=True)


# A `name = ...` line: a basic ("...") or a literal ('...') TOML string.
NAME_LINE = re.compile(r"""(?m)^name\s*=\s*("(?:[^"\\\n]|\\.)*"|'[^'\n]*')\s*(#.*)?$""")


def block_name(block: str) -> str | None:
    """The name an entry's block gives itself, however the TOML string is written."""
    mt = NAME_LINE.search(block)
    if mt is None:
        return None
    try:
        return tomllib.loads("v = " + mt.group(1))["v"]
    except tomllib.TOMLDecodeError:
        return None


def set_progress(text: str, name: str, values: dict, path: Path) -> str:
    """`text` (the queue) with the progress fields of entry `name` set to `values`, the rest
    of the file (comments, order) as it was; checked by reading it back."""
    blocks = re.split(r"(?m)^(?=\[\[)", text)
    hits = [i for i, b in enumerate(blocks) if block_name(b) == name]
    if len(hits) != 1:
        raise RelayError(f"{path}: found {len(hits)} entries named {name!r}")
    b = blocks[hits[0]]
    for field in PROGRESS:
        v = values[field]
        literal = f'"{v}"' if isinstance(v, str) else str(v)
        b, count = re.subn(rf"(?m)^{field}\s*=\s*[^#\n]*?(\s*#.*)?$",
                           lambda mt: f"{field} = {literal}{mt.group(1) or ''}", b)
        if count != 1:
            raise RelayError(f"{path}: entry {name!r} has {count} `{field}` lines")
    blocks[hits[0]] = b
    new = "".join(blocks)
    try:
        written = [m for m in tomllib.loads(new).get("model", []) if m.get("name") == name]
    except tomllib.TOMLDecodeError as e:
        raise RelayError(f"{path}: the queue would not parse after the update: {e}")
    if len(written) != 1 or any(written[0].get(f) != values[f] for f in PROGRESS):
        raise RelayError(f"{path}: entry {name!r}: the updated queue does not read back as "
                         f"{values}")
    return new


def stage_record(src: Path) -> dict:
    """The stage's stage.json, every field adopt uses checked to be of its kind."""
    path = src / "stage.json"
    try:
        rec = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError, UnicodeDecodeError) as e:
        raise RelayError(f"{path}: {e}")
    if not isinstance(rec, dict):
        raise RelayError(f"{path}: not a JSON object")
    for field in ("weights_sha256", "onnx_sha256"):
        v = rec.get(field)
        if not (isinstance(v, str) and re.fullmatch(r"[0-9a-f]{64}", v)):
            raise RelayError(f"{path}: field `{field}` is not a sha256 ({v!r})")
    for field in ("stage", "epochs", "epochs_done"):
        v = rec.get(field)
        if not isinstance(v, int) or isinstance(v, bool):
            raise RelayError(f"{path}: field `{field}` missing or not an integer ({v!r})")
    test = rec.get("test")
    score = test.get("mAP50-95") if isinstance(test, dict) else None
    if not isinstance(score, (int, float)) or isinstance(score, bool) or not 0 <= score <= 1:
        raise RelayError(f"{path}: field `test` holds no test metrics (`test.mAP50-95` between "
                         f"0 and 1; found {test!r})")
    return rec


def adopt(a) -> None:
    """Check everything (the record, the files and their sha256, the queue as it will be, the
    destinations), then copy each file to a temporary beside its destination and rename them
    all into place, the queue last: a failure before the renames leaves models/ and the
    queue as they were."""
    queue_path = Path(a.queue).resolve()
    root = Path(a.root).resolve()
    src = Path(a.stage_dir)
    rec = stage_record(src)
    models = load_queue(queue_path)
    m = entry(models, rec.get("model"), queue_path)
    n = m["stages_done"] + 1
    if rec["stage"] != n:
        raise RelayError(f"{src}: stage {rec['stage']} of {m['name']}, but the queue's next is "
                         f"stage {n} (adopted already, or trained from other weights)")
    start_sha = (rec.get("start") or {}).get("sha256", "")
    if start_sha != m["weights_sha256"]:
        raise RelayError(f"{src}: trained from weights {start_sha or '(from scratch)'}, but the "
                         f"queue's are {m['weights_sha256'] or '(none)'}")
    for f in RECORDS + ("weights.pt", "model.onnx"):
        if not (src / f).is_file():
            raise RelayError(f"{src}: {f} missing")
    for f, field in (("weights.pt", "weights_sha256"), ("model.onnx", "onnx_sha256")):
        found = sha256(src / f)
        if found != rec[field]:
            raise RelayError(f"{src / f}: sha256 {found}, stage.json says {rec[field]}")
    epochs = rec["epochs"]
    if epochs < 1 or rec["epochs_done"] != m["epochs_done"] + epochs:
        raise RelayError(f"{src / 'stage.json'}: epochs {epochs}, epochs_done "
                         f"{rec['epochs_done']} do not follow the queue's {m['epochs_done']}")
    values = {"stages_done": n, "epochs_done": rec["epochs_done"],
              "weights_sha256": rec["weights_sha256"], "onnx_sha256": rec["onnx_sha256"]}
    queue_text = set_progress(queue_path.read_text(), m["name"], values, queue_path)
    records = resolve(root, m["records"]) / f"stage{n}"
    copies = [(src / f, records / f) for f in RECORDS + OPTIONAL_RECORDS if (src / f).is_file()]
    copies += [(src / "weights.pt", resolve(root, m["weights"])),
               (src / "model.onnx", resolve(root, m["onnx"]))]
    for _, dest in copies:
        if dest.exists() and not dest.is_file():
            raise RelayError(f"{dest}: exists and is not a file; nothing was adopted")
    # Everything is checked; now write: temporaries first, then the renames, the queue last.
    made = sorted({p for _, dest in copies for p in (dest.parent, *dest.parent.parents)
                   if not p.exists()})
    staged = []
    try:
        for d in made:
            d.mkdir(exist_ok=True)
        for f, dest in copies:
            staged.append((temporary(dest), dest))
            copy_synced(f, staged[-1][0])
        staged.append((temporary(queue_path), queue_path))
        with open(staged[-1][0], "x") as q:
            q.write(queue_text)
            q.flush()
            os.fsync(q.fileno())
    except OSError as e:
        for tmp, _ in staged:
            tmp.unlink(missing_ok=True)
        for d in reversed(made):
            try:
                d.rmdir()
            except OSError:
                pass
        raise RelayError(f"cannot copy the stage's files ({e}); nothing was adopted")
    for tmp, dest in staged:
        os.replace(tmp, dest)
    print(f"relay: adopted stage {n} of {m['name']}: {rec['epochs_done']} of "
          f"{m['epochs_target']} epochs, test mAP50-95 {rec['test']['mAP50-95']:.3f}; "
          f"records in {records}")


def temporary(dest: Path) -> Path:
    """A hidden name beside `dest` for the copy that replaces it."""
    return dest.with_name(f".{dest.name}.tmp-{os.getpid()}")


def copy_synced(src: Path, dest: Path) -> None:
    """Copy `src` to the new file `dest`, on the disk before it returns (a full disk fails
    here, not after a rename)."""
    with open(src, "rb") as i, open(dest, "xb") as o:
        shutil.copyfileobj(i, o, 1 << 20)
        o.flush()
        os.fsync(o.fileno())


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--queue", default=str(ROOT / "models/queue.toml"))
    p.add_argument("--root", default=str(ROOT), help="the folder the queue's paths are relative to")
    sub = p.add_subparsers(dest="cmd", required=True)
    sub.add_parser("next", help="print the model the next stage trains")
    s = sub.add_parser("stage", help="train the next stage (on the lent machine)")
    s.add_argument("--out", required=True, help="where the files to commit go ($OUT)")
    s.add_argument("--model", help="this model rather than the queue's next")
    s.add_argument("--soig", default=str(ROOT / "target/release/soig"))
    s.add_argument("--python", help="the Python with Ultralytics (soig train's --python)")
    s.add_argument("--work", default="/tmp/relay-work", help="where the dataset is rendered")
    s.add_argument("--monitor", action="store_true",
                   help="record `nvidia-smi dmon` during the stage (gpu-dmon.txt)")
    d = sub.add_parser("adopt", help="take a stage's files into models/ and advance the queue")
    d.add_argument("stage_dir")
    a = p.parse_args()
    try:
        if a.cmd == "next":
            path = Path(a.queue)
            m = entry(load_queue(path), None, path)
            print(f"{m['name']} stage {m['stages_done'] + 1} "
                  f"({m['epochs_done']} of {m['epochs_target']} epochs done)")
        elif a.cmd == "stage":
            stage(a)
        else:
            adopt(a)
    except RelayError as e:
        sys.exit(f"relay: {e}")


if __name__ == "__main__":
    main()
