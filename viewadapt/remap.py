"""Feature remapping matrices ``S``, ``A`` and ``G = S (x) A`` (Wang et al. 2017, Sec. 3.2).

Direction convention
--------------------
Every matrix here maps features computed on an **input** grid to features on an
**output** grid, and takes the homography ``H_out_to_in`` that carries output-view pixel
coordinates to input-view pixel coordinates. For classifier adaptation the output is the
*source* (training) view and the input is the *target* view, so the homography is
``H_st`` (source -> target) from :mod:`viewadapt.geometry`, and

.. math:: x_{source} \\approx G\\,x_{target}, \\qquad
          w^T x_{source} \\approx (G^T w)^T x_{target}

(eq. (5)-(7)). The paper's eq. (1)-(4) are written for the other direction; the formulas
are the same with the roles renamed.

Feature layout: cell features are flattened row-major over ``(n_y, n_x, n_bins)``
(the layout of :func:`viewadapt.hog.hog_cells`), i.e. index ``(cy * n_x + cx) * B + b``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ._validation import check_homography
from .geometry import homography_jacobian

__all__ = [
    "CellGrid",
    "clip_polygons_to_rects",
    "polygon_areas",
    "cell_remap_matrix",
    "map_angles",
    "orientation_remap_matrix",
    "feature_remap_matrix",
    "quad_overlap_matrix",
    "assemble_remap_matrix",
    "ANGLE_RULES",
]

#: ``"covariant"``: gradients are covectors, ``u_out ~ J^T u_in`` (J = d in / d out);
#: ``"paper"``: the literal eq. (3), which moves directions like tangents, ``u_out ~ J^-1 u_in``;
#: ``"none"``: no angle remapping (``A = I``).
ANGLE_RULES = ("covariant", "paper", "none")


@dataclass(frozen=True)
class CellGrid:
    """A regular grid of square cells over a window.

    Cell ``(cy, cx)`` covers ``[x0 + cx c, x0 + (cx + 1) c] x [y0 + cy c, y0 + (cy + 1) c]``
    in pixel coordinates; with the default origin ``(-0.5, -0.5)`` cell 0 covers pixels
    ``0 .. c - 1`` (pixel centres are integers).

    Parameters
    ----------
    n_x, n_y : int
        Cells across and down.
    cell_size : float
        Cell side in pixels.
    origin : (2,) tuple
        ``(x0, y0)``, the outer corner of cell ``(0, 0)``.
    """

    n_x: int
    n_y: int
    cell_size: float
    origin: tuple = (-0.5, -0.5)

    def __post_init__(self):
        if int(self.n_x) != self.n_x or int(self.n_y) != self.n_y or self.n_x < 1 or self.n_y < 1:
            raise ValueError(f"grid needs positive integer n_x, n_y; got {self.n_x}, {self.n_y}")
        if not self.cell_size > 0:
            raise ValueError(f"cell_size must be positive, got {self.cell_size!r}")

    @classmethod
    def for_window(cls, width: int = 64, height: int = 128, cell_size: float = 8) -> "CellGrid":
        """The cell grid of a ``width`` x ``height`` window."""
        if width % cell_size or height % cell_size:
            raise ValueError(f"window {width}x{height} is not a multiple of cell_size={cell_size}")
        return cls(int(width // cell_size), int(height // cell_size), cell_size)

    @property
    def n_cells(self) -> int:
        return self.n_x * self.n_y

    @property
    def cell_area(self) -> float:
        return float(self.cell_size) ** 2

    def corners(self) -> np.ndarray:
        """(n_cells, 4, 2) cell corners, counter-clockwise in a y-down image (NW, SW, SE, NE)."""
        cy, cx = np.divmod(np.arange(self.n_cells), self.n_x)
        x0 = self.origin[0] + cx * self.cell_size
        y0 = self.origin[1] + cy * self.cell_size
        x1, y1 = x0 + self.cell_size, y0 + self.cell_size
        return np.stack([np.stack([x0, y0], -1), np.stack([x0, y1], -1),
                         np.stack([x1, y1], -1), np.stack([x1, y0], -1)], axis=1)

    def centers(self) -> np.ndarray:
        """(n_cells, 2) cell centres ``(x, y)``."""
        cy, cx = np.divmod(np.arange(self.n_cells), self.n_x)
        return np.stack([self.origin[0] + (cx + 0.5) * self.cell_size,
                         self.origin[1] + (cy + 0.5) * self.cell_size], -1)

    def bounds(self) -> tuple[float, float, float, float]:
        x0, y0 = self.origin
        return x0, y0, x0 + self.n_x * self.cell_size, y0 + self.n_y * self.cell_size


# ------------------------------------------------------------------ polygon clipping


def clip_polygons_to_rects(polygons, counts, rects):
    """Clip convex polygons to axis-aligned rectangles (Sutherland-Hodgman), compiled.

    Parameters
    ----------
    polygons : (P, V, 2) ndarray
        Vertices, the first ``counts[p]`` of each row valid.
    counts : (P,) int ndarray
    rects : (P, 4) ndarray
        ``(xmin, ymin, xmax, ymax)`` per polygon.

    Returns
    -------
    clipped : (P, V', 2) ndarray and counts : (P,) int ndarray (0 where nothing is left).
    """
    from ._kernels import clip_to_rects

    poly = np.ascontiguousarray(polygons, dtype=np.float64)
    cnt = np.ascontiguousarray(counts, dtype=np.int64)
    rects = np.ascontiguousarray(rects, dtype=np.float64)
    P, V = poly.shape[:2]
    if P == 0:
        return poly, cnt.copy()
    # each of the 4 edges adds at most one vertex per vertex (at most doubles the count)
    out = np.zeros((P, 16 * max(V, 1), 2))
    out_cnt = clip_to_rects(poly, cnt, rects, out, np.zeros(P, np.int64))
    return out[:, :max(int(out_cnt.max()), 1)], out_cnt


def polygon_areas(polygons, counts) -> np.ndarray:
    """Absolute shoelace areas of (P, V, 2) polygons with ``counts`` valid vertices."""
    poly = np.asarray(polygons, dtype=np.float64)
    cnt = np.asarray(counts, dtype=np.int64)
    P, V = poly.shape[:2]
    if P == 0:
        return np.zeros(0)
    idx = np.arange(V)[None, :]
    valid = idx < cnt[:, None]
    nxt_idx = np.where(cnt[:, None] > 0, (idx + 1) % np.maximum(cnt[:, None], 1), 0)
    nxt = np.take_along_axis(poly, nxt_idx[:, :, None].repeat(2, axis=2), axis=1)
    cross = poly[:, :, 0] * nxt[:, :, 1] - poly[:, :, 1] * nxt[:, :, 0]
    return 0.5 * np.abs(np.where(valid, cross, 0.0).sum(axis=1))


# ---------------------------------------------------------------------------- S (eq. 1)


def _check_orientation(H, points, what="output grid"):
    """Raise unless H keeps every point in front (w > 0) and preserves orientation."""
    w = (points @ H[:, :2].T + H[:, 2])[:, 2]
    if not (np.all(w > 1e-12) or np.all(w < -1e-12)):
        raise ValueError(
            f"the homography sends part of the {what} to infinity (the window crosses "
            "the horizon or lies behind the camera)"
        )
    det = np.linalg.det(homography_jacobian(H, points))
    if np.any(det <= 0):
        raise ValueError(
            "the homography reverses orientation (or is degenerate) over the window: "
            "det of its Jacobian <= 0; it cannot be a view of the same side of the plane"
        )


def cell_remap_matrix(H_out_to_in, out_grid: CellGrid, in_grid: CellGrid, *,
                      preserve: str = "sum") -> sp.csr_matrix:
    """Cell resampling matrix ``S`` from exact area overlaps (Wang et al. 2017, eq. (1)).

    Each output cell ``d_k`` is projected into the input view, ``d_k' = H d_k`` (a convex
    quadrilateral), and clipped against every input cell ``d_l``:

    .. math:: S_{kl} = \\frac{\\operatorname{area}(d_l \\cap d_{k'})}{\\operatorname{area}(d_l)}

    Parameters
    ----------
    H_out_to_in : (3, 3) array_like
        Maps output-view pixel coordinates to input-view pixel coordinates (``H_st`` for
        adaptation: output = source cells, input = target cells).
    out_grid, in_grid : CellGrid
    preserve : {"sum", "mean"}
        ``"sum"`` is eq. (1): each input cell contributes the fraction of its area that the
        projected output cell covers, so Haar-like *sums* carry over. ``"mean"``
        normalises each row by the covered area instead, for per-pixel *averages* (colour,
        the ACF toolbox's block means).

    Returns
    -------
    S : (out_grid.n_cells, in_grid.n_cells) scipy.sparse.csr_matrix

    Notes
    -----
    Output cells, or parts of them, that project outside the input grid get nothing from
    there (their rows sum to less). The overlap is computed exactly by polygon clipping,
    not by sampling; a singular, orientation-reversing or horizon-crossing homography is a
    ``ValueError``.
    """
    H = check_homography(H_out_to_in, "H_out_to_in")
    corners = out_grid.corners()                                  # (K, 4, 2)
    flat = corners.reshape(-1, 2)
    _check_orientation(H, np.vstack([flat, out_grid.centers()]))
    uvw = flat @ H[:, :2].T + H[:, 2]
    quads = (uvw[:, :2] / uvw[:, 2:3]).reshape(-1, 4, 2)          # (K, 4, 2), CCW kept
    return quad_overlap_matrix(quads, np.arange(len(quads)), out_grid.n_cells, in_grid,
                               preserve=preserve)


def quad_overlap_matrix(quads, owner, n_out: int, in_grid: CellGrid, *,
                        preserve: str = "sum") -> sp.csr_matrix:
    """``S`` from output-cell pieces already mapped into the input view.

    Row ``k`` of ``S`` collects, for every quadrilateral ``quads[p]`` with ``owner[p] == k``,
    its exact overlap with each input cell: ``S_kl = sum_p area(d_l & q_p) / area(d_l)``
    (``preserve="sum"``, eq. (1)) or the same normalised by the row's covered area
    (``"mean"``). :func:`cell_remap_matrix` passes one projected quadrilateral per output
    cell; :func:`viewadapt.mapping.mapping_cell_remap_matrix` passes the mapped pieces of
    subdivided cells.

    Parameters
    ----------
    quads : (P, 4, 2) array_like
        Vertices in the input view's pixel coordinates (any simple quadrilateral; each is
        clipped exactly against the input cells).
    owner : (P,) int array_like
        Output cell of each quadrilateral, in ``[0, n_out)``.
    n_out : int
    in_grid : CellGrid
    preserve : {"sum", "mean"}

    Returns
    -------
    S : (n_out, in_grid.n_cells) scipy.sparse.csr_matrix
    """
    if preserve not in ("sum", "mean"):
        raise ValueError(f"preserve must be 'sum' or 'mean', got {preserve!r}")
    quads = np.asarray(quads, dtype=np.float64).reshape(-1, 4, 2)
    owner = np.asarray(owner, dtype=np.int64).reshape(-1)
    if len(owner) != len(quads):
        raise ValueError(f"owner has {len(owner)} entries for {len(quads)} quadrilaterals")
    # candidate (piece, input cell) pairs from the mapped bounding boxes
    c = float(in_grid.cell_size)
    ox, oy = in_grid.origin
    lo = np.floor((quads.min(axis=1) - (ox, oy)) / c).astype(np.int64)
    hi = np.ceil((quads.max(axis=1) - (ox, oy)) / c).astype(np.int64) - 1
    lo = np.maximum(lo, 0)
    hi = np.minimum(hi, (in_grid.n_x - 1, in_grid.n_y - 1))
    nxs = np.maximum(hi[:, 0] - lo[:, 0] + 1, 0)
    nys = np.maximum(hi[:, 1] - lo[:, 1] + 1, 0)
    npairs = nxs * nys
    k_idx = np.repeat(np.arange(len(quads)), npairs)
    if k_idx.size == 0:
        return sp.csr_matrix((n_out, in_grid.n_cells))
    start = np.repeat(np.cumsum(npairs) - npairs, npairs)
    local = np.arange(k_idx.size) - start
    ly, lx = np.divmod(local, nxs[k_idx])
    ix = lo[k_idx, 0] + lx
    iy = lo[k_idx, 1] + ly
    rects = np.stack([ox + ix * c, oy + iy * c, ox + (ix + 1) * c, oy + (iy + 1) * c], -1)
    poly, cnt = clip_polygons_to_rects(quads[k_idx], np.full(k_idx.size, 4), rects)
    area = polygon_areas(poly, cnt)
    keep = area > 1e-12 * in_grid.cell_area
    rows, cols, area = owner[k_idx][keep], (iy * in_grid.n_x + ix)[keep], area[keep]
    if preserve == "sum":
        vals = area / in_grid.cell_area
    else:
        covered = np.bincount(rows, weights=area, minlength=n_out)
        vals = area / covered[rows]
    return sp.csr_matrix((vals, (rows, cols)), shape=(n_out, in_grid.n_cells))


# ---------------------------------------------------------------------- A (eq. 3-4)


def map_angles(theta, jacobian, rule: str = "covariant") -> np.ndarray:
    """Map unsigned orientations from the input view to the output view.

    Parameters
    ----------
    theta : (...) array_like
        Input-view angles, radians.
    jacobian : (..., 2, 2) array_like, its leading axes broadcast against ``theta``
        ``J = d(input coords) / d(output coords)`` at the point (the Jacobian of
        ``H_out_to_in``).
    rule : {"covariant", "paper", "none"}
        ``"covariant"``: a gradient is a covector; if ``I_out(p) = I_in(h(p))`` then
        ``grad I_out = J^T grad I_in``. ``"paper"``: Wang et al. eq. (3) read literally --
        it multiplies the direction ``(cos t, sin t)`` by the Jacobian, the rule for edge
        (tangent) directions; from input to output that is ``J^{-1}``.

    Returns
    -------
    ndarray of output-view angles in ``[0, pi)``, the broadcast shape.
    """
    theta = np.asarray(theta, dtype=np.float64)
    if rule == "none":
        return np.mod(theta, np.pi)
    J = np.asarray(jacobian, dtype=np.float64)
    if rule == "covariant":
        M = np.swapaxes(J, -1, -2)
    elif rule == "paper":
        M = np.linalg.inv(J)
    else:
        raise ValueError(f"rule must be one of {ANGLE_RULES}, got {rule!r}")
    u = np.stack([np.cos(theta), np.sin(theta)], axis=-1)[..., None]  # (..., 2, 1)
    v = (M @ u)[..., 0]
    return np.mod(np.arctan2(v[..., 1], v[..., 0]), np.pi)


def _bin_overlaps(start, length, n_bins):
    """Overlap of circular intervals [start, start+length) (mod n_bins, in bin units) with
    each unit bin. start, length: (..., T); returns (..., T, n_bins)."""
    s = np.mod(start, n_bins)[..., None]
    e = s + np.asarray(length)[..., None]
    b = np.arange(n_bins)
    out = np.zeros(np.shape(s)[:-1] + (n_bins,))
    for shift in (0, n_bins):          # the interval may wrap once past n_bins
        lo = np.maximum(s, b + shift)
        hi = np.minimum(e, b + 1 + shift)
        out += np.maximum(hi - lo, 0.0)
    return out


def orientation_remap_matrix(jacobian, n_bins: int = 9, rule: str = "covariant", *,
                             bin_offset: float = 0.0) -> np.ndarray:
    """Orientation-bin resampling ``A`` (Wang et al. 2017, eq. (3)-(4)).

    The edges of each input bin ``j``, ``[j pi/B, (j+1) pi/B)``, are mapped into the output
    view (:func:`map_angles`); the mapped interval is overlapped with every output bin:

    .. math:: A_{ij} = \\frac{|[\\theta_i, \\theta_{i+1}] \\cap [\\theta'_j, \\theta'_{j+1}]|}
                            {|[\\theta'_j, \\theta'_{j+1}]|}

    so each column sums to 1 (an input bin's mass is redistributed, not created).

    Parameters
    ----------
    jacobian : (2, 2) or (K, 2, 2) array_like
        Jacobian(s) of ``H_out_to_in`` (one per output cell for the per-cell form).
    n_bins : int
    rule : {"covariant", "paper", "none"}
    bin_offset : float
        Bin ``j`` covers ``[(j + bin_offset) pi/B, (j + 1 + bin_offset) pi/B)``: 0 for
        HOG (OpenCV's centres at ``(j + 1/2) pi/B``), -0.5 for ACF (centres at ``j pi/B``).

    Returns
    -------
    A : (n_bins, n_bins) or (K, n_bins, n_bins) ndarray, ``A[..., out_bin, in_bin]``.
    """
    J = np.asarray(jacobian, dtype=np.float64)
    if J.shape[-2:] != (2, 2):
        raise ValueError(f"jacobian must have shape (2, 2) or (K, 2, 2), got {J.shape}")
    if rule not in ANGLE_RULES:
        raise ValueError(f"rule must be one of {ANGLE_RULES}, got {rule!r}")
    det = np.linalg.det(J)
    if np.any(det <= 0) or not np.all(np.isfinite(J)):
        raise ValueError("jacobian must be finite with a positive determinant")
    single = J.ndim == 2
    J = J.reshape(-1, 2, 2)
    if rule == "none":
        A = np.broadcast_to(np.eye(n_bins), (len(J), n_bins, n_bins)).copy()
        return A[0] if single else A
    edges = (np.arange(n_bins + 1) + bin_offset) * (np.pi / n_bins)
    mapped = map_angles(np.broadcast_to(edges, (len(J), n_bins + 1)), J[:, None], rule)  # (K, B+1)
    # An orientation-preserving linear map moves angles monotonically (mod pi), so the
    # mapped bin j is the interval from mapped[j] going forward to mapped[j+1].
    scale = n_bins / np.pi
    start = mapped[:, :-1] * scale - bin_offset
    length = np.mod(mapped[:, 1:] - mapped[:, :-1], np.pi) * scale
    length = np.where(length <= 0, 1e-12, length)
    ov = _bin_overlaps(start, length, n_bins)                    # (K, in_bin, out_bin)
    A = np.swapaxes(ov / length[..., None], 1, 2)                # (K, out_bin, in_bin)
    return A[0] if single else A


# ------------------------------------------------------------------------ G = S (x) A


def feature_remap_matrix(H_out_to_in, out_grid: CellGrid, in_grid: CellGrid, *,
                         n_bins: int = 9, rule: str = "covariant", per_cell: bool = True,
                         anchor=None, preserve: str = "sum",
                         bin_offset: float = 0.0, n_plain: int = 0) -> sp.csr_matrix:
    """HOG-like feature remapping ``G = S (x) A`` (eq. (5)), or its per-cell refinement.

    Parameters
    ----------
    H_out_to_in : (3, 3) array_like
        Output view -> input view (``H_st`` for adapting a source-view classifier).
    out_grid, in_grid : CellGrid
    n_bins : int
        Orientation bins per cell (1 for Haar-like channels without orientation).
    rule : {"covariant", "paper", "none"}
        Angle rule for ``A`` (see :func:`map_angles`).
    per_cell : bool
        True: each output cell ``k`` gets its own ``A_k`` from the Jacobian at its centre,
        ``G[(k, i), (l, j)] = S_kl A_k[i, j]`` -- the angle map depends on position under a
        homography. False: the paper's single ``A`` from the Jacobian at ``anchor``.
    anchor : (2,) array_like, optional
        Output-view point for the single ``A``; default the centre of ``out_grid``.
    preserve : {"sum", "mean"}
        See :func:`cell_remap_matrix`.
    bin_offset : float
        See :func:`orientation_remap_matrix`.
    n_plain : int
        Channels without orientation after the ``n_bins`` bins of each cell (e.g. the
        texture energies of block-normalised HOG cells): remapped by ``S`` alone, so
        ``G = S (x) diag(A, I)``.

    Returns
    -------
    G : (out_grid.n_cells * D, in_grid.n_cells * D) scipy.sparse.csr_matrix
        ``D = n_bins + n_plain``; acting on features flattened as ``(cell, channel)``
        (row-major ``(n_y, n_x, D)``).
    """
    S = cell_remap_matrix(H_out_to_in, out_grid, in_grid, preserve=preserve)
    H = check_homography(H_out_to_in, "H_out_to_in")
    n_plain = _check_n_plain(n_plain)
    if n_bins == 1 or rule == "none":
        return assemble_remap_matrix(S, None, n_bins=n_bins, n_plain=n_plain)
    if not per_cell:
        if anchor is None:
            x0, y0, x1, y1 = out_grid.bounds()
            anchor = ((x0 + x1) / 2, (y0 + y1) / 2)
        J = homography_jacobian(H, np.asarray(anchor, float))
    else:
        J = homography_jacobian(H, out_grid.centers())
    A = orientation_remap_matrix(J, n_bins, rule, bin_offset=bin_offset)
    return assemble_remap_matrix(S, A, n_bins=n_bins, n_plain=n_plain)


def _check_n_plain(n_plain) -> int:
    if int(n_plain) != n_plain or n_plain < 0:
        raise ValueError(f"n_plain must be a non-negative integer, got {n_plain!r}")
    return int(n_plain)


def assemble_remap_matrix(S, A, *, n_bins: int, n_plain: int = 0) -> sp.csr_matrix:
    """``G = S (x) diag(A, I)`` from a cell resampling ``S`` and orientation resampling ``A``.

    Parameters
    ----------
    S : (K, L) sparse matrix
        Output cells x input cells.
    A : None, (n_bins, n_bins) or (K, n_bins, n_bins) array_like
        ``None``: no orientation remapping (``A = I``); one matrix for every output cell
        (the paper's single ``A``); or one per output cell, ``G[(k, i), (l, j)] = S_kl
        A_k[i, j]``.
    n_bins : int
        Orientation bins per cell.
    n_plain : int
        Channels without orientation after the bins, remapped by ``S`` alone.

    Returns
    -------
    G : (K (n_bins + n_plain), L (n_bins + n_plain)) scipy.sparse.csr_matrix, acting on
        features flattened as ``(cell, channel)``.
    """
    n_plain = _check_n_plain(n_plain)
    B = n_bins + n_plain
    S = sp.coo_matrix(S)
    if A is None:
        return sp.kron(S, sp.identity(B), format="csr")
    A = np.asarray(A, dtype=np.float64)
    if A.ndim == 2:
        if A.shape != (n_bins, n_bins):
            raise ValueError(f"A must be ({n_bins}, {n_bins}), got {A.shape}")
        return sp.kron(S, sp.block_diag([A, sp.identity(n_plain)]) if n_plain else
                       sp.csr_matrix(A), format="csr")
    if A.shape != (S.shape[0], n_bins, n_bins):
        raise ValueError(f"per-cell A must be ({S.shape[0]}, {n_bins}, {n_bins}), got {A.shape}")
    # entries (k, l, i, j) -> value S_kl * A_k[i, j] for the bins; S_kl on the diagonal of
    # the plain channels
    ii, jj = np.meshgrid(np.arange(n_bins), np.arange(n_bins), indexing="ij")
    rows = [(S.row[:, None, None] * B + ii[None]).ravel()]
    cols = [(S.col[:, None, None] * B + jj[None]).ravel()]
    vals = [(S.data[:, None, None] * A[S.row]).ravel()]             # (nnz, n_bins, n_bins)
    if n_plain:
        p = n_bins + np.arange(n_plain)
        rows.append((S.row[:, None] * B + p).ravel())
        cols.append((S.col[:, None] * B + p).ravel())
        vals.append(np.repeat(S.data, n_plain))
    rows, cols, vals = (np.concatenate(a) for a in (rows, cols, vals))
    nz = vals != 0
    return sp.csr_matrix((vals[nz], (rows[nz], cols[nz])),
                         shape=(S.shape[0] * B, S.shape[1] * B))
