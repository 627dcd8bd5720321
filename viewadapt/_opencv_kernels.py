"""Compiled inner loop of OpenCV's block-normalised HOG cells (numba), loaded on first use.

:func:`opencv_block_cells` accumulates every 2x2-cell block of an image's cell grid as
``cv2.HOGDescriptor`` does -- each pixel's magnitude split between its two orientation
bins, weighted by the block's separable Gaussian-times-bilinear window -- in two passes
(along rows, then down columns; 8 multiply-adds per pixel in the first), L2-Hys
normalises each block and writes each cell's copy from each block that contains it
(:mod:`viewadapt.detect.opencv_cells`). :func:`strongest_sqrt_gradient` and
:func:`angle_bins` are the element-wise steps of an 8-bit image's gradients around
``cv2.cartToPolar`` (:func:`viewadapt.detect.opencv_cells.opencv_gradients`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def _row_pass(mag, t, y, c, nx, ax, acc):  # pragma: no cover - compiled
    """Image row ``y`` along x into ``acc`` (nx - 1, 2, 9): each block's two cell columns,
    each pixel's magnitude split between its two bins and weighted by ``ax``."""
    n_bins = 9
    nbx = nx - 1
    for bx in range(nbx):
        for qx in range(2):
            for b in range(n_bins):
                acc[bx, qx, b] = 0.0
    for tile in range(nx):
        first = tile < nbx
        second = tile >= 1
        for i in range(c):
            x = tile * c + i
            m = mag[y, x]
            tt = t[y, x]
            b0 = int(tt)                 # t >= 0: truncation is the floor
            f = tt - np.float32(b0)
            if b0 >= n_bins:
                b0 -= n_bins
            b0 = min(max(b0, 0), n_bins - 1)
            b1 = b0 + 1 if b0 < n_bins - 1 else 0
            m1 = m * f
            m0 = m - m1
            if first:                    # the block's first column of cells
                w0 = ax[i, 0]
                w1 = ax[i, 1]
                acc[tile, 0, b0] += w0 * m0
                acc[tile, 0, b1] += w0 * m1
                acc[tile, 1, b0] += w1 * m0
                acc[tile, 1, b1] += w1 * m1
            if second:                   # the previous block's second column
                w0 = ax[c + i, 0]
                w1 = ax[c + i, 1]
                acc[tile - 1, 0, b0] += w0 * m0
                acc[tile - 1, 0, b1] += w0 * m1
                acc[tile - 1, 1, b0] += w1 * m0
                acc[tile - 1, 1, b1] += w1 * m1


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def _normalise_row(acc, by, nbx, eps, clip, blk, out, cy0, cy1):  # pragma: no cover - compiled
    """L2-Hys of block row ``by``'s blocks ``acc`` ([qy, bx, qx, bin] flat per qy), written
    as each cell's copy into the rows ``cy0 <= y < cy1`` of ``out``; ``blk`` (36,) scratch.
    Single precision, the sums in four partial sums."""
    n_bins = 9
    for bx in range(nbx):
        for qx in range(2):
            for qy in range(2):
                for b in range(n_bins):
                    blk[(2 * qx + qy) * n_bins + b] = acc[qy, (2 * bx + qx) * n_bins + b]
        z = np.float32(0.0)
        s0 = s1 = s2 = s3 = z
        for k in range(0, 36, 4):
            s0 += blk[k] * blk[k]
            s1 += blk[k + 1] * blk[k + 1]
            s2 += blk[k + 2] * blk[k + 2]
            s3 += blk[k + 3] * blk[k + 3]
        scale = np.float32(1.0) / (np.sqrt((s0 + s1) + (s2 + s3)) + eps)
        s0 = s1 = s2 = s3 = z
        for k in range(0, 36, 4):
            v0 = min(blk[k] * scale, clip)
            v1 = min(blk[k + 1] * scale, clip)
            v2 = min(blk[k + 2] * scale, clip)
            v3 = min(blk[k + 3] * scale, clip)
            blk[k], blk[k + 1], blk[k + 2], blk[k + 3] = v0, v1, v2, v3
            s0 += v0 * v0
            s1 += v1 * v1
            s2 += v2 * v2
            s3 += v3 * v3
        scale = np.float32(1.0) / (np.sqrt((s0 + s1) + (s2 + s3)) + np.float32(1e-3))
        for qx in range(2):
            for qy in range(2):
                if by + qy < cy0 or by + qy >= cy1:
                    continue
                q = 2 * qx + qy
                for b in range(n_bins):
                    out[by + qy, bx + qx, q * n_bins + b] = blk[q * n_bins + b] * scale


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def opencv_block_cells(mag, t, c, ax, eps, clip, out, cy0, cy1):  # pragma: no cover - compiled
    """Block-normalised cells of size ``c`` into ``out`` (ny, nx, 36), zeros where a cell's
    block does not exist; only cell rows ``cy0 <= cy < cy1`` are computed (the image rows
    of their blocks are read, no others), the other rows of ``out`` are left as they are
    (``0, ny``: every row).

    ``mag`` (M, N) float32 gradient magnitudes; ``t`` (M, N) float32 bin coordinates in
    ``[0, n_bins)`` (bin ``floor(t)`` gets ``1 - frac``, the next bin ``frac``); ``ax``
    (2c, 2) float32 the window's weight of each block pixel row (or column) for the block's
    two cells; ``eps`` the L2 floor, ``clip`` the L2-Hys threshold.

    One image row at a time: the row along x (:func:`_row_pass`), then added, weighted
    by the row's place in each block, into the two block rows that contain it; a block
    row is normalised and written when its last image row is in.
    """
    n_bins = 9
    ny, nx = mag.shape[0] // c, mag.shape[1] // c
    if ny < 2 or nx < 2:
        out[:] = 0
        return
    nbx, nby = nx - 1, ny - 1
    cy0, cy1 = max(cy0, 0), min(cy1, ny)
    if cy0 >= cy1:
        return
    # the block rows cy0 - 1 .. cy1 - 1 hold the rows' copies; their cell rows ya .. yb - 1
    ya, yb = max(cy0 - 1, 0), min(cy1 + 1, ny)
    # copies whose block does not exist: all on the grid's border, zeroed first
    for x in range(nx):
        if cy0 == 0:
            out[0, x, :] = 0
        if cy1 == ny:
            out[ny - 1, x, :] = 0
    for y in range(cy0, cy1):
        out[y, 0, :] = 0
        out[y, nx - 1, :] = 0
    n = nbx * 2 * n_bins
    row = np.empty((nbx, 2, n_bins), np.float32)                  # [bx, qx, bin]
    rf = row.ravel()
    # two block rows in flight, each [qy, bx, qx, bin]: ``cur`` (this cell row is its
    # first) and ``prev`` (its second)
    cur = np.zeros((2, n), np.float32)
    prev = np.zeros((2, n), np.float32)
    blk = np.empty(4 * n_bins, np.float32)                        # [qx, qy, bin]
    for cy in range(ya, yb):
        for r in range(c):
            _row_pass(mag, t, cy * c + r, c, nx, ax, row)
            if cy < nby:
                w0 = ax[r, 0]
                w1 = ax[r, 1]
                for k in range(n):
                    cur[0, k] += w0 * rf[k]
                    cur[1, k] += w1 * rf[k]
            if cy > ya:
                w0 = ax[c + r, 0]
                w1 = ax[c + r, 1]
                for k in range(n):
                    prev[0, k] += w0 * rf[k]
                    prev[1, k] += w1 * rf[k]
        if cy > ya:                                               # block row cy - 1 is done
            _normalise_row(prev, cy - 1, nbx, eps, clip, blk, out, cy0, cy1)
        cur, prev = prev, cur
        for k in range(n):
            cur[0, k] = 0.0
            cur[1, k] = 0.0


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def strongest_sqrt_gradient(img, root, gx, gy):  # pragma: no cover - compiled
    """Central differences of ``root[img]`` (``img`` (M, N, K) uint8 with K 1 or 3,
    ``root`` (256,) float32 its square roots; reflect-101 borders, M, N >= 2) of the
    channel of largest ``dx**2 + dy**2`` per pixel (ties keep the earlier channel), into
    (M, N) ``gx, gy``.

    Each image row is looked up once, into a ring of three channel-planar rows; the
    differences and the choice of channel then run along contiguous rows."""
    M, N, K = img.shape
    ring = np.empty((3, K, N), np.float32)        # image row r at ring[r % 3]
    dx = np.empty((K, N), np.float32)
    dy = np.empty((K, N), np.float32)
    for r in range(2):
        for j in range(N):
            for k in range(K):
                ring[r, k, j] = root[img[r, j, k]]
    for i in range(M):
        if 2 <= i + 1 < M:                        # row i + 1 replaces row i - 2
            nxt = ring[(i + 1) % 3]
            for j in range(N):
                for k in range(K):
                    nxt[k, j] = root[img[i + 1, j, k]]
        up = ring[(i - 1 if i > 0 else 1) % 3]
        mid = ring[i % 3]
        down = ring[(i + 1 if i < M - 1 else M - 2) % 3]
        for k in range(K):
            c, u, d, ox, oy = mid[k], up[k], down[k], dx[k], dy[k]
            ox[0] = 0.0                           # reflect-101: both neighbours are pixel 1
            for j in range(1, N - 1):
                ox[j] = c[j + 1] - c[j - 1]
            ox[N - 1] = 0.0
            for j in range(N):
                oy[j] = d[j] - u[j]
        gxi, gyi = gx[i], gy[i]
        if K == 1:
            gxi[:] = dx[0]
            gyi[:] = dy[0]
            continue
        for j in range(N):                        # K == 3, without branches
            x0 = dx[0, j]
            y0 = dy[0, j]
            x1 = dx[1, j]
            y1 = dy[1, j]
            x2 = dx[2, j]
            y2 = dy[2, j]
            m0 = x0 * x0 + y0 * y0
            m1 = x1 * x1 + y1 * y1
            one = m1 > m0
            bx = x1 if one else x0
            by = y1 if one else y0
            two = x2 * x2 + y2 * y2 > (m1 if one else m0)
            gxi[j] = x2 if two else bx
            gyi[j] = y2 if two else by


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def angle_bins(ang, scale, n_bins, t):  # pragma: no cover - compiled
    """``t = ang * scale - 1/2`` taken into ``[0, n_bins)`` (the product in double
    precision, rounded to float32, then the float32 steps; ``ang`` in ``[0, 2 pi)``: at
    most two turns of ``n_bins`` either way), into ``t``."""
    M, N = ang.shape
    half = np.float32(0.5)
    nb = np.float32(n_bins)
    for i in range(M):
        for j in range(N):
            v = np.float32(np.float64(ang[i, j]) * scale) - half
            for _ in range(2):
                if v < 0:
                    v += nb
                if v >= nb:
                    v -= nb
            t[i, j] = v
