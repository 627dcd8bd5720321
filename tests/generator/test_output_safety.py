"""What commands refuse to write, and what ``dataset verify`` finds.

An output folder overlapping an input folder; a folder another command wrote; two
``generate`` runs into one folder; elevation lists that are empty or repeat a view; files
a dataset does not hold, anywhere in its tree, and the content hash leaving them out.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import time

import numpy as np
import pytest

from benchmark.toydata import make_toy_dataset
from tests.folders import MICRO_ARGV, micro_config, tree
from tests.paths import REPO
from viewadapt.cli import main
from viewadapt.io.files import (
    LOCK, MARKER, UserError, atomic_output_dir, check_output_dir, running_command,
)

#: ``generate --preset tiny --renderer pyrender --persons 2 --scenes 1 --seed 3``: 10 images


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    return make_toy_dataset(tmp_path_factory.mktemp("toy") / "data", n_persons=3, n_scenes=3,
                            n_backgrounds=1, seed=7)


@pytest.fixture(scope="module")
def micro(tmp_path_factory):
    pytest.importorskip("pyrender", reason="optional: pip install pyrender")
    pytest.importorskip("anny", reason="needs the generator extra")
    from generator.pipeline import generate

    out = tmp_path_factory.mktemp("micro") / "ds"
    try:
        res = generate(micro_config(), 3, out, jobs=0, progress=False)
    except Exception as exc:  # noqa: BLE001 - no GL context on this machine
        pytest.skip(f"pyrender cannot render here: {exc}")
    assert res.complete
    return out


def _one_line_error(capsys, cmd: str) -> str:
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert err.startswith(f"viewadapt {cmd}: error: "), err
    return err


# ---------------------------------------------------------------- overlapping folders


def test_an_out_folder_overlapping_the_data_is_refused(toy, tmp_path, capsys):
    before = tree(toy)
    crossval = ["bench", "crossval", "--data", str(toy), "--quick"]
    for extra, what in [(["--out", str(toy)], "is the --data folder"),
                        (["--out", str(toy), "--overwrite"], "is the --data folder"),
                        (["--out", str(toy / "res")], f"lies inside --data {toy}"),
                        (["--out", str(tmp_path / "r"), "--cache", str(toy / "cache")],
                         f"lies inside --data {toy}")]:
        assert main(crossval + extra) == 2
        assert what in _one_line_error(capsys, "bench crossval")
    for cmd in (["bench", "sweep"], ["bench", "frames"]):
        assert main(cmd + ["--data", str(toy), "--out", str(toy / "x")]) == 2
        _one_line_error(capsys, " ".join(cmd))
    assert tree(toy) == before and not (tmp_path / "r").exists()
    outer = tmp_path / "outer"
    shutil.copytree(toy, outer / "data")
    assert main(["bench", "crossval", "--data", str(outer / "data"), "--out", str(outer),
                 "--quick"]) == 2
    assert f"lies inside --out {outer}" in _one_line_error(capsys, "bench crossval")
    assert sorted(p.name for p in outer.iterdir()) == ["data"]


def test_detect_and_the_dataset_commands_keep_out_of_their_inputs(toy, tmp_path, capsys):
    frames = tmp_path / "frames"
    frames.mkdir()
    calib = tmp_path / "camera.json"
    for out, inputs in [(frames / "det", [frames]), (tmp_path, [frames / "a.png"])]:
        assert main(["detect", "--calibration", str(calib), "--out", str(out),
                     *map(str, inputs)]) == 2
        assert "INPUT" in _one_line_error(capsys, "detect")
    assert sorted(p.name for p in frames.iterdir()) == []
    before = tree(toy)
    assert main(["dataset", "preview", str(toy), "--out", str(toy / "sheet.png")]) == 2
    _one_line_error(capsys, "dataset preview")
    assert main(["dataset", "verify", str(toy), "--fast", "--json", str(toy / "r.json")]) == 2
    _one_line_error(capsys, "dataset verify")
    assert tree(toy) == before


# ------------------------------------------------------- a folder another command wrote


def test_a_folder_is_reused_only_by_the_command_that_wrote_it(tmp_path, capsys):
    res = tmp_path / "res"
    with atomic_output_dir(res, command="bench crossval") as tmp:
        (tmp / "summary.csv").write_text("a,b\n")
    with running_command("detect"), pytest.raises(UserError, match="bench crossval"):
        check_output_dir(res)
    before = tree(res)
    assert main(["generate", "--preset", "tiny", "--renderer", "cycles", "--quiet",
                 "--out", str(res)]) == 2
    err = _one_line_error(capsys, "generate")
    assert "written by viewadapt bench crossval" in err and "--overwrite" in err
    assert tree(res) == before
    with running_command("bench sweep"):              # crossval and sweep share results
        check_output_dir(res)
    with running_command("bench crossval"):
        check_output_dir(res)
    with running_command("detect"):
        check_output_dir(res, overwrite=True)         # the user says so
    check_output_dir(res)                             # outside a command: any of ours


# ------------------------------------------------------------------- elevation lists


@pytest.mark.parametrize("text, what", [("", "empty"), ("0,0", "twice"),
                                        ("pi/4,45deg", "twice"), ("0:0:3", "twice"),
                                        (" , ", "cannot parse")])
def test_empty_or_repeated_elevations_are_one_line_errors(tmp_path, capsys, monkeypatch,
                                                          text, what):
    from generator import pipeline

    monkeypatch.setattr(pipeline, "generate", lambda *a, **k: pytest.fail("it would render"))
    out = tmp_path / "o"
    assert main(["generate", "--elevations", text, "--out", str(out)]) == 2
    assert what in _one_line_error(capsys, "generate")
    assert not out.exists()


@pytest.mark.parametrize("text, what", [("1", "exceed the person height"),
                                        ("inf", "must be a number"),
                                        ("nan", "must be a number")])
def test_a_bad_camera_distance_is_a_one_line_error(tmp_path, capsys, monkeypatch, text, what):
    from generator import pipeline

    monkeypatch.setattr(pipeline, "generate", lambda *a, **k: pytest.fail("it would render"))
    out = tmp_path / "o"
    assert main(["generate", "--distance", text, "--out", str(out)]) == 2
    assert what in _one_line_error(capsys, "generate")
    assert not out.exists()


def test_a_config_and_crossval_sources_refuse_repeated_elevations(tmp_path, capsys):
    from generator.sampling import GeneratorConfig

    with pytest.raises(ValueError, match="distinct"):
        GeneratorConfig(elevations=(0.0, 0.0)).validate()
    for sources in ("0,0", "0,pi/4,0.7853981633974483", ""):
        with pytest.raises(SystemExit) as e:
            main(["bench", "crossval", "--data", str(tmp_path), "--out", str(tmp_path / "r"),
                  "--sources", sources])
        err = capsys.readouterr().err
        assert e.value.code == 2 and "--sources" in err
        assert ("twice" if sources else "cannot read elevation") in err
    assert not (tmp_path / "r").exists()


# ------------------------------------------------------- two generate runs, one folder


@pytest.mark.blender
@pytest.mark.filterwarnings("ignore:tostring.. is deprecated:DeprecationWarning")
def test_a_second_generate_into_a_folder_being_written_is_refused(micro, tmp_path, capsys):
    from generator.verify import verify_dataset

    out = tmp_path / "D"
    proc = subprocess.Popen([sys.executable, "-m", "viewadapt.cli", *MICRO_ARGV, "--out",
                             str(out)], cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.time() + 150
        while time.time() < deadline and proc.poll() is None:
            if out.is_dir() and any(out.rglob("*.png")):
                break
            time.sleep(0.05)
        else:
            pytest.fail("no image appeared" if proc.poll() is None else "generate finished")
        assert main(MICRO_ARGV + ["--out", str(out)]) == 2
        err = _one_line_error(capsys, "generate")
        assert f"{out} is in use by viewadapt generate (pid {proc.pid}, started " in err
        assert "wait for it or choose another --out" in err
        _, perr = proc.communicate(timeout=150)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, perr
    assert not (out / LOCK).exists()
    rep = verify_dataset(out, check_hash=True)
    assert rep.ok and rep.hash_ok, rep.summary()
    assert tree(out) == tree(micro)


# ------------------------------------------------------------- files a dataset lacks


@pytest.mark.blender
@pytest.mark.filterwarnings("ignore:tostring.. is deprecated:DeprecationWarning")
def test_verify_names_every_foreign_file_and_the_hash_leaves_them_out(micro, tmp_path):
    from generator.pipeline import generate
    from generator.verify import verify_dataset

    ds = tmp_path / "ds"
    shutil.copytree(micro, ds)
    recorded = json.loads((micro / "dataset.json").read_text())["content_hash"]
    planted = ["evil.pkl", "person/evil.pkl", "depth/carpark/x.txt", "notes/readme.txt",
               ".parts/extra.json", ".hidden", "person/carpark/.p001_i0_e0.png.abc.tmp"]
    for rel in planted:
        (ds / rel).parent.mkdir(parents=True, exist_ok=True)
        (ds / rel).write_bytes(np.arange(8, dtype=np.uint8).tobytes())
    rep = verify_dataset(ds, check_hash=True)
    found = dict(rep.problems)
    assert sorted(set(found) & set(planted)) == sorted(planted), rep.summary()
    assert "leftover temporary file" in found["person/carpark/.p001_i0_e0.png.abc.tmp"]
    assert "not part of the dataset" in found["evil.pkl"]
    assert rep.hash_ok and not rep.ok                  # the data is intact; the strays fail it
    res = generate(micro_config(), 3, ds, jobs=0, progress=False)      # a rerun ("repair")
    assert res.complete and res.n_rendered == 0
    meta = json.loads((ds / "dataset.json").read_text())
    assert meta["content_hash"] == recorded             # the foreign files are not hashed
    assert not verify_dataset(ds).ok
    for rel in planted:
        (ds / rel).unlink()
    shutil.rmtree(ds / "notes")
    rep = verify_dataset(ds, check_hash=True)
    assert rep.ok and rep.hash_ok, rep.summary()
    (ds / MARKER).unlink()                              # bookkeeping, not data: still fine
    assert verify_dataset(ds).ok
