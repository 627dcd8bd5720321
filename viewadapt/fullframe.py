"""Full-frame viewpoint-adapted detection: every candidate window its own adapted detector.

Each world-space candidate window (:mod:`viewadapt.windows`) sees the person through its
own homography ``H_n`` (canonical window -> frame), so it needs its own adapted detector
(Wang et al. 2017, Sec. 5.1: "each position in the image corresponds to a unique relative
viewpoint and associated feature mapping ... computed off-line ... looked up at run-time").
For a linear model on cell features the adapted detector of window ``n`` is

.. math:: s_n = w^T G_n x + b = (G_n^T w)^T x + b

(eq. (5)-(7)), ``x`` the frame's cell features and ``G_n = S_n \\otimes A_n`` the remapping
from frame cells to the canonical window's cells (:func:`viewadapt.remap.feature_remap_matrix`
with ``H_out_to_in = H_n``). For boosted trees only the used rows of ``G_n`` are applied
(:meth:`viewadapt.boosting.AdaBoostTrees.decision_function_remapped`).

Frame features at native resolution
-----------------------------------
The frame's per-pixel channels are computed once (no image resampling). They are summed
into square cells whose size ``c`` is chosen per window close to the size of one of the
window's source cells in the frame (``8 s`` px for HOG, ``4 s`` for ACF, ``s`` the window's
frame pixels per canonical pixel), so that every window reads about one frame cell per
source cell; :class:`FrameFeatures` holds one cell map per size in use.

Small persons: an upsampled frame
---------------------------------
A person 30-48 px tall covers 2-3 px per source cell, and the frame's native cells are then
too coarse and noisy a sample of it (image warping interpolates such a window up to 64x128
first). :func:`build_multiresolution_operator` gives the windows of persons smaller than
``96 * upsample_below`` px the cells of the frame upsampled 2x (bilinear), and the others
the frame's own: two ordinary operators, each window still scored by ``w^T G_n x``.

The operator
------------
Neighbouring windows have nearly the same ``H_n`` up to a translation. Windows whose shapes
(``H_n`` with its centre moved to the origin) agree within ``tolerance`` frame cells share
one adapted template, placed at each window's position rounded to the cell grid: window
``n`` is then scored with the *snapped* homography ``T(c \\delta_n) H_g`` (``H_g`` the group's
prototype window, ``\\delta_n`` an integer cell shift). The scores are exactly
``w^T G(\\tilde H_n) x`` for those snapped homographies (tested), and the snapping is the
quantisation every sliding-window detector makes (half a cell in position; here also up to
``tolerance`` cells in shape). ``tolerance=0`` gives one template per window at its exact
position. Windows snapped onto the same position of the same template score the same and
are scored once.

Run-time forms, all the same operator (tested against each other and against
``w^T G_n x``), measured on a 384x288 frame with ~30,000 windows
(``benchmark/perf/runtime.py``):

* ``"runs"`` (default, fastest): a compiled loop (:mod:`viewadapt._kernels`, numba) over
  the ~14,000 distinct scored positions. A template row is one contiguous run of values,
  and so is the frame map row it meets, so each position costs ``n_y`` vectorised dot
  products and reads no index arrays -- the templates (a few MB) stay in cache;
* ``"sparse"``: one CSR matrix, a row per distinct scored position, times the
  concatenated cell maps -- ~1,600 weights per row, each with its column index: memory
  bound (~190 MB read per frame), several times slower;
* ``"template"``: one ``cv2.matchTemplate`` cross-correlation per shared template over its
  windows' region -- slower, because the ~700 templates each cost a call;
* ``"gather"``: each window's patch gathered and dotted with its template.

For trees each distinct position walks the trees in order until the soft cascade stops
it, and a remapped feature is computed (a short gather-and-dot over frame cells) only at the
nodes it reaches: ``"cascade"`` (default) as a compiled loop, ``"blocks"`` in numpy over
blocks of trees and all positions still alive (about four times slower).

References
----------
.. [1] P. Wang, K. Morton, P. Torrione, L. Collins, "Viewpoint Adaptation for Rigid Object
   Detection", arXiv preprint, 2017.
.. [2] N. Dalal, B. Triggs, "Histograms of Oriented Gradients for Human Detection", CVPR 2005.
.. [3] P. Dollár, R. Appel, S. Belongie, P. Perona, "Fast Feature Pyramids for Object
   Detection", IEEE TPAMI 36(8), 2014.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from ._validation import check_image
from .geometry import WINDOW_HEIGHT, WINDOW_WIDTH
from .boosting import cascade_step
from .nms import non_maximum_suppression
from .remap import CellGrid, feature_remap_matrix
from .windows import CandidateWindows, _map_points, person_boxes

__all__ = [
    "HOG_CELL", "FRAME_CELL_SIZES", "ACF_SHRINK",
    "fast_orientation_channels",
    "fast_acf_pixel_channels",
    "acf_window_features",
    "FrameFeatures",
    "HOG_CHANNELS", "HOG_WEIGHT_SHAPE",
    "cell_sums", "orientation_cell_maps", "channel_slices3", "correlate_slices",
    "block_normalize_cells",
    "hog_window_features",
    "hog_frame_features",
    "acf_frame_features",
    "choose_cell_sizes",
    "group_windows",
    "AdaptedLinearOperator",
    "AdaptedTreesOperator",
    "build_adapted_linear_operator",
    "build_adapted_trees_operator",
    "MultiResolutionOperator", "build_multiresolution_operator", "upsampled_windows",
    "detections_from_scores",
]

#: Source-view cell size of the HOG detectors (8 px in the 64x128 window, 16 x 8 cells).
HOG_CELL = 8
#: Frame cell sizes the adapted operators may choose from (:func:`choose_cell_sizes`).
FRAME_CELL_SIZES = (2, 3, 4, 6, 8, 12, 16)
#: Source-view ACF aggregation block (4 px, 32 x 16 blocks).
ACF_SHRINK = 4
#: Power-law exponent of the ACF gradient channels across scales (Dollár et al. 2014):
#: channels computed on the frame at ``s`` frame pixels per canonical pixel are, on average,
#: ``s ** -lambda`` times those of the same window warped to the canonical size, so the
#: adapted operator multiplies the remapped magnitude and orientation channels by
#: ``s ** lambda``. Measured without labels on 360 random candidate windows of the small
#: Blender set's frames, s = 0.26..1.05: 0.365 (``python -m benchmark.perf.acf_scaling``).
ACF_GRADIENT_LAMBDA = 0.365
_N_HOG_BINS = 9
#: Channels per cell of the full-frame HOG features: 9 orientations, 4 texture energies
#: (:func:`block_normalize_cells`).
HOG_CHANNELS = _N_HOG_BINS + 4
#: Shape of a source-view HOG/SVM weight array (cells down, cells across, channels).
HOG_WEIGHT_SHAPE = (WINDOW_HEIGHT // HOG_CELL, WINDOW_WIDTH // HOG_CELL, HOG_CHANNELS)
#: Clipping of block-normalised HOG values (Dalal & Triggs' L2-Hys threshold).
HOG_CLIP = 0.2
_N_ACF = 10
_N_ORIENT_ACF = 6
_CENTRE = np.array([(WINDOW_WIDTH - 1) / 2.0, (WINDOW_HEIGHT - 1) / 2.0])
_PROBES = np.array([[-0.5, -0.5], [WINDOW_WIDTH - 0.5, -0.5], [WINDOW_WIDTH - 0.5,
                    WINDOW_HEIGHT - 0.5], [-0.5, WINDOW_HEIGHT - 0.5],
                    [(WINDOW_WIDTH - 1) / 2.0, -0.5], [(WINDOW_WIDTH - 1) / 2.0,
                                                       WINDOW_HEIGHT - 0.5]])


# ---------------------------------------------------------------------------- features


def _strongest_gradient(dx, dy):
    """Per pixel of (M, N, K) float32 derivatives, the ``(dx, dy)`` planes of the channel of
    largest magnitude (ties keep the earlier channel)."""
    from ._kernels import strongest_gradient

    gx = np.empty(dx.shape[:2], np.float32)
    gy = np.empty(dx.shape[:2], np.float32)
    strongest_gradient(dx, dy, gx, gy)
    return gx, gy


def _gradient_polar(img):
    """HOG gradients of a float32 (M, N[, 3]) image: central differences with reflect-101
    borders, the colour channel of largest magnitude; ``(magnitude, angle in [0, 2 pi))``."""
    import cv2

    k = np.array([[-1.0, 0.0, 1.0]], np.float32)
    dx = cv2.filter2D(img, cv2.CV_32F, k, borderType=cv2.BORDER_REFLECT_101)
    dy = cv2.filter2D(img, cv2.CV_32F, k.T, borderType=cv2.BORDER_REFLECT_101)
    if img.ndim == 3:
        dx, dy = _strongest_gradient(dx, dy)
    return cv2.cartToPolar(dx, dy)


def fast_orientation_channels(image, *, n_bins: int = 9, gamma: bool = False) -> np.ndarray:
    """Per-pixel oriented gradient magnitudes in float32 (OpenCV kernels, compiled channel pick).

    The same quantity as :func:`viewadapt.hog.orientation_channels`:
    (optionally square-root gamma, then) central differences with reflect-101 borders, the
    colour channel of largest magnitude, the magnitude split linearly between the two
    nearest of ``n_bins`` unsigned bins centred at ``(b + 1/2) pi / n_bins``; in single
    precision.

    Parameters
    ----------
    image : (M, N[, 3]) ndarray, uint8 or float in [0, 1]
    n_bins : int
    gamma : bool
        Square-root gamma first (OpenCV's default).

    Returns
    -------
    (M, N, n_bins) float32 ndarray
    """
    import cv2

    img = check_image(image).astype(np.float32)
    if gamma:
        img = cv2.sqrt(img)
    mag, ang = _gradient_polar(img)
    # OpenCV element-wise calls on contiguous planes throughout: several times faster than
    # numpy on strided channel views (measured in benchmark/perf/runtime.py's feature time)
    t = cv2.subtract(cv2.multiply(ang, n_bins / np.pi), 0.5)      # in [-0.5, 2 n_bins)
    for _ in range(2):                                            # t mod n_bins
        cv2.add(t, float(n_bins), t, mask=cv2.compare(t, 0.0, cv2.CMP_LT))
        cv2.subtract(t, float(n_bins), t, mask=cv2.compare(t, float(n_bins), cv2.CMP_GE))
    planes = []
    for b in range(n_bins):
        d = cv2.absdiff(t, float(b))
        d = cv2.min(d, cv2.subtract(float(n_bins), d))             # circular distance
        planes.append(cv2.multiply(cv2.max(cv2.subtract(1.0, d), 0.0), mag))
    out = cv2.merge(planes)
    return out.reshape(mag.shape + (n_bins,))


def fast_acf_pixel_channels(image) -> np.ndarray:
    """:func:`viewadapt.acf.acf_pixel_channels` (default parameters) in float32 with OpenCV.

    The same channels -- toolbox LUV smoothed by ``convTri(., 1)``, gradient magnitude of
    the strongest colour channel normalised by ``convTri(M, 5) + 0.005``, six nearest-bin
    orientation channels -- computed with OpenCV kernels in single precision, channels
    last. Differences from the float64 reference are rounding (the orientation bin of a
    pixel lying on a bin boundary may differ).

    Parameters
    ----------
    image : (M, N[, 3]) ndarray, uint8 or float in [0, 1] RGB

    Returns
    -------
    (M, N, 10) float32 ndarray, channel order of :data:`viewadapt.acf.ACF_CHANNEL_NAMES`.
    """
    import cv2

    from . import acf as _acf

    from ._kernels import acf_channels_out, rgb_to_luv

    img = check_image(image, dtype=np.float32) * np.float32(1 / 255)
    if img.ndim == 2:
        img = cv2.merge([img, img, img])
    M, N = img.shape[:2]
    f32 = np.float32
    luv = np.empty((M, N, 3), np.float32)
    rgb_to_luv(img, _acf._RGB_TO_XYZ.astype(np.float32), f32(_acf._Y0), f32(_acf._KAPPA),
               f32(_acf._LUV_SCALE), f32(_acf._UN), f32(_acf._VN), f32(_acf._U_OFFSET),
               f32(_acf._V_OFFSET), luv)
    tri1 = _acf._triangle_kernel(1).astype(np.float32)
    luv = cv2.sepFilter2D(luv, -1, tri1, tri1, borderType=cv2.BORDER_REFLECT)
    # toolbox grad1: central differences / 2 inside, one-sided at the ends
    k = np.array([[-0.5, 0.0, 0.5]], np.float32)
    gx = cv2.filter2D(luv, -1, k, borderType=cv2.BORDER_REPLICATE)
    gy = cv2.filter2D(luv, -1, k.T, borderType=cv2.BORDER_REPLICATE)
    if N > 1:
        gx[:, 0] = luv[:, 1] - luv[:, 0]
        gx[:, -1] = luv[:, -1] - luv[:, -2]
    else:
        gx[:] = 0
    if M > 1:
        gy[0] = luv[1] - luv[0]
        gy[-1] = luv[-1] - luv[-2]
    else:
        gy[:] = 0
    dx, dy = _strongest_gradient(gx, gy)
    mag = cv2.magnitude(dx, dy)
    tri5 = _acf._triangle_kernel(5).astype(np.float32)
    mag = mag / (cv2.sepFilter2D(mag, -1, tri5, tri5, borderType=cv2.BORDER_REFLECT)
                 + np.float32(0.005))
    out = np.empty((M, N, 4 + _N_ORIENT_ACF), np.float32)
    acf_channels_out(luv, mag, dx, dy, _N_ORIENT_ACF, out)
    return out


@dataclass
class FrameFeatures:
    """Cell maps of one frame, one per cell size, zero-padded by ``pad`` cells.

    Attributes
    ----------
    maps : dict int -> (ny + 2 pad, nx + 2 pad, C) float32 ndarray
        Cell ``(i, j)`` of size ``c`` covers frame pixels ``[c (j - pad), c (j - pad + 1))``
        horizontally (pixel centres at integers, origin ``(-0.5, -0.5)``), likewise
        vertically; ``ny = M // c``, ``nx = N // c``.
    pad : int
    image_size : (width, height)
    """

    maps: dict
    pad: int
    image_size: tuple
    _split: dict = field(default_factory=dict, repr=False)
    #: (cell sizes, buffer) when the maps are consecutive views of one flat buffer
    _flat: tuple = field(default=None, repr=False)

    def split3(self, c: int):
        """The map of cell size ``c`` as contiguous 3-channel slices (for matchTemplate)."""
        if c not in self._split:
            F = self.maps[c]
            self._split[c] = channel_slices3(F)
        return self._split[c]

    def vector(self, cell_sizes) -> np.ndarray:
        """All maps of ``cell_sizes`` flattened and concatenated (the sparse operator's x);
        no copy when the maps already lie in one buffer in that order."""
        if self._flat is not None and tuple(cell_sizes) == self._flat[0]:
            return self._flat[1]
        return np.concatenate([self.maps[c].ravel() for c in cell_sizes])


def _pad(F, pad):
    out = np.zeros((F.shape[0] + 2 * pad, F.shape[1] + 2 * pad, F.shape[2]), np.float32)
    out[pad:pad + F.shape[0], pad:pad + F.shape[1]] = F
    return out


def channel_slices3(A) -> list:
    """``A`` (h, w, C) as contiguous slices of at most 3 channels (``cv2.matchTemplate``
    takes at most 4 channels)."""
    return [np.ascontiguousarray(A[:, :, k:k + 3]) for k in range(0, A.shape[2], 3)]


def correlate_slices(parts, templates) -> np.ndarray:
    """Multi-channel cross-correlation: ``sum_k matchTemplate(parts[k], templates[k])``
    (``TM_CCORR``) over matching :func:`channel_slices3` of a map and of a template."""
    import cv2

    res = None
    for part, tpl in zip(parts, templates):
        r = cv2.matchTemplate(part, tpl, cv2.TM_CCORR)
        res = r if res is None else res + r
    return res


def cell_sums(channels, c: int) -> np.ndarray:
    """Sums of ``channels`` (M, N[, C]) over ``c x c`` cells: (M // c, N // c, C) float32
    (the remainder rows and columns are dropped)."""
    import cv2

    M, N = channels.shape[:2]
    ny, nx = M // c, N // c
    if c == 1:
        return channels
    src = np.ascontiguousarray(channels[:ny * c, :nx * c])
    # INTER_AREA with an integer factor is the exact block mean
    out = cv2.resize(src, (nx, ny), interpolation=cv2.INTER_AREA)
    if out.ndim == 2:
        out = out[:, :, None]
    return out * np.float32(c * c)


def _multi_cell_sums(shape, cell_sizes, from_pixels) -> dict:
    """Cell sums over a frame of ``shape`` (rows, columns) at every size in ``cell_sizes``:
    ``from_pixels(c)`` computes a size from the pixels, a size that is a multiple of a
    smaller one is summed from that size's cells (same sums, fewer pixels read)."""
    out = {}
    for c in sorted(set(int(c) for c in cell_sizes)):
        if c < 1:
            raise ValueError(f"cell sizes must be positive integers, got {c}")
        base = max((b for b in out if b > 1 and c % b == 0), default=None)
        if base is None:
            out[c] = from_pixels(c)
        else:
            r = c // base
            ny, nx = shape[0] // c, shape[1] // c
            out[c] = cell_sums(out[base][:ny * r, :nx * r], r)
    return out


def orientation_cell_maps(image, cell_sizes, *, n_bins: int = _N_HOG_BINS) -> dict:
    """Oriented gradient magnitudes summed over ``c x c`` cells, for each ``c``.

    The cell sums of :func:`fast_orientation_channels` (gamma off) -- the same quantity up
    to float32 rounding -- without the (M, N, n_bins) per-pixel array: the strongest colour
    channel's gradient and its two nearest bins go straight into the cells (a compiled
    loop, :mod:`viewadapt._kernels`). Remainder rows and columns are dropped.

    Parameters
    ----------
    image : (M, N[, 3]) ndarray, uint8 or float in [0, 1]
    cell_sizes : iterable of int
    n_bins : int

    Returns
    -------
    dict int -> (M // c, N // c, n_bins) float32 ndarray
    """
    from ._kernels import orientation_cell_sums

    mag, ang = _gradient_polar(check_image(image, dtype=np.float32))
    M, N = mag.shape

    def from_pixels(c):
        out = np.zeros((M // c, N // c, n_bins), np.float32)
        orientation_cell_sums(mag, ang, n_bins, c, out)
        return out

    return _multi_cell_sums(mag.shape, cell_sizes, from_pixels)


def _check_frame(image, image_size):
    arr = np.asarray(image)
    if arr.ndim < 2:
        raise ValueError(f"frame must be an (M, N[, 3]) image, got shape {arr.shape}")
    if image_size is not None and (arr.shape[1], arr.shape[0]) != tuple(image_size):
        raise ValueError(f"frame is {arr.shape[1]}x{arr.shape[0]} px but the calibration "
                         f"and the precomputed detector are for {image_size[0]}x"
                         f"{image_size[1]} frames")
    return arr


def block_normalize_cells(cells, *, eps: float = 1.0, clip: float = HOG_CLIP,
                          out=None) -> np.ndarray:
    """Window-independent HOG cell features: Dalal-Triggs block normalisation per cell.

    Each cell's histogram ``X[l]`` is divided by the L2 norm of each of the four 2x2-cell
    blocks that contain it and clipped at ``clip`` (the L2-Hys threshold), giving four
    normalised copies ``F_k[l]``; these are reduced analytically as Felzenszwalb et al.
    (2010) do, to the 9 orientation sums ``sum_k F_k[l, b]`` and the 4 texture energies
    ``sum_b F_k[l, b]``:

    .. math:: F_k[l, b] = \\min\\left(\\frac{X[l, b]}
              {\\sqrt{\\sum_{l' \\in B_k(l)} \\|X[l']\\|^2 + \\epsilon^2}}, c\\right)

    The blocks lie on the image's own cell grid, never on a window's, so the features of a
    frame cell are the same for every window that reads it and ``G`` folds into linear
    weights. Numerator and denominator both grow with the cell's edge length, so the
    features are (to first order) the same at any cell size: the frame's at ``c`` px match
    the canonical window's at 8 px. Borders are reflected (``reflect-101``).

    Parameters
    ----------
    cells : (ny, nx, B) ndarray
        Oriented-magnitude cell sums.
    eps : float
        Floor of the block norm, in the cells' units (scale it with the cell area).
    clip : float
    out : (ny, nx, B + 4) float32 ndarray, optional
        Written in place (e.g. the inside of a zero-padded map); returned.

    Returns
    -------
    (ny, nx, B + 4) float32 ndarray: ``B`` orientation channels, then the texture energies
    of the up-left, up-right, down-left and down-right blocks.
    """
    from ._kernels import block_normalize

    X = np.ascontiguousarray(cells, dtype=np.float32)
    if X.ndim != 3:
        raise ValueError(f"cells must be (ny, nx, bins), got shape {X.shape}")
    ny, nx, nb = X.shape
    if out is None:
        out = np.empty((ny, nx, nb + 4), np.float32)
    elif out.shape != (ny, nx, nb + 4) or out.dtype != np.float32:
        raise ValueError(f"out must be float32 of shape {(ny, nx, nb + 4)}, got {out.dtype} "
                         f"{out.shape}")
    if X.size:
        block_normalize(X, float(eps), float(clip), out)
    return out


def hog_window_features(window, *, cell_size: int = HOG_CELL) -> np.ndarray:
    """Source-view features of the adapted HOG detector: block-normalised 8-px cells.

    :func:`block_normalize_cells` of the window's HOG cell sums (gamma off, 9 bins), the
    feature the full-frame detector reads at every cell size.

    Parameters
    ----------
    window : (128, 64[, 3]) ndarray

    Returns
    -------
    (16, 8, 13) float32 ndarray (flatten for a classifier).
    """
    X = orientation_cell_maps(window, [cell_size])[cell_size]
    return block_normalize_cells(X, eps=_hog_eps(cell_size))


def acf_window_features(window) -> np.ndarray:
    """Source-view ACF channels of a canonical window, as the full-frame detector reads them.

    :func:`acf_frame_features` of the window at the 4-px block size (the float32 OpenCV
    path of :func:`fast_acf_pixel_channels`), in the layout of
    :func:`viewadapt.acf.acf_channels`.

    Parameters
    ----------
    window : (128, 64[, 3]) ndarray

    Returns
    -------
    (10, 32, 16) float32 ndarray (flatten for a classifier).
    """
    F = acf_frame_features(window, [ACF_SHRINK], pad=0).maps[ACF_SHRINK]
    return np.ascontiguousarray(np.moveaxis(F, -1, 0))


#: Floor of :func:`block_normalize_cells` per pixel of cell area (gradient units of 0..255
#: images).
_EPS_PER_PX = 1.0


def _hog_eps(c: int) -> float:
    """Floor of the block norm for ``c x c`` cells: ``_EPS_PER_PX`` per pixel of cell area
    (the norms grow with the area, so the floor does too)."""
    return float(c * c) * _EPS_PER_PX


def hog_frame_features(image, cell_sizes, *, pad: int = 2, image_size=None) -> FrameFeatures:
    """Normalised HOG cell maps of a frame at several cell sizes, native resolution.

    The per-pixel gradients are computed once and summed into ``c x c`` cells of oriented
    magnitude for each ``c`` (:func:`orientation_cell_maps`), then
    normalised by :func:`block_normalize_cells` -- the features :func:`hog_window_features`
    computes on a canonical window with ``c = 8``.

    Parameters
    ----------
    image : (M, N[, 3]) ndarray
    cell_sizes : iterable of int
    pad : int
        Zero cells added on every side.
    image_size : (width, height), optional
        Expected frame size; a frame of another size is a ``ValueError``.

    Returns
    -------
    FrameFeatures with (M // c + 2 pad, N // c + 2 pad, 13) maps.
    """
    img = _check_frame(image, image_size)
    M, N = img.shape[:2]
    # all maps in one zero-padded buffer, in the order of the cell sizes given: the
    # operator's feature vector without a copy (FrameFeatures.vector)
    order = tuple(dict.fromkeys(int(c) for c in cell_sizes))
    cells = orientation_cell_maps(img, order)
    shapes = [(M // c + 2 * pad, N // c + 2 * pad, HOG_CHANNELS) for c in order]
    flat = np.zeros(sum(int(np.prod(sh)) for sh in shapes), np.float32)
    maps, off = {}, 0
    for c, sh in zip(order, shapes):
        F = flat[off:off + int(np.prod(sh))].reshape(sh)
        off += F.size
        X = cells[c]
        ny, nx = X.shape[:2]
        block_normalize_cells(X, eps=_hog_eps(c), out=F[pad:pad + ny, pad:pad + nx])
        maps[c] = F
    return FrameFeatures(maps, pad, (N, M), _flat=(order, flat))


def acf_frame_features(image, cell_sizes, *, pad: int = 2, smooth_channels: float = 1,
                       image_size=None, **kwargs) -> FrameFeatures:
    """ACF cell maps of a frame: pixel channels once, aggregated at each cell size.

    ``x_c = convTri(block_mean_c(P), smooth_channels)`` with ``P`` the ten full-resolution
    channels of :func:`viewadapt.acf.acf_pixel_channels` (``kwargs`` go there) -- the ACF
    channels the toolbox would compute with ``shrink = c``.

    Returns
    -------
    FrameFeatures with (ny + 2 pad, nx + 2 pad, 10) maps, channel order of
    :data:`viewadapt.acf.ACF_CHANNEL_NAMES`.
    """
    from .acf import _triangle_kernel, acf_pixel_channels, convolve_triangle

    import cv2

    img = _check_frame(image, image_size)
    if kwargs:
        P = acf_pixel_channels(img, shrink=1, **kwargs).astype(np.float32)   # (10, M, N)
        P = np.ascontiguousarray(np.moveaxis(P, 0, -1))
    else:
        P = fast_acf_pixel_channels(img)
    M, N = P.shape[:2]
    tri = _triangle_kernel(smooth_channels)
    maps = {}
    for c, A in _multi_cell_sums(P.shape, cell_sizes, lambda c: cell_sums(P, c)).items():
        A = A * np.float32(1.0 / (c * c))
        if tri is not None:
            if min(A.shape[:2]) > 1:
                A = cv2.sepFilter2D(A, -1, tri.astype(np.float32), tri.astype(np.float32),
                                    borderType=cv2.BORDER_REFLECT)
            else:
                A = np.moveaxis(convolve_triangle(np.moveaxis(A, -1, 0), smooth_channels),
                                0, -1)
        maps[c] = _pad(A.astype(np.float32), pad)
    return FrameFeatures(maps, pad, (N, M))


# ---------------------------------------------------------------------------- grouping


def choose_cell_sizes(scale, source_cell: int, *, cells_per_source_cell: float = 1.0,
                      allowed=(1, 2, 3, 4, 5, 6, 8, 10, 12, 16)) -> np.ndarray:
    """Frame cell size per window: the largest allowed ``c <= source_cell * s / rho``.

    Parameters
    ----------
    scale : (N,) array_like
        Frame pixels per canonical-window pixel of each window.
    source_cell : int
        The detector's cell size in the canonical window (8 for HOG, 4 for ACF).
    cells_per_source_cell : float
        ``rho``: at least this many frame cells per source cell along each axis (1: frame
        cells no larger than the source cells' image).
    allowed : sequence of int

    Returns
    -------
    (N,) int ndarray
    """
    s = np.asarray(scale, dtype=np.float64)
    allowed = np.sort(np.asarray(allowed, dtype=np.int64))
    target = source_cell * s / cells_per_source_cell
    idx = np.searchsorted(allowed, target, side="right") - 1
    return allowed[np.maximum(idx, 0)]


def _shapes(H):
    """(N, P, 2) probe points of each window relative to its mapped centre."""
    probes = _map_points(H, _PROBES)
    centre = _map_points(H, _CENTRE)
    return probes - centre[:, None, :], centre


def group_windows(windows: CandidateWindows, cell_size, tolerance: float):
    """Group windows that share an adapted template up to a whole-cell shift.

    A quadtree over each (person height, cell size) set's ground-grid indices splits a
    block until every window's shape -- the probe points of its window (corners, top and
    bottom centre) relative to its centre -- lies within ``tolerance * c`` px of the
    block's prototype (the window nearest the block's middle).

    Parameters
    ----------
    windows : CandidateWindows
    cell_size : (N,) int array_like
    tolerance : float
        In frame cells; 0 gives one group per window.

    Returns
    -------
    list of (prototype index, (k,) member indices) tuples.
    """
    H = windows.homographies
    c = np.asarray(cell_size)
    shapes, _ = _shapes(H)
    groups = []
    keys = np.stack([np.round(windows.person_height * 1e6), c], 1)
    for key in np.unique(keys, axis=0):
        members = np.flatnonzero(np.all(keys == key, axis=1))
        if tolerance <= 0:
            groups.extend((int(m), np.array([m])) for m in members)
            continue
        tau = tolerance * key[1]
        stack = [members]
        while stack:
            m = stack.pop()
            ij = windows.grid_index[m].astype(np.float64)
            mid = np.median(ij, axis=0)
            proto = m[np.argmin(np.abs(ij - mid).sum(1))]
            dev = np.abs(shapes[m] - shapes[proto]).max(axis=(1, 2))
            if dev.max() <= tau or len(m) == 1:
                groups.append((int(proto), m))
                continue
            span = ij.max(0) - ij.min(0)
            ax = int(np.argmax(span))
            if span[ax] == 0:                      # same grid cell (cannot happen): split
                half = len(m) // 2
                stack += [m[:half], m[half:]]
                continue
            cut = np.median(ij[:, ax])
            left = ij[:, ax] <= cut
            if left.all() or not left.any():
                left = ij[:, ax] < cut if (ij[:, ax] < cut).any() else ij[:, ax] <= ij[:, ax].min()
            stack += [m[left], m[~left]]
    return groups


def _patch_grid(H, c, image_size):
    """Frame-cell patch covering the footprint of window ``H``: (cx0, cy0, n_x, n_y)."""
    corners = _map_points(H[None], _PROBES[:4])[0]
    lo = np.floor((corners.min(0) + 0.5) / c).astype(int)
    hi = np.ceil((corners.max(0) + 0.5) / c).astype(int)
    return int(lo[0]), int(lo[1]), int(max(hi[0] - lo[0], 1)), int(max(hi[1] - lo[1], 1))


def _translation(dx, dy):
    return np.array([[1.0, 0.0, dx], [0.0, 1.0, dy], [0.0, 0.0, 1.0]])


@dataclass
class _Group:
    cell_size: int
    prototype: int                 # window index of the prototype
    origin: tuple                  # (cx0, cy0): prototype patch's top-left frame cell
    shape: tuple                   # (n_y, n_x) patch size in cells
    members: np.ndarray            # (k,) window indices
    shifts: np.ndarray             # (k, 2) integer cell shifts (dx, dy) per member
    template: object = None        # linear: (n_y, n_x, C) float32; trees: sparse G rows


class _SnappedBoxes:
    """Person boxes of an operator's ``snapped_homographies``, computed once."""

    def boxes(self) -> np.ndarray:
        """(N, 4) person boxes ``(x, y, w, h)`` of the scored (snapped) windows, in the
        frame's pixels."""
        return self._cached_boxes().copy()

    def _cached_boxes(self) -> np.ndarray:
        # computed once per operator (not per frame): ~18 ms for 30,000 windows
        b = getattr(self, "_boxes", None)
        if b is None:
            b = self._boxes = person_boxes(self.snapped_homographies)
        return b


class _OperatorBase(_SnappedBoxes):
    """Shared geometry of the adapted operators (see :class:`AdaptedLinearOperator`)."""

    source_cell: int = HOG_CELL

    def _setup(self, windows, cell_size, groups, pad):
        self.image_size = tuple(windows.image_size)
        self.n_windows = len(windows)
        self.groups = groups
        self.pad = pad
        self.cell_size = np.asarray(cell_size, dtype=np.int64)
        self.cell_sizes = sorted(set(int(g.cell_size) for g in groups))
        H = np.empty((self.n_windows, 3, 3))
        for g in groups:
            Hp = windows.homographies[g.prototype]
            c = g.cell_size
            T = np.zeros((len(g.members), 3, 3))
            T[:, 0, 0] = T[:, 1, 1] = T[:, 2, 2] = 1.0
            T[:, 0, 2] = c * g.shifts[:, 0]
            T[:, 1, 2] = c * g.shifts[:, 1]
            H[g.members] = T @ Hp
        self.snapped_homographies = H
        self.candidate_homographies = windows.homographies.copy()

    @property
    def n_templates(self) -> int:
        return len(self.groups)

    def feature_pixels(self) -> int:
        """Frame pixels whose channels are computed per frame (the whole frame, once)."""
        return int(self.image_size[0] * self.image_size[1])

    def _origins(self, g, features):
        p = features.pad
        ox = g.origin[0] + g.shifts[:, 0] + p
        oy = g.origin[1] + g.shifts[:, 1] + p
        return oy, ox

    def _check_features(self, features: FrameFeatures):
        if tuple(features.image_size) != self.image_size:
            raise ValueError(f"features are of a {features.image_size[0]}x"
                             f"{features.image_size[1]} frame, the operator is for "
                             f"{self.image_size[0]}x{self.image_size[1]} frames")
        if features.pad != self.pad:
            raise ValueError(f"features are padded by {features.pad} cells, the operator "
                             f"needs {self.pad}")
        missing = [c for c in self.cell_sizes if c not in features.maps]
        if missing:
            raise ValueError(f"features lack the cell sizes {missing}")


def _build_groups(windows, cell_size, tolerance):
    centre = _map_points(windows.homographies, _CENTRE)
    out = []
    for proto, members in group_windows(windows, cell_size, tolerance):
        c = int(cell_size[proto])
        d = np.round((centre[members] - centre[proto]) / c).astype(np.int64)
        if len(members) == 1:
            d[:] = 0
        H = windows.homographies[proto]
        cx0, cy0, nx, ny = _patch_grid(H, c, windows.image_size)
        out.append(_Group(c, int(proto), (cx0, cy0), (ny, nx), np.asarray(members), d))
    return out


def _required_pad(groups, image_size):
    w, h = image_size
    need = 1
    for g in groups:
        c = g.cell_size
        ny_map, nx_map = h // c, w // c
        ox = g.origin[0] + g.shifts[:, 0]
        oy = g.origin[1] + g.shifts[:, 1]
        need = max(need, int(-ox.min()), int(-oy.min()),
                   int((ox + g.shape[1] - nx_map).max()), int((oy + g.shape[0] - ny_map).max()))
    return need


def _hog_remap(H, g, rule):
    out_grid = CellGrid.for_window(WINDOW_WIDTH, WINDOW_HEIGHT, HOG_CELL)
    c = g.cell_size
    in_grid = CellGrid(g.shape[1], g.shape[0], c,
                       origin=(g.origin[0] * c - 0.5, g.origin[1] * c - 0.5))
    # normalised cell features are intensive (see block_normalize_cells): area-weighted
    # means; S (x) A on the orientation channels, S alone on the texture energies
    return feature_remap_matrix(H, out_grid, in_grid, n_bins=_N_HOG_BINS, rule=rule,
                                per_cell=True, preserve="mean",
                                n_plain=HOG_CHANNELS - _N_HOG_BINS)


def _acf_remap(H, g, rule):
    """G from a frame patch (n_y, n_x, 10) to source ACF channels (10, 32, 16)."""
    out_grid = CellGrid.for_window(WINDOW_WIDTH, WINDOW_HEIGHT, ACF_SHRINK)
    c = g.cell_size
    in_grid = CellGrid(g.shape[1], g.shape[0], c,
                       origin=(g.origin[0] * c - 0.5, g.origin[1] * c - 0.5))
    n_out, n_in = out_grid.n_cells, in_grid.n_cells
    # G = S (x) diag(A_k, I) (area-weighted means; S alone for L, U, V and the magnitude,
    # viewadapt.adapt.acf_remap_matrix), with the channels reordered: feature_remap_matrix
    # has the bins first and rows (cell, channel), the ACF frame maps the plain channels
    # first and the source features rows (channel, cell)
    nO, n_plain = _N_ORIENT_ACF, _N_ACF - _N_ORIENT_ACF
    G = feature_remap_matrix(H, out_grid, in_grid, n_bins=nO, rule=rule, per_cell=True,
                             preserve="mean", bin_offset=-0.5, n_plain=n_plain).tocoo()
    k, i = np.divmod(G.row, _N_ACF)
    m, j = np.divmod(G.col, _N_ACF)

    def acf_channel(ch):
        return np.where(ch < nO, ch + n_plain, ch - nO)

    return sp.csr_matrix((G.data, (acf_channel(i) * n_out + k, m * _N_ACF + acf_channel(j))),
                         shape=(_N_ACF * n_out, n_in * _N_ACF))


def _acf_gradient_rows() -> np.ndarray:
    """(5120,) bool: the rows of an ACF ``G`` that give the gradient magnitude and
    orientation channels (scaled by ``s ** lambda``, :data:`ACF_GRADIENT_LAMBDA`)."""
    n_out = (WINDOW_HEIGHT // ACF_SHRINK) * (WINDOW_WIDTH // ACF_SHRINK)
    return np.arange(_N_ACF * n_out) >= (_N_ACF - _N_ORIENT_ACF - 1) * n_out


@dataclass
class _FeatureMaker:
    """The frame features an operator reads (picklable, so operators can be cached)."""

    kind: str
    cell_sizes: list
    pad: int
    image_size: tuple
    kwargs: dict

    def __call__(self, image) -> FrameFeatures:
        if self.kind == "hog":
            return hog_frame_features(image, self.cell_sizes, pad=self.pad,
                                      image_size=self.image_size, **self.kwargs)
        return acf_frame_features(image, self.cell_sizes, pad=self.pad,
                                  image_size=self.image_size, **self.kwargs)


def _check_windows(windows):
    if not isinstance(windows, CandidateWindows) or len(windows) == 0:
        raise ValueError("windows must be a non-empty CandidateWindows "
                         "(viewadapt.windows.select_candidate_windows)")


# ------------------------------------------------------------------------ linear models


class AdaptedLinearOperator(_OperatorBase):
    """Per-window adapted linear detectors of one camera, applied as one operator.

    Built by :func:`build_adapted_linear_operator`. ``scores(features)`` returns
    ``(G(\\tilde H_n)^T w)^T x + b`` for every window ``n`` (eq. (7)).

    Attributes
    ----------
    groups : list
        Shared templates: cell size, patch, members and their cell shifts.
    snapped_homographies : (N, 3, 3) ndarray
        The homography each window is scored with (its candidate homography when
        ``tolerance == 0``).
    cell_size : (N,) int ndarray
    bias : float
    """

    nms_overlap, nms_threshold = "union", 0.5

    def __init__(self, windows, cell_size, groups, pad, bias, features):
        self._setup(windows, cell_size, groups, pad)
        self.bias = float(bias)
        self.features = features

    def weights_per_window(self) -> np.ndarray:
        """(N,) number of adapted weights (template entries) of each window."""
        out = np.zeros(self.n_windows, np.int64)
        for g in self.groups:
            out[g.members] = g.template.size
        return out

    def position_weights(self) -> np.ndarray:
        """(P,) number of adapted weights of each distinct scored position (windows
        snapped onto the same position of the same template are scored once)."""
        r = self._runs
        return (r.t_rows * r.t_run)[r.group]

    def scores(self, features: FrameFeatures, *, method: str = "runs") -> np.ndarray:
        """Scores of all windows on one frame's features.

        Parameters
        ----------
        features : FrameFeatures
            From :meth:`frame_features` (or :func:`hog_frame_features` with this
            operator's cell sizes and padding).
        method : {"runs", "sparse", "template", "gather"}
            ``"runs"`` (default, the fastest measured): a compiled loop over the distinct
            scored positions, each template row a contiguous dot product with the frame
            map row it meets; ``"sparse"``: the CSR matrix of :meth:`to_sparse` (one row
            per distinct position) times the feature vector, built on first use;
            ``"template"``: one ``cv2.matchTemplate`` cross-correlation per group over the
            region of its windows (``"gather"`` for groups whose windows are few or
            scattered); ``"gather"``: each window's patch gathered and dotted. All agree up
            to float32 rounding.

        Returns
        -------
        (N,) float64 ndarray
        """
        self._check_features(features)
        if method == "runs":
            from ._kernels import template_run_scores

            r = self._runs
            x = features.vector(self.cell_sizes)
            if x.size != r.n_features or x.dtype != np.float32:
                raise ValueError(f"features have {x.size} {x.dtype} values, the operator "
                                 f"reads {r.n_features} float32 values ({HOG_CHANNELS} "
                                 f"channels per cell)")
            out = np.empty(len(r.starts))
            template_run_scores(x, r.templates, r.t_offset, r.t_rows, r.t_run, r.x_stride,
                                r.starts, r.group, out)
            return out[r.row_of] + self.bias
        if method == "sparse":
            if getattr(self, "_csr", None) is None:
                self._csr = self.to_sparse(unique=True)
            W, rows = self._csr
            return np.asarray(W @ features.vector(self.cell_sizes),
                              dtype=np.float64)[rows] + self.bias
        if method not in ("template", "gather"):
            raise ValueError(f"method must be 'runs', 'sparse', 'template' or 'gather', "
                             f"got {method!r}")
        out = np.empty(self.n_windows)
        for g in self.groups:
            oy, ox = self._origins(g, features)
            ny, nx = g.shape
            y0, x0 = int(oy.min()), int(ox.min())
            y1, x1 = int(oy.max()) + ny, int(ox.max()) + nx
            region = (y1 - y0 - ny + 1) * (x1 - x0 - nx + 1)
            if method == "template" and len(g.members) >= 8 and region <= 6 * len(g.members):
                res = correlate_slices([p[y0:y1, x0:x1] for p in features.split3(g.cell_size)],
                                       channel_slices3(g.template))
                out[g.members] = res[oy - y0, ox - x0]
            else:
                F = features.maps[g.cell_size]
                win = np.lib.stride_tricks.sliding_window_view(F, (ny, nx), axis=(0, 1))
                patches = win[oy, ox]                       # (k, C, ny, nx)
                out[g.members] = np.einsum("kcyx,yxc->k", patches, g.template)
        return out + self.bias

    def frame_features(self, image) -> FrameFeatures:
        """The frame's feature maps this operator reads."""
        return self.features(image)

    def detect(self, image, *, threshold: float = 0.0, nms_threshold: float = 0.5,
               max_candidates: int = 2000, method: str = "runs") -> np.ndarray:
        """Features, scores and non-maximum suppression on one frame.

        Returns
        -------
        (D, 5) ndarray of ``(x, y, w, h, score)`` rows, by decreasing score.
        """
        _check_frame(image, self.image_size)
        s = self.scores(self.frame_features(image), method=method)
        return detections_from_scores(self._cached_boxes(), s, threshold=threshold,
                                      nms_threshold=nms_threshold,
                                      max_candidates=max_candidates)

    def _layout(self):
        w, h = self.image_size
        p = self.pad
        C = self.groups[0].template.shape[2]
        offsets, dims = {}, {}
        off = 0
        for c in self.cell_sizes:
            ny, nx = h // c + 2 * p, w // c + 2 * p
            offsets[c], dims[c] = off, (ny, nx)
            off += ny * nx * C
        return offsets, dims, off, C

    def _positions(self):
        """The distinct scored positions: per group, the (k_g,) offsets in
        :meth:`FrameFeatures.vector` of its distinct patch origins; and the (N,) position
        (row) of every window, rows numbered group after group."""
        offsets, dims, _, C = self._layout()
        p = self.pad
        row_of = np.empty(self.n_windows, np.intp)
        starts, n_rows = [], 0
        for g in self.groups:
            Nx = dims[g.cell_size][1]
            oy = g.origin[1] + g.shifts[:, 1] + p
            ox = g.origin[0] + g.shifts[:, 0] + p
            start, inv = np.unique(offsets[g.cell_size] + (oy * Nx + ox) * C,
                                   return_inverse=True)
            row_of[g.members] = n_rows + inv.ravel()
            starts.append(start)
            n_rows += len(start)
        return starts, row_of

    def _build_runs(self):
        """The tables of the ``"runs"`` form (:func:`viewadapt._kernels.template_run_scores`);
        each group's template becomes a view into them (one copy of the weights)."""
        _, dims, n_feat, C = self._layout()
        starts, row_of = self._positions()
        sizes = np.array([g.template.size for g in self.groups], np.int64)
        self._runs = _RunTables(
            templates=np.concatenate([g.template.ravel() for g in self.groups]).astype(
                np.float32),
            t_offset=np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64),
            t_rows=np.array([g.shape[0] for g in self.groups], np.int64),
            t_run=np.array([g.shape[1] * C for g in self.groups], np.int64),
            x_stride=np.array([dims[g.cell_size][1] * C for g in self.groups], np.int64),
            starts=np.concatenate(starts).astype(np.int64),
            group=np.repeat(np.arange(len(self.groups), dtype=np.int64),
                            [len(st) for st in starts]),
            row_of=row_of, n_features=int(n_feat))
        self._link_templates()

    def _link_templates(self):
        r = self._runs
        for g, off in zip(self.groups, r.t_offset):
            n = g.shape[0] * g.shape[1] * HOG_CHANNELS
            g.template = r.templates[off:off + n].reshape(g.shape[0], g.shape[1], HOG_CHANNELS)

    def __getstate__(self):
        # the templates are views into the run tables: pickle them once (there), and never
        # the CSR form (rebuilt on first use)
        state = self.__dict__.copy()
        state["groups"] = [replace(g, template=None) for g in self.groups]
        state.pop("_csr", None)
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._link_templates()

    def to_sparse(self, *, unique: bool = False):
        """The operator as one CSR matrix ``W`` with ``scores = W x + b``.

        ``x`` is :meth:`FrameFeatures.vector` of the operator's cell sizes (padded maps).

        Parameters
        ----------
        unique : bool
            Keep one row per distinct scored window (windows snapped onto the same
            template position score the same) and also return the (N,) row of each window.

        Returns
        -------
        W : (N or n_unique, n_features) float32 scipy.sparse.csr_matrix
        rows : (N,) intp ndarray, only with ``unique=True``
        """
        _, dims, n_feat, C = self._layout()
        starts, row_of = self._positions()
        parts = []                               # (template nz cols, nz vals)
        for g in self.groups:
            ny, nx = g.shape
            Nx = dims[g.cell_size][1]
            yy, xx, cc = np.meshgrid(np.arange(ny), np.arange(nx), np.arange(C), indexing="ij")
            t = g.template.ravel()
            nz = np.flatnonzero(t)
            parts.append((((yy * Nx + xx) * C + cc).ravel()[nz], t[nz]))
        counts = np.concatenate([np.full(len(st), base.size, np.int64)
                                 for (base, _), st in zip(parts, starts)])
        indptr = np.zeros(len(counts) + 1, np.int64)
        np.cumsum(counts, out=indptr[1:])
        indices = np.empty(indptr[-1], np.int32 if n_feat < 2**31 else np.int64)
        data = np.empty(indptr[-1], np.float32)
        r0 = 0
        for (base, vals), start in zip(parts, starts):
            k = base.size
            s0 = indptr[r0]
            blk = slice(s0, s0 + k * len(start))
            indices[blk] = (start[:, None] + base[None, :]).ravel()
            data[blk] = np.tile(vals, len(start))
            r0 += len(start)
        W = sp.csr_matrix((data, indices, indptr), shape=(len(counts), n_feat))
        if unique:
            return W, row_of
        return W[row_of]


@dataclass
class _RunTables:
    """Templates and distinct positions of an :class:`AdaptedLinearOperator`, flat."""

    templates: np.ndarray          # all templates, row-major (n_y, n_x, C), concatenated
    t_offset: np.ndarray           # (G,) start of each template in ``templates``
    t_rows: np.ndarray             # (G,) n_y
    t_run: np.ndarray              # (G,) n_x C: one template row, one contiguous run
    x_stride: np.ndarray           # (G,) N_x C: one row of the padded map it reads
    starts: np.ndarray             # (P,) offset of each distinct position in the x vector
    group: np.ndarray              # (P,) its group
    row_of: np.ndarray             # (N,) position of each window
    n_features: int                # size of the x vector


def build_adapted_linear_operator(windows: CandidateWindows, weights, bias: float = 0.0, *,
                                  features: str = "hog", tolerance: float = 0.5,
                                  cells_per_source_cell: float = 0.7,
                                  allowed_cell_sizes=FRAME_CELL_SIZES,
                                  rule: str = "covariant") -> AdaptedLinearOperator:
    """Precompute the adapted linear detector of every candidate window (eq. (7)).

    Parameters
    ----------
    windows : CandidateWindows
    weights : (16, 8, 13) or (1664,) array_like
        Source-view weights over the canonical window's block-normalised 8-px HOG cells,
        layout row-major ``(n_y, n_x, channel)``: a linear model trained on
        ``hog_window_features(window).ravel()``.
    bias : float
    features : {"hog"}
    tolerance : float
        Shape tolerance for sharing templates, frame cells (:func:`group_windows`);
        0 = one exact template per window.
    cells_per_source_cell : float
        See :func:`choose_cell_sizes`.
    allowed_cell_sizes : sequence of int
    rule : {"covariant", "paper", "none"}
        Angle rule of ``A`` (:func:`viewadapt.remap.map_angles`).

    Returns
    -------
    AdaptedLinearOperator
    """
    _check_windows(windows)
    if features != "hog":
        raise ValueError(f"features must be 'hog' for linear models, got {features!r}")
    w = np.asarray(weights, dtype=np.float64).ravel()
    n_src = int(np.prod(HOG_WEIGHT_SHAPE))
    if w.size != n_src or not np.all(np.isfinite(w)):
        raise ValueError(f"weights must be {n_src} finite values over {HOG_WEIGHT_SHAPE} cells "
                         f"(hog_window_features), got {w.size}")
    if not np.isfinite(tolerance) or tolerance < 0:
        raise ValueError(f"tolerance must be >= 0 cells, got {tolerance!r}")
    scale = windows.scale
    cell = choose_cell_sizes(scale, HOG_CELL, cells_per_source_cell=cells_per_source_cell,
                             allowed=allowed_cell_sizes)
    groups = _build_groups(windows, cell, tolerance)
    for g in groups:
        G = _hog_remap(windows.homographies[g.prototype], g, rule)
        g.template = np.asarray(G.T @ w, dtype=np.float32).reshape(g.shape[0], g.shape[1],
                                                                     HOG_CHANNELS)
    pad = _required_pad(groups, windows.image_size)
    make_features = _FeatureMaker("hog", sorted(set(cell.tolist())), pad,
                                  tuple(windows.image_size), {})
    op = AdaptedLinearOperator(windows, cell, groups, pad, bias, make_features)
    op.tolerance = float(tolerance)
    op._build_runs()                          # the run-time form, built once offline
    return op


# --------------------------------------------------------------------------- trees (ACF)


class AdaptedTreesOperator(_OperatorBase):
    """Per-window adapted boosted trees (ACF) of one camera.

    Each group holds the rows of its ``G`` that the trees read (``G[used]``). At run time
    each distinct window position walks the trees in order until the soft cascade stops it
    (Wang et al. 2017, Algorithm 2 with the toolbox's ``acfDetect`` cascade; a compiled
    loop, :meth:`scores`), and a remapped feature ``(G_n x)_f`` is computed only for the
    nodes a position reaches: one short dot product over a few frame cells (a row of
    ``G``, ~5.5 entries on average). On the small Blender set 78% of the positions stop
    after the first tree and 93% within eight.
    """

    source_cell = ACF_SHRINK

    nms_overlap, nms_threshold = "min", 0.65

    def __init__(self, windows, cell_size, groups, pad, model, features):
        self._setup(windows, cell_size, groups, pad)
        self.model = model
        self.features = features
        used = model.used_features_
        self.used = used
        feat = model.feature_
        self._cols = np.where(feat >= 0, np.searchsorted(used, np.maximum(feat, 0)), -1)
        self._thr = model.threshold_
        self._val = model.value_
        self._depth = (feat.shape[1] + 1).bit_length() - 2

    def frame_features(self, image) -> FrameFeatures:
        return self.features(image)

    def scores(self, features: FrameFeatures, *, method: str = "cascade") -> np.ndarray:
        """Soft-cascade scores of all windows.

        ``method="cascade"`` (default): a compiled loop
        (:func:`viewadapt._kernels.tree_cascade_scores`) over the distinct positions, each
        walking the trees in order until the cascade stops it and computing a remapped
        feature only at the nodes it reaches. ``method="blocks"``: the same in numpy,
        blocks of trees over all positions still alive (see the class notes).
        ``method="full"``: every used feature of every window remapped first, then
        :meth:`AdaBoostTrees.decision_function_remapped` -- the reference, slow.
        """
        self._check_features(features)
        if method == "cascade":
            return self._compiled_cascade(features)
        if method == "blocks":
            return self._lazy_cascade(features)
        if method != "full":
            raise ValueError(f"method must be 'cascade', 'blocks' or 'full', got {method!r}")
        out = np.empty(self.n_windows)
        n_src = self.model.n_features_in_
        lift = sp.csr_matrix((np.ones(len(self.used)), (self.used, np.arange(len(self.used)))),
                             shape=(n_src, len(self.used)))
        for g in self.groups:
            oy, ox = self._origins(g, features)
            ny, nx = g.shape
            F = features.maps[g.cell_size]
            win = np.lib.stride_tricks.sliding_window_view(F, (ny, nx), axis=(0, 1))
            X = win[oy, ox].transpose(0, 2, 3, 1).reshape(len(oy), -1)   # (k, ny nx C)
            out[g.members] = self.model.decision_function_remapped(
                X.astype(np.float64), lift @ g.template)
        return out

    def _gather_tables(self):
        """Distinct scored positions and, per used feature, each group's row of ``G`` as
        a ragged list of (offset, weight) pairs over the frame feature vector.

        Returns ``(pos_of, pos_group, pos_origin, rows)``: ``pos_of`` (N,) the position of
        each window; ``pos_group`` / ``pos_origin`` (P,) each position's group and the
        index of its patch's top-left entry in :meth:`FrameFeatures.vector`;
        ``rows[f] = (indptr, offsets, weights)``, the CSR rows of feature ``f`` of all
        groups: group ``g``'s row is ``offsets[indptr[g]:indptr[g + 1]]`` (int32, relative
        to a position's origin) with its ``weights`` (float32).
        """
        w, h = self.image_size
        p = self.pad
        C = _N_ACF
        start_of, Nx_of, off = {}, {}, 0
        for c in self.cell_sizes:
            ny, nx = h // c + 2 * p, w // c + 2 * p
            start_of[c], Nx_of[c] = off, nx
            off += ny * nx * C
        pos_of = np.empty(self.n_windows, np.intp)
        pos_group, pos_origin, per_group = [], [], []
        n_pos = 0
        for gi, g in enumerate(self.groups):
            Nx = Nx_of[g.cell_size]
            oy = g.origin[1] + g.shifts[:, 1] + p
            ox = g.origin[0] + g.shifts[:, 0] + p
            start, inv = np.unique(start_of[g.cell_size] + (oy * Nx + ox) * C,
                                   return_inverse=True)
            pos_of[g.members] = n_pos + inv.ravel()
            pos_group.append(np.full(len(start), gi, np.int32))
            pos_origin.append(start)
            n_pos += len(start)
            G = sp.csr_matrix(g.template)
            G.eliminate_zeros()              # S (x) A stores zeros where A has none
            G.sort_indices()
            yy, rem = np.divmod(G.indices, g.shape[1] * C)
            xx, cc = np.divmod(rem, C)
            per_group.append((G.indptr, ((yy * Nx + xx) * C + cc).astype(np.int32),
                              G.data.astype(np.float32)))
        # one CSR over (feature, group) rows: row f * n_groups + g
        n_groups = len(per_group)
        lens = np.array([[ip[f + 1] - ip[f] for ip, _, _ in per_group]
                         for f in range(len(self.used))], np.int64).ravel()
        indptr = np.r_[0, np.cumsum(lens)]
        offsets = np.concatenate([b[ip[f]:ip[f + 1]] for f in range(len(self.used))
                                  for ip, b, _ in per_group]).astype(np.int32)
        weights = np.concatenate([d[ip[f]:ip[f + 1]] for f in range(len(self.used))
                                  for ip, _, d in per_group]).astype(np.float32)
        return (pos_of, np.concatenate(pos_group), np.concatenate(pos_origin).astype(np.int64),
                (n_groups, indptr, offsets, weights))

    def _run_tables(self):
        """:meth:`_gather_tables`, built once (offline by the builder; here for operators
        made without it)."""
        if getattr(self, "_tables", None) is None:
            self._tables = self._gather_tables()
        return self._tables

    def _compiled_cascade(self, features):
        from ._kernels import tree_cascade_scores

        pos_of, pos_group, pos_origin, (n_groups, indptr, offsets, weights) = self._run_tables()
        thr = self.model.cascade_threshold
        out = np.empty(len(pos_group))
        tree_cascade_scores(features.vector(self.cell_sizes), pos_group, pos_origin, n_groups,
                            indptr, offsets, weights, self._cols, self._thr, self._val,
                            self._depth, 0.0 if thr is None else float(thr), thr is not None,
                            out)
        return out[pos_of]

    def _lazy_cascade(self, features):
        pos_of, pos_group, pos_origin, (n_groups, indptr, offsets, weights) = self._run_tables()
        x = features.vector(self.cell_sizes)
        n_pos = len(pos_group)
        cols, thr, val = self._cols, self._thr, self._val
        T, depth = cols.shape[0], self._depth

        def remapped(f, Q):
            """``(G_q x)_f`` for pairs (feature ``f[i]``, position ``Q[i]``): each a short
            dot product over frame cells, all gathered flat in one pass."""
            key = f * n_groups + pos_group[Q]
            a = indptr[key]
            lens = indptr[key + 1] - a
            start = np.cumsum(lens) - lens
            total = int(lens.sum())
            res = np.zeros(len(key), np.float32)
            if total == 0:
                return res
            k = np.arange(total) + np.repeat(a - start, lens)
            prod = x[np.repeat(pos_origin[Q], lens) + offsets[k]] * weights[k]
            nz = lens > 0
            res[nz] = np.add.reduceat(prod, start[nz])
            return res

        out = np.zeros(n_pos)
        alive = np.arange(n_pos)
        score = np.zeros(n_pos)
        t0, size = 0, 1
        while t0 < T and alive.size:
            # blocks of 1, 1, 2, 4, ... 32 trees: while most positions are still alive the
            # cascade rejects them after a tree or two, later blocks amortise the calls
            t1 = min(T, t0 + size)
            size = min(2 * size if t0 else 1, 32)
            c = cols[t0:t1]                                   # (B, nodes)
            node = np.zeros((alive.size, t1 - t0), np.intp)
            trees = np.arange(t1 - t0)[None, :]
            for _ in range(depth):                   # features only of the nodes reached
                f = c[trees, node]
                inner = f >= 0
                ii, jj = np.nonzero(inner)
                v = remapped(f[ii, jj], alive[ii])
                nxt = 2 * node[ii, jj] + 1 + (v >= thr[t0 + jj, node[ii, jj]])
                node[ii, jj] = nxt
            s, stopped = cascade_step(score, val[t0:t1][trees, node],
                                      self.model.cascade_threshold)
            out[alive[stopped]] = s[stopped]
            alive, score = alive[~stopped], s[~stopped]
            t0 = t1
        out[alive] = score
        return out[pos_of]

    def detect(self, image, *, threshold: float = 0.0, nms_threshold: float = 0.65,
               max_candidates: int = 2000, method: str = "cascade") -> np.ndarray:
        """Features, cascade scores and NMS (``overlap="min"``, as ACF) on one frame."""
        _check_frame(image, self.image_size)
        s = self.scores(self.frame_features(image), method=method)
        return detections_from_scores(self._cached_boxes(), s, threshold=threshold,
                                      nms_threshold=nms_threshold, overlap="min",
                                      max_candidates=max_candidates)


def build_adapted_trees_operator(windows: CandidateWindows, model, *, tolerance: float = 1.0,
                                 cells_per_source_cell: float = 0.7,
                                 allowed_cell_sizes=FRAME_CELL_SIZES,
                                 rule: str = "covariant",
                                 gradient_lambda: float = ACF_GRADIENT_LAMBDA,
                                 acf_kwargs=None) -> AdaptedTreesOperator:
    """Precompute ``G[used]`` of every window for an ACF boosted-trees model.

    Parameters
    ----------
    windows : CandidateWindows
    model : viewadapt.boosting.AdaBoostTrees
        Fitted on source-view ACF features ``acf_channels(window).ravel()`` (layout
        ``(10, 32, 16)``).
    tolerance, cells_per_source_cell, allowed_cell_sizes, rule
        As :func:`build_adapted_linear_operator`; cells are sized on the 4-px blocks, so
        the default tolerance of 1 cell is about the pixel tolerance of HOG's 0.5 cell.
    gradient_lambda : float
        Power-law scaling of the gradient channels (magnitude and orientations): the rows
        of ``G`` that produce them are multiplied by ``s ** gradient_lambda``, ``s`` the
        window's frame pixels per canonical pixel (:data:`ACF_GRADIENT_LAMBDA`); 0 turns it
        off. Colour channels are intensive and need no scaling.
    acf_kwargs : dict, optional
        Passed to :func:`acf_frame_features`.

    Returns
    -------
    AdaptedTreesOperator
    """
    _check_windows(windows)
    n_src = _N_ACF * (WINDOW_HEIGHT // ACF_SHRINK) * (WINDOW_WIDTH // ACF_SHRINK)
    if getattr(model, "n_features_in_", None) != n_src:
        raise ValueError(f"model must be fitted on {n_src} ACF features (10 x 32 x 16), got "
                         f"{getattr(model, 'n_features_in_', None)}")
    cell = choose_cell_sizes(windows.scale, ACF_SHRINK,
                             cells_per_source_cell=cells_per_source_cell,
                             allowed=allowed_cell_sizes)
    if not np.isfinite(gradient_lambda):
        raise ValueError(f"gradient_lambda must be finite, got {gradient_lambda!r}")
    groups = _build_groups(windows, cell, tolerance)
    used = model.used_features_
    gradient_row = _acf_gradient_rows()
    scale = windows.scale
    factor = np.ones(len(windows))
    for g in groups:
        G = _acf_remap(windows.homographies[g.prototype], g, rule)
        if gradient_lambda:
            factor[g.members] = scale[g.prototype] ** gradient_lambda
            G = sp.diags(np.where(gradient_row, factor[g.prototype], 1.0)) @ G
        Gu = sp.csr_matrix(sp.csr_matrix(G)[used])
        Gu.eliminate_zeros()
        g.template = Gu
    pad = _required_pad(groups, windows.image_size)
    make_features = _FeatureMaker("acf", sorted(set(cell.tolist())), pad,
                                  tuple(windows.image_size), dict(acf_kwargs or {}))
    op = AdaptedTreesOperator(windows, cell, groups, pad, model, make_features)
    op.tolerance = float(tolerance)
    op.gradient_factor = factor               # (N,) s ** gradient_lambda of each window
    op._tables = op._gather_tables()          # the run-time form, built once offline
    return op


# ------------------------------------------------------------------------------- output


# ------------------------------------------------------------- several frame resolutions


def upsampled_windows(windows: CandidateWindows, factor: int) -> CandidateWindows:
    """The same windows in the frame upsampled ``factor`` times (``cv2.resize``, pixel
    centres ``u' = f u + (f - 1) / 2``)."""
    f = int(factor)
    if f < 1:
        raise ValueError(f"factor must be a positive integer, got {factor!r}")
    w, h = windows.image_size
    return _band_windows(windows, f, (0, h))


def _frame_to_band(f, r0):
    """Homography from the frame's pixels to those of its rows ``r0..`` upsampled ``f``
    times by ``cv2.resize`` (pixel centres ``u' = f u + (f - 1) / 2``)."""
    c = (f - 1) / 2.0
    return np.array([[f, 0.0, c], [0.0, f, c - f * r0], [0.0, 0.0, 1.0]])


def _band_windows(windows, f, rows):
    """``windows`` in the band of frame rows ``rows = (r0, r1)`` upsampled ``f`` times."""
    r0, r1 = rows
    return CandidateWindows(windows.ground_xy, windows.person_height,
                            _frame_to_band(f, r0) @ windows.homographies,
                            (f * windows.image_size[0], f * (r1 - r0)), windows.grid_index)


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


class MultiResolutionOperator(_SnappedBoxes):
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
        self.image_size = tuple(windows.image_size)
        self.n_windows = len(windows)
        self.layers = [_Layer(*layer) for layer in layers]
        H = np.empty((self.n_windows, 3, 3))
        for f, op, idx, (r0, _) in self.layers:
            H[idx] = np.linalg.inv(_frame_to_band(f, r0)) @ op.snapped_homographies
        self.snapped_homographies = H
        first = self.layers[0].operator
        self.nms_overlap, self.nms_threshold = first.nms_overlap, first.nms_threshold

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
        img = _check_frame(image, self.image_size)
        return [layer.operator.frame_features(_upsampled_band(img, layer.factor, layer.rows))
                for layer in self.layers]

    def scores(self, features, **kw) -> np.ndarray:
        """(N,) scores of all windows from :meth:`frame_features` (``kw``: the layers'
        ``method``)."""
        if len(features) != len(self.layers):
            raise ValueError(f"features must be a list of {len(self.layers)} FrameFeatures "
                             "(MultiResolutionOperator.frame_features)")
        out = np.empty(self.n_windows)
        for layer, feats in zip(self.layers, features):
            out[layer.index] = layer.operator.scores(feats, **kw)
        return out

    def detect(self, image, *, threshold: float = 0.0, nms_threshold=None,
               max_candidates: int = 2000, **kw) -> np.ndarray:
        """Features, scores and non-maximum suppression (as the layers' operator kind).

        Returns
        -------
        (D, 5) ndarray of ``(x, y, w, h, score)`` rows in frame pixels, by decreasing score.
        """
        s = self.scores(self.frame_features(image), **kw)
        return detections_from_scores(
            self._cached_boxes(), s, threshold=threshold, overlap=self.nms_overlap,
            nms_threshold=self.nms_threshold if nms_threshold is None else nms_threshold,
            max_candidates=max_candidates)


def _upsampled_band(img, f, rows):
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
                                   upsample_below: float = 0.5,
                                   factor: int = 2) -> MultiResolutionOperator:
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
    _check_windows(windows)
    if not np.isfinite(upsample_below) or upsample_below < 0:
        raise ValueError(f"upsample_below must be >= 0, got {upsample_below!r}")
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
        ys = f * _map_points(sub.homographies, _PROBES[:4])[:, :, 1] + (f - 1) / 2
        align = _BAND_ALIGN // math.gcd(_BAND_ALIGN, f) * f
        y0 = max(0, int(np.floor((ys.min() - f * _BAND_MARGIN) / align)) * align)
        y1 = min(f * h, int(np.ceil(ys.max() + f * _BAND_MARGIN)))
        rows = (y0 // f, -(-y1 // f))
        layers.append((f, build(_band_windows(sub, f, rows)), idx, rows))
    return MultiResolutionOperator(windows, layers)


def detections_from_scores(boxes, scores, *, threshold: float = 0.0,
                           nms_threshold: float = 0.5, overlap: str = "union",
                           max_candidates: int = 2000) -> np.ndarray:
    """Threshold, keep the best ``max_candidates``, non-maximum suppression.

    Parameters
    ----------
    boxes : (N, 4) array_like
        ``(x, y, w, h)``.
    scores : (N,) array_like

    Returns
    -------
    (D, 5) ndarray of ``(x, y, w, h, score)``, decreasing score.
    """
    b = np.asarray(boxes, dtype=np.float64)
    s = np.asarray(scores, dtype=np.float64)
    keep = np.flatnonzero(s > threshold)
    if keep.size > max_candidates:
        keep = keep[np.argpartition(-s[keep], max_candidates - 1)[:max_candidates]]
    if keep.size == 0:
        return np.zeros((0, 5))
    k = non_maximum_suppression(b[keep], s[keep], nms_threshold, overlap=overlap)
    sel = keep[k]
    return np.c_[b[sel], s[sel]]
