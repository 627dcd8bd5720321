"""Compiled inner loops of the tree learner (numba), loaded on first use: quantisation into
bins and the weighted per-bin class histograms (:mod:`viewadapt.treegrow`)."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True, boundscheck=False)
def quantize_columns(X, edges, out):  # pragma: no cover - compiled
    """``out[f, i]`` = number of ``edges[f]`` entries ``<= X[i, f]`` (numpy's
    ``searchsorted(edges[f], X[i, f], side="right")`` for finite ``X``; ``edges[f]``
    ascending, +inf allowed) for an (n, d) ``X`` and (d, B) ``edges``; ``out`` is (d, n)
    uint8."""
    n, d = X.shape
    B = edges.shape[1]
    top = 1
    while top * 2 <= B:
        top *= 2
    for i0 in range(0, n, 32):               # 32 samples at a time: both arrays in cache
        i1 = min(i0 + 32, n)
        for f in range(d):
            e = edges[f]
            for i in range(i0, i1):
                x = X[i, f]
                pos = 0                      # count of edges <= x, by halving steps
                step = top
                while step > 0:
                    if pos + step <= B and e[pos + step - 1] <= x:
                        pos += step
                    step >>= 1
                out[f, i] = pos
    return out


@njit(cache=True, nogil=True, boundscheck=False)
def bin_histograms(XqT, samples, w, subset, out):  # pragma: no cover - compiled
    """``out[p, b] += w[i]`` for each sample ``i`` of ``samples`` (in the order given) whose
    feature ``subset[p]`` falls in bin ``b`` (``XqT`` (d, n) uint8 bins). Each entry is a
    float32 sum in sample order -- what a CSR product of the one-hot bin indicator with
    the weights adds up, so the same numbers."""
    for p in range(subset.shape[0]):
        col = XqT[subset[p]]
        row = out[p]
        for k in range(samples.shape[0]):
            i = samples[k]
            row[col[i]] += w[i]
    return out


@njit(cache=True, nogil=True, boundscheck=False)
def cascade_scores(x, origin, offset, feature, threshold, value, depth, n_trees,
                   cascade_threshold, use_cascade, cascade_scale,
                   out):  # pragma: no cover - compiled
    """Soft-cascade scores of complete-layout trees on windows read from a flat array.

    Window ``i`` reads its feature ``f`` at ``x[origin[i] + offset[f]]`` (rows of a matrix:
    ``origin = i * n_features``, ``offset = f``; a channel map: the window's corner and
    each feature's place in it) and walks trees ``0 .. n_trees - 1`` in order: at an inner
    node (``feature >= 0``) it goes right when the value is ``>= threshold``; the leaf's
    ``value`` is added to a float64 running score ``((h_1 + h_2) + h_3) + ...``; with
    ``use_cascade`` it stops at the first running score times ``cascade_scale[t]`` that is
    ``<= cascade_threshold`` and keeps that product (:func:`viewadapt.boosting.cascade_step`,
    the same sums). Writes ``out[i]``.
    """
    for i in range(origin.shape[0]):
        o = origin[i]
        score = 0.0
        for t in range(n_trees):
            node = 0
            for _ in range(depth):
                f = feature[t, node]
                if f < 0:
                    break
                node = 2 * node + 1 + (1 if x[o + offset[f]] >= threshold[t, node] else 0)
            score += value[t, node]
            if use_cascade and score * cascade_scale[t] <= cascade_threshold:
                score *= cascade_scale[t]
                break
        out[i] = score
    return out
