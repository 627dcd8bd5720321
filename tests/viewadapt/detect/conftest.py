"""Fixtures of the full-frame detector's tests: a small blurred-noise frame."""

import numpy as np
import pytest

#: (width, height) of the test frames and cameras of test_detector.py and test_channels.py
SIZE = (192, 144)


@pytest.fixture(scope="module")
def frame():
    import cv2

    rng = np.random.default_rng(3)
    img = rng.integers(0, 256, (SIZE[1], SIZE[0], 3), dtype=np.uint8)
    return cv2.GaussianBlur(img, (5, 5), 1.5)
