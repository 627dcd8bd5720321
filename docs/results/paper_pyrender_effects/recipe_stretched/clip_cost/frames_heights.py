"""One-off: where on rendered frames a source detector's misses fall, by person height.

``python frames_heights.py DATA RUN_A RUN_B [METHOD]``: two ``viewadapt bench frames`` runs
on the same frames of ``DATA`` (e.g. the shipped models and a recipe's), one method
(default ``hog_adapted``); prints, at 0.1 and 1 false positives per image, each run's miss
rate per box-height band and its false positives, by the clip's error breakdown
(:func:`benchmark.footage.errors.error_breakdown`: the Caltech matching of
:mod:`viewadapt.detect.evaluation`, no ignore regions), so that rendered frames can be read
the way ``bench footage`` reads the real clip (``errors.md``).
"""
import json
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from benchmark.footage.errors import error_breakdown
from benchmark.frames.methods import load_frames

data, runs = Path(sys.argv[1]), [Path(sys.argv[2]), Path(sys.argv[3])]
method = sys.argv[4] if len(sys.argv) > 4 else "hog_adapted"
frames = {f"{f.path.name}@{f.scene_id}": f for f in load_frames(data)}
sizes = {tuple(f.camera.image_size) for f in frames.values()}
assert len(sizes) == 1, sizes
size = sizes.pop()
print(f"{data}: {len(frames)} frames of {size[0]}x{size[1]}, method {method}")
for fppi in (0.1, 1.0):
    print(f"\nat {fppi:g} FPPI:\n\n| run | threshold | miss rate | per height band (px): "
          "missed/counted | false positives (background) |\n|---|---|---|---|---|")
    for run in runs:
        stored = json.loads((run / "detections.json").read_text())[method]
        names = list(stored)
        dets = [np.asarray(stored[n], float).reshape(-1, 5) for n in names]
        truth = [SimpleNamespace(boxes=frames[n].gt, occlusion=frames[n].occlusion,
                                 ignore=np.zeros(len(frames[n].gt), bool))
                 for n in names]
        r = error_breakdown(dets, truth, size, fppi=fppi)
        bands = "; ".join(f"{lo:g}-{hi:g}: {m}/{c}" for lo, hi, c, m in r["height_bands"] if c)
        print(f"| {run.name} | {r['threshold']:.3f} | {r['missed'] / r['counted']:.3f} "
              f"({r['missed']}/{r['counted']}) | {bands} | {r['false_positives']} "
              f"({r['background']}) |")
