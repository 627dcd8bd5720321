"""Calibrations other tools write: a PETS 2009 / Tsai XML made from a known camera reads
back as that camera (K, R, t, and its lens as OpenCV coefficients within 0.1 px); OpenCV
FileStorage YAML, XML and JSON; the reader is picked by suffix and content; every bad file
is one line."""

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from viewadapt.camera.distortion import Undistortion, distort_points
from viewadapt.geometry import camera_from_pose
from viewadapt.io import (
    calibration_format, read_calibration, read_distortion, read_imported_calibration,
    tsai_rotation,
)

SIZE = (640, 480)
#: the sensor and lens of the Tsai camera (mm, Willson's names)
FOCAL, SX, DPX, DPY, CX, CY = 6.0, 1.05, 0.0056, 0.0055, 322.3, 236.9
KAPPA1 = 4e-3                                       # mm^-2, about that of PETS 2009 View_001


@pytest.fixture(scope="module")
def camera():
    """The pinhole part of the Tsai camera: 6 m up, 25 degrees down, turned and moved."""
    return camera_from_pose(focal=[FOCAL * SX / DPX, FOCAL / DPY], principal_point=(CX, CY),
                            height=6.0, tilt=np.radians(25), azimuth=0.4,
                            position_xy=(3.0, -2.0), image_size=SIZE)


def _tsai_xml(cam, *, kappa1=KAPPA1, geometry=None, extra=""):
    rx, ry, rz = Rotation.from_matrix(cam.R).as_euler("xyz")      # R = Rz Ry Rx
    tx, ty, tz = cam.t * 1000.0
    geometry = geometry or (f'ncx="700" nfx="640" dx="{DPX * 640 / 700!r}" dy="{DPY!r}" '
                            f'dpx="{DPX!r}" dpy="{DPY!r}"')
    return (f'<?xml version="1.0" encoding="UTF-8"?>\n<Camera name="test">\n'
            f'  <Geometry width="{SIZE[0]}" height="{SIZE[1]}" {geometry}/>\n'
            f'  <Intrinsic focal="{FOCAL!r}" kappa1="{kappa1!r}" cx="{CX!r}" cy="{CY!r}" '
            f'sx="{SX!r}"/>\n'
            f'  <Extrinsic tx="{tx!r}" ty="{ty!r}" tz="{tz!r}" rx="{rx!r}" ry="{ry!r}" '
            f'rz="{rz!r}"/>{extra}\n</Camera>\n')


def _tsai_project(cam, ground_xy, kappa1=KAPPA1):
    """Tsai's own projection of ground points (metres): world mm -> camera -> undistorted
    sensor mm -> distorted sensor mm (``X_u = X_d (1 + kappa1 r_d^2)``, solved by Newton's
    method on the radius) -> pixels."""
    X = np.c_[ground_xy, np.zeros(len(ground_xy))] * 1000.0
    c = X @ cam.R.T + cam.t * 1000.0
    xu, yu = FOCAL * c[:, 0] / c[:, 2], FOCAL * c[:, 1] / c[:, 2]
    ru = np.hypot(xu, yu)
    rd = ru.copy()
    for _ in range(50):
        rd -= (rd + kappa1 * rd ** 3 - ru) / (1 + 3 * kappa1 * rd ** 2)
    s = rd / ru
    return np.c_[SX * xu * s / DPX + CX, yu * s / DPY + CY]


def _ground_points_in_view(cam):
    g = np.stack(np.meshgrid(np.linspace(-40, 40, 161), np.linspace(-40, 40, 161)), -1)
    g = g.reshape(-1, 2)
    c = np.c_[g, np.zeros(len(g))] @ cam.R.T + cam.t
    g = g[c[:, 2] > 0.5]
    uv = cam.project(np.c_[g, np.zeros(len(g))])
    inside = (uv[:, 0] >= 0) & (uv[:, 0] <= SIZE[0] - 1) & \
        (uv[:, 1] >= 0) & (uv[:, 1] <= SIZE[1] - 1)
    return g[inside]


def test_tsai_rotation_is_rz_ry_rx():
    a, b, g = 2.04, -0.89, -0.43
    assert np.allclose(tsai_rotation(a, b, g),
                       Rotation.from_euler("xyz", [a, b, g]).as_matrix(), atol=1e-14)


@pytest.mark.parametrize("with_dpx", [True, False])
def test_a_tsai_camera_reads_back(camera, tmp_path, with_dpx):
    geometry = None if with_dpx else (f'ncx="700" nfx="640" dx="{DPX * 640 / 700!r}" '
                                      f'dy="{DPY!r}" dpy="{DPY!r}"')   # dpx = dx ncx / nfx
    path = tmp_path / "View_001.xml"
    path.write_text(_tsai_xml(camera, geometry=geometry))
    assert calibration_format(path) == "tsai"
    cam = read_calibration(path)
    assert cam.image_size == SIZE
    assert np.allclose(cam.K, camera.K, rtol=1e-12, atol=1e-9)
    assert np.allclose(cam.R, camera.R, atol=1e-12) and np.allclose(cam.t, camera.t, atol=1e-9)
    dist = read_distortion(path)
    assert dist.shape == (5,) and dist[2] == dist[3] == 0
    assert dist[0] == pytest.approx(-KAPPA1 * FOCAL ** 2, rel=0.05)  # k1 ~ -kappa1 f^2
    imported = read_imported_calibration(path)
    assert imported.format == "tsai" and imported.fit_error_px < 0.01
    # ground points through the imported camera and lens land where Tsai's model puts them
    g = _ground_points_in_view(camera)
    assert len(g) > 200
    rvec = cv2.Rodrigues(cam.R)[0]
    ours = cv2.projectPoints(np.c_[g, np.zeros(len(g))], rvec, cam.t, cam.K, dist)[0]
    err = np.hypot(*(ours.reshape(-1, 2) - _tsai_project(camera, g)).T)
    assert err.max() < 0.1, err.max()
    # and the lens moves them by pixels: the distortion is there to be matched
    assert np.hypot(*(camera.project(np.c_[g, np.zeros(len(g))]) - _tsai_project(camera, g)).T
                    ).max() > 3


def test_tsai_without_distortion_and_a_lens_opencv_cannot_follow(camera, tmp_path):
    path = tmp_path / "cam.xml"
    path.write_text(_tsai_xml(camera, kappa1=0.0))
    assert read_distortion(path) is None
    path.write_text(_tsai_xml(camera, kappa1=0.5))
    with pytest.raises(ValueError, match="cannot be written as OpenCV's k1, k2, k3 within 0.5 "
                                         "px") as exc:
        read_calibration(path)
    assert len(str(exc.value).splitlines()) == 1


def test_bad_xml_is_one_line(camera, tmp_path):
    good = _tsai_xml(camera)
    cases = {
        "truncated": (good[:-30], "not well-formed XML"),
        "another root": ("<calibration><K/></calibration>", "its root is <calibration>"),
        "no Intrinsic": (good.replace("<Intrinsic", "<Other"), "lacks <Intrinsic>"),
        "no focal": (good.replace('focal="', 'f="'), "<Intrinsic> lacks the attribute focal"),
        "not a number": (good.replace(f'cx="{CX!r}"', 'cx="middle"'),
                         "<Intrinsic> cx is not a number ('middle')"),
        "negative dpy": (good.replace(f'dpy="{DPY!r}"', 'dpy="-0.1"'), "dpy must be positive"),
        "entities": ('<?xml version="1.0"?><!DOCTYPE x [<!ENTITY a "aaaa">]>' + good[38:],
                     "document type or entity declarations"),
    }
    for case, (text, want) in cases.items():
        path = tmp_path / "View_001.xml"
        path.write_text(text)
        with pytest.raises(ValueError) as exc:
            read_calibration(path)
        msg = str(exc.value)
        assert len(msg.splitlines()) == 1 and str(path) in msg and want in msg, (case, msg)


@pytest.mark.parametrize("suffix, pose", [(".yml", "rvec"), (".xml", "R"), (".json", "rvec")])
def test_opencv_filestorage(camera, tmp_path, suffix, pose):
    dist = np.array([[-0.21, 0.05, 1e-3, -2e-3, 0.0]])
    path = tmp_path / f"camera{suffix}"
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", SIZE[0])
    fs.write("image_height", SIZE[1])
    fs.write("camera_matrix", camera.K)
    fs.write("distortion_coefficients", dist)
    if pose == "rvec":
        fs.write("rvec", cv2.Rodrigues(camera.R)[0])
        fs.write("tvec", camera.t.reshape(3, 1))
    else:
        fs.write("R", camera.R)
        fs.write("t", camera.t.reshape(3, 1))
    fs.release()
    assert calibration_format(path) == "opencv"
    cam = read_calibration(path)
    assert cam.image_size == SIZE and np.allclose(cam.K, camera.K)
    assert np.allclose(cam.R, camera.R, atol=1e-9) and np.allclose(cam.t, camera.t)
    assert np.allclose(read_distortion(path), dist.ravel())


def test_bad_opencv_files_are_one_line(camera, tmp_path):
    header = "%YAML:1.0\n---\n"
    K = ("camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ "
         + ", ".join(repr(float(v)) for v in camera.K.ravel()) + " ]\n")
    size = "image_width: 640\nimage_height: 480\n"
    pose = "rvec: [0.1, 0.2, 0.3]\ntvec: [0.0, 0.0, 5.0]\n"
    cases = {
        "unparsable": (header + "camera_matrix: !!opencv-matrix\n  rows: [\n", "OpenCV cannot"),
        "no camera matrix": (header + size + pose, "no camera_matrix"),
        "no size": (header + K + pose, "image_width (pixels) is missing"),
        "no pose": (header + K + size, "the ground pose is missing"),
        "a short tvec": (header + K + size + "rvec: [0.1, 0.2, 0.3]\ntvec: [1.0, 2.0]\n",
                         "tvec must be 3 numbers"),
        "bad dist": (header + K + size + pose + "dist_coeffs: [0.1, 0.2, 0.3]\n",
                     "dist_coeffs: dist must be 4, 5, 8, 12 or 14 numbers"),
    }
    for case, (text, want) in cases.items():
        path = tmp_path / "cam.yml"
        path.write_text(text)
        with pytest.raises(ValueError) as exc:
            read_calibration(path)
        msg = str(exc.value)
        assert len(msg.splitlines()) == 1 and want in msg, (case, msg)


def test_the_project_format_is_still_read(camera, tmp_path):
    import json

    path = tmp_path / "cam.json"
    path.write_text(json.dumps({"image_size": list(SIZE), "K": camera.K.tolist(),
                                "R": camera.R.tolist(), "t": camera.t.tolist(),
                                "dist": [-0.1, 0.0, 0.0, 0.0]}))
    assert calibration_format(path) is None
    assert np.allclose(read_calibration(path).K, camera.K)
    assert read_distortion(path).tolist() == [-0.1, 0.0, 0.0, 0.0]
    with pytest.raises(FileNotFoundError, match="calibration file .* does not exist"):
        read_calibration(tmp_path / "missing.xml")


def test_distort_points_inverts_undistort_points(camera):
    dist = [-0.35, 0.1, 1e-3, -1e-3, 0.0]
    und = Undistortion(camera.K, dist, SIZE)
    rng = np.random.default_rng(0)
    p = rng.uniform([40, 30], [600, 450], size=(200, 2))
    assert np.allclose(und.undistort_points(distort_points(p, camera.K, dist)), p, atol=1e-6)
    assert np.allclose(distort_points(und.undistort_points(p), camera.K, dist), p, atol=1e-6)
    assert distort_points(np.zeros((0, 2)), camera.K, dist).shape == (0, 2)
