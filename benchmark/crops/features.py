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
import re
from pathlib import Path

import numpy as np
import pandas as pd

from viewadapt.geometry import WINDOW_HEIGHT, WINDOW_WIDTH
from viewadapt.io.files import atomic_path
from viewadapt.warp import translation, warp_to_source_view

from benchmark.crops.detectors import feature_key
from benchmark.data import Dataset, read_image

__all__ = ["REPRESENTATIONS", "compute_representation", "compute_representations",
           "WindowSet", "person_windows",
           "background_windows", "FeatureCache", "ROTATIONS_DEG", "rotation_about_centre",
           "rotated_windows", "scale_about_centre", "scaled_windows"]


#: representation -> (family, options); every representation of one family shares the
#: per-window gradient computation
REPRESENTATIONS = {
    "cells8": ("hog", dict(cell=8)), "cells4": ("hog", dict(cell=4)),
    "local8": ("hog", dict(cell=8, normalize="local")),
    "local4": ("hog", dict(cell=4, normalize="local")),
    "gamma_cells8": ("hog_gamma", dict(cell=8)), "gamma_cells4": ("hog_gamma", dict(cell=4)),
    "acf": ("acf", {}), "opencv": ("opencv", {}),
}


def _window_features(w, reps) -> dict:
    """Features of one window in each representation of ``reps``.

    Oriented gradients and ACF channels come from the float32 OpenCV paths of
    :mod:`viewadapt.detect` (the same quantities as :mod:`viewadapt.hog` /
    :mod:`viewadapt.acf` up to rounding, tested there; ~3x faster per window).
    """
    from viewadapt.detect import acf_window_features, cell_sums, fast_orientation_channels
    from viewadapt.hog import hog_descriptor, locally_normalize_channels

    out, O = {}, {}
    for rep in reps:
        family, opt = REPRESENTATIONS[rep]
        if family in ("hog", "hog_gamma"):
            if family not in O:
                O[family] = fast_orientation_channels(w, gamma=family == "hog_gamma")
            ch = O[family]
            if opt.get("normalize") == "local":
                key = family + "_local"
                if key not in O:
                    O[key] = locally_normalize_channels(ch, cell_size=8).astype(np.float32)
                ch = O[key]
            out[rep] = cell_sums(ch, opt["cell"]).ravel()
        elif family == "acf":
            out[rep] = acf_window_features(w).ravel()
        else:
            out[rep] = hog_descriptor(w, method="opencv")
    return out


def compute_representations(windows, reps) -> dict:
    """``{key: (n, d) float32}`` for an iterable of windows, one pass over the windows.

    ``reps`` are built-in representation names (:data:`REPRESENTATIONS`) or feature objects
    of a detector spec (:mod:`benchmark.crops.detectors`: a ``key`` and a call on one window);
    the result is keyed by the name or the ``key``.
    """
    builtin = [r for r in reps if isinstance(r, str)]
    custom = [r for r in reps if not isinstance(r, str)]
    rows = {feature_key(r): [] for r in reps}
    for w in windows:
        for r, v in _window_features(w, builtin).items():
            rows[r].append(v)
        for r in custom:
            v = np.asarray(r(w), dtype=np.float32)
            if v.ndim != 1:
                raise ValueError(f"features {feature_key(r)!r} must return a 1-D array per "
                                 f"window, got shape {v.shape}")
            rows[feature_key(r)].append(v)
    return {r: np.stack(v).astype(np.float32) for r, v in rows.items()}


def compute_representation(windows, rep: str) -> np.ndarray:
    return compute_representations(windows, [rep])[rep]


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

    def warped(self, H_window, key_suffix: str, *, crop_first: bool = True) -> "WindowSet":
        """The same windows, each resampled through ``H_window``: ``out(p) = win(H p)``.

        With ``crop_first`` (default) each 64x128 window is cut out first and warped on its
        own, pixels outside it replicated from its border -- exactly what happens to a
        person crop, which has no context beyond its 64x128 pixels. Treating background
        windows the same way keeps positives and negatives alike, so a classifier cannot
        learn the border artefacts as a cue. Without it the warp reads the whole image.
        """
        self._check_no_camera("warped")
        H = np.asarray(H_window, float)
        # the key names the homography too, so cached features never outlive a change of it
        h = hashlib.sha1(np.round(H / H[2, 2], 9).tobytes()).hexdigest()[:8]
        suffix = key_suffix + ("|cropfirst" if crop_first else "") + f"|H{h}"
        return WindowSet(f"{self.key}|{suffix}",
                         [(p, _then(Hi, H, crop_first)) for p, Hi in self.items], self.meta)

    def remapped(self, field, key_suffix: str) -> "WindowSet":
        """The same windows resampled through a dense map: ``out(p) = win(field[p])``.

        ``field`` is (64 x 128 x 2) target-window coordinates per source pixel (e.g. from an
        object model, :func:`benchmark.crops.crossval.warp_field`); each window is cut out first
        and resampled on its own, borders replicated, as :meth:`warped` with ``crop_first``.
        """
        self._check_no_camera("remapped")
        if any(isinstance(Hi, tuple) for _, Hi in self.items):
            raise ValueError("remapped: these windows are already cut out and warped; a dense "
                             "map does not compose with that warp")
        F = np.ascontiguousarray(field, dtype=np.float32)
        if F.shape != (WINDOW_HEIGHT, WINDOW_WIDTH, 2) or not np.isfinite(F).all():
            raise ValueError(f"field must be a finite ({WINDOW_HEIGHT}, {WINDOW_WIDTH}, 2) "
                             f"map, got {F.shape}")
        h = hashlib.sha1(np.round(F.astype(np.float64), 4).tobytes()).hexdigest()[:8]
        suffix = f"{key_suffix}|cropfirst|M{h}"
        items = [(p, (Hi, F)) for p, Hi in self.items]
        return WindowSet(f"{self.key}|{suffix}", items, self.meta)

    def through_camera(self, effects, seed: int = 0) -> "WindowSet":
        """The same windows, each passed through its own draw of ``effects`` (a
        :class:`viewadapt.camera.effects.CameraEffects`) after any warp; the draw of window
        ``i`` is seeded by ``(seed, the set's key, i)``, so it is the same in every run and
        every process."""
        import json
        import zlib

        self._check_no_camera("through_camera")
        h = hashlib.sha1(json.dumps(effects.to_dict(), sort_keys=True).encode()).hexdigest()[:8]
        base = zlib.crc32(self.key.encode())
        items = [(p, H, (effects, (int(seed), base, i))) for i, (p, H) in enumerate(self.items)]
        return WindowSet(f"{self.key}|cam{h}s{int(seed)}", items, self.meta)

    def _check_no_camera(self, what):
        if any(len(item) > 2 for item in self.items):
            raise ValueError(f"{what}: these windows already pass through camera effects, "
                             "which come last; warp first")

    def images(self, root: Path):
        cache = {}
        for item in self.items:
            rel, H = item[0], item[1]
            if rel not in cache:
                cache.clear()
                cache[rel] = read_image(root / rel)
            win = _window(cache[rel], H)
            if len(item) > 2:                             # camera effects, last
                from viewadapt.camera.effects import apply_camera_effects

                effects, seed = item[2]
                win = apply_camera_effects(win, effects.draw(np.random.default_rng(seed)))
            yield win


def _then(item, H, crop_first: bool):
    """The window item ``item`` (a matrix, or ``(T, warp)``: cut out with ``T``, then
    warped) resampled through ``H`` as well. A window already cut out and warped is warped
    once through both (``warp @ H``: its border is replicated once, not twice); it has no
    whole image to read from, and a dense map does not compose."""
    if not isinstance(item, tuple):
        return (item, H) if crop_first else item @ H
    T, Hw = item
    if not crop_first or np.ndim(Hw) != 2:
        raise ValueError("a window cut out and warped first can only be warped again by a "
                         "homography, cut out first")
    return T, Hw @ H


def _window(img, H):
    """The window item ``H`` (a matrix, or ``(T, warp)`` to crop with ``T`` first) of ``img``."""
    if isinstance(H, tuple):                              # crop first, then warp
        T, Hw = H
        win = _plain_window(img, T)
        if win is None:                                   # e.g. a rotated window
            win = warp_to_source_view(img, T)
        if Hw.ndim == 3:                                  # a dense map (object model)
            import cv2

            return cv2.remap(win, Hw[..., 0], Hw[..., 1], cv2.INTER_LINEAR,
                             borderMode=cv2.BORDER_REPLICATE)
        return warp_to_source_view(win, Hw)
    win = _plain_window(img, H)
    return warp_to_source_view(img, H) if win is None else win


def _plain_window(img, H):
    """The 64x128 window ``H`` cuts out of ``img`` when ``H`` is an integer translation that
    keeps it inside the image; None otherwise."""
    if np.allclose(H[2], [0, 0, 1]) and np.allclose(H[:2, :2], np.eye(2)) and \
            float(H[0, 2]).is_integer() and float(H[1, 2]).is_integer():
        x, y = int(H[0, 2]), int(H[1, 2])
        if 0 <= x and 0 <= y and x + WINDOW_WIDTH <= img.shape[1] and \
                y + WINDOW_HEIGHT <= img.shape[0]:
            return np.ascontiguousarray(img[y:y + WINDOW_HEIGHT, x:x + WINDOW_WIDTH])
    return None


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


#: bump when a representation's definition changes: old cache files then stop matching
FEATURE_VERSION = 4


class FeatureCache:
    """Computes features of window sets once per (dataset, window set, representation).

    The matrices it returns are read-only memory maps of its cache files: the operating
    system pages them in and out, and worker processes receive them by file name rather
    than as copies, so a paper-scale run holds no more of them in memory than it reads.
    """

    def __init__(self, ds: Dataset, cache_dir, *, n_jobs: int = 1, progress: bool = True):
        self.ds = ds
        self.dir = Path(cache_dir)
        self.n_jobs = n_jobs
        self.progress = progress
        self._mem = {}

    def _file(self, ws: WindowSet, rep) -> Path:
        rep = feature_key(rep)
        h = hashlib.sha256(
            f"v{FEATURE_VERSION}|{self.ds.fingerprint}|{ws.key}|{rep}|{len(ws)}".encode())
        for rel, H, *_ in ws.items[:50]:
            h.update(rel.encode())
            for M in (H if isinstance(H, tuple) else (H,)):
                h.update(np.round(M, 9).tobytes())
        safe = re.sub(r"[^A-Za-z0-9_.-]", "_", rep)[:40]
        return self.dir / f"{safe}-{h.hexdigest()[:20]}.npy"

    def get(self, ws: WindowSet, rep) -> np.ndarray:
        """(len(ws), d) float32 features of ``ws`` in representation ``rep``."""
        return self.get_many(ws, [rep])[feature_key(rep)]

    def _load(self, ws, rep):
        f = self._file(ws, rep)
        if f in self._mem:
            return self._mem[f]
        if f.is_file():
            try:
                X = np.load(f, mmap_mode="r")
                if X.ndim == 2 and X.shape[0] == len(ws):
                    self._mem[f] = X
                    return X
            except (ValueError, OSError):
                pass  # a truncated cache file: recompute it
        return None

    def get_many(self, ws: WindowSet, reps) -> dict:
        """Features of ``ws`` in several representations (names or feature objects, see
        :func:`compute_representations`), keyed by name, computing the missing ones in a
        single pass over the windows (shared reads, warps and gradients)."""
        by_key = {feature_key(r): r for r in reps}
        out = {k: self._load(ws, r) for k, r in by_key.items()}
        missing = [by_key[k] for k, X in out.items() if X is None]
        if missing:
            computed = self._compute(ws, missing)
            self.dir.mkdir(parents=True, exist_ok=True)
            for r, X in computed.items():
                f = self._file(ws, r)
                with atomic_path(f, suffix=".npy") as tmp:   # unique per writer
                    np.save(tmp, X)
                self._mem.pop(f, None)
                mapped = self._load(ws, r)             # None for an empty matrix
                out[r] = X if mapped is None else mapped
        return out

    def _compute(self, ws: WindowSet, reps) -> dict:
        from joblib import Parallel, delayed
        from tqdm.auto import tqdm

        if len(ws) == 0:
            return {feature_key(r): np.zeros((0, 0), np.float32) for r in reps}
        chunks = np.array_split(np.arange(len(ws)), max(1, min(len(ws) // 64, 256)))
        root = self.ds.root
        names = "+".join(r if isinstance(r, str) else str(r.key) for r in reps)
        it = tqdm(chunks, desc=f"features {names} {ws.key}", leave=False,
                  disable=not self.progress)
        # each task carries its own windows only (not the whole set, which would be
        # pickled again for every chunk)
        tasks = ([ws.items[i] for i in idx] for idx in it)
        if self.n_jobs == 1:
            parts = [_chunk_features(items, root, reps) for items in tasks]
        else:
            parts = Parallel(n_jobs=self.n_jobs)(
                delayed(_chunk_features)(items, root, reps, worker=True) for items in tasks)
        return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def _chunk_features(items, root, reps, worker: bool = False) -> dict:
    """:func:`compute_representations` of the windows ``items`` (``WindowSet`` items); in a
    worker process OpenCV runs single-threaded (the workers share the cores; OpenCV's own
    threads on 64x128 windows only add synchronisation)."""
    if worker:
        import cv2

        cv2.setNumThreads(1)
    return compute_representations(list(WindowSet("", items, pd.DataFrame()).images(root)),
                                   reps)


#: the rotations (degrees) of the rotated negative pool
ROTATIONS_DEG = (-60.0, -30.0, 30.0, 60.0)


def rotation_about_centre(degrees: float, size=(WINDOW_WIDTH, WINDOW_HEIGHT)) -> np.ndarray:
    """3x3 ``H`` with ``out(p) = win(H p)``: the window turned by ``degrees`` (image
    coordinates, y down) about its centre pixel ``((w - 1) / 2, (h - 1) / 2)``."""
    a = np.radians(float(degrees))
    c, s = np.cos(a), np.sin(a)
    cx, cy = (size[0] - 1) / 2, (size[1] - 1) / 2
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
    return translation(cx, cy) @ R @ translation(-cx, -cy)


def rotated_windows(ws: WindowSet, degrees: float) -> WindowSet:
    """The windows of ``ws`` rotated about their centres, read from the whole image."""
    return ws.warped(rotation_about_centre(degrees), f"rot{degrees:+.0f}", crop_first=False)


def scale_about_centre(sx: float, sy: float,
                       size=(WINDOW_WIDTH, WINDOW_HEIGHT)) -> np.ndarray:
    """3x3 ``H`` with ``out(p) = win(H p)``: the window's content magnified ``sx`` times
    across and ``sy`` times down about its centre pixel (``sy > 1``: a taller person)."""
    cx, cy = (size[0] - 1) / 2, (size[1] - 1) / 2
    return translation(cx, cy) @ np.diag([1.0 / sx, 1.0 / sy, 1.0]) @ translation(-cx, -cy)


def scaled_windows(ws: WindowSet, sx: float, sy: float) -> WindowSet:
    """The windows of ``ws`` magnified by ``(sx, sy)`` about their centres, each cut out
    first (a person crop has no context beyond its window: pixels a shrunk window needs
    from outside it are its border's, :meth:`WindowSet.warped`)."""
    return ws.warped(scale_about_centre(sx, sy), f"scale{sx:g}x{sy:g}")
