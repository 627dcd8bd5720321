"""Image-warping baseline (Li et al. 2008; Wang et al. 2017, Algorithm 1).

For every candidate window, warp the target-view image region into the source view with the
window's homography, then compute features on the warped window. Accurate but slow: the
features are recomputed per window. :mod:`viewadapt.remap` approximates the same thing on
features computed once.
"""

from __future__ import annotations

import numpy as np

from ._validation import check_homography
from .geometry import WINDOW_HEIGHT, WINDOW_WIDTH

__all__ = ["warp_to_source_view", "translation"]


def translation(dx: float, dy: float) -> np.ndarray:
    """(3, 3) homography ``p -> p + (dx, dy)``."""
    return np.array([[1.0, 0.0, dx], [0.0, 1.0, dy], [0.0, 0.0, 1.0]])


def warp_to_source_view(image, H_source_to_image, *, size=(WINDOW_WIDTH, WINDOW_HEIGHT),
                        interpolation: str = "linear", border: str = "replicate") -> np.ndarray:
    """Resample ``image`` into a source-view window: ``out(p) = image(H p)``.

    Parameters
    ----------
    image : (M, N[, C]) ndarray
        The target-view image (a whole frame or a region larger than the window, so that no
        border pixels enter the warped window).
    H_source_to_image : (3, 3) array_like
        Maps source-window pixel coordinates to ``image`` pixel coordinates, e.g.
        ``translation(x0, y0) @ H_st`` for a target window whose top-left pixel is
        ``(x0, y0)`` in ``image``, or a frame's window homography.
    size : (width, height)
        Output window size.
    interpolation : {"linear", "cubic", "nearest", "area"}
    border : {"replicate", "constant", "reflect"}
        What to read outside ``image``.

    Returns
    -------
    (height, width[, C]) ndarray, same dtype as ``image``.
    """
    import cv2

    img = np.asarray(image)
    if img.ndim not in (2, 3) or img.shape[0] == 0 or img.shape[1] == 0:
        raise ValueError(f"image must be a non-empty (M, N[, C]) array, got shape {img.shape}")
    if img.dtype == np.float64:
        work = img.astype(np.float32)
    elif img.dtype in (np.uint8, np.float32, np.uint16):
        work = img
    else:
        raise TypeError(f"image dtype {img.dtype} is not supported (uint8, uint16, float)")
    H = check_homography(H_source_to_image, "H_source_to_image")
    flags = {"linear": cv2.INTER_LINEAR, "cubic": cv2.INTER_CUBIC,
             "nearest": cv2.INTER_NEAREST, "area": cv2.INTER_AREA}
    borders = {"replicate": cv2.BORDER_REPLICATE, "constant": cv2.BORDER_CONSTANT,
               "reflect": cv2.BORDER_REFLECT_101}
    if interpolation not in flags:
        raise ValueError(f"interpolation must be one of {sorted(flags)}, got {interpolation!r}")
    if border not in borders:
        raise ValueError(f"border must be one of {sorted(borders)}, got {border!r}")
    w, h = (int(size[0]), int(size[1]))
    if w <= 0 or h <= 0:
        raise ValueError(f"size must be positive, got {size!r}")
    out = cv2.warpPerspective(np.ascontiguousarray(work), H, (w, h),
                              flags=flags[interpolation] | cv2.WARP_INVERSE_MAP,
                              borderMode=borders[border])
    if img.dtype == np.float64:
        out = out.astype(np.float64)
    if img.ndim == 3 and out.ndim == 2:
        out = out[:, :, None]
    return out
