import json

import numpy as np
import pytest

from benchmark.data import load_dataset
from benchmark.frames.methods import train_source_detectors
from benchmark.studies.acf_budget import main, truncated_trees
from tests.toy_frames import small_toy_frames
from viewadapt.io import SourceDetectors


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    return small_toy_frames(tmp_path_factory.mktemp("acfb") / "data")


def test_budgets_are_truncations_and_the_smallest_is_bench_frames_own(toy, tmp_path):
    out = tmp_path / "out"
    assert main(["--data", str(toy), "--out", str(out), "--trees", "16,64,8", "--quick"]) == 0
    rec = json.loads((out / "acf_budget.json").read_text())
    assert rec["budgets"] == [8, 16, 64] and rec["saved"][:2] == [8, 16]
    models = {n: SourceDetectors.load(out / f"trees_{n}" / "source_detectors.npz")
              for n in rec["saved"]}
    assert all(m.acf.n_estimators_ == n for n, m in models.items())
    longest = models[rec["saved"][-1]]
    for n, m in models.items():           # each budget is the first n trees of one run
        assert np.array_equal(m.acf.feature_, longest.acf.feature_[:n])
        assert np.array_equal(m.acf.value_, longest.acf.value_[:n])
        assert m.training["acf_trees"] == n and not m.training["acf_budget"]["no_colour"]
    # 64 trees (bench frames' quick budget) are bench frames' own trees under the paper's
    # training (the study's recipe), and its SVM
    ref = train_source_detectors(load_dataset(toy), quick=True, recipe="elevation0")
    if 64 in models:
        assert np.array_equal(models[64].acf.feature_, ref.acf.feature_)
        assert np.allclose(models[64].acf.value_, ref.acf.value_)
    assert np.array_equal(longest.hog_weights, ref.hog_weights)
    with pytest.raises(ValueError, match="cannot keep"):
        truncated_trees(longest.acf, longest.acf.n_estimators_ + 1)


def test_without_colour_no_tree_reads_a_colour_channel(toy, tmp_path):
    out = tmp_path / "nc"
    assert main(["--data", str(toy), "--out", str(out), "--trees", "32", "--no-colour",
                 "--quick"]) == 0
    rec = json.loads((out / "acf_budget.json").read_text())
    m = SourceDetectors.load(out / f"trees_{rec['saved'][-1]}" / "source_detectors.npz")
    per_channel = 32 * 16
    used = np.asarray(m.acf.feature_)
    assert rec["no_colour"] and used.size and used[used >= 0].min() >= 3 * per_channel
    for bad in ("0", "8,x"):
        with pytest.raises(SystemExit):
            main(["--data", str(toy), "--out", str(tmp_path / "bad"), "--trees", bad])


def test_learning_rate_shrinks_every_tree_and_is_recorded(toy, tmp_path):
    plain, slow = tmp_path / "plain", tmp_path / "slow"
    assert main(["--data", str(toy), "--out", str(plain), "--trees", "8", "--quick"]) == 0
    assert main(["--data", str(toy), "--out", str(slow), "--trees", "8", "--quick",
                 "--learning-rate", "0.5"]) == 0
    rec = json.loads((slow / "acf_budget.json").read_text())
    a = SourceDetectors.load(plain / "trees_8" / "source_detectors.npz").acf
    b = SourceDetectors.load(slow / "trees_8" / "source_detectors.npz").acf
    assert rec["learning_rate"] == 0.5 and b.learning_rate == 0.5 and a.learning_rate == 1.0
    # the same first split, its outputs halved; the training record names the rate
    assert np.array_equal(a.feature_[0], b.feature_[0])
    assert np.allclose(b.value_[0], 0.5 * a.value_[0])
    with pytest.raises(SystemExit):
        main(["--data", str(toy), "--out", str(tmp_path / "bad"), "--learning-rate", "0"])


def test_depth_one_trains_stumps(toy, tmp_path):
    out = tmp_path / "stumps"
    assert main(["--data", str(toy), "--out", str(out), "--trees", "8", "--quick",
                 "--depth", "1"]) == 0
    rec = json.loads((out / "acf_budget.json").read_text())
    m = SourceDetectors.load(out / "trees_8" / "source_detectors.npz").acf
    assert rec["depth"] == 1 and m.max_depth == 1 and m.feature_.shape[1] == 3
    assert (m.feature_[:, 0] >= 0).all() and (m.feature_[:, 1:] == -1).all()
    with pytest.raises(SystemExit):
        main(["--data", str(toy), "--out", str(tmp_path / "bad"), "--depth", "0"])
