"""Window classifiers: linear SVM with hard-negative mining (Dalal & Triggs 2005).

The boosted-trees ACF classifier lives in :mod:`viewadapt.boosting`; the viewpoint-adapted
wrapper in :mod:`viewadapt.adapt`.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.svm import LinearSVC
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, validate_data

__all__ = ["LinearSVMDetector"]


class LinearSVMDetector(ClassifierMixin, BaseEstimator):
    """Linear SVM window classifier with hard-negative mining.

    ``fit(X, y)`` treats every negative row of ``X`` as the *pool* of negative windows.
    It trains on all positives and ``initial_negatives`` random negatives, then, for
    ``mining_rounds`` rounds, scores the whole pool and adds the highest-scoring negatives
    not yet used (up to ``max_hard_negatives`` per round, only those scoring above
    ``-1``, i.e. inside the margin), and retrains -- the Dalal-Triggs bootstrapping.

    Parameters
    ----------
    C : float
        SVM regularisation (Dalal & Triggs used 0.01 on their descriptor).
    initial_negatives : int
        Negatives in the first round (all if the pool is smaller).
    mining_rounds : int
        Hard-negative rounds after the first training (0: no mining).
    max_hard_negatives : int
        Cap on negatives added per round.
    class_weight : dict, "balanced" or None
        Passed to LinearSVC.
    random_state : int, Generator or None
        Seeds the initial negative subset and LinearSVC.

    Attributes
    ----------
    coef_ : (1, n_features) ndarray
    intercept_ : (1,) ndarray
    classes_ : (2,) ndarray
    n_negatives_used_ : int
        Negatives in the final training set.
    """

    def __init__(self, *, C=0.01, initial_negatives=5000, mining_rounds=1,
                 max_hard_negatives=5000, class_weight=None, random_state=None):
        self.C = C
        self.initial_negatives = initial_negatives
        self.mining_rounds = mining_rounds
        self.max_hard_negatives = max_hard_negatives
        self.class_weight = class_weight
        self.random_state = random_state

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.classifier_tags.multi_class = False
        return tags

    def fit(self, X, y):
        X, y = validate_data(self, X, y, reset=True, dtype=np.float64)
        check_classification_targets(y)
        self.classes_ = np.unique(y)
        if len(self.classes_) != 2:
            raise ValueError(f"Only binary classification is supported. y has "
                             f"{len(self.classes_)} classes")
        if self.initial_negatives < 1 or self.mining_rounds < 0 or self.max_hard_negatives < 0:
            raise ValueError("initial_negatives must be >= 1, mining_rounds and "
                             "max_hard_negatives >= 0")
        rng = (self.random_state if isinstance(self.random_state, np.random.Generator)
               else np.random.default_rng(self.random_state))
        pos = np.flatnonzero(y == self.classes_[1])
        neg = np.flatnonzero(y == self.classes_[0])
        if len(neg) > self.initial_negatives:
            used = np.zeros(len(neg), bool)
            used[rng.choice(len(neg), self.initial_negatives, replace=False)] = True
        else:
            used = np.ones(len(neg), bool)
        seed = int(rng.integers(2**31 - 1))
        svm = None
        for round_ in range(self.mining_rounds + 1):
            idx = np.concatenate([pos, neg[used]])
            svm = LinearSVC(C=self.C, class_weight=self.class_weight, random_state=seed,
                            max_iter=5000, dual="auto")
            import warnings
            from sklearn.exceptions import ConvergenceWarning
            with warnings.catch_warnings():
                # liblinear's iteration cap is reported, not fatal: the solution is usable
                warnings.simplefilter("ignore", ConvergenceWarning)
                svm.fit(X[idx], y[idx])
            if round_ == self.mining_rounds or used.all():
                break
            cand = np.flatnonzero(~used)
            scores = svm.decision_function(X[neg[cand]])
            hard = cand[scores > -1.0]
            if hard.size == 0:
                break
            hard = hard[np.argsort(-scores[scores > -1.0], kind="stable")][: self.max_hard_negatives]
            used[hard] = True
        self.coef_ = svm.coef_.copy()
        self.intercept_ = svm.intercept_.copy()
        self.n_negatives_used_ = int(used.sum())
        return self

    def decision_function(self, X):
        """Scores ``X @ coef_.T + intercept_``, higher = positive class."""
        check_is_fitted(self, "coef_")
        X = validate_data(self, X, reset=False, dtype=np.float64)
        return X @ self.coef_[0] + self.intercept_[0]

    def predict(self, X):
        check_is_fitted(self, "coef_")
        return self.classes_[(self.decision_function(X) > 0).astype(int)]
