"""Histograms of oriented gradients (Dalal & Triggs 2005), with the linear part exposed.

Two levels are provided:

* **Oriented-magnitude channels** ``O[y, x, b]``: each pixel's gradient magnitude split
  between the two nearest of ``n_bins`` orientation bins over 180 degrees (linear
  interpolation between bin centres, as OpenCV does). Everything downstream that sums
  these over rectangles -- cell histograms, dense maps -- is linear in ``O``; that is
  what makes viewpoint remapping (``G = S (x) A``) well defined.
* **Cell histograms** (``hog_cells``): sums of ``O`` over ``cell_size`` x ``cell_size``
  cells (hard spatial binning), and the **Dalal-Triggs descriptor** (``hog_descriptor``):
  2x2-cell blocks at a stride of one cell, L2-Hys normalised, laid out exactly like
  ``cv2.HOGDescriptor`` so OpenCV's pretrained people detector applies.

The descriptor has two methods. ``method="opencv"`` reproduces OpenCV's computation
(square-root gamma, Gaussian block window with sigma 4, bilinear spatial interpolation of
each pixel into the 4 cells of each block). ``method="cells"`` builds blocks from the
plain cell histograms: that is the form whose cells can be remapped, and the one the
adapted HOG detectors use.

Notes
-----
Orientations follow OpenCV: unsigned angle ``theta = atan2(dy, dx) mod pi``; bin ``b`` is
centred at ``(b + 0.5) * pi / n_bins``. Gradients are central differences ``[-1, 0, 1]``
with reflect-101 borders (so the derivative across the image border is 0), and on colour
images the channel with the largest magnitude wins per pixel.
"""

from __future__ import annotations

import numpy as np

from ._validation import check_image

__all__ = [
    "image_gradients",
    "orientation_channels",
    "locally_normalize_channels",
    "hog_cells",
    "cells_to_blocks",
    "normalize_blocks_l2hys",
    "hog_descriptor",
    "hog_opencv_blocks",
    "hog_descriptor_index",
    "opencv_people_detector",
]


def image_gradients(image, *, gamma: bool = False,
                    dtype=np.float64) -> tuple[np.ndarray, np.ndarray]:
    """Central-difference gradients of an image, colour images by max-magnitude channel.

    Parameters
    ----------
    image : (M, N[, 3]) ndarray
        uint8 (0..255) or float (0..1).
    gamma : bool
        Apply OpenCV's square-root gamma (``sqrt`` of the 0..255 value) first.
    dtype : numpy dtype
        Arithmetic precision. ``float32`` reproduces OpenCV bit for bit, including which
        channel wins when two channels' magnitudes tie after rounding.

    Returns
    -------
    dx, dy : (M, N) float64 ndarrays, derivatives along x (columns) and y (rows).
    """
    img = check_image(image).astype(dtype)
    if gamma:
        img = np.sqrt(img)
    if img.ndim == 2:
        img = img[:, :, None]
    M, N = img.shape[:2]
    # reflect-101 borders (numpy's "reflect"); a 1-pixel dimension has no neighbours
    pad = np.pad(img, ((1, 1), (1, 1), (0, 0)), mode="reflect" if min(M, N) > 1 else "edge")
    dx = pad[1:-1, 2:] - pad[1:-1, :-2]
    dy = pad[2:, 1:-1] - pad[:-2, 1:-1]
    if img.shape[2] == 1:
        return dx[:, :, 0], dy[:, :, 0]
    mag2 = dx * dx + dy * dy
    # OpenCV keeps the first channel with the largest float32 magnitude (a later channel
    # must be strictly larger to win), which is what argmax does.
    best = np.argmax(mag2, axis=2)[:, :, None]
    return (np.take_along_axis(dx, best, axis=2)[:, :, 0],
            np.take_along_axis(dy, best, axis=2)[:, :, 0])


def orientation_channels(image, *, n_bins: int = 9, gamma: bool = False,
                         dtype=np.float64) -> np.ndarray:
    """Per-pixel gradient magnitude split between the two nearest orientation bins.

    .. math:: O_b(p) = |\\nabla I(p)| \\, \\max(0, 1 - |t(p) - b|_{\\circ}),\\quad
              t(p) = \\frac{n_{bins}}{\\pi}\\,\\theta(p) - \\frac12

    with :math:`|\\cdot|_\\circ` the circular distance modulo ``n_bins``.

    Parameters
    ----------
    image : (M, N[, 3]) ndarray
    n_bins : int
        Bins over 180 degrees (unsigned gradients).
    gamma : bool
        Square-root gamma first (OpenCV's default).

    Returns
    -------
    O : (M, N, n_bins) float64 ndarray, ``O.sum(-1)`` is the gradient magnitude.
    """
    n_bins = _check_bins(n_bins)
    dx, dy = image_gradients(image, gamma=gamma, dtype=dtype)
    return _orientation_channels_from_gradients(dx.astype(np.float64), dy.astype(np.float64),
                                                n_bins)


def _orientation_channels_from_gradients(dx, dy, n_bins):
    from ._kernels import split_orientations

    # numpy's hypot and arctan2 (vectorised libm/SVML; a compiled scalar atan2 can differ
    # in the last bit), then the split in one compiled pass:
    # t = mod(theta, pi) n_bins / pi - 1/2, (1 - frac) to bin floor(t), frac to the next
    mag = np.ascontiguousarray(np.hypot(dx, dy))
    theta = np.ascontiguousarray(np.arctan2(dy, dx))
    return split_orientations(mag, theta, int(n_bins), np.empty(mag.shape + (n_bins,)))


def locally_normalize_channels(channels, *, cell_size: int = 8, eps: float = 1e-2) -> np.ndarray:
    """Divide oriented channels by the local gradient energy around each pixel.

    .. math:: \\tilde O_b(p) = \\frac{O_b(p)}{\\sqrt{\\sum_{q \\in N(p)} |\\nabla I(q)|^2
              / |N(p)| + \\epsilon^2}}

    where ``N(p)`` is the ``2 cell_size`` square around ``p`` (a Dalal-Triggs block).
    The factor depends only on the image, never on a window, so cell sums of the result
    stay linear in ``tilde O`` and remapping folds into linear weights. This is our
    window-independent substitute for block normalisation (see ``viewadapt.adapt``).

    Parameters
    ----------
    channels : (M, N, B) ndarray, from :func:`orientation_channels`.
    cell_size : int
    eps : float
        Floor on the local RMS magnitude, in the image's 0..255 units (times 255 for a
        float image).

    Returns
    -------
    (M, N, B) ndarray
    """
    import cv2

    O = np.asarray(channels, dtype=np.float64)
    if O.ndim != 3:
        raise ValueError(f"channels must have shape (M, N, B), got {O.shape}")
    mag2 = O.sum(axis=2) ** 2  # |grad|^2 (the bins of one pixel sum to its magnitude)
    k = 2 * int(cell_size)
    local = cv2.boxFilter(mag2, -1, (k, k), normalize=True, borderType=cv2.BORDER_REFLECT_101)
    return O / np.sqrt(np.maximum(local, 0.0) + eps * eps)[:, :, None]


def _check_bins(n_bins):
    if int(n_bins) != n_bins or n_bins < 2:
        raise ValueError(f"n_bins must be an integer >= 2, got {n_bins!r}")
    return int(n_bins)


def _check_cell(cell_size):
    if int(cell_size) != cell_size or cell_size < 1:
        raise ValueError(f"cell_size must be a positive integer, got {cell_size!r}")
    return int(cell_size)


def hog_cells(image, *, cell_size: int = 8, n_bins: int = 9, gamma: bool = False,
              normalize: str | None = None, norm_cell_size: int = 8) -> np.ndarray:
    """HOG cell histograms: sums of oriented magnitudes over non-overlapping cells.

    Parameters
    ----------
    image : (M, N[, 3]) ndarray
        ``M`` and ``N`` must be multiples of ``cell_size``.
    cell_size : int
    n_bins : int
    gamma : bool
    normalize : {None, "local"}
        ``"local"`` divides each pixel's channels by its local gradient energy first
        (:func:`locally_normalize_channels`); the result is still a linear cell sum.
    norm_cell_size : int
        The local normalisation's neighbourhood is ``2 norm_cell_size`` pixels square,
        whatever ``cell_size`` is (8: a Dalal-Triggs block), so features on a finer target
        grid are normalised exactly like the source features they are remapped to.

    Returns
    -------
    H : (M // cell_size, N // cell_size, n_bins) float64 ndarray
    """
    cell_size = _check_cell(cell_size)
    img = np.asarray(image)
    if img.ndim >= 2 and (img.shape[0] % cell_size or img.shape[1] % cell_size):
        raise ValueError(
            f"image size {img.shape[1]}x{img.shape[0]} is not a multiple of cell_size={cell_size}"
        )
    O = orientation_channels(image, n_bins=n_bins, gamma=gamma)
    if normalize == "local":
        O = locally_normalize_channels(O, cell_size=norm_cell_size)
    elif normalize is not None:
        raise ValueError(f"normalize must be None or 'local', got {normalize!r}")
    return sum_cells(O, cell_size)


def sum_cells(channels, cell_size: int) -> np.ndarray:
    """Sum (M, N, B) channels over ``cell_size`` squares -> (M//c, N//c, B)."""
    O = np.asarray(channels)
    M, N, B = O.shape
    c = cell_size
    return O[: M // c * c, : N // c * c].reshape(M // c, c, N // c, c, B).sum(axis=(1, 3))


def cells_to_blocks(cells) -> np.ndarray:
    """Group a cell grid into 2x2-cell blocks at a one-cell stride, OpenCV layout.

    Parameters
    ----------
    cells : (ny, nx, B) ndarray

    Returns
    -------
    blocks : (nx - 1, ny - 1, 4, B) ndarray, indexed ``[block_x, block_y, cell, bin]`` with
        ``cell = 2 * cell_x + cell_y`` -- OpenCV's order (x outer, y inner, both for blocks
        and for the cells inside a block). ``blocks.reshape(-1)`` is the descriptor layout.
    """
    C = np.asarray(cells, dtype=np.float64)
    if C.ndim != 3 or C.shape[0] < 2 or C.shape[1] < 2:
        raise ValueError(f"cells must have shape (ny >= 2, nx >= 2, B), got {C.shape}")
    ny, nx, B = C.shape
    out = np.empty((nx - 1, ny - 1, 4, B))
    out[:, :, 0] = C[:-1, :-1].transpose(1, 0, 2)   # cell (x0, y0)
    out[:, :, 1] = C[1:, :-1].transpose(1, 0, 2)    # cell (x0, y1)
    out[:, :, 2] = C[:-1, 1:].transpose(1, 0, 2)    # cell (x1, y0)
    out[:, :, 3] = C[1:, 1:].transpose(1, 0, 2)     # cell (x1, y1)
    return out


def normalize_blocks_l2hys(blocks, *, clip: float = 0.2, eps: float | None = None) -> np.ndarray:
    """L2-Hys block normalisation exactly as OpenCV's ``normalizeBlockHistogram``.

    .. math:: v \\leftarrow \\min\\!\\left(\\frac{v}{\\lVert v\\rVert_2 + 0.1\\,d}, c\\right),
              \\qquad v \\leftarrow \\frac{v}{\\lVert v\\rVert_2 + 10^{-3}}

    with ``d`` the block length (36) and ``c = clip``; Dalal & Triggs use
    :math:`\\sqrt{\\lVert v\\rVert^2 + \\epsilon^2}` instead (set ``eps``).

    Parameters
    ----------
    blocks : (..., d) ndarray (the last axes are flattened per block if given as (..., 4, B))
    """
    v = np.asarray(blocks, dtype=np.float64)
    shape = v.shape
    if v.ndim >= 2 and shape[-2] == 4:
        v = v.reshape(shape[:-2] + (-1,))
    d = v.shape[-1]
    norm = np.sqrt(np.einsum("...i,...i->...", v, v))[..., None]
    v = v / (norm + (0.1 * d if eps is None else eps))
    np.minimum(v, clip, out=v)
    norm = np.sqrt(np.einsum("...i,...i->...", v, v))[..., None]
    v /= norm + 1e-3
    return v.reshape(shape)


def hog_descriptor(image, *, method: str = "cells", cell_size: int = 8, n_bins: int = 9,
                   gamma: bool | None = None) -> np.ndarray:
    """Dalal-Triggs HOG descriptor, layout-compatible with ``cv2.HOGDescriptor``.

    Parameters
    ----------
    image : (M, N[, 3]) ndarray
        One detection window, e.g. 128 x 64 (gives 3780 values).
    method : {"cells", "opencv"}
        ``"cells"``: blocks assembled from plain cell histograms (:func:`hog_cells`), the
        remappable form. ``"opencv"``: OpenCV's computation (Gaussian block window,
        bilinear spatial interpolation).
    gamma : bool, optional
        Square-root gamma. Defaults to True for ``"opencv"`` (OpenCV's default) and False
        for ``"cells"``.

    Returns
    -------
    (D,) float64 ndarray, ``D = (nx - 1) (ny - 1) 4 n_bins``.
    """
    if method == "cells":
        cells = hog_cells(image, cell_size=cell_size, n_bins=n_bins,
                          gamma=bool(gamma) if gamma is not None else False)
        blocks = cells_to_blocks(cells)
    elif method == "opencv":
        blocks = hog_opencv_blocks(image, cell_size=cell_size, n_bins=n_bins,
                                   gamma=True if gamma is None else bool(gamma))
    else:
        raise ValueError(f"method must be 'cells' or 'opencv', got {method!r}")
    return normalize_blocks_l2hys(blocks).reshape(-1)


def _opencv_block_weights(cell_size: int) -> np.ndarray:
    """(2c, 2c, 4) per-pixel weight of each block cell: Gaussian times bilinear (OpenCV)."""
    b = 2 * cell_size
    sigma = (b + b) / 8.0                          # OpenCV's getWinSigma() default
    i = np.arange(b)
    d = i - b * 0.5                                # OpenCV uses i - blockSize/2, not i + 0.5
    gauss = np.exp(-(d[:, None] ** 2 + d[None, :] ** 2) / (2 * sigma * sigma))
    coord = (i + 0.5) / cell_size - 0.5            # pixel position in cell units
    tent = np.maximum(0.0, 1.0 - np.abs(coord[:, None] - np.arange(2)[None, :]))  # (b, 2)
    W = np.empty((b, b, 4))
    for cx in range(2):
        for cy in range(2):
            W[:, :, 2 * cx + cy] = gauss * tent[:, cy][:, None] * tent[:, cx][None, :]
    return W


def hog_opencv_blocks(image, *, cell_size: int = 8, n_bins: int = 9,
                      gamma: bool = True) -> np.ndarray:
    """Unnormalised block histograms computed the way ``cv2.HOGDescriptor`` does.

    Returns
    -------
    blocks : (nx - 1, ny - 1, 4, n_bins) ndarray (see :func:`cells_to_blocks`).
    """
    cell_size = _check_cell(cell_size)
    img = np.asarray(image)
    if img.ndim >= 2 and (img.shape[0] % cell_size or img.shape[1] % cell_size):
        raise ValueError(
            f"image size {img.shape[1]}x{img.shape[0]} is not a multiple of cell_size={cell_size}"
        )
    O = orientation_channels(image, n_bins=n_bins, gamma=gamma, dtype=np.float32)
    M, N, B = O.shape
    c = cell_size
    ny, nx = M // c, N // c
    if ny < 2 or nx < 2:
        raise ValueError(f"image must hold at least 2x2 cells, got {N}x{M} pixels")
    W = _opencv_block_weights(c)                            # (2c, 2c, 4)
    # Tile sums with each of the 4 tile roles (quadrant of the block the tile fills), as one
    # matrix product per role: (tile, bin) rows of c*c pixels times the role's c*c x 4 weights.
    tiles = O.reshape(ny, c, nx, c, B).transpose(0, 2, 4, 1, 3).reshape(ny, nx, B, c * c)
    out = np.zeros((nx - 1, ny - 1, 4, B))
    for ry in range(2):
        for rx in range(2):
            Wq = W[ry * c:(ry + 1) * c, rx * c:(rx + 1) * c].reshape(c * c, 4)
            T = tiles @ Wq                                       # (ny, nx, B, 4)
            out += T[ry:ny - 1 + ry, rx:nx - 1 + rx].transpose(1, 0, 3, 2)
    return out


def hog_descriptor_index(block_x, block_y, cell_x, cell_y, bin_, *, n_blocks_y: int = 15,
                         n_bins: int = 9):
    """Flat index into the descriptor (OpenCV order) of a block, cell-in-block and bin."""
    return ((np.asarray(block_x) * n_blocks_y + block_y) * 4 + 2 * np.asarray(cell_x)
            + cell_y) * n_bins + bin_


def opencv_people_detector() -> tuple[np.ndarray, float]:
    """OpenCV's pretrained Dalal-Triggs people detector as ``(w, b)``.

    Returns
    -------
    w : (3780,) float64 weights over the OpenCV-layout descriptor.
    b : float, the bias: ``score = w @ x + b``.
    """
    import cv2

    v = np.asarray(cv2.HOGDescriptor_getDefaultPeopleDetector(), dtype=np.float64).ravel()
    return v[:-1].copy(), float(v[-1])
