"""Ground-truth person boxes of a user's frames, read for evaluation (CSV or COCO JSON)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

__all__ = ["read_boxes"]


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
