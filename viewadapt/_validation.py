"""Input checks shared by the public functions.

Every check raises ``ValueError`` (or ``TypeError`` for a wrong type) with a message that
names the argument and the problem, so that a user mistake never surfaces as a numpy
traceback from deep inside the library.
"""

from __future__ import annotations

import numbers

import numpy as np

__all__ = ["check_image", "check_homography", "check_elevation", "check_finite", "check_int",
           "check_stages"]


def check_image(image, name: str = "image", *, allow_color: bool = True,
                dtype=np.float64) -> np.ndarray:
    """Return ``image`` as ``dtype`` (float64 by default) in the 0..255 range, shape (M, N)
    or (M, N, 3).

    uint8 images are taken as 0..255; float images must lie in [0, 1] and are scaled by 255
    (the scale OpenCV's HOG sees, which matters for its normalisation constants).
    """
    arr = np.asarray(image)
    if arr.dtype == object or not (np.issubdtype(arr.dtype, np.number) or arr.dtype == bool):
        raise TypeError(f"{name} must be a numeric array, got dtype {arr.dtype}")
    if arr.ndim == 3 and allow_color:
        if arr.shape[2] not in (1, 3):
            raise ValueError(f"{name} must have 1 or 3 channels, got shape {arr.shape}")
        if arr.shape[2] == 1:
            arr = arr[:, :, 0]
    elif arr.ndim != 2:
        want = "(M, N) or (M, N, 3)" if allow_color else "(M, N)"
        raise ValueError(f"{name} must have shape {want}, got shape {arr.shape}")
    if arr.shape[0] == 0 or arr.shape[1] == 0:
        raise ValueError(f"{name} is empty (shape {arr.shape})")
    if arr.dtype == np.uint8:
        return arr.astype(dtype)
    if np.issubdtype(arr.dtype, np.integer) or arr.dtype == bool:
        raise TypeError(f"{name} must be uint8 (0..255) or float (0..1), got dtype {arr.dtype}")
    arr = arr.astype(np.float64)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or infinite values")
    lo, hi = float(arr.min()), float(arr.max())
    if lo < -1e-6 or hi > 1 + 1e-6:
        raise ValueError(
            f"float {name} must lie in [0, 1] (got values in [{lo:.3g}, {hi:.3g}]); "
            "pass uint8 for 0..255 images"
        )
    return (arr * 255.0).astype(dtype, copy=False)


def check_finite(arr, name: str) -> np.ndarray:
    arr = np.asarray(arr, dtype=np.float64)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return arr


def check_homography(H, name: str = "homography") -> np.ndarray:
    """Return ``H`` as a (3, 3) float64 array scaled so that ``H[2, 2] == 1`` when possible.

    Raises ``ValueError`` for a wrong shape, non-finite entries or a singular matrix.
    """
    H = np.asarray(H, dtype=np.float64)
    if H.shape != (3, 3):
        raise ValueError(f"{name} must have shape (3, 3), got {H.shape}")
    if not np.all(np.isfinite(H)):
        raise ValueError(f"{name} contains NaN or infinite values")
    scale = np.abs(H).max()
    if scale == 0 or abs(np.linalg.det(H / scale)) < 1e-12:
        raise ValueError(f"{name} is singular (det ~ 0); it does not map a plane to a plane")
    if abs(H[2, 2]) > 1e-12 * scale:
        H = H / H[2, 2]
    else:
        H = H / scale
    return H


def check_elevation(elevation, name: str = "elevation") -> float:
    """Elevation (tilt of the camera->object ray below horizontal) in radians, in [0, pi/2)."""
    try:
        value = float(elevation)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a number of radians, got {elevation!r}") from None
    if not np.isfinite(value) or value < 0 or value >= np.pi / 2:
        raise ValueError(f"{name} must lie in [0, pi/2) radians, got {value!r}")
    return value


def check_int(value, name: str, *, minimum: int) -> int:
    """``value`` as an ``int`` if it is an integer (not a bool) ``>= minimum``, else
    ``ValueError``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def check_stages(stages, n_estimators):
    """Boosting stages (strictly increasing tree counts, each at most ``n_estimators``) as
    a tuple of int; ``None``: ``(n_estimators,)``."""
    if stages is None:
        return (n_estimators,)
    try:
        stages = tuple(stages)
    except TypeError:
        raise ValueError(f"stages must be a sequence of tree counts or None, "
                         f"got {stages!r}") from None
    if not stages or any(isinstance(k, bool) or not isinstance(k, numbers.Integral) or k < 1
                         for k in stages):
        raise ValueError(f"stages must be positive integers, got {stages!r}")
    if any(b <= a for a, b in zip(stages, stages[1:])):
        raise ValueError(f"stages must be strictly increasing, got {stages!r}")
    if stages[-1] > n_estimators:
        raise ValueError(f"stages must not exceed n_estimators={n_estimators}, "
                         f"got {stages!r}")
    return tuple(int(k) for k in stages)
