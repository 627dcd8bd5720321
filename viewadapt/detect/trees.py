"""The adapted boosted trees (ACF) of every candidate window of a camera, as one operator.

For boosted trees ``G`` cannot be folded into the model, but only the rows of ``G`` that
the trees read are needed (Wang et al. 2017, Algorithm 2): each template group keeps
``G[used]``. At run time each distinct window position walks the trees in order until the
soft cascade (Dollár's ``acfDetect``) stops it, and a remapped feature ``(G_n x)_f`` is
computed only at the nodes it reaches -- one short dot product over a few frame cells, in
a compiled loop (:func:`viewadapt._kernels.tree_cascade_scores`, numba) that walks the
positions of one group together.

References
----------
.. [1] P. Wang, K. Morton, P. Torrione, L. Collins, "Viewpoint Adaptation for Rigid Object
   Detection", arXiv preprint, 2017.
.. [2] P. Dollár, R. Appel, S. Belongie, P. Perona, "Fast Feature Pyramids for Object
   Detection", IEEE TPAMI 36(8), 2014.
"""

from __future__ import annotations

from functools import partial

import numpy as np
import scipy.sparse as sp

from ..arrays import stored_array, under_prefix, with_prefix
from ..boosting import AdaBoostTrees
from .acf_channels import acf_frame_features
from .channels import (
    ACF_GRADIENT_LAMBDA, ACF_SHRINK, ACF_WEIGHT_SHAPE, N_ACF_CHANNELS, FrameFeatures,
)
from .frame_remap import (
    acf_frame_remap, acf_gradient_rows, resolve_object_model, window_mapping,
)
from .templates import (
    ACF_TOLERANCE, CELLS_PER_SOURCE_CELL, FRAME_CELL_SIZES, TemplateOperator, build_template_groups,
    check_windows, choose_cell_sizes, required_padding,
)
from .windows import CandidateWindows

__all__ = ["AdaptedTreesOperator", "build_adapted_trees_operator"]


class AdaptedTreesOperator(TemplateOperator):
    """Per-window adapted boosted trees (ACF) of one camera.

    Each group holds the rows of its ``G`` that the trees read (``G[used]``). At run time
    each distinct window position walks the trees in order until the soft cascade stops it
    (Wang et al. 2017, Algorithm 2 with the toolbox's ``acfDetect`` cascade; a compiled
    loop, :meth:`scores`), and a remapped feature ``(G_n x)_f`` is computed only for the
    nodes a position reaches: one short dot product over a few frame cells (a row of
    ``G``). Most positions are rejected after the first few trees, so few features are
    computed per position.
    """

    source_cell = ACF_SHRINK
    frame_feature_makers = (acf_frame_features,)

    nms_overlap, nms_threshold = "min", 0.65

    def __init__(self, windows, cell_size, groups, pad, model, features):
        self._setup(windows, cell_size, groups, pad)
        self.features = features
        self._set_model(model)

    def _set_model(self, model):
        self.model = model
        used = model.used_features_
        self.used = used
        feat = model.feature_
        #: per tree and node: the column in ``used`` of its feature (-1 at a leaf), its
        #: threshold and value; the trees' depth and cascade scales
        self.tree_nodes = np.where(feat >= 0, np.searchsorted(used, np.maximum(feat, 0)), -1)
        self.tree_thresholds = model.threshold_
        self.tree_values = model.value_
        self.tree_scales = np.ascontiguousarray(model.cascade_scale_, np.float64)
        self.tree_depth = (feat.shape[1] + 1).bit_length() - 2

    def frame_features(self, image) -> FrameFeatures:
        return self.features(image)

    def scores(self, features: FrameFeatures) -> np.ndarray:
        """Soft-cascade scores of all windows: a compiled loop over the distinct positions,
        each walking the trees in order until the cascade stops it and computing a
        remapped feature only at the nodes it reaches.

        Returns
        -------
        (N,) float64 ndarray
        """
        from .._kernels import tree_cascade_scores

        self.check_features(features)
        pos_of, pos_group, pos_origin, (n_groups, indptr, offsets, weights) = self.run_tables()
        thr = self.model.cascade_threshold
        out = np.empty(len(pos_group))
        tree_cascade_scores(features.vector(self.cell_sizes), pos_group, pos_origin, n_groups,
                            indptr, offsets, weights, self.tree_nodes, self.tree_thresholds,
                            self.tree_values, self.tree_depth,
                            0.0 if thr is None else float(thr), thr is not None,
                            self.tree_scales, out)
        return out[pos_of]

    def gather_tables(self):
        """Distinct scored positions and, per used feature, each group's row of ``G`` as
        a ragged list of (offset, weight) pairs over the frame feature vector.

        Returns ``(pos_of, pos_group, pos_origin, rows)``: ``pos_of`` (N,) the position of
        each window; ``pos_group`` / ``pos_origin`` (P,) each position's group and the
        index of its patch's top-left entry in :meth:`FrameFeatures.vector`;
        ``rows[f] = (indptr, offsets, weights)``, the CSR rows of feature ``f`` of all
        groups: group ``g``'s row is ``offsets[indptr[g]:indptr[g + 1]]`` (int32, relative
        to a position's origin) with its ``weights`` (float32).
        """
        w, h = self.image_size
        p = self.pad
        C = N_ACF_CHANNELS
        start_of, Nx_of, off = {}, {}, 0
        for c in self.cell_sizes:
            ny, nx = h // c + 2 * p, w // c + 2 * p
            start_of[c], Nx_of[c] = off, nx
            off += ny * nx * C
        pos_of = np.empty(self.n_windows, np.intp)
        pos_group, pos_origin, per_group = [], [], []
        n_pos = 0
        for gi, g in enumerate(self.groups):
            Nx = Nx_of[g.cell_size]
            oy = g.origin[1] + g.shifts[:, 1] + p
            ox = g.origin[0] + g.shifts[:, 0] + p
            start, inv = np.unique(start_of[g.cell_size] + (oy * Nx + ox) * C,
                                   return_inverse=True)
            pos_of[g.members] = n_pos + inv.ravel()
            pos_group.append(np.full(len(start), gi, np.int32))
            pos_origin.append(start)
            n_pos += len(start)
            G = sp.csr_matrix(g.template)
            G.eliminate_zeros()              # S (x) A stores zeros where A has none
            G.sort_indices()
            yy, rem = np.divmod(G.indices, g.shape[1] * C)
            xx, cc = np.divmod(rem, C)
            per_group.append((G.indptr, ((yy * Nx + xx) * C + cc).astype(np.int32),
                              G.data.astype(np.float32)))
        # one CSR over (feature, group) rows: row f * n_groups + g
        n_groups = len(per_group)
        lens = np.array([[ip[f + 1] - ip[f] for ip, _, _ in per_group]
                         for f in range(len(self.used))], np.int64).ravel()
        indptr = np.r_[0, np.cumsum(lens)]
        offsets = np.concatenate([b[ip[f]:ip[f + 1]] for f in range(len(self.used))
                                  for ip, b, _ in per_group]).astype(np.int32)
        weights = np.concatenate([d[ip[f]:ip[f + 1]] for f in range(len(self.used))
                                  for ip, _, d in per_group]).astype(np.float32)
        return (pos_of, np.concatenate(pos_group), np.concatenate(pos_origin).astype(np.int64),
                (n_groups, indptr, offsets, weights))

    def run_tables(self):
        """:meth:`gather_tables`, built once (offline by the builder; here for operators
        made without it)."""
        if getattr(self, "_tables", None) is None:
            self._tables = self.gather_tables()
        return self._tables

    def to_arrays(self):
        """The operator as ``(meta, arrays)``: JSON-ready metadata and plain arrays (its
        stored form, :class:`~viewadapt.io.cache.OperatorCache`): the groups'
        geometry, the model (``model/*``, :meth:`AdaBoostTrees.to_arrays`), each group's
        ``G[used]`` as CSR parts concatenated (``G_indptr``: ``n_used + 1`` entries per
        group, ``G_nnz_ptr`` (G + 1,) offsets into ``G_indices`` / ``G_data``), the window
        scaling and the run tables (``table_*``, :meth:`gather_tables`), so that a loaded
        operator needs no rebuilding."""
        meta, arrays = self._geometry_to_arrays()
        params, model_arrays = self.model.to_arrays()
        meta["model"] = params
        arrays.update(with_prefix("model/", model_arrays))
        Gs = [sp.csr_matrix(g.template) for g in self.groups]
        arrays.update(G_indptr=np.concatenate([G.indptr for G in Gs]).astype(np.int64),
                      G_nnz_ptr=np.r_[0, np.cumsum([G.nnz for G in Gs])].astype(np.int64),
                      G_indices=np.concatenate([G.indices for G in Gs]).astype(np.int32),
                      G_data=np.concatenate([G.data for G in Gs]))
        if hasattr(self, "gradient_factor"):
            arrays["gradient_factor"] = self.gradient_factor
        pos_of, pos_group, pos_origin, (n_groups, indptr, offsets, weights) = self.run_tables()
        arrays.update(table_pos_of=pos_of, table_pos_group=pos_group,
                      table_pos_origin=pos_origin, table_indptr=indptr,
                      table_offsets=offsets, table_weights=weights)
        return meta, arrays

    @classmethod
    def from_arrays(cls, meta: dict, arrays: dict) -> "AdaptedTreesOperator":
        """The operator :meth:`to_arrays` gave, after checking every table's shape and
        that every index lies within its array (so the compiled loop never reads outside
        them); ``ValueError`` otherwise."""
        op = cls.__new__(cls)
        op._geometry_from_arrays(meta, arrays)
        if not isinstance(meta.get("model"), dict):
            raise ValueError("it lacks its model's parameters")
        op._set_model(AdaBoostTrees.from_arrays(meta["model"], under_prefix("model/", arrays)))
        n, G, n_used, C = op.n_windows, len(op.groups), len(op.used), N_ACF_CHANNELS
        shape = np.array([g.shape for g in op.groups], np.int64)
        n_cols = shape.prod(1) * C
        # the groups' G[used]
        ip = stored_array(arrays, "G_indptr", "iu", shape=(G * (n_used + 1),))
        ip = ip.reshape(G, n_used + 1).astype(np.int64)
        nnz = stored_array(arrays, "G_nnz_ptr", "iu", shape=(G + 1,)).astype(np.int64)
        ind = stored_array(arrays, "G_indices", "iu", ndim=1)
        data = stored_array(arrays, "G_data", "f", shape=ind.shape)
        if nnz[0] != 0 or nnz[-1] != len(ind) or (np.diff(nnz) < 0).any() \
                or (ip[:, 0] != 0).any() or (np.diff(ip, axis=1) < 0).any() \
                or (ip[:, -1] != np.diff(nnz)).any():
            raise ValueError("its G_indptr or G_nnz_ptr do not split G_indices into groups")
        col_end = np.repeat(n_cols, np.diff(nnz))
        if len(ind) and (ind.min() < 0 or (ind >= col_end).any()):
            raise ValueError("its G_indices lie outside the groups' patches")
        for i, g in enumerate(op.groups):
            s = slice(nnz[i], nnz[i + 1])
            g.template = sp.csr_matrix((data[s], ind[s], ip[i]), shape=(n_used, n_cols[i]))
        if "gradient_factor" in arrays:
            op.gradient_factor = stored_array(arrays, "gradient_factor", "f", shape=(n,))
        # the run tables
        pos_of = stored_array(arrays, "table_pos_of", "iu", shape=(n,))
        pos_group = stored_array(arrays, "table_pos_group", "iu", ndim=1)
        n_pos = len(pos_group)
        origin = stored_array(arrays, "table_pos_origin", "iu", shape=(n_pos,))
        indptr = stored_array(arrays, "table_indptr", "iu", shape=(n_used * G + 1,))
        offsets = stored_array(arrays, "table_offsets", "iu", ndim=1)
        weights = stored_array(arrays, "table_weights", "f", shape=offsets.shape)
        if not n_pos or pos_of.min() < 0 or pos_of.max() >= n_pos or pos_group.min() < 0 \
                or pos_group.max() >= G or indptr[0] != 0 or indptr[-1] != len(offsets) \
                or (np.diff(indptr) < 0).any():
            raise ValueError("its run tables do not match its groups")
        # an entry of group g's rows lies inside g's patch; a patch at each position inside
        # the frame's feature vector
        start, nx_map, size = {}, {}, 0
        w, h = op.image_size
        for c in op.cell_sizes:
            start[c], nx_map[c] = size, w // c + 2 * op.pad
            size += (h // c + 2 * op.pad) * nx_map[c] * C
        span = np.array([((g.shape[0] - 1) * nx_map[g.cell_size] + g.shape[1]) * C
                         for g in op.groups], np.int64)
        entry_group = np.repeat(np.arange(n_used * G) % G, np.diff(indptr))
        if len(offsets) and (offsets.min() < 0 or (offsets >= span[entry_group]).any()):
            raise ValueError("its run tables read outside the groups' patches")
        if origin.min() < 0 or (origin + span[pos_group] > size).any():
            raise ValueError("its run tables read outside the frame's feature vector")
        op._tables = (np.ascontiguousarray(pos_of, np.intp),
                      np.ascontiguousarray(pos_group, np.int32),
                      np.ascontiguousarray(origin, np.int64),
                      (G, np.ascontiguousarray(indptr, np.int64),
                       np.ascontiguousarray(offsets, np.int32),
                       np.ascontiguousarray(weights, np.float32)))
        return op


def build_adapted_trees_operator(windows: CandidateWindows, model, *,
                                 tolerance: float = ACF_TOLERANCE,
                                 cells_per_source_cell: float = CELLS_PER_SOURCE_CELL,
                                 allowed_cell_sizes=FRAME_CELL_SIZES,
                                 rule: str = "covariant",
                                 gradient_lambda: float = ACF_GRADIENT_LAMBDA,
                                 acf_kwargs=None, object_model="plane") -> AdaptedTreesOperator:
    """Precompute ``G[used]`` of every window for an ACF boosted-trees model.

    Parameters
    ----------
    windows : CandidateWindows
    model : viewadapt.boosting.AdaBoostTrees
        Fitted on source-view ACF features ``acf_channels(window).ravel()`` (layout
        ``(10, 32, 16)``).
    tolerance, cells_per_source_cell, allowed_cell_sizes, rule
        As :func:`build_adapted_linear_operator`; cells are sized on the 4-px blocks, so
        the default tolerance of 1 cell is about the pixel tolerance of HOG's 0.5 cell.
    gradient_lambda : float
        Power-law scaling of the gradient channels (magnitude and orientations): the rows
        of ``G`` that produce them are multiplied by ``s ** gradient_lambda``, ``s`` the
        window's frame pixels per canonical pixel (:data:`ACF_GRADIENT_LAMBDA`); 0 turns it
        off. Colour channels are intensive and need no scaling.
    acf_kwargs : dict, optional
        Passed to :func:`acf_frame_features`.
    object_model : {"plane", "body"} or an object model
        As :func:`build_adapted_linear_operator`.

    Returns
    -------
    AdaptedTreesOperator
    """
    check_windows(windows)
    n_src = int(np.prod(ACF_WEIGHT_SHAPE))
    if getattr(model, "n_features_in_", None) != n_src:
        raise ValueError(f"model must be fitted on {n_src} ACF features (10 x 32 x 16), got "
                         f"{getattr(model, 'n_features_in_', None)}")
    cell = choose_cell_sizes(windows.scale, ACF_SHRINK,
                             cells_per_source_cell=cells_per_source_cell,
                             allowed=allowed_cell_sizes)
    if not np.isfinite(gradient_lambda):
        raise ValueError(f"gradient_lambda must be finite, got {gradient_lambda!r}")
    shape_model = resolve_object_model(object_model)
    groups = build_template_groups(windows, cell, tolerance)
    used = model.used_features_
    gradient_row = acf_gradient_rows()
    scale = windows.scale
    factor = np.ones(len(windows))
    for g in groups:
        G = acf_frame_remap(window_mapping(windows, g.prototype, shape_model), g, rule)
        if gradient_lambda:
            factor[g.members] = scale[g.prototype] ** gradient_lambda
            G = sp.diags(np.where(gradient_row, factor[g.prototype], 1.0)) @ G
        Gu = sp.csr_matrix(sp.csr_matrix(G)[used])
        Gu.eliminate_zeros()
        g.template = Gu
    pad = required_padding(groups, windows.image_size)
    make_features = partial(acf_frame_features, cell_sizes=sorted(set(cell.tolist())), pad=pad,
                            image_size=tuple(windows.image_size), **dict(acf_kwargs or {}))
    op = AdaptedTreesOperator(windows, cell, groups, pad, model, make_features)
    op.tolerance = float(tolerance)
    op.gradient_factor = factor               # (N,) s ** gradient_lambda of each window
    op._tables = op.gather_tables()          # the run-time form, built once offline
    return op

