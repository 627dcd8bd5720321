import numpy as np
import pytest
import scipy.sparse as sp
from skimage import data

from tests.tolerances import AREA, EXACT
from viewadapt.geometry import elevation_homography, homography_jacobian
from viewadapt.hog import hog_cells
from viewadapt.remap import (
    CellGrid, cell_remap_matrix, clip_polygons_to_rects, feature_remap_matrix, map_angles,
    orientation_remap_matrix, polygon_areas,
)
from viewadapt.warp import translation, warp_to_source_view

G8 = CellGrid.for_window(cell_size=8)


def _clip_reference(poly, rect):
    """Plain-loop Sutherland-Hodgman against one rectangle."""
    xmin, ymin, xmax, ymax = rect
    out = [tuple(p) for p in poly]
    for inside, inter in (
        (lambda p: p[0] >= xmin, lambda a, b: (xmin, a[1] + (b[1] - a[1]) * (xmin - a[0]) / (b[0] - a[0]))),
        (lambda p: p[0] <= xmax, lambda a, b: (xmax, a[1] + (b[1] - a[1]) * (xmax - a[0]) / (b[0] - a[0]))),
        (lambda p: p[1] >= ymin, lambda a, b: (a[0] + (b[0] - a[0]) * (ymin - a[1]) / (b[1] - a[1]), ymin)),
        (lambda p: p[1] <= ymax, lambda a, b: (a[0] + (b[0] - a[0]) * (ymax - a[1]) / (b[1] - a[1]), ymax)),
    ):
        src, out = out, []
        for i, a in enumerate(src):
            b = src[(i + 1) % len(src)]
            if inside(a):
                out.append(a)
                if not inside(b):
                    out.append(inter(a, b))
            elif inside(b):
                out.append(inter(a, b))
        if not out:
            return 0.0
    x, y = np.array(out).T
    return 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def test_clipping_against_plain_loop():
    rng = np.random.default_rng(0)
    n = 300
    centre = rng.uniform(-2, 2, (n, 1, 2))
    ang = np.sort(rng.uniform(0, 2 * np.pi, (n, 4)), axis=1)
    rad = rng.uniform(0.5, 2, (n, 1))
    quads = centre + rad[..., None] * np.stack([np.cos(ang), np.sin(ang)], -1)  # convex
    rects = np.column_stack([rng.uniform(-2, 0, n), rng.uniform(-2, 0, n),
                             rng.uniform(0.1, 2, n), rng.uniform(0.1, 2, n)])
    poly, cnt = clip_polygons_to_rects(quads, np.full(n, 4), rects)
    fast = polygon_areas(poly, cnt)
    slow = np.array([_clip_reference(q, r) for q, r in zip(quads, rects)])
    assert np.allclose(fast, slow, **AREA)


def _clip_vectorised(polygons, counts, rects):
    """The vectorised numpy form the compiled clipping replaced (reference, same arithmetic)."""
    poly = np.asarray(polygons, dtype=np.float64)
    cnt = np.asarray(counts, dtype=np.int64).copy()
    for axis, col, sign in ((0, 0, 1.0), (0, 2, -1.0), (1, 1, 1.0), (1, 3, -1.0)):
        P, V = poly.shape[:2]
        idx = np.arange(V)[None, :]
        valid = idx < cnt[:, None]
        nxt_idx = np.where(cnt[:, None] > 0, (idx + 1) % np.maximum(cnt[:, None], 1), 0)
        cur = poly
        nxt = np.take_along_axis(poly, nxt_idx[:, :, None].repeat(2, axis=2), axis=1)
        bound = rects[:, col][:, None]
        dc = sign * (cur[:, :, axis] - bound)
        dn = sign * (nxt[:, :, axis] - bound)
        cin, nin = dc >= 0, dn >= 0
        denom = np.where(dc - dn == 0, 1.0, dc - dn)
        inter = cur + (dc / denom)[:, :, None] * (nxt - cur)
        out = np.empty((P, 2 * V, 2))
        out[:, 0::2] = cur
        out[:, 1::2] = inter
        keep = np.empty((P, 2 * V), dtype=bool)
        keep[:, 0::2] = valid & cin
        keep[:, 1::2] = valid & (cin != nin)
        order = np.argsort(~keep, axis=1, kind="stable")
        poly = np.take_along_axis(out, order[:, :, None].repeat(2, axis=2), axis=1)
        cnt = keep.sum(axis=1)
        poly = poly[:, :max(int(cnt.max()), 1)]
    return poly, cnt


def test_compiled_clipping_equals_the_vectorised_form():
    # the same vertices bit for bit (hence the same areas and S), on convex quads, on
    # quads lying wholly outside their rectangle, and on cells mapped by a homography
    rng = np.random.default_rng(5)
    n = 2000
    centre = rng.uniform(-3, 3, (n, 1, 2))
    ang = np.sort(rng.uniform(0, 2 * np.pi, (n, 4)), axis=1)
    quads = centre + rng.uniform(0.2, 2, (n, 1))[..., None] * np.stack([np.cos(ang),
                                                                         np.sin(ang)], -1)
    quads[::50] = np.round(quads[::50])                  # vertices on the rectangle edges
    rects = np.column_stack([rng.uniform(-2, 0, n), rng.uniform(-2, 0, n),
                             rng.uniform(0.1, 2, n), rng.uniform(0.1, 2, n)])
    rects[::50] = np.round(rects[::50])
    for q, r in ((quads, rects), (quads[:7], rects[:7] + 100.0)):
        counts = np.full(len(q), 4)
        counts[::9] = 3                                 # triangles (the 4th vertex unused)
        got, got_n = clip_polygons_to_rects(q, counts, r)
        want, want_n = _clip_vectorised(q, counts, r)
        np.testing.assert_array_equal(got_n, want_n)
        assert got.shape == want.shape
        for k in range(len(q)):
            np.testing.assert_array_equal(got[k, :got_n[k]], want[k, :want_n[k]])
        np.testing.assert_array_equal(polygon_areas(got, got_n), polygon_areas(want, want_n))


def test_identity_homography_gives_identity():
    S = cell_remap_matrix(np.eye(3), G8, G8)
    assert np.allclose(S.toarray(), np.eye(128), **EXACT)
    for rule in ("covariant", "paper", "none"):
        G = feature_remap_matrix(np.eye(3), G8, G8, rule=rule)
        assert np.allclose(G.toarray(), np.eye(128 * 9), **EXACT)


def test_half_cell_shift_by_hand():
    # output cells shifted right by 4 px read half of two neighbouring input cells
    S = cell_remap_matrix(translation(4, 0), G8, G8).toarray()
    assert np.isclose(S[0, 0], 0.5) and np.isclose(S[0, 1], 0.5)
    assert np.isclose(S[7, 7], 0.5) and S[7].sum() == pytest.approx(0.5)  # right edge: half outside


def test_finer_input_grid_sums_four_cells():
    S = cell_remap_matrix(np.eye(3), G8, CellGrid.for_window(cell_size=4)).toarray()
    assert np.allclose(S.sum(1), 4) and np.allclose(S[0, [0, 1, 16, 17]], 1)


def test_mean_preserving_rows_sum_to_one():
    H = elevation_homography(0, np.pi / 4)
    S = cell_remap_matrix(H, G8, G8, preserve="mean")
    sums = np.asarray(S.sum(1)).ravel()
    assert np.allclose(sums[sums > 0], 1)


def test_scaling_homography_sum_form_area_ratio():
    # output cell projected by a 0.5 scale covers a quarter of an input cell
    H = np.diag([0.5, 0.5, 1.0]) @ translation(0.5, 0.5)
    H = translation(-0.5, -0.5) @ H
    S = cell_remap_matrix(H, G8, G8)
    assert np.isclose(S[0, 0], 0.25)
    assert np.allclose(np.asarray(S.sum(1)).ravel(), 0.25)


def test_angle_rules_by_hand():
    # vertical compression by c (input = target coords, J = diag(1, c)):
    J = np.diag([1.0, 0.5])
    t = np.deg2rad(45.0)
    # covariant: gradient (1, 1) -> J^T (1,1) = (1, 0.5) -> 26.57 deg
    assert np.isclose(np.rad2deg(map_angles(t, J, "covariant")), np.rad2deg(np.arctan(0.5)))
    # paper (tangent rule, J^-1): (1, 2) -> 63.43 deg
    assert np.isclose(np.rad2deg(map_angles(t, J, "paper")), np.rad2deg(np.arctan(2.0)))
    assert np.isclose(map_angles(t, J, "none"), t)
    # rotation by 90 degrees moves orientation energy by half the circle of 9 bins
    R90 = np.array([[0.0, -1.0], [1.0, 0.0]])
    A = orientation_remap_matrix(R90, 9, "covariant")
    assert np.allclose(A.sum(0), 1)
    assert A.max() == pytest.approx(0.5)  # 90 deg = 4.5 bins: each bin splits in two halves


def test_angle_map_matches_measured_gradients():
    # The measurement: a blurred edge warped by vertical foreshortening. Build it:
    # target image = source image compressed vertically by c; angles measured on pixels.
    import cv2

    c = 0.6
    yy, xx = np.mgrid[0:200, 0:200].astype(float)
    for deg in (10.0, 30.0, 60.0):
        th = np.deg2rad(deg)
        src = 1 / (1 + np.exp(-((xx - 100) * np.cos(th) + (yy - 100) * np.sin(th)) / 3))
        H = np.diag([1.0, 1 / c, 1.0])  # target coords -> source coords
        tgt = cv2.warpPerspective(src.astype(np.float32), H, (200, 200),
                                  flags=cv2.INTER_CUBIC | cv2.WARP_INVERSE_MAP)
        gy, gx = np.gradient(tgt.astype(float))
        m = np.hypot(gx, gy)
        measured = np.arctan2((gy * m)[40:60].sum(), (gx * m)[40:60].sum())
        # from source to target coordinates the Jacobian is diag(1, c); input=source here
        predicted = map_angles(th, np.diag([1.0, 1 / c]) @ np.eye(2), "covariant")
        # covariant rule with J = d source / d target = diag(1, 1/c)
        assert abs(np.rad2deg(measured - predicted)) < 1.5
        paper = map_angles(th, np.diag([1.0, 1 / c]), "paper")
        assert abs(np.rad2deg(measured - paper)) > 5


@pytest.mark.parametrize("es,et", [(0, np.pi / 8), (0, np.pi / 4), (np.pi / 8, np.pi / 4)])
def test_remap_fidelity_on_natural_images(es, et):
    # features of the target window mapped by G into source cells vs features of the
    # window warped into the source view (warped from the whole image: no black borders)
    H = elevation_homography(es, et)
    rng = np.random.default_rng(1)
    imgs = [data.astronaut(), data.chelsea(), data.coffee()]
    r = {rule: [] for rule in ("covariant", "paper", "none")}
    r["unadapted"] = []
    G4 = CellGrid.for_window(cell_size=4)
    Gs = {rule: feature_remap_matrix(H, G8, G4, rule=rule) for rule in ("covariant", "paper", "none")}
    for k in range(15):
        img = imgs[k % 3]
        y, x = rng.integers(40, img.shape[0] - 170), rng.integers(40, img.shape[1] - 110)
        tgt = img[y:y + 128, x:x + 64]
        want = hog_cells(warp_to_source_view(img, translation(x, y) @ H)).ravel()
        ft = hog_cells(tgt, cell_size=4).ravel()
        for rule, G in Gs.items():
            r[rule].append(np.corrcoef(G @ ft, want)[0, 1])
        r["unadapted"].append(np.corrcoef(hog_cells(tgt).ravel(), want)[0, 1])
    med = {k: np.median(v) for k, v in r.items()}
    assert med["covariant"] >= 0.9
    assert med["covariant"] > med["unadapted"] + 0.02
    assert med["covariant"] >= med["paper"]


def test_per_cell_and_single_A_agree_for_affine_maps():
    H = np.array([[1.0, 0.2, 0.0], [0.0, 0.7, 5.0], [0.0, 0.0, 1.0]])  # affine: J constant
    a = feature_remap_matrix(H, G8, G8, per_cell=True)
    b = feature_remap_matrix(H, G8, G8, per_cell=False)
    assert abs(a - b).max() < 1e-12


def test_G_is_kron_of_S_and_A_in_single_form():
    H = elevation_homography(0, np.pi / 4)
    G = feature_remap_matrix(H, G8, G8, per_cell=False)
    S = cell_remap_matrix(H, G8, G8)
    A = orientation_remap_matrix(homography_jacobian(H, [31.5, 63.5]))
    assert sp.issparse(G)
    assert abs(G - sp.kron(S, A)).max() < 1e-12


@pytest.mark.parametrize("per_cell", [True, False])
def test_plain_channels_are_remapped_by_S_alone(per_cell):
    """n_plain channels after the bins: G = S (x) diag(A_k, I) in the (cell, channel) layout,
    i.e. the bins exactly as without them and the plain channels by S."""
    H = elevation_homography(0, np.pi / 4)
    fine = CellGrid.for_window(cell_size=4)
    G = feature_remap_matrix(H, G8, fine, per_cell=per_cell, n_plain=4).toarray()
    G9 = feature_remap_matrix(H, G8, fine, per_cell=per_cell).toarray()
    S = cell_remap_matrix(H, G8, fine).toarray()
    n_out, n_in = S.shape
    G = G.reshape(n_out, 13, n_in, 13)
    assert np.allclose(G[:, :9, :, :9], G9.reshape(n_out, 9, n_in, 9), **EXACT)
    assert np.allclose(G[:, 9:, :, 9:], np.einsum("kl,ij->kilj", S, np.eye(4)), **EXACT)
    assert not G[:, :9, :, 9:].any() and not G[:, 9:, :, :9].any()
    with pytest.raises(ValueError, match="n_plain"):
        feature_remap_matrix(H, G8, fine, n_plain=-1)


def test_adaptation_identity_exact():
    H = elevation_homography(np.pi / 8, np.pi / 4)
    G = feature_remap_matrix(H, G8, CellGrid.for_window(cell_size=4))
    rng = np.random.default_rng(2)
    w, x = rng.normal(size=G.shape[0]), rng.normal(size=G.shape[1])
    assert np.isclose((G.T @ w) @ x, w @ (G @ x), **EXACT)


def test_errors():
    with pytest.raises(ValueError, match="singular"):
        cell_remap_matrix(np.zeros((3, 3)), G8, G8)
    with pytest.raises(ValueError, match="reverses orientation"):
        cell_remap_matrix(np.diag([-1.0, 1.0, 1.0]), G8, G8)
    horizon = np.array([[1.0, 0, 0], [0, 1, 0], [0, 0.02, -1.0]])  # w = 0 at y = 50
    with pytest.raises(ValueError, match="infinity"):
        cell_remap_matrix(horizon, G8, G8)
    with pytest.raises(ValueError, match="shape"):
        cell_remap_matrix(np.eye(2), G8, G8)
    with pytest.raises(ValueError, match="rule"):
        orientation_remap_matrix(np.eye(2), rule="tangent")
    with pytest.raises(ValueError, match="multiple"):
        CellGrid.for_window(60, 128, 8)
    with pytest.raises(ValueError, match="preserve"):
        cell_remap_matrix(np.eye(3), G8, G8, preserve="max")


def test_bin_offset_shifts_bins():
    # a rotation by exactly one bin width moves bin j to bin j+1 whatever the offset
    t = np.pi / 6
    R = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
    for off in (0.0, -0.5):
        A = orientation_remap_matrix(R, 6, "covariant", bin_offset=off)
        # covariant with J = R maps angle a to a - t (J^T = R^-1): bin j -> bin j-1
        assert np.allclose(A, np.roll(np.eye(6), -1, axis=0), atol=1e-9)
    # a half-bin rotation splits each bin in two equally, for either offset
    R2 = np.array([[np.cos(t / 2), -np.sin(t / 2)], [np.sin(t / 2), np.cos(t / 2)]])
    assert np.allclose(orientation_remap_matrix(R2, 6, bin_offset=-0.5).max(), 0.5)


def test_bin_offset_by_hand():
    # J = diag(1, 0.5), covariant: tan(out) = 0.5 tan(in). ACF bins centred on k*30 deg:
    # input bin 1 = [15, 45] deg -> [atan(.5 tan 15), atan(.5)] = [7.63, 26.57] deg, of
    # which 15 - 7.63 falls in output bin 0 = [-15, 15]
    A = orientation_remap_matrix(np.diag([1.0, 0.5]), 6, bin_offset=-0.5)
    lo, hi = np.rad2deg(np.arctan(0.5 * np.tan(np.deg2rad([15.0, 45.0]))))
    assert np.isclose(A[0, 1], (15 - lo) / (hi - lo))
    assert np.isclose(A[0, 0], 1.0)  # [-15, 15] shrinks towards 0, stays in bin 0
