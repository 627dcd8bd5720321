"""One-off measurement (docs/training.md point 53): per orientation bin, the share of HOG energy
(9 unsigned bins, bin b centred at (b + 0.5) * 20 degrees of the gradient angle: bins 0 and 8 hold
near-horizontal gradients, i.e. vertical edges; bin 4 near-vertical gradients, horizontal edges),
averaged over windows, of what the source SVM is shown: the source view's crops and background
windows (8-px cells), the pi/4 windows unadapted (8-px cells) and remapped from their 4-px cells by
each rule's plane G(0 -> pi/4), and the round trip of point 52 (source windows warped to pi/4 by the
plane, remapped back by the covariant G). Data /tmp/exp/dsfx, its feature cache /tmp/s13/cache_fx.
Usage: orientation_shares.py > orientation_shares.md"""
import numpy as np
from benchmark.data import load_dataset
from benchmark.crops.crossval import CrossvalConfig, variant_remap, view_maps
from benchmark.crops.features import FeatureCache, background_windows, person_windows
from viewadapt.adapt import remap_features
from viewadapt.geometry import elevation_homography

ds = load_dataset("/tmp/exp/dsfx")
cache = FeatureCache(ds, "/tmp/s13/cache_fx", n_jobs=1, progress=False)
cfg = CrossvalConfig(distance=float(ds.config.get("distance", 10.0)), framing=str(ds.config.get("framing", "plane")),
                     object_models=("plane",))
t = np.pi / 4
e0, et = ds.elevation_index(0.0), ds.elevation_index(t)
G = {r: variant_remap("hog", view_maps(0.0, t, cfg)["plane"], v, cfg)
     for r, v in (("covariant", "adapted"), ("eq3", "adapted[paper eq.3]"), ("S only", "adapted[S only]"))}
H = elevation_homography(0.0, t, distance=cfg.distance, framing=cfg.framing)
def share(X):
    E = X.reshape(len(X), -1, 9).sum(1)
    return (E / E.sum(1, keepdims=True)).mean(0)
rows = {}
for kind, mk in (("person", person_windows), ("background", lambda d, i: background_windows(d, i, stride=cfg.bg_stride))):
    src, tgt = mk(ds, e0), mk(ds, et)
    rows[f"{kind}: source 8-px"] = share(cache.get(src, "cells8"))
    rows[f"{kind}: target 8-px (unadapted)"] = share(cache.get(tgt, "cells8"))
    X4 = cache.get(tgt, "cells4")
    for r, g in G.items():
        rows[f"{kind}: target, {r} G"] = share(remap_features(g, X4))
    rt = src.warped(np.linalg.inv(H), f"rt{t:.4f}")
    rows[f"{kind}: round trip, covariant G"] = share(remap_features(G["covariant"], cache.get(rt, "cells4")))
print("| windows | " + " | ".join(f"bin {k}" for k in range(9)) + " |")
print("|---|" + "---|" * 9)
for k, v in rows.items():
    print(f"| {k} | " + " | ".join(f"{x:.3f}" for x in v) + " |")
