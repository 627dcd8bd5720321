"""Remap fidelity: how well ``G x_target`` reproduces the features of the warped window.

For each elevation pair, window and feature type we compute

* ``want``: features of the target window *warped into the source view* with the exact
  plane homography (read from the whole image, so no border pixels enter) -- what the
  image-warping baseline (Li et al. 2008) computes;
* ``got``:  ``G`` applied to features computed on the target window itself -- what
  feature remapping (Wang et al. 2017) computes;

and their Pearson correlation per window. The unadapted row correlates the target
features with ``want`` directly (no remapping). Images: scikit-image's natural sample
images and synthetic patterns (ellipses, bars, checkerboards), all shipped with the code.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from viewadapt.adapt import acf_remap_matrix, cells_to_descriptor, hog_remap_matrix
from viewadapt.geometry import elevation_homography
from viewadapt.hog import hog_cells
from viewadapt.remap import ANGLE_RULES
from viewadapt.warp import translation, warp_to_source_view

__all__ = ["sample_images", "synthetic_images", "remap_fidelity", "summarize_fidelity",
           "DEFAULT_PAIRS"]

DEFAULT_PAIRS = ((0.0, np.pi / 8), (0.0, np.pi / 4), (np.pi / 8, np.pi / 4))
MARGIN = 40  # pixels around each target window, so the warp never reads outside the image


def sample_images() -> dict[str, np.ndarray]:
    """Natural RGB images shipped with scikit-image."""
    from skimage import data

    return {name: getattr(data, name)() for name in
            ("astronaut", "chelsea", "coffee", "rocket", "immunohistochemistry")}


def synthetic_images(rng: np.random.Generator, n: int = 3, size=(384, 384)) -> dict:
    """Random ellipses, rotated bars and checkerboards on smooth noise, uint8 RGB."""
    import cv2

    out = {}
    H, W = size
    for i in range(n):
        img = cv2.GaussianBlur(rng.uniform(60, 190, (H // 8, W // 8, 3)).astype(np.float32),
                               (0, 0), 1.0)
        img = cv2.resize(img, (W, H), interpolation=cv2.INTER_CUBIC)
        for _ in range(25):
            colour = tuple(float(c) for c in rng.uniform(0, 255, 3))
            kind = rng.integers(3)
            c = (int(rng.integers(0, W)), int(rng.integers(0, H)))
            if kind == 0:
                cv2.ellipse(img, c, (int(rng.integers(5, 40)), int(rng.integers(5, 40))),
                            float(rng.uniform(0, 180)), 0, 360, colour, -1, cv2.LINE_AA)
            elif kind == 1:
                box = cv2.boxPoints((c, (float(rng.uniform(4, 12)), float(rng.uniform(30, 120))),
                                     float(rng.uniform(0, 180))))
                cv2.fillConvexPoly(img, box.astype(np.int32), colour, cv2.LINE_AA)
            else:
                s = int(rng.integers(4, 12))
                x, y = c
                patch = ((np.indices((48, 48)).sum(0) // s) % 2)[..., None] * np.array(colour)
                img[y:y + 48, x:x + 48] = patch[: max(0, min(48, H - y)), : max(0, min(48, W - x))]
        out[f"synthetic{i}"] = np.clip(img, 0, 255).astype(np.uint8)
    return out


def _corr(a, b) -> float:
    a, b = np.ravel(a), np.ravel(b)
    if a.std() == 0 or b.std() == 0:
        return np.nan
    return float(np.corrcoef(a, b)[0, 1])


def remap_fidelity(images: dict, *, pairs=DEFAULT_PAIRS, windows_per_image: int = 20,
                   target_cell_sizes=(8, 4), rules=ANGLE_RULES, acf: bool = True,
                   rng: np.random.Generator, progress: bool = False,
                   distance: float = 10.0) -> pd.DataFrame:
    """Per-window correlations between remapped and warped-window features.

    ``distance`` is the crop camera's distance in metres (the plane homographies'
    perspective, :func:`viewadapt.geometry.crop_camera`).

    Returns
    -------
    DataFrame with one row per (pair, image, window, feature, rule, form, target cell):
    columns ``source_elevation, target_elevation, image, window, feature, rule, form,
    target_cell_size, pearson``. ``feature`` is ``hog_cells``, ``hog_local`` (locally
    normalised cells), ``hog_blocks`` (remap cells, then L2-Hys blocks), ``acf`` (all ten
    channels) or ``acf_gradient`` (magnitude and orientation channels);
    ``rule`` is an angle rule or ``unadapted``.
    """
    from tqdm.auto import tqdm

    rows = []
    jobs = [(pair, name) for pair in pairs for name in images]
    it = tqdm(jobs, desc="remap fidelity", disable=not progress)
    if acf:
        from viewadapt.acf import acf_channels
    cache = {}
    for (es, et), name in it:
        img = images[name]
        H = elevation_homography(es, et, distance=distance)
        if (es, et) not in cache:
            cache[es, et] = (
                {(r, pc, tc): hog_remap_matrix(H, target_cell_size=tc, rule=r, per_cell=pc)
                 for r in rules for pc in (True, False) for tc in target_cell_sizes},
                {(r, pc): acf_remap_matrix(H, rule=r, per_cell=pc)
                 for r in rules for pc in (True, False)} if acf else {})
        Gs, Ga = cache[es, et]
        M, N = img.shape[:2]
        for k in range(windows_per_image):
            y = int(rng.integers(MARGIN, M - 128 - MARGIN))
            x = int(rng.integers(MARGIN, N - 64 - MARGIN))
            target = img[y:y + 128, x:x + 64]
            source = warp_to_source_view(img, translation(x, y) @ H)
            base = dict(source_elevation=es, target_elevation=et, image=name, window=k)
            for feat, norm in (("hog_cells", None), ("hog_local", "local")):
                want = hog_cells(source, normalize=norm)
                rows.append(base | dict(feature=feat, rule="unadapted", form="-",
                                        target_cell_size=8,
                                        pearson=_corr(hog_cells(target, normalize=norm), want)))
                tcells = {tc: hog_cells(target, cell_size=tc, normalize=norm).ravel()
                          for tc in target_cell_sizes}
                for (r, pc, tc), G in Gs.items():
                    rows.append(base | dict(feature=feat, rule=r,
                                            form="per-cell" if pc else "single",
                                            target_cell_size=tc,
                                            pearson=_corr(G @ tcells[tc], want)))
                if feat == "hog_cells":
                    want_d = cells_to_descriptor(want.ravel())
                    rows.append(base | dict(feature="hog_blocks", rule="unadapted", form="-",
                                            target_cell_size=8,
                                            pearson=_corr(cells_to_descriptor(tcells[8])
                                                          if 8 in tcells else
                                                          cells_to_descriptor(hog_cells(target).ravel()),
                                                          want_d)))
                    for (r, pc, tc), G in Gs.items():
                        rows.append(base | dict(
                            feature="hog_blocks", rule=r, form="per-cell" if pc else "single",
                            target_cell_size=tc,
                            pearson=_corr(cells_to_descriptor(G @ tcells[tc]), want_d)))
            if acf:
                want = acf_channels(source).ravel()
                tch = acf_channels(target).ravel()
                n = want.size // 10
                # all ten channels, and the gradient channels alone (magnitude + 6
                # orientations), whose correlation colour cannot inflate
                for feat, sl in (("acf", slice(None)), ("acf_gradient", slice(3 * n, None))):
                    rows.append(base | dict(feature=feat, rule="unadapted", form="-",
                                            target_cell_size=4,
                                            pearson=_corr(tch[sl], want[sl])))
                    for (r, pc), G in Ga.items():
                        rows.append(base | dict(feature=feat, rule=r,
                                                form="per-cell" if pc else "single",
                                                target_cell_size=4,
                                                pearson=_corr((G @ tch)[sl], want[sl])))
    return pd.DataFrame(rows)


def summarize_fidelity(df: pd.DataFrame) -> pd.DataFrame:
    """Median, mean and 10th percentile of the per-window correlations, per configuration."""
    keys = ["feature", "source_elevation", "target_elevation", "rule", "form", "target_cell_size"]
    g = df.groupby(keys, sort=False)["pearson"]
    out = pd.DataFrame({"median": g.median(), "mean": g.mean(),
                        "p10": g.quantile(0.1), "n_windows": g.count()}).reset_index()
    return out
