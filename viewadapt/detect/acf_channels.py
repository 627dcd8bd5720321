"""ACF frame features of the full-frame detectors (Dollár et al. 2014): the ten pixel
channels -- toolbox LUV, normalised gradient magnitude, six orientation channels -- once,
aggregated into square cells of each size the operator's windows need
(:func:`acf_frame_features`); :func:`acf_window_features` computes the same channels on a
canonical 64x128 window, what the source detector is trained on. The HOG counterparts are in
:mod:`viewadapt.detect.channels`.

References
----------
.. [1] P. Dollár, R. Appel, S. Belongie, P. Perona, "Fast Feature Pyramids for Object
   Detection", IEEE TPAMI 36(8), 2014.
"""

from __future__ import annotations

import numpy as np

from .._validation import check_image
from ..acf import LUV_CONSTANTS, acf_pixel_channels, convolve_triangle, triangle_kernel
from .channels import (
    ACF_SHRINK, N_ACF_CHANNELS, N_ACF_ORIENTS, FrameFeatures, cell_sums, check_frame,
    direct_cells, multi_cell_sums, padded_maps, strongest_gradient,
)

__all__ = ["fast_acf_pixel_channels", "acf_channel_cell_maps", "acf_window_features",
           "acf_frame_features"]


def _smoothed_luv(image) -> np.ndarray:
    """The toolbox LUV of an (M, N[, 3]) image smoothed by ``convTri(., 1)``: (M, N, 3)
    float32 (a grey image as three equal RGB channels)."""
    import cv2

    from .._acf_kernels import rgb_to_luv_rows

    img = check_image(image, dtype=np.float32) * np.float32(1 / 255)
    if img.ndim == 2:
        img = cv2.merge([img, img, img])
    luv = np.empty(img.shape[:2] + (3,), np.float32)
    xyz, *scalars = LUV_CONSTANTS
    rgb_to_luv_rows(img, xyz.astype(np.float32), *map(np.float32, scalars), luv)
    tri1 = triangle_kernel(1).astype(np.float32)
    return cv2.sepFilter2D(luv, -1, tri1, tri1, borderType=cv2.BORDER_REFLECT)


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

    from .._kernels import acf_channels_out

    luv = _smoothed_luv(image)
    M, N = luv.shape[:2]
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
    dx, dy = strongest_gradient(gx, gy)
    # not cv2.magnitude: its result depends on the output buffer's alignment (1 ulp)
    mag = np.sqrt(dx * dx + dy * dy)
    tri5 = triangle_kernel(5).astype(np.float32)
    mag = mag / (cv2.sepFilter2D(mag, -1, tri5, tri5, borderType=cv2.BORDER_REFLECT)
                 + np.float32(0.005))
    out = np.empty((M, N, 4 + N_ACF_ORIENTS), np.float32)
    acf_channels_out(luv, mag, dx, dy, N_ACF_ORIENTS, out)
    return out


def acf_channel_cell_maps(image, cell_sizes) -> dict:
    """The ten ACF pixel channels summed over ``c x c`` cells, for each ``c``.

    The cell sums of :func:`fast_acf_pixel_channels` (kept as the reference) up to float32
    rounding of the sums -- magnitudes and bins are the same numbers -- without its
    ten-channel pixel array: one compiled pass for the strongest gradient's magnitude and
    bin, ``convTri(M, 5)``, one that normalises and sums into the cells of each size not a
    multiple of a smaller one (:mod:`viewadapt._acf_kernels`); the others are summed from
    those. Remainder rows and columns are dropped.

    Parameters
    ----------
    image : (M, N[, 3]) ndarray, uint8 or float in [0, 1] RGB
    cell_sizes : iterable of int

    Returns
    -------
    dict int -> (M // c, N // c, 10) float32 ndarray
    """
    import cv2

    from .._acf_kernels import acf_channel_cell_sums, acf_gradient_bins

    sizes = sorted(set(int(c) for c in cell_sizes))
    if sizes and sizes[0] < 1:
        raise ValueError(f"cell sizes must be positive integers, got {sizes[0]}")
    luv = _smoothed_luv(image)
    M, N = luv.shape[:2]
    mag, bins = np.empty((M, N), np.float32), np.empty((M, N), np.int8)
    acf_gradient_bins(luv, N_ACF_ORIENTS, mag, bins)
    tri5 = triangle_kernel(5).astype(np.float32)
    mag_smooth = cv2.sepFilter2D(mag, -1, tri5, tri5, borderType=cv2.BORDER_REFLECT)
    C = 4 + N_ACF_ORIENTS
    direct, n_y, n_x, offsets, flat, pixel_sums = direct_cells(sizes, (M, N), C)
    acf_channel_cell_sums(luv, mag, mag_smooth, np.float32(0.005), bins, N_ACF_ORIENTS,
                          direct, offsets, n_x, n_y, flat)
    return multi_cell_sums((M, N), sizes, pixel_sums.__getitem__)


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


def acf_frame_features(image, cell_sizes, *, pad: int = 2, smooth_channels: float = 1,
                       image_size=None, **kwargs) -> FrameFeatures:
    """ACF cell maps of a frame: pixel channels once, aggregated at each cell size.

    ``x_c = convTri(block_mean_c(P), smooth_channels)`` with ``P`` the ten full-resolution
    channels of :func:`viewadapt.acf.acf_pixel_channels` (``kwargs`` go there) -- the ACF
    channels the toolbox would compute with ``shrink = c``; without ``kwargs`` the cell
    sums come from :func:`acf_channel_cell_maps` (float32).

    Returns
    -------
    FrameFeatures with (ny + 2 pad, nx + 2 pad, 10) maps, channel order of
    :data:`viewadapt.acf.ACF_CHANNEL_NAMES`.
    """
    import cv2

    img = check_frame(image, image_size)
    M, N = img.shape[:2]
    if kwargs:
        P = acf_pixel_channels(img, shrink=1, **kwargs).astype(np.float32)   # (10, M, N)
        P = np.ascontiguousarray(np.moveaxis(P, 0, -1))
        cells = multi_cell_sums(P.shape, cell_sizes, lambda c: cell_sums(P, c))
    else:
        cells = acf_channel_cell_maps(img, cell_sizes)
    tri = triangle_kernel(smooth_channels)
    order, flat, maps = padded_maps(cell_sizes, (M, N), pad, N_ACF_CHANNELS)
    for c, F in maps.items():
        A = cells[c]
        ny, nx = A.shape[:2]
        area = np.float32(1.0 / (c * c))
        if tri is not None and min(ny, nx) > 1:
            # the block mean's 1 / c^2 folded into the vertical kernel
            t = tri.astype(np.float32)
            A = cv2.sepFilter2D(A, -1, t, t * area, borderType=cv2.BORDER_REFLECT)
        elif tri is not None:
            A = np.moveaxis(convolve_triangle(np.moveaxis(A * area, -1, 0), smooth_channels),
                            0, -1)
        else:
            A = A * area
        F[pad:pad + ny, pad:pad + nx] = A
    return FrameFeatures(maps, pad, (N, M), _flat=(order, flat))
