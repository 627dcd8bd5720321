"""Source detectors for the full-frame detector, trained on canonical 64x128 windows.

A linear SVM on block-normalised HOG cells (Dalal & Triggs 2005) and boosted trees on ACF
channels (Dollár et al. 2014), each optionally also trained on frame-view copies of the
windows (:func:`~viewadapt.detect.frameview.frame_view_copies`): the window as the adapted
full-frame operator reads it from a frame, at a random person height and offset against
the frame's cell grid. Windows in, :class:`~viewadapt.io.models.SourceDetectors` out.
"""

from __future__ import annotations

import numpy as np

from ..boosting import AdaBoostTrees
from ..classifiers import LinearSVMDetector
from ..io.models import SourceDetectors
from .channels import HOG_WEIGHT_SHAPE
from .frameview import frame_view_copies
from .kinds import ACF_DETECTOR, HOG_DETECTOR
from .layers import UPSAMPLE_BELOW

__all__ = ["FRAME_VIEW_CHOICES", "DEFAULT_FRAME_VIEW", "check_frame_view", "train_on_windows"]

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
                     frame_view: str = DEFAULT_FRAME_VIEW) -> SourceDetectors:
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

    Returns
    -------
    SourceDetectors
        With ``training = {seed, frame_view, quick, crops, background_windows}``.
    """
    check_frame_view(frame_view)
    n_crops, neg = len(positives), list(negatives)
    pos = list(positives) + [np.ascontiguousarray(w[:, ::-1]) for w in positives]

    def training_set(kind, copy_seed):
        feats = kind.features
        Xp = np.stack([feats.window_features(w).ravel() for w in pos])
        Xn = np.stack([feats.window_features(w).ravel() for w in neg])
        if frame_view in (kind.name, "both"):
            kw = dict(upsample_below=UPSAMPLE_BELOW)
            Xp = np.vstack([Xp, frame_view_copies(pos, feats, seed=copy_seed, **kw)])
            Xn = np.vstack([Xn, frame_view_copies(neg, feats, seed=copy_seed + 1, **kw)])
        return np.vstack([Xp, Xn]), np.r_[np.ones(len(Xp), int), np.zeros(len(Xn), int)]

    X, y = training_set(HOG_DETECTOR, seed)
    # C = 0.01 as Dalal & Triggs (block-normalised, clipped cells as their descriptor)
    svm = LinearSVMDetector(C=0.01, initial_negatives=2000 if quick else 5000,
                            mining_rounds=1, random_state=seed).fit(X, y)
    # the channels the full-frame operator reads (float32 OpenCV path)
    X, y = training_set(ACF_DETECTOR, seed + 2)
    n_trees = 64 if quick else 256
    trees = AdaBoostTrees(n_estimators=n_trees, stages=None, max_bins=32 if quick else 64,
                          max_features=0.25 if quick else 0.125, random_state=seed)
    trees.fit(X, y)
    return SourceDetectors(svm.coef_[0].reshape(HOG_WEIGHT_SHAPE).astype(np.float64),
                           float(svm.intercept_[0]), trees,
                           training=dict(seed=seed, frame_view=frame_view, quick=quick,
                                         crops=n_crops, background_windows=len(neg)))
