"""Reading spec files: typed, validated field access whose errors name the file and field.

:class:`SpecReader` wraps parsed JSON and reads each field with its type and bounds checked;
a field that does not validate raises :class:`SpecError` with ``file: path.to.field:
problem`` (``assets/scenes/shop.json: objects[3].size: expected 3 positive numbers, got
[1, 0]``). :mod:`generator.specs` builds the scene and person specs with it.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from viewadapt.io.bounded import check_json_depth, read_limited_text

__all__ = ["check_field_types", "SpecError", "SpecReader", "read_json", "MAX_SPEC_BYTES"]

#: the largest scene spec or person roster read (bytes): 16 MB. The project's own are
#: 6-49 KB (``assets/persons.json``, 68 persons, is the largest): room for a roster of
#: thousands of persons or a scene of thousands of objects
MAX_SPEC_BYTES = 16 * 2 ** 20


class SpecError(ValueError):
    """A spec file that does not validate; the message names the file and the field."""


class SpecReader:
    """Typed field access that reports ``file: path.to.field: problem``."""

    def __init__(self, data: Any, source: str, path: str = ""):
        self.data, self.source, self.path = data, source, path

    def error(self, field_: str, msg: str) -> SpecError:
        where = f"{self.path}.{field_}" if self.path and field_ else (self.path or field_)
        return SpecError(f"{self.source}: {where}: {msg}")

    def _get(self, key, default, required):
        if not isinstance(self.data, dict):
            raise SpecError(f"{self.source}: {self.path or '<top>'}: expected an object, "
                            f"got {type(self.data).__name__}")
        if key not in self.data:
            if required:
                raise self.error(key, "missing required field")
            return default
        return self.data[key]

    def sub(self, key, required=True) -> "SpecReader | None":
        v = self._get(key, None, required)
        if v is None:
            return None
        return SpecReader(v, self.source, f"{self.path}.{key}" if self.path else key)

    def items(self, key, required=False) -> list["SpecReader"]:
        v = self._get(key, [], required)
        if not isinstance(v, list):
            raise self.error(key, f"expected a list, got {type(v).__name__}")
        base = f"{self.path}.{key}" if self.path else key
        return [SpecReader(x, self.source, f"{base}[{i}]") for i, x in enumerate(v)]

    def str(self, key, default=None, *, choices=None, required=None) -> str:
        required = default is None if required is None else required
        if isinstance(self.data, dict) and key not in self.data and not required:
            return default
        v = self._get(key, default, required)
        if v is None:
            return v
        if not isinstance(v, str) or not v:
            raise self.error(key, f"expected a non-empty string, got {v!r}")
        if choices is not None and v not in choices:
            raise self.error(key, f"{v!r} is not one of {', '.join(choices)}")
        return v

    def bool(self, key, default=None) -> bool:
        v = self._get(key, default, default is None)
        if not isinstance(v, bool):
            raise self.error(key, f"expected true or false, got {v!r}")
        return v

    def num(self, key, default=None, *, lo=-math.inf, hi=math.inf, integer=False,
            required=None) -> float:
        required = default is None if required is None else required
        v = self._get(key, default, required)
        if v is None:
            return v
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise self.error(key, f"expected a number, got {v!r}")
        if integer and int(v) != v:
            raise self.error(key, f"expected an integer, got {v!r}")
        if not lo <= v <= hi:
            raise self.error(key, f"{v!r} is outside [{lo}, {hi}]")
        return int(v) if integer else float(v)

    def vec(self, key, n, default=None, *, lo=-math.inf, hi=math.inf, positive=False,
            required=None) -> tuple[float, ...]:
        required = default is None if required is None else required
        v = self._get(key, default, required)
        if v is None:
            return v
        ok = (isinstance(v, (list, tuple)) and len(v) == n
              and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                      and math.isfinite(x) for x in v))
        if ok and positive:
            ok = all(x > 0 for x in v)
        if ok:
            ok = all(lo <= x <= hi for x in v)
        if not ok:
            what = f"{n} {'positive ' if positive else ''}numbers"
            if lo > -math.inf or hi < math.inf:
                what += f" in [{lo}, {hi}]"
            raise self.error(key, f"expected {what}, got {v!r}")
        return tuple(float(x) for x in v)

    def range(self, key, default=None, *, lo=-math.inf, hi=math.inf) -> tuple[float, float]:
        """A ``[min, max]`` pair (a single number means a fixed value)."""
        v = self._get(key, default, default is None)
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            v = [v, v]
        r = SpecReader({key: v}, self.source, self.path).vec(key, 2, lo=lo, hi=hi)
        if r[0] > r[1]:
            raise self.error(key, f"range minimum exceeds maximum: {list(r)}")
        return r

    def color(self, key, default=None) -> tuple[float, float, float]:
        return self.vec(key, 3, default, lo=0.0, hi=1.0)

    def colors(self, key, default=None) -> tuple[tuple[float, float, float], ...]:
        v = self._get(key, default, default is None)
        if not isinstance(v, list) or not v:
            raise self.error(key, f"expected a non-empty list of RGB colours, got {v!r}")
        out = []
        for i, c in enumerate(v):
            out.append(SpecReader({f"{key}[{i}]": c}, self.source, self.path)
                       .color(f"{key}[{i}]"))
        return tuple(out)

    def check_unknown(self, allowed):
        if isinstance(self.data, dict):
            extra = sorted(set(self.data) - set(allowed) - {"comment", "_comment"})
            if extra:
                raise self.error(extra[0], f"unknown field (allowed: {', '.join(sorted(allowed))})")


def read_json(path) -> Any:
    """The JSON content of a spec file, read within bounds: over :data:`MAX_SPEC_BYTES`
    (refused from its size), nested deeper than :data:`~viewadapt.io.bounded.MAX_JSON_DEPTH`
    (measured before parsing), not UTF-8 or not valid JSON is a ``SpecError`` naming it."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"spec file not found: {path}")
    try:
        text = read_limited_text(path, "spec file", MAX_SPEC_BYTES)
        check_json_depth(text, path)
    except FileNotFoundError:
        raise
    except ValueError as exc:
        raise SpecError(str(exc)) from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise SpecError(f"{path}: not valid JSON: {exc}") from None


def check_field_types(obj, bad) -> None:
    """Each field of a dataclass ``obj`` of the type of its default (a bool, an integer, a
    number, a string; ``elevations`` numbers, ``*_ids`` strings, other tuples two
    integers); ``bad(message)`` raises, naming the field (a config read from a file may
    hold anything, and ``float('steep')`` would not say where it came from)."""
    import dataclasses
    import numbers

    import numpy as np

    def number(v, integer=False):
        return (not isinstance(v, (bool, np.bool_))
                and isinstance(v, numbers.Integral if integer else numbers.Real)
                and (integer or math.isfinite(v)))

    for f in dataclasses.fields(obj):
        v, d = getattr(obj, f.name), f.default
        if isinstance(d, bool):
            ok, want = isinstance(v, bool), "true or false"
        elif isinstance(d, (int, float)):
            integer = isinstance(d, int)
            ok, want = number(v, integer), "an integer" if integer else "a number"
        elif isinstance(d, str):
            ok, want = isinstance(v, str), "a string"
        elif f.name == "elevations":
            ok = isinstance(v, (tuple, list)) and all(number(x) for x in v)
            want = "a list of numbers (radians)"
        elif f.name.endswith("_ids"):
            ok = isinstance(v, (tuple, list)) and all(isinstance(x, str) for x in v)
            want = "a list of ids"
        else:
            ok = (isinstance(v, (tuple, list)) and len(v) == 2
                  and all(number(x, integer=True) for x in v))
            want = "two integers"
        if not ok:
            bad(f"{f.name} must be {want}, got {v!r}")
