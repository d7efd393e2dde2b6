"""The training input path's throughput (issue #47, models/README.md "The input path, measured"):
CPU seconds per training sample through Ultralytics' own dataset (decode from the RAM cache,
mosaic, random perspective, flips; what each of the loader's workers does per image) and per
batch collated, for 1 and 3 colour channels and mosaic on and off. CPU time of this one process
(time.process_time), not wall time, so that other work on the machine moves the figures little;
a loader with W workers delivers at most W / (seconds per sample) images per second.

    soig run campaigns/model-survey-rotated.toml --set images=40 --out DS
    python scripts/profile-train-loader.py DS IMGSZ BATCH [SAMPLES]

Needs Ultralytics (scripts/setup-train.sh installs it into .venv-train).
"""
import os
import statistics
import sys
import tempfile
import time

os.environ["YOLO_OFFLINE"] = "1"
import torch  # noqa: E402
from ultralytics.cfg import get_cfg  # noqa: E402
from ultralytics.data.build import build_yolo_dataset  # noqa: E402
from ultralytics.data.utils import check_det_dataset  # noqa: E402

root, imgsz, batch = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
samples = int(sys.argv[4]) if len(sys.argv) > 4 else 48
torch.set_num_threads(1)


def data_yaml(channels: int) -> str:
    """The run's data.yaml with `channels` set (Ultralytics reads 1 as grey, IMREAD_GRAYSCALE)."""
    text = open(os.path.join(root, "data.yaml")).read()
    text = text.replace("train: images/", f"path: {root}\ntrain: images/", 1)
    f = tempfile.NamedTemporaryFile("w", suffix=".yaml", delete=False)
    f.write(text + f"channels: {channels}\n")
    f.close()
    return f.name


def per_sample(channels: int, mosaic: float) -> tuple[float, float]:
    """Median CPU seconds per augmented sample, and per collated batch."""
    yaml = data_yaml(channels)
    data = check_det_dataset(yaml)
    cfg = get_cfg(overrides={"imgsz": imgsz, "cache": "ram", "data": yaml, "mosaic": mosaic})
    ds = build_yolo_dataset(cfg, data["train"], batch, data, mode="train", stride=32)
    for i in range(4):  # warm: the RAM cache and first-call costs
        ds[i % len(ds)]
    times, items = [], []
    for i in range(samples):
        t = time.process_time()
        items.append(ds[i % len(ds)])
        times.append(time.process_time() - t)
    collate = []
    for k in range(0, len(items) - batch + 1, batch):
        t = time.process_time()
        ds.collate_fn(items[k : k + batch])
        collate.append(time.process_time() - t)
    os.unlink(yaml)
    return statistics.median(times), statistics.median(collate) if collate else float("nan")


print(f"{root}: imgsz {imgsz}, batch {batch}, {samples} samples each, CPU seconds of one thread")
print("| channels | mosaic | s per sample | s per batch collated | images/s for 16 workers |")
print("|---|---|---|---|---|")
for channels in (3, 1):
    for mosaic in (1.0, 0.0):
        s, c = per_sample(channels, mosaic)
        print(f"| {channels} | {'on' if mosaic else 'off'} | {s:.4f} | {c:.4f} | {16 / s:.0f} |",
              flush=True)
