"""One-off: where the person's gradients lie in the crops, by row.

``python extent.py SRC PLANAR``: the mean gradient magnitude (Sobel, grey levels) of the
person crops at elevation 0 and pi/4 of SRC and at pi/4 of PLANAR (planar_positives.py), the
window's centre columns (20-43) minus its side columns (2-9, 54-61), per row; prints the
rows where that excess is above half its maximum (the person's vertical extent) and the
profile every 8 rows. The plane model maps the elevation-0 window's rows 16 (head) and 112
(feet) to 27.7 and 95.8 at pi/4 (``elevation_homography(0, pi/4)``)."""
import glob
import sys

import cv2
import numpy as np


def profile(pattern):
    acc, n = 0.0, 0
    for f in sorted(glob.glob(pattern)):
        g = cv2.imread(f, cv2.IMREAD_GRAYSCALE).astype(np.float32)
        acc = acc + np.hypot(cv2.Sobel(g, cv2.CV_32F, 1, 0), cv2.Sobel(g, cv2.CV_32F, 0, 1))
        n += 1
    P = acc / n
    return n, P[:, 20:44].mean(1) - np.concatenate([P[:, 2:10], P[:, 54:62]], 1).mean(1)


src, planar = sys.argv[1], sys.argv[2]
for name, pat in (("elevation 0, rendered", f"{src}/person/*/*_e0.png"),
                  ("pi/4, rendered", f"{src}/person/*/*_e2.png"),
                  ("pi/4, planar", f"{planar}/person/*/*_e2.png")):
    n, d = profile(pat)
    rows = np.flatnonzero(d > 0.5 * d.max())
    print(f"{name:22s} ({n} crops): rows {rows.min()}..{rows.max()} above half the maximum; "
          f"every 8 rows: {' '.join(f'{v:.1f}' for v in d[::8])}")
