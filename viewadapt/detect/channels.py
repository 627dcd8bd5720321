"""Frame features of the full-frame detectors: per-pixel channels once, cell maps per size.

The adapted detectors never resample the frame. Its per-pixel channels -- HOG's oriented
gradient magnitudes (Dalal & Triggs 2005), ACF's LUV, gradient magnitude and orientation
channels (Dollár et al. 2014) -- are computed once and summed into square cells of each
size the operator's windows need (:func:`hog_frame_features`; ACF's in
:mod:`viewadapt.detect.acf_channels`); a window then reads about one frame cell per source
cell (:mod:`viewadapt.detect.templates`). HOG cells are block-normalised on the frame's own
grid (:func:`block_normalize_cells`), so the features of a frame cell are the same for every
window that reads it and ``G`` folds into linear weights. :func:`hog_window_features`
computes the same features on a canonical 64x128 window: what the source detectors are
trained on.

References
----------
.. [1] N. Dalal, B. Triggs, "Histograms of Oriented Gradients for Human Detection", CVPR 2005.
.. [2] P. Felzenszwalb, R. Girshick, D. McAllester, D. Ramanan, "Object Detection with
   Discriminatively Trained Part-Based Models", IEEE TPAMI 32(9), 2010.
.. [3] P. Dollár, R. Appel, S. Belongie, P. Perona, "Fast Feature Pyramids for Object
   Detection", IEEE TPAMI 36(8), 2014.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .._validation import check_image
from ..geometry import WINDOW_HEIGHT, WINDOW_WIDTH

__all__ = [
    "HOG_CELL", "N_HOG_BINS", "HOG_CHANNELS", "HOG_WEIGHT_SHAPE", "HOG_CLIP",
    "ACF_SHRINK", "N_ACF_CHANNELS", "N_ACF_ORIENTS", "ACF_WEIGHT_SHAPE", "ACF_GRADIENT_LAMBDA",
    "fast_orientation_channels", "strongest_gradient", "FrameFeatures", "check_frame",
    "gradient_polar", "gradient_bins", "padded_maps", "cell_sums", "multi_cell_sums",
    "direct_cells", "orientation_cell_maps", "channel_slices3", "correlate_slices",
    "block_normalize_cells", "hog_cell_eps", "hog_window_features", "hog_frame_features"]

#: Source-view cell size of the HOG detectors (8 px in the 64x128 window, 16 x 8 cells).
HOG_CELL = 8
#: Unsigned orientation bins of the HOG cells.
N_HOG_BINS = 9
#: Channels per cell of the full-frame HOG features: 9 orientations, 4 texture energies
#: (:func:`block_normalize_cells`).
HOG_CHANNELS = N_HOG_BINS + 4
#: Shape of a source-view HOG/SVM weight array (cells down, cells across, channels).
HOG_WEIGHT_SHAPE = (WINDOW_HEIGHT // HOG_CELL, WINDOW_WIDTH // HOG_CELL, HOG_CHANNELS)
#: Clipping of block-normalised HOG values (Dalal & Triggs' L2-Hys threshold).
HOG_CLIP = 0.2
#: Source-view ACF aggregation block (4 px, 32 x 16 blocks).
ACF_SHRINK = 4
#: ACF channels: L, U, V, gradient magnitude, then the orientation channels.
N_ACF_CHANNELS = 10
N_ACF_ORIENTS = 6
#: Shape of a source-view ACF feature array (channels, blocks down, blocks across).
ACF_WEIGHT_SHAPE = (N_ACF_CHANNELS, WINDOW_HEIGHT // ACF_SHRINK, WINDOW_WIDTH // ACF_SHRINK)
#: Power-law exponent of the ACF gradient channels across scales (Dollár et al. 2014):
#: channels computed on the frame at ``s`` frame pixels per canonical pixel are, on average,
#: ``s ** -lambda`` times those of the same window warped to the canonical size, so the
#: adapted operator multiplies the remapped magnitude and orientation channels by
#: ``s ** lambda``. Estimated without labels on candidate windows of rendered frames
#: (``python -m benchmark.studies.acf_scaling``; docs/findings.md).
ACF_GRADIENT_LAMBDA = 0.365




def strongest_gradient(dx, dy):
    """Per pixel of (M, N, K) float32 derivatives, the ``(dx, dy)`` planes of the channel of
    largest magnitude (ties keep the earlier channel)."""
    from .._kernels import strongest_gradient

    gx = np.empty(dx.shape[:2], np.float32)
    gy = np.empty(dx.shape[:2], np.float32)
    strongest_gradient(dx, dy, gx, gy)
    return gx, gy


def gradient_polar(img):
    """HOG gradients of a float32 (M, N[, 3]) image: central differences with reflect-101
    borders, the colour channel of largest magnitude; ``(magnitude, angle in [0, 2 pi))``."""
    import cv2

    k = np.array([[-1.0, 0.0, 1.0]], np.float32)
    dx = cv2.filter2D(img, cv2.CV_32F, k, borderType=cv2.BORDER_REFLECT_101)
    dy = cv2.filter2D(img, cv2.CV_32F, k.T, borderType=cv2.BORDER_REFLECT_101)
    if img.ndim == 3:
        dx, dy = strongest_gradient(dx, dy)
    return cv2.cartToPolar(dx, dy)


def gradient_bins(image, *, n_bins: int = 9, gamma: bool = False):
    """(M, N) float32 magnitude and bin coordinate ``t`` in ``[0, n_bins)`` (``1 - frac(t)``
    to bin ``floor(t)``, ``frac(t)`` to the next) of :func:`gradient_polar` (gamma first)."""
    import cv2

    img = check_image(image).astype(np.float32)
    if gamma:
        img = cv2.sqrt(img)
    mag, ang = gradient_polar(img)
    # OpenCV element-wise calls on contiguous planes throughout: several times faster than
    # numpy on strided channel views (measured in benchmark/frames/runtime.py's feature time)
    t = cv2.subtract(cv2.multiply(ang, n_bins / np.pi), 0.5)      # in [-0.5, 2 n_bins)
    for _ in range(2):                                            # t mod n_bins
        cv2.add(t, float(n_bins), t, mask=cv2.compare(t, 0.0, cv2.CMP_LT))
        cv2.subtract(t, float(n_bins), t, mask=cv2.compare(t, float(n_bins), cv2.CMP_GE))
    return mag, t


def fast_orientation_channels(image, *, n_bins: int = 9, gamma: bool = False) -> np.ndarray:
    """Per-pixel oriented gradient magnitudes, (M, N, n_bins) float32 (OpenCV kernels).

    The same quantity as :func:`viewadapt.hog.orientation_channels` in single precision:
    (``gamma``: square-root gamma, then) central differences with reflect-101 borders, the
    colour channel of largest magnitude, the magnitude split linearly between the two
    nearest of ``n_bins`` unsigned bins centred at ``(b + 1/2) pi / n_bins``
    (:func:`gradient_bins`). ``image``: (M, N[, 3]), uint8 or float in [0, 1].
    """
    import cv2

    mag, t = gradient_bins(image, n_bins=n_bins, gamma=gamma)
    planes = []
    for b in range(n_bins):
        d = cv2.absdiff(t, float(b))
        d = cv2.min(d, cv2.subtract(float(n_bins), d))             # circular distance
        planes.append(cv2.multiply(cv2.max(cv2.subtract(1.0, d), 0.0), mag))
    out = cv2.merge(planes)
    return out.reshape(mag.shape + (n_bins,))


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
    raw : tuple or None
        Raw 9-bin cell sums for a normalisation stage (``raw_cell_maps``' layout), or None.
    """

    maps: dict
    pad: int
    image_size: tuple
    _split: dict = field(default_factory=dict, repr=False)
    #: (cell sizes, buffer) when the maps are consecutive views of one flat buffer
    _flat: tuple = field(default=None, repr=False)
    raw: tuple = None

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
    if ny == 0 or nx == 0:                       # a frame smaller than one cell
        return np.zeros((ny, nx) + (channels.shape[2:] or (1,)), np.float32)
    src = np.ascontiguousarray(channels[:ny * c, :nx * c])
    # INTER_AREA with an integer factor is the exact block mean
    out = cv2.resize(src, (nx, ny), interpolation=cv2.INTER_AREA)
    if out.ndim == 2:
        out = out[:, :, None]
    return out * np.float32(c * c)


def multi_cell_sums(shape, cell_sizes, from_pixels) -> dict:
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


def orientation_cell_maps(image, cell_sizes, *, n_bins: int = N_HOG_BINS) -> dict:
    """Oriented gradient magnitudes summed over ``c x c`` cells, for each ``c``.

    The cell sums of :func:`fast_orientation_channels` (gamma off) -- the same quantity up
    to float32 rounding -- without any per-pixel frame array: gradient, strongest colour
    channel, magnitude and angle, and the split into the two nearest bins are computed one
    image row at a time and go straight into the cells of every size that is not a
    multiple of a smaller one, in one compiled pass (:mod:`viewadapt._kernels`); the other
    sizes are summed from those cells. Remainder rows and columns are dropped.

    Parameters
    ----------
    image : (M, N[, 3]) ndarray, uint8 or float in [0, 1]
    cell_sizes : iterable of int
    n_bins : int

    Returns
    -------
    dict int -> (M // c, N // c, n_bins) float32 ndarray
    """
    from .._kernels import hog_gradient_cell_sums

    img = _gradient_input(image)
    M, N = img.shape[:2]
    sizes = sorted(set(int(c) for c in cell_sizes))
    if sizes and sizes[0] < 1:
        raise ValueError(f"cell sizes must be positive integers, got {sizes[0]}")
    # the sizes multi_cell_sums computes from the pixels, all in one compiled pass
    direct, n_y, n_x, offsets, flat, pixel_sums = direct_cells(sizes, (M, N), n_bins)
    hog_gradient_cell_sums(img, n_bins, direct, offsets, n_x, n_y, flat)
    return multi_cell_sums((M, N), sizes, pixel_sums.__getitem__)


def direct_cells(sizes, frame_shape, channels: int):
    """The layout a compiled cell-sum pass fills: the cell sizes it computes from the
    pixels (those not a multiple of a smaller size > 1), their cell counts, offsets into
    one zeroed float32 buffer, the buffer, and each size's (ny, nx, channels) view of it.
    Returns ``(direct, n_y, n_x, offsets, flat, views)``."""
    M, N = frame_shape
    direct = [c for c in sizes if not any(b > 1 and c % b == 0 for b in sizes if b < c)]
    n_y = np.array([M // c for c in direct], np.int64)
    n_x = np.array([N // c for c in direct], np.int64)
    counts = n_y * n_x * channels
    offsets = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
    flat = np.zeros(int(counts.sum()), np.float32)
    views = {c: flat[o:o + k].reshape(ny, nx, channels)
             for c, o, k, ny, nx in zip(direct, offsets, counts, n_y, n_x)}
    return np.array(direct, np.int64), n_y, n_x, offsets, flat, views


def _gradient_input(image) -> np.ndarray:
    """``image`` as the (M, N, K) input of ``hog_gradient_cell_sums``: uint8 as it is (its
    differences are exact in float32), anything else through :func:`check_image` as
    float32 in 0..255."""
    arr = np.asarray(image)
    if not (arr.dtype == np.uint8 and arr.ndim in (2, 3) and arr.size
            and (arr.ndim == 2 or arr.shape[2] in (1, 3))):
        arr = check_image(arr, dtype=np.float32)
    return arr.reshape(arr.shape[:2] + (-1,))


def check_frame(image, image_size=None) -> np.ndarray:
    """``image`` as an array of shape (M, N[, 3]); with ``image_size`` (width, height) a
    frame of another size is a ``ValueError`` naming both sizes."""
    arr = np.asarray(image)
    if arr.ndim < 2:
        raise ValueError(f"frame must be an (M, N[, 3]) image, got shape {arr.shape}")
    if image_size is not None and (arr.shape[1], arr.shape[0]) != tuple(image_size):
        raise ValueError(f"frame is {arr.shape[1]}x{arr.shape[0]} px but the calibration "
                         f"and the precomputed detector are for {image_size[0]}x"
                         f"{image_size[1]} frames")
    return arr


def block_normalize_cells(cells, *, eps: float = 1.0, clip: float = HOG_CLIP,
                          out=None, rows=None) -> np.ndarray:
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
    rows : (int, int), optional
        Normalise only the cell rows ``rows[0] <= y < rows[1]`` (the same values as
        without ``rows``: their blocks still read the rows next to them); the other rows
        of ``out`` are left as they are (zeros when ``out`` is made here).

    Returns
    -------
    (ny, nx, B + 4) float32 ndarray: ``B`` orientation channels, then the texture energies
    of the up-left, up-right, down-left and down-right blocks.
    """
    from .._kernels import block_normalize

    X = np.ascontiguousarray(cells, dtype=np.float32)
    if X.ndim != 3:
        raise ValueError(f"cells must be (ny, nx, bins), got shape {X.shape}")
    ny, nx, nb = X.shape
    if out is None:
        out = (np.empty if rows is None else np.zeros)((ny, nx, nb + 4), np.float32)
    elif out.shape != (ny, nx, nb + 4) or out.dtype != np.float32:
        raise ValueError(f"out must be float32 of shape {(ny, nx, nb + 4)}, got {out.dtype} "
                         f"{out.shape}")
    r0, r1 = (0, ny) if rows is None else (max(int(rows[0]), 0), min(int(rows[1]), ny))
    if X.size and r0 < r1:
        block_normalize(X, float(eps), float(clip), out, r0, r1)
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
    return block_normalize_cells(X, eps=hog_cell_eps(cell_size))


#: Floor of :func:`block_normalize_cells` per pixel of cell area (gradient units of 0..255
#: images).
_EPS_PER_PX = 1.0


def hog_cell_eps(c: int) -> float:
    """Floor of the block norm for ``c x c`` cells: ``_EPS_PER_PX`` per pixel of cell area
    (the norms grow with the area, so the floor does too)."""
    return float(c * c) * _EPS_PER_PX


def padded_maps(cell_sizes, frame_shape, pad: int, channels: int):
    """One zero-padded float32 buffer holding a ``(M // c + 2 pad, N // c + 2 pad,
    channels)`` map per distinct cell size ``c``, in the order given: the operator's feature
    vector without a copy (``FrameFeatures.vector``). Returns ``(order, flat, maps)`` with
    ``maps[c]`` views into ``flat``."""
    M, N = frame_shape
    order = tuple(dict.fromkeys(int(c) for c in cell_sizes))
    shapes = [(M // c + 2 * pad, N // c + 2 * pad, channels) for c in order]
    flat = np.zeros(sum(int(np.prod(sh)) for sh in shapes), np.float32)
    maps, off = {}, 0
    for c, sh in zip(order, shapes):
        maps[c] = flat[off:off + int(np.prod(sh))].reshape(sh)
        off += maps[c].size
    return order, flat, maps


def hog_frame_features(image, cell_sizes, *, pad: int = 2, image_size=None,
                       raw_cell_sizes=(), rows=None, raw_rows=None) -> FrameFeatures:
    """Normalised HOG cell maps of a frame at several cell sizes, native resolution.

    The per-pixel gradients are computed once and summed into ``c x c`` cells of oriented
    magnitude for each ``c`` (:func:`orientation_cell_maps`), then
    normalised by :func:`block_normalize_cells` -- the features :func:`hog_window_features`
    computes on a canonical window with ``c = 8``. The raw cell sums of ``raw_cell_sizes``
    (the same pass) are kept as ``raw`` for a per-window normalisation stage.

    Parameters
    ----------
    image : (M, N[, 3]) ndarray
    cell_sizes : iterable of int
    pad : int
        Zero cells added on every side.
    image_size : (width, height), optional
        Expected frame size; a frame of another size is a ``ValueError``.
    raw_cell_sizes : iterable of int
    rows, raw_rows : dict ``c -> (y0, y1)``, optional
        Limit a size's normalised (``rows``) or raw (``raw_rows``) map to the cell rows an
        operator reads (the values there are those of the whole map; the other rows are 0).

    Returns
    -------
    FrameFeatures with (M // c + 2 pad, N // c + 2 pad, 13) maps.
    """
    img = check_frame(image, image_size)
    M, N = img.shape[:2]
    order, flat, maps = padded_maps(cell_sizes, (M, N), pad, HOG_CHANNELS)
    raw_sizes = [int(c) for c in raw_cell_sizes]
    cells = orientation_cell_maps(img, list(order) + raw_sizes)
    rows, raw_rows = rows or {}, raw_rows or {}
    for c, F in maps.items():
        ny, nx = cells[c].shape[:2]
        block_normalize_cells(cells[c], eps=hog_cell_eps(c), out=F[pad:pad + ny, pad:pad + nx],
                              rows=rows.get(c))
    raw = None
    if raw_sizes:                   # one flat buffer, as raw_cell_maps lays it out
        r_order, rflat, rmaps = padded_maps(raw_sizes, (M, N), 0, N_HOG_BINS)
        for c in r_order:
            y0, y1 = raw_rows.get(c, (0, M // c))
            rmaps[c][y0:y1] = cells[c][y0:y1]
        raw = (rmaps, rflat, np.cumsum([0] + [rmaps[c].size for c in r_order[:-1]]))
    return FrameFeatures(maps, pad, (N, M), _flat=(order, flat), raw=raw)
