"""Frame-view copies of training windows: exactly what the adapted operator reads."""

import numpy as np
import pytest

from tests.tolerances import FLOAT32

from viewadapt.detect import (
    ACF_FEATURES, FRAME_VIEW_SCALES, frame_view, frame_view_copies, frame_view_features,
)
from viewadapt.detect import (
    HOG_CHANNELS, build_adapted_linear_operator, build_adapted_trees_operator,
    build_multiresolution_operator, hog_window_features,
)
from viewadapt.detect import CandidateWindows, person_boxes


@pytest.fixture(scope="module")
def window():
    # a bright upright bar on a textured background: a crude person
    rng = np.random.default_rng(3)
    w = rng.integers(40, 90, (128, 64, 3)).astype(np.uint8)
    w[16:112, 24:40] = rng.integers(170, 230, (96, 16, 3))
    return w


def _operator_score(frame, H, build):
    """Score of the one window ``H`` by the full-frame multi-resolution operator."""
    wins = CandidateWindows(np.zeros((1, 2)), np.array([1.75]), H[None],
                            (frame.shape[1], frame.shape[0]), np.zeros((1, 2), int))
    op = build_multiresolution_operator(wins, build, upsample_below=0.5)
    return float(op.scores(op.frame_features(frame))[0])


@pytest.mark.parametrize("scale,offset", [(0.3, (0, 0)), (0.45, (5, 2)), (0.7, (3, 7)),
                                          (1.0, (1, 4)), (1.3, (6, 0))])
def test_linear_score_is_the_operators_score(window, scale, offset):
    # both sides of the 2x band threshold (0.5), several phases against the cell grid
    rng = np.random.default_rng(4)
    w = rng.normal(size=(16, 8, HOG_CHANNELS))
    frame, H = frame_view(window, scale, offset=offset)
    x = frame_view_features(window, scale, offset=offset)
    ref = _operator_score(frame, H, lambda ws: build_adapted_linear_operator(
        ws, w, 0.25, tolerance=0.0))
    assert float(w.ravel() @ x.ravel().astype(np.float64)) + 0.25 == pytest.approx(
        ref, rel=1e-4, abs=1e-4 * np.abs(w).sum())


@pytest.fixture(scope="module")
def trees(window):
    # boosted trees whose thresholds fall where frame-view ACF channels lie: fitted on
    # copies of the window at random scales, labelled by scale (so scores vary with it)
    from viewadapt.boosting import AdaBoostTrees

    rng = np.random.default_rng(6)
    scales = rng.choice(FRAME_VIEW_SCALES, 60)
    X = np.stack([frame_view_features(window, s, ACF_FEATURES, offset=tuple(rng.integers(0, 8, 2))).ravel()
                  for s in scales])
    y = (scales < 0.6).astype(int) ^ (rng.random(60) < 0.2)
    return AdaBoostTrees(n_estimators=16, stages=None, max_bins=16, max_features=0.2,
                         random_state=0).fit(X, y)


def test_trees_score_is_the_operators_score(window, trees):
    got, ref = [], []
    for scale, offset in [(0.3, (0, 0)), (0.45, (5, 2)), (0.7, (3, 7)), (1.0, (1, 4))]:
        frame, H = frame_view(window, scale, offset=offset)
        x = frame_view_features(window, scale, ACF_FEATURES, offset=offset)
        assert x.shape == (10, 32, 16)
        got.append(float(trees.decision_function(x.reshape(1, -1).astype(np.float64))[0]))
        ref.append(_operator_score(frame, H, lambda ws: build_adapted_trees_operator(
            ws, trees, tolerance=0.0)))
    assert np.allclose(got, ref, rtol=1e-5, atol=1e-5)
    assert np.ptp(ref) > 0                     # the scales score differently


def test_frame_view_geometry(window):
    frame, H = frame_view(window, 0.5, offset=(2, 6))
    assert frame.dtype == np.uint8
    # 24 + offset px of context on each side, shrunk by about 0.5
    assert frame.shape[:2] == (round((128 + 2 * 30) * 0.5), round((64 + 2 * 26) * 0.5))
    x, y, bw, bh = person_boxes(H[None])[0]
    assert bh == pytest.approx(96 * 0.5, rel=0.02)        # a 48 px person
    assert x + bw / 2 == pytest.approx(frame.shape[1] / 2, abs=0.6)


def test_aligned_copy_at_scale_one_is_the_window_features(window):
    # scale 1, 8-px frame cells, no offset: the frame's cells are the window's own (away
    # from the window's border, where the frame has context and the window has none)
    a = hog_window_features(window)[1:-1, 1:-1]
    b = frame_view_features(window, 1.0, cells_per_source_cell=1.0)[1:-1, 1:-1]
    assert np.allclose(a, b, **FLOAT32)
    # half a cell off the grid, or coarser cells: resampled, no longer the same
    c = frame_view_features(window, 1.0, offset=(4, 4), cells_per_source_cell=1.0)
    d = frame_view_features(window, 1.0, cells_per_source_cell=0.5)      # 16-px cells
    assert not np.allclose(a, c[1:-1, 1:-1], atol=1e-2)
    assert not np.allclose(a, d[1:-1, 1:-1], atol=1e-2)


def test_copies_are_seeded_and_cover_the_scales(window):
    a = frame_view_copies([window] * 6, seed=1)
    b = frame_view_copies([window] * 6, seed=1)
    c = frame_view_copies([window] * 6, seed=2)
    assert a.shape == (6, 16 * 8 * HOG_CHANNELS) and a.dtype == np.float32
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert min(FRAME_VIEW_SCALES) == 0.25 and max(FRAME_VIEW_SCALES) == 1.5
    assert frame_view_copies([], seed=0).shape == (0, 16 * 8 * HOG_CHANNELS)
    assert frame_view_copies([window], ACF_FEATURES).shape == (1, 10 * 32 * 16)
    with pytest.raises(ValueError, match="kind must be"):
        frame_view_copies([window], "sift")


@pytest.mark.parametrize("kw,msg", [
    (dict(scale=0.0), "scale must be a positive"),
    (dict(scale=float("nan")), "scale must be a positive"),
    (dict(scale=0.5, offset=(8, 0)), "offset must lie in 0..7"),
    (dict(scale=0.5, offset=(-1, 0)), "offset must lie in 0..7"),
])
def test_bad_arguments(window, kw, msg):
    with pytest.raises(ValueError, match=msg):
        frame_view_features(window, **kw)


def test_bad_window():
    with pytest.raises(ValueError, match="window must be 128x64"):
        frame_view_features(np.zeros((96, 48), np.uint8), 0.5)
    with pytest.raises(ValueError, match="scales must be"):
        frame_view_copies([np.zeros((128, 64), np.uint8)], scales=[0.5, -1])
