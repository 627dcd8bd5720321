"""Bootstrap intervals over frames for a `bench frames` run (benchmark.studies.frames_intervals)."""

import numpy as np
import pytest

from benchmark.frames.methods import FrameRecord
from benchmark.studies.frames_intervals import frame_bootstrap
from viewadapt.geometry import camera_from_pose


def _frames(n=12, seed=0):
    rng = np.random.default_rng(seed)
    cam = camera_from_pose(focal=200, principal_point=(95.5, 71.5), height=5.0, tilt=0.6,
                           image_size=(192, 144))
    frames = []
    for i in range(n):
        gt = np.c_[rng.uniform(0, 150, (3, 2)), np.full((3, 1), 20.0), np.full((3, 1), 50.0)]
        frames.append(FrameRecord(None, i, "s", cam, gt, np.zeros(3)))
    return frames


def _dets(frames, hit_rate, seed):
    rng = np.random.default_rng(seed)
    out = []
    for f in frames:
        d = [np.r_[b, 1.0 + rng.random()] for b in f.gt if rng.random() < hit_rate]
        d += [np.r_[rng.uniform(0, 150, 2), 20.0, 50.0, rng.random()] for _ in range(2)]
        out.append(np.array(d).reshape(-1, 5))
    return out


def test_intervals_and_paired_differences():
    frames = _frames()
    good = _dets(frames, 0.95, 1)
    poor = _dets(frames, 0.4, 2)
    tab = frame_bootstrap({"a": good, "b": poor, "a_again": [d.copy() for d in good]}, frames,
                          reference="a", n_boot=50).set_index("method")
    assert tab.loc["a", "ci_low"] <= tab.loc["a", "lamr"] <= tab.loc["a", "ci_high"]
    assert tab.loc["b", "lamr"] > tab.loc["a", "lamr"]
    assert tab.loc["b", "diff_low"] > 0                     # worse on every draw's pairing
    # the same detections: a difference of exactly 0 on every draw
    assert tab.loc["a_again", ["diff", "diff_low", "diff_high"]].tolist() == [0, 0, 0]


def test_bad_input():
    frames = _frames(4)
    d = _dets(frames, 0.9, 0)
    with pytest.raises(ValueError, match="reference"):
        frame_bootstrap({"a": d}, frames, reference="b")
    with pytest.raises(ValueError, match="frames"):
        frame_bootstrap({"a": d[:3]}, frames, reference="a")
