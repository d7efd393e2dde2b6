"""`[train] channels = 1` gives the model 3 channels of replicated grey give (issue #47;
python/train.py): checked here on CPU with Ultralytics.

1. A committed 3-channel checkpoint converted by `grey_weights` (first convolution summed over
   its input channels) predicts on a grey image what the original predicts on that image as BGR.
   Tolerance 1e-4 relative to the largest output: the two sum the same products in another order
   in float32 (measured: 1.6e-7).
2. The patched RandomHSV on a 1-channel image equals Ultralytics' own on the same image as BGR
   (any channel of it), bit for bit, with the same random draws.
3. `grey_data` writes a data.yaml that Ultralytics reads as 1 channel with the original folders.
4. `soig train` with `--set train.channels=1` from that checkpoint (tiny, 2 epochs on CPU)
   transfers every weight (Ultralytics' "Transferred N/N") and exports a 1-channel ONNX.

    .venv-train/bin/python3 scripts/train-grey-test.py
"""
import importlib.util
import os
import sys
import tempfile
from pathlib import Path

os.environ["YOLO_OFFLINE"] = "1"
import numpy as np  # noqa: E402
import torch  # noqa: E402

root = Path(__file__).resolve().parent.parent
spec = importlib.util.spec_from_file_location("train", root / "python/train.py")
train = importlib.util.module_from_spec(spec)
spec.loader.exec_module(train)

torch.manual_seed(0)
work = Path(tempfile.mkdtemp())

# 1. The converted checkpoint.
pt = root / "models/soig-yolov8n-survey-original.pt"
grey_pt = train.grey_weights(pt, work)
assert grey_pt != pt, "a 3-channel checkpoint must be converted"
three = torch.load(pt, map_location="cpu", weights_only=False)["model"].float().eval()
one = torch.load(grey_pt, map_location="cpu", weights_only=False)["model"].float().eval()
assert one.model[0].conv.in_channels == 1 and one.yaml["channels"] == 1
g = torch.rand(1, 1, 256, 256)
with torch.no_grad():
    y3 = three(g.expand(1, 3, 256, 256))[0]
    y1 = one(g)[0]
err = (y3 - y1).abs().max().item() / y3.abs().max().item()
assert err < 1e-4, f"grey model differs from the 3-channel one: {err:.2e} of the largest output"
assert train.grey_weights(grey_pt, work) == grey_pt, "a 1-channel checkpoint is kept as it is"

# 2. The HSV augmentation on grey.
from ultralytics.data.augment import RandomHSV  # noqa: E402

grey = (np.random.default_rng(1).random((64, 64)) * 255).astype(np.uint8)
bgr = np.repeat(grey[:, :, None], 3, axis=2).copy()
hsv = RandomHSV(hgain=0.015, sgain=0.7, vgain=0.4)
np.random.seed(5)
want = hsv({"img": bgr})["img"]
train.grey_hsv()
np.random.seed(5)
got = hsv({"img": grey[:, :, None].copy()})["img"]
assert got.shape == (64, 64, 1)
for c in range(3):
    assert np.array_equal(got[:, :, 0], want[:, :, c]), f"channel {c} differs"
assert not np.array_equal(got[:, :, 0], grey), "the value gain must change the image"
# A 3-channel image still takes Ultralytics' own path.
np.random.seed(5)
assert np.array_equal(hsv({"img": np.repeat(grey[:, :, None], 3, axis=2).copy()})["img"], want)

# 3. The 1-channel data.yaml.
from ultralytics.data.utils import check_det_dataset  # noqa: E402

ds = work / "ds"
(ds / "images/train").mkdir(parents=True)
(ds / "data.yaml").write_text("train: images/train\nval: images/train\nnc: 1\nnames:\n  0: debris\n")
data = check_det_dataset(str(train.grey_data(ds / "data.yaml", work)))
assert data["channels"] == 1 and Path(data["train"]) == ds / "images/train", data
# 4. End to end through soig train.
import re  # noqa: E402
import subprocess  # noqa: E402

soig = os.environ.get("SOIG", str(root / "target/release/soig"))
run = work / "run"
sets = ["images=12", "sensor.width_px=256", "sensor.height_px=256",
        'stages=["render","enhance","dataset"]', "train.epochs=2", "train.device=cpu",
        "train.workers=0", "train.imgsz=64", "train.batch=4", "train.channels=1",
        "train.model=../models/soig-yolov8n-survey-original.pt"]
cmd = [soig, "train", str(root / "campaigns/quickstart.toml"), "--python", sys.executable, "-q",
       "--out", str(run)] + [x for s in sets for x in ("--set", s)]
subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
log = (run / "train/train.log").read_text()
moved = re.search(r"Transferred (\d+)/(\d+) items", log)
assert moved and moved.group(1) == moved.group(2), moved and moved.group(0)
import onnxruntime  # noqa: E402

shape = onnxruntime.InferenceSession(str(run / "train/model.onnx")).get_inputs()[0].shape
assert shape == [1, 1, 64, 64], shape
print(f"train-grey-test: converted model within {err:.1e} of the 3-channel one; grey HSV bit-exact; "
      f"data.yaml read as 1 channel; soig train: {moved.group(0)}, ONNX input {shape}")
