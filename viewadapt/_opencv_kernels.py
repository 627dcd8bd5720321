"""Compiled inner loop of OpenCV's block-normalised HOG cells (numba), loaded on first use.

:func:`opencv_block_cells` accumulates every 2x2-cell block of an image's cell grid as
``cv2.HOGDescriptor`` does -- each pixel's magnitude split between its two orientation
bins, weighted by the block's separable Gaussian-times-bilinear window -- in two passes
(along rows, then down columns; 8 multiply-adds per pixel in the first), L2-Hys
normalises each block and writes each cell's copy from each block that contains it
(:mod:`viewadapt.detect.opencv_cells`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def opencv_block_cells(mag, t, c, ax, eps, clip, out):  # pragma: no cover - compiled
    """Block-normalised cells of size ``c`` into ``out`` (ny, nx, 36), zeros where a cell's
    block does not exist.

    ``mag`` (M, N) float32 gradient magnitudes; ``t`` (M, N) float32 bin coordinates in
    ``[0, n_bins)`` (bin ``floor(t)`` gets ``1 - frac``, the next bin ``frac``); ``ax``
    (2c, 2) float32 the window's weight of each block pixel row (or column) for the block's
    two cells; ``eps`` the L2 floor, ``clip`` the L2-Hys threshold.
    """
    n_bins = 9
    ny, nx = mag.shape[0] // c, mag.shape[1] // c
    out[:] = 0
    if ny < 2 or nx < 2:
        return
    nbx, nby = nx - 1, ny - 1
    rows = np.zeros((ny * c, nbx, 2, n_bins), np.float32)
    for y in range(ny * c):
        for tile in range(nx):
            for i in range(c):
                x = tile * c + i
                m = mag[y, x]
                tt = t[y, x]
                b0 = int(tt)                 # t >= 0: truncation is the floor
                f = tt - b0
                if b0 >= n_bins:
                    b0 -= n_bins
                b1 = b0 + 1 if b0 < n_bins - 1 else 0
                m1 = m * f
                m0 = m - m1
                if tile < nbx:               # the block's first column of cells
                    w0 = ax[i, 0]
                    w1 = ax[i, 1]
                    rows[y, tile, 0, b0] += w0 * m0
                    rows[y, tile, 0, b1] += w0 * m1
                    rows[y, tile, 1, b0] += w1 * m0
                    rows[y, tile, 1, b1] += w1 * m1
                if tile >= 1:                # the previous block's second column
                    w0 = ax[c + i, 0]
                    w1 = ax[c + i, 1]
                    rows[y, tile - 1, 0, b0] += w0 * m0
                    rows[y, tile - 1, 0, b1] += w0 * m1
                    rows[y, tile - 1, 1, b0] += w1 * m0
                    rows[y, tile - 1, 1, b1] += w1 * m1
    # down the columns: one block row at a time, each image row's blocks in one
    # contiguous sweep (qx, bin inner), accumulated into both cells of the block's column
    blk = np.empty((nbx, 2, 2, n_bins), np.float32)               # [bx, qx, qy, bin]
    for by in range(nby):
        blk[:] = 0
        for r in range(2 * c):
            row = rows[by * c + r]
            w0 = ax[r, 0]
            w1 = ax[r, 1]
            for bx in range(nbx):
                for qx in range(2):
                    for b in range(n_bins):
                        v = row[bx, qx, b]
                        blk[bx, qx, 0, b] += w0 * v
                        blk[bx, qx, 1, b] += w1 * v
        for bx in range(nbx):
            s = 0.0
            for qx in range(2):
                for qy in range(2):
                    for b in range(n_bins):
                        s += blk[bx, qx, qy, b] * blk[bx, qx, qy, b]
            scale = 1.0 / (math.sqrt(s) + eps)
            s = 0.0
            for qx in range(2):
                for qy in range(2):
                    for b in range(n_bins):
                        v = min(blk[bx, qx, qy, b] * scale, clip)
                        blk[bx, qx, qy, b] = v
                        s += v * v
            scale = 1.0 / (math.sqrt(s) + 1e-3)
            for qx in range(2):
                for qy in range(2):
                    q = 2 * qx + qy
                    for b in range(n_bins):
                        out[by + qy, bx + qx, q * n_bins + b] = blk[bx, qx, qy, b] * scale
