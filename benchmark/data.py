"""Reading and checking a generated dataset directory (the generator's output contract).

A dataset directory holds ``dataset.json`` (config, seed, versions), ``manifest.parquet``
(one row per image; ``manifest.csv`` is the same for eyes) and the images it names.
Everything that can be wrong with one is a :class:`DatasetError` naming the file and the
problem, raised before any long computation starts.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from viewadapt.io.bounded import MAX_INPUT_BYTES, read_json_object

__all__ = ["DatasetError", "Dataset", "load_dataset", "read_image", "read_json", "read_depth_map",
           "manifest_camera", "missing_planned_images",
           "REQUIRED_COLUMNS"]

REQUIRED_COLUMNS = ("path", "kind", "person_id", "scene_id", "instance", "elevation",
                    "elevation_index", "H_window_to_image", "width", "height")
#: the required columns that must hold numbers (the rest hold strings)
NUMERIC_COLUMNS = ("instance", "elevation", "elevation_index", "width", "height")
KINDS = ("person", "background", "frame")
#: the largest JSON file :func:`read_json` reads by default (bytes): 256 MB. It reads a
#: dataset's ``frames_coco.json`` (every frame and every person in one: about 1 KB a frame
#: and 0.7 KB a person) and a ``bench frames`` run's ``detections.json`` (every detection
#: of every frame), both growing with the number of frames; a dataset's ``dataset.json`` is
#: read with :data:`~viewadapt.io.bounded.MAX_INPUT_BYTES`, as ``generate`` reads it
MAX_JSON_BYTES = 256 * 2 ** 20


class DatasetError(ValueError):
    """A dataset directory that cannot be used as it is."""


@dataclass
class Dataset:
    """A loaded dataset: its root, ``dataset.json`` and manifest."""

    root: Path
    config: dict
    manifest: pd.DataFrame
    fingerprint: str = field(default="")

    @property
    def persons(self) -> pd.DataFrame:
        return self.manifest[self.manifest["kind"] == "person"]

    @property
    def backgrounds(self) -> pd.DataFrame:
        return self.manifest[self.manifest["kind"] == "background"]

    @property
    def frames(self) -> pd.DataFrame:
        return self.manifest[self.manifest["kind"] == "frame"]

    @property
    def elevations(self) -> np.ndarray:
        """Sorted elevations (radians) present among the person crops."""
        return np.sort(self.persons["elevation"].unique())

    def elevation_index(self, elevation: float) -> int:
        """Index of the dataset elevation closest to ``elevation``; error if none is close."""
        el = self.elevations
        i = int(np.argmin(np.abs(el - elevation)))
        if abs(el[i] - elevation) > 1e-6:
            have = ", ".join(f"{e:.4f}" for e in el)
            raise DatasetError(f"{self.root}: no crops at elevation {elevation:.4f} rad "
                               f"(the dataset has {have})")
        return i

    def path(self, rel: str) -> Path:
        return self.root / rel


def missing_planned_images(ds: Dataset) -> tuple[int, int] | None:
    """``(missing, planned)`` when the manifest lists fewer images than ``dataset.json``
    plans (``counts.images``: a generation that did not finish, or one shard of several);
    None when it lists them all or the dataset does not say what it plans."""
    counts = ds.config.get("counts") if isinstance(ds.config, dict) else None
    planned = counts.get("images") if isinstance(counts, dict) else None
    if isinstance(planned, bool) or not isinstance(planned, int):
        return None
    missing = planned - len(ds.manifest)
    return (missing, planned) if missing > 0 else None


def manifest_camera(row):
    """The :class:`viewadapt.geometry.Camera` of a manifest row (its ``K``, ``R``, ``t``)."""
    from viewadapt.geometry import Camera

    return Camera(np.array(json.loads(row["K"])), np.array(json.loads(row["R"])),
                  np.array(json.loads(row["t"])), (int(row["width"]), int(row["height"])))


def read_depth_map(root, row) -> np.ndarray:
    """The depth map of a person crop's manifest row (``depth_path``, beside the images).

    Uses the generator's reader (``generator.manifest.read_depth``: arrays only, checked
    shape); a missing or bad file is a :class:`DatasetError` naming it.
    """
    from generator.manifest import read_depth

    rel = row["depth_path"] if isinstance(row, dict) else getattr(row, "depth_path")
    if not rel:
        raise DatasetError(f"{root}: crop {row['path']} has no depth map; rerun "
                           "`viewadapt generate` with the same --out to add them")
    try:
        return read_depth(Path(root) / rel, (int(row["height"]), int(row["width"])))
    except FileNotFoundError:
        raise DatasetError(f"{root}: depth map {rel} is missing (`viewadapt dataset "
                           "verify`)") from None
    except ValueError as exc:
        raise DatasetError(str(exc)) from None


def read_json(path, *, error=ValueError, max_bytes: int = MAX_JSON_BYTES) -> dict:
    """The JSON object in ``path``, read within bounds: a file over ``max_bytes`` (refused
    from its size), nested deeper than :data:`~viewadapt.io.bounded.MAX_JSON_DEPTH`
    (measured before parsing), not UTF-8, not valid JSON or no JSON object raises ``error``
    naming the file (every JSON file the benchmark reads holds an object)."""
    try:
        return read_json_object(path, "JSON file", max_bytes)
    except FileNotFoundError:
        raise
    except ValueError as exc:
        raise error(str(exc)) from None


def _fingerprint(manifest: pd.DataFrame, config: dict) -> str:
    h = hashlib.sha256()
    h.update(json.dumps(config, sort_keys=True, default=str).encode())
    cols = [c for c in ("path", "kind", "person_id", "scene_id", "elevation", "seed")
            if c in manifest.columns]
    h.update(pd.util.hash_pandas_object(manifest[cols], index=False).values.tobytes())
    return h.hexdigest()[:16]


def load_dataset(root, *, check_files: bool = True) -> Dataset:
    """Load and validate a dataset directory.

    Checks: ``dataset.json`` parses; the manifest exists and has the required columns and
    known ``kind`` values; every listed file exists and is not empty (``check_files``);
    person crops come in complete paired views (every elevation for every
    person/scene/instance).
    """
    root = Path(root)
    if not root.is_dir():
        raise DatasetError(f"dataset directory {root} does not exist")
    cfg_path = root / "dataset.json"
    if not cfg_path.is_file():
        raise DatasetError(f"{root} is not a dataset: {cfg_path.name} is missing "
                           "(generate one with `viewadapt generate`)")
    config = read_json(cfg_path, error=DatasetError, max_bytes=MAX_INPUT_BYTES)
    man_path = root / "manifest.parquet"
    if man_path.is_file():
        try:
            manifest = pd.read_parquet(man_path)
        except Exception as exc:  # pyarrow raises several types for a corrupt file
            raise DatasetError(f"{man_path} cannot be read: {exc}") from None
    elif (root / "manifest.csv").is_file():
        manifest = pd.read_csv(root / "manifest.csv", keep_default_na=False)
    else:
        raise DatasetError(f"{root}: manifest.parquet (or manifest.csv) is missing")
    missing = [c for c in REQUIRED_COLUMNS if c not in manifest.columns]
    if missing:
        raise DatasetError(f"{man_path}: missing columns {missing}")
    for col in NUMERIC_COLUMNS:
        c = manifest[col]
        if c.dtype == object:               # manifest.csv: NaN read as ""
            try:
                c = manifest[col] = pd.to_numeric(c.where(c != "", None))
            except (ValueError, TypeError):
                pass
        if not pd.api.types.is_numeric_dtype(c) or pd.api.types.is_bool_dtype(c):
            raise DatasetError(f"{man_path}: column {col!r} must hold numbers, it holds "
                               f"{c.dtype} values such as {c.iloc[0]!r}" if len(c) else
                               f"{man_path}: column {col!r} must hold numbers")
    bad = sorted(set(manifest["kind"]) - set(KINDS))
    if bad:
        raise DatasetError(f"{man_path}: unknown kind values {bad} (expected {KINDS})")
    if manifest["path"].duplicated().any():
        dup = manifest.loc[manifest["path"].duplicated(), "path"].iloc[0]
        raise DatasetError(f"{man_path}: path {dup!r} is listed twice")
    manifest = manifest.reset_index(drop=True)
    for col in ("person_id", "scene_id"):
        manifest[col] = manifest[col].fillna("").astype(str)
    persons = manifest[manifest["kind"] == "person"]
    if len(persons) == 0:
        raise DatasetError(f"{man_path}: no person crops")
    if (persons["person_id"] == "").any():
        raise DatasetError(f"{man_path}: person rows without person_id")
    n_el = persons["elevation_index"].nunique()
    counts = persons.groupby(["person_id", "scene_id", "instance"])["elevation_index"].nunique()
    if (counts != n_el).any():
        k = counts[counts != n_el].index[0]
        raise DatasetError(f"{man_path}: person {k[0]} in scene {k[1]} instance {k[2]} lacks "
                           f"some of the {n_el} elevations (views must be paired)")
    if check_files:
        for rel in manifest["path"]:
            p = root / rel
            if not p.is_file():
                raise DatasetError(f"{root}: image {rel} is listed in the manifest but missing")
            if p.stat().st_size == 0:
                raise DatasetError(f"{root}: image {rel} is empty")
    return Dataset(root, config, manifest, _fingerprint(manifest, config))


def read_image(path) -> np.ndarray:
    """Read an image as uint8 RGB; a missing or corrupt file is a :class:`DatasetError`."""
    import cv2

    img = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if img is None:
        raise DatasetError(f"image {path} is missing or corrupt (cannot be decoded)")
    return np.ascontiguousarray(img[:, :, ::-1])
