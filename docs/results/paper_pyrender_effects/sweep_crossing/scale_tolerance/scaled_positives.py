"""One-off: the effects render with its pi/4 persons replaced by elevation-0 persons scaled.

``python scaled_positives.py SRC OUT K``: a dataset linked file by file to SRC (a rendered
dataset), except that every person crop at pi/4 is replaced by the elevation-0 crop of the
same person, scene and instance scaled vertically by ``K`` about the window's middle row
(63.5): ``out(x, y) = crop0(x, 63.5 + (y - 63.5) / K)``, bilinear, the border replicated
(``K < 1`` reads rows beyond the crop); for ``K < 1`` the rows are first smoothed by a
vertical Gaussian of sigma ``sqrt(1/K^2 - 1) / 2`` px against aliasing. Nothing else
changes -- the elevation-0 crops the source detector trains on and every background are
SRC's -- so a cross-validation on OUT has SRC's fold models and negatives, and its
``unadapted`` row is the source detector's miss rate on its own view's persons made
``K`` times as tall (K < 1: compressed, as an elevated view compresses them; K > 1:
stretched, as an adapted detector whose elevation estimate is too high stretches them).

``python scaled_positives.py SRC OUT 1 --flat-rows B`` (the control of the replicated
border): the crops unscaled, their top and bottom ``B`` rows replaced by copies of the
nearest row kept -- the rows that ``K < 1`` fills from the border (B = 14 for K = 0.789).
"""
import json
import os
import shutil
import sys
from pathlib import Path

import cv2
import numpy as np
import pandas as pd

src, out, k = Path(sys.argv[1]), Path(sys.argv[2]), float(sys.argv[3])
flat = int(sys.argv[5]) if len(sys.argv) == 6 and sys.argv[4] == "--flat-rows" else 0
assert len(sys.argv) in (4, 6) and (flat == 0 or k == 1.0)
out.mkdir()
cfg = json.loads((src / "dataset.json").read_text())
cfg["hybrid"] = (f"pi/4 person crops replaced by the elevation-0 crops of the same person, "
                 f"scene and instance scaled vertically by {k}, {flat} flat rows at top and "
                 "bottom (scaled_positives.py)")
(out / "dataset.json").write_text(json.dumps(cfg, indent=1))
for f in ("manifest.parquet", "manifest.csv", "frames_coco.json"):
    if (src / f).exists():
        shutil.copy(src / f, out / f)
m = pd.read_parquet(src / "manifest.parquet")
persons = m[m["kind"] == "person"]
top = persons["elevation_index"].max()
assert np.isclose(persons.loc[persons["elevation_index"] == top, "elevation"], np.pi / 4).all()
key = ["person_id", "scene_id", "instance"]
zero = persons[persons["elevation_index"] == 0].set_index(key)["path"]
c = 63.5
M = np.array([[1.0, 0.0, 0.0], [0.0, k, c * (1.0 - k)]])


def scaled(img):
    if k < 1.0:
        s = np.sqrt(1.0 / k ** 2 - 1.0) / 2.0
        img = cv2.GaussianBlur(img, (1, 2 * int(np.ceil(3 * s)) + 1), sigmaX=1e-3, sigmaY=s,
                               borderType=cv2.BORDER_REFLECT_101)
    if flat:
        img = img.copy()
        img[:flat] = img[flat]
        img[-flat:] = img[-flat - 1]
        return img
    return cv2.warpAffine(img, M, (img.shape[1], img.shape[0]), flags=cv2.INTER_LINEAR,
                          borderMode=cv2.BORDER_REPLICATE)


n = 0
for r in m.itertuples():
    dst = out / r.path
    dst.parent.mkdir(parents=True, exist_ok=True)
    if r.kind == "person" and r.elevation_index == top:
        img0 = cv2.imread(str(src / zero[(r.person_id, r.scene_id, r.instance)]),
                          cv2.IMREAD_UNCHANGED)
        assert cv2.imwrite(str(dst), scaled(img0))
        n += 1
    else:
        os.symlink(src / r.path, dst)
for d in ("depth", "frames"):
    if (src / d).exists() and not (out / d).exists():
        os.symlink(src / d, out / d)
print(len(m), "files,", n, f"pi/4 person crops replaced by elevation-0 crops scaled by {k}")
