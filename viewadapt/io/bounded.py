"""Reading files from outside with bounds: size, nesting, no YAML aliases, no XML entities.

Every text file a user hands the library (ground truth, ignore regions, calibrations of any
format) is read through these functions, so a crafted or mistaken file costs at most its
size and is refused in one line naming it:

* :func:`read_limited_text` -- the UTF-8 text of a file, refused from its size (``stat``)
  before a byte is read when over ``max_bytes`` (:data:`MAX_INPUT_BYTES` by default; a
  calibration :data:`MAX_CALIBRATION_BYTES`);
* :func:`parse_json` -- JSON nested at most ``max_depth`` levels (:func:`json_depth`,
  measured before parsing, so no ``RecursionError``);
* :func:`parse_yaml` -- YAML through ``yaml.SafeLoader``, with anchors and aliases refused
  (an alias "bomb" expands a few hundred bytes into gigabytes) and nesting bounded as it is
  composed; :func:`check_yaml` applies the same bounds to YAML another reader parses
  (OpenCV's FileStorage);
* :func:`parse_xml` -- XML without a document type (no entities to expand), nested at
  most ``max_depth`` elements.

The depth of a document counts its arrays and objects (mappings and sequences, elements)
from the outermost, so ``{"K": [[1, 0], [0, 1]]}`` is 3 levels deep.
"""

from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

__all__ = ["MAX_INPUT_BYTES", "MAX_JSON_DEPTH", "MAX_CALIBRATION_BYTES",
           "MAX_CALIBRATION_DEPTH", "size_words", "read_limited_text", "json_depth",
           "check_json_depth", "parse_json", "read_json_object", "parse_yaml", "check_yaml",
           "parse_xml"]

#: The largest ground-truth or ignore-region file read (bytes): 50 MB.
MAX_INPUT_BYTES = 50 * 2 ** 20
#: The deepest nesting of JSON arrays and objects read by default.
MAX_JSON_DEPTH = 64
#: The largest calibration file read (bytes): 1 MB (one is a few hundred bytes).
MAX_CALIBRATION_BYTES = 2 ** 20
#: The deepest nesting read in a calibration file (YAML, JSON or XML).
MAX_CALIBRATION_DEPTH = 16

_JSON_STRING = re.compile(r'"(?:[^"\\]|\\.)*"', re.DOTALL)


class _Refused(ValueError):
    """A document outside the bounds (told apart from a parser's own errors)."""


def size_words(n: int) -> str:
    """A byte count as a message says it: ``"16 MB"``, ``"12.5 MB"``, ``"4,096 bytes"``."""
    if n % 2 ** 20 == 0:
        return f"{n // 2 ** 20} MB"
    return f"{n / 2 ** 20:.1f} MB" if n >= 10 * 2 ** 20 else f"{n:,} bytes"


def read_limited_text(path, what: str = "file", max_bytes: int = MAX_INPUT_BYTES) -> str:
    """The text (UTF-8) of ``path``, refused with one line if over ``max_bytes``.

    The size is taken from the file system before anything is read.

    Raises
    ------
    FileNotFoundError
        ``path`` is not a file (``"{what} {path} does not exist"``).
    ValueError
        Over the size limit (``"{path}: 2.0 MB is over the 1 MB a {what} may have"``), or
        not UTF-8 text.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{what} {path} does not exist")
    size = path.stat().st_size
    if size > max_bytes:
        raise ValueError(f"{path}: {size_words(size)} is over the {size_words(max_bytes)} "
                         f"a {what} may have")
    try:
        return path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: not a UTF-8 text file (byte {exc.start})") from None


def json_depth(text: str) -> int:
    """How deep the arrays and objects of the JSON ``text`` nest (strings skipped)."""
    bare = _JSON_STRING.sub('""', text).encode()
    a = np.frombuffer(bare, dtype=np.uint8)
    step = (np.isin(a, (ord("["), ord("{"))).astype(np.int64)
            - np.isin(a, (ord("]"), ord("}"))))
    return int(np.cumsum(step).max()) if len(step) else 0


def check_json_depth(text: str, path, max_depth: int = MAX_JSON_DEPTH) -> None:
    """Refuse (one-line ``ValueError`` naming ``path``) JSON nested deeper than
    ``max_depth`` (:func:`json_depth`), without parsing it."""
    depth = json_depth(text)
    if depth > max_depth:
        raise ValueError(f"{path}: JSON nested {depth} levels deep, more than the "
                         f"{max_depth} read")


def parse_json(text: str, path, max_depth: int = MAX_JSON_DEPTH):
    """``json.loads(text)`` with one-line errors naming ``path``: nesting deeper than
    ``max_depth`` is refused before parsing (:func:`check_json_depth`, so no
    ``RecursionError``)."""
    check_json_depth(text, path, max_depth)
    try:
        return json.loads(text)
    except (ValueError, RecursionError) as exc:
        raise ValueError(f"{path} cannot be parsed: not valid JSON ({exc})") from None


def read_json_object(path, what: str = "JSON file", max_bytes: int = MAX_INPUT_BYTES) -> dict:
    """The JSON object in ``path``, read within bounds (:func:`read_limited_text`, then
    :func:`check_json_depth` before parsing); not valid JSON, or JSON that is no object, is
    a one-line ``ValueError`` naming the file."""
    text = read_limited_text(path, what, max_bytes)
    check_json_depth(text, path)
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path} is not valid JSON: {exc}") from None
    if not isinstance(doc, dict):
        raise ValueError(f"{path}: expected a JSON object, got a {type(doc).__name__}")
    return doc


def _yaml_problem(exc) -> str:
    """A YAML error in one line: the problem and where (``line L, column C``)."""
    problem = getattr(exc, "problem", None)
    mark = getattr(exc, "problem_mark", None)
    if problem and mark is not None:
        context = getattr(exc, "context", None)
        return (f"{context + ': ' if context else ''}{problem} at line {mark.line + 1}, "
                f"column {mark.column + 1}")
    return " ".join(str(exc).split())[:200]


def _bounded_loader(path, max_depth: int):
    """A ``yaml.SafeLoader`` subclass refusing anchors, aliases and nesting deeper than
    ``max_depth`` as it composes (before anything is built or expanded)."""
    import yaml

    class BoundedLoader(yaml.SafeLoader):
        depth = 0

        def compose_node(self, parent, index):
            event = self.peek_event()
            alias = isinstance(event, yaml.AliasEvent)
            if alias or getattr(event, "anchor", None) is not None:
                raise _Refused(f"{path}: YAML anchors and aliases ({'*' if alias else '&'}"
                               f"{event.anchor}, line {event.start_mark.line + 1}) are not "
                               "read; write the values out")
            nests = isinstance(event, (yaml.SequenceStartEvent, yaml.MappingStartEvent))
            if nests:
                self.depth += 1
                if self.depth > max_depth:
                    raise _Refused(f"{path}: YAML nested more than the {max_depth} levels "
                                   f"read (line {event.start_mark.line + 1})")
            try:
                return super().compose_node(parent, index)
            finally:
                if nests:
                    self.depth -= 1

    return BoundedLoader


def parse_yaml(text: str, path, max_depth: int = MAX_JSON_DEPTH):
    """``yaml.safe_load(text)`` within bounds, with one-line errors naming ``path``.

    Anchors (``&a``) and aliases (``*a``, merge keys ``<<: *a``) are refused, and so is
    nesting deeper than ``max_depth``, both while the document is composed: nothing is
    expanded or built first, and there is no ``RecursionError``.

    Raises
    ------
    ValueError
        One line: out of bounds, not valid YAML (the problem, its line and column), or
        PyYAML missing.
    """
    try:
        import yaml
    except ImportError:
        raise ValueError(f"{path}: reading YAML needs PyYAML (pip install pyyaml); or write "
                         "it as JSON") from None
    try:
        return yaml.load(text, Loader=_bounded_loader(path, max_depth))
    except _Refused as exc:
        raise ValueError(str(exc)) from None
    except (yaml.YAMLError, ValueError, TypeError, RecursionError) as exc:
        raise ValueError(f"{path} cannot be parsed: not valid YAML ({_yaml_problem(exc)})") \
            from None


def check_yaml(text: str, path, max_depth: int = MAX_JSON_DEPTH) -> bool:
    """Whether ``text`` is YAML PyYAML reads within the bounds of :func:`parse_yaml`.

    For YAML another parser reads (OpenCV's FileStorage, whose ``%YAML:1.0`` header is
    skipped here and whose tags such as ``!!opencv-matrix`` are composed, never built).

    Returns
    -------
    bool
        True if it was composed within the bounds; False if PyYAML cannot parse it (nothing
        was checked: the caller bounds it another way).

    Raises
    ------
    ValueError
        One line: anchors, aliases or nesting deeper than ``max_depth``.
    """
    import yaml

    lines = text.split("\n")
    for k, line in enumerate(lines):                 # directives, as blank lines
        if not line.startswith("%"):
            break
        lines[k] = ""
    loader = _bounded_loader(path, max_depth)("\n".join(lines))
    try:
        loader.get_single_node()
    except _Refused as exc:
        raise ValueError(str(exc)) from None
    except (yaml.YAMLError, ValueError, RecursionError):
        return False
    finally:
        loader.dispose()
    return True


def parse_xml(text: str, path, max_depth: int | None = None) -> ET.Element:
    """The root element of the XML ``text``; a document type (``<!DOCTYPE``, entity
    declarations) is refused, and so are elements nested deeper than ``max_depth`` (None:
    any depth), found as the text is parsed (it stops there); errors are one line naming
    ``path``."""
    if re.search(r"<!\s*(DOCTYPE|ENTITY)", text, re.IGNORECASE):
        raise ValueError(f"{path}: XML with a document type or entity declarations is not "
                         "read")
    try:
        if max_depth is None:
            return ET.fromstring(text)
        parser = ET.XMLPullParser(events=("start", "end"))
        root, depth, step = None, 0, 2 ** 16
        for k in range(0, max(len(text), 1), step):
            parser.feed(text[k:k + step])
            for event, el in parser.read_events():
                depth += 1 if event == "start" else -1
                root = el if root is None else root
                if depth > max_depth:
                    raise ValueError(f"{path}: XML nested more than the {max_depth} levels "
                                     "read")
        parser.close()
        return root
    except (ET.ParseError, RecursionError) as exc:
        raise ValueError(f"{path}: not well-formed XML ({exc})") from None
