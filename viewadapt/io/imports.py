"""Files other tools write: camera calibrations, and guarded readers for files from outside.

Calibrations (:func:`read_imported_calibration`, used by
:func:`viewadapt.io.calibration.read_calibration` and ``read_distortion``):

* **PETS 2009 / Tsai XML** (:func:`read_tsai_calibration`): ``<Camera>`` with
  ``<Geometry width height ncx nfx dx dy dpx dpy/>``, ``<Intrinsic focal kappa1 cx cy sx/>``
  and ``<Extrinsic tx ty tz rx ry rz/>``, the camera model of Tsai (1987) as R. Willson's
  implementation writes it: lengths in millimetres, world ``Z`` up, the ground ``Z = 0``.
* **OpenCV FileStorage** YAML, XML or JSON (:func:`read_opencv_calibration`), as
  ``cv::FileStorage`` writes it (OpenCV's calibration samples): ``camera_matrix``,
  ``distortion_coefficients``, ``image_width``, ``image_height`` and the ground pose.

Calibration files are read with the bounds of :mod:`viewadapt.io.bounded` (whose readers
are also importable from here): at most :data:`~viewadapt.io.bounded.MAX_CALIBRATION_BYTES`,
nested at most :data:`~viewadapt.io.bounded.MAX_CALIBRATION_DEPTH` levels (``cv2.FileStorage``
crashes on deep nesting), no YAML anchors or aliases, XML without a document type (no
entities to expand); every violation is a one-line ``ValueError`` naming the file.

References
----------
.. [1] R. Y. Tsai, "A versatile camera calibration technique for high-accuracy 3D machine
   vision metrology using off-the-shelf TV cameras and lenses", IEEE Journal of Robotics
   and Automation 3(4), 1987.
.. [2] R. Willson, "Tsai Camera Calibration Software" (``cal_main.c``, ``cal_tran.c``),
   Carnegie Mellon University, 1995.
.. [3] J. Ferryman and A. Shahrokni, "PETS2009: Dataset and challenge", IEEE PETS 2009.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import NamedTuple

import numpy as np

from viewadapt.camera.checks import check_calibration
from viewadapt.geometry import Camera
from viewadapt.io.bounded import (
    MAX_CALIBRATION_BYTES, MAX_CALIBRATION_DEPTH, MAX_INPUT_BYTES, MAX_JSON_DEPTH,
    check_json_depth, check_yaml, json_depth, parse_json, parse_xml, read_limited_text,
)

__all__ = ["TSAI_FIT_GRID", "MAX_TSAI_FIT_ERROR_PX", "ImportedCalibration",
           "read_calibration_text", "check_filestorage_text", "calibration_format",
           "read_imported_calibration", "read_tsai_calibration", "read_opencv_calibration",
           "tsai_rotation", "tsai_distortion_to_opencv",
           # the bounded readers, from viewadapt.io.bounded
           "MAX_INPUT_BYTES", "MAX_JSON_DEPTH", "read_limited_text", "parse_json", "parse_xml",
           "json_depth"]

#: Distorted image points (columns, rows) over which Tsai's lens is fitted by OpenCV's.
TSAI_FIT_GRID = (30, 20)
#: The largest error (pixels) of that fit that is accepted.
MAX_TSAI_FIT_ERROR_PX = 0.5


class ImportedCalibration(NamedTuple):
    """A calibration read from another tool's file.

    Attributes
    ----------
    camera : Camera
        ``K, R, t`` (OpenCV convention, world metres, Z up, ground ``Z = 0``).
    dist : (5,) ndarray or None
        OpenCV distortion coefficients ``[k1, k2, p1, p2, k3]`` of ``K``, None without.
    format : {"tsai", "opencv"}
    fit_error_px : float or None
        Tsai: the largest distance (pixels) between Tsai's lens and the OpenCV
        coefficients over the image (:func:`tsai_distortion_to_opencv`); None otherwise.
    """

    camera: Camera
    dist: np.ndarray | None
    format: str
    fit_error_px: float | None


# --------------------------------------------------------------------------- bounds


def read_calibration_text(path) -> str:
    """The text of a calibration file (any format), refused in one line over
    :data:`~viewadapt.io.bounded.MAX_CALIBRATION_BYTES` before it is read
    (:func:`~viewadapt.io.bounded.read_limited_text`)."""
    return read_limited_text(path, "calibration file", MAX_CALIBRATION_BYTES)


def check_filestorage_text(text: str, path) -> None:
    """Refuse (one-line ``ValueError``) an OpenCV FileStorage text ``cv2.FileStorage``
    should not parse: nested deeper than :data:`~viewadapt.io.bounded.MAX_CALIBRATION_DEPTH`
    levels (OpenCV's parser recurses, and crashes the process on deep nesting), YAML with
    anchors or aliases, XML with a document type.

    XML and JSON by their first character, anything else as YAML
    (:func:`~viewadapt.io.bounded.check_yaml`); YAML that PyYAML cannot parse is bounded by
    its brackets instead (:func:`~viewadapt.io.bounded.json_depth`: the flow nesting; block
    nesting needs one more column of indent a level, so the size limit bounds it to about
    1,400 levels, which OpenCV reads) and left to OpenCV to report.
    """
    head = text.lstrip()
    if head.startswith("<"):
        parse_xml(text, path, MAX_CALIBRATION_DEPTH)
    elif head.startswith(("{", "[")):
        check_json_depth(text, path, MAX_CALIBRATION_DEPTH)
    elif not check_yaml(text, path, MAX_CALIBRATION_DEPTH):
        check_json_depth(text, path, MAX_CALIBRATION_DEPTH)


# --------------------------------------------------------------------------- dispatch


def calibration_format(path) -> str | None:
    """Which reader a calibration file needs: ``"tsai"``, ``"opencv"`` or None (the
    project's own YAML/JSON, :func:`viewadapt.io.calibration.read_calibration`).

    XML (by suffix or content) by its root element: ``<Camera>`` is Tsai,
    ``<opencv_storage>`` OpenCV; YAML or JSON is OpenCV's when it starts with ``%YAML:``
    or holds an ``opencv-matrix``. Any other XML root is a one-line ``ValueError``.
    """
    path = Path(path)
    text = read_calibration_text(path)
    head = text.lstrip()
    if path.suffix.lower() == ".xml" or head.startswith("<"):
        root = parse_xml(text, path, MAX_CALIBRATION_DEPTH)
        if root.tag == "opencv_storage":
            return "opencv"
        if root.tag == "Camera":
            return "tsai"
        raise ValueError(f"{path}: an XML calibration must be a PETS 2009 / Tsai <Camera> or "
                         f"an OpenCV <opencv_storage> file; its root is <{root.tag}>")
    if head.startswith("%YAML:") or "opencv-matrix" in text:
        return "opencv"
    return None


def read_imported_calibration(path, format: str | None = None) -> ImportedCalibration:
    """A Tsai or OpenCV FileStorage calibration (``format`` as :func:`calibration_format`
    finds it when None)."""
    fmt = format or calibration_format(path)
    if fmt == "tsai":
        return read_tsai_calibration(path)
    if fmt == "opencv":
        return read_opencv_calibration(path)
    raise ValueError(f"{path}: not a Tsai XML or OpenCV FileStorage calibration")


# --------------------------------------------------------------------------- Tsai


def tsai_rotation(rx: float, ry: float, rz: float) -> np.ndarray:
    """World-to-camera rotation of Tsai's Euler angles (radians), as Willson's
    ``cal_tran.c`` builds it: ``R = Rz(rz) Ry(ry) Rx(rx)``, i.e. with ``a, b, g = rx, ry,
    rz``::

        [[cb cg, cg sa sb - ca sg, sa sg + ca cg sb],
         [cb sg, sa sb sg + ca cg, ca sb sg - cg sa],
         [-sb,   cb sa,            ca cb          ]]
    """
    ca, sa = np.cos(rx), np.sin(rx)
    cb, sb = np.cos(ry), np.sin(ry)
    cg, sg = np.cos(rz), np.sin(rz)
    return np.array([[cb * cg, cg * sa * sb - ca * sg, sa * sg + ca * cg * sb],
                     [cb * sg, sa * sb * sg + ca * cg, ca * sb * sg - cg * sa],
                     [-sb, cb * sa, ca * cb]])


def tsai_distortion_to_opencv(K, kappa, image_size, grid=TSAI_FIT_GRID):
    """OpenCV coefficients ``[k1, k2, 0, 0, k3]`` closest to Tsai's radial lens.

    Tsai's lens maps *distorted* sensor coordinates to undistorted ones, ``x_u = x_d (1 +
    kappa r_d^2)`` with ``r_d^2 = x_d^2 + y_d^2`` (here in normalised coordinates ``x =
    X / f``: ``kappa = kappa1 f^2``); OpenCV's maps undistorted to distorted, ``x_d = x_u
    (1 + k1 r^2 + k2 r^4 + k3 r^6)``. The three ``k`` are fitted by linear least squares
    in pixels over a ``grid`` (columns, rows) of distorted points spanning the image, and
    the fit is measured by projecting each point's undistorted position with OpenCV's
    model (``cv2.projectPoints``).

    Parameters
    ----------
    K : (3, 3) array_like
    kappa : float
        Tsai's ``kappa1`` in normalised coordinates (``kappa1 * focal**2``).
    image_size : (width, height)
    grid : (int, int)

    Returns
    -------
    dist : (5,) ndarray
    max_error_px : float
        The largest distance between a grid point and its OpenCV-model reprojection.
    """
    import cv2

    K = np.asarray(K, dtype=np.float64)
    w, h = image_size
    u, v = np.meshgrid(np.linspace(0, w - 1, grid[0]), np.linspace(0, h - 1, grid[1]))
    pix = np.c_[u.ravel(), v.ravel()]
    yd = (pix[:, 1] - K[1, 2]) / K[1, 1]
    xd = (pix[:, 0] - K[0, 2] - K[0, 1] * yd) / K[0, 0]
    s = 1 + kappa * (xd ** 2 + yd ** 2)
    xu, yu = xd * s, yd * s
    r2 = xu ** 2 + yu ** 2
    basis = np.stack([r2, r2 ** 2, r2 ** 3], axis=1)
    A = np.r_[K[0, 0] * xu[:, None] * basis, K[1, 1] * yu[:, None] * basis]
    b = np.r_[K[0, 0] * (xd - xu), K[1, 1] * (yd - yu)]
    k = np.linalg.lstsq(A, b, rcond=None)[0]
    dist = np.array([k[0], k[1], 0.0, 0.0, k[2]])
    obj = np.c_[xu, yu, np.ones_like(xu)]
    proj = cv2.projectPoints(obj, np.zeros(3), np.zeros(3), K, dist)[0].reshape(-1, 2)
    return dist, float(np.hypot(*(proj - pix).T).max())


def _attributes(root, tag, names, path) -> dict:
    el = root.find(tag)
    if el is None:
        raise ValueError(f"{path}: the Tsai calibration lacks <{tag}>")
    attrs = {k.lower(): v for k, v in el.attrib.items()}
    out = {}
    for n in names:
        if n not in attrs:
            raise ValueError(f"{path}: <{tag}> lacks the attribute {n}")
        try:
            out[n] = float(attrs[n])
        except ValueError:
            raise ValueError(f"{path}: <{tag}> {n} is not a number ({attrs[n]!r})") from None
        if not np.isfinite(out[n]):
            raise ValueError(f"{path}: <{tag}> {n} is not finite ({attrs[n]!r})")
    return out


def read_tsai_calibration(path) -> ImportedCalibration:
    """A camera from a PETS 2009 / Tsai calibration XML (see the module).

    The file's model (Tsai 1987; lengths in mm, world ``Z`` up, ground ``Z = 0``): a
    world point ``X`` (mm) goes to the camera as ``R X + T`` (``R``:
    :func:`tsai_rotation` of ``rx, ry, rz``, ``T = (tx, ty, tz)``), to undistorted sensor
    millimetres ``(X_u, Y_u) = focal (x, y) / z``, to distorted ones by ``X_u = X_d (1 +
    kappa1 r_d^2)``, and to pixels ``u = sx X_d / dpx + cx``, ``v = Y_d / dpy + cy``
    (``dpx = dx ncx / nfx`` where the file gives no ``dpx``).

    So ``K = [[focal sx / dpx, 0, cx], [0, focal / dpy, cy], [0, 0, 1]]``, ``R`` as is,
    ``t = T / 1000`` (metres), and the lens the OpenCV coefficients fitted by
    :func:`tsai_distortion_to_opencv` (refused above :data:`MAX_TSAI_FIT_ERROR_PX`).

    Raises
    ------
    ValueError
        One line: not well-formed, a missing element or attribute, a value that is not a
        number or not positive, a pose below the ground, a lens OpenCV's model cannot
        follow.
    """
    path = Path(path)
    root = parse_xml(read_calibration_text(path), path, MAX_CALIBRATION_DEPTH)
    if root.tag != "Camera":
        raise ValueError(f"{path}: a Tsai calibration has the root <Camera>, not "
                         f"<{root.tag}>")
    geometry = root.find("Geometry")
    given = {k.lower() for k in (geometry.attrib if geometry is not None else ())}
    g = _attributes(root, "Geometry", ["width", "height", "dpy"] + (
        ["dpx"] if "dpx" in given else ["dx", "ncx", "nfx"]), path)
    i = _attributes(root, "Intrinsic", ["focal", "kappa1", "cx", "cy", "sx"], path)
    e = _attributes(root, "Extrinsic", ["tx", "ty", "tz", "rx", "ry", "rz"], path)
    if "dpx" not in g:
        if g["nfx"] <= 0:
            raise ValueError(f"{path}: <Geometry> nfx must be positive, got {g['nfx']:g}")
        g["dpx"] = g["dx"] * g["ncx"] / g["nfx"]
    for tag, d, names in (("Geometry", g, ("dpx", "dpy")), ("Intrinsic", i, ("focal", "sx"))):
        for n in names:
            if d[n] <= 0:
                raise ValueError(f"{path}: <{tag}> {n} must be positive, got {d[n]:g}")
    w, h = g["width"], g["height"]
    if not (w == int(w) > 0 and h == int(h) > 0):
        raise ValueError(f"{path}: <Geometry> width and height must be positive whole "
                         f"numbers of pixels, got {w:g} x {h:g}")
    size = (int(w), int(h))
    K = np.array([[i["focal"] * i["sx"] / g["dpx"], 0.0, i["cx"]],
                  [0.0, i["focal"] / g["dpy"], i["cy"]], [0.0, 0.0, 1.0]])
    R = tsai_rotation(e["rx"], e["ry"], e["rz"])
    t = np.array([e["tx"], e["ty"], e["tz"]]) / 1000.0
    cam = check_calibration(K, R, t, size, name=f"calibration {path}")
    if i["kappa1"] == 0:
        return ImportedCalibration(cam, None, "tsai", None)
    dist, err = tsai_distortion_to_opencv(K, i["kappa1"] * i["focal"] ** 2, size)
    if not err <= MAX_TSAI_FIT_ERROR_PX:
        raise ValueError(f"{path}: Tsai's lens (kappa1 = {i['kappa1']:g} mm^-2) cannot be "
                         f"written as OpenCV's k1, k2, k3 within {MAX_TSAI_FIT_ERROR_PX} px "
                         f"over the image (the best fit is {err:.2f} px off)")
    return ImportedCalibration(cam, dist, "tsai", err)


# --------------------------------------------------------------------------- OpenCV

_OPENCV_KEYS = {
    "K": ("camera_matrix", "cameraMatrix", "K"),
    "dist": ("distortion_coefficients", "dist_coeffs", "distCoeffs", "D"),
    "rvec": ("rvec",), "tvec": ("tvec",), "R": ("R",), "t": ("t", "T"),
}


def _fs_node(fs, names):
    for n in names:
        node = fs.getNode(n)
        if not node.empty():
            return n, node
    return None, None


def _fs_array(node, name, path) -> np.ndarray:
    """A FileStorage node (a matrix, a sequence of numbers or a number) as floats."""
    if node.isSeq():
        vals = [node.at(k).real() for k in range(node.size())]
    elif node.isReal() or node.isInt():
        vals = [node.real()]
    else:
        m = node.mat()
        if m is None:
            raise ValueError(f"{path}: {name} is not a matrix or a list of numbers")
        vals = np.asarray(m, dtype=np.float64)
    a = np.asarray(vals, dtype=np.float64)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{path}: {name} has non-finite values")
    return a


def read_opencv_calibration(path) -> ImportedCalibration:
    """A camera from an OpenCV FileStorage file (YAML, XML or JSON; ``cv2.FileStorage``).

    Keys: ``camera_matrix`` (or ``cameraMatrix``, ``K``), 3x3; the optional
    ``distortion_coefficients`` (or ``dist_coeffs``, ``distCoeffs``, ``D``), 4, 5, 8, 12
    or 14 numbers in OpenCV's order; ``image_width`` and ``image_height``; and the pose
    of the ground: ``rvec`` and ``tvec`` (Rodrigues vector and translation, as
    ``cv2.solvePnP`` returns them) or ``R`` (3x3) and ``t``, world metres with Z up and
    the ground ``Z = 0``. ``K, R, t`` are checked as the project's own files are
    (:func:`~viewadapt.camera.checks.check_calibration`).

    The file is bounded first (:func:`check_filestorage_text`): size, nesting, no YAML
    aliases.

    Raises
    ------
    ValueError
        One line: out of those bounds, a file OpenCV cannot parse, a missing key, values of
        the wrong shape.
    """
    import cv2

    from viewadapt.camera.distortion import check_distortion

    path = Path(path)
    check_filestorage_text(read_calibration_text(path), path)
    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError) as exc:          # SystemError: cv2's parse errors
        msg = " ".join(str(exc.__cause__ or exc).split())
        m = re.search(r"error: \(-?\d+:([^)]*)\) (.*?)(?: in function|$)", msg)
        raise ValueError(f"{path}: OpenCV cannot parse it as a FileStorage file ("
                         f"{(m.group(1) + ': ' + m.group(2)) if m else msg[:160]})") from None
    try:
        if not fs.isOpened():
            raise ValueError(f"{path}: OpenCV cannot open it as a FileStorage file")
        name, node = _fs_node(fs, _OPENCV_KEYS["K"])
        if node is None:
            raise ValueError(f"{path}: no camera_matrix (or cameraMatrix, K)")
        K = _fs_array(node, name, path)
        if K.size != 9:
            raise ValueError(f"{path}: {name} must be 3x3, it has {K.size} values")
        K = K.reshape(3, 3)
        size = []
        for key in ("image_width", "image_height"):
            n = fs.getNode(key)
            if n.empty() or not (n.isInt() or n.isReal()):
                raise ValueError(f"{path}: {key} (pixels) is missing")
            size.append(n.real())
        if not all(s == int(s) > 0 for s in size):
            raise ValueError(f"{path}: image_width and image_height must be positive whole "
                             f"numbers, got {size[0]:g} and {size[1]:g}")
        dname, dnode = _fs_node(fs, _OPENCV_KEYS["dist"])
        dist = None
        if dnode is not None:
            try:
                dist = check_distortion(_fs_array(dnode, dname, path))
            except ValueError as exc:
                raise ValueError(f"{path}: {dname}: {exc}") from None
        rn, rnode = _fs_node(fs, _OPENCV_KEYS["rvec"])
        tn, tnode = _fs_node(fs, _OPENCV_KEYS["tvec"])
        if rnode is None or tnode is None:
            rn, rnode = _fs_node(fs, _OPENCV_KEYS["R"])
            tn, tnode = _fs_node(fs, _OPENCV_KEYS["t"])
        if rnode is None or tnode is None:
            raise ValueError(f"{path}: the ground pose is missing: give rvec and tvec, or R "
                             "and t (world metres, Z up, ground Z = 0)")
        rot = _fs_array(rnode, rn, path)
        t = _fs_array(tnode, tn, path)
    finally:
        fs.release()
    if rot.size == 3:
        rot = cv2.Rodrigues(rot.reshape(3, 1))[0]
    elif rot.size == 9:
        rot = rot.reshape(3, 3)
    else:
        raise ValueError(f"{path}: {rn} must be a Rodrigues vector (3) or a 3x3 rotation, it "
                         f"has {rot.size} values")
    if t.size != 3:
        raise ValueError(f"{path}: {tn} must be 3 numbers, it has {t.size}")
    cam = check_calibration(K, rot, t.ravel(), (int(size[0]), int(size[1])),
                            name=f"calibration {path}")
    if dist is not None and not dist.any():
        dist = None
    return ImportedCalibration(cam, dist, "opencv", None)
