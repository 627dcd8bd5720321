"""One-off probe (docs/training.md point 53): the covariant orientation map only in some source
cells, the identity elsewhere, S from the plane everywhere; sweep of HOG 0 -> pi/4 beside the full
covariant map. The cells: those at least half inside the mean body's silhouette in the
elevation-0 crop ("body cells", 24 of 128), those at least 90 % inside ("core body cells"), and
the complement of the first ("around the body"). Usage: body_cells.py DATA OUT CACHE"""
import sys
from pathlib import Path

import numpy as np

from benchmark.crops.crossval import CrossvalConfig
from benchmark.crops.features import FeatureCache
from benchmark.crops.sweep import run_sweep, sweep_summary
from benchmark.data import load_dataset
from benchmark.recipes import get_recipe
from benchmark.studies.sweep_decomposition import decomposition_lines, split_remap
from viewadapt.geometry import WINDOW_HEIGHT, WINDOW_WIDTH, crop_camera, elevation_homography
from viewadapt.objectmodel import object_model
from viewadapt.surface import surface_depth

CELL = 8


def body_coverage(distance):
    """Per source cell (row-major, as CellGrid), the share of its pixels inside the mean body."""
    V, F = object_model("body").mesh()
    d = surface_depth(V, F, crop_camera(0.0, distance=distance), (WINDOW_HEIGHT, WINDOW_WIDTH))
    inside = np.isfinite(d).reshape(WINDOW_HEIGHT // CELL, CELL, WINDOW_WIDTH // CELL, CELL)
    return inside.mean(axis=(1, 3)).ravel()


def main(data, out, cache_dir):
    ds = load_dataset(data)
    cfg = CrossvalConfig(seed=0, n_jobs=2, distance=float(ds.config.get("distance", 10.0)),
                         framing=str(ds.config.get("framing", "plane")), object_models=("plane",))
    cfg.recipe = get_recipe("regularised")
    truth = cfg.target
    cover = body_coverage(cfg.distance)
    mask = cover >= 0.5
    masks = {"body cells": mask, "core body cells": cover >= 0.9, "around the body": ~mask}
    for name, m in masks.items():
        print(f"{name}: {m.sum()} of {m.size}")
        print("\n".join("".join("#" if x else "." for x in row) for row in m.reshape(16, 8)))

    def H(x):
        return elevation_homography(0.0, x, distance=cfg.distance, framing=cfg.framing)

    def extra(e):
        He, Ht = H(e), H(truth)
        t = cfg.target_cell_size
        out = {"covariant: S true, A estimated": split_remap(Ht, He, "covariant", t),
               "body cells": split_remap(He, He, "covariant", t, keep=mask)}
        for name, m in masks.items():
            out[f"{name}: S true, A estimated"] = split_remap(Ht, He, "covariant", t, keep=m)
        return out

    cache = FeatureCache(ds, cache_dir, n_jobs=2)
    rows = run_sweep(ds, cfg, cache, detector="hog", step=np.pi / 72, sigma=0.0,
                     variants=("adapted", "adapted[paper eq.3]", "adapted[S only]"), extra=extra)
    summary = sweep_summary(rows)
    Path(out).mkdir(parents=True, exist_ok=True)
    lines = decomposition_lines(
        rows, summary, truth, title="Covariant orientation map in some cells only: " + ", ".join(
            f"{n} {m.sum()} of {m.size}" for n, m in masks.items()),
        intro=f"Data `{data}`, recipe regularised, HOG 0 → π/4, the person plane")
    (Path(out) / "body_cells.md").write_text("\n".join(lines) + "\n")
    summary.to_csv(Path(out) / "sweep_summary.csv", index=False)
    rows.to_parquet(Path(out) / "sweep_scores.parquet", index=False)
    print("\n".join(lines))


if __name__ == "__main__":
    main(*sys.argv[1:4])
