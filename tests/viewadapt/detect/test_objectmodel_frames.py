"""The full-frame detector with an object model other than the paper's plane (the mean
body of viewadapt.objectmodel) and with each angle rule: window mappings, operators and
FrameDetector options."""

import numpy as np
import pytest

from viewadapt.detect import (
    FrameDetector, build_adapted_linear_operator, select_candidate_windows, upsampled_windows,
)
from viewadapt.detect.frame_remap import window_mapping
from viewadapt.geometry import WINDOW_FEET, WINDOW_HEAD, apply_homography, camera_from_pose


@pytest.fixture(scope="module")
def camera():
    return camera_from_pose(focal=200, principal_point=(95.5, 71.5), height=5.0,
                            tilt=np.deg2rad(35), image_size=(192, 144))


@pytest.fixture(scope="module")
def windows(camera):
    return select_candidate_windows(camera, camera.image_size)


def test_plane_mapping_is_the_window_homography(windows):
    assert np.array_equal(window_mapping(windows, 3, "plane"), windows.homographies[3])


def test_body_mapping_is_the_plane_off_the_body(windows):
    """Off the body the mapping is the person plane's, to rounding (the source camera frames
    the same canonical window as the frame's homographies); on the body it is not, and a
    point on the body's front (nearer the elevated camera than the plane) lands lower."""
    off = np.array([[0.5, 20.0], [62.5, 60.0], [2.0, 110.0], [31.5, 3.0]])
    for n in np.linspace(0, len(windows) - 1, 7).astype(int):
        H = windows.homographies[n]
        body = window_mapping(windows, n, "body")
        assert np.allclose(body(off), apply_homography(H, off), atol=1e-6)
        front = WINDOW_FEET - [0, 8.0]               # the shins, facing the source camera
        d = body(front) - apply_homography(H, front)
        scale = np.linalg.norm(apply_homography(H, WINDOW_FEET) -
                               apply_homography(H, WINDOW_HEAD)) / 96
        assert d[1] > 2 * scale and abs(d[0]) < abs(d[1])


def test_body_mapping_follows_the_layer(windows):
    """On an upsampled layer the body mapping is the native one followed by the upsampling."""
    up = upsampled_windows(windows, 2)
    pts = np.array([[31.5, 50.0], [25.0, 90.0], [5.0, 10.0]])
    for n in (0, len(windows) // 2):
        native = window_mapping(windows, n, "body")(pts)
        assert np.allclose(window_mapping(up, n, "body")(pts), 2 * native + 0.5, atol=1e-9)


def test_body_needs_the_camera(windows):
    from dataclasses import replace

    with pytest.raises(ValueError, match="camera"):
        window_mapping(replace(windows, camera=None), 0, "body")
    with pytest.raises(ValueError, match="object model"):
        window_mapping(windows, 0, "cube")


def test_body_operator_differs_from_the_plane_but_agrees_in_the_large(windows):
    rng = np.random.default_rng(1)
    w = rng.normal(size=(16, 8, 13))
    sub = windows.subset(np.arange(0, len(windows), max(1, len(windows) // 40)))
    plane = build_adapted_linear_operator(sub, w, object_model="plane")
    body = build_adapted_linear_operator(sub, w, object_model="body")
    img = rng.integers(0, 256, (144, 192, 3)).astype(np.uint8)
    sp, sb = plane.scores(plane.frame_features(img)), body.scores(body.frame_features(img))
    assert sp.shape == sb.shape and not np.allclose(sp, sb)
    # the same detector through two models of the same person: correlated scores
    assert np.corrcoef(sp, sb)[0, 1] > 0.5


def test_frame_detector_options(camera):
    from viewadapt.io import SourceDetectors

    models = SourceDetectors(np.zeros((16, 8, 13)), 0.0, None)
    with pytest.raises(ValueError, match="object_model"):
        FrameDetector(camera, models, object_model="cube")
    with pytest.raises(ValueError, match="rule"):
        FrameDetector(camera, models, rule="literal")
    # each object model has its own cache key
    assert FrameDetector(camera, models).params["object_model"] == "plane"
    assert FrameDetector(camera, models, object_model="body").params["object_model"] == "body"
