"""One-off: the effects render with its pi/4 persons replaced by elevation-0 persons seen at a
lower resolution.

``python low_resolution.py SRC OUT R``: a dataset linked file by file to SRC
(:func:`benchmark.studies.derived_data.derive_dataset`), except that every person crop at
pi/4 is replaced by the elevation-0 crop of the same person, scene and instance resampled to
``R`` times its size (area averaging, as a camera's pixels integrate) and back to 64x128
(bilinear, as a detector's window reading a small person is). At ``R = 0.7`` the 96 px
person of the window is seen at 67 px, in the real clip's most frequent 60-80 px band.
Nothing else changes, so a cross-validation on OUT trains SRC's fold models on SRC's
negatives and its ``unadapted`` row is the source detector's miss rate on its own view's
persons at that resolution (the companion of ``scaled_positives.py``, which scales them
vertically instead).
"""
import sys
from pathlib import Path

import cv2

from benchmark.studies.derived_data import derive_from_source_view

src, out, r = Path(sys.argv[1]), Path(sys.argv[2]), float(sys.argv[3])
assert len(sys.argv) == 4 and 0 < r <= 1


def make(img, twin, row):
    h, w = img.shape[:2]
    small = cv2.resize(img, (round(w * r), round(h * r)), interpolation=cv2.INTER_AREA)
    return cv2.resize(small, (w, h), interpolation=cv2.INTER_LINEAR)


n = derive_from_source_view(src, out, f"pi/4 person crops replaced by the elevation-0 crops of "
                            f"the same person, scene and instance at {r} of their resolution "
                            "(low_resolution.py)", make)
print(n, f"pi/4 person crops replaced by elevation-0 crops at {r} of their resolution")
