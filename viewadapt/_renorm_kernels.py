"""Compiled loops of the per-window normalisation stage (numba), loaded on first use.

:func:`raw_cell_sums` sums each pixel's magnitude, split between its two orientation bins,
into ``c x c`` cells (hard spatial binning). :func:`renorm_scores` scores windows of an
OpenCV HOG/SVM from those cells: each source cell's histogram is the frame cells' under
the image of that cell (an axis-aligned rectangle, its centre mapped by the window's
homography and its sides by the homography's Jacobian there: ``S``), its orientations
mapped by the covariant rule at the window's centre (``A``); then the window's own 2x2-cell
blocks are L2-Hys normalised as ``cv2.HOGDescriptor`` does and dotted with the SVM's
weights (:mod:`viewadapt.detect.renorm`). Frame cells outside a map read as zero, so no
stored table can make the loops read outside the maps.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def raw_cell_sums(mag, t, c, out):  # pragma: no cover - compiled
    """(M // c, N // c, 9) cell sums of ``mag`` split between bins ``floor(t)`` (weight
    ``1 - frac``) and the next (``frac``), written into ``out``."""
    n_bins = 9
    ny, nx = mag.shape[0] // c, mag.shape[1] // c
    out[:] = 0
    for y in range(ny * c):
        cy = y // c
        for x in range(nx * c):
            m = mag[y, x]
            tt = t[y, x]
            b0 = int(tt)
            f = tt - b0
            if b0 >= n_bins:
                b0 -= n_bins
            b1 = b0 + 1 if b0 < n_bins - 1 else 0
            cx = x // c
            out[cy, cx, b0] += m * (1.0 - f)
            out[cy, cx, b1] += m * f


@njit(cache=True, nogil=True, inline="always")
def _map(H, x, y):
    """Image point and Jacobian of ``(x, y)`` under the homography ``H``."""
    u = H[0, 0] * x + H[0, 1] * y + H[0, 2]
    v = H[1, 0] * x + H[1, 1] * y + H[1, 2]
    w = H[2, 0] * x + H[2, 1] * y + H[2, 2]
    px, py = u / w, v / w
    j00 = (H[0, 0] - px * H[2, 0]) / w
    j01 = (H[0, 1] - px * H[2, 1]) / w
    j10 = (H[1, 0] - py * H[2, 0]) / w
    j11 = (H[1, 1] - py * H[2, 1]) / w
    return px, py, j00, j01, j10, j11


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _angle_taps(j00, j01, j10, j11, rule, lo, hi, frac):  # pragma: no cover - compiled
    """``A`` of the Jacobian ``[[j00, j01], [j10, j11]]`` as two taps per frame bin ``k``:
    source bins ``lo[k]`` (weight ``1 - frac[k]``) and ``hi[k]`` (``frac[k]``); ``rule`` 0
    covariant (``J^T``), 1 none, 2 the paper's eq. (3) read literally (``J^-1``)."""
    n_bins = len(lo)
    for k in range(n_bins):
        if rule == 1:
            lo[k], hi[k], frac[k] = k, k, 0.0
            continue
        phi = (k + 0.5) * math.pi / n_bins
        if rule == 0:
            gx = j00 * math.cos(phi) + j10 * math.sin(phi)
            gy = j01 * math.cos(phi) + j11 * math.sin(phi)
        else:
            det = j00 * j11 - j01 * j10
            gx = (j11 * math.cos(phi) - j01 * math.sin(phi)) / det
            gy = (-j10 * math.cos(phi) + j00 * math.sin(phi)) / det
        theta = math.atan2(gy, gx) % math.pi
        tt = theta * n_bins / math.pi - 0.5
        if tt < 0:
            tt += n_bins
        b0 = int(tt)
        f = tt - b0
        if b0 >= n_bins:
            b0 -= n_bins
        lo[k] = b0
        hi[k] = b0 + 1 if b0 < n_bins - 1 else 0
        frac[k] = f


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def _block_score(block, weights, at, eps, clip):  # pragma: no cover - compiled
    """``weights[at:at + 36] . L2Hys(block)`` (OpenCV's ``normalizeBlockHistogram``);
    ``block`` is overwritten."""
    ss = 0.0
    for k in range(len(block)):
        ss += block[k] * block[k]
    sc = 1.0 / (math.sqrt(ss) + eps)
    ss = 0.0
    for k in range(len(block)):
        v = min(block[k] * sc, clip)
        block[k] = v
        ss += v * v
    sc = 1.0 / (math.sqrt(ss) + 1e-3)
    total = 0.0
    for k in range(len(block)):
        total += weights[at + k] * block[k] * sc
    return total


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def renorm_scores(flat, offsets, dims, size_of, cells, H, weights, bias, eps, clip,
                  rule, out):  # pragma: no cover - compiled
    """Scores of windows ``n`` (their homographies ``H[n]``, canonical 64x128 -> frame px)
    from the raw cell map of size ``cells[size_of[n]]``: ``flat[offsets[s]:]`` laid out
    ``(dims[s, 0], dims[s, 1], 9)``. ``weights`` (3780,) OpenCV's descriptor layout;
    ``rule`` 0 = covariant (``J^T``), 1 = none (orientations kept), 2 = the paper's eq. (3)
    read literally (``J^-1``; :func:`viewadapt.remap.map_angles`)."""
    n_bins = 9
    src = np.empty((16, 8, n_bins), np.float32)
    lo = np.empty(n_bins, np.int64)              # frame bin k -> source bins lo, hi
    hi = np.empty(n_bins, np.int64)
    frac = np.empty(n_bins, np.float32)
    h = np.empty(n_bins, np.float32)
    block = np.empty(4 * n_bins, np.float32)
    for n in range(len(out)):
        s = size_of[n]
        c = cells[s]
        ny, nx = dims[s, 0], dims[s, 1]
        base = offsets[s]
        Hn = H[n]
        # A from the Jacobian at the window's centre
        _, _, j00, j01, j10, j11 = _map(Hn, 31.5, 63.5)
        _angle_taps(j00, j01, j10, j11, rule, lo, hi, frac)
        for j in range(16):
            for i in range(8):
                px, py, a00, a01, a10, a11 = _map(Hn, 8.0 * i + 3.5, 8.0 * j + 3.5)
                ex = 4.0 * abs(a00)
                ey = 4.0 * abs(a11)
                x0, x1, y0, y1 = px - ex, px + ex, py - ey, py + ey
                h[:] = 0
                u0 = int(math.floor((x0 + 0.5) / c))
                u1 = int(math.floor((x1 + 0.5) / c))
                v0 = int(math.floor((y0 + 0.5) / c))
                v1 = int(math.floor((y1 + 0.5) / c))
                for v in range(max(v0, 0), min(v1, ny - 1) + 1):
                    wy = min(y1, c * (v + 1) - 0.5) - max(y0, c * v - 0.5)
                    if wy <= 0:
                        continue
                    for u in range(max(u0, 0), min(u1, nx - 1) + 1):
                        wx = min(x1, c * (u + 1) - 0.5) - max(x0, c * u - 0.5)
                        if wx <= 0:
                            continue
                        wgt = wx * wy
                        at = base + (v * nx + u) * n_bins
                        for k in range(n_bins):
                            h[k] += wgt * flat[at + k]
                # per source pixel of the cell: the rectangle's area against the cell's 64
                scale = 64.0 / (c * c * max(4.0 * ex * ey, 1e-12))
                src[j, i, :] = 0
                for k in range(n_bins):
                    src[j, i, lo[k]] += (1.0 - frac[k]) * h[k] * scale
                    src[j, i, hi[k]] += frac[k] * h[k] * scale
        total = bias
        for bx in range(7):
            for by in range(15):
                for cx in range(2):
                    for cy in range(2):
                        q = 2 * cx + cy
                        for b in range(n_bins):
                            block[q * n_bins + b] = src[by + cy, bx + cx, b]
                total += _block_score(block, weights, (bx * 15 + by) * 4 * n_bins, eps, clip)
        out[n] = total


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _axis_taps(centre, jac, c, n, ax, role, first, w):  # pragma: no cover - compiled
    """Weights ``w[k]`` of frame cells ``first .. first + len(w) - 1`` along one axis for
    one cell role of a 2c-px block: each of the block's 16 source pixels (``ax[i, role]``
    its OpenCV window weight) spread over the frame cells its image ``centre + jac (i -
    7.5)`` (length ``|jac|``) overlaps, per frame pixel of it."""
    w[:] = 0
    half = 0.5 * abs(jac)
    for i in range(16):
        xf = centre + jac * (i - 7.5)
        a, b = xf - half, xf + half
        u0 = int(math.floor((a + 0.5) / c))
        u1 = int(math.floor((b + 0.5) / c))
        for u in range(max(u0, 0), min(u1, n - 1) + 1):
            ov = min(b, c * (u + 1) - 0.5) - max(a, c * u - 0.5)
            k = u - first
            if ov > 0 and 0 <= k < len(w):
                w[k] += ax[i, role] * ov / max(2.0 * half, 1e-12)


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def renorm_scores_binned(flat, offsets, dims, size_of, cells, H, weights, bias, eps, clip,
                         rule, ax, out):  # pragma: no cover - compiled
    """:func:`renorm_scores` with OpenCV's own spatial binning: each block's four cell
    histograms are the frame cells under the block's image weighted by OpenCV's Gaussian
    block window times each cell's bilinear tent (``ax``: (16, 2), the weights along one
    axis of a 16-px block), carried through the block's affine approximation (its centre
    and Jacobian under ``H[n]``)."""
    n_bins = 9
    lo = np.empty(n_bins, np.int64)              # frame bin k -> source bins lo, hi
    hi = np.empty(n_bins, np.int64)
    frac = np.empty(n_bins, np.float32)
    block = np.empty(4 * n_bins, np.float32)
    raw = np.empty((2, 2, n_bins), np.float32)
    wx = np.empty((2, 24), np.float32)
    wy = np.empty((2, 24), np.float32)
    for n in range(len(out)):
        s = size_of[n]
        c = cells[s]
        ny, nx = dims[s, 0], dims[s, 1]
        base = offsets[s]
        Hn = H[n]
        _, _, j00, j01, j10, j11 = _map(Hn, 31.5, 63.5)
        _angle_taps(j00, j01, j10, j11, rule, lo, hi, frac)
        total = bias
        for bx in range(7):
            for by in range(15):
                # the block's centre (source pixel 8 bx + 7.5, 8 by + 7.5) and Jacobian
                px, py, a00, a01, a10, a11 = _map(Hn, 8.0 * bx + 7.5, 8.0 * by + 7.5)
                ex = 8.0 * abs(a00) + 1.0
                ey = 8.0 * abs(a11) + 1.0
                u0 = max(int(math.floor((px - ex + 0.5) / c)), 0)
                v0 = max(int(math.floor((py - ey + 0.5) / c)), 0)
                nu = min(int(math.floor((px + ex + 0.5) / c)), nx - 1) - u0 + 1
                nv = min(int(math.floor((py + ey + 0.5) / c)), ny - 1) - v0 + 1
                raw[:] = 0
                if nu > 0 and nv > 0:
                    nu = min(nu, 24)
                    nv = min(nv, 24)
                    for r in range(2):
                        _axis_taps(px, a00, c, nx, ax, r, u0, wx[r, :nu])
                        _axis_taps(py, a11, c, ny, ax, r, v0, wy[r, :nv])
                    for v in range(nv):
                        for u in range(nu):
                            at = base + ((v0 + v) * nx + (u0 + u)) * n_bins
                            for cx in range(2):
                                for cy in range(2):
                                    wgt = wx[cx, u] * wy[cy, v]
                                    if wgt == 0:
                                        continue
                                    for k in range(n_bins):
                                        raw[cx, cy, k] += wgt * flat[at + k]
                inv = 1.0 / (c * c)
                block[:] = 0
                for cx in range(2):
                    for cy in range(2):
                        at = (2 * cx + cy) * n_bins
                        for k in range(n_bins):
                            v2 = raw[cx, cy, k] * inv
                            block[at + lo[k]] += (1.0 - frac[k]) * v2
                            block[at + hi[k]] += frac[k] * v2
                total += _block_score(block, weights, (bx * 15 + by) * 4 * n_bins, eps, clip)
        out[n] = total
