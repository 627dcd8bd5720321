"""benchmark.studies.footage_speed: the detect command and the bare detector timed on one clip."""

import json

import numpy as np
import pytest

from benchmark.data import load_dataset
from benchmark.frames.methods import train_source_detectors
from benchmark.studies.footage_speed import (
    format_table, main, median_interval, run_footage_benchmark,
)
from tests.toy_frames import small_toy_frames


def test_footage_benchmark_times_every_path(tmp_path):
    data = small_toy_frames(tmp_path / "data")
    model = train_source_detectors(load_dataset(data), quick=True, frame_view="none").save(
        tmp_path / "model.npz")
    res = run_footage_benchmark(data, n_frames=4, model=model, workdir=tmp_path / "w",
                                repeats=2)
    assert [r["method"] for r in res["rows"]] == [
        "detector on the decoded clip (video)", "detect (video)",
        "detector on the decoded clip (video, dist)", "detect (video, dist)",
        "detect (video, dist, lens windows)"]
    for r in res["rows"]:
        assert r["frames"] == 4 and r["fps"] > 0 and r["seconds"] > 0
        assert r["cpu_ms_per_frame"] > 0
    assert res["rows"][0]["ratio_to_detector"] == 1.0
    for r in (res["rows"][1], res["rows"][3], res["rows"][4]):   # the commands' paired ratios
        assert len(r["ratios"]) == 2
        assert r["ratio_to_detector"] == pytest.approx(np.median(r["ratios"]), abs=1e-4)
        assert r["ratio_low"] <= r["ratio_to_detector"] <= r["ratio_high"]
    assert res["windows"] > 1000            # the CAVIAR-like timing camera
    # the distorted clip was undistorted by the command
    meta = json.loads((tmp_path / "w" / "out_clip_dist_undistort" / "metadata.json").read_text())
    assert meta["undistortion"]["dist"] == res["distortion"]
    # and read as it is through the lens windows, against the same bare detector
    meta = json.loads((tmp_path / "w" / "out_clip_dist_windows" / "metadata.json").read_text())
    assert meta["lens_windows"]["dist"] == res["distortion"] and meta["undistortion"] is None
    assert (tmp_path / "w" / "out_clip_dist_windows_1" / "metadata.json").is_file()  # repeat
    assert "Bar: the command within 10 %" in format_table(res)


def test_median_interval_is_the_sign_test_interval():
    # Conover's table: for n = 15 the 95 % interval of the median is [x_(4), x_(12)],
    # coverage 1 - 2 P(B <= 3) = 0.9648; for n = 30, [x_(10), x_(21)]
    low, high, cover = median_interval(np.arange(15, 0, -1.0))
    assert (low, high) == (4.0, 12.0) and cover == pytest.approx(0.96484375)
    assert median_interval(np.arange(1, 31.0))[:2] == (10.0, 21.0)
    # too few values for 95 %: the whole range, at its own lower coverage
    assert median_interval([3.0, 1.0, 2.0, 5.0, 4.0]) == (1.0, 5.0, pytest.approx(0.9375))
    with pytest.raises(ValueError):
        median_interval([])


def test_footage_benchmark_bad_input(tmp_path, capsys):
    assert main(["--data", str(tmp_path), "--frames", "1"]) == 2
    assert "--frames" in capsys.readouterr().err
    assert main(["--data", str(tmp_path), "--repeats", "0"]) == 2
    assert "--repeats" in capsys.readouterr().err
    assert main(["--data", str(tmp_path / "none")]) == 2


def test_memory_benchmark_samples_the_detect_process(tmp_path):
    from benchmark.studies.footage_memory import format_memory, main as memory_main, \
        run_memory_benchmark

    data = small_toy_frames(tmp_path / "data")
    res = run_memory_benchmark(data, minutes=40 / 25 / 60, workdir=tmp_path / "w",
                               interval=0.05)
    assert res["returncode"] == 0, res["stderr_tail"]
    assert res["frames"] == 40 and res["detect_frames"] == 40
    assert len(res["samples"]) >= 2 and max(mb for _, mb in res["samples"]) > 50
    md = format_memory(res)
    assert "| 100% |" in md and "growth" in md
    assert memory_main(["--data", str(data), "--minutes", "0"]) == 2
