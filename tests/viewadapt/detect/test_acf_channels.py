"""The fused ACF cell sums (:func:`viewadapt.detect.acf_channels.acf_channel_cell_maps`) and
:func:`viewadapt.detect.acf_channels.acf_frame_features` against the unfused OpenCV path they
replaced: the per-pixel channels of
:func:`viewadapt.detect.acf_channels.fast_acf_pixel_channels` summed by
:func:`viewadapt.detect.channels.cell_sums`, on deterministic random images."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from numpy.testing import assert_allclose

from viewadapt.acf import triangle_kernel
from viewadapt.detect.acf_channels import (
    acf_channel_cell_maps, acf_frame_features, fast_acf_pixel_channels,
)
from viewadapt.detect.channels import N_ACF_CHANNELS, cell_sums
from tests.images import SHAPES, random_image

#: float32 tolerances: magnitudes and orientation bins are the same float32 numbers on both
#: paths, only the order of the cell sums differs (a few float32 ulps of each sum)
SUM_RTOL, SUM_ATOL_PER_MAX = 1e-5, 1e-6


def reference_cell_maps(image, cell_sizes):
    """Cell sums of the per-pixel channels (the path before the fused pass)."""
    P = fast_acf_pixel_channels(image)
    return {c: cell_sums(P, c) for c in cell_sizes}


def reference_frame_maps(image, cell_sizes, pad=2):
    """:func:`acf_frame_features`' maps as computed before the fused pass."""
    P = fast_acf_pixel_channels(image)
    tri = triangle_kernel(1).astype(np.float32)
    out = {}
    for c in cell_sizes:
        A = cell_sums(P, c) * np.float32(1.0 / (c * c))
        if min(A.shape[:2]) > 1:
            A = cv2.sepFilter2D(A, -1, tri, tri, borderType=cv2.BORDER_REFLECT)
        F = np.zeros((A.shape[0] + 2 * pad, A.shape[1] + 2 * pad, A.shape[2]), np.float32)
        F[pad:pad + A.shape[0], pad:pad + A.shape[1]] = A
        out[c] = F
    return out


@pytest.mark.parametrize("dtype", [np.uint8, np.float32, np.float64])
@pytest.mark.parametrize("shape", SHAPES)
def test_fused_cell_sums_match_pixel_channels_summed(shape, dtype):
    img = random_image(shape, seed=sum(shape), dtype=dtype)
    sizes = [1, 2, 3, 4, 6]
    got = acf_channel_cell_maps(img, sizes)
    ref = reference_cell_maps(img, sizes)
    assert sorted(got) == sizes
    for c in sizes:
        assert got[c].dtype == np.float32
        assert got[c].shape == (shape[0] // c, shape[1] // c, N_ACF_CHANNELS)
        atol = SUM_ATOL_PER_MAX * max(float(np.abs(ref[c]).max(initial=0.0)), 1.0)
        assert_allclose(got[c], ref[c], rtol=SUM_RTOL, atol=atol, err_msg=f"cell {c}")


def test_single_pixel_cells_are_the_pixel_channels_exactly():
    img = random_image((23, 31, 3), seed=3)
    np.testing.assert_array_equal(acf_channel_cell_maps(img, [1])[1],
                                  fast_acf_pixel_channels(img))


@pytest.mark.parametrize("shape", [(288, 384, 3), (96, 200), (41, 67, 3)])
def test_frame_features_match_the_unfused_path(shape):
    img = random_image(shape, seed=7)
    sizes = [2, 3, 4]
    feats = acf_frame_features(img, sizes)
    ref = reference_frame_maps(img, sizes)
    for c in sizes:
        assert_allclose(feats.maps[c], ref[c], rtol=SUM_RTOL, atol=1e-6, err_msg=f"cell {c}")


def test_smooth_image_frame_features_match():
    # a smooth gradient image: many pixels with small, similar gradients in all channels
    y, x = np.mgrid[0:120, 0:160]
    img = np.stack([x * 1.5, y * 2.0, (x + y) * 0.7], axis=-1).clip(0, 255).astype(np.uint8)
    feats = acf_frame_features(img, [2, 4])
    ref = reference_frame_maps(img, [2, 4])
    for c in (2, 4):
        assert_allclose(feats.maps[c], ref[c], rtol=SUM_RTOL, atol=1e-6)


def test_invalid_cell_size_raises():
    with pytest.raises(ValueError, match="positive integers"):
        acf_channel_cell_maps(random_image((8, 8, 3), seed=1), [0, 2])


def test_cube_root_is_the_correctly_rounded_float32_cube_root():
    from viewadapt._acf_kernels import cube_root_rows

    rng = np.random.default_rng(0)
    # the L* branch's range (Y above the knee up to white) and the whole float32 range
    y = np.concatenate([rng.uniform(0.0088, 1.0, 20000), np.geomspace(1e-30, 1e30, 20000),
                        [1.0, 8.0, 0.125]]).astype(np.float32)
    got = cube_root_rows(y, np.empty(y.shape, np.uint32), np.empty_like(y))
    np.testing.assert_array_equal(got, np.cbrt(y.astype(np.float64)).astype(np.float32))


@pytest.mark.parametrize("shape", [(37, 53, 3), (1, 9, 3), (64, 48, 3)])
def test_row_wise_luv_is_the_toolbox_luv_to_float32_rounding(shape):
    from viewadapt._acf_kernels import rgb_to_luv_rows
    from viewadapt.acf import LUV_CONSTANTS, rgb_to_luv

    img = random_image(shape, seed=5, dtype=np.float32)
    img[0, 0] = 0.0                                   # black: the 1e-35 floor
    img[0, -1] = 1.0                                  # white
    if shape[0] > 2:
        img[1, 0] = 0.03                              # grey below the L* knee
    xyz, *scalars = LUV_CONSTANTS
    got = rgb_to_luv_rows(img, xyz.astype(np.float32), *(np.float32(v) for v in scalars),
                          np.empty_like(img))
    # float64 toolbox conversion: a few float32 roundings of values up to ~1 apart
    assert_allclose(got, rgb_to_luv(img.astype(np.float64)), rtol=0, atol=2e-6)
