"""OpenCV's HOG/SVM people detectors (Dalal & Triggs 2005) over block-normalised cells.

A linear SVM over ``cv2.HOGDescriptor``'s descriptor (2x2-cell blocks at a one-cell
stride, L2-Hys normalised) is rewritten exactly as a linear model over *block-normalised
cells*: every cell carries the four normalised copies of its histogram, one per block
that contains it (36 channels: the cell's place in the block, OpenCV's order
``2 cell_x + cell_y``, times 9 bins), and the weight of a copy is the SVM's weight of that
block entry (:func:`opencv_cell_weights`). The frame's blocks lie on the frame's own cell
grid and are computed as OpenCV computes them -- square-root gamma, each pixel's
magnitude split between two orientation bins, a Gaussian block window (sigma = block / 4)
and bilinear spatial interpolation into the block's four cells, L2-Hys -- at each frame
cell size the operator reads (:func:`opencv_frame_features`). On a window that lies on
the grid at 8-px cells the model's score is OpenCV's own; the adapted operator
(:func:`~viewadapt.detect.linear.build_adapted_opencv_operator`) reads the frame's
normalised cells through ``G = S (x) A`` (Wang et al. 2017, eq. (7)) applied to each of
the four copies alike (:func:`~viewadapt.detect.frame_remap.opencv_frame_remap`): the
block normalisation is done in the target view, on the frame's grid, and ``G`` folds
into the weights. OpenCV's Daimler detector (48x96, no gamma correction;
:func:`opencv_daimler_people_detector`) is the same model in a window the canonical one
scaled by 3/4 (:func:`~viewadapt.detect.windows.detector_window_homography`).

References
----------
.. [1] N. Dalal, B. Triggs, "Histograms of Oriented Gradients for Human Detection", CVPR 2005.
.. [2] P. Wang, K. Morton, P. Torrione, L. Collins, "Viewpoint Adaptation for Rigid Object
   Detection", arXiv preprint, 2017.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np

from ..geometry import WINDOW_HEIGHT, WINDOW_WIDTH
from .channels import HOG_CELL, N_HOG_BINS, FrameFeatures, check_frame, gradient_bins, padded_maps

__all__ = ["OPENCV_CHANNELS", "OPENCV_WEIGHT_SHAPE", "OPENCV_L2HYS_CLIP", "opencv_cell_weights",
           "opencv_descriptor_weights", "opencv_default_people_detector",
           "DAIMLER_WINDOW", "opencv_daimler_people_detector", "opencv_gradients",
           "block_axis_weights", "opencv_block_cells", "raw_cell_maps", "opencv_window_features",
           "daimler_window_features",
           "OpenCVFrameFeatures",
           "opencv_frame_features"]

#: Channels per cell: the cell's histogram normalised in each of the 4 blocks containing it.
OPENCV_CHANNELS = 4 * N_HOG_BINS
#: Shape of an OpenCV 64x128 detector rewritten over cells (:func:`opencv_cell_weights`).
OPENCV_WEIGHT_SHAPE = (WINDOW_HEIGHT // HOG_CELL, WINDOW_WIDTH // HOG_CELL, OPENCV_CHANNELS)
#: OpenCV's L2-Hys clipping threshold (``HOGDescriptor::L2HysThreshold``).
OPENCV_L2HYS_CLIP = 0.2


def opencv_cell_weights(weights, *, window=(WINDOW_WIDTH, WINDOW_HEIGHT),
                        cell: int = HOG_CELL) -> np.ndarray:
    """A linear SVM over ``cv2.HOGDescriptor``'s descriptor as weights over normalised cells.

    Parameters
    ----------
    weights : (D,) array_like
        The descriptor's weights, OpenCV's layout (blocks x outer, y inner; in a block the
        cells x outer, y inner; then the bins), ``D = (nx - 1) (ny - 1) 36`` -- without the
        bias. 16-px blocks at an 8-px stride of 8-px cells.
    window : (width, height)

    Returns
    -------
    (ny, nx, 36) float64 ndarray ``W`` with ``W[y, x, 9 (2 qx + qy) + b]`` the weight of
    cell ``(x, y)``'s copy normalised in the block whose cell ``(qx, qy)`` it is: so that
    ``(W * opencv_window_features(window)).sum()`` is the SVM's ``w . descriptor``.
    """
    nx, ny = int(window[0]) // cell, int(window[1]) // cell
    w = np.asarray(weights, np.float64).ravel()
    n = (nx - 1) * (ny - 1) * OPENCV_CHANNELS
    if w.size != n or not np.all(np.isfinite(w)):
        raise ValueError(f"a {window[0]}x{window[1]} HOG detector has {n} finite weights "
                         f"(without its bias), got {w.size}")
    blocks = w.reshape(nx - 1, ny - 1, 2, 2, N_HOG_BINS)         # [bx, by, qx, qy, bin]
    W = np.zeros((ny, nx, 2, 2, N_HOG_BINS))                      # [y, x, qx, qy, bin]
    for qx in range(2):
        for qy in range(2):
            W[qy:qy + ny - 1, qx:qx + nx - 1, qx, qy] = blocks[:, :, qx, qy].transpose(1, 0, 2)
    return W.reshape(ny, nx, OPENCV_CHANNELS)


def opencv_descriptor_weights(W) -> np.ndarray:
    """The inverse of :func:`opencv_cell_weights`: (ny, nx, 36) cell weights -> the SVM's
    ``(nx - 1) (ny - 1) 36`` weights in OpenCV's descriptor layout."""
    W = np.asarray(W, np.float64)
    ny, nx = W.shape[:2]
    C = W.reshape(ny, nx, 2, 2, N_HOG_BINS)                       # [y, x, qx, qy, bin]
    out = np.empty((nx - 1, ny - 1, 2, 2, N_HOG_BINS))
    for qx in range(2):
        for qy in range(2):
            out[:, :, qx, qy] = C[qy:qy + ny - 1, qx:qx + nx - 1, qx, qy].transpose(1, 0, 2)
    return out.ravel()


def opencv_default_people_detector() -> tuple[np.ndarray, float]:
    """OpenCV's INRIA-trained people detector (``getDefaultPeopleDetector``) over cells:
    ``(W, b)``, ``W`` of :data:`OPENCV_WEIGHT_SHAPE` (:func:`opencv_cell_weights`)."""
    import cv2

    v = np.asarray(cv2.HOGDescriptor_getDefaultPeopleDetector(), np.float64).ravel()
    return opencv_cell_weights(v[:-1]), float(v[-1])


#: Window of OpenCV's Daimler people detector, (width, height) px: the 64x128 window scaled
#: by 3/4, the person 72 px tall in it as 96 px in the 64x128 one.
DAIMLER_WINDOW = (48, 96)


def opencv_daimler_people_detector() -> tuple[np.ndarray, float]:
    """OpenCV's Daimler-trained 48x96 people detector (``getDaimlerPeopleDetector``; Enzweiler
    & Gavrila 2009's data) over cells: ``(W, b)``, ``W`` (12, 6, 36)
    (:func:`opencv_cell_weights`). OpenCV's own example runs it without gamma correction
    (``HOGDescriptor((48, 96), (16, 16), (8, 8), (8, 8), 9)``)."""
    import cv2

    v = np.asarray(cv2.HOGDescriptor_getDaimlerPeopleDetector(), np.float64).ravel()
    return opencv_cell_weights(v[:-1], window=DAIMLER_WINDOW), float(v[-1])


@cache
def block_axis_weights(c: int) -> np.ndarray:
    """(2c, 2) per-pixel weight along one axis of a 2c-px block for its two cells: OpenCV's
    Gaussian block window (sigma = block / 4, centred at ``block / 2``) times the bilinear
    tent of each cell (centres at ``c / 2`` and ``3 c / 2``). Read-only (computed once per
    ``c``)."""
    b = 2 * c
    i = np.arange(b)
    sigma = b / 4.0
    gauss = np.exp(-((i - b / 2.0) ** 2) / (2 * sigma * sigma))
    coord = (i + 0.5) / c - 0.5
    tent = np.maximum(0.0, 1.0 - np.abs(coord[:, None] - np.arange(2)[None, :]))
    w = gauss[:, None] * tent
    w.setflags(write=False)
    return w


#: Square roots of the 8-bit values (the gamma of :func:`opencv_gradients`), and the
#: values themselves (no gamma).
_ROOTS = np.sqrt(np.arange(256, dtype=np.float32))
_LEVELS = np.arange(256, dtype=np.float32)


def opencv_gradients(image, *, gamma: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """``cv2.HOGDescriptor``'s gradients of an image: square-root gamma (unless ``gamma``
    is False), central differences (reflect-101 borders), the colour channel of largest
    magnitude; the (M, N)
    float32 magnitude and 9-bin coordinate of
    :func:`~viewadapt.detect.channels.gradient_bins`. An 8-bit image of at least 2 x 2
    pixels takes one compiled pass from its values' square roots to the strongest
    channel's differences, and the bin coordinates another, around ``cv2.cartToPolar``:
    the same float32 operations as :func:`~viewadapt.detect.channels.gradient_bins`."""
    import cv2

    from .._opencv_kernels import angle_bins, strongest_sqrt_gradient

    img = np.asarray(image)
    if img.ndim == 2:
        img = img[:, :, None]
    if img.dtype != np.uint8 or img.ndim != 3 or img.shape[2] not in (1, 3) \
            or min(img.shape[:2]) < 2:
        return gradient_bins(image, n_bins=N_HOG_BINS, gamma=bool(gamma))
    M, N = img.shape[:2]
    gx = np.empty((M, N), np.float32)
    gy = np.empty((M, N), np.float32)
    strongest_sqrt_gradient(img, _ROOTS if gamma else _LEVELS, gx, gy)
    mag, ang = cv2.cartToPolar(gx, gy)
    t = np.empty_like(ang)
    angle_bins(ang, N_HOG_BINS / np.pi, N_HOG_BINS, t)
    return mag, t


def opencv_block_cells(gradients, c: int, *, out=None, rows=None) -> np.ndarray:
    """Block-normalised cells of size ``c`` from :func:`opencv_gradients`.

    Every 2x2-cell block of the image's ``c``-px cell grid (one-cell stride) is
    accumulated as ``cv2.HOGDescriptor`` does (Gaussian window, bilinear interpolation
    into its cells) and L2-Hys normalised with OpenCV's floor ``0.1 * 36`` scaled by the
    cell area against 8-px cells (:func:`viewadapt._opencv_kernels.opencv_block_cells`);
    each cell then carries its copy from each block that contains it.

    Parameters
    ----------
    gradients : ((M, N), (M, N)) float32 ndarrays
        Magnitude and bin coordinate (:func:`opencv_gradients`).
    c : int
    out : (M // c, N // c, 36) float32 ndarray, optional
        Written in place (copies of blocks that do not exist are 0); returned.
    rows : (int, int), optional
        Compute only the cell rows ``rows[0] <= y < rows[1]`` (reading only the image rows
        of their blocks); the other rows of ``out`` are left as they are (zeros when ``out``
        is made here). Default: every row.

    Returns
    -------
    (M // c, N // c, 36) float32 ndarray, channel ``9 (2 qx + qy) + b``.
    """
    from .._opencv_kernels import opencv_block_cells as kernel

    mag, t = gradients
    ny, nx = mag.shape[0] // c, mag.shape[1] // c
    if out is None:
        out = np.zeros((ny, nx, OPENCV_CHANNELS), np.float32)
    y0, y1 = (0, ny) if rows is None else (int(rows[0]), int(rows[1]))
    kernel(mag, t, int(c), block_axis_weights(c).astype(np.float32),
           np.float32(0.1 * OPENCV_CHANNELS * (c / HOG_CELL) ** 2), np.float32(OPENCV_L2HYS_CLIP),
           out, y0, y1)
    return out


def opencv_window_features(window, *, gamma: bool = True) -> np.ndarray:
    """(16, 8, 36) normalised cells of a canonical 128x64 window (of any window, (h // 8,
    w // 8, 36)): ``cv2.HOGDescriptor``'s descriptor of the window rearranged by cell
    (:func:`opencv_cell_weights`' layout); ``gamma``: OpenCV's ``gammaCorrection``."""
    return opencv_block_cells(opencv_gradients(check_frame(window), gamma=gamma), HOG_CELL)


def daimler_window_features(window) -> np.ndarray:
    """(12, 6, 36) normalised cells of a 96x48 window as OpenCV's Daimler detector reads it
    (no gamma correction; :func:`opencv_window_features`)."""
    img = check_frame(window)
    if img.shape[:2] != DAIMLER_WINDOW[::-1]:
        raise ValueError(f"a Daimler window is {DAIMLER_WINDOW[1]}x{DAIMLER_WINDOW[0]} px, "
                         f"got {img.shape[0]}x{img.shape[1]}")
    return opencv_window_features(img, gamma=False)


def raw_cell_maps(gradients, cell_sizes, rows=None) -> tuple[dict, np.ndarray, np.ndarray]:
    """Raw 9-bin cell sums of :func:`~viewadapt.detect.opencv_cells.opencv_gradients` at
    each cell size, hard spatial binning: ``(maps, flat, offsets)`` with ``maps[c]`` a
    (M // c, N // c, 9) float32 view into ``flat`` starting at ``offsets[i]`` for the
    ``i``-th size of ``cell_sizes``. A size that is a multiple of a smaller one asked for
    is summed from that size's cells (the same pixels), the others from the pixels.
    ``rows``: optional dict ``c -> (y0, y1)``, the only cell rows of size ``c`` computed
    (the others are 0; a size others are summed from gets the span of theirs too); a size
    it does not name is computed whole."""
    from .._renorm_kernels import raw_cell_sums, sum_cells

    mag, t = gradients
    M, N = mag.shape
    sizes = [int(c) for c in cell_sizes]
    shapes = [(M // c, N // c, N_HOG_BINS) for c in sizes]
    offsets = np.r_[0, np.cumsum([int(np.prod(s)) for s in shapes])].astype(np.int64)
    flat = (np.empty if rows is None else np.zeros)(int(offsets[-1]), np.float32)
    maps = {}
    for c, s, off in zip(sizes, shapes, offsets):
        maps[c] = flat[off:off + int(np.prod(s))].reshape(s)
    parent = {}
    for c in sorted(maps):
        d = max((d for d in parent if c % d == 0), default=0)
        parent[c] = d
    want = {c: (0, maps[c].shape[0]) if rows is None or c not in rows
            else (int(rows[c][0]), int(rows[c][1])) for c in maps}
    for c in sorted(maps, reverse=True):           # a parent's rows cover its children's
        d = parent[c]
        if d:
            k = c // d
            y0, y1 = want[d]
            want[d] = (min(y0, k * want[c][0]), max(y1, k * want[c][1]))
    for c in sorted(maps):
        d = parent[c]
        if d:
            sum_cells(maps[d], c // d, maps[c], *want[c])
        else:
            raw_cell_sums(mag, t, c, maps[c], *want[c])
    for c, s, off in zip(sizes, shapes, offsets):                 # a size asked for twice
        region = flat[off:off + int(np.prod(s))]
        if region.ctypes.data != maps[c].ctypes.data:
            region[:] = maps[c].ravel()
    return maps, flat, offsets[:-1]


@dataclass
class OpenCVFrameFeatures(FrameFeatures):
    """:class:`FrameFeatures` of OpenCV's normalised cells; ``raw``: :func:`raw_cell_maps`
    of the same gradients, for the per-window normalisation stage (None when no raw cell
    size was asked for)."""


def opencv_frame_features(image, cell_sizes, *, pad: int = 2, image_size=None,
                          raw_cell_sizes=(), rows=None, raw_rows=None,
                          gamma: bool = True) -> OpenCVFrameFeatures:
    """OpenCV's block-normalised cells of a frame at several cell sizes, native resolution:
    the gradients once (:func:`opencv_gradients`), the cells of each size from them
    (:func:`opencv_block_cells`), and the raw 9-bin cells of each of ``raw_cell_sizes``
    (:func:`raw_cell_maps`). ``rows`` and ``raw_rows`` (dicts ``c -> (y0, y1)``, optional)
    limit a size's maps to the cell rows an operator reads (the others are 0); ``gamma``:
    OpenCV's square-root gamma correction (:func:`opencv_gradients`).

    Returns
    -------
    OpenCVFrameFeatures with (M // c + 2 pad, N // c + 2 pad, 36) maps, one flat buffer.
    """
    img = check_frame(image, image_size)
    M, N = img.shape[:2]
    order, flat, maps = padded_maps(cell_sizes, (M, N), pad, OPENCV_CHANNELS)
    grad = opencv_gradients(img, gamma=gamma)
    for c, F in maps.items():
        opencv_block_cells(grad, c, out=F[pad:pad + M // c, pad:pad + N // c],
                           rows=None if rows is None else rows.get(c))
    raw = raw_cell_maps(grad, raw_cell_sizes, raw_rows) if len(raw_cell_sizes) else None
    return OpenCVFrameFeatures(maps, pad, (N, M), _flat=(order, flat), raw=raw)
