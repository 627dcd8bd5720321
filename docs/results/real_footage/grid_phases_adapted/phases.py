"""One-off: the adapted detectors' LAMR on the PETS clip at each of n x n grid phases of the
candidate windows (benchmark.frames.phases.grid_phases; FrameDetector's grid_phase), the
bench footage runner otherwise, shipped models; each phase paired with the default grid
(10-frame block bootstrap). No image warping (18 min a phase). argv: OUT.json n method...
Environment: STRIDE=F,L runs with that ground stride (FrameDetector's ground_stride)."""
import os
import json, sys
from pathlib import Path

import numpy as np

import benchmark.footage.run as fr
from benchmark.frames.phases import grid_phases
from benchmark.frames.spec import FrameMethod
from viewadapt.detect.evaluation import evaluation_matches, matches_lamr, paired_groups_bootstrap
from viewadapt.io import SourceDetectors, shipped_model_path

D = Path("../shared/data/pets09_s2l1_view001")
out_path, n, names = Path(sys.argv[1]), int(sys.argv[2]), sys.argv[3:]
methods = [FrameMethod.parse(x) for x in names]
models = SourceDetectors.load(shipped_model_path())
res, matches = {}, {}
for ph in grid_phases(n):
    clip = fr.open_clip([D / "img1"], D / "calibration/View_001.xml", D / "gt/gt.txt",
                        D / "ignore.json")
    stride = os.environ.get("STRIDE")
    run = fr.run_footage(clip, methods, models, heights=(1.75,), grid_phase=ph,
                         ground_stride=None if stride is None
                         else [float(v) for v in stride.split(",")])
    size = clip.camera.image_size
    for m in methods:
        mt, _ = evaluation_matches(run.detections[m], run.truth, size, regions=clip.regions)
        matches.setdefault(m.name, []).append(mt)
        r = dict(phase=list(ph), lamr=matches_lamr(mt),
                 fps=run.n_frames / run.seconds[m])
        if len(matches[m.name]) > 1:
            r["minus_default_grid"] = paired_groups_bootstrap([mt], [matches[m.name][0]], block=10)
        res.setdefault(m.name, []).append(r)
        print(m.name, r, flush=True)
    out_path.write_text(json.dumps(res, indent=1))
summary = {k: dict(mean=float(np.mean([r["lamr"] for r in v])),
                   sd=float(np.std([r["lamr"] for r in v], ddof=1)),
                   min=float(min(r["lamr"] for r in v)), max=float(max(r["lamr"] for r in v)))
           for k, v in res.items()}
print(json.dumps(summary, indent=1))
out_path.write_text(json.dumps(dict(phases=res, summary=summary), indent=1))
