"""The compiled OpenCV-cell kernels against straightforward references on random inputs:
the gradients of 8-bit images, block-normalised cells, raw cell sums (a size summed from a
smaller one's cells) and the per-window normalisation stage with OpenCV's binning."""

import math

import numpy as np
import pytest

from viewadapt._opencv_kernels import opencv_block_cells as block_kernel
from viewadapt._renorm_kernels import renorm_scores_binned, sum_cells
from viewadapt.detect.channels import gradient_bins
from viewadapt.detect.opencv_cells import (
    OPENCV_CHANNELS, OPENCV_L2HYS_CLIP, block_axis_weights, opencv_block_cells, opencv_gradients,
    raw_cell_maps,
)


@pytest.mark.parametrize("shape", [(2, 2, 3), (3, 7), (5, 2, 1), (41, 57, 3), (1, 6, 3)])
def test_gradients_of_8_bit_images_are_gradient_bins(shape):
    """The same float32 values as the OpenCV element-wise path, bit for bit."""
    rng = np.random.default_rng(sum(shape))
    img = rng.integers(0, 256, shape, dtype=np.uint8)
    img[:2] = 128                                          # some ties and zero gradients
    for im in (img, img[::-1, ::2] if img.ndim == 3 else img[:, ::-1]):
        want = gradient_bins(im, n_bins=9, gamma=True)
        got = opencv_gradients(im)
        for g, w in zip(got, want):
            assert g.dtype == np.float32 and g.shape == im.shape[:2]
            np.testing.assert_array_equal(g, w)


def _gradients(shape, seed):
    """Random float32 magnitudes and bin coordinates in [0, 9)."""
    rng = np.random.default_rng(seed)
    mag = rng.gamma(2.0, 20.0, shape).astype(np.float32)
    t = (rng.random(shape) * 9).astype(np.float32)
    return mag, t


def _pixel_histograms(mag, t):
    """(M, N, 9) float64: each pixel's magnitude split between bins floor(t) and the next."""
    t = t.astype(np.float64)
    b0 = np.floor(t).astype(int) % 9
    f = t - np.floor(t)
    h = np.zeros(mag.shape + (9,))
    yy, xx = np.indices(mag.shape)
    np.add.at(h, (yy, xx, b0), mag * (1 - f))
    np.add.at(h, (yy, xx, (b0 + 1) % 9), mag * f)
    return h


def _l2hys(v, eps, clip):
    v = v / (np.sqrt((v * v).sum()) + eps)
    v = np.minimum(v, clip)
    return v / (np.sqrt((v * v).sum()) + 1e-3)


def _reference_block_cells(mag, t, c):
    """Every 2x2-cell block from its 2c x 2c pixels and the 2-D window weights, directly."""
    h = _pixel_histograms(mag, t)
    ax = block_axis_weights(c)
    eps = 0.1 * OPENCV_CHANNELS * (c / 8) ** 2
    ny, nx = mag.shape[0] // c, mag.shape[1] // c
    out = np.zeros((ny, nx, OPENCV_CHANNELS))
    for by in range(ny - 1):
        for bx in range(nx - 1):
            patch = h[by * c:by * c + 2 * c, bx * c:bx * c + 2 * c]
            blk = np.einsum("rq,ip,rib->pqb", ax, ax, patch)          # [qx, qy, bin]
            blk = _l2hys(blk.ravel(), eps, OPENCV_L2HYS_CLIP).reshape(2, 2, 9)
            for qx in range(2):
                for qy in range(2):
                    q = 2 * qx + qy
                    out[by + qy, bx + qx, 9 * q:9 * q + 9] = blk[qx, qy]
    return out


@pytest.mark.parametrize("c, shape, seed", [(4, (37, 53), 0), (3, (20, 31), 1), (8, (40, 64), 2),
                                            (6, (13, 25), 3), (5, (9, 40), 4)])
def test_block_cells_match_a_direct_reference(c, shape, seed):
    """Each block's copies, zeros where a cell's block does not exist, into a strided view."""
    mag, t = _gradients(shape, seed)
    ny, nx = shape[0] // c, shape[1] // c
    padded = np.full((ny + 4, nx + 4, OPENCV_CHANNELS), 7.0, np.float32)
    got = opencv_block_cells((mag, t), c, out=padded[2:2 + ny, 2:2 + nx])
    np.testing.assert_allclose(got, _reference_block_cells(mag, t, c), rtol=1e-5, atol=2e-6)
    assert np.all(padded[:2] == 7) and np.all(padded[:, -2:] == 7)   # nothing outside the view


def test_block_cells_of_a_grid_too_small_for_a_block_are_zero():
    mag, t = _gradients((7, 30), 5)
    out = np.full((1, 7, OPENCV_CHANNELS), 3.0, np.float32)
    block_kernel(mag, t, 4, block_axis_weights(4).astype(np.float32), np.float32(1.8),
                 np.float32(0.2), out, 0, 1)
    assert np.all(out == 0)


def test_raw_cell_maps_sum_each_size_from_the_pixels():
    """Sizes summed from a smaller size's cells equal the pixels' own cell sums."""
    mag, t = _gradients((50, 74), 6)
    h = _pixel_histograms(mag, t)
    sizes = [6, 2, 4, 3, 12, 5, 4]                          # 4 twice: both copies hold it
    maps, flat, offsets = raw_cell_maps((mag, t), sizes)
    assert list(maps) == sizes[:-1] and len(offsets) == len(sizes)
    for c, off in zip(sizes, offsets):
        ny, nx = 50 // c, 74 // c
        want = h[:ny * c, :nx * c].reshape(ny, c, nx, c, 9).sum(axis=(1, 3))
        assert maps[c].shape == (ny, nx, 9)
        np.testing.assert_allclose(maps[c], want, rtol=1e-5, atol=1e-3)
        np.testing.assert_array_equal(flat[off:off + maps[c].size], maps[c].ravel())


def test_sum_cells_sums_k_by_k_cells():
    rng = np.random.default_rng(7)
    src = rng.random((11, 14, 9)).astype(np.float32)
    out = np.full((3, 4, 9), np.nan, np.float32)
    sum_cells(src, 3, out, 0, 3)
    np.testing.assert_allclose(out, src[:9, :12].reshape(3, 3, 4, 3, 9).sum(axis=(1, 3)),
                               rtol=1e-6)


def _map(H, x, y):
    u, v, w = H @ np.array([x, y, 1.0])
    px, py = u / w, v / w
    return (px, py, (H[0, 0] - px * H[2, 0]) / w, (H[0, 1] - px * H[2, 1]) / w,
            (H[1, 0] - py * H[2, 0]) / w, (H[1, 1] - py * H[2, 1]) / w)


def _angle_matrix(j00, j01, j10, j11, rule):
    """(9, 9) ``A[j, k]``: frame bin k's share of source bin j."""
    A = np.zeros((9, 9))
    for k in range(9):
        if rule == 1:
            A[k, k] = 1
            continue
        phi = (k + 0.5) * math.pi / 9
        if rule == 0:
            gx = j00 * math.cos(phi) + j10 * math.sin(phi)
            gy = j01 * math.cos(phi) + j11 * math.sin(phi)
        else:
            det = j00 * j11 - j01 * j10
            gx = (j11 * math.cos(phi) - j01 * math.sin(phi)) / det
            gy = (-j10 * math.cos(phi) + j00 * math.sin(phi)) / det
        tt = (math.atan2(gy, gx) % math.pi) * 9 / math.pi - 0.5
        tt = tt + 9 if tt < 0 else tt
        b0 = int(tt) % 9
        A[b0, k] += 1 - (tt - int(tt))
        A[(b0 + 1) % 9, k] += tt - int(tt)
    return A


def _axis_taps(centre, jac, c, n, ax, first, m):
    """Each of the block's 16 source pixels spread over the frame cells its image overlaps."""
    w = np.zeros(m)
    half = 0.5 * abs(jac)
    for i in range(16):
        xf = centre + jac * (i - 7.5)
        a, b = xf - half, xf + half
        lo, hi = max(math.floor((a + 0.5) / c), 0), min(math.floor((b + 0.5) / c), n - 1)
        for u in range(lo, hi + 1):
            ov = min(b, c * (u + 1) - 0.5) - max(a, c * u - 0.5)
            if ov > 0 and 0 <= u - first < m:
                w[u - first] += ax[i] * ov / max(2 * half, 1e-12)
    return w


def _reference_scores(maps, sizes, H, cell, weights, bias, rule):
    """Each window's blocks gathered pixel by pixel of its 16 x 16 source pixels."""
    ax = block_axis_weights(8)
    out = []
    for Hn, c in zip(H, cell):
        F = maps[c].astype(np.float64)
        ny, nx = F.shape[:2]
        A = _angle_matrix(*_map(Hn, 31.5, 63.5)[2:], rule)
        total = bias
        for bx in range(7):
            for by in range(15):
                px, py, a00, _, _, a11 = _map(Hn, 8.0 * bx + 7.5, 8.0 * by + 7.5)
                ex, ey = 8 * abs(a00) + 1, 8 * abs(a11) + 1
                u0 = max(math.floor((px - ex + 0.5) / c), 0)
                v0 = max(math.floor((py - ey + 0.5) / c), 0)
                nu = min(min(math.floor((px + ex + 0.5) / c), nx - 1) - u0 + 1, 24)
                nv = min(min(math.floor((py + ey + 0.5) / c), ny - 1) - v0 + 1, 24)
                raw = np.zeros((2, 2, 9))
                if nu > 0 and nv > 0:
                    wx = [_axis_taps(px, a00, c, nx, ax[:, r], u0, nu) for r in range(2)]
                    wy = [_axis_taps(py, a11, c, ny, ax[:, r], v0, nv) for r in range(2)]
                    patch = F[v0:v0 + nv, u0:u0 + nu]
                    for cx in range(2):
                        for cy in range(2):
                            raw[cx, cy] = np.einsum("v,u,vuk->k", wy[cy], wx[cx], patch)
                blk = (raw @ A.T / (c * c)).ravel()
                blk = _l2hys(blk, 0.1 * OPENCV_CHANNELS, OPENCV_L2HYS_CLIP)
                total += weights[(bx * 15 + by) * 36:(bx * 15 + by + 1) * 36] @ blk
        out.append(total)
    return np.array(out)


def _windows(rng, n, shape):
    """Homographies of the canonical window into a frame of ``shape``: mild perspective,
    scales from 0.5 to 2.5 px per canonical px, some mirrored, some across the frame's
    border, and the raw cell size of each (about a source cell, or 2 px)."""
    H, cell = [], []
    for i in range(n):
        s = rng.uniform(0.5, 2.5)
        sx = -s if i % 5 == 4 else s
        x0 = rng.uniform(-40, shape[1] - 40) + (64 * s if sx < 0 else 0)
        y0 = rng.uniform(-60, shape[0] - 100)
        Hn = np.array([[sx, rng.normal(0, 0.05) * s, x0],
                       [rng.normal(0, 0.05) * s, s * rng.uniform(0.9, 1.1), y0],
                       [rng.normal(0, 4e-4), rng.normal(0, 4e-4), 1.0]])
        H.append(Hn)
        cell.append([4, 8, 16][min(int(s / 0.75), 2)] if i % 3 else 2)
    return np.array(H), np.array(cell)


@pytest.mark.parametrize("rule", [0, 1, 2])
def test_binned_stage_matches_the_pixelwise_reference(rule):
    rng = np.random.default_rng(10 + rule)
    shape = (220, 300)
    mag, t = _gradients(shape, 20 + rule)
    sizes = [2, 4, 8, 16]
    maps, flat, offsets = raw_cell_maps((mag, t), sizes)
    H, cell = _windows(rng, 30, shape)
    weights = rng.normal(0, 0.1, 3780).astype(np.float32)
    lut = {c: i for i, c in enumerate(sizes)}
    dims = np.array([maps[c].shape[:2] for c in sizes], np.int64)
    got = np.empty(len(H))
    renorm_scores_binned(flat, np.asarray(offsets, np.int64), dims,
                         np.array([lut[c] for c in cell], np.int64), np.array(sizes, np.int64),
                         H, weights, np.float32(0.5), np.float32(0.1 * OPENCV_CHANNELS),
                         np.float32(OPENCV_L2HYS_CLIP), rule, 8, 16,
                         block_axis_weights(8).astype(np.float32), got)
    want = _reference_scores(maps, sizes, H, cell, weights.astype(np.float64), 0.5, rule)
    np.testing.assert_allclose(got, want, rtol=0, atol=2e-5)
    assert np.ptp(want) > 0.1                               # the windows differ


@pytest.mark.parametrize("c, rows", [(4, (3, 7)), (4, (0, 2)), (6, (5, 8)), (8, (0, 5)),
                                     (5, (6, 99))])
def test_block_cells_of_some_rows_are_those_of_the_whole_grid(c, rows):
    """Only the rows asked for are written, each as in the whole grid's computation."""
    mag, t = _gradients((45, 61), 11 + c)
    ny, nx = 45 // c, 61 // c
    whole = opencv_block_cells((mag, t), c)
    part = opencv_block_cells((mag, t), c, out=np.full((ny, nx, OPENCV_CHANNELS), 5.0,
                                                      np.float32), rows=rows)
    y0, y1 = rows[0], min(rows[1], ny)
    np.testing.assert_array_equal(part[y0:y1], whole[y0:y1])
    assert np.all(part[:y0] == 5) and np.all(part[y1:] == 5)


def test_raw_cell_maps_of_some_rows_cover_the_sizes_summed_from_them():
    """A size summed from a smaller one gets its rows even when the smaller one's rows are
    asked for elsewhere; the rows not asked for are 0."""
    mag, t = _gradients((60, 50), 13)
    whole, _, _ = raw_cell_maps((mag, t), [2, 4, 5])
    rows = {2: (0, 3), 4: (10, 14), 5: (2, 4)}
    part, _, _ = raw_cell_maps((mag, t), [2, 4, 5], rows)
    for c, (y0, y1) in rows.items():
        np.testing.assert_array_equal(part[c][y0:y1], whole[c][y0:y1])
        if c != 2:
            assert not part[c][:y0].any() and not part[c][y1:].any()
    # the 2-px rows under the 4-px rows asked for were computed too (the span of both)
    np.testing.assert_array_equal(part[2][:28], whole[2][:28])
    assert not part[2][28:].any()
