"""One-off: adapted OpenCV over its 16 grid phases against OpenCV 2x with the ground-plane
filter over its 16 frame shifts (shifts.py's saved detections), both means, paired: every
phase and shift of both sides on the same resampled 10-frame blocks
(paired_groups_bootstrap). Also each side's default against the other's mean.
argv: SHIFTS_DIR OUT.json; environment VOTE=tau: the adapted detector's boxes voted
(--box-voting; the shifts' detections voted alike by shifts.py VOTE=tau)."""
import json, os, sys
from pathlib import Path

import numpy as np

import benchmark.footage.run as fr
from benchmark.frames.phases import grid_phases
from benchmark.frames.spec import FrameMethod
from viewadapt.detect.evaluation import evaluation_matches, matches_lamr, paired_groups_bootstrap
from viewadapt.io import SourceDetectors, shipped_model_path

D = Path("../shared/data/pets09_s2l1_view001")
shifts_dir, out = Path(sys.argv[1]), Path(sys.argv[2])
m = FrameMethod.parse("opencv_adapted")
models = SourceDetectors.load(shipped_model_path())
adapted = []
for ph in grid_phases(4):
    clip = fr.open_clip([D / "img1"], D / "calibration/View_001.xml", D / "gt/gt.txt",
                        D / "ignore.json")
    run = fr.run_footage(clip, [m], models, heights=(1.75,), grid_phase=ph,
                         box_voting=float(os.environ.get("VOTE", 0)))
    mt, _ = evaluation_matches(run.detections[m], run.truth, clip.camera.image_size,
                               regions=clip.regions)
    adapted.append(mt)
    truth, size, regions = run.truth, clip.camera.image_size, clip.regions
base = []
for dx in range(4):
    for dy in range(4):
        d = json.loads((shifts_dir / f"det_opencv_2x[ground]_{dx}_{dy}.json").read_text())
        mt, _ = evaluation_matches([np.asarray(x).reshape(-1, 5) for x in d], truth, size,
                                   regions=regions)
        base.append(mt)
res = dict(adapted_phase_lamr=[matches_lamr(x) for x in adapted],
           baseline_shift_lamr=[matches_lamr(x) for x in base],
           means_paired=paired_groups_bootstrap(adapted, base, block=10),
           defaults_paired=paired_groups_bootstrap(adapted[:1], base[:1], block=10),
           adapted_mean_minus_baseline_default=paired_groups_bootstrap(adapted, base[:1],
                                                                       block=10))
print(json.dumps({k: v for k, v in res.items() if "lamr" not in k}, indent=1))
out.write_text(json.dumps(res, indent=1))
