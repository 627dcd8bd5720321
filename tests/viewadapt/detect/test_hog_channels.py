"""The fused HOG pass (:func:`viewadapt.detect.channels.orientation_cell_maps`) against the
unfused OpenCV path it replaced: per-pixel channels of
:func:`viewadapt.detect.channels.fast_orientation_channels` summed by
:func:`viewadapt.detect.channels.cell_sums`, on deterministic random images."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from viewadapt.detect.channels import (
    HOG_CHANNELS, N_HOG_BINS, block_normalize_cells, cell_sums, fast_orientation_channels,
    hog_frame_features, orientation_cell_maps,
)
from tests.images import SHAPES, random_image

#: float32 tolerances: a pixel's bin position ``t`` in [0, 2 n_bins) is rounded to about
#: ``2 n_bins eps ~ 2e-6``, which moves up to that fraction of its magnitude between bins,
#: so cell sums agree to ~1e-5 of the map's largest value; block-normalised features are
#: of unit scale
SUM_RTOL, SUM_ATOL_PER_MAX = 1e-5, 1e-5
FEATURE_ATOL = 1e-5


def reference_cell_maps(image, cell_sizes):
    """Cell sums of the per-pixel oriented magnitudes (the path before the fused pass)."""
    P = fast_orientation_channels(image)
    return {c: cell_sums(P, c) for c in cell_sizes}


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("cell_sizes", [[1], [3], [4, 8], [3, 4, 6, 8], [5, 7, 10]])
def test_fused_cell_maps_match_unfused_path(shape, cell_sizes):
    img = random_image(shape, seed=hash((shape, tuple(cell_sizes))) % 2**32)
    got = orientation_cell_maps(img, cell_sizes)
    ref = reference_cell_maps(img, cell_sizes)
    assert sorted(got) == sorted(set(cell_sizes))
    for c in cell_sizes:
        assert got[c].shape == (shape[0] // c, shape[1] // c, N_HOG_BINS)
        assert got[c].dtype == np.float32
        scale = float(np.abs(ref[c]).max(initial=1.0))
        assert_allclose(got[c], ref[c], rtol=SUM_RTOL, atol=SUM_ATOL_PER_MAX * scale)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_float_images_match_uint8(dtype):
    img = random_image((41, 67, 3), seed=3)
    flt = random_image((41, 67, 3), seed=3, dtype=dtype)
    a = orientation_cell_maps(img, [4])[4]
    b = orientation_cell_maps(flt, [4])[4]
    ref = reference_cell_maps(flt, [4])[4]
    scale = float(np.abs(ref).max())
    assert_allclose(b, ref, rtol=SUM_RTOL, atol=SUM_ATOL_PER_MAX * scale)
    assert_allclose(a, b, rtol=SUM_RTOL, atol=SUM_ATOL_PER_MAX * scale)


def test_strided_and_single_channel_views():
    img = random_image((50, 70, 3), seed=5)
    bgr = img[:, :, ::-1]                                   # negative strides
    assert_allclose(orientation_cell_maps(bgr, [4])[4],
                    orientation_cell_maps(np.ascontiguousarray(bgr), [4])[4], rtol=0, atol=0)
    grey = img[:, :, :1]
    assert_allclose(orientation_cell_maps(grey, [5])[5],
                    orientation_cell_maps(np.ascontiguousarray(img[:, :, 0]), [5])[5],
                    rtol=0, atol=0)


@pytest.mark.parametrize("shape", [(120, 160, 3), (77, 90)])
def test_frame_features_match_unfused_path(shape):
    img = random_image(shape, seed=11)
    sizes = [3, 4, 6, 8]
    feats = hog_frame_features(img, sizes, pad=2)
    ref = reference_cell_maps(img, sizes)
    for c in sizes:
        X = ref[c]
        ny, nx = X.shape[:2]
        want = block_normalize_cells(X, eps=float(c * c))
        F = feats.maps[c]
        assert F.shape == (ny + 4, nx + 4, HOG_CHANNELS)
        assert_allclose(F[2:2 + ny, 2:2 + nx], want, rtol=1e-5, atol=FEATURE_ATOL)
        assert not F[:2].any() and not F[:, :2].any()


@pytest.mark.parametrize("ny, nx", [(9, 7), (2, 5), (1, 4), (6, 1)])
def test_block_normalisation_of_some_rows_is_that_of_the_whole_map(ny, nx):
    """``rows`` computes exactly those rows of the whole map's features (their blocks read
    the rows beside them, reflected only at the map's own border) and leaves the others."""
    X = np.random.default_rng(ny * nx).uniform(0, 5, (ny, nx, N_HOG_BINS)).astype(np.float32)
    whole = block_normalize_cells(X, eps=2.0)
    for r0, r1 in [(0, 1), (0, ny), (1, ny - 1), (ny - 1, ny), (ny // 2, ny // 2 + 1), (3, 2)]:
        part = block_normalize_cells(X, eps=2.0, rows=(r0, r1))
        inside = np.zeros(ny, bool)
        inside[max(r0, 0):max(r1, 0)] = True
        assert_allclose(part[inside], whole[inside], rtol=0, atol=0)
        assert not part[~inside].any()
    out = np.full((ny, nx, HOG_CHANNELS), 7.0, np.float32)
    block_normalize_cells(X, eps=2.0, out=out, rows=(0, 1))
    assert (out[1:] == 7.0).all() and (out[0] == whole[0]).all()


def test_frame_features_of_some_rows_are_those_of_the_whole_frame():
    img = random_image((96, 120, 3), seed=4)
    whole = hog_frame_features(img, [4, 6], pad=2, raw_cell_sizes=[3, 4])
    part = hog_frame_features(img, [4, 6], pad=2, raw_cell_sizes=[3, 4],
                              rows={4: (5, 11)}, raw_rows={3: (0, 4), 4: (20, 24)})
    F, G = whole.maps[4][2:-2], part.maps[4][2:-2]
    assert_allclose(G[5:11], F[5:11], rtol=0, atol=0)
    assert not G[:5].any() and not G[11:].any()
    assert_allclose(part.maps[6], whole.maps[6], rtol=0, atol=0)     # no rows: every row
    assert_allclose(part.raw[0][3][:4], whole.raw[0][3][:4], rtol=0, atol=0)
    assert not part.raw[0][3][4:].any() and not part.raw[0][4][:20].any()
    assert_allclose(part.raw[0][4][20:24], whole.raw[0][4][20:24], rtol=0, atol=0)


def test_errors():
    with pytest.raises(ValueError, match="positive"):
        orientation_cell_maps(random_image((10, 10), seed=0), [0, 4])
    with pytest.raises(ValueError, match="channels"):
        orientation_cell_maps(np.zeros((10, 10, 2), np.uint8), [4])
    with pytest.raises(ValueError, match="empty"):
        orientation_cell_maps(np.zeros((0, 10), np.uint8), [4])
