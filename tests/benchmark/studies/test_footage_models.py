"""benchmark.studies.footage_models: source models compared on one clip, paired."""

import json

import numpy as np
import pytest

from benchmark.data import load_dataset
from benchmark.footage.run import open_clip
from benchmark.frames.methods import train_source_detectors
from benchmark.frames.spec import FrameMethod
from benchmark.studies.footage_models import compare_models, main
from viewadapt.io import SourceDetectors
from tests.toy_frames import mot_toy_clip


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    root = tmp_path_factory.mktemp("models")
    toy = mot_toy_clip(root, n_frames=4)
    # a second model: the same data, the HOG/SVM trained with another seed and ACF kept
    other = train_source_detectors(load_dataset(root / "data"), quick=True, seed=7,
                                   frame_view="none")
    other.save(root / "other.npz")
    return toy, root / "other.npz"


def test_the_same_model_twice_differs_by_nothing(clip):
    toy, _ = clip
    c = open_clip([str(toy.img1)], toy.calibration, toy.gt)
    m = SourceDetectors.load(toy.model)
    methods = [FrameMethod.parse("hog_adapted")]
    rows = compare_models(c, {"a": m, "b": SourceDetectors.load(toy.model)}, methods,
                          heights=(1.75,))
    assert [(r["model"], r["method"]) for r in rows] == [("a", "hog_adapted"),
                                                          ("b", "hog_adapted")]
    assert rows[0]["lamr"] == rows[1]["lamr"]
    assert "difference" not in rows[0]
    assert rows[1]["reference"] == "a"
    assert rows[1]["difference"] == 0.0
    assert rows[1]["difference_low"] == rows[1]["difference_high"] == 0.0


def test_another_model_is_paired_against_the_first(clip, tmp_path):
    toy, other = clip
    out = tmp_path / "out"
    assert main([str(toy.img1), "--calibration", str(toy.calibration), "--boxes",
                 str(toy.gt), "--model", f"first={toy.model}", "--model", f"second={other}",
                 "--methods", "hog_adapted", "--block", "2", "--out", str(out)]) == 0
    import pandas as pd

    df = pd.read_csv(out / "models_summary.csv")
    assert df["model"].tolist() == ["first", "second"]
    first, second = df.iloc[0], df.iloc[1]
    assert np.isnan(first["difference"])
    # the point difference is the difference of the two LAMRs; the interval holds it
    assert second["difference"] == pytest.approx(second["lamr"] - first["lamr"], abs=1e-4)
    assert second["difference_low"] <= second["difference"] + 1e-9
    assert second["difference"] <= second["difference_high"] + 1e-9
    assert first["lamr_low"] <= first["lamr"] <= first["lamr_high"]
    run = json.loads((out / "run.json").read_text())
    assert list(run["models"]) == ["first", "second"]
    assert run["models"]["second"][0]["path"] == str(other)
    assert "| second | hog_adapted |" in (out / "models_summary.md").read_text()


def test_a_model_without_a_label_is_refused(clip, tmp_path, capsys):
    toy, _ = clip
    with pytest.raises(SystemExit):
        main([str(toy.img1), "--calibration", str(toy.calibration), "--boxes", str(toy.gt),
              "--model", str(toy.model), "--out", str(tmp_path / "o")])
    assert "LABEL=FILE" in capsys.readouterr().err


def test_a_label_of_several_models_is_compared_by_its_mean(clip):
    toy, other = clip
    c = open_clip([str(toy.img1)], toy.calibration, toy.gt)
    a, b = SourceDetectors.load(toy.model), SourceDetectors.load(other)
    methods = [FrameMethod.parse("hog_adapted")]
    single = compare_models(c, {"a": a, "b": b}, methods, heights=(1.75,))
    rows = compare_models(c, {"a": [a, a], "ab": [a, b]}, methods, heights=(1.75,), block=2)
    la, lb = single[0]["lamr"], single[1]["lamr"]
    assert rows[0]["models"] == 2 and rows[0]["lamr"] == pytest.approx(la)
    assert rows[0]["lamr_low"] == rows[0]["lamr_high"] == pytest.approx(la)
    r = rows[1]
    assert r["lamr"] == pytest.approx((la + lb) / 2)
    assert (r["lamr_low"], r["lamr_high"]) == pytest.approx((min(la, lb), max(la, lb)))
    assert r["lamr_each"] == f"{la:.3f} {lb:.3f}"
    assert r["difference"] == pytest.approx((lb - la) / 2)
    assert r["difference_low"] <= r["difference"] + 1e-9 <= r["difference_high"] + 2e-9
