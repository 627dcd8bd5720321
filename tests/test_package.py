import subprocess
import sys

import numpy as np
import pytest

import viewadapt
from viewadapt.cli import main


def test_import_never_pulls_blender_or_torch():
    # numba too: the JIT loads only when a full-frame operator first scores a frame
    code = ("import sys, viewadapt, viewadapt.detect; bad = [m for m in "
            "('bpy', 'torch', 'anny', 'benchmark', 'numba') "
            "if m in sys.modules]; print(bad); sys.exit(1 if bad else 0)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr


def test_public_names_exist():
    for name in viewadapt.__all__:
        assert hasattr(viewadapt, name), name
    for name in ("feature_remap_matrix", "adapt_linear_weights", "hog_descriptor",
                 "acf_channels", "log_average_miss_rate", "ViewpointAdaptedClassifier"):
        assert name in viewadapt.__all__


def test_cli_help_and_version(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--help"])
    assert e.value.code == 0
    assert "fidelity" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main(["--version"])
    assert "viewadapt" in capsys.readouterr().out
    assert main([]) == 2


def test_cli_bad_input_is_one_line_error(tmp_path, capsys):
    f = tmp_path / "file"
    f.write_text("x")
    assert main(["fidelity", "--out", str(f), "--windows", "1"]) == 2
    err = capsys.readouterr().err
    assert "not a directory" in err and "Traceback" not in err
    assert main(["fidelity", "--out", str(tmp_path / "o"), "--windows", "0"]) == 2
    assert not (tmp_path / "o").exists()
    capsys.readouterr()
    assert main(["fidelity", "--out", str(tmp_path / "o"), "--distance", "0.5"]) == 2
    err = capsys.readouterr().err
    assert "--distance: distance must be finite and exceed half the person height" in err
    assert err.count("\n") == 1
    assert not (tmp_path / "o").exists()


def test_cli_fidelity_writes_everything(tmp_path):
    out = tmp_path / "fid"
    assert main(["fidelity", "--out", str(out), "--windows", "1", "--synthetic", "1"]) == 0
    names = {p.name for p in out.iterdir()}
    for want in ("fidelity_summary.csv", "fidelity_summary.md", "fidelity_windows.csv",
                 "fidelity_8px.png", "fidelity_8px.pdf", "remap_illustration.png",
                 "metadata.json"):
        assert want in names
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".fid.partial")]
    import json
    import pandas as pd
    assert json.loads((out / "metadata.json").read_text())["seed"] == 0
    s = pd.read_csv(out / "fidelity_summary.csv")
    assert {"feature", "rule", "form", "median", "p10"} <= set(s.columns)
    assert set(s["rule"]) == {"unadapted", "covariant", "paper", "none"}
    assert json.loads((out / "metadata.json").read_text())["distance"] == 10.0


def test_fidelity_uses_the_camera_distance_it_is_given():
    """The same windows remapped by the homography of a 5 m and of a 10 m crop camera: the
    target windows read are the same, the remapped features are not."""
    from benchmark.crops.fidelity import remap_fidelity, synthetic_images

    imgs = synthetic_images(np.random.default_rng(0), n=1)
    kw = dict(pairs=((0.0, np.pi / 4),), windows_per_image=2, acf=False, rules=("covariant",),
              target_cell_sizes=(4,))
    near, far = (remap_fidelity(imgs, rng=np.random.default_rng(1), distance=d, **kw)
                 for d in (5.0, 10.0))
    default = remap_fidelity(imgs, rng=np.random.default_rng(1), **kw)
    assert default.equals(far)
    cov = near["rule"] == "covariant"
    assert len(near) == len(far) and cov.any()
    assert not np.allclose(near.loc[cov, "pearson"], far.loc[cov, "pearson"])


def test_jobs_defaults_are_per_command():
    """--jobs is 1 unless a command says otherwise (demo, reproduce, bench runtime: all
    cores), and one command's default never leaks into the others (argparse shares a parent
    parser's arguments between subcommands)."""
    from viewadapt.cli import build_parser

    p = build_parser()
    one = (["bench", "crossval", "--data", "d"], ["bench", "sweep", "--data", "d"],
           ["bench", "frames", "--data", "d"], ["generate"], ["fidelity"])
    for argv in one:
        assert p.parse_args(argv + ["--out", "o"]).jobs == 1, argv
    for argv in (["demo"], ["reproduce"], ["bench", "runtime", "--data", "d"]):
        assert p.parse_args(argv + ["--out", "o"]).jobs == -1, argv
    assert p.parse_args(["demo", "--out", "o", "--jobs", "2"]).jobs == 2
