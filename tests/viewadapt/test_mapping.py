"""G from a general mapping, depth maps and correspondences, and the object models."""

import numpy as np
import pytest

import viewadapt as va
from viewadapt.geometry import Camera, crop_camera, elevation_homography, homography_jacobian
from viewadapt.mapping import (
    GridMapping, homography_mapping, mapping_cell_remap_matrix, mapping_jacobian,
    mapping_remap_matrix,
)
from viewadapt.objectmodel import (
    PlaneModel, SurfaceOfRevolution, correspondence_mapping, crop_view_mapping, object_model,
    view_mapping,
)
from viewadapt.remap import CellGrid, cell_remap_matrix, feature_remap_matrix
from viewadapt.surface import backproject, project_with_depth, surface_depth, view_correspondence

SRC8 = CellGrid.for_window(64, 128, 8)
TGT4 = CellGrid.for_window(64, 128, 4)


# ------------------------------------------------------------------ planar special case


@pytest.mark.parametrize("pair", [(0.0, np.pi / 4), (np.pi / 8, np.pi / 4), (0.0, np.pi / 8)])
@pytest.mark.parametrize("kw", [dict(), dict(rule="paper"), dict(rule="none"),
                                dict(per_cell=False), dict(subdivisions=1),
                                dict(n_plain=4, preserve="mean", bin_offset=-0.5)])
def test_homography_mapping_reproduces_todays_G(pair, kw):
    H = elevation_homography(*pair)
    sub = kw.pop("subdivisions", 4)
    G0 = feature_remap_matrix(H, SRC8, TGT4, **kw)
    G1 = mapping_remap_matrix(homography_mapping(H), SRC8, TGT4, subdivisions=sub, **kw)
    assert G0.shape == G1.shape
    assert abs(G0 - G1).max() < 1e-6


def test_mapping_jacobian_is_the_homography_jacobian():
    H = elevation_homography(0.0, np.pi / 4)
    p = SRC8.centers()
    assert np.allclose(mapping_jacobian(homography_mapping(H), p), homography_jacobian(H, p),
                       atol=1e-7)


def test_sampled_homography_is_close_and_undefined_parts_are_dropped():
    H = elevation_homography(0.0, np.pi / 4)
    ys, xs = np.mgrid[-1:130, -1:66].astype(float)
    vals = homography_mapping(H)(np.stack([xs, ys], -1))
    g = GridMapping(vals, (-1.0, -1.0), 1.0)
    S0 = cell_remap_matrix(H, SRC8, TGT4)
    S1 = mapping_cell_remap_matrix(g, SRC8, TGT4)
    # bilinear between 1-px samples of a homography: close, not exact
    assert abs(S0 - S1).max() < 5e-3
    # the upper half undefined: those rows lose their mass, the others keep it
    vals[:65] = np.nan
    S2 = mapping_cell_remap_matrix(GridMapping(vals, (-1.0, -1.0), 1.0), SRC8, TGT4)
    rows = np.asarray(S2.sum(axis=1)).ravel().reshape(16, 8)
    assert np.all(rows[:7] == 0) and np.allclose(rows[9:], np.asarray(
        S0.sum(axis=1)).ravel().reshape(16, 8)[9:], atol=5e-3)


def test_bad_mappings_are_clear_value_errors():
    with pytest.raises(ValueError, match="undefined over the whole"):
        mapping_cell_remap_matrix(lambda p: np.full(np.shape(p), np.nan), SRC8, TGT4)
    # a mirror folds over
    mirror = lambda p: np.stack([63.0 - p[..., 0], p[..., 1]], -1)  # noqa: E731
    with pytest.raises(ValueError, match="folds over"):
        mapping_remap_matrix(mirror, SRC8, TGT4)
    assert mapping_cell_remap_matrix(mirror, SRC8, TGT4, folds="drop").nnz == 0
    with pytest.raises(ValueError, match="shape"):
        GridMapping(np.zeros((4, 4, 3)))
    with pytest.raises(ValueError, match="returned shape"):
        mapping_cell_remap_matrix(lambda p: p[..., :1], SRC8, TGT4)
    with pytest.raises(ValueError, match="rule"):
        mapping_remap_matrix(homography_mapping(np.eye(3)), SRC8, TGT4, rule="tangent")


def test_a_pure_translation_mapping_shifts_S():
    S = mapping_cell_remap_matrix(lambda p: p + (8.0, 0.0), SRC8, SRC8)
    # source cell (cy, cx) reads target cell (cy, cx + 1)
    assert S[0, 1] == pytest.approx(1.0) and S[0, 0] == 0


# ------------------------------------------------------------------ depth maps


def _quad(corners):
    return np.asarray(corners, float), np.array([[0, 1, 2], [0, 2, 3]])


def test_depth_of_a_plane_is_the_ray_intersection():
    cam = crop_camera(np.pi / 6)
    V, F = _quad([[-2, 0, -1], [2, 0, -1], [2, 0, 3], [-2, 0, 3]])   # the plane y = 0
    d = surface_depth(V, F, cam, (128, 64))
    assert np.isfinite(d).all()
    X = backproject(d, cam)
    assert np.abs(X[..., 1]).max() < 1e-9
    uv, z = project_with_depth(X, cam)
    ys, xs = np.mgrid[0:128, 0:64]
    assert np.abs(uv - np.stack([xs, ys], -1)).max() < 1e-8 and np.allclose(z, d)


def test_nearest_surface_wins_and_misses_are_nan():
    cam = crop_camera(0.0)
    near = _quad([[-0.2, -1, 0.6], [0.2, -1, 0.6], [0.2, -1, 1.2], [-0.2, -1, 1.2]])
    far = _quad([[-2, 0, -1], [2, 0, -1], [2, 0, 3], [-2, 0, 3]])
    V = np.vstack([far[0], near[0]])
    F = np.vstack([far[1], near[1] + 4])
    d = surface_depth(V, F, cam, (128, 64))
    assert d[63, 31] == pytest.approx(cam.t[2] - 1.0, abs=1e-9) or d[63, 31] < d[0, 0]
    small = surface_depth(*near, cam, (128, 64))
    assert np.isnan(small[0, 0]) and np.isfinite(small[63, 31])
    with pytest.raises(ValueError, match="faces"):
        surface_depth(V, np.array([[0, 1, 99]]), cam, (128, 64))


def _sphere(centre, radius):
    from generator.body import sphere_mesh

    v, f = sphere_mesh(48, 32)
    return v * radius + centre, f


def test_correspondences_agree_with_projected_vertices():
    """The projection check: body-like vertices seen in two views land where the stored
    correspondence says, to well under half a pixel."""
    V, F = _sphere(np.array([0.0, 0.0, 0.9]), 0.3)
    cs, ct = crop_camera(0.0), crop_camera(np.pi / 4)
    ds, dt = surface_depth(V, F, cs, (128, 64)), surface_depth(V, F, ct, (128, 64))
    uv, vis = view_correspondence(ds, cs, dt, ct)
    g = GridMapping(np.where(vis[..., None], uv, np.nan))
    ps, zs = project_with_depth(V, cs)
    pt, _ = project_with_depth(V, ct)
    # the vertices the source view sees: their depth is the depth map's there
    seen = np.abs(GridMapping(np.stack([ds, ds], -1))(ps)[:, 0] - zs) < 3e-3
    q = g(ps)
    ok = np.isfinite(q).all(1) & seen
    assert ok.sum() > 100
    err = np.linalg.norm(q[ok] - pt[ok], axis=1)
    assert np.percentile(err, 99) < 0.5, err.max()
    # the far side of the sphere is hidden from the elevated view; the near side visible
    assert vis.sum() < np.isfinite(ds).sum() and vis[63, 31]


def test_correspondence_input_errors():
    cam = crop_camera(0.0)
    with pytest.raises(ValueError, match="empty"):
        view_correspondence(np.full((128, 64), np.nan), cam, np.ones((128, 64)), cam)
    with pytest.raises(ValueError, match="2-D"):
        view_correspondence(np.ones((128, 64, 2)), cam, np.ones((128, 64)), cam)


# ------------------------------------------------------------------ object models


def test_mean_body_profile_is_a_person():
    body = SurfaceOfRevolution.mean_body()
    z, r = np.array(body.height_fraction), np.array(body.radius_fraction)
    assert z[-1] == 1.0 and r[-1] == 0.0
    # shoulders wider than the neck, radii of a person (metres at 1.75 m)
    assert 0.12 < r.max() * 1.75 < 0.3
    assert r[np.argmin(np.abs(z - 0.87))] < r[np.argmin(np.abs(z - 0.75))]
    with pytest.raises(ValueError):
        SurfaceOfRevolution((0.0, 0.5, 0.4), (0.1, 0.1, 0.0))
    with pytest.raises(ValueError, match="object model"):
        object_model("cylinder")


def test_plane_model_is_the_elevation_homography():
    m = crop_view_mapping(PlaneModel(), 0.0, np.pi / 4)
    p = SRC8.centers()
    assert np.allclose(m(p), va.apply_homography(elevation_homography(0.0, np.pi / 4), p))


def test_body_mapping_identity_at_equal_elevation_and_plane_far_off_body():
    body = object_model("body")
    same = crop_view_mapping(body, np.pi / 8, np.pi / 8)
    p = np.array([[31.5, 63.5], [20.0, 40.0], [5.0, 100.0]])
    assert np.allclose(same(p), p, atol=1e-6)
    m = crop_view_mapping(body, 0.0, np.pi / 4)
    H = elevation_homography(0.0, np.pi / 4)
    off = np.array([[2.0, 60.0], [61.0, 30.0]])                 # beside the body
    assert np.allclose(m(off), va.apply_homography(H, off), atol=1e-6)
    # the body's front lies in front of the plane: from above it appears lower
    centre = np.array([[31.5, 63.5]])
    assert m(centre)[0, 1] > va.apply_homography(H, centre)[0, 1] + 3
    G = va.hog_remap_matrix(m, target_cell_size=4)
    assert G.shape == (128 * 9, 512 * 9) and G.nnz > 0


def test_view_mapping_moves_the_person_between_placements():
    """A person at another ground position and azimuth in a frame: the mapping is the
    same as the crop mapping seen from that camera (the model is turned with it)."""
    body = object_model("body")
    src = crop_camera(0.0)
    tgt = crop_camera(np.pi / 5, azimuth=0.9)
    shift = np.array([3.0, -2.0, 0.0])
    tgt_moved = Camera(tgt.K, tgt.R, tgt.t - tgt.R @ shift, tgt.image_size)
    a = view_mapping(body, src, tgt)
    b = view_mapping(body, src, tgt_moved, target_ground=shift[:2])
    p = np.array([[31.5, 63.5], [25.0, 30.0], [40.0, 100.0]])
    assert np.allclose(a(p), b(p), atol=1e-6)


def test_correspondence_mapping_falls_back_off_the_body():
    V, F = _sphere(np.array([0.0, 0.0, 0.9]), 0.3)
    cs, ct = crop_camera(0.0), crop_camera(np.pi / 4)
    ds, dt = surface_depth(V, F, cs, (128, 64)), surface_depth(V, F, ct, (128, 64))
    H = elevation_homography(0.0, np.pi / 4)
    m = correspondence_mapping(ds, cs, dt, ct, fallback=H)
    corner = np.array([[-0.5, -0.5], [63.5, 127.5]])
    assert np.allclose(m(corner), va.apply_homography(H, corner), atol=1e-3)   # bilinear
    G = mapping_remap_matrix(m, SRC8, TGT4, folds="drop")
    assert G.shape == (128 * 9, 512 * 9)
