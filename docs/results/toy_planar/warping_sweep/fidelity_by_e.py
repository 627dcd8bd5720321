"""One-off (docs/training.md point 59): per estimate e, how close the covariant G(e) and S only
are to warping the window by H(0 -> e): mean correlation of block-normalised descriptors and
mean score difference under fold 0's source model, 600 persons and 600 background windows.

    python fidelity_by_e.py DATA OUT
"""
import numpy as np, sys
from pathlib import Path
from viewadapt.adapt import hog_remap_matrix
from viewadapt.geometry import elevation_homography
from benchmark.crops.crossval import CrossvalConfig, run_crossval
from benchmark.crops.detectors import detector_spec
from benchmark.crops.features import FeatureCache, person_windows, background_windows
from benchmark.data import load_dataset
from benchmark.recipes import get_recipe
from viewadapt.adapt import cells_to_descriptor
ds = load_dataset(sys.argv[1]); out = Path(sys.argv[2])
cfg = CrossvalConfig(seed=0, n_jobs=1); cfg.sources=(0.0,); cfg.detectors=("hog",); cfg.object_models=("plane",); cfg.upper_bound=False; cfg.synthesised=False
cache = FeatureCache(ds, out / "cache")
models = {}
run_crossval(ds, cfg, cache, models=models)
model = models[sorted(models)[0]]
spec = detector_spec("hog")
et = ds.elevation_index(np.pi/4)
pw, bw = person_windows(ds, et), background_windows(ds, et, stride=16)
rng = np.random.default_rng(0)
for name, ws in (("persons", pw), ("backgrounds", bw)):
    Xt = next(iter(cache.get_many(ws, ["cells4"]).values()))
    sel = rng.choice(len(Xt), min(600, len(Xt)), replace=False)
    for e in (0.52, 0.65, 0.785, 0.92, 1.05, 1.13):
        H = elevation_homography(0.0, e)
        Xw = next(iter(cache.get_many(ws.warped(H, f"fid{e:.4f}"), ["cells8"]).values()))[sel]
        dw = cells_to_descriptor(Xw.astype(np.float64))
        rows = {}
        for rule in ("covariant", "none"):
            G = hog_remap_matrix(H, target_cell_size=4, rule=rule)
            dg = spec.adapted_inputs(Xt[sel], G)
            c = np.mean([np.corrcoef(a, b)[0, 1] for a, b in zip(dw, dg)])
            sw, sg = model.decision_function(dw), model.decision_function(dg)
            rows[rule] = (c, np.mean(sg - sw))
        print(f"{name:11s} e={e:.3f} warp mean score {np.mean(model.decision_function(dw)):+.3f} | covariant corr {rows['covariant'][0]:.3f} score-warp {rows['covariant'][1]:+.3f} | S only corr {rows['none'][0]:.3f} score-warp {rows['none'][1]:+.3f}", flush=True)
