"""Compiled inner loops (numba), imported only when a run-time operator first needs them.

Kept apart so that ``import viewadapt`` stays light: numba and its JIT load on the first
frame scored, and the compiled code is cached on disk (``cache=True``: next to this file,
or numba's user-wide cache directory where that is read-only).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, fastmath=True, nogil=True, boundscheck=False)
def template_run_scores(x, templates, t_offset, t_rows, t_run, x_stride, starts, group,
                        out):  # pragma: no cover - compiled; tested through its callers
    """``out[r] = sum_dy templates[t_offset[g] + dy t_run[g] : + t_run[g]] .
    x[starts[r] + dy x_stride[g] : + t_run[g]]`` over ``dy < t_rows[g]``, ``g = group[r]``.

    One adapted template per group, stored row-major ``(n_y, n_x, C)``: each of its ``n_y``
    rows is one contiguous run of ``n_x C`` values, and so is the patch row it meets in a
    padded ``(N_y, N_x, C)`` cell map (``x_stride = N_x C`` apart). Each run is a float32
    dot product (vectorised); runs add up in float64.
    """
    for r in range(starts.shape[0]):
        g = group[r]
        t0 = t_offset[g]
        n = t_run[g]
        stride = x_stride[g]
        s0 = starts[r]
        total = 0.0
        for dy in range(t_rows[g]):
            tv = templates[t0 + dy * n:t0 + dy * n + n]
            xv = x[s0 + dy * stride:s0 + dy * stride + n]
            acc = np.float32(0.0)
            for k in range(n):
                acc += tv[k] * xv[k]
            total += acc
        out[r] = total
    return out


@njit(cache=True, nogil=True, boundscheck=False)
def strongest_gradient(dx, dy, gx, gy):  # pragma: no cover - compiled
    """Per pixel of (M, N, K) derivatives, the ``(dx, dy)`` of the channel of largest
    ``dx**2 + dy**2`` (ties keep the earlier channel), written into (M, N) ``gx, gy``."""
    M, N, K = dx.shape
    for i in range(M):
        for j in range(N):
            bx = dx[i, j, 0]
            by = dy[i, j, 0]
            best = bx * bx + by * by
            for k in range(1, K):
                x = dx[i, j, k]
                y = dy[i, j, k]
                m = x * x + y * y
                if m > best:
                    best = m
                    bx = x
                    by = y
            gx[i, j] = bx
            gy[i, j] = by


@njit(cache=True, nogil=True, boundscheck=False)
def orientation_cell_sums(mag, ang, n_bins, c, out):  # pragma: no cover - compiled
    """Oriented-magnitude sums over ``c x c`` cells, added into ``out`` (ny, nx, n_bins).

    Pixel ``(i, j)`` with ``i < ny c, j < nx c`` adds its magnitude to the two unsigned bins
    nearest its angle (centres ``(b + 1/2) pi / n_bins``), split linearly -- the
    channels of ``viewadapt.detect.fast_orientation_channels`` summed per cell.
    """
    ny, nx = out.shape[0], out.shape[1]
    scale = np.float32(n_bins / np.pi)
    nb = np.float32(n_bins)
    for i in range(ny * c):
        ci = i // c
        for j in range(nx * c):
            t = ang[i, j] * scale - np.float32(0.5)
            while t < 0:
                t += nb
            while t >= nb:
                t -= nb
            b0 = int(t)
            f = t - np.float32(b0)
            b1 = b0 + 1
            if b1 == n_bins:
                b1 = 0
            m = mag[i, j]
            cj = j // c
            out[ci, cj, b0] += (np.float32(1.0) - f) * m
            out[ci, cj, b1] += f * m


# OpenCV's fastAtan2 polynomial (cv::cartToPolar's angle, core/src/mathfuncs_core), in
# degrees; reproduced so that the fused pass gives cartToPolar's angles to rounding
_ATAN_P1 = np.float32(0.9997878412794807 * 180 / np.pi)
_ATAN_P3 = np.float32(-0.3258083974640975 * 180 / np.pi)
_ATAN_P5 = np.float32(0.1555786518463281 * 180 / np.pi)
_ATAN_P7 = np.float32(-0.04432655554792128 * 180 / np.pi)
_ATAN_EPS = np.float32(np.finfo(np.float64).eps)
_DEG = np.float32(np.pi / 180)


@njit(cache=True, nogil=True, boundscheck=False, inline="always")
def strongest_of_three(x0, y0, x1, y1, x2, y2):
    """The pair ``(x, y)`` of largest ``x**2 + y**2`` of three (ties keep the earlier): the
    strongest colour channel's gradient, as the HOG and ACF feature passes pick it."""
    m0 = x0 * x0 + y0 * y0
    m1 = x1 * x1 + y1 * y1
    m2 = x2 * x2 + y2 * y2
    t1 = m1 > m0
    x0 = x1 if t1 else x0
    y0 = y1 if t1 else y0
    m0 = m1 if t1 else m0
    t2 = m2 > m0
    return (x2 if t2 else x0), (y2 if t2 else y0)


@njit(cache=True, nogil=True, boundscheck=False, inline="always")
def _strongest_difference(img, i, iu, idn, jl, j, jr):
    """Central differences at pixel ``(i, j)`` of the channel of largest ``dx**2 + dy**2``
    (ties keep the earlier channel), from neighbours ``iu, idn, jl, jr``: the border
    pixels of ``hog_gradient_cell_sums`` (its interior loop does the same per pixel)."""
    gx = np.float32(img[i, jr, 0]) - np.float32(img[i, jl, 0])
    gy = np.float32(img[idn, j, 0]) - np.float32(img[iu, j, 0])
    if img.shape[2] == 3:
        return strongest_of_three(
            gx, gy,
            np.float32(img[i, jr, 1]) - np.float32(img[i, jl, 1]),
            np.float32(img[idn, j, 1]) - np.float32(img[iu, j, 1]),
            np.float32(img[i, jr, 2]) - np.float32(img[i, jl, 2]),
            np.float32(img[idn, j, 2]) - np.float32(img[iu, j, 2]))
    return gx, gy


# error_model="numpy": no zero-division checks, which would keep the row loops scalar
@njit(cache=True, fastmath=True, nogil=True, boundscheck=False, error_model="numpy")
def hog_gradient_cell_sums(img, n_bins, sizes, offsets, n_x, n_y,
                           out):  # pragma: no cover - compiled; tested through its callers
    """Oriented-magnitude cell sums straight from an (M, N, K) image (``K`` = 1 or 3),
    several cell sizes in one pass.

    Per pixel: central differences with reflect-101 borders of each channel, the channel
    of largest ``dx**2 + dy**2`` (ties keep the earlier), its magnitude and angle (OpenCV's
    ``cartToPolar`` polynomial), the magnitude split linearly between the two nearest
    unsigned bins (centres ``(b + 1/2) pi / n_bins``) -- the computation of
    ``cv2.filter2D``, ``strongest_gradient``, ``cv2.cartToPolar`` and
    ``orientation_cell_sums`` without their full-frame arrays: one image row at a time.
    Size ``sizes[s]`` adds into the ``(n_y[s], n_x[s], n_bins)`` block of the flat ``out``
    starting at ``offsets[s]`` (pixels past the last whole cell are dropped), in the pixel
    order of ``orientation_cell_sums``.
    """
    M, N = img.shape[0], img.shape[1]
    gxr = np.empty(N, np.float32)
    gyr = np.empty(N, np.float32)
    w0 = np.empty(N, np.float32)
    w1 = np.empty(N, np.float32)
    b0s = np.empty(N, np.int32)
    b1s = np.empty(N, np.int32)
    scale = np.float32(n_bins / np.pi)
    nb = np.float32(n_bins)
    zero = np.float32(0.0)
    one = np.float32(1.0)
    for i in range(M):
        # reflect-101 borders (a single row or column reflects onto itself)
        iu = i - 1 if i > 0 else min(1, M - 1)
        idn = i + 1 if i < M - 1 else max(M - 2, 0)
        gxr[0], gyr[0] = _strongest_difference(img, i, iu, idn, min(1, N - 1), 0,
                                               min(1, N - 1))
        ru = img[iu]
        rc = img[i]
        rd = img[idn]
        if img.shape[2] == 3:
            # the interior of the row, channels unrolled (vectorises; see
            # _strongest_difference for the borders)
            for j in range(1, N - 1):
                gxr[j], gyr[j] = strongest_of_three(
                    np.float32(rc[j + 1, 0]) - np.float32(rc[j - 1, 0]),
                    np.float32(rd[j, 0]) - np.float32(ru[j, 0]),
                    np.float32(rc[j + 1, 1]) - np.float32(rc[j - 1, 1]),
                    np.float32(rd[j, 1]) - np.float32(ru[j, 1]),
                    np.float32(rc[j + 1, 2]) - np.float32(rc[j - 1, 2]),
                    np.float32(rd[j, 2]) - np.float32(ru[j, 2]))
        else:
            for j in range(1, N - 1):
                gxr[j] = np.float32(rc[j + 1, 0]) - np.float32(rc[j - 1, 0])
                gyr[j] = np.float32(rd[j, 0]) - np.float32(ru[j, 0])
        if N > 1:
            gxr[N - 1], gyr[N - 1] = _strongest_difference(img, i, iu, idn, N - 2, N - 1,
                                                           N - 2)
        for j in range(N):
            gx = gxr[j]
            gy = gyr[j]
            m = np.sqrt(gx * gx + gy * gy)
            ax = abs(gx)
            ay = abs(gy)
            c = min(ax, ay) / (max(ax, ay) + _ATAN_EPS)
            cc = c * c
            a = (((_ATAN_P7 * cc + _ATAN_P5) * cc + _ATAN_P3) * cc + _ATAN_P1) * c
            a = a if ax >= ay else np.float32(90.0) - a
            a = np.float32(180.0) - a if gx < zero else a
            a = np.float32(360.0) - a if gy < zero else a
            t = (a * _DEG) * scale - np.float32(0.5)           # in [-1/2, 2 n_bins]
            t = t + nb if t < zero else t
            t = t - nb if t >= nb else t
            t = t - nb if t >= nb else t
            b0 = np.int32(t)
            f = t - np.float32(b0)
            b1 = b0 + 1
            b0s[j] = b0
            b1s[j] = 0 if b1 == n_bins else b1
            w0[j] = (one - f) * m
            w1[j] = f * m
        for s in range(sizes.shape[0]):
            cs = sizes[s]
            ci = i // cs
            if ci >= n_y[s]:
                continue
            nxs = n_x[s]
            row = offsets[s] + ci * nxs * n_bins
            j = 0
            for cj in range(nxs):
                base = row + cj * n_bins
                for _ in range(cs):
                    out[base + b0s[j]] += w0[j]
                    out[base + b1s[j]] += w1[j]
                    j += 1
    return out


@njit(cache=True, nogil=True, boundscheck=False)
def reflect_index(i, n, edge):  # pragma: no cover - compiled
    """Index ``i`` of ``-1 .. n`` reflected into ``0 .. n - 1`` (reflect-101; ``edge``: a
    single row or column, which reflects onto itself)."""
    if i < 0:
        return 0 if edge else 1
    if i >= n:
        return n - 1 if edge else n - 2
    return i


@njit(cache=True, nogil=True, boundscheck=False)
def block_inverse_norms(X, eps, r0, r1, E, inv):  # pragma: no cover - compiled
    """``inv[i, j]``, ``r0 <= i <= r1``: one over the L2 norm (floor ``eps``) of the 2x2-cell
    block of ``X`` (ny, nx, B) on cell rows ``{i - 1, i}`` and columns ``{j - 1, j}``,
    reflected (reflect-101) at the map's border; ``E`` (ny, nx) scratch, the cells' squared
    norms of the rows those blocks read."""
    ny, nx, nb = X.shape
    edge = min(ny, nx) == 1
    e0 = 0 if r0 <= 1 else r0 - 1
    e1 = ny if r1 >= ny - 1 else r1 + 1
    for i in range(e0, e1):
        for j in range(nx):
            s = np.float32(0.0)
            for b in range(nb):
                s += X[i, j, b] * X[i, j, b]
            E[i, j] = s
    e2 = np.float32(eps) * np.float32(eps)
    for i in range(r0, r1 + 1):
        i0 = reflect_index(i - 1, ny, edge)
        i1 = reflect_index(i, ny, edge)
        for j in range(nx + 1):
            j0 = reflect_index(j - 1, nx, edge)
            j1 = reflect_index(j, nx, edge)
            s = E[i0, j0] + E[i1, j0] + E[i0, j1] + E[i1, j1]
            inv[i, j] = np.float32(1.0) / np.sqrt(s + e2)


@njit(cache=True, nogil=True, boundscheck=False)
def block_normalize(X, eps, clip, out, r0=0, r1=-1):  # pragma: no cover - compiled
    """The body of ``viewadapt.detect.block_normalize_cells`` (see there): ``X`` (ny, nx,
    B) cell histograms -> ``out`` (ny, nx, B + 4), only its rows ``r0 <= i < r1``
    (``r1 < 0``: to the last; the other rows of ``out`` are left as they are). Those rows
    are those of the whole map: their blocks read the rows next to them and reflect at the
    map's own border only."""
    ny, nx, nb = X.shape
    if r1 < 0 or r1 > ny:
        r1 = ny
    r0 = max(r0, 0)
    if r0 >= r1:
        return
    E = np.empty((ny, nx), np.float32)
    inv = np.empty((ny + 1, nx + 1), np.float32)
    block_inverse_norms(X, eps, r0, r1, E, inv)
    cl = np.float32(clip)
    for i in range(r0, r1):
        for j in range(nx):
            for b in range(nb):
                out[i, j, b] = 0.0
            for k in range(4):
                v = inv[i + k // 2, j + k % 2]
                tex = np.float32(0.0)
                for b in range(nb):
                    f = min(X[i, j, b] * v, cl)
                    out[i, j, b] += f
                    tex += f
                out[i, j, nb + k] = tex


@njit(cache=True, nogil=True, boundscheck=False)
def acf_channels_out(luv, mag, dx, dy, n_orient, out):  # pragma: no cover - compiled
    """The ten ACF pixel channels into ``out`` (H, W, 4 + n_orient): L, U, V, the
    normalised magnitude, and the magnitude in the unsigned orientation bin of
    ``(dx, dy)`` (bin ``k`` centred at ``k pi / n_orient``; a pixel exactly on a boundary
    goes to the upper bin, as ``floor(theta n / pi + 1/2)`` does)."""
    H, W = mag.shape
    cs = np.empty(n_orient, np.float32)
    sn = np.empty(n_orient, np.float32)
    for k in range(n_orient):
        b = (k + 0.5) * np.pi / n_orient
        cs[k] = np.cos(b)
        sn[k] = np.sin(b)
    for i in range(H):
        for j in range(W):
            out[i, j, 0] = luv[i, j, 0]
            out[i, j, 1] = luv[i, j, 1]
            out[i, j, 2] = luv[i, j, 2]
            m = mag[i, j]
            out[i, j, 3] = m
            x = dx[i, j]
            y = dy[i, j]
            if y < 0 or (y == 0 and x < 0):          # the upper half-plane: unsigned angle
                x = -x
                y = -y
            k_bin = 0
            for k in range(n_orient):                # boundaries at or below the angle
                if cs[k] * y - sn[k] * x >= 0:
                    k_bin += 1
            if k_bin == n_orient:
                k_bin = 0
            for k in range(n_orient):
                out[i, j, 4 + k] = m if k == k_bin else np.float32(0.0)


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def tree_cascade_scores(x, pos_group, pos_origin, n_groups, indptr, offsets, weights, cols,
                        thr, val, depth, cascade_threshold, use_cascade, cascade_scale,
                        out):  # pragma: no cover - compiled; tested through its callers
    """Soft-cascade scores of remapped boosted trees.

    Position ``p`` (group ``g = pos_group[p]``, patch origin ``o = pos_origin[p]`` in the
    frame feature vector ``x``) walks the trees in order; at each inner node it computes
    its remapped feature ``f = cols[t, node]`` as the float32 dot product of row
    ``f * n_groups + g`` of the CSR ``(indptr, offsets, weights)`` with
    ``x[o + offsets]`` (terms in row order), branches on ``thr[t, node]`` and adds the
    leaf's ``val`` to a float64 running score; with ``use_cascade`` it stops at the first
    running score times ``cascade_scale[t]`` that is ``<= cascade_threshold`` and keeps
    that product (:func:`viewadapt.boosting.cascade_step`). Writes ``out[p]``.

    Consecutive positions of one group are walked together, tree by tree and node by
    node: the positions still alive that sit at a node share its row, so the row's terms
    are the outer loop and the positions the inner one -- independent sums, each in the
    same order as one position alone (the same scores bit for bit), instead of one long
    chain of dependent additions at a time.
    """
    T = cols.shape[0]
    P = pos_group.shape[0]
    longest = 0                          # the longest run of one group
    a = 0
    while a < P:
        b = a + 1
        while b < P and pos_group[b] == pos_group[a]:
            b += 1
        longest = max(longest, b - a)
        a = b
    alive = np.empty(longest, np.int64)  # per live slot: its position, origin, node, score
    base = np.empty(longest, np.int64)
    node = np.empty(longest, np.int64)
    score = np.empty(longest, np.float64)
    sel = np.empty(longest, np.int64)    # the slots at one node, their origins, their sums
    sel_base = np.empty(longest, np.int64)
    acc = np.empty(longest, np.float32)
    a = 0
    while a < P:
        g = pos_group[a]
        b = a + 1
        while b < P and pos_group[b] == g:
            b += 1
        n = b - a
        for i in range(n):
            alive[i] = a + i
            base[i] = pos_origin[a + i]
            score[i] = 0.0
        for t in range(T):
            if n == 0:
                break
            for i in range(n):
                node[i] = 0
            lo = 0
            for _ in range(depth):       # the nodes lo .. 2 lo of one depth
                hi = 2 * lo + 1
                for nd in range(lo, hi):
                    f = cols[t, nd]
                    if f < 0:            # a leaf: its slots stay there
                        continue
                    m = 0
                    for i in range(n):
                        if node[i] == nd:
                            sel[m] = i
                            sel_base[m] = base[i]
                            m += 1
                    if m == 0:
                        continue
                    key = f * n_groups + g
                    for i in range(m):
                        acc[i] = np.float32(0.0)
                    for k in range(indptr[key], indptr[key + 1]):
                        ok = offsets[k]
                        wk = weights[k]
                        for i in range(m):
                            acc[i] += x[sel_base[i] + ok] * wk
                    th = thr[t, nd]
                    for i in range(m):
                        node[sel[i]] = 2 * nd + 1 + (1 if acc[i] >= th else 0)
                lo = hi
            m = 0
            for i in range(n):           # add the leaves; keep the slots the cascade passes
                s = score[i] + val[t, node[i]]
                if use_cascade and s * cascade_scale[t] <= cascade_threshold:
                    out[alive[i]] = s * cascade_scale[t]
                else:
                    alive[m] = alive[i]
                    base[m] = base[i]
                    score[m] = s
                    m += 1
            n = m
        for i in range(n):
            out[alive[i]] = score[i]
        a = b
    return out


@njit(cache=True, nogil=True, boundscheck=False)
def csr_rows_product(indptr, indices, data, X, out):  # pragma: no cover - compiled
    """``out[r] = G @ X[r]`` for every row of the (n, m) C-contiguous ``X``, with ``G`` the
    (S, m) CSR ``(indptr, indices, data)``: per output entry a float64 sum from 0 over the
    row's terms in stored order -- the arithmetic of scipy's ``csr_matvecs`` on ``X.T``,
    so the same numbers, without the transposed copies on either side."""
    S = indptr.shape[0] - 1
    for r in range(X.shape[0]):
        x = X[r]
        o = out[r]
        for s in range(S):
            acc = 0.0
            for k in range(indptr[s], indptr[s + 1]):
                acc += data[k] * np.float64(x[indices[k]])
            o[s] = acc
    return out


@njit(cache=True, nogil=True, boundscheck=False)
def rasterize_depth(uv, z, faces, x0, y0, step, out):  # pragma: no cover - compiled
    """Z-buffer of triangles on a regular sample grid.

    ``uv`` (V, 2) projected vertices (pixels), ``z`` (V,) their camera depths (> 0),
    ``faces`` (F, 3). Sample ``(i, j)`` sits at pixel ``(x0 + j step, y0 + i step)``;
    ``out`` (n_y, n_x) starts at +inf and receives the nearest depth of a triangle covering
    the sample, ``1 / z`` interpolated with the screen-space barycentrics (exact for a
    planar triangle under perspective).
    """
    ny, nx = out.shape
    for f in range(faces.shape[0]):
        a = faces[f, 0]
        b = faces[f, 1]
        c = faces[f, 2]
        ax = uv[a, 0]
        ay = uv[a, 1]
        bx = uv[b, 0]
        by = uv[b, 1]
        cx = uv[c, 0]
        cy = uv[c, 1]
        den = (bx - ax) * (cy - ay) - (cx - ax) * (by - ay)
        if den == 0.0:
            continue
        ia = 1.0 / z[a]
        ib = 1.0 / z[b]
        ic = 1.0 / z[c]
        j0 = int(np.ceil((min(ax, bx, cx) - x0) / step))
        j1 = int(np.floor((max(ax, bx, cx) - x0) / step))
        i0 = int(np.ceil((min(ay, by, cy) - y0) / step))
        i1 = int(np.floor((max(ay, by, cy) - y0) / step))
        if j0 < 0:
            j0 = 0
        if i0 < 0:
            i0 = 0
        if j1 > nx - 1:
            j1 = nx - 1
        if i1 > ny - 1:
            i1 = ny - 1
        for i in range(i0, i1 + 1):
            py = y0 + i * step
            for j in range(j0, j1 + 1):
                px = x0 + j * step
                wb = ((px - ax) * (cy - ay) - (cx - ax) * (py - ay)) / den
                wc = ((bx - ax) * (py - ay) - (px - ax) * (by - ay)) / den
                wa = 1.0 - wb - wc
                if wa < -1e-9 or wb < -1e-9 or wc < -1e-9:
                    continue
                d = 1.0 / (wa * ia + wb * ib + wc * ic)
                if d < out[i, j]:
                    out[i, j] = d
    return out


@njit(cache=True, nogil=True, boundscheck=False)
def split_orientations(mag, theta, n_bins, out):  # pragma: no cover - compiled
    """Each pixel's magnitude split linearly between the two nearest of ``n_bins`` unsigned
    orientation bins: ``t = (theta mod pi) n_bins / pi - 1/2``, ``(1 - frac)`` of ``mag`` to
    bin ``floor(t) mod n_bins`` and ``frac`` to the next (float64, the operations of
    :func:`viewadapt.hog.orientation_channels` in their order). ``mag``, ``theta``: (M, N);
    ``out``: (M, N, n_bins), overwritten."""
    M, N = mag.shape
    scale = n_bins / np.pi
    for i in range(M):
        for j in range(N):
            t = (theta[i, j] % np.pi) * scale - 0.5
            lo = np.floor(t)
            frac = t - lo
            k = int(lo) % n_bins
            g = mag[i, j]
            for b in range(n_bins):
                out[i, j, b] = 0.0
            out[i, j, k] = g * (1.0 - frac)
            out[i, j, (k + 1) % n_bins] += g * frac
    return out


@njit(cache=True, nogil=True, boundscheck=False)
def clip_to_rects(poly, counts, rects, out, out_counts):  # pragma: no cover - compiled
    """Sutherland-Hodgman clipping of each polygon ``poly[p, :counts[p]]`` to the
    rectangle ``rects[p] = (xmin, ymin, xmax, ymax)``: the edges x >= xmin, x <= xmax,
    y >= ymin, y <= ymax in that order; per vertex, the vertex if inside, then the edge's
    crossing ``cur + t (nxt - cur)``, ``t = dc / (dc - dn)`` (the arithmetic of
    :func:`viewadapt.remap.clip_polygons_to_rects`' vectorised form). Writes the vertices
    into ``out[p]`` (room for ``2**4`` times the input's) and their count into
    ``out_counts[p]``."""
    P, V = poly.shape[0], poly.shape[1]
    cap = out.shape[1]
    ax = np.empty(cap)
    ay = np.empty(cap)
    bx = np.empty(cap)
    by = np.empty(cap)
    for p in range(P):
        n = counts[p]
        for i in range(n):
            ax[i] = poly[p, i, 0]
            ay[i] = poly[p, i, 1]
        for e in range(4):
            axis = 0 if e < 2 else 1
            col = (0, 2, 1, 3)[e]
            sign = 1.0 if e % 2 == 0 else -1.0
            bound = rects[p, col]
            m = 0
            for i in range(n):
                j = i + 1
                if j == n:
                    j = 0
                cx, cy, nx, ny = ax[i], ay[i], ax[j], ay[j]
                dc = sign * ((cx if axis == 0 else cy) - bound)
                dn = sign * ((nx if axis == 0 else ny) - bound)
                cin = dc >= 0
                if cin:
                    bx[m] = cx
                    by[m] = cy
                    m += 1
                if cin != (dn >= 0):
                    d = dc - dn
                    t = dc / (1.0 if d == 0 else d)
                    bx[m] = cx + t * (nx - cx)
                    by[m] = cy + t * (ny - cy)
                    m += 1
            n = m
            for i in range(n):
                ax[i] = bx[i]
                ay[i] = by[i]
        out_counts[p] = n
        for i in range(n):
            out[p, i, 0] = ax[i]
            out[p, i, 1] = ay[i]
    return out_counts
