"""The compiled soft-cascade walk of remapped trees (:func:`viewadapt._kernels.
tree_cascade_scores`, which walks the positions of a group together) against a plain
one-position-at-a-time loop: the same scores bit for bit, on random tables with early
leaves, groups in several runs, with and without the cascade, and with cascade scales
(:attr:`viewadapt.boosting.AdaBoostTrees.cascade_scale_`)."""

from __future__ import annotations

import numpy as np
import pytest

from viewadapt._kernels import tree_cascade_scores


def one_position_at_a_time(x, pos_group, pos_origin, n_groups, indptr, offsets, weights,
                           cols, thr, val, depth, cascade_threshold, use_cascade, scale):
    out = np.empty(len(pos_group))
    for p in range(len(pos_group)):
        g, o, score = pos_group[p], pos_origin[p], 0.0
        for t in range(cols.shape[0]):
            node = 0
            for _ in range(depth):
                f = cols[t, node]
                if f < 0:
                    break
                key = f * n_groups + g
                s = np.float32(0.0)
                for k in range(indptr[key], indptr[key + 1]):
                    s = np.float32(s + x[o + offsets[k]] * weights[k])
                node = 2 * node + 1 + int(s >= thr[t, node])
            score += float(val[t, node])
            if use_cascade and score * scale[t] <= cascade_threshold:
                score *= scale[t]
                break
        out[p] = score
    return out


def random_tables(seed, depth):
    rng = np.random.default_rng(seed)
    n_used, n_groups, n_trees = 7, 4, 12
    n_nodes = 2 ** (depth + 1) - 1
    x = rng.normal(size=500).astype(np.float32)
    lens = rng.integers(0, 6, n_used * n_groups)           # some empty rows
    indptr = np.r_[0, np.cumsum(lens)].astype(np.int64)
    offsets = rng.integers(0, 40, indptr[-1]).astype(np.int32)
    weights = rng.normal(size=indptr[-1]).astype(np.float32)
    cols = rng.integers(0, n_used, (n_trees, n_nodes)).astype(np.int64)
    cols[:, 2 ** depth - 1:] = -1                          # the leaves
    cols[rng.random(n_trees) < 0.3, 1] = -1                # early leaves
    thr = rng.normal(scale=0.5, size=(n_trees, n_nodes)).astype(np.float32)
    val = rng.normal(scale=0.3, size=(n_trees, n_nodes))
    # runs of groups, one group in two runs
    pos_group = np.repeat(np.array([0, 2, 1, 2, 3], np.int32), [9, 1, 17, 5, 30])
    pos_origin = rng.integers(0, 450, len(pos_group)).astype(np.int64)
    return (x, pos_group, pos_origin, n_groups, indptr, offsets, weights, cols, thr, val,
            depth)


@pytest.mark.parametrize("scaled", [False, True])
@pytest.mark.parametrize("depth", [1, 2, 3])
@pytest.mark.parametrize("threshold", [None, -0.2, 0.1])
def test_group_walk_equals_one_position_at_a_time(depth, threshold, scaled):
    tables = random_tables(depth * 10 + 1, depth)
    scale = np.where(np.arange(12) < 4, 1.5, 1.0) if scaled else np.ones(12)  # a gate's
    cascade = (0.0 if threshold is None else threshold, threshold is not None, scale)
    got = tree_cascade_scores(*tables, *cascade, np.empty(len(tables[1])))
    ref = one_position_at_a_time(*tables, *cascade)
    np.testing.assert_array_equal(got, ref)
    if threshold is not None and threshold < 0 and not scaled:
        assert (got <= threshold).any() and (got > threshold).any()   # both kinds of stop
    if threshold is not None and scaled:                  # the scales change where they stop
        plain = tree_cascade_scores(*tables, *cascade[:2], np.ones(12), np.empty(len(got)))
        assert not np.array_equal(got, plain)


def test_no_positions():
    tables = list(random_tables(0, 2))
    tables[1], tables[2] = tables[1][:0], tables[2][:0]
    assert tree_cascade_scores(*tables, 0.0, True, np.ones(12), np.empty(0)).shape == (0,)
