"""Source detectors for the full-frame detector, trained on canonical 64x128 windows.

A linear SVM on block-normalised HOG cells (Dalal & Triggs 2005) and boosted trees on ACF
channels (Dollár et al. 2014), each optionally also trained on frame-view copies of the
windows (:func:`~viewadapt.detect.frameview.frame_view_copies`): the window as the adapted
full-frame operator reads it from a frame, at a random person height and offset against
the frame's cell grid. The boosted trees may be the average of several models, each
trained with its own seed (:func:`~viewadapt.ensembles.average_trees`; bagging, Breiman
1996). Windows in, :class:`~viewadapt.io.models.SourceDetectors` out.
"""

from __future__ import annotations

import numpy as np

from ..boosting import AdaBoostTrees
from .._validation import check_int
from ..classifiers import LinearSVMDetector
from ..ensembles import average_trees
from ..io.models import SourceDetectors
from .channels import HOG_WEIGHT_SHAPE
from .frameview import frame_view_copies
from .kinds import ACF_DETECTOR, HOG_DETECTOR
from .layers import UPSAMPLE_BELOW

__all__ = ["FRAME_VIEW_CHOICES", "DEFAULT_FRAME_VIEW", "check_frame_view", "train_on_windows",
           "window_training_set", "hog_svm", "acf_trees"]

#: ``frame_view`` choices of :func:`train_on_windows`: which detectors also train on
#: frame-view copies of the windows.
FRAME_VIEW_CHOICES = ("hog", "acf", "both", "none")
#: Both detectors train on the copies.
DEFAULT_FRAME_VIEW = "both"


def check_frame_view(frame_view: str) -> str:
    """``frame_view`` if it is one of :data:`FRAME_VIEW_CHOICES`; ValueError otherwise."""
    if frame_view not in FRAME_VIEW_CHOICES:
        raise ValueError(f"frame_view must be one of {FRAME_VIEW_CHOICES}, got {frame_view!r}")
    return frame_view


def train_on_windows(positives, negatives, *, seed: int = 0, quick: bool = False,
                     frame_view: str = DEFAULT_FRAME_VIEW,
                     svm_params=None, acf_members: int = 1) -> SourceDetectors:
    """HOG/SVM and ACF boosted trees trained on canonical windows.

    Parameters
    ----------
    positives, negatives : list of (128, 64[, 3]) ndarray
        Person windows (each is also used left-right mirrored, as Dalal & Triggs) and
        background windows of the source view.
    seed : int
        Seeds the SVM's negative sampling, the trees and the frame-view copies.
    quick : bool
        Fewer initial negatives (2000, not 5000), trees (64, not 256) and histogram bins.
    frame_view : {"hog", "acf", "both", "none"}
        Which detectors also train on one frame-view copy of every window.
    svm_params : dict, optional
        :class:`~viewadapt.classifiers.LinearSVMDetector` parameters instead of
        :func:`hog_svm`'s (e.g. ``{"C": 0.001}``); recorded in ``training``.
    acf_members : int
        The boosted trees are the average (:func:`~viewadapt.ensembles.average_trees`) of
        this many models; member ``k`` is trained as a single model of seed ``seed + k``
        would be (its trees' feature subsets and its frame-view copies), so member 0 is the
        single model and gates the others (``average_trees``' ``gate``: the same mean, a
        window member 0 rejects costs its trees alone). Recorded in ``training`` when above
        1, with each member's number of trees (``acf_member_trees``, so that
        :func:`~viewadapt.ensembles.split_average` can take the average apart). 0: no ACF
        model (``acf`` is None; for studies that train their own trees).

    Returns
    -------
    SourceDetectors
        With ``training = {seed, frame_view, quick, crops, background_windows}``.
    """
    check_frame_view(frame_view)
    acf_members = check_int(acf_members, "acf_members", minimum=0)
    X, y = window_training_set(HOG_DETECTOR, positives, negatives, frame_view=frame_view,
                               seed=seed)
    svm = hog_svm(seed=seed, quick=quick, **dict(svm_params or {})).fit(X, y)
    # the channels the full-frame operator reads (float32 OpenCV path)
    members = []
    for k in range(acf_members):
        X, y = window_training_set(ACF_DETECTOR, positives, negatives, frame_view=frame_view,
                                   seed=seed + k + 2)
        members.append(acf_trees(seed=seed + k, quick=quick).fit(X, y))
        del X, y
    trees = average_trees(members, gate=True) if len(members) > 1 \
        else next(iter(members), None)
    training = dict(seed=seed, frame_view=frame_view, quick=quick, crops=len(positives),
                    background_windows=len(negatives))
    if svm_params:
        training["svm_params"] = dict(svm_params)
    if acf_members > 1:
        training["acf_members"] = acf_members
        training["acf_member_trees"] = [int(m.n_estimators_) for m in members]
    return SourceDetectors(svm.coef_[0].reshape(HOG_WEIGHT_SHAPE).astype(np.float64),
                           float(svm.intercept_[0]), trees, training=training)


def window_training_set(kind, positives, negatives, *, frame_view: str = DEFAULT_FRAME_VIEW,
                        seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``(X, y)`` a detector ``kind`` (:data:`HOG_DETECTOR`, :data:`ACF_DETECTOR`) trains
    on in :func:`train_on_windows`: the features of every positive and its mirror image,
    then of every negative (label 1, then 0); with ``frame_view`` naming ``kind`` (or
    ``"both"``) also one frame-view copy of each (seeded ``seed`` for the positives,
    ``seed + 1`` for the negatives)."""
    check_frame_view(frame_view)
    pos = list(positives) + [np.ascontiguousarray(w[:, ::-1]) for w in positives]
    feats = kind.features
    Xp = np.stack([feats.window_features(w).ravel() for w in pos])
    Xn = np.stack([feats.window_features(w).ravel() for w in negatives])
    if frame_view in (kind.name, "both"):
        kw = dict(upsample_below=UPSAMPLE_BELOW)
        Xp = np.vstack([Xp, frame_view_copies(pos, feats, seed=seed, **kw)])
        Xn = np.vstack([Xn, frame_view_copies(list(negatives), feats, seed=seed + 1, **kw)])
    return np.vstack([Xp, Xn]), np.r_[np.ones(len(Xp), int), np.zeros(len(Xn), int)]


def hog_svm(*, seed: int = 0, quick: bool = False, **params) -> LinearSVMDetector:
    """The (untrained) HOG/SVM of :func:`train_on_windows`: ``C = 0.01`` as Dalal & Triggs
    (block-normalised, clipped cells as their descriptor), 5000 initial negatives (``quick``:
    2000) and one round of hard negatives; ``params`` override any
    :class:`~viewadapt.classifiers.LinearSVMDetector` parameter."""
    base = dict(C=0.01, initial_negatives=2000 if quick else 5000, mining_rounds=1,
                random_state=seed)
    return LinearSVMDetector(**(base | params))


def acf_trees(*, seed: int = 0, quick: bool = False, **params) -> AdaBoostTrees:
    """The (untrained) boosted trees of :func:`train_on_windows`: 256 depth-2 trees on 64
    bins, an eighth of the features per tree (``quick``: 64 trees, 32 bins, a quarter);
    ``params`` override any :class:`~viewadapt.boosting.AdaBoostTrees` parameter."""
    base = dict(n_estimators=64 if quick else 256, stages=None, max_bins=32 if quick else 64,
                max_features=0.25 if quick else 0.125, random_state=seed)
    return AdaBoostTrees(**(base | params))
