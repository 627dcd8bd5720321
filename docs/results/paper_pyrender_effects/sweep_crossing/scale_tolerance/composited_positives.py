"""One-off: elevation-0 persons, scaled, pasted on background windows of either view.

``python composited_positives.py SRC OUT K BG``: a dataset linked file by file to SRC (a
rendered dataset with depth maps; :func:`benchmark.studies.derived_data.derive_dataset`),
except that every person crop at pi/4 is replaced by the elevation-0 crop of the same
person, scene and instance cut out by its depth map (finite on the person's pixels),
scaled vertically by ``K`` about the window's middle row
(:func:`~benchmark.studies.derived_data.scale_vertically`, the cut-out premultiplied by its
mask and the mask resampled with it as a soft alpha), and pasted on a 64x128 window of one
of the same scene's background images at elevation index ``BG`` (0: the view the persons
were rendered in; 2: pi/4, the ground seen from above), the image and the window's place
drawn from a generator seeded by the crop's path. Nothing else changes, so a
cross-validation on OUT has SRC's fold models and negatives; its ``unadapted`` row says
what the background behind a compressed person does to the source detector.
"""
import sys
import zlib
from pathlib import Path

import cv2
import numpy as np
import pandas as pd

from benchmark.studies.derived_data import derive_from_source_view, scale_vertically

src, out, k, bg = Path(sys.argv[1]), Path(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4])
m = pd.read_parquet(src / "manifest.parquet")
bgs = {s: list(p) for s, p in m[(m["kind"] == "background") & (m["elevation_index"] == bg)]
       .groupby("scene_id")["path"]}


def make(img, z, r):
    person = img.astype(np.float32)
    alpha = np.isfinite(np.load(src / z["depth_path"])["depth"]).astype(np.float32)
    person = scale_vertically(person * alpha[..., None], k, border=cv2.BORDER_CONSTANT)
    alpha = scale_vertically(alpha, k, border=cv2.BORDER_CONSTANT)
    rng = np.random.default_rng(zlib.crc32(r.path.encode()))
    b = cv2.imread(str(src / bgs[r.scene_id][rng.integers(len(bgs[r.scene_id]))]),
                   cv2.IMREAD_UNCHANGED).astype(np.float32)
    y0, x0 = rng.integers(b.shape[0] - 128 + 1), rng.integers(b.shape[1] - 64 + 1)
    # premultiplied: the person's colour where the mask covers, the window elsewhere
    comp = person + (1.0 - alpha[..., None]) * b[y0:y0 + 128, x0:x0 + 64]
    return np.clip(np.rint(comp), 0, 255).astype(np.uint8)


n = derive_from_source_view(src, out, f"pi/4 person crops replaced by the elevation-0 persons "
                            f"(depth-map cut-outs) scaled vertically by {k} on background "
                            f"windows of elevation index {bg} (composited_positives.py)", make)
print(n, f"pi/4 person crops replaced: elevation-0 persons x {k} on background windows of "
      f"elevation index {bg}")
