"""benchmark.studies.negatives: the rotated negatives, the paired gap statistics and the study's CLI."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from benchmark.crops.features import rotated_windows, rotation_about_centre
from benchmark.crops.features import WindowSet
from benchmark.studies.negatives import gap_changes, main
from benchmark.toydata import make_toy_dataset
from viewadapt.geometry import apply_homography
from viewadapt.warp import translation


def test_rotation_turns_about_the_window_centre():
    H = rotation_about_centre(90.0)
    c = np.array([[31.5, 63.5]])
    assert np.allclose(apply_homography(H, c), c)
    # image coordinates (y down): +90 degrees turns +x onto +y
    assert np.allclose(apply_homography(H, c + [10, 0]), c + [0, 10])
    assert np.allclose(rotation_about_centre(-30) @ rotation_about_centre(30), np.eye(3))


def test_rotated_windows_turn_the_image_content(tmp_path):
    import cv2

    img = np.zeros((256, 256, 3), np.uint8)
    img[:, ::8] = 255                                  # vertical stripes
    cv2.imwrite(str(tmp_path / "bg.png"), img)
    ws = WindowSet("bg", [("bg.png", translation(96, 64))],
                   pd.DataFrame({"scene_id": ["s"], "label": [0]}))
    (win,) = list(rotated_windows(ws, 90.0).images(tmp_path))
    g = win[..., 0].astype(float)
    # after a quarter turn the stripes run horizontally: rows vary, columns do not
    assert g.std(axis=1).mean() < 1.0 < g.std(axis=0).mean()


def _scores(det):
    """Two pools x two rules on the same 4 persons (2 windows each) and 200 negatives."""
    rows = []
    rng = np.random.default_rng(0)
    neg = rng.normal(size=200) - 5
    for (pool, rule), hits in det.items():
        pos = np.where(np.repeat(hits, 2), 10.0, -10.0)
        rows.append(pd.DataFrame({"pool": pool, "rule": rule, "score": np.r_[pos, neg],
                                  "label": np.r_[np.ones(8, int), np.zeros(200, int)],
                                  "person_id": np.r_[np.repeat(list("abcd"), 2),
                                                     np.full(200, "")]}))
    return pd.concat(rows, ignore_index=True)


def test_gap_changes_are_paired_differences_of_the_gaps():
    det = {("p0", "cov"): [0, 0, 1, 1], ("p0", "eq3"): [1, 1, 1, 1],
           ("p1", "cov"): [1, 1, 1, 0], ("p1", "eq3"): [1, 1, 1, 0]}
    g = gap_changes(_scores(det), a="cov", b="eq3", reference_pool="p0", n_boot=200,
                    rng=np.random.default_rng(0)).set_index("pool")
    assert g.loc["p0", "gap"] == pytest.approx(0.5) and g.loc["p0", "change"] == 0
    assert g.loc["p0", "change_ci_low"] == g.loc["p0", "change_ci_high"] == 0
    assert g.loc["p1", "gap"] == pytest.approx(0.0)
    assert g.loc["p1", "change"] == pytest.approx(-0.5)
    assert g.loc["p1", "change_ci_low"] <= -0.5 <= g.loc["p1", "change_ci_high"]


def test_gap_changes_refuse_other_persons_and_missing_rules():
    det = {("p0", "cov"): [0, 0, 1, 1], ("p0", "eq3"): [1, 1, 1, 1]}
    s = _scores(det)
    with pytest.raises(ValueError, match="reference pool 'p9'"):
        gap_changes(s, a="cov", b="eq3", reference_pool="p9", rng=np.random.default_rng(0))
    with pytest.raises(ValueError, match="no rows of rules"):
        gap_changes(s, a="x", b="y", reference_pool="p0", rng=np.random.default_rng(0))
    s.loc[(s["rule"] == "eq3") & (s["person_id"] == "d"), "person_id"] = "e"
    with pytest.raises(ValueError, match="same test persons"):
        gap_changes(s, a="cov", b="eq3", reference_pool="p0", rng=np.random.default_rng(0))


def test_study_end_to_end_on_the_toy_set(tmp_path, capsys):
    data = make_toy_dataset(tmp_path / "data", n_persons=9, n_scenes=3, n_backgrounds=1,
                            seed=1)
    out = tmp_path / "res"
    assert main(["--data", str(data), "--out", str(out), "--folds", "1", "--quick"]) == 0
    summ = pd.read_csv(out / "negatives_summary.csv")
    # 4 shared pools x (4 rules + unadapted) + the per-rule pool's 4 rows
    assert len(summ) == 24 and set(summ["pool"]) == {
        "elevation 0", "+ rotated", "+ shifted (control)", "+ pi/4 backgrounds",
        "+ pi/4 through G"}
    n = summ.groupby("pool")["n_train_negatives"].first()
    assert n["+ rotated"] == n["+ shifted (control)"] == 5 * n["elevation 0"]
    assert n["+ pi/4 backgrounds"] == n["+ pi/4 through G"] > n["elevation 0"]
    for f in ("negatives_gaps.csv", "negative_bin_shares.csv", "scores.parquet", "negatives.md", "negatives.png",
              "run.json"):
        assert (out / f).is_file(), f
    shares = pd.read_csv(out / "negative_bin_shares.csv")
    assert np.allclose(shares.groupby("negatives")["energy_share"].sum(), 1, atol=1e-4)
    assert shares.groupby("negatives").size().eq(9).all() and len(shares) == 9 * 8
    capsys.readouterr()
    assert main(["--data", str(data), "--out", str(tmp_path / "bad"), "--folds", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--folds must be an integer in 1..9" in err[0]
    assert not (tmp_path / "bad").exists() or not any((tmp_path / "bad").iterdir())
