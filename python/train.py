#!/usr/bin/env python3
"""Train a YOLOv8 debris detector on a soig dataset, export ONNX, write summary.json.

Trains in chunks when given --budget-s or --chunk-epochs: each chunk ends at an epoch boundary
before its budget (the next epoch estimated by the longest one of the chunk so far) or its count and keeps a resumable
checkpoint, weights/resume.pt (Ultralytics' last.pt with its optimizer state: the end of
training strips the optimizer from last.pt and best.pt, so the copy is taken as each epoch is
saved). --resume continues from it with the checkpoint's own schedule (epochs, learning rates,
seed). Only the chunk that completes the schedule validates on the test split and exports ONNX;
summary.json says `finished` and, for every chunk, the epochs it ran.

Runs fully offline (no downloads): sets YOLO_OFFLINE, a private YOLO_CONFIG_DIR under --out
with a bundled font as Arial.ttf, and trains with amp=False unless --amp, which skips
Ultralytics' AMP check (it downloads weights to compare with) and uses AMP on CUDA only.

--channels 1 trains on the grey frames as they are (issue #47: a third of the bytes every
loader worker, the collation and the GPU feed move) and gives the same model as 3 channels of
replicated grey: a 3-channel starting checkpoint's first convolution is summed over its input
channels (exact on grey input), and Ultralytics' HSV augmentation, which skips 1-channel images,
applies its value gain (what it does to a grey BGR pixel: hue and saturation leave grey as it
is).
"""
import argparse
import csv
import hashlib
import importlib.util
import json
import os
import re
import shutil
import sys
import time
from pathlib import Path


def parse_args():
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--data", required=True, help="Ultralytics data.yaml written by soig")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--model", default="yolov8n.yaml", help="model yaml (from scratch) or .pt")
    p.add_argument("--epochs", type=int, default=200)
    p.add_argument("--batch", type=int, default=16)
    p.add_argument("--imgsz", type=int, default=640)
    p.add_argument("--optimizer", default="auto")
    p.add_argument("--device", default="auto", help="cpu, 0 (first GPU) or auto")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--workers", type=int, default=8)
    p.add_argument("--patience", type=int, default=100)
    p.add_argument("--time-hours", type=float, default=None, help="Ultralytics `time` limit in hours")
    p.add_argument("--cache", default="false", help="Ultralytics `cache`: false, ram or disk")
    p.add_argument("--budget-s", type=float, default=None,
                   help="end this chunk at the last epoch boundary that fits in this many seconds")
    p.add_argument("--chunk-epochs", type=int, default=None,
                   help="end this chunk after this many epochs")
    p.add_argument("--resume", action="store_true", help="continue from weights/resume.pt")
    p.add_argument("--amp", action="store_true",
                   help="mixed precision on CUDA, without Ultralytics' AMP check (it downloads weights)")
    p.add_argument("--channels", type=int, choices=(1, 3), default=3,
                   help="network input channels: 1 trains on the grey frames as they are")
    p.add_argument("--no-val", action="store_true",
                   help="validate only at the end of the schedule, not after every epoch")
    return p.parse_args()


def setup_offline(out: Path):
    """Offline Ultralytics: private config dir with a local TTF as Arial.ttf. Must run before import."""
    cfg = out / "yolo-config"
    font = cfg / "Ultralytics" / "Arial.ttf"
    font.parent.mkdir(parents=True, exist_ok=True)
    if not font.exists():
        import matplotlib

        src = Path(matplotlib.get_data_path()) / "fonts" / "ttf" / "DejaVuSans.ttf"
        shutil.copyfile(src, font)
    os.environ["YOLO_OFFLINE"] = "1"
    os.environ["YOLO_CONFIG_DIR"] = str(cfg)


def polars_or_stand_in() -> bool:
    """Ultralytics 8.4 imports polars only for its plots and for a copy of results.csv inside
    the checkpoint. Where polars is missing (its 54 MB wheel did not fit on the GPU machine this
    project trains on), train without plots and leave that copy empty: a stand-in module whose
    read_csv raises, which Ultralytics catches. Returns whether the real polars is there."""
    if importlib.util.find_spec("polars") is not None:
        return True
    import types

    def read_csv(*_args, **_kwargs):
        raise ImportError("polars is not installed")

    stand_in = types.ModuleType("polars")
    stand_in.read_csv = read_csv
    sys.modules["polars"] = stand_in
    print("train.py: polars is not installed; training without Ultralytics' plots", flush=True)
    return False


def sha256(path: Path) -> str:
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


def skip_amp_check():
    """Ultralytics' check_amp runs a downloaded model with and without AMP to catch GPUs whose
    AMP is broken; offline it cannot. Trust AMP on CUDA (the lent H100s), never on CPU, as the
    check itself would answer there."""
    import ultralytics.engine.trainer as trainer

    trainer.check_amp = lambda model: next(model.parameters()).device.type == "cuda"


def grey_data(data: Path, out: Path) -> Path:
    """`data` with `channels: 1` (Ultralytics then reads the PNGs with IMREAD_GRAYSCALE and builds
    a 1-channel network), its folders kept by an absolute `path`."""
    text = data.read_text()
    if re.search(r"(?m)^(path|channels)\s*:", text):
        sys.exit(f"train.py: {data} already sets `path` or `channels`; soig's data.yaml sets neither")
    grey = out / "data-grey.yaml"
    grey.write_text(f"path: {json.dumps(str(data.parent))}\n{text.rstrip()}\nchannels: 1\n")
    return grey


def grey_weights(pt: Path, out: Path) -> Path:
    """A 3-channel checkpoint as a 1-channel one: the first convolution's kernel summed over its
    input channels, exact on grey input (conv(w, [g, g, g]) = conv(w_B + w_G + w_R, g)). A
    1-channel checkpoint is returned as it is."""
    import torch

    ckpt = torch.load(pt, map_location="cpu", weights_only=False)
    changed = False
    for key in ("model", "ema"):
        m = ckpt.get(key) if isinstance(ckpt, dict) else None
        if m is None:
            continue
        conv = m.model[0].conv
        if conv.in_channels == 1:
            continue
        grey = torch.nn.Conv2d(1, conv.out_channels, conv.kernel_size, conv.stride, conv.padding,
                               conv.dilation, conv.groups, conv.bias is not None)
        # Summed in float32 and kept so: a half-precision sum would round it (Ultralytics loads
        # every checkpoint as float32 anyway).
        grey.weight.data = conv.weight.data.float().sum(1, keepdim=True)
        if conv.bias is not None:
            grey.bias.data = conv.bias.data.float()
        m.model[0].conv = grey
        # DetectionModel takes its channels from the yaml before the data's: say 1.
        m.yaml["channels"] = 1
        changed = True
    if not changed:
        return pt
    dst = out / f"{pt.stem}-grey.pt"
    torch.save(ckpt, dst)
    return dst


def grey_hsv():
    """Ultralytics' RandomHSV skips 1-channel images; give them its value gain, as it treats a
    grey BGR image (same random draws, same lookup table)."""
    import cv2
    import numpy as np
    from ultralytics.data import augment

    three = augment.RandomHSV.__call__

    def call(self, labels):
        img = labels["img"]
        if img.ndim == 3 and img.shape[-1] == 3 or not (self.hgain or self.sgain or self.vgain):
            return three(self, labels)
        r = np.random.uniform(-1, 1, 3) * [self.hgain, self.sgain, self.vgain]
        x = np.arange(0, 256, dtype=r.dtype)
        lut_val = np.clip(x * (r[2] + 1), 0, 255).astype(img.dtype)
        img[...] = cv2.LUT(img, lut_val).reshape(img.shape)  # in place, as RandomHSV does
        return labels

    augment.RandomHSV.__call__ = call


def box_metrics(m) -> dict:
    b = m.box
    return {"precision": float(b.mp), "recall": float(b.mr), "mAP50": float(b.map50), "mAP50-95": float(b.map)}


class Chunk:
    """Ends a chunk at an epoch boundary before its budget and keeps resume.pt, the last epoch's
    checkpoint with its optimizer state (Ultralytics strips last.pt when training ends)."""

    def __init__(self, budget_s, max_epochs, t0):
        self.budget_s = budget_s
        self.max_epochs = max_epochs
        self.t0 = t0
        self.epoch_s = []
        self.first = None  # 0-based index of the chunk's first epoch
        self.last = None
        self.budget_stop = False

    def on_model_save(self, trainer):
        now = time.time()
        self.epoch_s.append(round(now - trainer.epoch_time_start, 2))
        if self.first is None:
            self.first = trainer.epoch
        self.last = trainer.epoch
        # Copy, then rename: a chunk killed mid-copy leaves the previous resume.pt whole.
        tmp = trainer.wdir / "resume.pt.partial"
        shutil.copyfile(trainer.last, tmp)
        os.replace(tmp, trainer.wdir / "resume.pt")
        # The longest epoch so far bounds the next one (the chunk's first also carries the data
        # loaders' start, so the estimate errs on the early side).
        if not trainer.stop and trainer.epoch + 1 < trainer.epochs:
            over_time = self.budget_s is not None and now - self.t0 + max(self.epoch_s) > self.budget_s
            over_count = self.max_epochs is not None and len(self.epoch_s) >= self.max_epochs
            if over_time or over_count:
                trainer.stop = self.budget_stop = True

    def record(self):
        epochs = [] if self.first is None else [self.first + 1, self.last + 1]
        return {"epochs": epochs, "epoch_s": self.epoch_s, "budget_s": self.budget_s,
                "max_epochs": self.max_epochs}


def main():
    a = parse_args()
    out = Path(a.out).resolve()
    data = Path(a.data).resolve()
    if not data.is_file():
        sys.exit(f"train.py: data yaml not found: {data}")
    out.mkdir(parents=True, exist_ok=True)
    setup_offline(out)

    plots = polars_or_stand_in()
    import torch
    import ultralytics
    from ultralytics import YOLO

    if a.amp:
        skip_amp_check()
    if a.channels == 1:
        data = grey_data(data, out)
        grey_hsv()
        if a.model.endswith(".pt") and not a.resume:
            a.model = str(grey_weights(Path(a.model), out))
    device = None if a.device == "auto" else a.device
    cache = {"false": False, "true": True}.get(a.cache, a.cache)
    summary_path = out / "summary.json"
    chunks = []
    t0 = time.time()
    chunk = Chunk(a.budget_s, a.chunk_epochs, t0)
    save_dir = out / "train"
    if a.resume:
        resume_pt = save_dir / "weights" / "resume.pt"
        if not resume_pt.is_file():
            sys.exit(f"train.py: nothing to resume: {resume_pt} not found")
        if summary_path.is_file():
            chunks = json.loads(summary_path.read_text()).get("chunks", [])
        # Ultralytics resumes from last.pt; the resumable copy replaces the stripped one.
        shutil.copyfile(resume_pt, save_dir / "weights" / "last.pt")
        model = YOLO(str(save_dir / "weights" / "last.pt"))
        model.add_callback("on_model_save", chunk.on_model_save)
        # Only what Ultralytics lets a resume change (the loader's); the schedule is the checkpoint's.
        model.train(resume=True, data=str(data), device=device, workers=a.workers, cache=cache,
                    plots=plots)
    else:
        model = YOLO(a.model)
        model.add_callback("on_model_save", chunk.on_model_save)
        model.train(
            data=str(data), epochs=a.epochs, batch=a.batch, imgsz=a.imgsz, optimizer=a.optimizer,
            device=device, seed=a.seed, workers=a.workers, patience=a.patience, time=a.time_hours,
            cache=cache, project=str(out), name="train", exist_ok=True,
            amp=a.amp, deterministic=True, plots=plots, val=not a.no_val,
        )
    train_wall_s = time.time() - t0
    trainer = model.trainer
    save_dir = Path(trainer.save_dir)
    best = save_dir / "weights" / "best.pt"
    results_csv = save_dir / "results.csv"
    if not best.is_file():
        sys.exit(f"train.py: training produced no best.pt in {best.parent}")
    with open(results_csv) as f:
        epochs_completed = sum(1 for _ in csv.DictReader(f))
    chunks.append({**chunk.record(), "wall_s": round(train_wall_s, 1)})
    # Done when the schedule ran out, or Ultralytics stopped it (patience, `time`), not the budget.
    finished = not chunk.budget_stop
    base = {
        "ultralytics": ultralytics.__version__,
        "torch": torch.__version__,
        "args": vars(a),
        "plots": plots,
        "amp": bool(trainer.amp),  # whether mixed precision ran (--amp asks; CUDA only)
        "finished": finished,
        "chunks": chunks,
        "epochs_completed": epochs_completed,
        "epochs_planned_final": int(trainer.epochs),
        "train_wall_s": round(sum(c["wall_s"] for c in chunks), 1),
        "results_csv": str(results_csv),
    }
    if not finished:
        summary_path.write_text(json.dumps(base, indent=2) + "\n")
        print(json.dumps(base, indent=2))
        return
    (save_dir / "weights" / "resume.pt").unlink(missing_ok=True)

    # Validation of best.pt: val split, test split (Ultralytics defaults), test split at the paper's conf/iou.
    def val(split, name, **kw):
        return box_metrics(YOLO(str(best)).val(
            data=str(data), split=split, imgsz=a.imgsz, batch=a.batch, device=device, plots=plots,
            project=str(out), name=name, exist_ok=True, **kw))

    metrics = {
        "val": val("val", "val"),
        "test": val("test", "test"),
        "test_conf0.5_iou0.5": val("test", "test-conf0.5", conf=0.5, iou=0.5),
    }

    simplify = all(importlib.util.find_spec(m) is not None for m in ("onnxslim", "onnxruntime"))
    onnx = YOLO(str(best)).export(format="onnx", opset=17, imgsz=a.imgsz, simplify=simplify,
                                  dynamic=False, nms=False)
    if not onnx or not Path(onnx).is_file():
        sys.exit("train.py: ONNX export failed")
    onnx = Path(onnx).resolve()

    summary = {
        **base,
        "best_epoch": int(trainer.stopper.best_epoch),  # 1-based, by fitness = mAP50-95 on val
        "metrics": metrics,
        "onnx": {"path": str(onnx), "sha256": sha256(onnx), "bytes": onnx.stat().st_size,
                 "opset": 17, "imgsz": a.imgsz, "simplify": simplify},
        "best_pt": str(best),
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    print(json.dumps(summary, indent=2))


if __name__ == "__main__":
    try:
        main()
    except SystemExit:
        raise
    except Exception as e:  # clear message, non-zero exit
        import traceback

        traceback.print_exc()
        sys.exit(f"train.py: failed: {type(e).__name__}: {e}")
