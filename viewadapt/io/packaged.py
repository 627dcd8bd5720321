"""Data files shipped inside the package (``viewadapt/data``)."""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path

__all__ = ["packaged_path", "read_packaged_json"]


def packaged_path(name: str) -> Path:
    """Path of the file ``name`` in ``viewadapt/data``."""
    return Path(str(resources.files("viewadapt") / "data" / name))


def read_packaged_json(name: str):
    """The JSON document ``viewadapt/data/<name>``."""
    return json.loads(resources.files("viewadapt").joinpath("data", name).read_text())
