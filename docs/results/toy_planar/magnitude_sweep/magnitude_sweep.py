"""One-off (docs/training.md point 59): the covariant G with the gradients' magnitudes.

Under a warp ``out(p) = in(H p)`` a gradient is a covector: ``grad out = J^T grad in``
(``J`` the Jacobian of ``H`` at ``p``), so its direction turns -- what the covariant ``A``
does -- and its magnitude changes by ``|J^T u|`` for a unit direction ``u``. ``A`` moves a
bin's mass and keeps it (its columns sum to 1); ``S`` with ``preserve="sum"`` gives a source
cell the energy of its footprint in the target, ``det J`` times its area. A warped window's
source cell holds instead ``|J^T u| / det J`` times that per target direction ``u``. Here
``G_mag[(k, i), (l, j)] = S_kl A_k[i, j] |J_k^T u_j| / det J_k`` (``u_j`` the centre
direction of target bin ``j``, ``J_k`` at source cell ``k``'s centre) is swept beside the
adapted rows on the same folds and models.

    python magnitude_sweep.py DATA OUT [--recipe R] [--object-models plane]
"""

import argparse
from pathlib import Path

import numpy as np

from viewadapt.adapt import hog_remap_matrix
from viewadapt.geometry import elevation_homography, homography_jacobian
from viewadapt.remap import CellGrid

from benchmark.crops.crossval import CrossvalConfig
from benchmark.crops.features import FeatureCache
from benchmark.crops.sweep import run_sweep, sweep_summary
from benchmark.data import load_dataset
from benchmark.recipes import get_recipe
from benchmark.studies.sweep_intervals import sweep_intervals

N_BINS = 9


def magnitude_remap(H, target_cell_size=4):
    """The covariant per-cell G of HOG cells with each (source cell, target bin) entry
    scaled by |J^T u_j| / det J (see the module's docstring)."""
    G = hog_remap_matrix(H, target_cell_size=target_cell_size, rule="covariant",
                         per_cell=True).tocoo()
    J = homography_jacobian(H, CellGrid.for_window(64, 128, 8).centers())   # (K, 2, 2)
    phi = (np.arange(N_BINS) + 0.5) * np.pi / N_BINS
    u = np.stack([np.cos(phi), np.sin(phi)], 0)                             # (2, B)
    m = np.linalg.norm(np.swapaxes(J, 1, 2) @ u, axis=1) / np.linalg.det(J)[:, None]
    data = G.data * m[G.row // N_BINS, G.col % N_BINS]
    import scipy.sparse as sp

    return sp.csr_matrix((data, (G.row, G.col)), shape=G.shape)


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("data", type=Path)
    ap.add_argument("out", type=Path)
    ap.add_argument("--recipe", default="elevation0")
    ap.add_argument("--object-models", nargs="+", default=["plane"])
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    ds = load_dataset(args.data)
    truth = np.pi / 4
    cfg = CrossvalConfig.for_dataset(ds, seed=0, n_jobs=1)
    cfg.object_models = tuple(args.object_models)
    cfg.recipe = get_recipe(args.recipe)
    cache = FeatureCache(ds, args.out / "cache")

    def extra(e):
        H = elevation_homography(0.0, e, distance=cfg.distance, framing=cfg.framing)
        return {"adapted[covariant, magnitude]": magnitude_remap(H, cfg.target_cell_size)}

    rows = run_sweep(ds, cfg, cache, detector="hog", sigma=0.0, extra=extra,
                     variants=("adapted", "adapted[S only]", "adapted[paper eq.3]"))
    rows.to_parquet(args.out / "sweep_scores.parquet", index=False)
    sweep_summary(rows).to_csv(args.out / "sweep_summary.csv", index=False)
    tab = sweep_intervals(rows, true_elevation=truth, n_boot=1000, seed=0)
    tab.to_csv(args.out / "sweep_intervals.csv", index=False, float_format="%.4f")
    cols = ["method", "best_estimate", "best_mr", "mr_at_true", "crossing_interp",
            "band_interp", "band_interp_low", "band_interp_high"]
    print(tab[cols].to_string(index=False))
    (args.out / "summary.txt").write_text(tab[cols].to_string(index=False) + "\n")
