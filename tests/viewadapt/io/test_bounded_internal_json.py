"""The JSON the library reads back from folders a user can write is read within bounds:
the metadata of an array file (models, cached operators), an output folder's lock file,
and its marker (or the ``run.json`` / ``dataset.json`` of an older output). Its size is
checked before it is read and its nesting before it is parsed, so a planted or damaged
file is a one-line error naming it -- or, for a lock or a marker, a file that is not the
project's -- never a ``RecursionError``, a ``MemoryError`` or a hang."""

import json
import os
import re
import threading
import zipfile

import numpy as np
import pytest

from viewadapt.io import arrayfile, files, locks
from viewadapt.io.arrayfile import ArrayFileError, read_array_file, write_array_file
from viewadapt.io.files import LOCK, MARKER, UserError, check_output_dir, read_marker
from viewadapt.io.locks import hold_output_dir

FMT, VERSION, REMEDY = "viewadapt.test", 1, "write it again"
#: JSON nested 100,000 levels: beyond what ``json`` can parse (a RecursionError)
ABYSS = "[" * 100_000 + "]" * 100_000


def _nested(depth: int) -> str:
    return "[" * depth + "]" * depth


# ------------------------------------------------------------------ array file metadata


def _array_file(path, meta_bytes: bytes, *, raw_member: bool = False):
    """An array file whose metadata entry holds ``meta_bytes`` exactly (``raw_member``:
    stored as a bare zip member, not a ``.npy`` array)."""
    with open(path, "wb") as fh:
        np.savez(fh, x=np.zeros(3))
    with zipfile.ZipFile(path, "a") as z:
        if raw_member:
            z.writestr(arrayfile.METADATA_KEY, meta_bytes)
        else:
            from io import BytesIO
            buf = BytesIO()
            np.save(buf, np.frombuffer(meta_bytes, np.uint8))
            z.writestr(arrayfile.METADATA_KEY + ".npy", buf.getvalue())
    return path


def _head(extra: str) -> bytes:
    return ('{"format": "%s", "format_version": %d, "x": %s}' % (FMT, VERSION, extra)).encode()


def _refused(path, match):
    with pytest.raises(ArrayFileError, match=match) as err:
        read_array_file(path, FMT, VERSION, remedy=REMEDY)
    msg = str(err.value)
    assert "\n" not in msg and str(path) in msg and msg.endswith(REMEDY), msg
    return msg


def test_a_well_formed_array_file_still_reads(tmp_path):
    p = write_array_file(tmp_path / "ok.npz", FMT, VERSION, {"deep": [[[1]]]}, {"a": [1, 2]})
    meta, arrays = read_array_file(p, FMT, VERSION, remedy=REMEDY)
    assert meta["deep"] == [[[1]]] and arrays["a"].tolist() == [1, 2]
    p = _array_file(tmp_path / "hand.npz", _head(_nested(60)))  # 61 levels: within bounds
    assert read_array_file(p, FMT, VERSION, remedy=REMEDY)[0]["format"] == FMT


def test_metadata_nested_too_deep_is_one_line_naming_the_file(tmp_path):
    p = _array_file(tmp_path / "deep.npz", _head(_nested(199)))           # 200 levels
    msg = _refused(p, "has no readable metadata")
    assert "nested 200 levels deep, more than the 64 read" in msg, msg


def test_metadata_beyond_what_json_parses_is_no_recursion_error(tmp_path):
    p = _array_file(tmp_path / "abyss.npz", _head(ABYSS))
    assert "nested 100001 levels deep" in _refused(p, "has no readable metadata")


@pytest.mark.parametrize("size", [2_000, 20_000])   # read, then refused; refused unread
def test_metadata_over_the_size_limit_is_one_line(size, tmp_path, monkeypatch):
    monkeypatch.setattr(arrayfile, "MAX_METADATA_BYTES", 1_000)
    p = _array_file(tmp_path / "big.npz", _head(json.dumps("y" * size)))
    msg = _refused(p, "has no readable metadata")
    assert re.search(r"[\d,]+ bytes is over the 1,000 bytes it may have", msg), msg


def test_the_size_limit_is_checked_before_the_metadata_is_read(tmp_path, monkeypatch):
    monkeypatch.setattr(arrayfile, "MAX_METADATA_BYTES", 1_000)
    p = _array_file(tmp_path / "big.npz", _head(json.dumps("y" * 100_000)))
    read = []
    real = np.lib.npyio.NpzFile.__getitem__
    monkeypatch.setattr(np.lib.npyio.NpzFile, "__getitem__",
                        lambda self, k: read.append(k) or real(self, k))
    _refused(p, "is over the 1,000 bytes it may have")
    assert arrayfile.METADATA_KEY not in read


def test_metadata_not_utf8_or_not_json_or_not_an_array_is_one_line(tmp_path):
    _refused(_array_file(tmp_path / "latin.npz", _head('"caf\xe9"').decode().encode("latin-1")),
             r"not UTF-8 text, byte \d+")
    _refused(_array_file(tmp_path / "junk.npz", b'{"format": '), "not valid JSON")
    _refused(_array_file(tmp_path / "list.npz", b"[1, 2]"), "not a JSON object")
    _refused(_array_file(tmp_path / "raw.npz", _head("1"), raw_member=True),
             "an entry is not an array")


def test_a_model_file_with_deep_metadata_is_one_line_at_the_model_reader(tmp_path):
    from viewadapt.io import SOURCE_DETECTORS_FORMAT, SOURCE_DETECTORS_VERSION, SourceDetectors

    p = tmp_path / "source_detectors.npz"
    _array_file(p, ('{"format": "%s", "format_version": %d, "x": %s}' % (
        SOURCE_DETECTORS_FORMAT, SOURCE_DETECTORS_VERSION, ABYSS)).encode())
    with pytest.raises(ValueError, match="has no readable metadata") as err:
        SourceDetectors.load(p)
    assert "\n" not in str(err.value) and str(p) in str(err.value)


# ------------------------------------------------------------------ lock files


def test_a_lock_file_nested_too_deep_records_no_holder(tmp_path):
    for depth, text in ((200, _nested(200)), (100_001, ABYSS)):
        p = tmp_path / f"lock{depth}"
        p.write_text(text)
        assert locks._read_info(p) is None


def test_a_lock_file_over_the_size_limit_records_no_holder(tmp_path, monkeypatch):
    p = tmp_path / LOCK
    record = {"pid": os.getppid(), "host": "h", "command": "x" * 500, "started": 0}
    p.write_text(json.dumps(record))
    assert locks._read_info(p) == record                 # within the limit: read
    monkeypatch.setattr(locks, "MAX_LOCK_BYTES", 100)
    assert locks._read_info(p) is None                   # over it: no holder, not read


def test_a_planted_deep_lock_file_is_stale_without_flock(tmp_path, monkeypatch):
    """Where ``flock`` is missing the recorded pid decides: a planted file too deep to
    parse records no one, so the folder is taken over, as with a corrupt lock file."""
    monkeypatch.setattr(locks, "_flock", lambda: None)
    out = tmp_path / "out"
    out.mkdir()
    (out / LOCK).write_text(ABYSS)
    with hold_output_dir(out, "detect"):
        assert json.loads((out / LOCK).read_text())["pid"] == os.getpid()
    assert not (out / LOCK).exists()


def test_a_symbolic_link_as_lock_file_is_refused_and_its_target_kept(tmp_path):
    victim = tmp_path / "precious.txt"
    victim.write_text("precious\n")
    out = tmp_path / "out"
    out.mkdir()
    os.symlink(victim, out / LOCK)
    with pytest.raises(UserError, match=f"{re.escape(LOCK)} is a symbolic link") as err:
        with hold_output_dir(out, "detect"):
            pytest.fail("the lock was taken through a link")
    assert "\n" not in str(err.value) and str(out) in str(err.value)
    assert victim.read_text() == "precious\n" and (out / LOCK).is_symlink()


@pytest.mark.parametrize("kind", ["fifo", "folder"])
def test_a_lock_path_that_is_no_file_is_one_line(kind, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    os.mkfifo(out / LOCK) if kind == "fifo" else (out / LOCK).mkdir()
    with pytest.raises(UserError, match="a folder" if kind == "folder" else "not a regular"):
        with hold_output_dir(out, "detect"):
            pytest.fail("the lock was taken")
    assert (out / LOCK).exists() and not (out / LOCK).is_file()


# ------------------------------------------------------------------ markers, run.json


def test_a_marker_over_the_size_limit_is_not_ours(tmp_path, monkeypatch):
    out = tmp_path / "out"
    out.mkdir()
    marker = {"written_by": "viewadapt", "commands": ["detect"], "files": ["f" * 2_000]}
    (out / MARKER).write_text(json.dumps(marker))
    (out / "other.txt").write_text("x")
    assert read_marker(out) == marker
    monkeypatch.setattr(files, "MAX_MARKER_BYTES", 1_000)
    assert read_marker(out) is None
    with pytest.raises(UserError, match="is not empty and was not written by viewadapt") as e:
        check_output_dir(out)
    assert "\n" not in str(e.value)


def test_a_legacy_run_json_over_the_size_limit_is_not_ours(tmp_path, monkeypatch):
    out = tmp_path / "out"
    out.mkdir()
    (out / "run.json").write_text(json.dumps({"viewadapt": "0.1.0", "pad": "p" * 2_000}))
    assert files.is_project_output(out)
    monkeypatch.setattr(files, "MAX_MARKER_BYTES", 1_000)
    assert not files.is_project_output(out)


def test_a_marker_nested_too_deep_is_not_ours(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    for text in (_nested(200), ABYSS):
        (out / MARKER).write_text(text)
        assert read_marker(out) is None


def test_a_fifo_as_marker_is_not_opened(tmp_path):
    """A FIFO planted as the marker would block a plain read forever."""
    out = tmp_path / "out"
    out.mkdir()
    fifo = out / MARKER
    os.mkfifo(fifo)
    got = []
    t = threading.Thread(target=lambda: got.append(read_marker(out)), daemon=True)
    t.start()
    t.join(5)
    blocked = t.is_alive()
    if blocked:                                   # let a blocked reader go (end of file)
        os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
        t.join(5)
    assert not blocked and got == [None]
