"""Source detectors trained on canonical windows (viewadapt.detect.training)."""

import numpy as np
import pytest

from viewadapt.detect import HOG_WEIGHT_SHAPE, check_frame_view, train_on_windows


def _windows(rng, n, person):
    """Blurred-noise 128x64 windows; "persons" carry a bright vertical bar."""
    import cv2

    out = []
    for _ in range(n):
        w = cv2.GaussianBlur(rng.integers(0, 256, (128, 64), dtype=np.uint8), (5, 5), 1.5)
        if person:
            w[16:112, 26:38] = 230
        out.append(w)
    return out


@pytest.fixture(scope="module")
def windows():
    rng = np.random.default_rng(0)
    return _windows(rng, 12, True), _windows(rng, 40, False)


def test_training_records_what_it_trained_on_and_is_seeded(windows):
    pos, neg = windows
    a = train_on_windows(pos, neg, seed=3, quick=True, frame_view="none")
    assert a.training == dict(seed=3, frame_view="none", quick=True, crops=12,
                              background_windows=40)
    assert a.hog_weights.shape == HOG_WEIGHT_SHAPE
    b = train_on_windows(pos, neg, seed=3, quick=True, frame_view="none")
    assert np.array_equal(a.hog_weights, b.hog_weights) and a.hog_bias == b.hog_bias
    c = train_on_windows(pos, neg, seed=4, quick=True, frame_view="none")
    assert not np.array_equal(a.hog_weights, c.hog_weights)


def test_frame_view_is_checked(windows):
    pos, neg = windows
    with pytest.raises(ValueError, match="frame_view must be one of"):
        train_on_windows(pos, neg, frame_view="all")
    assert check_frame_view("both") == "both"
