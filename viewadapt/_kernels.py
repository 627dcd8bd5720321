"""Compiled inner loops (numba), imported only when a run-time operator first needs them.

Kept apart so that ``import viewadapt`` stays light: numba and its JIT load on the first
frame scored, and the compiled code is cached on disk (``cache=True``: next to this file,
or numba's user-wide cache directory where that is read-only).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, fastmath=True, nogil=True, boundscheck=False)
def template_run_scores(x, templates, t_offset, t_rows, t_run, x_stride, starts, group,
                        out):  # pragma: no cover - compiled; tested through its callers
    """``out[r] = sum_dy templates[t_offset[g] + dy t_run[g] : + t_run[g]] .
    x[starts[r] + dy x_stride[g] : + t_run[g]]`` over ``dy < t_rows[g]``, ``g = group[r]``.

    One adapted template per group, stored row-major ``(n_y, n_x, C)``: each of its ``n_y``
    rows is one contiguous run of ``n_x C`` values, and so is the patch row it meets in a
    padded ``(N_y, N_x, C)`` cell map (``x_stride = N_x C`` apart). Each run is a float32
    dot product (vectorised); runs add up in float64.
    """
    for r in range(starts.shape[0]):
        g = group[r]
        t0 = t_offset[g]
        n = t_run[g]
        stride = x_stride[g]
        s0 = starts[r]
        total = 0.0
        for dy in range(t_rows[g]):
            tv = templates[t0 + dy * n:t0 + dy * n + n]
            xv = x[s0 + dy * stride:s0 + dy * stride + n]
            acc = np.float32(0.0)
            for k in range(n):
                acc += tv[k] * xv[k]
            total += acc
        out[r] = total
    return out


@njit(cache=True, nogil=True, boundscheck=False)
def strongest_gradient(dx, dy, gx, gy):  # pragma: no cover - compiled
    """Per pixel of (M, N, K) derivatives, the ``(dx, dy)`` of the channel of largest
    ``dx**2 + dy**2`` (ties keep the earlier channel), written into (M, N) ``gx, gy``."""
    M, N, K = dx.shape
    for i in range(M):
        for j in range(N):
            bx = dx[i, j, 0]
            by = dy[i, j, 0]
            best = bx * bx + by * by
            for k in range(1, K):
                x = dx[i, j, k]
                y = dy[i, j, k]
                m = x * x + y * y
                if m > best:
                    best = m
                    bx = x
                    by = y
            gx[i, j] = bx
            gy[i, j] = by


@njit(cache=True, nogil=True, boundscheck=False)
def orientation_cell_sums(mag, ang, n_bins, c, out):  # pragma: no cover - compiled
    """Oriented-magnitude sums over ``c x c`` cells, added into ``out`` (ny, nx, n_bins).

    Pixel ``(i, j)`` with ``i < ny c, j < nx c`` adds its magnitude to the two unsigned bins
    nearest its angle (centres ``(b + 1/2) pi / n_bins``), split linearly -- the
    channels of ``viewadapt.fullframe.fast_orientation_channels`` summed per cell.
    """
    ny, nx = out.shape[0], out.shape[1]
    scale = np.float32(n_bins / np.pi)
    nb = np.float32(n_bins)
    for i in range(ny * c):
        ci = i // c
        for j in range(nx * c):
            t = ang[i, j] * scale - np.float32(0.5)
            while t < 0:
                t += nb
            while t >= nb:
                t -= nb
            b0 = int(t)
            f = t - np.float32(b0)
            b1 = b0 + 1
            if b1 == n_bins:
                b1 = 0
            m = mag[i, j]
            cj = j // c
            out[ci, cj, b0] += (np.float32(1.0) - f) * m
            out[ci, cj, b1] += f * m


@njit(cache=True, nogil=True, boundscheck=False)
def _reflect(i, n, edge):
    if i < 0:
        return 0 if edge else 1
    if i >= n:
        return n - 1 if edge else n - 2
    return i


@njit(cache=True, nogil=True, boundscheck=False)
def block_normalize(X, eps, clip, out):  # pragma: no cover - compiled
    """The body of ``viewadapt.fullframe.block_normalize_cells`` (see there): ``X`` (ny, nx,
    B) cell histograms -> ``out`` (ny, nx, B + 4)."""
    ny, nx, nb = X.shape
    E = np.empty((ny, nx), np.float32)
    for i in range(ny):
        for j in range(nx):
            s = np.float32(0.0)
            for b in range(nb):
                s += X[i, j, b] * X[i, j, b]
            E[i, j] = s
    edge = min(ny, nx) == 1
    # inv[i, j]: 1 / norm of the block of cells rows {i - 1, i}, columns {j - 1, j}
    inv = np.empty((ny + 1, nx + 1), np.float32)
    e2 = np.float32(eps) * np.float32(eps)
    for i in range(ny + 1):
        i0 = _reflect(i - 1, ny, edge)
        i1 = _reflect(i, ny, edge)
        for j in range(nx + 1):
            j0 = _reflect(j - 1, nx, edge)
            j1 = _reflect(j, nx, edge)
            s = E[i0, j0] + E[i1, j0] + E[i0, j1] + E[i1, j1]
            inv[i, j] = np.float32(1.0) / np.sqrt(s + e2)
    cl = np.float32(clip)
    for i in range(ny):
        for j in range(nx):
            for b in range(nb):
                out[i, j, b] = 0.0
            for k in range(4):
                v = inv[i + k // 2, j + k % 2]
                tex = np.float32(0.0)
                for b in range(nb):
                    f = min(X[i, j, b] * v, cl)
                    out[i, j, b] += f
                    tex += f
                out[i, j, nb + k] = tex
