"""OpenCV's 48x96 Daimler people detector, adapted in full frames like OpenCV's 64x128 one."""

import cv2
import numpy as np
import pytest

from tests.images import bars_scene
from viewadapt.detect import (
    DAIMLER_DETECTOR, DAIMLER_WINDOW, OPENCV_DETECTOR, FrameDetector, RenormStage,
    build_adapted_opencv_operator, daimler_window_features, detector_window_homography,
    opencv_daimler_people_detector, opencv_descriptor_weights, opencv_frame_features,
    opencv_gradients, opencv_kind, opencv_window_features, raw_cell_maps,
    select_candidate_windows,
)
from viewadapt.geometry import WINDOW_CORNERS, camera_from_pose, map_points

SIZE = (192, 144)


def _scene(shape, seed):
    return bars_scene(shape, seed)


def _daimler_hog():
    """OpenCV's Daimler detector as OpenCV's own example sets it up (no gamma)."""
    hog = cv2.HOGDescriptor((48, 96), (16, 16), (8, 8), (8, 8), 9)
    v = np.asarray(cv2.HOGDescriptor_getDaimlerPeopleDetector(), np.float64).ravel()
    return hog, v[:-1], v[-1]


@pytest.fixture(scope="module")
def camera():
    return camera_from_pose(focal=200.0, principal_point=(95.5, 71.5), height=4.0,
                            tilt=np.radians(35), image_size=SIZE)


def test_the_daimler_window_is_the_canonical_window_scaled():
    T = detector_window_homography(DAIMLER_WINDOW)
    corners = np.array([[-0.5, -0.5], [47.5, -0.5], [47.5, 95.5], [-0.5, 95.5]])
    np.testing.assert_allclose(map_points(T[None], corners)[0], WINDOW_CORNERS, atol=1e-12)
    np.testing.assert_array_equal(detector_window_homography((64, 128)), np.eye(3))
    with pytest.raises(ValueError, match="canonical window's shape"):
        detector_window_homography((50, 96))


def test_window_cells_score_as_opencvs_daimler_detector():
    """The cells of a 96x48 window, no gamma, with the Daimler weights are OpenCV's score of
    that window; gamma on would read other features; another size is refused."""
    hog, v, b = _daimler_hog()
    W, bias = opencv_daimler_people_detector()
    assert W.shape == (12, 6, 36) and bias == pytest.approx(b)
    img = _scene((96, 48), 1)
    want = float(hog.compute(img).ravel() @ v + b)
    assert (W * daimler_window_features(img)).sum() + bias == pytest.approx(want, abs=1e-4)
    assert DAIMLER_DETECTOR.window_scores(None, daimler_window_features(img).ravel()[None]) \
        == pytest.approx(want, abs=1e-4)
    assert abs((W * opencv_window_features(img)).sum() + bias - want) > 1e-3
    with pytest.raises(ValueError, match="96x48"):
        daimler_window_features(_scene((128, 64), 2))


def test_the_stage_on_a_grid_window_is_opencvs_daimler_score():
    """A Daimler window at scale 1 on the frame (its canonical homography the inverse of the
    window scaling): with one-pixel raw cells, no gamma, the stage's score is OpenCV's."""
    hog, v, b = _daimler_hog()
    img = _scene((200, 160), 3)
    x0, y0 = 48, 32
    Hd = np.array([[1.0, 0, x0], [0, 1.0, y0], [0, 0, 1.0]])
    Hc = Hd @ np.linalg.inv(detector_window_homography(DAIMLER_WINDOW))
    stage = RenormStage(Hc[None], [1], v, b, window=DAIMLER_WINDOW)
    got = stage.scores([0], raw_cell_maps(opencv_gradients(img, gamma=False), [1]))[0]
    want = hog.compute(img, winStride=(8, 8), padding=(0, 0), locations=[(x0, y0)]).ravel()
    assert got == pytest.approx(float(want @ v + b), abs=1e-3)
    with pytest.raises(ValueError, match="1980 finite values"):
        RenormStage(Hc[None], [1], np.zeros(3780), 0.0, window=DAIMLER_WINDOW)


def test_adapted_daimler_scores_equal_explicitly_remapped_cells(camera):
    """The fold's score of a window is ``w . G x + b`` with ``x`` the frame's cells without
    gamma and ``G`` the remap of the window's 48x96 cells through its homography times the
    window scaling; the cell sizes follow the Daimler window's larger cells."""
    from viewadapt.remap import CellGrid, feature_remap_matrix

    frame = _scene((SIZE[1], SIZE[0]), 6)
    windows = select_candidate_windows(camera)
    sub = windows.subset(np.arange(0, len(windows), max(1, len(windows) // 40)))
    W, b = opencv_daimler_people_detector()
    op = build_adapted_opencv_operator(sub, W, b, tolerance=0.5, renorm=False,
                                       window=DAIMLER_WINDOW, gamma=False)
    inria = build_adapted_opencv_operator(sub, np.zeros((16, 8, 36)), 0.0, renorm=False)
    assert op.features.keywords["gamma"] is False and "gamma" not in inria.features.keywords
    assert np.all(op.cell_size >= inria.cell_size) and np.any(op.cell_size > inria.cell_size)
    T = detector_window_homography(DAIMLER_WINDOW)
    s = op.scores(op.frame_features(frame))
    for n in range(0, len(sub), 5):
        c = int(op.cell_size[n])
        x = opencv_frame_features(frame, [c], pad=0, gamma=False).maps[c]
        ny, nx = x.shape[:2]
        G9 = feature_remap_matrix(op.snapped_homographies[n] @ T, CellGrid.for_window(48, 96, 8),
                                  CellGrid(nx, ny, c), n_bins=9, preserve="mean")
        xq = x.astype(np.float64).reshape(ny * nx, 4, 9)
        ref = sum(W[:, :, 9 * q:9 * q + 9].ravel() @ (G9 @ xq[:, q].ravel()) for q in range(4))
        assert s[n] == pytest.approx(ref + b, rel=1e-4, abs=1e-4 * np.abs(W).sum())


def test_a_frame_detector_runs_the_daimler_detector(camera, tmp_path):
    """``daimler`` is its own kind: its own cache entry, the same detections from the
    cache, other scores than OpenCV's INRIA detector, and another 48x96 model in its place
    through ``opencv_kind(..., detector="daimler")``."""
    frame = _scene((SIZE[1], SIZE[0]), 9)
    det = FrameDetector(camera, None, cache_dir=tmp_path, thresholds={"daimler": -3.0})
    first = det.detect(frame, "daimler")
    again = FrameDetector(camera, None, cache_dir=tmp_path, thresholds={"daimler": -3.0})
    assert np.array_equal(again.detect(frame, "daimler"), first) and again.cache_hit["daimler"]
    assert first.shape[1] == 5 and len(first) > 0
    assert DAIMLER_DETECTOR.model_fingerprint() != OPENCV_DETECTOR.model_fingerprint()
    op = det.operator("daimler")
    assert all(L.operator.stage.window == DAIMLER_WINDOW for L in op.layers)
    W, b = opencv_daimler_people_detector()
    mine = opencv_kind(opencv_descriptor_weights(W) * 0.5, b, detector="daimler")
    other = FrameDetector(camera, None, kinds={"daimler": mine}, thresholds={"daimler": -3.0})
    assert mine.model_fingerprint() != DAIMLER_DETECTOR.model_fingerprint()
    assert not np.array_equal(other.detect(frame, "daimler"), first)
    with pytest.raises(ValueError, match="detector must be one of"):
        opencv_kind(W, b, detector="sift")


def test_a_daimler_hog_file_is_read_with_its_layout(tmp_path):
    """A 48x96 HOGDescriptor file (no gamma) is read as a Daimler detector; as a 64x128
    detector it is a one-line error naming winSize, and a 64x128 file as a Daimler one."""
    from viewadapt.io import DAIMLER_FILE_LAYOUT, read_opencv_hog_detector

    hog, v, b = _daimler_hog()
    hog.setSVMDetector(np.r_[v, b].astype(np.float32))
    path = tmp_path / "daimler.yml"
    hog.save(str(path))
    w, bias = read_opencv_hog_detector(path, DAIMLER_FILE_LAYOUT)
    np.testing.assert_allclose(w, v, rtol=1e-6)
    assert bias == pytest.approx(b, rel=1e-6)
    with pytest.raises(ValueError, match="winSize") as err:
        read_opencv_hog_detector(path)
    assert str(path) in str(err.value) and "\n" not in str(err.value)
    inria = cv2.HOGDescriptor()
    inria.setSVMDetector(cv2.HOGDescriptor_getDefaultPeopleDetector())
    inria.save(str(tmp_path / "inria.yml"))
    with pytest.raises(ValueError, match="winSize"):
        read_opencv_hog_detector(tmp_path / "inria.yml", DAIMLER_FILE_LAYOUT)
