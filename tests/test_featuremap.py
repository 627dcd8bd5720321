import numpy as np
import pytest

from tests.tolerances import EXACT
from viewadapt.featuremap import DenseFeatureMap, hog_feature_map
from viewadapt.hog import hog_cells, orientation_channels


@pytest.fixture(scope="module")
def frame():
    return np.random.default_rng(0).integers(0, 256, (96, 128, 3)).astype(np.uint8)


def test_aligned_cells_equal_hog_cells(frame):
    fm = hog_feature_map(frame)
    assert np.allclose(fm.cells(0, 0, 8, 16, 12), hog_cells(frame), **EXACT)
    assert np.allclose(fm.cells(16, 8, 8, 4, 3), hog_cells(frame)[1:4, 2:6], **EXACT)


def test_unaligned_window_against_brute_force(frame):
    fm = hog_feature_map(frame)
    O = orientation_channels(frame)
    x0, y0 = 13, 5
    got = fm.cells(x0, y0, 4, 3, 2)
    for cy in range(2):
        for cx in range(3):
            want = O[y0 + 4 * cy:y0 + 4 * cy + 4, x0 + 4 * cx:x0 + 4 * cx + 4].sum((0, 1))
            assert np.allclose(got[cy, cx], want, **EXACT)


def test_window_layout(frame):
    fm = hog_feature_map(frame)
    v = fm.window(8, 0, width=32, height=64)
    assert v.shape == (8 * 4 * 9,)
    assert np.allclose(v.reshape(8, 4, 9), hog_cells(frame)[0:8, 1:5], **EXACT)


def test_shrunk_map_reads_whole_channel_pixels():
    ch = np.arange(4 * 6 * 2, dtype=float).reshape(4, 6, 2)
    fm = DenseFeatureMap(ch, shrink=4)
    assert fm.frame_shape == (16, 24)
    got = fm.cells(4, 0, 8, 2, 2)
    assert np.allclose(got[0, 0], ch[0:2, 1:3].sum((0, 1)), **EXACT)


def test_errors(frame):
    fm = hog_feature_map(frame)
    with pytest.raises(ValueError, match="outside"):
        fm.window(100, 0)
    with pytest.raises(ValueError, match="outside"):
        fm.cells(-8, 0, 8, 1, 1)
    with pytest.raises(ValueError, match="multiples of shrink"):
        DenseFeatureMap(np.zeros((4, 4, 1)), shrink=4).cells(2, 0, 8, 1, 1)
    with pytest.raises(ValueError, match="shape"):
        DenseFeatureMap(np.zeros((4, 4)))
