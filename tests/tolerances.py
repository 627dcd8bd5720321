"""Tolerances used across the test suite, in one table (after Kornia's _DTYPE_PRECISIONS).

Each entry says why it is what it is; tests import from here instead of inventing numbers.
"""

import numpy as np

#: Pure float64 linear algebra (homography chains, G^T w vs w^T G x).
EXACT = dict(rtol=1e-10, atol=1e-10)
#: float32 pipelines (OpenCV computes in float32).
FLOAT32 = dict(rtol=1e-5, atol=1e-5)
#: Polygon areas from clipping: sums of products of float64 coordinates.
AREA = dict(rtol=1e-9, atol=1e-9)


def dtype_tol(dtype):
    return EXACT if np.dtype(dtype) == np.float64 else FLOAT32
