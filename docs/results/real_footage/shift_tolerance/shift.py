"""One-off: how fast each detector's score falls when its window slides sideways off an
annotated person (PETS, every 10th frame, counted persons >= 60 px tall): windows framing
each ground-truth box as the canonical window frames a person (96 px tall, feet at
WINDOW_FEET), shifted by d canonical px, scored by image warping (warp_scores) with OpenCV's
INRIA SVM and the shipped HOG. Scores as z against 3000 random windows of the same frames.
Prints per shift the mean z over persons and its ratio to the unshifted mean."""
import json
from pathlib import Path

import numpy as np

from benchmark.footage.run import open_clip
from benchmark.frames.methods import warp_scores
from viewadapt.detect.windows import WINDOW_FEET, WINDOW_HEAD
from viewadapt.io import SourceDetectors, shipped_model_path

D = Path("../shared/data/pets09_s2l1_view001")
clip = open_clip([D / "img1"], D / "calibration/View_001.xml", D / "gt/gt.txt", D / "ignore.json",
                 every=10)
models = SourceDetectors.load(shipped_model_path())
SHIFTS = np.arange(-12, 13, 2)
rng = np.random.default_rng(0)
per = {k: [] for k in ("opencv", "hog")}
bg = {k: [] for k in per}
n_person = 0
for frame in clip.stream:
    img = frame.image
    t = clip.truth_of(frame)
    boxes = np.asarray(t.boxes, float).reshape(-1, 4)
    ign = np.asarray(t.ignore, bool) if t.ignore is not None else np.zeros(len(boxes), bool)
    Hs = []
    for (x, y, w, h), bad in zip(boxes, ign):
        if bad or h < 60 or x < 40 or x + w > img.shape[1] - 40:
            continue
        s = h / (WINDOW_FEET[1] - WINDOW_HEAD[1])
        cx = x + w / 2
        for d in SHIFTS:
            Hs.append([[s, 0, cx - s * (WINDOW_FEET[0] + d)], [0, s, y + h - s * WINDOW_FEET[1]],
                       [0, 0, 1]])
    n = len(Hs) // len(SHIFTS)
    n_person += n
    Hb = []
    for _ in range(200):
        s = rng.uniform(0.6, 1.3)
        Hb.append([[s, 0, rng.uniform(0, img.shape[1] - 64 * s)],
                   [0, s, rng.uniform(0, img.shape[0] - 128 * s)], [0, 0, 1]])
    for k in per:
        if n:
            per[k].append(warp_scores(img, np.array(Hs, float), models, k).reshape(n, len(SHIFTS)))
        bg[k].append(warp_scores(img, np.array(Hb, float), models, k))
out = {"persons": n_person, "shifts": SHIFTS.tolist()}
for k in per:
    P = np.concatenate(per[k])
    B = np.concatenate(bg[k])
    z = (P - B.mean()) / B.std()
    m = z.mean(0)
    out[k] = dict(mean_z=m.round(3).tolist(), ratio=(m / m[SHIFTS == 0][0]).round(3).tolist(),
                  best_shift_sd=float(SHIFTS[np.argmax(z, 1)].std()))
    print(k, out[k])
Path(__file__).with_suffix(".json").write_text(json.dumps(out, indent=1))
