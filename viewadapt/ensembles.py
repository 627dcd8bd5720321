"""The average of several boosted-tree models, as one :class:`~viewadapt.boosting.AdaBoostTrees`.

Boosted trees trained on the same windows with different seeds (each tree reads its own
random subset of the features) disagree most where the training data say least, and
averaging their scores removes that part of the error -- the variance of the fit, which
bagging removes by averaging models fitted to resampled data (Breiman 1996).
:func:`average_trees` stores the average as one model: the members' trees interleaved --
every member's first tree, then every member's second, ... -- with each tree's outputs
divided by the number of members. Its score is the mean of the members' scores, and its
soft cascade (Bourdev & Brandt 2005) stops a window when the mean of the members' partial
scores over the same number of trees drops to the threshold. Because it is an ordinary
:class:`~viewadapt.boosting.AdaBoostTrees`, it is adapted (Wang et al. 2017, Algorithm 2),
saved and loaded like any single model. :func:`average_source_detectors` averages whole
model files the same way (the HOG/SVMs by their weights).

References
----------
.. [1] L. Breiman, "Bagging Predictors", Machine Learning 24(2), 1996.
.. [2] L. Bourdev, J. Brandt, "Robust Object Detection via Soft Cascade", CVPR 2005.
.. [3] P. Wang, K. Morton, P. Torrione, L. Collins, "Viewpoint Adaptation for Rigid Object
   Detection", arXiv preprint, 2017.
"""

from __future__ import annotations

import numpy as np

from .boosting import AdaBoostTrees

__all__ = ["average_trees", "average_source_detectors"]

#: the fitted arrays of one tree each, interleaved member by member
_PER_TREE = ("feature_", "threshold_", "value_", "train_loss_")


def average_trees(models) -> AdaBoostTrees:
    """One :class:`~viewadapt.boosting.AdaBoostTrees` whose score is the mean of ``models``'.

    Parameters
    ----------
    models : sequence of fitted AdaBoostTrees
        Trained on the same features (the same ``n_features_in_``, classes, tree depth and
        soft-cascade threshold); they may hold different numbers of trees (training stops
        early once the loss vanishes).

    Returns
    -------
    AdaBoostTrees
        The members' trees interleaved (round ``t`` holds the ``t``-th tree of every member
        that has one), their outputs divided by ``len(models)``; the first member's
        parameters, with ``n_estimators`` the total, no training stages and no seed. Without
        the soft cascade its decision function is the members' mean to rounding. One model
        is returned as a copy of itself.

    Raises
    ------
    ValueError
        For no models, an unfitted one, or members that do not share their features,
        classes, depth or cascade threshold.
    """
    models = list(models)
    if not models:
        raise ValueError("average_trees needs at least one model")
    arrays = []
    for i, m in enumerate(models):
        if not isinstance(m, AdaBoostTrees) or not hasattr(m, "feature_"):
            raise ValueError(f"model {i} is not a fitted AdaBoostTrees")
        arrays.append(m.to_arrays())
    params, first = arrays[0]
    for i, (p, a) in enumerate(arrays[1:], start=1):
        for key in ("n_features_in_", "max_depth", "cascade_threshold"):
            if p[key] != params[key]:
                raise ValueError(f"model {i} has {key} = {p[key]!r}, model 0 {params[key]!r}")
        if not np.array_equal(a["classes_"], first["classes_"]):
            raise ValueError(f"model {i} has other classes than model 0")
    k = len(models)
    longest = max(len(a["feature_"]) for _, a in arrays)
    order = [(i, t) for t in range(longest) for i, (_, a) in enumerate(arrays)
             if t < len(a["feature_"])]
    out = {name: np.stack([arrays[i][1][name][t] for i, t in order]) for name in _PER_TREE}
    out["value_"] = out["value_"] / k
    out["classes_"] = first["classes_"]
    if "feature_names_in_" in first:
        out["feature_names_in_"] = first["feature_names_in_"]
    params = dict(params, n_estimators=len(order), stages=None, random_state=None)
    return AdaBoostTrees.from_arrays(params, out)


def average_source_detectors(models):
    """The average of several :class:`~viewadapt.io.models.SourceDetectors` (e.g. trained
    on renders of other seeds): the HOG/SVMs' weights and biases averaged (a linear model's
    mean score is the score of its mean weights) and the ACF models averaged by
    :func:`average_trees`. The training record lists each member's record under
    ``average_of``. ``ValueError`` for fewer than two models or one without an ACF model.
    """
    from .io.models import SourceDetectors

    models = list(models)
    if len(models) < 2:
        raise ValueError(f"averaging needs at least two models, got {len(models)}")
    for i, m in enumerate(models):
        if not isinstance(m, SourceDetectors) or m.acf is None:
            raise ValueError(f"model {i} is not a SourceDetectors with an ACF model")
    weights = np.mean([np.asarray(m.hog_weights, np.float64) for m in models], axis=0)
    bias = float(np.mean([m.hog_bias for m in models]))
    return SourceDetectors(weights, bias, average_trees([m.acf for m in models]),
                           training={"average_of": [dict(m.training) for m in models]})
