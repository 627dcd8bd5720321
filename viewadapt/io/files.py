"""Writing outputs safely: atomic files and output folders, output checks, run metadata.

One leaf module (it imports nothing else of the project but the version and the bounded
readers of :mod:`viewadapt.io.bounded`) that the library,
the generator, the benchmark and the command line all use, so every file is written the
same way: into a temporary file or folder beside its destination, moved into place only
when complete. An interrupted or failing run leaves the destination as it was.

Ownership: every output directory the project writes holds a marker file,
:data:`MARKER` (``.viewadapt-output``: JSON with the commands that wrote there and the
files its atomic outputs moved in). A non-empty ``--out`` without it (and without the
``dataset.json`` / ``run.json`` / ``metadata.json`` of an output written before markers
existed) is refused unless ``--overwrite`` is given, and files the project did not write
are never deleted, ``--overwrite`` or not. A marked folder is reused only by the command
that wrote it (or one of :data:`SHARED_OUTPUTS`): a ``bench crossval`` folder is no
``generate`` folder. An output folder never overlaps an input folder
(:func:`check_apart`). While a command writes a folder it holds the folder's lock,
:data:`LOCK` (:mod:`viewadapt.io.locks`).

Files are created with the permissions the process's umask allows (``0o666 & ~umask``,
directories ``0o777 & ~umask``), like any ``open()``, not the 0600 of ``mkstemp``.
"""

from __future__ import annotations

import contextlib
import contextvars
import json
import os
import shutil
import sys
import tempfile
import threading
import time
from pathlib import Path

from viewadapt.io.bounded import MAX_INPUT_BYTES, parse_json, read_limited_text
from viewadapt.version import __version__

__all__ = ["UserError", "RunError", "MARKER", "LOCK", "SHARED_OUTPUTS", "atomic_path",
           "atomic_write_bytes", "atomic_write_text", "atomic_output_dir", "check_output_dir",
           "claim_output_dir", "check_broken_link", "check_apart", "is_project_output",
           "is_lock_file", "read_marker", "write_marker", "clean_stale_partials", "current_command",
           "running_command", "umask", "run_metadata", "FailedRunCleanup", "MAX_MARKER_BYTES"]

#: the marker file in every output directory the project writes
MARKER = ".viewadapt-output"
#: the lock file of an output directory being written (``LOCK.shard-I-of-N`` per shard of a
#: sharded ``generate``); :mod:`viewadapt.io.locks`
LOCK = ".viewadapt-lock"
#: the largest marker, or ``dataset.json`` / ``run.json`` / ``metadata.json`` of an older
#: output, read back to tell whose a folder is (bytes); a larger one is not the project's
MAX_MARKER_BYTES = MAX_INPUT_BYTES
#: groups of commands that write the same kind of folder and may reuse each other's
SHARED_OUTPUTS = (frozenset({"bench crossval", "bench sweep"}),)

#: the command being run (``"bench crossval"``), set by the command line for the markers
_COMMAND: contextvars.ContextVar = contextvars.ContextVar("viewadapt_command", default=None)


class UserError(Exception):
    """A mistake in the command line or its inputs: reported in one line, no traceback."""


class RunError(Exception):
    """A run that failed for a reason outside the user's inputs (a worker died, a disk
    filled): reported in one line saying what was kept, exit code 1."""


# --------------------------------------------------------------------------- permissions

_UMASK_LOCK = threading.Lock()


def umask() -> int:
    """The process's umask (read from ``/proc`` where possible, without changing it)."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    with _UMASK_LOCK:                      # the portable way: set and restore
        mask = os.umask(0o022)
        os.umask(mask)
    return mask


def _file_mode() -> int:
    return 0o666 & ~umask()


def _dir_mode() -> int:
    return 0o777 & ~umask()


# --------------------------------------------------------------------------- atomic files


@contextlib.contextmanager
def atomic_path(path, *, suffix: str = ".tmp"):
    """Yield a temporary path beside ``path``; on a clean exit it replaces ``path``.

    For writers that need a file name (an encoder, a renderer). On an exception the
    temporary file is removed and ``path`` is untouched. The parent folder is created.
    ``suffix`` keeps the extension writers infer the format from (e.g. ``".png"``). The
    file gets the umask's permissions (``0o666 & ~umask``).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        if os.path.exists(tmp):
            os.chmod(tmp, _file_mode())
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


# --------------------------------------------------------------------------- ownership


def current_command() -> str:
    """The command being run, as the markers record it (``"viewadapt"`` outside the CLI)."""
    return _COMMAND.get() or "viewadapt"


@contextlib.contextmanager
def running_command(name: str):
    """Record ``name`` (e.g. ``"bench crossval"``) as the command writing outputs."""
    token = _COMMAND.set(name)
    try:
        yield
    finally:
        _COMMAND.reset(token)


def _read_back(p: Path):
    """The JSON of a file the project wrote into an output folder, or None if it is absent,
    not a regular file (a FIFO is never opened), over :data:`MAX_MARKER_BYTES` (refused
    from its size), nested deeper than :data:`~viewadapt.io.bounded.MAX_JSON_DEPTH`
    (measured before parsing) or not valid UTF-8 JSON: none of these is the project's."""
    try:
        return parse_json(read_limited_text(p, "file", MAX_MARKER_BYTES), p)
    except (OSError, ValueError):
        return None


def read_marker(out) -> dict | None:
    """The marker of an output directory, or None (absent, unreadable or out of bounds:
    :func:`_read_back`)."""
    d = _read_back(Path(out) / MARKER)
    return d if isinstance(d, dict) else None


def _legacy_output(out: Path) -> bool:
    """An output the project wrote before markers existed: a generated dataset's
    ``dataset.json``, or the ``run.json`` / ``metadata.json`` of a command."""
    for name, key in (("dataset.json", "format"), ("run.json", "viewadapt"),
                      ("metadata.json", "viewadapt")):
        d = _read_back(out / name)
        if isinstance(d, dict) and (str(d.get(key, "")).startswith("viewadapt")
                                    if key == "format" else key in d):
            return True
    return False


def is_project_output(out) -> bool:
    """True if ``out`` is a directory the project wrote (marker, or a legacy output)."""
    out = Path(out)
    return out.is_dir() and (read_marker(out) is not None or _legacy_output(out))


def is_lock_file(name: str) -> bool:
    """True for the name of an output folder's lock file (:data:`LOCK`, or a shard's)."""
    return name == LOCK or name.startswith(LOCK + ".shard-")


def _is_empty(out: Path) -> bool:
    return not any(True for p in out.iterdir() if p.name != MARKER and not is_lock_file(p.name))


def _shares_outputs(a: str, b: str) -> bool:
    return a == b or any(a in g and b in g for g in SHARED_OUTPUTS)


def _check_writer(out: Path, command: str) -> None:
    """Refuse a marked folder that another command (not of :data:`SHARED_OUTPUTS`) wrote.
    Outside the command line (``"viewadapt"``) any folder of the project's qualifies, and
    a folder marked from outside it may be used by any command."""
    if command == "viewadapt":
        return
    writers = [c for c in (read_marker(out) or {}).get("commands", []) if isinstance(c, str)]
    if not writers or "viewadapt" in writers:
        return
    if not any(_shares_outputs(c, command) for c in writers):
        raise UserError(f"--out {out} was written by viewadapt {' and '.join(writers)}, not by "
                        f"{command}: a folder is reused only by the command that wrote it; "
                        "choose another --out, or pass --overwrite (files of the same names "
                        "are replaced, no other file is deleted)")


def write_marker(out, command: str | None = None, files=()) -> None:
    """Add ``command`` and ``files`` (relative POSIX paths) to ``out``'s marker."""
    out = Path(out)
    old = read_marker(out) or {}
    commands = sorted(set(old.get("commands", [])) | {command or current_command()})
    listed = sorted(f for f in set(old.get("files", [])) | set(files) if (out / f).exists())
    atomic_write_text(out / MARKER, json.dumps(
        {"written_by": "viewadapt", "viewadapt": __version__, "commands": commands,
         "files": listed}, indent=1) + "\n")


def check_output_dir(out, *, overwrite: bool = False, command: str | None = None) -> None:
    """Fail (:class:`UserError`) before any work if ``out`` cannot become the output
    directory of ``command`` (default: the running command): it or a folder above it is a
    broken symbolic link (:func:`check_broken_link`), it is a file or lies under one, it is
    not writable, a non-empty directory the project did not write, or one another command
    wrote (unless ``overwrite``)."""
    out = Path(out)
    check_broken_link(out)
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out} exists and is not a directory")
    parent = out.parent if not out.exists() else out
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        raise UserError(f"--out {out}: {parent} is a file, not a folder")
    if not os.access(parent, os.W_OK):
        raise UserError(f"--out {out}: {parent} is not writable")
    if (out.is_dir() and not overwrite and not _is_empty(out)
            and not is_project_output(out)):
        raise UserError(f"--out {out} is not empty and was not written by viewadapt (no "
                        f"{MARKER}); choose a new or empty directory, or pass --overwrite "
                        "(files of the same names are replaced, no other file is deleted)")
    if out.is_dir() and not overwrite and not _is_empty(out):
        _check_writer(out, command or current_command())


def check_broken_link(path, option: str = "--out") -> None:
    """Fail (:class:`UserError`) if ``path`` or a folder above it is a symbolic link to
    nothing: nothing can be written through it, and replacing it would lose where it
    pointed. The message names the link and its target (``--out X is a broken symbolic
    link (to Y); remove it or choose another --out``)."""
    path = Path(path)
    for p in (path, *path.parents):
        if p.is_symlink() and not p.exists():
            where = f"{option} {path} is" if p == path else f"{option} {path}: {p} is"
            raise UserError(f"{where} a broken symbolic link (to {os.readlink(p)}); remove it "
                            f"or choose another {option}")


def _inside(a: Path, b: Path) -> bool:
    return a != b and b in a.parents


def check_apart(outputs: dict, inputs: dict) -> None:
    """Fail (:class:`UserError`) if an output folder is an input, lies inside an input
    folder, or holds an input. ``outputs`` and ``inputs`` map an option's name
    (``"--out"``, ``"--data"``) to a path or a list of paths; None is skipped. Paths are
    compared with symbolic links resolved."""
    def paths(d):
        for opt, v in d.items():
            for p in (v if isinstance(v, (list, tuple)) else [v]):
                if p is not None and str(p) != "":
                    yield opt, Path(p), Path(os.path.realpath(p))

    for o_opt, o, ro in paths(outputs):
        for i_opt, i, ri in paths(inputs):
            if ro == ri:
                raise UserError(f"{o_opt} {o} is the {i_opt} folder itself: its outputs would "
                                f"be written into an input; choose another {o_opt}")
            if _inside(ro, ri):
                raise UserError(f"{o_opt} {o} lies inside {i_opt} {i}: its outputs would be "
                                f"written into an input; choose a {o_opt} outside it")
            if _inside(ri, ro):
                raise UserError(f"{i_opt} {i} lies inside {o_opt} {o}: writing there could "
                                f"change an input; choose a {o_opt} that does not hold it")


def claim_output_dir(out, *, overwrite: bool = False, command: str | None = None) -> bool:
    """:func:`check_output_dir`, then create ``out`` and mark it; True if it was created."""
    out = Path(out)
    check_output_dir(out, overwrite=overwrite, command=command)
    created = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    write_marker(out, command)
    return created


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:               # someone else's live process
        return True
    return True


#: a ``.partial-`` folder of the old naming (no pid) this long untouched is stale
_LEGACY_PARTIAL_AGE_S = 24 * 3600


def clean_stale_partials(out) -> list:
    """Remove the ``.<name>.partial-<pid>-*`` folders beside ``out`` whose process is
    gone (left by a killed run); return them. Folders of the old naming (no pid) are
    removed once untouched for a day."""
    out = Path(out)
    gone = []
    if not out.parent.is_dir():
        return gone
    for p in out.parent.glob(f".{out.name}.partial-*"):
        if not p.is_dir():
            continue
        tag = p.name[len(f".{out.name}.partial-"):]
        pid, sep, _ = tag.partition("-")
        if sep and pid.isdigit():
            stale = int(pid) != os.getpid() and not _pid_alive(int(pid))
        else:
            try:
                stale = time.time() - p.stat().st_mtime > _LEGACY_PARTIAL_AGE_S
            except OSError:
                continue
        if stale:
            shutil.rmtree(p, ignore_errors=True)
            gone.append(p)
    return gone


class atomic_output_dir:
    """Write outputs into a temporary folder beside ``out`` and move them in at the end.

    ``with atomic_output_dir(out) as tmp:`` -- everything written under ``tmp`` lands in
    ``out`` (replacing files of the same name) only if the block succeeds; a run that fails
    or is interrupted leaves ``out`` as it was. A folder of ``tmp`` is merged into the
    folder of the same name in ``out``: files the project wrote there before (listed in
    the marker) and not written again are removed, any other file is kept. The marker
    records ``command`` (default: the running command) and the files moved in.
    """

    def __init__(self, out, *, command: str | None = None):
        self.out = Path(out)
        self.command = command

    def __enter__(self) -> Path:
        if self.out.exists() and not self.out.is_dir():
            raise UserError(f"--out {self.out} exists and is not a directory")
        self.out.parent.mkdir(parents=True, exist_ok=True)
        clean_stale_partials(self.out)
        self.tmp = Path(tempfile.mkdtemp(prefix=f".{self.out.name}.partial-{os.getpid()}-",
                                         dir=self.out.parent))
        os.chmod(self.tmp, _dir_mode())
        return self.tmp

    def __exit__(self, exc_type, exc, tb):
        if exc_type is not None:
            shutil.rmtree(self.tmp, ignore_errors=True)
            return False
        try:
            self.out.mkdir(parents=True, exist_ok=True)
            owned = set((read_marker(self.out) or {}).get("files", []))
            written = []
            for item in sorted(self.tmp.iterdir()):
                if item.name == MARKER:
                    continue
                _merge(item, self.out / item.name, item.name, owned, written)
            write_marker(self.out, self.command, written)
        finally:
            shutil.rmtree(self.tmp, ignore_errors=True)
        return False


def _merge(src: Path, dest: Path, rel: str, owned: set, written: list) -> None:
    """Move ``src`` to ``dest``; folders merge (see :class:`atomic_output_dir`)."""
    if src.is_dir() and not src.is_symlink():
        if dest.exists() and not dest.is_dir():
            if rel not in owned:
                raise UserError(f"{dest} is a file the project did not write, where a "
                                "folder of outputs belongs; move it away")
            dest.unlink()
        dest.mkdir(exist_ok=True)
        os.chmod(dest, _dir_mode())
        new = {p.name for p in src.iterdir()}
        for old in list(dest.iterdir()):            # earlier outputs not written again
            r = f"{rel}/{old.name}"
            if old.name in new:
                continue
            if old.is_dir() and not old.is_symlink():
                _remove_owned(old, r, owned)
            elif r in owned:
                old.unlink()
        for p in sorted(src.iterdir()):
            _merge(p, dest / p.name, f"{rel}/{p.name}", owned, written)
        return
    if dest.is_dir() and not dest.is_symlink():
        _remove_owned(dest, rel, owned)
        if dest.exists():
            raise UserError(f"{dest} is a folder holding files the project did not write, "
                            "where an output file belongs; move it away")
    os.replace(src, dest)
    written.append(rel)


def _remove_owned(d: Path, rel: str, owned: set) -> None:
    """Delete the files under ``d`` the project wrote, then folders left empty."""
    for p in list(d.iterdir()):
        r = f"{rel}/{p.name}"
        if p.is_dir() and not p.is_symlink():
            _remove_owned(p, r, owned)
        elif r in owned:
            p.unlink()
    with contextlib.suppress(OSError):
        d.rmdir()


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


def _files_under(d: Path) -> set:
    if not d.is_dir():
        return set()
    return {p.relative_to(d).as_posix() for p in d.rglob("*")
            if p.is_file() and not (p.parent == d and is_lock_file(p.name))}


class FailedRunCleanup:
    """What a failed or interrupted command leaves in its ``--out``.

    Outputs are atomic, so a failing command leaves only what it wrote outside them
    (caches). Empty folders it made go; if it made ``--out`` and left nothing in it, that
    goes too; files it left (cached features or operators, a demo's dataset: a rerun
    reuses them) are kept, named in the error line, and ``--out`` stays marked as the
    project's so a rerun is accepted. ``generate`` is not handled here: its images are
    kept for a resume and it says so itself.
    """

    def __init__(self, out, name: str):
        self.out = Path(out)
        self.name = name
        self.existed = self.out.exists()
        self.before = _files_under(self.out)
        self.dirs_before = ({p for p in self.out.rglob("*") if p.is_dir()}
                            if self.out.is_dir() else set())
        self.marked_before = (self.out / MARKER).is_file()

    def finish(self) -> str:
        """Clean up after a failure; returns what was kept, for the error line."""
        if not self.out.is_dir():
            return "nothing was written"
        made = (p for p in self.out.rglob("*") if p.is_dir() and p not in self.dirs_before)
        for d in sorted(made, key=lambda p: len(p.parts), reverse=True):
            try:
                d.rmdir()                        # only empty folders this run made
            except OSError:
                pass
        new = sorted(_files_under(self.out) - self.before - {MARKER})
        if not new:
            if not self.marked_before:           # the marker this run put there goes too
                (self.out / MARKER).unlink(missing_ok=True)
            if not self.existed:
                try:
                    self.out.rmdir()
                except OSError:
                    pass
                return "nothing was written"
            return f"nothing in {self.out} was changed"
        tops = sorted({f.split("/", 1)[0] + ("/" if "/" in f else "") for f in new})
        write_marker(self.out, self.name)
        return (f"kept {len(new)} file(s) it wrote under {self.out}: {', '.join(tops)}; a "
                "rerun reuses them")
