"""One writer per output folder: the advisory lock of ``viewadapt.io.locks``.

A second process writing into a held folder is refused in one line naming the holder and
writes nothing; a lock of a killed process is taken over; the lock goes on success, error
and Ctrl-C; one process may take its own lock again (a pipeline's stages run in it), and
the shards of one ``generate`` share a folder but not a shard.
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
import subprocess
import sys
import textwrap

import pytest

from benchmark.toydata import make_toy_dataset
from tests.folders import tree
from tests.paths import REPO
from viewadapt.cli import main
from viewadapt.io.files import LOCK, UserError
from viewadapt.io.locks import hold_output_dir

#: takes the lock of argv[1] for command argv[2] (shard argv[3] "I/N"), says so, and lets
#: it go when its standard input ends
HOLDER = textwrap.dedent("""
    import sys
    from viewadapt.io.locks import hold_output_dir
    shard = tuple(map(int, sys.argv[3].split("/"))) if len(sys.argv) > 3 else None
    with hold_output_dir(sys.argv[1], sys.argv[2], shard=shard):
        print("held", flush=True)
        sys.stdin.read()
""")


@contextlib.contextmanager
def held_elsewhere(out, command="generate", shard=None):
    """A live process of its own holding ``out``'s lock."""
    extra = [f"{shard[0]}/{shard[1]}"] if shard else []
    proc = subprocess.Popen([sys.executable, "-c", HOLDER, str(out), command, *extra],
                            cwd=REPO, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline().strip()
        assert line == "held", proc.stderr.read()
        yield proc
    finally:
        proc.stdin.close()                               # the holder lets go and ends
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        proc.stdout.close()
        proc.stderr.close()


def taken_elsewhere(out, command="generate", shard=None) -> bool:
    """Whether another process can take ``out``'s lock now."""
    try:
        with held_elsewhere(out, command, shard):
            return True
    except AssertionError:
        return False


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    return make_toy_dataset(tmp_path_factory.mktemp("toy") / "data", n_persons=3, n_scenes=3,
                            n_backgrounds=1, seed=7)


def test_a_second_writer_is_refused_in_one_line_naming_the_holder(tmp_path):
    out = tmp_path / "D"
    with held_elsewhere(out, "generate") as proc:
        before = tree(out)
        with pytest.raises(UserError) as e:
            with hold_output_dir(out, "bench crossval"):
                pytest.fail("the lock was taken twice")
        assert tree(out) == before                       # nothing written
    msg = str(e.value)
    assert "\n" not in msg
    assert re.fullmatch(rf"{re.escape(str(out))} is in use by viewadapt generate \(pid "
                        rf"{proc.pid}, started \d\d:\d\d:\d\d\); wait for it or choose "
                        r"another --out", msg), msg


def test_the_lock_goes_on_success_error_and_ctrl_c(tmp_path):
    out = tmp_path / "D"
    out.mkdir()
    for exc in (None, ValueError("bad"), KeyboardInterrupt()):
        with contextlib.suppress(ValueError, KeyboardInterrupt):
            with hold_output_dir(out, "detect"):
                assert (out / LOCK).is_file() and not taken_elsewhere(out)
                if exc is not None:
                    raise exc
        assert not (out / LOCK).exists()
        assert taken_elsewhere(out)
    assert list(out.iterdir()) == []


def test_the_lock_of_a_killed_run_is_taken_over_silently(tmp_path):
    out = tmp_path / "D"
    with held_elsewhere(out) as proc:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        assert (out / LOCK).is_file()                     # left behind, naming a dead pid
        with hold_output_dir(out, "generate"):
            assert not taken_elsewhere(out)
    assert not (out / LOCK).exists()
    # a lock file written by hand (or by a run on a machine without flock) naming a gone pid
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    (out / LOCK).write_text(f'{{"pid": {dead.pid}, "host": "{os.uname().nodename}", '
                            '"command": "generate", "started": 0}')
    with hold_output_dir(out, "generate"):
        pass
    assert not (out / LOCK).exists()


def test_one_process_may_take_its_own_lock_again(tmp_path):
    out = tmp_path / "D"
    with hold_output_dir(out, "demo"):
        with hold_output_dir(out, "demo"):              # a stage writing into the same folder
            pass
        assert (out / LOCK).is_file() and not taken_elsewhere(out)   # still held
        with hold_output_dir(out / "data", "generate"):  # a stage's own folder
            assert not taken_elsewhere(out / "data")
        assert taken_elsewhere(out / "data")
    assert taken_elsewhere(out)


def test_a_lock_removes_the_folder_it_made_if_nothing_was_written(tmp_path):
    out = tmp_path / "new" / "D"
    with hold_output_dir(out, "detect"):
        assert out.is_dir()
    assert not out.exists()
    with hold_output_dir(out, "detect"):
        (out / "a.txt").write_text("a")
    assert sorted(p.name for p in out.iterdir()) == ["a.txt"]


def test_shards_share_a_folder_but_not_a_shard(tmp_path):
    out = tmp_path / "D"
    with held_elsewhere(out, "generate", shard=(0, 2)) as proc:
        with hold_output_dir(out, "generate", shard=(1, 2)):
            pass
        with pytest.raises(UserError, match=rf"in use by viewadapt generate --shard 0/2 "
                                            rf"\(pid {proc.pid}"):
            with hold_output_dir(out, "generate", shard=(0, 2)):
                pass
        with pytest.raises(UserError, match=rf"in use by viewadapt generate --shard 0/2 "
                                            rf"\(pid {proc.pid}"):
            with hold_output_dir(out, "generate"):
                pass
    with held_elsewhere(out, "generate") as proc:
        with pytest.raises(UserError, match=rf"in use by viewadapt generate \(pid {proc.pid}"):
            with hold_output_dir(out, "generate", shard=(1, 2)):
                pass
    assert not out.exists()                             # made by the locks, left empty


def test_a_command_into_a_held_folder_is_one_line_and_writes_nothing(tmp_path, toy, capsys):
    out = tmp_path / "D"
    with held_elsewhere(out, "generate") as proc:
        before = tree(out)
        assert main(["bench", "crossval", "--data", str(toy), "--out", str(out),
                     "--quick"]) == 2
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
        assert err.startswith(f"viewadapt bench crossval: error: {out} is in use by viewadapt "
                              f"generate (pid {proc.pid}, started ")
        assert main(["generate", "--preset", "tiny", "--renderer", "cycles", "--quiet",
                     "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1
        assert err.startswith(f"viewadapt generate: error: {out} is in use by viewadapt "
                              f"generate (pid {proc.pid}")
        assert tree(out) == before


def test_a_failed_command_leaves_no_lock_and_a_stage_writes_its_own_folder(
        tmp_path, toy, capsys, monkeypatch):
    import benchmark.crops.crossval as crossval

    def fails(ds, cfg, cache):
        raise ValueError("bad settings")

    monkeypatch.setattr(crossval, "run_crossval", fails)
    out = tmp_path / "demo"
    out.mkdir()
    with hold_output_dir(out, "demo"):                  # the parent pipeline's folder
        for sub in (out / "results", out):
            assert main(["bench", "crossval", "--data", str(toy), "--out", str(sub),
                         "--quick"]) == 2
            err = capsys.readouterr().err
            assert "bad settings" in err and "in use" not in err
        assert not (out / "results").exists()
        assert (out / LOCK).is_file()                   # still the parent's
    assert list(out.iterdir()) == []
