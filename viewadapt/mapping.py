"""Feature remapping ``G = S (x) A`` from a general point mapping, not only a homography.

Wang et al. (2017) model the object as a plane, so the map between two views is a
homography and each projected cell is a quadrilateral (:mod:`viewadapt.remap`). Their
conclusion names "more complex 3D models" as the next step; then the map between views is
any function ``m: output-view pixels -> input-view pixels`` (for adaptation: source view ->
target view, as ``H_st``), possibly undefined where the object is not (off the body, or
hidden in the input view). This module builds ``S`` and ``A`` from such a map:

* ``S``: each output cell is cut into ``subdivisions x subdivisions`` pieces whose corners are
  mapped; each mapped piece is clipped exactly against the input cells
  (:func:`viewadapt.remap.quad_overlap_matrix`). Under a homography the mapped pieces tile the
  projected cell exactly, so the homography path is the special case (same ``S``).
* ``A``: per output cell from the map's local Jacobian ``J = dm/dp`` (central differences at
  the cell centre), with any rule of :func:`viewadapt.remap.map_angles`.

A mapping is a callable taking ``(..., 2)`` points and returning ``(..., 2)`` points with NaN
where it is undefined: :func:`homography_mapping`, :class:`GridMapping` (sampled on a
regular grid, e.g. from rendered correspondences or an object model), or your own.
Undefined pieces are *dropped* -- the output cell then gets only what its defined pieces
cover -- so callers who want a fallback (e.g. the person plane off the body) fill it in
before (:meth:`GridMapping.filled`).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ._validation import check_homography
from .remap import (
    ANGLE_RULES, CellGrid, assemble_remap_matrix, orientation_remap_matrix, quad_overlap_matrix,
)

__all__ = ["homography_mapping", "GridMapping", "mapping_jacobian",
           "mapping_cell_remap_matrix", "mapping_remap_matrix"]


def homography_mapping(H):
    """The point mapping of a homography: ``p -> H(p)`` (NaN where ``H`` sends ``p`` to
    infinity or behind the centre of projection, i.e. ``w <= 0`` after scaling ``H`` so that
    its centre point has ``w > 0``)."""
    H = check_homography(H, "H")

    def m(points):
        p = np.asarray(points, dtype=np.float64)
        uvw = p @ H[:, :2].T + H[:, 2]
        w = uvw[..., 2:3]
        with np.errstate(divide="ignore", invalid="ignore"):
            out = uvw[..., :2] / w
        return np.where(w > 1e-12, out, np.nan)

    return m


class GridMapping:
    """A mapping sampled on a regular grid of output-view points, bilinearly interpolated.

    Parameters
    ----------
    values : (n_y, n_x, 2) array_like
        ``values[i, j]`` is the image of the point ``origin + (j, i) * step``; NaN where the
        mapping is undefined.
    origin : (2,) array_like
        ``(x, y)`` of ``values[0, 0]``.
    step : float
        Grid spacing in output-view pixels.

    A query point gets a value only if the four samples around it are defined and it lies
    inside the grid; elsewhere NaN.
    """

    def __init__(self, values, origin=(0.0, 0.0), step: float = 1.0):
        v = np.asarray(values, dtype=np.float64)
        if v.ndim != 3 or v.shape[2] != 2 or v.shape[0] < 2 or v.shape[1] < 2:
            raise ValueError(f"values must have shape (n_y >= 2, n_x >= 2, 2), got {v.shape}")
        if not np.isfinite(step) or step <= 0:
            raise ValueError(f"step must be a positive number of pixels, got {step!r}")
        if np.isinf(v).any():
            raise ValueError("values contain infinite entries (use NaN for undefined points)")
        self.values = v
        self.origin = (float(origin[0]), float(origin[1]))
        self.step = float(step)

    @property
    def defined(self) -> np.ndarray:
        """(n_y, n_x) bool: where the samples are defined."""
        return np.isfinite(self.values).all(axis=2)

    def points(self) -> np.ndarray:
        """(n_y, n_x, 2) output-view coordinates of the samples."""
        ny, nx = self.values.shape[:2]
        ys, xs = np.mgrid[0:ny, 0:nx].astype(np.float64)
        return np.stack([self.origin[0] + xs * self.step, self.origin[1] + ys * self.step], -1)

    def filled(self, fallback) -> "GridMapping":
        """A copy with the undefined samples taken from ``fallback`` (another mapping)."""
        v = self.values.copy()
        bad = ~self.defined
        if bad.any():
            v[bad] = np.asarray(fallback(self.points()[bad]), dtype=np.float64)
        return GridMapping(v, self.origin, self.step)

    def __call__(self, points) -> np.ndarray:
        p = np.asarray(points, dtype=np.float64)
        shape = p.shape
        p = p.reshape(-1, 2)
        ny, nx = self.values.shape[:2]
        gx = (p[:, 0] - self.origin[0]) / self.step
        gy = (p[:, 1] - self.origin[1]) / self.step
        inside = (gx >= 0) & (gx <= nx - 1) & (gy >= 0) & (gy <= ny - 1)
        gx = np.where(inside, gx, 0.0)
        gy = np.where(inside, gy, 0.0)
        x0 = np.minimum(np.floor(gx).astype(np.int64), nx - 2)
        y0 = np.minimum(np.floor(gy).astype(np.int64), ny - 2)
        fx, fy = (gx - x0)[:, None], (gy - y0)[:, None]
        v = self.values
        out = ((1 - fx) * (1 - fy) * v[y0, x0] + fx * (1 - fy) * v[y0, x0 + 1]
               + (1 - fx) * fy * v[y0 + 1, x0] + fx * fy * v[y0 + 1, x0 + 1])
        # a corner that is undefined but carries zero weight still makes the point undefined:
        # the mapping is not known all around it
        corners_ok = (np.isfinite(v[y0, x0]).all(1) & np.isfinite(v[y0, x0 + 1]).all(1)
                      & np.isfinite(v[y0 + 1, x0]).all(1) & np.isfinite(v[y0 + 1, x0 + 1]).all(1))
        out[~(inside & corners_ok)] = np.nan
        return out.reshape(shape)


def mapping_jacobian(mapping, points, *, step: float = 1e-3) -> np.ndarray:
    """``J = dm/dp`` at each point by central differences (NaN where undefined).

    Parameters
    ----------
    mapping : callable, (..., 2) -> (..., 2)
    points : (N, 2) array_like
    step : float
        Half the difference stencil, output-view pixels. For a homography the error is of
        order ``step**2`` times its second derivatives (< 1e-9 at the crop scale).

    Returns
    -------
    (N, 2, 2) ndarray, ``J[n, i, j] = d out_i / d in_j``.
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    e = np.array([[step, 0.0], [0.0, step]])
    stencil = np.stack([p + e[0], p - e[0], p + e[1], p - e[1]], axis=1)   # (N, 4, 2)
    m = np.asarray(mapping(stencil), dtype=np.float64)
    J = np.empty((len(p), 2, 2))
    J[:, :, 0] = (m[:, 0] - m[:, 1]) / (2 * step)
    J[:, :, 1] = (m[:, 2] - m[:, 3]) / (2 * step)
    return J


def _signed_areas(q) -> np.ndarray:
    """Signed shoelace areas of (P, 4, 2) quadrilaterals."""
    x, y = q[..., 0], q[..., 1]
    return 0.5 * (x * np.roll(y, -1, axis=-1) - np.roll(x, -1, axis=-1) * y).sum(axis=-1)


def _mapped_pieces(mapping, out_grid: CellGrid, subdivisions: int, folds: str):
    """Mapped sub-cell quadrilaterals of every output cell: (quads, owner, n_defined)."""
    if int(subdivisions) != subdivisions or subdivisions < 1:
        raise ValueError(f"subdivisions must be a positive integer, got {subdivisions!r}")
    if folds not in ("raise", "drop"):
        raise ValueError(f"folds must be 'raise' or 'drop', got {folds!r}")
    n = int(subdivisions)
    h = out_grid.cell_size / n
    x0, y0 = out_grid.origin
    nx, ny = out_grid.n_x * n, out_grid.n_y * n
    ys, xs = np.mgrid[0:ny + 1, 0:nx + 1].astype(np.float64)
    pts = np.stack([x0 + xs * h, y0 + ys * h], -1)                      # (ny+1, nx+1, 2)
    m = np.asarray(mapping(pts), dtype=np.float64)
    if m.shape != pts.shape:
        raise ValueError(f"the mapping returned shape {m.shape} for points of shape {pts.shape}")
    # sub-cell corners in the order of CellGrid.corners: NW, SW, SE, NE
    quads = np.stack([m[:-1, :-1], m[1:, :-1], m[1:, 1:], m[:-1, 1:]], axis=2)  # (ny, nx, 4, 2)
    quads = quads.reshape(-1, 4, 2)
    sy, sx = np.divmod(np.arange(ny * nx), nx)
    owner = (sy // n) * out_grid.n_x + sx // n
    ok = np.isfinite(quads).all(axis=(1, 2))
    if not ok.any():
        raise ValueError("the mapping is undefined over the whole output grid (empty mask?)")
    ref = np.sign(_signed_areas(out_grid.corners()[:1]))[0]           # orientation of a cell
    area = _signed_areas(quads[ok]) * ref
    bad = area <= 1e-9 * h * h
    if bad.any():
        if folds == "raise":
            raise ValueError(
                f"the mapping folds over: {int(bad.sum())} of {int(ok.sum())} mapped sub-cells "
                "reverse orientation or collapse (mark hidden points undefined, or pass "
                "folds='drop')")
        idx = np.flatnonzero(ok)
        ok[idx[bad]] = False
    return quads[ok], owner[ok], int(ok.sum())


def mapping_cell_remap_matrix(mapping, out_grid: CellGrid, in_grid: CellGrid, *,
                              subdivisions: int = 4, preserve: str = "sum",
                              folds: str = "raise") -> sp.csr_matrix:
    """``S`` (eq. (1)) for a general mapping of output-view points to input-view points.

    Parameters
    ----------
    mapping : callable, (..., 2) -> (..., 2), NaN where undefined
    out_grid, in_grid : CellGrid
    subdivisions : int
        Each output cell is cut into ``subdivisions**2`` square pieces; each piece's four
        mapped corners span the quadrilateral clipped against the input cells. Exact for a
        homography at any value; for a curved mapping the error falls with the square of
        the piece size.
    preserve : {"sum", "mean"}
        See :func:`viewadapt.remap.cell_remap_matrix`.
    folds : {"raise", "drop"}
        A piece whose mapped orientation is reversed (the mapping folds over, as a surface
        does where it turns away) is a ``ValueError``, or is dropped.

    Returns
    -------
    S : (out_grid.n_cells, in_grid.n_cells) scipy.sparse.csr_matrix
    """
    quads, owner, _ = _mapped_pieces(mapping, out_grid, subdivisions, folds)
    return quad_overlap_matrix(quads, owner, out_grid.n_cells, in_grid, preserve=preserve)


def _cell_jacobians(mapping, out_grid: CellGrid, jacobian: str):
    """(K, 2, 2) Jacobians per output cell; identity where the mapping is undefined there."""
    c = out_grid.centers()
    if jacobian == "center":
        J = mapping_jacobian(mapping, c, step=1e-3 * out_grid.cell_size)
    elif jacobian == "mean":
        # mean over a 4 x 4 lattice of points inside the cell, the defined ones
        off = (np.arange(4) + 0.5) / 4 - 0.5
        oy, ox = np.meshgrid(off, off, indexing="ij")
        pts = (c[:, None, :] + out_grid.cell_size * np.stack([ox.ravel(), oy.ravel()], -1)[None])
        Js = mapping_jacobian(mapping, pts.reshape(-1, 2), step=1e-3 * out_grid.cell_size)
        Js = Js.reshape(len(c), -1, 2, 2)
        good = np.isfinite(Js).all(axis=(2, 3))
        cnt = good.sum(axis=1)
        J = np.where(good[..., None, None], Js, 0.0).sum(axis=1) / np.maximum(cnt, 1)[:, None, None]
        J[cnt == 0] = np.nan
    else:
        raise ValueError(f"jacobian must be 'center' or 'mean', got {jacobian!r}")
    undefined = ~np.isfinite(J).all(axis=(1, 2)) | (np.linalg.det(np.nan_to_num(J)) <= 0)
    J[undefined] = np.eye(2)
    return J, undefined


def mapping_remap_matrix(mapping, out_grid: CellGrid, in_grid: CellGrid, *, n_bins: int = 9,
                         rule: str = "covariant", per_cell: bool = True, anchor=None,
                         preserve: str = "sum", bin_offset: float = 0.0, n_plain: int = 0,
                         subdivisions: int = 4, jacobian: str = "center",
                         folds: str = "raise") -> sp.csr_matrix:
    """``G = S (x) A`` from a general mapping (the homography version is
    :func:`viewadapt.remap.feature_remap_matrix`, to which this reduces for a planar map).

    Parameters
    ----------
    mapping : callable, (..., 2) -> (..., 2)
        Output-view pixels -> input-view pixels (source -> target for adaptation), NaN where
        undefined.
    out_grid, in_grid : CellGrid
    n_bins, rule, preserve, bin_offset, n_plain
        As in :func:`viewadapt.remap.feature_remap_matrix`.
    per_cell : bool
        One ``A`` per output cell from the mapping's Jacobian there (default), or one for
        the window from the Jacobian at ``anchor`` (default the grid's centre).
    subdivisions, folds
        See :func:`mapping_cell_remap_matrix`.
    jacobian : {"center", "mean"}
        Per-cell ``J``: at the cell centre (default; exact for a homography), or the mean
        of the defined Jacobians on a 4 x 4 lattice in the cell (for curved mappings).
        A cell where ``J`` is undefined or folds gets ``A = I``.

    Returns
    -------
    G : scipy.sparse.csr_matrix, layouts as :func:`viewadapt.remap.feature_remap_matrix`.
    """
    if rule not in ANGLE_RULES:
        raise ValueError(f"rule must be one of {ANGLE_RULES}, got {rule!r}")
    S = mapping_cell_remap_matrix(mapping, out_grid, in_grid, subdivisions=subdivisions,
                                  preserve=preserve, folds=folds)
    if n_bins == 1 or rule == "none":
        return assemble_remap_matrix(S, None, n_bins=n_bins, n_plain=n_plain)
    if per_cell:
        J, _ = _cell_jacobians(mapping, out_grid, jacobian)
    else:
        if anchor is None:
            x0, y0, x1, y1 = out_grid.bounds()
            anchor = ((x0 + x1) / 2, (y0 + y1) / 2)
        J = mapping_jacobian(mapping, np.asarray(anchor, float)[None],
                             step=1e-3 * out_grid.cell_size)[0]
        if not np.isfinite(J).all() or np.linalg.det(J) <= 0:
            raise ValueError("the mapping is undefined or folds at the anchor of the single A")
    A = orientation_remap_matrix(J, n_bins, rule, bin_offset=bin_offset)
    return assemble_remap_matrix(S, A, n_bins=n_bins, n_plain=n_plain)
