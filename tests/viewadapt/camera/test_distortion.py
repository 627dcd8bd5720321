"""Lens distortion: `dist` in calibration files, `Undistortion` and `distort_image`.

`distort_image` must put a feature where OpenCV's lens model (cv2.projectPoints) sends it,
`Undistortion` must invert it, and a calibration file's `dist` is validated field by field.
"""

import json

import cv2
import numpy as np
import pytest

from viewadapt.camera import Undistortion, check_distortion, distort_image
from viewadapt.geometry import camera_from_pose
from viewadapt.io import read_calibration, read_distortion

SIZE = (384, 288)
K = np.array([[340.0, 0.0, 191.5], [0.0, 340.0, 143.5], [0.0, 0.0, 1.0]])
#: barrel distortion of a wide surveillance lens: it moves the image corners by ~28 px
DIST = np.array([-0.28, 0.09, 0.0012, -0.0008, -0.015])


def _smooth_image(rng):
    """A smooth (384x288) float32 test image in [0, 1]: low-frequency waves and blobs."""
    h, w = SIZE[1], SIZE[0]
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    img = 0.5 + 0.2 * np.sin(x / 17.0 + 0.3) * np.cos(y / 23.0) + 0.1 * np.sin((x + y) / 31.0)
    for cx, cy, s in rng.uniform([0, 0, 8], [w, h, 20], size=(6, 3)):
        img += 0.15 * np.exp(-((x - cx) ** 2 + (y - cy) ** 2) / (2 * s ** 2))
    return np.clip(img, 0, 1).astype(np.float32)


def _project_through_lens(undistorted_px):
    """Where the lens model sends undistorted pixels: cv2.projectPoints of their rays."""
    p = np.asarray(undistorted_px, dtype=np.float64)
    rays = np.c_[(p - K[:2, 2]) / np.diag(K)[:2], np.ones(len(p))]
    q, _ = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), K, DIST)
    return q.reshape(-1, 2)


def test_undistort_inverts_distort_away_from_the_borders():
    img = _smooth_image(np.random.default_rng(0))
    distorted = distort_image(img, K, DIST)
    back = Undistortion(K, DIST, SIZE)(distorted)
    assert back.shape == img.shape and back.dtype == img.dtype
    inner = (slice(30, -30), slice(30, -30))
    err = np.abs(back[inner] - img[inner]).mean()
    moved = np.abs(distorted[inner] - img[inner]).mean()
    assert err < 5e-4 and moved > 50 * err, (err, moved)


def test_distort_image_puts_features_where_project_points_does():
    h, w = SIZE[1], SIZE[0]
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    points = np.array([[60.0, 50.0], [320.0, 40.0], [191.5, 143.5], [40.0, 240.0],
                       [330.0, 250.0], [250.0, 100.0]])
    expected = _project_through_lens(points)
    assert np.abs(expected - points).max() > 5                # the lens moves them
    for p, q in zip(points, expected):
        blob = np.exp(-((x - p[0]) ** 2 + (y - p[1]) ** 2) / (2 * 1.5 ** 2)).astype(np.float32)
        d = distort_image(blob, K, DIST).astype(np.float64)
        win = (np.abs(x - q[0]) < 8) & (np.abs(y - q[1]) < 8)
        centroid = np.array([(d * x)[win].sum(), (d * y)[win].sum()]) / d[win].sum()
        np.testing.assert_allclose(centroid, q, atol=0.05)


def test_undistortion_points_and_maps_invert_the_lens_model():
    und = Undistortion(K, DIST, SIZE)
    rng = np.random.default_rng(1)
    p = rng.uniform([20, 20], [364, 268], size=(50, 2))
    np.testing.assert_allclose(und.undistort_points(_project_through_lens(p)), p, atol=1e-6)
    # the map reads each undistorted pixel from its distorted position
    i, j = 200, 300
    np.testing.assert_allclose([und.map_x[i, j], und.map_y[i, j]],
                               _project_through_lens([[j, i]])[0], atol=1e-3)


def test_undistortion_keeps_uint8_colour_frames_and_checks_their_size():
    frame = np.random.default_rng(2).integers(0, 256, (SIZE[1], SIZE[0], 3), dtype=np.uint8)
    out = Undistortion(K, DIST, SIZE)(frame)
    assert out.shape == frame.shape and out.dtype == np.uint8
    # zero distortion is the identity
    np.testing.assert_array_equal(Undistortion(K, np.zeros(5), SIZE)(frame), frame)
    with pytest.raises(ValueError, match="frame is 288x384 px, the undistortion is for 384x288"):
        Undistortion(K, DIST, SIZE)(frame.transpose(1, 0, 2))


@pytest.mark.parametrize("bad, match", [
    ([0.1, 0.2, 0.3], "got 3"), (np.zeros(6), "got 6"), ([0.1, np.nan, 0, 0, 0], "non-finite"),
    (["a", 0, 0, 0, 0], "4, 5, 8, 12 or 14 numbers"),
])
def test_check_distortion_refuses_bad_values(bad, match):
    with pytest.raises(ValueError, match=match) as err:
        check_distortion(bad)
    assert "\n" not in str(err.value)
    with pytest.raises(ValueError, match=match):
        Undistortion(K, bad, SIZE)
    with pytest.raises(ValueError, match=match):
        distort_image(np.zeros((4, 4), np.float32), K, bad)


# ---------------------------------------------------------------- calibration files


@pytest.fixture
def camera():
    return camera_from_pose(focal=340.0, principal_point=(191.5, 143.5), height=4.5,
                            tilt=np.radians(35), image_size=SIZE)


def _file(tmp_path, camera, suffix=".json", **extra):
    d = {"image_size": list(SIZE), "K": camera.K.tolist(), "R": camera.R.tolist(),
         "t": camera.t.tolist(), **extra}
    p = tmp_path / f"cam{suffix}"
    if suffix == ".json":
        p.write_text(json.dumps(d))
    else:
        import yaml

        p.write_text(yaml.safe_dump(d))
    return p


@pytest.mark.parametrize("n", [4, 5, 8, 12, 14])
def test_dist_is_read_and_read_calibration_ignores_it(n, camera, tmp_path):
    dist = np.round(np.linspace(-0.2, 0.1, n), 4)
    p = _file(tmp_path, camera, dist=dist.tolist())
    np.testing.assert_array_equal(read_distortion(p), dist)
    cam = read_calibration(p)
    np.testing.assert_array_equal(cam.K, camera.K)
    np.testing.assert_array_equal(cam.t, camera.t)


def test_dist_absent_null_or_zero_is_none(camera, tmp_path):
    assert read_distortion(_file(tmp_path, camera)) is None
    assert read_distortion(_file(tmp_path, camera, dist=None)) is None
    assert read_distortion(_file(tmp_path, camera, dist=[0, 0, 0, 0, 0])) is None


def test_dist_in_yaml_forms(camera, tmp_path):
    p = tmp_path / "cam.yaml"
    p.write_text(_file(tmp_path, camera, suffix=".yaml").read_text()
                 + "dist: [-0.2, 1e-3, 0, 0, 0.01]\n")       # YAML 1.1: 1e-3 is a string
    np.testing.assert_allclose(read_distortion(p), [-0.2, 1e-3, 0, 0, 0.01])
    p = _file(tmp_path, camera, dist=[[-0.2, 0.05, 0, 0, 0]])            # OpenCV's 1x5
    np.testing.assert_allclose(read_distortion(p), [-0.2, 0.05, 0, 0, 0])
    p = _file(tmp_path, camera, dist=[[-0.2], [0.05], [0], [0]])           # 4x1
    np.testing.assert_allclose(read_distortion(p), [-0.2, 0.05, 0, 0])


@pytest.mark.parametrize("value, match", [
    ([0.1, 0.2, 0.3], "dist has 3 coefficients"),
    ([0.1] * 6, "dist has 6 coefficients"),
    ([0.1, float("nan"), 0, 0, 0], "dist has non-finite values"),
    ([0.1, float("inf"), 0, 0, 0], "dist has non-finite values"),
    ("-0.2, 0.05", "dist must be a list of 4, 5, 8, 12 or 14 numbers"),
    (0.1, "dist must be a list"),
    ([0.1, "abc", 0, 0, 0], "dist must be a list"),
    ([True, 0, 0, 0, 0], "dist must be a list"),
    ([[0.1, 0.2], [0.3, 0.4]], "dist must be a list"),
    ({"k1": 0.1}, "dist must be a list"),
])
def test_bad_dist_is_a_one_line_error_naming_the_field(value, match, camera, tmp_path):
    p = _file(tmp_path, camera, dist=value)
    with pytest.raises(ValueError, match=match) as err:
        read_distortion(p)
    assert "\n" not in str(err.value) and str(err.value).startswith(f"calibration {p}: dist")
    read_calibration(p)                                      # the camera itself is fine


def _lens_camera():
    return camera_from_pose(focal=340.0, principal_point=(191.5, 143.5), height=5.0,
                            tilt=np.radians(25), image_size=SIZE)


def test_distort_pixels_is_the_lens_model_and_undistortion_inverts_it():
    from viewadapt.detect.windows import distort_pixels

    rng = np.random.default_rng(2)
    p = rng.uniform([20, 20], [364, 268], size=(200, 2))
    np.testing.assert_allclose(distort_pixels(p, K, DIST), _project_through_lens(p), atol=1e-9)
    np.testing.assert_allclose(distort_pixels(p, K, np.zeros(5)), p, atol=1e-9)
    back = Undistortion(K, DIST, SIZE).undistort_points(distort_pixels(p, K, DIST))
    np.testing.assert_allclose(back, p, atol=1e-6)


def test_windows_through_the_lens_follow_it_to_a_fraction_of_a_pixel():
    from viewadapt.detect.windows import (
        distort_pixels, map_points, select_candidate_windows, windows_through_lens,
    )
    from viewadapt.geometry import WINDOW_CORNERS

    cam = _lens_camera()
    W = select_candidate_windows(cam)
    grid = np.stack(np.meshgrid(np.linspace(0, 63, 7), np.linspace(0, 127, 13)), -1).reshape(-1, 2)
    same, keep = windows_through_lens(W, cam.K, np.zeros(5))
    assert keep.all()
    np.testing.assert_allclose(map_points(same.homographies, grid),
                               map_points(W.homographies, grid), atol=1e-3)
    L, keep = windows_through_lens(W, cam.K, DIST)
    assert 0 < len(L) <= len(W) and len(L) == keep.sum()
    np.testing.assert_array_equal(L.ground_xy, W.ground_xy[keep])
    want = distort_pixels(map_points(W.homographies[keep], grid), cam.K, DIST)
    err = np.linalg.norm(map_points(L.homographies, grid) - want, axis=-1)
    assert err.max() < 1.5 and np.median(err) < 0.2
    # the lens moves the windows (barrel: towards the centre), and they stay in the frame
    moved = np.linalg.norm(map_points(L.homographies, WINDOW_CORNERS)
                           - map_points(W.homographies[keep], WINDOW_CORNERS), axis=-1)
    assert moved.max() > 5
    c = map_points(L.homographies, WINDOW_CORNERS)
    assert (c[..., 0] >= -0.5).all() and (c[..., 0] <= SIZE[0] - 0.5).all()


def test_frame_detector_through_a_lens(tmp_path):
    from viewadapt.detect import FrameDetector
    from viewadapt.io import SourceDetectors, shipped_model_path

    cam = _lens_camera()
    models = SourceDetectors.load(shipped_model_path())
    det = FrameDetector(cam, models, lens=DIST, cache_dir=tmp_path)
    plain = FrameDetector(cam, models, cache_dir=tmp_path)
    assert det.params["lens"] == DIST.tolist() and "lens" not in plain.params
    assert det.windows.camera is cam and len(det.windows) > 0
    np.testing.assert_array_equal(det.windows.dist, DIST)
    img = np.zeros((SIZE[1], SIZE[0], 3), np.uint8)
    assert det.detect(img).shape[1] == 5
    assert not det.cache_hit["hog"]            # its own operator, not the pinhole one's
    with pytest.raises(ValueError, match="got 3"):
        FrameDetector(cam, models, lens=[0.1, 0.2, 0.3])


def test_the_body_model_maps_through_the_lens(tmp_path):
    """Windows through the lens with the mean body: each window's mapping is the pinhole
    body mapping, distorted by the lens (the native frame: no layer transform); where the
    lens is the identity it is the pinhole mapping; a detector takes the two together and
    its operator scores a distorted frame."""
    from viewadapt.detect import (
        FrameDetector, build_adapted_linear_operator, select_candidate_windows, window_mapping,
        windows_through_lens,
    )
    from viewadapt.detect.windows import distort_pixels
    from viewadapt.io import SourceDetectors, shipped_model_path
    from viewadapt.objectmodel import object_model

    cam = _lens_camera()
    body = object_model("body")
    pinhole = select_candidate_windows(cam)
    lensed, keep = windows_through_lens(pinhole, cam.K, DIST)
    flat, _ = windows_through_lens(pinhole, cam.K, np.zeros(5))
    grid = np.stack(np.meshgrid(np.linspace(4, 60, 5), np.linspace(8, 120, 7)), -1).reshape(-1, 2)
    idx = np.flatnonzero(keep)
    for n in (0, len(idx) // 2, len(idx) - 1):
        want = window_mapping(pinhole, idx[n], body)(grid)
        got = window_mapping(lensed, n, body)(grid)
        ok = np.all(np.isfinite(want), axis=1)
        assert ok.sum() > len(grid) // 2
        np.testing.assert_allclose(got[ok], distort_pixels(want[ok], cam.K, DIST), atol=1e-6)
        assert np.abs(got[ok] - want[ok]).max() > 0.5          # the lens moves them
        np.testing.assert_allclose(window_mapping(flat, idx[n], body)(grid)[ok], want[ok],
                                   atol=1e-6)
    models = SourceDetectors.load(shipped_model_path())
    det = FrameDetector(cam, models, lens=DIST, object_model="body", cache_dir=tmp_path)
    assert det.params["object_model"] == "body" and det.params["lens"] == DIST.tolist()
    sub = det.windows.subset(np.arange(0, len(det.windows), max(1, len(det.windows) // 30)))
    op = build_adapted_linear_operator(sub, models.hog_weights, models.hog_bias,
                                       object_model="body")
    img = distort_image(_smooth_image(np.random.default_rng(5)), cam.K, DIST)
    assert np.isfinite(op.scores(op.frame_features(img))).all()
