import numpy as np
import pytest

from benchmark.data import load_dataset
from benchmark.frames.methods import train_source_detectors
from benchmark.studies.svm_budget import main
from tests.toy_frames import small_toy_frames
from viewadapt.io import SourceDetectors


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    return small_toy_frames(tmp_path_factory.mktemp("svmb") / "data")


def test_default_c_is_the_papers_training_and_other_settings_change_only_the_svm(toy, tmp_path):
    ref = train_source_detectors(load_dataset(toy), quick=True, recipe="elevation0")
    runs = {}
    for name, argv in {"default": [], "strong": ["--C", "0.001"],
                       "all": ["--all-negatives"]}.items():
        assert main(["--data", str(toy), "--out", str(tmp_path / name), "--quick", *argv]) == 0
        runs[name] = SourceDetectors.load(tmp_path / name / "source_detectors.npz")
    assert np.array_equal(runs["default"].hog_weights, ref.hog_weights)
    assert runs["default"].hog_bias == ref.hog_bias
    for m in runs.values():                                           # trees untouched
        assert np.array_equal(m.acf.feature_, ref.acf.feature_)
    assert not np.array_equal(runs["strong"].hog_weights, ref.hog_weights)
    # every negative at once differs from one mining round only when the pool is larger
    # than the initial draw (quick: 2000)
    pool = 2 * ref.training["background_windows"]              # and their frame-view copies
    assert np.array_equal(runs["all"].hog_weights, ref.hog_weights) == (pool <= 2000)
    assert runs["strong"].training["svm_params"] == {"C": 0.001}
    assert runs["all"].training["svm_params"]["mining_rounds"] == 0
    # stronger regularisation: smaller weights
    assert np.linalg.norm(runs["strong"].hog_weights) < np.linalg.norm(ref.hog_weights)
    for bad in ("0", "-1", "inf"):
        with pytest.raises(SystemExit):
            main(["--data", str(toy), "--out", str(tmp_path / "bad"), "--C", bad])
