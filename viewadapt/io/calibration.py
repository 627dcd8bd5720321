"""Camera calibration files, and the ground-point correspondences a calibration is made from.

A calibrated camera is what turns the image search into a search over the ground plane
(Wang et al. 2017, Sec. 5.1); :func:`read_calibration` reads one from the project's YAML or
JSON, a PETS 2009 / Tsai XML or an OpenCV FileStorage file (:mod:`viewadapt.io.imports`),
:func:`read_distortion` its optional lens distortion coefficients;
:func:`read_correspondences` the image <-> ground points ``viewadapt calibrate`` fits a
camera to.
"""

from __future__ import annotations

import csv
import difflib
from pathlib import Path
from typing import NamedTuple

import numpy as np

from viewadapt.camera.checks import check_calibration
from viewadapt.camera.distortion import DISTORTION_SIZES
from viewadapt.geometry import Camera, camera_from_pose
from viewadapt.io.bounded import MAX_CALIBRATION_DEPTH, parse_json, parse_yaml, read_limited_text
from viewadapt.io.imports import (
    ImportedCalibration, calibration_format, read_calibration_text, read_imported_calibration,
)

__all__ = ["CalibrationFile", "read_calibration_file", "read_calibration", "read_distortion",
           "read_correspondences", "CORRESPONDENCE_COLUMNS", "CALIBRATION_KEYS"]


class CalibrationFile(NamedTuple):
    """A calibration file as :func:`read_calibration_file` reads it.

    Attributes
    ----------
    camera : Camera
    dist : (D,) ndarray or None
        OpenCV lens distortion coefficients of ``camera.K`` (:func:`read_distortion`).
    imported : ImportedCalibration or None
        How another tool's file (Tsai XML, OpenCV FileStorage) was read; None for the
        project's own format.
    """

    camera: Camera
    dist: np.ndarray | None
    imported: ImportedCalibration | None


#: The keys of the project's calibration files, by what reads or writes them: the matrix
#: form, the pose form, the lens (:func:`read_distortion`), and the informational keys
#: ``viewadapt calibrate`` adds (there ``focal`` is ``"estimated"`` or ``"given"``). Any
#: other key is refused, with the closest of these suggested.
CALIBRATION_KEYS = {
    "matrix": ("image_size", "K", "R", "t"),
    "pose": ("image_size", "focal", "principal_point", "height", "tilt", "roll"),
    "lens": ("dist",),
    "written by viewadapt calibrate": ("reprojection_error_px", "camera_height_m", "tilt_deg",
                                       "focal", "correspondences"),
}


def read_calibration(path) -> Camera:
    """A camera from a calibration file: the project's YAML or JSON, or another tool's.

    Other tools' files (:func:`~viewadapt.io.imports.calibration_format` tells them apart:
    an ``.xml`` by its root element, YAML or JSON by OpenCV's ``%YAML:`` header or
    ``opencv-matrix`` types): a PETS 2009 / Tsai XML
    (:func:`~viewadapt.io.imports.read_tsai_calibration`) or an OpenCV FileStorage YAML,
    XML or JSON (:func:`~viewadapt.io.imports.read_opencv_calibration`).

    The project's format (either form; lengths in metres, angles in degrees, pixels for focal and
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

    Other keys are not used here: OpenCV lens distortion coefficients ``dist: [k1, k2, p1,
    p2, k3]`` are read by :func:`read_distortion` (``K, R, t`` then describe the
    undistorted frame), and ``viewadapt calibrate`` adds the informational
    ``reprojection_error_px``, ``camera_height_m``, ``tilt_deg``, ``focal`` and
    ``correspondences``. A key that is none of these (:data:`CALIBRATION_KEYS`) is refused,
    naming the closest known one: ``calibration cam.yaml: unknown key 'rol' (did you mean
    'roll'?)``.

    Every file is read within bounds (:mod:`viewadapt.io.bounded`): at most 1 MB (refused
    before it is read), nested at most 16 levels, YAML without anchors or aliases.
    """
    path = Path(path)
    fmt = _format(path)
    if fmt is not None:
        return read_imported_calibration(path, fmt).camera
    return _camera_of(_read_mapping(path), path)


def read_distortion(path) -> np.ndarray | None:
    """The OpenCV lens distortion coefficients of a calibration file, or ``None``.

    The optional key ``dist`` holds 4, 5, 8, 12 or 14 numbers in OpenCV's order ``[k1,
    k2, p1, p2[, k3[, k4, k5, k6[, s1, s2, s3, s4[, tau_x, tau_y]]]]]`` (radial, tangential,
    thin-prism and tilt terms of ``cv2.projectPoints``; a ``1xN`` or ``Nx1`` nested list is
    flattened). The file's ``K`` is the camera matrix the coefficients refer to, and ``K,
    R, t`` describe the undistorted frame (:class:`~viewadapt.camera.distortion.Undistortion`).

    A Tsai or OpenCV FileStorage file gives its own coefficients
    (:func:`~viewadapt.io.imports.read_imported_calibration`: Tsai's lens fitted by
    OpenCV's ``k1, k2, k3``).

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
    fmt = _format(path)
    if fmt is not None:
        return read_imported_calibration(path, fmt).dist
    return _dist_of(_read_mapping(path), path)


def read_calibration_file(path) -> CalibrationFile:
    """A calibration file read once: its camera (:func:`read_calibration`), its lens
    (:func:`read_distortion`) and, for another tool's file, how it was imported -- the
    same checks and errors as the two readers, in that order."""
    path = Path(path)
    fmt = _format(path)
    if fmt is not None:
        imported = read_imported_calibration(path, fmt)
        return CalibrationFile(imported.camera, imported.dist, imported)
    d = _read_mapping(path)
    return CalibrationFile(_camera_of(d, path), _dist_of(d, path), None)


def _camera_of(d: dict, path: Path) -> Camera:
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


def _dist_of(d: dict, path: Path) -> np.ndarray | None:
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


def _format(path):
    """:func:`calibration_format`, with the missing file named as a calibration file."""
    if not Path(path).is_file():
        raise FileNotFoundError(f"calibration file {path} does not exist")
    return calibration_format(path)


def _read_mapping(path) -> dict:
    """The parsed YAML or JSON mapping of a calibration file, every key known (one-line
    errors)."""
    path = Path(path)
    text = read_calibration_text(path)
    if path.suffix.lower() == ".json":
        d = parse_json(text, path, MAX_CALIBRATION_DEPTH)
    else:
        d = parse_yaml(text, path, MAX_CALIBRATION_DEPTH)
    if not isinstance(d, dict):
        raise ValueError(f"{path}: expected a mapping with K, R, t or focal, height, tilt")
    _check_keys(d, path)
    return d


def _check_keys(d: dict, path) -> None:
    """Refuse keys not in :data:`CALIBRATION_KEYS`, suggesting the closest known ones."""
    known = list(dict.fromkeys(k for keys in CALIBRATION_KEYS.values() for k in keys))
    unknown = [k for k in d if k not in known]
    if not unknown:
        return
    by_lower = {k.lower(): k for k in known}
    shown, unmatched = [], False
    for key in unknown[:5]:
        close = difflib.get_close_matches(str(key).lower(), list(by_lower), n=1)
        shown.append(f"{str(key)!r}" + (f" (did you mean {by_lower[close[0]]!r}?)" if close
                                        else ""))
        unmatched |= not close
    more = f" and {len(unknown) - 5} more" if len(unknown) > 5 else ""
    msg = (f"calibration {path}: unknown key{'s' if len(unknown) > 1 else ''} "
           f"{', '.join(shown)}{more}")
    if unmatched:
        msg += f" (the keys read are {', '.join(repr(k) for k in known)})"
    raise ValueError(msg)


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


#: Columns of the correspondences CSV: pixels (u, v) and ground metres (X, Y).
CORRESPONDENCE_COLUMNS = ("u", "v", "X", "Y")


def read_correspondences(path) -> tuple[np.ndarray, np.ndarray]:
    """Image <-> ground-plane correspondences from a CSV with columns ``u, v, X, Y``.

    ``u, v`` are pixels (pixel centres at integers), ``X, Y`` metres on the ground plane
    ``Z = 0``; other columns are ignored, spaces around values too, and lines starting
    with ``#`` are comments.

    Returns
    -------
    image_points : (N, 2) ndarray
    ground_points : (N, 2) ndarray

    Raises
    ------
    ValueError
        One line: missing columns, an empty or non-numeric cell, NaN or infinity.
    """
    path = Path(path)
    lines = [ln for ln in read_limited_text(path, "correspondences file").splitlines()
             if ln.strip() and not ln.lstrip().startswith("#")]
    rows = list(csv.reader(lines, skipinitialspace=True))
    if not rows:
        raise ValueError(f"{path}: empty; expected a CSV with the columns u, v, X, Y "
                         "(pixels and metres)")
    header = [c.strip() for c in rows[0]]
    missing = [c for c in CORRESPONDENCE_COLUMNS if c not in header]
    if missing:
        raise ValueError(f"{path}: lacks the column(s) {', '.join(missing)} (need u, v, X, "
                         f"Y: pixels and ground metres; found {', '.join(header) or 'none'})")
    idx = [header.index(c) for c in CORRESPONDENCE_COLUMNS]
    data = np.empty((len(rows) - 1, 4))
    for i, row in enumerate(rows[1:]):
        line = i + 2
        for j, (k, c) in enumerate(zip(idx, CORRESPONDENCE_COLUMNS)):
            cell = row[k].strip() if k < len(row) else ""
            if not cell:
                raise ValueError(f"{path}: row {line} has no value in column {c}")
            try:
                data[i, j] = float(cell)
            except ValueError:
                raise ValueError(f"{path}: row {line}, column {c}: {cell!r} is not a number") \
                    from None
            if not np.isfinite(data[i, j]):
                raise ValueError(f"{path}: row {line}, column {c} is {cell!r}; the values must "
                                 "be finite")
    return data[:, :2].copy(), data[:, 2:].copy()
