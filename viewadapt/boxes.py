"""Detection boxes ``(x, y, w, h)``: input checks and pairwise overlaps.

Boxes are in continuous pixel coordinates, as in Piotr Dollár's toolbox: a box covers
``[x, x + w) x [y, y + h)`` and its area is ``w * h`` (no "+1" pixel convention).
"""

from __future__ import annotations

import numpy as np

__all__ = ["check_boxes", "check_scores", "box_intersections", "safe_ratio", "box_iou",
           "mapped_boxes"]


def check_boxes(boxes, name: str = "boxes") -> np.ndarray:
    """Return ``boxes`` as a (N, 4) float64 array of ``(x, y, w, h)`` rows.

    An empty sequence gives a (0, 4) array. Raises ``ValueError`` for a wrong shape,
    NaN/infinite coordinates or a negative width/height.
    """
    arr = np.asarray(boxes, dtype=np.float64)
    if arr.size == 0:
        if arr.ndim == 1 or (arr.ndim == 2 and arr.shape[1] in (0, 4)):
            return np.zeros((0, 4), dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 4:
        raise ValueError(f"{name} must have shape (N, 4) with rows (x, y, w, h), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or infinite values")
    bad = np.flatnonzero((arr[:, 2] < 0) | (arr[:, 3] < 0))
    if bad.size:
        raise ValueError(
            f"{name} has negative box sizes (w < 0 or h < 0) in rows {bad[:5].tolist()}"
            + (" ..." if bad.size > 5 else "")
        )
    return arr


def check_scores(scores, n: int, name: str = "scores", other: str = "boxes") -> np.ndarray:
    """Return ``scores`` as a finite (n,) float64 array."""
    arr = np.asarray(scores, dtype=np.float64)
    if arr.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {arr.shape}")
    if arr.shape[0] != n:
        raise ValueError(f"{name} and {other} have different lengths ({arr.shape[0]} != {n})")
    if np.isnan(arr).any():
        raise ValueError(f"{name} contains NaN values")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains infinite values")
    return arr


def box_intersections(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Pairwise intersection areas, shape (len(a), len(b)), of (x, y, w, h) boxes."""
    iw = np.minimum(a[:, None, 0] + a[:, None, 2], b[None, :, 0] + b[None, :, 2]) - np.maximum(
        a[:, None, 0], b[None, :, 0]
    )
    ih = np.minimum(a[:, None, 1] + a[:, None, 3], b[None, :, 1] + b[None, :, 3]) - np.maximum(
        a[:, None, 1], b[None, :, 1]
    )
    return np.clip(iw, 0.0, None) * np.clip(ih, 0.0, None)


def safe_ratio(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    """``num / den`` with 0 where ``den == 0`` (degenerate boxes overlap nothing)."""
    out = np.zeros(np.broadcast_shapes(num.shape, den.shape), dtype=np.float64)
    np.divide(num, den, out=out, where=den > 0)
    return out


def box_iou(a, b) -> np.ndarray:
    """Pairwise intersection over union, shape (len(a), len(b)), of (x, y, w, h) boxes
    (0 for degenerate ones)."""
    a = np.asarray(a, float).reshape(-1, 4)
    b = np.asarray(b, float).reshape(-1, 4)
    inter = box_intersections(a, b)
    return safe_ratio(inter, (a[:, 2] * a[:, 3])[:, None] + (b[:, 2] * b[:, 3])[None] - inter)


def mapped_boxes(detections, mapping) -> np.ndarray:
    """Detections ``(x, y, w, h, score)`` (D, 5) through a point mapping: each box's corners
    and edge midpoints mapped by ``mapping((P, 2) points) -> (P, 2) points``, their bounding
    box kept, the score unchanged (e.g. boxes found on an undistorted frame back into the
    distorted frame's pixels)."""
    d = np.asarray(detections, dtype=np.float64).reshape(-1, 5)
    if len(d) == 0:
        return d.copy()
    x, y, w, h = d[:, 0], d[:, 1], d[:, 2], d[:, 3]
    u = np.array([0, 0.5, 1, 1, 1, 0.5, 0, 0])
    v = np.array([0, 0, 0, 0.5, 1, 1, 1, 0.5])
    pts = np.stack([x[:, None] + u * w[:, None], y[:, None] + v * h[:, None]], -1)
    q = np.asarray(mapping(pts.reshape(-1, 2)), dtype=np.float64).reshape(-1, 8, 2)
    lo, hi = q.min(axis=1), q.max(axis=1)
    return np.c_[lo, hi - lo, d[:, 4]]
