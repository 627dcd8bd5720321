"""One-off: adapted HOG - image warping of the same model on PETS, per grid phase and as the
mean over the phases, each with the paired 10-frame block bootstrap (the frames resampled
once for every phase of both; viewadapt.detect.evaluation.paired_groups_bootstrap).
argv: OUT.json NAME=detections.json [NAME=detections.json ...] (each holding hog_adapted and
hog_warp)"""
import json, sys
from pathlib import Path

import numpy as np

from benchmark.footage.run import open_clip
from viewadapt.detect.evaluation import evaluation_matches, matches_lamr, paired_groups_bootstrap

D = Path("../shared/data/pets09_s2l1_view001")
clip = open_clip([D / "img1"], D / "calibration/View_001.xml", D / "gt/gt.txt", D / "ignore.json")
frames = list(clip.stream)
truth = [clip.truth_of(f) for f in frames]
keys = [str(f.source) for f in frames]
size = clip.camera.image_size
res, A, W = {}, [], []
for arg in sys.argv[2:]:
    name, path = arg.split("=", 1)
    d = json.loads(Path(path).read_text())
    ma, mw = (evaluation_matches([np.asarray(d[m][k], float).reshape(-1, 5) for k in keys],
                                 truth, size, regions=clip.regions)[0]
              for m in ("hog_adapted", "hog_warp"))
    A.append(ma), W.append(mw)
    res[name] = dict(adapted=matches_lamr(ma), warping=matches_lamr(mw),
                     adapted_minus_warping=paired_groups_bootstrap([ma], [mw], block=10))
    print(name, res[name], flush=True)
res["mean_over_phases"] = dict(
    adapted=float(np.mean([r["adapted"] for r in res.values()])),
    warping=float(np.mean([r["warping"] for r in res.values()])),
    adapted_minus_warping=paired_groups_bootstrap(A, W, block=10))
print("mean", res["mean_over_phases"])
Path(sys.argv[1]).write_text(json.dumps(res, indent=1))
