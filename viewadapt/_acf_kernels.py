"""Compiled inner loops of the ACF frame features (numba), loaded on first use.

The gradient, orientation and aggregation stages of
:func:`viewadapt.detect.acf_channels.acf_frame_features` without the ten-channel per-pixel
array: :func:`acf_gradient_bins` writes one magnitude plane and one orientation-bin plane,
:func:`acf_channel_cell_sums` sums the ten channels straight into cells. Both keep the
float32 operations of the OpenCV / numpy path they replace
(:func:`viewadapt.detect.acf_channels.fast_acf_pixel_channels`), so magnitudes and bins are the
same numbers; only the order of the cell sums differs.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._kernels import strongest_of_three


@njit(cache=True, nogil=True, boundscheck=False, inline="always")
def _strongest_grad1(luv, i, iu, idn, hy, jl, j, jr, hx):
    """``(dx, dy)`` of the channel of largest ``dx**2 + dy**2`` at pixel ``(i, j)``
    (ties keep the earlier): the toolbox's ``grad1`` differences ``h (a_hi - a_lo)``
    with ``h = 1/2`` inside, 1 at the ends (``a_hi = a_lo`` along an axis of length 1
    gives 0)."""
    return strongest_of_three(hx * (luv[i, jr, 0] - luv[i, jl, 0]),
                              hy * (luv[idn, j, 0] - luv[iu, j, 0]),
                              hx * (luv[i, jr, 1] - luv[i, jl, 1]),
                              hy * (luv[idn, j, 1] - luv[iu, j, 1]),
                              hx * (luv[i, jr, 2] - luv[i, jl, 2]),
                              hy * (luv[idn, j, 2] - luv[iu, j, 2]))


# no fastmath: the magnitudes and the bin tests stay the float32 operations of the OpenCV
# / numpy path (no contraction into fused multiply-adds), so both give the same numbers
@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def acf_gradient_bins(luv, n_orient, mag, bins):  # pragma: no cover - compiled
    """Gradient magnitude and orientation bin of an (M, N, 3) float32 smoothed LUV image.

    Per pixel: the toolbox's ``grad1`` differences of each channel (central / 2 inside,
    one-sided at the ends, zero along an axis of length 1), the channel of largest
    ``dx**2 + dy**2`` (ties keep the earlier), ``mag = sqrt(dx**2 + dy**2)`` into (M, N)
    ``mag`` and the nearest unsigned orientation bin (bin ``k`` centred at
    ``k pi / n_orient``, a pixel on a boundary goes to the upper bin) into (M, N)
    ``bins`` -- the operations of ``cv2.filter2D`` (``h (b - a)`` is what it computes
    for ``[-h, 0, h]``, exactly), ``strongest_gradient``, ``np.sqrt`` and
    ``acf_channels_out`` in the same float32 order, one image row at a time.
    """
    M, N = luv.shape[0], luv.shape[1]
    cs = np.empty(n_orient, np.float32)
    sn = np.empty(n_orient, np.float32)
    for k in range(n_orient):
        b = (k + 0.5) * np.pi / n_orient
        cs[k] = np.cos(b)
        sn[k] = np.sin(b)
    gxr = np.empty(N, np.float32)
    gyr = np.empty(N, np.float32)
    kb = np.empty(N, np.int32)
    half = np.float32(0.5)
    one = np.float32(1.0)
    zero = np.float32(0.0)
    for i in range(M):
        iu = max(i - 1, 0)
        idn = min(i + 1, M - 1)
        hy = half if 0 < i < M - 1 else one
        ru = luv[iu]
        rc = luv[i]
        rd = luv[idn]
        gxr[0], gyr[0] = _strongest_grad1(luv, i, iu, idn, hy, 0, 0, min(1, N - 1), one)
        # the interior of the row, channels unrolled (vectorises)
        for j in range(1, N - 1):
            gxr[j], gyr[j] = strongest_of_three(
                half * (rc[j + 1, 0] - rc[j - 1, 0]), hy * (rd[j, 0] - ru[j, 0]),
                half * (rc[j + 1, 1] - rc[j - 1, 1]), hy * (rd[j, 1] - ru[j, 1]),
                half * (rc[j + 1, 2] - rc[j - 1, 2]), hy * (rd[j, 2] - ru[j, 2]))
        if N > 1:
            gxr[N - 1], gyr[N - 1] = _strongest_grad1(luv, i, iu, idn, hy, N - 2, N - 1,
                                                      N - 1, one)
        for j in range(N):
            x = gxr[j]
            y = gyr[j]
            mag[i, j] = np.sqrt(x * x + y * y)
            flip = y < zero or (y == zero and x < zero)    # unsigned angle: upper half-plane
            gxr[j] = -x if flip else x
            gyr[j] = -y if flip else y
            kb[j] = 0
        for k in range(n_orient):                          # boundaries at or below the angle
            c = cs[k]
            s = sn[k]
            for j in range(N):
                kb[j] += 1 if c * gyr[j] - s * gxr[j] >= zero else 0
        for j in range(N):
            bins[i, j] = 0 if kb[j] == n_orient else kb[j]
    return mag


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def acf_channel_cell_sums(luv, mag, mag_smooth, norm_const, bins, n_orient, sizes, offsets,
                          n_x, n_y, out):  # pragma: no cover - compiled
    """The ten ACF channels summed into cells, several cell sizes in one pass.

    Per pixel: L, U, V from (M, N, 3) ``luv``, the normalised magnitude
    ``m = mag / (mag_smooth + norm_const)`` and ``m`` in orientation channel ``bins``
    (the values ``acf_channels_out`` writes); size ``sizes[s]`` adds them into the
    ``(n_y[s], n_x[s], 4 + n_orient)`` block of the flat ``out`` starting at
    ``offsets[s]`` (pixels past the last whole cell are dropped). Each image row's
    ``c`` pixels of a cell are summed first, then added to the cell.
    """
    M, N = mag.shape
    C = 4 + n_orient
    mr = np.empty(N, np.float32)
    for i in range(M):
        mi = mag[i]
        si = mag_smooth[i]
        for j in range(N):                          # vectorises (no division check)
            mr[j] = mi[j] / (si[j] + norm_const)
        li = luv[i]
        bi = bins[i]
        for s in range(sizes.shape[0]):
            c = sizes[s]
            ci = i // c
            if ci >= n_y[s]:
                continue
            nxs = n_x[s]
            row = offsets[s] + ci * nxs * C
            for cj in range(nxs):
                base = row + cj * C
                j0 = cj * c
                a0 = li[j0, 0]
                a1 = li[j0, 1]
                a2 = li[j0, 2]
                a3 = mr[j0]
                out[base + 4 + bi[j0]] += a3
                for j in range(j0 + 1, j0 + c):
                    a0 += li[j, 0]
                    a1 += li[j, 1]
                    a2 += li[j, 2]
                    m = mr[j]
                    a3 += m
                    out[base + 4 + bi[j]] += m
                out[base] += a0
                out[base + 1] += a1
                out[base + 2] += a2
                out[base + 3] += a3
    return out


@njit(cache=True, nogil=True, boundscheck=False, inline="always")
def _cube_root_halley(v, g):
    """``v ** (1/3)`` for ``v > 0`` as float32 from a guess ``g`` within a few per cent: two
    Halley steps ``r <- r (r^3 + 2 v) / (2 r^3 + v)`` in float64 (cubic convergence: a 4 %
    guess ends below 1e-12 relative), rounded once -- the correctly rounded float32 cube
    root of ``v``, where ``powf(v, 1/3f)`` is off by one ulp for about a fifth of inputs."""
    v = np.float64(v)
    r = np.float64(g)
    r3 = r * r * r
    r = r * (r3 + 2.0 * v) / (2.0 * r3 + v)
    r3 = r * r * r
    r = r * (r3 + 2.0 * v) / (2.0 * r3 + v)
    return np.float32(r)


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def cube_root_rows(y, guess, out):  # pragma: no cover - compiled
    """Correctly rounded float32 cube roots of the (W,) float32 ``y`` into ``out`` (values
    for ``y <= 0`` are meaningless; the LUV conversion reads them only above the L* knee):
    the exponent-bits guess ``bits(y) / 3 + 0x2a5137a0`` (about 4 %; written into the
    (W,) uint32 scratch ``guess``) refined by :func:`_cube_root_halley` -- two loops that
    vectorise, where a ``powf`` call per value does not (no SVML)."""
    yi = y.view(np.uint32)
    for j in range(y.shape[0]):
        guess[j] = yi[j] // np.uint32(3) + np.uint32(0x2a5137a0)
    g = guess.view(np.float32)
    for j in range(y.shape[0]):
        out[j] = _cube_root_halley(y[j], g[j])
    return out


# error_model="numpy": no zero-division check on ``1 / (x + 15 y + 3 z + 1e-35)``, which
# kept the loop scalar; no fastmath, so the float32 operations are the same everywhere
@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def rgb_to_luv_rows(img, M, y0, kappa, scale, un, vn, u_off, v_off,
                    out):  # pragma: no cover - compiled
    """Per pixel of an (H, W, 3) float32 RGB image in [0, 1]: XYZ = ``M`` RGB, then the
    toolbox's scaled LUV (``viewadapt.acf.rgb_to_luv``) in float32, written into ``out``;
    one image row at a time in loops that vectorise, the cube root of ``Y`` by
    :func:`cube_root_rows`."""
    H, W = img.shape[0], img.shape[1]
    yr = np.empty(W, np.float32)
    ur = np.empty(W, np.float32)
    vr = np.empty(W, np.float32)
    cr = np.empty(W, np.float32)
    guess = np.empty(W, np.uint32)
    for i in range(H):
        row = img[i]
        for j in range(W):
            r = row[j, 0]
            g = row[j, 1]
            b = row[j, 2]
            x = M[0, 0] * r + M[0, 1] * g + M[0, 2] * b
            y = M[1, 0] * r + M[1, 1] * g + M[1, 2] * b
            z = M[2, 0] * r + M[2, 1] * g + M[2, 2] * b
            inv = np.float32(1.0) / (x + np.float32(15.0) * y + np.float32(3.0) * z
                                     + np.float32(1e-35))
            yr[j] = y
            ur[j] = np.float32(52.0) * x * inv - np.float32(13.0) * un
            vr[j] = np.float32(117.0) * y * inv - np.float32(13.0) * vn
        cube_root_rows(yr, guess, cr)
        for j in range(W):
            y = yr[j]
            if y > y0:
                L = (np.float32(116.0) * cr[j] - np.float32(16.0)) * scale
            else:
                L = y * kappa * scale
            out[i, j, 0] = L
            out[i, j, 1] = L * ur[j] + u_off
            out[i, j, 2] = L * vr[j] + v_off
    return out
