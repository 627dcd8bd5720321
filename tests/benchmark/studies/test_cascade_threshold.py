"""benchmark.studies.cascade_threshold: what the adapted OpenCV detector's cascade drops."""

import json

import numpy as np
import pandas as pd
import pytest

from benchmark.studies.cascade_threshold import cascade_table, main, window_score_pairs
from tests.toy_frames import mot_toy_clip


def test_the_table_counts_what_each_threshold_keeps_and_drops():
    folded = np.array([-3.0, -2.0, -1.0, 0.5, -2.5])
    final = np.array([-2.0, 0.2, -0.5, 1.0, -1.0])
    rows = cascade_table([(folded, final), (folded[:2], final[:2])], thresholds=(-2.0, -1.0),
                         levels=(0.0, -1.0))
    # 7 windows over 2 frames; folded >= -2: 3 + 1, >= -1: 2 + 0
    assert [r["rescored_per_frame"] for r in rows] == [2.0, 1.0]
    # final >= 0: the windows of folded -2 (twice) and 0.5; final >= -1: and -1 and -2.5
    assert rows[0]["n_final_ge_0"] == 3 and rows[0]["dropped_final_ge_0"] == 0.0
    assert rows[1]["dropped_final_ge_0"] == pytest.approx(2 / 3)
    assert rows[0]["n_final_ge_-1"] == 5
    assert rows[0]["dropped_final_ge_-1"] == pytest.approx(1 / 5)


def test_a_clip_is_scored_both_ways(tmp_path):
    """Every window's folded score equals the operator's where the stage does not rescore,
    and its final score the cascade's where it does; the command writes its table."""
    from viewadapt.detect import FrameDetector
    from viewadapt.detect.layers import upsampled_band
    from viewadapt.io import read_frame
    from viewadapt.io.calibration import read_calibration_file

    toy = mot_toy_clip(tmp_path / "toy", n_frames=2)
    cal = read_calibration_file(toy.calibration)
    det = FrameDetector(cal.camera, None, cache_dir=tmp_path / "cache")
    img = read_frame(sorted(toy.img1.iterdir())[0])
    folded, final = window_score_pairs(det, img)
    op = det.operator("opencv")
    cascade = np.concatenate([L.operator.scores(L.operator.frame_features(
        upsampled_band(img, L.factor, L.rows))) for L in op.layers])
    kept = folded >= op.layers[0].operator.stage.threshold
    assert kept.any() and (~kept).any()
    np.testing.assert_allclose(final[kept], cascade[kept])
    np.testing.assert_allclose(folded[~kept], cascade[~kept], atol=1e-5)
    assert np.abs(final[kept] - folded[kept]).max() > 1e-2
    out = tmp_path / "out"
    assert main(["--data", str(toy.root / "data"), "--clip", str(toy.img1), "--calibration",
                 str(toy.calibration), "--cache", str(tmp_path / "cache"), "--out",
                 str(out)]) == 0
    table = pd.read_csv(out / "cascade.csv")
    assert list(table["source"].unique()) == ["renders", "clip"]
    for _, t in table.groupby("source"):
        assert np.all(np.diff(t["rescored_per_frame"]) <= 0)
        assert np.all(np.diff(t["dropped_final_ge_-1"].fillna(0)) >= 0)
    assert json.loads((out / "run.json").read_text())["frames"] == {"renders": 2, "clip": 2}
    assert (out / "cascade.md").read_text().startswith("# Cascade")


def test_no_input_is_one_line(tmp_path, capsys):
    assert main(["--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("python -m benchmark.studies.cascade_threshold: error: ")
    assert "give --data and/or --clip" in err and len(err.strip().splitlines()) == 1


def test_the_hog_stage_is_studied_with_its_model(tmp_path):
    toy = mot_toy_clip(tmp_path / "toy", n_frames=1)
    out = tmp_path / "out"
    assert main(["--kind", "hog", "--model", str(toy.model), "--clip", str(toy.img1),
                 "--calibration", str(toy.calibration), "--out", str(out)]) == 0
    run = json.loads((out / "run.json").read_text())
    assert run["kind"] == "hog" and run["model"] == str(toy.model)
    assert (pd.read_csv(out / "cascade.csv")["rescored_per_frame"] > 0).any()
