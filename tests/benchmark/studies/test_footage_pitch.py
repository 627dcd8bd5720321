"""benchmark.studies.footage_pitch: the adapted detectors under a wrongly calibrated tilt."""

import numpy as np
import pandas as pd
import pytest

from benchmark.studies.footage_pitch import main, pitched
from viewadapt.camera.calibrate import camera_height_and_tilt
from viewadapt.geometry import crop_camera
from tests.toy_frames import mot_toy_clip


def camera_tilt(camera):
    return np.radians(camera_height_and_tilt(camera.R, camera.t)[1])


@pytest.mark.parametrize("elevation", [0.2, np.pi / 4])
def test_a_camera_tilt_is_the_elevation_it_looks_down_from(elevation):
    # the crops' camera looks at the person's centre from `elevation` above the horizontal
    assert camera_tilt(crop_camera(elevation)) == pytest.approx(elevation, abs=1e-9)


def test_pitching_turns_the_camera_about_its_centre():
    cam = crop_camera(0.3)
    for delta in (-0.2, 0.05, 0.3):
        p = pitched(cam, delta)
        assert camera_tilt(p) - camera_tilt(cam) == pytest.approx(delta, abs=1e-9)
        np.testing.assert_allclose(p.center, cam.center, atol=1e-9)
        np.testing.assert_array_equal(p.K, cam.K)
        back = pitched(p, -delta)
        np.testing.assert_allclose(back.R, cam.R, atol=1e-12)
        np.testing.assert_allclose(back.t, cam.t, atol=1e-9)


def test_the_study_pairs_every_error_with_the_calibration_and_the_baseline(tmp_path, capsys):
    toy = mot_toy_clip(tmp_path, n_frames=3)
    clip = [str(toy.img1), "--calibration", str(toy.calibration), "--boxes", str(toy.gt),
            "--model", str(toy.model)]
    out = tmp_path / "out"
    assert main(clip + ["--methods", "hog_adapted", "--errors", "0.15", "--out", str(out)]) == 0
    df = pd.read_csv(out / "pitch.csv")
    assert df["tilt_error"].tolist() == [0.0, 0.15]       # the calibration as given is added
    at0, at15 = df.iloc[0], df.iloc[1]
    assert at0["minus_calibrated"] == 0.0 and at0["tilt_change"] == pytest.approx(0.0)
    assert at15["tilt_change"] == pytest.approx(0.15, abs=0.01)
    assert at15["minus_calibrated"] == pytest.approx(at15["lamr"] - at0["lamr"], abs=1e-9)
    for r in (at0, at15):
        assert r["lamr_low"] <= r["lamr"] <= r["lamr_high"]
    assert (out / "pitch.md").is_file() and (out / "pitch.png").is_file()
    capsys.readouterr()
    # a baseline that reads the calibration, and errors beyond the range: one line each
    assert main(clip + ["--baseline", "hog_adapted", "--out", str(tmp_path / "o2")]) == 2
    assert main(clip + ["--errors", "0.9", "--out", str(tmp_path / "o3")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 2 and all(line.startswith("python -m benchmark.studies.footage_pitch: "
                                                   "error: ") for line in lines)
