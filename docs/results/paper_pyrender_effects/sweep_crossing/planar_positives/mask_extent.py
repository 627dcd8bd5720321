"""One-off: the rendered person's own vertical extent in the crops, from its depth maps.

``python mask_extent.py SRC``: for each elevation, each person crop's depth map (finite on
the person's pixels only) gives its first and last person row; prints their medians and 5-95 %
ranges and the mean share of person pixels per row, every 8 rows. The plane model maps the
elevation-0 window's rows 16 and 112 to 27.7 and 95.8 at pi/4. Output: mask_extent.txt."""
import glob
import sys

import numpy as np

src = sys.argv[1]
for e in ("e0", "e1", "e2"):
    tops, bots, cover = [], [], 0.0
    files = sorted(glob.glob(f"{src}/depth/*/*_{e}.npz"))
    for f in files:
        m = np.isfinite(np.load(f)["depth"])
        rows = np.flatnonzero(m.any(1))
        if len(rows):
            tops.append(rows[0])
            bots.append(rows[-1])
        cover = cover + m
    tops, bots, share = np.array(tops), np.array(bots), (cover / len(files)).mean(1)
    print(f"{e}: {len(files)} masks; top row median {np.median(tops):.0f} (5-95%: "
          f"{np.percentile(tops, 5):.0f}-{np.percentile(tops, 95):.0f}), bottom row median "
          f"{np.median(bots):.0f} ({np.percentile(bots, 5):.0f}-{np.percentile(bots, 95):.0f}); "
          f"mean mask share per row every 8 rows: " + " ".join(f"{v:.2f}" for v in share[::8]))
