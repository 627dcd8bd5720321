"""The dataset directory: manifest rows, part files, depth maps, assembly.

Layout of a dataset directory ``DIR``::

    DIR/dataset.json             config, master seed, versions, spec hashes
    DIR/manifest.parquet         one row per image (and manifest.csv, the same rows)
    DIR/frames_coco.json         COCO annotations of the surveillance frames
    DIR/person/<scene>/<person>_i<instance>_e<elevation_index>.png
    DIR/background/<scene>/bg_i<k>_e<elevation_index>.png
    DIR/frames/<scene>/frame_<k>.png
    DIR/depth/<scene>/<person>_i<instance>_e<elevation_index>.npz
                                 per person crop: the body's depth map (camera z, metres,
                                 NaN off the body) on the crop's pixel grid, from the posed
                                 mesh and the recorded camera (viewadapt.surface)
    DIR/.parts/<unit>.json       per work unit: its manifest rows (written after its images)

Every file is written atomically (:mod:`viewadapt.io.files`: a temporary name beside it, moved
in with ``os.replace``), so a killed run leaves only complete files. The manifest is rebuilt
from the part files at the end of every run, in plan order, so a resumed or sharded run
gives the same manifest as an uninterrupted one. :mod:`generator.verify` checks a dataset
directory.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import numpy as np

from viewadapt.io.bounded import MAX_INPUT_BYTES, parse_json, read_limited_text
from viewadapt.io.files import atomic_write_bytes, atomic_write_text

__all__ = ["MANIFEST_COLUMNS", "INT_COLUMNS", "FLOAT_COLUMNS", "part_path", "read_part",
           "write_part", "png_is_complete", "assemble_manifest", "read_manifest",
           "json_matrix", "versions", "spec_hashes", "write_depth", "read_depth",
           "depth_is_complete", "content_hash", "HASH_EXCLUDED", "DATA_FILES",
           "dataset_files", "MAX_COCO_BYTES", "OPTIONAL_COLUMNS", "manifest_columns"]

#: the largest ``frames_coco.json`` read back (bytes): 256 MB. It lists every frame (about
#: 1 KB each) and every person in one (about 0.7 KB each), growing with ``--frames``; the
#: ``paper`` preset's 26 frames take about 0.1 MB. A part file (one work unit's rows, 1.2-1.7
#: KB each, 21 at most in ``paper``) and ``dataset.json`` (3-4 KB) are read back with
#: :data:`~viewadapt.io.bounded.MAX_INPUT_BYTES`
MAX_COCO_BYTES = 256 * 2 ** 20

#: Column order of manifest.parquet / manifest.csv.
MANIFEST_COLUMNS = [
    "path", "kind", "person_id", "scene_id", "instance", "elevation", "elevation_index",
    "azimuth", "rotation", "ground_x", "ground_y", "pose", "gait_phase", "stature",
    "sun_elevation", "sun_azimuth", "sun_strength", "sun_color", "sky_strength",
    "sky_horizon", "sky_zenith", "area_light_strength", "n_area_lights", "exposure",
    "K", "R", "t", "H_window_to_image", "H_plane_to_image", "box_silhouette", "framing",
    "distance", "person_height", "n_persons", "width", "height", "seed", "render_seed",
    "renderer", "samples", "supersample", "depth_path",
]

#: Columns after :data:`MANIFEST_COLUMNS` that a manifest has only when some row has them:
#: ``camera_effects``, the JSON parameters of the camera effects each image went through
#: (:mod:`generator.camera_effects`; only in datasets made with effects on, so a dataset
#: without them has the manifest, and the content hash, of a generator without effects).
OPTIONAL_COLUMNS = ["camera_effects"]


def manifest_columns(rows: list[dict]) -> list[str]:
    """The columns of a manifest of ``rows``: :data:`MANIFEST_COLUMNS`, then each of
    :data:`OPTIONAL_COLUMNS` some row has."""
    return MANIFEST_COLUMNS + [c for c in OPTIONAL_COLUMNS if any(c in r for r in rows)]


def json_matrix(a) -> str:
    """A matrix/vector as a compact JSON string of nested lists (full float precision)."""
    return json.dumps(np.asarray(a, dtype=np.float64).tolist(), separators=(",", ":"))


def part_path(out, uid: str) -> Path:
    return Path(out) / ".parts" / (uid.replace("/", "__") + ".json")


def write_part(out, uid: str, rows: list[dict], coco: dict | None = None) -> None:
    atomic_write_text(part_path(out, uid), json.dumps({"unit": uid, "rows": rows,
                                                       "coco": coco}))


def read_part(out, uid: str) -> dict | None:
    """The part file of unit ``uid`` (a dict), or None: absent, over
    :data:`~viewadapt.io.bounded.MAX_INPUT_BYTES`, nested deeper than
    :data:`~viewadapt.io.bounded.MAX_JSON_DEPTH` (both refused before parsing), not UTF-8
    JSON, no JSON object or another unit's; the unit is then rendered again."""
    p = part_path(out, uid)
    if not p.is_file():
        return None
    try:
        d = parse_json(read_limited_text(p, "part file", MAX_INPUT_BYTES), p)
    except (ValueError, OSError):
        return None
    return d if isinstance(d, dict) and d.get("unit") == uid else None


_PNG_SIG = b"\x89PNG\r\n\x1a\n"


def png_is_complete(path) -> bool:
    """Cheap check: PNG signature at the start and the IEND chunk at the end."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(8)
            fh.seek(0, os.SEEK_END)
            if fh.tell() < 57:
                return False
            fh.seek(-12, os.SEEK_END)
            tail = fh.read(12)
    except OSError:
        return False
    return head == _PNG_SIG and tail[4:8] == b"IEND"


# --------------------------------------------------------------------------- depth maps


def write_depth(path, depth) -> None:
    """Write a crop's depth map (float32, NaN off the body) atomically as ``.npz``.

    The bytes depend on the values only: numpy's zip entries carry a fixed time stamp."""
    import io

    d = np.asarray(depth, dtype=np.float32)
    if d.ndim != 2:
        raise ValueError(f"a depth map is 2-D, got shape {d.shape}")
    buf = io.BytesIO()
    np.savez_compressed(buf, depth=d)
    atomic_write_bytes(path, buf.getvalue())


def read_depth(path, shape=None) -> np.ndarray:
    """A crop's depth map (float32 (h, w), NaN off the body).

    Raises ``ValueError`` naming the file if it is unreadable, holds anything but one
    float 2-D ``depth`` array (arrays only: nothing is unpickled), has a non-positive
    depth, or its shape differs from ``shape`` (``(height, width)``) when given.
    """
    import zipfile

    try:
        with np.load(path, allow_pickle=False) as z:
            if set(z.files) != {"depth"}:
                raise ValueError(f"{path}: a depth file holds one array 'depth', found "
                                 f"{sorted(z.files)}")
            d = z["depth"]
    except FileNotFoundError:
        raise
    except (OSError, zipfile.BadZipFile, EOFError) as exc:
        raise ValueError(f"{path}: unreadable depth file ({exc})") from None
    if d.ndim != 2 or d.dtype.kind != "f":
        raise ValueError(f"{path}: depth must be a float 2-D array, got {d.dtype} {d.shape}")
    if shape is not None and d.shape != tuple(shape):
        raise ValueError(f"{path}: depth map is {d.shape[1]}x{d.shape[0]}, the crop is "
                         f"{shape[1]}x{shape[0]}")
    finite = d[np.isfinite(d)]
    if np.isinf(d).any() or (finite <= 0).any():
        raise ValueError(f"{path}: depth must be positive or NaN")
    return d


def depth_is_complete(path, shape) -> bool:
    """True if ``path`` holds a valid depth map of ``shape``."""
    try:
        read_depth(path, shape)
    except (ValueError, FileNotFoundError):
        return False
    return True


# --------------------------------------------------------------------------- metadata


def versions() -> dict:
    """Versions of Blender (bpy), anny, torch and viewadapt, without importing bpy/torch."""
    from importlib import metadata

    import viewadapt

    out = {"viewadapt": viewadapt.__version__}
    for dist, key in (("bpy", "blender"), ("anny", "anny"), ("torch", "torch"),
                      ("numpy", "numpy"), ("opencv-python-headless", "opencv"),
                      ("pyrender", "pyrender")):
        try:
            out[key] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            out[key] = None
    return out


def spec_hashes(paths) -> dict:
    """sha256 of each spec file (provenance in dataset.json)."""
    out = {}
    for p in paths:
        p = Path(p)
        if p.is_file():
            out[p.name] = hashlib.sha256(p.read_bytes()).hexdigest()[:16]
    return out


# --------------------------------------------------------------------------- manifest


def assemble_manifest(out, uids: list[str]):
    """Collect the rows of every finished unit (in ``uids`` order) and write the manifest.

    Writes ``manifest.parquet``, ``manifest.csv`` and ``frames_coco.json`` atomically.

    Returns
    -------
    (DataFrame, list of unfinished uids)
    """
    import pandas as pd

    out = Path(out)
    rows, missing = [], []
    coco = {"info": {"description": "viewadapt synthetic surveillance frames",
                     "box_convention": "[x, y, w, h], pixel centres at integer coordinates "
                                       "(the image spans [-0.5, W-0.5])"},
            "categories": [{"id": 1, "name": "person"}], "images": [], "annotations": []}
    for uid in uids:
        part = read_part(out, uid)
        if part is None:
            missing.append(uid)
            continue
        rows += part["rows"]
        if part.get("coco"):
            for img in part["coco"]["images"]:
                img = dict(img, id=len(coco["images"]) + 1)
                coco["images"].append(img)
                for ann in part["coco"]["annotations"]:
                    if ann["file_name"] != img["file_name"]:
                        continue
                    a = {k: v for k, v in ann.items() if k != "file_name"}
                    a.update(id=len(coco["annotations"]) + 1, image_id=img["id"])
                    coco["annotations"].append(a)
    df = pd.DataFrame(rows, columns=manifest_columns(rows))
    df = _typed(df)
    import io

    buf = io.BytesIO()
    df.to_parquet(buf, index=False)
    atomic_write_bytes(out / "manifest.parquet", buf.getvalue())
    atomic_write_text(out / "manifest.csv", df.to_csv(index=False))
    atomic_write_text(out / "frames_coco.json", json.dumps(coco, indent=1))
    return df, missing


#: manifest columns of integers and of floats (the others hold strings)
INT_COLUMNS = ("instance", "elevation_index", "n_area_lights", "n_persons", "width", "height",
               "seed", "render_seed", "samples", "supersample")
FLOAT_COLUMNS = ("elevation", "azimuth", "rotation", "ground_x", "ground_y", "gait_phase",
                 "stature", "sun_elevation", "sun_azimuth", "sun_strength", "sky_strength",
                 "area_light_strength", "exposure", "distance", "person_height")


def _typed(df):
    ints, floats = list(INT_COLUMNS), list(FLOAT_COLUMNS)
    for c in ints:
        df[c] = df[c].astype("int64")
    for c in floats:
        df[c] = df[c].astype("float64")
    for c in set(df.columns) - set(ints) - set(floats):
        df[c] = df[c].fillna("").astype(str)
    return df


def read_manifest(out):
    """The manifest of a dataset directory as a DataFrame."""
    import pandas as pd

    p = Path(out) / "manifest.parquet"
    if not p.is_file():
        raise FileNotFoundError(f"{out}: no manifest.parquet (generation unfinished? run "
                                f"`viewadapt generate` again with the same --out to finish)")
    return pd.read_parquet(p)


# --------------------------------------------------------------------------- content hash

#: the files of a dataset directory besides the images and depth maps its manifest lists
DATA_FILES = ("manifest.parquet", "manifest.csv", "frames_coco.json")
#: files of a dataset directory its content hash leaves out: ``dataset.json`` (it records
#: the hash and the package versions of the machine), the ownership marker and every
#: hidden file or folder (``.parts/``: the per-unit bookkeeping the manifest is assembled
#: from; temporary files; locks), and any file the manifest does not list (a file someone
#: put there is no part of the data; ``dataset verify`` names it). No data file records a
#: time: the PNGs carry no text or time chunks (generator.png); numpy writes the depth
#: files' zip entries with a fixed time stamp.
HASH_EXCLUDED = ("dataset.json", ".*", "files the manifest does not list")


def _inside(rel: str) -> bool:
    """A manifest path naming a data file inside the dataset (relative, no ``..``, not
    hidden)."""
    p = Path(rel)
    return bool(rel) and not p.is_absolute() and not any(
        part == ".." or part.startswith(".") for part in p.parts)


def dataset_files(out, manifest=None) -> list[str]:
    """The data files of a dataset directory (relative POSIX paths, sorted): every image
    and depth map its manifest lists and :data:`DATA_FILES`, those present. ``manifest``:
    the manifest if already read (else read from ``out``; an unreadable one lists none)."""
    out = Path(out)
    if manifest is None:
        try:
            manifest = read_manifest(out)
        except Exception:  # noqa: BLE001 - a missing or unreadable manifest lists nothing
            manifest = None
    listed = set(DATA_FILES)
    if manifest is not None:
        for col in ("path", "depth_path"):
            if col in manifest.columns:
                listed |= {str(v) for v in manifest[col] if isinstance(v, str) and _inside(v)}
    return sorted(rel for rel in listed if (out / rel).is_file())


def content_hash(out, manifest=None) -> dict:
    """The dataset's content hash: sha256 over the sorted ``(relative path, sha256)`` of
    its data files (:func:`dataset_files`: the images and depth maps the manifest lists,
    manifest.parquet/.csv, frames_coco.json; nothing of :data:`HASH_EXCLUDED`). Returns
    ``{"sha256": ..., "n_files": ..., "excludes": ...}``."""
    out = Path(out)
    entries = []
    for rel in dataset_files(out, manifest):
        p = out / rel
        h = hashlib.sha256()
        with open(p, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
        entries.append((rel, h.hexdigest()))
    total = hashlib.sha256()
    for rel, digest in sorted(entries):
        total.update(f"{rel}\0{digest}\n".encode())
    return {"sha256": total.hexdigest(), "n_files": len(entries),
            "excludes": list(HASH_EXCLUDED)}
