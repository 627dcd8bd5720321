"""One-off (docs/training.md point 59): the share of HOG energy per orientation bin, summed
over all test windows, of the warped windows (H(0 -> e)), of G(e) (covariant) and of S only.

    python binshares.py DATA CACHE
"""
import numpy as np, sys
from pathlib import Path
from viewadapt.adapt import hog_remap_matrix
from viewadapt.geometry import elevation_homography
from benchmark.crops.features import FeatureCache, person_windows, background_windows
from benchmark.data import load_dataset
ds = load_dataset(sys.argv[1]); cache = FeatureCache(ds, Path(sys.argv[2]))
et = ds.elevation_index(np.pi/4)
for name, ws in (("persons", person_windows(ds, et)), ("backgrounds", background_windows(ds, et, stride=16))):
    Xt = next(iter(cache.get_many(ws, ["cells4"]).values())).astype(np.float64)
    for e in (0.785, 0.92, 1.0, 1.05):
        H = elevation_homography(0.0, e)
        Xw = next(iter(cache.get_many(ws.warped(H, f"fid{e:.4f}"), ["cells8"]).values())).astype(np.float64)
        out = []
        for rule in ("covariant", "none"):
            G = hog_remap_matrix(H, target_cell_size=4, rule=rule)
            Xg = (G @ Xt.T).T
            out.append(Xg.reshape(len(Xg), -1, 9).sum((0, 1)))
        w = Xw.reshape(len(Xw), -1, 9).sum((0, 1))
        f = lambda v: " ".join(f"{x:.3f}" for x in v / v.sum())
        print(f"{name} e={e:.3f} total G/warp {out[0].sum()/w.sum():.2f}\n  warp {f(w)}\n  cov  {f(out[0])}\n  none {f(out[1])}")
