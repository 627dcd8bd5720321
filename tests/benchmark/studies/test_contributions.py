"""benchmark.studies.contributions on the planar toy dataset: contributions add up to the scores."""

import numpy as np
import pandas as pd
import pytest

from benchmark.studies.contributions import (
    CELL_REPS, CELL_SHAPE, VARIANTS, bin_energy, check_request, descriptor_cell_matrix, main,
    model_inputs, run_contributions, score_contributions,
)
from benchmark.crops.crossval import CrossvalConfig, fold_masks, task_seed, variant_remap, view_maps
from benchmark.crops.detectors import detector_spec
from benchmark.crops.features import FeatureCache, background_windows, person_windows
from benchmark.crops.folds import make_folds
from benchmark.data import load_dataset
from benchmark.toydata import make_toy_dataset
from viewadapt.adapt import cells_to_descriptor


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    return make_toy_dataset(tmp_path_factory.mktemp("toy") / "data", n_persons=9, n_scenes=3,
                            n_backgrounds=1, seed=1)


@pytest.fixture(scope="module")
def cache_dir(tmp_path_factory):
    """One feature cache for the module (the CLI run reuses the fixture's features)."""
    return tmp_path_factory.mktemp("cache")


@pytest.fixture(scope="module")
def trained(toy, cache_dir):
    """Per detector: the source model of fold 0 and pi/4 test features in every cell size."""
    ds = load_dataset(toy)
    cfg = CrossvalConfig(initial_negatives=2000)
    cache = FeatureCache(ds, cache_dir, progress=False)
    p = ds.persons
    fold = make_folds(p["person_id"], p["scene_id"], rng=np.random.default_rng(cfg.seed))[0]
    e0, et = ds.elevation_index(0.0), ds.elevation_index(cfg.target)
    out = {}
    for det in CELL_REPS:
        spec, r8 = detector_spec(det), CELL_REPS[det][8]
        tr = [(w, fold_masks(w.meta, fold, True)) for w in (person_windows(ds, e0),
                                                            background_windows(ds, e0))]
        Xp, Xn = (cache.get(w, r8)[m] for w, m in tr)
        model = spec.fit(Xp, Xn, seed=task_seed(cfg.seed, det, 0.0, fold), config=cfg)
        X = {c: np.vstack([cache.get(w, r) for w in (person_windows(ds, et),
                                                     background_windows(ds, et))])
             for c, r in CELL_REPS[det].items()}
        out[det] = (spec, model, X)
    return ds, cfg, out


def test_descriptor_cell_matrix_sends_each_element_to_its_cell():
    P = descriptor_cell_matrix()
    assert P.shape == (3780, int(np.prod(CELL_SHAPE)))
    assert np.all(np.asarray(P.sum(1)).ravel() == 1)              # one (cell, bin) each
    for y, x, b in ((0, 0, 0), (15, 7, 8), (7, 3, 4), (0, 7, 2)):
        cells = np.zeros(CELL_SHAPE)
        cells[y, x, b] = 1.0
        d = cells_to_descriptor(cells.ravel())
        back = (P.T @ (d > 0).astype(float)).reshape(CELL_SHAPE)
        assert back[y, x, b] > 0 and back.sum() == back[y, x, b]
        # interior cells sit in 4 blocks, corners in 1
        assert back[y, x, b] == (1 + (0 < y < 15)) * (1 + (0 < x < 7))


@pytest.mark.parametrize("det", sorted(CELL_REPS))
def test_contributions_sum_to_the_decision_function(trained, det):
    ds, cfg, out = trained
    spec, model, X = out[det]
    # unadapted: the source model on the pi/4 8-px cells
    C, b = score_contributions(det, model, model_inputs(det, X[8]))
    ref = spec.score(model, X[8])
    np.testing.assert_allclose(C.sum((1, 2, 3)) + b, ref, atol=1e-6, rtol=0)
    if det == "hog":
        np.testing.assert_allclose(
            C.sum((1, 2, 3)) + b, model.decision_function(cells_to_descriptor(X[8])), atol=1e-6)
    import dataclasses

    maps = view_maps(0.0, cfg.target, cfg)
    for v, method in VARIANTS.items():
        model_name = "body" if "body" in v else "plane"
        for c in (4, 8):
            G = variant_remap(det, maps[model_name], method,
                              dataclasses.replace(cfg, target_cell_size=c))
            C, b = score_contributions(det, model, model_inputs(det, X[c], G))
            s = spec.score_adapted(model, X[c], G)
            cell_map, bins = C.sum(-1), C.sum((1, 2))
            assert cell_map.shape == (len(s), 16, 8) and bins.shape == (len(s), 9)
            np.testing.assert_allclose(cell_map.sum((1, 2)) + b, s, atol=1e-6, rtol=0)
            np.testing.assert_allclose(bins.sum(1) + b, s, atol=1e-6, rtol=0)
            np.testing.assert_allclose(bins.sum(1), cell_map.sum((1, 2)), atol=1e-9)


def test_bad_requests_are_value_errors():
    with pytest.raises(ValueError, match="unknown variant 'covariant'"):
        check_request(["hog"], ["covariant"], 9, (4,))
    with pytest.raises(ValueError, match="unknown detector 'acf'"):
        check_request(["acf"], list(VARIANTS), 9, (4,))
    with pytest.raises(ValueError, match="cell size 6"):
        check_request(["hog"], list(VARIANTS), 9, (6,))
    for n in (0, 10, -1, 2.5, True):
        with pytest.raises(ValueError, match="--folds must be an integer in 1..9"):
            check_request(["hog"], list(VARIANTS), n, (4,))
    check_request(["hog", "hog_local"], list(VARIANTS), 9, (4, 8))


def test_bin_energy_is_a_mean_of_normalised_histograms():
    E = np.zeros((3, 128 * 9))
    E[0, 0] = 2.0                       # all in bin 0
    E[1, 9 + 4] = 5.0                   # all in bin 4 (another cell)
    h = bin_energy(E)                   # the empty window is left out
    np.testing.assert_allclose(h, np.r_[0.5, 0, 0, 0, 0.5, 0, 0, 0, 0])


def test_run_rejects_bad_fold_counts_before_work(toy, tmp_path):
    ds = load_dataset(toy)
    cache = FeatureCache(ds, tmp_path / "cache", progress=False)
    for n in (0, 10):
        with pytest.raises(ValueError, match="--folds"):
            run_contributions(ds, CrossvalConfig(), cache, n_folds=n)
    with pytest.raises(ValueError, match="unknown variant"):
        run_contributions(ds, CrossvalConfig(), cache, variants=("covariant, sphere",))
    assert not (tmp_path / "cache").exists()


def test_cli_writes_consistent_tables(toy, trained, cache_dir, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["--data", str(toy), "--out", str(out), "--folds", "1", "--quick",
                 "--cache", str(cache_dir)]) == 0
    text = capsys.readouterr().out
    assert "fold 1/1 p0s0" in text
    for f in ("score_summary.csv", "contributions.csv", "bins.csv", "bin_energy.csv",
              "bin_ablation.csv",
              "histogram_distances.csv", "contribution_maps.png", "bin_contributions.png",
              "contribution_maps_hog_local.png", "contributions.md", "run.json"):
        assert (out / f).is_file() and (out / f).stat().st_size > 0, f
    S = pd.read_csv(out / "score_summary.csv")
    assert set(S["variant"]) == set(VARIANTS) | {"unadapted", "oracle", "source view"}
    assert len(S) == 2 * (2 * len(VARIANTS) + 3)
    np.testing.assert_allclose(S["margin"], S["persons_mean"] - S["top1pct_background_mean"],
                               atol=1e-5)
    C = pd.read_csv(out / "contributions.csv")
    B = pd.read_csv(out / "bins.csv")
    key = ["detector", "variant", "cell_size"]
    for pop, bias, mean in (("persons", "persons_bias_mean", "persons_mean"),
                            ("top1pct_background", "top_bias_mean", "top1pct_background_mean")):
        tot_c = C[C["population"] == pop].groupby(key)["contribution"].sum()
        tot_b = B[B["population"] == pop].groupby(key)["contribution"].sum()
        ref = S.set_index(key)
        np.testing.assert_allclose(tot_c + ref.loc[tot_c.index, bias], ref.loc[tot_c.index, mean],
                                   atol=1e-4)
        np.testing.assert_allclose(tot_b.loc[tot_c.index], tot_c, atol=1e-4)
    assert C.groupby(key + ["population"]).size().eq(128).all()
    A = pd.read_csv(out / "bin_ablation.csv")
    assert len(A) == 2 * (len(VARIANTS) + 3) * 10           # 4-px variants + references
    assert A["mr_at_fppw_0.01"].between(0, 1).all()
    D = pd.read_csv(out / "histogram_distances.csv")
    assert (D.loc[D["variant"] == "elevation 0", "l1_to_elevation0"] == 0).all()
    assert ((D["l1_to_elevation0"] >= 0) & (D["l1_to_elevation0"] <= 2)).all()
    E = pd.read_csv(out / "bin_energy.csv")
    np.testing.assert_allclose(E.groupby(["detector", "population", "variant", "cell_size"])
                               ["energy_fraction"].sum(), 1.0, atol=1e-5)


def test_cli_reports_bad_input_without_traceback(toy, tmp_path, capsys):
    assert main(["--data", str(toy), "--out", str(tmp_path / "o"), "--folds", "12"]) == 2
    assert "--folds must be an integer in 1..9" in capsys.readouterr().err
    assert main(["--data", str(tmp_path / "nope"), "--out", str(tmp_path / "o")]) == 2
    assert not (tmp_path / "o").exists()
