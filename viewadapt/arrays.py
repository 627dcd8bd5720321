"""Named arrays: the checked reading of one array, and prefixes that nest one object's
arrays inside another's (how models and operators are turned into plain arrays and back;
the files that hold them are :mod:`viewadapt.io.arrayfile`)."""

from __future__ import annotations

import numpy as np

__all__ = ["stored_array", "with_prefix", "under_prefix", "is_int", "is_json_scalar"]


def stored_array(arrays: dict, key: str, kinds: str, *, ndim=None, shape=None,
                 finite: bool = True) -> np.ndarray:
    """``arrays[key]`` after checking it: present, of a dtype kind in ``kinds`` (``"b"``
    bool, ``"i"``/``"u"`` integers, ``"f"`` floats, ``"U"`` text), of ``ndim`` dimensions
    and of ``shape`` (``None`` entries match any length), and (with ``finite``) without
    NaN or infinite values; ``ValueError`` otherwise."""
    if key not in arrays:
        raise ValueError(f"it lacks the array {key!r}")
    a = arrays[key]
    if a.dtype.kind not in kinds:
        raise ValueError(f"its array {key!r} is of dtype {a.dtype}")
    if ndim is not None and a.ndim != ndim:
        raise ValueError(f"its array {key!r} has {a.ndim} dimensions, not {ndim}")
    if shape is not None and (a.ndim != len(shape) or any(
            s is not None and s != n for s, n in zip(shape, a.shape))):
        raise ValueError(f"its array {key!r} has shape {a.shape}, not {tuple(shape)}")
    if finite and a.dtype.kind == "f" and not np.all(np.isfinite(a)):
        raise ValueError(f"its array {key!r} holds NaN or infinite values")
    return a


def with_prefix(prefix: str, arrays: dict) -> dict:
    """``arrays`` with ``prefix`` before every name (an object's arrays inside another's)."""
    return {prefix + k: v for k, v in arrays.items()}


def under_prefix(prefix: str, arrays: dict) -> dict:
    """The arrays named ``prefix...``, without the prefix (inverse of :func:`with_prefix`)."""
    n = len(prefix)
    return {k[n:]: v for k, v in arrays.items() if k.startswith(prefix)}


def is_int(v) -> bool:
    """An integer (Python or numpy), not a bool."""
    return isinstance(v, (int, np.integer)) and not isinstance(v, bool)


def is_json_scalar(v) -> bool:
    """None, a string, a number or a bool: a value JSON keeps as it is."""
    return v is None or isinstance(v, (str, int, float, bool))
