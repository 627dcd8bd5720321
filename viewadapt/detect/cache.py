"""Adapted operators cached on disk, keyed by calibration, model and parameters.

Building a camera's adapted operators (every template's ``G^T w`` or ``G[used]``) is the
offline step of Wang et al. (2017, Sec. 5.1); the cache makes it once per camera and model.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..files import atomic_path
from ..version import __version__

__all__ = ["DEFAULT_CACHE_LIMIT_GB", "check_cache_limit", "OperatorCache"]


#: default size limit of an operator cache directory, GiB (one paper camera's ACF operator
#: is about 45 MB, so a 13-camera run with both detectors holds about 0.8 GB per model)
DEFAULT_CACHE_LIMIT_GB = 2.0


def check_cache_limit(limit_gb):
    """``limit_gb`` if it is None or a finite number >= 0, else ValueError."""
    if limit_gb is not None and not (np.isfinite(limit_gb) and limit_gb >= 0):
        raise ValueError(f"the cache limit must be >= 0 GB, got {limit_gb}")
    return limit_gb


class OperatorCache:
    """Adapted operators on disk, keyed by (calibration, model, parameters).

    The key is a hash of the camera's ``K, R, t`` and image size, the model's fingerprint,
    the window and operator parameters and the library version, so a changed calibration
    or model never reuses a stale operator. Files are written atomically.

    ``limit_gb`` caps the directory's operators: after each save the least recently used
    ones (by modification time; a load refreshes it) are deleted until the rest fit, never
    the one just written. ``None`` or 0: no limit.
    """

    #: bump whenever what an operator holds or computes changes (2: ACF gradient rows
    #: scaled by s ** lambda, gather tables, G without explicit zeros; 3: block-normalised
    #: HOG cells with texture channels; 4: the "runs" tables, no CSR matrix stored; 5: one
    #: copy of the HOG templates, in the run tables; 6: the viewadapt.detect package)
    VERSION = 6

    def __init__(self, directory, limit_gb: float | None = DEFAULT_CACHE_LIMIT_GB):
        self.dir = Path(directory)
        self.limit = int(check_cache_limit(limit_gb) * 2**30) if limit_gb else None

    def key(self, parts: dict) -> str:
        import hashlib

        blob = json.dumps({"v": self.VERSION, "viewadapt": __version__, **parts},
                          sort_keys=True, default=lambda o: np.asarray(o).tolist())
        return hashlib.sha256(blob.encode()).hexdigest()[:24]

    def path(self, parts: dict) -> Path:
        return self.dir / f"operator-{self.key(parts)}.pkl"

    def load(self, parts: dict):
        import pickle

        p = self.path(parts)
        try:
            op = pickle.loads(p.read_bytes())
        except Exception:       # missing (or evicted by another process), truncated, foreign
            return None
        try:
            p.touch()           # recently used: evicted last
        except OSError:
            pass
        return op

    def save(self, parts: dict, operator) -> Path:
        import pickle

        p = self.path(parts)
        with atomic_path(p, suffix=".pkl") as tmp:   # a full disk leaves no half a file
            with open(tmp, "wb") as fh:
                pickle.dump(operator, fh, protocol=pickle.HIGHEST_PROTOCOL)
        self.evict(keep=p)
        return p

    def evict(self, keep=None) -> list:
        """Delete the least recently used operators until the directory's fit the limit
        (never ``keep``); return the deleted paths."""
        if self.limit is None:
            return []
        files = []
        for f in self.dir.glob("operator-*.pkl"):
            try:
                st = f.stat()
            except FileNotFoundError:               # evicted meanwhile by another process
                continue
            files.append((st.st_mtime, st.st_size, f))
        total = sum(size for _, size, _ in files)
        gone = []
        for _, size, f in sorted(files, key=lambda t: t[0]):
            if total <= self.limit:
                break
            if keep is not None and f == Path(keep):
                continue
            f.unlink(missing_ok=True)
            total -= size
            gone.append(f)
        return gone
