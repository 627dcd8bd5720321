"""Full-frame viewpoint-adapted detection: windows, per-window operators, cache, input errors."""

import cv2
import numpy as np
import pytest

from tests.tolerances import EXACT, FLOAT32
from benchmark.frames.scoring_forms import linear_scores, trees_scores
from viewadapt.detect import (
    ACF_SHRINK, HOG_CELL, HOG_CHANNELS, TemplateGroup, acf_frame_remap, build_adapted_linear_operator,
    acf_frame_features, build_adapted_trees_operator,
    hog_frame_features, build_multiresolution_operator, patch_grid, upsampled_windows, upsampled_band,
)
from viewadapt.geometry import (
    WINDOW_HEAD, Camera, camera_from_pose, look_at_rotation, map_points,
    window_to_image_homography,
)
from viewadapt.remap import CellGrid, feature_remap_matrix
from viewadapt.detect import (
    GROUND_STRIDE_M, check_ground_visible, select_candidate_windows, window_homographies,
)

F, CX, CY, HEIGHT, TILT = 200.0, 95.5, 71.5, 4.0, np.radians(35)
SIZE = (192, 144)


@pytest.fixture(scope="module")
def camera():
    # looking along +X from (0, 0, 4 m), 35 degrees down
    return camera_from_pose(focal=F, principal_point=(CX, CY), height=HEIGHT, tilt=TILT,
                            image_size=SIZE)


@pytest.fixture(scope="module")
def windows(camera):
    return select_candidate_windows(camera)


# ------------------------------------------------------------------------------ windows


def test_stride_is_the_papers():
    assert GROUND_STRIDE_M == pytest.approx(8 * 1.75 / 96)
    assert GROUND_STRIDE_M == pytest.approx(0.1458, abs=1e-4)


def test_windows_on_the_optical_axis_match_hand_geometry(windows):
    # A ground point at distance d straight ahead is seen at angle atan(h / d) below the
    # horizon, i.e. atan(h / d) - tilt below the optical axis: y = cy + f tan(that).
    # The person's head (1.75 m) likewise; x stays on the centre column.
    on_axis = windows.grid_index[:, 1] == 0
    assert on_axis.sum() > 10
    d = windows.ground_xy[on_axis, 0]
    assert np.allclose(windows.ground_xy[on_axis, 1], 0.0, atol=1e-12)
    assert np.allclose(d / GROUND_STRIDE_M, np.round(d / GROUND_STRIDE_M), atol=1e-9)
    feet = windows.feet[on_axis]
    assert np.allclose(feet[:, 0], CX, atol=1e-9)
    assert np.allclose(feet[:, 1], CY + F * np.tan(np.arctan(HEIGHT / d) - TILT), atol=1e-9)
    head_y = CY + F * np.tan(np.arctan((HEIGHT - 1.75) / d) - TILT)
    assert np.allclose(windows.scale[on_axis] * 96, feet[:, 1] - head_y, atol=1e-9)


def test_windows_inside_and_apart(windows):
    corners = windows.window_corners()
    w, h = SIZE
    assert corners[..., 0].min() >= -0.5 and corners[..., 0].max() <= w - 0.5
    assert corners[..., 1].min() >= -0.5 and corners[..., 1].max() <= h - 0.5
    feet = windows.feet
    d2 = ((feet[:, None] - feet[None]) ** 2).sum(-1)
    np.fill_diagonal(d2, np.inf)
    assert d2.min() >= 1.0                      # the paper's 1-px rule
    assert (windows.scale * 96 >= 16).all()
    # every ground position is a grid point of the camera-aligned grid
    ij = windows.ground_xy / GROUND_STRIDE_M
    assert np.allclose(ij, np.round(ij), atol=1e-9)


def test_grid_phase_moves_the_grid_and_nothing_else(camera, windows):
    # this camera's grid is axis-aligned (it looks along +X from above the origin), so a
    # phase moves every ground position by that fraction of a stride along X and Y
    assert np.array_equal(select_candidate_windows(camera, grid_phase=(0, 0)).ground_xy,
                          windows.ground_xy)
    shifted = select_candidate_windows(camera, grid_phase=(0.25, 0.5))
    ij = shifted.ground_xy / GROUND_STRIDE_M - [0.25, 0.5]
    assert np.allclose(ij, np.round(ij), atol=1e-9)
    assert np.allclose(ij, shifted.grid_index, atol=1e-9)
    # the same rules hold on the moved grid: inside, 1 px apart, own homographies
    feet = shifted.feet
    d2 = ((feet[:, None] - feet[None]) ** 2).sum(-1)
    np.fill_diagonal(d2, np.inf)
    assert d2.min() >= 1.0
    k = len(shifted) // 2
    H = window_to_image_homography(camera, shifted.ground_xy[k])
    assert np.allclose(H / H[2, 2], shifted.homographies[k], **EXACT)
    assert abs(len(shifted) - len(windows)) < 0.1 * len(windows)
    for bad in [(1.0, 0.0), (-0.1, 0.0), (0.5,), (np.nan, 0.0)]:
        with pytest.raises(ValueError, match="grid_phase"):
            select_candidate_windows(camera, grid_phase=bad)


def test_a_lateral_stride_of_half_is_the_grid_and_its_half_phase(camera):
    """stride=(s, s / 2) places windows where the grid at lateral phases 0 and 1/2 together
    does (without the 1-px thinning, which then acts across both); one number is both
    strides; a bad stride is a one-line error."""
    s = GROUND_STRIDE_M
    kw = dict(min_separation=0.0)
    dense = select_candidate_windows(camera, stride=(s, s / 2), **kw)
    both = np.concatenate([select_candidate_windows(camera, grid_phase=(0, b), **kw).ground_xy
                           for b in (0.0, 0.5)])
    key = lambda xy: set(map(tuple, np.round(xy / s * 4).astype(int)))  # noqa: E731
    assert key(dense.ground_xy) == key(both) and len(dense) == len(both)
    ij = dense.ground_xy / [s, s / 2]
    assert np.allclose(ij, dense.grid_index, atol=1e-9)
    assert np.array_equal(select_candidate_windows(camera, stride=(s, s)).ground_xy,
                          select_candidate_windows(camera).ground_xy)
    phased = select_candidate_windows(camera, stride=(s, s / 2), grid_phase=(0.5, 0.5))
    assert np.allclose(phased.ground_xy / [s, s / 2] - 0.5, phased.grid_index, atol=1e-9)
    for bad in [0.0, -1.0, (s, 0.0), (s, s, s), np.nan, "0.1", [[s]]]:
        with pytest.raises(ValueError, match="stride must be positive metres") as err:
            select_candidate_windows(camera, stride=bad)
        assert "\n" not in str(err.value)


def test_vectorised_homographies_match_geometry(camera, windows):
    for k in (0, len(windows) // 2, len(windows) - 1):
        H = window_to_image_homography(camera, windows.ground_xy[k])
        assert np.allclose(H / H[2, 2], windows.homographies[k], **EXACT)
    H2 = window_homographies(camera, windows.ground_xy[:3], [1.6, 1.75, 1.9])
    assert np.allclose(H2[2], window_to_image_homography(camera, windows.ground_xy[2], 1.9)
                       / window_to_image_homography(camera, windows.ground_xy[2], 1.9)[2, 2],
                       **EXACT)


def test_min_person_height_drops_only_the_shorter_persons(camera, windows):
    from viewadapt.detect import FrameDetector

    def tall(W):
        return np.linalg.norm(W.feet - map_points(W.homographies, WINDOW_HEAD), axis=1)

    short = np.percentile(tall(windows), 30)
    kept = select_candidate_windows(camera, min_person_height_px=short)
    assert 0 < len(kept) < len(windows) and tall(kept).min() >= short
    # the windows kept are those of the default set that are tall enough, the same ones
    # (the 1-px thinning runs near to far, so dropping far rows changes no nearer window)
    mine = tall(windows) >= short
    assert np.array_equal(kept.ground_xy, windows.ground_xy[mine])
    assert np.array_equal(FrameDetector(camera, None, min_person_height=short).windows.ground_xy,
                          kept.ground_xy)
    for bad in (-1.0, float("nan"), "24"):
        with pytest.raises(ValueError, match="min_person_height"):
            FrameDetector(camera, None, min_person_height=bad)


def test_several_heights(camera):
    W = select_candidate_windows(camera, person_heights=(1.6, 1.9))
    assert set(np.unique(W.person_height)) == {1.6, 1.9}


# ----------------------------------------------------------------------------- features


def _explicit_hog_score(frame, H, c, w, b):
    """w^T G(H) x + b with G built against the whole frame's cell grid at size c."""
    x = hog_frame_features(frame, [c], pad=0).maps[c]
    ny, nx = x.shape[:2]
    G = feature_remap_matrix(H, CellGrid.for_window(64, 128, HOG_CELL), CellGrid(nx, ny, c),
                             n_bins=9, n_plain=4, preserve="mean")
    return float(w.ravel() @ (G @ x.astype(np.float64).ravel()) + b)


@pytest.mark.parametrize("tolerance", [0.0, 0.5])
def test_adapted_scores_equal_explicitly_remapped_features(windows, frame, tolerance):
    rng = np.random.default_rng(1)
    sub = windows.subset(np.arange(0, len(windows), max(1, len(windows) // 60)))
    w = rng.normal(size=(16, 8, HOG_CHANNELS))
    op = build_adapted_linear_operator(sub, w, 0.3, tolerance=tolerance)
    feats = op.frame_features(frame)
    s = {m: linear_scores(op, feats, m) for m in ("sparse", "template", "gather")}
    s["runs"] = op.scores(feats)                                  # the compiled loop
    for n in range(0, len(sub), 7):
        ref = _explicit_hog_score(frame, op.snapped_homographies[n], int(op.cell_size[n]), w, 0.3)
        for m in s:
            assert s[m][n] == pytest.approx(ref, rel=1e-4, abs=1e-4 * np.abs(w).sum())
    if tolerance == 0:
        assert np.allclose(op.snapped_homographies, sub.homographies, **EXACT)
    else:
        assert op.n_templates < len(sub)
    # the one-matrix forms are the same operator
    W = op.to_sparse()
    assert W.shape[0] == len(sub)
    assert np.allclose(W @ feats.vector(op.cell_sizes) + op.bias, s["sparse"], **FLOAT32)
    Wu, rows = op.to_sparse(unique=True)
    pw = op.position_weights()
    assert pw.size == Wu.shape[0] == len(np.unique(rows)) <= len(sub)
    assert np.array_equal(op.weights_per_window(), pw[rows])


def test_linear_operator_pickles_one_copy_of_its_templates(windows, frame):
    import pickle

    rng = np.random.default_rng(2)
    w = rng.normal(size=(16, 8, HOG_CHANNELS))
    op = build_adapted_linear_operator(windows, w, 0.1, tolerance=0.0)
    feats = op.frame_features(frame)
    before = {m: linear_scores(op, feats, m) for m in ("sparse", "template")}
    before["runs"] = op.scores(feats)
    blob = pickle.dumps(op)
    nbytes = op._runs.templates.nbytes
    # the group templates are views into the run tables, pickled once
    assert nbytes < len(blob) < 1.5 * nbytes + 4e5
    back = pickle.loads(blob)
    assert all(np.shares_memory(g.template, back._runs.templates) for g in back.groups)
    for m, s in before.items():
        again = back.scores(feats) if m == "runs" else linear_scores(back, feats, m)
        assert np.array_equal(again, s)


def test_adapted_trees_equal_explicit_remap(windows, frame):
    from viewadapt.boosting import AdaBoostTrees

    rng = np.random.default_rng(2)
    X = rng.random((300, 5120))
    y = (X[:, :40].sum(1) > 20).astype(int)
    model = AdaBoostTrees(n_estimators=24, stages=None, max_bins=16, max_features=0.05,
                          random_state=0).fit(X, y)
    sub = windows.subset(np.arange(0, len(windows), max(1, len(windows) // 25)))
    op = build_adapted_trees_operator(sub, model, tolerance=0.5)
    feats = op.frame_features(frame)
    cascade = op.scores(feats)
    full = trees_scores(op, feats, "full")
    assert np.allclose(cascade, full, rtol=1e-6, atol=1e-6)
    # the compiled loop and the numpy blocks walk the same trees to the same cascade stops
    assert np.allclose(cascade, trees_scores(op, feats, "blocks"), rtol=1e-6, atol=1e-6)
    assert (cascade <= model.cascade_threshold).any()        # some windows stopped early
    # against G built for each snapped window over the whole frame grid
    for n in range(0, len(sub), 5):
        c = int(op.cell_size[n])
        x = feats.maps[c][op.pad:-op.pad, op.pad:-op.pad]
        g = TemplateGroup(c, n, (0, 0), x.shape[:2], np.array([n]), np.zeros((1, 2), int))
        G = acf_frame_remap(op.snapped_homographies[n], g, "covariant")
        src = G @ x.astype(np.float64).ravel()
        src[3 * 512:] *= op.gradient_factor[n]       # power-law scaling of the gradients
        assert cascade[n] == pytest.approx(model.decision_function(src[None])[0], abs=1e-5)
    assert ACF_SHRINK == 4
    # the scaling is s ** lambda of each window's group prototype; lambda = 0 turns it off
    assert np.all((op.gradient_factor > 0) & (op.gradient_factor <= 1.2))
    assert not np.allclose(op.gradient_factor, 1)
    plain = build_adapted_trees_operator(sub, model, tolerance=0.5, gradient_lambda=0.0)
    assert np.all(plain.gradient_factor == 1)


# ---------------------------------------------------------------------------- the cache


def test_operator_cache_invalidates_on_calibration_change(tmp_path, frame):
    from viewadapt.detect import FrameDetector

    class Models:  # the minimal model interface FrameDetector needs
        hog_weights = np.random.default_rng(0).normal(size=(16, 8, HOG_CHANNELS))
        hog_bias = 0.0

        def fingerprint(self):
            return "test-model"

    cam = camera_from_pose(focal=F, principal_point=(CX, CY), height=HEIGHT, tilt=TILT,
                           image_size=SIZE)
    d1 = FrameDetector(cam, Models(), cache_dir=tmp_path)
    s1 = d1.operator("hog").scores(d1.operator("hog").frame_features(frame))
    assert d1.cache_hit["hog"] is False
    d2 = FrameDetector(cam, Models(), cache_dir=tmp_path)
    s2 = d2.operator("hog").scores(d2.operator("hog").frame_features(frame))
    assert d2.cache_hit["hog"] is True
    assert np.array_equal(s1, s2)
    moved = camera_from_pose(focal=F, principal_point=(CX, CY), height=HEIGHT,
                             tilt=TILT + 0.01, image_size=SIZE)
    d3 = FrameDetector(moved, Models(), cache_dir=tmp_path)
    d3.operator("hog")
    assert d3.cache_hit["hog"] is False
    assert len(list(tmp_path.glob("operator-*.npz"))) == 2
    # another grid phase is another operator; the default phase is the default grid's
    d4 = FrameDetector(cam, Models(), cache_dir=tmp_path, grid_phase=(0.5, 0.0))
    d4.operator("hog")
    assert d4.cache_hit["hog"] is False and len(d4.windows) != len(d1.windows)
    d5 = FrameDetector(cam, Models(), cache_dir=tmp_path, grid_phase=(0.0, 0.0))
    d5.operator("hog")
    assert d5.cache_hit["hog"] is True
    # so is another minimum person height (fewer windows, its own operator)
    d6 = FrameDetector(cam, Models(), cache_dir=tmp_path, min_person_height=48)
    d6.operator("hog")
    assert d6.cache_hit["hog"] is False and len(d6.windows) < len(d1.windows)


def test_operator_cache_keeps_to_its_size_limit(tmp_path, windows):
    import os

    from viewadapt.io import OperatorCache

    w = np.random.default_rng(0).normal(size=(16, 8, HOG_CHANNELS))
    op = build_adapted_linear_operator(windows.subset(np.arange(40)), w, 0.0)
    size = OperatorCache(tmp_path / "probe", limit_gb=None).save({}, op).stat().st_size
    cache = OperatorCache(tmp_path, limit_gb=2.5 * size / 2**30)   # two fit
    keys = [{"camera": i} for i in range(4)]
    for i in (0, 1):
        os.utime(cache.save(keys[i], op), (1000 + i, 1000 + i))
    assert cache.load(keys[0]) is not None                  # used now: evicted last
    cache.save(keys[2], op)
    assert cache.load(keys[1]) is None                      # the least recently used went
    assert cache.load(keys[0]) is not None and cache.load(keys[2]) is not None
    # a legacy pickle entry is never read and goes first, however recent
    legacy = tmp_path / "operator-0123456789abcdef01234567.pkl"
    legacy.write_bytes(b"\x80\x04" + bytes(size))
    os.utime(legacy, (5000, 5000))
    assert cache.evict() == [legacy] and not legacy.exists()
    # a limit below one operator keeps just the newest
    small = OperatorCache(tmp_path, limit_gb=size / 4 / 2**30)
    newest = small.save(keys[3], op)
    assert list(tmp_path.glob("operator-*.npz")) == [newest]
    # no limit: nothing is deleted
    for limit in (None, 0):
        free = OperatorCache(tmp_path, limit_gb=limit)
        for k in keys:
            free.save(k, op)
        assert free.evict() == [] and len(list(tmp_path.glob("operator-*.npz"))) == 4
    with pytest.raises(ValueError, match="cache limit"):
        OperatorCache(tmp_path, limit_gb=-1)


# ---------------------------------------------------------------------------- bad input


def test_ground_behind_camera():
    R = look_at_rotation([1.0, 0.0, -0.5])
    C = np.array([0.0, 0.0, -2.0])                       # below the ground
    cam = Camera(np.array([[F, 0, CX], [0, F, CY], [0, 0, 1.0]]), R, -R @ C, SIZE)
    with pytest.raises(ValueError, match="behind the camera"):
        select_candidate_windows(cam)


def test_horizon_below_the_whole_frame():
    R = look_at_rotation([1.0, 0.0, 1.0])                # looking 45 degrees up
    C = np.array([0.0, 0.0, 3.0])
    cam = Camera(np.array([[F, 0, CX], [0, F, CY], [0, 0, 1.0]]), R, -R @ C, SIZE)
    with pytest.raises(ValueError, match="horizon"):
        check_ground_visible(cam, SIZE)
    with pytest.raises(ValueError, match="horizon"):
        select_candidate_windows(cam)


def test_no_window_fits():
    # level camera 1 m high: the horizon crosses the middle, persons are cut by the border
    cam = camera_from_pose(focal=60.0, principal_point=(CX, CY), height=1.0, tilt=0.0,
                           image_size=SIZE)
    with pytest.raises(ValueError, match="no candidate window"):
        select_candidate_windows(cam, min_person_height_px=200)


def test_frame_of_the_wrong_size(windows, frame):
    op = build_adapted_linear_operator(windows.subset(np.arange(5)), np.ones((16, 8, HOG_CHANNELS)))
    with pytest.raises(ValueError, match="calibration"):
        op.detect(frame[:-8])
    with pytest.raises(ValueError, match="weights"):
        build_adapted_linear_operator(windows, np.ones(10))
    with pytest.raises(ValueError, match="form must be"):
        linear_scores(op, op.frame_features(frame), "dense")
    # maps of the right sizes but another feature (ACF, 10 channels): refused, never read
    # out of bounds by the compiled loop
    acf = acf_frame_features(frame, op.cell_sizes, pad=op.pad)
    with pytest.raises(ValueError, match="13 channels per cell"):
        op.scores(acf)


def test_acf_remap_is_s_kron_a(windows):
    """The ACF G of one window equals S (L, U, V, magnitude) and S (x) A (orientations)
    built by feature_remap_matrix, in the (y, x, channel) -> (channel, y, x) layouts."""
    H = windows.homographies[len(windows) // 2]
    c = 2
    cx0, cy0, nx, ny = patch_grid(H, c)          # the window's footprint only
    g = TemplateGroup(c, 0, (cx0, cy0), (ny, nx), np.array([0]), np.zeros((1, 2), int))
    G = acf_frame_remap(H, g, "covariant").toarray()
    out = CellGrid.for_window(64, 128, ACF_SHRINK)
    inn = CellGrid(nx, ny, c, origin=(cx0 * c - 0.5, cy0 * c - 0.5))
    assert 0 < inn.n_cells < 2000
    S = feature_remap_matrix(H, out, inn, n_bins=1, preserve="mean").toarray()
    GO = feature_remap_matrix(H, out, inn, n_bins=6, preserve="mean", bin_offset=-0.5).toarray()
    n_out, n_in = out.n_cells, inn.n_cells
    G4 = G.reshape(10, n_out, n_in, 10)
    for ch in range(4):
        assert np.allclose(G4[ch, :, :, ch], S, **EXACT)
    ref = GO.reshape(n_out, 6, n_in, 6).transpose(1, 0, 2, 3)       # (out bin, k, l, in bin)
    assert np.allclose(G4[4:, :, :, 4:], ref, **EXACT)


# ------------------------------------------------------------ small persons, upsampled frame


def test_upsampled_windows_map_through_the_resize_convention(windows):

    W2 = upsampled_windows(windows, 2)
    assert W2.image_size == (2 * SIZE[0], 2 * SIZE[1])
    assert np.allclose(W2.feet, 2 * windows.feet + 0.5, **EXACT)
    assert np.allclose(W2.scale, 2 * windows.scale, **EXACT)
    # cv2.resize's pixel centres: a bright dot at (x, y) lands around (2x + 0.5, 2y + 0.5)
    img = np.zeros((SIZE[1], SIZE[0]), np.float32)
    img[40, 70] = 1.0
    big = cv2.resize(img, (2 * SIZE[0], 2 * SIZE[1]), interpolation=cv2.INTER_LINEAR)
    ys, xs = np.mgrid[:big.shape[0], :big.shape[1]]
    assert (big * xs).sum() / big.sum() == pytest.approx(2 * 70 + 0.5, abs=1e-6)
    assert (big * ys).sum() / big.sum() == pytest.approx(2 * 40 + 0.5, abs=1e-6)
    with pytest.raises(ValueError, match="factor"):
        upsampled_windows(windows, 0)


def test_multiresolution_scores_are_the_layers_explicit_scores(windows, frame):
    """Small persons' windows score w^T G(U H) x_2x on the upsampled frame's cells, the
    others w^T G(H) x on the frame's; boxes come back in frame pixels."""

    rng = np.random.default_rng(7)
    sub = windows.subset(np.arange(0, len(windows), max(1, len(windows) // 80)))
    s_mid = float(np.median(sub.scale))
    w = rng.normal(size=(16, 8, HOG_CHANNELS))

    def build(win):
        return build_adapted_linear_operator(win, w, 0.2, tolerance=0.0)

    op = build_multiresolution_operator(sub, build, upsample_below=s_mid)
    assert [layer.factor for layer in op.layers] == [1, 2]
    small = np.flatnonzero(sub.scale < s_mid)
    assert np.array_equal(op.layers[1].index, small) and 0 < len(small) < len(sub)
    # only the band of rows the small windows cover is upsampled, and it holds the same
    # pixels as those rows of the whole upsampled frame
    r0, r1 = op.layers[1].rows
    assert 0 <= r0 < r1 <= SIZE[1] and (r0, r1) != (0, SIZE[1])
    assert (2 * r0) % 48 == 0
    big = cv2.resize(frame, (2 * SIZE[0], 2 * SIZE[1]), interpolation=cv2.INTER_LINEAR)
    band = big[2 * r0:2 * r1]
    assert np.array_equal(upsampled_band(frame, 2, (r0, r1)), band)
    # tolerance 0: every window is scored at its own homography, in frame pixels
    assert np.allclose(op.snapped_homographies, sub.homographies, atol=1e-9)
    assert np.allclose(op.boxes(), sub.person_boxes(), atol=1e-6)
    feats = op.frame_features(frame)
    s = op.scores(feats)
    U = np.array([[2.0, 0, 0.5], [0, 2.0, 0.5 - 2 * r0], [0, 0, 1]])   # frame -> band
    ref_native = build(sub)
    for n in range(0, len(sub), 5):
        if sub.scale[n] < s_mid:
            k = int(np.flatnonzero(small == n)[0])
            c = int(op.layers[1].operator.cell_size[k])
            ref = _explicit_hog_score(band, U @ sub.homographies[n], c, w, 0.2)
        else:
            ref = _explicit_hog_score(frame, sub.homographies[n],
                                      int(ref_native.cell_size[n]), w, 0.2)
        assert s[n] == pytest.approx(ref, rel=1e-4, abs=1e-4 * np.abs(w).sum())
    # the band gives the scores the whole upsampled frame would (its edges are far enough)
    whole = build(upsampled_windows(sub.subset(small), 2))
    assert np.allclose(whole.scores(whole.frame_features(big)), s[small], rtol=1e-5,
                       atol=1e-5 * np.abs(w).sum())
    # no window below the threshold: one native layer, the plain operator's scores
    flat = build_multiresolution_operator(sub, build, upsample_below=0.0)
    assert [layer.factor for layer in flat.layers] == [1]
    assert np.allclose(flat.scores(flat.frame_features(frame)),
                       ref_native.scores(ref_native.frame_features(frame)), **EXACT)
    d = op.detect(frame, threshold=-np.inf)
    assert d.shape[1] == 5 and len(d) > 0
    with pytest.raises(ValueError, match="upsample_below"):
        build_multiresolution_operator(sub, build, upsample_below=-1)
    with pytest.raises(ValueError, match="list of 2 FrameFeatures"):
        op.scores(feats[:1])
    with pytest.raises(ValueError, match="calibration"):
        op.detect(frame[:-8])


def test_detector_kinds_are_the_specs_every_part_reads(windows, frame):
    """Each adapted detector kind's spec: its NMS is its operator's, its window features
    have the layout its operator scores, and an unknown kind is a one-line error."""
    from viewadapt.detect import DETECTOR_KINDS, detector_kind

    assert set(DETECTOR_KINDS) == {"hog", "acf"}
    for kind in DETECTOR_KINDS.values():
        assert detector_kind(kind.name) is kind is detector_kind(kind)
        assert (kind.nms_overlap, kind.nms_threshold) == (kind.operator_class.nms_overlap,
                                                          kind.operator_class.nms_threshold)
        x = kind.features.window_features(frame[:128, :64])
        assert x.shape == kind.features.shape
    with pytest.raises(ValueError, match=r"unknown detector 'sift'; choose from "
                                         r"\('hog', 'acf', 'opencv', 'daimler'\)"):
        detector_kind("sift")


def test_each_kind_upsamples_below_its_own_scale_unless_told(tmp_path, camera):
    """The project's detectors read persons under 48 px upsampled; OpenCV's, trained on
    64x128 windows alone, every person smaller than its window (scale 1), Daimler's 48x96
    below 3/4; a given threshold holds for every kind, and is part of the cache key."""
    from viewadapt.detect import CELLS_PER_SOURCE_CELL, FrameDetector
    from viewadapt.detect.kinds import OPENCV_FOLD_CELLS_PER_SOURCE_CELL

    class Models:  # the minimal model interface FrameDetector needs for hog
        hog_weights = np.random.default_rng(1).normal(size=(16, 8, HOG_CHANNELS))
        hog_bias = 0.0

        def fingerprint(self):
            return "test-model"

    det = FrameDetector(camera, Models(), cache_dir=tmp_path)
    assert (det.upsample_below("hog"), det.upsample_below("acf"), det.upsample_below("opencv"),
            det.upsample_below("daimler")) == (0.5, 0.5, 0.75, 0.75)
    # OpenCV's INRIA detector's fold, which its stage rescores, reads coarser cells; the
    # fold alone and the other kinds the default, unless the detector is given a value
    assert [det.cells_per_source_cell(k) for k in ("hog", "acf", "opencv", "daimler")] == [
        CELLS_PER_SOURCE_CELL, CELLS_PER_SOURCE_CELL, OPENCV_FOLD_CELLS_PER_SOURCE_CELL,
        CELLS_PER_SOURCE_CELL] and OPENCV_FOLD_CELLS_PER_SOURCE_CELL < CELLS_PER_SOURCE_CELL
    assert FrameDetector(camera, None, stage=False).cells_per_source_cell("opencv") \
        == CELLS_PER_SOURCE_CELL
    given = FrameDetector(camera, None, cells_per_source_cell=0.9)
    assert given.cells_per_source_cell("opencv") == 0.9
    assert given.cache_key("opencv")["cells_per_source_cell"] == 0.9
    assert det.cache_key("opencv")["cells_per_source_cell"] == OPENCV_FOLD_CELLS_PER_SOURCE_CELL
    scale = det.windows.scale
    assert scale.max() < 0.75 and (scale < 0.5).any() and (scale >= 0.5).any()
    # every person on this small camera is under 96 px: all upsampled for OpenCV's detector
    assert [layer.factor for layer in det.operator("opencv").layers] == [2]
    assert [layer.factor for layer in det.operator("hog").layers] == [1, 2]
    told = FrameDetector(camera, None, cache_dir=tmp_path, upsample_below=0.5)
    assert told.upsample_below("opencv") == 0.5
    told.operator("opencv")
    assert told.cache_hit["opencv"] is False        # another operator, not the cached one
    assert sum(len(L.index) for L in told.operator("opencv").layers if L.factor == 2) \
        == int((scale < 0.5).sum())
    for bad in (-1, float("nan"), float("inf"), "half"):
        with pytest.raises(ValueError, match="upsample_below must be a finite number >= 0"):
            FrameDetector(camera, None, upsample_below=bad)


def test_min_person_height_takes_any_real_number(camera):
    from viewadapt.detect import FrameDetector

    a = FrameDetector(camera, None, min_person_height=np.float32(44))
    b = FrameDetector(camera, None, min_person_height=np.int64(44))
    assert np.array_equal(a.windows.ground_xy, b.windows.ground_xy)
    with pytest.raises(ValueError, match="min_person_height"):
        FrameDetector(camera, None, min_person_height=True)
