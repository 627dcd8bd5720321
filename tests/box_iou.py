"""A plain reference IoU for the tests (independent of viewadapt's matching code)."""

import numpy as np


def iou(a, b):
    """(A, B) IoU of (A, 4) and (B, 4) boxes x, y, w, h."""
    a, b = np.asarray(a, float)[:, None], np.asarray(b, float)[None]
    iw = np.minimum(a[..., 0] + a[..., 2], b[..., 0] + b[..., 2]) - np.maximum(a[..., 0],
                                                                               b[..., 0])
    ih = np.minimum(a[..., 1] + a[..., 3], b[..., 1] + b[..., 3]) - np.maximum(a[..., 1],
                                                                               b[..., 1])
    inter = np.clip(iw, 0, None) * np.clip(ih, 0, None)
    return inter / (a[..., 2] * a[..., 3] + b[..., 2] * b[..., 3] - inter)
