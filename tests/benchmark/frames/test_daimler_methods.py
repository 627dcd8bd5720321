"""The Daimler detector's unadapted baseline (OpenCV's detectMultiScale) and image warping."""

import cv2
import numpy as np
import pytest

from benchmark.frames.methods import opencv_detect, warp_scores
from tests.images import bars_scene
from viewadapt.detect import DAIMLER_WINDOW, detector_window_homography


def _scene(shape, seed):
    return bars_scene(shape, seed, bars=8)


def test_daimler_pyramid_boxes_are_the_person_in_its_48x96_windows():
    """At the frame's own scale a Daimler window is 96 px tall; its box is the person in it,
    3/4 of the INRIA window's person box (72 px tall, 30 px wide in a 96-px window)."""
    img = _scene((160, 120), 0)
    d = opencv_detect(img, upsample=1, hit_threshold=-3.0, detector="daimler")
    assert d.shape[1] == 5 and len(d) > 0
    smallest = d[np.argmin(d[:, 3])]
    assert smallest[3] == pytest.approx(72.0) and smallest[2] == pytest.approx(0.41 * 96 * 0.75,
                                                                               abs=0.5)
    assert not np.array_equal(d, opencv_detect(img, upsample=1, hit_threshold=-3.0))
    with pytest.raises(ValueError, match="'opencv' or 'daimler'"):
        opencv_detect(img, detector="sift")


def test_daimler_warping_reads_its_own_48x96_window():
    """A window whose canonical homography is a Daimler window at scale 1 warps to that
    crop: its warped score is OpenCV's Daimler score of the crop."""
    img = _scene((200, 160), 1)
    x0, y0 = 40, 56
    H = np.array([[1.0, 0, x0], [0, 1.0, y0], [0, 0, 1.0]]) @ np.linalg.inv(
        detector_window_homography(DAIMLER_WINDOW))
    hog = cv2.HOGDescriptor((48, 96), (16, 16), (8, 8), (8, 8), 9)
    v = np.asarray(cv2.HOGDescriptor_getDaimlerPeopleDetector(), np.float64).ravel()
    crop = np.ascontiguousarray(img[y0:y0 + 96, x0:x0 + 48])
    want = float(hog.compute(crop).ravel() @ v[:-1] + v[-1])
    assert warp_scores(img, H[None], None, "daimler")[0] == pytest.approx(want, abs=1e-3)
