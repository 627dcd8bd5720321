"""Alternative scoring forms of the adapted operators, for timing and as test references.

The operators of :mod:`viewadapt.detect` score with one compiled loop each. These are the
same operators written other ways; ``bench runtime`` times them against the compiled loops
(:func:`scoring_forms_ms`) and the tests check that all agree:

* linear -- ``"sparse"``: one CSR matrix (a row per distinct scored position) times the
  concatenated cell maps; ``"template"``: one ``cv2.matchTemplate`` cross-correlation per
  shared template over its windows' region; ``"gather"``: each window's patch gathered and
  dotted with its template.
* trees -- ``"blocks"``: the soft cascade in numpy, blocks of trees over all positions
  still alive; ``"full"``: every used feature of every window remapped first, then
  :meth:`viewadapt.boosting.AdaBoostTrees.decision_function_remapped` (the reference).
"""

from __future__ import annotations

import time
import weakref

import numpy as np
import scipy.sparse as sp

from viewadapt.boosting import cascade_step
from viewadapt.detect import (
    AdaptedLinearOperator, AdaptedTreesOperator, MultiResolutionOperator, channel_slices3,
    correlate_slices,
)

__all__ = ["LINEAR_FORMS", "TREES_FORMS", "linear_scores", "trees_scores", "scoring_forms_ms"]

LINEAR_FORMS = ("sparse", "template", "gather")
#: each linear operator's CSR form, built on first use (kept outside the operator, so it
#: is never pickled with it)
_CSR = weakref.WeakKeyDictionary()
TREES_FORMS = ("blocks", "full")


def _per_layer(op, features, score):
    if isinstance(op, MultiResolutionOperator):
        out = np.empty(op.n_windows)
        for layer, feats in zip(op.layers, features):
            out[layer.index] = score(layer.operator, feats)
        return out
    return score(op, features)


def linear_scores(op, features, form: str) -> np.ndarray:
    """(N,) scores of an :class:`AdaptedLinearOperator` (or a multi-resolution operator of
    them) in the scoring ``form`` of :data:`LINEAR_FORMS`."""
    if form not in LINEAR_FORMS:
        raise ValueError(f"form must be one of {LINEAR_FORMS}, got {form!r}")
    return _per_layer(op, features, lambda o, f: _linear(o, f, form))


def _median_ms(fn, repeat):
    ts = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t)
    return round(1e3 * float(np.median(ts)), 2)


def scoring_forms_ms(hog, acf, frame, repeat=3):
    """Milliseconds (median, rounded to 0.01) of scoring ``frame`` with the adapted
    operators' compiled loops and with other forms of the same operators.

    ``hog`` and ``acf`` are the adapted HOG and ACF operators; the slow forms
    (``"template"``, ``"gather"``) are timed twice, the others ``repeat`` times. Returns
    (HOG forms, ACF forms), each a dict from the form in words to milliseconds.
    """
    f0, a0 = hog.frame_features(frame), acf.frame_features(frame)
    hog_forms = {"runs: compiled loop over distinct positions (default)":
                 _median_ms(lambda: _per_layer(hog, f0, lambda o, f: o.fold_scores(f)),
                            repeat),
                 "sparse, one row per distinct position":
                 _median_ms(lambda: linear_scores(hog, f0, "sparse"), repeat),
                 "template: matchTemplate per shared template":
                 _median_ms(lambda: linear_scores(hog, f0, "template"), 2),
                 "gather: patch x template per window":
                 _median_ms(lambda: linear_scores(hog, f0, "gather"), 2)}
    acf_forms = {"cascade: compiled loop, the positions of a group together (default)":
                 _median_ms(lambda: acf.scores(a0), repeat),
                 "blocks: numpy, blocks of trees over the positions still alive":
                 _median_ms(lambda: trees_scores(acf, a0, "blocks"), repeat)}
    return hog_forms, acf_forms


def _linear(op: AdaptedLinearOperator, features, form):
    op.check_features(features)
    if form == "sparse":
        csr = _CSR.get(op)
        if csr is None:
            csr = _CSR[op] = op.to_sparse(unique=True)
        W, rows = csr
        return np.asarray(W @ features.vector(op.cell_sizes), dtype=np.float64)[rows] + op.bias
    out = np.empty(op.n_windows)
    for g in op.groups:
        oy, ox = op.patch_origins(g, features)
        ny, nx = g.shape
        y0, x0 = int(oy.min()), int(ox.min())
        y1, x1 = int(oy.max()) + ny, int(ox.max()) + nx
        region = (y1 - y0 - ny + 1) * (x1 - x0 - nx + 1)
        if form == "template" and len(g.members) >= 8 and region <= 6 * len(g.members):
            res = correlate_slices([p[y0:y1, x0:x1] for p in features.split3(g.cell_size)],
                                   channel_slices3(g.template))
            out[g.members] = res[oy - y0, ox - x0]
        else:                              # "gather", or few or scattered windows
            F = features.maps[g.cell_size]
            win = np.lib.stride_tricks.sliding_window_view(F, (ny, nx), axis=(0, 1))
            out[g.members] = np.einsum("kcyx,yxc->k", win[oy, ox], g.template)
    return out + op.bias


def trees_scores(op, features, form: str) -> np.ndarray:
    """(N,) scores of an :class:`AdaptedTreesOperator` (or a multi-resolution operator of
    them) in the scoring ``form`` of :data:`TREES_FORMS`."""
    if form not in TREES_FORMS:
        raise ValueError(f"form must be one of {TREES_FORMS}, got {form!r}")
    score = _trees_full if form == "full" else _trees_blocks
    return _per_layer(op, features, score)


def _trees_full(op: AdaptedTreesOperator, features):
    op.check_features(features)
    out = np.empty(op.n_windows)
    n_src = op.model.n_features_in_
    lift = sp.csr_matrix((np.ones(len(op.used)), (op.used, np.arange(len(op.used)))),
                         shape=(n_src, len(op.used)))
    for g in op.groups:
        oy, ox = op.patch_origins(g, features)
        ny, nx = g.shape
        F = features.maps[g.cell_size]
        win = np.lib.stride_tricks.sliding_window_view(F, (ny, nx), axis=(0, 1))
        X = win[oy, ox].transpose(0, 2, 3, 1).reshape(len(oy), -1)   # (k, ny nx C)
        out[g.members] = op.model.decision_function_remapped(X.astype(np.float64),
                                                             lift @ g.template)
    return out


def _trees_blocks(op: AdaptedTreesOperator, features):
    op.check_features(features)
    pos_of, pos_group, pos_origin, (n_groups, indptr, offsets, weights) = op.run_tables()
    x = features.vector(op.cell_sizes)
    n_pos = len(pos_group)
    cols, thr, val = op.tree_nodes, op.tree_thresholds, op.tree_values
    T, depth = cols.shape[0], op.tree_depth

    def remapped(f, Q):
        """``(G_q x)_f`` for pairs (feature ``f[i]``, position ``Q[i]``): each a short
        dot product over frame cells, all gathered flat in one pass."""
        key = f * n_groups + pos_group[Q]
        a = indptr[key]
        lens = indptr[key + 1] - a
        start = np.cumsum(lens) - lens
        total = int(lens.sum())
        res = np.zeros(len(key), np.float32)
        if total == 0:
            return res
        k = np.arange(total) + np.repeat(a - start, lens)
        prod = x[np.repeat(pos_origin[Q], lens) + offsets[k]] * weights[k]
        nz = lens > 0
        res[nz] = np.add.reduceat(prod, start[nz])
        return res

    out = np.zeros(n_pos)
    alive = np.arange(n_pos)
    score = np.zeros(n_pos)
    t0, size = 0, 1
    while t0 < T and alive.size:
        # blocks of 1, 1, 2, 4, ... 32 trees: while most positions are still alive the
        # cascade rejects them after a tree or two, later blocks amortise the calls
        t1 = min(T, t0 + size)
        size = min(2 * size if t0 else 1, 32)
        c = cols[t0:t1]                                   # (B, nodes)
        node = np.zeros((alive.size, t1 - t0), np.intp)
        trees = np.arange(t1 - t0)[None, :]
        for _ in range(depth):                   # features only of the nodes reached
            f = c[trees, node]
            ii, jj = np.nonzero(f >= 0)
            v = remapped(f[ii, jj], alive[ii])
            node[ii, jj] = 2 * node[ii, jj] + 1 + (v >= thr[t0 + jj, node[ii, jj]])
        s, stopped = cascade_step(score, val[t0:t1][trees, node], op.model.cascade_threshold,
                                  op.model.cascade_scale_[t0:t1])
        out[alive[stopped]] = s[stopped]
        alive, score = alive[~stopped], s[~stopped]
        t0 = t1
    out[alive] = score
    return out[pos_of]
