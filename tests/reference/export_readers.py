"""Reads soig's exports with their own libraries, for tests/export.rs.

    export_readers.py coco GT.json DETECTIONS.json
        pycocotools: COCO(GT), loadRes(DETECTIONS), COCOeval 'bbox'; prints the dataset's counts
        and stats[0], [1], [2], [8] (AP, AP50, AP75, AR100) as JSON.
    export_readers.py regions FILE.reg ...
        astropy-regions: Regions.read(FILE, format='ds9') for each file; prints each region's
        kind and coordinates (0-based pixels, as regions converts DS9's 1-based `image`) as JSON.

Needs the project's .venv (scripts/setup.sh installs pycocotools and regions).
"""
import contextlib
import io
import json
import sys


def coco(gt_path, dt_path):
    from pycocotools.coco import COCO
    from pycocotools.cocoeval import COCOeval

    with contextlib.redirect_stdout(io.StringIO()):
        gt = COCO(gt_path)
        dt = gt.loadRes(dt_path) if json.load(open(dt_path)) else None
        stats = [-1.0] * 12
        if dt is not None:
            e = COCOeval(gt, dt, "bbox")
            e.evaluate()
            e.accumulate()
            e.summarize()
            stats = [float(s) for s in e.stats]
    return {
        "images": len(gt.getImgIds()),
        "annotations": len(gt.getAnnIds()),
        "categories": [c["name"] for c in gt.loadCats(gt.getCatIds())],
        "ap": stats[0],
        "ap50": stats[1],
        "ap75": stats[2],
        "ar100": stats[8],
    }


def regions(paths):
    from regions import Regions

    out = {}
    for p in paths:
        shapes = []
        for r in Regions.read(p, format="ds9"):
            kind = type(r).__name__
            if kind == "LinePixelRegion":
                xy = [r.start.x, r.start.y, r.end.x, r.end.y]
            elif kind == "RectanglePixelRegion":
                xy = [r.center.x, r.center.y, r.width, r.height, r.angle.value]
            elif kind == "PolygonPixelRegion":
                xy = [v for pair in zip(r.vertices.x, r.vertices.y) for v in pair]
            else:
                xy = []
            shapes.append({"kind": kind, "xy": [float(v) for v in xy],
                           "text": str(r.meta.get("text", ""))})
        out[p] = shapes
    return out


if __name__ == "__main__":
    if sys.argv[1] == "coco":
        print(json.dumps(coco(sys.argv[2], sys.argv[3])))
    else:
        print(json.dumps(regions(sys.argv[2:])))
