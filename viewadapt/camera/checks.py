"""A camera's intrinsics and pose checked before use: one-line errors that name the field.

:func:`check_calibration` turns OpenCV's ``K, R, t`` (world Z up, ground at Z = 0,
``x_cam = R X + t``) into a :class:`~viewadapt.geometry.Camera`, whatever they came from
(a calibration file, :func:`~viewadapt.camera.calibrate.calibrate_from_ground_points`).
"""

from __future__ import annotations

import numpy as np

from viewadapt.geometry import Camera

__all__ = ["check_calibration"]


def _matrix(value, field, shape, name) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: {field} must be {_shape_words(shape)}") from None
    if a.shape != shape and not (len(shape) == 1 and a.size == shape[0] and a.ndim == 2
                                 and 1 in a.shape):
        raise ValueError(f"{name}: {field} must be {_shape_words(shape)}, got shape "
                         f"{a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: {field} has non-finite values (NaN or infinity)")
    return a.reshape(shape)


def _shape_words(shape) -> str:
    return "a 3x3 matrix of numbers" if len(shape) == 2 else "3 numbers"


def check_calibration(K, R, t, image_size, *, name: str = "calibration") -> Camera:
    """A :class:`~viewadapt.geometry.Camera` from ``K, R, t`` after checking them.

    Parameters
    ----------
    K : (3, 3) array_like
        Intrinsics: finite, upper-triangular (``K[1, 0] = K[2, 0] = K[2, 1] = 0``),
        ``K[2, 2] > 0`` (divided out if not 1), focal lengths ``fx = K[0, 0]`` and
        ``fy = K[1, 1]`` positive, principal point ``(K[0, 2], K[1, 2])`` inside the image
        (``-0.5 .. width - 0.5``, ``-0.5 .. height - 0.5``). The skew ``K[0, 1]`` may be
        non-zero.
    R : (3, 3) array_like
        World-to-camera rotation: ``R R^T = I`` within 1e-6 (then re-orthonormalised to
        the nearest rotation) and ``det R = +1``.
    t : (3,) array_like
        Finite; the camera centre ``-R^T t`` must lie above the ground (``Z > 0``).
    image_size : (width, height)
    name : str
        Starts every error message (e.g. ``"calibration cam.yaml"``).

    Returns
    -------
    Camera

    Raises
    ------
    ValueError
        One line naming the field, e.g. ``"calibration cam.yaml: K has a negative focal
        length (fx = -274)"``.
    """
    w, h = image_size
    K = _matrix(K, "K", (3, 3), name)
    R = _matrix(R, "R", (3, 3), name)
    t = _matrix(t, "t", (3,), name)
    low = {"K[1,0]": K[1, 0], "K[2,0]": K[2, 0], "K[2,1]": K[2, 1]}
    bad = [f"{k} = {v:g}" for k, v in low.items() if v != 0]
    if bad:
        raise ValueError(f"{name}: K must be upper-triangular ({', '.join(bad)}; expected "
                         "[[fx, s, cx], [0, fy, cy], [0, 0, 1]])")
    if K[2, 2] <= 0:
        raise ValueError(f"{name}: K[2,2] must be positive (normally 1), got {K[2, 2]:g}")
    K = K / K[2, 2]
    for f, v in (("fx", K[0, 0]), ("fy", K[1, 1])):
        if v <= 0:
            raise ValueError(f"{name}: K has a {'negative' if v < 0 else 'zero'} focal "
                             f"length ({f} = {v:g})")
    cx, cy = K[0, 2], K[1, 2]
    if not (-0.5 <= cx <= w - 0.5 and -0.5 <= cy <= h - 0.5):
        raise ValueError(f"{name}: K's principal point (cx, cy) = ({cx:g}, {cy:g}) lies "
                         f"outside the {w}x{h} image")
    dev = float(np.abs(R @ R.T - np.eye(3)).max())
    if dev > 1e-6:
        raise ValueError(f"{name}: R is not a rotation (R R^T differs from the identity by "
                         f"{dev:.2g}, more than 1e-6)")
    det = float(np.linalg.det(R))
    if det < 0:
        raise ValueError(f"{name}: R has determinant {det:.3g}, not +1 (a reflection, not a "
                         "rotation)")
    if dev > 1e-12:                             # the nearest rotation (Camera's own
        U, _, Vt = np.linalg.svd(R)             # check allows 1e-8)
        R = U @ Vt
    centre = -R.T @ t
    if centre[2] <= 0:
        raise ValueError(f"{name}: the camera centre -R^T t is at height {centre[2]:g} m, "
                         "at or below the ground plane Z = 0 (world Z is up; check the sign "
                         "of t)")
    return Camera(K, R, t, (int(w), int(h)))
