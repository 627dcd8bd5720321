"""Speed of the core pieces, as ratios against OpenCV measured in the same run.

    python -m benchmark.studies.core_speed [--windows 300] [--repeat 5]

Prints per-call times (best of ``--repeat``) and each one's ratio to
``cv2.HOGDescriptor().compute`` on one 64x128 window. Absolute times depend on the
machine; the ratios are the result. Not a test: nothing here asserts a time.
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def _best(fn, repeat):
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def run(windows: int = 300, repeat: int = 5, seed: int = 0) -> list[tuple[str, float]]:
    import cv2
    from skimage import data

    from viewadapt.adapt import adapt_linear_weights, hog_remap_matrix
    from viewadapt.geometry import elevation_homography
    from viewadapt.hog import hog_cells, hog_descriptor

    rng = np.random.default_rng(seed)
    img = data.astronaut()
    wins = []
    for _ in range(windows):
        y, x = rng.integers(0, 512 - 128), rng.integers(0, 512 - 64)
        wins.append(np.ascontiguousarray(img[y:y + 128, x:x + 64]))
    hog = cv2.HOGDescriptor()
    H = elevation_homography(0.0, np.pi / 4)
    n = len(wins)
    rows = []
    t_cv = _best(lambda: [hog.compute(w) for w in wins], repeat) / n
    rows.append(("OpenCV HOGDescriptor.compute, per window", t_cv))
    rows.append(("our hog_cells (8 px), per window",
                 _best(lambda: [hog_cells(w) for w in wins], repeat) / n))
    rows.append(("our hog_descriptor(method='cells'), per window",
                 _best(lambda: [hog_descriptor(w) for w in wins], repeat) / n))
    rows.append(("our hog_descriptor(method='opencv'), per window",
                 _best(lambda: [hog_descriptor(w, method="opencv") for w in wins[:50]],
                       repeat) / 50))
    for tc in (8, 4):
        for per_cell in (False, True):
            rows.append((f"build G, 64x128, target cells {tc} px, "
                         f"{'per-cell' if per_cell else 'single'} A",
                         _best(lambda: hog_remap_matrix(H, target_cell_size=tc,
                                                        per_cell=per_cell), repeat)))
    G = hog_remap_matrix(H, target_cell_size=4)
    w = rng.normal(size=G.shape[0])
    rows.append(("apply G^T w (adapt a linear model, offline, once)",
                 _best(lambda: adapt_linear_weights(w, G), repeat)))
    X = np.abs(rng.normal(size=(n, G.shape[1])))
    wa = adapt_linear_weights(w, G)
    rows.append(("score one window with adapted weights w'^T x",
                 _best(lambda: X @ wa, repeat) / n))
    rows.append(("score one window by remapping features w^T (G x)",
                 _best(lambda: (G @ X.T).T @ w, repeat) / n))
    return rows


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--windows", type=int, default=300)
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--seed", type=int, default=0)
    a = p.parse_args(argv)
    rows = run(a.windows, a.repeat, a.seed)
    base = rows[0][1]
    width = max(len(r[0]) for r in rows)
    print(f"{'what'.ljust(width)}  {'time':>12}  {'ratio to OpenCV compute':>24}")
    for name, t in rows:
        print(f"{name.ljust(width)}  {t * 1e3:9.3f} ms  {t / base:24.3f}")
    print(f"AdaBoostTrees: 64 depth-2 trees on 2000 x 5000 features: {boosting_speed():.1f} s")


if __name__ == "__main__":
    main()


def boosting_speed(seed: int = 13) -> float:
    """Seconds to train 64 depth-2 trees on 2000 x 5000 features (one core)."""
    from viewadapt.boosting import AdaBoostTrees

    rng = np.random.default_rng(seed)
    X = rng.normal(size=(2000, 5000))
    y = rng.integers(0, 2, 2000)
    X[:, :50] += 0.3 * y[:, None]
    t = time.perf_counter()
    AdaBoostTrees(n_estimators=64, stages=None).fit(X, y)
    return time.perf_counter() - t
