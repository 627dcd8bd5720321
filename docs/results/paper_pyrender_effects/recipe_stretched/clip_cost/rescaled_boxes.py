"""One-off: a ``bench footage`` run's boxes rescaled about their feet points, evaluated again.

``python rescaled_boxes.py RUN FACTOR METHOD CLIP_ARGS...`` (CLIP_ARGS: the clip's frames,
``--calibration``, ``--boxes``, ``--ignore`` as ``bench footage`` reads them): every stored
box of ``METHOD`` in ``RUN/detections.json`` becomes ``FACTOR`` times as tall and as wide
about its bottom centre (the feet point stays), scores kept, and is evaluated as the run
was (:func:`viewadapt.detect.evaluation.evaluation_summary`: LAMR with its block-bootstrap
interval; :func:`benchmark.footage.errors.error_breakdown` at 1 FPPI by box height). A run
that scanned for a shorter person (``--heights``) then has boxes of the usual person's size,
so its evaluation no longer also measures the boxes' size. FACTOR 1 reproduces the run.
"""
import argparse
import json
from pathlib import Path

import numpy as np

from benchmark.footage.errors import error_breakdown
from benchmark.footage.run import add_clip_arguments, open_clip, stored_detections
from viewadapt.detect.evaluation import evaluation_summary

ap = argparse.ArgumentParser()
ap.add_argument("run", type=Path)
ap.add_argument("factor", type=float)
ap.add_argument("method")
add_clip_arguments(ap)
args = ap.parse_args()
stored = json.loads((args.run / "detections.json").read_text())[args.method]
clip = open_clip(args.inputs, args.calibration, args.boxes, args.ignore)
keys = list(stored)
truth = clip.stored_truth(keys)
dets = []
for d in stored_detections(stored, keys):
    d = d.copy()
    cx, bottom = d[:, 0] + d[:, 2] / 2, d[:, 1] + d[:, 3]
    d[:, 2:4] *= args.factor
    d[:, 0], d[:, 1] = cx - d[:, 2] / 2, bottom - d[:, 3]
    dets.append(d)
size = clip.camera.image_size
ev, _ = evaluation_summary(dets, truth, size, regions=clip.regions)
r = error_breakdown(dets, truth, size, regions=clip.regions, fppi=1.0)
bands = "; ".join(f"{lo:g}-{hi:g}: {m}/{c}" for lo, hi, c, m in r["height_bands"] if c)
print(f"| {args.run.name} x{args.factor:g} | {ev['lamr']:.3f} ({ev['lamr_ci95'][0]:.3f}-"
      f"{ev['lamr_ci95'][1]:.3f}) | {r['missed'] / r['counted']:.3f} | {bands} | "
      f"{r['false_positives']} ({r['duplicates']} duplicates, {r['background']} background) |")
