"""Writing outputs safely: atomic files and output folders, output checks, run metadata.

One leaf module (it imports nothing else of the project but the version) that the library,
the generator, the benchmark and the command line all use, so every file is written the
same way: into a temporary file or folder beside its destination, moved into place only
when complete. An interrupted or failing run leaves the destination as it was.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

from .version import __version__

__all__ = ["UserError", "atomic_path", "atomic_write_bytes", "atomic_write_text",
           "atomic_output_dir", "check_output_dir", "run_metadata"]


class UserError(Exception):
    """A mistake in the command line or its inputs: reported in one line, no traceback."""


@contextlib.contextmanager
def atomic_path(path, *, suffix: str = ".tmp"):
    """Yield a temporary path beside ``path``; on a clean exit it replaces ``path``.

    For writers that need a file name (an encoder, a renderer). On an exception the
    temporary file is removed and ``path`` is untouched. The parent folder is created.
    ``suffix`` keeps the extension writers infer the format from (e.g. ``".png"``).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def atomic_write_bytes(path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (flushed to disk before the rename)."""
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())


def atomic_write_text(path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    atomic_write_bytes(path, text.encode())


class atomic_output_dir:
    """Write outputs into a temporary folder beside ``out`` and move them in at the end.

    ``with atomic_output_dir(out) as tmp:`` -- everything written under ``tmp`` lands in
    ``out`` (replacing entries of the same name) only if the block succeeds; a run that
    fails or is interrupted leaves ``out`` as it was.
    """

    def __init__(self, out):
        self.out = Path(out)

    def __enter__(self) -> Path:
        if self.out.exists() and not self.out.is_dir():
            raise UserError(f"--out {self.out} exists and is not a directory")
        self.out.parent.mkdir(parents=True, exist_ok=True)
        self.tmp = Path(tempfile.mkdtemp(prefix=f".{self.out.name}.partial-",
                                         dir=self.out.parent))
        return self.tmp

    def __exit__(self, exc_type, exc, tb):
        if exc_type is not None:
            shutil.rmtree(self.tmp, ignore_errors=True)
            return False
        self.out.mkdir(parents=True, exist_ok=True)
        for item in self.tmp.iterdir():
            dest = self.out / item.name
            if dest.is_dir() and not dest.is_symlink():
                shutil.rmtree(dest)
            os.replace(item, dest)
        self.tmp.rmdir()
        return False


def check_output_dir(out) -> None:
    """Fail (:class:`UserError`) before any work if ``out`` cannot become a directory."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out} exists and is not a directory")
    parent = out.parent if not out.exists() else out
    while not parent.exists():
        parent = parent.parent
    if not os.access(parent, os.W_OK):
        raise UserError(f"--out {out}: {parent} is not writable")


def run_metadata(seed=None, **extra) -> dict:
    """What produced an output: versions, the command line, the seed, the time."""
    import cv2
    import numpy as np
    import scipy
    import sklearn

    return {"viewadapt": __version__, "command": sys.argv[1:] if sys.argv else [],
            "seed": seed, "created": time.strftime("%Y-%m-%dT%H:%M:%S"),
            "numpy": np.__version__, "scipy": scipy.__version__, "opencv": cv2.__version__,
            "scikit-learn": sklearn.__version__} | extra
