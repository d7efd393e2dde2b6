#!/usr/bin/env python3
"""Reference figures for crates/detect/src/yolo/ (the YOLOv8 ONNX detector), from Ultralytics itself.

Run from the crate root:

    python tests/reference/yolo_reference.py            # writes tests/fixtures/yolo/*

It
  1. builds a tiny YOLOv8 detection model from scratch (no download; the yolov8.yaml architecture
     with small width/channel multiples, nc=1, torch seed 0, random weights made input-dependent:
     see export_model), exports it to ONNX at imgsz 640 (tests/fixtures/yolo/tiny.onnx);
  2. writes three greyscale test PNGs (1024x1024, 1024x768, 300x200: block noise, dots, a streak);
  3. runs Ultralytics' own `YOLO('tiny.onnx').predict(png, conf, iou, imgsz=640, max_det)` on them and
     writes the boxes (xyxy) and scores to tests/fixtures/yolo/expected.toml (read by
     tests/yolo.rs);
  4. pins FNV-1a hashes of Ultralytics' LetterBox output and of cv2.resize(INTER_LINEAR) on
     synthetic images of many sizes, to pin the bit-exact resize;
  5. writes invalid models for the error tests: not_onnx.onnx (text), wrong_shape.onnx (output
     (1, 3, 7)), rank2.onnx (output (1, 3)).

Needs: ultralytics (pinned figures made with 8.4.190, torch 2.15, torchvision 0.29, opencv-python
5.0, onnxruntime 1.32, onnx 1.23, onnxslim 0.1), matplotlib (for a TTF: Ultralytics wants a font).
Runs offline: YOLO_OFFLINE=1, a private YOLO_CONFIG_DIR with a TTF copied to Ultralytics/Arial.ttf.
`--yolov8n DIR` additionally exports the standard yolov8n (random weights) at 640 and 1024 into DIR
for timing (not committed: 12 MB each).
"""

import argparse
import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

CONF = 0.1
IOU = 0.5
MAX_DET = 50
IMGSZ = 640
SEED = 0
# yolov8.yaml's architecture at depth 0.33 (as n), width 1/16 (n: 1/4), max channels 256 (n: 1024),
# and DFL reg_max 4 (YOLOv8: 16; the DFL decode is inside the graph, the output format is the same).
TINY_SCALE = [0.33, 0.0625, 256]
TINY_REG_MAX = 4

ROOT = Path(__file__).resolve().parent.parent.parent  # the repository (this file is in tests/reference/)
OUT = ROOT / "tests" / "fixtures" / "yolo"


def setup_offline_ultralytics():
    cfg = Path(tempfile.mkdtemp(prefix="yolo-cfg-"))
    os.environ["YOLO_CONFIG_DIR"] = str(cfg)
    os.environ["YOLO_OFFLINE"] = "1"
    import matplotlib

    ttf = Path(matplotlib.get_data_path()) / "fonts" / "ttf" / "DejaVuSans.ttf"
    (cfg / "Ultralytics").mkdir(parents=True, exist_ok=True)
    for name in ("Arial.ttf", "Arial.Unicode.ttf"):
        shutil.copy(ttf, cfg / "Ultralytics" / name)
    return cfg


def fixture_toml(provenance, predictions, letterbox, resize):
    """tests/fixtures/yolo/expected.toml: the thresholds; the LetterBox pins (w, h, FNV-1a of
    LetterBox((640, 640), auto=False) of pattern(w, h)) and the resize pins (w, h, dw, dh, FNV-1a
    of cv2.resize(pattern(w, h), (dw, dh), INTER_LINEAR)); a [[prediction]] per test PNG: its
    LetterBox's FNV-1a and Ultralytics' boxes, [x1, y1, x2, y2, score, class] sorted by score.
    A row one a line, a float as repr() writes it (Rust reads it back as the same double), a
    hash as 16 hex digits."""
    def rows(items):
        return "[\n" + "".join(f"  {json.dumps(r)},\n" for r in items) + "]"

    lines = [f"# {provenance}", f"conf = {CONF!r}", f"iou = {IOU!r}", f"max_det = {MAX_DET}",
             f"letterbox = {rows([[w, h, f'{x:016x}'] for w, h, x in letterbox])}",
             f"resize = {rows([[w, h, dw, dh, f'{x:016x}'] for w, h, dw, dh, x in resize])}"]
    for name, lbh, boxes in predictions:
        lines += ["", "[[prediction]]", f"file = {json.dumps(name)}", f'letterbox_fnv1a = "{lbh:016x}"',
                  f"boxes = {rows(boxes)}"]
    return "\n".join(lines) + "\n"


def fnv1a64(data: bytes) -> int:
    h = 0xCBF29CE484222325
    for b in data:
        h ^= b
        h = (h * 0x100000001B3) & 0xFFFFFFFFFFFFFFFF
    return h


def pattern(w, h):
    """Deterministic hash noise, the same as `pattern` in tests/yolo.rs (u32 arithmetic)."""
    import numpy as np

    y, x = np.mgrid[0:h, 0:w].astype(np.uint64)
    m = np.uint64(0xFFFFFFFF)
    v = ((x * np.uint64(73856093)) & m) ^ ((y * np.uint64(19349663)) & m)
    v ^= v >> np.uint64(13)
    v = (v * np.uint64(1274126177)) & m
    v ^= v >> np.uint64(16)
    return (v & np.uint64(255)).astype(np.uint8)


def make_image(w, h, seed):
    """Greyscale sky: 2x2-block Gaussian noise (compresses well), Gaussian dots, one streak."""
    import numpy as np

    rng = np.random.default_rng(seed)
    noise = rng.normal(40.0, 4.0, size=((h + 1) // 2, (w + 1) // 2))
    img = np.kron(noise, np.ones((2, 2)))[:h, :w]
    yy, xx = np.mgrid[0:h, 0:w]
    for _ in range(25):
        cx, cy = rng.uniform(0, w), rng.uniform(0, h)
        amp, sig = rng.uniform(60, 200), rng.uniform(1.0, 3.0)
        x0, x1 = int(max(cx - 5 * sig, 0)), int(min(cx + 5 * sig + 1, w))
        y0, y1 = int(max(cy - 5 * sig, 0)), int(min(cy + 5 * sig + 1, h))
        img[y0:y1, x0:x1] += amp * np.exp(-((xx[y0:y1, x0:x1] - cx) ** 2 + (yy[y0:y1, x0:x1] - cy) ** 2) / (2 * sig**2))
    # A streak (debris trail): a thick line segment.
    x0, y0 = 0.2 * w, 0.3 * h
    x1, y1 = 0.7 * w, 0.6 * h
    t = np.clip(((xx - x0) * (x1 - x0) + (yy - y0) * (y1 - y0)) / ((x1 - x0) ** 2 + (y1 - y0) ** 2), 0, 1)
    d2 = (xx - (x0 + t * (x1 - x0))) ** 2 + (yy - (y0 + t * (y1 - y0))) ** 2
    img += 150 * np.exp(-d2 / (2 * 1.5**2))
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def export_model(yaml_text, name, imgsz, outdir, liven=False, dynamic=False):
    """Build a model from a YAML (random weights, torch seed SEED) and export it to ONNX.

    liven: a freshly initialised YOLOv8 outputs nearly constant boxes and scores (features fade out
    through the un-calibrated BatchNorms; the class bias is log(5 / nc / (640 / stride)^2)). To get
    input-dependent outputs, calibrate the BatchNorm statistics on a few synthetic sky images and
    scale the last convolutions (box x3, class x2), with the class bias at -4.
    """
    import numpy as np
    import torch
    from ultralytics import YOLO

    work = Path(tempfile.mkdtemp(prefix="yolo-export-"))
    yaml_path = work / f"{name}.yaml"
    yaml_path.write_text(yaml_text)
    torch.manual_seed(SEED)
    model = YOLO(str(yaml_path), task="detect")
    if liven:
        net = model.model
        for bn in net.modules():
            if isinstance(bn, torch.nn.BatchNorm2d):
                bn.reset_running_stats()
                bn.momentum = None  # cumulative average over the calibration pass
        imgs = np.stack([np.repeat(make_image(imgsz, imgsz, 100 + s)[None], 3, 0) for s in range(4)])
        net.train()
        with torch.no_grad():
            net(torch.from_numpy(imgs).float() / 255)
        net.eval()
        head = net.model[-1]
        with torch.no_grad():
            for seq in head.cv3:
                seq[-1].bias.fill_(-4.0)
                seq[-1].weight.mul_(2.0)
            for seq in head.cv2:
                seq[-1].weight.mul_(3.0)
    f = model.export(format="onnx", imgsz=imgsz, simplify=True, dynamic=dynamic, opset=17, device="cpu")
    dst = Path(outdir) / f"{name}.onnx"
    shutil.move(f, dst)
    shutil.rmtree(work, ignore_errors=True)
    return dst


def v8_yaml(scale, key="t"):
    import ultralytics

    src = Path(ultralytics.__file__).parent / "cfg" / "models" / "v8" / "yolov8.yaml"
    lines = []
    skip = False
    for line in src.read_text().splitlines():
        if line.startswith("nc:"):
            lines.append("nc: 1")
            continue
        if line.startswith("scales:"):
            lines.append("scales:")
            lines.append(f"  {key}: [{scale[0]}, {scale[1]}, {scale[2]}]")
            skip = True
            continue
        if skip:
            if line.startswith("  "):
                continue
            skip = False
        lines.append(line)
    return "\n".join(lines) + "\n"


def write_bad_models(outdir):
    import onnx
    from onnx import TensorProto, helper

    (outdir / "not_onnx.onnx").write_text("this is not an ONNX model\n")

    def graph(out_shape, name):
        x = helper.make_tensor_value_info("images", TensorProto.FLOAT, [1, 3, 640, 640])
        y = helper.make_tensor_value_info("output0", TensorProto.FLOAT, out_shape)
        shape = helper.make_tensor("shape", TensorProto.INT64, [len(out_shape)], [1, 3] + [1] * (len(out_shape) - 2))
        nodes = [
            helper.make_node("GlobalAveragePool", ["images"], ["pooled"]),
            helper.make_node("Reshape", ["pooled", "shape"], ["flat"]),
        ]
        inits = [shape]
        if len(out_shape) == 3:
            reps = helper.make_tensor("reps", TensorProto.INT64, [3], [1, 1, out_shape[2]])
            inits.append(reps)
            nodes.append(helper.make_node("Tile", ["flat", "reps"], ["output0"]))
        else:
            nodes.append(helper.make_node("Identity", ["flat"], ["output0"]))
        g = helper.make_graph(nodes, name, [x], [y], inits)
        m = helper.make_model(g, opset_imports=[helper.make_opsetid("", 17)], producer_name="yolo_reference.py")
        m.ir_version = 8
        onnx.checker.check_model(m)
        onnx.save(m, outdir / f"{name}.onnx")

    graph([1, 3, 7], "wrong_shape")
    graph([1, 3], "rank2")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=OUT)
    ap.add_argument("--yolov8n", type=Path, help="also export random-weight yolov8n at 640 and 1024 here")
    args = ap.parse_args()
    setup_offline_ultralytics()

    import cv2
    import numpy as np
    import onnxruntime
    import torch
    import torchvision
    import ultralytics
    from ultralytics import YOLO
    from ultralytics.data.augment import LetterBox

    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    print(
        f"# ultralytics {ultralytics.__version__}, torch {torch.__version__}, torchvision {torchvision.__version__}, "
        f"opencv {cv2.__version__}, onnxruntime {onnxruntime.__version__}",
        file=sys.stderr,
    )

    model_path = export_model(f"reg_max: {TINY_REG_MAX}\n" + v8_yaml(TINY_SCALE), "tiny", IMGSZ, out, liven=True)
    print(f"# {model_path}: {model_path.stat().st_size} bytes", file=sys.stderr)
    write_bad_models(out)

    images = [("sky_1024x1024.png", 1024, 1024, 1), ("sky_1024x768.png", 1024, 768, 2), ("sky_300x200.png", 300, 200, 3)]
    for name, w, h, seed in images:
        cv2.imwrite(str(out / name), make_image(w, h, seed))

    model = YOLO(str(model_path), task="detect")
    provenance = (f"Generated by tests/reference/yolo_reference.py, do not edit (Ultralytics {ultralytics.__version__}, "
                  f"opencv {cv2.__version__}, onnxruntime {onnxruntime.__version__}): "
                  f"YOLO('tiny.onnx').predict(png, conf={CONF}, iou={IOU}, imgsz={IMGSZ}, max_det={MAX_DET}).")
    predictions = []
    for name, w, h, _ in images:
        path = out / name
        bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
        lb = LetterBox((IMGSZ, IMGSZ), auto=False, stride=32)(image=bgr)
        assert (lb[..., 0] == lb[..., 1]).all() and (lb[..., 0] == lb[..., 2]).all()
        lbh = fnv1a64(np.ascontiguousarray(lb[..., 0]).tobytes())
        r = model.predict(str(path), conf=CONF, iou=IOU, imgsz=IMGSZ, max_det=MAX_DET, verbose=False)[0]
        xyxy = r.boxes.xyxy.cpu().numpy()  # float32
        conf = r.boxes.conf.cpu().numpy()
        cls = r.boxes.cls.cpu().numpy()
        print(f"# {name}: {len(conf)} boxes, scores {conf.min() if len(conf) else 0:.4f}..{conf.max() if len(conf) else 0:.4f}", file=sys.stderr)
        # the float32 values widened to float64: exact, so Rust can compare to the bit.
        boxes = [[float(v) for v in (*b, c)] + [float(round(k))] for b, c, k in zip(xyxy, conf, cls)]
        predictions.append((name, lbh, boxes))

    # Bit-exact resize pins: LetterBox on synthetic images, and plain cv2.resize.
    letterbox = []
    for w, h in [(1024, 1024), (1024, 768), (300, 200), (1280, 1280), (1280, 960), (2048, 1536), (641, 333), (17, 900), (640, 640), (5, 3), (1472, 1472), (1088, 1088)]:
        img = cv2.cvtColor(pattern(w, h), cv2.COLOR_GRAY2BGR)
        lb = LetterBox((IMGSZ, IMGSZ), auto=False, stride=32)(image=img)
        assert (lb[..., 0] == lb[..., 1]).all() and (lb[..., 0] == lb[..., 2]).all()
        letterbox.append((w, h, fnv1a64(np.ascontiguousarray(lb[..., 0]).tobytes())))
    resize = []
    for w, h, dw, dh in [(1024, 1024, 640, 640), (300, 200, 640, 427), (1280, 960, 640, 480), (640, 640, 320, 320), (1000, 1500, 427, 640),
                         (17, 900, 12, 640), (3, 1, 640, 213), (640, 480, 641, 481), (100, 100, 33, 77), (1024, 1024, 1023, 1025), (2, 2, 1, 1)]:
        img = pattern(w, h)
        r1 = cv2.resize(img, (dw, dh), interpolation=cv2.INTER_LINEAR)
        r3 = cv2.resize(cv2.cvtColor(img, cv2.COLOR_GRAY2BGR), (dw, dh), interpolation=cv2.INTER_LINEAR)
        assert all((r3[..., c] == r1).all() for c in range(3)), (w, h, dw, dh)
        resize.append((w, h, dw, dh, fnv1a64(r1.tobytes())))

    (out / "expected.toml").write_text(fixture_toml(provenance, predictions, letterbox, resize))
    print(f"# wrote {out / 'expected.toml'}", file=sys.stderr)

    if args.yolov8n:
        args.yolov8n.mkdir(parents=True, exist_ok=True)
        for sz in (640, 1024):
            p = export_model(v8_yaml([0.33, 0.25, 1024], "n"), f"yolov8n_{sz}", sz, args.yolov8n)
            print(f"# {p}: {p.stat().st_size} bytes", file=sys.stderr)


if __name__ == "__main__":
    main()
