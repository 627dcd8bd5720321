"""One writer per output folder: an advisory lock held while a command writes there.

``with hold_output_dir(out, "bench crossval"):`` takes ``out``'s lock: ``fcntl.flock`` on
the file :data:`viewadapt.io.files.LOCK` inside ``out`` (the folder is created if needed),
which records the holder (pid, host, command, start time). A second process asking for a
held folder gets a one-line :class:`~viewadapt.io.files.UserError` naming the holder and
writes nothing. The kernel drops the lock of a process that dies, so the lock of a killed
run is taken over silently; where ``flock`` is not supported the recorded pid decides (a
pid that is gone, or another host's after a day, no longer holds it).

The lock covers the exact folder, not its sub-folders: a pipeline (``demo``, ``reproduce``)
holds its ``--out`` while its stages hold the folders they write inside it. One process may
take a lock it already holds again (the stages of a pipeline run in its process); the lock
goes when the outermost holder is done -- on success, on an error and on Ctrl-C. The last
holder removes the lock file, and the folder too if the lock made it and it is left empty.

The shards of one ``generate`` (``shard=(i, n)``) write disjoint files into one folder: each
holds the folder's lock shared and the lock of its own shard
(``LOCK.shard-<i>-of-<n>``) exclusively, so shards run side by side, but not two runs of
one shard, nor an unsharded run beside any shard.
"""

from __future__ import annotations

import errno
import json
import os
import socket
import stat
import threading
import time
from pathlib import Path

from .bounded import parse_json, read_limited_text
from .files import LOCK, UserError, umask

__all__ = ["hold_output_dir"]

#: folders this process holds: real path -> [count, [(path, fd), ...], created]
_HELD: dict = {}
_HELD_GUARD = threading.Lock()
#: a lock file of another host, without flock, older than this no longer holds its folder
_FOREIGN_LOCK_AGE_S = 24 * 3600
#: the largest lock file read (bytes; one is a line of about 100): larger records no holder
MAX_LOCK_BYTES = 64 * 2 ** 10


def _flock():
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        return None
    return fcntl


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True
    return True


def _read_info(path: Path) -> dict | None:
    """The holder ``path`` records, or None. A file that is absent, not a regular file,
    over :data:`MAX_LOCK_BYTES` (refused from its size, before it is read), nested deeper
    than :data:`~viewadapt.io.bounded.MAX_JSON_DEPTH` (measured before it is parsed) or not
    valid JSON records no holder, like a corrupt one: never an exception."""
    try:
        d = parse_json(read_limited_text(path, "lock file", MAX_LOCK_BYTES), path)
    except (OSError, ValueError):
        return None
    return d if isinstance(d, dict) and isinstance(d.get("pid"), int) else None


def _describe(info: dict) -> str:
    here = socket.gethostname()
    host = f" on {info['host']}" if info.get("host") not in (None, here) else ""
    started = info.get("started")
    when = ""
    if isinstance(started, (int, float)) and started > 0:
        fmt = "%H:%M:%S" if time.strftime("%Y%m%d", time.localtime(started)) == \
            time.strftime("%Y%m%d") else "%Y-%m-%d %H:%M:%S"
        when = f", started {time.strftime(fmt, time.localtime(started))}"
    return f"viewadapt {info.get('command') or '?'} (pid {info['pid']}{host}{when})"


def _live(info: dict | None) -> bool:
    return info is not None and (info.get("host") != socket.gethostname()
                                 or _pid_alive(info["pid"]))


def _in_use(out: Path, path: Path) -> UserError:
    """The error of a held lock, naming the holder (its record is written just after the
    lock is taken, so a moment is allowed for it; a folder held shared names a shard)."""
    info = None
    for _ in range(40):
        info = _read_info(path)
        if not _live(info) and path.name == LOCK:
            shards = (_read_info(p) for p in sorted(out.glob(LOCK + ".shard-*")))
            info = next((i for i in shards if _live(i)), None)
        if _live(info):
            break
        time.sleep(0.025)
    who = _describe(info) if _live(info) else "another viewadapt run"
    return UserError(f"{out} is in use by {who}; wait for it or choose another --out")


def _stale_by_pid(path: Path) -> bool:
    """Without flock: True if ``path`` records no live holder."""
    info = _read_info(path)
    if info is None or info["pid"] == os.getpid():
        return True
    if info.get("host") != socket.gethostname():
        try:
            return time.time() - path.stat().st_mtime > _FOREIGN_LOCK_AGE_S
        except OSError:
            return True
    return not _pid_alive(info["pid"])


def _not_a_lock(out: Path, path: Path) -> UserError:
    """The error of something else than a regular file where ``out``'s lock file belongs
    (it is neither written through nor removed)."""
    what = ("a symbolic link" if path.is_symlink() else "a folder" if path.is_dir()
            else "not a regular file")
    return UserError(f"{out}: {path.name} is {what}, not a lock file viewadapt wrote; remove "
                     "it or choose another --out")


def _take(out: Path, path: Path, shared: bool, record: dict | None) -> int:
    """Open ``path`` and lock it (shared or exclusive, never waiting); the file descriptor.
    Retries when the file was removed by its last holder between the open and the lock,
    and (shared) for a moment while a shard that ends holds it exclusively to remove it."""
    fcntl = _flock()
    for attempt in range(50):
        try:                                      # a symbolic link is never followed
            fd = os.open(path, os.O_RDWR | os.O_CREAT | getattr(os, "O_CLOEXEC", 0)
                         | getattr(os, "O_NOFOLLOW", 0), 0o666 & ~umask())
        except OSError as exc:
            if path.is_symlink() or path.is_dir() or exc.errno in (errno.ELOOP, errno.EISDIR,
                                                                   errno.ENXIO):
                raise _not_a_lock(out, path) from None
            raise
        try:
            if not stat.S_ISREG(os.fstat(fd).st_mode):
                raise _not_a_lock(out, path)
            if fcntl is not None:
                try:
                    fcntl.flock(fd, (fcntl.LOCK_SH if shared else fcntl.LOCK_EX)
                                | fcntl.LOCK_NB)
                except BlockingIOError:
                    if shared and attempt < 20:
                        os.close(fd)
                        time.sleep(0.02)
                        continue
                    raise _in_use(out, path) from None
                except OSError as exc:
                    if exc.errno not in (errno.ENOLCK, errno.EOPNOTSUPP, errno.ENOSYS,
                                         errno.EINVAL):
                        raise
                    fcntl = None                      # a file system without flock
            if fcntl is None and not shared and not _stale_by_pid(path):
                raise _in_use(out, path)
            st = os.fstat(fd)
            try:
                now = os.stat(path)
            except FileNotFoundError:
                now = None
            if now is None or (now.st_ino, now.st_dev) != (st.st_ino, st.st_dev):
                os.close(fd)                          # removed meanwhile: lock the new one
                continue
            os.ftruncate(fd, 0)                       # a shared holder records no one
            if record is not None:
                os.write(fd, (json.dumps(record) + "\n").encode())
            return fd
        except BaseException:
            try:
                os.close(fd)
            except OSError:
                pass
            raise
    raise UserError(f"{out}: cannot take the lock {path.name} (it keeps being replaced); "
                    "another run is starting or ending there: try again")


def _let_go(path: Path, fd: int, shared: bool) -> None:
    """Release one lock; the file goes if no one else holds it (and it is still ours)."""
    fcntl = _flock()
    try:
        mine = True
        if fcntl is not None and shared:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                mine = False                          # other shards still hold it
        if mine:
            try:
                st, now = os.fstat(fd), os.stat(path)
                if (now.st_ino, now.st_dev) == (st.st_ino, st.st_dev):
                    os.unlink(path)
            except OSError:
                pass
        if fcntl is not None:
            try:
                fcntl.flock(fd, fcntl.LOCK_UN)
            except OSError:                           # a file system without flock
                pass
    finally:
        os.close(fd)


class hold_output_dir:
    """Hold ``out``'s lock for ``command`` (``shard=(i, n)``: one shard of a ``generate``)
    inside a ``with`` block; raises :class:`~viewadapt.io.files.UserError` naming the
    holder when another process holds it. See the module's description."""

    def __init__(self, out, command: str | None = None, *, shard=None):
        self.out = Path(out)
        self.command = command or "viewadapt"
        self.shard = tuple(shard) if shard is not None else None
        self._key = None

    def __enter__(self) -> "hold_output_dir":
        if self.out.exists() and not self.out.is_dir():
            raise UserError(f"--out {self.out} exists and is not a directory")
        key = os.path.realpath(self.out)
        with _HELD_GUARD:
            if key in _HELD:
                _HELD[key][0] += 1
                self._key = key
                return self
            created = not self.out.exists()
            self.out.mkdir(parents=True, exist_ok=True)
            what = self.command
            if self.shard is not None:
                what += f" --shard {self.shard[0]}/{self.shard[1]}"
            record = {"pid": os.getpid(), "host": socket.gethostname(), "command": what,
                      "started": time.time()}
            taken = []
            try:
                if self.shard is None:
                    taken.append((self.out / LOCK, _take(self.out, self.out / LOCK, False,
                                                         record), False))
                else:
                    taken.append((self.out / LOCK, _take(self.out, self.out / LOCK, True,
                                                         None), True))
                    own = self.out / f"{LOCK}.shard-{self.shard[0]}-of-{self.shard[1]}"
                    taken.append((own, _take(self.out, own, False, record), False))
            except BaseException:
                for path, fd, shared in reversed(taken):
                    _let_go(path, fd, shared)
                if created:
                    try:
                        self.out.rmdir()
                    except OSError:
                        pass
                raise
            _HELD[key] = [1, taken, created]
            self._key = key
        return self

    def __exit__(self, exc_type, exc, tb):
        with _HELD_GUARD:
            held = _HELD.get(self._key)
            if held is None:
                return False
            held[0] -= 1
            if held[0] > 0:
                return False
            del _HELD[self._key]
        _, taken, created = held
        for path, fd, shared in reversed(taken):
            _let_go(path, fd, shared)
        if created:
            try:
                self.out.rmdir()                      # made by the lock, left empty
            except OSError:
                pass
        return False
