"""benchmark.studies.frames_vs_crops: person elevations, window labels, and the study end to end on
toy frames (its frame LAMRs must be those of the detector it stands for)."""

import json

import numpy as np
import pandas as pd
import pytest

from benchmark.frames.methods import evaluate_method, load_frames, train_source_detectors
from benchmark.studies.frames_vs_crops import (
    ELEVATION_EDGES, FPPW_LEVELS, crop_tables, label_windows, main, person_elevations,
)
from benchmark.data import load_dataset
from viewadapt.detect import FrameDetector, ground_truth_rows
from viewadapt.geometry import camera_from_pose
from tests.toy_frames import small_toy_frames


def test_person_elevation_is_the_angle_to_mid_height():
    cam = camera_from_pose(focal=300, principal_point=(191.5, 143.5), height=5.0,
                           tilt=np.radians(35), azimuth=0.0, position_xy=(0.0, 0.0),
                           image_size=(384, 288))
    centre = -cam.R.T @ cam.t
    ground = np.array([centre[:2] + [4.0, 3.0], centre[:2] + [0.0, 10.0]])
    e = person_elevations(cam, ground, person_height=1.8)
    assert e == pytest.approx(np.arctan2(5.0 - 0.9, [5.0, 10.0]))
    # a person right below the camera is seen straight down
    assert person_elevations(cam, centre[None, :2], 1.8)[0] == pytest.approx(np.pi / 2)


def test_label_windows_fits_and_background():
    gt = ground_truth_rows(np.array([[100.0, 50, 20, 60]]), np.array([0.0]), (384, 288))
    windows = np.array([[100.0, 50, 20, 60],       # the person's own box
                        [104.0, 52, 20, 60],       # slightly off: still fits
                        [100.0, 80, 20, 60],       # half overlap: neither
                        [300.0, 50, 20, 60]])      # elsewhere: background
    fits, bg, touches = label_windows(windows, gt)
    assert fits.tolist() == [[True, True, False, False]]
    assert bg.tolist() == [False, False, False, True]
    assert touches.tolist() == [True, True, True, False]
    # a wider full box reaches the last window
    _, _, touches = label_windows(windows, gt, np.array([[100.0, 50, 210, 60]]))
    assert touches.all()
    fits, bg, touches = label_windows(windows, np.zeros((0, 5)))
    assert fits.shape == (0, 4) and bg.all() and not touches.any()


def test_crop_tables_need_the_rules_rows():
    d = pd.DataFrame({"detector": ["acf"], "source_elevation": [0.0],
                      "target_elevation": [np.pi / 4], "method": ["adapted"],
                      "score": [0.0], "label": [1], "fold": [0], "person_id": ["a"]})
    with pytest.raises(ValueError, match="no HOG rows"):
        crop_tables(d)


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    return small_toy_frames(tmp_path_factory.mktemp("fvc") / "data")


def test_study_end_to_end(toy, tmp_path):
    models = train_source_detectors(load_dataset(toy), quick=True)
    model = tmp_path / "models.npz"
    models.save(model)
    # a cross-validation-like score table for the crops' side
    rng = np.random.default_rng(0)
    folders = []
    for target in (np.pi / 4, np.pi / 8):
        rows = []
        for m in ("adapted", "adapted[paper eq.3]", "adapted[S only]"):
            rows.append(pd.DataFrame({
                "detector": "hog", "source_elevation": 0.0, "target_elevation": target,
                "method": m, "score": np.r_[rng.normal(1, 1, 40), rng.normal(-1, 1, 400)],
                "label": np.r_[np.ones(40, int), np.zeros(400, int)], "fold": 0,
                "person_id": np.r_[np.repeat(list("abcdefgh"), 5), np.full(400, "")]}))
        folders.append(tmp_path / f"cv{len(folders)}")
        folders[-1].mkdir()
        pd.concat(rows).to_parquet(folders[-1] / "scores.parquet")
    out = tmp_path / "out"
    assert main(["--data", str(toy), "--out", str(out), "--model", str(model),
                 "--crossval", *map(str, folders), "--quiet"]) == 0
    for name in ("frames_vs_crops.md", "window_miss_rates.csv", "window_differences.csv",
                 "persons.csv", "frames_vs_crops.png", "run.json"):
        assert (out / name).is_file(), name
    run = json.loads((out / "run.json").read_text())
    frames = load_frames(toy)
    # the study's frame LAMR is the detector's own, for every rule
    for rule, method in (("covariant", "adapted"), ("paper", "adapted[paper eq.3]")):
        det = FrameDetector(frames[0].camera, models, person_heights=(1.65, 1.85), rule=rule)
        lamr = evaluate_method([det.detect(f.image(), "hog") for f in frames], frames)["lamr"]
        assert run["lamr"][method] == pytest.approx(lamr, abs=1e-12)
    persons = pd.read_csv(out / "persons.csv")
    n_scored = sum(int((ground_truth_rows(f.gt, f.occlusion, f.camera.image_size)[:, 4] == 0)
                       .sum()) for f in frames)
    assert len(persons) == n_scored == run["n_persons"]
    assert persons.elevation.between(0, np.pi / 2).all()
    rates = pd.read_csv(out / "window_miss_rates.csv")
    assert set(rates.fppw) == set(FPPW_LEVELS)
    assert rates.miss_rate.between(0, 1).all()
    # more false positives allowed: never more misses
    for _, g in rates.groupby(["subset", "method"]):
        mr = g.sort_values("fppw").miss_rate.to_numpy()
        assert (np.diff(mr) <= 1e-12).all()
    assert set(rates.subset[rates.subset.str.startswith("crops")]) == \
        {"crops at 0.39 rad", "crops at 0.79 rad"}
    clear = rates[rates.subset.str.contains("touching no person")]
    assert len(clear) == 3 * len(FPPW_LEVELS)
    assert (clear.n_background <= rates[rates.subset == "all frame persons"].n_background.max()
            ).all()
    for col in ("top_touching_share", "top_small_share"):
        assert rates[rates.subset == "all frame persons"][col].between(0, 1).all()
    # persons no window fits are misses, not part of the mean score
    assert rates.persons_mean.abs().max() < 1e3
    n_bins = len(ELEVATION_EDGES) - 1
    assert rates.subset.str.startswith("elevation").sum() <= 3 * n_bins * len(FPPW_LEVELS)


def test_bad_input_is_one_line(toy, tmp_path, capsys):
    assert main(["--data", str(tmp_path), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    assert "frames_coco.json" in capsys.readouterr().err
    assert main(["--data", str(toy), "--out", str(tmp_path / "o2"), "--crossval",
                 str(tmp_path), "--quiet"]) == 2
    assert "scores.parquet" in capsys.readouterr().err
    assert not (tmp_path / "o").exists() and not (tmp_path / "o2").exists()
