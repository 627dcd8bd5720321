"""Snapshots of folders and the micro dataset's settings, shared by the tests that compare
what a command wrote (resumes, extensions, refusals that must leave a folder untouched)."""

import hashlib
from pathlib import Path

#: ``viewadapt generate`` arguments of the micro dataset: the tiny preset cut to 2 persons
#: in 1 scene (pyrender, seed 3), 10 images.
MICRO_ARGV = ["generate", "--preset", "tiny", "--renderer", "pyrender", "--persons", "2",
              "--scenes", "1", "--seed", "3", "--quiet"]


def micro_config(**kw):
    """The micro dataset's generator configuration (``kw`` overrides its fields)."""
    from generator.sampling import preset_config

    return preset_config("tiny", renderer="pyrender", n_persons=2, n_scenes=1, **kw)


def file_bytes(root: Path) -> dict:
    """Relative path -> bytes of every file under ``root`` (hidden ones included)."""
    return {p.relative_to(root).as_posix(): p.read_bytes()
            for p in sorted(Path(root).rglob("*")) if p.is_file()}


def file_hashes(root: Path) -> dict:
    """Relative path -> sha256 of every file under ``root`` (hidden ones included)."""
    return {k: hashlib.sha256(v).hexdigest() for k, v in file_bytes(root).items()}


def tree(root: Path) -> list:
    """Every entry under ``root``, sorted: ``(relative path, bytes)``, ``None`` for folders."""
    return sorted((p.relative_to(root).as_posix(), p.read_bytes() if p.is_file() else None)
                  for p in Path(root).rglob("*"))
