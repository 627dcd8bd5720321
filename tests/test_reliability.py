"""Nothing lost, nothing run that should not run: outputs, resumes, errors, determinism.

One test (or a few) per reported failure. Datasets are rendered with pyrender in this
process (a micro set of 10 images, once per module) or are the planar toy sets of
``benchmark.toydata``; one test renders a single Blender image (PNG chunks), and the
Cycles ``tiny`` kill-and-resume byte-identity test is ``slow``.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from benchmark.toydata import make_toy_dataset
from tests.folders import MICRO_ARGV, file_bytes, file_hashes, micro_config
from viewadapt.cli import build_parser, main
from viewadapt.io.files import (
    MARKER, UserError, atomic_output_dir, atomic_write_text, check_output_dir, read_marker,
)

REPO = Path(__file__).resolve().parent.parent
#: the micro set: ``generate --preset tiny --renderer pyrender --persons 2 --scenes 1
#: --seed 3``: 1 background x 3 elevations, 2 persons x 3 elevations, 1 frame (carpark)
MICRO_IMAGES = 10


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
    assert res.complete and res.n_images == MICRO_IMAGES
    return out


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    return make_toy_dataset(tmp_path_factory.mktemp("toy") / "data", n_persons=3, n_scenes=3,
                            n_backgrounds=1, seed=7)


# ------------------------------------------------------------- (3) existing output replaced


def test_every_command_with_an_out_dir_takes_overwrite():
    parser = build_parser()
    seen = []

    def walk(p, name):
        opts = {o for a in p._actions for o in a.option_strings}
        if "--out" in opts and "--jobs" in opts:
            seen.append(name)
            assert "--overwrite" in opts, name
        for a in p._actions:
            if a.__class__.__name__ == "_SubParsersAction":
                for sub, sp in a.choices.items():
                    walk(sp, f"{name} {sub}".strip())

    walk(parser, "")
    for cmd in ("generate", "detect", "fidelity", "demo", "reproduce", "bench crossval",
                "bench sweep", "bench frames", "bench runtime"):
        assert cmd in seen


def test_generate_and_crossval_refuse_a_foreign_directory(tmp_path, toy, capsys):
    foreign = tmp_path / "mine"
    foreign.mkdir()
    (foreign / "manifest.csv").write_text("my,own\n1,2\n")
    (foreign / "report.md").write_text("# my notes\n")
    assert main(["generate", "--preset", "tiny", "--renderer", "pyrender",
                 "--out", str(foreign)]) == 2
    err = capsys.readouterr().err
    assert "not written by viewadapt" in err and "--overwrite" in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert main(["bench", "crossval", "--data", str(toy), "--out", str(foreign),
                 "--quick"]) == 2
    assert "not written by viewadapt" in capsys.readouterr().err
    assert (foreign / "manifest.csv").read_text() == "my,own\n1,2\n"
    assert (foreign / "report.md").read_text() == "# my notes\n"
    assert sorted(p.name for p in foreign.iterdir()) == ["manifest.csv", "report.md"]
    check_output_dir(foreign, overwrite=True)            # the flag lets a run write there
    empty = tmp_path / "empty"
    empty.mkdir()
    check_output_dir(empty)                              # an empty folder is fine


def test_replacing_outputs_keeps_files_the_project_did_not_write(tmp_path):
    out = tmp_path / "res"
    with atomic_output_dir(out, command="detect") as tmp:
        (tmp / "annotated").mkdir()
        (tmp / "annotated" / "00000_a.png").write_bytes(b"old a")
        (tmp / "annotated" / "00001_b.png").write_bytes(b"old b")
        (tmp / "detections.csv").write_text("old")
    assert read_marker(out)["commands"] == ["detect"]
    (out / "annotated" / "my_notes.txt").write_text("mine")          # a user's file
    check_output_dir(out)                                            # ours: no flag needed
    with atomic_output_dir(out, command="detect") as tmp:
        (tmp / "annotated").mkdir()
        (tmp / "annotated" / "00000_a.png").write_bytes(b"new a")
        (tmp / "detections.csv").write_text("new")
    assert (out / "annotated" / "my_notes.txt").read_text() == "mine"
    assert (out / "annotated" / "00000_a.png").read_bytes() == b"new a"
    assert not (out / "annotated" / "00001_b.png").exists()        # ours, not rewritten
    assert (out / "detections.csv").read_text() == "new"
    # --overwrite into a foreign folder: same names replaced, nothing else deleted
    foreign = tmp_path / "foreign"
    (foreign / "annotated").mkdir(parents=True)
    (foreign / "annotated" / "x.png").write_bytes(b"user")
    (foreign / "detections.csv").write_text("user")
    with pytest.raises(UserError, match="--overwrite"):
        check_output_dir(foreign)
    check_output_dir(foreign, overwrite=True)
    with atomic_output_dir(foreign) as tmp:
        (tmp / "annotated").mkdir()
        (tmp / "annotated" / "y.png").write_bytes(b"ours")
        (tmp / "detections.csv").write_text("ours")
    assert (foreign / "annotated" / "x.png").read_bytes() == b"user"
    assert (foreign / "detections.csv").read_text() == "ours"
    assert (foreign / MARKER).is_file()


# ------------------------------------------------------------ (5) corrupt image survives


@pytest.mark.blender
@pytest.mark.filterwarnings("ignore:tostring.. is deprecated:DeprecationWarning")
def test_a_rerun_renders_a_truncated_png_again(micro, tmp_path, capsys):
    from generator.pipeline import generate
    from generator.verify import verify_dataset

    ds = tmp_path / "ds"
    shutil.copytree(micro, ds)
    rel = "person/carpark/p002_i0_e1.png"
    data = (ds / rel).read_bytes()
    (ds / rel).write_bytes(data[: len(data) - 40])                 # IEND and more cut off
    assert not verify_dataset(ds).ok
    res = generate(micro_config(), 3, ds, jobs=0, progress=False)
    assert res.complete and res.n_rendered == 1 and res.n_repaired == 1
    assert "1 kept file(s) are truncated or corrupt" in capsys.readouterr().err
    assert "replacing truncated or corrupt" in res.summary()
    assert verify_dataset(ds).ok
    assert (ds / rel).read_bytes() == (micro / rel).read_bytes()


def test_png_check_finds_what_iend_alone_misses(tmp_path):
    import cv2

    from generator.png import png_problem

    p = tmp_path / "a.png"
    cv2.imwrite(str(p), np.random.default_rng(0).integers(0, 255, (32, 16, 3), np.uint8))
    assert png_problem(p, (16, 32)) is None
    assert "size 16x32" in png_problem(p, (32, 16))
    data = bytearray(p.read_bytes())
    data[60] ^= 0xFF                                              # inside IDAT: CRC fails
    p.write_bytes(bytes(data))
    assert "CRC" in png_problem(p)
    p.write_bytes(bytes(data[:40]) + bytes(data[-12:]))            # IEND kept, data cut
    assert png_problem(p) is not None


# -------------------------------------------------------- (6) crossval on an incomplete set


def test_crossval_refuses_an_incomplete_dataset(toy, tmp_path, capsys):
    inc = tmp_path / "inc"
    shutil.copytree(toy, inc)
    meta = json.loads((inc / "dataset.json").read_text())
    n = len(pd.read_parquet(inc / "manifest.parquet"))
    meta["counts"] = {"images": n + 3}                 # 3 planned images never generated
    (inc / "dataset.json").write_text(json.dumps(meta))
    res = tmp_path / "res"
    argv = ["bench", "crossval", "--data", str(inc), "--out", str(res), "--quick",
            "--detectors", "hog", "--sources", "0", "--object-models", "plane",
            "--no-upper-bound"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "3 of the" in err and "--allow-incomplete" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1 and not res.exists()
    assert main(argv + ["--allow-incomplete"]) == 0
    assert "WARNING" in capsys.readouterr().err
    run = json.loads((res / "run.json").read_text())
    assert "3 of the" in run["incomplete_dataset"]
    assert "incomplete dataset" in (res / "report.md").read_text().split("\n\n")[1]


# ------------------------------------------------------------- (7) tracebacks, not errors


@pytest.mark.blender
@pytest.mark.filterwarnings("ignore:tostring.. is deprecated:DeprecationWarning")
def test_verify_checks_every_manifest_column(micro, tmp_path, capsys):
    ds = tmp_path / "ds"
    shutil.copytree(micro, ds)
    man = pd.read_parquet(ds / "manifest.parquet")
    man.drop(columns=["elevation"]).to_parquet(ds / "manifest.parquet", index=False)
    assert main(["dataset", "verify", str(ds)]) == 1
    assert "'elevation'" in capsys.readouterr().out
    man.assign(width=man["width"].astype(str)).to_parquet(ds / "manifest.parquet", index=False)
    assert main(["dataset", "verify", str(ds)]) == 1
    assert "'width'" in capsys.readouterr().out
    man.drop(columns=["path"]).to_parquet(ds / "manifest.parquet", index=False)
    assert main(["dataset", "verify", str(ds)]) == 1
    cap = capsys.readouterr()
    assert "'path'" in cap.out and "Traceback" not in cap.err


def test_elevation_divided_by_zero_is_a_one_line_error(tmp_path, capsys):
    assert main(["generate", "--elevations", "pi/0", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "cannot parse" in err and len(err.strip().splitlines()) == 1
    with pytest.raises(SystemExit) as e:
        main(["bench", "crossval", "--data", str(tmp_path), "--out", str(tmp_path / "r"),
              "--target", "pi/0"])
    assert e.value.code == 2 and "cannot read elevation" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_crossval_target_is_one_elevation(tmp_path, capsys):
    from benchmark.crops.command import _config
    from viewadapt.cli import build_parser

    args = build_parser().parse_args(["bench", "crossval", "--data", str(tmp_path), "--out",
                                      str(tmp_path / "r"), "--target", "pi/8"])
    assert args.target == pytest.approx(np.pi / 8)
    ds = type("DS", (), {"config": {}})()
    assert _config(args, ds).target == pytest.approx(np.pi / 8)
    with pytest.raises(SystemExit) as e:
        main(["bench", "crossval", "--data", str(tmp_path), "--out", str(tmp_path / "r"),
              "--target", "0,pi/4"])
    assert e.value.code == 2 and "one target elevation" in capsys.readouterr().err


def test_an_unreachable_scheduler_is_a_one_line_error(tmp_path, capsys, monkeypatch):
    pytest.importorskip("distributed")
    from generator import pipeline

    monkeypatch.setattr(pipeline, "SCHEDULER_TIMEOUT_S", 1)
    out = tmp_path / "ds"
    t0 = time.perf_counter()
    assert main(["generate", "--renderer", "cycles", "--scheduler", "tcp://127.0.0.1:9",
                 "--out", str(out)]) == 2
    assert time.perf_counter() - t0 < 20
    err = capsys.readouterr().err
    assert "cannot reach a Dask scheduler" in err and "Traceback" not in err
    assert not out.exists()                               # no empty manifest left behind


@pytest.mark.blender
@pytest.mark.filterwarnings("ignore:tostring.. is deprecated:DeprecationWarning")
def test_a_killed_worker_is_a_one_line_error_and_the_resume_is_byte_identical(micro,
                                                                            tmp_path):
    """(7) kill -9 of the pool worker; (9) the resumed set has the uninterrupted one's
    bytes, file for file, and records the same content hash."""
    from generator.pipeline import generate
    from generator.verify import verify_dataset

    out = tmp_path / "ds"
    code = textwrap.dedent(f"""
        import sys
        from viewadapt.cli import main
        if __name__ == "__main__":
            sys.exit(main({MICRO_ARGV + ["--out", str(out)]!r}))
    """)
    proc = subprocess.Popen([sys.executable, "-c", code], cwd=REPO, start_new_session=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.time() + 150
        while time.time() < deadline and proc.poll() is None:
            if out.is_dir() and any(out.rglob("*.png")):
                break
            time.sleep(0.05)
        else:
            pytest.fail("no image appeared" if proc.poll() is None else "generate finished")
        workers = [int(k) for k in Path(f"/proc/{proc.pid}/task/{proc.pid}/children")
                   .read_text().split()
                   if b"spawn_main" in Path(f"/proc/{k}/cmdline").read_bytes()]
        assert workers
        for k in workers:
            os.kill(k, signal.SIGKILL)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 1
    last = [ln for ln in err.splitlines() if ln.startswith("viewadapt generate")]
    assert len(last) == 1 and "worker process died" in last[0] and "resume" in last[0]
    assert "Traceback" not in err and "BrokenProcessPool" not in err
    assert not (out / "manifest.parquet").exists()            # no partial manifest
    res = generate(micro_config(), 3, out, jobs=0, progress=False)
    assert res.complete and res.n_kept >= 1
    a, b = file_hashes(micro), file_hashes(out)              # micro: uninterrupted
    assert a.keys() == b.keys()
    assert [k for k in a if a[k] != b[k]] == []
    meta = json.loads((out / "dataset.json").read_text())
    assert meta["content_hash"]["n_files"] == sum(not k.startswith(".") and
                                                 k != "dataset.json" for k in a)
    assert verify_dataset(out, check_hash=True).hash_ok


# -------------------------------------------------------- (8) failed runs leave things


def test_a_failed_crossval_says_what_it_kept_on_a_line_of_its_own(toy, tmp_path, capsys,
                                                                 monkeypatch):
    import benchmark.crops.crossval as crossval
    from tqdm.auto import tqdm

    def fails_after_caching(ds, cfg, cache):
        bar = tqdm(total=10, desc="features", file=sys.stderr)
        bar.update(3)
        cache.dir.mkdir(parents=True, exist_ok=True)
        np.save(cache.dir / "f.npy", np.zeros(3))
        raise ValueError("something went wrong")

    monkeypatch.setattr(crossval, "run_crossval", fails_after_caching)
    out = tmp_path / "res"
    argv = ["bench", "crossval", "--data", str(toy), "--out", str(out), "--quick"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    line = next(ln for ln in err.split("\n") if "something went wrong" in ln)
    assert line.startswith("viewadapt bench crossval: error:")   # not after the bar
    assert "kept 1 file(s)" in line and "cache/" in line and "nothing was written" not in line
    check_output_dir(out)                                # the rerun is not refused

    def fails_at_once(ds, cfg, cache):
        raise ValueError("bad settings")

    monkeypatch.setattr(crossval, "run_crossval", fails_at_once)
    out2 = tmp_path / "res2"
    assert main(["bench", "crossval", "--data", str(toy), "--out", str(out2)]) == 2
    assert not out2.exists()


def test_stale_partial_folders_of_dead_processes_are_removed(tmp_path):
    out = tmp_path / "res"
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = tmp_path / f".res.partial-{dead.pid}-abcd1234"
    live = tmp_path / f".res.partial-{os.getppid()}-efgh5678"
    for d in (stale, live):
        d.mkdir()
        (d / "x").write_text("half")
    with atomic_output_dir(out) as tmp:
        (tmp / "a.txt").write_text("a")
    assert not stale.exists() and live.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([live.name, "res"])


@pytest.mark.blender
@pytest.mark.filterwarnings("ignore:tostring.. is deprecated:DeprecationWarning")
def test_ctrl_c_of_generate_says_what_it_kept(micro, tmp_path, capsys, monkeypatch):
    from generator import pipeline

    real = pipeline.generate

    def interrupted_after_two_units(config, seed, out, **kw):
        n = []

        def log(res):
            n.append(res)
            if len(n) == 2:
                raise KeyboardInterrupt
        return real(config, seed, out, **dict(kw, jobs=0, log=log))

    monkeypatch.setattr(pipeline, "generate", interrupted_after_two_units)
    out = tmp_path / "ds"
    assert main(MICRO_ARGV + ["--out", str(out)]) == 130
    err = capsys.readouterr().err.strip().splitlines()[-1]
    n_png = len(list(out.rglob("*.png")))
    assert n_png == 6
    assert "nothing was written" not in err
    assert f"kept {n_png} of {MICRO_IMAGES} images" in err and "resume" in err
    assert not (out / "manifest.parquet").exists()
    monkeypatch.setattr(pipeline, "generate", real)
    res = real(micro_config(), 3, out, jobs=0, progress=False)
    assert res.complete and res.n_kept == 6
    assert file_hashes(out) == file_hashes(micro)


# ---------------------------------------------------------- (9) byte-identical datasets


@pytest.mark.slow
@pytest.mark.blender
def test_tiny_preset_killed_and_resumed_is_byte_identical(tmp_path):
    """Cycles: the tiny preset rendered twice, once killed (SIGKILL of the whole command)
    and resumed; every file's sha256 equal."""
    pytest.importorskip("bpy", reason="needs the generator extra")
    from generator.pipeline import generate
    from generator.sampling import preset_config

    ref, out = tmp_path / "ref", tmp_path / "killed"
    cmd = [sys.executable, "-m", "viewadapt.cli", "generate", "--preset", "tiny", "--quiet"]
    subprocess.run(cmd + ["--out", str(ref)], cwd=REPO, check=True, capture_output=True)
    proc = subprocess.Popen(cmd + ["--out", str(out)], cwd=REPO, start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.time() + 300
        while time.time() < deadline and proc.poll() is None:
            if (out / "person").is_dir() and len(list((out / "person").rglob("*.png"))) >= 10:
                break
            time.sleep(0.05)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    res = generate(preset_config("tiny"), 0, out, jobs=1, progress=False)
    assert res.complete and res.n_kept >= 10
    a, b = file_hashes(ref), file_hashes(out)
    assert a.keys() == b.keys() and [k for k in a if a[k] != b[k]] == []


# ------------------------------------------------------------------ (10) file permissions


def test_outputs_respect_the_umask(tmp_path):
    old = os.umask(0o027)
    try:
        atomic_write_text(tmp_path / "a.txt", "x")
        with atomic_output_dir(tmp_path / "res") as tmp:
            (tmp / "b.txt").write_text("y")
            (tmp / "sub").mkdir()
        os.umask(0o002)
        atomic_write_text(tmp_path / "c.txt", "z")
    finally:
        os.umask(old)
    assert (tmp_path / "a.txt").stat().st_mode & 0o777 == 0o640
    assert (tmp_path / "c.txt").stat().st_mode & 0o777 == 0o664
    assert (tmp_path / "res").stat().st_mode & 0o777 == 0o750
    assert (tmp_path / "res" / MARKER).stat().st_mode & 0o777 == 0o640


# ------------------------------------------------------------------------- (11) minor


@pytest.mark.blender
@pytest.mark.filterwarnings("ignore:tostring.. is deprecated:DeprecationWarning")
def test_a_larger_frames_extends_a_set_and_other_changes_are_named(micro, tmp_path):
    from generator.pipeline import generate
    from generator.verify import verify_dataset

    ds = tmp_path / "ds"
    shutil.copytree(micro, ds)
    with pytest.raises(ValueError, match=r"--samples 8 \(this run: 4\)"):
        generate(micro_config(samples=4), 3, ds, jobs=0, progress=False)
    res = generate(micro_config(frames=2), 3, ds, jobs=0, progress=False)
    assert res.complete and res.n_rendered == 1 and res.n_images == MICRO_IMAGES + 1
    assert verify_dataset(ds, check_hash=True).ok
    for rel in ("person/carpark/p001_i0_e0.png", "frames/carpark/frame_0.png"):
        assert (ds / rel).read_bytes() == (micro / rel).read_bytes()
    with pytest.raises(ValueError, match="frames can only be added"):
        generate(micro_config(frames=1), 3, ds, jobs=0, progress=False)


@pytest.mark.blender
@pytest.mark.filterwarnings("ignore:tostring.. is deprecated:DeprecationWarning")
def test_more_background_views_extend_a_set_as_if_rendered_at_once(micro, tmp_path):
    from generator.pipeline import generate

    grown, direct = tmp_path / "grown", tmp_path / "direct"
    shutil.copytree(micro, grown)
    res = generate(micro_config(backgrounds_per_scene=2), 3, grown, jobs=0, progress=False)
    assert res.complete and res.n_rendered == 3            # the new view, every elevation
    assert generate(micro_config(backgrounds_per_scene=2), 3, direct, jobs=0,
                    progress=False).complete
    want, got = file_bytes(direct), file_bytes(grown)
    assert want.keys() == got.keys()
    assert [k for k in want if want[k] != got[k]] == []
    assert all(got[k] == v for k, v in file_bytes(micro).items() if k.endswith(".png"))
    with pytest.raises(ValueError, match="background views can only be added"):
        generate(micro_config(), 3, grown, jobs=0, progress=False)


@pytest.mark.blender
@pytest.mark.filterwarnings("ignore:tostring.. is deprecated:DeprecationWarning")
def test_a_config_field_of_the_wrong_type_is_named(micro, tmp_path, capsys):
    from generator.sampling import GeneratorConfig

    with pytest.raises(ValueError, match="elevations must be a list of numbers"):
        GeneratorConfig.from_dict({"elevations": ["steep"]})
    with pytest.raises(ValueError, match="samples must be an integer, got 'many'"):
        GeneratorConfig.from_dict({"samples": "many"})
    ds = tmp_path / "ds"
    shutil.copytree(micro, ds)
    meta = json.loads((ds / "dataset.json").read_text())
    meta["config"]["elevations"] = ["steep"]
    (ds / "dataset.json").write_text(json.dumps(meta))
    assert main(["dataset", "verify", str(ds)]) == 1
    assert "elevations must be a list of numbers (radians), got ('steep',)" in \
        capsys.readouterr().out


# ------------------------------------- (9) Blender's PNGs (last: bpy joins this process)


@pytest.mark.blender
def test_blender_pngs_carry_no_date_or_render_time(tmp_path):
    pytest.importorskip("bpy", reason="needs the generator extra")
    from generator.blender import BlenderRenderer
    from generator.layout import layout_scene
    from generator.png import METADATA_CHUNKS, png_problem, strip_png_metadata
    from generator.sampling import GeneratorConfig, plan_dataset

    cfg = GeneratorConfig(preset="micro", person_ids=("p001",), scene_ids=("plaza",),
                          backgrounds_per_scene=1, frames=1, persons_per_frame=(1, 1))
    plan = plan_dataset(cfg, 0)
    unit = next(u for u in plan.units if u.kind == "background")
    s = unit.samples[0]
    r = BlenderRenderer(threads=2, n_slots=1, denoise=False)
    r.load_scene(layout_scene(plan.scenes[unit.scene_id]))
    r.set_persons([])
    r.set_lighting(s.lighting)
    cam = s.cameras[0]
    r.set_camera(cam.K, cam.R, cam.t, 64, 64, 1)
    r.render(tmp_path / "a.png", samples=1, seed=5)
    time.sleep(1.1)                                   # the date stamp has whole seconds
    r.render(tmp_path / "b.png", samples=1, seed=5)
    a, b = (tmp_path / "a.png").read_bytes(), (tmp_path / "b.png").read_bytes()
    assert png_problem(tmp_path / "a.png", (64, 64)) is None
    assert strip_png_metadata(a) is None                # no tEXt/zTXt/iTXt/tIME left
    assert a == b
    assert METADATA_CHUNKS == (b"tEXt", b"zTXt", b"iTXt", b"tIME")
