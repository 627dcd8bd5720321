"""The per-window normalisation stage for the project's HOG/SVM (block_normalize_cells)."""

import numpy as np
import pytest

from tests.images import bars_scene
from tests.viewadapt.detect.unread_rows import scramble_unread_rows
from viewadapt.detect import (
    HOG_WEIGHT_SHAPE, RenormStage, block_normalize_cells, build_adapted_linear_operator,
    hog_frame_features, select_candidate_windows,
)
from viewadapt.detect.channels import hog_cell_eps
from viewadapt.geometry import camera_from_pose

SIZE = (192, 144)


def _weights(seed):
    rng = np.random.default_rng(seed)
    return rng.normal(0, 0.05, HOG_WEIGHT_SHAPE), -0.3


def test_on_a_grid_window_the_stage_normalises_the_frame_cells_in_the_window():
    """A window at scale 1 on the 8-px grid reads the frame's own raw cells: its score is
    the SVM on those cells block-normalised as a canonical window's (reflected at the
    window's border, not the frame's neighbours), unlike the fold's frame-grid blocks."""
    img = bars_scene((200, 160), 3, bars=10)
    W, b = _weights(0)
    x0, y0 = 48, 32
    H = np.array([[1.0, 0, x0], [0, 1.0, y0], [0, 0, 1.0]])
    stage = RenormStage(H[None], [8], W, b, binning="cells", model="hog")
    f = hog_frame_features(img, [8], pad=0, raw_cell_sizes=[8])
    X = f.raw[0][8][y0 // 8:y0 // 8 + 16, x0 // 8:x0 // 8 + 8]
    want = float((block_normalize_cells(X, eps=hog_cell_eps(8)) * W).sum() + b)
    assert stage.scores([0], f.raw)[0] == pytest.approx(want, abs=1e-4)
    frame_grid = float((f.maps[8][y0 // 8:y0 // 8 + 16, x0 // 8:x0 // 8 + 8] * W).sum() + b)
    assert abs(frame_grid - want) > 1e-3
    with pytest.raises(ValueError, match="binning 'cells'"):
        RenormStage(H[None], [8], W, b, model="hog")
    with pytest.raises(ValueError, match="1664 finite values"):
        RenormStage(H[None], [8], np.zeros(3780), b, binning="cells", model="hog")


def test_the_hog_cascade_rescores_what_the_fold_keeps_and_is_stored(tmp_path):
    from viewadapt.io import OperatorCache

    cam = camera_from_pose(focal=200.0, principal_point=(95.5, 71.5), height=4.0,
                           tilt=np.radians(35), image_size=SIZE)
    frame = bars_scene((SIZE[1], SIZE[0]), 12)
    windows = select_candidate_windows(cam)
    W, b = _weights(1)
    fold = build_adapted_linear_operator(windows, W, b)
    s1 = fold.scores(fold.frame_features(frame))
    thr = float(np.median(s1))
    op = build_adapted_linear_operator(windows, W, b, renorm=True, verify_threshold=thr)
    assert fold.stage is None and op.stage.model == "hog"
    feats = op.frame_features(frame)
    s = op.scores(feats)
    kept = s1 >= thr
    assert kept.any() and (~kept).any()
    np.testing.assert_allclose(s[~kept], s1[~kept], atol=1e-5)   # the fold's scores stay
    np.testing.assert_allclose(op.fold_scores(feats), s1, atol=1e-5)  # the fold alone
    assert np.abs(s[kept] - s1[kept]).max() > 1e-3
    np.testing.assert_allclose(s[kept], op.stage.scores(np.flatnonzero(kept), feats.raw))
    np.testing.assert_allclose(op.snapped_homographies, windows.homographies)
    cache = OperatorCache(tmp_path)
    cache.save({"k": 1}, op)
    back = cache.load({"k": 1})
    assert back.stage.model == "hog" and back.stage.binning == "cells"
    np.testing.assert_allclose(back.scores(back.frame_features(frame)), s)


def test_cell_maps_move_each_source_cell_before_the_window_homography():
    """``cell_maps`` of the window's own plane are the identity (the same scores as the
    plane's stage on an affine window); a map moving every cell one cell to the right
    scores as the window shifted by 8 canonical px; a hidden cell reads nothing."""
    from viewadapt.detect import cell_maps_of_mapping
    from viewadapt.mapping import homography_mapping

    img = bars_scene((200, 160), 5, bars=10)
    W, b = _weights(3)
    f = hog_frame_features(img, [4], pad=0, raw_cell_sizes=[4])
    H = np.array([[0.9, 0.05, 40.2], [0.02, 0.8, 20.7], [0, 0, 1.0]])
    ident = cell_maps_of_mapping(homography_mapping(H), H)
    np.testing.assert_allclose(ident[..., 2:], np.broadcast_to([1.0, 0, 0, 1.0], (16, 8, 4)),
                               atol=1e-9)
    plane = RenormStage(H[None], [4], W, b, binning="cells", model="hog")
    mapped = RenormStage(H[None], [4], W, b, binning="cells", model="hog",
                         cell_maps=ident[None], cell_map_of=[0])
    np.testing.assert_allclose(mapped.scores([0], f.raw), plane.scores([0], f.raw), atol=1e-5)
    T = np.array([[1.0, 0, 8.0], [0, 1.0, 0], [0, 0, 1.0]])
    shift = cell_maps_of_mapping(homography_mapping(H @ T), H)
    moved = RenormStage(H[None], [4], W, b, binning="cells", model="hog",
                        cell_maps=shift[None], cell_map_of=[0])
    want = RenormStage((H @ T)[None], [4], W, b, binning="cells", model="hog")
    np.testing.assert_allclose(moved.scores([0], f.raw), want.scores([0], f.raw), atol=1e-5)
    hidden = ident.copy()
    hidden[3:9, 2:6] = np.nan
    cut = RenormStage(H[None], [4], W, b, binning="cells", model="hog",
                      cell_maps=hidden[None], cell_map_of=[0]).scores([0], f.raw)[0]
    assert np.isfinite(cut) and abs(cut - plane.scores([0], f.raw)[0]) > 1e-3
    # where the model hides a point, the window's plane stands in
    plane_m = homography_mapping(H)
    holes = cell_maps_of_mapping(lambda p: np.where(p[:, :1] > 30, np.nan, plane_m(p)), H)
    np.testing.assert_allclose(holes, ident, atol=1e-9)
    with pytest.raises(ValueError, match="cell maps need model 'hog'"):
        RenormStage(H[None], [4], np.zeros(3780), b, cell_maps=ident[None], cell_map_of=[0])
    with pytest.raises(ValueError, match="one cell map index"):
        RenormStage(H[None], [4], W, b, binning="cells", model="hog",
                    cell_maps=ident[None], cell_map_of=[1])


def test_the_body_models_hog_operator_has_the_stage_and_stores_it(tmp_path):
    """With the mean body the stage moves each window's cells as its template group's body
    mapping does; the stored operator scores the same, and it reads only the rows it says."""
    from viewadapt.io import OperatorCache

    cam = camera_from_pose(focal=200.0, principal_point=(95.5, 71.5), height=4.0,
                           tilt=np.radians(35), image_size=SIZE)
    frame = bars_scene((SIZE[1], SIZE[0]), 13)
    windows = select_candidate_windows(cam)
    W, b = _weights(4)
    op = build_adapted_linear_operator(windows, W, b, renorm=True, object_model="body",
                                       verify_threshold=-1e9)
    plane = build_adapted_linear_operator(windows, W, b, renorm=True, verify_threshold=-1e9)
    st = op.stage
    assert st.cell_maps.shape == (len(op.groups), 16, 8, 6) and plane.stage.cell_maps is None
    moved = np.nanmax(np.abs(st.cell_maps[..., :2] - plane_centres()), axis=(1, 2, 3))
    assert np.nanmax(moved) > 0.5          # the body is not the plane
    feats = op.frame_features(frame)
    s = op.scores(feats)
    assert np.abs(s - plane.scores(plane.frame_features(frame))).max() > 1e-3
    cache = OperatorCache(tmp_path)
    cache.save({"k": 2}, op)
    back = cache.load({"k": 2})
    np.testing.assert_array_equal(back.stage.cell_map_of, st.cell_map_of)
    np.testing.assert_allclose(back.scores(back.frame_features(frame)), s)
    whole = op.features(frame)
    rows, raw_rows = op.read_rows()
    scramble_unread_rows(whole, rows, raw_rows, seed=6)
    np.testing.assert_allclose(op.scores(whole), s, atol=1e-5)


def plane_centres():
    ys, xs = np.mgrid[0:16, 0:8].astype(np.float64)
    return np.stack([8.0 * xs + 3.5, 8.0 * ys + 3.5], -1)


def test_the_hog_operator_reads_only_the_cell_rows_it_computes():
    """As OpenCV's (test_opencv_detector): map rows outside ``read_rows`` can hold anything
    -- the fold's and the stage's scores, every window rescored, do not change -- and the
    features the operator computes per frame leave rows out on this camera."""
    cam = camera_from_pose(focal=200.0, principal_point=(95.5, 71.5), height=4.0,
                           tilt=np.radians(35), image_size=SIZE)
    frame = bars_scene((SIZE[1], SIZE[0]), 14)
    W, b = _weights(2)
    op = build_adapted_linear_operator(select_candidate_windows(cam), W, b, renorm=True,
                                       verify_threshold=-1e9)
    whole = op.features(frame)
    want = op.scores(whole)
    rows, raw_rows = op.read_rows()
    assert set(rows) == set(op.cell_sizes) and set(raw_rows) == set(op.stage.cell_sizes)
    left_out = scramble_unread_rows(whole, rows, raw_rows, seed=5)
    assert left_out > 0
    np.testing.assert_array_equal(op.scores(whole), want)
    np.testing.assert_array_equal(op.scores(op.frame_features(frame)), want)


def test_a_window_a_hair_below_a_cell_size_reads_that_size():
    """The stage's raw cells may be up to STAGE_CELL_TOLERANCE larger than a window's
    source cells' image, no more (8-px source cells: scale s reads at most 8 s px)."""
    from viewadapt.detect import STAGE_CELL_TOLERANCE, stage_cell_sizes

    allowed = (2, 3, 4, 6, 8)
    s = np.array([3.0, 3.0 / (1 + STAGE_CELL_TOLERANCE / 2), 3.0 / (1 + 2 * STAGE_CELL_TOLERANCE),
                  7.99, 0.1]) / 8
    np.testing.assert_array_equal(stage_cell_sizes(s, allowed), [3, 3, 2, 8, 2])


def test_a_frame_detector_with_the_hog_stage(tmp_path):
    """``hog_kind()`` carries the stage (threshold 0 unless given), as the registry's HOG
    does; each setting is its own cache entry, and the fold alone keeps the model's key."""
    from viewadapt.detect import HOG_DETECTOR, FrameDetector, hog_kind
    from viewadapt.io import SourceDetectors, shipped_model_path

    cam = camera_from_pose(focal=200.0, principal_point=(95.5, 71.5), height=4.0,
                           tilt=np.radians(35), image_size=SIZE)
    models = SourceDetectors.load(shipped_model_path())
    kind = hog_kind(verify_threshold=-1.0)
    staged, fold = hog_kind(), hog_kind(renorm=False)
    assert staged.model_fingerprint(models) == HOG_DETECTOR.model_fingerprint(models)
    assert len({k.model_fingerprint(models) for k in (kind, staged, fold)}) == 3
    assert fold.model_fingerprint(models) == models.fingerprint()
    det = FrameDetector(cam, models, kinds={"hog": kind}, cache_dir=tmp_path)
    assert all(L.operator.stage.threshold == -1.0 for L in det.operator("hog").layers)
    assert det.detect(bars_scene((SIZE[1], SIZE[0]), 4)).shape[1] == 5
    default = FrameDetector(cam, models, cache_dir=tmp_path)
    assert all(L.operator.stage.threshold == 0.0 for L in default.operator("hog").layers)
    plain = FrameDetector(cam, models, kinds={"hog": fold}, cache_dir=tmp_path)
    assert all(L.operator.stage is None for L in plain.operator("hog").layers)


def test_only_kinds_with_a_stage_have_a_fold():
    from viewadapt.detect import ACF_DETECTOR, DAIMLER_DETECTOR, HOG_DETECTOR, OPENCV_DETECTOR

    assert HOG_DETECTOR.stages("body") and not OPENCV_DETECTOR.stages("body")

    for kind in (HOG_DETECTOR, OPENCV_DETECTOR, DAIMLER_DETECTOR):
        fold = kind.fold()
        assert kind.has_stage and not fold.has_stage and fold.name == kind.name
        with pytest.raises(ValueError, match="no normalisation stage"):
            fold.fold()
    assert not ACF_DETECTOR.has_stage
    with pytest.raises(ValueError, match="the acf detector has no normalisation stage"):
        ACF_DETECTOR.fold()
