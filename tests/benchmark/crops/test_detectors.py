"""Detector specs: the built-ins, and a user's detector in a module of their own run by
``bench crossval`` without editing the project."""

import re
import sys
import textwrap

import numpy as np
import pandas as pd
import pytest

from benchmark.crops.detectors import BUILTIN_DETECTORS, detector_spec
from benchmark.toydata import make_toy_dataset
from viewadapt.cli import main
from tests.paths import REPO as REPO_ROOT

#: the worked example of docs/detectors.md: its python code block, run as a user's module
DOC = REPO_ROOT / "docs" / "detectors.md"
USER_MODULE = re.search(r"```python\n(.*?)```", DOC.read_text(encoding="utf-8"), re.S).group(1)


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    return make_toy_dataset(tmp_path_factory.mktemp("toy") / "data", n_persons=9, n_scenes=3,
                            n_backgrounds=2, seed=2)


@pytest.fixture
def user_module(tmp_path, monkeypatch):
    pkg = tmp_path / "user_pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "hog12.py").write_text(textwrap.dedent(USER_MODULE))
    monkeypatch.syspath_prepend(str(tmp_path))
    yield "user_pkg.hog12:Hog12Detector"
    for m in [m for m in sys.modules if m.startswith("user_pkg")]:
        del sys.modules[m]
    detector_spec.cache_clear()


def test_a_users_detector_runs_in_the_cross_validation(toy, tmp_path, user_module):
    out = tmp_path / "res"
    # one process: worker processes started earlier in the session would not see the
    # temporary module (with --jobs > 1 a user's module must be importable, as installed)
    assert main(["bench", "crossval", "--data", str(toy), "--out", str(out), "--quick",
                 "--jobs", "1", "--detectors", "hog", user_module]) == 0
    s = pd.read_csv(out / "summary.csv")
    mine = s[s["detector"] == "hog12"]
    assert set(mine["method"]) >= {"unadapted", "adapted", "adapted[S only]",
                                   "adapted[paper eq.3]", "image warping", "synthesised",
                                   "oracle"}
    assert mine["n_pos"].gt(0).all() and mine["mr_at_fppw_0.01"].between(0, 1).all()
    assert (out / "det_hog12.png").is_file()
    # the toy persons are planar: adapting 0 -> pi/4 helps this detector too
    row = mine.set_index(["source_elevation", "method"])["mr_at_fppw_0.01"]
    assert row[(0.0, "adapted")] <= row[(0.0, "unadapted")]
    # its features were cached under its own key
    assert list((out / "cache").glob("hog12-cells8-v1-*.npy"))


def test_bad_detector_names_are_one_line_errors(toy, tmp_path, capsys, user_module):
    for name, msg in (("nothing", "unknown detector 'nothing'"),
                      ("no_such_pkg.mod:X", "cannot load detector"),
                      ("user_pkg.hog12:Missing", "cannot load detector"),
                      ("user_pkg.hog12:Hog12Cells", "cannot create detector"),
                      ("user_pkg.hog12:np", "lacks")):
        assert main(["bench", "crossval", "--data", str(toy), "--out", str(tmp_path / "r"),
                     "--quick", "--detectors", name]) == 2
        err = capsys.readouterr().err
        assert msg in err and err.count("\n") == 1
    assert not (tmp_path / "r").exists()                 # refused before any work


def test_builtin_specs_fold_G_as_the_explicit_remap():
    """score_adapted of every built-in equals its score on the explicitly remapped features
    (or, for trees, the remapped features of the used rows)."""
    from types import SimpleNamespace

    from viewadapt.geometry import elevation_homography

    from benchmark.recipes import RECIPES

    cfg = SimpleNamespace(target_cell_size=4, C=0.01, initial_negatives=200, mining_rounds=0,
                          max_hard_negatives=100, acf_estimators=8, acf_stages=None,
                          acf_max_bins=16, acf_max_features=0.5, recipe=RECIPES["elevation0"])
    rng = np.random.default_rng(0)
    H = elevation_homography(0.0, np.pi / 4)
    for name in ("hog", "hog_local", "opencv"):
        spec = BUILTIN_DETECTORS[name]
        G = spec.remap_matrix(H, rule="covariant", per_cell=True, config=cfg)
        Xt = rng.random((30, G.shape[1])).astype(np.float32)
        Xp, Xn = rng.random((20, G.shape[0])), rng.random((40, G.shape[0]))
        model = spec.fit(Xp, Xn, seed=0, config=cfg)
        direct = spec.score(model, np.asarray((G @ Xt.T.astype(np.float64)).T))
        assert np.allclose(spec.score_adapted(model, Xt, G), direct, rtol=1e-6, atol=1e-6)
