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
