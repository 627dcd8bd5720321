import numpy as np
import pytest

from tests.tolerances import EXACT
from viewadapt.geometry import (
    PERSON_HEIGHT_M, Camera, apply_homography, camera_from_pose, crop_camera, crop_homography,
    elevation_homography, frame_transfer_homography, homography_jacobian, look_at_rotation,
    window_to_image_homography, window_to_plane,
)


def test_window_to_plane_golden():
    # feet (31.5, 111.5) -> (0, 0); head (31.5, 15.5) -> (0, 1.75); s = 1.75 / 96 m/px
    M = window_to_plane()
    assert np.allclose(M @ [31.5, 111.5, 1], [0, 0, 1], **EXACT)
    assert np.allclose(M @ [31.5, 15.5, 1], [0, PERSON_HEIGHT_M, 1], **EXACT)
    assert np.allclose(M @ [63.5, 111.5, 1], [32 * 1.75 / 96, 0, 1], **EXACT)


def test_look_at_axes_by_hand():
    # looking along +Y with Z up: right = +X, down = -Z
    R = look_at_rotation([0, 1, 0])
    assert np.allclose(R, [[1, 0, 0], [0, 0, -1], [0, 1, 0]], **EXACT)
    with pytest.raises(ValueError, match="vertical"):
        look_at_rotation([0, 0, -1])


def test_crop_homography_level_view_is_identity():
    assert np.allclose(crop_homography(0.0), np.eye(3), atol=1e-9)


@pytest.mark.parametrize("elev", [np.pi / 8, np.pi / 4, 1.2])
def test_crop_aims_at_window_centre_and_foreshortens(elev):
    H = crop_homography(elev)
    # the person's centre (window centre) stays at the window centre at every elevation
    assert np.allclose(apply_homography(H, [31.5, 63.5]), [31.5, 63.5], atol=1e-9)
    head, feet = apply_homography(H, [[31.5, 15.5], [31.5, 111.5]])
    height_px = feet[1] - head[1]
    # vertical foreshortening of a 1.75 m plane seen from distance 10 m at elevation e:
    # roughly 96 cos(e) (exactly: perspective adds a little); the head is nearer, so larger
    assert 96 * np.cos(elev) * 0.97 < height_px < 96 * np.cos(elev) * 1.03
    J_head = homography_jacobian(H, [31.5, 15.5])
    J_feet = homography_jacobian(H, [31.5, 111.5])
    assert J_head[0, 0] > J_feet[0, 0]  # keystone: top wider than bottom


def test_pi4_person_height_matches_reference_pilot():
    # shared/reference/plane_framing_pilot.png: at pi/4 the person is about 70 px tall
    H = crop_homography(np.pi / 4)
    head, feet = apply_homography(H, [[31.5, 15.5], [31.5, 111.5]])
    assert 66 < feet[1] - head[1] < 72


def test_elevation_homography_roundtrip_and_composition():
    Hab = elevation_homography(0.0, np.pi / 8)
    Hba = elevation_homography(np.pi / 8, 0.0)
    assert np.allclose(Hab @ Hba / (Hab @ Hba)[2, 2], np.eye(3), atol=1e-9)
    Hac = elevation_homography(0.0, np.pi / 4)
    Hbc = elevation_homography(np.pi / 8, np.pi / 4)
    comp = Hbc @ Hab
    assert np.allclose(comp / comp[2, 2], Hac, atol=1e-9)
    pts = np.random.default_rng(0).uniform([0, 0], [63, 127], size=(20, 2))
    back = apply_homography(Hba, apply_homography(Hab, pts))
    assert np.allclose(back, pts, atol=1e-9)


def test_homography_matches_projected_plane_points():
    cam = crop_camera(np.pi / 4)
    H = crop_homography(np.pi / 4)
    # a point on the person plane 1.2 m up and 0.3 m to the camera's right
    uv = np.linalg.solve(window_to_plane(), [0.3, 1.2, 1.0])
    e_u = cam.R[0]  # camera right axis, horizontal here
    X = np.array([0, 0, 0.0]) + 0.3 * np.array([e_u[0], e_u[1], 0]) / np.hypot(*e_u[:2]) \
        + 1.2 * np.array([0, 0, 1.0])
    assert np.allclose(apply_homography(H, uv[:2] / uv[2]), cam.project(X), atol=1e-9)


def test_jacobian_against_finite_differences():
    H = elevation_homography(0, np.pi / 4)
    p = np.array([20.0, 90.0])
    J = homography_jacobian(H, p)
    eps = 1e-6
    num = np.stack([(apply_homography(H, p + [eps, 0]) - apply_homography(H, p - [eps, 0])),
                    (apply_homography(H, p + [0, eps]) - apply_homography(H, p - [0, eps]))],
                   axis=1) / (2 * eps)
    assert np.allclose(J, num, atol=1e-6)


def test_frame_camera_projection_and_transfer():
    cam = camera_from_pose(focal=300, principal_point=(191.5, 143.5), height=4.0,
                           tilt=np.deg2rad(45), azimuth=np.pi / 2)
    # optical axis hits the ground 4 m ahead along +Y (azimuth pi/2)
    assert np.allclose(cam.project([0, 4.0, 0]), [191.5, 143.5], atol=1e-9)
    H = window_to_image_homography(cam, (0.0, 4.0))
    feet = apply_homography(H, [31.5, 111.5])
    assert np.allclose(feet, cam.project([0, 4.0, 0]), atol=1e-9)
    head = apply_homography(H, [31.5, 15.5])
    assert np.allclose(head, cam.project([0, 4.0, PERSON_HEIGHT_M]), atol=1e-9)
    Ht = frame_transfer_homography(cam, (0.0, 4.0), 0.0)
    assert np.allclose(Ht, H, atol=1e-9)  # the 0-elevation crop is the canonical window


def test_camera_dict_roundtrip():
    cam = crop_camera(0.3)
    cam2 = Camera.from_dict(cam.to_dict())
    assert np.allclose(cam.P, cam2.P, **EXACT)


@pytest.mark.parametrize("bad", [-0.1, np.pi / 2, 2.0, np.nan])
def test_elevation_out_of_range(bad):
    with pytest.raises(ValueError, match=r"\[0, pi/2\)"):
        crop_homography(bad)


def test_bad_camera_inputs():
    with pytest.raises(ValueError, match="rotation"):
        Camera(np.eye(3), np.diag([1.0, 1.0, -1.0]), np.zeros(3))
    with pytest.raises(ValueError, match="height"):
        camera_from_pose(focal=300, principal_point=(0, 0), height=-1, tilt=0.5)
    cam = camera_from_pose(focal=300, principal_point=(0, 0), height=4, tilt=0.5)
    with pytest.raises(ValueError, match="below the camera"):
        window_to_image_homography(cam, (0.0, 0.0))
    with pytest.raises(ValueError, match="behind the camera"):
        cam.project([-10.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="behind the camera"):
        window_to_image_homography(cam, (-5.0, 0.0))
    with pytest.raises(ValueError, match="distance"):
        crop_homography(0.1, distance=0.5)


@pytest.mark.parametrize("distance", [0.875, 0.5, 0.0, -3.0, np.nan, np.inf])
def test_check_distance_refuses_a_camera_on_or_in_the_person(distance):
    from viewadapt.geometry import check_distance, crop_camera

    with pytest.raises(ValueError, match="exceed half the person height"):
        check_distance(distance)                        # 1.75 m person: head 0.875 m away
    with pytest.raises(ValueError, match="exceed half the person height"):
        crop_camera(0.3, distance=distance)


def test_check_distance_passes_a_distance_beyond_the_head_unchanged():
    from viewadapt.geometry import check_distance

    assert check_distance(0.876) == 0.876
    assert check_distance(10) == 10 and type(check_distance(10)) is int
    with pytest.raises(ValueError, match=r"\(1.0 m\)"):
        check_distance(0.9, person_height=2.0)          # the rule follows the person
    assert check_distance(0.9, person_height=1.6) == 0.9


@pytest.mark.parametrize("elevation", [0.0, np.pi / 8, np.pi / 4, 1.2])
def test_silhouette_framed_crop_homography_keeps_the_person_box(elevation):
    from viewadapt.geometry import apply_homography, crop_homography, elevation_homography

    H = crop_homography(elevation, framing="silhouette")
    ends = apply_homography(H, np.array([[31.5, 15.5], [31.5, 111.5]]))
    # head and feet of the planar person land where the canonical window has them
    assert np.allclose(ends, [[31.5, 15.5], [31.5, 111.5]], atol=1e-9)
    assert np.allclose(elevation_homography(elevation, elevation, framing="silhouette"),
                       np.eye(3), atol=1e-12)
    plane = crop_homography(elevation)
    if elevation > 0:
        # the plane-framed person is foreshortened; the silhouette framing scales it back
        p = apply_homography(plane, np.array([[31.5, 15.5], [31.5, 111.5]]))
        assert p[1, 1] - p[0, 1] < 96 - 1
    with pytest.raises(ValueError, match="framing"):
        crop_homography(elevation, framing="tight")
