import numpy as np
import pytest

from tests.tolerances import EXACT
from viewadapt.boosting import AdaBoostTrees
from viewadapt.boosting import cascade_step
from viewadapt.ensembles import average_trees, split_average


def _data(seed=0, n=300, d=12):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n, d))
    y = (X[:, 0] + 0.5 * X[:, 3] - X[:, 7] + 0.3 * rng.normal(size=n) > 0).astype(int)
    return X, y


def _members(n=3, trees=16, **kw):
    X, y = _data()
    return [AdaBoostTrees(n_estimators=trees, stages=None, max_features=0.5, random_state=s,
                          **kw).fit(X, y) for s in range(n)], X


def test_the_average_scores_the_members_mean_without_the_cascade():
    members, X = _members(cascade_threshold=None)
    avg = average_trees(members)
    assert avg.n_estimators_ == sum(m.n_estimators_ for m in members)
    want = np.mean([m.decision_function(X) for m in members], axis=0)
    np.testing.assert_allclose(avg.decision_function(X), want, **EXACT)
    # the members differ (their seeds pick other features), so the mean is not any one
    assert not np.allclose(members[0].decision_function(X), want)


def test_the_trees_are_interleaved_member_by_member():
    members, _ = _members(n=2, trees=5)
    avg = average_trees(members)
    for t in range(5):
        for i, m in enumerate(members):
            np.testing.assert_array_equal(avg.feature_[2 * t + i], m.feature_[t])
            np.testing.assert_array_equal(avg.value_[2 * t + i], m.value_[t] / 2)


def _leaf(m, t, x):
    node = 0
    while m.feature_[t, node] >= 0:
        node = 2 * node + (2 if x[m.feature_[t, node]] >= m.threshold_[t, node] else 1)
    return m.value_[t, node]


def _round_by_round(members, x, k, s=0.0, trees=16):
    """Plain loop: ``members``' trees round by round, member by member, each output over
    ``k``, from running score ``s``, stopping at -1: ``(score, stopped)``."""
    for t in range(trees):
        for m in members:
            s += _leaf(m, t, x) / k
            if s <= -1.0:
                return s, True
    return s, False


def test_the_cascade_stops_on_the_running_mean_of_the_members():
    members, X = _members(cascade_threshold=-1.0)
    avg, k = average_trees(members), len(members)
    runs = [_round_by_round(members, x, k) for x in X]
    want, stops = np.array([s for s, _ in runs]), sum(stop for _, stop in runs)
    assert 0 < stops < len(X)
    np.testing.assert_allclose(avg.decision_function(X), want, **EXACT)


def test_members_of_different_lengths_are_averaged():
    X, y = _data()
    a = AdaBoostTrees(n_estimators=4, stages=None, random_state=0, cascade_threshold=None)
    b = AdaBoostTrees(n_estimators=7, stages=None, random_state=1, cascade_threshold=None)
    a.fit(X, y), b.fit(X, y)
    avg = average_trees([a, b])
    assert avg.n_estimators_ == 11
    np.testing.assert_allclose(avg.decision_function(X),
                               (a.decision_function(X) + b.decision_function(X)) / 2, **EXACT)


def test_one_model_is_its_own_average_and_survives_storage():
    (m,), X = _members(n=1)
    avg = average_trees([m])
    assert avg is not m
    np.testing.assert_array_equal(avg.decision_function(X), m.decision_function(X))
    again = AdaBoostTrees.from_arrays(*avg.to_arrays())
    np.testing.assert_array_equal(again.decision_function(X), avg.decision_function(X))


@pytest.mark.parametrize("change, match", [
    ("features", "n_features_in_"), ("depth", "max_depth"), ("cascade", "cascade_threshold"),
    ("unfitted", "not a fitted"), ("none", "at least one")])
def test_members_that_do_not_match_are_refused(change, match):
    members, X = _members(n=2, trees=4)
    _, y = _data()
    if change == "features":
        members[1] = AdaBoostTrees(n_estimators=4, stages=None).fit(X[:, :5], y)
    elif change == "depth":
        members[1] = AdaBoostTrees(n_estimators=4, stages=None, max_depth=1).fit(X, y)
    elif change == "cascade":
        members[1] = AdaBoostTrees(n_estimators=4, stages=None, cascade_threshold=-2.0).fit(X, y)
    elif change == "unfitted":
        members[1] = AdaBoostTrees()
    else:
        members = []
    with pytest.raises(ValueError, match=match):
        average_trees(members)


def test_the_gated_average_stops_where_its_first_member_does_then_on_the_running_mean():
    members, X = _members(cascade_threshold=-1.0)
    avg, k = average_trees(members, gate=True), len(members)
    want, gated, stops = np.zeros(len(X)), 0, 0
    for j, x in enumerate(X):      # plain loop: member 0 alone, then the others round by round
        s = 0.0
        for t in range(16):
            s += _leaf(members[0], t, x) / k
            if s * k <= -1.0:
                s *= k
                gated += 1
                break
        else:
            s, stopped = _round_by_round(members[1:], x, k, s)
            stops += stopped
        want[j] = s
    assert 0 < gated < len(X) and stops > 0
    got = avg.decision_function(X)
    np.testing.assert_allclose(got, want, **EXACT)
    # a window member 0 stops keeps member 0's own cascade score
    own = members[0].decision_function(X)
    np.testing.assert_allclose(got[own <= -1.0], own[own <= -1.0], rtol=0, atol=1e-12)
    # without the cascade the gated and the plain average are the same mean
    for m in members:
        m.cascade_threshold = None
    plain, gate = average_trees(members), average_trees(members, gate=True)
    np.testing.assert_allclose(gate.decision_function(X), plain.decision_function(X),
                               rtol=0, atol=1e-12)
    np.testing.assert_array_equal(gate.cascade_scale_[:16], k)
    np.testing.assert_array_equal(gate.cascade_scale_[16:], 1.0)


def test_a_gated_average_survives_storage_and_blocked_evaluation():
    members, X = _members(cascade_threshold=-1.0)
    avg = average_trees(members, gate=True)
    again = AdaBoostTrees.from_arrays(*avg.to_arrays())
    np.testing.assert_array_equal(again.cascade_scale_, avg.cascade_scale_)
    np.testing.assert_array_equal(again.decision_function(X), avg.decision_function(X))
    # cascade_step over blocks of trees, as the pyramids' reference evaluates them
    h = np.stack([[_leaf(avg, t, x) for t in range(avg.n_estimators_)] for x in X])
    score, alive = np.zeros(len(X)), np.arange(len(X))
    for t0 in range(0, avg.n_estimators_, 5):
        sl = slice(t0, t0 + 5)
        s, stopped = cascade_step(score[alive], h[alive, sl], -1.0, avg.cascade_scale_[sl])
        score[alive] = s
        alive = alive[~stopped]
    np.testing.assert_allclose(score, avg.decision_function(X), **EXACT)
    # a plain model stores no scales, and bad ones are refused
    assert "cascade_scale_" not in members[0].to_arrays()[1]
    params, arrays = avg.to_arrays()
    for bad in (arrays["cascade_scale_"][:-1], -arrays["cascade_scale_"]):
        with pytest.raises(ValueError, match="cascade_scale_"):
            AdaBoostTrees.from_arrays(params, dict(arrays, cascade_scale_=bad))


def test_a_plain_average_splits_back_into_its_members():
    members, X = _members(n=3, trees=8)
    parts = split_average(average_trees(members), 3)
    for m, p in zip(members, parts):
        np.testing.assert_allclose(p.decision_function(X), m.decision_function(X),
                                   rtol=0, atol=1e-12)
    for m, p in zip(members, split_average(average_trees(members, gate=True), 3)):
        np.testing.assert_allclose(p.decision_function(X), m.decision_function(X),
                                   rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="not an average of 5"):
        split_average(average_trees(members), 5)
    with pytest.raises(ValueError, match="not an average of 4"):
        split_average(average_trees(members, gate=True), 4)
    broken = average_trees(members, gate=True)
    broken.cascade_scale_ = np.full(broken.n_estimators_, 3.0)      # no tree after the gate
    with pytest.raises(ValueError, match="not an average of 3"):
        split_average(broken, 3)
    with pytest.raises(ValueError, match="training loss rises"):   # 24 trees read as 2 x 12
        split_average(average_trees(members), 2)
    with pytest.raises(ValueError, match="scaled cascade"):
        average_trees([average_trees(members, gate=True), members[0]])


@pytest.mark.parametrize("gate", [False, True])
def test_an_average_of_members_of_different_lengths_splits_back_given_their_lengths(gate):
    X, y = _data()
    members = [AdaBoostTrees(n_estimators=n, stages=None, max_features=0.5, random_state=s,
                             cascade_threshold=None).fit(X, y)
               for s, n in enumerate((5, 9, 3))]
    avg = average_trees(members, gate=gate)
    parts = split_average(avg, [5, 9, 3])
    assert [p.n_estimators_ for p in parts] == [5, 9, 3]
    for m, p in zip(members, parts):
        np.testing.assert_allclose(p.decision_function(X), m.decision_function(X),
                                   rtol=0, atol=1e-12)
    # 17 trees in 3 members: read as equally long they do not divide; lengths that do not
    # add up, or a member without trees, are refused
    with pytest.raises(ValueError, match="not an average of 3 equally long"):
        split_average(avg, 3)
    with pytest.raises(ValueError, match=r"models of \[5, 9, 4\] trees"):
        split_average(avg, [5, 9, 4])
    with pytest.raises(ValueError, match="tree count"):
        split_average(avg, [5, 0, 12])
