"""The tree learner's compiled quantisation and histograms against the numpy / scipy
forms they replaced: the same bins, and the same float32 sums bit for bit."""

import numpy as np
import pytest
import scipy.sparse as sp

from viewadapt.treegrow import bin_edges, node_histograms, quantize


def _data(seed=0, n=300, d=40):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n, d)) ** 3
    X[:, 3] = np.round(X[:, 3])          # ties and repeated values
    X[:, 5] = 1.0                        # a constant feature: +inf padded edges
    return X


@pytest.mark.parametrize("n_bins", [2, 16, 64, 256])
def test_quantize_is_searchsorted_right(n_bins):
    X = _data(n_bins)
    edges = bin_edges(X, n_bins)
    want = np.stack([np.searchsorted(edges[f], X[:, f], side="right")
                     for f in range(X.shape[1])])
    got = quantize(X, edges)
    assert got.dtype == np.uint8 and got.shape == X.shape[::-1]
    np.testing.assert_array_equal(got, want)


def _sparse_histograms(Xq, members, w, masks, subset, n_bins):
    """The previous form: a CSR one-hot indicator of (feature, bin) per class times the
    float32 weights (scipy sums each row in sample order, in float32)."""
    k = 1 if masks is None else masks.shape[0]
    out = np.empty((k, 2, subset.size, n_bins), np.float32)
    for c, m in enumerate(members):
        sub = Xq[m][:, subset].astype(np.int64)
        cols = (np.arange(subset.size) * n_bins)[None, :] + sub
        one_hot = sp.csr_array((np.ones(sub.size, np.float32), cols.ravel(),
                                np.arange(0, sub.size + 1, subset.size)),
                               shape=(len(m), subset.size * n_bins)).T.tocsr()
        wc = w[m].astype(np.float32)
        for j in range(k):
            v = wc if masks is None else wc * masks[j, m]
            out[j, c] = (one_hot @ v).reshape(subset.size, n_bins)
    return out


@pytest.mark.parametrize("with_masks", [False, True])
def test_histograms_are_the_sparse_products_exactly(with_masks):
    X = _data(1)
    n_bins = 16
    XqT = quantize(X, bin_edges(X, n_bins))
    rng = np.random.default_rng(2)
    y = rng.random(len(X)) < 0.3
    members = (np.flatnonzero(~y), np.flatnonzero(y))
    w = rng.random(len(X)) ** 4
    w /= w.sum()
    subset = np.sort(rng.choice(X.shape[1], 17, replace=False))
    masks = rng.random((3, len(X))) < 0.4 if with_masks else None
    got = node_histograms(XqT, members, w, masks, subset, n_bins)
    want = _sparse_histograms(XqT.T, members, w, masks, subset, n_bins)
    np.testing.assert_array_equal(got, want)
