"""Classifier adaptation (Wang et al. 2017, Sec. 4): fold ``G`` into a trained detector.

Three ways, by how the detector's features relate to the remappable cells:

* **Linear in the cells** (raw or locally normalised HOG cells, ACF channels with a linear
  model): ``w' = G^T w`` -- exact and offline, eq. (5)-(7). :func:`adapt_linear_weights`.
* **Block-normalised HOG** (the Dalal-Triggs descriptor) is not linear in the cells. We
  remap the cells first and normalise the blocks after, at run time:
  ``score = w^T N(G x_t)`` (:func:`remap_cells_to_descriptor`). The alternative that stays
  linear -- train on locally normalised cells (:func:`viewadapt.hog.locally_normalize_channels`,
  a window-independent normalisation) and fold ``G`` into the weights -- is offered by
  ``representation="linear"`` with ``hog_cells(..., normalize="local")`` features.
* **Nonlinear** (boosted trees over ACF): remap only the features the trees use, i.e. the
  rows ``G[used]``, at run time (:class:`ViewpointAdaptedClassifier` calls the estimator's
  ``decision_function_remapped`` when it has one).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from sklearn.base import BaseEstimator, ClassifierMixin, clone
from sklearn.utils.validation import check_is_fitted, validate_data

from .geometry import WINDOW_HEIGHT, WINDOW_WIDTH, elevation_homography
from .hog import normalize_blocks_l2hys
from .mapping import mapping_remap_matrix
from .remap import CellGrid, feature_remap_matrix

__all__ = [
    "adapt_linear_weights",
    "hog_remap_matrix",
    "acf_remap_matrix",
    "elevation_remap_matrix",
    "remap_cells_to_descriptor",
    "remap_features",
    "cells_to_descriptor",
    "ViewpointAdaptedClassifier",
]


def adapt_linear_weights(weights, G) -> np.ndarray:
    """Adapt linear weights to the target view: ``w' = G^T w`` (eq. (7)).

    Parameters
    ----------
    weights : (n_source_features,) array_like
    G : (n_source_features, n_target_features) sparse matrix or ndarray

    Returns
    -------
    (n_target_features,) ndarray such that ``w'^T x_t == w^T (G x_t)`` for every ``x_t``.
    """
    w = np.asarray(weights, dtype=np.float64)
    if w.ndim != 1:
        raise ValueError(f"weights must be a vector, got shape {w.shape}")
    if G.shape[0] != w.shape[0]:
        raise ValueError(
            f"G maps into {G.shape[0]} source features but the weights have {w.shape[0]}"
        )
    return np.asarray(G.T @ w).ravel()


def _remap_matrix(H_st, out_grid, in_grid, **kw):
    """``G`` through a homography, or through a general mapping when ``H_st`` is callable."""
    if callable(H_st):
        return mapping_remap_matrix(H_st, out_grid, in_grid, folds="drop", **kw)
    return feature_remap_matrix(H_st, out_grid, in_grid, **kw)


def hog_remap_matrix(H_st, *, source_cell_size: int = 8, target_cell_size: int = 8,
                     window=(WINDOW_WIDTH, WINDOW_HEIGHT), n_bins: int = 9,
                     rule: str = "covariant", per_cell: bool = True, target_grid=None,
                     preserve: str = "sum", n_plain: int = 0) -> sp.csr_matrix:
    """``G`` for HOG cell features of one window: target cells -> source cells.

    Parameters
    ----------
    H_st : (3, 3) array_like or callable
        Source-window pixels -> target-window pixels: a homography (the planar model) or
        any point mapping (:mod:`viewadapt.mapping`, e.g. from
        :func:`viewadapt.objectmodel.crop_view_mapping`); a mapping's pieces that fold over
        are dropped.
    source_cell_size, target_cell_size : int
        Cell sizes of the classifier (source) and of the target features (a finer target
        grid, e.g. 4 px, resamples more accurately).
    target_grid : CellGrid, optional
        The target cells instead of the window's ``target_cell_size`` grid, e.g. a patch of
        a frame's cells (:mod:`viewadapt.detect`).
    preserve : {"sum", "mean"}
        Cell histograms are sums over their pixels (``"sum"``, raw HOG cells) or intensive
        values (``"mean"``, e.g. block-normalised cells): area-weighted sums or means.
    n_plain : int
        Channels per cell after the ``n_bins`` orientations that are resampled by ``S``
        alone (e.g. texture energies).

    Returns
    -------
    G : sparse (n_src_cells * (n_bins + n_plain), n_tgt_cells * (n_bins + n_plain)),
        layouts of ``hog_cells(...).ravel()`` (cell-major, channels last).
    """
    w, h = window
    if target_grid is None:
        target_grid = CellGrid.for_window(w, h, target_cell_size)
    return _remap_matrix(H_st, CellGrid.for_window(w, h, source_cell_size), target_grid,
                         n_bins=n_bins, rule=rule, per_cell=per_cell, preserve=preserve,
                         n_plain=n_plain)


def _bin_major_permutation(n_cells: int, n_bins: int) -> sp.csr_matrix:
    """P with ``P @ x_cellmajor == x_binmajor`` for (cell, bin) -> (bin, cell) layouts."""
    idx = np.arange(n_cells * n_bins).reshape(n_cells, n_bins).T.ravel()
    return sp.csr_matrix((np.ones(idx.size), (np.arange(idx.size), idx)),
                         shape=(idx.size, idx.size))


def acf_remap_matrix(H_st, *, shrink: int = 4, window=(WINDOW_WIDTH, WINDOW_HEIGHT),
                     n_color: int = 4, n_orients: int = 6, rule: str = "covariant",
                     per_cell: bool = True, target_grid=None,
                     target_layout: str = "channels_first") -> sp.csr_matrix:
    """``G`` for ACF channels of one window, source layout ``(channel, y, x)``; ``H_st`` a
    homography or a point mapping, as for :func:`hog_remap_matrix`.

    The first ``n_color`` channels (LUV and gradient magnitude) are per-pixel averages
    over each ``shrink`` block and are resampled by area-weighted means (``S`` with
    ``preserve="mean"``); the ``n_orients`` orientation channels (hard-binned over 180
    degrees) also get the orientation resampling ``A``.

    Parameters
    ----------
    target_grid : CellGrid, optional
        The target blocks instead of the window's ``shrink`` grid (e.g. a frame patch).
    target_layout : {"channels_first", "channels_last"}
        Layout of the target features: ``(channel, y, x)`` as :func:`viewadapt.acf.acf_channels`,
        or ``(y, x, channel)`` as a frame's cell maps.

    Returns
    -------
    G : sparse (C h w, C n_target_cells) with ``C = n_color + n_orients``, ``h, w`` the
        window's size over ``shrink``.
    """
    if target_layout not in ("channels_first", "channels_last"):
        raise ValueError(f"target_layout must be 'channels_first' or 'channels_last', "
                         f"got {target_layout!r}")
    w, h = window
    grid = CellGrid.for_window(w, h, shrink)
    in_grid = grid if target_grid is None else target_grid
    S = _remap_matrix(H_st, grid, in_grid, n_bins=1, preserve="mean")
    # ACF orientation bin k is centred on k pi / n_orients (viewadapt.acf)
    GO = _remap_matrix(H_st, grid, in_grid, n_bins=n_orients, rule=rule,
                       per_cell=per_cell, preserve="mean", bin_offset=-0.5)
    GO = (_bin_major_permutation(grid.n_cells, n_orients) @ GO
          @ _bin_major_permutation(in_grid.n_cells, n_orients).T)    # -> (bin, cell) layout
    G = sp.block_diag([S] * n_color + [GO], format="csr")
    if target_layout == "channels_last":
        G = (G @ _bin_major_permutation(in_grid.n_cells, n_color + n_orients)).tocsr()
    return G


def elevation_remap_matrix(source_elevation: float, target_elevation: float, *,
                           features: str = "hog", distance: float = 10.0,
                           **kwargs) -> sp.csr_matrix:
    """``G`` between two elevations of the cropped-window set-up.

    Parameters
    ----------
    source_elevation, target_elevation : float
        Radians in ``[0, pi/2)``.
    features : {"hog", "acf"}
    distance : float
        Camera distance of the crop set-up (see :func:`viewadapt.geometry.crop_camera`).
    **kwargs
        Passed to :func:`hog_remap_matrix` or :func:`acf_remap_matrix`.
    """
    H = elevation_homography(source_elevation, target_elevation, distance=distance)
    if features == "hog":
        return hog_remap_matrix(H, **kwargs)
    if features == "acf":
        return acf_remap_matrix(H, **kwargs)
    raise ValueError(f"features must be 'hog' or 'acf', got {features!r}")


#: windows per block of :func:`cells_to_descriptor`: its block arrays stay in the cache
_DESCRIPTOR_CHUNK = 128


def cells_to_descriptor(cells, cell_shape=(16, 8, 9)) -> np.ndarray:
    """Dalal-Triggs descriptors from flattened cell histograms.

    Parameters
    ----------
    cells : (n_cells * n_bins,) or (n_windows, n_cells * n_bins) array_like
    cell_shape : (n_y, n_x, n_bins)

    Returns
    -------
    (D,) or (n_windows, D) ndarray in OpenCV's layout.
    """
    X = np.asarray(cells)
    single = X.ndim == 1
    X = np.atleast_2d(X)
    if X.shape[1] != int(np.prod(cell_shape)):
        raise ValueError(f"cells have {X.shape[1]} values, cell_shape {cell_shape} needs "
                         f"{int(np.prod(cell_shape))}")
    ny, nx, B = cell_shape
    out = np.empty((len(X), (nx - 1) * (ny - 1) * 4 * B))
    # blocks [n, block_x, block_y, cell (2 cx + cy), bin], as viewadapt.hog.cells_to_blocks,
    # written straight into that layout, C-contiguous (the reshapes below are then free);
    # a block of windows at a time (each window's numbers do not depend on the others)
    blocks = np.empty((min(len(X), _DESCRIPTOR_CHUNK), nx - 1, ny - 1, 4, B))
    for a in range(0, len(X), _DESCRIPTOR_CHUNK):
        part = np.asarray(X[a:a + _DESCRIPTOR_CHUNK], dtype=np.float64)
        m = len(part)
        C = part.reshape(m, ny, nx, B).transpose(0, 2, 1, 3)      # [n, x, y, bin]
        b = blocks[:m]
        for k, (dx, dy) in enumerate(((0, 0), (0, 1), (1, 0), (1, 1))):
            b[:, :, :, k] = C[:, dx:nx - 1 + dx, dy:ny - 1 + dy]
        out[a:a + m] = normalize_blocks_l2hys(b).reshape(m, -1)
    return out[0] if single else out


def remap_features(G, X) -> np.ndarray:
    """``(G @ X.T).T``: every row of ``X`` (target-view features) remapped by ``G``.

    A compiled loop over the rows of ``X`` (:func:`viewadapt._kernels.csr_rows_product`):
    float64 sums over each row of ``G`` in CSR order, the numbers of scipy's product
    ``G @ X.T`` without its transposed copies.

    Parameters
    ----------
    G : (n_source, n_target) sparse matrix (used as CSR)
    X : (n, n_target) or (n_target,) array_like, float32 or float64

    Returns
    -------
    (n, n_source) float64 ndarray
    """
    from ._kernels import csr_rows_product

    G = sp.csr_matrix(G)
    X = np.atleast_2d(np.asarray(X))
    if X.dtype not in (np.float32, np.float64):
        X = X.astype(np.float64)
    X = np.ascontiguousarray(X)
    if X.shape[1] != G.shape[1]:
        raise ValueError(f"features have {X.shape[1]} values, G has {G.shape[1]} columns")
    out = np.empty((X.shape[0], G.shape[0]))
    return csr_rows_product(G.indptr, G.indices, G.data.astype(np.float64, copy=False), X, out)


def remap_cells_to_descriptor(target_cells, G, source_cell_shape=(16, 8, 9)) -> np.ndarray:
    """Remap target-view cells into the source view, then block-normalise: ``N(G x_t)``."""
    src = remap_features(G, target_cells)
    out = cells_to_descriptor(src, source_cell_shape)
    return out[0] if np.ndim(target_cells) == 1 else out


class ViewpointAdaptedClassifier(ClassifierMixin, BaseEstimator):
    """A source-view classifier that scores target-view features through ``G``.

    ``fit`` trains ``estimator`` on *source-view* features; ``decision_function`` and
    ``predict`` take *target-view* features ``X_t`` and score them as the trained model
    would score ``G X_t``:

    * ``representation="linear"``: if the fitted estimator has ``coef_``/``intercept_``
      the weights are adapted once, ``w' = G^T w`` (zero run-time cost); otherwise, if it
      has ``decision_function_remapped(X_t, G)`` (boosted trees) only the used rows of
      ``G`` are applied; else ``G X_t`` is formed.
    * ``representation="blocks"``: the features are HOG cells; the estimator is trained on
      Dalal-Triggs descriptors of the source cells, and scores ``N(G x_t)``.

    Parameters
    ----------
    estimator : estimator, default LinearSVC
        Any classifier with ``decision_function``.
    remap : sparse matrix or ndarray, optional
        ``G`` (n_source_features x n_target_features). If None, it is built from the
        elevations for HOG cells with the options below; identity when they are equal.
    source_elevation, target_elevation : float
    rule : {"covariant", "paper", "none"}
    per_cell : bool
    target_cell_size : int
        Cell size of the target-view HOG features when ``remap`` is None.
    representation : {"linear", "blocks"}
    cell_shape : tuple
        ``(n_y, n_x, n_bins)`` of the source cells for ``"blocks"``.
    """

    def __init__(self, estimator=None, *, remap=None, source_elevation=0.0,
                 target_elevation=0.0, rule="covariant", per_cell=True, target_cell_size=8,
                 representation="linear", cell_shape=(16, 8, 9)):
        self.estimator = estimator
        self.remap = remap
        self.source_elevation = source_elevation
        self.target_elevation = target_elevation
        self.rule = rule
        self.per_cell = per_cell
        self.target_cell_size = target_cell_size
        self.representation = representation
        self.cell_shape = cell_shape

    # -- helpers -----------------------------------------------------------------------
    def _make_estimator(self):
        if self.estimator is None:
            from sklearn.svm import LinearSVC
            return LinearSVC(C=0.01)
        return clone(self.estimator)

    def _source_features(self, X):
        if self.representation == "blocks":
            return cells_to_descriptor(X, self.cell_shape)
        return X

    def _build_remap(self, n_features):
        if self.remap is not None:
            G = self.remap if sp.issparse(self.remap) else np.asarray(self.remap, float)
            if G.ndim != 2 or G.shape[0] != n_features:
                raise ValueError(f"remap must have {n_features} rows (the source features), "
                                 f"got shape {G.shape}")
            return sp.csr_matrix(G)
        source_cell = WINDOW_WIDTH // self.cell_shape[1]
        if self.source_elevation == self.target_elevation and \
                self.target_cell_size == source_cell:
            return sp.identity(n_features, format="csr")
        G = elevation_remap_matrix(self.source_elevation, self.target_elevation,
                                   rule=self.rule, per_cell=self.per_cell,
                                   source_cell_size=source_cell,
                                   target_cell_size=self.target_cell_size,
                                   n_bins=self.cell_shape[2])
        if G.shape[0] != n_features:
            raise ValueError(f"the HOG remap for cell_shape {self.cell_shape} has {G.shape[0]} "
                             f"source features, but X has {n_features}; pass remap= for "
                             "other feature layouts")
        return G

    def _finish(self, n_features):
        if self.representation not in ("linear", "blocks"):
            raise ValueError(f"representation must be 'linear' or 'blocks', "
                             f"got {self.representation!r}")
        self.remap_ = self._build_remap(n_features)
        est = self.estimator_
        self.adapted_coef_ = None
        if self.representation == "linear" and hasattr(est, "coef_") and \
                np.ndim(est.coef_) <= 2 and np.shape(est.coef_)[0] == 1:
            self.adapted_coef_ = adapt_linear_weights(np.ravel(est.coef_), self.remap_)
            self.adapted_intercept_ = float(np.ravel(est.intercept_)[0])
        self.n_features_in_ = self.remap_.shape[1]
        return self

    # -- sklearn API -------------------------------------------------------------------
    def fit(self, X, y):
        """Train the estimator on source-view features ``X`` and build the adaptation."""
        X, y = validate_data(self, X, y, reset=True)
        from sklearn.utils.multiclass import check_classification_targets
        check_classification_targets(y)
        self.estimator_ = self._make_estimator().fit(self._source_features(X), y)
        self.classes_ = self.estimator_.classes_
        return self._finish(X.shape[1])

    @classmethod
    def from_fitted(cls, estimator, **params) -> "ViewpointAdaptedClassifier":
        """Wrap an already-trained source-view estimator (e.g. OpenCV's people detector)."""
        self = cls(estimator=estimator, **params)
        self.estimator_ = estimator
        self.classes_ = getattr(estimator, "classes_", np.array([0, 1]))
        if hasattr(estimator, "coef_"):
            n = np.shape(estimator.coef_)[-1]
        elif self.remap is not None:
            n = self.remap.shape[0]
        else:
            n = getattr(estimator, "n_features_in_")
        if self.representation == "blocks":
            n = int(np.prod(self.cell_shape))
        return self._finish(n)

    def decision_function(self, X):
        """Scores of target-view features ``X`` (n_samples, n_target_features), higher =
        positive class."""
        check_is_fitted(self, "estimator_")
        X = validate_data(self, X, reset=False)
        if self.adapted_coef_ is not None:
            return X @ self.adapted_coef_ + self.adapted_intercept_
        if self.representation == "linear" and hasattr(self.estimator_,
                                                       "decision_function_remapped"):
            return self.estimator_.decision_function_remapped(X, self.remap_)
        src = np.asarray((self.remap_ @ X.T).T)
        return self.estimator_.decision_function(self._source_features(src))

    def predict(self, X):
        check_is_fitted(self, "estimator_")
        scores = np.asarray(self.decision_function(X))
        if scores.ndim == 2:
            return self.classes_[np.argmax(scores, axis=1)]
        return self.classes_[(scores > 0).astype(int)]
