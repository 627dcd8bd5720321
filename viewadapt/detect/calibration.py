"""Inputs of the detector on a user's footage: camera calibration files and ground truth.

A calibrated camera is what turns the image search into a search over the ground plane
(Wang et al. 2017, Sec. 5.1); :func:`read_calibration` reads one from YAML or JSON.
:func:`read_boxes` reads optional ground-truth person boxes for evaluation.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..geometry import Camera, camera_from_pose

__all__ = ["read_calibration", "read_boxes", "read_frame"]


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
    """
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
    if "image_size" not in d:
        raise ValueError(f"{path}: image_size [width, height] is missing")
    size = tuple(int(v) for v in d["image_size"])
    if all(k in d for k in ("K", "R", "t")):
        return Camera(np.asarray(d["K"], float), np.asarray(d["R"], float),
                      np.asarray(d["t"], float).reshape(-1), size)
    if all(k in d for k in ("focal", "height", "tilt")):
        pp = d.get("principal_point", ((size[0] - 1) / 2, (size[1] - 1) / 2))
        tilt = float(d["tilt"])
        if not 0 <= tilt < 90:              # reported in the degrees the file is written in
            raise ValueError(f"{path}: tilt must lie in [0, 90) degrees below the horizontal, "
                             f"got {tilt:g}")
        return camera_from_pose(focal=d["focal"], principal_point=pp, height=float(d["height"]),
                                tilt=np.radians(tilt),
                                roll=np.radians(float(d.get("roll", 0.0))), image_size=size)
    raise ValueError(f"{path}: give either K, R, t or focal, height, tilt")


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
