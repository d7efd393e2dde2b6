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
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


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


def set_progress(text: str, name: str, values: dict, path: Path) -> str:
    """`text` (the queue) with the progress fields of entry `name` set to `values`, the rest
    of the file (comments, order) as it was."""
    blocks = re.split(r"(?m)^(?=\[\[)", text)
    hits = [i for i, b in enumerate(blocks)
            if re.search(rf'(?m)^name\s*=\s*"{re.escape(name)}"\s*(#.*)?$', b)]
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
    return "".join(blocks)


def adopt(a) -> None:
    queue_path = Path(a.queue).resolve()
    root = Path(a.root).resolve()
    src = Path(a.stage_dir)
    try:
        rec = json.loads((src / "stage.json").read_text())
    except (OSError, json.JSONDecodeError) as e:
        raise RelayError(f"{src / 'stage.json'}: {e}")
    models = load_queue(queue_path)
    m = entry(models, rec.get("model"), queue_path)
    n = m["stages_done"] + 1
    if rec.get("stage") != n:
        raise RelayError(f"{src}: stage {rec.get('stage')} of {m['name']}, but the queue's next is "
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
        if found != rec.get(field):
            raise RelayError(f"{src / f}: sha256 {found}, stage.json says {rec.get(field)}")
    epochs = rec.get("epochs")
    if not isinstance(epochs, int) or epochs < 1 or rec.get("epochs_done") != m["epochs_done"] + epochs:
        raise RelayError(f"{src / 'stage.json'}: epochs {epochs}, epochs_done "
                         f"{rec.get('epochs_done')} do not follow the queue's {m['epochs_done']}")
    # Everything is checked; now write, the queue last, so that an interrupted adopt is redone.
    records = resolve(root, m["records"]) / f"stage{n}"
    records.mkdir(parents=True, exist_ok=True)
    for f in RECORDS + OPTIONAL_RECORDS:
        if (src / f).is_file():
            shutil.copyfile(src / f, records / f)
    for f, dest in (("weights.pt", m["weights"]), ("model.onnx", m["onnx"])):
        d = resolve(root, dest)
        d.parent.mkdir(parents=True, exist_ok=True)
        tmp = d.with_name(d.name + ".partial")
        shutil.copyfile(src / f, tmp)
        os.replace(tmp, d)
    values = {"stages_done": n, "epochs_done": rec["epochs_done"],
              "weights_sha256": rec["weights_sha256"], "onnx_sha256": rec["onnx_sha256"]}
    text = set_progress(queue_path.read_text(), m["name"], values, queue_path)
    tmp = queue_path.with_name(queue_path.name + ".partial")
    tmp.write_text(text)
    os.replace(tmp, queue_path)
    print(f"relay: adopted stage {n} of {m['name']}: {rec['epochs_done']} of "
          f"{m['epochs_target']} epochs, test mAP50-95 {rec['test']['mAP50-95']:.3f}; "
          f"records in {records}")


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
