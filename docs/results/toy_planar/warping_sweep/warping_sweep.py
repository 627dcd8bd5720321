"""One-off (docs/training.md point 59): image warping swept over the elevation estimate.

Beside `bench sweep`'s adapted rows, on the same folds and the same fold models (from
`run_crossval`, the seeds the sweep derives): each test window of the true elevation warped
into the training view by the *estimated* plane homography `H(0 -> e)` (`out(p) = win(H p)`,
each 64x128 window cut out first, as the cross-validation's image warping does) and scored
by the source model. Writes the sweep's scores with the warping rows added, its summary and
`sweep_intervals` into OUT.

    python warping_sweep.py DATA OUT [--step RAD]
"""

import argparse
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from viewadapt.geometry import elevation_homography

from benchmark.crops.crossval import CrossvalConfig, fold_masks, run_crossval
from benchmark.crops.detectors import detector_spec
from benchmark.crops.features import FeatureCache, background_windows, person_windows
from benchmark.crops.folds import make_folds
from benchmark.crops.sweep import run_sweep, sweep_summary
from benchmark.data import load_dataset
from benchmark.recipes import get_recipe
from benchmark.studies.sweep_intervals import sweep_intervals

ap = argparse.ArgumentParser()
ap.add_argument("data", type=Path)
ap.add_argument("out", type=Path)
ap.add_argument("--step", type=float, default=np.pi / 72)
ap.add_argument("--recipe", default="elevation0")
args = ap.parse_args()
args.out.mkdir(parents=True, exist_ok=True)
ds = load_dataset(args.data)
truth = np.pi / 4
cfg = CrossvalConfig.for_dataset(ds, seed=0, n_jobs=1)
cfg.sources, cfg.detectors, cfg.object_models = (0.0,), ("hog",), ("plane",)
cfg.upper_bound, cfg.synthesised = False, False
cfg.recipe = get_recipe(args.recipe)
cache = FeatureCache(ds, args.out / "cache")
models = {}
run_crossval(ds, cfg, cache, models=models)
rows = run_sweep(ds, cfg, cache, detector="hog", step=args.step, sigma=0.0, models=models,
                 variants=("adapted", "adapted[S only]", "adapted[paper eq.3]"))
spec = detector_spec("hog")
rng = np.random.default_rng(cfg.seed)
p = ds.persons
folds = make_folds(p["person_id"], p["scene_id"], rng=rng)   # the sweep's own folds
et = ds.elevation_index(truth)
pw, bw = person_windows(ds, et), background_windows(ds, et, stride=cfg.bg_stride)
labels = np.r_[np.ones(len(pw.meta), np.int8), np.zeros(len(bw.meta), np.int8)]
pids = np.r_[pw.meta["person_id"].to_numpy(), np.full(len(bw.meta), "")]
tests = [np.flatnonzero(np.r_[fold_masks(pw.meta, f, False), fold_masks(bw.meta, f, False)])
         for f in folds]
parts = []
for e in tqdm(np.arange(0.0, np.pi / 2 - 1e-3, args.step), desc="warping sweep"):
    H = elevation_homography(0.0, float(e), distance=cfg.distance, framing=cfg.framing)
    key = f"warpsweep{e:.6f}"
    X = np.vstack([next(iter(cache.get_many(ws.warped(H, key),
                                            [spec.source_features]).values()))
                   for ws in (pw, bw)])
    for f, idx in zip(folds, tests):
        m = models[("hog", 0.0, f.name)]
        parts.append(pd.DataFrame({"fold": f.name, "method": "image warping[estimate]",
                                   "estimate": float(e), "label": labels[idx],
                                   "score": np.asarray(spec.score(m, X[idx]), np.float32),
                                   "person_id": pids[idx]}))
rows = pd.concat([rows] + parts, ignore_index=True)
rows.to_parquet(args.out / "sweep_scores.parquet", index=False)
sweep_summary(rows).to_csv(args.out / "sweep_summary.csv", index=False)
tab = sweep_intervals(rows, true_elevation=truth, n_boot=1000, seed=0)
tab.to_csv(args.out / "sweep_intervals.csv", index=False, float_format="%.4f")
cols = ["method", "best_estimate", "best_mr", "mr_at_true", "crossing_interp", "band_interp",
        "band_interp_low", "band_interp_high"]
print(tab[cols].to_string(index=False))
(args.out / "summary.txt").write_text(tab[cols].to_string(index=False) + "\n")
