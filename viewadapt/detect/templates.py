"""Candidate windows grouped into shared templates: the layout every adapted operator shares.

Each world-space candidate window (:mod:`viewadapt.detect.windows`) sees the person through
its own homography ``H_n`` (canonical window -> frame), so it needs its own adapted detector
(Wang et al. 2017, Sec. 5.1: "each position in the image corresponds to a unique relative
viewpoint and associated feature mapping ... computed off-line ... looked up at run-time").
For a linear model on cell features the adapted detector of window ``n`` is

.. math:: s_n = w^T G_n x + b = (G_n^T w)^T x + b

(eq. (5)-(7)), ``x`` the frame's cell features (:mod:`viewadapt.detect.channels`) and
``G_n = S_n \\otimes A_n`` the remapping from frame cells to the canonical window's cells
(:mod:`viewadapt.detect.frame_remap`).

Cell sizes: each window reads frame cells of the allowed size closest to (below) the size
of one of its source cells in the frame (:func:`choose_cell_sizes`), so every window reads
about one frame cell per source cell.

Templates: neighbouring windows have nearly the same ``H_n`` up to a translation. Windows
whose shapes (``H_n`` with its centre moved to the origin) agree within ``tolerance`` frame
cells share one adapted template, placed at each window's position rounded to the cell grid
(:func:`group_windows`, :func:`build_template_groups`): window ``n`` is then scored with the
*snapped* homography ``T(c \\delta_n) H_g`` (``H_g`` the group's prototype window,
``\\delta_n`` an integer cell shift) -- the quantisation every sliding-window detector
makes (half a cell in position; here also up to ``tolerance`` cells in shape).
``tolerance=0`` gives one template per window at its exact position.

References
----------
.. [1] P. Wang, K. Morton, P. Torrione, L. Collins, "Viewpoint Adaptation for Rigid Object
   Detection", arXiv preprint, 2017.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..arrays import is_int, stored_array
from ..geometry import WINDOW_CENTRE, WINDOW_CORNERS, map_points
from ..nms import detections_from_scores
from .channels import HOG_CELL, FrameFeatures, check_frame
from .features import feature_maker_from_dict, feature_maker_to_dict
from .windows import CandidateWindows, person_boxes

__all__ = [
    "FRAME_CELL_SIZES", "CELLS_PER_SOURCE_CELL", "HOG_TOLERANCE", "ACF_TOLERANCE",
    "choose_cell_sizes", "group_windows", "patch_grid", "TemplateGroup",
    "build_template_groups", "required_padding", "check_windows", "SnappedBoxes",
    "TemplateOperator",
]

#: Frame cell sizes the adapted operators may choose from (:func:`choose_cell_sizes`).
FRAME_CELL_SIZES = (2, 3, 4, 6, 8, 12, 16)
#: At least this many frame cells per source cell along each axis (``rho`` of
#: :func:`choose_cell_sizes`): frame cells a little finer than the source cells' image.
CELLS_PER_SOURCE_CELL = 0.7
#: Shape tolerance for sharing templates, in frame cells: HOG's cells are sized on its 8-px
#: cells, ACF's on its 4-px blocks, so ACF's 1 cell is about the pixel tolerance of HOG's 0.5.
HOG_TOLERANCE = 0.5
ACF_TOLERANCE = 1.0
#: Probe points of a window's shape: its corners and the top and bottom of its centre line.
_PROBES = np.vstack([WINDOW_CORNERS, [[WINDOW_CENTRE[0], WINDOW_CORNERS[0, 1]],
                                      [WINDOW_CENTRE[0], WINDOW_CORNERS[2, 1]]]])


def choose_cell_sizes(scale, source_cell: int, *, cells_per_source_cell: float = 1.0,
                      allowed=(1, 2, 3, 4, 5, 6, 8, 10, 12, 16)) -> np.ndarray:
    """Frame cell size per window: the largest allowed ``c <= source_cell * s / rho``.

    Parameters
    ----------
    scale : (N,) array_like
        Frame pixels per canonical-window pixel of each window.
    source_cell : int
        The detector's cell size in the canonical window (8 for HOG, 4 for ACF).
    cells_per_source_cell : float
        ``rho``: at least this many frame cells per source cell along each axis (1: frame
        cells no larger than the source cells' image).
    allowed : sequence of int

    Returns
    -------
    (N,) int ndarray
    """
    s = np.asarray(scale, dtype=np.float64)
    allowed = np.sort(np.asarray(allowed, dtype=np.int64))
    target = source_cell * s / cells_per_source_cell
    idx = np.searchsorted(allowed, target, side="right") - 1
    return allowed[np.maximum(idx, 0)]


def _shapes(H):
    """(N, P, 2) probe points of each window relative to its mapped centre."""
    probes = map_points(H, _PROBES)
    centre = map_points(H, WINDOW_CENTRE)
    return probes - centre[:, None, :], centre


def group_windows(windows: CandidateWindows, cell_size, tolerance: float):
    """Group windows that share an adapted template up to a whole-cell shift.

    A quadtree over each (person height, cell size) set's ground-grid indices splits a
    block until every window's shape -- the probe points of its window (corners, top and
    bottom centre) relative to its centre -- lies within ``tolerance * c`` px of the
    block's prototype (the window nearest the block's middle).

    Parameters
    ----------
    windows : CandidateWindows
    cell_size : (N,) int array_like
    tolerance : float
        In frame cells; 0 gives one group per window.

    Returns
    -------
    list of (prototype index, (k,) member indices) tuples.
    """
    H = windows.homographies
    c = np.asarray(cell_size)
    shapes, _ = _shapes(H)
    groups = []
    keys = np.stack([np.round(windows.person_height * 1e6), c], 1)
    for key in np.unique(keys, axis=0):
        members = np.flatnonzero(np.all(keys == key, axis=1))
        if tolerance <= 0:
            groups.extend((int(m), np.array([m])) for m in members)
            continue
        tau = tolerance * key[1]
        stack = [members]
        while stack:
            m = stack.pop()
            ij = windows.grid_index[m].astype(np.float64)
            mid = np.median(ij, axis=0)
            proto = m[np.argmin(np.abs(ij - mid).sum(1))]
            dev = np.abs(shapes[m] - shapes[proto]).max(axis=(1, 2))
            if dev.max() <= tau or len(m) == 1:
                groups.append((int(proto), m))
                continue
            span = ij.max(0) - ij.min(0)
            ax = int(np.argmax(span))
            if span[ax] == 0:                      # same grid cell (cannot happen): split
                half = len(m) // 2
                stack += [m[:half], m[half:]]
                continue
            cut = np.median(ij[:, ax])
            left = ij[:, ax] <= cut
            if left.all() or not left.any():
                left = ij[:, ax] < cut if (ij[:, ax] < cut).any() else ij[:, ax] <= ij[:, ax].min()
            stack += [m[left], m[~left]]
    return groups


def patch_grid(H, c):
    """Frame-cell patch of ``c``-px cells covering the footprint of window ``H`` (canonical
    window -> frame px): ``(cx0, cy0, n_x, n_y)``, its top-left cell and size."""
    corners = map_points(H[None], _PROBES[:4])[0]
    lo = np.floor((corners.min(0) + 0.5) / c).astype(int)
    hi = np.ceil((corners.max(0) + 0.5) / c).astype(int)
    return int(lo[0]), int(lo[1]), int(max(hi[0] - lo[0], 1)), int(max(hi[1] - lo[1], 1))


@dataclass
class TemplateGroup:
    """Windows that share one adapted template, each at a whole-cell shift of the
    prototype's patch."""

    cell_size: int
    prototype: int                 # window index of the prototype
    origin: tuple                  # (cx0, cy0): prototype patch's top-left frame cell
    shape: tuple                   # (n_y, n_x) patch size in cells
    members: np.ndarray            # (k,) window indices
    shifts: np.ndarray             # (k, 2) integer cell shifts (dx, dy) per member
    template: object = None        # linear: (n_y, n_x, C) float32; trees: sparse G rows


class SnappedBoxes:
    """What every adapted operator shares: the person boxes of its ``snapped_homographies``
    (computed once) and detection -- scores of its windows thresholded and non-maximum
    suppressed with the operator's :attr:`nms_overlap` and :attr:`nms_threshold`."""

    #: non-maximum suppression of the operator's detections
    #: (:func:`~viewadapt.nms.detections_from_scores`)
    nms_overlap, nms_threshold = "union", 0.5

    def detect(self, image, *, threshold: float = 0.0, nms_threshold: float | None = None,
               max_candidates: int = 2000, return_index: bool = False, vote: float = 0.0):
        """Features, scores and non-maximum suppression on one frame (``nms_threshold`` by
        default the operator's; ``vote``: box voting's temperature,
        :func:`viewadapt.nms.voted_boxes`, 0 none).

        Returns
        -------
        (D, 5) ndarray of ``(x, y, w, h, score)`` rows in frame pixels, by decreasing score;
        with ``return_index``, also the (D,) indices of their windows.
        """
        check_frame(image, self.image_size)
        s = self.scores(self.frame_features(image))
        return detections_from_scores(
            self._cached_boxes(), s, threshold=threshold, overlap=self.nms_overlap,
            nms_threshold=self.nms_threshold if nms_threshold is None else nms_threshold,
            max_candidates=max_candidates, return_index=return_index, vote=vote)

    def boxes(self) -> np.ndarray:
        """(N, 4) person boxes ``(x, y, w, h)`` of the scored (snapped) windows, in the
        frame's pixels; read-only (one array per operator, not copied per frame)."""
        return self._cached_boxes()

    def _cached_boxes(self) -> np.ndarray:
        # computed once per operator (not per frame): ~18 ms for 30,000 windows
        b = getattr(self, "_boxes", None)
        if b is None:
            b = self._boxes = person_boxes(self.snapped_homographies)
            b.setflags(write=False)
        return b


class TemplateOperator(SnappedBoxes):
    """Shared geometry of the adapted operators (see :class:`AdaptedLinearOperator`)."""

    source_cell: int = HOG_CELL
    #: the frame feature functions a stored operator of this class may name (checked on load)
    frame_feature_makers = None

    def _setup(self, windows, cell_size, groups, pad):
        self.image_size = tuple(windows.image_size)
        self.n_windows = len(windows)
        self.groups = groups
        self.pad = pad
        self.cell_size = np.asarray(cell_size, dtype=np.int64)
        self.cell_sizes = sorted(set(int(g.cell_size) for g in groups))
        H = np.empty((self.n_windows, 3, 3))
        for g in groups:
            Hp = windows.homographies[g.prototype]
            c = g.cell_size
            T = np.zeros((len(g.members), 3, 3))
            T[:, 0, 0] = T[:, 1, 1] = T[:, 2, 2] = 1.0
            T[:, 0, 2] = c * g.shifts[:, 0]
            T[:, 1, 2] = c * g.shifts[:, 1]
            H[g.members] = T @ Hp
        self.snapped_homographies = H

    @property
    def n_templates(self) -> int:
        return len(self.groups)

    def feature_pixels(self) -> int:
        """Frame pixels whose channels are computed per frame (the whole frame, once)."""
        return int(self.image_size[0] * self.image_size[1])

    def patch_origins(self, g, features):
        """(k,) rows and columns, in ``features``' padded maps, of the patch origins of
        group ``g``'s windows."""
        p = features.pad
        ox = g.origin[0] + g.shifts[:, 0] + p
        oy = g.origin[1] + g.shifts[:, 1] + p
        return oy, ox

    def _geometry_to_arrays(self):
        """The geometry every operator shares as ``(meta, arrays)`` (for the stored form
        of :meth:`to_arrays`): frame size, windows, padding, feature maker, and the groups
        flattened -- members and shifts concatenated, ``group_members_ptr`` (G + 1,) their
        offsets."""
        gs = self.groups
        sizes = [len(g.members) for g in gs]
        meta = dict(image_size=[int(v) for v in self.image_size], n_windows=int(self.n_windows),
                    pad=int(self.pad), features=feature_maker_to_dict(self.features))
        if hasattr(self, "tolerance"):
            meta["tolerance"] = float(self.tolerance)
        arrays = dict(
            cell_size=self.cell_size, snapped_homographies=self.snapped_homographies,
            group_cell_size=np.array([g.cell_size for g in gs], np.int64),
            group_prototype=np.array([g.prototype for g in gs], np.int64),
            group_origin=np.array([g.origin for g in gs], np.int64).reshape(-1, 2),
            group_shape=np.array([g.shape for g in gs], np.int64).reshape(-1, 2),
            group_members_ptr=np.r_[0, np.cumsum(sizes)].astype(np.int64),
            group_members=np.concatenate([g.members for g in gs]).astype(np.int64),
            group_shifts=np.concatenate([g.shifts for g in gs]).astype(np.int64).reshape(-1, 2))
        return meta, arrays

    def _geometry_from_arrays(self, meta: dict, arrays: dict):
        """Set the shared geometry from :meth:`_geometry_to_arrays`' ``(meta, arrays)``
        (group templates left empty), checking every entry; ``ValueError`` otherwise."""
        size, n, pad = meta.get("image_size"), meta.get("n_windows"), meta.get("pad")
        if not (isinstance(size, list) and len(size) == 2 and all(is_int(v) and v > 0
                                                                  for v in size)):
            raise ValueError(f"its image_size is {size!r}")
        if not (is_int(n) and n > 0 and is_int(pad) and pad >= 0):
            raise ValueError(f"its window count {n!r} or padding {pad!r} is not valid")
        cell = stored_array(arrays, "cell_size", "iu", shape=(n,))
        H = stored_array(arrays, "snapped_homographies", "f", shape=(n, 3, 3))
        g_cell = stored_array(arrays, "group_cell_size", "iu", ndim=1)
        n_groups = len(g_cell)
        proto = stored_array(arrays, "group_prototype", "iu", shape=(n_groups,))
        origin = stored_array(arrays, "group_origin", "iu", shape=(n_groups, 2))
        shape = stored_array(arrays, "group_shape", "iu", shape=(n_groups, 2))
        ptr = stored_array(arrays, "group_members_ptr", "iu", shape=(n_groups + 1,))
        members = stored_array(arrays, "group_members", "iu", shape=(n,))
        shifts = stored_array(arrays, "group_shifts", "iu", shape=(n, 2))
        if n_groups == 0 or (g_cell <= 0).any() or (cell <= 0).any() or (shape <= 0).any():
            raise ValueError("its groups, cell sizes or patch shapes are empty or not positive")
        if ptr[0] != 0 or ptr[-1] != n or (np.diff(ptr) <= 0).any():
            raise ValueError("its group_members_ptr does not split the windows into groups")
        if members.min() < 0 or members.max() >= n or proto.min() < 0 or proto.max() >= n \
                or (np.bincount(members, minlength=n) != 1).any():
            raise ValueError("its groups do not hold every window exactly once")
        self.image_size = (int(size[0]), int(size[1]))
        self.n_windows = int(n)
        self.pad = int(pad)
        self.cell_size = np.ascontiguousarray(cell, dtype=np.int64)
        self.snapped_homographies = np.ascontiguousarray(H, dtype=np.float64)
        self.groups = [TemplateGroup(int(g_cell[i]), int(proto[i]),
                                     (int(origin[i, 0]), int(origin[i, 1])),
                                     (int(shape[i, 0]), int(shape[i, 1])),
                                     members[ptr[i]:ptr[i + 1]].astype(np.int64),
                                     shifts[ptr[i]:ptr[i + 1]].astype(np.int64))
                       for i in range(n_groups)]
        self.cell_sizes = sorted(set(int(c) for c in g_cell))
        if "tolerance" in meta:
            self.tolerance = float(meta["tolerance"])
        self.features = feature_maker_from_dict(meta.get("features"))
        expected = type(self).frame_feature_makers
        if expected is not None and self.features.func not in expected:
            raise ValueError(f"its feature maker is {self.features.func.__name__}, not "
                             f"{' or '.join(f.__name__ for f in expected)}")
        kw = self.features.keywords
        if kw.get("pad") != self.pad or kw.get("image_size") != self.image_size \
                or sorted(kw.get("cell_sizes") or ()) != self.cell_sizes:
            raise ValueError("its feature maker's padding, frame size or cell sizes are not "
                             "those of its groups")

    def check_features(self, features: FrameFeatures):
        """ValueError unless ``features`` are of this operator's frame size, padding and
        cell sizes."""
        if tuple(features.image_size) != self.image_size:
            raise ValueError(f"features are of a {features.image_size[0]}x"
                             f"{features.image_size[1]} frame, the operator is for "
                             f"{self.image_size[0]}x{self.image_size[1]} frames")
        if features.pad != self.pad:
            raise ValueError(f"features are padded by {features.pad} cells, the operator "
                             f"needs {self.pad}")
        missing = [c for c in self.cell_sizes if c not in features.maps]
        if missing:
            raise ValueError(f"features lack the cell sizes {missing}")


def build_template_groups(windows: CandidateWindows, cell_size, tolerance: float) -> list:
    """:func:`group_windows` as :class:`TemplateGroup` s: each member's cell shift from the
    prototype (its mapped centre's offset rounded to whole cells) and the prototype's
    patch (:func:`patch_grid`); templates not yet filled in."""
    centre = map_points(windows.homographies, WINDOW_CENTRE)
    out = []
    for proto, members in group_windows(windows, cell_size, tolerance):
        c = int(cell_size[proto])
        d = np.round((centre[members] - centre[proto]) / c).astype(np.int64)
        if len(members) == 1:
            d[:] = 0
        H = windows.homographies[proto]
        cx0, cy0, nx, ny = patch_grid(H, c)
        out.append(TemplateGroup(c, int(proto), (cx0, cy0), (ny, nx), np.asarray(members), d))
    return out


def required_padding(groups, image_size) -> int:
    """Zero cells needed on every side of the frame's cell maps so that every group's
    patch, at every member's shift, lies inside them (at least 1)."""
    w, h = image_size
    need = 1
    for g in groups:
        c = g.cell_size
        ny_map, nx_map = h // c, w // c
        ox = g.origin[0] + g.shifts[:, 0]
        oy = g.origin[1] + g.shifts[:, 1]
        need = max(need, int(-ox.min()), int(-oy.min()),
                   int((ox + g.shape[1] - nx_map).max()), int((oy + g.shape[0] - ny_map).max()))
    return need


def check_windows(windows):
    """ValueError unless ``windows`` is a non-empty :class:`CandidateWindows`."""
    if not isinstance(windows, CandidateWindows) or len(windows) == 0:
        raise ValueError("windows must be a non-empty CandidateWindows "
                         "(viewadapt.detect.select_candidate_windows)")


