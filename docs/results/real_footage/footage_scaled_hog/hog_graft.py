"""The shipped models with their HOG/SVM retrained under another recipe (docs/training.md
point 68): usage ``python hog_graft.py RECIPE OUT.npz DATA0 DATA1``.

The shipped file is the average of the `averaged`-recipe models of two renders (training.md
point 42). This trains the HOG/SVM alone on each render (``train_source_detectors(...,
acf=False)``: the recipe's windows, the shipped frame-view copies, the recipe's C, seed 0),
averages the two weight vectors and biases, and writes the shipped file with its HOG
replaced (its ACF model untouched), the HOG's training records under
``training["hog_grafted"]``."""
import sys
from dataclasses import replace

import numpy as np

from benchmark.data import load_dataset
from benchmark.frames.methods import DEFAULT_FRAME_VIEW, train_source_detectors
from viewadapt.io.models import SourceDetectors, shipped_model_path

recipe, out, *datas = sys.argv[1:]
shipped = SourceDetectors.load(shipped_model_path())
frame_view = shipped.training.get("average_of", [{}])[0].get("frame_view", DEFAULT_FRAME_VIEW)
ws, bs, records = [], [], []
for d in datas:
    m = train_source_detectors(load_dataset(d), recipe=recipe, frame_view=frame_view, acf=False)
    ws.append(np.asarray(m.hog_weights, float))
    bs.append(float(m.hog_bias))
    records.append(dict(m.training, data=str(d)))
    print(d, "crops", m.training.get("crops"), "background windows",
          m.training.get("background_windows"), flush=True)
graft = replace(shipped, hog_weights=np.mean(ws, axis=0), hog_bias=float(np.mean(bs)),
                training=dict(shipped.training, hog_grafted=records))
graft.save(out)
print("wrote", out, "frame_view", frame_view)
