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

import cv2
import numpy as np

from benchmark.studies.derived_data import derive_dataset, source_view_twins
from viewadapt.geometry import elevation_homography
from viewadapt.warp import warp_to_source_view

src, out = Path(sys.argv[1]), Path(sys.argv[2])
cfg = json.loads((src / "dataset.json").read_text())
twin = source_view_twins(src)
Hinv = np.linalg.inv(elevation_homography(
    0.0, np.pi / 4, distance=float(cfg.get("distance", 10.0)),
    framing=str(cfg.get("framing", "plane"))))


def replace(r):
    z = twin(r)
    if z is None:
        return None
    img0 = cv2.imread(str(src / z["path"]), cv2.IMREAD_UNCHANGED)
    return warp_to_source_view(img0, Hinv)


n = derive_dataset(src, out, "pi/4 person crops replaced by the elevation-0 crops of the same "
                   "person, scene and instance warped through the person plane "
                   "(planar_positives.py)", replace)
print(n, "pi/4 person crops made planar")
