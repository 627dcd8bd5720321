import numpy as np
import pytest

from benchmark.data import load_dataset
from benchmark.frames.methods import train_source_detectors
from benchmark.studies.average_models import main
from tests.toy_frames import small_toy_frames
from viewadapt.boosting import AdaBoostTrees
from viewadapt.ensembles import average_source_detectors
from viewadapt.io import SourceDetectors


@pytest.fixture(scope="module")
def two(tmp_path_factory):
    root = tmp_path_factory.mktemp("avgm")
    ds = load_dataset(small_toy_frames(root / "data"))
    paths = []
    for s in (0, 1):
        p = root / f"m{s}.npz"
        # single-model files (the averaged recipe's already hold nine members each)
        train_source_detectors(ds, quick=True, seed=s, recipe="elevation0").save(p)
        paths.append(p)
    return paths


def _free(trees):
    out = AdaBoostTrees.from_arrays(*trees.to_arrays())
    out.cascade_threshold = None
    return out


def test_the_average_of_two_files_scores_their_mean(two, tmp_path):
    out = tmp_path / "avg.npz"
    assert main([str(p) for p in two] + ["--out", str(out)]) == 0
    avg, a, b = (SourceDetectors.load(p) for p in (out, *two))
    np.testing.assert_allclose(avg.hog_weights, (a.hog_weights + b.hog_weights) / 2)
    assert avg.hog_bias == pytest.approx((a.hog_bias + b.hog_bias) / 2)
    X = np.random.default_rng(0).random((40, a.acf.n_features_in_))
    want = (_free(a.acf).decision_function(X) + _free(b.acf).decision_function(X)) / 2
    np.testing.assert_allclose(_free(avg.acf).decision_function(X), want, rtol=1e-10, atol=1e-10)
    assert [r["seed"] for r in avg.training["average_of"]] == [0, 1]
    assert avg.training["average_of_files"] == [str(p) for p in two]


def test_bad_inputs_are_one_line_errors_and_write_nothing(two, tmp_path, capsys):
    out = tmp_path / "avg.npz"
    with pytest.raises(SystemExit):
        main([str(two[0]), "--out", str(out)])                       # one model
    assert main([str(two[0]), str(tmp_path / "missing.npz"), "--out", str(out)]) == 2
    assert "missing.npz" in capsys.readouterr().err
    assert not out.exists()
    out.write_bytes(b"mine")
    with pytest.raises(SystemExit):
        main([str(p) for p in two] + ["--out", str(out)])            # never overwritten
    assert out.read_bytes() == b"mine"
    with pytest.raises(ValueError, match="at least two"):
        average_source_detectors([SourceDetectors.load(two[0])])


def test_the_gated_average_splits_averaged_members_and_scores_the_same_mean(two, tmp_path):
    plain, gated = tmp_path / "plain.npz", tmp_path / "gated.npz"
    assert main([str(p) for p in two] + ["--out", str(plain), "--plain"]) == 0
    assert main([str(p) for p in two] + ["--out", str(gated)]) == 0
    p, g, a = (SourceDetectors.load(f) for f in (plain, gated, two[0]))
    n = a.acf.n_estimators_
    assert g.training["acf_gate"] is True and "acf_gate" not in p.training
    np.testing.assert_array_equal(g.acf.cascade_scale_[:n], 2.0)     # the first file gates
    np.testing.assert_array_equal(g.acf.cascade_scale_[n:], 1.0)
    X = np.random.default_rng(1).random((40, a.acf.n_features_in_))
    np.testing.assert_allclose(_free(g.acf).decision_function(X),
                               _free(p.acf).decision_function(X), rtol=0, atol=1e-10)
    np.testing.assert_array_equal(g.hog_weights, p.hog_weights)


def test_files_whose_members_stopped_at_different_lengths_are_averaged(tmp_path):
    from benchmark.recipes import Recipe

    ds = load_dataset(small_toy_frames(tmp_path / "data"))
    three = Recipe("three", "three ACF members", svm_c=0.001, acf_members=3)
    paths = []
    for s in (0, 1):
        m = train_source_detectors(ds, quick=True, seed=s, recipe=three)
        # the record says how many trees each member kept, which split_average needs
        assert sum(m.training["acf_member_trees"]) == m.acf.n_estimators_
        paths.append(tmp_path / f"m{s}.npz")
        m.save(paths[-1])
    out = tmp_path / "avg.npz"
    assert main([str(p) for p in paths] + ["--out", str(out)]) == 0
    avg, a, b = (SourceDetectors.load(p) for p in (out, *paths))
    lengths = a.training["acf_member_trees"] + b.training["acf_member_trees"]
    assert avg.acf.n_estimators_ == sum(lengths)
    X = np.random.default_rng(2).random((40, a.acf.n_features_in_))
    want = (_free(a.acf).decision_function(X) + _free(b.acf).decision_function(X)) / 2
    np.testing.assert_allclose(_free(avg.acf).decision_function(X), want, rtol=0, atol=1e-10)
    # every member of both files, the first of the first gating the rest
    np.testing.assert_array_equal(avg.acf.cascade_scale_[:lengths[0]], 6.0)
    np.testing.assert_array_equal(avg.acf.cascade_scale_[lengths[0]:], 1.0)
