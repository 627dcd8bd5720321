"""``viewadapt calibrate --out``: a path it cannot write is refused in one line (exit 2)
naming the path and why, with no errno text and nothing left behind."""

import os
from pathlib import Path

import pytest

from tests.viewadapt.camera.test_calibrate import CAMERAS, _camera, _ground_points, _write_csv


def _calibrate(tmp_path, out, capsys, *extra):
    from viewadapt.cli import main

    uv, XY = _ground_points(_camera(**CAMERAS["lobby"]))
    pts = _write_csv(tmp_path / "pts.csv", uv, XY)
    capsys.readouterr()
    rc = main(["calibrate", str(pts), "--image-size", "384,288", "--out", str(out), *extra])
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def _refused(rc, stdout, stderr, want):
    assert rc == 2 and stdout == "" and stderr.count("\n") == 1, (rc, stdout, stderr)
    assert stderr == f"viewadapt calibrate: error: {want}\n", stderr
    assert "Errno" not in stderr


@pytest.mark.parametrize("overwrite", [[], ["--overwrite"]])
def test_a_broken_symbolic_link_is_refused(overwrite, tmp_path, capsys):
    link = tmp_path / "cam.yaml"
    os.symlink(tmp_path / "gone.yaml", link)
    _refused(*_calibrate(tmp_path, link, capsys, *overwrite),
             f"--out {link} is a broken symbolic link (to {tmp_path / 'gone.yaml'}); remove "
             "it or choose another --out")
    assert link.is_symlink() and not (tmp_path / "gone.yaml").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cam.yaml", "pts.csv"]


def test_a_file_where_a_folder_belongs(tmp_path, capsys):
    (tmp_path / "afile").write_text("x")
    out = tmp_path / "afile" / "cam.yaml"
    _refused(*_calibrate(tmp_path, out, capsys),
             f"cannot write {out}: {tmp_path / 'afile'} is a file, not a folder")


def test_missing_folders_are_still_made(tmp_path, capsys):
    out = tmp_path / "new" / "dir" / "cam.yaml"
    rc, _, stderr = _calibrate(tmp_path, out, capsys)
    assert rc == 0 and stderr == "" and out.is_file()


def test_a_folder_it_may_not_write(tmp_path, capsys):
    """As any user: /sys refuses new files even to root; a read-only folder as others."""
    sys_dir = Path("/sys")
    if sys_dir.is_dir() and not os.access(sys_dir / "cam.yaml", os.F_OK):
        out = sys_dir / "cam.yaml"
        rc, stdout, stderr = _calibrate(tmp_path, out, capsys)
        assert rc == 2 and stdout == "" and stderr.count("\n") == 1, stderr
        assert stderr.startswith(f"viewadapt calibrate: error: cannot write {out}: permission "
                                 "denied"), stderr
        out = sys_dir / "nowhere" / "cam.yaml"
        rc, stdout, stderr = _calibrate(tmp_path, out, capsys)
        assert rc == 2 and stderr.startswith(f"viewadapt calibrate: error: cannot write {out}: ")
        assert stderr.count("\n") == 1 and "Errno" not in stderr, stderr
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        if os.access(ro, os.W_OK):               # root writes anywhere
            pytest.skip("this user can write a read-only folder")
        out = ro / "cam.yaml"
        _refused(*_calibrate(tmp_path, out, capsys),
                 f"cannot write {out}: permission denied ({ro} is not writable)")
    finally:
        ro.chmod(0o755)
