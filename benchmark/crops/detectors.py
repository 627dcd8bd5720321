"""The detectors of the cross-validation and the sweep: one spec per detector.

A *detector spec* says everything the benchmark needs to know about a detector: the
features it reads on a 64x128 window, the finer features the adapted rows remap from, its
``G`` (the remappable part), how it is trained and how it scores -- plain, and through
``G``. ``bench crossval`` and ``bench sweep`` read nothing else, so a user adds a detector
without editing the project: ``--detectors hog my_package.module:MyDetector`` names any
importable object (a class is instantiated) that follows :class:`CropDetector`'s protocol;
docs/detectors.md has a worked example.

The protocol (attributes and methods; :class:`CropDetector` supplies the optional ones):

``name``
    the detector's label in the results.
``source_features``, ``target_features``
    features of a window: a built-in representation's name
    (:data:`benchmark.crops.features.REPRESENTATIONS`) or an object with a ``key`` (a string that
    names it in the feature cache; change it when the features change) that is called
    with one (128, 64, 3) uint8 window and returns a 1-D float array. The classifier
    reads ``source_features``; ``G`` maps ``target_features`` (often the same features on
    a finer grid) to them.
``remap_matrix(mapping, *, rule, per_cell, config)``
    ``G``, sparse (n_source, n_target), through ``mapping`` (a 3x3 homography, or a
    callable point mapping, :mod:`viewadapt.mapping`) from source- to target-window pixels,
    with the angle rule ``rule`` and per-cell (or one) ``A``.
``fit(X_pos, X_neg, *, seed, config)``
    a trained model from source features of positives and negatives.
``score(model, X)``
    (n,) scores of source features.
optional: ``score_adapted(model, X_target, G)``
    (n,) scores of target features through ``G``; by default ``score(model, G x)``.
    ``adapted_inputs(X_target, G)`` / ``score_adapted_inputs(model, A, G)`` split it into
    the part shared by all models and the rest (the sweep scores nine fold models on the
    same remapped windows).
optional: ``pretrained`` (no training: source elevation 0 only, no synthesised row),
    ``ablations`` (run the angle-rule and single-``A`` ablation rows), ``exact_geometry``
    (run the exact-correspondence upper-bound rows).

``config`` is the run's :class:`benchmark.crops.crossval.CrossvalConfig` (``C``,
``mining_rounds``, ``initial_negatives``, ``acf_*`` ... and ``target_cell_size``).
"""

from __future__ import annotations

import functools
import importlib
import re

import numpy as np

from viewadapt.adapt import acf_remap_matrix, cells_to_descriptor, hog_remap_matrix, remap_features
from viewadapt.ensembles import average_trees

__all__ = ["CropDetector", "HogDescriptorDetector", "LinearCellsDetector", "AcfTreesDetector",
           "OpenCVPeopleDetector", "BUILTIN_DETECTORS", "detector_spec", "feature_key"]


def feature_key(features) -> str:
    """The feature cache's name of a ``source_features`` / ``target_features`` entry."""
    return features if isinstance(features, str) else str(features.key)


class CropDetector:
    """Base of the detector specs: the protocol's optional parts (see the module notes)."""

    name = ""
    source_features = None
    target_features = None
    pretrained = False
    ablations = False
    exact_geometry = False

    def remap_matrix(self, mapping, *, rule, per_cell, config):
        raise NotImplementedError

    def fit(self, X_pos, X_neg, *, seed, config):
        raise NotImplementedError

    def score(self, model, X):
        raise NotImplementedError

    def adapted_inputs(self, X_target, G):
        """The model-independent part of :meth:`score_adapted`: here ``G x`` per window."""
        return remap_features(G, X_target)

    def score_adapted_inputs(self, model, A, G):
        """:meth:`score_adapted` from ``adapted_inputs(X_target, G)`` (rows may be a subset)."""
        return self.score(model, A)

    def score_adapted(self, model, X_target, G):
        """(n,) scores of target-view features through ``G``."""
        return self.score_adapted_inputs(model, self.adapted_inputs(X_target, G), G)


def _svm(config, seed):
    from viewadapt.classifiers import LinearSVMDetector

    return LinearSVMDetector(C=config.recipe.svm_C(config.C),
                             initial_negatives=config.initial_negatives,
                             mining_rounds=config.mining_rounds,
                             max_hard_negatives=config.max_hard_negatives, random_state=seed)


def _labels(n_pos, n_neg):
    return np.r_[np.ones(n_pos, int), np.zeros(n_neg, int)]


class _HogCells(CropDetector):
    """HOG cell histograms: ``G`` through :func:`viewadapt.adapt.hog_remap_matrix` from the
    finer target cells (``config.target_cell_size``)."""

    ablations = True
    exact_geometry = True

    def remap_matrix(self, mapping, *, rule, per_cell, config):
        return hog_remap_matrix(mapping, target_cell_size=config.target_cell_size, rule=rule,
                                per_cell=per_cell)


class HogDescriptorDetector(_HogCells):
    """Dalal & Triggs: a linear SVM on the block-normalised descriptor of 8-px cells.

    Adapted: the target's 4-px cells remapped, then normalised (``N(G x)``).
    """

    name = "hog"
    source_features, target_features = "cells8", "cells4"

    def fit(self, X_pos, X_neg, *, seed, config):
        return _svm(config, seed).fit(cells_to_descriptor(np.vstack([X_pos, X_neg])),
                                      _labels(len(X_pos), len(X_neg)))

    def score(self, model, X):
        return model.decision_function(cells_to_descriptor(X.astype(np.float64)))

    def adapted_inputs(self, X_target, G):
        return cells_to_descriptor(remap_features(G, X_target))

    def score_adapted_inputs(self, model, A, G):
        return model.decision_function(A)


class LinearCellsDetector(_HogCells):
    """A linear SVM on locally normalised HOG cells; adapted by folding ``G`` into the
    weights, ``w' = G^T w`` (Wang et al. 2017, eq. (7))."""

    name = "hog_local"
    source_features, target_features = "local8", "local4"

    def fit(self, X_pos, X_neg, *, seed, config):
        return _svm(config, seed).fit(np.vstack([X_pos, X_neg]), _labels(len(X_pos), len(X_neg)))

    def score(self, model, X):
        return model.decision_function(X)

    def adapted_inputs(self, X_target, G):
        return X_target

    def score_adapted_inputs(self, model, A, G):
        from viewadapt.adapt import adapt_linear_weights

        w = adapt_linear_weights(model.coef_[0], G)          # offline, eq. (7)
        return A.astype(np.float64) @ w + model.intercept_[0]


class AcfTreesDetector(CropDetector):
    """Boosted depth-2 trees on ACF channels (Dollár et al. 2014); adapted by remapping only
    the features the trees read, ``G[used] x`` (Algorithm 2)."""

    name = "acf"
    source_features = target_features = "acf"

    def remap_matrix(self, mapping, *, rule, per_cell, config):
        return acf_remap_matrix(mapping, rule=rule, per_cell=per_cell)

    @staticmethod
    def _trees(config, seed):
        from viewadapt.boosting import AdaBoostTrees

        return AdaBoostTrees(n_estimators=config.acf_estimators, stages=config.acf_stages,
                             max_bins=config.acf_max_bins, max_features=config.acf_max_features,
                             random_state=seed)

    def fit(self, X_pos, X_neg, *, seed, config):
        # the recipe's members (Recipe.acf_members): member k trained as seed + k would be
        k = config.recipe.acf_members
        members = [self._fit_one(X_pos, X_neg, seed=seed + i, config=config) for i in range(k)]
        return members[0] if k == 1 else average_trees(members, gate=True)

    def _fit_one(self, X_pos, X_neg, *, seed, config):
        # the ACF toolbox bootstraps hard negatives between stages; we mine once with a
        # first model on a random subset, as the SVM does
        rng = np.random.default_rng(seed)
        n0 = min(len(X_neg), config.initial_negatives)
        first = rng.choice(len(X_neg), n0, replace=False)
        clf = self._trees(config, seed).fit(np.vstack([X_pos, X_neg[first]]),
                                            _labels(len(X_pos), n0))
        if config.mining_rounds > 0 and len(X_neg) > n0:
            rest = np.setdiff1d(np.arange(len(X_neg)), first)
            s = clf.decision_function(X_neg[rest])
            hard = rest[np.argsort(-s)[: config.max_hard_negatives]]
            hard = hard[clf.decision_function(X_neg[hard]) > -1.0]
            keep = np.r_[first, hard]
            clf = self._trees(config, seed).fit(np.vstack([X_pos, X_neg[keep]]),
                                                _labels(len(X_pos), len(keep)))
        return clf

    def score(self, model, X):
        return model.decision_function(X)

    def adapted_inputs(self, X_target, G):
        return X_target

    def score_adapted_inputs(self, model, A, G):
        return model.decision_function_remapped(A.astype(np.float64), G)


class OpenCVPeopleDetector(HogDescriptorDetector):
    """OpenCV's default people detector (trained on INRIA, level views): pretrained, on the
    gamma-corrected cells its descriptor is built from."""

    name = "opencv"
    source_features, target_features = "gamma_cells8", "gamma_cells4"
    pretrained = True
    ablations = False

    def fit(self, X_pos, X_neg, *, seed, config):
        from viewadapt.hog import opencv_people_detector

        return opencv_people_detector()

    def score(self, model, X):
        w, b = model
        return cells_to_descriptor(X.astype(np.float64)) @ w + b

    def score_adapted_inputs(self, model, A, G):
        w, b = model
        return A @ w + b


#: the built-in detectors by name
BUILTIN_DETECTORS = {d.name: d for d in (HogDescriptorDetector(), LinearCellsDetector(),
                                         AcfTreesDetector(), OpenCVPeopleDetector())}
_REQUIRED = ("name", "source_features", "target_features", "remap_matrix", "fit", "score")


class _UserDetector(CropDetector):
    """A user's spec with :class:`CropDetector`'s defaults for the optional parts it lacks
    (the user's object itself is left as it is)."""

    def __init__(self, spec):
        self.spec = spec
        for a in _REQUIRED[:3] + ("pretrained", "ablations", "exact_geometry"):
            setattr(self, a, getattr(spec, a, getattr(CropDetector, a)))
        self.remap_matrix, self.fit, self.score = spec.remap_matrix, spec.fit, spec.score
        if hasattr(spec, "score_adapted"):
            self.score_adapted = spec.score_adapted
            if hasattr(spec, "adapted_inputs"):
                self.adapted_inputs = spec.adapted_inputs
                self.score_adapted_inputs = spec.score_adapted_inputs
            else:                        # its own adapted scoring, nothing shared
                self.adapted_inputs = lambda Xt, G: Xt
                self.score_adapted_inputs = spec.score_adapted


@functools.lru_cache(maxsize=None)
def detector_spec(name: str):
    """The detector spec called ``name``: a built-in (:data:`BUILTIN_DETECTORS`) or
    ``"package.module:Object"`` (a class is instantiated); a ``ValueError`` in one line if
    it cannot be imported or lacks part of the protocol."""
    if name in BUILTIN_DETECTORS:
        return BUILTIN_DETECTORS[name]
    mod, sep, attr = str(name).partition(":")
    if not sep or not mod or not attr:
        raise ValueError(f"unknown detector {name!r}: use one of "
                         f"{sorted(BUILTIN_DETECTORS)} or package.module:Object")
    try:
        obj = getattr(importlib.import_module(mod), attr)
    except (ImportError, AttributeError) as exc:
        raise ValueError(f"cannot load detector {name!r}: {exc}") from None
    try:
        spec = obj() if isinstance(obj, type) else obj
    except Exception as exc:  # noqa: BLE001 - a user's class: report, never a traceback
        raise ValueError(f"cannot create detector {name!r}: {exc}") from None
    missing = [a for a in _REQUIRED if not hasattr(spec, a)]
    if missing:
        raise ValueError(f"detector {name!r} lacks {', '.join(missing)} of the detector "
                         "protocol (benchmark.crops.detectors, docs/detectors.md)")
    if not re.fullmatch(r"[A-Za-z0-9_.-]+", str(spec.name)) or spec.name in BUILTIN_DETECTORS:
        raise ValueError(f"detector {name!r}: its name {spec.name!r} must be letters, digits, "
                         "'_', '.' or '-' and not a built-in detector's")
    return _UserDetector(spec)
