import math


import numpy as np
import pytest
import scipy.sparse as sp
from sklearn.base import clone
from sklearn.exceptions import NotFittedError
from sklearn.utils.estimator_checks import parametrize_with_checks

from tests.tolerances import EXACT
from viewadapt.boosting import AdaBoostTrees


def _reference_scores(clf, X, n_trees=None, threshold="model"):
    """Plain loop over samples and trees: walk each tree, add, stop at the cascade."""
    thr = clf.cascade_threshold if threshold == "model" else threshold
    n_trees = clf.n_estimators_ if n_trees is None else n_trees
    out = np.zeros(len(X))
    for i, x in enumerate(X):
        s = 0.0
        for t in range(n_trees):
            node = 0
            while clf.feature_[t, node] >= 0:
                f = clf.feature_[t, node]
                node = 2 * node + (2 if x[f] >= clf.threshold_[t, node] else 1)
            s = s + clf.value_[t, node]
            if thr is not None and s <= thr:
                break
        out[i] = s
    return out


def _reference_running_scores(clf, X):
    """``(n_samples, n_estimators_)`` running sums without any cascade, plain loop."""
    out = np.zeros((len(X), clf.n_estimators_))
    for i, x in enumerate(X):
        s = 0.0
        for t in range(clf.n_estimators_):
            node = 0
            while clf.feature_[t, node] >= 0:
                f = clf.feature_[t, node]
                node = 2 * node + (2 if x[f] >= clf.threshold_[t, node] else 1)
            s = s + clf.value_[t, node]
            out[i, t] = s
    return out


def _blobs(n, rng, sep=2.0, d=6):
    y = rng.integers(0, 2, n)
    X = rng.normal(size=(n, d))
    X[:, 0] += sep * (2 * y - 1)
    return X, y


def _xor(n, rng, d=5):
    X = rng.normal(size=(n, d))
    y = ((X[:, 1] > 0) ^ (X[:, 3] > 0)).astype(int)
    return X, y


# ------------------------------------------------------------------ sklearn contract
@parametrize_with_checks([AdaBoostTrees(n_estimators=8, stages=(8,))])
def test_sklearn_contract(estimator, check):
    check(estimator)


# ------------------------------------------------------------------ golden values
# X = 0..6, y = [0 0 0 1 0 1 1]: 4 negatives (weight 1/8 each), 3 positives (1/6 each).
# Half Gini impurity w0 w1 / (w0 + w1) summed over both sides, split after k samples:
# k=1 .214, k=2 .167, k=3 .100, k=4 .206, k=5 .125, k=6 .200 -> threshold 2.5 (midway).
GOLDEN_X = np.arange(7, dtype=float)[:, None]
GOLDEN_Y = np.array([0, 0, 0, 1, 0, 1, 1])


def test_single_stump_golden_real():
    clf = AdaBoostTrees(n_estimators=1, max_depth=1, stages=None).fit(GOLDEN_X, GOLDEN_Y)
    np.testing.assert_array_equal(clf.feature_, [[0, -1, -1]])
    assert clf.threshold_[0, 0] == 2.5
    # left {0,1,2}: no positives -> .5 log(0) clipped to -4; right: W- = 1/8, W+ = 1/2
    np.testing.assert_allclose(clf.value_[0], [0.0, -4.0, math.log(2.0)], **EXACT)
    # exponential loss after the tree: 3 e^-4 / 8 + e^{log 2} / 8 + 3 e^{-log 2} / 6
    assert clf.train_loss_[0] == pytest.approx(3 * math.exp(-4) / 8 + 0.25 + 0.25, rel=1e-12)
    np.testing.assert_allclose(clf.decision_function([[1.0], [2.5], [9.0]]),
                               [-4.0, math.log(2.0), math.log(2.0)], **EXACT)
    np.testing.assert_array_equal(clf.predict([[1.0], [3.0]]), [0, 1])


def test_single_stump_golden_discrete():
    clf = AdaBoostTrees(n_estimators=1, max_depth=1, stages=None, algorithm="discrete")
    clf.fit(GOLDEN_X, GOLDEN_Y)
    # the stump misclassifies x = 4 (weight 1/8): alpha = .5 log((1 - 1/8) / (1/8))
    alpha = 0.5 * math.log(7.0)
    np.testing.assert_allclose(clf.value_[0, 1:], [-alpha, alpha], **EXACT)


# ------------------------------------------------------------------ learning
def test_learns_separable_problem():
    rng = np.random.default_rng(0)
    X, y = _blobs(400, rng, sep=3.0)
    Xt, yt = _blobs(400, rng, sep=3.0)
    clf = AdaBoostTrees(n_estimators=32, stages=(8, 32)).fit(X, y)
    assert clf.score(Xt, yt) >= 0.99


@pytest.mark.parametrize("algorithm", ["real", "discrete"])
def test_learns_xor_with_depth_two_trees(algorithm):
    rng = np.random.default_rng(1)
    X, y = _xor(600, rng)
    Xt, yt = _xor(600, rng)
    clf = AdaBoostTrees(n_estimators=64, stages=(64,), algorithm=algorithm).fit(X, y)
    assert clf.score(Xt, yt) >= 0.95
    assert set(clf.used_features_) >= {1, 3}
    # a single stump layer cannot represent XOR
    stumps = AdaBoostTrees(n_estimators=64, max_depth=1, stages=None).fit(X, y)
    assert stumps.score(Xt, yt) < 0.75


def test_train_loss_matches_thresholded_evaluation():
    # training routes samples by quantised bins, evaluation by real thresholds: they agree
    rng = np.random.default_rng(2)
    X, y = _xor(300, rng)
    clf = AdaBoostTrees(n_estimators=16, stages=None, cascade_threshold=None,
                        max_bins=16).fit(X, y)
    H = clf.decision_function(X)
    ys = np.where(y == 1, 1.0, -1.0)
    n_c = np.where(y == 1, y.sum(), (1 - y).sum())
    assert clf.train_loss_[-1] == pytest.approx(np.sum(np.exp(-ys * H) / (2 * n_c)), rel=1e-10)
    assert np.all(np.diff(clf.train_loss_) < 0)


def test_string_labels_and_positive_class():
    rng = np.random.default_rng(3)
    X, y = _blobs(200, rng, sep=3.0)
    labels = np.array(["background", "person"])[y]
    clf = AdaBoostTrees(n_estimators=8, stages=None).fit(X, labels)
    np.testing.assert_array_equal(clf.classes_, ["background", "person"])
    scores = clf.decision_function(X)
    assert scores[y == 1].mean() > 0 > scores[y == 0].mean()


# ------------------------------------------------------------------ evaluation
def test_vectorised_evaluation_matches_plain_loop():
    rng = np.random.default_rng(4)
    X, y = _xor(300, rng)
    clf = AdaBoostTrees(n_estimators=100, stages=(10, 100), max_depth=3).fit(X, y)
    Xt, _ = _xor(150, rng)
    np.testing.assert_array_equal(clf.decision_function(Xt), _reference_scores(clf, Xt))
    clf.set_params(cascade_threshold=None)
    np.testing.assert_array_equal(clf.decision_function(Xt), _reference_scores(clf, Xt))


def test_soft_cascade_keeps_scores_of_survivors():
    rng = np.random.default_rng(5)
    X, y = _blobs(300, rng, sep=1.0)
    cascaded = AdaBoostTrees(n_estimators=40, stages=None, cascade_threshold=-1.0).fit(X, y)
    full = clone(cascaded).set_params(cascade_threshold=None).fit(X, y)
    np.testing.assert_array_equal(cascaded.value_, full.value_)
    Xt, _ = _blobs(300, rng, sep=1.0)
    s_casc, s_full = cascaded.decision_function(Xt), full.decision_function(Xt)
    # running scores without the cascade, tree by tree
    running = _reference_running_scores(full, Xt)
    np.testing.assert_array_equal(running[:, -1], s_full)
    survived = (running > -1.0).all(axis=1)
    assert 0 < survived.sum() < len(Xt)
    np.testing.assert_array_equal(s_casc[survived], s_full[survived])
    # stopped samples keep the running score of the first tree that took them to <= -1
    stopped = ~survived
    first = np.argmax(running <= -1.0, axis=1)
    np.testing.assert_array_equal(s_casc[stopped], running[stopped, first[stopped]])
    assert np.all(s_casc[stopped] <= -1.0)


def test_staged_decision_function():
    rng = np.random.default_rng(6)
    X, y = _xor(300, rng)
    clf = AdaBoostTrees(n_estimators=48, stages=(4, 16, 48)).fit(X, y)
    staged = list(clf.staged_decision_function(X))
    assert len(staged) == 3
    for k, s in zip((4, 16, 48), staged):
        np.testing.assert_array_equal(s, _reference_scores(clf, X, n_trees=k))
    np.testing.assert_array_equal(staged[-1], clf.decision_function(X))
    # stages beyond the trees actually trained are dropped; the last is n_estimators_
    short = AdaBoostTrees(n_estimators=12, stages=(5,)).fit(X, y)
    assert len(list(short.staged_decision_function(X))) == 2


def test_used_features_are_the_informative_ones():
    rng = np.random.default_rng(7)
    X = np.zeros((400, 10))
    X[:, 3] = rng.normal(size=400)
    X[:, 7] = rng.normal(size=400)
    y = ((X[:, 3] > 0) & (X[:, 7] > 0)).astype(int)
    clf = AdaBoostTrees(n_estimators=16, stages=None).fit(X, y)
    np.testing.assert_array_equal(clf.used_features_, [3, 7])
    np.testing.assert_array_equal(clf.used_features_,
                                  np.unique(clf.feature_[clf.feature_ >= 0]))


# ------------------------------------------------------------------ remapping
def _remapping_problem(seed=8, n_source=12, n_target=15):
    rng = np.random.default_rng(seed)
    X, y = _xor(300, rng, d=n_source)
    X[:, 8:] = 0.0                       # constant features: never split on, never used
    clf = AdaBoostTrees(n_estimators=32, stages=None).fit(X, y)
    G = sp.random(n_source, n_target, density=0.3, format="csr", random_state=seed) * 2.0
    Xt = rng.normal(size=(200, n_target))
    return clf, G, Xt


@pytest.mark.parametrize("fmt", ["csr", "csc", "coo", "csr_array"])
def test_remapped_evaluation_equals_remapping_then_evaluating(fmt):
    clf, G, Xt = _remapping_problem()
    expected = clf.decision_function((G @ Xt.T).T)
    Gf = sp.csr_array(G) if fmt == "csr_array" else G.asformat(fmt)
    np.testing.assert_array_equal(clf.decision_function_remapped(Xt, Gf), expected)


def test_remapped_evaluation_dense_and_only_used_rows_matter():
    clf, G, Xt = _remapping_problem()
    expected = clf.decision_function((G @ Xt.T).T)
    np.testing.assert_allclose(clf.decision_function_remapped(Xt, G.toarray()), expected,
                               **EXACT)
    unused = np.setdiff1d(np.arange(G.shape[0]), clf.used_features_)
    assert set(unused) >= {8, 9, 10, 11}
    Gd = G.toarray()
    Gd[unused] = 1e6
    np.testing.assert_array_equal(clf.decision_function_remapped(Xt, sp.csr_matrix(Gd)),
                                  clf.decision_function_remapped(Xt, G))


def test_identity_remapping_is_plain_evaluation():
    clf, _, _ = _remapping_problem()
    X = np.random.default_rng(9).normal(size=(50, 12))
    np.testing.assert_array_equal(clf.decision_function_remapped(X, sp.eye(12, format="csr")),
                                  clf.decision_function(X))


# ------------------------------------------------------------------ determinism
def test_random_state_determines_feature_subsets():
    rng = np.random.default_rng(10)
    X, y = _xor(200, rng, d=20)
    a = AdaBoostTrees(n_estimators=16, stages=None, max_features=0.3, random_state=0).fit(X, y)
    b = AdaBoostTrees(n_estimators=16, stages=None, max_features=0.3, random_state=0).fit(X, y)
    c = AdaBoostTrees(n_estimators=16, stages=None, max_features=0.3, random_state=1).fit(X, y)
    np.testing.assert_array_equal(a.feature_, b.feature_)
    np.testing.assert_array_equal(a.threshold_, b.threshold_)
    np.testing.assert_array_equal(a.value_, b.value_)
    assert not np.array_equal(a.feature_, c.feature_)
    # with every feature considered the seed is irrelevant
    d = AdaBoostTrees(n_estimators=8, stages=None, random_state=0).fit(X, y)
    e = AdaBoostTrees(n_estimators=8, stages=None, random_state=1).fit(X, y)
    np.testing.assert_array_equal(d.feature_, e.feature_)


# ------------------------------------------------------------------ errors
def test_rejects_multiclass_one_class_and_continuous_targets():
    X = np.random.default_rng(11).normal(size=(30, 3))
    with pytest.raises(ValueError, match="Only binary classification is supported"):
        AdaBoostTrees(n_estimators=2, stages=None).fit(X, np.arange(30) % 3)
    with pytest.raises(ValueError, match="got 1 class"):
        AdaBoostTrees(n_estimators=2, stages=None).fit(X, np.ones(30))
    with pytest.raises(ValueError, match="Unknown label type"):
        AdaBoostTrees(n_estimators=2, stages=None).fit(X, np.linspace(0, 1, 30))


@pytest.mark.parametrize("params, match", [
    (dict(n_estimators=0), "n_estimators"),
    (dict(n_estimators=8, stages=(4, 2)), "strictly increasing"),
    (dict(n_estimators=8, stages=(4, 16)), "must not exceed n_estimators"),
    (dict(n_estimators=8, stages=(0, 8)), "positive integers"),
    (dict(n_estimators=8, stages=8), "sequence"),
    (dict(n_estimators=8, stages=None, cascade_threshold=float("nan")), "cascade_threshold"),
    (dict(n_estimators=8, stages=None, algorithm="gentle"), "algorithm"),
    (dict(n_estimators=8, stages=None, max_bins=1), "max_bins"),
    (dict(n_estimators=8, stages=None, max_bins=300), "max_bins"),
    (dict(n_estimators=8, stages=None, max_features=0.0), "max_features"),
    (dict(n_estimators=8, stages=None, max_features=1.5), "max_features"),
    (dict(n_estimators=8, stages=None, max_depth=0), "max_depth"),
    (dict(n_estimators=8, stages=None, learning_rate=0.0), "learning_rate"),
    (dict(n_estimators=8, stages=None, learning_rate=1.5), "learning_rate"),
    (dict(n_estimators=8, stages=None, learning_rate=float("nan")), "learning_rate"),
    (dict(n_estimators=8, stages=None, learning_rate=True), "learning_rate"),
])
def test_rejects_bad_parameters_at_fit(params, match):
    X, y = _blobs(40, np.random.default_rng(12))
    with pytest.raises(ValueError, match=match):
        AdaBoostTrees(**params).fit(X, y)


def test_evaluation_errors():
    clf, G, Xt = _remapping_problem()
    with pytest.raises(ValueError, match="features"):
        clf.decision_function(np.zeros((3, 5)))
    with pytest.raises(ValueError, match="G must have shape"):
        clf.decision_function_remapped(Xt, G[:5])
    with pytest.raises(ValueError, match="X_target has 4 features"):
        clf.decision_function_remapped(Xt[:, :4], G)
    bad = G.toarray()
    bad[0, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        clf.decision_function_remapped(Xt, bad)
    unfitted = AdaBoostTrees()
    with pytest.raises(NotFittedError):
        unfitted.used_features_
    with pytest.raises(NotFittedError):
        unfitted.decision_function(Xt)
    with pytest.raises(NotFittedError):
        unfitted.decision_function_remapped(Xt, G)


def test_training_stops_when_the_loss_vanishes():
    # separable data: every tree adds 4 to each margin, loss ~ e^{-4t} < 1e-40 by t = 24
    X, y = _blobs(100, np.random.default_rng(14), sep=10.0)
    clf = AdaBoostTrees(n_estimators=100, stages=(10, 100)).fit(X, y)
    assert clf.n_estimators_ < 100
    assert clf.train_loss_[-1] < 1e-40 <= clf.train_loss_[-2]
    assert clf.feature_.shape[0] == clf.n_estimators_
    assert len(list(clf.staged_decision_function(X))) == 2


def test_shrinkage_scales_the_first_tree_and_slows_the_reweighting():
    X, y = _blobs(200, np.random.default_rng(15), sep=1.0)
    full = AdaBoostTrees(n_estimators=20, stages=None, random_state=0).fit(X, y)
    slow = AdaBoostTrees(n_estimators=20, stages=None, random_state=0,
                         learning_rate=0.25).fit(X, y)
    # the first tree sees the same weights: the same splits, its outputs times nu
    np.testing.assert_array_equal(slow.feature_[0], full.feature_[0])
    np.testing.assert_allclose(slow.value_[0], 0.25 * full.value_[0], **EXACT)
    # after it the weights differ, and the training loss falls more slowly
    assert slow.train_loss_[0] > full.train_loss_[0]
    assert slow.train_loss_[-1] > full.train_loss_[-1]
    # shrinkage is kept in the model's parameters and survives a save
    params, arrays = slow.to_arrays()
    assert params["learning_rate"] == 0.25
    back = AdaBoostTrees.from_arrays(params, arrays)
    np.testing.assert_array_equal(back.decision_function(X), slow.decision_function(X))
