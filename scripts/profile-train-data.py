"""Where a training epoch's time goes on CPU at 1024 px (models/README.md): PNG decode per image,
one augmented training sample (decode + mosaic + Ultralytics' augmentation) uncached and with
cache=ram, and YOLOv8n forward+backward per image. Usage: python profile-train-data.py RUN_DIR
(a soig output with data.yaml)."""
import os, sys, time, glob
os.environ["YOLO_OFFLINE"]="1"
import cv2
root=sys.argv[1]
pngs=sorted(glob.glob(root+"/images/train/*.png"))[:16]
t=time.time()
for p in pngs: im=cv2.imread(p)
dec=(time.time()-t)/len(pngs)
from ultralytics.data.build import build_yolo_dataset
from ultralytics.cfg import get_cfg
from ultralytics.data.utils import check_det_dataset
data=check_det_dataset(root+"/data.yaml")
res={}
for cache in (False,"ram"):
    cfg=get_cfg(overrides={"imgsz":1024,"cache":cache,"data":root+"/data.yaml"})
    ds=build_yolo_dataset(cfg, data["train"], 16, data, mode="train", stride=32)
    t=time.time(); n=0
    for i in range(32): ds[i % len(ds)]; n+=1
    res[cache]=(time.time()-t)/n
import torch
from ultralytics import YOLO
torch.set_num_threads(2)
m=YOLO("yolov8n.yaml").model.train()
x=torch.randn(4,3,1024,1024)
t=time.time()
for _ in range(2):
    out=m(x); out=out.values() if isinstance(out, dict) else out; s=sum(o.sum() for o in out if hasattr(o, "sum")); s.backward()
fb=(time.time()-t)/2/4
print(f"png decode {dec*1000:.1f} ms/img; train sample (decode+mosaic+aug) cache=False {res[False]*1000:.1f} ms, cache=ram {res['ram']*1000:.1f} ms; yolov8n fwd+bwd CPU 2 threads {fb*1000:.0f} ms/img")
