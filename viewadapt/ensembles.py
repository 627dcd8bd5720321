"""The average of several boosted-tree models, as one :class:`~viewadapt.boosting.AdaBoostTrees`.

Boosted trees trained on the same windows with different seeds (each tree reads its own
random subset of the features) disagree most where the training data say least, and
averaging their scores removes that part of the error -- the variance of the fit, which
bagging removes by averaging models fitted to resampled data (Breiman 1996).
:func:`average_trees` stores the average as one model: the members' trees interleaved --
every member's first tree, then every member's second, ... -- with each tree's outputs
divided by the number of members. Its score is the mean of the members' scores, and its
soft cascade (Bourdev & Brandt 2005) stops a window when the mean of the members' partial
scores over the same number of trees drops to the threshold. Averaging ``K`` members costs
``K`` times one member's trees per window; with ``gate=True`` the first member's trees come
first and the cascade reads their running sum times ``K`` (the first member's own score,
``cascade_scale_``), so a window that member rejects costs what it costs alone, and only the
windows it keeps go on to the other members (a two-stage cascade, Viola & Jones 2001, whose
first stage is one of the averaged models). Because it is an ordinary
:class:`~viewadapt.boosting.AdaBoostTrees`, it is adapted (Wang et al. 2017, Algorithm 2),
saved and loaded like any single model. :func:`average_source_detectors` averages whole
model files the same way (the HOG/SVMs by their weights).

References
----------
.. [1] L. Breiman, "Bagging Predictors", Machine Learning 24(2), 1996.
.. [2] L. Bourdev, J. Brandt, "Robust Object Detection via Soft Cascade", CVPR 2005.
.. [3] P. Wang, K. Morton, P. Torrione, L. Collins, "Viewpoint Adaptation for Rigid Object
   Detection", arXiv preprint, 2017.
.. [4] P. Viola, M. Jones, "Rapid Object Detection using a Boosted Cascade of Simple
   Features", CVPR 2001.
"""

from __future__ import annotations

import numpy as np

from .boosting import AdaBoostTrees

__all__ = ["average_trees", "split_average", "average_source_detectors"]

#: the fitted arrays of one tree each, interleaved member by member
_PER_TREE = ("feature_", "threshold_", "value_", "train_loss_")


def average_trees(models, *, gate: bool = False) -> AdaBoostTrees:
    """One :class:`~viewadapt.boosting.AdaBoostTrees` whose score is the mean of ``models``'.

    Parameters
    ----------
    models : sequence of fitted AdaBoostTrees
        Trained on the same features (the same ``n_features_in_``, classes, tree depth and
        soft-cascade threshold), with the plain cascade (unit ``cascade_scale_``); they may
        hold different numbers of trees (training stops early once the loss vanishes).
    gate : bool
        The first model's trees first, the cascade reading their running sum as that
        model's own score (``cascade_scale_`` ``len(models)``), then the others'
        interleaved. The score of a window no tree stops is the same mean (summed in
        another order); a window stops early where the first model's own cascade stops it.

    Returns
    -------
    AdaBoostTrees
        The members' trees interleaved (round ``t`` holds the ``t``-th tree of every member
        that has one; with ``gate`` the first member's trees before them), their outputs
        divided by ``len(models)``; the first member's
        parameters, with ``n_estimators`` the total, no training stages and no seed. Without
        the soft cascade its decision function is the members' mean to rounding. One model
        is returned as a copy of itself.

    Raises
    ------
    ValueError
        For no models, an unfitted one, one with a scaled cascade, or members that do not
        share their features, classes, depth or cascade threshold.
    """
    models = list(models)
    if not models:
        raise ValueError("average_trees needs at least one model")
    arrays = []
    for i, m in enumerate(models):
        if not isinstance(m, AdaBoostTrees) or not hasattr(m, "feature_"):
            raise ValueError(f"model {i} is not a fitted AdaBoostTrees")
        if np.any(m.cascade_scale_ != 1.0):
            raise ValueError(f"model {i} has a scaled cascade (a gated average): "
                             "average its members instead")
        arrays.append(m.to_arrays())
    params, first = arrays[0]
    for i, (p, a) in enumerate(arrays[1:], start=1):
        for key in ("n_features_in_", "max_depth", "cascade_threshold"):
            if p[key] != params[key]:
                raise ValueError(f"model {i} has {key} = {p[key]!r}, model 0 {params[key]!r}")
        if not np.array_equal(a["classes_"], first["classes_"]):
            raise ValueError(f"model {i} has other classes than model 0")
    k = len(models)
    order = _interleaved([len(a["feature_"]) for _, a in arrays], gate=gate)
    out = {name: np.stack([arrays[i][1][name][t] for i, t in order]) for name in _PER_TREE}
    out["value_"] = out["value_"] / k
    if gate and k > 1:
        lead = len(first["feature_"])
        out["cascade_scale_"] = np.repeat([float(k), 1.0], [lead, len(order) - lead])
    out["classes_"] = first["classes_"]
    if "feature_names_in_" in first:
        out["feature_names_in_"] = first["feature_names_in_"]
    params = dict(params, n_estimators=len(order), stages=None, random_state=None)
    return AdaBoostTrees.from_arrays(params, out)


def _interleaved(lengths, *, gate: bool) -> list:
    """``(member, tree)`` of every tree of an :func:`average_trees` of members holding
    ``lengths`` trees, in the order it stores them."""
    k, longest = len(lengths), max(lengths)
    lead = [(0, t) for t in range(lengths[0])] if gate else []
    return lead + [(i, t) for t in range(longest) for i in range(1 if gate else 0, k)
                   if t < lengths[i]]


def split_average(model, members) -> list:
    """The models an :func:`average_trees` was made of, gated or not (member ``j``: its
    trees in their order, outputs times their number; their sums equal the members' own to
    rounding).

    ``members`` is their number when they are equally long, or each one's number of trees
    (a sequence; :func:`~viewadapt.detect.training.train_on_windows` records them as
    ``acf_member_trees``: training stops a member early once its loss vanishes).
    ``ValueError`` when the trees cannot be such an average: tree counts that do not add
    up, cascade scales that are not a gate's, or a member whose training loss rises (the
    trees of several members mixed)."""
    equal = isinstance(members, (int, np.integer))
    lengths = [int(members)] if equal else [int(n) for n in np.atleast_1d(members)]
    if not isinstance(model, AdaBoostTrees) or not hasattr(model, "feature_") \
            or not lengths or min(lengths) < 1:
        raise ValueError("need a fitted AdaBoostTrees and members >= 1 (or every member's "
                         f"tree count), got {members!r}")
    n, scale = model.n_estimators_, model.cascade_scale_
    if equal:
        k = lengths[0]
        if n % k:
            raise ValueError(f"{n} trees are not an average of {k} equally long models")
        lengths = [n // k] * k
    k = len(lengths)
    if sum(lengths) != n:
        raise ValueError(f"{n} trees are not an average of models of {lengths} trees")
    gated = k > 1 and np.array_equal(scale, np.repeat([float(k), 1.0],
                                                      [lengths[0], n - lengths[0]]))
    if not (gated or np.all(scale == 1.0)):
        raise ValueError(f"{n} trees with these cascade scales are not an average of {k} "
                         f"models of {lengths} trees")
    params, arrays = model.to_arrays()
    member = np.array([i for i, _ in _interleaved(lengths, gate=gated)])
    out = []
    for j in range(k):
        idx = np.flatnonzero(member == j)
        part = {name: arrays[name][idx] for name in _PER_TREE}
        if np.any(np.diff(part["train_loss_"]) > 1e-12 * part["train_loss_"][:-1]):
            raise ValueError(f"member {j} of {k}: its training loss rises, so the trees are "
                             f"not an average of {k} models of {lengths} trees")
        part["value_"] = part["value_"] * k
        part["classes_"] = arrays["classes_"]
        if "feature_names_in_" in arrays:
            part["feature_names_in_"] = arrays["feature_names_in_"]
        out.append(AdaBoostTrees.from_arrays(dict(params, n_estimators=len(idx)), part))
    return out


def _members_in(record):
    """The boosted models a source-detector file's ACF averages, from its training record:
    each one's tree count where recorded (``acf_member_trees``, or those of the files under
    ``average_of``), else how many (``average_of``, ``acf_members`` or its recipe's; 1 when
    none) -- :func:`split_average`'s ``members``."""
    if isinstance(record.get("average_of"), list):
        parts = [_members_in(r) for r in record["average_of"]]
        if all(isinstance(p, list) for p in parts):
            return [n for p in parts for n in p]
        return sum(len(p) if isinstance(p, list) else p for p in parts)
    if isinstance(record.get("acf_member_trees"), list):
        return [int(n) for n in record["acf_member_trees"]]
    recipe = record.get("recipe") or {}
    return int(record.get("acf_members") or recipe.get("acf_members") or 1)


def average_source_detectors(models, *, gate: bool = True):
    """The average of several :class:`~viewadapt.io.models.SourceDetectors` (e.g. trained
    on renders of other seeds): the HOG/SVMs' weights and biases averaged (a linear model's
    mean score is the score of its mean weights) and the ACF models averaged by
    :func:`average_trees`. The training record lists each member's record under
    ``average_of``. With ``gate`` (the default) every ACF model that is itself an average
    (its record's ``acf_members``, split by its ``acf_member_trees`` where recorded) is first
    split into its members (:func:`split_average`) and all of them are averaged with
    ``gate=True``: the first model's first member gates the rest.
    ``ValueError`` for fewer than two models or one without an ACF model.
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
    if gate:
        members = [t for m in models for t in split_average(m.acf, _members_in(m.training))]
        acf = average_trees(members, gate=True)
    else:
        acf = average_trees([m.acf for m in models])
    return SourceDetectors(weights, bias, acf, training={
        "average_of": [dict(m.training) for m in models], **({"acf_gate": True} if gate else {})})
