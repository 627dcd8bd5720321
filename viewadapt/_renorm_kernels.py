"""Compiled loops of the per-window normalisation stage (numba), loaded on first use.

:func:`raw_cell_sums` sums each pixel's magnitude, split between its two orientation bins,
into ``c x c`` cells (hard spatial binning; :func:`sum_cells` sums such cells into larger
ones). :func:`renorm_scores` scores windows of an OpenCV HOG/SVM from those cells: each
source cell's histogram is the frame cells' under the image of that cell (an axis-aligned
rectangle, its centre mapped by the window's homography and its sides by the homography's
Jacobian there: ``S``), its orientations mapped by the covariant rule at the window's
centre (``A``); then the window's own 2x2-cell blocks are L2-Hys normalised as
``cv2.HOGDescriptor`` does and dotted with the SVM's weights
(:mod:`viewadapt.detect.renorm`); :func:`hog_renorm_scores` normalises the same source
cells as the project's HOG (:func:`viewadapt.detect.block_normalize_cells`). Frame cells
outside a map read as zero, so no stored table can make the loops read outside the maps.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ._kernels import block_inverse_norms


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def raw_cell_sums(mag, t, c, out, cy0, cy1):  # pragma: no cover - compiled
    """(M // c, N // c, 9) cell sums of ``mag`` split between bins ``floor(t)`` (weight
    ``1 - frac``) and the next (``frac``), written into the cell rows ``cy0 <= cy < cy1``
    of ``out`` (the others are left as they are)."""
    n_bins = 9
    ny, nx = mag.shape[0] // c, mag.shape[1] // c
    cy0, cy1 = max(cy0, 0), min(cy1, ny)
    for cy in range(cy0, cy1):
        for cx in range(nx):
            for b in range(n_bins):
                out[cy, cx, b] = 0.0
    for cy in range(cy0, cy1):
        for r in range(c):
            y = cy * c + r
            for cx in range(nx):
                for i in range(c):
                    x = cx * c + i
                    m = mag[y, x]
                    tt = t[y, x]
                    b0 = int(tt)             # t >= 0: truncation is the floor
                    f = tt - np.float32(b0)
                    if b0 >= n_bins:
                        b0 -= n_bins
                    b0 = min(max(b0, 0), n_bins - 1)
                    b1 = b0 + 1 if b0 < n_bins - 1 else 0
                    m1 = m * f
                    out[cy, cx, b0] += m - m1
                    out[cy, cx, b1] += m1


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def sum_cells(src, k, out, y0, y1):  # pragma: no cover - compiled
    """(ny // k, nx // k, B) sums of ``src`` (ny, nx, B) over ``k x k`` cells into the rows
    ``y0 <= y < y1`` of ``out`` (the others are left as they are)."""
    my, mx = src.shape[0] // k, src.shape[1] // k
    nb = src.shape[2]
    for y in range(max(y0, 0), min(y1, my)):
        for x in range(mx):
            for b in range(nb):
                out[y, x, b] = 0.0
        for r in range(k):
            for x in range(mx):
                for i in range(k):
                    for b in range(nb):
                        out[y, x, b] += src[y * k + r, x * k + i, b]


@njit(cache=True, nogil=True, inline="always")
def _map(H, x, y):
    """Image point and Jacobian of ``(x, y)`` under the homography ``H``."""
    u = H[0, 0] * x + H[0, 1] * y + H[0, 2]
    v = H[1, 0] * x + H[1, 1] * y + H[1, 2]
    w = H[2, 0] * x + H[2, 1] * y + H[2, 2]
    px, py = u / w, v / w
    j00 = (H[0, 0] - px * H[2, 0]) / w
    j01 = (H[0, 1] - px * H[2, 1]) / w
    j10 = (H[1, 0] - py * H[2, 0]) / w
    j11 = (H[1, 1] - py * H[2, 1]) / w
    return px, py, j00, j01, j10, j11


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _angle_taps(j00, j01, j10, j11, rule, lo, hi, frac):  # pragma: no cover - compiled
    """``A`` of the Jacobian ``[[j00, j01], [j10, j11]]`` as two taps per frame bin ``k``:
    source bins ``lo[k]`` (weight ``1 - frac[k]``) and ``hi[k]`` (``frac[k]``); ``rule`` 0
    covariant (``J^T``), 1 none, 2 the paper's eq. (3) read literally (``J^-1``)."""
    n_bins = len(lo)
    for k in range(n_bins):
        if rule == 1:
            lo[k], hi[k], frac[k] = k, k, 0.0
            continue
        phi = (k + 0.5) * math.pi / n_bins
        if rule == 0:
            gx = j00 * math.cos(phi) + j10 * math.sin(phi)
            gy = j01 * math.cos(phi) + j11 * math.sin(phi)
        else:
            det = j00 * j11 - j01 * j10
            gx = (j11 * math.cos(phi) - j01 * math.sin(phi)) / det
            gy = (-j10 * math.cos(phi) + j00 * math.sin(phi)) / det
        theta = math.atan2(gy, gx) % math.pi
        tt = theta * n_bins / math.pi - 0.5
        if tt < 0:
            tt += n_bins
        b0 = int(tt)
        f = tt - b0
        if b0 >= n_bins:
            b0 -= n_bins
        b0 = min(max(b0, 0), n_bins - 1)         # (a non-finite Jacobian: still a bin)
        lo[k] = b0
        hi[k] = b0 + 1 if b0 < n_bins - 1 else 0
        frac[k] = f


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def _block_score(block, weights, at, eps, clip):  # pragma: no cover - compiled
    """``weights[at:at + 36] . L2Hys(block)`` (OpenCV's ``normalizeBlockHistogram``);
    ``block`` (36,) is overwritten. Sums in four interleaved partial sums."""
    s0 = s1 = s2 = s3 = 0.0
    for k in range(0, 36, 4):
        s0 += block[k] * block[k]
        s1 += block[k + 1] * block[k + 1]
        s2 += block[k + 2] * block[k + 2]
        s3 += block[k + 3] * block[k + 3]
    sc = 1.0 / (math.sqrt((s0 + s1) + (s2 + s3)) + eps)
    s0 = s1 = s2 = s3 = 0.0
    for k in range(0, 36, 4):
        v0 = min(block[k] * sc, clip)
        v1 = min(block[k + 1] * sc, clip)
        v2 = min(block[k + 2] * sc, clip)
        v3 = min(block[k + 3] * sc, clip)
        block[k], block[k + 1], block[k + 2], block[k + 3] = v0, v1, v2, v3
        s0 += v0 * v0
        s1 += v1 * v1
        s2 += v2 * v2
        s3 += v3 * v3
    sc = 1.0 / (math.sqrt((s0 + s1) + (s2 + s3)) + 1e-3)
    s0 = s1 = s2 = s3 = 0.0
    for k in range(0, 36, 4):
        s0 += weights[at + k] * block[k]
        s1 += weights[at + k + 1] * block[k + 1]
        s2 += weights[at + k + 2] * block[k + 2]
        s3 += weights[at + k + 3] * block[k + 3]
    return ((s0 + s1) + (s2 + s3)) * sc


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def _rect_cell(flat, base, ny, nx, c, ic, area, px, py, ex, ey, h):  # pragma: no cover
    """The raw cells of size ``c`` (``flat[base:]``, (ny, nx, 9)) under the axis-aligned
    rectangle of centre ``(px, py)`` and half-sides ``ex, ey``, area-weighted, summed into
    ``h`` (9,) and scaled per source pixel of an 8-px cell (``area`` = 16 / c^2 against
    the rectangle's area 4 ex ey)."""
    n_bins = 9
    x0, x1, y0, y1 = px - ex, px + ex, py - ey, py + ey
    for k in range(n_bins):
        h[k] = 0.0
    # the frame cells the rectangle can touch (one more at an exact boundary reads
    # weight 0)
    u0 = max(int(math.floor((x0 + 0.5) * ic)), 0)
    u1 = min(int(math.floor((x1 + 0.5) * ic)), nx - 1)
    v0 = max(int(math.floor((y0 + 0.5) * ic)), 0)
    v1 = min(int(math.floor((y1 + 0.5) * ic)), ny - 1)
    for v in range(v0, v1 + 1):
        wy = min(y1, c * (v + 1) - 0.5) - max(y0, c * v - 0.5)
        if wy <= 0:
            continue
        for u in range(u0, u1 + 1):
            wx = min(x1, c * (u + 1) - 0.5) - max(x0, c * u - 0.5)
            if wx <= 0:
                continue
            wgt = np.float32(wx * wy)
            at = base + (v * nx + u) * n_bins
            for k in range(n_bins):
                h[k] += wgt * flat[at + k]
    return np.float32(area / max(ex * ey, 2.5e-13))


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _window_cells(flat, base, ny, nx, c, Hn, rule, ncx, ncy, lo, hi, frac, h,
                  src):  # pragma: no cover - compiled
    """The (ncy, ncx, 9) source cells ``src`` of one window (homography ``Hn``) from the
    raw cells of size ``c`` at ``flat[base:]`` ((ny, nx, 9)): each source cell the frame
    cells under its image (an axis-aligned rectangle: its centre mapped, its sides by the
    Jacobian there; ``S``), per source pixel of an 8-px cell, its orientations mapped by
    the rule at the window's centre (``A``); ``lo, hi, frac, h`` scratch. (The centre and
    Jacobian of :func:`_map` inline, with one division; the cell weights in float32.)"""
    n_bins = 9
    _, _, j00, j01, j10, j11 = _map(Hn, 4.0 * ncx - 0.5, 4.0 * ncy - 0.5)
    _angle_taps(j00, j01, j10, j11, rule, lo, hi, frac)
    ic = 1.0 / c
    area = 16.0 / (c * c)          # 64 / c^2 against the rectangle's area 4 ex ey
    h00, h01, h02 = Hn[0, 0], Hn[0, 1], Hn[0, 2]
    h10, h11, h12 = Hn[1, 0], Hn[1, 1], Hn[1, 2]
    h20, h21, h22 = Hn[2, 0], Hn[2, 1], Hn[2, 2]
    for j in range(ncy):
        y = 8.0 * j + 3.5
        for i in range(ncx):
            x = 8.0 * i + 3.5
            iw = 1.0 / (h20 * x + h21 * y + h22)
            px = (h00 * x + h01 * y + h02) * iw
            py = (h10 * x + h11 * y + h12) * iw
            ex = 4.0 * abs((h00 - px * h20) * iw)
            ey = 4.0 * abs((h11 - py * h21) * iw)
            scale = _rect_cell(flat, base, ny, nx, c, ic, area, px, py, ex, ey, h)
            for k in range(n_bins):
                src[j, i, k] = 0.0
            for k in range(n_bins):
                t = h[k] * scale
                src[j, i, lo[k]] += (np.float32(1.0) - frac[k]) * t
                src[j, i, hi[k]] += frac[k] * t


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _mapped_window_cells(flat, base, ny, nx, c, Hn, R, rule, ncx, ncy, lo, hi, frac, h,
                         src):  # pragma: no cover - compiled
    """:func:`_window_cells` for an object model that is not the window's plane: source
    cell ``(j, i)`` is first moved within the canonical window by ``R[j, i]`` -- its
    centre's image ``R[j, i, :2]`` and the Jacobian there ``R[j, i, 2:]`` (row-major
    2x2) -- then mapped by ``Hn``; its rectangle's sides and its ``A`` come from the
    Jacobian of the two composed, at that cell (as the fold's per-cell ``A``). A cell whose
    ``R`` is not finite (the object model hides it) reads nothing."""
    n_bins = 9
    ic = 1.0 / c
    area = 16.0 / (c * c)
    for j in range(ncy):
        for i in range(ncx):
            for k in range(n_bins):
                src[j, i, k] = 0.0
            cx, cy = R[j, i, 0], R[j, i, 1]
            r00, r01, r10, r11 = R[j, i, 2], R[j, i, 3], R[j, i, 4], R[j, i, 5]
            if not (math.isfinite(cx) and math.isfinite(cy) and math.isfinite(r00)
                    and math.isfinite(r01) and math.isfinite(r10) and math.isfinite(r11)):
                continue
            px, py, a00, a01, a10, a11 = _map(Hn, cx, cy)
            j00 = a00 * r00 + a01 * r10
            j01 = a00 * r01 + a01 * r11
            j10 = a10 * r00 + a11 * r10
            j11 = a10 * r01 + a11 * r11
            _angle_taps(j00, j01, j10, j11, rule, lo, hi, frac)
            scale = _rect_cell(flat, base, ny, nx, c, ic, area, px, py, 4.0 * abs(j00),
                               4.0 * abs(j11), h)
            for k in range(n_bins):
                t = h[k] * scale
                src[j, i, lo[k]] += (np.float32(1.0) - frac[k]) * t
                src[j, i, hi[k]] += frac[k] * t


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def renorm_scores(flat, offsets, dims, size_of, cells, H, weights, bias, eps, clip,
                  rule, ncx, ncy, out):  # pragma: no cover - compiled
    """Scores of windows ``n`` (their homographies ``H[n]``, the detector's window of
    ``ncx x ncy`` 8-px cells (64x128: 8 x 16) -> frame px) from the raw cell map of size
    ``cells[size_of[n]]``: ``flat[offsets[s]:]`` laid out ``(dims[s, 0], dims[s, 1], 9)``.
    ``weights`` ((ncx - 1) (ncy - 1) 36,) OpenCV's descriptor layout;
    ``rule`` 0 = covariant (``J^T``), 1 = none (orientations kept), 2 = the paper's eq. (3)
    read literally (``J^-1``; :func:`viewadapt.remap.map_angles`)."""
    n_bins = 9
    src = np.empty((ncy, ncx, n_bins), np.float32)
    lo = np.empty(n_bins, np.int64)              # frame bin k -> source bins lo, hi
    hi = np.empty(n_bins, np.int64)
    frac = np.empty(n_bins, np.float32)
    h = np.empty(n_bins, np.float32)
    block = np.empty(4 * n_bins, np.float32)
    for n in range(len(out)):
        s = size_of[n]
        _window_cells(flat, offsets[s], dims[s, 0], dims[s, 1], cells[s], H[n], rule, ncx,
                      ncy, lo, hi, frac, h, src)
        total = bias
        for bx in range(ncx - 1):
            for by in range(ncy - 1):
                for cx in range(2):
                    for cy in range(2):
                        q = 2 * cx + cy
                        for b in range(n_bins):
                            block[q * n_bins + b] = src[by + cy, bx + cx, b]
                total += _block_score(block, weights, (bx * (ncy - 1) + by) * 4 * n_bins,
                                      eps, clip)
        out[n] = total


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _hog_window_score(src, W2, eps, clip, E, inv):  # pragma: no cover - compiled
    """``sum(W * block_normalize(src))`` without the features: each cell's copy in block
    ``k`` (``min(X v_k, clip)``, ``v_k`` the block's inverse norm, reflected at the
    window's border as :func:`viewadapt._kernels.block_normalize` does) is dotted with
    ``W2[i, j, k]``, its orientation weights plus its texture weight ``k``; ``E``, ``inv``
    scratch ((ny, nx) and (ny + 1, nx + 1))."""
    ny, nx, nb = src.shape
    block_inverse_norms(src, eps, 0, ny, E, inv)
    cl = np.float32(clip)
    total = 0.0
    for i in range(ny):
        for j in range(nx):
            for k in range(4):
                v = inv[i + k // 2, j + k % 2]
                acc = np.float32(0.0)
                for b in range(nb):
                    acc += min(src[i, j, b] * v, cl) * W2[i, j, k, b]
                total += acc
    return total


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def hog_renorm_scores(flat, offsets, dims, size_of, cells, H, weights, bias, eps, clip,
                      rule, ncx, ncy, out, R=None, r_of=None):  # pragma: no cover - compiled
    """:func:`renorm_scores` for the project's HOG/SVM: each window's source cells
    (:func:`_window_cells`) block-normalised in the window as
    :func:`viewadapt.detect.block_normalize_cells` normalises a canonical window's cells
    (13 channels per cell, reflected borders, floor ``eps``, clip ``clip``), dotted with
    ``weights`` ((ncy, ncx, 13) flat) plus ``bias``. The 13 channels are not formed: each
    clipped block copy is dotted with its orientation weights plus its block's texture
    weight (:func:`_hog_window_score`; the same sum in another order). With ``R``
    ((M, ncy, ncx, 6)) and ``r_of`` ((N,) int), window ``n``'s source cells are first
    moved by ``R[r_of[n]]`` (:func:`_mapped_window_cells`: an object model other than the
    plane)."""
    n_bins = 9
    nc = n_bins + 4
    src = np.empty((ncy, ncx, n_bins), np.float32)
    W2 = np.empty((ncy, ncx, 4, n_bins), np.float32)   # [cell, block k, bin]
    for i in range(ncy):
        for j in range(ncx):
            at = (i * ncx + j) * nc
            for k in range(4):
                for b in range(n_bins):
                    W2[i, j, k, b] = weights[at + b] + weights[at + n_bins + k]
    E = np.empty((ncy, ncx), np.float32)
    inv = np.empty((ncy + 1, ncx + 1), np.float32)
    lo = np.empty(n_bins, np.int64)
    hi = np.empty(n_bins, np.int64)
    frac = np.empty(n_bins, np.float32)
    h = np.empty(n_bins, np.float32)
    for n in range(len(out)):
        s = size_of[n]
        if R is None:
            _window_cells(flat, offsets[s], dims[s, 0], dims[s, 1], cells[s], H[n], rule,
                          ncx, ncy, lo, hi, frac, h, src)
        else:
            _mapped_window_cells(flat, offsets[s], dims[s, 0], dims[s, 1], cells[s], H[n],
                                 R[r_of[n]], rule, ncx, ncy, lo, hi, frac, h, src)
        out[n] = _hog_window_score(src, W2, eps, clip, E, inv) + bias


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _axis_tables(ax, cum, tab):  # pragma: no cover - compiled
    """Tables of the block taps of :func:`renorm_scores_binned` from ``ax`` (16, 2):
    ``tab[o, r, i]`` the weight of the
    ``i``-th source pixel from the low end of the block's image (``o`` 0: pixels in order,
    a positive Jacobian; 1: reversed) for cell role ``r``, ``cum[o, r, i]`` the sum of
    ``tab[o, r, :i]``."""
    for o in range(2):
        for r in range(2):
            acc = 0.0
            for i in range(16):
                a = ax[i, r] if o == 0 else ax[15 - i, r]
                tab[o, r, i] = a
                cum[o, r, i] = acc
                acc += a
            cum[o, r, 16] = acc


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def renorm_scores_binned(flat, offsets, dims, size_of, cells, H, weights, bias, eps, clip,
                         rule, ncx, ncy, ax, out):  # pragma: no cover - compiled
    """:func:`renorm_scores` with OpenCV's own spatial binning: each block's four cell
    histograms are the frame cells under the block's image weighted by OpenCV's Gaussian
    block window times each cell's bilinear tent (``ax``: (16, 2), the weights along one
    axis of a 16-px block), carried through the block's affine approximation (its centre
    and Jacobian under ``H[n]``).

    Per axis, the weight of a frame cell for one of the block's two cell roles is the
    integral over the cell of the block's 16 source pixels' weights (each spread over its
    image, per frame pixel), read from running sums at the cell's two ends
    (:func:`_axis_tables`). The weights are separable: the cells are summed down the rows
    first, then along ``u``. A window's blocks (105 in a 64x128 window) are gathered
    first, then mapped to the source bins, normalised and scored all together, block index
    innermost. (No helper taking arrays is called per block: each such call would count
    references.)
    """
    n_bins = 9
    nq = 4 * n_bins
    nby = ncy - 1
    nb = (ncx - 1) * nby
    lo = np.empty(n_bins, np.int64)              # frame bin k -> source bins lo, hi
    hi = np.empty(n_bins, np.int64)
    frac = np.empty(n_bins, np.float32)
    p0 = np.empty(24 * n_bins, np.float32)       # a block's rows of cells summed for cy = 0
    p1 = np.empty(24 * n_bins, np.float32)       # and for cy = 1
    w = np.empty((2, 2, 24), np.float32)         # [axis, role, cell] weights of one block
    cum = np.empty((2, 2, 17), np.float64)
    tab = np.empty((2, 2, 16), np.float64)
    _axis_tables(ax, cum, tab)
    geo = np.empty((nb, 2, 2), np.float64)       # [block, axis]: centre, Jacobian
    ext = np.empty((nb, 2, 2), np.int64)         # [block, axis]: first cell, count
    raws = np.empty((nq, nb), np.float32)        # [frame channel, block]
    blocks = np.empty((nq, nb), np.float32)      # [source channel, block]
    wt = np.empty((nq, nb), np.float32)          # the weights, [channel, block]
    for b in range(nb):
        for k in range(nq):
            wt[k, b] = weights[b * nq + k]
    ss = np.empty(nb, np.float64)
    sc = np.empty(nb, np.float64)
    for n in range(len(out)):
        s = size_of[n]
        c = cells[s]
        ny, nx = dims[s, 0], dims[s, 1]
        base = offsets[s]
        Hn = H[n]
        _, _, j00, j01, j10, j11 = _map(Hn, 4.0 * ncx - 0.5, 4.0 * ncy - 0.5)
        _angle_taps(j00, j01, j10, j11, rule, lo, hi, frac)
        inv = 1.0 / (c * c)
        # each block's centre (source pixel 8 bx + 7.5, 8 by + 7.5), Jacobian and the
        # frame cells that can hold its image
        for b in range(nb):
            px, py, a00, a01, a10, a11 = _map(Hn, 8.0 * (b // nby) + 7.5, 8.0 * (b % nby) + 7.5)
            ex = 8.0 * abs(a00) + 1.0
            ey = 8.0 * abs(a11) + 1.0
            u0 = max(int(math.floor((px - ex + 0.5) / c)), 0)
            v0 = max(int(math.floor((py - ey + 0.5) / c)), 0)
            geo[b, 0, 0], geo[b, 0, 1], geo[b, 1, 0], geo[b, 1, 1] = px, a00, py, a11
            ext[b, 0, 0] = u0
            ext[b, 0, 1] = min(int(math.floor((px + ex + 0.5) / c)), nx - 1) - u0 + 1
            ext[b, 1, 0] = v0
            ext[b, 1, 1] = min(int(math.floor((py + ey + 0.5) / c)), ny - 1) - v0 + 1
        for b in range(nb):
            u0, nu, v0, nv = ext[b, 0, 0], ext[b, 0, 1], ext[b, 1, 0], ext[b, 1, 1]
            if nu <= 0 or nv <= 0:
                for k in range(nq):
                    raws[k, b] = 0.0
                continue
            nu = min(nu, 24)
            nv = min(nv, 24)
            for a in range(2):
                centre, jac = geo[b, a, 0], geo[b, a, 1]
                first = u0 if a == 0 else v0
                hl = abs(jac)                      # a source pixel's image length
                o = 0 if jac > 0 else 1
                low = centre - 8.0 * hl            # the block's image starts here
                ih = 1.0 / hl if hl > 0.0 else 0.0
                scale = hl / max(hl, 1e-12)
                g0 = g1 = 0.0
                for k in range((nu if a == 0 else nv) + 1):
                    # the source pixels' weight below the cell boundary c (first + k) - 1/2
                    q = (c * (first + k) - 0.5 - low) * ih
                    if not q > 0.0:                # also NaN
                        q = 0.0
                    if q > 16.0:
                        q = 16.0
                    i = min(int(q), 15)
                    f = q - i
                    h0 = cum[o, 0, i] + tab[o, 0, i] * f
                    h1 = cum[o, 1, i] + tab[o, 1, i] * f
                    if k > 0:
                        w[a, 0, k - 1] = (h0 - g0) * scale
                        w[a, 1, k - 1] = (h1 - g1) * scale
                    g0, g1 = h0, h1
            # cells of zero weight in both roles at the ends add nothing
            ua, ub = 0, nu
            while ua < ub and w[0, 0, ua] == 0 and w[0, 1, ua] == 0:
                ua += 1
            while ub > ua and w[0, 0, ub - 1] == 0 and w[0, 1, ub - 1] == 0:
                ub -= 1
            L = (ub - ua) * n_bins
            for j in range(L):
                p0[j] = 0.0
                p1[j] = 0.0
            for v in range(nv):
                y0 = w[1, 0, v]
                y1 = w[1, 1, v]
                if y0 == 0 and y1 == 0:
                    continue
                at = base + ((v0 + v) * nx + u0 + ua) * n_bins
                fr = flat[at:at + L]               # (a view: no index wraparound)
                for j in range(L):
                    f = fr[j]
                    p0[j] += y0 * f
                    p1[j] += y1 * f
            for k in range(n_bins):
                r00 = r01 = r10 = r11 = np.float32(0.0)
                for u in range(ua, ub):
                    x0 = w[0, 0, u]
                    x1 = w[0, 1, u]
                    at = (u - ua) * n_bins + k
                    r00 += x0 * p0[at]
                    r01 += x0 * p1[at]
                    r10 += x1 * p0[at]
                    r11 += x1 * p1[at]
                raws[k, b] = r00
                raws[n_bins + k, b] = r01
                raws[2 * n_bins + k, b] = r10
                raws[3 * n_bins + k, b] = r11
        # frame bins -> source bins (A), per cell area
        for k in range(nq):
            for b in range(nb):
                blocks[k, b] = 0.0
        for k in range(n_bins):
            f1 = np.float32(frac[k] * inv)
            f0 = np.float32(inv) - f1
            for q in range(4):
                src = raws[q * n_bins + k]
                d0 = blocks[q * n_bins + lo[k]]
                for b in range(nb):
                    d0[b] += f0 * src[b]
                d1 = blocks[q * n_bins + hi[k]]
                for b in range(nb):
                    d1[b] += f1 * src[b]
        # L2-Hys (OpenCV's normalizeBlockHistogram) and the weights, every block at once
        for b in range(nb):
            ss[b] = 0.0
        for k in range(nq):
            row = blocks[k]
            for b in range(nb):
                ss[b] += row[b] * row[b]
        for b in range(nb):
            sc[b] = 1.0 / (math.sqrt(ss[b]) + eps)
            ss[b] = 0.0
        for k in range(nq):
            row = blocks[k]
            for b in range(nb):
                v = min(row[b] * sc[b], clip)
                row[b] = v
                ss[b] += v * v
        for b in range(nb):
            sc[b] = 1.0 / (math.sqrt(ss[b]) + 1e-3)
            ss[b] = 0.0
        for k in range(nq):
            row = blocks[k]
            wk = wt[k]
            for b in range(nb):
                ss[b] += wk[b] * row[b]
        total = bias
        for b in range(nb):
            total += ss[b] * sc[b]
        out[n] = total
