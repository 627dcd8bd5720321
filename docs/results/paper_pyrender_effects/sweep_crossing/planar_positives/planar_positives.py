"""One-off: the effects render with its pi/4 persons made exactly planar.

``python planar_positives.py SRC OUT``: a dataset linked file by file to SRC (a rendered
dataset; :func:`benchmark.studies.derived_data.derive_dataset`), except that every person
crop at pi/4 is replaced by the elevation-0 crop of the same person, scene and instance
warped into the pi/4 view through the person plane -- ``out(q) = crop0(H^-1 q)``,
``H = elevation_homography(0, pi/4)``, borders replicated: the windows synthesised training
trains on. Everything else (the elevation-0 crops the source detector trains on, every
background) is SRC's own, so a sweep on OUT has the same fold models and negatives as on
SRC; only the test persons' geometry differs (a plane instead of a rendered body, with the
rendered appearance of the elevation-0 view).
"""
import json
import sys
from pathlib import Path

import numpy as np

from benchmark.studies.derived_data import derive_from_source_view
from viewadapt.geometry import elevation_homography
from viewadapt.warp import warp_to_source_view

src, out = Path(sys.argv[1]), Path(sys.argv[2])
cfg = json.loads((src / "dataset.json").read_text())
Hinv = np.linalg.inv(elevation_homography(
    0.0, np.pi / 4, distance=float(cfg.get("distance", 10.0)),
    framing=str(cfg.get("framing", "plane"))))


n = derive_from_source_view(src, out, "pi/4 person crops replaced by the elevation-0 crops of "
                            "the same person, scene and instance warped through the person "
                            "plane (planar_positives.py)",
                            lambda img0, twin, row: warp_to_source_view(img0, Hinv))
print(n, "pi/4 person crops made planar")
