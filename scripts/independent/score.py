"""Score soig detect's detections.csv against gen.py's truth.json: a detection at conf >= 0.5
is a hit when its box has IoU >= 0.5 with the streak's box (the segment's bounding box widened
by 2.6 sigma = 3.7 px, where 99% of a Gaussian line's cross-section lies)."""
import csv, json, os, sys
dets, truth = sys.argv[1], json.load(open(sys.argv[2]))
by = {}
for r in csv.DictReader(open(dets)):
    if float(r["confidence"]) >= 0.5:
        by.setdefault(os.path.basename(r["file"]), []).append([float(r[k]) for k in ("x1", "y1", "x2", "y2")])
def iou(a, b):
    w = min(a[2], b[2]) - max(a[0], b[0]); h = min(a[3], b[3]) - max(a[1], b[1])
    if w <= 0 or h <= 0: return 0.0
    i = w * h
    return i / ((a[2]-a[0])*(a[3]-a[1]) + (b[2]-b[0])*(b[3]-b[1]) - i)
pad = 3.7
near = [0, 0]; far = [0, 0]; fp = 0; boxes = 0
for t in truth:
    (x0, y0), (x1, y1) = t["start_xy"], t["end_xy"]
    box = [max(0, min(x0, x1) - pad), max(0, min(y0, y1) - pad), min(1024, max(x0, x1) + pad), min(1024, max(y0, y1) + pad)]
    ds = by.get(t["file"], [])
    boxes += len(ds)
    hits = [d for d in ds if iou(d, box) >= 0.5]
    fp += len(ds) - min(len(hits), 1)
    band = near if abs(t["off_deg"]) < 5 else far
    band[0] += 1; band[1] += bool(hits)
tp = near[1] + far[1]
print(f"{len(truth)} frames: recall within 5 deg {near[1]}/{near[0]}, beyond {far[1]}/{far[0]}; "
      f"false boxes {fp}; precision {tp / max(tp + fp, 1):.3f} (conf >= 0.5, IoU >= 0.5)")
