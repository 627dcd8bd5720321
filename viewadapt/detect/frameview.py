"""Training windows as the full-frame adapted detectors see them ("frame-view copies").

The adapted detector never sees a person at the canonical 64x128 resolution. It reads the
frame's block-normalised cells, ``c`` px wide on the frame's own grid, and remaps them to
the canonical window's 8-px cells (``G x``, :mod:`viewadapt.detect`). A person 30-90 px
tall is then a coarser, phase-shifted and resampled version of what the detector was trained
on. Image warping has the same loss of detail but computes its cells on the window's own
grid.

:func:`frame_view_features` puts a source window into that situation without any target
data. It shrinks the window (with reflected context) to ``scale`` times its size, at a
sub-cell offset, and computes the frame features there exactly as the operator does:
the 2x band below ``upsample_below``, the cell size of :func:`choose_cell_sizes`, and
``G`` of :func:`viewadapt.detect.build_adapted_linear_operator`. A test checks it
against the operator's score.

A linear SVM trained on the crops plus one such copy of each learns weights that hold up
under that resampling, and the ACF trees likewise (measured effects: docs/findings.md).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import scipy.sparse as sp

from .._validation import check_image
from ..geometry import WINDOW_HEIGHT, WINDOW_WIDTH
from .channels import HOG_CELL
from .features import FeatureKind, HOG_FEATURES
from .layers import UPSAMPLE_BELOW, UPSAMPLE_FACTOR, frame_to_band
from .templates import (
    CELLS_PER_SOURCE_CELL, FRAME_CELL_SIZES, TemplateGroup, choose_cell_sizes, patch_grid,
)
from .windows import window_scale

__all__ = ["FRAME_VIEW_SCALES", "frame_view", "frame_view_features", "frame_view_copies"]

#: Scales (frame px per canonical px) the copies are drawn from: persons of 24 to 144 px,
#: log-spaced (the surveillance frames' range; a grid so that ``G`` is built once each).
FRAME_VIEW_SCALES = tuple(float(v) for v in np.round(np.geomspace(0.25, 1.5, 12), 4))

#: Reflected context around the window before shrinking, canonical px (3 source cells).
_CONTEXT = 24


def _frame_view_geometry(scale, offset, f, image_shape):
    """(H, shrunken frame size): canonical window -> frame px, for a window with
    ``_CONTEXT + offset`` px of context on the left/top, shrunk by ``scale``."""
    ox, oy = offset
    h, w = image_shape
    big_w, big_h = w + 2 * (_CONTEXT + ox), h + 2 * (_CONTEXT + oy)
    W, H = max(1, int(round(big_w * scale))), max(1, int(round(big_h * scale)))
    sx, sy = W / big_w, H / big_h
    Hm = np.array([[sx, 0.0, sx * (_CONTEXT + ox + 0.5) - 0.5],
                   [0.0, sy, sy * (_CONTEXT + oy + 0.5) - 0.5],
                   [0.0, 0.0, 1.0]])
    if f > 1:
        Hm = frame_to_band(f, 0) @ Hm
    return Hm, (W, H)


@lru_cache(maxsize=1024)
def _frame_view_remap(kind, scale, offset, f, image_shape, cells_per_source_cell,
                      allowed_cell_sizes, rule, gradient_lambda):
    """``G`` (csr), the frame cell size, the patch (cx0, cy0, nx, ny) and the frame size of
    one frame view, built as the operator of ``kind`` builds them."""
    Hm, size = _frame_view_geometry(scale, offset, f, image_shape)
    # frame px per canonical px, computed as the operator does (a boundary case such as
    # 8 * 0.7 / 0.7 must pick the same cell size)
    s = window_scale(Hm)[0]
    c = int(choose_cell_sizes([s], kind.source_cell, cells_per_source_cell=cells_per_source_cell,
                              allowed=allowed_cell_sizes)[0])
    cx0, cy0, nx, ny = patch_grid(Hm, c)
    g = TemplateGroup(c, 0, (cx0, cy0), (ny, nx), np.zeros(1, int), np.zeros((1, 2), int))
    G = kind.frame_remap(Hm, g, rule)
    if gradient_lambda and kind.gradient_rows is not None:   # as the trees operator scales
        G = sp.diags(np.where(kind.gradient_rows, s ** gradient_lambda, 1.0)) @ G
    return G.tocsr(), c, (cx0, cy0, nx, ny), size


def frame_view(window, scale: float, *, offset=(0, 0)):
    """``window`` shrunk into a small frame: (frame, H) with ``H`` canonical window -> frame px.

    The window gets 24 px of reflected context (``offset`` px more on the left and top,
    which shifts it against the frame's cell grid) and is resized by ``scale`` (area
    interpolation below 1, linear above) to a uint8 frame, as a renderer would produce it.

    Parameters
    ----------
    window : (128, 64[, 3]) ndarray
    scale : float
        Frame pixels per canonical-window pixel (a person of ``96 scale`` px), > 0.
    offset : (int, int)
        Extra context, canonical px, in ``0..7``.

    Returns
    -------
    frame : (h, w[, 3]) uint8 ndarray
    H : (3, 3) ndarray
    """
    import cv2

    img = check_image(window, "window", dtype=np.float32)
    if img.shape[:2] != (WINDOW_HEIGHT, WINDOW_WIDTH):
        raise ValueError(f"window must be {WINDOW_HEIGHT}x{WINDOW_WIDTH} px, got "
                         f"{img.shape[0]}x{img.shape[1]}")
    scale = float(scale)
    if not np.isfinite(scale) or scale <= 0:
        raise ValueError(f"scale must be a positive number, got {scale!r}")
    ox, oy = (int(v) for v in offset)
    if not (0 <= ox < HOG_CELL and 0 <= oy < HOG_CELL):
        raise ValueError(f"offset must lie in 0..{HOG_CELL - 1}, got {tuple(offset)}")
    H, size = _frame_view_geometry(scale, (ox, oy), 1, img.shape[:2])
    mx, my = _CONTEXT + ox, _CONTEXT + oy
    big = cv2.copyMakeBorder(img, my, my, mx, mx, cv2.BORDER_REFLECT_101)
    frame = cv2.resize(big, size, interpolation=cv2.INTER_AREA if scale < 1
                       else cv2.INTER_LINEAR)
    return np.clip(np.rint(frame), 0, 255).astype(np.uint8), H


def frame_view_features(window, scale: float, kind: FeatureKind = HOG_FEATURES, *,
                        offset=(0, 0), cells_per_source_cell: float = CELLS_PER_SOURCE_CELL,
                        upsample_below: float = UPSAMPLE_BELOW, factor: int = UPSAMPLE_FACTOR,
                        allowed_cell_sizes=FRAME_CELL_SIZES, rule: str = "covariant",
                        gradient_lambda: float | None = None) -> np.ndarray:
    """The canonical features of ``window`` as the adapted detector of ``kind`` reads them
    from a frame in which the window is ``scale`` times its size.

    The frame is :func:`frame_view`'s, upsampled ``factor`` times if ``scale <
    upsample_below``, and featurised by ``kind.frame_features`` at the cell size the operator
    would choose. The result is ``G x`` with ``G`` the window's remapping from those cells
    to the canonical window's (``kind.frame_remap``, the gradient rows scaled by
    ``s ** gradient_lambda`` for ACF), the same ``G`` that an operator built with
    ``tolerance=0`` and these parameters applies: a model's score of the result is that
    operator's score (tested).

    Parameters
    ----------
    window : (128, 64[, 3]) ndarray
    scale : float
        Frame pixels per canonical-window pixel, > 0.
    kind : FeatureKind
        :data:`~viewadapt.detect.templates.HOG_FEATURES` (default) or
        :data:`~viewadapt.detect.templates.ACF_FEATURES`.
    offset : (int, int)
        The window's phase against the cell grid, ``0..7`` canonical px (:func:`frame_view`).
    cells_per_source_cell, upsample_below, factor, allowed_cell_sizes, rule
        As in :func:`viewadapt.detect.build_adapted_linear_operator` and
        :func:`viewadapt.detect.build_multiresolution_operator`.
    gradient_lambda : float, optional
        Default ``kind.gradient_lambda``.

    Returns
    -------
    float32 ndarray of ``kind.shape``, the layout of ``kind.window_features``.
    """
    import cv2

    lam = kind.gradient_lambda if gradient_lambda is None else gradient_lambda
    frame, _ = frame_view(window, scale, offset=offset)
    f = int(factor) if scale < upsample_below else 1
    G, c, (cx0, cy0, nx, ny), size = _frame_view_remap(
        kind, float(scale), tuple(int(v) for v in offset), f, (WINDOW_HEIGHT, WINDOW_WIDTH),
        float(cells_per_source_cell), tuple(int(v) for v in allowed_cell_sizes), rule,
        float(lam))
    if f > 1:
        frame = cv2.resize(frame, (f * size[0], f * size[1]), interpolation=cv2.INTER_LINEAR)
    ny_map, nx_map = frame.shape[0] // c, frame.shape[1] // c
    pad = max(1, -cx0, -cy0, cx0 + nx - nx_map, cy0 + ny - ny_map)
    F = kind.frame_features(frame, [c], pad=pad).maps[c]
    x = F[cy0 + pad:cy0 + pad + ny, cx0 + pad:cx0 + pad + nx].ravel()
    return np.asarray(G @ x, dtype=np.float32).reshape(kind.shape)


def frame_view_copies(windows, kind: FeatureKind = HOG_FEATURES, *, seed=0,
                      scales=FRAME_VIEW_SCALES, **kwargs) -> np.ndarray:
    """One frame-view copy of each window: a random scale of ``scales`` and a random offset.

    Parameters
    ----------
    windows : iterable of (128, 64[, 3]) ndarray
    seed : int or numpy Generator
    scales : sequence of float
    kind : FeatureKind
    **kwargs
        Passed to :func:`frame_view_features`.

    Returns
    -------
    (N, prod(kind.shape)) float32 ndarray, rows of ``frame_view_features(...).ravel()``.
    """
    if not isinstance(kind, FeatureKind):
        raise ValueError(f"kind must be a FeatureKind (HOG_FEATURES, ACF_FEATURES), got {kind!r}")
    rng = np.random.default_rng(seed)
    scales = np.asarray(scales, dtype=np.float64)
    if scales.ndim != 1 or not len(scales) or not np.all(np.isfinite(scales) & (scales > 0)):
        raise ValueError("scales must be a non-empty sequence of positive numbers")
    rows = []
    for w in windows:
        s = float(scales[rng.integers(len(scales))])
        off = (int(rng.integers(HOG_CELL)), int(rng.integers(HOG_CELL)))
        rows.append(frame_view_features(w, s, kind, offset=off, **kwargs).ravel())
    if not rows:
        return np.zeros((0, int(np.prod(kind.shape))), np.float32)
    return np.stack(rows)
