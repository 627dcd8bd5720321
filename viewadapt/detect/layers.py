"""Several frame resolutions: small persons' windows read an upsampled band of the frame.

A person 30-48 px tall covers 2-3 px per source cell, and the frame's native cells are then
too coarse and noisy a sample of it (image warping interpolates such a window up to 64x128
first). :func:`build_multiresolution_operator` gives the windows of persons smaller than
``96 * upsample_below`` px the cells of the frame upsampled 2x (bilinear) -- only the band
of rows they cover -- and the others the frame's own: ordinary adapted operators, each
window still scored by ``w^T G_n x``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..arrays import stored_array, under_prefix, with_prefix
from ..geometry import WINDOW_CORNERS, map_points
from .channels import check_frame
from .templates import SnappedBoxes, check_windows
from .windows import CandidateWindows

__all__ = ["UPSAMPLE_BELOW", "UPSAMPLE_FACTOR", "check_upsample_below", "frame_to_band",
           "upsampled_windows", "upsampled_band",
           "MultiResolutionOperator", "build_multiresolution_operator"]

#: Windows with fewer frame pixels per canonical pixel than this (persons smaller than
#: ``96 * UPSAMPLE_BELOW`` = 48 px) read the frame upsampled :data:`UPSAMPLE_FACTOR` times;
#: chosen on rendered frames (docs/findings.md, "full frames").
UPSAMPLE_BELOW = 0.5
UPSAMPLE_FACTOR = 2


def check_upsample_below(value, name: str = "upsample_below"):
    """``value`` as a float (None stays None: each detector kind's own threshold); a
    ValueError naming ``name`` when it is not a finite number >= 0."""
    if value is None:
        return None
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = float("nan")
    if not np.isfinite(v) or v < 0:
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    return v


def upsampled_windows(windows: CandidateWindows, factor: int) -> CandidateWindows:
    """The same windows in the frame upsampled ``factor`` times (``cv2.resize``, pixel
    centres ``u' = f u + (f - 1) / 2``)."""
    f = int(factor)
    if f < 1:
        raise ValueError(f"factor must be a positive integer, got {factor!r}")
    w, h = windows.image_size
    return _band_windows(windows, f, (0, h))


def frame_to_band(f, r0) -> np.ndarray:
    """Homography from the frame's pixels to those of its rows ``r0..`` upsampled ``f``
    times by ``cv2.resize`` (pixel centres ``u' = f u + (f - 1) / 2``)."""
    c = (f - 1) / 2.0
    return np.array([[f, 0.0, c], [0.0, f, c - f * r0], [0.0, 0.0, 1.0]])


def _band_windows(windows, f, rows):
    """``windows`` in the band of frame rows ``rows = (r0, r1)`` upsampled ``f`` times."""
    r0, r1 = rows
    return CandidateWindows(windows.ground_xy, windows.person_height,
                            frame_to_band(f, r0) @ windows.homographies,
                            (f * windows.image_size[0], f * (r1 - r0)), windows.grid_index,
                            windows.camera, windows.dist)


class _Layer(NamedTuple):
    factor: int                    # upsampling of the frame this layer reads
    operator: object               # adapted operator in that frame's band coordinates
    index: np.ndarray              # (k,) its windows
    rows: tuple                    # (r0, r1): the frame rows upsampled (all rows if 1)


#: Context kept around an upsampled band, frame px: gradients, block normalisation and ACF
#: smoothing near the band's edges never reach a window's cells (16 px = 2 cells of 16 px
#: in the 2x frame, and the band starts on a multiple of every cell size).
_BAND_MARGIN = 16
_BAND_ALIGN = 48                   # lcm of the allowed cell sizes, upsampled-frame px


class MultiResolutionOperator(SnappedBoxes):
    """Adapted operators of one camera over the frame and an upsampled copy of it.

    Windows of small persons (frame pixels per canonical pixel ``s`` below
    ``upsample_below``) read cells of the frame upsampled ``factor`` times (bilinear), and
    only the band of rows those windows cover (plus a margin) is upsampled; the others
    read the frame itself. Each part is an ordinary adapted operator
    (:class:`AdaptedLinearOperator`, :class:`AdaptedTreesOperator`) built for its windows
    in its own frame's coordinates, so every window's score is still ``w^T G_n x`` -- with
    ``x`` the cells of the frame it reads. Built by :func:`build_multiresolution_operator`.

    Attributes
    ----------
    layers : list of (factor, operator, (k,) window indices, (r0, r1) frame rows)
    snapped_homographies : (N, 3, 3) ndarray
        Each window's scored homography, in the frame's own pixels.
    """

    def __init__(self, windows, layers):
        self._set_layers(tuple(windows.image_size), len(windows), layers)

    def _set_layers(self, image_size, n_windows, layers):
        self.image_size = tuple(image_size)
        self.n_windows = int(n_windows)
        self.layers = [_Layer(*layer) for layer in layers]
        H = np.empty((self.n_windows, 3, 3))
        for f, op, idx, (r0, _) in self.layers:
            H[idx] = np.linalg.inv(frame_to_band(f, r0)) @ op.snapped_homographies
        self.snapped_homographies = H
        first = self.layers[0].operator
        self.nms_overlap, self.nms_threshold = first.nms_overlap, first.nms_threshold

    def to_arrays(self, layer_to_arrays):
        """The operator as ``(meta, arrays)`` (its stored form,
        :class:`~viewadapt.io.cache.OperatorCache`): frame size, window count, and per
        layer its factor, rows and operator -- ``layer_to_arrays(op) -> (meta, arrays)``,
        arrays under ``layer{i}/`` -- with ``layer{i}/index`` its windows."""
        meta = dict(image_size=[int(v) for v in self.image_size], n_windows=self.n_windows,
                    layers=[])
        arrays = {}
        for i, layer in enumerate(self.layers):
            m, a = layer_to_arrays(layer.operator)
            meta["layers"].append(dict(factor=int(layer.factor),
                                       rows=[int(r) for r in layer.rows], operator=m))
            arrays.update(with_prefix(f"layer{i}/", a))
            arrays[f"layer{i}/index"] = np.asarray(layer.index, np.int64)
        return meta, arrays

    @classmethod
    def from_arrays(cls, meta: dict, arrays: dict, layer_from_arrays):
        """The operator :meth:`to_arrays` gave, each layer's operator rebuilt by
        ``layer_from_arrays(meta, arrays)``; ``ValueError`` unless the layers' windows
        are every window exactly once, each layer's operator is of its windows and frame
        band, and its factor and rows are those of a band of the frame."""
        size, n, layers = meta.get("image_size"), meta.get("n_windows"), meta.get("layers")
        if not (isinstance(size, list) and len(size) == 2
                and all(isinstance(v, int) and v > 0 for v in size)
                and isinstance(n, int) and n > 0 and isinstance(layers, list) and layers):
            raise ValueError("its frame size, window count or layers are not valid")
        w, h = size
        out, seen = [], np.zeros(n, np.int64)
        for i, layer in enumerate(layers):
            if not isinstance(layer, dict):
                raise ValueError(f"its layer {i} is not valid")
            f, rows = layer.get("factor"), layer.get("rows")
            if not (isinstance(f, int) and 1 <= f <= 8 and isinstance(rows, list)
                    and len(rows) == 2 and all(isinstance(r, int) for r in rows)
                    and 0 <= rows[0] < rows[1] <= h):
                raise ValueError(f"its layer {i} has factor {f!r} and rows {rows!r}")
            index = stored_array(arrays, f"layer{i}/index", "iu", ndim=1)
            if len(index) == 0 or index.min() < 0 or index.max() >= n:
                raise ValueError(f"its layer {i} has windows outside 0..{n - 1}")
            seen += np.bincount(index, minlength=n)
            op = layer_from_arrays(layer.get("operator"), under_prefix(f"layer{i}/", arrays))
            band = (f * w, f * (rows[1] - rows[0])) if f > 1 else (w, h)
            if op.n_windows != len(index) or tuple(op.image_size) != band:
                raise ValueError(f"its layer {i}'s operator is not of its windows and band")
            out.append((f, op, index.astype(np.int64), (rows[0], rows[1])))
        if (seen != 1).any():
            raise ValueError("its layers do not hold every window exactly once")
        obj = cls.__new__(cls)
        obj._set_layers((w, h), n, out)
        return obj

    @property
    def n_templates(self) -> int:
        return sum(layer.operator.n_templates for layer in self.layers)

    @property
    def cell_sizes(self) -> list:
        """Cell sizes in frame pixels (``c / factor`` on an upsampled layer)."""
        return sorted(set(c / layer.factor for layer in self.layers
                          for c in layer.operator.cell_sizes))

    def feature_pixels(self) -> int:
        """Pixels whose channels are computed per frame, all layers."""
        return sum(layer.operator.feature_pixels() for layer in self.layers)

    def position_weights(self) -> np.ndarray:
        """Adapted weights of each distinct scored position, all layers (linear models)."""
        return np.concatenate([layer.operator.position_weights() for layer in self.layers])

    def frame_features(self, image) -> list:
        """One :class:`FrameFeatures` per layer."""
        img = check_frame(image, self.image_size)
        return [layer.operator.frame_features(upsampled_band(img, layer.factor, layer.rows))
                for layer in self.layers]

    def scores(self, features) -> np.ndarray:
        """(N,) scores of all windows from :meth:`frame_features`."""
        if len(features) != len(self.layers):
            raise ValueError(f"features must be a list of {len(self.layers)} FrameFeatures "
                             "(MultiResolutionOperator.frame_features)")
        out = np.empty(self.n_windows)
        for layer, feats in zip(self.layers, features):
            out[layer.index] = layer.operator.scores(feats)
        return out


def upsampled_band(img, f, rows):
    """Rows ``r0:r1`` of ``img`` upsampled ``f`` times: the same pixels as those rows of the
    whole frame upsampled by ``cv2.resize`` (two rows of context resized with them)."""
    import cv2

    if f == 1:
        return img
    r0, r1 = rows
    a, b = max(r0 - 2, 0), min(r1 + 2, img.shape[0])
    big = cv2.resize(np.ascontiguousarray(img[a:b]), (f * img.shape[1], f * (b - a)),
                     interpolation=cv2.INTER_LINEAR)
    return big[f * (r0 - a):f * (r1 - a)]


def build_multiresolution_operator(windows: CandidateWindows, build, *,
                                   upsample_below: float = UPSAMPLE_BELOW,
                                   factor: int = UPSAMPLE_FACTOR) -> MultiResolutionOperator:
    """Adapted operators of small persons' windows on an upsampled frame, the rest native.

    Parameters
    ----------
    windows : CandidateWindows
    build : callable
        ``build(windows) -> operator``, e.g.
        ``lambda w: build_adapted_linear_operator(w, weights, bias)``; called once per
        layer with that layer's windows in its own frame's coordinates (for the upsampled
        layer: the band of frame rows its windows cover, upsampled).
    upsample_below : float
        Windows with fewer than this many frame pixels per canonical-window pixel (a person
        of ``96 s`` px) read the upsampled frame; 0 = none.
    factor : int
        Upsampling of that frame.

    Returns
    -------
    MultiResolutionOperator
    """
    check_windows(windows)
    if upsample_below is None:
        raise ValueError("upsample_below must be >= 0, got None")
    upsample_below = check_upsample_below(upsample_below)
    f = int(factor)
    small = windows.scale < upsample_below
    w, h = windows.image_size
    layers = []
    idx = np.flatnonzero(~small)
    if len(idx):
        layers.append((1, build(windows.subset(idx)), idx, (0, h)))
    idx = np.flatnonzero(small)
    if len(idx):
        sub = windows.subset(idx)
        # the rows the windows cover, in upsampled px, widened by the margin; the band
        # starts on a multiple of every cell size and of f
        ys = f * map_points(sub.homographies, WINDOW_CORNERS)[:, :, 1] + (f - 1) / 2
        align = _BAND_ALIGN // math.gcd(_BAND_ALIGN, f) * f
        y0 = max(0, int(np.floor((ys.min() - f * _BAND_MARGIN) / align)) * align)
        y1 = min(f * h, int(np.ceil(ys.max() + f * _BAND_MARGIN)))
        rows = (y0 // f, -(-y1 // f))
        layers.append((f, build(_band_windows(sub, f, rows)), idx, rows))
    return MultiResolutionOperator(windows, layers)

