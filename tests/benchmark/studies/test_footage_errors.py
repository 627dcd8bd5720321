"""benchmark.footage.errors and benchmark.studies.footage_errors: a method's misses and false
positives on a clip, sorted."""

import json

import cv2
import numpy as np
import pandas as pd
import pytest

from benchmark.footage.errors import clip_errors, error_breakdown, error_map, neighbours
from benchmark.studies.footage_errors import main
from viewadapt.geometry import camera_from_pose
from viewadapt.io import FrameBoxes

SIZE = (200, 150)
H = 60.0
W = 0.41 * H                    # the protocol's aspect: standardising changes nothing


def _box(x, y):
    return [x, y, W, H]


#: frame 0: A alone; frame 1: B and C side by side (a group)
TRUTH = [FrameBoxes(np.array([_box(20, 30)]), np.zeros(1), np.zeros(1, bool)),
         FrameBoxes(np.array([_box(100, 40), _box(112, 42)]), np.zeros(2), np.zeros(2, bool))]
DETS = [np.array([_box(20, 30) + [0.9],          # a hit on A
                  _box(20, 54) + [0.8],          # A badly framed: IoU 36/84, localisation
                  _box(20, 31) + [0.6]]),        # A again: a duplicate
        np.array([_box(160, 10) + [0.7]])]       # nothing there: background


def test_neighbours_are_boxes_a_window_of_one_also_shows():
    assert neighbours([_box(100, 40), _box(112, 42), _box(20, 30)]).tolist() == \
        [True, True, False]
    assert neighbours([_box(100, 40), _box(100 + 0.9 * W, 40)]).tolist() == [False, False]
    assert neighbours([_box(100, 40), _box(110, 40 + 0.6 * H)]).tolist() == [False, False]


def test_every_error_is_sorted_once():
    r = error_breakdown(DETS, TRUTH, SIZE, fppi=5.0)
    assert r["threshold"] == pytest.approx(0.6)
    assert (r["counted"], r["missed"]) == (3, 2)
    assert (r["with_neighbour"], r["missed_with_neighbour"]) == (2, 2)
    assert (r["false_positives"], r["localisation"], r["duplicates"], r["background"]) == \
        (3, 1, 1, 1)
    assert r["localisation_on_missed"] == 0                      # A is found
    assert [b[2:] for b in r["height_bands"]] == [(0, 0), (3, 2), (0, 0), (0, 0), (0, 0)]
    assert r["log_height_ratio_mean"] == pytest.approx(0) and r["log_height_ratio_sd"] == 0
    # at most one false positive in the two frames: the threshold keeps the first only
    r = error_breakdown(DETS, TRUTH, SIZE, fppi=0.5)
    assert r["threshold"] == pytest.approx(0.8)
    assert (r["false_positives"], r["localisation"], r["missed"]) == (1, 1, 2)
    # an ignore region over the group: its persons are not counted, A's errors stay
    region = [np.array([[90, 0], [200, 0], [200, 150], [90, 150]], float)]
    r = error_breakdown(DETS, TRUTH, SIZE, regions=region, fppi=5.0)
    assert (r["counted"], r["missed"], r["false_positives"]) == (1, 0, 2)
    # without the hit, A is missed under its badly framed detection: an error twice
    r = error_breakdown([DETS[0][1:2], DETS[1]], TRUTH, SIZE, fppi=5.0)
    assert (r["missed"], r["localisation"], r["localisation_on_missed"]) == (3, 1, 1)


def test_the_map_marks_found_missed_and_false():
    img = np.full((SIZE[1], SIZE[0], 3), 100, np.uint8)
    out = error_map(img, DETS, TRUTH, SIZE, fppi=5.0)
    assert out.shape == img.shape and out.dtype == np.uint8
    foot = lambda b: (int(b[1] + b[3]), int(b[0] + b[2] / 2))  # noqa: E731
    assert tuple(out[foot(_box(20, 30))]) == (0, 200, 0)          # A found
    assert tuple(out[foot(_box(100, 40))]) == (230, 0, 0)         # B missed
    assert (out[foot(_box(160, 10))] != 110).any()                # a cross on the FP


def test_clip_errors_are_the_breakdowns_and_the_map_of_one_matching():
    img = np.full((SIZE[1], SIZE[0], 3), 100, np.uint8)
    per, view = clip_errors(img, DETS, TRUTH, SIZE, fppis=(0.5, 5.0), title="t")
    assert per == {f: error_breakdown(DETS, TRUTH, SIZE, fppi=f) for f in (0.5, 5.0)}
    np.testing.assert_array_equal(view, error_map(img, DETS, TRUTH, SIZE, fppi=5.0, title="t"))


def test_main_reads_a_footage_folder_and_says_what_is_wrong(tmp_path):
    cam = camera_from_pose(focal=150.0, principal_point=(99.5, 74.5), height=4.0,
                           tilt=np.radians(20), image_size=SIZE)
    img1 = tmp_path / "img1"
    img1.mkdir()
    lines = []
    for k, t in enumerate(TRUTH, 1):
        cv2.imwrite(str(img1 / f"{k:06d}.png"), np.full((SIZE[1], SIZE[0], 3), 90, np.uint8))
        lines += [f"{k},{j + 1},{x},{y},{w},{h},1,-1,-1,-1" for j, (x, y, w, h)
                  in enumerate(t.boxes.tolist())]
    (tmp_path / "gt.txt").write_text("\n".join(lines) + "\n")
    (tmp_path / "cam.json").write_text(json.dumps(
        {"image_size": list(SIZE), "K": cam.K.tolist(), "R": cam.R.tolist(),
         "t": cam.t.tolist()}))
    run = tmp_path / "run"
    run.mkdir()
    (run / "detections.json").write_text(json.dumps(
        {"hog_adapted": {f"{k:06d}.png": d.tolist() for k, d in enumerate(DETS, 1)}}))
    args = [str(img1), "--calibration", str(tmp_path / "cam.json"), "--boxes",
            str(tmp_path / "gt.txt"), "--detections", str(run)]
    assert main(args + ["--fppi", "0.5", "5", "--out", str(tmp_path / "out")]) == 0
    df = pd.read_csv(tmp_path / "out" / "errors.csv")
    assert df["fppi"].tolist() == [0.5, 5.0]
    assert df["missed"].tolist() == [2, 2] and df["background"].tolist() == [0, 1]
    assert cv2.imread(str(tmp_path / "out" / "error_map.jpg")).shape == (SIZE[1], SIZE[0], 3)
    assert "| hog_adapted | 5 |" in (tmp_path / "out" / "errors.md").read_text()
    with pytest.raises(SystemExit):
        main(args + ["--methods", "acf_adapted", "--out", str(tmp_path / "other")])
    assert not (tmp_path / "other").exists()
