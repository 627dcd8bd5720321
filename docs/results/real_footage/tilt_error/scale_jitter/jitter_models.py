"""One-off: HOG source models of the effects render (dsfx, seed 0) whose positives are each scaled about the
person's feet by a random factor, log-uniform within +-8 % (borders reflected), or with the argument `up`
within [1, 1.08] only (a larger person: no border needed), C = 0.001, seeds 0-2 (no ACF)."""
from pathlib import Path
import cv2
import numpy as np
from benchmark.data import load_dataset
from benchmark.crops.features import background_windows, person_windows
from viewadapt.detect import train_on_windows
from viewadapt.geometry import WINDOW_FEET

def jitter(img, s):
    fx, fy = WINDOW_FEET
    M = np.array([[s, 0, fx - s * fx], [0, s, fy - s * fy]], np.float64)
    return cv2.warpAffine(img, M, (img.shape[1], img.shape[0]), flags=cv2.INTER_LINEAR,
                          borderMode=cv2.BORDER_REFLECT_101)

import sys
UP = sys.argv[1:] == ["up"]     # up: factors in [1, 1.08] only (no reflected border)
out = Path("/tmp/s12/models"); out.mkdir(exist_ok=True)   # where the runs wrote them
fx = load_dataset(Path("/tmp/exp/dsfx"))
pos = list(person_windows(fx, 0).images(fx.root))
rng = np.random.default_rng(12345)
scales = np.exp(rng.uniform(0.0, np.log(1.08), len(pos))) if UP else np.exp(rng.uniform(-np.log(1.08), np.log(1.08), len(pos)))
pos = [jitter(p, s) for p, s in zip(pos, scales)]
neg = list(background_windows(fx, 0, stride=16).images(fx.root))
print(len(pos), len(neg), flush=True)
for seed in (0, 1, 2):
    f = out / (f"p0n0jitup_s{seed}.npz" if UP else f"p0n0jit_s{seed}.npz")
    train_on_windows(pos, neg, seed=seed, frame_view="both", svm_params={"C": 0.001},
                     acf_members=0).save(f)
    print(f, flush=True)
