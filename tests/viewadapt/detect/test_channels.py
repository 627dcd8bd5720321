"""Frame features: the fused HOG and ACF channels, cell maps and block normalisation of
:mod:`viewadapt.detect.channels` against plain references."""

import cv2
import numpy as np
import pytest

from tests.tolerances import FLOAT32
from viewadapt.detect import (
    block_normalize_cells,
    acf_frame_features, acf_window_features, fast_acf_pixel_channels,
    fast_orientation_channels, hog_frame_features, hog_window_features, orientation_cell_maps,
)
from viewadapt.hog import orientation_channels


def test_fast_orientation_channels_match_reference(frame):
    ref = orientation_channels(frame)
    fast = fast_orientation_channels(frame)
    assert fast.dtype == np.float32
    assert np.allclose(fast, ref, rtol=1e-4, atol=1e-3 * ref.max())


@pytest.mark.parametrize("grey", [False, True])
def test_fast_acf_pixel_channels_match_reference(frame, grey):
    from viewadapt.acf import acf_pixel_channels

    img = frame.mean(axis=2).astype(np.uint8) if grey else frame
    ref = np.moveaxis(acf_pixel_channels(img, shrink=1), 0, -1)
    fast = fast_acf_pixel_channels(img)
    assert fast.dtype == np.float32 and fast.shape == ref.shape
    # colour and magnitude channels: float32 rounding
    assert np.allclose(fast[..., :4], ref[..., :4], rtol=1e-4, atol=1e-5)
    # orientation: the same bins except for pixels on a bin boundary
    flipped = ~np.isclose(fast[..., 4:], ref[..., 4:], rtol=1e-4, atol=1e-5).all(-1)
    assert flipped.mean() < 2e-3
    assert np.allclose(fast[..., 4:].sum(-1), ref[..., 3], rtol=1e-4, atol=1e-5)


def test_acf_frame_features_match_reference_aggregation(frame):
    from viewadapt.acf import acf_pixel_channels, aggregate_channels

    maps = acf_frame_features(frame, [2, 4], pad=1).maps
    for c in (2, 4):
        ref = aggregate_channels(acf_pixel_channels(frame, shrink=c), shrink=c)
        got = np.moveaxis(maps[c][1:-1, 1:-1], -1, 0)
        assert got.shape == ref.shape
        assert np.abs(got - ref).mean() < 1e-4 * np.abs(ref).mean()
        assert np.allclose(got[:4], ref[:4], rtol=1e-3, atol=1e-5)


def test_acf_window_features_are_the_reference_channels():
    from viewadapt.acf import acf_channels

    rng = np.random.default_rng(1)
    win = cv2.GaussianBlur(rng.integers(0, 256, (128, 64, 3), dtype=np.uint8), (5, 5), 1.5)
    got, ref = acf_window_features(win), acf_channels(win)
    assert got.shape == ref.shape == (10, 32, 16) and got.dtype == np.float32
    assert np.abs(got - ref).mean() < 1e-3 * np.abs(ref).mean()


def _block_normalize_loop(X, eps, clip):
    """Plain-loop reference: four reflected 2x2 blocks per cell, L2 norm, clip, reduce
    (a map one cell high or wide repeats its edge instead)."""
    ny, nx, nb = X.shape

    def refl(i, n):          # reflect-101 index
        if min(ny, nx) == 1:
            return min(max(i, 0), n - 1)
        return -i if i < 0 else (2 * (n - 1) - i if i >= n else i)

    out = np.zeros((ny, nx, nb + 4))
    for i in range(ny):
        for j in range(nx):
            for k, (di, dj) in enumerate(((-1, -1), (-1, 0), (0, -1), (0, 0))):
                e = sum(float(np.sum(X[refl(i + di + a, ny), refl(j + dj + b, nx)] ** 2))
                        for a in (0, 1) for b in (0, 1))
                f = np.minimum(X[i, j] / np.sqrt(e + eps ** 2), clip)
                out[i, j, :nb] += f
                out[i, j, nb + k] = f.sum()
    return out


def test_block_normalize_cells_against_a_plain_loop():
    rng = np.random.default_rng(4)
    X = rng.gamma(0.5, 200.0, size=(5, 4, 9)).astype(np.float32)
    X[1, 2] = 0                                      # an empty cell: the floor applies
    got = block_normalize_cells(X, eps=30.0, clip=0.2)
    ref = _block_normalize_loop(X.astype(np.float64), 30.0, 0.2)
    assert got.shape == (5, 4, 13) and got.dtype == np.float32
    assert np.allclose(got, ref, rtol=1e-5, atol=1e-6)
    assert np.all(got[:, :, :9] <= 4 * 0.2 + 1e-6) and np.any(got[:, :, :9] > 0.2)
    # a cell that dominates its blocks is clipped in every normalisation
    X[3, 1, 4] = 1e6
    got = block_normalize_cells(X, eps=30.0, clip=0.2)
    assert got[3, 1, 4] == pytest.approx(0.8)
    with pytest.raises(ValueError, match="cells"):
        block_normalize_cells(X[0])
    row = X[2:3]                                     # one cell high: edge blocks
    assert np.allclose(block_normalize_cells(row, eps=30.0, clip=0.2),
                       _block_normalize_loop(row.astype(np.float64), 30.0, 0.2),
                       rtol=1e-5, atol=1e-6)
    # in place into the inside of a zero-padded map
    padded = np.zeros((7, 6, 13), np.float32)
    block_normalize_cells(X, eps=30.0, clip=0.2, out=padded[1:-1, 1:-1])
    assert np.array_equal(padded[1:-1, 1:-1], got) and not padded[0].any()
    with pytest.raises(ValueError, match="out"):
        block_normalize_cells(X, out=padded)


@pytest.mark.parametrize("kind", ["colour uint8", "grey float"])
def test_orientation_cell_maps_are_cell_sums_of_the_pixel_channels(kind):
    """The fused per-cell binning equals summing fast_orientation_channels over cells, at
    sizes from pixels (2, 3, 5) and from smaller cells (4, 6), remainders dropped."""
    rng = np.random.default_rng(6)
    img = cv2.GaussianBlur(rng.integers(0, 256, (61, 47, 3), dtype=np.uint8), (0, 0), 1.5)
    if kind == "grey float":
        img = img[:, :, 1] / 255.0
    O = fast_orientation_channels(img).astype(np.float64)
    got = orientation_cell_maps(img, [6, 2, 3, 4, 5])
    assert sorted(got) == [2, 3, 4, 5, 6]
    for c, X in got.items():
        ny, nx = 61 // c, 47 // c
        ref = O[:ny * c, :nx * c].reshape(ny, c, nx, c, 9).sum(axis=(1, 3))
        assert X.shape == (ny, nx, 9) and X.dtype == np.float32
        assert np.allclose(X, ref, rtol=1e-4, atol=1e-3), c
    with pytest.raises(ValueError, match="positive"):
        orientation_cell_maps(img, [0])


def test_block_normalised_features_hardly_change_with_cell_size():
    """Features of a scene at 8 px cells and of the same scene at half resolution with
    4 px cells are close (the premise of reading frame cells of any size)."""
    rng = np.random.default_rng(5)
    big = cv2.GaussianBlur(cv2.resize(rng.integers(0, 256, (32, 16, 3), dtype=np.uint8),
                                      (128, 256), interpolation=cv2.INTER_CUBIC), (0, 0), 2)
    small = cv2.resize(big, (64, 128), interpolation=cv2.INTER_AREA)
    f8 = hog_frame_features(big, [8], pad=0).maps[8]
    f4 = hog_frame_features(small, [4], pad=0).maps[4]
    other = hog_frame_features(np.ascontiguousarray(big[::-1]), [8], pad=0).maps[8]
    d_same, d_other = np.abs(f8 - f4).mean(), np.abs(f8 - other).mean()
    assert d_same < 0.35 * d_other


def test_window_features_are_frame_features_at_8px():
    rng = np.random.default_rng(0)
    win = rng.integers(0, 256, (128, 64, 3), dtype=np.uint8)
    f = hog_frame_features(win, [8], pad=0).maps[8]
    assert np.allclose(hog_window_features(win), f, **FLOAT32)


def test_hog_maps_share_one_buffer_in_the_order_given(frame):
    f = hog_frame_features(frame, [4, 2, 8, 4], pad=2)
    assert list(f.maps) == [4, 2, 8]
    ref = np.concatenate([f.maps[c].ravel() for c in (4, 2, 8)])
    v = f.vector([4, 2, 8])
    assert np.array_equal(v, ref) and np.shares_memory(v, f.maps[2])      # no copy
    other = f.vector([2, 4])                                              # another order
    assert np.array_equal(other, np.concatenate([f.maps[2].ravel(), f.maps[4].ravel()]))
    assert not np.shares_memory(other, f.maps[2])
    # each map is the single-size computation (cell sums may be summed from finer ones)
    for c in (2, 4, 8):
        one = hog_frame_features(frame, [c], pad=2).maps[c]
        assert np.allclose(f.maps[c], one, **FLOAT32)


# ------------------------------------------------------------- per-window adapted scores
