"""Datasets derived from a rendered one by replacing some of its images.

The one-off studies under ``docs/results`` that ask what one property of the test persons
does to a detector (their planarity, their vertical scale, the background behind them)
replace the person crops of one view and keep everything else, so that a cross-validation
or sweep on the derived dataset trains the same fold models on the same negatives as on the
original and only the replaced images differ. :func:`derive_dataset` writes such a dataset
(every kept image a symbolic link to the original's); :func:`scale_vertically` is the
resampling the scale studies apply to a crop. :func:`derive_from_source_view` is the
common case: each top-view person crop replaced by an image made from the source-view crop
of the same person, scene and instance (its "twin", :func:`source_view_twins`).
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np

__all__ = ["derive_dataset", "derive_from_source_view", "source_view_twins",
           "scale_vertically"]


def derive_dataset(src, out, note: str, replace) -> int:
    """Write ``out``: the dataset ``src`` with the images ``replace`` gives.

    ``dataset.json`` is ``src``'s with ``"hybrid": note``; the manifests (and
    ``frames_coco.json``) are copied; every image the manifest lists is a symbolic link to
    ``src``'s, except where ``replace(row)`` (``row``: the manifest's row, a named tuple)
    returns an image, written there as PNG instead; ``src``'s ``depth`` and ``frames``
    folders are linked. ``out`` must not exist. Returns how many images were replaced.
    """
    import cv2
    import pandas as pd

    src, out = Path(src), Path(out)
    out.mkdir()
    cfg = json.loads((src / "dataset.json").read_text())
    cfg["hybrid"] = note
    (out / "dataset.json").write_text(json.dumps(cfg, indent=1))
    for f in ("manifest.parquet", "manifest.csv", "frames_coco.json"):
        if (src / f).exists():
            shutil.copy(src / f, out / f)
    n = 0
    for row in pd.read_parquet(src / "manifest.parquet").itertuples():
        dst = out / row.path
        dst.parent.mkdir(parents=True, exist_ok=True)
        img = replace(row)
        if img is None:
            os.symlink(src / row.path, dst)
            continue
        if not cv2.imwrite(str(dst), img):
            raise OSError(f"could not write {dst}")
        n += 1
    for d in ("depth", "frames"):
        if (src / d).exists() and not (out / d).exists():
            os.symlink(src / d, out / d)
    return n


def source_view_twins(src, *, top_elevation: float = np.pi / 4):
    """``twin(row)``: for a manifest row of ``src`` (as :func:`derive_dataset` passes it)
    that is a person crop at the dataset's highest elevation, the manifest row (a
    ``pandas.Series``) of the elevation-0 crop of the same person, scene and instance; None
    for every other row. Raises ``ValueError`` unless that highest elevation is
    ``top_elevation`` radians."""
    import pandas as pd

    persons = pd.read_parquet(Path(src) / "manifest.parquet").query("kind == 'person'")
    top = persons["elevation_index"].max()
    found = persons.loc[persons["elevation_index"] == top, "elevation"]
    if not np.isclose(found, top_elevation).all():
        raise ValueError(f"{src}: the highest elevation is {float(found.iloc[0]):.4f} rad, "
                         f"not {top_elevation:.4f}")
    zero = persons[persons["elevation_index"] == 0].set_index(
        ["person_id", "scene_id", "instance"], drop=False)

    def twin(row):
        if row.kind != "person" or row.elevation_index != top:
            return None
        return zero.loc[(row.person_id, row.scene_id, row.instance)]

    return twin


def derive_from_source_view(src, out, note: str, make, *,
                            top_elevation: float = np.pi / 4) -> int:
    """:func:`derive_dataset` of ``src`` in which every person crop at the highest elevation
    (``top_elevation``, checked) is replaced by ``make(image, twin, row)``: ``image`` the
    elevation-0 crop of the same person, scene and instance as stored (``cv2.imread``,
    ``IMREAD_UNCHANGED``), ``twin`` its manifest row (:func:`source_view_twins`), ``row``
    the replaced crop's. Returns how many crops were replaced."""
    import cv2

    twin_of = source_view_twins(src, top_elevation=top_elevation)

    def replace(row):
        twin = twin_of(row)
        if twin is None:
            return None
        path = Path(src) / twin["path"]
        image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        if image is None:
            raise OSError(f"could not read {path}")
        return make(image, twin, row)

    return derive_dataset(src, out, note, replace)


def scale_vertically(img, k: float, *, centre: float = 63.5, border=None):
    """``img`` scaled vertically by ``k`` about row ``centre`` (the 128-row window's middle):
    ``out(x, y) = img(x, centre + (y - centre) / k)``, bilinear, the same size. For ``k < 1``
    the rows are first smoothed by a vertical Gaussian of sigma ``sqrt(1/k^2 - 1) / 2`` px
    against aliasing (the border reflected). ``border``: OpenCV's border mode for rows read
    beyond the image (default: the nearest row replicated); ``cv2.BORDER_CONSTANT`` reads
    zeros there."""
    import cv2

    if not k > 0:
        raise ValueError(f"the scale must be positive, got {k!r}")
    border = cv2.BORDER_REPLICATE if border is None else border
    if k < 1.0:
        s = np.sqrt(1.0 / k ** 2 - 1.0) / 2.0
        img = cv2.GaussianBlur(img, (1, 2 * int(np.ceil(3 * s)) + 1), sigmaX=1e-3, sigmaY=s,
                               borderType=cv2.BORDER_REFLECT_101)
    M = np.array([[1.0, 0.0, 0.0], [0.0, k, centre * (1.0 - k)]])
    return cv2.warpAffine(img, M, (img.shape[1], img.shape[0]), flags=cv2.INTER_LINEAR,
                          borderMode=border, borderValue=0)
