"""Ground-truth person boxes of a user's frames, and the image regions left out of them.

:func:`read_boxes` reads four formats, chosen by the file's name, else by its content:

* **CSV** (``.csv``): a header with ``frame, x, y, w, h`` (pixels, top-left corner and
  size) and optionally ``occlusion`` (hidden fraction, 0..1) and ``ignore`` (0/1).
* **COCO JSON** (``.json``): ``images`` with ``id`` and ``file_name``, ``annotations``
  with ``image_id`` and ``bbox`` ``[x, y, w, h]`` (optionally ``occlusion``; ``iscrowd``
  or ``ignore`` 1 marks an ignore region). When ``categories`` name a ``person`` (or
  ``pedestrian``), only that category's annotations are read.
* **MOTChallenge** ``gt.txt`` (a ``.txt`` file, or lines of six or more numbers):
  ``frame, id, x, y, w, h[, flag[, ...]]``, ``frame`` 1-based; MOT15 adds the world
  position ``X, Y, Z``, MOT16/17/20 the ``class`` and ``visibility`` (Milan et al. 2016).
* **CAVIAR XML** (``.xml``): ``<frame number="N"><objectlist><object id=...><box xc yc w
  h/>`` (centre and size), frames numbered from 0 (Fisher 2004).

Frames are matched by file name (CSV, COCO) -- by as much of the path the file gives as it
takes to tell images apart when the file names the same file name in several folders (a
COCO file of several cameras' ``frame_0.png``) -- or by number (MOTChallenge, CAVIAR, a CSV
``frame`` that is a whole number): an image whose name (without suffix) ends in the
number, e.g. ``000007.jpg`` for MOTChallenge frame 7; in a video the frame of that index
(MOTChallenge frame ``k`` and COCO image ``id`` ``k`` are the ``k``-th frame, 1-based as
``detect``'s own ``det.txt`` and ``detections_coco.json``; CAVIAR and CSV numbers are
0-based frame indices as in ``detections.csv``).

An *ignored* box is the Caltech protocol's ignore region (Dollár et al. 2012): it is not
counted, and a detection on it is neither a hit nor a false positive.
:func:`read_ignore_regions` reads image polygons whose boxes -- detections and ground truth
alike -- are left out (a box is in a polygon when its bottom-centre is).

Every bad file is a one-line ``ValueError`` naming the file and the line or field; files
over :data:`~viewadapt.io.bounded.MAX_INPUT_BYTES` and JSON nested deeper than
:data:`~viewadapt.io.bounded.MAX_JSON_DEPTH` levels are refused (:mod:`viewadapt.io.bounded`).

References
----------
.. [1] A. Milan, L. Leal-Taixé, I. Reid, S. Roth, K. Schindler, "MOT16: A Benchmark for
   Multi-Object Tracking", arXiv:1603.00831, 2016 (the ``gt.txt`` columns and classes).
.. [2] R. B. Fisher, "The PETS04 Surveillance Ground-Truth Data Sets", IEEE PETS 2004
   (CAVIAR's XML).
.. [3] P. Dollár, C. Wojek, B. Schiele, P. Perona, "Pedestrian Detection: An Evaluation of
   the State of the Art", IEEE TPAMI 34(4), 2012.
"""

from __future__ import annotations

import csv
import re
from collections import Counter
from pathlib import Path, PurePosixPath
from typing import NamedTuple

import numpy as np

from viewadapt.io.bounded import parse_json, parse_xml, read_limited_text

__all__ = ["BOX_FORMATS", "MOT_MIN_VISIBILITY", "MOT_COUNTED_CLASSES", "MOT_IGNORED_CLASSES",
           "FrameBoxes", "boxes_format", "read_boxes", "read_ignore_regions", "frame_number"]

#: The ground-truth formats :func:`read_boxes` reads.
BOX_FORMATS = ("csv", "coco", "mot", "caviar")
#: MOTChallenge boxes less visible than this (column 9, MOT16 on) are ignored.
MOT_MIN_VISIBILITY = 0.25
#: MOT16 classes counted: pedestrian.
MOT_COUNTED_CLASSES = (1,)
#: MOT16 classes ignored, as MOTChallenge's evaluation does: person on vehicle, static
#: person, distractor, reflection. Other classes (vehicles, occluders) are dropped.
MOT_IGNORED_CLASSES = (2, 7, 8, 12)

_NUMBER_AT_END = re.compile(r"(\d+)$")
_MOT_NAMES = ("frame", "id", "x", "y", "w", "h", "flag", "class", "visibility")


class FrameBoxes(NamedTuple):
    """The ground truth of one frame.

    Attributes
    ----------
    boxes : (G, 4) float64 ndarray
        ``x, y, w, h`` in pixels.
    occlusion : (G,) float64 ndarray
        Hidden fraction, 0 where the format gives none.
    ignore : (G,) bool ndarray
        Boxes that are ignore regions (not counted, absorb detections).
    """

    boxes: np.ndarray
    occlusion: np.ndarray
    ignore: np.ndarray

    @classmethod
    def empty(cls) -> "FrameBoxes":
        """A frame without persons."""
        return cls(np.zeros((0, 4)), np.zeros(0), np.zeros(0, dtype=bool))


class _Rows(NamedTuple):
    """What a reader found, per box: the frame among images (a file name, or a number its
    name ends in), the frame of a video (0-based index, or None), ``x, y, w, h,
    occlusion`` and the ignore flag."""

    frames: list
    indices: list
    values: np.ndarray
    ignore: np.ndarray


def frame_number(name) -> int | None:
    """The number a frame's file name (without suffix) ends in, or None
    (``000007.jpg`` -> 7, ``frame_12.png`` -> 12)."""
    m = _NUMBER_AT_END.search(Path(str(name)).stem)
    return int(m.group(1)) if m else None


def boxes_format(path, text: str | None = None) -> str:
    """The format of a ground-truth file (one of :data:`BOX_FORMATS`): by suffix
    (``.csv``, ``.json``, ``.xml``, ``.txt``) or name (``gt.txt``), else by content (JSON,
    XML, lines of numbers, a CSV header)."""
    path = Path(path)
    suffix = path.suffix.lower()
    by_suffix = {".csv": "csv", ".json": "coco", ".xml": "caviar", ".txt": "mot"}
    if suffix in by_suffix:
        return by_suffix[suffix]
    text = read_limited_text(path, "boxes file") if text is None else text
    head = text.lstrip()
    if head.startswith(("{", "[")):
        return "coco"
    if head.startswith("<"):
        return "caviar"
    first = head.split("\n", 1)[0]
    return "mot" if re.match(r"^[-+]?\d", first) else "csv"


def read_boxes(path, frame_paths=None, *, n_frames: int | None = None,
               min_visibility: float = MOT_MIN_VISIBILITY) -> dict:
    """Ground-truth person boxes of a user's frames (see the module for the formats).

    Parameters
    ----------
    path : path
        CSV, COCO JSON, MOTChallenge ``gt.txt`` or CAVIAR XML.
    frame_paths : sequence of paths, or None
        The input's images; None for a video (frames by index).
    n_frames : int, optional
        A video's frame count, to check that the file describes some of its frames.
    min_visibility : float
        MOTChallenge boxes of a lower visibility are ignored.

    Returns
    -------
    dict
        Images: file name -> :class:`FrameBoxes`, for every image (empty for an image
        without boxes). A video: 0-based frame index -> :class:`FrameBoxes` for the frames
        with boxes (any other frame has none).

    Raises
    ------
    ValueError
        One line naming the file and the line or field; also when no frame of the file
        is among the frames given.
    """
    path = Path(path)
    text = read_limited_text(path, "boxes file")
    fmt = boxes_format(path, text)
    reader = {"csv": _read_csv, "coco": _read_coco, "mot": _read_mot,
              "caviar": _read_caviar}[fmt]
    rows = reader(text, path, min_visibility) if fmt == "mot" else reader(text, path)
    if frame_paths is None:
        keys = _video_keys(rows, path)
        if n_frames and keys and min(keys) >= n_frames:
            raise ValueError(f"{path}: none of its frames is among the video's {n_frames} "
                             "frames")
        wanted = sorted(set(keys))
    else:
        keys = _image_keys(rows, [Path(p) for p in frame_paths], path)
        wanted = sorted({Path(p).name for p in frame_paths})
    out = {}
    for k in wanted:
        out[k] = FrameBoxes.empty()
    if not len(keys):
        return out
    key_arr = np.array(keys, dtype=object)
    for k in wanted:
        sel = key_arr == k
        if sel.any():
            v = rows.values[sel]
            out[k] = FrameBoxes(v[:, :4].copy(), v[:, 4].copy(), rows.ignore[sel].copy())
    return out


def _image_keys(rows: _Rows, paths, path) -> list:
    """The image (file name) of each row, or None where no image is it. A row's file name
    with folders matches the image whose path ends in them when the file uses that file
    name in more than one folder, else by its name alone; images that share a file name
    are refused (their boxes could not be told apart)."""
    by_name = {}
    for p in paths:
        other = by_name.setdefault(p.name, p)
        if other != p:
            raise ValueError(f"{path}: the images {other} and {p} have the same file name, "
                             "and boxes are matched to images by name: give images with "
                             "distinct names")
    numbers = {}
    if any(isinstance(f, int) for f in rows.frames):
        for p in paths:
            n = frame_number(p.name)
            if n is None:
                continue
            if n in numbers and numbers[n] != p.name:
                raise ValueError(f"{path} names frames by number, and the images "
                                 f"{numbers[n]} and {p.name} both end in {n}")
            numbers[n] = p.name
    paths_of = [None if isinstance(f, int) else _posix(f) for f in rows.frames]
    named = set(paths_of) - {None}
    folders = Counter(q.name for q in named)    # file name -> distinct paths the file gives it

    def image_of(q):
        p = by_name.get(q.name)
        if p is None or (folders[q.name] > 1
                         and Path(p).absolute().parts[-len(q.parts):] != q.parts):
            return None
        return p.name

    image = {q: image_of(q) for q in named}       # once per distinct name, not per row
    keys = [numbers.get(f) if q is None else image[q] for f, q in zip(rows.frames, paths_of)]
    if rows.frames and all(k is None for k in keys):
        shown = ", ".join(str(f) for f in sorted(set(rows.frames), key=str)[:3])
        raise ValueError(f"{path}: none of its frames ({shown} ...) is among the frames "
                         "given (a frame number matches the image whose name ends in it; a "
                         "file name used in several folders, the image whose path ends in "
                         "that folder)")
    return keys


def _posix(name) -> PurePosixPath:
    """A frame's name in a boxes file as a relative POSIX path (backslashes as slashes, a
    root dropped)."""
    q = PurePosixPath(str(name).replace("\\", "/"))
    return q.relative_to("/") if q.is_absolute() else q


def _video_keys(rows: _Rows, path) -> list:
    for f, i in zip(rows.frames, rows.indices):
        if i is None:
            raise ValueError(f"{path}: frame {f!r} names an image, but the input is a video "
                             "(its frames are matched by number)")
    return list(rows.indices)


def _number(cell, what) -> float:
    """``cell`` as a finite float, or a ``ValueError`` saying ``what`` it is."""
    try:
        x = float(cell)
    except (TypeError, ValueError):
        raise ValueError(f"{what} is not a number ({cell!r})") from None
    if not np.isfinite(x):
        raise ValueError(f"{what} is not finite ({cell!r})")
    return x


def _check_box(x, y, w, h, where) -> None:
    if w <= 0 or h <= 0:
        raise ValueError(f"{where}: the box needs a positive width and height, got w = {w:g}, "
                         f"h = {h:g}")


def _whole(x: float, what, low: int) -> int:
    if x != int(x) or x < low:
        raise ValueError(f"{what} must be a whole number >= {low}, got {x:g}")
    return int(x)


# --------------------------------------------------------------------------- CSV


def _read_csv(text: str, path) -> _Rows:
    lines = [(i + 1, ln) for i, ln in enumerate(text.splitlines())
             if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise ValueError(f"{path}: empty; expected a CSV with the columns frame, x, y, w, h")
    rows = list(csv.reader([ln for _, ln in lines], skipinitialspace=True))
    header = [c.strip() for c in rows[0]]
    missing = [c for c in ("frame", "x", "y", "w", "h") if c not in header]
    if missing:
        raise ValueError(f"{path}: lacks the column(s) {', '.join(missing)} (need frame, x, y, "
                         f"w, h[, occlusion, ignore]; found {', '.join(header) or 'none'})")
    col = {c: header.index(c) for c in ("frame", "x", "y", "w", "h", "occlusion", "ignore")
           if c in header}
    frames, values, ignore = [], [], []
    for (line, _), row in zip(lines[1:], rows[1:]):
        where = f"{path} line {line}"

        def cell(c, default=None):
            k = col.get(c)
            v = row[k].strip() if k is not None and k < len(row) else ""
            if not v:
                if default is not None:
                    return default
                raise ValueError(f"{where}: column {c} is empty")
            return v

        try:
            f = cell("frame")
            frames.append(int(f) if re.fullmatch(r"\d+", f) else f)
            v = [_number(cell(c), f"column {c}") for c in ("x", "y", "w", "h")]
            occ = _number(cell("occlusion", "0"), "column occlusion")
            ign = _number(cell("ignore", "0"), "column ignore")
        except ValueError as exc:
            if str(exc).startswith(where):
                raise
            raise ValueError(f"{where}: {exc}") from None
        if not 0 <= occ <= 1:
            raise ValueError(f"{where}: column occlusion must lie in [0, 1], got {occ:g}")
        if ign not in (0, 1):
            raise ValueError(f"{where}: column ignore must be 0 or 1, got {ign:g}")
        _check_box(*v, where)
        values.append(v + [occ])
        ignore.append(bool(ign))
    return _rows(frames, [f if isinstance(f, int) else None for f in frames], values, ignore)


def _rows(frames, indices, values, ignore) -> _Rows:
    return _Rows(frames, indices, np.array(values, dtype=np.float64).reshape(-1, 5),
                 np.array(ignore, dtype=bool))


# --------------------------------------------------------------------------- COCO


def _read_coco(text: str, path) -> _Rows:
    d = parse_json(text, path)
    if not isinstance(d, dict) or not isinstance(d.get("images"), list) \
            or not isinstance(d.get("annotations"), list):
        raise ValueError(f"{path}: a COCO file needs the lists images and annotations")
    files = {}
    for k, im in enumerate(d["images"]):
        if not isinstance(im, dict) or "id" not in im or "file_name" not in im:
            raise ValueError(f"{path}: images[{k}] needs id and file_name")
        try:
            files[im["id"]] = str(im["file_name"])
        except TypeError:
            raise ValueError(f"{path}: images[{k}]: id must be a number or a string") from None
    person = None
    cats = d.get("categories")
    if isinstance(cats, list):
        person = {c.get("id") for c in cats if isinstance(c, dict)
                  and str(c.get("name", "")).lower() in ("person", "pedestrian")} or None
    frames, indices, values, ignore = [], [], [], []
    for k, a in enumerate(d["annotations"]):
        where = f"{path}: annotations[{k}]"
        if not isinstance(a, dict):
            raise ValueError(f"{where} is not an object")
        if person is not None and a.get("category_id") not in person:
            continue
        try:
            known = a.get("image_id") in files
        except TypeError:
            known = False
        if not known:
            raise ValueError(f"{where}: image_id {a.get('image_id')!r} is not among images")
        b = a.get("bbox")
        if not isinstance(b, list) or len(b) != 4 or any(isinstance(v, bool) for v in b):
            raise ValueError(f"{where}: bbox must be [x, y, w, h], got {b!r}")
        try:
            v = [_number(x, f"bbox {c}") for x, c in zip(b, "xywh")]
            occ = _number(a.get("occlusion", 0.0), "occlusion")
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None
        if not 0 <= occ <= 1:
            raise ValueError(f"{where}: occlusion must lie in [0, 1], got {occ:g}")
        _check_box(*v, where)
        i = a["image_id"]
        frames.append(files[i])
        indices.append(i - 1 if isinstance(i, int) and not isinstance(i, bool) and i >= 1
                       else None)
        values.append(v + [occ])
        ignore.append(bool(a.get("iscrowd", 0)) or bool(a.get("ignore", 0)))
    return _rows(frames, indices, values, ignore)


# --------------------------------------------------------------------------- MOTChallenge


def _read_mot(text: str, path, min_visibility: float) -> _Rows:
    frames, values, ignore = [], [], []
    n_cols = None
    for line, raw in enumerate(text.splitlines(), 1):
        if not raw.strip():
            continue
        cells = [c.strip() for c in raw.strip().rstrip(",").split(",")]
        where = f"{path} line {line}"
        if len(cells) < 6:
            raise ValueError(f"{where}: {len(cells)} columns; a MOTChallenge line has frame, "
                             "id, x, y, w, h[, flag, ...]")
        if n_cols is None:
            n_cols = len(cells)
        elif len(cells) != n_cols:
            raise ValueError(f"{where}: {len(cells)} columns, the lines before have {n_cols}")
        names = _MOT_NAMES if n_cols == 9 else _MOT_NAMES[:7] + ("X", "Y", "Z")
        try:
            v = [_number(c, f"column {names[k] if k < len(names) else k + 1}")
                 for k, c in enumerate(cells)]
            frame = _whole(v[0], "column frame", 1)
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None
        x, y, w, h = v[2:6]
        _check_box(x, y, w, h, where)
        ign = len(v) > 6 and v[6] == 0                          # flag 0: not considered
        if n_cols == 9:                                         # MOT16 on: class, visibility
            cls = v[7]
            if cls in MOT_IGNORED_CLASSES:
                ign = True
            elif cls not in MOT_COUNTED_CLASSES:
                continue
            if not 0 <= v[8] <= 1:
                raise ValueError(f"{where}: column visibility must lie in [0, 1], got "
                                 f"{v[8]:g}")
            ign = ign or v[8] < min_visibility
        frames.append(frame)
        values.append([x, y, w, h, 0.0])
        ignore.append(ign)
    if n_cols is None:
        raise ValueError(f"{path}: empty; expected MOTChallenge lines frame, id, x, y, w, h, "
                         "...")
    return _rows(frames, [f - 1 for f in frames], values, ignore)


# --------------------------------------------------------------------------- CAVIAR


def _read_caviar(text: str, path) -> _Rows:
    root = parse_xml(text, path)
    frame_els = [root] if root.tag == "frame" else root.findall("frame")
    if root.tag not in ("dataset", "frame") or not frame_els:
        raise ValueError(f"{path}: a CAVIAR file has <dataset> with <frame number=...> "
                         f"elements; found <{root.tag}>")
    frames, values, ignore = [], [], []
    for k, fe in enumerate(frame_els):
        try:
            number = _whole(_number(fe.get("number"), "number"), "number", 0)
        except ValueError as exc:
            raise ValueError(f"{path}: <frame> {k + 1}: {exc}") from None
        for j, obj in enumerate(fe.iter("object")):
            where = f"{path}: frame {number}, object {obj.get('id', j + 1)}"
            box = obj.find("box")
            if box is None:
                raise ValueError(f"{where} has no <box>")
            try:
                xc, yc, w, h = (_number(box.get(c), f"box {c}") for c in ("xc", "yc", "w", "h"))
            except ValueError as exc:
                raise ValueError(f"{where}: {exc}") from None
            _check_box(xc, yc, w, h, where)
            frames.append(number)
            values.append([xc - w / 2, yc - h / 2, w, h, 0.0])
            ignore.append(False)
    return _rows(frames, list(frames), values, ignore)


# --------------------------------------------------------------------------- regions


def read_ignore_regions(path) -> list:
    """Image polygons whose boxes are ignored, from ``{"polygons": [[[x, y], ...], ...]}``.

    A box lies in a region when its bottom-centre ``(x + w / 2, y + h)`` does (even-odd
    rule; :func:`viewadapt.detect.evaluation.in_regions`): detections there are dropped
    before matching, ground truth there is ignored.

    Returns
    -------
    list of (N, 2) float64 ndarray
        Each polygon's vertices in pixels, ``N >= 3``.

    Raises
    ------
    ValueError
        One line naming the polygon and point.
    """
    path = Path(path)
    d = parse_json(read_limited_text(path, "ignore regions file"), path)
    if not isinstance(d, dict) or not isinstance(d.get("polygons"), list):
        raise ValueError(f'{path}: expected {{"polygons": [[[x, y], ...], ...]}} (pixels)')
    out = []
    for k, poly in enumerate(d["polygons"]):
        if not isinstance(poly, list) or len(poly) < 3:
            raise ValueError(f"{path}: polygons[{k}] must be a list of at least 3 points "
                             "[x, y]")
        pts = []
        for j, p in enumerate(poly):
            if not isinstance(p, list) or len(p) != 2 or any(isinstance(v, bool) for v in p):
                raise ValueError(f"{path}: polygons[{k}][{j}] must be [x, y], got {p!r}")
            try:
                pts.append([_number(v, f"polygons[{k}][{j}]") for v in p])
            except ValueError as exc:
                raise ValueError(f"{path}: {exc}") from None
        out.append(np.array(pts, dtype=np.float64))
    return out
