"""An ``--out`` that cannot become a folder is refused in one line before any work: a
broken symbolic link (itself or a folder above it), or a file where a folder belongs."""

import os

import pytest

from viewadapt.io.files import UserError, check_output_dir, claim_output_dir


def _main(argv, capsys):
    from viewadapt.cli import main

    capsys.readouterr()
    rc = main(argv)
    return rc, capsys.readouterr().err


def test_a_broken_symbolic_link_is_named(tmp_path):
    link = tmp_path / "out"
    os.symlink(tmp_path / "gone", link)
    want = (f"--out {link} is a broken symbolic link (to {tmp_path / 'gone'}); remove it or "
            "choose another --out")
    for check in (check_output_dir, claim_output_dir):
        with pytest.raises(UserError) as exc:
            check(link)
        assert str(exc.value) == want
    assert link.is_symlink() and not (tmp_path / "gone").exists()
    inner = link / "sub"
    with pytest.raises(UserError) as exc:
        check_output_dir(inner)
    assert str(exc.value) == (f"--out {inner}: {link} is a broken symbolic link (to "
                              f"{tmp_path / 'gone'}); remove it or choose another --out")


def test_a_link_to_a_folder_is_still_an_output(tmp_path):
    (tmp_path / "real").mkdir()
    link = tmp_path / "out"
    os.symlink(tmp_path / "real", link)
    assert claim_output_dir(link) is False
    assert (tmp_path / "real" / ".viewadapt-output").is_file()


def test_a_file_above_out_is_named(tmp_path):
    (tmp_path / "afile").write_text("x")
    out = tmp_path / "afile" / "sub" / "out"
    with pytest.raises(UserError) as exc:
        claim_output_dir(out)
    assert str(exc.value) == f"--out {out}: {tmp_path / 'afile'} is a file, not a folder"


@pytest.mark.parametrize("case", ["dangling", "under a file"])
def test_detect_refuses_them_in_one_line(case, tmp_path, capsys):
    if case == "dangling":
        out = tmp_path / "out"
        os.symlink(tmp_path / "gone", out)
        want = f"--out {out} is a broken symbolic link (to {tmp_path / 'gone'})"
    else:
        (tmp_path / "afile").write_text("x")
        out = tmp_path / "afile" / "out"
        want = f"--out {out}: {tmp_path / 'afile'} is a file, not a folder"
    rc, err = _main(["detect", "--calibration", str(tmp_path / "cam.yaml"), "--out", str(out),
                     str(tmp_path / "frame.png")], capsys)
    assert rc == 2 and err.startswith(f"viewadapt detect: error: {want}"), err
    assert err.count("\n") == 1 and "Errno" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) in (["out"], ["afile"])


def test_a_deeply_nested_json_in_out_is_not_taken_for_ours(tmp_path):
    """A ``run.json`` (or marker) too deep for ``json`` is a file the project did not
    write: the usual one line, no RecursionError."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "run.json").write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(UserError, match="is not empty and was not written by viewadapt"):
        check_output_dir(out)
    (out / ".viewadapt-output").write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(UserError, match="is not empty and was not written by viewadapt"):
        check_output_dir(out)
