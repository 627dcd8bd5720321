"""Window sets and their features, computed once and cached on disk.

A *window set* is a list of 64x128 windows: person crops of one elevation, background
windows cut on a grid from the person-free images of one elevation, and the same windows
warped by a homography (the image-warping baseline, and synthesised training data).
Features of a window set are cached in ``cache_dir`` under a key made of the dataset's
fingerprint, the window set and the representation, so reruns with other classifier
settings skip the feature computation.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pandas as pd

from viewadapt.geometry import WINDOW_HEIGHT, WINDOW_WIDTH
from viewadapt.warp import translation, warp_to_source_view

from .data import Dataset, read_image

__all__ = ["REPRESENTATIONS", "compute_representation", "WindowSet", "person_windows",
           "background_windows", "FeatureCache"]


def _hog(cell, normalize=None, gamma=False):
    from viewadapt.hog import hog_cells

    return lambda w: hog_cells(w, cell_size=cell, normalize=normalize, gamma=gamma).ravel()


def _acf(w):
    from viewadapt.acf import acf_channels

    return acf_channels(w).ravel()


def _ocv(w):
    from viewadapt.hog import hog_descriptor

    return hog_descriptor(w, method="opencv")


#: name -> function(window uint8 (128, 64, 3)) -> 1-D float features
REPRESENTATIONS = {
    "cells8": _hog(8), "cells4": _hog(4),
    "local8": _hog(8, "local"), "local4": _hog(4, "local"),
    "gamma_cells4": _hog(4, gamma=True), "gamma_cells8": _hog(8, gamma=True),
    "acf": _acf, "opencv": _ocv,
}


def compute_representation(windows, rep: str) -> np.ndarray:
    fn = REPRESENTATIONS[rep]
    return np.stack([fn(w) for w in windows]).astype(np.float32)


class WindowSet:
    """Windows to featurise: each item is (image path, H: window -> image pixels).

    ``H`` is a translation for plain windows, composed with a homography for warped ones.
    """

    def __init__(self, key: str, items: list, meta: pd.DataFrame):
        self.key = key
        self.items = items
        self.meta = meta.reset_index(drop=True)

    def __len__(self):
        return len(self.items)

    def warped(self, H_window, key_suffix: str) -> "WindowSet":
        """The same windows, each resampled through ``H_window`` first (``out(p) = img(H_i H p)``)."""
        H = np.asarray(H_window, float)
        return WindowSet(f"{self.key}|{key_suffix}", [(p, Hi @ H) for p, Hi in self.items],
                         self.meta)

    def images(self, root: Path):
        cache = {}
        for rel, H in self.items:
            if rel not in cache:
                cache.clear()
                cache[rel] = read_image(root / rel)
            img = cache[rel]
            if np.allclose(H[2], [0, 0, 1]) and np.allclose(H[:2, :2], np.eye(2)) and \
                    float(H[0, 2]).is_integer() and float(H[1, 2]).is_integer():
                x, y = int(H[0, 2]), int(H[1, 2])
                if 0 <= x and 0 <= y and x + WINDOW_WIDTH <= img.shape[1] and \
                        y + WINDOW_HEIGHT <= img.shape[0]:
                    yield np.ascontiguousarray(img[y:y + WINDOW_HEIGHT, x:x + WINDOW_WIDTH])
                    continue
            yield warp_to_source_view(img, H)


def person_windows(ds: Dataset, elevation_index: int, rows: pd.DataFrame | None = None) -> WindowSet:
    """Person crops of one elevation (the whole 64x128 image each)."""
    p = ds.persons if rows is None else rows
    p = p[p["elevation_index"] == elevation_index].sort_values("path")
    items = [(rel, translation(0, 0)) for rel in p["path"]]
    meta = p[["path", "person_id", "scene_id", "instance"]].assign(label=1)
    return WindowSet(f"person|e{elevation_index}", items, meta)


def background_windows(ds: Dataset, elevation_index: int, *, stride: int = 16) -> WindowSet:
    """All 64x128 windows on a ``stride`` grid of the background images of one elevation."""
    b = ds.backgrounds
    b = b[b["elevation_index"] == elevation_index].sort_values("path")
    items, meta = [], []
    for _, r in b.iterrows():
        W, H = int(r["width"]), int(r["height"])
        for y in range(0, H - WINDOW_HEIGHT + 1, stride):
            for x in range(0, W - WINDOW_WIDTH + 1, stride):
                items.append((r["path"], translation(x, y)))
                meta.append((r["path"], "", r["scene_id"], int(r["instance"]), x, y))
    meta = pd.DataFrame(meta, columns=["path", "person_id", "scene_id", "instance", "x", "y"])
    return WindowSet(f"background|e{elevation_index}|s{stride}", items, meta.assign(label=0))


class FeatureCache:
    """Computes features of window sets once per (dataset, window set, representation)."""

    def __init__(self, ds: Dataset, cache_dir, *, n_jobs: int = 1, progress: bool = True):
        self.ds = ds
        self.dir = Path(cache_dir)
        self.n_jobs = n_jobs
        self.progress = progress
        self._mem = {}

    def _file(self, ws: WindowSet, rep: str) -> Path:
        h = hashlib.sha256(f"{self.ds.fingerprint}|{ws.key}|{rep}|{len(ws)}".encode())
        for rel, H in ws.items[:50]:
            h.update(rel.encode())
            h.update(np.round(H, 9).tobytes())
        return self.dir / f"{rep}-{h.hexdigest()[:20]}.npy"

    def get(self, ws: WindowSet, rep: str) -> np.ndarray:
        """(len(ws), d) float32 features of ``ws`` in representation ``rep``."""
        f = self._file(ws, rep)
        if f in self._mem:
            return self._mem[f]
        if f.is_file():
            try:
                X = np.load(f)
                if X.shape[0] == len(ws):
                    self._mem[f] = X
                    return X
            except (ValueError, OSError):
                pass  # a truncated cache file: recompute it
        X = self._compute(ws, rep)
        self.dir.mkdir(parents=True, exist_ok=True)
        tmp = f.with_suffix(".tmp.npy")
        np.save(tmp, X)
        tmp.replace(f)
        self._mem[f] = X
        return X

    def _compute(self, ws: WindowSet, rep: str) -> np.ndarray:
        from joblib import Parallel, delayed
        from tqdm.auto import tqdm

        if len(ws) == 0:
            return np.zeros((0, 0), np.float32)
        chunks = np.array_split(np.arange(len(ws)), max(1, min(len(ws) // 64, 64)))
        root = self.ds.root

        def work(idx):
            sub = WindowSet(ws.key, [ws.items[i] for i in idx], ws.meta.iloc[idx])
            return compute_representation(list(sub.images(root)), rep)

        it = tqdm(chunks, desc=f"features {rep} {ws.key}", leave=False, disable=not self.progress)
        if self.n_jobs == 1:
            parts = [work(c) for c in it]
        else:
            parts = Parallel(n_jobs=self.n_jobs)(delayed(work)(c) for c in it)
        return np.concatenate(parts)
