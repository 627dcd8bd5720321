"""Files of named arrays and JSON metadata: how models and operators are kept on disk.

A file is an uncompressed ``.npz`` archive (:func:`numpy.savez`) of plain numeric, boolean
or text arrays plus one ``metadata`` entry, a uint8 array of UTF-8 JSON::

    {"format": "viewadapt.operator", "format_version": 7, "viewadapt": "0.1.0", ...}

It is read with ``numpy.load(..., allow_pickle=False)``, and only after its first bytes
show a zip archive, so nothing in it is ever executed (a pickle is refused before it is
opened). Objects are rebuilt from the arrays and metadata by the reader of each format,
from an explicit list of the project's own classes and functions. A file that is not such
an archive, is truncated or corrupt, is of another format or format version, or lacks an
entry, is a one-line ``ValueError`` (:class:`ArrayFileError`) naming the file and what to do.
The metadata is read within bounds (:mod:`viewadapt.io.bounded`): at most
:data:`MAX_METADATA_BYTES`, its stored size checked before it is read, and nested at most
:data:`~viewadapt.io.bounded.MAX_JSON_DEPTH` levels, measured before it is parsed.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from viewadapt.io.bounded import MAX_JSON_DEPTH, size_words, json_depth
from viewadapt.io.files import atomic_path
from viewadapt.version import __version__

__all__ = ["ArrayFileError", "MAX_METADATA_BYTES", "write_array_file", "read_array_file"]

#: the entry that holds the JSON metadata
METADATA_KEY = "metadata"
_ZIP_MAGIC = b"PK\x03\x04"
#: dtype kinds an array file may hold: bool, integers, floats, text (never objects)
_PLAIN_KINDS = "biufU"
#: the largest metadata read (bytes of JSON): 16 MB (a model's or operator's is a few kB)
MAX_METADATA_BYTES = 16 * 2 ** 20
#: room for the ``.npy`` header of the metadata entry above its bytes
_NPY_HEADER_BYTES = 4096


class ArrayFileError(ValueError):
    """A file that is not a readable array file of the expected format (one line)."""


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (tuple, set, frozenset)):
        return list(o)
    return str(o)                  # provenance only (paths and the like): kept as text


def write_array_file(path, fmt: str, version: int, meta: dict, arrays: dict) -> Path:
    """Write ``arrays`` and ``meta`` as an array file of format ``fmt`` (atomically).

    Parameters
    ----------
    path : path
    fmt : str
        Format name, e.g. ``"viewadapt.operator"``.
    version : int
        Format version: readers refuse any other.
    meta : dict
        JSON-ready metadata (NumPy scalars and arrays become numbers and lists, anything
        else unknown to JSON its text).
    arrays : dict str -> array_like
        Plain arrays (no object dtype).

    Returns
    -------
    Path of the file written.
    """
    path = Path(path)
    head = {"format": fmt, "format_version": int(version), "viewadapt": __version__}
    blob = json.dumps({**head, **meta}, default=_json_default).encode()
    out = {}
    for k, a in arrays.items():
        a = np.asarray(a)
        if a.dtype.kind not in _PLAIN_KINDS or k == METADATA_KEY:
            raise ValueError(f"array {k!r} of dtype {a.dtype} cannot be stored in an array file")
        out[k] = a
    out[METADATA_KEY] = np.frombuffer(blob, np.uint8)
    with atomic_path(path) as tmp:               # an interrupted write leaves no half a file
        with open(tmp, "wb") as fh:
            np.savez(fh, **out)
            fh.flush()
            os.fsync(fh.fileno())
    return path


def read_array_file(path, fmt: str, version: int, *, remedy: str):
    """Read an array file of format ``fmt`` and version ``version``: ``(meta, arrays)``.

    ``remedy`` (what the user should do, e.g. "write it again with ...") ends every error
    message. Raises :class:`ArrayFileError` for a file that is not a zip archive (a pickle
    included: it is never opened), is truncated or corrupt, lacks its metadata, or is of
    another format or version; ``FileNotFoundError`` for a missing file.
    """
    p = Path(path)
    with open(p, "rb") as fh:               # closed here whatever np.load does
        magic = fh.read(4)
        if magic != _ZIP_MAGIC:
            what = ("a pickle, which this version never loads" if magic[:1] == b"\x80"
                    else "not an .npz archive")
            raise ArrayFileError(f"{p} is not a {fmt} file ({what}): {remedy}")
        fh.seek(0)
        try:
            with np.load(fh, allow_pickle=False) as z:
                stored = _stored_size(z, METADATA_KEY)
                if stored > MAX_METADATA_BYTES + _NPY_HEADER_BYTES:
                    arrays = None                 # refused below, before it is read
                else:
                    arrays = {k: z[k] for k in z.files}
        except Exception:  # noqa: BLE001 - zip, npy-header and I/O errors of a damaged file
            raise ArrayFileError(f"{p} cannot be read (truncated, corrupt, or holding "
                                 f"pickled objects): {remedy}") from None
    if arrays is None:
        raise ArrayFileError(f"{p} has no readable metadata ({size_words(stored)} is over "
                             f"the {size_words(MAX_METADATA_BYTES)} it may have): {remedy}")
    if not all(isinstance(a, np.ndarray) for a in arrays.values()):
        raise ArrayFileError(f"{p} cannot be read (an entry is not an array): {remedy}")
    meta = _read_metadata(p, arrays.pop(METADATA_KEY, None), remedy)
    if meta.get("format") != fmt:
        raise ArrayFileError(f"{p} holds {meta.get('format')!r}, not {fmt!r}: {remedy}")
    if meta.get("format_version") != version:
        raise ArrayFileError(f"{p} is {fmt} format version {meta.get('format_version')!r} "
                             f"(written by viewadapt {meta.get('viewadapt')}); this version "
                             f"reads version {version}: {remedy}")
    return meta, arrays


def _stored_size(z, key: str) -> int:
    """The size (bytes, uncompressed) the archive of ``np.load`` ``z`` records for the
    entry ``key`` (0 if absent), read from its directory: nothing of the entry is read."""
    for name in (key + ".npy", key):
        try:
            return int(z.zip.getinfo(name).file_size)
        except KeyError:
            continue
    return 0


def _read_metadata(p: Path, raw, remedy: str) -> dict:
    """The metadata dict of ``p`` from its ``uint8`` entry ``raw``, within the bounds:
    :data:`MAX_METADATA_BYTES` and :data:`~viewadapt.io.bounded.MAX_JSON_DEPTH` levels (the
    depth measured before parsing, so no ``RecursionError``); else one-line
    :class:`ArrayFileError`."""
    def refuse(why=""):
        return ArrayFileError(f"{p} has no readable metadata{f' ({why})' if why else ''}: "
                              f"{remedy}")

    if raw is None or raw.dtype != np.uint8 or raw.ndim != 1:
        raise refuse()
    if raw.nbytes > MAX_METADATA_BYTES:
        raise refuse(f"{size_words(raw.nbytes)} is over the "
                     f"{size_words(MAX_METADATA_BYTES)} it may have")
    try:
        text = raw.tobytes().decode("utf-8")
    except UnicodeDecodeError as exc:
        raise refuse(f"not UTF-8 text, byte {exc.start}") from None
    depth = json_depth(text)
    if depth > MAX_JSON_DEPTH:
        raise refuse(f"JSON nested {depth} levels deep, more than the {MAX_JSON_DEPTH} read")
    try:
        meta = json.loads(text)
    except (ValueError, RecursionError):
        raise refuse("not valid JSON") from None
    if not isinstance(meta, dict):
        raise refuse("not a JSON object")
    return meta
