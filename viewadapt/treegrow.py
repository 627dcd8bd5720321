"""Depth-limited decision trees on quantised features: the weak learners of
:class:`viewadapt.boosting.AdaBoostTrees`.

Features are quantised once into per-feature quantile bins; a tree grows from the
weighted class histograms of its nodes over those bins, each split chosen by its
impurity, after ``binaryTreeTrain`` of Piotr Dollár's toolbox.

References
----------
.. [1] P. Dollár, "Piotr's Computer Vision Matlab Toolbox",
   https://github.com/pdollar/toolbox (``classify/binaryTreeTrain.m``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["bin_edges", "quantize", "node_histograms", "best_split", "gini", "grow_tree"]

# binaryTreeTrain defaults: a node is a leaf when its (normalised) weight is below
# minWeight or its positive fraction is outside [1e-3, 1 - 1e-3]
_MIN_NODE_WEIGHT = 0.01
_MIN_PRIOR = 1e-3
# leaf outputs .5 * log(p / (1 - p)) are clipped to [-4, 4] (binaryTreeTrain)
_MAX_LEAF_VALUE = 4.0


def bin_edges(X, n_bins):
    """Per-feature quantile bin edges, ``(n_features, n_bins - 1)``, +inf padded.

    Edges lie midway between order statistics, so with ``n_samples <= n_bins`` every gap
    between distinct values gets its own edge.
    """
    n, d = X.shape
    Xs = np.sort(X, axis=0)      # sorts each column
    if n <= n_bins:
        pos = np.arange(1, n)
    else:
        pos = (np.arange(1, n_bins) * n) // n_bins
    edges = np.full((n_bins - 1, d), np.inf)
    edges[:pos.size] = Xs[pos - 1] * 0.5 + Xs[pos] * 0.5
    return np.ascontiguousarray(edges.T)


def quantize(X, edges):
    """Bin indices, feature-major: ``(n_features, n_samples)`` uint8 with ``bin = number of
    edges <= x``, so ``bin >= b  <=>  x >= edges[b - 1]`` (a compiled binary search,
    :func:`viewadapt._tree_kernels.quantize_columns`)."""
    from ._tree_kernels import quantize_columns

    X = np.asarray(X, dtype=np.float64)
    edges = np.ascontiguousarray(edges, dtype=np.float64)
    if edges.shape[1] > 255:
        raise ValueError(f"at most 256 bins fit in uint8, got {edges.shape[1] + 1}")
    return quantize_columns(X, edges, np.empty(X.shape[::-1], np.uint8))


def node_histograms(XqT, members, w, masks, subset, n_bins):
    """Weighted per-class histograms ``(k, 2, n_feat, n_bins)`` float32 of ``k`` sample
    subsets (``masks``: (k, n_samples) bool, or None for all samples) over the features
    ``subset`` of the feature-major bins ``XqT``; ``members`` are the samples of each class
    in increasing order. Each entry is a float32 sum over the subset's samples of the
    class in that order (:func:`viewadapt._tree_kernels.bin_histograms`)."""
    from ._tree_kernels import bin_histograms

    k = 1 if masks is None else masks.shape[0]
    out = np.zeros((k, 2, subset.size, n_bins), dtype=np.float32)
    w32 = w.astype(np.float32)
    for c, m in enumerate(members):
        for j in range(k):
            samples = m if masks is None else m[masks[j, m]]
            bin_histograms(XqT, samples, w32, subset, out[j, c])
    return out


def best_split(hist):
    """Weighted-Gini best split of one node from its ``(2, n_feat, n_bins)`` histograms.

    Splitting at bin ``b`` sends bins ``< b`` left. Minimises
    :math:`\\sum_{side} W_- W_+ / (W_- + W_+)` (half the weighted Gini impurity).

    Returns
    -------
    feat_pos, bin : int
        Position in the feature subset and split bin in 1..n_bins (``n_bins``, everything
        left, is never better than not splitting; the caller rejects it).
    """
    _, n_feat, n_bins = hist.shape
    L0 = np.cumsum(hist[0], axis=1)        # weight left of the split after each bin
    L1 = np.cumsum(hist[1], axis=1)
    T0 = L0[:, -1:].copy()
    T1 = L1[:, -1:].copy()
    tiny = np.float32(1e-30)
    # w0 w1 / (w0 + w1) <= min(w0, w1): no blow-up when a side is (nearly) empty.
    # In place on two work arrays: these are (n_feat, n_bins), megabytes each.
    den = np.add(L0, L1)
    np.maximum(den, tiny, out=den)
    imp = np.multiply(L0, L1)
    imp /= den
    np.subtract(T0, L0, out=L0)            # right side; >= 0 (sums of non-negatives)
    np.subtract(T1, L1, out=L1)
    np.add(L0, L1, out=den)
    np.maximum(den, tiny, out=den)
    np.multiply(L0, L1, out=L0)
    L0 /= den
    imp += L0
    flat = int(np.argmin(imp))
    return flat // n_bins, flat % n_bins + 1


def gini(w0, w1):
    """Weighted Gini impurity of a node with class weights ``w0``, ``w1``."""
    return w0 * w1 / (w0 + w1) if w0 + w1 > 0 else 0.0


def grow_tree(XqT, members, subset, w, n_bins, depth):
    """One weighted tree, level by level (binaryTreeTrain with split='gini').

    Returns the leaf of every training sample, and per node (complete-tree layout) the
    global feature (-1 for leaves), the split bin and the output value.
    """
    n = XqT.shape[1]
    n_nodes = 2 ** (depth + 1) - 1
    feature = np.full(n_nodes, -1, dtype=np.int32)
    split_bin = np.zeros(n_nodes, dtype=np.int64)
    value = np.zeros(n_nodes)
    is_pos = np.zeros(n, dtype=bool)
    is_pos[members[1]] = True
    node_of = np.zeros(n, dtype=np.intp)
    hists = {0: node_histograms(XqT, members, w, None, subset, n_bins)[0]}
    for level in range(depth + 1):
        first, last = 2 ** level - 1, 2 ** (level + 1) - 1
        W0 = np.bincount(node_of, weights=np.where(is_pos, 0.0, w), minlength=n_nodes)
        W1 = np.bincount(node_of, weights=np.where(is_pos, w, 0.0), minlength=n_nodes)
        counts = np.bincount(node_of, minlength=n_nodes)
        Wn = W0 + W1
        with np.errstate(divide="ignore", invalid="ignore"):
            # binaryTreeTrain: hs = max(-4, min(4, .5 * log(prior / (1 - prior))))
            h = np.clip(0.5 * np.log(W1 / W0), -_MAX_LEAF_VALUE, _MAX_LEAF_VALUE)
            prior = W1 / Wn
        live = np.arange(first, last)
        live = live[counts[live] > 0]
        value[live] = np.nan_to_num(h[live], nan=0.0)
        if level == depth:
            break
        cand = live[(Wn[live] >= _MIN_NODE_WEIGHT) & (prior[live] >= _MIN_PRIOR)
                    & (prior[live] <= 1.0 - _MIN_PRIOR)]
        if cand.size == 0:
            break
        split_nodes = []
        for j in cand:
            fp, b = best_split(hists[j])
            f = int(subset[fp])
            in_node = node_of == j
            right = in_node & (XqT[f] >= b)
            left = in_node & ~right
            # exact float64 gain of the chosen split (histograms were float32)
            l0, l1 = w[left & ~is_pos].sum(), w[left & is_pos].sum()
            r0, r1 = w[right & ~is_pos].sum(), w[right & is_pos].sum()
            gain = gini(W0[j], W1[j]) - gini(l0, l1) - gini(r0, r1)
            if not left.any() or not right.any() or gain <= 1e-12 * Wn[j]:
                continue
            feature[j] = f
            split_bin[j] = b
            node_of[left] = 2 * j + 1
            node_of[right] = 2 * j + 2
            split_nodes.append((j, int(left.sum()) <= int(right.sum())))
        if not split_nodes or level + 1 == depth:
            continue
        # children's histograms: build the smaller child's, subtract it from the parent's
        smaller = np.array([2 * j + 1 if left_small else 2 * j + 2
                            for j, left_small in split_nodes])
        masks = node_of[None, :] == smaller[:, None]
        small_h = node_histograms(XqT, members, w, masks, subset, n_bins)
        for (j, left_small), s_node, hs in zip(split_nodes, smaller, small_h):
            other = 2 * j + 2 if left_small else 2 * j + 1
            hists[s_node] = hs
            hists[other] = np.maximum(hists[j] - hs, 0.0)
        for j, _ in split_nodes:
            del hists[j]
    return node_of, feature, split_bin, value
