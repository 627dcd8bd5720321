"""A check shared by the OpenCV and HOG operators' tests: map rows an operator does not read
can hold anything."""

import numpy as np


def scramble_unread_rows(features, rows, raw_rows, seed) -> int:
    """Fill every cell row of ``features``' maps outside ``rows`` (and of its raw cells
    outside ``raw_rows``) with random values, in place; returns how many rows that was."""
    rng = np.random.default_rng(seed)
    left_out, p = 0, features.pad
    for c, F in features.maps.items():
        y0, y1 = rows[c]
        inner = F[p:F.shape[0] - p]
        left_out += y0 + len(inner) - y1
        inner[:y0] = rng.uniform(0, 1, inner[:y0].shape)
        inner[y1:] = rng.uniform(0, 1, inner[y1:].shape)
    for c, R in features.raw[0].items():
        y0, y1 = raw_rows[c]
        left_out += y0 + len(R) - y1
        R[:y0] = rng.uniform(0, 50, R[:y0].shape)
        R[y1:] = rng.uniform(0, 50, R[y1:].shape)
    return left_out
