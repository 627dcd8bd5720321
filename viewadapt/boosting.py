"""Boosted depth-limited trees with a soft cascade: the ACF detector's classifier.

:class:`AdaBoostTrees` follows Piotr Dollár's toolbox (``adaBoostTrain`` /
``binaryTreeTrain`` for training, ``acfDetect`` for evaluation): AdaBoost over small
decision trees on quantised features, class-balanced initial weights, and at run time a
*soft cascade* that stops summing trees for a window as soon as its running score drops to
the cascade threshold.

For viewpoint adaptation (Wang et al. 2017, Sec. 4) a non-linear classifier cannot absorb
the feature remapping ``x_source ~= G x_target`` into its parameters, so the remapping is
applied at run time -- but only to the features the trees actually read:
:attr:`AdaBoostTrees.used_features_` lists them and
:meth:`AdaBoostTrees.decision_function_remapped` evaluates ``G[used] @ x`` and nothing else.

References
----------
.. [1] P. Dollár, R. Appel, S. Belongie, P. Perona, "Fast Feature Pyramids for Object
   Detection", IEEE TPAMI 36(8), 2014.
.. [2] P. Dollár, "Piotr's Computer Vision Matlab Toolbox", version 3.x:
   ``adaBoostTrain.m``, ``binaryTreeTrain.m``, ``acfDetect1.cpp``.
.. [3] J. Friedman, T. Hastie, R. Tibshirani, "Additive logistic regression: a statistical
   view of boosting", Annals of Statistics 28(2), 2000 (Real AdaBoost).
.. [4] L. Bourdev, J. Brandt, "Robust Object Detection via Soft Cascade", CVPR 2005.
.. [5] P. Wang, K. Morton, P. Torrione, L. Collins, "Viewpoint Adaptation for Rigid
   Object Detection", arXiv preprint, 2017.
"""

from __future__ import annotations

import numbers

import numpy as np
import scipy.sparse as sp
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.utils import check_array, check_random_state
from sklearn.utils.multiclass import check_classification_targets, type_of_target
from sklearn.utils.validation import check_is_fitted, validate_data

from ._validation import check_int, check_stages
from .treegrow import bin_edges, grow_tree, quantize

__all__ = ["AdaBoostTrees", "cascade_step"]

# discrete AdaBoost's alpha is clipped to [-5, 5] (adaBoostTrain)
_MAX_ALPHA = 5.0
# adaBoostTrain stops once the exponential loss sum(exp(-y H)) / 2 falls below 1e-40
_MIN_LOSS = 1e-40
_MAX_DEPTH_LIMIT = 12


class AdaBoostTrees(ClassifierMixin, BaseEstimator):
    """AdaBoost over depth-limited trees, evaluated with a soft cascade (ACF's classifier).

    Training (toolbox ``adaBoostTrain`` with ``binaryTreeTrain``): features are quantised
    into at most ``max_bins`` bins; sample weights start class-balanced,
    :math:`w_i = 1 / (2 N_{y_i})`; each round fits a tree of depth ``max_depth`` by the
    weighted Gini criterion and sets leaf outputs

    .. math:: h(\\ell) = \\operatorname{clip}\\left(\\tfrac12 \\log\\frac{p_\\ell}{1 - p_\\ell},
              -4, 4\\right), \\qquad p_\\ell = \\frac{W_+(\\ell)}{W_+(\\ell) + W_-(\\ell)}

    (Real AdaBoost, Friedman et al. 2000); weights are then
    :math:`w_i \\propto \\exp(-y_i H(x_i)) / (2 N_{y_i})` with :math:`y_i = \\pm 1` and
    :math:`H = \\sum_t h_t`. With ``algorithm="discrete"`` the leaves output
    :math:`\\pm\\alpha_t`, :math:`\\alpha_t = \\operatorname{clip}(\\tfrac12\\log((1 -
    \\epsilon_t)/\\epsilon_t), -5, 5)`, :math:`\\epsilon_t` the tree's weighted error.

    Evaluation (toolbox ``acfDetect1``): :math:`H_t(x) = H_{t-1}(x) + h_t(x)` tree by tree;
    with the soft cascade a sample stops at the first ``t`` with
    :math:`c_t H_t(x) \\le \\theta` (``cascade_threshold``) and keeps :math:`c_t H_t(x)` as
    its score, :math:`c_t` (``cascade_scale_``) 1 unless the model says otherwise (e.g. an
    average whose first member's trees stand for the whole: :mod:`viewadapt.ensembles`).

    Parameters
    ----------
    n_estimators : int
        Number of trees to train (the toolbox's final ``nWeak``). Training stops earlier
        when the exponential loss falls below 1e-40 (``n_estimators_`` says how many).
    max_depth : int
        Depth of every tree (ACF uses 2).
    stages : tuple of int or None
        Tree counts after which :meth:`staged_decision_function` reports scores: the
        toolbox trains ACF in bootstrapping rounds with ``nWeak = [32 128 512 2048]``.
        Strictly increasing, each at most ``n_estimators``. ``None`` means
        ``(n_estimators,)``. Does not affect :meth:`fit`: hard-negative mining between
        rounds happens outside this class.
    cascade_threshold : float or None
        Soft-cascade threshold :math:`\\theta` (the toolbox's ``cascThr = -1``). ``None``
        disables the cascade: every tree is summed for every sample.
    algorithm : {"real", "discrete"}
        Real AdaBoost (leaf outputs are half log-odds) or Discrete AdaBoost (the
        toolbox's ``adaBoostTrain`` default ``discrete = 1``).
    max_bins : int
        Number of quantisation bins per feature, 2..256 (the toolbox's ``nBins = 256``).
    max_features : float or int
        Features considered per tree: a fraction in (0, 1] or a count. Below 1 the subset
        is drawn afresh for each tree (the toolbox's ``fracFtrs``, e.g. 1/16 in its INRIA
        demo, draws per node).
    random_state : int, numpy.random.Generator, RandomState or None
        Seeds the feature subsets; unused when all features are considered.
    learning_rate : float
        Shrinkage :math:`\\nu \\in (0, 1]` (Friedman 2001, "Greedy function approximation",
        Sec. 5): each tree's leaf outputs are multiplied by :math:`\\nu` before they enter
        :math:`H`, so the sample weights move more slowly from tree to tree. 1 (the
        default) is plain AdaBoost, as the toolbox trains.

    Attributes
    ----------
    classes_ : (2,) ndarray
        Class labels; ``classes_[1]`` is the positive class (the person).
    n_features_in_ : int
    n_estimators_ : int
        Number of trees trained.
    feature_ : (n_estimators_, 2 ** (max_depth + 1) - 1) int32 ndarray
        Feature split on at each node, ``-1`` for leaves and unreachable nodes. Nodes are
        stored as complete binary trees: the children of node ``k`` are ``2k + 1`` (left,
        ``x[feature] < threshold``) and ``2k + 2`` (right, ``x[feature] >= threshold``).
    threshold_ : (n_estimators_, 2 ** (max_depth + 1) - 1) float64 ndarray
    value_ : (n_estimators_, 2 ** (max_depth + 1) - 1) float64 ndarray
        Output of each node (alpha included); only leaves are summed.
    train_loss_ : (n_estimators_,) float64 ndarray
        Exponential loss :math:`\\sum_i \\exp(-y_i H(x_i)) / (2 N_{y_i})` after each tree.
    cascade_scale_ : (n_estimators_,) float64 ndarray
        :math:`c_t`: the factor by which the running score after tree ``t`` is multiplied
        before the soft cascade compares it with the threshold (its estimate of the whole
        model's score; a stopped sample keeps the product). Ones after :meth:`fit`.
    used_features_ : (n_used,) intp ndarray
        Sorted indices of the features read by any tree (a property).

    Notes
    -----
    Departures from the toolbox:

    * Quantisation bins come from per-feature quantiles (edges midway between order
      statistics, like scikit-learn's histogram gradient boosting) instead of ``nBins``
      equal steps between the feature's minimum and maximum; outliers do not waste bins.
      Thresholds are stored as real feature values, so evaluation never quantises.
    * With ``max_features < 1`` the feature subset is drawn per tree, not per node.
    * Discrete AdaBoost stops when a tree's weighted error reaches 1/2 (the toolbox does
      this only in verbose mode).
    * The split search accumulates histograms in float32, as the toolbox does in single
      precision; the chosen split's gain and the leaf outputs are recomputed in float64.

    Training cost is dominated by one pass over the ``n_samples x n_features`` quantised
    matrix per tree level (sparse one-hot histograms, the smaller child's only; its
    sibling's is the parent's minus it); besides ``X``, memory is about 9 bytes per
    ``n_samples x n_features`` entry. Measured on one core: 2000 samples x 5000 features x
    64 depth-2 trees in about 8 s (1.5 s of it quantisation and set-up), 2 s with
    ``max_features=1/16``.

    Examples
    --------
    >>> import numpy as np
    >>> from viewadapt.boosting import AdaBoostTrees
    >>> rng = np.random.default_rng(0)
    >>> X = rng.normal(size=(200, 5)); y = (X[:, 0] + X[:, 1] > 0).astype(int)
    >>> clf = AdaBoostTrees(n_estimators=32, stages=(8, 32)).fit(X, y)
    >>> clf.score(X, y) > 0.9
    True
    """

    def __init__(self, *, n_estimators=2048, max_depth=2, stages=(32, 128, 512, 2048),
                 cascade_threshold=-1.0, algorithm="real", max_bins=256,
                 max_features=1.0, random_state=None, learning_rate=1.0):
        self.n_estimators = n_estimators
        self.max_depth = max_depth
        self.stages = stages
        self.cascade_threshold = cascade_threshold
        self.algorithm = algorithm
        self.max_bins = max_bins
        self.max_features = max_features
        self.random_state = random_state
        self.learning_rate = learning_rate

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        # Binary only: a detector's classifier separates person from background. fit
        # raises "Only binary classification is supported." for anything else.
        tags.classifier_tags.multi_class = False
        return tags

    # ------------------------------------------------------------------ parameters
    def _checked_params(self):
        name = type(self).__name__
        T = check_int(self.n_estimators, "n_estimators", minimum=1)
        depth = check_int(self.max_depth, "max_depth", minimum=1)
        if depth > _MAX_DEPTH_LIMIT:
            raise ValueError(f"max_depth must be <= {_MAX_DEPTH_LIMIT} (trees are stored "
                             f"as complete binary trees), got {self.max_depth!r}")
        stages = check_stages(self.stages, T)
        thr = self.cascade_threshold
        if thr is not None and (isinstance(thr, bool) or not isinstance(thr, numbers.Real)
                                or not np.isfinite(thr)):
            raise ValueError(f"cascade_threshold must be a finite number or None, got {thr!r}")
        if self.algorithm not in ("real", "discrete"):
            raise ValueError(
                f"algorithm must be 'real' or 'discrete', got {self.algorithm!r} ({name})")
        n_bins = check_int(self.max_bins, "max_bins", minimum=2)
        if n_bins > 256:
            raise ValueError(f"max_bins must be between 2 and 256, got {self.max_bins!r}")
        mf = self.max_features
        if isinstance(mf, bool) or not isinstance(mf, numbers.Real):
            raise ValueError(f"max_features must be a fraction in (0, 1] or a positive "
                             f"integer, got {mf!r}")
        if isinstance(mf, numbers.Integral):
            if mf < 1:
                raise ValueError(f"max_features must be a positive integer or a fraction "
                                 f"in (0, 1], got {mf!r}")
        elif not (0.0 < mf <= 1.0):
            raise ValueError(f"max_features must be a fraction in (0, 1] or a positive "
                             f"integer, got {mf!r}")
        lr = self.learning_rate
        if isinstance(lr, bool) or not isinstance(lr, numbers.Real) or not 0.0 < lr <= 1.0:
            raise ValueError(f"learning_rate must be a number in (0, 1], got {lr!r}")
        return T, depth, stages, n_bins

    # ------------------------------------------------------------------ training
    def fit(self, X, y):
        """Train ``n_estimators`` boosted trees.

        Parameters
        ----------
        X : (n_samples, n_features) array_like
            Feature vectors (e.g. flattened ACF channels of windows).
        y : (n_samples,) array_like
            Two class labels; the larger one (``classes_[1]``) is the positive class.

        Returns
        -------
        self : AdaBoostTrees
        """
        T, depth, _, n_bins = self._checked_params()
        X, y = validate_data(self, X, y, dtype=np.float64)
        check_classification_targets(y)
        y_type = type_of_target(y, input_name="y", raise_unknown=True)
        if y_type != "binary":
            raise ValueError("Only binary classification is supported. The type of the "
                             f"target is {y_type}.")
        classes, y_idx = np.unique(y, return_inverse=True)
        if classes.size != 2:
            raise ValueError(f"{type(self).__name__} needs samples of 2 classes; got 1 class "
                             f"({classes[0]!r})")
        rng = check_random_state(self.random_state)
        n, d = X.shape
        mf = self.max_features
        n_sub = mf if isinstance(mf, numbers.Integral) else int(np.floor(mf * d))
        n_sub = int(min(max(n_sub, 1), d))

        edges = bin_edges(X, n_bins)                    # (d, n_bins - 1)
        XqT = quantize(X, edges)                        # (d, n) uint8
        is_pos = y_idx == 1
        members = (np.flatnonzero(~is_pos), np.flatnonzero(is_pos))
        ysign = np.where(is_pos, 1.0, -1.0)
        # class-balanced initial weights 1 / (2 N_c), kept as logs (adaBoostTrain: exp(H0)/N0/2)
        log_w0 = -np.log(2.0 * np.where(is_pos, members[1].size, members[0].size))
        margin = np.zeros(n)                             # y_i H(x_i)

        n_nodes = 2 ** (depth + 1) - 1
        feature = np.full((T, n_nodes), -1, dtype=np.int32)
        threshold = np.zeros((T, n_nodes))
        value = np.zeros((T, n_nodes))
        losses = np.zeros(T)
        n_trained = 0
        for t in range(T):
            log_w = log_w0 - margin
            top = log_w.max()
            w = np.exp(log_w - top)
            w /= w.sum()                                  # binaryTreeTrain normalises
            if n_sub < d:
                subset = np.sort(rng.choice(d, size=n_sub, replace=False))
            else:
                subset = np.arange(d)
            leaf_of, f_t, b_t, v_t = grow_tree(XqT, members, subset, w, n_bins, depth)
            if self.algorithm == "discrete":
                # adaBoostTrain: hs = (hs > 0) * 2 - 1, alpha from the weighted error
                v_t = np.where(v_t > 0, 1.0, -1.0)
                err = np.float64(w[v_t[leaf_of] != ysign].sum())
                with np.errstate(divide="ignore"):
                    alpha = float(np.clip(0.5 * np.log((1.0 - err) / err),
                                          -_MAX_ALPHA, _MAX_ALPHA))
                if alpha <= 0:
                    break
                v_t = v_t * alpha
            v_t = v_t * float(self.learning_rate)          # x 1.0 is exact: plain AdaBoost
            feature[t] = f_t
            internal = f_t >= 0
            threshold[t, internal] = edges[f_t[internal], b_t[internal] - 1]
            value[t] = v_t
            margin += ysign * v_t[leaf_of]
            n_trained = t + 1
            log_w = log_w0 - margin
            top = log_w.max()
            log_loss = top + np.log(np.exp(log_w - top).sum())
            with np.errstate(over="ignore", under="ignore"):
                losses[t] = np.exp(log_loss)
            if log_loss < np.log(_MIN_LOSS):
                break
        if n_trained == 0:
            raise ValueError("the first tree's weighted error is 1/2 or more; discrete "
                             "AdaBoost cannot learn from these features")

        self.classes_ = classes
        self.n_estimators_ = n_trained
        self.feature_ = feature[:n_trained]
        self.threshold_ = threshold[:n_trained]
        self.value_ = value[:n_trained]
        self.train_loss_ = losses[:n_trained]
        self.cascade_scale_ = np.ones(n_trained)
        return self

    # ------------------------------------------------------------------ evaluation
    @property
    def used_features_(self):
        """Sorted indices of the features read by any tree, ``(n_used,)`` intp ndarray.

        Only these rows of a remapping matrix ``G`` are needed at run time
        (:meth:`decision_function_remapped`).
        """
        check_is_fitted(self, "feature_")
        return np.unique(self.feature_[self.feature_ >= 0]).astype(np.intp)

    def decision_function(self, X):
        """Boosted score with the soft cascade (higher = positive class).

        Parameters
        ----------
        X : (n_samples, n_features) array_like

        Returns
        -------
        scores : (n_samples,) float64 ndarray
            :math:`H_T(x)`, or :math:`H_t(x)` at the first ``t`` where
            :math:`H_t(x) \\le` ``cascade_threshold``.
        """
        check_is_fitted(self)
        X = validate_data(self, X, dtype=np.float64, reset=False)
        return self._scores(X, self.feature_, self.n_estimators_)

    def predict(self, X):
        """Class labels: ``classes_[1]`` where the score is > 0.

        Parameters
        ----------
        X : (n_samples, n_features) array_like

        Returns
        -------
        labels : (n_samples,) ndarray
        """
        scores = self.decision_function(X)
        return self.classes_[(scores > 0).astype(np.intp)]

    def staged_decision_function(self, X):
        """Scores after each of ``stages`` trees (as if the model stopped there).

        Parameters
        ----------
        X : (n_samples, n_features) array_like

        Yields
        ------
        scores : (n_samples,) float64 ndarray
            For each stage ``k`` in ``stages`` with ``k < n_estimators_``, then for
            ``n_estimators_``: the score of the first ``k`` trees, soft cascade included.
            The last one equals :meth:`decision_function`.
        """
        check_is_fitted(self)
        X = validate_data(self, X, dtype=np.float64, reset=False)
        for k in self._stage_ends():
            yield self._scores(X, self.feature_, k)

    def decision_function_remapped(self, X_target, G):
        """Scores of target-view features through a source-from-target remapping.

        Computes ``decision_function((G @ X_target.T).T)`` while evaluating only the rows
        of ``G`` that the trees read (Wang et al. 2017, Sec. 4, Algorithm 2: the
        features are remapped, :math:`f(w) \\to G f(w)`, then classified):

        .. math:: H(G x) = \\sum_t h_t\\big((G_{U} x)\\big), \\qquad
                  U = \\texttt{used\\_features\\_}.

        Parameters
        ----------
        X_target : (n_samples, n_target_features) array_like
            Features computed in the target view.
        G : (n_features_in_, n_target_features) scipy.sparse matrix/array or ndarray
            Maps target-view features to source-view (training-view) features,
            ``x_source ~= G @ x_target``.

        Returns
        -------
        scores : (n_samples,) float64 ndarray
            Bit-identical to ``decision_function((G @ X_target.T).T)`` for a sparse
            ``G`` (same sums in the same order); equal up to rounding for a dense one.
        """
        check_is_fitted(self)
        used = self.used_features_
        if sp.issparse(G):
            G = G.tocsr()
        else:
            G = np.asarray(G)
            if G.dtype == object or not np.issubdtype(G.dtype, np.number):
                raise TypeError(f"G must be a numeric matrix, got dtype {G.dtype}")
        if G.ndim != 2 or G.shape[0] != self.n_features_in_:
            raise ValueError(f"G must have shape ({self.n_features_in_}, n_target_features) "
                             f"(one row per source feature), got {G.shape}")
        X_target = check_array(X_target, dtype=np.float64)
        if X_target.shape[1] != G.shape[1]:
            raise ValueError(f"X_target has {X_target.shape[1]} features but G maps "
                             f"{G.shape[1]} target features")
        if not np.all(np.isfinite(G.data if sp.issparse(G) else G)):
            raise ValueError("G contains NaN or infinite values")
        Gu = G[used]
        Xs = np.asarray(Gu @ X_target.T, dtype=np.float64).T     # (n_samples, n_used)
        # positions of each tree's features within ``used``; leaves stay -1
        cols = np.where(self.feature_ >= 0,
                        np.searchsorted(used, np.maximum(self.feature_, 0)), -1)
        return self._scores(Xs, cols, self.n_estimators_)

    # ------------------------------------------------------------------ storage
    def to_arrays(self):
        """The fitted model as plain data: ``(params, arrays)``.

        ``params`` are the hyper-parameters (JSON-ready; ``random_state`` only when it is
        an int or None -- it seeds training alone -- else None) and ``n_features_in_``;
        ``arrays`` the fitted arrays (``classes_``, ``feature_``, ``threshold_``,
        ``value_``, ``train_loss_``, ``cascade_scale_`` unless all ones, and
        ``feature_names_in_`` as text if fitted on named columns). :meth:`from_arrays` rebuilds the model; nothing needs pickling.
        """
        check_is_fitted(self, "feature_")
        params = {}
        for k, v in self.get_params().items():
            if k == "random_state" and not (v is None or isinstance(v, numbers.Integral)):
                v = None
            elif k == "stages" and v is not None:
                v = [int(s) for s in v]
            elif isinstance(v, numbers.Integral) and not isinstance(v, bool):
                v = int(v)
            elif isinstance(v, numbers.Real) and not isinstance(v, bool):
                v = float(v)
            params[k] = v
        params["n_features_in_"] = int(self.n_features_in_)
        classes = np.asarray(self.classes_)
        if classes.dtype.kind not in "biufU":
            classes = classes.astype(str)
        arrays = dict(classes_=classes, feature_=self.feature_, threshold_=self.threshold_,
                      value_=self.value_, train_loss_=self.train_loss_)
        if np.any(self.cascade_scale_ != 1.0):
            arrays["cascade_scale_"] = self.cascade_scale_
        if hasattr(self, "feature_names_in_"):
            arrays["feature_names_in_"] = np.asarray(self.feature_names_in_, dtype=str)
        return params, arrays

    @classmethod
    def from_arrays(cls, params: dict, arrays: dict) -> "AdaBoostTrees":
        """The fitted model :meth:`to_arrays` gave; ``ValueError`` for unknown parameters
        or missing, mis-shaped or out-of-range arrays."""
        params = dict(params)
        n_in = params.pop("n_features_in_", None)
        unknown = set(params) - set(cls().get_params())
        if unknown:
            raise ValueError(f"unknown AdaBoostTrees parameters {sorted(unknown)}")
        model = cls(**params)
        n_max, depth, _, _ = model._checked_params()
        if isinstance(n_in, bool) or not isinstance(n_in, int) or n_in < 1:
            raise ValueError(f"n_features_in_ must be a positive integer, got {n_in!r}")

        def get(key, kinds):
            a = arrays.get(key)
            if a is None or np.asarray(a).dtype.kind not in kinds:
                raise ValueError(f"the stored AdaBoostTrees lacks its {key} array")
            return np.asarray(a)

        feature = get("feature_", "iu")
        n_nodes = 2 ** (depth + 1) - 1
        if feature.ndim != 2 or feature.shape[1] != n_nodes or not 1 <= len(feature) <= n_max:
            raise ValueError(f"feature_ has shape {feature.shape}, not (<= {n_max}, {n_nodes})")
        if feature.size and (feature.min() < -1 or feature.max() >= n_in):
            raise ValueError(f"feature_ holds features outside -1..{n_in - 1}")
        threshold, value = get("threshold_", "f"), get("value_", "f")
        loss, classes = get("train_loss_", "f"), get("classes_", "biufU")
        if threshold.shape != feature.shape or value.shape != feature.shape \
                or loss.shape != feature.shape[:1] or classes.shape != (2,):
            raise ValueError("threshold_, value_, train_loss_ or classes_ do not match "
                             "feature_'s shape")
        if np.isnan(threshold).any() or not np.all(np.isfinite(value)):
            raise ValueError("threshold_ or value_ holds NaN or infinite values")
        scale = np.ones(len(feature)) if "cascade_scale_" not in arrays \
            else get("cascade_scale_", "f")
        if scale.shape != feature.shape[:1] or not np.all(np.isfinite(scale) & (scale > 0)):
            raise ValueError(f"cascade_scale_ must be {len(feature)} positive finite factors")
        model.n_features_in_ = n_in
        if "feature_names_in_" in arrays:
            names = get("feature_names_in_", "U")
            if names.shape != (n_in,):
                raise ValueError(f"feature_names_in_ has shape {names.shape}, not ({n_in},)")
            model.feature_names_in_ = names.astype(object)
        model.classes_ = classes
        model.n_estimators_ = int(len(feature))
        model.feature_ = np.ascontiguousarray(feature, dtype=np.int32)
        model.threshold_ = np.ascontiguousarray(threshold, dtype=np.float64)
        model.value_ = np.ascontiguousarray(value, dtype=np.float64)
        model.train_loss_ = np.ascontiguousarray(loss, dtype=np.float64)
        model.cascade_scale_ = np.ascontiguousarray(scale, dtype=np.float64)
        return model

    def _stage_ends(self):
        T = self.n_estimators_
        stages = check_stages(self.stages, check_int(self.n_estimators, "n_estimators", minimum=1))
        ends = [k for k in stages if k < T]
        return ends + [T]

    def _scores(self, X, feature, n_trees):
        """Running sums of tree outputs over the first ``n_trees`` trees, soft cascade.

        ``X`` columns are indexed by ``feature``. Per sample the arithmetic is the plain
        sequential sum ``((h_1 + h_2) + h_3) + ...`` (a compiled loop,
        :meth:`gathered_scores`), so cascade / no cascade, truncated
        / full and remapped / direct evaluations agree bit for bit on the trees they share.
        """
        X = np.ascontiguousarray(X, dtype=np.float64)
        n, m = X.shape
        return self.gathered_scores(X.ravel(), np.arange(n, dtype=np.int64) * m,
                                    np.arange(m, dtype=np.int64), feature=feature,
                                    n_trees=n_trees)

    def gathered_scores(self, x, origin, offset, *, feature=None, n_trees=None):
        """Soft-cascade scores of windows read from one flat array: window ``i``'s feature
        ``f`` is ``x[origin[i] + offset[f]]`` (e.g. windows of a channel map, without
        copying each window out). The same sums as :meth:`decision_function`
        (:func:`viewadapt._tree_kernels.cascade_scores`); ``feature`` replaces the trees'
        feature indices (columns of ``offset``), ``n_trees`` truncates.

        Returns
        -------
        (len(origin),) float64 ndarray
        """
        from ._tree_kernels import cascade_scores

        check_is_fitted(self)
        thr = self.cascade_threshold
        feature = self.feature_ if feature is None else feature
        origin = np.ascontiguousarray(origin, dtype=np.int64).ravel()
        offset = np.ascontiguousarray(offset, dtype=np.int64).ravel()
        depth = (self.feature_.shape[1] + 1).bit_length() - 2
        return cascade_scores(np.ascontiguousarray(x).ravel(), origin, offset,
                              np.ascontiguousarray(feature, dtype=np.int64),
                              np.ascontiguousarray(self.threshold_, dtype=np.float64),
                              np.ascontiguousarray(self.value_, dtype=np.float64), depth,
                              int(self.n_estimators_ if n_trees is None else n_trees),
                              0.0 if thr is None else float(thr), thr is not None,
                              np.ascontiguousarray(self.cascade_scale_, dtype=np.float64),
                              np.empty(origin.shape[0]))


# ---------------------------------------------------------------------- helpers
def cascade_step(score, h, threshold, scale=None):
    """Add a block of tree outputs to running scores, with the soft cascade.

    Parameters
    ----------
    score : (n,) ndarray, running scores before the block.
    h : (n, t) ndarray, outputs of the block's ``t`` trees, in order.
    threshold : float or None
        Cascade threshold; a sample stops at the first tree whose running score is
        ``<= threshold`` (acfDetect1: ``if (h <= cascThr) break``) and keeps that score.
    scale : (t,) ndarray or None
        The block's ``cascade_scale_``: the running score after tree ``k`` is multiplied by
        ``scale[k]`` before the comparison, and a stopped sample keeps the product.

    Returns
    -------
    score : (n,) ndarray, the running scores after the block (or at the stop).
    stopped : (n,) bool ndarray, samples that stopped inside the block.

    The running score is a sequential cumulative sum, so blocked, truncated and remapped
    evaluations agree bit for bit on the trees they share.
    """
    run = np.cumsum(np.concatenate([score[:, None], h], axis=1), axis=1)[:, 1:]
    if threshold is None:
        return run[:, -1], np.zeros(len(run), bool)
    scaled = run if scale is None else run * np.asarray(scale, np.float64)[None, :]
    below = scaled <= threshold
    stopped = below.any(axis=1)
    first = np.argmax(below, axis=1)
    return np.where(stopped, scaled[np.arange(len(run)), first], run[:, -1]), stopped
