"""benchmark.studies.calibration_roundtrip (and its detector check, benchmark.studies.calibration_lamr):
`viewadapt calibrate` on a dataset's own frame cameras.

On the toy frames (no Blender): exact points give the camera back, noisy ones small finite
errors; the detector scores the same with a noiselessly recovered camera as with the true
one; the study's CLI writes all its outputs, and bad input is one line, exit code 2 and
nothing written.
"""

import json

import numpy as np
import pandas as pd
import pytest

from benchmark.studies.calibration_lamr import FOCAL_MODES, VARIANTS
from benchmark.frames.phases import (
    frame_matches, grid_phases, matches_lamr, paired_lamr_difference, phase_mean_difference,
)
from benchmark.studies.calibration_roundtrip import (
    calibrate_draws, choose_ground_points, group_cameras, main, summarize_draws,
    write_correspondences,
)
from benchmark.data import load_dataset
from benchmark.frames.methods import evaluate_method, load_frames, train_source_detectors
from viewadapt.cli import main as viewadapt_main
from viewadapt.io.calibration import read_correspondences
from viewadapt.geometry import Camera, camera_from_pose
from viewadapt.io import read_calibration
from tests.toy_frames import small_toy_frames

OUTPUTS = ("calibration_roundtrip.csv", "calibration_summary.csv", "calibration_detector.csv",
           "calibration_lamr.csv", "calibration_roundtrip.md", "run.json")


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    """The frames of tests/benchmark/frames/test_command.py's toy set: one camera, two frames."""
    return small_toy_frames(tmp_path_factory.mktemp("tf") / "data")


@pytest.fixture(scope="module")
def model_file(toy, tmp_path_factory):
    """Source detectors trained quickly (as `bench frames --quick`), saved."""
    path = tmp_path_factory.mktemp("models") / "source_detectors.npz"
    train_source_detectors(load_dataset(toy), seed=0, quick=True).save(path)
    return path


@pytest.fixture(scope="module")
def camera(toy):
    (group,) = group_cameras(load_frames(toy)).values()
    return group[0].camera


def _run(argv, capsys):
    capsys.readouterr()
    rc = main([str(a) for a in argv])
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


# ------------------------------------------------------------------------------ points


def test_ground_points_spread_over_the_visible_ground(camera):
    w, h = camera.image_size
    for seed in range(5):
        uv, XY = choose_ground_points(camera, 6, np.random.default_rng(seed))
        assert uv.shape == XY.shape == (6, 2)
        assert np.all((uv[:, 0] > 0) & (uv[:, 0] < w - 1))
        assert np.all((uv[:, 1] >= (h - 1) / 3) & (uv[:, 1] < h - 1))
        # they are the projections of ground points
        np.testing.assert_allclose(camera.project(np.c_[XY, np.zeros(6)]), uv, atol=1e-9)
        # spread over the plane: no line holds them (as find_ground_homography checks)
        for p in (uv, XY):
            sv = np.linalg.svd(p - p.mean(axis=0), compute_uv=False)
            assert sv[1] / sv[0] > 0.2
        # two or more rows and columns: points left and right, near and far
        assert np.ptp(uv[:, 0]) > 0.4 * w and np.ptp(uv[:, 1]) > 0.25 * h
    a = choose_ground_points(camera, 6, np.random.default_rng(1))
    b = choose_ground_points(camera, 6, np.random.default_rng(1))
    np.testing.assert_array_equal(a[0], b[0])


@pytest.mark.parametrize("n", [4, 5, 9, 12])
def test_any_number_of_points_from_four(camera, n):
    uv, XY = choose_ground_points(camera, n, np.random.default_rng(n))
    assert len(uv) == len(np.unique(np.round(uv, 6), axis=0)) == n


def test_refuses_too_few_points_and_a_camera_above_the_ground_it_sees(camera):
    with pytest.raises(ValueError, match="at least 4"):
        choose_ground_points(camera, 3, np.random.default_rng(0))
    level = camera_from_pose(focal=150.0, principal_point=(95.5, 71.5), height=3.0,
                             tilt=0.0, image_size=(192, 144))
    a = np.radians(-40)                                  # pitched 40 degrees up
    R = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]]) @ level.R
    up = Camera(level.K, R, -R @ level.center, level.image_size)
    assert up.R[2, 2] > 0.6                              # the optical axis points up
    with pytest.raises(ValueError, match="too little ground"):
        choose_ground_points(up, 6, np.random.default_rng(0))


def test_correspondences_csv_is_read_back_exactly(camera, tmp_path):
    uv, XY = choose_ground_points(camera, 6, np.random.default_rng(0))
    uv2, XY2 = read_correspondences(write_correspondences(tmp_path / "p.csv", uv, XY))
    np.testing.assert_array_equal(uv2, uv)
    np.testing.assert_array_equal(XY2, XY)


# ------------------------------------------------------------------------- calibration


def test_noiseless_round_trip_recovers_the_camera(camera, tmp_path):
    draws, cals = calibrate_draws("toy", camera, n_points=6, noise_px=0.0, n_draws=4,
                                  rng=np.random.default_rng(0), points_dir=tmp_path)
    assert len(draws) == 4 * len(FOCAL_MODES) and (draws["error"] == "").all()
    assert len(list(tmp_path.glob("draw_*.csv"))) == 4
    # relative 1e-6: height in %, tilt against the true tilt
    assert (draws["height_error_pct"].abs() < 1e-4).all()
    assert (draws["tilt_error_deg"].abs() < 1e-6 * draws["true_tilt_deg"]).all()
    est = draws[draws["focal"] == "estimated"]
    assert (est["focal_error_pct"].abs() < 1e-4).all()
    assert draws.loc[draws["focal"] == "known", "focal_error_pct"].isna().all()
    assert (draws["reprojection_rms_px"] < 1e-6).all()
    assert len(cals) == 4
    for per_draw in cals:
        for mode in FOCAL_MODES:
            np.testing.assert_allclose(per_draw[mode].camera.P, camera.P, atol=1e-7)


def test_noisy_round_trip_errors_are_finite_and_small(camera):
    noise = 0.5
    draws, _ = calibrate_draws("toy", camera, n_points=6, noise_px=noise, n_draws=10,
                               rng=np.random.default_rng(3))
    assert (draws["error"] == "").all()
    cols = ["height_error_pct", "tilt_error_deg", "centre_error_m", "reprojection_rms_px"]
    assert np.isfinite(draws[cols].to_numpy()).all()
    # a 131 px focal length at 192x144: 0.5 px weighs twice what it does at 384x288
    assert draws["height_error_pct"].abs().max() < 10
    assert draws["tilt_error_deg"].abs().max() < 2
    assert 0.1 * noise < draws["reprojection_rms_px"].median() < 2 * noise
    # the errors are the noise's: none without it, some with it
    assert draws["height_error_pct"].abs().median() > 1e-3


def test_summary_medians_percentiles_and_bars():
    rows = [{"camera": "a", "draw": k, "focal": m, "height_error_pct": e,
             "tilt_error_deg": -e / 10, "focal_error_pct": np.nan if m == "known" else e,
             "centre_error_m": 0.0, "reprojection_rms_px": 0.5, "error": ""}
            for m in FOCAL_MODES for k, e in enumerate([0.5, -1.0, 1.5, 3.0])]
    rows[-1] = rows[-1] | {"error": "refused", "height_error_pct": np.nan}
    s = summarize_draws(pd.DataFrame(rows)).set_index(["camera", "focal"])
    known, est = s.loc[("all", "known")], s.loc[("all", "estimated")]
    assert known["height_pct_median"] == pytest.approx(1.25)
    assert known["height_pct_p95"] == pytest.approx(np.percentile([0.5, 1, 1.5, 3], 95))
    assert known["tilt_deg_p95"] == pytest.approx(np.percentile([0.05, .1, .15, .3], 95))
    assert not known["height_bar_met"] and known["tilt_bar_met"]     # 3 % > 2 %
    assert known["height_within_bar"] == 0.75
    # a failed draw is counted, left out of the statistics and fails the bars
    assert est["n_failed"] == 1 and est["height_pct_p95"] < 2
    assert not est["height_bar_met"] and not est["tilt_bar_met"]
    assert est["height_within_bar"] == 0.75
    assert np.isnan(known["focal_pct_median"]) and est["focal_pct_median"] == 1.0


def test_staged_lamr_equals_evaluate_method(toy):
    """The bootstrap's match-once, accumulate-per-replicate LAMR against the benchmark's."""
    frames = load_frames(toy)
    rng = np.random.default_rng(0)
    for _ in range(5):
        dets = []
        for f in frames:
            n = int(rng.integers(0, 12))
            jitter = rng.normal(0, 4, (len(f.gt), 4))
            boxes = np.r_[f.gt + jitter, np.c_[rng.uniform(0, 150, (n, 2)),
                                               rng.uniform(8, 40, (n, 1)),
                                               rng.uniform(20, 90, (n, 1))]]
            dets.append(np.c_[boxes, rng.normal(size=len(boxes))])
        dets[int(rng.integers(len(dets)))] = np.zeros((0, 5))          # a frame without any
        assert matches_lamr(frame_matches(dets, frames)) == evaluate_method(dets, frames)["lamr"]


def test_paired_lamr_difference(toy):
    frames = load_frames(toy)
    perfect = [np.c_[f.gt, np.ones(len(f.gt))] for f in frames]
    half = [d[: len(d) // 2] for d in perfect]
    rng = np.random.default_rng(0)
    assert paired_lamr_difference(perfect, perfect, frames, n_boot=30, rng=rng) == (0, 0, 0)
    diff, lo, hi = paired_lamr_difference(half, perfect, frames, n_boot=30, rng=rng)
    assert diff > 0.2 and 0 < lo <= diff <= hi
    diff0, lo0, hi0 = paired_lamr_difference(half, perfect, frames, n_boot=0, rng=rng)
    assert diff0 == diff and np.isnan(lo0) and np.isnan(hi0)


def test_grid_phases():
    assert grid_phases(1) == [(0.0, 0.0)]
    assert grid_phases(2) == [(0.0, 0.0), (0.0, 0.5), (0.5, 0.0), (0.5, 0.5)]
    assert len(set(grid_phases(4))) == 16
    with pytest.raises(ValueError, match="at least 1"):
        grid_phases(0)


def test_phase_mean_difference(toy):
    frames = load_frames(toy)
    perfect = [np.c_[f.gt, np.ones(len(f.gt))] for f in frames]
    half = [d[: len(d) // 2] for d in perfect]
    none = [d[:0] for d in perfect]
    lamr = {k: matches_lamr(frame_matches(v, frames))
            for k, v in (("perfect", perfect), ("half", half), ("none", none))}
    # one phase each: the paired difference, replicate for replicate
    a = phase_mean_difference([half], [perfect], frames, n_boot=25,
                              rng=np.random.default_rng(3))
    b = paired_lamr_difference(half, perfect, frames, n_boot=25, rng=np.random.default_rng(3))
    assert a == b
    # the means over the phases (two against three of them)
    diff, lo, hi = phase_mean_difference([half, none], [perfect, perfect, half], frames,
                                         n_boot=25, rng=np.random.default_rng(0))
    expected = (lamr["half"] + lamr["none"]) / 2 - (2 * lamr["perfect"] + lamr["half"]) / 3
    assert diff == pytest.approx(expected) and lo <= diff <= hi
    assert phase_mean_difference([half, perfect], [perfect, half], frames, n_boot=10,
                                 rng=np.random.default_rng(0)) == (0, 0, 0)


# --------------------------------------------------------------------------------- CLI


def test_cli_noiseless_writes_everything_and_detects_as_the_true_camera(
        toy, model_file, camera, tmp_path, capsys):
    out = tmp_path / "out"
    rc, stdout, err = _run(["--data", toy, "--out", out, "--model", model_file,
                            "--noise", 0, "--draws", 2, "--cache", tmp_path / "cache",
                            "--bootstrap", 20, "--phases", 2, "--jobs", 2], capsys)
    assert rc == 0, err
    for name in OUTPUTS:
        assert (out / name).is_file()
    draws = pd.read_csv(out / "calibration_roundtrip.csv")
    assert len(draws) == 2 * len(FOCAL_MODES)
    run = json.loads((out / "run.json").read_text())
    det = run["detector"]
    assert set(det) == {"true_lamr", *VARIANTS[1:]}
    assert 0 < det["true_lamr"] < 1
    for v in VARIANTS[1:]:
        assert abs(det[v]["first_diff"]) <= 1e-9 and det[v]["first_within_bar"]
        assert det[v]["first_ci_low"] == det[v]["first_ci_high"] == 0
    lamr = pd.read_csv(out / "calibration_lamr.csv")
    assert list(lamr["variant"]) == list(VARIANTS) and list(lamr["draw"]) == [-1, 0, 0]
    assert lamr["lamr"].nunique() == 1 and (lamr["n_detections"] > 0).all()
    assert (lamr["n_phases"] == 4).all() and lamr["lamr_grid0"].nunique() == 1
    assert (lamr["lamr_min"] <= lamr["lamr"]).all() and (lamr["lamr"] <= lamr["lamr_max"]).all()
    per_cam = pd.read_csv(out / "calibration_detector.csv")
    # every variant at the four grid phases, in grid_phases order
    assert list(per_cam["variant"]) == [v for v in VARIANTS for _ in range(4)]
    assert [tuple(p) for p in per_cam[["phase_forward", "phase_left"]].to_numpy()[:4]] == \
        grid_phases(2)
    # the same camera gives the same windows and detections at the same phase
    for _, g in per_cam.groupby(["phase_forward", "phase_left"]):
        assert g["n_detections"].nunique() == 1 and g["n_windows"].nunique() == 1
    # one camera: the reported LAMR is the mean of its per-phase LAMRs, the first the
    # default grid's
    true = per_cam[per_cam["variant"] == "true"]
    np.testing.assert_allclose(lamr["lamr"].iloc[0], true["lamr"].mean(), rtol=1e-5)
    np.testing.assert_allclose(lamr["lamr_grid0"].iloc[0], true["lamr"].iloc[0], rtol=1e-5)
    assert run["grid_phases"] == 4
    for m in FOCAL_MODES:
        assert run["calibration"][m]["height_bar_met"] and run["calibration"][m]["tilt_bar_met"]
    md = (out / "calibration_roundtrip.md").read_text()
    assert "**not met**" not in md and "Not measured here" in md
    # the first draw's calibration files read back as the true camera ...
    files = sorted((out / "calibrations").glob("*.yaml"))
    assert [f.name for f in files] == ["fscene00_focal-estimated.yaml",
                                       "fscene00_focal-known.yaml"]
    for f in files:
        np.testing.assert_allclose(read_calibration(f).P, camera.P, atol=1e-7)
    # ... and `viewadapt calibrate` on the written points says what the study found
    csv = out / "points" / "fscene00" / "draw_00.csv"
    assert csv.is_file()
    rc = viewadapt_main(["calibrate", str(csv), "--image-size", "192,144",
                         "--out", str(tmp_path / "cli.yaml")])
    assert rc == 0
    np.testing.assert_allclose(read_calibration(tmp_path / "cli.yaml").P,
                               read_calibration(files[0]).P, rtol=0, atol=1e-9)


def test_cli_with_noise_trains_its_own_model(toy, tmp_path, capsys):
    out = tmp_path / "out"
    rc, stdout, err = _run(["--data", toy, "--out", out, "--quick", "--draws", 3, "--phases", 1,
                            "--points", 5, "--detector-draws", 2, "--bootstrap", 20], capsys)
    assert rc == 0, err
    assert "training" in stdout
    draws = pd.read_csv(out / "calibration_roundtrip.csv")
    assert len(draws) == 3 * len(FOCAL_MODES) and (draws["n_points"] == 5).all()
    assert np.isfinite(draws["height_error_pct"]).all()
    assert (draws["reprojection_rms_px"] > 0).all()
    run = json.loads((out / "run.json").read_text())
    assert run["seed"] == 0 and run["noise_px"] == 0.5 and "trained here" in run["model"]
    for v in VARIANTS[1:]:
        d = run["detector"][v]
        assert d["n_draws"] == 2 and d["min_diff"] <= d["median_diff"] <= d["max_diff"]
        assert d["first_ci_low"] <= d["first_diff"] <= d["first_ci_high"]
    lamr = pd.read_csv(out / "calibration_lamr.csv")
    assert list(lamr["draw"]) == [-1, 0, 0, 1, 1] and np.isfinite(lamr["lamr"]).all()
    assert "Over the first 2 draws" in (out / "calibration_roundtrip.md").read_text()
    assert len(pd.read_csv(out / "points" / "fscene00" / "draw_02.csv")) == 5


def test_cli_without_the_detector_check_needs_no_model(toy, tmp_path, capsys):
    out = tmp_path / "out"
    rc, stdout, err = _run(["--data", toy, "--out", out, "--draws", 3, "--detector-draws", 0,
                            "--model", tmp_path / "never_read.npz"], capsys)
    assert rc == 0, err
    assert "training" not in stdout
    assert len(pd.read_csv(out / "calibration_roundtrip.csv")) == 3 * len(FOCAL_MODES)
    assert not (out / "calibration_lamr.csv").exists()
    assert not (out / "calibration_detector.csv").exists()
    run = json.loads((out / "run.json").read_text())
    assert run["detector"] is None and run["model"] is None
    md = (out / "calibration_roundtrip.md").read_text()
    assert "Detector check" not in md and "## Camera recovery" in md


@pytest.mark.parametrize("case", ["no frames", "points", "noise", "noise nan", "draws",
                                  "detector draws", "detector draws negative", "phases", "jobs",
                                  "model", "option"])
def test_bad_input_is_one_line_and_writes_nothing(case, toy, tmp_path, capsys):
    no_frames = tmp_path / "crops_only"
    no_frames.mkdir()
    (no_frames / "dataset.json").write_text("{}")
    args = {"no frames": ["--data", no_frames],
            "points": ["--data", toy, "--points", 3],
            "noise": ["--data", toy, "--noise", -0.5],
            "noise nan": ["--data", toy, "--noise", "nan"],
            "draws": ["--data", toy, "--draws", 0],
            "detector draws": ["--data", toy, "--draws", 2, "--detector-draws", 3],
            "detector draws negative": ["--data", toy, "--detector-draws", -1],
            "phases": ["--data", toy, "--phases", 0],
            "jobs": ["--data", toy, "--jobs", 0],
            "option": ["--data", toy, "--points", "six"],
            "model": ["--data", toy, "--model", tmp_path / "missing.npz"]}[case]
    out = tmp_path / "out"
    rc, stdout, err = _run([*args, "--out", out], capsys)
    assert rc == 2
    assert len(err.strip().splitlines()) == 1 and "error" in err
    assert not out.exists()
