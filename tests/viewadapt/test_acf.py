import numpy as np
import pytest

from tests.tolerances import EXACT
from viewadapt.acf import (
    ACF_CHANNEL_NAMES, acf_channel_names, acf_channels, acf_pixel_channels,
    aggregate_channels, convolve_triangle, orientation_bin_centers,
    orientation_channel_slice, rgb_to_luv,
)

# The toolbox's constants are given to 6 decimals: a grey pixel's v' = 9 / 19.217197 is
# 0.4683305, not v'_n = 0.468331, so V misses its offset by up to 13 * (100/270) * 4.7e-7
# = 2.3e-6 (U by less).
LUV_CONST_ATOL = 3e-6

U0, V0 = 88 / 270, 134 / 270


def _luv_reference(r, g, b):
    """rgbConvertMex.cpp rgb2luv for one pixel with r, g, b in [0, 1], written out."""
    x = 0.430574 * r + 0.341550 * g + 0.178325 * b
    y = 0.222015 * r + 0.706655 * g + 0.071330 * b
    z = 0.020183 * r + 0.129553 * g + 0.939180 * b
    lstar = 116 * y ** (1 / 3) - 16 if y > (6 / 29) ** 3 else y * (29 / 3) ** 3
    l = lstar / 270
    d = x + 15 * y + 3 * z + 1e-35
    return (l, l * (13 * 4 * x / d - 13 * 0.197833) + 88 / 270,
            l * (13 * 9 * y / d - 13 * 0.468331) + 134 / 270)


# ----------------------------------------------------------------------------- LUV
def test_luv_golden_white_black():
    luv = rgb_to_luv(np.array([[[255, 255, 255], [0, 0, 0]]], np.uint8))
    # white: Y = 0.222015 + 0.706655 + 0.071330 = 1 -> L* = 100; chromaticity = white point
    np.testing.assert_allclose(luv[0, 0], [100 / 270, U0, V0], rtol=0, atol=LUV_CONST_ATOL)
    assert luv[0, 0, 0] == pytest.approx(100 / 270, rel=1e-12)
    # black: L = 0 exactly, so U, V are exactly their offsets
    np.testing.assert_array_equal(luv[0, 1], [0.0, U0, V0])


def test_luv_golden_grey_and_red():
    luv = rgb_to_luv(np.array([[[128, 128, 128], [255, 0, 0], [2, 2, 2]]], np.uint8))
    # grey 128: Y = 128/255 > (6/29)^3, L* = 116 (128/255)^(1/3) - 16 = 76.1894...
    assert luv[0, 0, 0] == pytest.approx((116 * (128 / 255) ** (1 / 3) - 16) / 270, rel=1e-12)
    assert luv[0, 0, 0] == pytest.approx(0.28218317, abs=1e-8)
    np.testing.assert_allclose(luv[0, 0, 1:], [U0, V0], rtol=0, atol=LUV_CONST_ATOL)
    # pure red, values worked out from the toolbox formula (see _luv_reference)
    np.testing.assert_allclose(luv[0, 1], [0.20088944, 0.98631385, 0.63877395], atol=1e-8)
    np.testing.assert_allclose(luv[0, 1], _luv_reference(1, 0, 0), **EXACT)
    # grey 2: Y = 2/255 < (6/29)^3 is on the linear part, L* = (29/3)^3 * 2/255
    assert luv[0, 2, 0] == pytest.approx((29 / 3) ** 3 * 2 / 255 / 270, rel=1e-12)


def test_luv_matches_reference_loop_on_random_pixels():
    rng = np.random.default_rng(0)
    img = rng.integers(0, 256, size=(4, 5, 3), dtype=np.uint8)
    luv = rgb_to_luv(img)
    ref = np.array([[_luv_reference(*(img[i, j] / 255.0)) for j in range(5)] for i in range(4)])
    np.testing.assert_allclose(luv, ref, **EXACT)


def test_luv_float_and_grey_inputs():
    rng = np.random.default_rng(1)
    img = rng.integers(0, 256, size=(3, 4, 3), dtype=np.uint8)
    np.testing.assert_allclose(rgb_to_luv(img / 255.0), rgb_to_luv(img), **EXACT)
    grey = img[:, :, 0]
    np.testing.assert_array_equal(rgb_to_luv(grey), rgb_to_luv(np.repeat(grey[..., None], 3, 2)))


# ------------------------------------------------------------------ triangle filter
def _tri_reference(x, kernel):
    r = len(kernel) // 2
    pad = np.pad(x, r, mode="symmetric")          # Matlab padarray(..., 'symmetric')
    rows = np.array([np.convolve(row, kernel, mode="valid") for row in pad])
    return np.array([np.convolve(col, kernel, mode="valid") for col in rows.T]).T


@pytest.mark.parametrize("radius, kernel", [
    (1, np.array([1, 2, 1]) / 4),
    (5, np.array([1, 2, 3, 4, 5, 6, 5, 4, 3, 2, 1]) / 36),
    (0.5, np.array([1, 7.6, 1]) / 9.6),          # p = 12 / (0.5 * 2.5) - 2 = 7.6
])
def test_convolve_triangle_against_padded_convolution(radius, kernel):
    x = np.random.default_rng(2).random((7, 9))
    np.testing.assert_allclose(convolve_triangle(x, radius), _tri_reference(x, kernel), **EXACT)


def test_convolve_triangle_keeps_constants_and_radius_zero():
    x = np.full((2, 4, 6), 3.25)
    np.testing.assert_allclose(convolve_triangle(x, 5), x, **EXACT)
    y = np.random.default_rng(3).random((4, 6))
    np.testing.assert_array_equal(convolve_triangle(y, 0), y)


# ------------------------------------------------------------------ channel values
def test_constant_image_has_zero_gradients_and_its_luv():
    colour = np.array([200, 120, 40], np.uint8)
    img = np.broadcast_to(colour, (12, 8, 3)).copy()
    C = acf_channels(img)
    assert C.shape == (10, 3, 2)
    np.testing.assert_array_equal(C[3:], 0.0)
    expected = rgb_to_luv(colour[None, None])[0, 0]
    np.testing.assert_allclose(C[:3], np.broadcast_to(expected[:, None, None], (3, 3, 2)),
                               **EXACT)
    np.testing.assert_allclose(expected, _luv_reference(200 / 255, 120 / 255, 40 / 255), **EXACT)


def _vertical_step(size=16, value=200):
    img = np.zeros((size, size), np.uint8)
    img[:, size // 2:] = value
    return img


def test_step_edge_golden_magnitude():
    # No smoothing and no normalisation: L jumps from 0 to l200 between columns 7 and 8, so
    # the central difference is l200 / 2 on both columns and 0 elsewhere; theta = 0.
    l200 = (116 * (200 / 255) ** (1 / 3) - 16) / 270
    P = acf_pixel_channels(_vertical_step(), shrink=1, smooth_color=0, norm_radius=0)
    expected = np.zeros((16, 16))
    expected[:, 7:9] = l200 / 2
    np.testing.assert_allclose(P[3], expected, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(P[4], expected, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(P[5:], 0.0)
    # With normalisation radius 5 the local average at column 7 is m (6 + 5) / 36
    # (triangle weights [1..5, 6, 5..1] / 36; M is constant along the columns).
    Pn = acf_pixel_channels(_vertical_step(), shrink=1, smooth_color=0)
    m = l200 / 2
    assert Pn[3, 5, 7] == pytest.approx(m / (11 / 36 * m + 0.005), rel=1e-10)
    assert Pn[3, 5, 3] == 0.0


def test_step_edge_energy_in_bin_of_zero_and_rotation_moves_it():
    C = acf_channels(_vertical_step())
    orient = C[orientation_channel_slice()]
    total = orient.sum(axis=(1, 2))
    assert total[0] > 1.0
    np.testing.assert_array_equal(total[1:], 0.0)
    # the magnitude channel is the sum of the orientation channels (hard binning)
    np.testing.assert_allclose(orient.sum(axis=0), C[3], **EXACT)
    # rotated by 90 degrees: a horizontal edge, theta = pi / 2 -> the bin centred there
    C90 = acf_channels(np.rot90(_vertical_step()))
    total90 = C90[orientation_channel_slice()].sum(axis=(1, 2))
    k = int(np.argmin(np.abs(orientation_bin_centers() - np.pi / 2)))
    assert k == 3
    assert total90[k] == pytest.approx(total[0], rel=1e-12)
    np.testing.assert_array_equal(np.delete(total90, k), 0.0)


@pytest.mark.parametrize("ramp, bin_", [
    (np.add.outer(np.arange(16), np.arange(16)), 1),        # brighter down-right: pi/4
    (np.subtract.outer(np.arange(16), np.arange(16)) + 15, 3),  # brighter down-left: 3pi/4
])
def test_diagonal_ramps_fix_the_y_down_convention(ramp, bin_):
    img = (ramp * 8).astype(np.uint8)
    total = acf_channels(img, n_orients=4)[orientation_channel_slice(4)].sum(axis=(1, 2))
    assert total[bin_] > 0
    np.testing.assert_array_equal(np.delete(total, bin_), 0.0)


def test_soft_orientation_splits_between_bin_centres():
    # theta = pi / 4 with 6 bins is o = 1.5: half to bin 1 (pi/6), half to bin 2 (pi/3).
    # Away from the border (smoothing and one-sided differences there break the symmetry
    # of the ramp, since L is not linear in the grey level) dx == dy exactly.
    img = (np.add.outer(np.arange(16), np.arange(16)) * 8).astype(np.uint8)
    P = acf_pixel_channels(img, interpolate_orientation=True)
    O = P[orientation_channel_slice()]
    inner = (slice(None), slice(2, -2), slice(2, -2))
    np.testing.assert_allclose(O[1][inner[1:]], P[3][inner[1:]] / 2, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(O[2][inner[1:]], P[3][inner[1:]] / 2, rtol=1e-9, atol=1e-12)
    np.testing.assert_array_equal(np.delete(O, [1, 2], axis=0)[inner], 0.0)
    np.testing.assert_allclose(O.sum(axis=0), P[3], **EXACT)


def test_rotation_by_90_degrees_permutes_orientation_channels():
    # np.rot90 maps (dx, dy) to (dy, -dx): theta -> theta + pi/2, i.e. bin k -> k + 3 of 6.
    # Symmetric borders, block means and triangle filters all commute with the rotation.
    img = np.random.default_rng(4).integers(0, 256, size=(24, 16, 3), dtype=np.uint8)
    C = acf_channels(img)
    R = acf_channels(np.rot90(img))
    np.testing.assert_allclose(R[:4], np.rot90(C[:4], axes=(1, 2)), **EXACT)
    for k in range(6):
        np.testing.assert_allclose(R[4 + (k + 3) % 6], np.rot90(C[4 + k]), **EXACT)


# ------------------------------------------------------------------ aggregation
def test_acf_channels_is_aggregate_of_pixel_channels_and_crops():
    img = np.random.default_rng(5).integers(0, 256, size=(130, 67, 3), dtype=np.uint8)
    C = acf_channels(img)
    assert C.shape == (10, 32, 16)
    np.testing.assert_array_equal(C, aggregate_channels(acf_pixel_channels(img), 4, 1))
    np.testing.assert_array_equal(C, acf_channels(img[:128, :64]))
    assert acf_pixel_channels(img).shape == (10, 128, 64)


def test_aggregate_block_mean_golden():
    P = np.arange(16, dtype=np.float64).reshape(1, 4, 4)
    A = aggregate_channels(P, shrink=2, smooth_channels=0)
    np.testing.assert_allclose(A[0], [[2.5, 4.5], [10.5, 12.5]], **EXACT)


def test_aggregate_channels_is_linear():
    rng = np.random.default_rng(6)
    P, Q = rng.random((2, 10, 20, 12))
    a, b = 1.7, -0.3
    np.testing.assert_allclose(aggregate_channels(a * P + b * Q),
                               a * aggregate_channels(P) + b * aggregate_channels(Q), **EXACT)


def test_channel_names_and_slice():
    assert len(ACF_CHANNEL_NAMES) == 10
    assert ACF_CHANNEL_NAMES[:4] == ("L", "U", "V", "gradient_magnitude")
    assert ACF_CHANNEL_NAMES[orientation_channel_slice()] == tuple(
        f"orientation_{k}" for k in range(6))
    assert len(acf_channel_names(8)) == 12
    np.testing.assert_allclose(orientation_bin_centers(4), [0, np.pi / 4, np.pi / 2,
                                                            3 * np.pi / 4])


# ------------------------------------------------------------------ errors
@pytest.mark.parametrize("image, match", [
    (np.zeros((0, 8, 3), np.uint8), "empty"),
    (np.full((8, 8), np.nan), "NaN"),
    (np.zeros((8, 8, 4), np.uint8), "channels"),
    (np.zeros((8, 8, 3, 1), np.uint8), "shape"),
    (np.zeros((3, 16, 3), np.uint8), "smaller than shrink"),
    (np.full((8, 8), 2.0), r"\[0, 1\]"),
])
def test_acf_channels_rejects_bad_images(image, match):
    with pytest.raises(ValueError, match=match):
        acf_channels(image)


@pytest.mark.parametrize("kwargs, match", [
    (dict(shrink=0), "shrink"),
    (dict(shrink=2.0), "shrink"),
    (dict(n_orients=0), "n_orients"),
    (dict(norm_const=0.0), "norm_const"),
    (dict(norm_radius=2.5), "radius"),
    (dict(smooth_color=-1), "radius"),
])
def test_acf_channels_rejects_bad_parameters(kwargs, match):
    with pytest.raises(ValueError, match=match):
        acf_channels(np.zeros((16, 16), np.uint8), **kwargs)


def test_aggregate_channels_rejects_bad_input():
    with pytest.raises(ValueError, match="shape"):
        aggregate_channels(np.zeros((8, 8)))
    with pytest.raises(ValueError, match="NaN"):
        aggregate_channels(np.full((1, 8, 8), np.nan))
    with pytest.raises(ValueError, match="smaller than shrink"):
        aggregate_channels(np.zeros((1, 2, 8)), shrink=4)
    with pytest.raises(ValueError, match="radius"):
        convolve_triangle(np.zeros((4, 4)), 1.5)


def test_fast_acf_features_are_the_same_bits_every_call():
    # flat patches (like rendered crops) once made the OpenCV magnitude kernel round by
    # one ulp differently depending on where its output buffer lay: cached features then
    # differed from run to run
    from viewadapt.detect import acf_window_features

    rng = np.random.default_rng(0)
    img = np.full((128, 64, 3), 120, np.uint8)
    for _ in range(12):
        y, x = rng.integers(0, 120), rng.integers(0, 60)
        h, w = rng.integers(4, 60), rng.integers(4, 40)
        img[y:y + h, x:x + w] = rng.integers(0, 256, 3)
    first = acf_window_features(img)
    for _ in range(16):
        assert np.array_equal(acf_window_features(img), first)
