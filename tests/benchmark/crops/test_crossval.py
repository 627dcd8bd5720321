"""The benchmark pipeline end to end on the planar toy dataset (no Blender needed)."""

import json

import numpy as np
import pandas as pd
import pytest

from benchmark.crops.folds import make_folds
from benchmark.crops.summarize import operating_threshold
from benchmark.data import DatasetError, load_dataset, read_image
from benchmark.toydata import make_toy_dataset
from viewadapt.cli import main
from viewadapt.metrics import miss_rate_at_fppw


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    return make_toy_dataset(tmp_path_factory.mktemp("toy") / "data", n_persons=9, n_scenes=3,
                            n_backgrounds=2, seed=1)


@pytest.fixture(scope="module")
def results(toy, tmp_path_factory):
    out = tmp_path_factory.mktemp("res") / "results"
    assert main(["bench", "crossval", "--data", str(toy), "--out", str(out), "--quick",
                 "--detectors", "hog", "acf", "opencv"]) == 0
    assert main(["bench", "sweep", "--data", str(toy), "--out", str(out), "--quick",
                 "--step", str(np.pi / 36), "--sigma", "0.1"]) == 0
    return out


def test_folds_are_person_and_scene_disjoint_on_the_manifest(toy):
    ds = load_dataset(toy)
    p = ds.persons
    folds = make_folds(p["person_id"], p["scene_id"], rng=np.random.default_rng(0))
    assert len(folds) == 9
    tested = set()
    for f in folds:
        train = p[p["person_id"].isin(f.train_persons) & p["scene_id"].isin(f.train_scenes)]
        test = p[p["person_id"].isin(f.test_persons) & p["scene_id"].isin(f.test_scenes)]
        assert len(train) and len(test)
        assert not set(train["person_id"]) & set(test["person_id"])
        assert not set(train["scene_id"]) & set(test["scene_id"])
        tested |= set(zip(test["person_id"], test["scene_id"]))
    # every (person, scene) combination is tested exactly once over the nine folds
    assert tested == set(zip(p["person_id"], p["scene_id"]))


def test_too_few_persons_or_scenes():
    with pytest.raises(ValueError, match=r"at least 3 persons \(it has 2\)"):
        make_folds(["a", "b", "a"], ["s1", "s2", "s3"], rng=np.random.default_rng(0))
    with pytest.raises(ValueError, match="3 scenes"):
        make_folds(["a", "b", "c"], ["s1", "s1", "s2"], rng=np.random.default_rng(0))


def test_operating_threshold_matches_toolbox_rule():
    rng = np.random.default_rng(3)
    for _ in range(50):
        n_pos, n_neg = rng.integers(1, 40), rng.integers(1, 400)
        pos = np.round(rng.normal(1, 1, n_pos), 1)   # rounding makes ties
        neg = np.round(rng.normal(0, 1, n_neg), 1)
        y = np.r_[np.ones(n_pos), np.zeros(n_neg)].astype(int)
        want = miss_rate_at_fppw(y, np.r_[pos, neg], 1e-2)
        got = 1 - (pos >= operating_threshold(neg, 1e-2)).mean()
        assert np.isclose(got, want)


def test_results_schema_and_files(results):
    s = pd.read_csv(results / "summary.csv")
    for col in ("detector", "source_elevation", "target_elevation", "method", "mr_at_fppw_0.01",
                "mr_at_fppw_0.01_std", "lamr", "ci_low", "ci_high"):
        assert col in s.columns
    assert set(s["detector"]) == {"hog", "acf", "opencv"}
    hog0 = s[(s["detector"] == "hog") & np.isclose(s["source_elevation"], 0)]
    assert {"unadapted", "adapted", "image warping", "synthesised", "adapted[S only]",
            "adapted[paper eq.3]", "adapted[single A]"} <= set(hog0["method"])
    assert "oracle" in set(s.loc[s["detector"] == "hog", "method"])
    scores = pd.read_parquet(results / "scores.parquet")
    assert {"fold", "label", "score", "person_id", "scene_id", "method"} <= set(scores.columns)
    assert scores["fold"].nunique() == 9
    for name in ("det_hog.png", "det_hog.pdf", "det_acf.png", "det_opencv.png", "sweep.png",
                 "sweep.pdf", "score_shift.png", "remap_illustration.png", "report.md",
                 "paired_differences.csv", "sweep_summary.csv", "sweep_scores.parquet", "folds.json", "run.json"):
        assert (results / name).is_file(), name
    report = (results / "report.md").read_text()
    assert "det_hog.png" in report and "sweep.png" in report and "0.787" in report
    sw = pd.read_csv(results / "sweep_summary.csv")
    assert sw["estimate"].max() < np.pi / 2 and "unadapted" in set(sw["method"])
    # the sweep records its true elevation (the report and the intervals read it)
    assert json.loads((results / "run.json").read_text())["sweep"]["target"] == \
        pytest.approx(np.pi / 4)
    # adapting to the source's own elevation is the identity: same level as unadapted,
    # and the sweep's unadapted level is the cross-validation's (same folds, same pooling)
    un = sw.loc[sw["method"] == "unadapted", "mr_at_fppw_0.01"].iloc[0]
    at0 = sw.loc[(sw["method"] == "adapted") & (sw["estimate"] == 0), "mr_at_fppw_0.01"].iloc[0]
    assert np.isclose(un, at0)
    cv = s[(s["detector"] == "hog") & np.isclose(s["source_elevation"], 0)
           & (s["method"] == "unadapted")]["mr_at_fppw_0.01"].iloc[0]
    assert np.isclose(un, cv)


def test_planar_toy_data_adaptation_helps(results):
    # the toy persons are exactly planar: adapting 0 -> pi/4 must not be worse than not
    s = pd.read_csv(results / "summary.csv").set_index(["detector", "source_elevation", "method"])
    un = s.loc[("hog", 0.0, "unadapted"), "mr_at_fppw_0.01"]
    ad = s.loc[("hog", 0.0, "adapted"), "mr_at_fppw_0.01"]
    assert ad <= un


def test_results_dir_of_another_dataset_is_refused(results, tmp_path, capsys):
    other = make_toy_dataset(tmp_path / "other", n_persons=3, n_scenes=3, n_backgrounds=1, seed=7)
    before = sorted(p.name for p in results.iterdir())
    assert main(["bench", "crossval", "--data", str(other), "--out", str(results),
                 "--quick", "--detectors", "opencv"]) == 2
    assert "another dataset" in capsys.readouterr().err
    assert sorted(p.name for p in results.iterdir()) == before


def test_dataset_errors(toy, tmp_path):
    with pytest.raises(DatasetError, match="dataset.json is missing"):
        load_dataset(tmp_path)
    import shutil
    bad = tmp_path / "bad"
    shutil.copytree(toy, bad)
    man = pd.read_parquet(bad / "manifest.parquet")
    (bad / man["path"].iloc[0]).unlink()
    with pytest.raises(DatasetError, match="missing"):
        load_dataset(bad)
    man.iloc[1:].to_parquet(bad / "manifest.parquet")   # drop one view: pairing broken
    with pytest.raises(DatasetError, match="paired"):
        load_dataset(bad)
    (bad / "manifest.parquet").write_bytes(b"not parquet")
    with pytest.raises(DatasetError, match="cannot be read"):
        load_dataset(bad)
    corrupt = tmp_path / "c.png"
    corrupt.write_bytes(b"\x89PNG garbage")
    with pytest.raises(DatasetError, match="corrupt"):
        read_image(corrupt)


def test_cli_reports_dataset_errors_without_traceback(tmp_path, capsys):
    assert main(["bench", "crossval", "--data", str(tmp_path / "nope"), "--out",
                 str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "does not exist" in err and "Traceback" not in err
    assert not (tmp_path / "o").exists()
    assert main(["report", str(tmp_path)]) == 2


def test_reproduce_runs_every_stage_in_order(tmp_path, monkeypatch):
    import argparse

    import benchmark.pipelines as cli

    calls = []
    monkeypatch.setattr(cli, "main", lambda argv: calls.append(argv) or 0)
    monkeypatch.setattr(cli, "blender_available", lambda: True)
    from benchmark.recipes import get_recipe

    args = argparse.Namespace(out=tmp_path / "repro", seed=3, jobs=2, framing="silhouette",
                              recipe=get_recipe("elevation0"))
    assert cli._cmd_reproduce(args) == 0
    assert [c[:2] for c in calls] == [["generate", "--preset"], ["bench", "crossval"],
                                      ["bench", "sweep"], ["bench", "frames"]]
    assert "silhouette" in calls[0] and all("3" in c for c in calls)
    # every stage that trains gets the one recipe; rendering trains nothing
    assert "--recipe" not in calls[0]
    assert all(c[c.index("--recipe") + 1] == "elevation0" for c in calls[1:])
    stages = json.loads((tmp_path / "repro" / "reproduce.json").read_text())["stage_seconds"]
    assert len(stages) == 4
    # a failing stage stops the run with its exit code
    calls.clear()
    monkeypatch.setattr(cli, "main", lambda argv: calls.append(argv) or (2 if argv[0] == "bench"
                                                                      else 0))
    assert cli._cmd_reproduce(args) == 2 and len(calls) == 2


def test_sweep_in_two_processes_and_with_the_crossval_models_equals_one(toy, tmp_path):
    # the estimates are scored by worker processes in any order; the rows come back in the
    # order of one process, with the same scores bit for bit; the cross-validation's source
    # models are the ones the sweep trains
    from benchmark.crops.crossval import CrossvalConfig, run_crossval
    from benchmark.crops.features import FeatureCache
    from benchmark.crops.sweep import run_sweep

    ds = load_dataset(toy)
    cache = FeatureCache(ds, tmp_path / "cache", progress=False)

    def cfg(n):
        return CrossvalConfig(n_jobs=n, acf_estimators=8, acf_stages=(8,), detectors=("hog",),
                              ablations=False, synthesised=False, upper_bound=False)

    models = {}
    run_crossval(ds, cfg(2), cache, progress=False, models=models)
    assert len(models) == 27 and ("hog", 0.0, "p0s0") in models
    runs = [run_sweep(ds, cfg(n), cache, step=np.pi / 12, sigma=0.1, progress=False,
                      models=m) for n, m in ((1, None), (2, None), (1, models))]
    assert len(runs[0]) > 0 and runs[0]["estimate"].nunique() > 3
    for other in runs[1:]:
        pd.testing.assert_frame_equal(runs[0], other, check_exact=True)


def test_crossval_takes_prepared_data_only_for_its_own_configuration(toy, tmp_path):
    from dataclasses import replace

    from benchmark.crops.crossval import CrossvalConfig, prepare, run_crossval
    from benchmark.crops.features import FeatureCache

    ds = load_dataset(toy)
    cache = FeatureCache(ds, tmp_path / "cache", progress=False)
    cfg = CrossvalConfig(acf_estimators=8, acf_stages=(8,), detectors=("hog",),
                         ablations=False, synthesised=False, upper_bound=False,
                         sources=(0.0,))
    data = prepare(ds, cfg, cache)
    scores, _ = run_crossval(ds, cfg, cache, progress=False, data=data)
    again, _ = run_crossval(ds, cfg, cache, progress=False)
    pd.testing.assert_frame_equal(scores, again, check_exact=True)
    # the number of processes does not change what is prepared
    run_crossval(ds, replace(cfg, n_jobs=2), cache, progress=False, data=data)
    for other in (replace(cfg, target_cell_size=8), replace(cfg, sources=(0.0, np.pi / 8)),
                  replace(cfg, detectors=("hog", "acf"))):
        with pytest.raises(ValueError, match="prepared for another"):
            run_crossval(ds, other, cache, progress=False, data=data)


@pytest.mark.parametrize("extra, noted", [
    (["--object-models", "body"], True), (["--object-models", "body", "--no-upper-bound"], False),
    (["--object-models", "plane", "body"], False),
    (["--object-models", "body", "--detectors", "acf"], False)])
def test_crossval_says_when_the_exact_geometry_rows_cannot_run(toy, tmp_path, capsys,
                                                               monkeypatch, extra, noted):
    """The exact-geometry rows share the plane's adapted negatives: a HOG run without the
    plane gets none, and says so (before any work) instead of leaving them out silently."""
    from benchmark.crops import crossval

    def stop(*a, **k):                  # no need to run it: the note comes before the work
        raise KeyboardInterrupt

    monkeypatch.setattr(crossval, "run_crossval", stop)
    assert main(["bench", "crossval", "--data", str(toy), "--out", str(tmp_path / "o"),
                 "--quick", *extra]) != 0
    err = capsys.readouterr().err
    assert "interrupted" in err
    assert ("no exact-geometry rows without the plane" in err) is noted, err
