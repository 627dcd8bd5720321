"""One-off: OpenCV's own detectMultiScale baselines on the PETS clip with every frame shifted
by (dx, dy) whole native pixels, dx, dy in 0..n-1 (the frame on a canvas dx, dy px larger,
its first columns and rows replicated, nothing of it cut; boxes shifted back): at 2x
upsampling one native pixel is a quarter of detectMultiScale's 8-px stride at its finest level, so the n x n shifts sample the phase of its window grid as
FrameDetector's grid_phase samples ours. The bench footage runner's methods (FrameMethods:
opencv_detect, ground_plane_filter through the lens), the clip's protocol. Each shift paired
with shift (0, 0) (10-frame block bootstrap); per-frame detections saved.
argv: OUT_DIR n method...; environment SHIFTS="dx,dy;dx,dy;..." runs those shifts instead
(the first paired with the others); VOTE=tau: box voting after the NMS (--box-voting)."""
import json, os, sys
from pathlib import Path

import cv2
import numpy as np

import benchmark.footage.run as fr
from benchmark.frames.methods import FrameMethods, opencv_detect
from benchmark.frames.runtime import single_thread
from benchmark.frames.spec import FrameMethod
from viewadapt.detect.evaluation import evaluation_matches, matches_lamr, paired_groups_bootstrap
from viewadapt.io import SourceDetectors, shipped_model_path

D = Path("../shared/data/pets09_s2l1_view001")
out, n, names = Path(sys.argv[1]), int(sys.argv[2]), sys.argv[3:]
out.mkdir(parents=True, exist_ok=True)
methods = [FrameMethod.parse(x) for x in names]
clip = fr.open_clip([D / "img1"], D / "calibration/View_001.xml", D / "gt/gt.txt",
                    D / "ignore.json")
fm = FrameMethods(clip.camera, SourceDetectors.load(shipped_model_path()),
                  person_heights=(1.75,), lens=np.asarray(clip.dist).tolist())
frames, truth = [], []
for f in clip.stream:
    frames.append(f.image)
    truth.append(clip.truth_of(f))
size = clip.camera.image_size
res, matches = {}, {}
shifts = [(dx, dy) for dx in range(n) for dy in range(n)]
if os.environ.get("SHIFTS"):     # "0,0;8,0": these shifts instead, the first the reference
    shifts = [tuple(int(v) for v in p.split(",")) for p in os.environ["SHIFTS"].split(";")]
with single_thread():
    for dx, dy in shifts:
        dets = {m: [] for m in methods}
        for im in frames:
            # the frame whole on a canvas dx, dy px larger, its first rows and columns
            # replicated (shifting within the frame instead cuts persons at the far
            # border: at 8 px that cost OpenCV 2x with the filter +0.07)
            shifted = cv2.copyMakeBorder(im, dy, 0, dx, 0, cv2.BORDER_REPLICATE)
            raw = {}
            for m in methods:
                base = FrameMethod.parse(m.name.replace("[ground]", ""))
                if base not in raw:    # the unfiltered boxes, shifted back
                    d = opencv_detect(shifted, upsample=base.upsample, detector=base.kind,
                                      vote=float(os.environ.get("VOTE", 0)))
                    d = d.copy()
                    d[:, 0] -= dx
                    d[:, 1] -= dy
                    raw[base] = d
                d = fm.on_ground(raw[base]) if m.ground else raw[base]
                dets[m].append(np.asarray(d, np.float64).reshape(-1, 5))
        for m in methods:
            mt, _ = evaluation_matches(dets[m], truth, size, regions=clip.regions)
            matches.setdefault(m.name, []).append(mt)
            r = dict(shift=[dx, dy], lamr=matches_lamr(mt))
            if len(matches[m.name]) > 1:
                r["minus_no_shift"] = paired_groups_bootstrap([mt], [matches[m.name][0]],
                                                              block=10)
            res.setdefault(m.name, []).append(r)
            print(m.name, r, flush=True)
            (out / f"det_{m.name}_{dx}_{dy}.json").write_text(
                json.dumps([d.tolist() for d in dets[m]]))
        (out / "shifts.json").write_text(json.dumps(res, indent=1))
summary = {k: dict(mean=float(np.mean([r["lamr"] for r in v])),
                   sd=float(np.std([r["lamr"] for r in v], ddof=1)),
                   min=float(min(r["lamr"] for r in v)), max=float(max(r["lamr"] for r in v)))
           for k, v in res.items()}
print(json.dumps(summary, indent=1))
(out / "shifts.json").write_text(json.dumps(dict(shifts=res, summary=summary), indent=1))
