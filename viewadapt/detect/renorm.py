"""The per-window normalisation stage of the adapted OpenCV detector.

A block-normalised HOG/SVM (Dalal & Triggs 2005) is not linear in the cells: OpenCV
normalises each 2x2-cell block of the *window*. The folded operator
(:func:`~viewadapt.detect.linear.build_adapted_opencv_operator`) normalises blocks of the
*frame's* cells instead, so that ``G`` folds into the weights (Wang et al. 2017, eq. (7));
:class:`RenormStage` does what that approximates, for the windows the folded operator
scores at least ``threshold`` (a cascade): the frame's raw cell histograms are remapped to
the window's cells by ``G = S (x) A`` -- ``S`` from each source cell's image under the
window's own homography, ``A`` by the covariant rule -- and the window's blocks are L2-Hys
normalised and scored as OpenCV scores them
(:func:`viewadapt._renorm_kernels.renorm_scores`); the windows below ``threshold`` keep their
folded score. The frame cells it reads are about one source cell in size
(:data:`RENORM_CELLS_PER_SOURCE_CELL`). Nothing is warped. With ``model="hog"`` it does the
same for the project's HOG/SVM.

References
----------
.. [1] N. Dalal, B. Triggs, "Histograms of Oriented Gradients for Human Detection", CVPR 2005.
.. [2] P. Wang, K. Morton, P. Torrione, L. Collins, "Viewpoint Adaptation for Rigid Object
   Detection", arXiv preprint, 2017.
"""

from __future__ import annotations

import numpy as np

from ..arrays import is_int, stored_array
from ..remap import ANGLE_RULES
from .channels import HOG_CELL, HOG_CHANNELS, HOG_CLIP, hog_cell_eps
from ..geometry import WINDOW_HEIGHT, WINDOW_WIDTH
from .opencv_cells import OPENCV_CHANNELS, OPENCV_L2HYS_CLIP, block_axis_weights
from .templates import choose_cell_sizes
from .windows import detector_window_homography

__all__ = ["RENORM_CELLS_PER_SOURCE_CELL", "STAGE_CELL_TOLERANCE", "VERIFY_THRESHOLD",
           "OPENCV_STAGE_CELL_SIZES", "HOG_VERIFY_THRESHOLD", "OPENCV_DESCRIPTOR_SIZE",
           "BINNINGS", "stage_cell_sizes", "cell_maps_of_mapping", "RenormStage"]

#: Frame cells per source cell of the raw cells the stage reads
#: (:func:`~viewadapt.detect.templates.choose_cell_sizes`' ``cells_per_source_cell``).
RENORM_CELLS_PER_SOURCE_CELL = 1.0
#: How much larger than its source cells' image a window's raw cells may be (a fraction):
#: a window whose scale falls just below a cell size's boundary reads that size, as its
#: neighbours do, instead of a size a handful of windows would need a whole frame's raw
#: cells for (windows mapped through a lens straggle across the boundaries).
STAGE_CELL_TOLERANCE = 0.02
#: Folded score from which a window of OpenCV's detectors is rescored: half an SVM margin
#: below the lowest detection threshold the DET curves use (``DEFAULT_THRESHOLD``, -1).
#: Chosen on the 104 rendered frames and the PETS 2009 clip (docs/real_footage.md): -2 and
#: -1.5 gave the same LAMR on both, and -1.5 rescores about a third as many windows.
VERIFY_THRESHOLD = -1.5
#: The raw cell sizes the stage of OpenCV's detectors reads: one base size and its
#: doublings, so that one pass over the frame's pixels makes them all (the larger are sums
#: of the base's cells, :func:`~viewadapt.detect.opencv_cells.raw_cell_maps`). A window
#: reads the largest of them at most its source cells' image: on the rendered frames and
#: the PETS clip the same LAMR as the full ladder (docs/real_footage.md).
OPENCV_STAGE_CELL_SIZES = (3, 6, 12)
#: The project's HOG/SVM's stage threshold: a window is rescored when the fold scores it a
#: person (the SVM's own boundary). Chosen on rendered frames (the paper preset's 104,
#: docs/real_footage.md): folded thresholds -1.5 to 1 gave the same LAMR within 0.005, and
#: the HOG scores spread too narrowly for a threshold as low as OpenCV's to be affordable
#: (20,000 windows per 768x576 frame at -2).
HOG_VERIFY_THRESHOLD = 0.0
#: Length of OpenCV's 64x128 descriptor (7 x 15 blocks of 36).
OPENCV_DESCRIPTOR_SIZE = 7 * 15 * OPENCV_CHANNELS
_RULE_CODES = {"covariant": 0, "none": 1, "paper": 2}
#: How :class:`RenormStage` bins the frame's cells into a window's blocks.
BINNINGS = ("opencv", "cells")
#: The models :class:`RenormStage` scores: each one's block-norm floor and clipping
#: (OpenCV's ``0.1 * 36`` and L2-Hys 0.2; the project's HOG's floor for 8-px cells, its clip)
_MODELS = {"opencv": (0.1 * OPENCV_CHANNELS, OPENCV_L2HYS_CLIP),
           "hog": (hog_cell_eps(HOG_CELL), HOG_CLIP)}


class RenormStage:
    """Per-window remapping of raw cells and OpenCV's block normalisation (see the module).

    Parameters
    ----------
    homographies : (N, 3, 3) array_like
        Canonical window -> frame pixels of each window.
    cell_size : (N,) int array_like
        The raw cell size each window reads.
    weights : (3780,) array_like
        The SVM's weights in OpenCV's descriptor layout (of its ``window``); ``bias`` its
        bias.
    threshold : float
        Windows whose folded score is below it are not rescored (they keep it).
    rule : {"covariant", "paper", "none"}
    binning : {"opencv", "cells"}
        How a block's cell histograms gather the frame's cells: ``"opencv"`` weights them
        with OpenCV's Gaussian block window and bilinear cell tents carried through the
        block's affine approximation (:func:`viewadapt._renorm_kernels.renorm_scores_binned`);
        ``"cells"``: each source cell reads the frame cells under its image, hard binned
        (:func:`viewadapt._renorm_kernels.renorm_scores`).
    window : (width, height)
        The detector's window, px: the canonical 64x128 or that window scaled
        (:func:`~viewadapt.detect.windows.detector_window_homography`, e.g. Daimler's 48x96);
        ``homographies`` stay those of the canonical window.
    model : {"opencv", "hog"}
        ``"hog"``: the project's HOG/SVM instead (``weights`` over the window's (16, 8, 13)
        :func:`~viewadapt.detect.block_normalize_cells` features), its source cells hard
        binned (``binning`` must be ``"cells"``) and normalised as that function does
        (:func:`viewadapt._renorm_kernels.hog_renorm_scores`).
    cell_maps, cell_map_of : (M, 16, 8, 6) and (N,) arrays, optional
        ``model="hog"`` only: an object model other than the window's plane (e.g. the mean
        body, :mod:`viewadapt.objectmodel`). Window ``n``'s source cells are first moved
        within the canonical window by ``cell_maps[cell_map_of[n]]`` -- each cell centre's
        image and the 2x2 Jacobian there (row-major; a cell with a NaN reads nothing),
        :func:`cell_maps_of_mapping` -- then mapped by its homography; ``S`` and ``A`` per
        cell from the two composed.
    """

    def __init__(self, homographies, cell_size, weights, bias, *,
                 threshold: float = VERIFY_THRESHOLD, rule: str = "covariant",
                 binning: str = "opencv", window=(WINDOW_WIDTH, WINDOW_HEIGHT),
                 model: str = "opencv", cell_maps=None, cell_map_of=None):
        H = np.ascontiguousarray(homographies, np.float64).reshape(-1, 3, 3)
        cell = np.ascontiguousarray(cell_size, np.int64).ravel()
        w = np.ascontiguousarray(weights, np.float32).ravel()
        if len(cell) != len(H) or (len(cell) and cell.min() < 1):
            raise ValueError(f"one positive cell size per window: {len(cell)} sizes for "
                             f"{len(H)} windows")
        T = detector_window_homography(window)
        self.window = (int(window[0]), int(window[1]))
        self._cells = (self.window[0] // HOG_CELL, self.window[1] // HOG_CELL)
        if model not in _MODELS or (model == "hog" and binning != "cells"):
            raise ValueError(f"model must be one of {tuple(_MODELS)} (hog with binning "
                             f"'cells'), got {model!r} with binning {binning!r}")
        self.model = model
        nx, ny = self._cells
        n_w = (nx - 1) * (ny - 1) * OPENCV_CHANNELS if model == "opencv" \
            else nx * ny * HOG_CHANNELS
        if w.size != n_w or not np.all(np.isfinite(w)) or not np.all(np.isfinite(H)):
            raise ValueError(f"weights must be {n_w} finite values and the homographies finite")
        if rule not in ANGLE_RULES or not np.isfinite(threshold) or not np.isfinite(bias):
            raise ValueError(f"rule must be one of {ANGLE_RULES} and the threshold and bias "
                             f"finite, got {rule!r}, {threshold!r}, {bias!r}")
        if binning not in BINNINGS:
            raise ValueError(f"binning must be one of {BINNINGS}, got {binning!r}")
        self.binning = binning
        self.homographies, self.cell = H, cell
        #: detector window -> frame px of each window
        self._window_h = H @ T if self.window != (WINDOW_WIDTH, WINDOW_HEIGHT) else H
        self.weights, self.bias = w, float(bias)
        self.threshold, self.rule = float(threshold), str(rule)
        self.cell_sizes = sorted(set(int(c) for c in cell))
        self.cell_maps = self.cell_map_of = None
        if (cell_maps is None) != (cell_map_of is None):
            raise ValueError("cell_maps and cell_map_of come together")
        if cell_maps is not None:
            R = np.ascontiguousarray(cell_maps, np.float64)
            of = np.ascontiguousarray(cell_map_of, np.int64).ravel()
            if model != "hog" or R.ndim != 4 or R.shape[1:] != (ny, nx, 6):
                raise ValueError(f"cell maps need model 'hog' and shape (M, {ny}, {nx}, 6), "
                                 f"got model {model!r} and shape {R.shape}")
            if len(of) != len(H) or (len(of) and (of.min() < 0 or of.max() >= len(R))):
                raise ValueError(f"one cell map index in [0, {len(R)}) per window: "
                                 f"{len(of)} indices for {len(H)} windows")
            if np.isinf(R).any():
                raise ValueError("cell maps must be finite or NaN (hidden cells)")
            self.cell_maps, self.cell_map_of = R, of

    def scores(self, index, raw) -> np.ndarray:
        """Scores of the windows ``index`` from
        :func:`~viewadapt.detect.opencv_cells.raw_cell_maps`' output ``raw`` (its maps must
        hold this stage's cell sizes)."""
        from .._renorm_kernels import hog_renorm_scores, renorm_scores, renorm_scores_binned

        maps, flat, offsets = raw
        index = np.asarray(index, np.int64)
        sizes = sorted(maps)
        if any(c not in maps for c in self.cell_sizes):
            raise ValueError(f"the raw cells hold sizes {sizes}, the stage reads "
                             f"{self.cell_sizes}")
        order = list(maps)
        pos = {c: i for i, c in enumerate(order)}
        lut = np.full(max(order) + 1, -1, np.int64)
        for c, i in pos.items():
            lut[c] = i
        size_of = lut[self.cell[index]]
        dims = np.array([maps[c].shape[:2] for c in order], np.int64).reshape(-1, 2)
        out = np.empty(len(index))
        eps, clip = _MODELS[self.model]
        args = (flat, np.asarray(offsets, np.int64), dims, size_of, np.array(order, np.int64),
                np.ascontiguousarray(self._window_h[index]), self.weights,
                np.float32(self.bias), np.float32(eps), np.float32(clip),
                _RULE_CODES[self.rule], *self._cells)
        if self.model == "hog" and self.cell_maps is not None:
            hog_renorm_scores(*args, out, self.cell_maps, self.cell_map_of[index])
        elif self.model == "hog":
            hog_renorm_scores(*args, out)
        elif self.binning == "opencv":
            renorm_scores_binned(*args, block_axis_weights(HOG_CELL).astype(np.float32), out)
        else:
            renorm_scores(*args, out)
        return out

    def read_rows(self, image_size) -> dict:
        """``c -> (y0, y1)``: the rows of the raw cell map of each size ``c`` that
        :meth:`scores` can read on a frame of ``image_size`` (width, height), for any of
        the windows -- the frame cells under each block's (or cell's) affine image, as the
        compiled loops bound them, and a row more on each side."""
        h = int(image_size[1])
        nx, ny = self._cells
        if self.binning == "opencv":    # each block's centre, its reach 8 |J_yy| + 1 px
            points = [(8.0 * bx + 7.5, 8.0 * by + 7.5)
                      for bx in range(nx - 1) for by in range(ny - 1)]
            half, margin = 8.0, 1.0
        else:                           # each cell's centre, its reach 4 |J_yy|
            points = [(8.0 * i + 3.5, 8.0 * j + 3.5) for i in range(nx) for j in range(ny)]
            half, margin = 4.0, 0.0
        out = {}
        for c in self.cell_sizes:
            H = self._window_h[self.cell == c]
            R = None if self.cell_maps is None else self.cell_maps[self.cell_map_of[
                self.cell == c]].reshape(len(H), -1, 6)
            ny = h // c
            y0, y1 = ny, 0
            for n in range(len(points)):
                if R is None:
                    x, y = points[n]
                else:                   # each window's cell n (row-major) moved first
                    x, y = R[:, n, 0], R[:, n, 1]
                w = H[:, 2, 0] * x + H[:, 2, 1] * y + H[:, 2, 2]
                py = (H[:, 1, 0] * x + H[:, 1, 1] * y + H[:, 1, 2]) / w
                j11 = (H[:, 1, 1] - py * H[:, 2, 1]) / w
                if R is not None:
                    j10 = (H[:, 1, 0] - py * H[:, 2, 0]) / w
                    j11 = j10 * R[:, n, 3] + j11 * R[:, n, 5]
                    keep = np.isfinite(py) & np.isfinite(j11)
                    if not keep.any():
                        continue
                    py, j11 = py[keep], j11[keep]
                ey = half * np.abs(j11) + margin
                lo = np.floor((py - ey + 0.5) / c)
                hi = np.floor((py + ey + 0.5) / c)
                y0 = min(y0, int(max(lo.min() - 1, 0)))      # a row more each side:
                y1 = max(y1, int(min(hi.max() + 1, ny - 1)) + 1)  # rounding
            out[c] = (y0, max(y0, y1))
        return out

    def to_arrays(self) -> tuple[dict, dict]:
        """``(meta, arrays)`` of the stage (its homographies are the operator's)."""
        meta = dict(threshold=self.threshold, rule=self.rule, bias=self.bias,
                    binning=self.binning)
        if self.model != "opencv":
            meta["model"] = self.model
        if self.window != (WINDOW_WIDTH, WINDOW_HEIGHT):
            meta["window"] = list(self.window)
        arrays = dict(renorm_cell=self.cell, renorm_weights=self.weights)
        if self.cell_maps is not None:
            arrays.update(renorm_cell_maps=self.cell_maps, renorm_cell_map_of=self.cell_map_of)
        return meta, arrays

    @classmethod
    def from_arrays(cls, meta, arrays, homographies) -> "RenormStage":
        """The stage :meth:`to_arrays` gave; ``ValueError`` for any other content."""
        if not isinstance(meta, dict) or not all(
                isinstance(meta.get(k), (int, float)) and not isinstance(meta.get(k), bool)
                for k in ("threshold", "bias")):
            raise ValueError("its normalisation stage has no valid threshold and bias")
        cell = stored_array(arrays, "renorm_cell", "iu", ndim=1)
        if len(cell) and not all(is_int(c) for c in cell[:1]):
            raise ValueError("its normalisation stage's cell sizes are not integers")
        maps = of = None
        if "renorm_cell_maps" in arrays or "renorm_cell_map_of" in arrays:
            maps = stored_array(arrays, "renorm_cell_maps", "f", ndim=4, finite=False)
            of = stored_array(arrays, "renorm_cell_map_of", "iu", ndim=1)
        return cls(homographies, cell, stored_array(arrays, "renorm_weights", "f", ndim=1),
                   meta["bias"], threshold=meta["threshold"], rule=meta.get("rule"),
                   binning=meta.get("binning"), window=_stored_window(meta.get("window")),
                   model=meta.get("model", "opencv"), cell_maps=maps, cell_map_of=of)


def _stored_window(v):
    """A stored stage's detector window (absent: the canonical one); ``ValueError`` for
    anything but two positive integers."""
    if v is None:
        return (WINDOW_WIDTH, WINDOW_HEIGHT)
    if not (isinstance(v, list) and len(v) == 2
            and all(isinstance(x, int) and not isinstance(x, bool) and 16 <= x <= 1024
                    for x in v)):
        raise ValueError(f"its normalisation stage's window is {v!r}")
    return tuple(v)


def cell_maps_of_mapping(mapping, homography, *, cells=(WINDOW_WIDTH // HOG_CELL,
                                                      WINDOW_HEIGHT // HOG_CELL),
                         step: float = 0.5) -> np.ndarray:
    """(ny, nx, 6): where an object model moves each 8-px cell of the canonical window
    relative to the window's plane, for :class:`RenormStage`'s ``cell_maps``: ``mapping``
    (canonical px -> frame px, e.g. :func:`~viewadapt.detect.frame_remap.window_mapping`
    of the mean body) followed by the inverse of the window's ``homography``, at each cell
    centre -- the point (2) and its Jacobian (4, row-major, central differences of
    ``step`` px). Where the model hides a point (the mapping is NaN there) the window's
    plane stands in (docs/real_footage.md has the measurement behind that choice)."""
    nx, ny = cells
    ys, xs = np.mgrid[0:ny, 0:nx].astype(np.float64)
    c = np.stack([8.0 * xs + 3.5, 8.0 * ys + 3.5], -1)
    d = np.array([[0.0, 0.0], [step, 0.0], [-step, 0.0], [0.0, step], [0.0, -step]])
    pts = (c[:, :, None, :] + d).reshape(-1, 2)
    H = np.asarray(homography, np.float64)
    p = np.asarray(mapping(pts), np.float64)
    on_plane = np.c_[pts, np.ones(len(pts))] @ H.T
    p = np.where(np.isfinite(p), p, on_plane[:, :2] / on_plane[:, 2:])   # hidden: the plane
    Hi = np.linalg.inv(H)
    q = np.concatenate([p, np.ones((len(p), 1))], 1) @ Hi.T
    q = (q[:, :2] / q[:, 2:]).reshape(ny, nx, 5, 2)
    out = np.empty((ny, nx, 6))
    out[..., :2] = q[:, :, 0]
    out[..., 2:6:2] = (q[:, :, 1] - q[:, :, 2]) / (2 * step)    # d/dx of (x', y')
    out[..., 3:6:2] = (q[:, :, 3] - q[:, :, 4]) / (2 * step)    # d/dy
    out[~np.all(np.isfinite(out), axis=-1)] = np.nan
    return out


def stage_cell_sizes(scale, allowed) -> np.ndarray:
    """The raw cell size of each window of frame pixels per canonical pixel ``scale``: the
    largest allowed size at most :data:`STAGE_CELL_TOLERANCE` larger than the image of a
    source cell at :data:`RENORM_CELLS_PER_SOURCE_CELL`."""
    s = np.asarray(scale, np.float64) * (1.0 + STAGE_CELL_TOLERANCE)
    return choose_cell_sizes(s, HOG_CELL, cells_per_source_cell=RENORM_CELLS_PER_SOURCE_CELL,
                             allowed=allowed)
