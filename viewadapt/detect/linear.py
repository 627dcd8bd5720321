"""The adapted linear detector of every candidate window of a camera, as one operator.

:func:`build_adapted_linear_operator` folds each template group's ``G`` into the source
weights offline, ``w_g = G_g^T w`` (Wang et al. 2017, eq. (7)); at run time every window's
score is ``w_g^T x + b`` over its patch of the frame's cell maps. The scoring loop is
compiled (:func:`viewadapt._kernels.template_run_scores`, numba): it visits each distinct
scored position once, and since a template row is one contiguous run of values, as is the
frame map row it meets, each position costs ``n_y`` vectorised dot products and reads no
index arrays. :meth:`AdaptedLinearOperator.to_sparse` gives the same operator as one
sparse matrix.

References
----------
.. [1] P. Wang, K. Morton, P. Torrione, L. Collins, "Viewpoint Adaptation for Rigid Object
   Detection", arXiv preprint, 2017.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import partial

import numpy as np
import scipy.sparse as sp

from ..arrays import stored_array
from ..geometry import WINDOW_HEIGHT, WINDOW_WIDTH
from ..objectmodel import PlaneModel
from .channels import (
    HOG_CELL, HOG_CHANNELS, HOG_WEIGHT_SHAPE, N_HOG_BINS, FrameFeatures, hog_frame_features,
)
from .features import FEATURE_CHANNELS
from .frame_remap import (
    cell_hog_remap, from_detector_window, hog_frame_remap, resolve_object_model, window_mapping,
)
from .opencv_cells import (
    OPENCV_CHANNELS, opencv_descriptor_weights, opencv_frame_features,
)
from .renorm import (
    HOG_VERIFY_THRESHOLD, OPENCV_STAGE_CELL_SIZES, VERIFY_THRESHOLD, RenormStage,
    cell_maps_of_mapping, stage_cell_sizes,
)
from .templates import (
    CELLS_PER_SOURCE_CELL, FRAME_CELL_SIZES, HOG_TOLERANCE, TemplateOperator, build_template_groups,
    check_windows, choose_cell_sizes, required_padding,
)
from .windows import CandidateWindows, detector_window_homography

__all__ = ["AdaptedLinearOperator", "OPENCV_FOLD_CELL_SIZES", "build_adapted_linear_operator",
           "build_adapted_opencv_operator"]

#: The frame cell sizes the folded operator of OpenCV's detectors reads when their stage
#: rescores every window it keeps (:func:`build_adapted_opencv_operator`): one size and its
#: double, as each size costs a pass of block normalisation over the frame. Chosen on the
#: 104 rendered frames and the PETS 2009 clip (docs/real_footage.md): the same LAMR as the
#: full :data:`FRAME_CELL_SIZES` on both.
OPENCV_FOLD_CELL_SIZES = (6, 12)


class AdaptedLinearOperator(TemplateOperator):
    """Per-window adapted linear detectors of one camera, applied as one operator.

    Built by :func:`build_adapted_linear_operator`. ``scores(features)`` returns
    ``(G(\\tilde H_n)^T w)^T x + b`` for every window ``n`` (eq. (7)).

    Attributes
    ----------
    groups : list
        Shared templates: cell size, patch, members and their cell shifts.
    snapped_homographies : (N, 3, 3) ndarray
        The homography each window is scored with (its candidate homography when
        ``tolerance == 0``).
    cell_size : (N,) int ndarray
    bias : float
    """

    nms_overlap, nms_threshold = "union", 0.5
    frame_feature_makers = (hog_frame_features, opencv_frame_features)

    def __init__(self, windows, cell_size, groups, pad, bias, features, channels=HOG_CHANNELS):
        self._setup(windows, cell_size, groups, pad)
        self.bias = float(bias)
        self.features = features
        #: channels per frame cell (13: the project's HOG cells; 36: OpenCV's)
        self.channels = int(channels)
        #: the per-window normalisation stage (:class:`~viewadapt.detect.renorm.RenormStage`)
        #: that rescores the windows of folded score >= its threshold, or None
        self.stage = None

    def weights_per_window(self) -> np.ndarray:
        """(N,) number of adapted weights (template entries) of each window."""
        out = np.zeros(self.n_windows, np.int64)
        for g in self.groups:
            out[g.members] = g.template.size
        return out

    def position_weights(self) -> np.ndarray:
        """(P,) number of adapted weights of each distinct scored position (windows
        snapped onto the same position of the same template are scored once)."""
        r = self._runs
        return (r.t_rows * r.t_run)[r.group]

    def scores(self, features: FrameFeatures) -> np.ndarray:
        """Scores of all windows on one frame's features: :meth:`fold_scores`, the windows
        that reach the normalisation stage's threshold rescored by it (:attr:`stage`).

        Parameters
        ----------
        features : FrameFeatures
            From :meth:`frame_features`.

        Returns
        -------
        (N,) float64 ndarray
        """
        s = self.fold_scores(features)
        stage = self.stage
        if stage is None:
            return s
        # the cascade: the windows the fold keeps, rescored with their own normalisation;
        # the others keep their folded score (below the stage's threshold)
        cand = np.flatnonzero(s >= stage.threshold)
        s[cand] = stage.scores(cand, features.raw)
        return s

    def fold_scores(self, features: FrameFeatures) -> np.ndarray:
        """Scores of all windows on one frame's features by the folded operator alone
        (eq. (7); without the normalisation stage).

        Parameters
        ----------
        features : FrameFeatures
            From :meth:`frame_features` (or :func:`hog_frame_features` with this
            operator's cell sizes and padding).

        Returns
        -------
        (N,) float64 ndarray
        """
        from .._kernels import template_run_scores

        self.check_features(features)
        r = self._runs
        x = features.vector(self.cell_sizes)
        if x.size != r.n_features or x.dtype != np.float32:
            raise ValueError(f"features have {x.size} {x.dtype} values, the operator "
                             f"reads {r.n_features} float32 values ({self.channels} "
                             f"channels per cell)")
        out = np.empty(len(r.starts))
        template_run_scores(x, r.templates, r.t_offset, r.t_rows, r.t_run, r.x_stride,
                            r.starts, r.group, out)
        return out[r.row_of] + self.bias

    def frame_features(self, image) -> FrameFeatures:
        """The frame's feature maps this operator reads (HOG's and OpenCV's cells: only the
        cell rows it reads, :meth:`read_rows`)."""
        if getattr(self.features, "func", None) in (opencv_frame_features, hog_frame_features):
            rows, raw_rows = self.read_rows()
            return self.features(image, rows=rows, raw_rows=raw_rows)
        return self.features(image)

    def read_rows(self) -> tuple[dict, dict]:
        """``(rows, raw_rows)``: per cell size ``c``, the cell rows ``(y0, y1)`` of the
        frame's (unpadded) map that some template reads, and those of the raw cells the
        normalisation stage can read (empty without a stage). Computed once per stage."""
        cached = getattr(self, "_read_rows", None)
        if cached is None or cached[0] is not self.stage:
            h = self.image_size[1]
            rows = {}
            for g in self.groups:
                oy = g.origin[1] + g.shifts[:, 1]
                y0, y1 = int(oy.min()), int(oy.max()) + g.shape[0]
                a, b = rows.get(g.cell_size, (y0, y1))
                rows[g.cell_size] = (min(a, y0), max(b, y1))
            rows = {c: (max(a, 0), min(b, h // c)) for c, (a, b) in rows.items()}
            raw = self.stage.read_rows(self.image_size) if self.stage is not None else {}
            self._read_rows = (self.stage, rows, raw)
        return self._read_rows[1:]

    def layout(self, channels=None):
        """Offsets and (rows, columns) of each cell size's padded map in
        :meth:`FrameFeatures.vector`, the vector's length and the channels per cell
        (``channels``, default the templates')."""
        w, h = self.image_size
        p = self.pad
        C = self.groups[0].template.shape[2] if channels is None else int(channels)
        offsets, dims = {}, {}
        off = 0
        for c in self.cell_sizes:
            ny, nx = h // c + 2 * p, w // c + 2 * p
            offsets[c], dims[c] = off, (ny, nx)
            off += ny * nx * C
        return offsets, dims, off, C

    def positions(self):
        """The distinct scored positions: per group, the (k_g,) offsets in
        :meth:`FrameFeatures.vector` of its distinct patch origins; and the (N,) position
        (row) of every window, rows numbered group after group."""
        offsets, dims, _, C = self.layout()
        p = self.pad
        row_of = np.empty(self.n_windows, np.intp)
        starts, n_rows = [], 0
        for g in self.groups:
            Nx = dims[g.cell_size][1]
            oy = g.origin[1] + g.shifts[:, 1] + p
            ox = g.origin[0] + g.shifts[:, 0] + p
            start, inv = np.unique(offsets[g.cell_size] + (oy * Nx + ox) * C,
                                   return_inverse=True)
            row_of[g.members] = n_rows + inv.ravel()
            starts.append(start)
            n_rows += len(start)
        return starts, row_of

    def _build_runs(self):
        """The tables of the ``"runs"`` form (:func:`viewadapt._kernels.template_run_scores`);
        each group's template becomes a view into them (one copy of the weights)."""
        _, dims, n_feat, C = self.layout()
        starts, row_of = self.positions()
        sizes = np.array([g.template.size for g in self.groups], np.int64)
        self._runs = _RunTables(
            templates=np.concatenate([g.template.ravel() for g in self.groups]).astype(
                np.float32),
            t_offset=np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64),
            t_rows=np.array([g.shape[0] for g in self.groups], np.int64),
            t_run=np.array([g.shape[1] * C for g in self.groups], np.int64),
            x_stride=np.array([dims[g.cell_size][1] * C for g in self.groups], np.int64),
            starts=np.concatenate(starts).astype(np.int64),
            group=np.repeat(np.arange(len(self.groups), dtype=np.int64),
                            [len(st) for st in starts]),
            row_of=row_of, n_features=int(n_feat))
        self._link_templates()

    def _link_templates(self):
        r = self._runs
        for g, off in zip(self.groups, r.t_offset):
            C = self.channels
            n = g.shape[0] * g.shape[1] * C
            g.template = r.templates[off:off + n].reshape(g.shape[0], g.shape[1], C)

    def __getstate__(self):
        # the templates are views into the run tables: pickle them once (there)
        state = self.__dict__.copy()
        state["groups"] = [replace(g, template=None) for g in self.groups]
        state.pop("_read_rows", None)
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._link_templates()

    def to_arrays(self):
        """The operator as ``(meta, arrays)``: JSON-ready metadata and plain arrays (its
        stored form, :class:`~viewadapt.io.cache.OperatorCache`); the groups' geometry
        and the run tables (``runs_*``: the templates, once, and the distinct positions)."""
        meta, arrays = self._geometry_to_arrays()
        r = self._runs
        meta.update(bias=float(self.bias), n_features=int(r.n_features))
        arrays.update({f"runs_{k}": getattr(r, k) for k in _RUN_ARRAYS})
        if self.stage is not None:
            m, a = self.stage.to_arrays()
            meta["renorm"] = m
            arrays.update(a)
        return meta, arrays

    @classmethod
    def from_arrays(cls, meta: dict, arrays: dict) -> "AdaptedLinearOperator":
        """The operator :meth:`to_arrays` gave, after checking that every table is of its
        shape and every index within its array (so the compiled loop never reads outside
        them); ``ValueError`` otherwise."""
        op = cls.__new__(cls)
        op._geometry_from_arrays(meta, arrays)
        bias, n_feat = meta.get("bias"), meta.get("n_features")
        if isinstance(bias, bool) or not isinstance(bias, (int, float)) or not np.isfinite(bias):
            raise ValueError(f"its bias is {bias!r}")
        op.bias = float(bias)
        op.channels = FEATURE_CHANNELS[op.features.func.__name__]
        op.stage = None
        if "renorm" in meta:
            op.stage = RenormStage.from_arrays(meta["renorm"], arrays, op.snapped_homographies)
            if len(op.stage.cell) != op.n_windows or max(op.stage.cell_sizes) > 64 \
                    or sorted(op.features.keywords.get("raw_cell_sizes") or ()) \
                    != op.stage.cell_sizes:
                raise ValueError("its normalisation stage does not match its windows")
        G = len(op.groups)
        t = {k: stored_array(arrays, f"runs_{k}", kinds, ndim=1)
             for k, kinds in zip(_RUN_ARRAYS, ("f",) + ("iu",) * 7)}
        _, dims, size, C = op.layout(op.channels)
        n_pos = len(t["starts"])
        g_shape = np.array([g.shape for g in op.groups], np.int64)
        stride = np.array([dims[g.cell_size][1] * C for g in op.groups], np.int64)
        if n_feat != size or any(len(t[k]) != G for k in ("t_offset", "t_rows", "t_run",
                                                          "x_stride")) \
                or len(t["group"]) != n_pos or len(t["row_of"]) != op.n_windows:
            raise ValueError("its run tables do not match its groups and frame layout")
        if not (np.array_equal(t["t_rows"], g_shape[:, 0])
                and np.array_equal(t["t_run"], g_shape[:, 1] * C)
                and np.array_equal(t["x_stride"], stride)
                and np.array_equal(t["t_offset"], np.r_[0, np.cumsum(g_shape.prod(1) * C)[:-1]])
                and len(t["templates"]) == g_shape.prod(1).sum() * C
                and n_pos and t["group"].min() >= 0 and t["group"].max() < G
                and t["row_of"].min() >= 0 and t["row_of"].max() < n_pos):
            raise ValueError("its run tables do not match its groups")
        g = t["group"]
        end = t["starts"] + (t["t_rows"][g] - 1) * t["x_stride"][g] + t["t_run"][g]
        if t["starts"].min() < 0 or end.max() > size:
            raise ValueError("its run tables read outside the frame's feature vector")
        op._runs = _RunTables(
            templates=np.ascontiguousarray(t["templates"], np.float32),
            **{k: np.ascontiguousarray(t[k], np.int64) for k in _RUN_ARRAYS[1:-1]},
            row_of=np.ascontiguousarray(t["row_of"], np.intp), n_features=int(size))
        op._link_templates()
        return op

    def to_sparse(self, *, unique: bool = False):
        """The operator as one CSR matrix ``W`` with ``scores = W x + b``.

        ``x`` is :meth:`FrameFeatures.vector` of the operator's cell sizes (padded maps).

        Parameters
        ----------
        unique : bool
            Keep one row per distinct scored window (windows snapped onto the same
            template position score the same) and also return the (N,) row of each window.

        Returns
        -------
        W : (N or n_unique, n_features) float32 scipy.sparse.csr_matrix
        rows : (N,) intp ndarray, only with ``unique=True``
        """
        _, dims, n_feat, C = self.layout()
        starts, row_of = self.positions()
        parts = []                               # (template nz cols, nz vals)
        for g in self.groups:
            ny, nx = g.shape
            Nx = dims[g.cell_size][1]
            yy, xx, cc = np.meshgrid(np.arange(ny), np.arange(nx), np.arange(C), indexing="ij")
            t = g.template.ravel()
            nz = np.flatnonzero(t)
            parts.append((((yy * Nx + xx) * C + cc).ravel()[nz], t[nz]))
        counts = np.concatenate([np.full(len(st), base.size, np.int64)
                                 for (base, _), st in zip(parts, starts)])
        indptr = np.zeros(len(counts) + 1, np.int64)
        np.cumsum(counts, out=indptr[1:])
        indices = np.empty(indptr[-1], np.int32 if n_feat < 2**31 else np.int64)
        data = np.empty(indptr[-1], np.float32)
        r0 = 0
        for (base, vals), start in zip(parts, starts):
            k = base.size
            s0 = indptr[r0]
            blk = slice(s0, s0 + k * len(start))
            indices[blk] = (start[:, None] + base[None, :]).ravel()
            data[blk] = np.tile(vals, len(start))
            r0 += len(start)
        W = sp.csr_matrix((data, indices, indptr), shape=(len(counts), n_feat))
        if unique:
            return W, row_of
        return W[row_of]


@dataclass
class _RunTables:
    """Templates and distinct positions of an :class:`AdaptedLinearOperator`, flat."""

    templates: np.ndarray          # all templates, row-major (n_y, n_x, C), concatenated
    t_offset: np.ndarray           # (G,) start of each template in ``templates``
    t_rows: np.ndarray             # (G,) n_y
    t_run: np.ndarray              # (G,) n_x C: one template row, one contiguous run
    x_stride: np.ndarray           # (G,) N_x C: one row of the padded map it reads
    starts: np.ndarray             # (P,) offset of each distinct position in the x vector
    group: np.ndarray              # (P,) its group
    row_of: np.ndarray             # (N,) position of each window
    n_features: int                # size of the x vector


#: the arrays of :class:`_RunTables`, in their order (:meth:`AdaptedLinearOperator.to_arrays`)
_RUN_ARRAYS = ("templates", "t_offset", "t_rows", "t_run", "x_stride", "starts", "group",
               "row_of")


def build_adapted_linear_operator(windows: CandidateWindows, weights, bias: float = 0.0, *,
                                  tolerance: float = HOG_TOLERANCE,
                                  cells_per_source_cell: float = CELLS_PER_SOURCE_CELL,
                                  allowed_cell_sizes=FRAME_CELL_SIZES,
                                  rule: str = "covariant",
                                  object_model="plane", renorm: bool = False,
                                  verify_threshold: float = HOG_VERIFY_THRESHOLD
                                  ) -> AdaptedLinearOperator:
    """Precompute the adapted linear detector of every candidate window (eq. (7)).

    Parameters
    ----------
    windows : CandidateWindows
    weights : (16, 8, 13) or (1664,) array_like
        Source-view weights over the canonical window's block-normalised 8-px HOG cells,
        layout row-major ``(n_y, n_x, channel)``: a linear model trained on
        ``hog_window_features(window).ravel()``.
    bias : float
    tolerance : float
        Shape tolerance for sharing templates, frame cells (:func:`group_windows`);
        0 = one exact template per window.
    cells_per_source_cell : float
        See :func:`choose_cell_sizes`.
    allowed_cell_sizes : sequence of int
    rule : {"covariant", "paper", "none"}
        Angle rule of ``A`` (:func:`viewadapt.remap.map_angles`).
    object_model : {"plane", "body"} or an object model
        How a person's pixels move between the views (:func:`window_mapping`): the paper's
        plane (each window's homography) or e.g. the mean body of
        :mod:`viewadapt.objectmodel` (needs ``windows.camera``).
    renorm, verify_threshold : bool, float
        With ``renorm`` the windows whose folded score reaches ``verify_threshold`` are
        rescored by a :class:`~viewadapt.detect.renorm.RenormStage` of the HOG model: raw
        cells remapped by each window's own ``G`` and block-normalised in the window (as
        :func:`build_adapted_opencv_operator` does for OpenCV's blocks); the boxes are then
        the windows' own. With an object model other than the plane, each window's cells
        are first moved as its template group's prototype's are by the model, relative to
        the prototype's plane (:func:`~viewadapt.detect.renorm.cell_maps_of_mapping`).

    Returns
    -------
    AdaptedLinearOperator
    """
    check_windows(windows)
    w = np.asarray(weights, dtype=np.float64).ravel()
    n_src = int(np.prod(HOG_WEIGHT_SHAPE))
    if w.size != n_src or not np.all(np.isfinite(w)):
        raise ValueError(f"weights must be {n_src} finite values over {HOG_WEIGHT_SHAPE} cells "
                         f"(hog_window_features), got {w.size}")
    cell, groups = _template_groups(windows, tolerance, cells_per_source_cell, allowed_cell_sizes)
    model = resolve_object_model(object_model)
    plane = isinstance(model, PlaneModel)
    maps, map_of = [], np.zeros(len(windows.homographies), np.int64)
    for n, g in enumerate(groups):
        mapping = window_mapping(windows, g.prototype, model)
        G = hog_frame_remap(mapping, g, rule)
        g.template = np.asarray(G.T @ w, dtype=np.float32).reshape(g.shape[0], g.shape[1],
                                                                     HOG_CHANNELS)
        if renorm and not plane:    # the group's cells moved by the model, off its plane
            maps.append(cell_maps_of_mapping(mapping, windows.homographies[g.prototype]))
            map_of[g.members] = n
    stage = None
    if renorm:
        stage = RenormStage(windows.homographies,
                            stage_cell_sizes(windows.scale, allowed_cell_sizes), w, bias,
                            threshold=verify_threshold, rule=rule, binning="cells",
                            model="hog", **({} if plane else dict(
                                cell_maps=np.array(maps).reshape(-1, *HOG_WEIGHT_SHAPE[:2], 6),
                                cell_map_of=map_of)))
    op = _operator(windows, cell, groups, bias, tolerance, hog_frame_features, HOG_CHANNELS,
                   **({"raw_cell_sizes": stage.cell_sizes} if stage else {}))
    if stage is not None:           # the final scores are the windows' own
        op.stage = stage
        op.snapped_homographies = stage.homographies
    return op


def _template_groups(windows, tolerance, cells_per_source_cell, allowed_cell_sizes,
                     source_px: float = 1.0):
    """The frame cell size of every window and the template groups of both builders;
    ``source_px``: canonical-window px per detector-window px (4/3 for Daimler's)."""
    if not np.isfinite(tolerance) or tolerance < 0:
        raise ValueError(f"tolerance must be >= 0 cells, got {tolerance!r}")
    cell = choose_cell_sizes(windows.scale * source_px, HOG_CELL,
                             cells_per_source_cell=cells_per_source_cell,
                             allowed=allowed_cell_sizes)
    return cell, build_template_groups(windows, cell, tolerance)


def _operator(windows, cell, groups, bias, tolerance, maker, channels, **feature_kw):
    """The operator of groups whose templates are set: padding, the frame features'
    ``maker`` (a function of :data:`~viewadapt.detect.features.FEATURE_MAKERS`) and the
    run tables, built once offline."""
    pad = required_padding(groups, windows.image_size)
    make_features = partial(maker, cell_sizes=sorted(set(cell.tolist())), pad=pad,
                            image_size=tuple(windows.image_size), **feature_kw)
    op = AdaptedLinearOperator(windows, cell, groups, pad, bias, make_features, channels)
    op.tolerance = float(tolerance)
    op._build_runs()
    return op


def build_adapted_opencv_operator(windows: CandidateWindows, weights, bias: float = 0.0, *,
                                  tolerance: float = HOG_TOLERANCE,
                                  cells_per_source_cell: float = CELLS_PER_SOURCE_CELL,
                                  allowed_cell_sizes=None,
                                  rule: str = "covariant",
                                  object_model="plane", renorm: bool = True,
                                  verify_threshold: float = VERIFY_THRESHOLD,
                                  stage_cell_sizes_allowed=OPENCV_STAGE_CELL_SIZES,
                                  window=(WINDOW_WIDTH, WINDOW_HEIGHT), gamma: bool = True
                                  ) -> AdaptedLinearOperator:
    """The adapted detector of every candidate window for an OpenCV HOG/SVM (eq. (7)).

    ``weights`` are the SVM's over OpenCV's block-normalised cells
    (:func:`~viewadapt.detect.opencv_cells.opencv_cell_weights`, shape
    :data:`~viewadapt.detect.opencv_cells.OPENCV_WEIGHT_SHAPE`); the frame's cells are
    normalised on the frame's grid (:func:`~viewadapt.detect.opencv_cells.opencv_frame_features`)
    and each group's template is ``G^T w`` with ``G`` the 9-bin ``S (x) A`` on each of a
    cell's four normalised copies (:func:`~viewadapt.detect.frame_remap.opencv_frame_remap`).
    With ``renorm`` (the paper's plane only) the windows whose folded score reaches
    ``verify_threshold`` are rescored by :class:`~viewadapt.detect.renorm.RenormStage`
    (raw cells remapped by each window's own ``G``, blocks normalised in the window); the
    operator's boxes are then the windows' exact ones, and the raw cells it reads are the
    ``stage_cell_sizes_allowed`` (:data:`~viewadapt.detect.renorm.OPENCV_STAGE_CELL_SIZES`).
    ``allowed_cell_sizes`` are the folded operator's (default:
    :data:`OPENCV_FOLD_CELL_SIZES` with a stage, which rescores every window the fold
    keeps, so that the fold only ranks candidates; :data:`FRAME_CELL_SIZES` without). The
    other parameters are :func:`build_adapted_linear_operator`'s.

    ``window`` is the detector's, (width, height) px: the canonical 64x128 or that window
    scaled (Daimler's 48x96; :func:`~viewadapt.detect.windows.detector_window_homography`),
    ``weights`` then of shape ``(height // 8, width // 8, 36)``; ``gamma``: OpenCV's
    square-root gamma correction in the features (Daimler's detector runs without).
    """
    check_windows(windows)
    T = detector_window_homography(window)
    shape = (int(window[1]) // HOG_CELL, int(window[0]) // HOG_CELL, OPENCV_CHANNELS)
    w = np.asarray(weights, dtype=np.float64)
    if w.size != int(np.prod(shape)) or not np.all(np.isfinite(w)):
        raise ValueError(f"weights must be {int(np.prod(shape))} finite values "
                         f"over {shape} cells (opencv_cell_weights), got {w.size}")
    k = float(T[0, 0])                     # canonical px per detector px
    model = resolve_object_model(object_model)
    staged = bool(renorm) and isinstance(model, PlaneModel)
    if allowed_cell_sizes is None:
        allowed_cell_sizes = OPENCV_FOLD_CELL_SIZES if staged else FRAME_CELL_SIZES
    cell, groups = _template_groups(windows, tolerance, cells_per_source_cell,
                                    allowed_cell_sizes, k)
    # one 9-bin weight vector per normalised copy q (channels 9 q ... 9 q + 8)
    wq = w.reshape(shape[:2] + (OPENCV_CHANNELS // N_HOG_BINS, N_HOG_BINS))
    wq = [wq[:, :, q].ravel() for q in range(wq.shape[2])]
    for g in groups:
        mapping = from_detector_window(window_mapping(windows, g.prototype, model), T)
        G9 = cell_hog_remap(mapping, g, rule, window=window).T.tocsr()
        g.template = np.concatenate(
            [np.asarray(G9 @ v, np.float32).reshape(g.shape[0], g.shape[1], N_HOG_BINS)
             for v in wq], axis=2)
    stage = None
    if staged:
        stage = RenormStage(windows.homographies,
                            stage_cell_sizes(windows.scale * k, stage_cell_sizes_allowed),
                            opencv_descriptor_weights(w.reshape(shape)), bias,
                            threshold=verify_threshold, rule=rule, window=window)
    extra = {} if gamma else {"gamma": False}  # (the stored keys of before when on)
    op = _operator(windows, cell, groups, bias, tolerance, opencv_frame_features,
                   OPENCV_CHANNELS, raw_cell_sizes=stage.cell_sizes if stage else [], **extra)
    if stage is not None:           # the final scores are the windows' own
        op.stage = stage
        op.snapped_homographies = stage.homographies
    return op
