"""The streak-shaped label sets (`[artifacts] obb_labels`, `keypoint_labels`; issue #45 item 3)
load in Ultralytics as written, and `yolo obb` trains on the OBB set unedited: checked on CPU.

1. `soig run` writes the quickstart campaign (12 images, 256 px) with both sets.
2. `check_det_dataset` reads `obb/data.yaml` and `keypoints/data.yaml` (pose: kpt_shape [2, 3]).
3. Ultralytics' dataset for the obb and pose tasks reads every label file: none corrupt or
   missing, one instance per axis-aligned box, the oriented boxes' corners in [0, 1].
4. `yolo obb` (yolov8n-obb.yaml from scratch, 1 epoch, imgsz 256) trains on `obb/data.yaml`,
   its oriented boxes reaching the loss (a box loss above 0: at imgsz 64 the 5 px wide boxes
   fall under Ultralytics' 2 px filter and the loss is 0), and validates on its val images.

    .venv-train/bin/python3 scripts/streak-labels-test.py
"""
import os
import subprocess
import sys
import tempfile
from pathlib import Path

os.environ["YOLO_OFFLINE"] = "1"
import numpy as np  # noqa: E402
from ultralytics.data.build import build_yolo_dataset  # noqa: E402
from ultralytics.data.utils import check_det_dataset  # noqa: E402
from ultralytics.cfg import get_cfg  # noqa: E402

root = Path(__file__).resolve().parent.parent
work = Path(tempfile.mkdtemp())
out = work / "run"
soig = os.environ.get("SOIG", str(root / "target/release/soig"))
sets = ["images=12", "sensor.width_px=256", "sensor.height_px=256",
        'stages=["render","enhance","dataset"]', "artifacts.obb_labels=true",
        "artifacts.keypoint_labels=true"]
subprocess.run([soig, "run", str(root / "campaigns/quickstart.toml"), "-q", "--out", str(out)]
               + [x for s in sets for x in ("--set", s)], check=True, stdout=subprocess.DEVNULL)

boxes = {}
for split in ("train", "val", "test"):
    for f in (out / "labels" / split).glob("*.txt"):
        boxes[(split, f.stem)] = len(f.read_text().splitlines())
n_boxes = sum(boxes.values())
assert n_boxes > 0, "no labelled object"

report = []
for task, folder in (("obb", "obb"), ("pose", "keypoints")):
    data = check_det_dataset(str(out / folder / "data.yaml"))
    assert Path(data["train"]) == out / folder / "images/train", data["train"]
    if task == "pose":
        assert data["kpt_shape"] == [2, 3], data["kpt_shape"]
    cfg = get_cfg(overrides={"task": task, "imgsz": 64, "cache": False})
    instances = 0
    for split in ("train", "val", "test"):
        ds = build_yolo_dataset(cfg, data[split], batch=4, data=data, mode="val", stride=32)
        # Ultralytics drops a corrupt label with a warning: every file must have been read.
        assert len(ds.labels) == len(list((out / folder / "images" / split).glob("*.png")))
        for lb in ds.labels:
            key = (split, Path(lb["im_file"]).stem)
            assert len(lb["cls"]) == boxes[key], (key, len(lb["cls"]), boxes[key])
            instances += len(lb["cls"])
            if task == "obb":
                seg = np.asarray(lb["segments"])
                assert seg.shape[1:] == (4, 2) and seg.min() >= 0 and seg.max() <= 1, key
            else:
                assert lb["keypoints"].shape[1:] == (2, 3), key
    assert instances == n_boxes, (task, instances, n_boxes)
    report.append(f"{task} {instances} instances")

from ultralytics import YOLO  # noqa: E402

model = YOLO("yolov8n-obb.yaml")
model.train(data=str(out / "obb/data.yaml"), epochs=1, imgsz=256, batch=4, device="cpu",
            workers=0, plots=False, project=str(work), name="obb", verbose=False, amp=False)
metrics = model.val(data=str(out / "obb/data.yaml"), imgsz=256, batch=4, device="cpu",
                    workers=0, plots=False, project=str(work), name="obb-val", verbose=False)
box_loss = float(next(iter(model.trainer.tloss.values())))  # box, cls, dfl, angle
assert box_loss > 0, "no oriented box reached the loss"
assert hasattr(metrics, "box") and metrics.box.map50 >= 0.0
print(f"streak-labels-test: {', '.join(report)} (= the {n_boxes} axis-aligned boxes); "
      f"yolo obb trained 1 epoch on obb/data.yaml (box loss {box_loss:.2f}), "
      f"val mAP50 {metrics.box.map50:.3f}")
sys.exit(0)
