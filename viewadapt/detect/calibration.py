"""Inputs of the detector on a user's footage: camera calibration files and ground truth.

A calibrated camera is what turns the image search into a search over the ground plane
(Wang et al. 2017, Sec. 5.1); :func:`read_calibration` reads one from YAML or JSON,
:func:`read_distortion` its optional lens distortion coefficients.
:func:`read_boxes` reads optional ground-truth person boxes for evaluation.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..geometry import Camera, camera_from_pose

__all__ = ["read_calibration", "read_distortion", "check_calibration", "read_boxes",
           "read_frame"]


def read_frame(path) -> np.ndarray:
    """A frame as uint8 RGB (M, N, 3); a missing or undecodable file is a ``ValueError``."""
    import cv2

    img = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if img is None:
        raise ValueError(f"frame {path} is missing or cannot be decoded as an image")
    return np.ascontiguousarray(img[:, :, ::-1])


def read_calibration(path) -> Camera:
    """A camera from a YAML or JSON calibration file.

    Format (either form; lengths in metres, angles in degrees, pixels for focal and
    principal point)::

        image_size: [384, 288]        # width, height (required)
        K: [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]
        R: [[...], [...], [...]]      # world -> camera rotation, world Z up, ground Z = 0
        t: [tx, ty, tz]               # x_cam = R X + t (OpenCV convention)

    or::

        image_size: [384, 288]
        focal: 300                    # or [fx, fy]
        principal_point: [191.5, 143.5]   # optional, default the image centre
        height: 4.5                   # camera height above the ground
        tilt: 35                      # degrees below horizontal
        roll: 0                       # optional, degrees

    ``K, R, t`` are checked (:func:`check_calibration`): finite; ``K`` upper-triangular
    with positive focal lengths and its principal point inside the image (a ``K[2, 2]``
    other than 1 is divided out; a skew ``K[0, 1]`` is accepted: it enters the window
    homographies like any other entry of ``K``); ``R`` a rotation (``R R^T = I`` within
    1e-6, re-orthonormalised, ``det R = +1``); ``t`` three numbers; the camera centre
    above the ground plane. Every mistake is a one-line ``ValueError`` naming the field.

    Other keys are ignored here: OpenCV lens distortion coefficients ``dist: [k1, k2, p1,
    p2, k3]`` are read by :func:`read_distortion` (``K, R, t`` then describe the
    undistorted frame), and ``viewadapt calibrate`` adds the informational
    ``reprojection_error_px``, ``camera_height_m`` and ``tilt_deg``.
    """
    path = Path(path)
    d = _read_mapping(path)
    if "image_size" not in d:
        raise ValueError(f"{path}: image_size [width, height] is missing")
    size = _image_size(d["image_size"], path)
    if all(k in d for k in ("K", "R", "t")):
        return check_calibration(d["K"], d["R"], d["t"], size, name=f"calibration {path}")
    if all(k in d for k in ("focal", "height", "tilt")):
        pp = d.get("principal_point", ((size[0] - 1) / 2, (size[1] - 1) / 2))
        tilt = _number(d["tilt"], "tilt", path, "degrees below the horizontal")
        if not 0 <= tilt < 90:              # reported in the degrees the file is written in
            raise ValueError(f"{path}: tilt must lie in [0, 90) degrees below the horizontal, "
                             f"got {tilt:g}")
        height = _number(d["height"], "height", path, "metres above the ground")
        roll = _number(d.get("roll", 0.0), "roll", path, "degrees")
        focal = d["focal"]
        focal = ([_number(f, "focal", path, "pixels") for f in focal]
                 if isinstance(focal, (list, tuple)) else _number(focal, "focal", path, "pixels"))
        return camera_from_pose(focal=focal, principal_point=pp, height=height,
                                tilt=np.radians(tilt), roll=np.radians(roll), image_size=size)
    raise ValueError(f"{path}: give either K, R, t or focal, height, tilt")


#: How many distortion coefficients OpenCV accepts: (k1, k2, p1, p2[, k3[, k4, k5, k6[, s1,
#: s2, s3, s4[, tau_x, tau_y]]]]).
DISTORTION_SIZES = (4, 5, 8, 12, 14)


def read_distortion(path) -> np.ndarray | None:
    """The OpenCV lens distortion coefficients of a calibration file, or ``None``.

    The optional key ``dist`` holds 4, 5, 8, 12 or 14 numbers in OpenCV's order ``[k1,
    k2, p1, p2[, k3[, k4, k5, k6[, s1, s2, s3, s4[, tau_x, tau_y]]]]]`` (radial, tangential,
    thin-prism and tilt terms of ``cv2.projectPoints``; a ``1xN`` or ``Nx1`` nested list is
    flattened). The file's ``K`` is the camera matrix the coefficients refer to, and ``K,
    R, t`` describe the undistorted frame (:class:`~viewadapt.detect.distortion.Undistortion`).

    Returns
    -------
    (D,) float64 ndarray, or ``None`` when ``dist`` is absent, null or all zero.

    Raises
    ------
    ValueError
        One line naming ``dist``: not a list of numbers, a count OpenCV does not accept, or
        non-finite values (and the parse errors of :func:`read_calibration`).
    """
    path = Path(path)
    d = _read_mapping(path)
    value = d.get("dist")
    if value is None:
        return None
    want = ("a list of 4, 5, 8, 12 or 14 numbers (OpenCV's k1, k2, p1, p2[, k3[, k4, k5, "
            "k6[, s1..s4[, tau_x, tau_y]]]])")
    flat = value
    if (isinstance(value, (list, tuple)) and len(value) == 1
            and isinstance(value[0], (list, tuple))):
        flat = value[0]                                     # [[k1, k2, ...]]
    elif (isinstance(value, (list, tuple)) and value
          and all(isinstance(v, (list, tuple)) and len(v) == 1 for v in value)):
        flat = [v[0] for v in value]                        # [[k1], [k2], ...]
    shown = repr(value) if len(repr(value)) <= 80 else repr(value)[:77] + "..."
    try:                                # YAML 1.1 reads "1e-3" (no dot) as a string
        if not isinstance(flat, (list, tuple)) or any(isinstance(v, bool) for v in flat):
            raise TypeError
        a = np.array([float(v) for v in flat], dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"calibration {path}: dist must be {want}, got {shown}") from None
    if len(a) not in DISTORTION_SIZES:
        raise ValueError(f"calibration {path}: dist has {len(a)} coefficients; it must be "
                         f"{want}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"calibration {path}: dist has non-finite values (NaN or infinity)")
    return a if a.any() else None


def _read_mapping(path) -> dict:
    """The parsed YAML or JSON mapping of a calibration file (one-line errors)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"calibration file {path} does not exist")
    text = path.read_text()
    try:
        if path.suffix.lower() == ".json":
            d = json.loads(text)
        else:
            try:
                import yaml
            except ImportError:
                raise ValueError(f"{path}: reading YAML needs PyYAML (pip install pyyaml); "
                                 "or write the calibration as JSON") from None
            d = yaml.safe_load(text)
    except ValueError as exc:
        if "PyYAML" in str(exc):
            raise
        raise ValueError(f"{path} cannot be parsed: {exc}") from None
    except Exception as exc:  # yaml raises its own error types
        raise ValueError(f"{path} cannot be parsed: {exc}") from None
    if not isinstance(d, dict):
        raise ValueError(f"{path}: expected a mapping with K, R, t or focal, height, tilt")
    return d


def _number(value, field, path, unit) -> float:
    """``value`` as a finite float, or a one-line ``ValueError`` naming ``field``."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"calibration {path}: {field} must be a number ({unit}), "
                         f"got {value!r}") from None
    if not np.isfinite(x):
        raise ValueError(f"calibration {path}: {field} must be finite ({unit}), got {value!r}")
    return x


def _image_size(value, path) -> tuple:
    try:
        w, h = (float(v) for v in value)
    except (TypeError, ValueError):
        raise ValueError(f"calibration {path}: image_size must be [width, height] in pixels, "
                         f"got {value!r}") from None
    if not (w == int(w) > 0 and h == int(h) > 0):
        raise ValueError(f"calibration {path}: image_size must be two positive whole "
                         f"numbers of pixels, got {value!r}")
    return int(w), int(h)


def _matrix(value, field, shape, name) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: {field} must be {_shape_words(shape)}") from None
    if a.shape != shape and not (len(shape) == 1 and a.size == shape[0] and a.ndim == 2
                                 and 1 in a.shape):
        raise ValueError(f"{name}: {field} must be {_shape_words(shape)}, got shape "
                         f"{a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: {field} has non-finite values (NaN or infinity)")
    return a.reshape(shape)


def _shape_words(shape) -> str:
    return "a 3x3 matrix of numbers" if len(shape) == 2 else "3 numbers"


def check_calibration(K, R, t, image_size, *, name: str = "calibration") -> Camera:
    """A :class:`~viewadapt.geometry.Camera` from ``K, R, t`` after checking them.

    Parameters
    ----------
    K : (3, 3) array_like
        Intrinsics: finite, upper-triangular (``K[1, 0] = K[2, 0] = K[2, 1] = 0``),
        ``K[2, 2] > 0`` (divided out if not 1), focal lengths ``fx = K[0, 0]`` and
        ``fy = K[1, 1]`` positive, principal point ``(K[0, 2], K[1, 2])`` inside the image
        (``-0.5 .. width - 0.5``, ``-0.5 .. height - 0.5``). The skew ``K[0, 1]`` may be
        non-zero.
    R : (3, 3) array_like
        World-to-camera rotation: ``R R^T = I`` within 1e-6 (then re-orthonormalised to
        the nearest rotation) and ``det R = +1``.
    t : (3,) array_like
        Finite; the camera centre ``-R^T t`` must lie above the ground (``Z > 0``).
    image_size : (width, height)
    name : str
        Starts every error message (e.g. ``"calibration cam.yaml"``).

    Returns
    -------
    Camera

    Raises
    ------
    ValueError
        One line naming the field, e.g. ``"calibration cam.yaml: K has a negative focal
        length (fx = -274)"``.
    """
    w, h = image_size
    K = _matrix(K, "K", (3, 3), name)
    R = _matrix(R, "R", (3, 3), name)
    t = _matrix(t, "t", (3,), name)
    low = {"K[1,0]": K[1, 0], "K[2,0]": K[2, 0], "K[2,1]": K[2, 1]}
    bad = [f"{k} = {v:g}" for k, v in low.items() if v != 0]
    if bad:
        raise ValueError(f"{name}: K must be upper-triangular ({', '.join(bad)}; expected "
                         "[[fx, s, cx], [0, fy, cy], [0, 0, 1]])")
    if K[2, 2] <= 0:
        raise ValueError(f"{name}: K[2,2] must be positive (normally 1), got {K[2, 2]:g}")
    K = K / K[2, 2]
    for f, v in (("fx", K[0, 0]), ("fy", K[1, 1])):
        if v <= 0:
            raise ValueError(f"{name}: K has a {'negative' if v < 0 else 'zero'} focal "
                             f"length ({f} = {v:g})")
    cx, cy = K[0, 2], K[1, 2]
    if not (-0.5 <= cx <= w - 0.5 and -0.5 <= cy <= h - 0.5):
        raise ValueError(f"{name}: K's principal point (cx, cy) = ({cx:g}, {cy:g}) lies "
                         f"outside the {w}x{h} image")
    dev = float(np.abs(R @ R.T - np.eye(3)).max())
    if dev > 1e-6:
        raise ValueError(f"{name}: R is not a rotation (R R^T differs from the identity by "
                         f"{dev:.2g}, more than 1e-6)")
    det = float(np.linalg.det(R))
    if det < 0:
        raise ValueError(f"{name}: R has determinant {det:.3g}, not +1 (a reflection, not a "
                         "rotation)")
    if dev > 1e-12:                             # the nearest rotation (Camera's own
        U, _, Vt = np.linalg.svd(R)             # check allows 1e-8)
        R = U @ Vt
    centre = -R.T @ t
    if centre[2] <= 0:
        raise ValueError(f"{name}: the camera centre -R^T t is at height {centre[2]:g} m, "
                         "at or below the ground plane Z = 0 (world Z is up; check the sign "
                         "of t)")
    return Camera(K, R, t, (int(w), int(h)))


def read_boxes(path, frame_paths) -> dict:
    """Ground-truth person boxes of a user's frames, from CSV or COCO JSON.

    CSV: a header with ``frame, x, y, w, h`` (pixels, top-left corner and size) and
    optionally ``occlusion`` (hidden fraction, 0..1); ``frame`` is the frame's file name or
    path. COCO: ``images`` with ``id`` and ``file_name``, ``annotations`` with ``image_id``
    and ``bbox`` ``[x, y, w, h]`` (and optionally ``occlusion``). Frames are matched by file
    name; a frame without boxes has no persons.

    Returns
    -------
    dict file name -> ((G, 4) boxes, (G,) occlusion)
    """
    import pandas as pd

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"boxes file {path} does not exist")
    names = {Path(p).name for p in frame_paths}
    try:
        if path.suffix.lower() == ".json":
            d = json.loads(path.read_text())
            files = {im["id"]: Path(im["file_name"]).name for im in d["images"]}
            rows = [(files[a["image_id"]], *a["bbox"], float(a.get("occlusion", 0.0)))
                    for a in d["annotations"]]
            df = pd.DataFrame(rows, columns=["frame", "x", "y", "w", "h", "occlusion"])
        else:
            df = pd.read_csv(path)
            missing = {"frame", "x", "y", "w", "h"} - set(df.columns)
            if missing:
                raise ValueError(f"lacks the columns {sorted(missing)} (need frame, x, y, w, h"
                                 "[, occlusion])")
            if "occlusion" not in df.columns:
                df["occlusion"] = 0.0
            df["frame"] = [Path(str(f)).name for f in df["frame"]]
    except (KeyError, TypeError, json.JSONDecodeError, pd.errors.ParserError) as exc:
        raise ValueError(f"{path}: not a boxes CSV or COCO file ({exc})") from None
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    vals = df[["x", "y", "w", "h", "occlusion"]].to_numpy(np.float64)
    if not np.all(np.isfinite(vals)) or (vals[:, 2:4] <= 0).any():
        raise ValueError(f"{path}: boxes need finite x, y and positive w, h")
    if len(df) and not set(df["frame"]) & names:
        raise ValueError(f"{path}: none of its frames ({', '.join(sorted(set(df['frame']))[:3])}"
                         f" ...) is among the frames given")
    out = {}
    for n in names:
        d = df[df["frame"] == n]
        out[n] = (d[["x", "y", "w", "h"]].to_numpy(np.float64).reshape(-1, 4),
                  d["occlusion"].to_numpy(np.float64))
    return out
