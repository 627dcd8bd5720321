"""``viewadapt dataset verify``: check a dataset directory against its manifest and plan.

The manifest has every column of :data:`generator.manifest.MANIFEST_COLUMNS` with its type;
every row's image exists, is a complete PNG and decodes to the recorded size; every person
crop has its depth map; no file is listed twice; everything ``dataset.json`` plans was
generated (re-planned in numpy by :func:`generator.contents.planned_paths`); every frame is
in ``frames_coco.json``; with ``check_hash``, the content hash recomputed
(:func:`generator.manifest.content_hash`) equals the one ``dataset.json`` records.

Every file anywhere in the tree that the dataset does not hold is named (leftover
temporary files, images the manifest does not list, anything put there): a dataset's files
are ``dataset.json``, the manifest files, ``frames_coco.json``, the images and depth maps
the manifest lists, and its bookkeeping (the ownership marker, a writer's lock, the
``.parts/`` file of each work unit). The content hash covers the data files alone, so a
foreign file never changes it (nor gets into the hash a rerun records), and ``verify``
fails while one is there.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from viewadapt.io.bounded import MAX_INPUT_BYTES, check_json_depth, read_limited_text
from viewadapt.io.files import MARKER, is_lock_file

from .contents import planned_paths, replan
from .manifest import (
    DATA_FILES, FLOAT_COLUMNS, INT_COLUMNS, MANIFEST_COLUMNS, MAX_COCO_BYTES, content_hash,
    part_path, png_is_complete, read_depth, read_manifest,
)
from .png import png_problem

__all__ = ["VerifyReport", "verify_dataset"]


@dataclass
class VerifyReport:
    """What ``dataset verify`` found."""

    directory: str
    n_rows: int = 0
    n_ok: int = 0
    n_planned: int | None = None
    problems: list = field(default_factory=list)     # (path, message)
    #: True when the content hash was recomputed and matches dataset.json's
    hash_ok: bool | None = None

    @property
    def ok(self) -> bool:
        return not self.problems

    def summary(self) -> str:
        head = (f"{self.directory}: {self.n_ok}/{self.n_rows} images OK"
                + (f", {self.n_planned} planned" if self.n_planned is not None else ""))
        if self.hash_ok:
            head += "; content hash matches"
        if self.ok:
            return head + "; no problems found"
        lines = [head + f"; {len(self.problems)} problem(s):"]
        lines += [f"  {p}: {m}" for p, m in self.problems[:200]]
        if len(self.problems) > 200:
            lines.append(f"  ... and {len(self.problems) - 200} more")
        return "\n".join(lines)


def _depth_ok(out: Path, row, rep: VerifyReport) -> bool:
    """Person crops: their depth map is listed, present and of the crop's size."""
    if row.kind != "person":
        return True
    rel = getattr(row, "depth_path", "")
    if not rel:
        rep.problems.append((row.path, "no depth map listed (rerun `viewadapt generate` with "
                                       "the same --out to add them)"))
        return False
    try:
        read_depth(out / rel, (row.height, row.width))
    except FileNotFoundError:
        rep.problems.append((rel, "missing"))
        return False
    except ValueError as exc:
        rep.problems.append((rel, str(exc).split(": ", 1)[-1]))
        return False
    return True


#: the columns the per-row checks read
_ROW_COLUMNS = ("path", "kind", "width", "height", "depth_path")


def _column_problems(df) -> list:
    """(column, problem) for each manifest column that is missing or of the wrong type."""
    import pandas as pd

    out = []
    for c in MANIFEST_COLUMNS:
        if c not in df.columns:
            out.append((c, "missing"))
            continue
        col = df[c]
        if c in INT_COLUMNS:
            ok = pd.api.types.is_integer_dtype(col) and not pd.api.types.is_bool_dtype(col)
            want = "integers"
        elif c in FLOAT_COLUMNS:
            ok = pd.api.types.is_numeric_dtype(col) and not pd.api.types.is_bool_dtype(col)
            want = "numbers"
        else:
            ok = (pd.api.types.is_string_dtype(col) or col.dtype == object) and all(
                isinstance(v, str) for v in col)
            want = "strings"
        if not ok:
            bad = next((v for v in col if not isinstance(v, str)), None) \
                if want == "strings" else col.dtype
            out.append((c, f"must hold {want}, holds {bad!r}" if want == "strings"
                        else f"must hold {want}, holds {bad}"))
    return out


#: the folders of a dataset's images and depth maps
DATA_DIRS = ("person", "background", "frames", "depth")


def _foreign_files(out: Path, df, part_names) -> list:
    """``(relative path, what)`` of every file under ``out`` the dataset does not hold.
    ``df``: the manifest (None: unreadable, so no image or depth map is expected);
    ``part_names``: the ``.parts/`` files expected (None: any ``.json`` there)."""
    expected = {"dataset.json", MARKER, *DATA_FILES}
    if df is not None:
        for col in ("path", "depth_path"):
            if col in df.columns:
                expected |= {v for v in df[col] if isinstance(v, str) and v}
    found = []
    for f in sorted(out.rglob("*")):
        if not f.is_file():
            continue
        rel = f.relative_to(out)
        r = rel.as_posix()
        if r in expected or (len(rel.parts) == 1 and is_lock_file(f.name)):
            continue
        if rel.parts[0] == ".parts" and len(rel.parts) == 2 and (
                r in part_names if part_names is not None else f.suffix == ".json"):
            continue
        if f.name.startswith("."):
            what = "leftover temporary file"
        elif rel.parts[0] in DATA_DIRS and len(rel.parts) > 1:
            what = "not in the manifest"
        else:
            what = "not part of the dataset (viewadapt does not write it; move it away)"
        found.append((r, what))
    return found


def _read_json(path: Path, max_bytes: int):
    """The JSON of a dataset file, read within bounds: over ``max_bytes`` (refused from its
    size), nested deeper than :data:`~viewadapt.io.bounded.MAX_JSON_DEPTH` (measured before
    parsing) or not UTF-8 is a ``ValueError`` naming it; invalid JSON a
    ``json.JSONDecodeError``."""
    text = read_limited_text(path, "file", max_bytes)
    check_json_depth(text, path)
    return json.loads(text)


def verify_dataset(out, *, decode: bool = True, check_plan: bool = True,
                   check_hash: bool = False) -> VerifyReport:
    """Check a dataset directory: the manifest's columns and types; every row's image
    exists and is a complete, intact PNG of the recorded size; no duplicate file; no file
    anywhere that the dataset does not hold; nothing planned is missing; with
    ``check_hash`` the content hash (over the data files alone).
    """
    out = Path(out)
    if not out.is_dir():
        raise FileNotFoundError(f"dataset directory not found: {out}")
    meta_p = out / "dataset.json"
    if not meta_p.is_file():
        raise FileNotFoundError(f"{out}: no dataset.json; not a dataset directory")
    rep = VerifyReport(str(out))
    try:
        meta = _read_json(meta_p, MAX_INPUT_BYTES)
    except json.JSONDecodeError as exc:
        rep.problems.append(("dataset.json", f"unreadable JSON: {exc}"))
        return rep
    except ValueError as exc:                # too large, too deep, not UTF-8
        rep.problems.append(("dataset.json", f"unreadable: {exc}"))
        return rep
    try:
        df = read_manifest(out)
    except FileNotFoundError as exc:
        rep.problems.append(("manifest.parquet", str(exc)))
        df = None
    except Exception as exc:  # noqa: BLE001 - any parquet failure is a finding
        rep.problems.append(("manifest.parquet", f"unreadable: {exc}"))
        df = None
    if df is not None:
        bad_cols = _column_problems(df)
        rep.problems += [(f"manifest.parquet column {c!r}", m) for c, m in bad_cols]
        if {c for c, _ in bad_cols} & set(_ROW_COLUMNS):
            rep.n_rows = len(df)
            rep.problems += _foreign_files(out, None, None)
            return rep                       # the row checks cannot read this manifest
    if df is not None:
        rep.n_rows = len(df)
        dup = df["path"][df["path"].duplicated()]
        for p in dup:
            rep.problems.append((p, "listed twice in the manifest"))
        for row in df.itertuples(index=False):
            f = out / row.path
            if not f.is_file():
                rep.problems.append((row.path, "missing"))
                continue
            if f.stat().st_size == 0:
                rep.problems.append((row.path, "empty file"))
                continue
            if not png_is_complete(f):
                rep.problems.append((row.path, "truncated or not a PNG"))
                continue
            if decode:
                problem = png_problem(f, (row.width, row.height))
                if problem is not None:
                    rep.problems.append((row.path, f"unreadable ({problem})"
                                         if not problem.startswith("size") else problem))
                    continue
            if not _depth_ok(out, row, rep):
                continue
            rep.n_ok += 1
    part_names = None
    if check_plan and df is not None:
        try:
            plan = replan(meta)
            planned = planned_paths(meta, plan)
            part_names = {part_path(out, u.uid).relative_to(out).as_posix()
                          for u in plan.units}
            rep.n_planned = len(planned)
            for p in sorted(set(planned) - set(df["path"])):
                rep.problems.append((p, "planned but not generated"))
        except Exception as exc:  # noqa: BLE001
            rep.problems.append(("dataset.json", f"cannot re-plan the dataset: {exc}"))
    rep.problems += _foreign_files(out, df, part_names)
    coco_p = out / "frames_coco.json"
    if df is not None and (df["kind"] == "frame").any():
        try:
            coco = _read_json(coco_p, MAX_COCO_BYTES)
            names = {im["file_name"] for im in coco["images"]}
            for p in df.loc[df["kind"] == "frame", "path"]:
                if p not in names:
                    rep.problems.append((p, "frame missing from frames_coco.json"))
        except (OSError, ValueError, KeyError, TypeError) as exc:
            # ValueError: invalid JSON, too large, too deep, not UTF-8; TypeError: no
            # object of images with file names
            rep.problems.append(("frames_coco.json", f"unreadable: {exc}"))
    if check_hash:
        recorded = meta.get("content_hash") if isinstance(meta, dict) else None
        want = recorded.get("sha256") if isinstance(recorded, dict) else None
        if not want:
            rep.problems.append(("dataset.json", "records no content hash (generation "
                                                 "unfinished, or made before hashes: rerun "
                                                 "`viewadapt generate` with the same --out)"))
        else:
            got = content_hash(out, df)
            if got["sha256"] != want:
                rep.problems.append(("dataset.json", f"content hash differs: recorded "
                                                     f"{want[:16]}…, the files give "
                                                     f"{got['sha256'][:16]}… ({got['n_files']} "
                                                     "files)"))
            else:
                rep.hash_ok = True
    return rep
