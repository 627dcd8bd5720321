"""Adapted operators cached on disk, keyed by calibration, model and parameters.

Building a camera's adapted operators (every template's ``G^T w`` or ``G[used]``) is the
offline step of Wang et al. (2017, Sec. 5.1); the cache makes it once per camera and model.

An entry is an array file (:mod:`viewadapt.io.arrayfile`) of format
``"viewadapt.operator"``, never a pickle: the operator's own arrays (templates, ``G`` rows,
run tables, geometry) with JSON metadata naming its class from :data:`OPERATOR_CLASSES`
and its feature maker from :data:`~viewadapt.detect.templates.FEATURE_MAKERS`; loading
rebuilds nothing but those classes, from checked arrays.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from viewadapt.detect.layers import MultiResolutionOperator
from viewadapt.detect.linear import AdaptedLinearOperator
from viewadapt.detect.trees import AdaptedTreesOperator
from viewadapt.io.arrayfile import read_array_file, write_array_file
from viewadapt.version import __version__

__all__ = ["DEFAULT_CACHE_LIMIT_GB", "check_cache_limit", "OPERATOR_FORMAT", "OPERATOR_CLASSES",
           "operator_to_arrays", "operator_from_arrays", "OperatorCache"]


#: default size limit of an operator cache directory, GiB (one paper camera's ACF operator
#: is about 45 MB, so a 13-camera run with both detectors holds about 0.8 GB per model)
DEFAULT_CACHE_LIMIT_GB = 2.0
#: format name of a cache entry (its format version is :attr:`OperatorCache.VERSION`)
OPERATOR_FORMAT = "viewadapt.operator"
#: The operator classes a cache entry may name: nothing else is ever built from one.
OPERATOR_CLASSES = {c.__name__: c for c in (AdaptedLinearOperator, AdaptedTreesOperator,
                                            MultiResolutionOperator)}


def check_cache_limit(limit_gb):
    """``limit_gb`` if it is None or a finite number >= 0, else ValueError."""
    if limit_gb is not None and not (np.isfinite(limit_gb) and limit_gb >= 0):
        raise ValueError(f"the cache limit must be >= 0 GB, got {limit_gb}")
    return limit_gb


def operator_to_arrays(op):
    """An adapted operator of :data:`OPERATOR_CLASSES` as ``(meta, arrays)``: its
    ``to_arrays()`` with ``meta["class"]`` its class name (a multi-resolution operator's
    layers likewise, nested); ``ValueError`` for any other object."""
    cls = type(op)
    if OPERATOR_CLASSES.get(cls.__name__) is not cls:
        raise ValueError(f"only the operators {sorted(OPERATOR_CLASSES)} can be stored, got "
                         f"{cls.__name__}")
    if cls is MultiResolutionOperator:
        meta, arrays = op.to_arrays(operator_to_arrays)
    else:
        meta, arrays = op.to_arrays()
    return {"class": cls.__name__, **meta}, arrays


def operator_from_arrays(meta, arrays, *, nested: bool = False):
    """The operator :func:`operator_to_arrays` described, built only from
    :data:`OPERATOR_CLASSES` (a multi-resolution operator's layers only from the
    single-resolution ones); ``ValueError`` for any other class or a bad entry."""
    name = meta.get("class") if isinstance(meta, dict) else None
    cls = OPERATOR_CLASSES.get(name) if isinstance(name, str) else None
    if cls is None or nested and cls is MultiResolutionOperator:
        raise ValueError(f"its operator class {name!r} is not one of {sorted(OPERATOR_CLASSES)}")
    if cls is MultiResolutionOperator:
        return cls.from_arrays(meta, arrays,
                               lambda m, a: operator_from_arrays(m, a, nested=True))
    return cls.from_arrays(meta, arrays)


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
    #: copy of the HOG templates, in the run tables; 6: the viewadapt.detect package; 7:
    #: entries are array files, operator-*.npz, never pickles). Also the entries' format
    #: version.
    VERSION = 7
    #: legacy entries (pickles of versions <= 6): never read, counted in the size limit
    #: and deleted first
    _LEGACY = "operator-*.pkl"

    def __init__(self, directory, limit_gb: float | None = DEFAULT_CACHE_LIMIT_GB):
        self.dir = Path(directory)
        self.limit = int(check_cache_limit(limit_gb) * 2**30) if limit_gb else None

    def key(self, parts: dict) -> str:
        import hashlib

        blob = json.dumps({"v": self.VERSION, "viewadapt": __version__, **parts},
                          sort_keys=True, default=lambda o: np.asarray(o).tolist())
        return hashlib.sha256(blob.encode()).hexdigest()[:24]

    def path(self, parts: dict) -> Path:
        """The entry of ``parts``: ``DIR/operator-<key>.npz``."""
        return self.dir / f"operator-{self.key(parts)}.npz"

    def load(self, parts: dict):
        """The operator cached for ``parts``, or None: a missing entry, and also one that
        cannot be read -- not an array file (a pickle is never opened), truncated, of
        another format or version, of another key, or with a bad table -- is a miss (the
        caller builds the operator and :meth:`save` overwrites the entry)."""
        p = self.path(parts)
        try:
            meta, arrays = read_array_file(p, OPERATOR_FORMAT, self.VERSION,
                                           remedy="it is rebuilt")
            if meta.get("key") != self.key(parts):
                return None
            op = operator_from_arrays(meta.get("operator"), arrays)
        except Exception:  # noqa: BLE001 - missing (or evicted by another process),
            return None     # unreadable, foreign or damaged: nothing of it was executed
        try:
            p.touch()           # recently used: evicted last
        except OSError:
            pass
        return op

    def save(self, parts: dict, operator) -> Path:
        """Write ``operator`` (one of :data:`OPERATOR_CLASSES`) as the entry of ``parts``
        (atomically: a full disk leaves no half a file), then keep to the size limit."""
        p = self.path(parts)
        meta, arrays = operator_to_arrays(operator)
        provenance = json.loads(json.dumps(parts, default=lambda o: np.asarray(o).tolist()))
        write_array_file(p, OPERATOR_FORMAT, self.VERSION,
                         {"key": self.key(parts), "key_parts": provenance, "operator": meta},
                         arrays)
        self.evict(keep=p)
        return p

    def evict(self, keep=None) -> list:
        """Delete the least recently used operators until the directory's fit the limit
        (never ``keep``; legacy ``operator-*.pkl`` entries first); return the deleted
        paths."""
        if self.limit is None:
            return []
        files = []
        for legacy, pattern in ((True, self._LEGACY), (False, "operator-*.npz")):
            for f in self.dir.glob(pattern):
                try:
                    st = f.stat()
                except FileNotFoundError:           # evicted meanwhile by another process
                    continue
                files.append((not legacy, st.st_mtime, st.st_size, f))
        total = sum(t[2] for t in files)
        gone = []
        for _, _, size, f in sorted(files, key=lambda t: t[:2]):
            if total <= self.limit:
                break
            if keep is not None and f == Path(keep):
                continue
            f.unlink(missing_ok=True)
            total -= size
            gone.append(f)
        return gone
