"""OpenCV's HOG/SVM people detector as block-normalised cells, and adapted in full frames."""

import re

import cv2
import numpy as np
import pytest

from tests.images import bars_scene
from tests.tolerances import FLOAT32
from tests.viewadapt.detect.unread_rows import scramble_unread_rows
from viewadapt.detect import (
    FRAME_CELL_SIZES, HOG_CELL, OPENCV_CHANNELS, OPENCV_FOLD_CELL_SIZES, OPENCV_STAGE_CELL_SIZES,
    OPENCV_WEIGHT_SHAPE, FrameDetector, build_adapted_opencv_operator,
    detector_kind, opencv_block_cells, opencv_cell_weights, opencv_default_people_detector,
    opencv_frame_features, opencv_frame_remap, opencv_window_features, select_candidate_windows,
    TemplateGroup,
)
from viewadapt.detect import opencv_gradients
from viewadapt.geometry import camera_from_pose

SIZE = (192, 144)


def _scene(shape, seed):
    return bars_scene(shape, seed)


def _descriptor_from_cells(F):
    """The 3780 OpenCV descriptor values read back out of (16, 8, 36) cells."""
    where = opencv_cell_weights(np.arange(1, 3781, dtype=np.float64)).astype(int) - 1
    d = np.full(3780, np.nan)
    d[where[where >= 0]] = F[where >= 0]
    return d


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_window_cells_are_opencvs_descriptor(seed):
    """The 36-channel cells of a 64x128 window hold exactly cv2.HOGDescriptor's values, and
    the cell weights give OpenCV's own score."""
    win = _scene((128, 64), seed)
    d = cv2.HOGDescriptor().compute(win).ravel()
    F = opencv_window_features(win)
    assert F.shape == OPENCV_WEIGHT_SHAPE
    got = _descriptor_from_cells(F)
    assert not np.isnan(got).any()                 # every descriptor value has its cell copy
    np.testing.assert_allclose(got, d, atol=2e-6)
    v = np.asarray(cv2.HOGDescriptor_getDefaultPeopleDetector(), np.float64).ravel()
    W, b = opencv_default_people_detector()
    assert b == v[-1]
    assert float((W * F).sum() + b) == pytest.approx(float(d @ v[:-1] + v[-1]), abs=1e-4)


def test_frame_cells_are_opencvs_descriptor_at_every_grid_window():
    """On a frame, the window at any 8-px grid position reads OpenCV's descriptor of the
    same window computed on the whole frame (gradients across the window's border)."""
    img = _scene((200, 160), 4)
    hog = cv2.HOGDescriptor()
    maps = opencv_frame_features(img, [8], pad=2).maps[8]
    for x, y in [(0, 0), (48, 16), (96, 72)]:
        d = hog.compute(img, winStride=(8, 8), padding=(0, 0), locations=[(x, y)]).ravel()
        F = maps[2 + y // 8:2 + y // 8 + 16, 2 + x // 8:2 + x // 8 + 8]
        np.testing.assert_allclose(_descriptor_from_cells(F), d, atol=2e-6)


def test_blocks_missing_at_the_border_are_zero_copies():
    O = opencv_gradients(_scene((64, 48), 5))
    F = opencv_block_cells(O, 8)
    assert F.shape == (8, 6, OPENCV_CHANNELS)
    # the top-left cell is only ever the (0, 0) cell of a block: its other copies are 0
    assert np.all(F[0, 0, 9:] == 0) and np.any(F[0, 0, :9] > 0)
    # an interior cell is in four blocks
    assert all(np.any(F[3, 3, 9 * q:9 * q + 9] > 0) for q in range(4))


def test_cell_weights_refuse_another_layout():
    with pytest.raises(ValueError, match="a 64x128 HOG detector has 3780 finite weights"):
        opencv_cell_weights(np.zeros(1980))
    W = opencv_cell_weights(np.ones(1980), window=(48, 96))      # Daimler's 48x96 window
    assert W.shape == (12, 6, OPENCV_CHANNELS)
    # each weight lands once: corner cells carry 9 weights, interior cells 36
    assert W.sum() == 1980 and W[0, 0].sum() == 9 and W[5, 3].sum() == 36


def test_four_copies_remap_is_the_9_bin_remap_on_each():
    from viewadapt.detect import cell_hog_remap
    H = np.array([[0.9, 0.05, 30.0], [0.0, 0.7, 12.0], [0.0, 0.0005, 1.0]])
    g = TemplateGroup(cell_size=6, prototype=0, origin=(4, 1), shape=(17, 12),
                      members=np.array([0]), shifts=np.zeros((1, 2), np.int64))
    G9 = cell_hog_remap(H, g).toarray()
    G36 = opencv_frame_remap(H, g).toarray()
    n_src, n_tgt = G9.shape[0] // 9, G9.shape[1] // 9
    assert G36.shape == (n_src * 36, n_tgt * 36)
    G36 = G36.reshape(n_src, 4, 9, n_tgt, 4, 9)
    for q in range(4):
        for r in range(4):
            want = G9.reshape(n_src, 9, n_tgt, 9) if q == r else 0
            assert np.array_equal(G36[:, q, :, :, r, :], np.broadcast_to(
                want, (n_src, 9, n_tgt, 9)))


@pytest.fixture(scope="module")
def camera():
    return camera_from_pose(focal=200.0, principal_point=(95.5, 71.5), height=4.0,
                            tilt=np.radians(35), image_size=SIZE)


def test_adapted_scores_equal_explicitly_remapped_cells(camera):
    """The operator's score of a window is ``w . G x + b`` with ``x`` the frame's OpenCV
    cells and ``G`` the four-copies remap of the window's snapped homography."""
    from viewadapt.remap import CellGrid, feature_remap_matrix

    frame = _scene((SIZE[1], SIZE[0]), 6)
    windows = select_candidate_windows(camera)
    sub = windows.subset(np.arange(0, len(windows), max(1, len(windows) // 40)))
    rng = np.random.default_rng(7)
    W = rng.normal(size=OPENCV_WEIGHT_SHAPE)
    op = build_adapted_opencv_operator(sub, W, -0.4, tolerance=0.5, renorm=False)
    assert op.stage is None
    s = op.scores(op.frame_features(frame))
    for n in range(0, len(sub), 5):
        c = int(op.cell_size[n])
        x = opencv_frame_features(frame, [c], pad=0).maps[c]
        ny, nx = x.shape[:2]
        G9 = feature_remap_matrix(op.snapped_homographies[n], CellGrid.for_window(64, 128, HOG_CELL),
                                  CellGrid(nx, ny, c), n_bins=9, preserve="mean")
        xq = x.astype(np.float64).reshape(ny * nx, 4, 9)
        ref = sum(W[:, :, 9 * q:9 * q + 9].ravel() @ (G9 @ xq[:, q].ravel()) for q in range(4))
        assert s[n] == pytest.approx(ref - 0.4, rel=1e-4, abs=1e-4 * np.abs(W).sum())


def test_stored_operator_keeps_its_36_channels(camera, tmp_path):
    from viewadapt.io import OperatorCache

    frame = _scene((SIZE[1], SIZE[0]), 8)
    op = build_adapted_opencv_operator(select_candidate_windows(camera),
                                       *opencv_default_people_detector())
    cache = OperatorCache(tmp_path)
    cache.save({"k": 1}, op)
    back = cache.load({"k": 1})
    assert back.channels == OPENCV_CHANNELS and back.groups[0].template.shape[2] == 36
    assert back.stage is not None and back.stage.threshold == op.stage.threshold
    np.testing.assert_array_equal(back.stage.cell, op.stage.cell)
    np.testing.assert_allclose(back.scores(back.frame_features(frame)),
                               op.scores(op.frame_features(frame)), **FLOAT32)


def test_frame_detector_runs_opencvs_detector_without_source_models(camera, tmp_path):
    """``opencv`` needs no models of ours: its cache key is OpenCV's weights, and it finds
    the same detections with or without the cache."""
    kind = detector_kind("opencv")
    assert kind.model_fingerprint(None) == kind.model_fingerprint(object())
    frame = _scene((SIZE[1], SIZE[0]), 9)
    det = FrameDetector(camera, None, cache_dir=tmp_path, thresholds={"opencv": -3.0})
    first = det.detect(frame, "opencv")
    again = FrameDetector(camera, None, cache_dir=tmp_path, thresholds={"opencv": -3.0})
    assert np.array_equal(again.detect(frame, "opencv"), first) and again.cache_hit["opencv"]
    assert first.shape[1] == 5 and len(first) > 0


def test_the_stage_on_a_grid_window_is_opencvs_descriptor():
    """A window at scale 1: with one-pixel raw cells and OpenCV's binning the stage's score
    is OpenCV's own (cv2.HOGDescriptor on the frame); with 8-px cells and hard binning it is
    OpenCV's SVM on the descriptor of hard-binned cells; orientations turn with the window."""
    from viewadapt.detect import RenormStage, raw_cell_maps
    from viewadapt.hog import cells_to_blocks, hog_cells, normalize_blocks_l2hys

    img = _scene((200, 160), 11)
    v = np.asarray(cv2.HOGDescriptor_getDefaultPeopleDetector(), np.float64).ravel()
    x0, y0 = 48, 32
    H = np.array([[1.0, 0, x0], [0, 1.0, y0], [0, 0, 1.0]])
    grad = opencv_gradients(img)
    exact = RenormStage(H[None], [1], v[:-1], v[-1], binning="opencv")
    d = cv2.HOGDescriptor().compute(img, winStride=(8, 8), padding=(0, 0),
                                    locations=[(x0, y0)]).ravel()
    assert exact.scores([0], raw_cell_maps(grad, [1]))[0] == pytest.approx(
        float(d @ v[:-1] + v[-1]), abs=1e-3)
    stage = RenormStage(H[None], [8], v[:-1], v[-1], binning="cells")
    got = stage.scores([0], raw_cell_maps(grad, [8]))[0]
    cells = hog_cells(img, cell_size=8, gamma=True)[y0 // 8:y0 // 8 + 16, x0 // 8:x0 // 8 + 8]
    d = normalize_blocks_l2hys(cells_to_blocks(cells)).ravel()
    assert got == pytest.approx(float(d @ v[:-1] + v[-1]), abs=2e-3)
    # the orientations turn with the window: a sheared window reads other bins
    sheared = RenormStage((H @ np.array([[1.0, 0.6, 0], [0, 1.0, 0], [0, 0, 1.0]]))[None],
                          [8], v[:-1], v[-1], binning="cells")
    assert sheared.scores([0], raw_cell_maps(opencv_gradients(img), [8]))[0] != \
        pytest.approx(got, abs=1e-2)


def test_the_cascade_rescores_what_the_fold_keeps(camera):
    frame = _scene((SIZE[1], SIZE[0]), 12)
    windows = select_candidate_windows(camera)
    W, b = opencv_default_people_detector()
    op = build_adapted_opencv_operator(windows, W, b, verify_threshold=-3.0)
    # with a stage the fold reads its own few cell sizes, the stage one base size's ladder;
    # without, the fold reads every frame cell size
    assert set(op.cell_sizes) <= set(OPENCV_FOLD_CELL_SIZES)
    assert set(op.stage.cell_sizes) <= set(OPENCV_STAGE_CELL_SIZES)
    alone = build_adapted_opencv_operator(windows, W, b, renorm=False)
    assert alone.stage is None and len(alone.cell_sizes) > len(op.cell_sizes)
    fold = build_adapted_opencv_operator(windows, W, b, renorm=False,
                                         allowed_cell_sizes=OPENCV_FOLD_CELL_SIZES)
    s1 = fold.scores(fold.frame_features(frame))
    feats = op.frame_features(frame)
    s = op.scores(feats)
    kept = s1 >= -3.0
    assert kept.any() and (~kept).any()
    np.testing.assert_allclose(s[~kept], s1[~kept], atol=1e-5)   # the fold's scores stay
    np.testing.assert_allclose(s[kept], op.stage.scores(np.flatnonzero(kept), feats.raw))
    # the boxes are the windows' own (not snapped to a template)
    np.testing.assert_allclose(op.snapped_homographies, windows.homographies)
    assert build_adapted_opencv_operator(windows, W, b, object_model="body").stage is None


def _save_hog(path, weights, bias=None, **layout):
    hog = cv2.HOGDescriptor(*layout.pop("ctor", ()))
    v = np.r_[weights, [] if bias is None else [bias]].astype(np.float32)
    hog.setSVMDetector(v)
    hog.save(str(path))
    return path


def test_a_hog_file_saved_by_opencv_is_read_back(tmp_path):
    from viewadapt.io import read_opencv_hog_detector

    rng = np.random.default_rng(13)
    w = rng.normal(size=3780).astype(np.float32)
    for suffix in ("yml", "xml"):
        got, b = read_opencv_hog_detector(_save_hog(tmp_path / f"hog.{suffix}", w, -0.25))
        np.testing.assert_allclose(got, w, rtol=1e-6)
        assert b == pytest.approx(-0.25)
    got, b = read_opencv_hog_detector(_save_hog(tmp_path / "nobias.yml", w))
    assert b == 0.0


@pytest.mark.parametrize("make, field", [
    (lambda p: _save_hog(p, np.zeros(1981), ctor=((48, 96), (16, 16), (8, 8), (8, 8), 9)),
     "winSize"),
    (lambda p: p.write_text(re.sub(r"SVMDetector: \[[^\]]*\]", "SVMDetector: [ 1., 2. ]",
                                   _save_hog(p, np.zeros(3781)).read_text())) and p,
     "OpenCV cannot read it as a HOGDescriptor file"),
    (lambda p: p.write_text("%YAML:1.0\n---\nK: [1, 2, 3]\n") and p, "not an OpenCV HOGDescriptor"),
])
def test_a_hog_file_of_another_layout_is_one_line(tmp_path, make, field):
    from viewadapt.io import read_opencv_hog_detector

    path = make(tmp_path / "bad.yml")
    with pytest.raises(ValueError) as err:
        read_opencv_hog_detector(path)
    assert field in str(err.value) and str(path) in str(err.value)
    assert "\n" not in str(err.value)


def test_a_frame_detector_with_its_own_opencv_weights(camera, tmp_path):
    """Another 64x128 HOG/SVM (here OpenCV's, perturbed, through a saved file) is adapted in
    place of OpenCV's: its own scores and cache entry."""
    from viewadapt.detect import opencv_descriptor_weights, opencv_kind
    from viewadapt.io import read_opencv_hog_detector

    rng = np.random.default_rng(14)
    w = opencv_descriptor_weights(opencv_default_people_detector()[0])
    mine = (w + rng.normal(scale=0.05, size=w.shape)).astype(np.float32)
    path = _save_hog(tmp_path / "mine.yml", mine, -0.2)
    frame = _scene((SIZE[1], SIZE[0]), 15)

    def scores(det):
        op = det.operator("opencv")
        return np.nan_to_num(op.scores(op.frame_features(frame)), neginf=-99.0)

    cache = tmp_path / "cache"
    default = scores(FrameDetector(camera, None, cache_dir=cache))
    own = scores(FrameDetector(camera, None, cache_dir=cache,
                               kinds={"opencv": opencv_kind(*read_opencv_hog_detector(path))}))
    direct = scores(FrameDetector(camera, None, kinds={"opencv": opencv_kind(mine, -0.2)}))
    np.testing.assert_allclose(own, direct, rtol=1e-5, atol=1e-5)
    assert np.abs(own - default).max() > 1e-2
    assert len(list(cache.glob("operator-*.npz"))) == 2          # one cache entry each
    with pytest.raises(ValueError, match="kinds\\['hog'\\] must be a detector kind"):
        FrameDetector(camera, None, kinds={"hog": opencv_kind(mine, -0.2)})


def test_the_operator_reads_only_the_cell_rows_it_computes(camera):
    """Every map row outside :meth:`read_rows` can hold anything: the scores -- the fold's
    and the normalisation stage's, every window rescored -- do not change; and the rows left
    out are a real part of the maps on this camera (with every frame cell size, each of which
    only some windows read)."""
    frame = _scene((SIZE[1], SIZE[0]), 13)
    W, b = opencv_default_people_detector()
    op = build_adapted_opencv_operator(select_candidate_windows(camera), W, b,
                                       verify_threshold=-1e9, allowed_cell_sizes=FRAME_CELL_SIZES,
                                       stage_cell_sizes_allowed=FRAME_CELL_SIZES)
    whole = op.features(frame)
    want = op.scores(whole)
    assert np.isfinite(want).all()
    rows, raw_rows = op.read_rows()
    assert set(rows) == set(op.cell_sizes) and set(raw_rows) == set(op.stage.cell_sizes)
    left_out = scramble_unread_rows(whole, rows, raw_rows, seed=3)
    assert left_out > 0
    np.testing.assert_array_equal(op.scores(whole), want)
    np.testing.assert_array_equal(op.scores(op.frame_features(frame)), want)
