#!/usr/bin/env python3
"""Reference figures for soig's `metrics` module, computed with the real libraries.

* COCO: pycocotools (COCO / COCOeval, iouType 'bbox'), installed with `pip install pycocotools`.
* Ultralytics, current: the installed `ultralytics` package (`pip install ultralytics`, 8.4.190 when this was
  written): `box_iou`, `DetectionValidator._process_batch` -> `BaseValidator.match_predictions`, and
  `DetMetrics.update_stats` / `DetMetrics.process` -> `ap_per_class`, fed exactly as
  `DetectionValidator.update_metrics` feeds them.
* Ultralytics, legacy (<= 8.3.x, the np.unique matching): the functions `box_iou`, `smooth`, `compute_ap`,
  `ap_per_class` (ultralytics/utils/metrics.py) and `match_predictions` (ultralytics/engine/validator.py) are
  taken verbatim from the 8.3.0 wheel (`pip download --no-deps ultralytics==8.3.0`, unzipped; pass its folder
  with --legacy DIR) and exec'd; `np.trapz` (removed in numpy 2.4) is bound to `np.trapezoid`, the plot
  functions are no-ops; the loop of 8.3.0's `DetectionValidator.update_metrics` / `get_stats` is restated below.

Usage: python metrics_reference.py [--legacy /path/to/unzipped/ultralytics-8.3.0] [--toml OUT.toml]
As run for the pinned figures (numpy 2.4.6, torch 2.15.0, ultralytics 8.4.190, pycocotools 2.0.11):
    python -m venv /tmp/mvenv && /tmp/mvenv/bin/pip install pycocotools ultralytics
    /tmp/mvenv/bin/pip download --no-deps ultralytics==8.3.0 -d /tmp/uold
    (cd /tmp/uold && mkdir v830 && cd v830 && unzip -q ../ultralytics-8.3.0-py3-none-any.whl)
    /tmp/mvenv/bin/python reference/metrics_reference.py --legacy /tmp/uold/v830 --toml fixtures/metrics/expected.toml
(from tests/), the pinned figures that crates/detect/src/metrics/cases.rs reads.

The hand-made test cases are data, tests/fixtures/metrics/cases.toml, which the Rust tests of
crates/detect/src/metrics/cases.rs read too; the random ones come from the same splitmix64 generator here
and there, so both sides build bit-identical inputs (each case's input checksum is printed and pinned too).
"""
import argparse
import json
import ast
import importlib.metadata
import contextlib
import io
import sys
import tomllib
from pathlib import Path

import numpy as np
import torch

M64 = (1 << 64) - 1


class SplitMix64:
    def __init__(self, seed):
        self.state = seed & M64

    def next_u64(self):
        self.state = (self.state + 0x9E3779B97F4A7C15) & M64
        z = self.state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & M64
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & M64
        return z ^ (z >> 31)

    def uniform(self):
        return (self.next_u64() >> 11) * (2.0 ** -53)

    def below(self, n):
        return self.next_u64() % n


# An image: (truth boxes [[x1,y1,x2,y2]], truth classes, detections [[x1,y1,x2,y2,score,class]])

def random_box(rng):
    """A box of 4-64 px a side with its corner anywhere in 1000 x 1000: (x1, y1, w, h), drawn
    in the order w, h, x1, y1 (the Rust stress test draws the same)."""
    w = 4.0 + 60.0 * rng.uniform()
    h = 4.0 + 60.0 * rng.uniform()
    x1 = 1000.0 * rng.uniform()
    y1 = 1000.0 * rng.uniform()
    return x1, y1, w, h


def stress(seed, n_images, n_classes):
    rng = SplitMix64(seed)
    images = []
    for _ in range(n_images):
        truth, tcls, dets = [], [], []
        for _ in range(rng.below(6)):
            x1, y1, w, h = random_box(rng)
            c = rng.below(n_classes)
            truth.append([x1, y1, x1 + w, y1 + h])
            tcls.append(c)
            for _ in range(rng.below(3)):
                j = 0.3 * rng.uniform()
                dx1 = (2.0 * rng.uniform() - 1.0) * j * w
                dy1 = (2.0 * rng.uniform() - 1.0) * j * h
                dx2 = (2.0 * rng.uniform() - 1.0) * j * w
                dy2 = (2.0 * rng.uniform() - 1.0) * j * h
                dc = c if rng.uniform() < 0.9 else rng.below(n_classes)
                score = rng.uniform()
                dets.append([x1 + dx1, y1 + dy1, x1 + w + dx2, y1 + h + dy2, score, dc])
        for _ in range(rng.below(3)):
            x1, y1, w, h = random_box(rng)
            dc = rng.below(n_classes)
            score = 0.6 * rng.uniform()
            dets.append([x1, y1, x1 + w, y1 + h, score, dc])
        images.append((truth, tcls, dets))
    return images


CASES_TOML = Path(__file__).resolve().parents[1] / "fixtures/metrics/cases.toml"


def load_cases(path):
    """The hand-made cases (tests/fixtures/metrics/cases.toml, which the Rust tests read too):
    per image, (truth boxes, truth classes, detections)."""
    return {name: [([t[:4] for t in im["truth"]], [t[4] for t in im["truth"]], im["detections"]) for im in images]
            for name, images in tomllib.loads(path.read_text()).items()}


CASES = {**load_cases(CASES_TOML), "stress_single": stress(42, 50, 1), "stress_multi": stress(7, 40, 3)}


def checksum(images):
    s = 0.0
    for k, (truth, tcls, dets) in enumerate(images):
        for b, c in zip(truth, tcls):
            s += (k + 1) * (b[0] + 2 * b[1] + 3 * b[2] + 4 * b[3] + 5 * c)
        for d in dets:
            s += (k + 1) * (d[0] - 2 * d[1] + 3 * d[2] - 4 * d[3] + 1000 * d[4] + 7 * d[5])
    return s


def as_tensors(truth, tcls, dets):
    """Boxes, classes and scores as the Ultralytics validator holds them (float32), detections in NMS order
    (descending confidence; tied confidences in input order)."""
    tb = torch.tensor(np.array(truth, dtype=np.float64).reshape(-1, 4))  # float64 here; box_iou does .float()
    tc = torch.tensor(np.array(tcls, dtype=np.float32).reshape(-1))
    d = np.array(dets, dtype=np.float64).reshape(-1, 6)
    conf = d[:, 4].astype(np.float32)
    order = np.argsort(-conf, kind="stable")
    d, conf = d[order], conf[order]
    pb = torch.tensor(d[:, :4])
    pc = torch.tensor(d[:, 5].astype(np.float32))
    pconf = torch.tensor(conf)
    return tb, tc, pb, pc, pconf


def ultralytics_current(images):
    from ultralytics.models.yolo.detect.val import DetectionValidator
    from ultralytics.utils.metrics import DetMetrics

    v = DetectionValidator.__new__(DetectionValidator)  # only iouv / niou are used by _process_batch
    v.iouv = torch.linspace(0.5, 0.95, 10)
    v.niou = v.iouv.numel()
    classes = sorted({int(c) for _, tc, _ in images for c in tc} | {int(d[5]) for _, _, ds in images for d in ds})
    metrics = DetMetrics(names={c: f"c{c}" for c in classes})
    for k, (truth, tcls, dets) in enumerate(images):
        tb, tc, pb, pc, pconf = as_tensors(truth, tcls, dets)
        pbatch = {"bboxes": tb, "cls": tc}
        predn = {"bboxes": pb, "cls": pc, "conf": pconf}
        cls = pbatch["cls"].cpu().numpy()
        no_pred = predn["cls"].shape[0] == 0
        metrics.update_stats(  # as DetectionValidator.update_metrics
            {
                **v._process_batch(predn, pbatch),
                "target_cls": cls,
                "target_img": np.unique(cls),
                "conf": np.zeros(0) if no_pred else predn["conf"].cpu().numpy(),
                "pred_cls": np.zeros(0) if no_pred else predn["cls"].cpu().numpy(),
                "im_name": f"{k}.png",
            }
        )
    metrics.process(plot=False)
    b = metrics.box
    return summarise_ultra(b.mp, b.mr, b.map50, b.map, b.all_ap, b.p_curve, b.r_curve, b.f1_curve, b.px,
                           b.prec_values, images)


def load_legacy(root):
    """exec the 8.3.0 sources of the functions we need."""
    ns = {"np": np, "torch": torch, "Path": Path, "math": __import__("math")}
    np_shim = type(sys)("np_shim")
    np_shim.__dict__.update(np.__dict__)
    np_shim.trapz = np.trapezoid
    ns["np"] = np_shim
    ns["plot_pr_curve"] = lambda *a, **k: None
    ns["plot_mc_curve"] = lambda *a, **k: None
    wanted = {"utils/metrics.py": ["box_iou", "smooth", "compute_ap", "ap_per_class"],
              "engine/validator.py": ["match_predictions"]}
    for rel, names in wanted.items():
        src = (Path(root) / "ultralytics" / rel).read_text()
        tree = ast.parse(src)
        found = {}
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef) and node.name in names and node.name not in found:
                node.decorator_list = []
                found[node.name] = ast.unparse(node)
        for n in names:
            exec(found[n], ns)
    return ns


def ultralytics_legacy(images, ns):
    class V:
        pass

    v = V()
    v.iouv = torch.linspace(0.5, 0.95, 10)
    v.niou = v.iouv.numel()
    stats = dict(tp=[], conf=[], pred_cls=[], target_cls=[], target_img=[])
    classes = sorted({int(c) for _, tc, _ in images for c in tc} | {int(d[5]) for _, _, ds in images for d in ds})
    names = {c: f"c{c}" for c in classes}
    for truth, tcls, dets in images:  # 8.3.0 DetectionValidator.update_metrics
        tb, tc, pb, pc, pconf = as_tensors(truth, tcls, dets)
        npr = len(dets)
        stat = dict(conf=torch.zeros(0), pred_cls=torch.zeros(0), tp=torch.zeros(npr, v.niou, dtype=torch.bool))
        cls, bbox = tc, tb
        nl = len(cls)
        stat["target_cls"] = cls
        stat["target_img"] = cls.unique()
        if npr == 0:
            if nl:
                for k in stats.keys():
                    stats[k].append(stat[k])
            continue
        stat["conf"] = pconf
        stat["pred_cls"] = pc
        if nl:
            # 8.3.0 _process_batch: iou = box_iou(gt_bboxes, detections[:, :4]); match_predictions(...)
            stat["tp"] = ns["match_predictions"](v, pc, cls, ns["box_iou"](bbox, pb))
        for k in stats.keys():
            stats[k].append(stat[k])
    # 8.3.0 get_stats
    stats = {k: torch.cat(x, 0).cpu().numpy() for k, x in stats.items()}
    stats.pop("target_img", None)
    if len(stats) and stats["tp"].any():
        (p, r, f1, all_ap, _, p_curve, r_curve, f1_curve, px, prec_values) = ns["ap_per_class"](
            stats["tp"], stats["conf"], stats["pred_cls"], stats["target_cls"], plot=True,
            save_dir=Path("/nonexistent"), names=names)[2:]
        mp = p.mean() if len(p) else 0.0
        mr = r.mean() if len(r) else 0.0
        map50 = all_ap[:, 0].mean() if len(all_ap) else 0.0
        mapall = all_ap.mean() if len(all_ap) else 0.0
        return summarise_ultra(mp, mr, map50, mapall, all_ap, p_curve, r_curve, f1_curve, px, prec_values, images)
    return summarise_ultra(0.0, 0.0, 0.0, 0.0, np.zeros((0, 10)), np.zeros((0, 1000)), np.zeros((0, 1000)),
                           np.zeros((0, 1000)), np.linspace(0, 1, 1000), np.zeros((0, 1000)), images,
                           f1_index=0)


def smooth(y, f):
    nf = round(len(y) * f * 2) // 2 + 1
    p = np.ones(nf // 2)
    yp = np.concatenate((p * y[0], y, p * y[-1]), 0)
    return np.convolve(yp, np.ones(nf) / nf, mode="valid")


def summarise_ultra(mp, mr, map50, mapall, all_ap, p_curve, r_curve, f1_curve, px, prec_values, images,
                    f1_index=None):
    all_ap = np.asarray(all_ap).reshape(-1, 10)
    p_curve, r_curve, f1_curve = (np.asarray(c).reshape(-1, 1000) for c in (p_curve, r_curve, f1_curve))
    prec_values = np.asarray(prec_values).reshape(-1, 1000)
    nc = len(all_ap)
    if f1_index is None:  # the index ap_per_class used (recomputed the same way: smooth(f1.mean(0), 0.1).argmax())
        f1_index = int(smooth(f1_curve.mean(0), 0.1).argmax()) if nc else 0
    def mean(a):
        return a.mean(0)

    return {
        "precision": float(mp),
        "recall": float(mr),
        "map50": float(map50),
        "map50_95": float(mapall),
        "ap_per_iou": [float(x) for x in (all_ap.mean(0) if nc else np.zeros(10))],
        "f1_conf": float(px[f1_index]),
        "precision_curve": mean(p_curve) if len(p_curve) else np.zeros(0),
        "recall_curve": mean(r_curve) if len(r_curve) else np.zeros(0),
        "f1_curve": mean(f1_curve) if len(f1_curve) else np.zeros(0),
        "pr_curve_map50": mean(prec_values) if len(prec_values) else np.zeros(0),
        "px": np.asarray(px),
        "n_truth": sum(len(t) for t, _, _ in images),
        "n_detections": sum(len(d) for _, _, d in images),
    }


def coco_reference(images):
    from pycocotools.coco import COCO
    from pycocotools.cocoeval import COCOeval

    classes = sorted({int(c) for _, tc, _ in images for c in tc} | {int(d[5]) for _, _, ds in images for d in ds})
    gt = {"images": [{"id": k + 1} for k in range(len(images))], "categories": [{"id": c} for c in classes],
          "annotations": []}
    res = []
    for k, (truth, tcls, dets) in enumerate(images):
        for b, c in zip(truth, tcls):
            w, h = b[2] - b[0], b[3] - b[1]
            gt["annotations"].append({"id": len(gt["annotations"]) + 1, "image_id": k + 1, "category_id": int(c),
                                      "bbox": [b[0], b[1], w, h], "area": w * h, "iscrowd": 0})
        for d in dets:
            res.append({"image_id": k + 1, "category_id": int(d[5]), "bbox": [d[0], d[1], d[2] - d[0], d[3] - d[1]],
                        "score": d[4]})
    with contextlib.redirect_stdout(io.StringIO()):
        cgt = COCO()
        cgt.dataset = gt
        cgt.createIndex()
        if res:
            cdt = cgt.loadRes(res)
        else:  # COCO.loadRes([]) raises IndexError (anns[0]); an empty result set built directly instead
            cdt = COCO()
            cdt.dataset = {"images": gt["images"], "categories": gt["categories"], "annotations": []}
            cdt.createIndex()
        e = COCOeval(cgt, cdt, "bbox")
        e.evaluate()
        e.accumulate()
        e.summarize()
    prec = e.eval["precision"][0, :, :, 0, 2]  # IoU 0.5, all recall thresholds, all classes, area all, 100 dets
    p50 = []
    for row in prec:
        ok = row[row > -1]
        p50.append(float(ok.mean()) if len(ok) else -1.0)
    return {"ap": float(e.stats[0]), "ap50": float(e.stats[1]), "ap75": float(e.stats[2]), "ar100": float(e.stats[8]),
            "precision_at_50": p50}


CURVE_SAMPLES = [0, 1, 100, 250, 400, 500, 600, 750, 900, 998, 999]


def runs(values):
    """Run-length encoding: [(value, count)]."""
    out = []
    for v in values:
        if out and out[-1][0] == v:
            out[-1][1] += 1
        else:
            out.append([v, 1])
    return out


def pinned_ultra(r):
    """The figures of one Ultralytics version that the Rust test pins: the scalars, and of each
    curve its length, mean and the values at CURVE_SAMPLES."""
    out = {k: float(r[k]) for k in ("precision", "recall", "map50", "map50_95", "f1_conf")}
    out["ap_per_iou"] = [float(x) for x in r["ap_per_iou"]]
    for c in ("precision_curve", "recall_curve", "f1_curve", "pr_curve_map50"):
        a = r[c]
        out[c] = {"len": len(a), "mean": float(a.mean()) if len(a) else 0.0,
                  "samples": [[i, float(a[i])] for i in CURVE_SAMPLES] if len(a) else []}
    return out


def toml_value(v):
    """A TOML value; a float as repr() writes it, the shortest text that reads back as the same
    double (Rust's parser reads it exactly; serde_json's, by default, only to within one unit in
    the last place: hence TOML), a NaN as nan."""
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(x)}" for k, x in v.items()) + " }"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, str):
        return json.dumps(v)  # a TOML basic string: the same escapes
    if isinstance(v, float):
        return repr(float(v))  # nan, inf and -inf are TOML's spellings too
    return str(int(v))


def fixture_toml(provenance, expected):
    """tests/fixtures/metrics/expected.toml: a [[case]] per case, its Ultralytics figures in
    [case.current] and [case.legacy], a figure one a line."""
    lines = [f"# {provenance}"]
    for case in expected:
        lines += ["", "[[case]]"]
        lines += [f"{k} = {toml_value(v)}" for k, v in case.items() if k not in ("current", "legacy")]
        for version in ("current", "legacy"):
            if version in case:
                lines += ["", f"[case.{version}]"]
                lines += [f"{k} = {toml_value(v)}" for k, v in case[version].items()]
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--legacy", help="folder of the unzipped ultralytics 8.3.0 wheel")
    ap.add_argument("--toml", help="write the pinned figures (TOML) here")
    args = ap.parse_args()
    import ultralytics
    import pycocotools
    print(f"numpy {np.__version__}, torch {torch.__version__}, ultralytics {ultralytics.__version__}, "
          f"pycocotools {importlib.metadata.version('pycocotools')}")
    legacy = load_legacy(args.legacy) if args.legacy else None
    provenance = (f"Generated by tests/reference/metrics_reference.py --toml, do not edit (pycocotools "
                  f"{importlib.metadata.version('pycocotools')}, ultralytics {ultralytics.__version__} and the "
                  f"8.3.0 sources, numpy {np.__version__}, torch {torch.__version__}): the cases of "
                  "crates/detect/src/metrics/cases.rs.")
    expected = []
    for name, images in CASES.items():
        cur = ultralytics_current(images)
        coco = coco_reference(images)
        print(f"== {name}: {cur['n_truth']} objects, {cur['n_detections']} detections, "
              f"input checksum {checksum(images)!r}")
        print(f"  COCO AP {coco['ap']:.6f} AP50 {coco['ap50']:.6f} AP75 {coco['ap75']:.6f} AR100 {coco['ar100']:.6f}")
        print(f"  Ultralytics {ultralytics.__version__}: P {cur['precision']:.6f} R {cur['recall']:.6f} "
              f"mAP50 {cur['map50']:.6f} mAP50-95 {cur['map50_95']:.6f} F1 conf {cur['f1_conf']:.6f}")
        leg = None
        if legacy is not None:
            leg = ultralytics_legacy(images, legacy)
            print(f"  Ultralytics 8.3.0: P {leg['precision']:.6f} R {leg['recall']:.6f} "
                  f"mAP50 {leg['map50']:.6f} mAP50-95 {leg['map50_95']:.6f} F1 conf {leg['f1_conf']:.6f}")
        case = {"name": name, "n_truth": cur["n_truth"], "n_detections": cur["n_detections"],
                "checksum": float(checksum(images)),
                "coco": {**{k: float(coco[k]) for k in ("ap", "ap50", "ap75", "ar100")},
                         "precision_at_50": [[float(v), n] for v, n in runs(coco["precision_at_50"])]},
                "current": pinned_ultra(cur)}
        if leg is not None:
            case["legacy"] = pinned_ultra(leg)
        expected.append(case)
    if args.toml:
        Path(args.toml).write_text(fixture_toml(provenance, expected))
        print(f"wrote {args.toml}")


if __name__ == "__main__":
    main()
