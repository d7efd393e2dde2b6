"""Independent survey-like frames from SatSim (AFRL's simulator, not soig's renderer; issue #44):
stars trailed at one common angle (a slewing sensor, 50-150 px trails), one debris line each at a
random angle (30% within 5 deg of the trails), per-pixel SNR 1-5 at the streak's core, soig's
default sensor as ../shared/design/independent-frames.md matches it. The FITS carry no WCS.
Writes OUT/frame_NNN.fits and OUT/truth.json (streak ends in px, x = column, y = row; the angle
to the trails). Checked: the debris lies on its predicted segment, ends included, and the trail
angle is measured from +x towards +y, as `soig detect --star-trail-angle-deg` takes it.

    python3 -m venv .venv-satsim && .venv-satsim/bin/pip install satsim numpy astropy
    .venv-satsim/bin/python scripts/independent/satsim_frames.py OUT N SEED [SNR_PX] [--near FRAC]
    soig detect OUT/*.fits --out DET --psf-fwhm-px 3.34
    python3 scripts/independent/score.py DET/detections.csv OUT/truth.json

`--near FRAC` raises the share of debris within 5 deg of the trails (default 0.3) for development
sets; the random draws are the same as without it, so a seed's default set is unchanged.
Not in CI (TensorFlow, 3 GB); about 5 s a frame here. The frames are not committed.
"""
import json, math, os, sys, shutil
import numpy as np
from satsim.satsim import image_generator
from astropy.io import fits as afits
near_frac = 0.3
if "--near" in sys.argv:
    k = sys.argv.index("--near")
    near_frac = float(sys.argv[k + 1])
    del sys.argv[k:k + 2]
out, n, seed = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
os.makedirs(out, exist_ok=True)
rng = np.random.default_rng(seed)
bins = [9, 10, 11, 12, 13, 14, 15, 16, 16.5]
dens = [3.75, 8.75, 46.25, 82.5, 162.5, 356.25, 722.5, 562.5]
truth = []
for i in range(n):
    trail_deg = float(rng.uniform(0, 180))
    trail_px_s = float(rng.uniform(10, 30))  # trails 50-150 px in 5 s
    near = rng.random() < near_frac
    off = float(rng.uniform(0.5, 5) * rng.choice([-1, 1])) if near else float(rng.uniform(5, 90) * rng.choice([-1, 1]))
    deb_deg = trail_deg + off
    length = float(rng.uniform(150, 600))
    speed = length / 5.0
    th = math.radians(deb_deg)
    # SatSim's [row, col], normalised origin; x = col, y = row
    vc, vr = speed * math.cos(th), speed * math.sin(th)
    c0 = float(rng.uniform(0.2, 0.8)) * 1024 - vc * 2.5
    r0 = float(rng.uniform(0.2, 0.8)) * 1024 - vr * 2.5
    # Per-pixel SNR at the streak's core 1-5: signal per px = pe * 5 s / (length * sqrt(2 pi) sigma),
    # sigma 1.42 px; noise sqrt(320 e sky + 8^2 read) = 19.6 e.
    snr_px = float(rng.uniform(1, 5)) if len(sys.argv) < 5 else float(sys.argv[4])
    pe = snr_px * 19.6 * length * math.sqrt(2 * math.pi) * 1.42 / 5.0
    thr = math.radians(trail_deg)
    ssp = {
        "version": 1,
        "sim": {"mode": "fftconv2p", "spacial_osf": 3, "temporal_osf": 100, "padding": 100,
                "samples": 1, "enable_shot_noise": True, "save_jpeg": False, "save_movie": False,
                "seed": int(seed * 1000 + i)},
        "fpa": {"height": 1024, "width": 1024, "y_fov": 0.2, "x_fov": 0.2,
                "dark_current": {"$sample": "random.lognormal", "mean": -1, "sigma": 1, "size": [1024, 1024], "seed": 7},
                "gain": 1, "bias": 0, "zeropoint": 22.26,
                "a2d": {"response": "linear", "fwc": 100000, "gain": 1.6, "bias": 100},
                "noise": {"read": 8, "electronic": 0},
                "psf": {"mode": "gaussian", "eod": 0.07553},
                "time": {"exposure": 5, "gap": 0}, "num_frames": 1},
        "background": {"stray": {"mode": "none"}, "galactic": 16.98},
        "geometry": {
            "stars": {"mode": "bins", "mv": {"bins": bins, "density": dens},
                      "motion": {"mode": "affine-polar", "rotation": 0, "translation": [trail_deg, trail_px_s]}},
            "obs": {"mode": "list", "list": [{"mode": "line", "origin": [r0 / 1024, c0 / 1024],
                                              "velocity": [vr, vc], "pe": pe}]}},
    }
    d = os.path.join(out, f"tmp{i}")
    img = next(iter(image_generator(ssp, d, with_meta=False, num_sets=1)))
    afits.PrimaryHDU(np.asarray(img).astype(np.uint16)).writeto(os.path.join(out, f"frame_{i:03d}.fits"), overwrite=True)
    shutil.rmtree(d, ignore_errors=True)
    truth.append({"file": f"frame_{i:03d}.fits", "start_xy": [c0, r0], "end_xy": [c0 + vc * 5, r0 + vr * 5],
                  "trail_deg": trail_deg, "debris_deg": deb_deg, "off_deg": off, "pe_per_s": pe, "snr_px": snr_px})
    print(i, json.dumps(truth[-1]), flush=True)
json.dump(truth, open(os.path.join(out, "truth.json"), "w"), indent=1)
